//! Evidence for the default `K_p` (`docs/model.md`, notes §4): the paper's printed gains put
//! `K_p` on the modal rows, which no motor actuates, and leave the joints without proportional
//! feedback. `cargo test -p flexarm-tests --test gains -- --nocapture` prints the numbers.

use flexarm_core::Vector4;
use flexarm_core::trajectory::{Circle, JointTrajectory, Trapezoid};
use flexarm_sim::sim::{SimConfig, simulate};

#[test]
fn joint_gains_track_far_better_than_the_printed_modal_gains() {
    let printed = Vector4::new(0.0, 0.0, 90.0, 14.0);
    for (name, traj) in [
        ("trapezoid", JointTrajectory::Trapezoid(Trapezoid::paper())),
        (
            "circle",
            JointTrajectory::Circle(Circle::paper(0.3, 0.7).unwrap()),
        ),
    ] {
        let ours = SimConfig::default();
        let mut paper = ours;
        paper.gains.kp = printed;
        let (a, _) = simulate(&ours, &traj, false).unwrap();
        let (b, _) = simulate(&paper, &traj, false).unwrap();
        println!(
            "{name}: Eq. 37 joint error {:.3e} rad with K_p = diag(90, 14, 0, 0), {:.3e} rad with the printed diag(0, 0, 90, 14); Eq. 38 |θ̃| ({:.2e}, {:.2e}) vs ({:.2e}, {:.2e}) rad",
            a.l2_error,
            b.l2_error,
            a.tail_error_abs[0],
            a.tail_error_abs[1],
            b.tail_error_abs[0],
            b.tail_error_abs[1]
        );
        assert!(a.l2_error < 0.2 * b.l2_error);
        assert!(
            a.tail_error_abs[0] < 0.1 * b.tail_error_abs[0]
                && a.tail_error_abs[1] < 0.1 * b.tail_error_abs[1]
        );
        // The modal rows of K_p reach no actuator: the deflections barely change.
        assert!((a.l2_delta - b.l2_delta).abs() < 0.1 * a.l2_delta);
    }
}

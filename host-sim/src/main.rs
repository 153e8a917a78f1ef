//! `flexarm-sim`: runs the paper's trapezoid move under each controller and prints the indices.

use flexarm_core::control::motor::MotorLaw;
use flexarm_core::control::piezo::PiezoGains;
use flexarm_core::trajectory::{JointTrajectory, Trapezoid};
use flexarm_sim::sim::{SimConfig, simulate};

fn main() {
    let traj = JointTrajectory::Trapezoid(Trapezoid::paper());
    println!(
        "| controller | L2 δ | L2 θ̃ [rad] | L2 tip [m] | L θ̃1 | L θ̃2 | max|τ| [N·m] | max|V_a| [V] |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for (name, law, piezo) in [
        ("Eq. 7", MotorLaw::Tracking, None),
        (
            "Eq. 7 + piezo",
            MotorLaw::Tracking,
            Some(PiezoGains::default()),
        ),
        ("Eq. 16", MotorLaw::Robust, None),
        (
            "Eq. 16 + piezo",
            MotorLaw::Robust,
            Some(PiezoGains::default()),
        ),
    ] {
        let cfg = SimConfig {
            law,
            piezo,
            ..SimConfig::default()
        };
        match simulate(&cfg, &traj, false) {
            Ok((s, _)) => println!(
                "| {name} | {:.3e} | {:.3e} | {:.3e} | {:.2e} | {:.2e} | {:.2} / {:.2} | {:.1} |",
                s.l2_delta,
                s.l2_error,
                s.l2_tip,
                s.tail_error[0],
                s.tail_error[1],
                s.max_tau[0],
                s.max_tau[1],
                s.max_v_a
            ),
            Err(e) => {
                eprintln!("error: {e}");
                std::process::exit(1);
            }
        }
    }
}

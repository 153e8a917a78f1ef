//! Trajectories, inverse kinematics and indices.

#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)] // tests may index and unwrap

use flexarm_core::indices::{L2Norm, TailMean};
use flexarm_core::kinematics::{Elbow, Planar2};
use flexarm_core::params::{ArmParams, Gains, Limits, ParamError};
use flexarm_core::trajectory::{
    Circle, Cubic, JointTrajectory, Profile, TrajectoryError, Trapezoid,
};
use flexarm_core::{Vector2, Vector4};
use proptest::prelude::*;

const KIN: Planar2<f64> = Planar2 { a1: 0.3, a2: 0.7 };

proptest! {
    #[test]
    fn inverse_kinematics_round_trips(r in 0.41..0.99f64, phi in -3.1..3.1f64, neg in any::<bool>()) {
        let p = Vector2::new(r * phi.cos(), r * phi.sin());
        let elbow = if neg { Elbow::Negative } else { Elbow::Positive };
        let th = KIN.inverse(&p, elbow, 0.0).unwrap();
        prop_assert!((KIN.forward(&th) - p).norm() < 1e-12);
        let side_ok = if neg { th.y <= 0.0 } else { th.y >= 0.0 };
        prop_assert!(side_ok);
    }

    /// A path segment's derivatives are its curve's, its ends are as given, and its closed-form
    /// peaks bound a dense sampling and are reached by it.
    #[test]
    fn a_cubic_segment_has_consistent_derivatives_and_exact_peaks(
        q in prop::array::uniform4(-2.0..2.0f64),
        v in prop::array::uniform4(-3.0..3.0f64),
        duration in 0.05..3.0f64,
    ) {
        let c = Cubic {
            start: Vector2::new(q[0], q[1]),
            end: Vector2::new(q[2], q[3]),
            v0: Vector2::new(v[0], v[1]),
            v1: Vector2::new(v[2], v[3]),
            duration,
        };
        let at = |t: f64| c.sample(t);
        let (first, last) = (at(duration * 1e-12), at(duration * (1.0 - 1e-12)));
        prop_assert!((first.q - c.start).norm() < 1e-9 && (last.q - c.end).norm() < 1e-9);
        prop_assert!((first.qd - c.v0).norm() < 1e-6 && (last.qd - c.v1).norm() < 1e-6);
        let (vp, ap) = c.peaks();
        let (mut vs, mut as_) = (Vector2::<f64>::zeros(), Vector2::<f64>::zeros());
        let h = duration * 1e-6;
        for k in 0..=2000 {
            let t = (duration * f64::from(k) / 2000.0).clamp(1e-12, duration * (1.0 - 1e-12));
            let b = at(t);
            if k > 0 && k < 2000 {
                let (a, d) = (at(t - h), at(t + h));
                prop_assert!(((d.q - a.q) / (2.0 * h) - b.qd).norm() < 1e-5 * (1.0 + b.qd.norm()));
                prop_assert!(((d.qd - a.qd) / (2.0 * h) - b.qdd).norm() < 1e-4 * (1.0 + b.qdd.norm()));
            }
            vs = vs.sup(&b.qd.abs());
            as_ = as_.sup(&b.qdd.abs());
        }
        for j in 0..2 {
            prop_assert!(vs[j] <= vp[j] * (1.0 + 1e-12) && vs[j] >= vp[j] * (1.0 - 1e-4) - 1e-12, "speed {} {}", vs[j], vp[j]);
            prop_assert!(as_[j] <= ap[j] * (1.0 + 1e-9) && as_[j] >= ap[j] * (1.0 - 1e-6) - 1e-9, "acceleration {} {}", as_[j], ap[j]);
        }
    }

    #[test]
    fn outside_the_annulus_is_an_error_not_nan(r in prop_oneof![0.0..0.399f64, 1.001..10.0f64], phi in -3.1..3.1f64) {
        let p = Vector2::new(r * phi.cos(), r * phi.sin());
        let e = KIN.inverse(&p, Elbow::Positive, 0.0);
        let unreachable = matches!(e, Err(TrajectoryError::Unreachable { .. }));
        prop_assert!(unreachable, "{:?}", e);
    }
}

#[test]
fn the_printed_circle_is_rejected_with_a_clear_error() {
    let e = Circle::<f64>::as_printed(0.3, 0.7).unwrap_err();
    let msg = e.to_string();
    assert!(
        matches!(e, TrajectoryError::Unreachable { distance, .. } if (distance - 0.2).abs() < 1e-7),
        "{e:?}"
    );
    assert!(
        msg.contains("unreachable") && msg.contains("0.200 m") && msg.contains("0.400 m"),
        "{msg}"
    );
    assert_eq!(
        KIN.inverse(&Vector2::new(f64::NAN, 0.0), Elbow::Positive, 0.0),
        Err(TrajectoryError::NotFinite)
    );
}

/// Finite differences of a trajectory's position and velocity match its velocity and
/// acceleration (away from the profile's switching instants).
fn check_derivatives(traj: &JointTrajectory<f64>, t_end: f64) {
    let h = 1e-6;
    let mut t = 0.013;
    while t < t_end {
        let (a, b, c) = (traj.sample(t - h), traj.sample(t), traj.sample(t + h));
        assert!(
            ((c.q - a.q) / (2.0 * h) - b.qd).norm() < 1e-5,
            "q̇ at t = {t}"
        );
        assert!(
            ((c.qd - a.qd) / (2.0 * h) - b.qdd).norm() < 1e-4,
            "q̈ at t = {t}"
        );
        t += 0.0497;
    }
}

#[test]
fn trapezoid_reaches_its_target_smoothly() {
    let tr = Trapezoid::<f64>::paper();
    let traj = JointTrajectory::Trapezoid(tr);
    let half_pi = core::f64::consts::FRAC_PI_2;
    assert_eq!(traj.sample(0.0).q, Vector2::zeros());
    assert!((traj.sample(2.0).q - Vector2::new(half_pi, half_pi)).norm() < 1e-12);
    assert_eq!(traj.sample(4.0).qd, Vector2::zeros());
    // Peak speed A/(T − t_a) = (π/2)/1.5 at mid-move.
    assert!((traj.sample(1.0).qd.x - half_pi / 1.5).abs() < 1e-12);
    check_derivatives(&traj, 2.5);
    assert_eq!(
        Profile::<f64>::new(1.0, 0.6),
        Err(TrajectoryError::InvalidTiming)
    );
    assert_eq!(
        Profile::<f64>::new(f64::NAN, 0.1),
        Err(TrajectoryError::NotFinite)
    );
}

#[test]
fn reachable_circle_follows_its_path() {
    let c = Circle::<f64>::paper(0.3, 0.7).unwrap();
    let traj = JointTrajectory::Circle(c);
    check_derivatives(&traj, 4.0);
    // Starts at rest at the top of the circle and runs clockwise.
    let s0 = traj.sample(0.0);
    assert!((KIN.forward(&s0.q) - Vector2::new(0.65, 0.2)).norm() < 1e-12);
    assert_eq!(s0.qd, Vector2::zeros());
    let (p, v, _) = c.tip(1.0);
    assert!(
        v.x * (p.y - 0.0) - v.y * (p.x - 0.65) > 0.0,
        "clockwise: (p − c) × v < 0"
    );
    for k in 0..400 {
        let t = k as f64 * 0.01;
        let s = traj.sample(t);
        let (p, _, _) = c.tip(t);
        assert!((KIN.forward(&s.q) - p).norm() < 1e-9);
        assert!(((p - Vector2::new(0.65, 0.0)).norm() - 0.2).abs() < 1e-12);
    }
}

#[test]
fn l2_and_tail_mean_match_hand_values() {
    let mut l2 = L2Norm::<f64>::default();
    let mut tail = TailMean::<f64, 2>::new(5.0, 3.0);
    let dt = 1e-3;
    for k in 0..5000 {
        let t = k as f64 * dt;
        // (3, 4) before t = 2 s, then (±1, 0) alternating: RMS² = (2·25 + 3·1)/5.
        let x = if t < 2.0 - 1e-12 {
            Vector2::new(3.0, 4.0)
        } else {
            Vector2::new(if k % 2 == 0 { 1.0 } else { -1.0 }, 0.0)
        };
        l2.add(&x, dt);
        tail.add(t, &x, dt);
    }
    assert!((l2.value() - (53.0f64 / 5.0).sqrt()).abs() < 1e-9);
    assert!(
        tail.signed().x.abs() < 1e-9,
        "the oscillation cancels in the signed mean"
    );
    assert!((tail.absolute().x - 1.0).abs() < 1e-9);
    assert_eq!(L2Norm::<f64>::default().value(), 0.0);
}

#[test]
fn parameters_validate() {
    assert_eq!(ArmParams::<f64>::default().validate(), Ok(()));
    assert_eq!(Gains::<f32>::default().validate(), Ok(()));
    assert_eq!(Limits::<f32>::default().validate(), Ok(()));
    let p = ArmParams::<f64> {
        m2: -0.3,
        ..Default::default()
    };
    assert_eq!(p.validate(), Err(ParamError::NotPositive("m2")));
    let mut p = ArmParams::<f64>::default();
    p.modes.omega = Vector2::new(90.0, 30.0);
    assert_eq!(p.validate(), Err(ParamError::FrequenciesNotIncreasing));
    let mut p = ArmParams::<f64>::default();
    p.modes.zeta.y = -0.01;
    assert_eq!(p.validate(), Err(ParamError::Negative("zeta[1]")));
    let p = ArmParams::<f64> {
        a1: f64::NAN,
        ..Default::default()
    };
    assert_eq!(p.validate(), Err(ParamError::NotFinite("a1")));
    let mut g = Gains::<f32> {
        kp: Vector4::new(0.0, 0.0, 90.0, 14.0),
        ..Default::default()
    };
    assert_eq!(
        g.validate(),
        Ok(()),
        "the paper's printed K_p is allowed, for the comparison"
    );
    g.kp.y = -1.0;
    assert_eq!(g.validate(), Err(ParamError::Negative("kp")));
    let l = Limits::<f32> {
        v_a_max: 0.0,
        ..Default::default()
    };
    assert!(l.validate().is_err());
}

/// The motor loop samples the trajectory at `t = kT` and holds the sample for one period, so the
/// desired acceleration it feeds forward integrates to `Σ_{i<k} q̈_d(iT) T`. That sum must be the
/// analytic `q̇_d(kT)`: exactly (to round-off) on the trapezoid's ramp, where `q̈_d` is constant,
/// and within the left-rectangle error `t T/2 · max|q⃛_d|` on the circle and a waypoint segment. A start that is not
/// right-continuous (`q̈_d(0) = 0`) leaves the whole first period's `q̈_d(0) T` out: 2.09e-3 rad/s
/// on the trapezoid.
#[test]
fn held_acceleration_integrates_to_the_desired_velocity() {
    const T: f64 = 1e-3; // the motor period at 1 kHz
    const PERIODS: usize = 400; // inside the first ramp of both (0.5 s)
    let circle = JointTrajectory::Circle(Circle::<f64>::paper(0.3, 0.7).unwrap());
    let trapezoid = JointTrajectory::Trapezoid(Trapezoid::<f64>::paper());
    // A waypoint segment from rest (`crate::drive`'s first segment of a path).
    let cubic = JointTrajectory::Cubic(Cubic {
        start: Vector2::new(0.2, -0.1),
        end: Vector2::new(1.2, -0.6),
        v0: Vector2::zeros(),
        v1: Vector2::new(0.3, 0.0),
        duration: 0.5,
    });
    for (name, traj) in [
        ("trapezoid", trapezoid),
        ("circle", circle),
        ("cubic", cubic),
    ] {
        // Largest jerk over the window, by central differences of q̈_d on a grid of T/10.
        let jerk = (1..10 * PERIODS)
            .map(|i| {
                let t = i as f64 * T / 10.0;
                let h = T / 100.0;
                ((traj.sample(t + h).qdd - traj.sample(t - h).qdd) / (2.0 * h)).amax()
            })
            .fold(0.0, f64::max);
        let mut v = traj.sample(0.0).qd;
        for k in 1..=PERIODS {
            v += traj.sample((k - 1) as f64 * T).qdd * T;
            let t = k as f64 * T;
            let err = (v - traj.sample(t).qd).amax();
            let bound = t * T / 2.0 * jerk + 1e-12;
            assert!(err <= bound, "{name}, t = {t}: {err:e} > {bound:e}");
        }
        // The first period's feedforward is the ramp's acceleration, not zero.
        let a0 = traj.sample(0.0).qdd.amax();
        assert!(a0 > 0.1, "{name}: q̈_d(0) = {a0}");
        if name == "trapezoid" {
            assert!(jerk == 0.0, "constant acceleration on the ramp");
        }
    }
}

#[test]
fn profile_is_at_rest_before_the_start_and_for_a_nan_time() {
    let p = Profile::<f32>::new(2.0, 0.5).unwrap();
    assert_eq!(p.sample(-1e-6), (0.0, 0.0, 0.0));
    assert_eq!(p.sample(f32::NAN), (0.0, 0.0, 0.0));
    assert_eq!(p.sample(f32::NEG_INFINITY), (0.0, 0.0, 0.0));
    // Right-continuous at the start: position and speed 0, acceleration of the first ramp.
    let (s, sd, sdd) = p.sample(0.0);
    assert_eq!((s, sd), (0.0, 0.0));
    assert_eq!(sdd, 1.0 / (1.5 * 0.5));
    assert_eq!(p.sample(f32::INFINITY), (1.0, 0.0, 0.0));
}

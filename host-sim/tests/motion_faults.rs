//! The motion checks against the truth plant (six modes of the 2.5 mm beam, drives with a
//! current-loop lag and Coulomb and viscous friction, the piezo amplifier, the film's charge
//! amplifier): the drive and the firmware's controller (`SimConfig::controller`, `f32`, the
//! observer) at the board's rates, 1 kHz and 10 kHz, with a failure injected between the plant
//! and the controller. One scenario each: a reversed encoder on joint 1, a frozen encoder on
//! joint 2 mid-move, a stall against a rigid obstacle, a reference that runs into the end of
//! the range at speed. Each must end in its fault within the stated time, with the joint's
//! travel, its peak speed and its coast after the fault within stated bounds; the same move
//! without a failure runs clean.
//!
//! Encoders: 16384 counts a revolution. While the amplifiers are off, each joint's holding
//! brake acts as a viscous torque of 20 N·m·s/rad. The obstacle: a spring of 10⁴ N·m/rad with
//! 200 N·m·s/rad of damping beyond it (critically damped on joint 1's inertia; 0.3 mrad deep
//! under the frozen-encoder check's 3 N·m).

use flexarm_core::drive::{Drive, Mode, MoveLimits, MoveRequest};
use flexarm_core::observer::Measurement;
use flexarm_core::time::Ticks;
use flexarm_core::trajectory::{JointTrajectory, Profile, Trapezoid};
use flexarm_core::{Fault, Vector2};
use flexarm_sim::plant::Plant;
use flexarm_sim::sim::SimConfig;
use flexarm_sim::truth_plant::TruthSpec;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Failure {
    None,
    /// Joint 1's encoder counts the other way.
    Reversed,
    /// Joint 2's reading stops changing at this time [s].
    FrozenFrom(f64),
    /// A rigid obstacle in joint 1's way at this angle [rad].
    Wall(f64),
}

struct Run {
    ctrl: flexarm_core::controller::Controller<f32>,
    drive: Drive<f32>,
    plant: Box<dyn Plant + Send>,
    now: Ticks,
    failure: Failure,
    frozen: Option<f32>,
    /// Time [s] and true joint angles [rad] when the first fault latched or its stop began.
    fault_at: Option<(f64, Vector2<f64>)>,
    /// Largest true joint speed before it [rad/s].
    peak_speed: f64,
}

const COUNTS: f64 = 16384.0 / std::f64::consts::TAU;

impl Run {
    fn new(failure: Failure, start: Vector2<f64>) -> Self {
        let cfg = SimConfig::default()
            .with_truth(TruthSpec::default())
            .unwrap();
        let hold = JointTrajectory::Trapezoid(Trapezoid {
            start: start.cast::<f32>(),
            amplitude: Vector2::zeros(),
            profile: Profile::new(1.0, 0.25).unwrap(),
        });
        let mut ctrl = cfg.controller(&hold).unwrap();
        let plant = cfg.plant_at(start).unwrap();
        let drive = Drive::new(&mut ctrl, 1000, Ticks(0), MoveLimits::default());
        let mut r = Self {
            ctrl,
            drive,
            plant,
            now: Ticks(0),
            failure,
            frozen: None,
            fault_at: None,
            peak_speed: 0.0,
        };
        let theta = r.encoders();
        r.ctrl.reset_observer(theta);
        r
    }

    fn t(&self) -> f64 {
        self.now.0 as f64 * 1e-3
    }

    fn theta(&self) -> Vector2<f64> {
        let x = self.plant.state();
        Vector2::new(x.q.x, x.q.y)
    }

    fn encoders(&mut self) -> Vector2<f32> {
        let th = self.theta().map(|a| ((a * COUNTS).round() / COUNTS) as f32);
        match self.failure {
            Failure::Reversed => Vector2::new(-th.x, th.y),
            Failure::FrozenFrom(t0) if self.t() >= t0 => {
                Vector2::new(th.x, *self.frozen.get_or_insert(th.y))
            }
            _ => th,
        }
    }

    /// One motor period: ten piezo periods of the plant, then the drive's step.
    fn period(&mut self, tau: &mut Vector2<f64>, enabled: &mut bool) {
        for _ in 0..10 {
            let v_a = f64::from(self.ctrl.piezo_step(self.plant.film() as f32));
            let x = self.plant.state();
            let mut applied = if *enabled { *tau } else { Vector2::zeros() };
            if !*enabled {
                applied -= Vector2::new(x.qd.x, x.qd.y) * 20.0;
            }
            if let Failure::Wall(at) = self.failure
                && x.q.x > at
            {
                applied.x -= 1e4 * (x.q.x - at) + 200.0 * x.qd.x;
            }
            self.plant.step(&applied, v_a, 1e-4).unwrap();
        }
        let y = Measurement {
            theta: self.encoders(),
            v_f: self.plant.film() as f32,
        };
        let r = self.drive.step(&mut self.ctrl, self.now, Some(&y));
        *tau = r.command.tau.cast::<f64>();
        *enabled = r.command.enable;
        self.now = self.now.next();
        if self.fault_at.is_none() {
            let x = self.plant.state();
            self.peak_speed = self.peak_speed.max(x.qd.x.abs().max(x.qd.y.abs()));
            if self.ctrl.fault().is_some() || self.drive.pending().is_some() {
                self.fault_at = Some((self.t(), self.theta()));
            }
        }
    }

    fn run(&mut self, seconds: f64) {
        let (mut tau, mut enabled) = (Vector2::zeros(), false);
        for _ in 0..(seconds * 1000.0).round() as usize {
            self.period(&mut tau, &mut enabled);
        }
    }
}

/// Arms at rest at (0, 0), holds 0.1 s, starts (0, 0) → (1, 1) rad in 2 s with 0.5 s ramps
/// (peak 0.67 rad/s), and runs `seconds` after the start.
fn moving(failure: Failure, seconds: f64) -> Run {
    let mut r = Run::new(failure, Vector2::zeros());
    r.drive.arm(&mut r.ctrl, r.now).unwrap();
    r.run(0.1);
    let request = MoveRequest::Trapezoid {
        target: Vector2::new(1.0, 1.0),
        move_time: 2.0,
        ramp_time: 0.5,
    };
    r.drive.start(&mut r.ctrl, r.now, &request).unwrap();
    r.run(seconds);
    r
}

fn report(name: &str, r: &Run, since: f64, from: Vector2<f64>) -> (f64, f64, f64) {
    let (t, at) = r.fault_at.unwrap_or((f64::NAN, Vector2::zeros()));
    let travel = (at - from).abs().max();
    let coast = (r.theta() - at).abs().max();
    println!(
        "{name}: {:?} {:.0} ms after {since:.2} s; travel {travel:.4} rad, peak speed {:.3} rad/s, coast {coast:.4} rad",
        r.ctrl.fault(),
        (t - since) * 1e3,
        r.peak_speed
    );
    ((t - since), travel, coast)
}

#[test]
fn without_a_failure_the_move_runs_clean() {
    let r = moving(Failure::None, 3.0);
    println!(
        "no failure: {:?}, {:?}, ends at {:?}",
        r.ctrl.fault(),
        r.drive.mode(&r.ctrl),
        r.theta()
    );
    assert_eq!(r.ctrl.fault(), None);
    assert_eq!(r.drive.mode(&r.ctrl), Mode::Armed);
    assert!((r.theta() - Vector2::new(1.0, 1.0)).abs().max() < 1e-2);
}

#[test]
fn a_reversed_encoder_on_joint_1_ends_in_runaway() {
    let r = moving(Failure::Reversed, 1.5);
    let (dt, travel, coast) = report("reversed encoder", &r, 0.1, Vector2::zeros());
    assert_eq!(r.ctrl.fault(), Some(Fault::Runaway));
    assert!(dt < 0.15, "within 150 ms of the start");
    assert!(travel < 0.05 && r.peak_speed < 1.0 && coast < 0.06);
}

#[test]
fn a_frozen_encoder_on_joint_2_mid_move_ends_in_frozen_encoder() {
    let mut r = moving(Failure::FrozenFrom(0.8), 0.0);
    r.run(0.7);
    let frozen_at = r.theta();
    r.run(1.0);
    let (dt, travel, coast) = report("frozen encoder", &r, 0.8, frozen_at);
    assert_eq!(r.ctrl.fault(), Some(Fault::FrozenEncoder));
    assert!(dt < 0.05, "within 50 ms of freezing");
    assert!(travel < 0.06 && r.peak_speed < 1.3 && coast < 0.08);
}

#[test]
fn a_stall_against_an_obstacle_is_cut() {
    let r = moving(Failure::Wall(0.3), 1.5);
    let profile = Profile::new(2.0f64, 0.5).unwrap();
    let contact = (0..2000)
        .map(|k| f64::from(k) * 1e-3)
        .find(|&t| profile.sample(t).0 >= 0.3)
        .unwrap()
        + 0.1;
    let (dt, _, coast) = report("stall", &r, contact, Vector2::new(0.3, 0.3));
    // On the truth plant the impact throws joint 2 against its torque: the runaway check sees
    // it first (on the core's stiff-link arm, the frozen-encoder check does, 25 ms after
    // contact). Either is category 0: power off at once.
    let fault = r.ctrl.fault().unwrap();
    assert!(
        matches!(
            fault,
            Fault::Runaway | Fault::FrozenEncoder | Fault::FollowingError
        ),
        "{fault:?}"
    );
    assert_eq!(fault.stop_category(), 0);
    assert!(dt > 0.0 && dt < 0.07, "within 70 ms of contact");
    assert!(coast < 0.03);
}

#[test]
fn a_reference_into_the_range_limit_stops_in_category_1_short_of_the_hard_limit() {
    let mut r = Run::new(Failure::None, Vector2::new(2.0, 0.0));
    r.drive.arm(&mut r.ctrl, r.now).unwrap();
    let request = MoveRequest::Trapezoid {
        target: Vector2::new(2.5, 0.0),
        move_time: 2.0,
        ramp_time: 0.5,
    };
    r.drive.start(&mut r.ctrl, r.now, &request).unwrap();
    // The reference goes on to 4 rad at 1.5 rad/s, past the end of joint 1's range (π).
    r.ctrl.trajectory = JointTrajectory::Trapezoid(Trapezoid {
        start: Vector2::new(2.0, 0.0),
        amplitude: Vector2::new(2.0, 0.0),
        profile: Profile::new(2.0 / 1.5 + 0.2, 0.2).unwrap(),
    });
    let (mut tau, mut enabled) = (Vector2::zeros(), false);
    let mut max_theta: f64 = 0.0;
    for _ in 0..3000 {
        r.period(&mut tau, &mut enabled);
        max_theta = max_theta.max(r.theta().x);
    }
    let (t, at) = r.fault_at.unwrap();
    println!(
        "soft limit: the stop began at {t:.3} s at θ1 = {:.3} rad; fault {:?}; largest θ1 {max_theta:.4} rad (π − {:.4})",
        at.x,
        r.ctrl.fault(),
        std::f64::consts::PI - max_theta
    );
    assert_eq!(r.ctrl.fault(), Some(Fault::SoftLimit));
    assert!(max_theta < std::f64::consts::PI - 0.005, "{max_theta}");
    assert!(!enabled, "power removed after the stop");
}

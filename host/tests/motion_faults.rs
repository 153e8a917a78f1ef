//! The motion checks against the truth plant (six modes of the 2.5 mm beam, drives with a
//! current-loop lag and Coulomb and viscous friction, the piezo amplifier, the film's charge
//! amplifier): the firmware (`SimConfig::board_config`: `f32`, the observer, the drive) on the
//! host's rig (`flexarm_host::rig`) at the board's rates, 1 kHz and 10 kHz, with a failure injected between the plant
//! and the controller. One scenario each: a reversed encoder on joint 1, a frozen encoder on
//! joint 2 mid-move, a stall against a rigid obstacle, a reference that runs into the end of
//! the range at speed. Each must end in its fault within the stated time, with the joint's
//! travel, its peak speed and its coast after the fault within stated bounds; the same move
//! without a failure runs clean.
//!
//! Encoders: 16384 counts a revolution. While the brake output is engaged (whenever the
//! amplifiers are cut), each joint's holding brake acts as a viscous torque of 20 N·m·s/rad. The obstacle: a spring of 10⁴ N·m/rad with
//! 200 N·m·s/rad of damping beyond it (critically damped on joint 1's inertia; 0.3 mrad deep
//! under the frozen-encoder check's 3 N·m).

use flexarm_core::drive::{Mode, MoveRequest};
use flexarm_core::time::Ticks;
use flexarm_core::trajectory::{JointTrajectory, Profile, Trapezoid};
use flexarm_core::{Fault, Vector2};
use flexarm_host::plant::Plant;
use flexarm_host::rig::Rig;
use flexarm_host::sim::SimConfig;
use flexarm_host::truth_plant::TruthSpec;
use flexarm_machine::Board;

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

const COUNTS: f64 = 16384.0 / std::f64::consts::TAU;

/// The truth plant as a board: stepped 1e-4 s a piezo period with the commands held, its
/// brakes while disabled, the obstacle, the encoders with the failure.
struct TruthBoard {
    plant: Box<dyn Plant + Send>,
    failure: Failure,
    frozen: Option<f32>,
    tau: Vector2<f64>,
    v_a: f64,
    enabled: bool,
    /// The brake output (`true` engaged).
    brake: bool,
    /// The brake stuck released (a broken coil driver, a worn lining): the output is written,
    /// the joints coast on their friction.
    brake_stuck: bool,
    /// Plant time [s].
    t: f64,
}

impl TruthBoard {
    fn theta(&self) -> Vector2<f64> {
        let x = self.plant.state();
        Vector2::new(x.q.x, x.q.y)
    }
}

impl Board for TruthBoard {
    fn encoders(&mut self) -> Vector2<f32> {
        let th = self.theta().map(|a| ((a * COUNTS).round() / COUNTS) as f32);
        match self.failure {
            Failure::Reversed => Vector2::new(-th.x, th.y),
            Failure::FrozenFrom(t0) if self.t >= t0 => {
                Vector2::new(th.x, *self.frozen.get_or_insert(th.y))
            }
            _ => th,
        }
    }
    fn film_voltage(&mut self) -> f32 {
        self.plant.film() as f32
    }
    fn set_torques(&mut self, tau: Vector2<f32>) {
        self.tau = tau.cast::<f64>();
    }
    fn set_piezo(&mut self, v_a: f32) {
        self.v_a = f64::from(v_a);
    }
    fn set_enable(&mut self, on: bool) {
        self.enabled = on;
    }
    fn set_brake(&mut self, engaged: bool) {
        self.brake = engaged;
    }
    fn brake_engaged(&mut self) -> bool {
        self.brake
    }
    fn amplifier_fault(&mut self) -> bool {
        false
    }
    fn tick(&mut self) {
        let x = self.plant.state();
        let mut applied = if self.enabled {
            self.tau
        } else {
            Vector2::zeros()
        };
        if self.brake && !self.brake_stuck {
            applied -= Vector2::new(x.qd.x, x.qd.y) * 20.0;
        }
        if let Failure::Wall(at) = self.failure
            && x.q.x > at
        {
            applied.x -= 1e4 * (x.q.x - at) + 200.0 * x.qd.x;
        }
        self.plant.step(&applied, self.v_a, 1e-4).unwrap();
        self.t += 1e-4;
    }
}

struct Run {
    /// The firmware's controller and drive at the board's rates on the truth plant.
    rig: Rig<TruthBoard>,
    /// Time [s] and true joint angles [rad] when the first fault latched or its stop began.
    fault_at: Option<(f64, Vector2<f64>)>,
    /// Largest true joint speed before it [rad/s].
    peak_speed: f64,
}

impl Run {
    fn new(failure: Failure, start: Vector2<f64>) -> Self {
        let cfg = SimConfig::default()
            .with_truth(TruthSpec::default())
            .unwrap();
        let board = TruthBoard {
            plant: cfg.plant_at(start).unwrap(),
            failure,
            frozen: None,
            tau: Vector2::zeros(),
            v_a: 0.0,
            enabled: false,
            brake: true,
            brake_stuck: false,
            t: 0.0,
        };
        Self {
            rig: {
                let mut rig = Rig::new(cfg.board_config().unwrap(), board, Ticks(0));
                // The plant's encoders read its own angles: the arm's frame, declared.
                rig.declare_encoders().unwrap();
                rig
            },
            fault_at: None,
            peak_speed: 0.0,
        }
    }

    fn t(&self) -> f64 {
        self.rig.now().0 as f64 * 1e-3
    }

    fn theta(&self) -> Vector2<f64> {
        self.rig.board.theta()
    }

    /// One motor period: ten piezo periods of the plant, then the drive's step (the rig's).
    fn period(&mut self) {
        self.rig.period();
        if self.fault_at.is_none() {
            let x = self.rig.board.plant.state();
            self.peak_speed = self.peak_speed.max(x.qd.x.abs().max(x.qd.y.abs()));
            if self.rig.control.ctrl.fault().is_some() || self.rig.drive.pending().is_some() {
                self.fault_at = Some((self.t(), self.theta()));
            }
        }
    }

    fn run(&mut self, seconds: f64) {
        for _ in 0..(seconds * 1000.0).round() as usize {
            self.period();
        }
    }
}

/// Arms at rest at (0, 0), holds 0.1 s, starts (0, 0) → (1, 1) rad in 2 s with 0.5 s ramps
/// (peak 0.67 rad/s), and runs `seconds` after the start.
fn moving(failure: Failure, seconds: f64) -> Run {
    let mut r = Run::new(failure, Vector2::zeros());
    r.rig.arm().unwrap();
    r.run(0.1);
    let request = MoveRequest::Trapezoid {
        target: Vector2::new(1.0, 1.0),
        move_time: 2.0,
        ramp_time: 0.5,
    };
    r.rig.start(&request).unwrap();
    r.run(seconds);
    r
}

fn report(name: &str, r: &Run, since: f64, from: Vector2<f64>) -> (f64, f64, f64) {
    let (t, at) = r.fault_at.unwrap_or((f64::NAN, Vector2::zeros()));
    let travel = (at - from).abs().max();
    let coast = (r.theta() - at).abs().max();
    println!(
        "{name}: {:?} {:.0} ms after {since:.2} s; travel {travel:.4} rad, peak speed {:.3} rad/s, coast {coast:.4} rad",
        r.rig.control.ctrl.fault(),
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
        r.rig.control.ctrl.fault(),
        r.rig.mode(),
        r.theta()
    );
    assert_eq!(r.rig.control.ctrl.fault(), None);
    assert_eq!(r.rig.mode(), Mode::Armed);
    assert!((r.theta() - Vector2::new(1.0, 1.0)).abs().max() < 1e-2);
}

#[test]
fn a_reversed_encoder_on_joint_1_ends_in_runaway() {
    let r = moving(Failure::Reversed, 1.5);
    let (dt, travel, coast) = report("reversed encoder", &r, 0.1, Vector2::zeros());
    assert_eq!(r.rig.control.ctrl.fault(), Some(Fault::Runaway));
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
    assert_eq!(r.rig.control.ctrl.fault(), Some(Fault::FrozenEncoder));
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
    let fault = r.rig.control.ctrl.fault().unwrap();
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
    r.rig.arm().unwrap();
    let request = MoveRequest::Trapezoid {
        target: Vector2::new(2.5, 0.0),
        move_time: 2.0,
        ramp_time: 0.5,
    };
    r.rig.start(&request).unwrap();
    // The reference goes on to 4 rad at 1.5 rad/s, past the end of joint 1's range (π).
    r.rig.control.ctrl.trajectory = JointTrajectory::Trapezoid(Trapezoid {
        start: Vector2::new(2.0, 0.0),
        amplitude: Vector2::new(2.0, 0.0),
        profile: Profile::new(2.0 / 1.5 + 0.2, 0.2).unwrap(),
    });
    let mut max_theta: f64 = 0.0;
    for _ in 0..3000 {
        r.period();
        max_theta = max_theta.max(r.theta().x);
    }
    let (t, at) = r.fault_at.unwrap();
    println!(
        "soft limit: the stop began at {t:.3} s at θ1 = {:.3} rad; fault {:?}; largest θ1 {max_theta:.4} rad (π − {:.4})",
        at.x,
        r.rig.control.ctrl.fault(),
        std::f64::consts::PI - max_theta
    );
    assert_eq!(r.rig.control.ctrl.fault(), Some(Fault::SoftLimit));
    assert!(max_theta < std::f64::consts::PI - 0.005, "{max_theta}");
    assert!(!r.rig.board.enabled, "power removed after the stop");
}

/// How a category-0 cut comes.
#[derive(Clone, Copy, Debug)]
enum Cut {
    /// Joint 2's encoder freezes at 0.8 s (`FrozenEncoder`).
    Frozen,
    /// Joint 1's encoder reversed at the start (`Runaway`).
    Reversed,
    /// The link's `Estop` (a disarm) at 1.1 s, at the move's peak speed (0.67 rad/s on both
    /// joints).
    Estop,
}

/// The coast after a category-0 cut during the move (0, 0) → (1, 1) rad: the largest joint
/// travel from the cut to rest [rad] and the time to rest [s] (both joints under 0.01 rad/s;
/// at most 20 s), with the brake working or stuck released. Asserts that the brake output is
/// engaged from the cut on.
fn coast_after(cut: Cut, brake_stuck: bool) -> (f64, f64) {
    let failure = match cut {
        Cut::Frozen => Failure::FrozenFrom(0.8),
        Cut::Reversed => Failure::Reversed,
        Cut::Estop => Failure::None,
    };
    let mut r = moving(failure, 0.0);
    r.rig.board.brake_stuck = brake_stuck;
    if let Cut::Estop = cut {
        r.run(1.0);
        assert_eq!(
            r.rig.answer(flexarm_link::Command::Estop),
            flexarm_link::Reply::Done
        );
        // A disarm, not a latched fault: the cut is the next period's.
        r.fault_at = Some((r.t(), r.theta()));
    }
    while r.fault_at.is_none() && r.t() < 3.0 {
        r.period();
    }
    let (t_cut, at) = r.fault_at.expect("a cut");
    let mut rest = None;
    while r.t() < t_cut + 20.0 {
        r.period();
        assert!(
            r.rig.board.brake && !r.rig.board.enabled,
            "brake engaged from the cut on"
        );
        let x = r.rig.board.plant.state();
        if x.qd.x.abs().max(x.qd.y.abs()) < 1e-2 {
            rest = Some(r.t() - t_cut);
            break;
        }
    }
    let coast = (r.theta() - at).abs().max();
    (coast, rest.unwrap_or(f64::INFINITY))
}

/// The coast table of docs/safety.md ("The brake"): each category-0 cut with the holding brake
/// and with its output stuck released. The brake must hold every coast under 0.06 rad and
/// bring the joints to rest (0.01 rad/s) within 0.5 s; without it the arm coasts on its
/// friction alone, several times farther.
#[test]
fn the_brake_shortens_the_coast_after_a_category_0_cut() {
    for cut in [Cut::Frozen, Cut::Reversed, Cut::Estop] {
        let (braked, t_braked) = coast_after(cut, false);
        let (free, t_free) = coast_after(cut, true);
        println!(
            "{cut:?}: coast with the brake {braked:.4} rad, at rest after {t_braked:.3} s; stuck released {free:.4} rad, at rest after {t_free:.3} s"
        );
        assert!(
            braked < 0.06 && t_braked < 0.5,
            "{cut:?}: {braked} rad, {t_braked} s"
        );
        assert!(
            free > 3.0 * braked,
            "{cut:?}: {free} rad against {braked} rad"
        );
    }
}

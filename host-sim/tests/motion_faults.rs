//! The motion checks against the truth plant (six modes of the 2.5 mm beam, drives with a
//! current-loop lag and Coulomb and viscous friction, the piezo amplifier, the film's charge
//! amplifier): the firmware (`SimConfig::board_config`: `f32`, the observer, the drive) on the
//! host's rig (`flexarm_sim::rig`) at the board's rates, 1 kHz and 10 kHz, with a failure
//! injected between the plant and the controller. One scenario each: a reversed encoder on
//! joint 1, a frozen encoder on joint 2 mid-move, a stall against a rigid obstacle, a
//! reference that runs into the end of the range at speed; and the encoder grid: a frozen
//! encoder on either joint at reference speeds from 0.01 to 2 rad/s, a coupling slipping at
//! 0.5 rad/s holding and moving (`cargo test -p flexarm-sim --test motion_faults --
//! --nocapture --test-threads 1` prints its table, docs/safety.md). Each must end in its fault
//! within the stated time, with the joint's travel, its peak speed and its coast after the
//! fault within stated bounds; the same move without a failure runs clean.
//!
//! Encoders: 16384 counts a revolution. While the amplifiers are off, each joint's holding
//! brake acts as a viscous torque of 20 N·m·s/rad. The obstacle: a spring of 10⁴ N·m/rad with
//! 200 N·m·s/rad of damping beyond it (critically damped on joint 1's inertia).

use flexarm_core::drive::{Mode, MoveRequest};
use flexarm_core::time::Ticks;
use flexarm_core::trajectory::{JointTrajectory, Profile, Trapezoid};
use flexarm_core::{Fault, Vector2};
use flexarm_machine::Board;
use flexarm_sim::plant::Plant;
use flexarm_sim::rig::Rig;
use flexarm_sim::sim::SimConfig;
use flexarm_sim::truth_plant::TruthSpec;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Failure {
    None,
    /// Joint 1's encoder counts the other way.
    Reversed,
    /// The joint's reading stops changing at this time [s].
    Frozen {
        joint: usize,
        from: f64,
    },
    /// The joint's reading drifts off it at `rate` [rad/s] from this time [s] (a slipping
    /// coupling).
    Slip {
        joint: usize,
        from: f64,
        rate: f64,
    },
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
        let mut th = th;
        match self.failure {
            Failure::Reversed => th.x = -th.x,
            Failure::Frozen { joint, from } if self.t >= from => {
                th[joint] = *self.frozen.get_or_insert(th[joint]);
            }
            Failure::Slip { joint, from, rate } if self.t >= from => {
                th[joint] += ((self.t - from) * rate) as f32;
            }
            _ => {}
        }
        th
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
    fn amplifier_fault(&mut self) -> bool {
        false
    }
    fn tick(&mut self) {
        let x = self.plant.state();
        let mut applied = if self.enabled {
            self.tau
        } else {
            -Vector2::new(x.qd.x, x.qd.y) * 20.0
        };
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
            t: 0.0,
        };
        Self {
            rig: Rig::new(cfg.board_config().unwrap(), board, Ticks(0)),
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
fn a_reversed_encoder_on_joint_1_is_cut_before_it_travels() {
    let r = moving(Failure::Reversed, 1.5);
    let (dt, travel, coast) = report("reversed encoder", &r, 0.1, Vector2::zeros());
    assert_eq!(r.rig.control.ctrl.fault(), Some(Fault::EncoderMismatch));
    assert!(dt < 0.1, "within 100 ms of the start");
    assert!(travel < 0.01 && r.peak_speed < 0.5 && coast < 0.02);
}

#[test]
fn a_frozen_encoder_on_joint_2_mid_move_ends_in_frozen_encoder() {
    let mut r = moving(
        Failure::Frozen {
            joint: 1,
            from: 0.8,
        },
        0.0,
    );
    r.run(0.7);
    let frozen_at = r.theta();
    r.run(1.0);
    let (dt, travel, coast) = report("frozen encoder", &r, 0.8, frozen_at);
    assert_eq!(r.rig.control.ctrl.fault(), Some(Fault::FrozenEncoder));
    assert!(dt < 0.02, "within 20 ms of freezing");
    assert!(travel < 0.02 && r.peak_speed < 0.8 && coast < 0.05);
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
    // On the truth plant the impact throws joint 2 where its torque does not move it: the
    // encoder check names it a mismatch (on the core's stiff-link arm, a frozen reading of
    // joint 1, 4 ms after contact). Either is category 0: power off at once.
    let fault = r.rig.control.ctrl.fault().unwrap();
    assert!(
        matches!(fault, Fault::EncoderMismatch | Fault::FrozenEncoder),
        "{fault:?}"
    );
    assert_eq!(fault.stop_category(), 0);
    assert!(dt > 0.0 && dt < 0.03, "within 30 ms of contact");
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

/// What an encoder failure did: the fault, from the onset to the cut [s], the failing joint's
/// true travel from the onset to the cut and the part of it its reading did not show [rad],
/// its coast after the cut [rad].
#[derive(Debug)]
struct Outcome {
    fault: Option<Fault>,
    detect: f64,
    travel: f64,
    unseen: f64,
    coast: f64,
}

/// One scenario of the encoder grid: both joints move from `(−A, −A)` to `(A, A)` at the
/// cruise speed `speed` [rad/s] (ramps at 5 rad/s², at least 0.1 s; `A` at most 1.2 rad), and
/// `joint`'s encoder fails (`frozen`, or slipping at `slip` rad/s) 0.1 s into the cruise; a
/// speed of 0 holds (0, 0), the failure 0.3 s after arming. Runs until the cut (at most 1 s
/// after the onset), then until the joints rest.
fn encoder_scenario(joint: usize, speed: f64, slip: Option<f64>) -> Outcome {
    let ramp = (speed / 5.0).max(0.1);
    let half = (speed * (ramp + 1.1) / 2.0).min(1.2);
    let onset = 0.1 + if speed > 0.0 { ramp + 0.1 } else { 0.2 };
    let failure = match slip {
        None => Failure::Frozen { joint, from: onset },
        Some(rate) => Failure::Slip {
            joint,
            from: onset,
            rate,
        },
    };
    let mut r = Run::new(failure, Vector2::new(-half, -half));
    r.rig.arm().unwrap();
    r.run(0.1);
    if speed > 0.0 {
        let request = MoveRequest::Trapezoid {
            target: Vector2::new(half as f32, half as f32),
            move_time: (2.0 * half / speed + ramp) as f32,
            ramp_time: ramp as f32,
        };
        r.rig.start(&request).unwrap();
    }
    while r.t() < onset - 5e-4 {
        r.period();
    }
    let from = r.theta()[joint];
    let read_from = f64::from(r.rig.board.encoders()[joint]);
    while r.fault_at.is_none() && r.t() < onset + 1.0 {
        r.period();
    }
    let (t, at) = r.fault_at.unwrap_or((r.t(), r.theta()));
    // The reading when the fault was found: the board's now, less the slip since.
    let read = f64::from(r.rig.board.encoders()[joint]) - slip.map_or(0.0, |v| v * (r.t() - t));
    let unseen = ((at[joint] - from) - (read - read_from)).abs();
    for _ in 0..1000 {
        r.period();
    }
    Outcome {
        fault: r.rig.control.ctrl.fault(),
        detect: if r.fault_at.is_some() {
            t - onset
        } else {
            f64::INFINITY
        },
        travel: (at[joint] - from).abs(),
        unseen,
        coast: (r.theta()[joint] - at[joint]).abs(),
    }
}

/// A row of the table; a failure not cut shows its joint's travel over the second it ran.
fn print_row(joint: usize, speed: f64, failure: &str, o: &Outcome) {
    let (detect, coast) = match o.fault {
        Some(_) => (format!("{:.0}", o.detect * 1e3), format!("{:.4}", o.coast)),
        None => ("> 1000".into(), "—".into()),
    };
    println!(
        "| {} | {failure} | {speed} | {} | {detect} | {:.4} | {:.4} | {coast} |",
        joint + 1,
        o.fault.map_or("none".into(), |f| format!("`{f:?}`")),
        o.travel,
        o.unseen,
    );
}

const TABLE_HEAD: &str = "| joint | failure | reference speed [rad/s] | fault | detected after [ms] | travel before the cut [rad] | of it unseen [rad] | coast after [rad] |\n|---|---|---|---|---|---|---|---|";

/// A frozen encoder on either joint at reference speeds from 0.01 to 2 rad/s (issue 33: the
/// speed-threshold check let the joint travel 0.48 to 1.96 rad below 0.1 rad/s): cut, as a
/// frozen encoder, before its joint travels 0.05 rad.
#[test]
fn a_frozen_encoder_is_cut_within_0_05_rad_at_any_speed() {
    println!("{TABLE_HEAD}");
    let mut worst: f64 = 0.0;
    for joint in 0..2 {
        for speed in [0.01, 0.03, 0.05, 0.1, 0.3, 1.0, 2.0] {
            let o = encoder_scenario(joint, speed, None);
            print_row(joint, speed, "frozen", &o);
            assert_eq!(
                o.fault,
                Some(Fault::FrozenEncoder),
                "{joint} {speed}: {o:?}"
            );
            assert!(o.travel <= 0.05, "{joint} {speed}: {o:?}");
            worst = worst.max(o.travel);
        }
    }
    println!("worst travel before the cut: {worst:.4} rad");
}

/// A coupling that starts to slip at 0.5 rad/s (issue 33: 2.9 rad in 5.8 s unnoticed while
/// holding), holding or moving: cut as a mismatch within 30 ms, its joint less than 0.015 rad
/// from where its reading puts it (the slip so far: the law holds the reading on the reference).
#[test]
fn a_slipping_encoder_is_cut_holding_or_moving() {
    println!("{TABLE_HEAD}");
    for joint in 0..2 {
        for speed in [0.0, 0.1, 1.0] {
            let o = encoder_scenario(joint, speed, Some(0.5));
            print_row(joint, speed, "slip 0.5 rad/s", &o);
            assert_eq!(
                o.fault,
                Some(Fault::EncoderMismatch),
                "{joint} {speed}: {o:?}"
            );
            assert!(
                o.detect < 0.03 && o.unseen < 0.015,
                "{joint} {speed}: {o:?}"
            );
        }
    }
}

/// The slowest slips the check catches, holding and at 0.1 rad/s: from 0.2 and 0.1 rad/s on
/// joint 1, 0.5 and 0.2 rad/s on joint 2 (within 50 ms). Slower slips look like the friction and
/// disturbance the check allows for (`flexarm_core::motion::COULOMB`, `DISTURBANCE`): the
/// table printed shows how far their joints drift unseen in a second (docs/safety.md).
#[test]
fn the_slowest_slips_caught_are_as_stated() {
    println!("{TABLE_HEAD}");
    for (joint, holding, moving) in [(0, 0.2, 0.1), (1, 0.5, 0.2)] {
        for rate in [0.02, 0.05, 0.1, 0.2, 0.5] {
            for (speed, least) in [(0.0, holding), (0.1, moving)] {
                let o = encoder_scenario(joint, speed, Some(rate));
                print_row(joint, speed, &format!("slip {rate} rad/s"), &o);
                if rate >= least {
                    assert_eq!(o.fault, Some(Fault::EncoderMismatch), "{rate} {o:?}");
                    assert!(o.detect < 0.05, "{rate} {o:?}");
                }
            }
        }
    }
}

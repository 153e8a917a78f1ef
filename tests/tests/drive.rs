//! The drive's modes in closed loop with the QEMU board's simulated arm, as the hardware
//! board's firmware runs them on the host's rig (`flexarm_host::rig`: `f32`, motor loop 1 kHz,
//! piezo loop 10 kHz, the generated `HARDWARE` configuration): disarmed outputs are safe while the observer
//! follows; arm holds; a move is validated whole or refused with its reason; a stop decelerates
//! within the limits and holds; a fault is cleared only when its cause is gone.

#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

use flexarm_core::Fault;
use flexarm_core::Vector2;
use flexarm_core::Vector4;
use flexarm_core::drive::{Mode, MoveRequest, Refused, Waypoint};
use flexarm_core::observer::Measurement;
use flexarm_host::rig::Rig;
use flexarm_link::msg::Board;
use flexarm_tests::{Injection, TestArm, firmware, test_rig};

struct Bench {
    rig: Rig<TestArm>,
}

impl Bench {
    /// The hardware board's firmware (piezo 10 kHz, motor 1 kHz) on the simulated arm at rest
    /// at `theta` [rad].
    fn new(theta: Vector2<f32>) -> Self {
        Self {
            rig: test_rig(
                firmware(Board::Hardware),
                [theta.x, theta.y],
                Injection::None,
            ),
        }
    }

    fn measurement(&mut self) -> Measurement<f32> {
        flexarm_machine::period::sense(&mut self.rig.board).y
    }

    /// One motor period: ten piezo periods of the plant, then the motor step. Returns the
    /// largest |τ| and |V_a| commanded.
    fn period(&mut self) -> (f32, f32) {
        let p = self.rig.period();
        (p.command.tau.abs().max(), self.rig.board.take_peak())
    }

    fn run(&mut self, seconds: f32) -> (f32, f32) {
        let mut peak = (0.0f32, 0.0f32);
        for _ in 0..(seconds * 1000.0) as usize {
            let (t, v) = self.period();
            peak = (peak.0.max(t), peak.1.max(v));
        }
        peak
    }

    /// `Tuning::set` in the drive's mode now.
    fn tune(
        &mut self,
        t: &mut flexarm_core::tuning::Tuning<f32>,
        p: flexarm_core::tuning::Tunable,
        v: f32,
    ) -> Result<(), flexarm_core::tuning::TuneError> {
        let mode = self.rig.mode();
        t.set(&mut self.rig.control.ctrl, mode, p, v)
    }

    fn theta(&self) -> Vector2<f32> {
        self.rig.board.sim.arm.x.q.xy()
    }
}

fn trapezoid(target: [f32; 2], move_time: f32, ramp_time: f32) -> MoveRequest<f32> {
    MoveRequest::Trapezoid {
        target: Vector2::new(target[0], target[1]),
        move_time,
        ramp_time,
    }
}

#[test]
fn disarmed_the_outputs_are_safe_and_the_observer_follows() {
    let mut b = Bench::new(Vector2::new(0.3, -0.2));
    // A free swing of the arm: an initial speed, no torque.
    b.rig.board.sim.arm.x.qd = Vector4::new(0.5, -0.4, 0.0, 0.0);
    let (tau, v) = b.run(1.0);
    assert_eq!(b.rig.drive.mode(&b.rig.control.ctrl), Mode::Disarmed);
    assert_eq!((tau, v), (0.0, 0.0), "safe command while disarmed");
    assert!(!b.rig.board.sim.arm.enabled());
    let err = (b.rig.control.ctrl.estimate().0.xy() - b.theta())
        .abs()
        .max();
    assert!(err < 2e-3, "the observer follows the free arm: {err}");
    // A move is refused until armed.
    let r = b.rig.start(&trapezoid([0.5, 0.0], 2.0, 0.5));
    assert_eq!(r, Err(Refused::NotArmed));
}

#[test]
fn armed_it_holds_a_move_runs_and_ends_holding_at_its_target() {
    let mut b = Bench::new(Vector2::new(0.1, 0.2));
    b.rig.arm().unwrap();
    b.run(0.5);
    assert_eq!(b.rig.drive.mode(&b.rig.control.ctrl), Mode::Armed);
    assert!((b.theta() - Vector2::new(0.1, 0.2)).abs().max() < 2e-3);
    let d = b
        .rig
        .drive
        .start(
            &mut b.rig.control.ctrl,
            b.rig.motor.now(),
            &trapezoid([1.0, -0.6], 2.0, 0.5),
        )
        .unwrap();
    assert_eq!(d, 2.0);
    assert_eq!(b.rig.drive.mode(&b.rig.control.ctrl), Mode::Moving);
    // While it runs another move is refused.
    let r = b.rig.start(&trapezoid([0.0, 0.0], 2.0, 0.5));
    assert_eq!(r, Err(Refused::Moving));
    b.run(1.995);
    assert_eq!(b.rig.drive.mode(&b.rig.control.ctrl), Mode::Moving);
    b.run(0.01);
    assert_eq!(
        b.rig.drive.mode(&b.rig.control.ctrl),
        Mode::Armed,
        "holding from the move's end"
    );
    b.run(1.0);
    let err = (b.theta() - Vector2::new(1.0, -0.6)).abs().max();
    assert!(err < 2e-3, "holds the target: {err}");
    assert!(b.rig.control.ctrl.fault().is_none());
}

#[test]
fn a_move_is_validated_whole_and_refused_with_its_reason() {
    let mut b = Bench::new(Vector2::zeros());
    b.rig.arm().unwrap();
    let held = b.rig.control.ctrl.trajectory;
    for (req, why) in [
        (trapezoid([f32::NAN, 0.0], 2.0, 0.5), Refused::OutOfRange),
        (trapezoid([0.5, 0.0], 2.0, 1.5), Refused::OutOfRange),
        (trapezoid([0.5, 0.0], -1.0, 0.5), Refused::OutOfRange),
        // Longer than MAX_MOVE_TIME (an hour), up to a mistyped 1e30 s.
        (trapezoid([0.5, 0.0], 3601.0, 1.0), Refused::OutOfRange),
        (trapezoid([0.5, 0.0], 1e30, 1.0), Refused::OutOfRange),
        (trapezoid([3.5, 0.0], 4.0, 1.0), Refused::Unreachable),
        (trapezoid([0.0, -2.75], 4.0, 1.0), Refused::Unreachable),
        // 2 rad in 0.5 s: 5.3 rad/s.
        (trapezoid([2.0, 0.0], 0.5, 0.125), Refused::TooFast),
        // 1 rad, 0.05 s ramps: 1.05 rad/s but 21 rad/s².
        (trapezoid([1.0, 0.0], 1.0, 0.05), Refused::TooFast),
    ] {
        assert_eq!(b.rig.start(&req), Err(why), "{req:?}");
        assert_eq!(b.rig.control.ctrl.trajectory, held, "nothing applied");
        assert_eq!(b.rig.drive.mode(&b.rig.control.ctrl), Mode::Armed);
    }
    // The torque estimate: a move within speed and acceleration limits but asking more than
    // half of a lowered torque limit.
    b.rig.control.ctrl.motor.limits.tau_max = Vector2::new(1.0, 1.0);
    let r = b.rig.start(&trapezoid([1.5, 0.0], 1.0, 0.2));
    assert_eq!(r, Err(Refused::TooFast));
}

#[test]
fn a_stop_decelerates_within_the_limits_and_holds() {
    let mut b = Bench::new(Vector2::zeros());
    b.rig.arm().unwrap();
    b.rig.start(&trapezoid([2.0, 1.0], 2.0, 0.5)).unwrap();
    b.run(1.0); // mid-move, at 1.33 rad/s on joint 1
    let speed = b.rig.board.sim.arm.x.qd.x;
    assert!(speed > 1.0, "{speed}");
    b.rig.stop().unwrap();
    assert_eq!(b.rig.drive.mode(&b.rig.control.ctrl), Mode::Stopping);
    let at_stop = b.theta();
    // Reference: v²/(2a) = 1.33²/20 = 0.09 rad to rest at 10 rad/s².
    b.run(0.5);
    assert_eq!(
        b.rig.drive.mode(&b.rig.control.ctrl),
        Mode::Armed,
        "the stop ended"
    );
    b.run(0.5);
    let travelled = (b.theta() - at_stop).abs().max();
    assert!(travelled > 0.06 && travelled < 0.12, "{travelled}");
    assert!(
        b.rig.board.sim.arm.x.qd.xy().abs().max() < 1e-2,
        "at rest: {:?}",
        b.rig.board.sim.arm.x.qd
    );
    assert!(
        b.rig.board.sim.arm.enabled(),
        "category 1: the power stays on until the host disarms"
    );
    assert!(b.rig.control.ctrl.fault().is_none());
}

#[test]
fn a_fault_is_cleared_only_when_its_cause_is_gone() {
    let mut b = Bench::new(Vector2::zeros());
    b.rig.arm().unwrap();
    b.run(0.1);
    // An encoder reading out of range.
    let bad = Measurement {
        theta: Vector2::new(5.0, 0.0),
        v_f: 0.0,
    };
    b.rig
        .control
        .ctrl
        .motor_step(b.rig.drive.time(b.rig.motor.now()), Some(&bad));
    assert_eq!(b.rig.control.ctrl.fault(), Some(Fault::OutOfRange));
    assert_eq!(b.rig.drive.mode(&b.rig.control.ctrl), Mode::Fault);
    assert_eq!(b.rig.arm(), Err(Refused::Faulted));
    assert_eq!(
        b.rig
            .drive
            .clear(&mut b.rig.control.ctrl, Some(&bad), false),
        Err(Refused::CauseActive)
    );
    let good = b.measurement();
    assert_eq!(
        b.rig
            .drive
            .clear(&mut b.rig.control.ctrl, Some(&good), false),
        Ok(Fault::OutOfRange)
    );
    assert_eq!(b.rig.drive.mode(&b.rig.control.ctrl), Mode::Disarmed);
    assert_eq!(
        b.rig
            .drive
            .clear(&mut b.rig.control.ctrl, Some(&good), false),
        Err(Refused::CauseActive)
    );
    // An amplifier fault stays while its line is asserted; a clock failure never clears.
    b.rig.control.ctrl.trip(Fault::Amplifier);
    assert_eq!(
        b.rig
            .drive
            .clear(&mut b.rig.control.ctrl, Some(&good), true),
        Err(Refused::CauseActive)
    );
    assert_eq!(
        b.rig
            .drive
            .clear(&mut b.rig.control.ctrl, Some(&good), false),
        Ok(Fault::Amplifier)
    );
    b.rig.control.ctrl.trip(Fault::Clock);
    assert_eq!(
        b.rig
            .drive
            .clear(&mut b.rig.control.ctrl, Some(&good), false),
        Err(Refused::CauseActive)
    );
    // After a clear the drive re-arms and holds.
    let mut b = Bench::new(Vector2::zeros());
    b.rig.control.ctrl.trip(Fault::Overrun);
    let good = b.measurement();
    b.rig
        .drive
        .clear(&mut b.rig.control.ctrl, Some(&good), false)
        .unwrap();
    b.rig.arm().unwrap();
    b.run(0.5);
    assert!(b.theta().abs().max() < 2e-3 && b.rig.control.ctrl.fault().is_none());
}

#[test]
fn disarm_is_always_accepted_and_cuts_the_outputs_in_the_same_period() {
    let mut b = Bench::new(Vector2::zeros());
    b.rig.arm().unwrap();
    b.rig.start(&trapezoid([1.0, 1.0], 2.0, 0.5)).unwrap();
    b.run(0.7);
    b.rig.drive.disarm(&mut b.rig.control.ctrl);
    let (tau, v) = b.period();
    assert_eq!((tau, v), (0.0, 0.0));
    assert!(!b.rig.board.sim.arm.enabled());
    assert_eq!(b.rig.drive.mode(&b.rig.control.ctrl), Mode::Disarmed);
}

#[test]
fn the_link_watchdog_stops_a_move_the_host_stopped_watching() {
    let mut b = Bench::new(Vector2::zeros());
    b.rig.drive.link_timeout = 200; // 0.2 s at 1 kHz
    b.rig.arm().unwrap();
    // No host has spoken: a move runs to its end unwatched (the QEMU verdict runs' boot move).
    b.rig.start(&trapezoid([0.5, 0.0], 1.0, 0.25)).unwrap();
    b.run(1.1);
    assert_eq!(
        (
            b.rig.drive.mode(&b.rig.control.ctrl),
            b.rig.drive.link_stops()
        ),
        (Mode::Armed, 0)
    );
    // A host that keeps talking keeps its move.
    b.rig.drive.heard(b.rig.motor.now());
    b.rig.start(&trapezoid([0.0, 0.0], 1.0, 0.25)).unwrap();
    for _ in 0..11 {
        b.rig.drive.heard(b.rig.motor.now());
        b.run(0.1);
    }
    assert_eq!(
        (
            b.rig.drive.mode(&b.rig.control.ctrl),
            b.rig.drive.link_stops()
        ),
        (Mode::Armed, 0)
    );
    assert!(b.theta().abs().max() < 2e-3, "reached its target");
    // A host that falls silent: stopped 0.2 s later, short of the target, then holding.
    b.rig.drive.heard(b.rig.motor.now());
    b.rig.start(&trapezoid([1.0, 0.0], 2.0, 0.5)).unwrap();
    b.run(0.15);
    assert_eq!(
        b.rig.drive.mode(&b.rig.control.ctrl),
        Mode::Moving,
        "within the timeout"
    );
    b.run(0.1);
    assert_ne!(b.rig.drive.mode(&b.rig.control.ctrl), Mode::Moving);
    assert_eq!(b.rig.drive.link_stops(), 1);
    b.run(1.0);
    assert_eq!(b.rig.drive.mode(&b.rig.control.ctrl), Mode::Armed);
    let held = b.theta().x;
    assert!(
        held > 0.01 && held < 0.2,
        "stopped early in the move: {held}"
    );
    assert!(
        b.rig.board.sim.arm.enabled() && b.rig.control.ctrl.fault().is_none(),
        "a stop, not a fault"
    );
}

#[test]
fn parameters_are_validated_whole_refused_while_moving_and_applied_at_rest() {
    use flexarm_core::control::piezo::{PiezoGains, PiezoLaw};
    use flexarm_core::tuning::{Tunable, TuneError};
    let mut b = Bench::new(Vector2::zeros());
    // The board's: its piezo period, its ceilings (10 N·m, the hardware's ±175 V window).
    let mut t = b.rig.cfg.tuning();
    // The hardware board ships the piezo loop off (issue 35), nothing measured: the laws a
    // design rule builds are refused. The paper's rate law at its shipped gain (30 s, 100 Hz)
    // is past this board's ceiling (issue 36: the spillover study's ten-mode link, a factor of
    // 2; `RateCeiling`), so it is refused too; at the study's rule (3.16 s, 30 Hz) it is
    // taken (disarmed). While the law is off its gains are not held to the ceiling.
    use flexarm_core::control::select::PiezoLawKind;
    assert_eq!(b.rig.control.ctrl.selected(), PiezoLawKind::Off);
    assert_eq!(
        b.tune(&mut t, Tunable::PiezoLaw, 3.0),
        Err(TuneError::Unidentified)
    );
    assert_eq!(
        b.tune(&mut t, Tunable::PiezoLaw, 1.0),
        Err(TuneError::Unstable)
    );
    b.tune(&mut t, Tunable::CutoffHz, 30.0).unwrap();
    b.tune(&mut t, Tunable::Kc, 3.16).unwrap();
    b.tune(&mut t, Tunable::PiezoLaw, 1.0).unwrap();
    assert_eq!(b.rig.control.ctrl.selected(), PiezoLawKind::Rate);
    // At rest: applied, and read back. (A K_p whose velocity loop runs at 0.99 of the rate
    // the period allows is accepted, 1.01 refused: `Model::velocity_loop_rate`.)
    let kp = b.rig.control.ctrl.motor.gains.kp;
    let rate = |k: f32| {
        let m = &b.rig.control.ctrl.motor.model;
        m.velocity_loop_rate(Vector2::new(k * kp.x, k * kp.y)) * b.rig.control.ctrl.motor_period
    };
    let edge = 1.0 / rate(1.0);
    for (k, ok) in [(0.99 * edge, true), (1.01 * edge, false)] {
        let r = b
            .tune(&mut t, Tunable::Kp(0), k * kp.x)
            .and_then(|()| b.tune(&mut t, Tunable::Kp(1), k * kp.y));
        assert_eq!(r.is_ok(), ok, "K_p × {k}: {r:?}");
        b.tune(&mut t, Tunable::Kp(0), kp.x).unwrap();
        b.tune(&mut t, Tunable::Kp(1), kp.y).unwrap();
    }
    b.tune(&mut t, Tunable::Kp(1), 20.0).unwrap();
    assert_eq!(t.get(&b.rig.control.ctrl, Tunable::Kp(1)), Ok(20.0));
    assert_eq!(b.rig.control.ctrl.motor.gains.kp.y, 20.0);
    b.tune(&mut t, Tunable::Kc, 3.0).unwrap();
    assert_eq!(t.get(&b.rig.control.ctrl, Tunable::Kc), Ok(3.0));
    // k_c = 0: the piezo loop off (bring-up, before the film's sign is known): a film voltage
    // that moves gives a command with k_c = 3 s, none with 0.
    b.rig.control.ctrl.set_armed(true);
    let ramp = |b: &mut Bench| {
        (1..=5)
            .map(|k| b.rig.control.ctrl.piezo_step(0.01 * k as f32).abs())
            .sum::<f32>()
    };
    assert!(ramp(&mut b) > 1.0);
    b.tune(&mut t, Tunable::Kc, 0.0).unwrap();
    assert_eq!(ramp(&mut b), 0.0);
    b.tune(&mut t, Tunable::Kc, 3.0).unwrap();
    b.rig.control.ctrl.set_armed(false);
    let want = PiezoLaw::new(
        &PiezoGains {
            k_c: 3.0,
            cutoff_hz: 30.0,
        },
        1e-4,
        175.0,
    );
    assert_eq!(
        b.rig.control.ctrl.piezo, want,
        "the piezo law rebuilt with the new gain"
    );
    // Refused, and nothing written: out of range, unknown, above the board's ceiling.
    let before = (b.rig.control.ctrl.motor, b.rig.control.ctrl.piezo, t);
    for (p, v, why) in [
        (Tunable::Kp(0), -1.0, TuneError::OutOfRange),
        (Tunable::Lambda(2), 0.0, TuneError::OutOfRange),
        (Tunable::Kc, f32::NAN, TuneError::OutOfRange),
        (Tunable::Kc, -3.0, TuneError::OutOfRange),
        (Tunable::CutoffHz, 1e9, TuneError::OutOfRange),
        (Tunable::TauMax(0), 12.0, TuneError::OutOfRange),
        // Under the floor, 1 % of the 10 N·m ceiling (issue 36: 1e-30 was accepted).
        (Tunable::TauMax(0), 1e-30, TuneError::OutOfRange),
        (Tunable::TauMax(1), 0.09, TuneError::OutOfRange),
        (Tunable::VaMax, 180.0, TuneError::OutOfRange),
        (Tunable::VaMin, 5.0, TuneError::OutOfRange),
        (Tunable::VaMin, -180.0, TuneError::OutOfRange),
        // Outside the sampled motor loop's stable region at this board's 1 kHz (issue 36):
        // K_p 1e6 (its velocity loop's rate times the period far past 1), Λ 1e9, and a Λ just
        // past the rule λT ≤ 1 (1.005).
        (Tunable::Kp(0), 1e6, TuneError::Unstable),
        (Tunable::Lambda(0), 1e9, TuneError::Unstable),
        (Tunable::Lambda(1), 1005.0, TuneError::Unstable),
        // The rate law past its ceiling: 3.6 s at 30 Hz (the ceiling 3.3 s there), and the
        // shipped 100 Hz corner under 3 s (1.1 s there).
        (Tunable::Kc, 3.6, TuneError::Unstable),
        (Tunable::CutoffHz, 100.0, TuneError::Unstable),
        (Tunable::Kp(4), 1.0, TuneError::Unknown),
        (Tunable::DDelta(2), 1.0, TuneError::Unknown),
    ] {
        assert_eq!(b.tune(&mut t, p, v), Err(why), "{p:?} = {v}");
    }
    assert_eq!(
        (b.rig.control.ctrl.motor, b.rig.control.ctrl.piezo, t),
        before
    );
    assert_eq!(
        t.get(&b.rig.control.ctrl, Tunable::TauMax(2)),
        Err(TuneError::Unknown)
    );
    // Just above the floor: accepted (and put back).
    let ceiling = b.rig.control.ctrl.motor.limits.tau_max.y;
    b.tune(&mut t, Tunable::TauMax(1), 0.2).unwrap();
    assert_eq!(t.get(&b.rig.control.ctrl, Tunable::TauMax(1)), Ok(0.2));
    b.tune(&mut t, Tunable::TauMax(1), ceiling).unwrap();
    // An asymmetric window for a patch rated −30 V … +175 V: the law saturates there.
    b.tune(&mut t, Tunable::VaMin, -30.0).unwrap();
    assert_eq!(t.get(&b.rig.control.ctrl, Tunable::VaMin), Ok(-30.0));
    assert_eq!(b.rig.control.ctrl.piezo.window(), (-30.0, 175.0));
    // While a move runs: refused; after it: accepted.
    b.rig.arm().unwrap();
    b.rig.start(&trapezoid([0.3, 0.0], 1.0, 0.25)).unwrap();
    b.run(0.1);
    assert_eq!(b.tune(&mut t, Tunable::Kp(0), 50.0), Err(TuneError::Moving));
    b.run(1.0);
    b.tune(&mut t, Tunable::Kp(0), 50.0).unwrap();
    assert_eq!(b.rig.control.ctrl.motor.gains.kp.x, 50.0);
    b.run(0.5);
    assert!(b.rig.control.ctrl.fault().is_none() && (b.theta().x - 0.3).abs() < 2e-3);
}

#[test]
fn a_circle_starts_where_the_tip_is_held_and_is_refused_otherwise() {
    use flexarm_core::trajectory::Circle;
    let start = Circle::<f32>::paper(0.3, 0.7).unwrap().start;
    let mut b = Bench::new(start);
    b.rig.arm().unwrap();
    b.run(0.2);
    let circle = |centre: [f32; 2], radius: f32, period: f32| MoveRequest::Circle {
        centre: Vector2::new(centre[0], centre[1]),
        radius,
        period,
        ramp_time: 0.5,
        clockwise: true,
    };
    let held = b.rig.control.ctrl.trajectory;
    for (req, why) in [
        // The tip is not on this circle.
        (circle([0.6, 0.0], 0.2, 4.0), Refused::Unreachable),
        // On it, but the circle leaves the reachable annulus.
        (
            circle([0.65, 0.2], 0.2 * 2f32.sqrt(), 4.0),
            Refused::Unreachable,
        ),
        // One revolution in 0.8 s: too fast.
        (circle([0.65, 0.0], 0.2, 1.0), Refused::TooFast),
        (circle([0.65, 0.0], 0.2, f32::NAN), Refused::OutOfRange),
        (circle([0.65, 0.0], 0.2, 1e7), Refused::OutOfRange),
        (circle([0.65, 0.0], -0.2, 4.0), Refused::OutOfRange),
    ] {
        assert_eq!(b.rig.start(&req), Err(why), "{req:?}");
        assert_eq!(b.rig.control.ctrl.trajectory, held, "nothing applied");
    }
    assert_eq!(b.rig.start(&circle([0.65, 0.0], 0.2, 4.0)), Ok(4.0));
    let mut worst: f32 = 0.0;
    for _ in 0..4100 {
        b.period();
        let t = b.rig.drive.time(b.rig.motor.now());
        let target = b.rig.control.ctrl.trajectory.sample(t).q;
        worst = worst.max((b.theta() - target).abs().max());
    }
    assert_eq!(b.rig.drive.mode(&b.rig.control.ctrl), Mode::Armed);
    println!("circle: largest |θ − θ_d| {worst:.2e} rad");
    assert!(worst < 2e-3, "{worst}");
    assert!((b.theta() - start).abs().max() < 2e-3, "back at its start");
}

/// The path of the waypoint test: joint 1 out and back, joint 2 on a detour, 12 waypoints.
fn path() -> Vec<Waypoint<f32>> {
    let pts: [(f32, f32, f32); 12] = [
        (0.2, 0.1, 0.4),
        (0.4, 0.3, 0.4),
        (0.7, 0.4, 0.5),
        (0.9, 0.4, 0.3),
        (1.0, 0.2, 0.3),
        (1.0, 0.0, 0.4),
        (0.8, -0.3, 0.5),
        (0.5, -0.5, 0.5),
        (0.3, -0.4, 0.4),
        (0.2, -0.2, 0.3),
        (0.1, 0.0, 0.3),
        (0.1, 0.0, 0.2),
    ];
    pts.iter()
        .map(|&(a, b, dt)| Waypoint {
            theta: Vector2::new(a, b),
            dt,
        })
        .collect()
}

#[test]
fn a_waypoint_path_is_uploaded_in_chunks_validated_whole_and_tracked_without_overshoot() {
    let mut b = Bench::new(Vector2::zeros());
    b.rig.arm().unwrap();
    b.run(0.1);
    let pts = path();
    let go = |n: usize| MoveRequest::Waypoints { count: n };
    // Chunks: a gap is refused; the list ends after the last chunk written.
    assert_eq!(
        b.rig
            .drive
            .load_waypoints(&b.rig.control.ctrl, 1, &pts[..8]),
        Err(Refused::Waypoints)
    );
    b.rig
        .drive
        .load_waypoints(&b.rig.control.ctrl, 0, &pts[..8])
        .unwrap();
    assert_eq!(
        b.rig.start(&go(12)),
        Err(Refused::Waypoints),
        "four waypoints missing"
    );
    assert_eq!(
        b.rig
            .drive
            .load_waypoints(&b.rig.control.ctrl, 8, &[pts[0]; 25]),
        Err(Refused::Waypoints),
        "33 waypoints"
    );
    b.rig
        .drive
        .load_waypoints(&b.rig.control.ctrl, 8, &pts[8..])
        .unwrap();
    assert_eq!(b.rig.drive.waypoints_loaded(), 12);
    // Bad values, each refused with its reason and nothing applied.
    let held = b.rig.control.ctrl.trajectory;
    let mut bad = |k: usize, w: Waypoint<f32>, why: Refused| {
        let mut p = pts.clone();
        p[k] = w;
        b.rig
            .drive
            .load_waypoints(&b.rig.control.ctrl, 0, &p)
            .unwrap();
        assert_eq!(b.rig.start(&go(12)), Err(why), "{w:?}");
        assert_eq!(b.rig.control.ctrl.trajectory, held, "nothing applied");
    };
    let w = |a: f32, c: f32, dt: f32| Waypoint {
        theta: Vector2::new(a, c),
        dt,
    };
    bad(5, w(1.0, 2.8, 0.4), Refused::Unreachable);
    bad(5, w(1.0, f32::NAN, 0.4), Refused::OutOfRange);
    bad(5, w(1.0, 0.0, 0.0), Refused::OutOfRange);
    bad(5, w(1.0, 0.0, 0.05), Refused::TooFast);
    // A path longer than MAX_MOVE_TIME in all.
    bad(5, w(1.0, 0.0, 3600.0), Refused::OutOfRange);
    b.rig
        .drive
        .load_waypoints(&b.rig.control.ctrl, 0, &pts)
        .unwrap();
    let total: f32 = pts.iter().map(|w| w.dt).sum();
    assert_eq!(b.rig.start(&go(12)), Ok(total));
    // Uploading into the running path is refused.
    assert_eq!(
        b.rig
            .drive
            .load_waypoints(&b.rig.control.ctrl, 0, &pts[..1]),
        Err(Refused::Moving)
    );

    // Run it: the reference is continuous (position and speed) through every waypoint, passes
    // through each at its time, never leaves the box of the two waypoints around it, and the
    // arm tracks it.
    let (lo, hi) = pts.iter().fold(
        (Vector2::zeros(), Vector2::zeros()),
        |(lo, hi): (Vector2<f32>, Vector2<f32>), w| (lo.inf(&w.theta), hi.sup(&w.theta)),
    );
    let mut previous = b
        .rig
        .control
        .ctrl
        .trajectory
        .sample(b.rig.drive.time(b.rig.motor.now()));
    let (mut worst, mut jump_q, mut jump_v, mut peak_v, mut outside) =
        (0f32, 0f32, 0f32, 0f32, 0f32);
    let mut passed = Vec::new();
    let mut at = 0.0f32;
    let periods = (total * 1000.0) as usize + 300;
    for k in 0..periods {
        b.period();
        let r = b
            .rig
            .control
            .ctrl
            .trajectory
            .sample(b.rig.drive.time(b.rig.motor.now()));
        jump_q = jump_q.max((r.q - previous.q - previous.qd * 1e-3).abs().max());
        jump_v = jump_v.max((r.qd - previous.qd).abs().max());
        peak_v = peak_v.max(r.qd.abs().max());
        outside = outside.max((lo - r.q).max().max((r.q - hi).max()));
        previous = r;
        worst = worst.max((b.theta() - r.q).abs().max());
        // The reference at each waypoint's time (within one motor period).
        let t = (k + 1) as f32 * 1e-3;
        if let Some(w) = pts.get(passed.len())
            && t + 0.5e-3 >= at + w.dt
        {
            at += w.dt;
            passed.push((r.q - w.theta).abs().max());
        }
    }
    let miss = passed.iter().cloned().fold(0.0, f32::max);
    println!(
        "path: |θ − θ_d| {worst:.2e} rad; reference steps: position {jump_q:.2e} rad beyond v·T, speed {jump_v:.2e} rad/s per period; \
         peak speed {peak_v:.2} rad/s; waypoints missed by {miss:.2e} rad; outside the waypoints' box {outside:.1e} rad"
    );
    assert_eq!(passed.len(), 12);
    assert_eq!(b.rig.drive.mode(&b.rig.control.ctrl), Mode::Armed);
    // A period's speed change at the limits' 10 rad/s² is 0.01 rad/s; the position beyond the
    // speed's step, half that times T.
    assert!(jump_v < 0.012, "{jump_v}");
    assert!(jump_q < 1e-5, "{jump_q}");
    assert!(peak_v <= 3.0, "{peak_v}");
    // The waypoints' times are whole motor periods here: the sample there is the waypoint, to
    // the rounding of the path's time.
    assert!(miss < 1e-5, "{miss}");
    assert!(outside <= 0.0, "no overshoot: {outside}");
    assert!(worst < 2e-3, "{worst}");
    assert!((b.theta() - pts[11].theta).abs().max() < 1e-3);
}

#[test]
fn a_stop_during_a_path_ends_it() {
    let mut b = Bench::new(Vector2::zeros());
    b.rig.arm().unwrap();
    let pts = path();
    b.rig
        .drive
        .load_waypoints(&b.rig.control.ctrl, 0, &pts)
        .unwrap();
    b.rig.start(&MoveRequest::Waypoints { count: 12 }).unwrap();
    b.run(1.0);
    b.rig.stop().unwrap();
    b.run(1.0);
    assert_eq!(b.rig.drive.mode(&b.rig.control.ctrl), Mode::Armed);
    let held = b
        .rig
        .control
        .ctrl
        .trajectory
        .sample(b.rig.drive.time(b.rig.motor.now()))
        .q;
    b.run(2.0);
    let after = b
        .rig
        .control
        .ctrl
        .trajectory
        .sample(b.rig.drive.time(b.rig.motor.now()))
        .q;
    assert_eq!(held, after, "the path does not resume after the stop");
    // Stopped short of the path's second half (joint 2 negative from waypoint 7 on).
    assert!(held.y > 0.0, "{held:?}");
}

#[test]
fn a_plan_starts_only_from_the_pose_it_was_made_for() {
    let mut b = Bench::new(Vector2::zeros());
    b.rig.arm().unwrap();
    let from = b.rig.drive.held(&b.rig.control.ctrl, b.rig.motor.now());
    let copy = b.rig.drive;
    let plan = copy
        .plan(
            &b.rig.control.ctrl.motor,
            from,
            &trapezoid([0.3, 0.0], 1.0, 0.25),
        )
        .unwrap();
    // Another move starts and ends in between: the held pose is no longer the plan's.
    b.rig.start(&trapezoid([0.1, 0.0], 0.5, 0.1)).unwrap();
    assert_eq!(
        b.rig
            .drive
            .begin(&mut b.rig.control.ctrl, b.rig.motor.now(), &plan),
        Err(Refused::Moving)
    );
    b.run(1.0);
    assert_eq!(
        b.rig
            .drive
            .begin(&mut b.rig.control.ctrl, b.rig.motor.now(), &plan),
        Err(Refused::Moving)
    );
    let from = b.rig.drive.held(&b.rig.control.ctrl, b.rig.motor.now());
    let plan = b
        .rig
        .drive
        .plan(
            &b.rig.control.ctrl.motor,
            from,
            &trapezoid([0.3, 0.0], 1.0, 0.25),
        )
        .unwrap();
    assert_eq!(
        b.rig
            .drive
            .begin(&mut b.rig.control.ctrl, b.rig.motor.now(), &plan),
        Ok(1.0)
    );
}

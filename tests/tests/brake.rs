//! The holding brake (issue 33, safe brake control) on the host's rig: the hardware board's
//! firmware (motor loop 1 kHz, piezo loop 10 kHz) on the QEMU board's simulated arm, whose
//! joints brake only while the board's brake output is engaged
//! (`flexarm_machine::simulated::SimulatedArm`). Every motor period of every run here checks
//! the rule: the brake output is released exactly when the period enabled the amplifiers, and
//! only in a mode that drives the joints (armed, moving, stopping, homing); disarmed or faulted
//! it is engaged. The runs walk every path that cuts the amplifiers: boot, disarm, the link's
//! `Estop`, a category-0 motion fault, a category-1 fault at the end of its stop, a fault the
//! supervisor latches between periods, a failed homing search; the link's status and telemetry
//! report the output. And the coast after a cut, with the brake and with it stuck released, and
//! the brakes' watch that latches `BrakeSlip` (`flexarm_core::brake`).

#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

use flexarm_core::drive::{Mode, MoveRequest};
use flexarm_core::homing::{Config, JointHoming, Method};
use flexarm_core::{Fault, Vector2, Vector4};
use flexarm_host::rig::Rig;
use flexarm_link::msg::{Board as Kind, Channels, Reply};
use flexarm_link::{Command, Request};
use flexarm_machine::Board;
use flexarm_machine::simulated::SimulatedArm;
use flexarm_tests::{Injection, TestArm, firmware, test_rig};

/// The modes in which the brake may be released: the amplifiers drive the joints.
fn drives(mode: Mode) -> bool {
    matches!(
        mode,
        Mode::Armed | Mode::Moving | Mode::Stopping | Mode::Homing
    )
}

/// One motor period, checked: the brake output (read back from the board) is released exactly
/// when the period enabled the amplifiers, and only in a mode that drives the joints. Returns
/// whether it is engaged.
fn period<B: Board>(rig: &mut Rig<B>) -> bool {
    let p = rig.period();
    let engaged = rig.board.brake_engaged();
    assert_eq!(
        engaged, !p.command.enable,
        "tick {}: brake engaged {engaged} with the amplifiers enabled {}",
        p.tick.0, p.command.enable
    );
    if !engaged {
        assert!(
            drives(rig.mode()),
            "tick {}: released in {:?}",
            p.tick.0,
            rig.mode()
        );
    }
    if p.fault.is_some() {
        assert!(
            engaged,
            "tick {}: a fault latched, brake released",
            p.tick.0
        );
    }
    engaged
}

/// `seconds` of checked periods; the brake's state after the last.
fn run<B: Board>(rig: &mut Rig<B>, seconds: f32) -> bool {
    let mut engaged = rig.board.brake_engaged();
    for _ in 0..(seconds * 1000.0).round() as usize {
        engaged = period(rig);
    }
    engaged
}

/// The link's status: the brake as it reports it.
fn status_brake<B: Board>(rig: &mut Rig<B>) -> bool {
    match rig.answer(Command::Status) {
        Reply::Status(s) => s.brake_engaged,
        r => panic!("status: {r:?}"),
    }
}

fn trapezoid() -> MoveRequest<f32> {
    MoveRequest::Trapezoid {
        target: Vector2::new(1.0, 1.0),
        move_time: 2.0,
        ramp_time: 0.5,
    }
}

fn bench(injection: Injection) -> Rig<TestArm> {
    let mut rig = test_rig(firmware(Kind::Hardware), [0.0, 0.0], injection);
    // The link watchdog off: these runs ask the session between periods.
    rig.drive.link_timeout = 0;
    rig
}

#[test]
fn at_boot_and_disarmed_the_brake_is_engaged_and_armed_it_is_released() {
    let mut rig = bench(Injection::None);
    assert!(rig.board.brake_engaged(), "engaged before the first period");
    assert!(status_brake(&mut rig));
    assert!(run(&mut rig, 0.1), "disarmed: engaged");
    assert_eq!(rig.answer(Command::Arm), Reply::Done);
    assert!(
        !period(&mut rig),
        "armed: released in the first armed period"
    );
    assert!(!status_brake(&mut rig));
    assert_eq!(rig.answer(Command::Disarm), Reply::Done);
    assert!(period(&mut rig), "disarmed: engaged in the next period");
    assert!(status_brake(&mut rig));
}

#[test]
fn a_disarm_or_an_estop_during_a_move_engages_the_brake() {
    for cut in [Command::Disarm, Command::Estop] {
        let mut rig = bench(Injection::None);
        rig.arm().unwrap();
        rig.start(&trapezoid()).unwrap();
        assert!(!run(&mut rig, 1.0), "moving: released");
        assert_eq!(rig.answer(cut.clone()), Reply::Done);
        assert!(period(&mut rig), "{cut:?}: engaged in the next period");
        assert_eq!(rig.mode(), Mode::Disarmed);
        assert!(run(&mut rig, 0.5));
        assert!(status_brake(&mut rig));
    }
}

#[test]
fn a_category_0_motion_fault_engages_the_brake_in_the_period_it_latches() {
    let mut rig = bench(Injection::Reversed);
    rig.arm().unwrap();
    rig.start(&trapezoid()).unwrap();
    let mut latched = None;
    for k in 0..1000 {
        let engaged = period(&mut rig);
        if rig.control.ctrl.fault().is_some() {
            latched = Some(k);
            assert!(engaged, "engaged in the period the fault latched");
            break;
        }
        assert!(!engaged, "released while moving");
    }
    assert!(latched.is_some());
    assert_eq!(rig.control.ctrl.fault(), Some(Fault::Runaway));
    assert!(run(&mut rig, 0.5));
    assert!(status_brake(&mut rig));
}

#[test]
fn a_category_1_fault_keeps_the_brake_released_through_its_stop_and_engages_it_at_the_latch() {
    let mut rig = bench(Injection::None);
    rig.arm().unwrap();
    rig.start(&trapezoid()).unwrap();
    run(&mut rig, 0.8);
    rig.drive.heat_for_test(Vector2::new(0.96, 0.0));
    let mut stopping = 0;
    loop {
        let engaged = period(&mut rig);
        if rig.control.ctrl.fault().is_some() {
            assert!(engaged);
            break;
        }
        assert_eq!(rig.mode(), Mode::Stopping);
        assert!(!engaged, "the controlled stop drives the joints: released");
        stopping += 1;
        assert!(stopping < 2000, "the stop ends");
    }
    assert_eq!(rig.control.ctrl.fault(), Some(Fault::Overload));
    // 0.67 rad/s at the move limits' 10 rad/s²: 67 ms.
    assert!(stopping > 50, "a stop of {stopping} periods");
}

/// A fault latched outside the motor loop (the supervisor's stalled-loop `Overrun`, between two
/// periods): the next period's outputs are the safe ones, the brake with them; `Clear` leaves
/// the drive disarmed, the brake still engaged.
#[test]
fn a_fault_latched_between_periods_and_its_clear_keep_the_brake_engaged() {
    let mut rig = bench(Injection::None);
    rig.arm().unwrap();
    assert!(!run(&mut rig, 0.2));
    rig.control.ctrl.trip(Fault::Overrun);
    assert!(period(&mut rig), "engaged in the next period");
    assert!(run(&mut rig, 0.1));
    assert!(matches!(rig.answer(Command::Clear), Reply::Cleared(_)));
    assert_eq!(rig.mode(), Mode::Disarmed);
    assert!(run(&mut rig, 0.1));
    assert!(status_brake(&mut rig));
}

/// A homing search drives the joints (released); a search that finds nothing ends disarmed,
/// the brake engaged.
#[test]
fn a_homing_search_releases_the_brake_and_a_failed_one_engages_it() {
    let cfg = firmware(Kind::Hardware);
    let sim = SimulatedArm::paper(cfg.patch, Vector4::zeros(), cfg.piezo_period());
    let mut rig = Rig::new(cfg, sim, flexarm_core::time::Ticks(0));
    rig.drive.link_timeout = 0;
    let mut c = Config::default();
    c.joints[0] = JointHoming {
        method: Method::EndStop,
        angle: 3.1,
        speed: 0.4,
        torque: 1.0,
        travel: 0.3,
    };
    rig.drive.configure_homing(c).unwrap();
    assert!(run(&mut rig, 0.05));
    rig.home().unwrap();
    let (mut searched, mut released) = (0, 0);
    while rig.mode() == Mode::Homing {
        let engaged = period(&mut rig);
        if rig.mode() == Mode::Homing {
            assert!(!engaged, "searching: released");
            released += 1;
        }
        searched += 1;
        assert!(searched < 3000, "the search ends");
    }
    assert!(released > 100, "{released} periods of search");
    assert_eq!(rig.mode(), Mode::Disarmed);
    assert!(rig.drive.homing().failed());
    assert!(rig.board.brake_engaged());
    assert!(run(&mut rig, 0.1));
}

/// Every telemetry frame carries the brake output of its period.
#[test]
fn telemetry_carries_the_brake() {
    let mut rig = bench(Injection::None);
    let subscribe = Command::Subscribe {
        decimation: 1,
        channels: Channels(Channels::ERROR),
    };
    assert_eq!(
        rig.request(&Request {
            id: 1,
            command: subscribe
        }),
        Reply::Done
    );
    let mut seen = [false; 2];
    for k in 0..300 {
        if k == 100 {
            rig.arm().unwrap();
        }
        if k == 200 {
            rig.control.ctrl.trip(Fault::Overrun);
        }
        let engaged = period(&mut rig);
        let frames = rig.take();
        let t = frames
            .iter()
            .find_map(|(_, t)| t.clone())
            .expect("a frame a period");
        assert_eq!(t.brake_engaged, engaged, "tick {}", t.tick);
        seen[usize::from(engaged)] = true;
    }
    assert_eq!(seen, [true, true], "both states streamed");
}

/// The link's `Estop` one second into the move (0.67 rad/s), the brake stuck released or not.
fn estop_mid_move(stuck: bool) -> Rig<TestArm> {
    let mut rig = bench(Injection::None);
    rig.board.sim.brake_stuck_released = stuck;
    rig.arm().unwrap();
    rig.start(&trapezoid()).unwrap();
    run(&mut rig, 1.0);
    assert_eq!(rig.answer(Command::Estop), Reply::Done);
    rig
}

/// The coast after a category-0 cut at speed on the simulated arm (the core's frictionless
/// model): with the brake (50 ms time constant) the joints stop within 0.05 rad; with the brake
/// stuck released they coast on at the cut's speed.
#[test]
fn the_simulated_arm_coasts_on_without_its_brake() {
    let mut coast = [0.0f32; 2];
    for (i, stuck) in [false, true].into_iter().enumerate() {
        let mut rig = estop_mid_move(stuck);
        let at = rig.board.sim.arm.x.q.xy();
        assert!(run(&mut rig, 1.0), "engaged (stuck released: {stuck})");
        coast[i] = (rig.board.sim.arm.x.q.xy() - at).abs().max();
    }
    println!(
        "simulated arm, Estop at 0.67 rad/s: coast in 1 s {:.4} rad with the brake, {:.4} rad stuck released",
        coast[0], coast[1]
    );
    assert!(coast[0] < 0.05, "{coast:?}");
    assert!(coast[1] > 0.5, "{coast:?}");
}

/// Periods from now until `fault` latches (at most `seconds`), and the simulated arm's joints'
/// travel since now, the larger of the two [rad].
fn until(rig: &mut Rig<TestArm>, fault: Fault, seconds: f32) -> (Option<usize>, f32) {
    let q = |rig: &Rig<TestArm>| rig.board.sim.arm.x.q.xy();
    let at = q(rig);
    for k in 1..=(seconds * 1000.0).round() as usize {
        period(rig);
        if rig.control.ctrl.fault() == Some(fault) {
            return (Some(k), (q(rig) - at).abs().max());
        }
    }
    (None, (q(rig) - at).abs().max())
}

/// The brakes' watch (`flexarm_core::brake`): an Estop in the middle of the move (0.67 rad/s),
/// the brake stuck released: the drive latches `BrakeSlip` once the brake should have settled
/// (0.2 s) and the joint has gone on 0.02 rad past it, within 0.25 s of the cut; `arm` is
/// refused until it is cleared, and a brake still stuck trips it again after the clear. A
/// brake that holds: nothing in 3 s, after the Estop and after the clear.
#[test]
fn a_brake_that_does_not_hold_latches_brake_slip() {
    for stuck in [false, true] {
        let mut rig = estop_mid_move(stuck);
        let (seen, travel) = until(&mut rig, Fault::BrakeSlip, 3.0);
        println!(
            "Estop at 0.67 rad/s, brake stuck released {stuck}: BrakeSlip after {seen:?} ms, the joints {travel:.4} rad on"
        );
        if !stuck {
            assert_eq!(seen, None);
            assert_eq!(rig.control.ctrl.fault(), None);
            continue;
        }
        let ms = seen.expect("latched");
        assert!((200..=250).contains(&ms), "{ms} ms");
        assert_eq!(rig.arm(), Err(flexarm_core::drive::Refused::Faulted));
        assert_eq!(
            rig.answer(Command::Clear),
            Reply::Cleared(Fault::BrakeSlip as u8)
        );
        let (again, _) = until(&mut rig, Fault::BrakeSlip, 1.0);
        assert!(again.is_some(), "the brake still does not hold");
        rig.board.sim.brake_stuck_released = false;
        assert_eq!(
            rig.answer(Command::Clear),
            Reply::Cleared(Fault::BrakeSlip as u8)
        );
        assert_eq!(until(&mut rig, Fault::BrakeSlip, 3.0).0, None, "repaired");
        rig.arm().unwrap();
    }
}

/// A category-0 cut by another fault (the supervisor's `Overrun`) with the brake stuck
/// released: the joints coast on under the first fault, which stays the one latched; once it
/// is cleared the brake's fault latches at once, by the clear itself.
#[test]
fn a_brake_slip_under_another_fault_latches_once_that_one_is_cleared() {
    let mut rig = bench(Injection::None);
    rig.board.sim.brake_stuck_released = true;
    rig.arm().unwrap();
    rig.start(&trapezoid()).unwrap();
    run(&mut rig, 1.0);
    rig.control.ctrl.trip(Fault::Overrun);
    let (seen, travel) = until(&mut rig, Fault::BrakeSlip, 1.0);
    assert_eq!(seen, None);
    assert!(travel > 0.3, "coasting: {travel} rad");
    assert_eq!(rig.control.ctrl.fault(), Some(Fault::Overrun));
    assert_eq!(
        rig.answer(Command::Clear),
        Reply::Cleared(Fault::Overrun as u8)
    );
    // Latched by the clear itself: no `arm` fits between.
    assert_eq!(rig.control.ctrl.fault(), Some(Fault::BrakeSlip));
    assert_eq!(rig.arm(), Err(flexarm_core::drive::Refused::Faulted));
    period(&mut rig);
    assert_eq!(rig.control.ctrl.fault(), Some(Fault::BrakeSlip));
}

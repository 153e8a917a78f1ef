//! The command link's session (`flexarm_machine::session`) on the host, without QEMU: the QEMU
//! board's firmware (its generated configuration) on the host's rig (`flexarm_host::rig`), each
//! command answered between two periods as the firmware's idle task answers it. Every command,
//! its refusals, the subscription's frames and the fault recorder's pages.

use flexarm_core::Fault;
use flexarm_host::rig::Rig;
use flexarm_link::msg::{
    Board, Channels, Command, MAX_CHANNELS, Mode, Move, Param, Refusal, Reply, SAMPLES_PER_PAGE,
    Telemetry, Waypoint,
};
use flexarm_link::{Request, VERSION};
use flexarm_machine::session::MIN_LINK_TIMEOUT_PERIODS;
use flexarm_machine::simulated::SimulatedArm;
use flexarm_tests::{firmware, rig};

fn qemu() -> Rig<SimulatedArm> {
    rig(firmware(Board::Qemu), [0.0, 0.0])
}

fn trapezoid(target: [f32; 2], move_time: f32, ramp_time: f32) -> Command {
    Command::Move(Move::Trapezoid {
        target,
        move_time,
        ramp_time,
    })
}

/// Runs `periods` motor periods.
fn run(r: &mut Rig<SimulatedArm>, periods: usize) {
    for _ in 0..periods {
        r.period();
    }
}

fn mode(r: &mut Rig<SimulatedArm>) -> Mode {
    match r.answer(Command::Status) {
        Reply::Status(s) => s.mode,
        other => panic!("status: {other:?}"),
    }
}

/// The frames the session made of the queued records.
fn frames(r: &mut Rig<SimulatedArm>) -> Vec<Telemetry> {
    r.take().into_iter().filter_map(|(_, f)| f).collect()
}

#[test]
fn the_handshake_names_the_board_its_rates_and_its_configurations_hash() {
    let mut r = qemu();
    assert_eq!(
        r.answer(Command::Hello {
            version: VERSION + 1
        }),
        Reply::Refused(Refusal::Version)
    );
    let Reply::Hello(h) = r.answer(Command::Hello { version: VERSION }) else {
        panic!("no hello");
    };
    assert_eq!(
        (h.version, h.board, h.motor_hz, h.piezo_hz),
        (VERSION, Board::Qemu, 100, 1000)
    );
    assert_eq!(h.params_hash, r.cfg.hash());
    // Another configuration, another hash.
    let mut other = r.cfg;
    other.piezo.k_c = 3.0;
    assert_ne!(other.hash(), h.params_hash);
    assert_eq!(r.answer(Command::Ping), Reply::Done);
}

#[test]
fn the_drive_follows_arm_moves_stop_disarm_and_estop() {
    let mut r = qemu();
    assert_eq!(mode(&mut r), Mode::Disarmed);
    assert_eq!(
        r.answer(trapezoid([0.5, 0.2], 2.0, 0.5)),
        Reply::Refused(Refusal::NotArmed)
    );
    assert_eq!(r.answer(Command::Stop), Reply::Refused(Refusal::NotArmed));
    assert_eq!(r.answer(Command::Arm), Reply::Done);
    run(&mut r, 10);
    assert_eq!(mode(&mut r), Mode::Armed);
    for (bad, why) in [
        (trapezoid([f32::NAN, 0.0], 2.0, 0.5), Refusal::OutOfRange),
        (trapezoid([3.5, 0.0], 4.0, 1.0), Refusal::Unreachable),
        (trapezoid([2.0, 0.0], 0.5, 0.125), Refusal::TooFast),
    ] {
        assert_eq!(r.answer(bad), Reply::Refused(why));
        assert_eq!(mode(&mut r), Mode::Armed, "nothing applied");
    }
    assert_eq!(r.answer(trapezoid([0.5, 0.2], 2.0, 0.5)), Reply::Done);
    assert_eq!(mode(&mut r), Mode::Moving);
    assert_eq!(
        r.answer(trapezoid([0.0, 0.0], 2.0, 0.5)),
        Reply::Refused(Refusal::Moving)
    );
    run(&mut r, 100);
    assert_eq!(r.answer(Command::Stop), Reply::Done);
    assert_eq!(mode(&mut r), Mode::Stopping);
    run(&mut r, 50);
    assert_eq!(mode(&mut r), Mode::Armed, "the stop ended holding");
    // Disarm cuts the outputs the next period; estop too, from any mode.
    assert_eq!(r.answer(Command::Disarm), Reply::Done);
    let p = r.period();
    assert!(!p.command.enable && p.command.tau == flexarm_core::Vector2::zeros());
    assert_eq!(mode(&mut r), Mode::Disarmed);
    assert_eq!(r.answer(Command::Arm), Reply::Done);
    assert_eq!(r.answer(trapezoid([0.3, 0.0], 2.0, 0.5)), Reply::Done);
    run(&mut r, 20);
    assert_eq!(r.answer(Command::Estop), Reply::Done);
    assert!(!r.period().command.enable);
    assert_eq!(mode(&mut r), Mode::Disarmed);
}

#[test]
fn a_waypoint_path_is_uploaded_in_chunks_and_refused_with_a_gap_or_a_wrong_count() {
    let mut r = qemu();
    let chunk = |first: u16, pts: &[[f32; 3]]| Command::Waypoints {
        first,
        points: pts
            .iter()
            .map(|&[a, b, dt]| Waypoint { theta: [a, b], dt })
            .collect(),
    };
    let path = [[0.2, 0.1, 0.5], [0.4, 0.2, 0.5], [0.3, 0.0, 0.5]];
    assert_eq!(r.answer(Command::Arm), Reply::Done);
    assert_eq!(
        r.answer(chunk(1, &path[..2])),
        Reply::Refused(Refusal::Waypoints)
    );
    assert_eq!(r.answer(chunk(0, &path[..2])), Reply::Done);
    assert_eq!(r.answer(chunk(2, &path[2..])), Reply::Done);
    let go = |count| Command::Move(Move::Waypoints { count });
    assert_eq!(r.answer(go(4)), Reply::Refused(Refusal::Waypoints));
    assert_eq!(r.answer(go(3)), Reply::Done);
    run(&mut r, 200);
    assert_eq!(mode(&mut r), Mode::Armed, "the path ended holding");
    let end = r.control.ctrl.step_estimate();
    assert!((end.x - 0.3).abs() < 0.01 && end.y.abs() < 0.01, "{end:?}");
}

#[test]
fn every_parameter_is_read_written_at_rest_and_refused_while_moving_or_out_of_range() {
    let mut r = qemu();
    let cfg = r.cfg;
    let g = cfg.gains;
    // Every parameter the link declares boots with its configuration's value.
    for info in flexarm_link::params::PARAMS {
        let want = cfg.param(info.param).unwrap_or(0.0);
        assert_eq!(
            r.answer(Command::Get(info.param)),
            Reply::Value(want),
            "{}",
            info.name
        );
    }
    let expected = [
        (Param::Kp0, g.kp.x),
        (Param::Kp1, g.kp.y),
        (Param::Kp2, g.kp.z),
        (Param::Kp3, g.kp.w),
        (Param::Lambda0, g.lambda.x),
        (Param::Lambda3, g.lambda.w),
        (Param::DDelta0, g.d_delta.x),
        (Param::DDelta1, g.d_delta.y),
        (Param::Kc, cfg.piezo.k_c),
        (Param::CutoffHz, cfg.piezo.cutoff_hz),
        (Param::TauMax0, cfg.limits.tau_max.x),
        (Param::TauMax1, cfg.limits.tau_max.y),
        (Param::VaMax, cfg.limits.v_a_max),
        (Param::VaMin, cfg.limits.v_a_min),
        (Param::LinkTimeout, cfg.link_timeout_s as f32),
        (Param::VaBias, 0.0),
    ];
    for (p, v) in expected {
        assert_eq!(r.answer(Command::Get(p)), Reply::Value(v), "{p:?}");
    }
    // Written at rest and read back; the controller runs it.
    // (The QEMU board's K_p sits at the sampled loop's bound, λT = 0.9996 at 100 Hz: lower is
    // accepted, higher refused.)
    for (p, v) in [
        (Param::Kp1, 5.0),
        (Param::Kc, 3.162),
        (Param::VaMin, -30.0),
        (Param::LinkTimeout, 2.0),
    ] {
        assert_eq!(r.answer(Command::Set(p, v)), Reply::Done, "{p:?}");
        assert_eq!(r.answer(Command::Get(p)), Reply::Value(v), "{p:?}");
    }
    assert_eq!(r.control.ctrl.motor.gains.kp.y, 5.0);
    assert_eq!(r.control.ctrl.piezo.window(), (-30.0, cfg.limits.v_a_max));
    assert_eq!(r.drive.link_timeout, 2 * cfg.motor_hz());
    // Refused, nothing written.
    for (p, v, why) in [
        (Param::Kp0, -1.0, Refusal::OutOfRange),
        (Param::Kc, f32::NAN, Refusal::OutOfRange),
        (Param::CutoffHz, 1e6, Refusal::OutOfRange),
        (Param::TauMax0, 1e3, Refusal::OutOfRange),
        (Param::VaMax, 1e6, Refusal::OutOfRange),
        (Param::LinkTimeout, -1.0, Refusal::OutOfRange),
        // Shorter than three motor periods (0.004 s at the QEMU board's 100 Hz read back as
        // 0, the watchdog off: issue 36).
        (
            Param::LinkTimeout,
            (MIN_LINK_TIMEOUT_PERIODS as f32 - 0.5) / cfg.motor_hz() as f32,
            Refusal::OutOfRange,
        ),
        (Param::Kp0, 2e4, Refusal::OutOfRange),
        // Inside the declared range, outside the sampled loop's stable region at 100 Hz.
        (Param::Kp1, 10.0, Refusal::Unstable),
        // Inside the declared range, past the rate law's ceiling on this board's arm (279 s
        // at the 100 Hz corner, a stability factor of 2; `RateCeiling`).
        (Param::Kc, 400.0, Refusal::Unstable),
        (Param::VaMin, 5.0, Refusal::OutOfRange),
    ] {
        let before = r.answer(Command::Get(p));
        assert_eq!(r.answer(Command::Set(p, v)), Reply::Refused(why), "{p:?}");
        assert_eq!(r.answer(Command::Get(p)), before, "{p:?} unchanged");
    }
    // 0, given, turns the watchdog off.
    assert_eq!(r.answer(Command::Set(Param::LinkTimeout, 0.0)), Reply::Done);
    assert_eq!(r.drive.link_timeout, 0);
    // While a move runs: refused.
    assert_eq!(r.answer(Command::Arm), Reply::Done);
    assert_eq!(r.answer(trapezoid([0.3, 0.0], 2.0, 0.5)), Reply::Done);
    for p in [Param::Kp0, Param::Kc, Param::LinkTimeout, Param::VaBias] {
        assert_eq!(
            r.answer(Command::Set(p, 1.0)),
            Reply::Refused(Refusal::Moving),
            "{p:?}"
        );
    }
}

#[test]
fn the_piezo_bias_is_set_only_while_holding_and_ends_with_the_hold() {
    let mut r = qemu();
    let bias = |v| Command::Set(Param::VaBias, v);
    assert_eq!(r.answer(bias(10.0)), Reply::Refused(Refusal::NotArmed));
    assert_eq!(r.answer(Command::Arm), Reply::Done);
    run(&mut r, 5);
    assert_eq!(r.answer(bias(1e3)), Reply::Refused(Refusal::OutOfRange));
    assert_eq!(r.answer(bias(10.0)), Reply::Done);
    assert_eq!(r.answer(Command::Get(Param::VaBias)), Reply::Value(10.0));
    // The piezo loop adds it: the command the motor period reports moves by about 10 V.
    let p = r.period();
    assert!((p.command.v_a - 10.0).abs() < 1.0, "{}", p.command.v_a);
    // A move ends the hold, and the bias with it.
    assert_eq!(r.answer(trapezoid([0.2, 0.0], 2.0, 0.5)), Reply::Done);
    r.period();
    assert_eq!(r.answer(Command::Get(Param::VaBias)), Reply::Value(0.0));
}

#[test]
fn a_subscription_streams_its_channels_at_its_decimation_until_unsubscribed() {
    let mut r = qemu();
    let subscribe = |decimation, bits| Command::Subscribe {
        decimation,
        channels: Channels(bits),
    };
    assert_eq!(
        r.answer(subscribe(0, Channels::ALL)),
        Reply::Refused(Refusal::OutOfRange)
    );
    assert_eq!(
        r.answer(subscribe(1, Channels::ALL | 1 << 9)),
        Reply::Refused(Refusal::OutOfRange)
    );
    // The hardware's 1 kHz stream of every channel fits its line; a 100 kHz one would not.
    let mut fast = r.cfg;
    (fast.piezo_hz, fast.motor_divider) = (1_000_000, 10);
    let mut fast = rig(fast, [0.0, 0.0]);
    assert_eq!(
        fast.answer(subscribe(1, Channels::ALL)),
        Reply::Refused(Refusal::OutOfRange)
    );
    assert_eq!(fast.answer(subscribe(100, Channels::ALL)), Reply::Done);
    // Every channel, then a subset: each frame carries its channels' values, in order.
    assert_eq!(r.answer(Command::Arm), Reply::Done);
    assert_eq!(r.answer(subscribe(1, Channels::ALL)), Reply::Done);
    assert_eq!(r.answer(trapezoid([0.4, 0.3], 2.0, 0.5)), Reply::Done);
    frames(&mut r);
    let mut all = Vec::new();
    for _ in 0..50 {
        let p = r.period();
        let f = frames(&mut r);
        assert_eq!(f.len(), 1, "one frame a period at decimation 1");
        let f0 = &f[0];
        assert_eq!(f0.values.len(), Channels(Channels::ALL).values());
        assert!(f0.values.len() <= MAX_CHANNELS);
        // By name, as the console reads them.
        let v = |bit, j| f0.value(bit, j).unwrap();
        assert_eq!(
            [v(Channels::TAU, 0), v(Channels::TAU, 1)],
            [p.command.tau.x, p.command.tau.y]
        );
        assert_eq!(v(Channels::V_A, 0), p.command.v_a);
        assert_eq!(
            [
                v(Channels::THETA, 0),
                v(Channels::THETA, 1),
                v(Channels::DELTA, 0),
                v(Channels::DELTA, 1)
            ],
            [p.q.x, p.q.y, p.q.z, p.q.w]
        );
        assert_eq!(
            [
                v(Channels::ERROR, 0),
                v(Channels::ERROR, 1),
                v(Channels::V_F, 0)
            ],
            [p.error.x, p.error.y, p.y.v_f]
        );
        assert_eq!(f0.value(Channels::TAU, 2), None);
        all.push(f[0].clone());
    }
    assert!(
        all.windows(2)
            .all(|w| w[1].seq == w[0].seq + 1 && w[1].tick == w[0].tick + 1)
    );
    let bits = Channels::TAU | Channels::V_F;
    assert_eq!(r.answer(subscribe(5, bits)), Reply::Done);
    frames(&mut r);
    let mut subset = Vec::new();
    for _ in 0..20 {
        let p = r.period();
        for f in frames(&mut r) {
            assert_eq!(f.channels, Channels(bits));
            // Read by name, a subset's columns are its own: τ at 0 and 1, V_f at 2.
            assert_eq!(f.values[..], [p.command.tau.x, p.command.tau.y, p.y.v_f]);
            assert_eq!(f.value(Channels::V_F, 0), Some(p.y.v_f));
            assert_eq!(f.value(Channels::THETA, 0), None, "not in the subset");
            subset.push(f);
        }
    }
    assert_eq!(subset.len(), 4, "one frame every 5 periods");
    assert!(subset.windows(2).all(|w| w[1].tick == w[0].tick + 5));
    assert_eq!(r.answer(Command::Unsubscribe), Reply::Done);
    run(&mut r, 10);
    assert!(frames(&mut r).is_empty());
}

#[test]
fn a_fault_is_recorded_paged_out_and_cleared_only_when_its_cause_is_gone() {
    let mut r = qemu();
    assert_eq!(
        r.answer(Command::Clear),
        Reply::Refused(Refusal::CauseActive)
    );
    assert_eq!(r.answer(Command::Arm), Reply::Done);
    assert_eq!(r.answer(trapezoid([0.4, 0.3], 2.0, 0.5)), Reply::Done);
    run(&mut r, 30);
    r.control.ctrl.trip(Fault::Overrun);
    let last = r.period();
    assert_eq!(last.fault, Some(Fault::Overrun));
    let Reply::Status(s) = r.answer(Command::Status) else {
        panic!("status");
    };
    assert_eq!((s.mode, s.fault), (Mode::Fault, Some(Fault::Overrun as u8)));
    assert_eq!(r.answer(Command::Arm), Reply::Refused(Refusal::Faulted));
    assert_eq!(
        r.answer(trapezoid([0.0, 0.0], 2.0, 0.5)),
        Reply::Refused(Refusal::Faulted)
    );
    // The recorder froze on the fault's period: every period before it (the QEMU board records
    // each), paged out in order.
    let mut samples = Vec::new();
    loop {
        let Reply::Faults(page) = r.answer(Command::Faults {
            from: samples.len() as u16,
        }) else {
            panic!("no page");
        };
        assert_eq!(page.fault, Some(Fault::Overrun as u8));
        assert!(page.samples.len() <= SAMPLES_PER_PAGE);
        let total = usize::from(page.total);
        samples.extend(page.samples);
        if samples.len() >= total {
            break;
        }
    }
    assert_eq!(samples.len(), r.recorder.len());
    assert!(samples.windows(2).all(|w| w[1].tick == w[0].tick + 1));
    let end = samples.last().unwrap();
    assert_eq!(end.tick, last.tick.0);
    assert_eq!(
        end.tau,
        [0.0, 0.0],
        "the fault's period commands the safe state"
    );
    assert_eq!(
        r.answer(Command::Faults {
            from: samples.len() as u16 + 1
        }),
        Reply::Refused(Refusal::NoRecord)
    );
    // The overrun's cause is gone (a measurement in range): cleared, disarmed, recording again.
    assert_eq!(
        r.answer(Command::Clear),
        Reply::Cleared(Fault::Overrun as u8)
    );
    assert_eq!(mode(&mut r), Mode::Disarmed);
    assert!(r.recorder.is_empty() && r.recorder.fault().is_none());
    assert_eq!(r.answer(Command::Arm), Reply::Done);
}

#[test]
fn the_test_commands_are_refused_by_a_build_that_does_not_answer_them() {
    let mut r = qemu();
    assert_eq!(
        r.answer(Command::TestAmplifierFault(true)),
        Reply::Refused(Refusal::Unsupported)
    );
}

/// The session decodes its requests from the line's bytes: a frame split anywhere, and a
/// corrupted one dropped with its reason.
#[test]
fn requests_are_decoded_from_the_bytes_and_a_corrupted_frame_is_refused() {
    let mut r = qemu();
    let req = Request {
        id: 7,
        command: Command::Get(Param::Kc),
    };
    let mut out = [0u8; flexarm_link::MAX_FRAME];
    let bytes = flexarm_link::encode(&req, &mut out).unwrap().to_vec();
    let mut got = None;
    for b in &bytes {
        if let Some(x) = r.session.receive(*b) {
            got = Some(x);
        }
    }
    assert_eq!(got, Some(Ok(req)));
    let mut bad = bytes.clone();
    bad[2] ^= 0x10;
    let errors: Vec<_> = bad.iter().filter_map(|b| r.session.receive(*b)).collect();
    assert!(matches!(errors[..], [Err(_)]), "{errors:?}");
}

/// After a power-on the motors are assumed hot (issue 33: `Drive::restore_heat` without a
/// valid store) and the controller's torque limit is derated, changing every period as they
/// cool: `Get` reads the rated limit, which a `Set` sets and a configuration's dump keeps; a
/// limit set while hot holds and stays once cool.
#[test]
fn the_torque_limit_reads_the_rated_value_while_the_motors_are_hot() {
    use flexarm_core::retained::HeatStore;
    let mut r = qemu();
    let cfg = r.cfg;
    assert!(!r.drive.restore_heat(&HeatStore::invalid()));
    run(&mut r, 10);
    assert!(
        r.control.ctrl.motor.limits.tau_max.x < cfg.limits.tau_max.x,
        "derated"
    );
    assert_eq!(
        r.answer(Command::Get(Param::TauMax0)),
        Reply::Value(cfg.limits.tau_max.x)
    );
    assert_eq!(r.answer(Command::Set(Param::TauMax0, 3.0)), Reply::Done);
    run(&mut r, 10);
    assert!(r.control.ctrl.motor.limits.tau_max.x <= 3.0);
    assert_eq!(r.answer(Command::Get(Param::TauMax0)), Reply::Value(3.0));
    r.drive.heat_for_test(flexarm_core::Vector2::zeros());
    run(&mut r, 2);
    assert_eq!(r.control.ctrl.motor.limits.tau_max.x, 3.0);
    assert_eq!(r.control.ctrl.motor.limits.tau_max.y, cfg.limits.tau_max.y);
}

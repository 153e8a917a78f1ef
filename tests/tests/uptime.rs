//! The time base: a move started after days of uptime runs exactly like one started at boot,
//! on the host's rig of the hardware board's firmware (`flexarm_host::rig`), through the drive
//! (`Drive::step` samples the move at `Drive::time`). The counters' wraps fall 1 s into the
//! paper's 2 s move, at its peak speed: a wrap after the move's end would not show a time base
//! that jumps there, since the reference then holds the end pose whatever the time. A build
//! whose time base jumps half a second at the `u64` wrap (`--features
//! flexarm-core/mutant-wrap-jump`) must fail `a_move_started_after_any_uptime_gives_the_same_torques_to_the_bit`
//! (scripts/qemu-uptime runs it and requires the failure).

#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)] // tests may index and unwrap

use flexarm_core::control::motor::MotorLaw;
use flexarm_core::time::{MoveClock, Ticks};
use flexarm_core::trajectory::Trapezoid;
use flexarm_host::rig::Rig;
use flexarm_link::msg::Board;
use flexarm_machine::simulated::SimulatedArm;
use flexarm_tests::firmware;

const MOTOR_HZ: u32 = 1000;
const DAY: u64 = 86_400 * MOTOR_HZ as u64;

/// The paper's move (to (π/2, π/2) in 2 s) under Eq. 16 on the simulated arm, the hardware
/// board's firmware booted at tick `start`, the move started at once. Returns, for 6 s of motor
/// periods, the drive's move time and every torque command, as bits, and the latched fault's
/// number (0: none).
fn run(start: u64) -> Vec<[u32; 4]> {
    let cfg = flexarm_machine::BoardConfig {
        law: MotorLaw::Robust,
        ..firmware(Board::Hardware)
    };
    let arm = SimulatedArm::paper(
        cfg.patch,
        flexarm_core::Vector4::zeros(),
        cfg.piezo_period(),
    );
    let mut rig = Rig::new(cfg, arm, Ticks(start));
    flexarm_tests::declared(&mut rig);
    rig.arm().unwrap();
    let paper = Trapezoid::<f32>::paper();
    let request = flexarm_core::drive::MoveRequest::Trapezoid {
        target: paper.start + paper.amplitude,
        move_time: paper.profile.duration(),
        ramp_time: paper.profile.ramp(),
    };
    assert_eq!(request_duration(&request), 2.0);
    rig.start(&request).unwrap();
    (0..6000)
        .map(|_| {
            let p = rig.period();
            [
                rig.drive.time(p.tick).to_bits(),
                p.command.tau.x.to_bits(),
                p.command.tau.y.to_bits(),
                p.fault.map_or(0, |f| f as u32),
            ]
        })
        .collect()
}

fn request_duration(r: &flexarm_core::drive::MoveRequest<f32>) -> f32 {
    match *r {
        flexarm_core::drive::MoveRequest::Trapezoid { move_time, .. } => move_time,
        _ => f32::NAN,
    }
}

#[test]
fn a_move_started_after_any_uptime_gives_the_same_torques_to_the_bit() {
    let reference = run(0);
    assert!(
        reference.iter().all(|r| r[3] == 0),
        "the run from tick 0 faulted"
    );
    for start in [
        DAY,
        4_294_967_296 - 1000, // a u32 count of periods would wrap 1 s into the move (49.7 days)
        3652 * DAY,           // ten years
        u64::MAX - 999,       // the u64 count wraps 1 s into the 2 s move, at its peak speed
    ] {
        let r = run(start);
        if let Some(k) = (0..r.len()).find(|&k| r[k] != reference[k]) {
            panic!(
                "start at tick {start}: period {k} differs (move time {} s, torques {:?} N·m, fault {}; from tick 0: {} s, {:?} N·m)",
                f32::from_bits(r[k][0]),
                [f32::from_bits(r[k][1]), f32::from_bits(r[k][2])],
                r[k][3],
                f32::from_bits(reference[k][0]),
                [
                    f32::from_bits(reference[k][1]),
                    f32::from_bits(reference[k][2])
                ]
            );
        }
    }
}

#[test]
fn absolute_f32_time_would_not() {
    // What the firmware did before: t = k / rate in f32 from a u32 count since boot. One day in,
    // consecutive periods' times step by 0 or 7.8 ms, not by the 1 ms of the move's own clock.
    let old = |now: u64| (now as u32) as f32 / MOTOR_HZ as f32 - 86_400.0;
    let clock = MoveClock::new(Ticks(DAY), MOTOR_HZ);
    let steps: Vec<f32> = (DAY..DAY + 100).map(|k| old(k + 1) - old(k)).collect();
    assert!(
        steps.iter().all(|&s| s == 0.0 || s == 0.0078125),
        "{steps:?}"
    );
    assert!(steps.contains(&0.0));
    for k in 0..100 {
        assert_eq!(clock.local_time(Ticks(DAY + k)), k as f32 / 1000.0);
    }
}

#[test]
fn elapsed_time_saturates_past_any_move_and_wraps_with_the_counter() {
    let c = MoveClock::new(Ticks(u64::MAX - 1), MOTOR_HZ);
    assert_eq!(c.elapsed(Ticks(u64::MAX)), 1);
    assert_eq!(c.elapsed(Ticks(0)), 2);
    assert_eq!(c.local_time(Ticks(2)), 4e-3);
    assert_eq!(c.elapsed(Ticks(1 << 40)), u32::MAX);
    assert_eq!(c.start(), Ticks(u64::MAX - 1));
    assert_eq!(Ticks(u64::MAX).next(), Ticks(0));
}

/// The overflow table's figures for the link's counters (docs/firmware.md, "Time base"), from
/// what they count: the receive byte counter (`u32`) at most at the line's full rate, 921 600
/// baud 8N1 (`flexarm_machine::session::BAUD`), 92 160 bytes a second; the telemetry sequence
/// number (`u32`) and the telemetry drops (`u32`, saturating) at most one a motor period, 1 kHz
/// on the hardware board, as a stream of every channel at decimation 1 (accepted: it fits the
/// line) shows: one frame a period, and with nobody taking the frames, once the 64-record queue
/// is full, one record dropped a period.
#[test]
fn the_link_counters_overflow_when_the_table_says() {
    use flexarm_link::Command;
    use flexarm_link::msg::{Channels, Reply};
    let hw = firmware(Board::Hardware);
    let rx_hours = 2f64.powi(32) / (f64::from(flexarm_machine::session::BAUD) / 10.0) / 3600.0;
    let mut rig = flexarm_tests::rig(hw, [0.0, 0.0]);
    let subscribe = Command::Subscribe {
        decimation: 1,
        channels: Channels(Channels::ALL),
    };
    assert_eq!(rig.answer(subscribe), Reply::Done);
    for _ in 0..1000 {
        rig.period();
    }
    let dropped = match rig.answer(Command::Status) {
        Reply::Status(s) => s.telemetry_dropped,
        r => panic!("{r:?}"),
    };
    let frames: Vec<u32> = rig
        .take()
        .into_iter()
        .filter_map(|(_, t)| t.map(|t| t.seq))
        .collect();
    let per_second = f64::from(dropped) + frames.len() as f64;
    let days = |rate: f64| 2f64.powi(32) / rate / 86_400.0;
    println!(
        "receive bytes: {rx_hours:.2} h at the full line rate; telemetry: {per_second} records in 1 s at {} Hz ({} frames queued, {dropped} dropped): sequence number and drops {:.1} days",
        hw.motor_hz(),
        frames.len(),
        days(per_second)
    );
    assert!((rx_hours - 12.95).abs() < 0.01, "{rx_hours}");
    assert_eq!(frames.len(), flexarm_host::rig::QUEUE);
    assert_eq!(per_second, f64::from(hw.motor_hz()));
    assert!((days(per_second) - 49.7).abs() < 0.05);
}

/// The telemetry records' `t` is the move time (`Period::t`, `Drive::time`), not uptime: 0 at
/// the period a move starts, one motor period more each period, whatever the tick count at
/// boot (here 1000 periods before the `u64` wrap, which falls inside the hold before the move).
#[test]
fn telemetry_time_is_the_move_time() {
    use flexarm_link::Command;
    use flexarm_link::msg::{Channels, Reply};
    use flexarm_machine::Record;
    for boot in [0, u64::MAX - 999] {
        let cfg = firmware(Board::Hardware);
        let arm = SimulatedArm::paper(
            cfg.patch,
            flexarm_core::Vector4::zeros(),
            cfg.piezo_period(),
        );
        let mut rig = Rig::new(cfg, arm, Ticks(boot));
        flexarm_tests::declared(&mut rig);
        let subscribe = Command::Subscribe {
            decimation: 1,
            channels: Channels(Channels::ERROR),
        };
        assert_eq!(rig.answer(subscribe), Reply::Done);
        rig.arm().unwrap();
        for _ in 0..1500 {
            rig.period();
        }
        let _ = rig.take();
        let start = rig.drive.next_tick();
        rig.start(&flexarm_core::drive::MoveRequest::Trapezoid {
            target: flexarm_core::Vector2::new(0.5, 0.5),
            move_time: 1.0,
            ramp_time: 0.25,
        })
        .unwrap();
        for _ in 0..50 {
            rig.period();
        }
        let times: Vec<(u64, f32)> = rig
            .take()
            .into_iter()
            .filter_map(|(r, _)| match r {
                Record::Sample { tick, t, .. } => Some((tick, t)),
                Record::Fault { .. } => None,
            })
            .collect();
        assert_eq!(times.len(), 50);
        for (tick, t) in times {
            let k = tick.wrapping_sub(start.0);
            assert_eq!(t, k as f32 / 1000.0, "boot {boot}, tick {tick}");
        }
    }
}

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

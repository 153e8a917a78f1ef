//! The time base: a move started after days of uptime runs exactly like one started at boot,
//! on the host's rig of the hardware board's firmware (`flexarm_host::rig`).

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
/// board's firmware booted at tick `start`, the move started at once. Returns every torque
/// command's bits, 6 s of them.
fn run(start: u64) -> Vec<[u32; 2]> {
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
    rig.start(&request).unwrap();
    (0..6000)
        .map(|_| {
            let p = rig.period();
            assert!(p.fault.is_none(), "fault at tick {}", p.tick.0);
            [p.command.tau.x.to_bits(), p.command.tau.y.to_bits()]
        })
        .collect()
}

#[test]
fn a_move_started_after_any_uptime_gives_the_same_torques_to_the_bit() {
    let reference = run(0);
    for start in [
        DAY,
        4_294_967_296 - 3000, // a u32 count of periods would wrap 3 s into the move (49.7 days)
        3652 * DAY,           // ten years
        u64::MAX - 3000,      // the u64 count wraps 3 s into the move
    ] {
        assert!(run(start) == reference, "start at tick {start}");
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

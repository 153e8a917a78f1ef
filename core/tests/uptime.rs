//! The time base: a move started after days of uptime runs exactly like one started at boot.

#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)] // tests may index and unwrap

use flexarm_core::Vector4;
use flexarm_core::control::motor::MotorLaw;
use flexarm_core::controller::Controller;
use flexarm_core::observer::Measurement;
use flexarm_core::observer_gains::{GAIN_1KHZ, gain};
use flexarm_core::simarm::{SensorModel, SimArm};
use flexarm_core::time::{MoveClock, Ticks};
use flexarm_core::trajectory::{JointTrajectory, Trapezoid};

const MOTOR_HZ: u32 = 1000;
const DAY: u64 = 86_400 * MOTOR_HZ as u64;

/// The paper's move on the simulated arm, the motor loop at 1 kHz and the piezo loop at 10 kHz,
/// started at tick `start`; the trajectory's time comes from `time(now)`. Returns every torque
/// command's bits, 6 s of them.
fn run(start: u64, time: impl Fn(Ticks) -> f32) -> Vec<[u32; 2]> {
    let mut c = Controller::<f32>::paper(
        MotorLaw::Robust,
        JointTrajectory::Trapezoid(Trapezoid::paper()),
        1e-4,
        1e-3,
        gain(&GAIN_1KHZ),
    );
    let mut arm = SimArm::new(
        c.motor.model,
        c.patch,
        Vector4::zeros(),
        SensorModel::default(),
    );
    c.reset_observer(arm.encoders());
    let mut now = Ticks(start);
    let mut out = Vec::new();
    for _ in 0..6000 {
        let y = Measurement {
            theta: arm.encoders(),
            v_f: arm.film_voltage(),
        };
        let cmd = c.motor_step(time(now), Some(&y)).command;
        assert!(c.fault().is_none(), "fault at tick {}", now.0);
        arm.set_torques(cmd.tau);
        arm.set_enable(cmd.enable);
        out.push([cmd.tau.x.to_bits(), cmd.tau.y.to_bits()]);
        for _ in 0..10 {
            arm.set_piezo(c.piezo_step(arm.film_voltage()));
            assert!(arm.step(1e-4));
        }
        now = now.next();
    }
    out
}

#[test]
fn a_move_started_after_any_uptime_gives_the_same_torques_to_the_bit() {
    let reference = run(0, |now| MoveClock::new(Ticks(0), MOTOR_HZ).local_time(now));
    for start in [
        DAY,
        4_294_967_296 - 3000, // a u32 count of periods would wrap 3 s into the move (49.7 days)
        3652 * DAY,           // ten years
        u64::MAX - 3000,      // the u64 count wraps 3 s into the move
    ] {
        let clock = MoveClock::new(Ticks(start), MOTOR_HZ);
        let torques = run(start, |now| clock.local_time(now));
        assert!(torques == reference, "start at tick {start}");
    }
}

#[test]
fn absolute_f32_time_would_not() {
    // What the firmware did before: t = k / rate in f32 from a u32 count since boot. One day in,
    // the trajectory is sampled on a 7.8 ms grid and the torques differ.
    let reference = run(0, |now| MoveClock::new(Ticks(0), MOTOR_HZ).local_time(now));
    let day = run(DAY, |now| {
        (now.0 as u32) as f32 / MOTOR_HZ as f32 - 86_400.0
    });
    assert!(day != reference);
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

//! Arbitrary sensor samples into the complete controller: it must never panic, and its outputs
//! must stay finite and inside their limits. `cargo fuzz run -s none controller`.
#![no_main]

use flexarm_core::Vector2;
use flexarm_core::control::motor::MotorLaw;
use flexarm_core::controller::Controller;
use flexarm_core::observer::Measurement;
use flexarm_core::observer_gains::{GAIN_1KHZ, gain};
use flexarm_core::params::Limits;
use flexarm_core::trajectory::{JointTrajectory, Trapezoid};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let limits = Limits::<f32>::default();
    let mut c = Controller::paper(
        MotorLaw::Robust,
        JointTrajectory::Trapezoid(Trapezoid::paper()),
        1e-4,
        1e-3,
        gain(&GAIN_1KHZ),
    );
    // Each 17-byte chunk: time, θ1, θ2, V_f (f32, little endian) and a flag byte
    // (bit 0: a new sample arrived; bit 1: reset the latch first).
    for (k, chunk) in data.chunks_exact(17).enumerate() {
        let f = |i: usize| f32::from_le_bytes([chunk[i], chunk[i + 1], chunk[i + 2], chunk[i + 3]]);
        let (t, y) = (
            f(0),
            Measurement {
                theta: Vector2::new(f(4), f(8)),
                v_f: f(12),
            },
        );
        if chunk[16] & 2 != 0 {
            c.reset(Vector2::zeros());
        }
        let r = c.motor_step(t, if chunk[16] & 1 != 0 { Some(&y) } else { None });
        assert!(
            r.command
                .tau
                .iter()
                .zip(limits.tau_max.iter())
                .all(|(x, l)| x.is_finite() && x.abs() <= *l),
            "step {k}"
        );
        assert_eq!(
            r.command.enable,
            c.fault().is_none(),
            "enabled exactly when no fault is latched"
        );
        let v_a = c.piezo_step(y.v_f);
        assert!(v_a.is_finite() && v_a.abs() <= limits.v_a_max);
        if c.fault().is_some() {
            assert_eq!(v_a, 0.0, "0 V in the safe state");
        }
    }
});

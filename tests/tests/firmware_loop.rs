//! The firmware's control schedule on the host, with the same core code the firmware runs:
//! the complete controller (observer, checks, latch) against the `f32` simulated arm of the
//! QEMU board, the piezo loop stepping the plant every piezo period and the motor loop running
//! every `ratio` piezo periods. These runs justify the bounds the QEMU run checks
//! (`docs/firmware.md`): `cargo test -p flexarm-tests --test firmware_loop -- --nocapture`.

use flexarm_core::control::motor::MotorLaw;
use flexarm_core::control::piezo::PiezoPatch;
use flexarm_core::controller::Controller;
use flexarm_core::model::Model;
use flexarm_core::observer::Measurement;
use flexarm_core::observer_gains::{GAIN_1KHZ, GAIN_100HZ, gain};
use flexarm_core::params::ArmParams;
use flexarm_core::simarm::{SensorModel, SimArm};
use flexarm_core::trajectory::{JointTrajectory, Trapezoid};
use flexarm_core::{Vector2, Vector4};

struct Outcome {
    max_error: f32,
    tail_error: f32,
    max_tip: f32,
    final_tip: f32,
    enabled_to_the_end: bool,
}

fn run(piezo_hz: f32, ratio: u32, table: &[[f32; 3]; 8], law: MotorLaw, seconds: f32) -> Outcome {
    let dt_p = 1.0 / piezo_hz;
    let dt_m = dt_p * ratio as f32;
    let arm = ArmParams::<f32>::default();
    let patch = PiezoPatch::<f32>::paper();
    let traj = JointTrajectory::Trapezoid(Trapezoid::paper());
    let mut ctrl = Controller::paper(law, traj, dt_p, dt_m, gain(table));
    // As the firmware: the paper's gains, slowed for a slow motor loop.
    ctrl.motor.gains = flexarm_core::params::Gains::default_for((1.0 / dt_m).round() as u32);
    let mut sim = SimArm::new(
        Model::new(arm),
        patch,
        Vector4::zeros(),
        SensorModel::default(),
    );
    let mut out = Outcome {
        max_error: 0.0,
        tail_error: 0.0,
        max_tip: 0.0,
        final_tip: 0.0,
        enabled_to_the_end: true,
    };
    let (mut tail_sum, mut tail_n) = (0.0f32, 0u32);
    let ticks = (seconds * piezo_hz).round() as u32;
    for k in 0..ticks {
        let v_a = ctrl.piezo_step(sim.film_voltage());
        sim.set_piezo(v_a);
        assert!(sim.step(dt_p), "plant diverged");
        if k % ratio == ratio - 1 {
            let t = (k / ratio) as f32 * dt_m;
            let y = Measurement {
                theta: sim.encoders(),
                v_f: sim.film_voltage(),
            };
            let rep = ctrl.motor_step(t, Some(&y));
            sim.set_torques(rep.command.tau);
            sim.set_enable(rep.command.enable);
            out.enabled_to_the_end &= rep.command.enable;
            let e = (Vector2::new(sim.x.q.x, sim.x.q.y) - traj.sample(t).q)
                .abs()
                .max();
            out.max_error = out.max_error.max(e);
            if t >= seconds - 3.0 {
                tail_sum += e;
                tail_n += 1;
            }
            let tip = sim.model.tip_deflection(&sim.x.q).abs();
            out.max_tip = out.max_tip.max(tip);
            out.final_tip = tip;
        }
    }
    out.tail_error = tail_sum / tail_n as f32;
    out
}

#[test]
fn qemu_rates_track_and_damp() {
    for (name, hz, ratio, table) in [
        ("QEMU (piezo 1 kHz, motor 100 Hz)", 1e3, 10, &GAIN_100HZ),
        ("hardware (10 kHz, 1 kHz)", 1e4, 10, &GAIN_1KHZ),
    ] {
        for law in [MotorLaw::Tracking, MotorLaw::Robust] {
            let o = run(hz, ratio, table, law, 6.0);
            println!(
                "{name}, {law:?}: max |θ − θ_d| {:.3e} rad, mean over the last 3 s {:.3e} rad, max |tip| {:.3e} m, final |tip| {:.3e} m",
                o.max_error, o.tail_error, o.max_tip, o.final_tip
            );
            assert!(o.enabled_to_the_end, "no fault in a healthy run");
            assert!(o.max_error < 0.05, "tracks the move within 0.05 rad");
            assert!(o.tail_error < 2e-3, "settles within 2 mrad");
            assert!(
                o.max_tip < 0.02 && o.final_tip < 1e-3,
                "vibration bounded and damped"
            );
        }
    }
}

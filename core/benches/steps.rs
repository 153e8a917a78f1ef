//! Host (x86) timings of the hot-path functions the firmware runs, in `f32`:
//! `cargo bench -p flexarm-core --bench steps`. The Cortex-M4F instruction counts are measured
//! under QEMU by the firmware's benchmark build.

#![allow(clippy::unwrap_used, clippy::indexing_slicing)] // benchmark set-up

use criterion::{Criterion, criterion_group, criterion_main};
use flexarm_core::control::motor::{MotorController, MotorLaw};
use flexarm_core::control::piezo::{PiezoGains, PiezoLaw};
use flexarm_core::control::tracking::eq7;
use flexarm_core::controller::Controller;
use flexarm_core::model::Model;
use flexarm_core::observer::Measurement;
use flexarm_core::observer_gains::{GAIN_1KHZ, gain};
use flexarm_core::params::{ArmParams, Gains, Limits};
use flexarm_core::trajectory::{JointTarget, JointTrajectory, Trapezoid};
use flexarm_core::{Vector2, Vector4};
use std::hint::black_box;

fn states() -> Vec<(Vector4<f32>, Vector4<f32>, JointTarget<f32>)> {
    // A deterministic spread of states (LCG), like the firmware benchmark's random set.
    let mut seed = 0x1234_5678u32;
    let mut r = move |s: f32| {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (seed >> 8) as f32 / (1u32 << 24) as f32 * 2.0 * s - s
    };
    (0..256)
        .map(|_| {
            let q = Vector4::new(r(3.0), r(3.0), r(0.01), r(0.001));
            let qd = Vector4::new(r(2.0), r(2.0), r(0.3), r(0.1));
            let t = JointTarget {
                q: Vector2::new(r(3.0), r(3.0)),
                qd: Vector2::new(r(1.0), r(1.0)),
                qdd: Vector2::new(r(2.0), r(2.0)),
            };
            (q, qd, t)
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let model = Model::new(ArmParams::<f32>::default());
    let gains = Gains::default();
    let set = states();
    c.bench_function("eq7 (256 states)", |b| {
        b.iter(|| {
            for (q, qd, t) in &set {
                black_box(eq7(&model, &gains, black_box(q), black_box(qd), t));
            }
        })
    });
    let motor = MotorController {
        model,
        gains,
        limits: Limits::default(),
        law: MotorLaw::Robust,
    };
    c.bench_function("motor law, Eq. 16 + saturation (256 states)", |b| {
        b.iter(|| {
            for (q, qd, t) in &set {
                black_box(motor.step(1.0, black_box(q), black_box(qd), t).unwrap());
            }
        })
    });
    let mut piezo = PiezoLaw::new(&PiezoGains::default(), 1e-4, 200.0);
    c.bench_function("piezo step (256 samples)", |b| {
        b.iter(|| {
            for (q, _, _) in &set {
                black_box(piezo.step(black_box(q.z * 100.0)));
            }
        })
    });
    let mut ctrl = Controller::paper(
        MotorLaw::Robust,
        JointTrajectory::Trapezoid(Trapezoid::paper()),
        1e-4,
        1e-3,
        gain(&GAIN_1KHZ),
    );
    c.bench_function(
        "complete motor step with observer and checks (one step)",
        |b| {
            let mut k = 0u32;
            b.iter(|| {
                k = k.wrapping_add(1);
                let y = Measurement {
                    theta: Vector2::new(0.0, 0.0),
                    v_f: 0.0,
                };
                black_box(ctrl.motor_step(black_box((k % 1000) as f32 * 1e-3), Some(&y)))
            })
        },
    );
}

criterion_group!(benches, bench);
criterion_main!(benches);

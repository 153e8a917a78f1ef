//! Speed of the simulator: `cargo bench -p flexarm-sim --bench study`.
//! One 5 s scenario at the default rates (plant 0.1 ms, motor 1 kHz, piezo 10 kHz), and the
//! whole `paper` study (12 runs, in parallel on the machine's cores).

use criterion::{Criterion, criterion_group, criterion_main};
use flexarm_core::control::piezo::PiezoGains;
use flexarm_core::trajectory::{JointTrajectory, Trapezoid};
use flexarm_sim::sim::{SimConfig, simulate};
use flexarm_sim::study::{self, Options};

fn bench(c: &mut Criterion) {
    let traj = JointTrajectory::Trapezoid(Trapezoid::paper());
    let cfg = SimConfig {
        piezo: Some(PiezoGains::default()),
        ..SimConfig::default()
    };
    let mut g = c.benchmark_group("simulator");
    g.sample_size(10);
    g.bench_function("trapezoid 5 s, Eq. 7 + piezo, default rates", |b| {
        b.iter(|| simulate(&cfg, &traj, false))
    });
    g.bench_function("paper study (12 runs, recorded)", |b| {
        b.iter(|| {
            study::run(
                study::paper_cases(&Options::default())
                    .ok()
                    .unwrap_or_default(),
                true,
                false,
            )
            .map(|o| o.len())
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

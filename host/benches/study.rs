//! Speed of the simulator: `cargo bench -p flexarm-host --bench study`.
//! One 5 s scenario at the default rates (plant 0.1 ms, motor 1 kHz, piezo 10 kHz), and the
//! whole `paper` study (12 runs, in parallel on the machine's cores); the same scenario on the
//! truth plant with six modes, motor models and transducers (issue 14: at least 100× faster
//! than real time, i.e. under 50 ms).

use criterion::{Criterion, criterion_group, criterion_main};
use flexarm_core::control::piezo::PiezoGains;
use flexarm_core::trajectory::{JointTrajectory, Trapezoid};
use flexarm_host::sim::{SimConfig, simulate};
use flexarm_host::study::{self, Options};
use flexarm_host::truth_plant::TruthSpec;

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
    let truth = cfg
        .with_truth(TruthSpec::default())
        .expect("the default truth plant builds");
    g.bench_function(
        "trapezoid 5 s on the truth plant, N = 6, default rates",
        |b| b.iter(|| simulate(&truth, &traj, false)),
    );
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

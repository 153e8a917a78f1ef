//! The full placement sweep: `x_a`, `l_a` in 0.01 m steps over the feasible triangle of the
//! 0.7 m link (2485 patches), 31 gains, on rayon's pool.
//!
//! `CARGO_TARGET_DIR=/work/target-beam cargo bench -p flexarm-placement --bench sweep`

use criterion::{Criterion, criterion_group, criterion_main};
use flexarm_beam::config::default_gains;
use flexarm_beam::design::DesignModel;
use flexarm_placement::optimize::sweep;
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let model = DesignModel::default();
    let gains = default_gains();
    let mut g = c.benchmark_group("placement");
    g.sample_size(10);
    g.bench_function("full_sweep_2485_patches_31_gains", |b| {
        b.iter(|| sweep(black_box(&model), 0.01, 0.01, black_box(&gains)))
    });
    g.bench_function("one_patch_modes", |b| {
        b.iter(|| black_box(&model).patch_modes(black_box(0.09), black_box(0.35)))
    });
    let pm = model.patch_modes(0.09, 0.35);
    g.bench_function("one_gain_lyapunov", |b| {
        b.iter(|| {
            pm.as_ref()
                .ok()
                .and_then(|pm| model.energy(pm, black_box(30.0)))
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

//! Robustness: the controller keeps its nominal model while the simulated arm's masses,
//! inertias, modal frequencies and damping ratios are perturbed, uniformly and independently,
//! by up to ±10 % or ±20 %.

use std::fmt::Write as _;
use std::path::Path;

use flexarm_core::control::piezo::PiezoGains;
use flexarm_core::params::{ArmParams, ModalData};
use flexarm_core::trajectory::{JointTrajectory, Trapezoid};
use indicatif::{ProgressBar, ProgressStyle};
use plotters::prelude::*;
use rayon::prelude::*;

use crate::sim::{Rng, SimConfig, SimError, Summary, simulate};
use crate::truth_plant::TruthSpec;

/// Tracking bounds a run must keep to count as a success.
pub mod bounds {
    /// Largest |θ − θ_d| over the run [rad] (nominal: 1.0e-3 rad).
    pub const MAX_ERROR: f64 = 0.01;
    /// Eq. 38 mean |θ − θ_d| over the last 3 s, each joint [rad] (nominal: 3e-5 rad).
    pub const TAIL_ERROR: f64 = 1e-3;
}

/// The arm with each perturbed quantity scaled by `1 + level·u`, `u` uniform in [−1, 1].
pub fn perturb(nominal: &ArmParams<f64>, level: f64, rng: &mut Rng) -> ArmParams<f64> {
    let mut f = || 1.0 + level * (2.0 * rng.uniform() - 1.0);
    let mut p = *nominal;
    p.m1 *= f();
    p.m2 *= f();
    p.m_h2 *= f();
    p.i_1 *= f();
    p.i_h1 *= f();
    p.i_h2 *= f();
    let omega = nalgebra::Vector2::new(p.modes.omega.x * f(), p.modes.omega.y * f());
    let zeta = nalgebra::Vector2::new(p.modes.zeta.x * f(), p.modes.zeta.y * f());
    p.modes = ModalData::uniform(p.m2, p.a2, omega, zeta);
    p
}

/// The result of one batch.
#[derive(Clone, Debug)]
pub struct Batch {
    /// Perturbation level (0.1 = ±10 %).
    pub level: f64,
    /// Summaries of the runs that finished (`None`: diverged or faulted).
    pub runs: Vec<Option<Summary>>,
}

impl Batch {
    /// Fraction of runs that finished and kept the tracking bounds.
    pub fn success(&self) -> f64 {
        let ok = self.runs.iter().flatten().filter(|s| within(s)).count();
        ok as f64 / self.runs.len().max(1) as f64
    }

    /// Fraction of runs that finished (stable).
    pub fn stable(&self) -> f64 {
        self.runs.iter().flatten().count() as f64 / self.runs.len().max(1) as f64
    }
}

fn within(s: &Summary) -> bool {
    s.max_error <= bounds::MAX_ERROR && s.tail_error_abs.iter().all(|e| *e <= bounds::TAIL_ERROR)
}

/// Most runs per perturbation level the command accepts.
pub const MAX_RUNS: usize = 100_000;

/// Runs `runs` perturbed copies of the paper's trapezoid move under Eq. 7 + piezo, at each level,
/// on the controller's own model or on the truth plant `truth` (then every mode's frequency
/// and damping ratio is perturbed, and the controller keeps the nominal truncation).
pub fn run(
    levels: &[f64],
    runs: usize,
    seed: u64,
    truth: Option<TruthSpec>,
    progress: bool,
) -> Result<Vec<Batch>, SimError> {
    let mut base = SimConfig {
        piezo: Some(PiezoGains::default()),
        ..SimConfig::default()
    };
    if let Some(t) = truth {
        base = base.with_truth(t)?;
    }
    run_on(&base, levels, runs, seed, progress)
}

/// [`run`] about the configuration `base` (its arm perturbed, its gains and plant kept).
pub fn run_on(
    base: &SimConfig,
    levels: &[f64],
    runs: usize,
    seed: u64,
    progress: bool,
) -> Result<Vec<Batch>, SimError> {
    let traj = JointTrajectory::Trapezoid(Trapezoid::paper());
    let bar = if progress {
        ProgressBar::new((levels.len() * runs) as u64)
    } else {
        ProgressBar::hidden()
    };
    if let Ok(style) = ProgressStyle::with_template("{bar:40} {pos}/{len} runs {elapsed}") {
        bar.set_style(style);
    }
    let out = levels
        .iter()
        .map(|&level| {
            let runs = (0..runs)
                .into_par_iter()
                .map(|i| {
                    let mut rng = Rng::new(
                        seed ^ (i as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ level.to_bits(),
                    );
                    let plant = Some(perturb(&base.plant.unwrap_or(base.arm), level, &mut rng));
                    let truth = base.truth.map(|mut t| {
                        for j in 0..t.modes {
                            t.omega_scale[j] *= 1.0 + level * (2.0 * rng.uniform() - 1.0);
                            t.zeta[j] *= 1.0 + level * (2.0 * rng.uniform() - 1.0);
                        }
                        t
                    });
                    let cfg = SimConfig {
                        plant,
                        truth,
                        ..*base
                    };
                    let r = simulate(&cfg, &traj, false).ok().map(|(s, _)| s);
                    bar.inc(1);
                    r
                })
                .collect();
            Batch { level, runs }
        })
        .collect();
    bar.finish_and_clear();
    Ok(out)
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let i = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[i.min(sorted.len() - 1)]
}

/// Markdown report of the batches.
pub fn report(batches: &[Batch]) -> String {
    let mut s = format!(
        "Success: the run stays stable (no divergence, no fault) and keeps max |θ − θ_d| ≤ {} rad and the Eq. 38 mean |θ − θ_d| ≤ {} rad on each joint.\n\n\
         | perturbation | runs | stable | within bounds | Eq. 37 θ̃ [rad] p5 / p50 / p95 / max | Eq. 37 δ [√kg·m] p5 / p50 / p95 / max | Eq. 38 mean \\|θ̃1\\| [rad] p50 / p95 / max |\n\
         |---|---|---|---|---|---|---|\n",
        bounds::MAX_ERROR,
        bounds::TAIL_ERROR
    );
    for b in batches {
        let col = |f: &dyn Fn(&Summary) -> f64| {
            let mut v: Vec<f64> = b.runs.iter().flatten().map(f).collect();
            v.sort_by(f64::total_cmp);
            v
        };
        let e = col(&|s| s.l2_error);
        let d = col(&|s| s.l2_delta);
        let t = col(&|s| s.tail_error_abs[0]);
        let _ = writeln!(
            s,
            "| ±{:.0} % | {} | {:.1} % | {:.1} % | {:.2e} / {:.2e} / {:.2e} / {:.2e} | {:.2e} / {:.2e} / {:.2e} / {:.2e} | {:.2e} / {:.2e} / {:.2e} |",
            b.level * 100.0,
            b.runs.len(),
            b.stable() * 100.0,
            b.success() * 100.0,
            percentile(&e, 0.05),
            percentile(&e, 0.5),
            percentile(&e, 0.95),
            percentile(&e, 1.0),
            percentile(&d, 0.05),
            percentile(&d, 0.5),
            percentile(&d, 0.95),
            percentile(&d, 1.0),
            percentile(&t, 0.5),
            percentile(&t, 0.95),
            percentile(&t, 1.0),
        );
    }
    s
}

/// Histogram of the Eq. 37 joint error per level, as SVG.
pub fn figure(path: &Path, batches: &[Batch]) -> Result<(), Box<dyn std::error::Error>> {
    let root = SVGBackend::new(path, (900, 500)).into_drawing_area();
    root.fill(&WHITE)?;
    let all: Vec<f64> = batches
        .iter()
        .flat_map(|b| b.runs.iter().flatten().map(|s| s.l2_error))
        .collect();
    let hi = all.iter().copied().fold(0.0, f64::max).max(1e-12) * 1.05;
    let bins = 40;
    let w = hi / bins as f64;
    let counts: Vec<Vec<u32>> = batches
        .iter()
        .map(|b| {
            let mut c = vec![0u32; bins];
            for s in b.runs.iter().flatten() {
                let i = ((s.l2_error / w) as usize).min(bins - 1);
                c[i] += 1;
            }
            c
        })
        .collect();
    let top = counts.iter().flatten().copied().max().unwrap_or(1).max(1);
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "Monte Carlo: Eq. 37 joint tracking error, perturbed plant",
            ("sans-serif", 20),
        )
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..hi, 0u32..top + top / 10 + 1)?;
    chart
        .configure_mesh()
        .x_desc("Eq. 37 of θ − θ_d [rad]")
        .y_desc("runs")
        .draw()?;
    let colours = [BLUE.mix(0.5), RED.mix(0.5), GREEN.mix(0.5)];
    for (k, (b, c)) in batches.iter().zip(&counts).enumerate() {
        let col = colours[k % colours.len()];
        chart
            .draw_series(c.iter().enumerate().map(|(i, n)| {
                Rectangle::new(
                    [(i as f64 * w, 0), ((i as f64 + 1.0) * w, *n)],
                    col.filled(),
                )
            }))?
            .label(format!("±{:.0} %", b.level * 100.0))
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], col.filled()));
    }
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .draw()?;
    root.present()?;
    Ok(())
}

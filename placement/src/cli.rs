//! The `optimize` command: the entry point `flexarm-sim optimize [config.toml]` calls.
//!
//! Writes into `out_dir`:
//! - `grid.csv`: every patch of the grid with its best gain, `J`, `J0`, `W0`, frequencies and
//!   slope differences;
//! - `summary.md`: the text this function returns;
//! - `piezo.toml`: the chosen patch as a `[piezo]` fragment (see [`flexarm_beam::fragment`]);
//! - with `plots`: `heatmap.svg` (`J`), `heatmap_share.svg` (`J0/W0`), `gain.svg`, `modes.svg`.

use crate::optimize::{Bounds, Sweep, refine, sweep};
use crate::plot;
use flexarm_beam::config::Config;
use flexarm_beam::design::{Amplifier, DesignModel, Normalization, Objective, Weights};
use flexarm_beam::fragment::piezo_fragment;
use flexarm_beam::point::{Optimum, evaluate};
use flexarm_core::params::ArmParams;
use std::error::Error;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

const TAU: f64 = std::f64::consts::TAU;

/// The grid optimum, refined when the configuration asks.
fn optimum(
    model: &DesignModel,
    w: &Weights,
    s: &Sweep,
    cfg: &Config,
) -> Result<Optimum, Box<dyn Error>> {
    let (p, k, _) = s
        .best(w)
        .ok_or("no grid point could be evaluated (see grid.csv)")?;
    let pt = &s.points[p];
    let start = (pt.x_a, pt.l_a, s.gains[k]);
    let o = &cfg.optimize;
    let r = if o.refine {
        let b = Bounds {
            min_length: o.min_length,
            k_min: o.k_c.iter().copied().fold(f64::INFINITY, f64::min),
            k_max: o.k_max,
        };
        refine(model, w, start, o.step, &b)
    } else {
        evaluate(model, w, start.0, start.1, start.2)
    };
    r.ok_or_else(|| "the best grid point could not be re-evaluated".into())
}

fn hz(o: &Optimum) -> String {
    o.modes
        .omega()
        .iter()
        .map(|w| format!("{:.3}", w / TAU))
        .collect::<Vec<_>>()
        .join(", ")
}

/// `grid.csv`: one row per patch with its best feasible gain, `J`, `J0`, `W0`, and the
/// frequencies and slope differences of every mode kept. A value that was not computed is an
/// empty field, and `status` says why; no field is NaN or infinite.
fn grid_csv(s: &Sweep, w: &Weights, modes: usize) -> String {
    let mut head = String::from("x_a_m,l_a_m,status,best_k_c_s,k_c_limit_s,J,J0,W0");
    for j in 1..=modes {
        let _ = write!(head, ",f{j}_hz");
    }
    for j in 1..=modes {
        let _ = write!(head, ",slope_diff{j}");
    }
    let mut csv = head + "\n";
    let num = |v: f64| {
        if v.is_finite() {
            format!("{v:e}")
        } else {
            String::new()
        }
    };
    for (p, (k, j)) in s.points.iter().zip(s.best_per_point(w)) {
        let status = if p.omega.len() < modes {
            "modes failed"
        } else if !j.is_finite() {
            "no stable feasible gain"
        } else {
            "ok"
        };
        let _ = write!(
            csv,
            "{:.4},{:.4},{status},{},{},{},{},{}",
            p.x_a,
            p.l_a,
            num(if j.is_finite() { s.gains[k] } else { f64::NAN }),
            num(p.k_limit),
            num(j),
            num(p.j0.get(k).copied().unwrap_or(f64::NAN)),
            num(p.w0),
        );
        for i in 0..modes {
            let _ = write!(
                csv,
                ",{}",
                num(p.omega.get(i).map_or(f64::NAN, |o| o / TAU))
            );
        }
        for i in 0..modes {
            let _ = write!(
                csv,
                ",{}",
                num(p.slope_diff.get(i).copied().unwrap_or(f64::NAN))
            );
        }
        csv.push('\n');
    }
    csv
}

/// What the optimum asks of the amplifier, and which bound on the gain is active.
fn amplifier_note(model: &DesignModel, best: &Optimum, k_max: f64) -> String {
    let a = &model.amplifier;
    let pm = &best.modes;
    let by_mode: Vec<String> = model
        .volts_per_gain_by_mode(pm)
        .iter()
        .map(|v| format!("{:.0}", best.k_c * v))
        .collect();
    let tips: Vec<String> = a
        .reference_tip_speed
        .iter()
        .map(|r| format!("{r}"))
        .collect();
    let v = best.k_c * model.volts_per_gain(pm);
    let limit = model.amplifier.headroom() / model.volts_per_gain(pm);
    let active = if a.enforce && best.k_c >= limit * (1.0 - 1e-6) {
        format!("the amplifier (k_c ≤ {limit:.1} s at this patch)")
    } else if best.k_c >= k_max * (1.0 - 1e-6) {
        format!("K_max = {k_max} s")
    } else {
        "none: the optimum is interior in k_c".into()
    };
    format!(
        "\nAmplifier: {} V … +{} V{}. The reference vibration ({} m/s of tip speed per mode, worst phase) asks \
         for {v:.0} V at the optimum ({} V per mode); the amplifier allows k_c ≤ {limit:.1} s at this \
         patch. Active bound on k_c: {active}. (k_a = {:.4e} N·m/V, k_s = {:.4e} V/rad, Δφ' = {:?}.)\n",
        a.v_min,
        a.v_max,
        if a.enforce { "" } else { " (not enforced)" },
        tips.join(", "),
        by_mode.join(" / "),
        pm.k_a,
        pm.k_s,
        pm.slope_diff
    )
}

fn row(label: &str, o: &Optimum) -> String {
    format!(
        "| {label} | {:.3} | {:.3} | {:.1} | {:.4e} | {:.4e} | {:.3} | {} |\n",
        o.x_a,
        o.l_a,
        o.k_c,
        o.j,
        o.energy.j0,
        o.energy.j0 / o.energy.w0,
        hz(o)
    )
}

/// Runs the optimization; returns the terminal summary.
pub fn run_optimize(
    config: Option<&Path>,
    out_dir: &Path,
    plots: bool,
) -> Result<String, Box<dyn Error>> {
    let cfg = match config {
        Some(p) => Config::load(p)?,
        None => Config::default(),
    };
    std::fs::create_dir_all(out_dir)
        .map_err(|e| format!("cannot create {}: {e}", out_dir.display()))?;
    let model = cfg.model();
    let w = cfg.weights();
    let o = &cfg.optimize;

    let t0 = Instant::now();
    let s = sweep(&model, o.step, o.min_length, &o.k_c);
    let t_sweep = t0.elapsed();
    let grid_best = {
        let (p, k, j) = s.best(&w).ok_or("no grid point could be evaluated")?;
        (s.points[p].x_a, s.points[p].l_a, s.gains[k], j)
    };
    let best = optimum(&model, &w, &s, &cfg)?;

    let mut out = String::new();
    let _ = writeln!(out, "# Piezo placement on link 2 (flexarm-beam)\n");
    let bare = model.layers.bare();
    let patched = model.layers.patched();
    let _ = writeln!(
        out,
        "Design beam: a2 = {} m, EI = {:.4e} N·m² (patched {:.4e}), ρA = {:.4e} kg/m (patched {:.4e}), \
         mass {:.4} kg; tip mass {} kg; {} modes, ζ = {:?}; normalization {:?}; objective {:?}; \
         α = {}, β_c = {}, λ = {:?}.",
        model.length,
        bare.ei,
        patched.ei,
        bare.rho_a,
        patched.rho_a,
        bare.rho_a * model.length,
        model.tip_mass,
        model.mode_count(),
        model.zeta,
        model.normalization,
        o.objective,
        o.alpha,
        o.beta_c,
        o.lambda
    );
    let bare_model = DesignModel {
        patch_structure: false,
        ..model.clone()
    };
    if let Ok(b) = bare_model
        .beam(0.0, model.length)
        .and_then(|b| b.frequencies(model.mode_count()))
    {
        let f: Vec<String> = b.iter().map(|w| format!("{:.3}", w / TAU)).collect();
        let _ = writeln!(
            out,
            "Bare beam frequencies: {} Hz (the controller's defaults are the paper's 4.716, 14.395 Hz).",
            f.join(", ")
        );
    }
    let _ = writeln!(
        out,
        "\nGrid: {} patches × {} gains (step {} m), {} failed, swept in {:.1} ms on {} threads.",
        s.points.len(),
        s.gains.len(),
        o.step,
        s.failures(),
        t_sweep.as_secs_f64() * 1e3,
        rayon::current_num_threads()
    );
    let _ = writeln!(
        out,
        "Grid optimum: x_a = {:.3} m, l_a = {:.3} m, k_c = {:.2} s, J = {:.5e}.\n",
        grid_best.0, grid_best.1, grid_best.2, grid_best.3
    );
    let header = "| case | x_a [m] | l_a [m] | k_c [s] | J | J0 | J0/W0 | f [Hz] |\n|---|---|---|---|---|---|---|---|\n";
    out.push_str(header);
    out.push_str(&row("**optimum (refined)**", &best));
    for (label, k) in [
        ("paper point, k_c = 30 s", 30.0),
        ("paper patch, optimum k_c", best.k_c),
    ] {
        if let Some(p) = evaluate(&model, &w, 0.09, 0.35, k) {
            out.push_str(&row(label, &p));
        }
    }
    // Without the amplifier: the paper's problem, bounded by K_max alone.
    let free_model = DesignModel {
        amplifier: Amplifier {
            enforce: false,
            ..model.amplifier.clone()
        },
        ..model.clone()
    };
    if model.amplifier.enforce {
        let free = sweep(&free_model, o.step, o.min_length, &o.k_c);
        if let Ok(u) = optimum(&free_model, &w, &free, &cfg) {
            out.push_str(&row("without the amplifier constraint", &u));
        }
    }
    out.push_str(&amplifier_note(&model, &best, o.k_max));
    if cfg.sensitivity.enabled {
        let _ = writeln!(
            out,
            "\n## Sensitivity (each row re-optimizes with one change)\n"
        );
        out.push_str(header);
        let sc = &cfg.sensitivity;
        for &a in &sc.alpha {
            let wv = Weights { alpha: a, ..w };
            if let Ok(r) = optimum(&model, &wv, &s, &cfg) {
                out.push_str(&row(&format!("α = {a}"), &r));
            }
        }
        for &b in &sc.beta_c {
            let wv = Weights { beta_c: b, ..w };
            if let Ok(r) = optimum(&model, &wv, &s, &cfg) {
                out.push_str(&row(&format!("β_c = {b}"), &r));
            }
        }
        for &km in &sc.k_max {
            // The same grid with the gains above K_max dropped, and a refinement bounded by it.
            let keep: Vec<usize> = (0..s.gains.len()).filter(|&k| s.gains[k] <= km).collect();
            if keep.is_empty() {
                continue;
            }
            let sub = Sweep {
                gains: keep.iter().map(|&k| s.gains[k]).collect(),
                points: s
                    .points
                    .iter()
                    .map(|p| crate::optimize::GridPoint {
                        j0: keep.iter().map(|&k| p.j0[k]).collect(),
                        ..p.clone()
                    })
                    .collect(),
            };
            let mut c = cfg.clone();
            c.optimize.k_max = km;
            if let Ok(r) = optimum(&model, &w, &sub, &c) {
                out.push_str(&row(&format!("K_max = {km} s"), &r));
            }
        }
        // The normalized objective: J0/W0 is a share in [0, 1], so its weights live on another
        // scale; β_c = 0 here (any β_c ≳ 1e-3 would just pin the gain to its lower bound).
        for obj in [Objective::Paper, Objective::Fraction] {
            if obj != w.objective {
                for a in [0.0, 0.3, 1.0] {
                    let wv = Weights {
                        objective: obj,
                        alpha: a,
                        beta_c: 0.0,
                    };
                    if let Ok(r) = optimum(&model, &wv, &s, &cfg) {
                        out.push_str(&row(&format!("objective {obj:?}, α = {a}, β_c = 0"), &r));
                    }
                }
            }
        }
        let mut variants: Vec<(String, DesignModel)> = Vec::new();
        for &rho in &sc.rho_b {
            if rho != model.layers.rho_b {
                let mut m = model.clone();
                m.layers.rho_b = rho;
                variants.push((format!("ρ_b = {rho:.0} kg/m³"), m));
            }
        }
        for &tm in &sc.tip_mass {
            if tm != model.tip_mass {
                variants.push((
                    format!("tip mass {tm} kg"),
                    DesignModel {
                        tip_mass: tm,
                        ..model.clone()
                    },
                ));
            }
        }
        for n in [
            Normalization::UnitModalMass,
            Normalization::UnitTip,
            Normalization::PaperTip,
        ] {
            if n != model.normalization {
                variants.push((
                    format!("normalization {n:?}"),
                    DesignModel {
                        normalization: n,
                        ..model.clone()
                    },
                ));
            }
        }
        variants.push((
            format!("patch_structure = {}", !model.patch_structure),
            DesignModel {
                patch_structure: !model.patch_structure,
                ..model.clone()
            },
        ));
        for (label, m) in variants {
            let sv = sweep(&m, o.step, o.min_length, &o.k_c);
            if let Ok(r) = optimum(&m, &w, &sv, &cfg) {
                out.push_str(&row(&label, &r));
            }
        }
    }

    // Files.
    let csv = grid_csv(&s, &w, model.mode_count());
    let write = |name: &str, text: &str| -> Result<(), Box<dyn Error>> {
        let path = out_dir.join(name);
        std::fs::write(&path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        Ok(())
    };
    write("grid.csv", &csv)?;
    write(
        "piezo.toml",
        &piezo_fragment(&model, &best, &ArmParams::default()),
    )?;
    if plots {
        let kmin = o.k_c.iter().copied().fold(f64::INFINITY, f64::min);
        let j: Vec<f64> = s.best_per_point(&w).iter().map(|b| b.1).collect();
        plot::heat_map(
            &out_dir.join("heatmap.svg"),
            &s,
            &j,
            "J = α l_a² + β_c k_c − J0 (best k_c per patch)",
            match model.normalization {
                Normalization::UnitModalMass => "J [J]",
                _ => "J [units of J0 in this normalization]",
            },
            o.step,
            model.length,
            &best,
        )?;
        let share: Vec<f64> = s
            .points
            .iter()
            .map(|p| {
                p.j0.iter()
                    .zip(&s.gains)
                    .filter(|(_, k)| **k <= p.k_limit)
                    .fold(f64::NAN, |m, (j, _)| m.max(j / p.w0))
            })
            .collect();
        plot::heat_map(
            &out_dir.join("heatmap_share.svg"),
            &s,
            &share,
            "J0/W0: share of the initial energy removed (best feasible k_c per patch)",
            "J0/W0 [-]",
            o.step,
            model.length,
            &best,
        )?;
        let limit: Vec<f64> = s
            .points
            .iter()
            .map(|p| p.k_limit.min(o.k_max).log10())
            .collect();
        plot::heat_map(
            &out_dir.join("heatmap_gain_limit.svg"),
            &s,
            &limit,
            "largest feasible k_c: min(K_max, amplifier limit); feasible gains lie below",
            "log10 of k_c [s]",
            o.step,
            model.length,
            &best,
        )?;
        plot::gain_curves(
            &out_dir.join("gain.svg"),
            &model,
            &w,
            &best,
            (kmin, o.k_max),
        )?;
        plot::mode_shapes(&out_dir.join("modes.svg"), &model, &best)?;
    }
    write("summary.md", &out)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_config_is_an_error_not_a_panic() {
        let dir = std::env::temp_dir().join(format!("flexarm-beam-cli-{}", std::process::id()));
        let _ = std::fs::create_dir_all(&dir);
        let cfg = dir.join("bad.toml");
        let _ = std::fs::write(&cfg, "[optimize]\nalpha = -3.0\n");
        let r = run_optimize(Some(&cfg), &dir, false);
        assert!(r.is_err_and(|e| e.to_string().contains("optimize.alpha")));
        let r = run_optimize(Some(&dir.join("missing.toml")), &dir, false);
        assert!(r.is_err_and(|e| e.to_string().contains("cannot read")));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn grid_has_a_column_per_mode_and_no_nan() {
        for (modes, zeta, lambda, speed) in [
            (1, "[0.07]", "[20.0]", "[0.2]"),
            (
                3,
                "[0.07, 0.03, 0.02]",
                "[20.0, 10.0, 5.0]",
                "[0.2, 0.02, 0.01]",
            ),
        ] {
            let dir = std::env::temp_dir()
                .join(format!("flexarm-beam-modes{modes}-{}", std::process::id()));
            let _ = std::fs::create_dir_all(&dir);
            let cfg = dir.join("modes.toml");
            let _ = std::fs::write(
                &cfg,
                format!(
                    "[beam]\nzeta = {zeta}\n[optimize]\nlambda = {lambda}\nstep = 0.1\nmin_length = 0.1\nk_c = [1.0, 10.0, 1000.0]\nrefine = false\n[amplifier]\nreference_tip_speed = {speed}\n[sensitivity]\nenabled = false\n"
                ),
            );
            let r = run_optimize(Some(&cfg), &dir, false);
            assert!(r.is_ok(), "{r:?}");
            let csv = std::fs::read_to_string(dir.join("grid.csv")).unwrap_or_default();
            let head = csv.lines().next().unwrap_or("");
            assert!(head.contains(&format!("f{modes}_hz")), "{head}");
            assert!(!head.contains(&format!("f{}_hz", modes + 1)), "{head}");
            assert_eq!(
                head.split(',').count(),
                8 + 2 * modes,
                "one frequency and one slope per mode: {head}"
            );
            let lower = csv.to_lowercase();
            assert!(!lower.contains("nan") && !lower.contains("inf"), "{csv}");
            // Gains above the amplifier's limit are infeasible: an empty field and a status.
            assert!(
                csv.lines()
                    .skip(1)
                    .all(|l| l.split(',').count() == 8 + 2 * modes)
            );
            let _ = std::fs::remove_dir_all(&dir);
        }
    }

    #[test]
    fn coarse_run_writes_every_file() {
        let dir = std::env::temp_dir().join(format!("flexarm-beam-run-{}", std::process::id()));
        let _ = std::fs::create_dir_all(&dir);
        let cfg = dir.join("coarse.toml");
        let _ = std::fs::write(
            &cfg,
            "[optimize]\nstep = 0.1\nmin_length = 0.1\nk_c = [10.0, 100.0]\nrefine = false\n\
             [sensitivity]\nenabled = false\n",
        );
        let r = run_optimize(Some(&cfg), &dir, true);
        assert!(
            r.as_ref().is_ok_and(|s| s.contains("Grid optimum")),
            "{r:?}"
        );
        for f in [
            "grid.csv",
            "piezo.toml",
            "summary.md",
            "heatmap.svg",
            "gain.svg",
            "modes.svg",
        ] {
            assert!(dir.join(f).is_file(), "{f} missing");
        }
        let csv = std::fs::read_to_string(dir.join("grid.csv")).unwrap_or_default();
        // Header + 7·8/2 patches.
        assert_eq!(csv.lines().count(), 1 + 28);
        let _ = std::fs::remove_dir_all(&dir);
    }
}

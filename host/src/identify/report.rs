//! The reports of the modes, decay, inertia and closed-loop steps: Markdown tables, the
//! measured and fitted responses as CSV and SVG.

use std::fmt::Write as _;

use flexarm_core::control::piezo::PiezoPatch;
use flexarm_core::params::ArmParams;

use super::decay::DecayFit;
use super::inertia::{InertiaFit, Rigid};
use super::modal::{Input, ModesFit};
use super::model::LoopRun;

/// `x` against `truth` in percent, or a dash.
fn pct(x: f64, truth: Option<f64>) -> String {
    match truth {
        Some(t) if t != 0.0 => format!("{:+.2} %", (x / t - 1.0) * 100.0),
        _ => "—".into(),
    }
}

/// `x ± s` with `digits` decimals, or a dash when `x` is not a number.
fn plus_minus(x: f64, s: f64, digits: usize) -> String {
    if !x.is_finite() {
        return "—".into();
    }
    if s.is_finite() {
        format!("{x:.digits$} ± {s:.digits$}")
    } else {
        format!("{x:.digits$}")
    }
}

/// The modes' report: the inputs and what the fit chose, every resonance found (frequency,
/// damping, products, each with its standard deviation, the coherence where meaningful, the
/// orders it was stable over), which the controller keeps and which it leaves out and why;
/// against the true controller model `truth` when known.
pub fn modes_report(fit: &ModesFit, truth: Option<(&ArmParams<f64>, &PiezoPatch<f64>)>) -> String {
    let tau = std::f64::consts::TAU;
    let mut s = format!(
        "Inputs: {}; output: the film's reading v_f. Band {:.3}–{:.1} Hz.\n\n",
        fit.inputs
            .iter()
            .map(|i| i.name())
            .collect::<Vec<_>>()
            .join(" and "),
        fit.band.0,
        fit.band.1
    );
    for n in &fit.notes {
        let _ = writeln!(s, "- {n}.");
    }
    s.push_str(
        "\n| mode | f [Hz] | ζ | g = k_a k_s Δφ'² [V/V·s⁻²] | c = k_s Δφ' w [V·s²/rad·s⁻²] | coherence | stable over | controller |\n|---|---|---|---|---|---|---|---|\n",
    );
    let digits = |x: f64, s: f64| {
        // As many decimals as the spread asks, two significant digits of it.
        let d = if s.is_finite() && s > 0.0 {
            (1.0 - s.log10().floor()).max(0.0) as usize
        } else {
            4
        };
        plus_minus(x, s, d.min(6))
    };
    for (j, m) in fit.all.iter().enumerate() {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} orders | {} |",
            j + 1,
            digits(m.hz(), m.sigma[0] / tau),
            digits(m.zeta, m.sigma[1]),
            digits(m.piezo_film, m.sigma[2]),
            digits(m.base_film, m.sigma[3]),
            m.coherence.map_or("—".into(), |c| format!("{c:.3}")),
            m.stable,
            match fit.kept.iter().position(|k| *k == j + 1) {
                Some(i) => format!("mode {}", i + 1),
                None => "left out".into(),
            }
        );
    }
    let kept: Vec<String> = fit.kept.iter().map(|k| k.to_string()).collect();
    let out: Vec<String> = (1..=fit.all.len())
        .filter(|k| !fit.kept.contains(k))
        .map(|k| {
            let above = fit.kept.iter().all(|q| *q < k);
            format!(
                "{k} ({:.3} Hz: {})",
                fit.all[k - 1].hz(),
                if above {
                    "above the controller's modes"
                } else {
                    "not among the modes asked"
                }
            )
        })
        .collect();
    let _ = writeln!(
        s,
        "\nThe controller keeps mode(s) {}{}. Left out: {}.",
        kept.join(" and "),
        if fit.kept == [1, 2] {
            " (the lowest two: the default)"
        } else {
            " (asked with --keep)"
        },
        if out.is_empty() {
            "none".to_string()
        } else {
            out.join("; ")
        }
    );
    if fit.held.is_some() {
        s.push_str(
            "These are the held arm's modes (the base is not an input): its first mode can lie several per cent from the clamped link's the controller needs.\n",
        );
    }
    if let Some(f) = fit.highpass_hz {
        let _ = writeln!(
            s,
            "The fit also finds a real pole at {f:.2} Hz (the film amplifier's high-pass)."
        );
    }
    if let Some((a, p)) = truth {
        s.push_str(
            "\n| controller mode | true f | true ζ | true g | error f | error ζ | error g |\n|---|---|---|---|---|---|---|\n",
        );
        for (j, m) in fit.modes.iter().enumerate().take(2) {
            let t = (
                a.modes.omega[j] / tau,
                a.modes.zeta[j],
                p.k_a * p.k_s * p.slope_diff[j].powi(2),
            );
            let _ = writeln!(
                s,
                "| {} | {:.4} | {:.4} | {:.4} | {} | {} | {} |",
                j + 1,
                t.0,
                t.1,
                t.2,
                pct(m.hz(), Some(t.0)),
                pct(m.zeta, Some(t.1)),
                pct(m.piezo_film, Some(t.2)),
            );
        }
    }
    s
}

/// The measured and fitted responses: `f_Hz, coherence`, then per input (`piezo`: V_f/V_a,
/// `base`: V_f/α) the measured and fitted real and imaginary parts (measured: `NaN` where
/// the record gives no nonparametric estimate; coherence empty where not meaningful).
pub fn frf_csv(fit: &ModesFit) -> String {
    let mut s = String::from("f_Hz,coherence");
    for i in &fit.inputs {
        let p = match i {
            Input::Patch => "piezo",
            Input::Base => "base",
        };
        let _ = write!(s, ",{p}_re,{p}_im,{p}_fit_re,{p}_fit_im");
    }
    s.push('\n');
    let sp = &fit.spectra;
    for (k, f) in sp.freq.iter().enumerate() {
        let c = sp
            .coherence
            .as_ref()
            .map_or(String::new(), |c| format!("{:.4}", c[k]));
        let _ = write!(s, "{f:.5},{c}");
        for i in 0..fit.inputs.len() {
            let (h, g) = (sp.h[k][i], fit.fit.eval(i, *f));
            let _ = write!(s, ",{:.6e},{:.6e},{:.6e},{:.6e}", h.re, h.im, g.re, g.im);
        }
        s.push('\n');
    }
    s
}

/// The stabilization diagram: `k` (room for modes), `f_Hz`, `zeta`, `stable_orders`.
pub fn stability_csv(fit: &ModesFit) -> String {
    let mut s = String::from("k,f_Hz,zeta,stable_orders\n");
    for p in &fit.diagram {
        let _ = writeln!(s, "{},{:.5},{:.5},{}", p.k, p.hz, p.zeta, p.run);
    }
    s
}

/// The responses' magnitudes, measured (dots, where the record gives them) and fitted (line),
/// one panel per input.
pub fn frf_figure(
    path: &std::path::Path,
    fit: &ModesFit,
) -> Result<(), Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    let root = SVGBackend::new(path, (900, 420)).into_drawing_area();
    root.fill(&WHITE)?;
    let panels = root.split_evenly((1, fit.inputs.len().max(1)));
    let sp = &fit.spectra;
    let (f0, f1) = (
        sp.freq.first().copied().unwrap_or(1.0),
        sp.freq.last().copied().unwrap_or(2.0),
    );
    for (i, area) in panels.iter().enumerate().take(fit.inputs.len()) {
        let name = match fit.inputs[i] {
            Input::Patch => "V_f / V_a [V/V]",
            Input::Base => "V_f / base angle [V/rad]",
        };
        let measured: Vec<(f64, f64)> = sp
            .freq
            .iter()
            .zip(&sp.h)
            .filter(|(_, h)| h[i].norm().is_finite())
            .map(|(f, h)| (*f, h[i].norm().max(1e-12)))
            .collect();
        let fitted: Vec<(f64, f64)> = sp
            .freq
            .iter()
            .map(|f| (*f, fit.fit.eval(i, *f).norm().max(1e-12)))
            .collect();
        let hi = measured
            .iter()
            .chain(&fitted)
            .map(|p| p.1)
            .fold(1e-12, f64::max)
            * 2.0;
        let lo = measured
            .iter()
            .chain(&fitted)
            .map(|p| p.1)
            .fold(f64::INFINITY, f64::min)
            / 2.0;
        let mut chart = ChartBuilder::on(area)
            .caption(name, ("sans-serif", 16))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d((f0..f1).log_scale(), (lo..hi).log_scale())?;
        chart
            .configure_mesh()
            .x_desc("frequency [Hz]")
            .y_desc("magnitude")
            .draw()?;
        chart.draw_series(measured.iter().map(|p| Circle::new(*p, 2, BLUE.filled())))?;
        chart.draw_series(LineSeries::new(fitted, RED.stroke_width(2)))?;
    }
    root.present()?;
    Ok(())
}

/// The rigid combinations' table, against `truth` when known.
pub fn inertia_report(fit: &InertiaFit, truth: Option<Rigid>) -> String {
    let mut s = String::from(
        "| combination | identified [kg·m²] | truth [kg·m²] | error |\n|---|---|---|---|\n",
    );
    for (name, x, t) in [
        (
            "A = I_h1 + I_1 + m1 a1²/4 + (m_h2 + m2) a1²",
            fit.rigid.a,
            truth.map(|t| t.a),
        ),
        (
            "J = I_h2 + I_2x + m2 a2²/3",
            fit.rigid.j,
            truth.map(|t| t.j),
        ),
        ("S = a1 m2 a2 / 2", fit.rigid.s, truth.map(|t| t.s)),
    ] {
        let _ = writeln!(
            s,
            "| {name} | {x:.5} | {} | {} |",
            t.map_or("—".into(), |t| format!("{t:.5}")),
            pct(x, t)
        );
    }
    let _ = writeln!(
        s,
        "\nTorque residual {:.3} N·m RMS of {:.3} N·m. The same fit's friction, (F_c, F_v) per joint: ({:.3}, {:.3}) and ({:.3}, {:.3}) N·m, N·m·s/rad; the friction experiment measures it better.",
        fit.residual,
        fit.torque_rms,
        fit.friction[0].0,
        fit.friction[0].1,
        fit.friction[1].0,
        fit.friction[1].1
    );
    s
}

/// The closed-loop check's table: Eq. 37 of the joint error and of the tip deflection, each
/// against the first row's (the true parameters).
pub fn loop_report(runs: &[LoopRun]) -> String {
    let mut s = String::from(
        "| controller built from | Eq. 37 ‖θ − θ_d‖ [rad] | vs true | Eq. 37 ‖tip‖ [m] | vs true | max tip [m] |\n|---|---|---|---|---|---|\n",
    );
    let first = runs.first().map(|r| r.summary);
    for r in runs {
        let m = &r.summary;
        let _ = writeln!(
            s,
            "| {} | {:.4e} | {} | {:.4e} | {} | {:.3e} |",
            r.name,
            m.l2_error,
            pct(m.l2_error, first.map(|f| f.l2_error)),
            m.l2_tip,
            pct(m.l2_tip, first.map(|f| f.l2_tip)),
            m.max_tip
        );
    }
    s
}

/// The held arm's decay: every measured mode, ascending, with its amplitude, and each model's
/// prediction of each (its nearest mode) against them, then the modes a prediction rings at
/// besides (at least a tenth of its largest amplitude).
pub fn decay_report(measured: &DecayFit, predictions: &[(&str, DecayFit)]) -> String {
    let tau = std::f64::consts::TAU;
    let seen = &measured.modes;
    let row = |cells: Vec<String>| format!("| {} |\n", cells.join(" | "));
    let mut head = vec![String::new()];
    for j in 1..=seen.len() {
        head.push(format!("f{j} [Hz]"));
        head.push(format!("ζ{j}"));
    }
    head.push("also rings at".into());
    let mut s = row(head);
    s += &format!("{}|\n", "|---".repeat(2 + 2 * seen.len()));
    let mut cells = vec!["measured".to_string()];
    for m in seen {
        cells.push(format!("{:.4}", m.omega / tau));
        cells.push(format!("{:.4}", m.zeta));
    }
    cells.push("—".into());
    s += &row(cells);
    let mut cells = vec!["amplitude [V]".to_string()];
    for m in seen {
        cells.push(format!("{:.3e}", m.amplitude));
        cells.push(String::new());
    }
    cells.push(String::new());
    s += &row(cells);
    for (name, p) in predictions {
        let mut cells = vec![name.to_string()];
        let mut matched = Vec::new();
        for m in seen {
            match p.nearest(m.omega) {
                Some(q) => {
                    matched.push(q.omega);
                    cells.push(format!(
                        "{:.4} ({})",
                        q.omega / tau,
                        pct(q.omega, Some(m.omega))
                    ));
                    cells.push(format!("{:.4} ({})", q.zeta, pct(q.zeta, Some(m.zeta))));
                }
                None => cells.extend(["—".to_string(), "—".to_string()]),
            }
        }
        let largest = p.modes.iter().map(|m| m.amplitude).fold(0.0, f64::max);
        let others: Vec<String> = p
            .modes
            .iter()
            .filter(|m| !matched.contains(&m.omega) && m.amplitude >= 0.1 * largest)
            .map(|m| format!("{:.2} Hz (ζ {:.3})", m.omega / tau, m.zeta))
            .collect();
        cells.push(if others.is_empty() {
            "—".into()
        } else {
            others.join(", ")
        });
        s += &row(cells);
    }
    s
}

/// The averaged decay and the pencil's reconstruction: `t_s, decay_V, fitted_V`.
pub fn decay_csv(fit: &DecayFit) -> String {
    let mut s = String::from("t_s,decay_V,fitted_V\n");
    for (k, (y, f)) in fit.decay.iter().zip(&fit.fitted).enumerate() {
        let _ = writeln!(s, "{:.5},{y:.6e},{f:.6e}", k as f64 * fit.dt);
    }
    s
}

/// The averaged decay (dots) and the pencil's reconstruction (line) against time.
pub fn decay_figure(
    path: &std::path::Path,
    fit: &DecayFit,
) -> Result<(), Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    let root = SVGBackend::new(path, (900, 420)).into_drawing_area();
    root.fill(&WHITE)?;
    let t_end = fit.decay.len() as f64 * fit.dt;
    let peak = fit
        .decay
        .iter()
        .chain(&fit.fitted)
        .map(|v| v.abs())
        .fold(1e-12, f64::max)
        * 1.1;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!("the film's decay, {} taps averaged", fit.taps),
            ("sans-serif", 16),
        )
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..t_end, -peak..peak)?;
    chart
        .configure_mesh()
        .x_desc("time after the tap [s]")
        .y_desc("V_f [V]")
        .draw()?;
    chart.draw_series(
        fit.decay
            .iter()
            .enumerate()
            .map(|(k, y)| Circle::new((k as f64 * fit.dt, *y), 1, BLUE.filled())),
    )?;
    chart.draw_series(LineSeries::new(
        fit.fitted
            .iter()
            .enumerate()
            .map(|(k, y)| (k as f64 * fit.dt, *y)),
        RED.stroke_width(1),
    ))?;
    root.present()?;
    Ok(())
}

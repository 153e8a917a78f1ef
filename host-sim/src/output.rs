//! Outputs of a study: a CSV of every signal per run, SVG figures, a Markdown table of the
//! indices. Figures are SVG drawn by plotters' pure-Rust SVG backend (no system fonts needed).

use std::fmt::Write as _;
use std::fs;
use std::path::Path;

use plotters::prelude::*;

use crate::study::{Outcome, label};

/// Writes `<scenario>_<controller>.csv`: one row per motor period.
pub fn write_csv(dir: &Path, o: &Outcome) -> std::io::Result<()> {
    let mut s = String::from(
        "t_s,theta1_rad,theta2_rad,theta1_d_rad,theta2_d_rad,delta1,delta2,delta1_dot,delta2_dot,delta1_seen,delta2_seen,tip_m,tau1_Nm,tau2_Nm,v_a_V,v_f_V\n",
    );
    for p in &o.trace {
        let q = &p.x.q;
        let _ = writeln!(
            s,
            "{:.5},{:.7e},{:.7e},{:.7e},{:.7e},{:.7e},{:.7e},{:.7e},{:.7e},{:.7e},{:.7e},{:.7e},{:.7e},{:.7e},{:.7e},{:.7e}",
            p.t,
            q.x,
            q.y,
            p.q_d.x,
            p.q_d.y,
            q.z,
            q.w,
            p.x.qd.z,
            p.x.qd.w,
            p.delta_seen.x,
            p.delta_seen.y,
            p.tip,
            p.tau.x,
            p.tau.y,
            p.v_a,
            p.v_f
        );
    }
    fs::write(
        dir.join(format!("{}_{}.csv", o.case.scenario, o.case.controller)),
        s,
    )
}

type Series = (&'static str, Vec<(f64, f64)>);

/// Points drawn per curve at most: a long run's figure stays a few hundred kilobytes (the CSV
/// keeps every sample).
const MAX_DRAWN: usize = 2000;

/// The curve to draw: every point of a short series; of a long one, the first and the extreme
/// points of each of `MAX_DRAWN / 2` buckets, so that no peak is lost.
fn decimate(pts: &[(f64, f64)]) -> Vec<(f64, f64)> {
    if pts.len() <= MAX_DRAWN {
        return pts.to_vec();
    }
    let per = pts.len().div_ceil(MAX_DRAWN / 2);
    let mut out = Vec::with_capacity(MAX_DRAWN + 2);
    for chunk in pts.chunks(per) {
        let lo = chunk
            .iter()
            .copied()
            .fold(chunk[0], |a, p| if p.1 < a.1 { p } else { a });
        let hi = chunk
            .iter()
            .copied()
            .fold(chunk[0], |a, p| if p.1 > a.1 { p } else { a });
        if lo.0 <= hi.0 {
            out.extend([lo, hi]);
        } else {
            out.extend([hi, lo]);
        }
    }
    out
}

fn panel(
    area: &DrawingArea<SVGBackend, plotters::coord::Shift>,
    title: &str,
    unit: &str,
    series: &[Series],
) -> Result<(), Box<dyn std::error::Error>> {
    let t_max = series
        .iter()
        .flat_map(|s| s.1.iter().map(|p| p.0))
        .fold(0.0, f64::max);
    let (lo, hi) = series
        .iter()
        .flat_map(|s| s.1.iter().map(|p| p.1))
        .fold((0.0f64, 0.0f64), |(a, b), y| (a.min(y), b.max(y)));
    let pad = ((hi - lo) * 0.05).max(1e-12);
    // Headroom above the data for the legend, so that it never covers a curve.
    let legend_room = (hi - lo).max(1e-12) * 0.12 * series.len() as f64;
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 16))
        .margin(8)
        .x_label_area_size(30)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..t_max.max(1e-9), (lo - pad)..(hi + pad + legend_room))?;
    chart
        .configure_mesh()
        .x_desc("t [s]")
        .y_desc(unit)
        .label_style(("sans-serif", 11))
        .draw()?;
    let colours = [BLUE, RED, GREEN, MAGENTA];
    for (i, (name, pts)) in series.iter().enumerate() {
        let c = colours[i % colours.len()];
        chart
            .draw_series(LineSeries::new(decimate(pts), c.stroke_width(1)))?
            .label(*name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], c));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .label_font(("sans-serif", 11))
        .draw()?;
    Ok(())
}

/// Writes `<scenario>_<controller>.svg`: joint errors, modal coordinates, tip deflection,
/// piezo voltage and motor torques of one run (the paper's Figs. 8–10, 15, 19–24).
pub fn write_figure(dir: &Path, o: &Outcome) -> Result<(), Box<dyn std::error::Error>> {
    let path = dir.join(format!("{}_{}.svg", o.case.scenario, o.case.controller));
    let root = SVGBackend::new(&path, (1000, 1650)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(
        &format!("{}: {}", o.case.scenario, label(o.case.controller)),
        ("sans-serif", 22),
    )?;
    let panels = root.split_evenly((6, 1));
    let tr = &o.trace;
    let s =
        |f: &dyn Fn(&crate::sim::Sample) -> f64| tr.iter().map(|p| (p.t, f(p))).collect::<Vec<_>>();
    panel(
        &panels[0],
        "Joint tracking error",
        "rad",
        &[
            ("θ1 − θ1d", s(&|p| p.x.q.x - p.q_d.x)),
            ("θ2 − θ2d", s(&|p| p.x.q.y - p.q_d.y)),
        ],
    )?;
    // Each mode on its own axis: δ2 is an order of magnitude below δ1.
    panel(&panels[1], "Mode 1", "√kg·m", &[("δ1", s(&|p| p.x.q.z))])?;
    panel(&panels[2], "Mode 2", "√kg·m", &[("δ2", s(&|p| p.x.q.w))])?;
    panel(
        &panels[3],
        "Tip deflection",
        "m",
        &[("w(a2)", s(&|p| p.tip))],
    )?;
    panel(
        &panels[4],
        "Piezo actuator voltage",
        "V",
        &[("V_a", s(&|p| p.v_a))],
    )?;
    panel(
        &panels[5],
        "Motor torques",
        "N·m",
        &[("τ1", s(&|p| p.tau.x)), ("τ2", s(&|p| p.tau.y))],
    )?;
    root.present()?;
    Ok(())
}

/// The Markdown table of the indices of every run.
pub fn indices_table(outcomes: &[Outcome]) -> String {
    let mut s = String::from(
        "| scenario | controller | Eq. 37 δ [√kg·m] | Eq. 37 θ̃ [rad] | Eq. 37 tip [m] | Eq. 38 θ̃1, θ̃2 [rad] | Eq. 38 mean \\|θ̃\\| [rad] | Eq. 38 mean \\|δ\\| [√kg·m] | max \\|tip\\| [m] | max \\|τ\\| [N·m] | max \\|V_a\\| [V] |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for o in outcomes {
        let m = &o.summary;
        let _ = writeln!(
            s,
            "| {} | {} | {:.3e} | {:.3e} | {:.3e} | {:.2e}, {:.2e} | {:.2e}, {:.2e} | {:.2e}, {:.2e} | {:.3e} | {:.2}, {:.2} | {:.1} |",
            o.case.scenario,
            label(o.case.controller),
            m.l2_delta,
            m.l2_error,
            m.l2_tip,
            m.tail_error[0],
            m.tail_error[1],
            m.tail_error_abs[0],
            m.tail_error_abs[1],
            m.tail_delta_abs[0],
            m.tail_delta_abs[1],
            m.max_tip,
            m.max_tau[0],
            m.max_tau[1],
            m.max_v_a
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_bounds_the_points_and_keeps_the_peaks() {
        let n = 1_000_000;
        let pts: Vec<(f64, f64)> = (0..n)
            .map(|i| {
                let t = i as f64 * 1e-4;
                (t, (t * 37.0).sin() + if i == 777_777 { 5.0 } else { 0.0 })
            })
            .collect();
        let d = decimate(&pts);
        assert!(d.len() <= MAX_DRAWN + 2, "{}", d.len());
        assert!(d.iter().any(|p| p.1 > 5.0), "the spike survives");
        let min = pts.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
        assert!(d.iter().any(|p| p.1 == min), "the minimum survives");
        assert!(d.windows(2).all(|w| w[0].0 <= w[1].0), "time stays ordered");
        let short = &pts[..100];
        assert_eq!(decimate(short), short.to_vec());
    }
}

//! Outputs of a study: a CSV of every signal per run, SVG figures, a Markdown table of the
//! indices. Figures are SVG drawn by plotters' pure-Rust SVG backend (no system fonts needed).

use std::fmt::Write as _;
use std::fs;
use std::path::Path;

use plotters::prelude::*;

use crate::study::{Outcome, label};

/// The header of a trace's CSV ([`write_csv`], [`read_csv`]).
pub const CSV_HEADER: &str = "t_s,theta1_rad,theta2_rad,theta1_d_rad,theta2_d_rad,delta1,delta2,delta1_dot,delta2_dot,delta1_seen,delta2_seen,tip_m,tau1_Nm,tau2_Nm,v_a_V,v_f_V";

/// Most samples a trace read back holds: as many as a run keeps
/// ([`crate::sim::MAX_RECORDED_SAMPLES`], about 150 MB in memory).
pub const MAX_TRACE_SAMPLES: usize = crate::sim::MAX_RECORDED_SAMPLES as usize;
/// Largest trace file read [bytes]: 300 bytes a sample of [`MAX_TRACE_SAMPLES`] (a row as
/// [`trace_csv`] writes it is about 235 bytes). A larger file is refused before it is read.
pub const MAX_TRACE_BYTES: u64 = 300 * MAX_TRACE_SAMPLES as u64;
/// Longest line of a trace [bytes]: sixteen numbers with room to spare.
const MAX_TRACE_LINE: usize = 4096;

/// Reads a trace written by [`write_csv`] (a run of the simulator or a recording of the
/// firmware, `flexarm record`); an error names the file, the line and the column. `NaN` stands
/// for a value the source did not have (a recording has no modal rates). A byte-order mark
/// before the header is skipped. The file is read line by line, never whole: one larger than
/// [`MAX_TRACE_BYTES`], with more than [`MAX_TRACE_SAMPLES`] samples or a line longer than
/// 4096 bytes is refused with its size.
pub fn read_csv(path: &Path) -> Result<Vec<crate::sim::Sample>, String> {
    read_csv_within(path, MAX_TRACE_BYTES, MAX_TRACE_SAMPLES)
}

/// [`read_csv`] with the bounds `max_bytes` and `max_samples`.
fn read_csv_within(
    path: &Path,
    max_bytes: u64,
    max_samples: usize,
) -> Result<Vec<crate::sim::Sample>, String> {
    use crate::sim::Sample;
    use flexarm_core::plant::State;
    use nalgebra::{Vector2, Vector4};
    use std::io::{BufRead, Read};
    let shown = path.display();
    let file = fs::File::open(path).map_err(|e| format!("{shown}: {e}"))?;
    let bytes = file.metadata().map_err(|e| format!("{shown}: {e}"))?.len();
    let mb = |b: u64| b as f64 / 1e6;
    if bytes > max_bytes {
        return Err(format!(
            "{shown}: {:.1} MB: a trace is read up to {:.0} MB ({max_samples} samples)",
            mb(bytes),
            mb(max_bytes)
        ));
    }
    let header = |first: &str| match first.trim_start_matches('\u{feff}').trim() == CSV_HEADER {
        true => Ok(()),
        false => Err(format!(
            "{shown}:1: not a flexarm trace (the header must be {CSV_HEADER})"
        )),
    };
    let mut reader = std::io::BufReader::new(file);
    let mut line = String::new();
    let mut n = 0;
    let mut trace: Vec<Sample> = Vec::new();
    loop {
        line.clear();
        n += 1;
        let read = reader
            .by_ref()
            .take(MAX_TRACE_LINE as u64 + 1)
            .read_line(&mut line)
            .map_err(|e| format!("{shown}:{n}: {e}"))?;
        if read == 0 {
            break;
        }
        if read > MAX_TRACE_LINE && !line.ends_with('\n') {
            return Err(format!(
                "{shown}:{n}: a line longer than {MAX_TRACE_LINE} bytes: not a flexarm trace"
            ));
        }
        if n == 1 {
            header(&line)?;
            continue;
        }
        if line.trim().is_empty() {
            continue;
        }
        if trace.len() == max_samples {
            return Err(format!(
                "{shown}:{n}: more than {max_samples} samples ({:.0} MB file): a trace holds at most {max_samples}, as a run does",
                mb(bytes)
            ));
        }
        let mut v = [0.0f64; 16];
        let fields: Vec<&str> = line.trim_end_matches(['\n', '\r']).split(',').collect();
        if fields.len() != v.len() {
            return Err(format!(
                "{shown}:{n}: {} values, the header names {}",
                fields.len(),
                v.len()
            ));
        }
        for (k, (slot, f)) in v.iter_mut().zip(&fields).enumerate() {
            let name = CSV_HEADER.split(',').nth(k).unwrap_or("?");
            *slot = f
                .trim()
                .parse()
                .map_err(|_| format!("{shown}:{n}: {name} = {f:?} is not a number"))?;
            if k != 7 && k != 8 && !slot.is_finite() {
                return Err(format!("{shown}:{n}: {name} = {f} is not finite"));
            }
        }
        if let Some(prev) = trace.last().map(|p: &Sample| p.t)
            && v[0] <= prev
        {
            return Err(format!("{shown}:{n}: t_s = {} does not increase", v[0]));
        }
        trace.push(Sample {
            t: v[0],
            x: State {
                q: Vector4::new(v[1], v[2], v[5], v[6]),
                qd: Vector4::new(f64::NAN, f64::NAN, v[7], v[8]),
            },
            q_d: Vector2::new(v[3], v[4]),
            delta_seen: Vector2::new(v[9], v[10]),
            tip: v[11],
            tau: Vector2::new(v[12], v[13]),
            v_a: v[14],
            v_f: v[15],
        });
    }
    if n == 1 {
        header("")?;
    }
    if trace.len() < 2 {
        return Err(format!("{shown}: fewer than two samples"));
    }
    Ok(trace)
}

/// Writes `<scenario>_<controller>.csv`: one row per motor period.
pub fn write_csv(dir: &Path, o: &Outcome) -> std::io::Result<()> {
    let path = dir.join(format!("{}_{}.csv", o.case.scenario, o.case.controller));
    // Row by row: the text of a long trace is never held whole beside the trace.
    let mut w = std::io::BufWriter::new(fs::File::create(path)?);
    write_trace(&mut w, &o.trace)?;
    std::io::Write::flush(&mut w)
}

/// A trace as the CSV [`read_csv`] reads ([`CSV_HEADER`]).
pub fn trace_csv(trace: &[crate::sim::Sample]) -> String {
    let mut out = Vec::new();
    // Writing into memory does not fail.
    let _ = write_trace(&mut out, trace);
    String::from_utf8(out).unwrap_or_default()
}

/// Writes the header and one row per sample of `trace` to `w`.
fn write_trace(w: &mut impl std::io::Write, trace: &[crate::sim::Sample]) -> std::io::Result<()> {
    writeln!(w, "{CSV_HEADER}")?;
    for p in trace {
        let q = &p.x.q;
        writeln!(
            w,
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
        )?;
    }
    Ok(())
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
    // A value the source did not have (`NaN`: the fault recorder has no V_a) is not drawn.
    let series: Vec<Series> = series
        .iter()
        .map(|(n, pts)| {
            (
                *n,
                pts.iter().copied().filter(|p| p.1.is_finite()).collect(),
            )
        })
        .collect();
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

/// Writes `path`: two traces of the same move on the same axes (joint errors, mode 1, tip,
/// `V_a`, torque), one colour per trace.
pub fn write_comparison(
    path: &Path,
    title: &str,
    a: (&'static str, &[crate::sim::Sample]),
    b: (&'static str, &[crate::sim::Sample]),
) -> Result<(), Box<dyn std::error::Error>> {
    use crate::sim::Sample;
    let root = SVGBackend::new(path, (1000, 1650)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(title, ("sans-serif", 22))?;
    let panels = root.split_evenly((6, 1));
    let s = |tr: &[Sample], f: &dyn Fn(&Sample) -> f64| {
        tr.iter().map(|p| (p.t, f(p))).collect::<Vec<_>>()
    };
    let both = |f: &dyn Fn(&Sample) -> f64| -> [Series; 2] { [(a.0, s(a.1, f)), (b.0, s(b.1, f))] };
    panel(
        &panels[0],
        "Joint 1 tracking error θ1 − θ1d",
        "rad",
        &both(&|p| p.x.q.x - p.q_d.x),
    )?;
    panel(
        &panels[1],
        "Joint 2 tracking error θ2 − θ2d",
        "rad",
        &both(&|p| p.x.q.y - p.q_d.y),
    )?;
    panel(&panels[2], "Mode 1 δ1", "√kg·m", &both(&|p| p.x.q.z))?;
    panel(&panels[3], "Tip deflection", "m", &both(&|p| p.tip))?;
    panel(
        &panels[4],
        "Piezo actuator voltage V_a",
        "V",
        &both(&|p| p.v_a),
    )?;
    panel(&panels[5], "Motor torque τ1", "N·m", &both(&|p| p.tau.x))?;
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

    fn scratch(name: &str, text: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("flexarm-output-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        fs::write(&p, text).unwrap();
        p
    }

    /// `n` rows of a valid trace.
    fn rows(n: usize) -> String {
        let zeros = ",0".repeat(15);
        (0..n).map(|i| format!("{i}{zeros}\n")).collect()
    }

    #[test]
    fn a_trace_is_read_line_by_line_within_its_bounds() {
        // A byte-order mark before the header (a spreadsheet's export) is skipped.
        let p = scratch("bom.csv", &format!("\u{feff}{CSV_HEADER}\n{}", rows(3)));
        assert_eq!(read_csv(&p).map(|t| t.len()), Ok(3));
        // One sample more than the bound: refused at that line, with the bound.
        let p = scratch("long.csv", &format!("{CSV_HEADER}\n{}", rows(11)));
        assert_eq!(read_csv_within(&p, u64::MAX, 11).map(|t| t.len()), Ok(11));
        let e = read_csv_within(&p, u64::MAX, 10).unwrap_err();
        assert!(e.contains("long.csv:12: more than 10 samples"), "{e}");
        // A file larger than the bound is refused before it is read.
        let size = fs::metadata(&p).unwrap().len();
        let e = read_csv_within(&p, size - 1, 100).unwrap_err();
        assert!(e.contains("a trace is read up to"), "{e}");
        // A line without an end is not read whole.
        let p = scratch(
            "line.csv",
            &format!("{CSV_HEADER}\n{}", "1".repeat(100_000)),
        );
        let e = read_csv(&p).unwrap_err();
        assert!(
            e.contains("line.csv:2: a line longer than 4096 bytes"),
            "{e}"
        );
        let p = scratch("empty.csv", "");
        assert!(read_csv(&p).unwrap_err().contains("not a flexarm trace"));
    }
}

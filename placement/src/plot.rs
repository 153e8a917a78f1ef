//! SVG figures (plotters, pure Rust; the text is left to the SVG viewer's fonts).

use crate::optimize::Sweep;
use flexarm_beam::design::{DesignModel, Weights};
use flexarm_beam::point::Optimum;
use plotters::prelude::*;
use std::error::Error;
use std::path::Path;

type R = Result<(), Box<dyn Error>>;
/// A named curve with its style.
type Curve<S> = (String, Vec<(f64, f64)>, S);

/// A viridis-like colour map on `t ∈ [0, 1]`.
fn colour(t: f64) -> RGBColor {
    const STOPS: [(f64, f64, f64); 5] = [
        (68.0, 1.0, 84.0),
        (59.0, 82.0, 139.0),
        (33.0, 145.0, 140.0),
        (94.0, 201.0, 98.0),
        (253.0, 231.0, 37.0),
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = t * 4.0;
    let i = (x.floor() as usize).min(3);
    let f = x - i as f64;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    let lerp = |p: f64, q: f64| (p + (q - p) * f).round() as u8;
    RGBColor(lerp(a.0, b.0), lerp(a.1, b.1), lerp(a.2, b.2))
}

/// Heat map of one value per grid patch over `(x_a, l_a)`, with the optimum (cross) and the
/// paper's point (circle).
#[allow(clippy::too_many_arguments)]
pub fn heat_map(
    path: &Path,
    sweep: &Sweep,
    values: &[f64],
    title: &str,
    bar_label: &str,
    step: f64,
    length: f64,
    opt: &Optimum,
) -> R {
    let (lo, hi) = values
        .iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
            (l.min(*v), h.max(*v))
        });
    let span = if hi > lo { hi - lo } else { 1.0 };
    let root = SVGBackend::new(path, (900, 720)).into_drawing_area();
    root.fill(&WHITE)?;
    let (left, right) = root.split_horizontally(750);
    let h2 = step / 2.0;
    let mut chart = ChartBuilder::on(&left)
        .caption(title, ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(-h2..length + h2, 0.0..length + h2)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc("x_a [m]")
        .y_desc("l_a [m]")
        .draw()?;
    chart.draw_series(sweep.points.iter().zip(values).map(|(p, v)| {
        Rectangle::new(
            [(p.x_a - h2, p.l_a - h2), (p.x_a + h2, p.l_a + h2)],
            colour((v - lo) / span).filled(),
        )
    }))?;
    chart
        .draw_series(std::iter::once(Cross::new(
            (opt.x_a, opt.l_a),
            9,
            RED.stroke_width(3),
        )))?
        .label(format!(
            "optimum x_a = {:.3}, l_a = {:.3}, k_c = {:.1} s",
            opt.x_a, opt.l_a, opt.k_c
        ))
        .legend(|(x, y)| Cross::new((x, y), 6, RED.stroke_width(3)));
    chart
        .draw_series(std::iter::once(Circle::new(
            (0.09, 0.35),
            8,
            WHITE.stroke_width(3),
        )))?
        .label("paper x_a = 0.09, l_a = 0.35")
        .legend(|(x, y)| Circle::new((x, y), 6, BLACK.stroke_width(2)));
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()?;
    // Colour bar.
    let mut bar = ChartBuilder::on(&right)
        .margin_top(45)
        .margin_bottom(57)
        .margin_right(10)
        .y_label_area_size(95)
        .build_cartesian_2d(0.0..1.0, lo..lo + span)?;
    bar.configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_desc(bar_label)
        .axis_desc_style(("sans-serif", 16))
        .y_label_style(("sans-serif", 13))
        // Trailing spaces: the SVG text is laid out from an estimated width, and real fonts are
        // wider, so the label would run under the bar.
        .y_label_formatter(&|v| {
            if v.abs() >= 1e4 || (v.abs() < 1e-2 && *v != 0.0) {
                format!("{v:.1e}   ")
            } else {
                format!("{v:.3}   ")
            }
        })
        .draw()?;
    let n = 100;
    bar.draw_series((0..n).map(|i| {
        let (a, b) = (i as f64 / n as f64, (i + 1) as f64 / n as f64);
        Rectangle::new(
            [(0.0, lo + a * span), (1.0, lo + b * span)],
            colour((a + b) / 2.0).filled(),
        )
    }))?;
    root.present()?;
    Ok(())
}

/// `J0(k_c)` and `J(k_c)` at the optimum patch and at the paper's patch (Figs. 13–14).
pub fn gain_curves(
    path: &Path,
    model: &DesignModel,
    w: &Weights,
    opt: &Optimum,
    k_range: (f64, f64),
) -> R {
    let gains: Vec<f64> = (0..=200)
        .map(|i| k_range.0 * (k_range.1 / k_range.0).powf(i as f64 / 200.0))
        .collect();
    let paper = model.patch_modes(0.09, 0.35).ok();
    let mut series: Vec<Curve<RGBColor>> = Vec::new();
    for (name, pm, col) in [
        ("optimum patch", Some(&opt.modes), BLUE),
        ("paper patch (0.09, 0.35)", paper.as_ref(), RED),
    ] {
        let Some(pm) = pm else { continue };
        let e: Vec<(f64, f64, f64)> = gains
            .iter()
            .filter_map(|&k| {
                model
                    .energy(pm, k)
                    .map(|e| (k, e.j0, w.objective(pm.l_a, k, &e)))
            })
            .collect();
        series.push((
            format!("−J0, {name}"),
            e.iter().map(|t| (t.0, -t.1)).collect(),
            col,
        ));
        series.push((
            format!("J, {name}"),
            e.iter().map(|t| (t.0, t.2)).collect(),
            RGBColor(col.0 / 2, col.1 / 2 + 100, col.2 / 2),
        ));
    }
    let (lo, hi) = series
        .iter()
        .flat_map(|s| s.1.iter())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| {
            (l.min(p.1), h.max(p.1))
        });
    let pad = (hi - lo).abs().max(1e-12) * 0.05;
    let root = SVGBackend::new(path, (900, 600)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption("Objective against the gain k_c", ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(80)
        .build_cartesian_2d((k_range.0..k_range.1).log_scale(), lo - pad..hi + pad)?;
    chart
        .configure_mesh()
        .x_desc("k_c [s]")
        .y_desc("J, −J0")
        .y_label_formatter(&|v| format!("{v:.2e}"))
        .draw()?;
    for (name, pts, col) in series {
        chart
            .draw_series(LineSeries::new(pts, col.stroke_width(2)))?
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], col));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}

/// Mode shapes of the optimum design against the bare beam's, patch shaded.
pub fn mode_shapes(path: &Path, model: &DesignModel, opt: &Optimum) -> R {
    let bare = DesignModel {
        patch_structure: false,
        ..model.clone()
    }
    .patch_modes(opt.x_a, opt.l_a)
    .ok();
    let n = 200;
    let xs: Vec<f64> = (0..=n)
        .map(|i| model.length * i as f64 / n as f64)
        .collect();
    let mut series: Vec<Curve<ShapeStyle>> = Vec::new();
    let cols = [BLUE, RED, GREEN, MAGENTA];
    for (j, m) in opt.modes.modes.iter().enumerate() {
        let c = cols[j % 4];
        series.push((
            format!(
                "mode {} with patch, {:.3} Hz",
                j + 1,
                m.omega / std::f64::consts::TAU
            ),
            xs.iter().map(|&x| (x, m.phi(x))).collect(),
            c.stroke_width(2),
        ));
    }
    if let Some(b) = &bare {
        for (j, m) in b.modes.iter().enumerate() {
            let c = cols[j % 4];
            series.push((
                format!(
                    "mode {} bare, {:.3} Hz",
                    j + 1,
                    m.omega / std::f64::consts::TAU
                ),
                xs.iter().map(|&x| (x, m.phi(x))).collect(),
                c.mix(0.4).stroke_width(1),
            ));
        }
    }
    let (lo, hi) = series
        .iter()
        .flat_map(|s| s.1.iter())
        .fold((0.0f64, 0.0f64), |(l, h), p| (l.min(p.1), h.max(p.1)));
    let root = SVGBackend::new(path, (900, 560)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "Unit-modal-mass shapes of the design beam",
            ("sans-serif", 22),
        )
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..model.length, lo * 1.1..hi * 1.1)?;
    chart
        .configure_mesh()
        .x_desc("x [m]")
        .y_desc("φ [1/√kg]")
        .draw()?;
    chart.draw_series(std::iter::once(Rectangle::new(
        [(opt.x_a, lo * 1.1), (opt.x_a + opt.l_a, hi * 1.1)],
        RGBColor(230, 230, 230).filled(),
    )))?;
    for (name, pts, style) in series {
        let col = style.color;
        chart
            .draw_series(LineSeries::new(pts, style))?
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], col));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperLeft)
        .draw()?;
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_map_ends_and_clamps() {
        assert_eq!(colour(0.0), RGBColor(68, 1, 84));
        assert_eq!(colour(1.0), RGBColor(253, 231, 37));
        assert_eq!(colour(2.0), colour(1.0));
        assert_eq!(colour(f64::NAN), colour(0.0));
    }
}

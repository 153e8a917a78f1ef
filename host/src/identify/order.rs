//! How many modes a record holds: a stabilization diagram.
//!
//! The rational fit ([`super::rational`]) is run with room for `k = 1, 2, …, K` modes (a
//! denominator of degree `2k + 1`: the modes and one real pole, the film amplifier's
//! high-pass). A fit with more room than the record has modes spends it on noise, and the
//! poles it spends are not the same from one `k` to the next; a mode of the arm comes back at
//! every `k` once there is room for it. A pole at `k` is *stable* when the fit at `k − 1` has
//! one within [`F_TOL`] in frequency and [`ZETA_TOL`] in damping ratio; a pole stable at
//! [`RUN`] consecutive `k` (so seen at `RUN + 1` of them) is a mode of the record. The fit
//! used is the one at the smallest `k` that holds every such mode; the diagram itself is a
//! file of the modes step (`modes_stability.csv`).

use super::IdentifyError;
use super::rational::{self, RationalFit, Shape};
use super::spectra::Spectra;

/// A pole is stable against the order below within this share of its frequency.
pub const F_TOL: f64 = 0.01;
/// … and of its damping ratio.
pub const ZETA_TOL: f64 = 0.2;
/// Whether `a` and `b` [Hz or rad/s] are one resonance: `a` within `2 F_TOL` of `b`.
pub fn same_mode(a: f64, b: f64) -> bool {
    (a / b - 1.0).abs() < 2.0 * F_TOL
}

/// Consecutive stable orders that make a pole a mode.
pub const RUN: usize = 1;
/// Sanathanan–Koerner passes per order of the diagram, and of the chosen fit.
const PASSES: (usize, usize) = (5, 10);
/// The diagram stops this many orders past the last that brought a new mode.
const PAST: usize = 3;

/// One pole of one order of the diagram.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiagramPole {
    /// Room for `k` modes.
    pub k: usize,
    /// Frequency [Hz].
    pub hz: f64,
    /// Damping ratio.
    pub zeta: f64,
    /// Consecutive orders up to this one at which it was stable (0: new).
    pub run: usize,
    /// The weight of the diagram it belongs to ([`TILTS`]).
    pub tilt: f64,
}

/// The diagram and the fit chosen from it.
#[derive(Clone, Debug, PartialEq)]
pub struct Selection {
    /// Every order's lightly damped poles in the band.
    pub diagram: Vec<DiagramPole>,
    /// The modes of the record: `(hz, zeta)` of each stable chain, at the chosen order.
    pub chosen: usize,
    /// The fit at the chosen order, with its spread.
    pub fit: RationalFit,
    /// Its weight ([`TILTS`]).
    pub tilt: f64,
    /// The frequencies [Hz] of the record's modes (stable chains) the chosen fit holds.
    pub modes_hz: Vec<f64>,
}

/// The lines' weights, `1/f^tilt` ([`Shape::tilt`]): the diagram runs at both, and the
/// modes are those stable at either. `1/f` counts each octave alike and finds the modes at
/// the band's bottom (on a 1 m link with modes at 1.5, 6.9, 21 and 41 Hz a flat weight found
/// the upper two only); `1/√f` is closer to the output error's own weight and places the
/// upper ones better (on the family: within 0.3 % where `1/f` gave up to 0.5 %), and found a
/// weak second mode that `1/f` missed (a 0.5 kg payload's 14.7 Hz).
pub const TILTS: [f64; 2] = [0.5, 1.0];

/// The shape of the fit with room for `k` modes for inputs whose numerators start at the
/// powers `low` (the transient polynomials, if any, of the numerators' degree less one),
/// weighted by `tilt`: the diagram's, or with `spread` the chosen fit's.
pub fn shape(k: usize, low: &[usize], tilt: f64, spread: bool) -> Shape {
    let order = 2 * k + 1;
    Shape {
        order,
        num: low.iter().map(|&lo| (lo, order + 2)).collect(),
        transient: order + 1,
        iterations: if spread { PASSES.1 } else { PASSES.0 },
        spread,
        tilt,
    }
}

/// One diagram at the weight `tilt`: its poles and each order's poles in the band.
type Scan = (Vec<DiagramPole>, Vec<(usize, Vec<(f64, f64)>)>);

fn scan(
    sp: &Spectra,
    low: &[usize],
    band: (f64, f64),
    k_max: usize,
    tilt: f64,
) -> Result<Scan, IdentifyError> {
    let mut diagram: Vec<DiagramPole> = Vec::new();
    let mut fits: Vec<(usize, Vec<(f64, f64)>)> = Vec::new();
    let mut last_err = None;
    for k in 1..=k_max {
        let fit = match rational::fit(sp, &shape(k, low, tilt, false)) {
            Ok(f) => f,
            Err(e) => {
                last_err = Some(e);
                break;
            }
        };
        let poles: Vec<(f64, f64)> = rational::modes(&fit)
            .0
            .iter()
            .map(|m| (m.omega / std::f64::consts::TAU, m.zeta))
            .filter(|(f, z)| *f >= band.0 && *f <= band.1 && *z > 0.0)
            .collect();
        for &(hz, zeta) in &poles {
            let below = diagram
                .iter()
                .filter(|p| p.k + 1 == k)
                .filter(|p| {
                    (p.hz / hz - 1.0).abs() < F_TOL && (p.zeta / zeta - 1.0).abs() < ZETA_TOL
                })
                .min_by(|a, b| (a.hz - hz).abs().total_cmp(&(b.hz - hz).abs()));
            diagram.push(DiagramPole {
                k,
                hz,
                zeta,
                run: below.map_or(0, |p| p.run + 1),
                tilt,
            });
        }
        fits.push((k, poles));
        // Stop once PAST orders have brought no new stable pole.
        let newest = diagram
            .iter()
            .filter(|p| p.run == RUN)
            .map(|p| p.k)
            .max()
            .unwrap_or(0);
        if k >= newest.max(RUN + 1) + PAST {
            break;
        }
    }
    if fits.is_empty() {
        return Err(last_err.unwrap_or_else(|| {
            IdentifyError::Data("no order of the rational fit could be run".into())
        }));
    }
    Ok((diagram, fits))
}

/// Runs the diagram on `sp` for `k = 1 … k_max` (fewer when the lines run out or no new mode
/// comes) inside `band` [Hz] at both weights, the inputs' numerators starting at `low`; the
/// modes are the poles stable at either; the fit chosen is the first (at `1/√f`, then at
/// `1/f`) whose poles hold every mode. An error when not even one order fits.
pub fn select(
    sp: &Spectra,
    low: &[usize],
    band: (f64, f64),
    k_max: usize,
) -> Result<Selection, IdentifyError> {
    let mut diagram = Vec::new();
    let mut scans = Vec::new();
    for tilt in TILTS {
        let (d, fits) = scan(sp, low, band, k_max, tilt)?;
        diagram.extend(d);
        scans.push((tilt, fits));
    }
    // The modes: poles stable over RUN orders at either weight, one per frequency.
    let mut modes_hz: Vec<f64> = Vec::new();
    let mut stable: Vec<&DiagramPole> = diagram.iter().filter(|p| p.run >= RUN).collect();
    stable.sort_by(|a, b| b.run.cmp(&a.run).then(b.k.cmp(&a.k)));
    for p in stable {
        if !modes_hz.iter().any(|f| same_mode(*f, p.hz)) {
            modes_hz.push(p.hz);
        }
    }
    modes_hz.sort_by(f64::total_cmp);
    let holds = |poles: &[(f64, f64)]| {
        modes_hz
            .iter()
            .all(|f| poles.iter().any(|(g, _)| same_mode(*g, *f)))
    };
    let (tilt, chosen) = scans
        .iter()
        .find_map(|(tilt, fits)| {
            fits.iter()
                .find(|(_, poles)| holds(poles))
                .map(|(k, _)| (*tilt, *k))
        })
        .unwrap_or_else(|| {
            let (tilt, fits) = &scans[0];
            (*tilt, fits.last().map_or(1, |f| f.0))
        });
    let fit = rational::fit(sp, &shape(chosen, low, tilt, true))?;
    Ok(Selection {
        diagram,
        chosen,
        fit,
        tilt,
        modes_hz,
    })
}

//! `flexarm-sim spillover`: the piezo loop against the truth plant's link (issue 14). Host
//! side, `f64`. Four questions, each a table of the report:
//!
//! 1. **Margins of the shipped loop** (`k_c = 30 s`, 100 Hz corner): the factor on `k_c`
//!    before the sampled loop goes unstable ([`crate::spillover::gain_margin`], joints held),
//!    against the number of modes `N`, for the hardware board's 10 kHz loop (ideal; with the
//!    amplifier's bandwidth; with the film read one period late as well, the realistic board)
//!    and the QEMU board's 1 kHz.
//! 2. **The gain and the corner**: on the realistic board with `N = 10`, the margin and the
//!    closed-loop damping ratios of modes 1 and 2 against `k_c`, for several corners.
//! 3. **The design rule** ([`recommend`]): the gain and corner that damp modes 1 and 2 best
//!    while keeping a factor of at least [`MARGIN`] with every mode kept.
//! 4. **The whole loop in simulation**: the paper's trapezoid on the truth plant with `N`
//!    modes, Eq. 7 + piezo, full state and the firmware's observer with realistic sensors,
//!    with the shipped and the recommended piezo gains (the observer sees the film too, so its
//!    residuals carry the modes it does not know), and the observer's gain scaled by
//!    designing it for [`OBSERVER_NOISE`] times the firmware's modal process noise.
//! 5. **The laws against the film's feedthrough** ([`compare`], issue 35): the paper's rate law
//!    (shipped, and its design rule of question 3), the rate law with the identified
//!    feedthrough subtracted, integral resonant control and positive position feedback (the
//!    core's `cancel`, `irc`, `ppf`, each with its design rule from the identified loop), on the
//!    realistic board, across the bond factor of the film's feedthrough and `N = 2 … 10`: the
//!    factor on the actuator path's gain before instability, the closed-loop damping ratios of
//!    modes 1 and 2 ([`band_damping`]) and the paper's trapezoid on the truth plant.

use std::fmt::Write as _;
use std::path::Path;

use flexarm_core::Vector2;
use flexarm_core::control::cancel::{CancelGains, FeedthroughCancel};
use flexarm_core::control::irc::{Irc, IrcGains};
use flexarm_core::control::linear::IdentifiedLoop;
use flexarm_core::control::piezo::{PiezoGains, PiezoPatch};
use flexarm_core::control::ppf::{Ppf, PpfFilter, PpfGains};
use flexarm_core::observer::NoiseModel;
use flexarm_core::params::ArmParams;
use flexarm_core::trajectory::{JointTrajectory, Trapezoid};
use plotters::prelude::*;

use crate::eigen::{EigenError, eigenvalues};
use crate::sim::{PiezoLawChoice, Sensors, SimConfig, SimError, StateSource, Summary, simulate};
use crate::spillover::{
    LinearLaw, ModalLink, PiezoLoop, closed_loop, closed_loop_with, gain_margin, gain_margin_with,
};
use crate::truth_plant::{MAX_MODES, TruthSpec};
use nalgebra::DMatrix;

/// The residual vibration of the closed-loop runs is Eq. 38 over their last second [s] (half
/// the run if shorter).
pub const RESIDUAL_WINDOW: f64 = 1.0;

/// Factors on the modal process noise the observer is designed for (1: the firmware's).
pub const OBSERVER_NOISE: [f64; 3] = [0.1, 1.0, 10.0];

/// The factor on `k_c` the recommended design keeps before instability (6 dB).
pub const MARGIN: f64 = 2.0;

/// The shipped piezo loop on the hardware board: `k_c = 30 s`, 100 Hz corner, 10 kHz.
pub const SHIPPED: PiezoLoop = PiezoLoop {
    k_c: 30.0,
    cutoff_hz: 100.0,
    period: 1e-4,
    delay: false,
    amplifier_hz: None,
};

/// The loops of question 1, with their labels.
pub fn loops(spec: &TruthSpec) -> [(&'static str, PiezoLoop); 4] {
    let amp = Some(spec.amplifier_hz).filter(|f| f.is_finite());
    [
        ("10 kHz, ideal amplifier", SHIPPED),
        (
            "10 kHz, amplifier",
            PiezoLoop {
                amplifier_hz: amp,
                ..SHIPPED
            },
        ),
        (
            "10 kHz, amplifier, film one period late",
            realistic(spec, SHIPPED),
        ),
        (
            "1 kHz (QEMU board), ideal amplifier",
            PiezoLoop {
                period: 1e-3,
                ..SHIPPED
            },
        ),
    ]
}

/// `law` on the realistic hardware board: the amplifier of `spec` and the one-period delay.
pub fn realistic(spec: &TruthSpec, law: PiezoLoop) -> PiezoLoop {
    PiezoLoop {
        delay: true,
        amplifier_hz: Some(spec.amplifier_hz).filter(|f| f.is_finite()),
        ..law
    }
}

/// Damping ratios of the closed loop's modes 1 and 2 for the rate law of `law`
/// ([`band_damping`]).
pub fn modal_damping(link: &ModalLink, law: &PiezoLoop) -> Result<[f64; 2], EigenError> {
    band_damping(link, law.period, &closed_loop(link, law))
}

/// Damping ratios of the closed loop `m` (period `period`) in the bands of the link's modes 1
/// and 2: the discrete eigenvalues mapped to `s = ln λ / T`, and in each band the least damped
/// oscillating one, `ζ = −Re s / |s|`. Mode `j`'s band runs from the geometric mean of `ω_{j−1}`
/// and `ω_j` (0 for mode 1) to that of `ω_j` and `ω_{j+1}`: a law's own poles there (a PPF
/// filter's) count, since they ring in the same band. `NaN` for a band without an eigenvalue.
pub fn band_damping(
    link: &ModalLink,
    period: f64,
    m: &DMatrix<f64>,
) -> Result<[f64; 2], EigenError> {
    let s: Vec<_> = eigenvalues(m)?
        .iter()
        .filter(|l| l.im > 0.0)
        .map(|l| l.ln() / period)
        .collect();
    let w = &link.omega;
    let edge = |j: usize| match (j.checked_sub(1).and_then(|i| w.get(i)), w.get(j)) {
        (Some(a), Some(b)) => (a * b).sqrt(),
        (None, _) => 0.0,
        (Some(a), None) => 2.0 * a,
    };
    let band = |j: usize| {
        let (lo, hi) = (edge(j), edge(j + 1));
        s.iter()
            .filter(|x| x.norm() > lo && x.norm() <= hi)
            .map(|x| -x.re / x.norm())
            .fold(f64::NAN, f64::min)
    };
    Ok([band(0), band(1)])
}

/// One point of the gain scan.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScanPoint {
    /// Corner of the rate filter [Hz].
    pub cutoff_hz: f64,
    /// Gain [s].
    pub k_c: f64,
    /// Factor on `k_c` before instability (`∞` when stable to 1e6).
    pub margin: f64,
    /// Closed-loop damping ratios of modes 1 and 2.
    pub zeta: [f64; 2],
}

/// Gains of the scan: 0.1 to 100 s, 10 a decade.
pub fn gains() -> Vec<f64> {
    (0..=30)
        .map(|i| 10f64.powf(-1.0 + f64::from(i) / 10.0))
        .collect()
}

/// Corners of the scan [Hz].
pub const CORNERS: [f64; 4] = [30.0, 100.0, 300.0, 1000.0];

/// The margin and the damping of modes 1–2 over `gains` × `corners` for the loop `base`.
pub fn scan(
    link: &ModalLink,
    base: &PiezoLoop,
    gains: &[f64],
    corners: &[f64],
) -> Result<Vec<ScanPoint>, EigenError> {
    let mut out = Vec::new();
    for &cutoff_hz in corners {
        for &k_c in gains {
            let law = PiezoLoop {
                k_c,
                cutoff_hz,
                ..*base
            };
            out.push(ScanPoint {
                cutoff_hz,
                k_c,
                margin: gain_margin(link, &law, 1e6)?.unwrap_or(f64::INFINITY),
                zeta: modal_damping(link, &law)?,
            });
        }
    }
    Ok(out)
}

/// The design rule: of the points with a margin of at least [`MARGIN`], the one whose weaker
/// mode (1 or 2) is damped most.
pub fn recommend(points: &[ScanPoint]) -> Option<ScanPoint> {
    points
        .iter()
        .filter(|p| p.margin >= MARGIN)
        .max_by(|a, b| {
            a.zeta[0]
                .min(a.zeta[1])
                .total_cmp(&b.zeta[0].min(b.zeta[1]))
        })
        .copied()
}

/// A closed-loop run of question 4.
#[derive(Clone, Debug)]
pub struct Run {
    /// What ran.
    pub label: String,
    /// Its indices (`None`: it faulted or diverged, with why).
    pub summary: Result<Summary, String>,
}

/// The report.
#[derive(Clone, Debug)]
pub struct Report {
    /// The truth plant studied (its largest `N`).
    pub spec: TruthSpec,
    /// Frequencies of its modes [Hz].
    pub frequencies_hz: Vec<f64>,
    /// Question 1: per loop, the margin for `N` = 1 … `spec.modes`.
    pub margins: Vec<(&'static str, Vec<f64>)>,
    /// Question 2.
    pub scan: Vec<ScanPoint>,
    /// Question 3.
    pub recommended: Option<ScanPoint>,
    /// The shipped gain on the realistic board with every mode: damping of modes 1 and 2.
    pub shipped_zeta: [f64; 2],
    /// Question 4.
    pub runs: Vec<Run>,
    /// Question 5: every law at every bond factor.
    pub comparison: Vec<LawRow>,
}

/// Runs the study on the truth plant `spec` (its `modes` is the largest `N`), on the paper's
/// arm and patch; question 5 at the bond factors `bonds` (none: skipped); `sim_duration` [s] is
/// the length of the closed-loop runs.
pub fn run(spec: &TruthSpec, bonds: &[f64], sim_duration: f64) -> Result<Report, SimError> {
    let arm = ArmParams::<f64>::default();
    let patch = PiezoPatch::<f64>::paper();
    let link_n = |n: usize| {
        ModalLink::from_truth(&TruthSpec { modes: n, ..*spec }, &arm, &patch)
            .map_err(|e| SimError::Truth(e.to_string()))
    };
    let full = link_n(spec.modes)?;
    let margins = loops(spec)
        .into_iter()
        .map(|(label, law)| {
            let row = (1..=spec.modes)
                .map(|n| {
                    gain_margin(&full.truncated(n), &law, 1e6)
                        .map(|m| m.unwrap_or(f64::INFINITY))
                        .map_err(eigen_error)
                })
                .collect::<Result<Vec<_>, SimError>>()?;
            Ok((label, row))
        })
        .collect::<Result<Vec<_>, SimError>>()?;
    let board = realistic(spec, SHIPPED);
    let points = scan(&full, &board, &gains(), &CORNERS).map_err(eigen_error)?;
    let recommended = recommend(&points);
    let z = modal_damping(&full, &board).map_err(eigen_error)?;

    let traj = JointTrajectory::Trapezoid(Trapezoid::paper());
    let mut runs = Vec::new();
    let mut gains = vec![("shipped", SHIPPED.k_c, SHIPPED.cutoff_hz)];
    if let Some(r) = recommended {
        gains.push(("recommended", r.k_c, r.cutoff_hz));
    }
    for (name, k_c, cutoff_hz) in gains {
        let mut cases = vec![(
            StateSource::Full,
            Sensors::default(),
            1.0,
            "full state".into(),
        )];
        for f in OBSERVER_NOISE {
            cases.push((
                StateSource::Observer,
                Sensors::realistic(),
                f,
                format!("observer ({f}× modal noise), realistic sensors"),
            ));
        }
        for (state, sensors, noise, what) in cases {
            let mut observer_noise = NoiseModel::default();
            observer_noise.accel_modal *= noise;
            let cfg = SimConfig {
                piezo: Some(PiezoGains {
                    k_c: k_c as f32,
                    cutoff_hz: cutoff_hz as f32,
                }),
                state,
                sensors,
                observer_noise,
                duration: sim_duration,
                tail_window: (sim_duration / 2.0).min(RESIDUAL_WINDOW),
                ..SimConfig::default()
            }
            .with_truth(*spec)?;
            runs.push(Run {
                label: format!("{name} (k_c = {k_c:.3} s, {cutoff_hz} Hz), {what}"),
                summary: simulate(&cfg, &traj, false)
                    .map(|(s, _)| s)
                    .map_err(|e| e.to_string()),
            });
        }
    }
    Ok(Report {
        spec: *spec,
        frequencies_hz: full
            .omega
            .iter()
            .map(|w| w / std::f64::consts::TAU)
            .collect(),
        margins,
        scan: points,
        recommended,
        shipped_zeta: z,
        runs,
        comparison: match recommended {
            Some(r) => compare(spec, bonds, r, sim_duration)?,
            None => Vec::new(),
        },
    })
}

/// The bond factors of the film's feedthrough the laws are compared at (`--bond`).
pub const BONDS: [f64; 3] = [0.0, 0.5, 1.0];

/// One law at one bond factor (question 5).
#[derive(Clone, Debug)]
pub struct LawRow {
    /// The law and its gains.
    pub label: String,
    /// Which law (for the verdict): `rate shipped`, `rate rule`, `cancel`, `irc`, `ppf`.
    pub kind: &'static str,
    /// The bond factor `β`.
    pub bond: f64,
    /// The factor on the actuator path's gain before instability for `N = 2 … 10` (the link's
    /// modes up to `spec.modes`), on the realistic board.
    pub margins: Vec<(usize, f64)>,
    /// Closed-loop damping ratios of modes 1 and 2 with every mode ([`band_damping`]).
    pub zeta: [f64; 2],
    /// The paper's trapezoid on the truth plant with every mode and this bond, full state,
    /// realistic sensors with the film read one piezo period late (the board of the margins),
    /// Eq. 7 + this law.
    pub run: Result<Summary, String>,
    /// The same with a noise-free film (no ADC, no noise; the delays kept): what the law
    /// settles to when the film's noise does not drive it.
    pub clean: Result<Summary, String>,
}

impl LawRow {
    /// The smallest factor over `N`.
    pub fn worst_margin(&self) -> f64 {
        self.margins
            .iter()
            .map(|m| m.1)
            .fold(f64::INFINITY, f64::min)
    }
}

/// A law of question 5: its kind, label, linear form, and what the simulator runs (a law of
/// issue 35, or the paper's rate law with these gains).
type Candidate = (
    &'static str,
    String,
    LinearLaw,
    Option<PiezoLawChoice>,
    Option<PiezoGains<f32>>,
);

/// The identified loop of `link` (every mode, this bond) as commissioning would measure it:
/// the first two modes, their film gains, `F̂ = β F` and `D̂ = β F + Σ_{j>2} g_j/ω_j²` (the
/// modes above the band quasi-static). An ideal identification: the study's question is the
/// laws', not the identification's.
pub fn identified(link: &ModalLink) -> IdentifiedLoop<f64> {
    let g: Vec<f64> = link
        .slope_diff
        .iter()
        .map(|d| link.k_a * link.k_s * d * d)
        .collect();
    let residual: f64 = g
        .iter()
        .zip(&link.omega)
        .skip(2)
        .map(|(g, w)| g / (w * w))
        .sum();
    IdentifiedLoop {
        omega: Vector2::new(link.omega[0], link.omega[1]),
        zeta: Vector2::new(link.zeta[0], link.zeta[1]),
        film_gain: Vector2::new(g[0], g[1]),
        direct: link.feedthrough + residual,
        feedthrough: link.feedthrough,
    }
}

/// Question 5: the shipped rate law, the rate law's design rule `rule` (question 3), and the
/// laws of issue 35 by their design rules, on the realistic board of `spec` at each bond factor.
pub fn compare(
    spec: &TruthSpec,
    bonds: &[f64],
    rule: ScanPoint,
    sim_duration: f64,
) -> Result<Vec<LawRow>, SimError> {
    let arm = ArmParams::<f64>::default();
    let patch = PiezoPatch::<f64>::paper();
    let period = SHIPPED.period;
    let board = realistic(spec, SHIPPED).board();
    let (v_min, v_max) = (spec.amplifier_window[0], spec.amplifier_window[1]);
    let rule_gains = PiezoGains {
        k_c: rule.k_c,
        cutoff_hz: rule.cutoff_hz,
    };
    let mut rows = Vec::new();
    for &bond in bonds {
        let bonded = TruthSpec {
            film_bond: bond,
            ..*spec
        };
        let full = ModalLink::from_truth(&bonded, &arm, &patch)
            .map_err(|e| SimError::Truth(e.to_string()))?;
        let id = identified(&full);
        let bad = |what: &str| SimError::Truth(format!("the {what} design rule refused the loop"));
        let ppf = PpfGains::design(&id).ok_or_else(|| bad("PPF"))?;
        let irc = IrcGains::design(&id).ok_or_else(|| bad("IRC"))?;
        let cancel = CancelGains::design(&id, rule_gains).ok_or_else(|| bad("cancellation"))?;
        let f32_gains = |g: &PiezoGains<f64>| PiezoGains {
            k_c: g.k_c as f32,
            cutoff_hz: g.cutoff_hz as f32,
        };
        let laws: Vec<Candidate> = vec![
            (
                "rate shipped",
                format!(
                    "rate, shipped ({} s, {} Hz)",
                    SHIPPED.k_c, SHIPPED.cutoff_hz
                ),
                LinearLaw::rate(SHIPPED.k_c, SHIPPED.cutoff_hz, period),
                None,
                Some(PiezoGains::default()),
            ),
            (
                "rate rule",
                format!("rate, rule ({:.2} s, {} Hz)", rule.k_c, rule.cutoff_hz),
                LinearLaw::rate(rule.k_c, rule.cutoff_hz, period),
                None,
                Some(f32_gains(&rule_gains)),
            ),
            (
                "cancel",
                format!(
                    "rate rule on V_f − F̂ V_a(t − 2T), F̂ = {:.2e}",
                    cancel.feedthrough + 0.0
                ),
                LinearLaw::from(&FeedthroughCancel::new(&cancel, period, v_min, v_max).linear()),
                Some(PiezoLawChoice::Cancel(CancelGains {
                    rate: f32_gains(&cancel.rate),
                    feedthrough: cancel.feedthrough as f32,
                    lag: cancel.lag,
                })),
                None,
            ),
            (
                "irc",
                format!(
                    "IRC (Γ = {:.3e} /s, d = {:.2e}, leak {:.2} Hz)",
                    irc.gamma, irc.feedthrough, irc.leak_hz
                ),
                LinearLaw::from(&Irc::new(&irc, period, v_min, v_max).linear()),
                Some(PiezoLawChoice::Irc(IrcGains {
                    gamma: irc.gamma as f32,
                    feedthrough: irc.feedthrough as f32,
                    leak_hz: irc.leak_hz as f32,
                })),
                None,
            ),
            (
                "ppf",
                format!(
                    "PPF (k = {:.0}, {:.0} V/V at {:.1}, {:.1} Hz, ζ {})",
                    ppf.filters[0].gain,
                    ppf.filters[1].gain,
                    ppf.filters[0].freq_hz,
                    ppf.filters[1].freq_hz,
                    ppf.filters[0].zeta
                ),
                LinearLaw::from(&Ppf::new(&ppf, period, v_min, v_max).linear()),
                Some(PiezoLawChoice::Ppf(PpfGains {
                    filters: ppf.filters.map(|f| PpfFilter {
                        gain: f.gain as f32,
                        freq_hz: f.freq_hz as f32,
                        zeta: f.zeta as f32,
                    }),
                })),
                None,
            ),
        ];
        for (kind, label, law, choice, rate) in laws {
            let margins = (2..=full.omega.len())
                .map(|n| {
                    gain_margin_with(&full.truncated(n), &board, &law, 1e6)
                        .map(|m| (n, m.unwrap_or(f64::INFINITY)))
                        .map_err(eigen_error)
                })
                .collect::<Result<Vec<_>, SimError>>()?;
            let zeta = band_damping(&full, period, &closed_loop_with(&full, &board, &law, 1.0))
                .map_err(eigen_error)?;
            let trapezoid = |sensors: Sensors| -> Result<Result<Summary, String>, SimError> {
                let cfg = SimConfig {
                    piezo: rate,
                    piezo_law: choice,
                    state: StateSource::Full,
                    sensors,
                    duration: sim_duration,
                    tail_window: (sim_duration / 2.0).min(RESIDUAL_WINDOW),
                    ..SimConfig::default()
                }
                .with_truth(bonded)?;
                Ok(
                    simulate(&cfg, &JointTrajectory::Trapezoid(Trapezoid::paper()), false)
                        .map(|(s, _)| s)
                        .map_err(|e| e.to_string()),
                )
            };
            rows.push(LawRow {
                label,
                kind,
                bond,
                margins,
                zeta,
                run: trapezoid(Sensors {
                    piezo_delay: true,
                    ..Sensors::realistic()
                })?,
                clean: trapezoid(Sensors {
                    delay: true,
                    piezo_delay: true,
                    ..Sensors::default()
                })?,
            });
        }
    }
    Ok(rows)
}

/// The laws that meet issue 35's goal on `rows`: at every bond factor a factor of at least
/// [`MARGIN`] for every `N`, and modes 1 and 2 damped at least as much as the rate law's rule
/// damps them without feedthrough (`β = 0`). Empty if `rows` has no rule at `β = 0`.
pub fn meeting_the_goal(rows: &[LawRow]) -> Vec<&'static str> {
    let Some(base) = rows
        .iter()
        .find(|r| r.kind == "rate rule" && r.bond == 0.0)
        .map(|r| r.zeta)
    else {
        return Vec::new();
    };
    let mut kinds: Vec<&'static str> = Vec::new();
    for r in rows {
        if !kinds.contains(&r.kind) {
            kinds.push(r.kind);
        }
    }
    kinds
        .into_iter()
        .filter(|k| {
            rows.iter()
                .filter(|r| r.kind == *k)
                .all(|r| r.worst_margin() >= MARGIN && r.zeta[0] >= base[0] && r.zeta[1] >= base[1])
        })
        .collect()
}

fn eigen_error(e: EigenError) -> SimError {
    SimError::Truth(format!("the spillover loop's eigenvalues: {e}"))
}

fn factor(x: f64) -> String {
    if x.is_infinite() {
        "> 1e6".into()
    } else if x < 1.0 {
        format!("**{x:.2}**")
    } else {
        format!("{x:.2}")
    }
}

/// The report as Markdown.
pub fn markdown(r: &Report) -> String {
    let mut s = String::new();
    let f: Vec<String> = r.frequencies_hz.iter().map(|f| format!("{f:.1}")).collect();
    let _ = writeln!(
        s,
        "Truth plant: link 2 as the {:.1} mm beam with the paper's patch, {} modes at {} Hz; amplifier {} Hz.\n",
        r.spec.thickness * 1e3,
        r.spec.modes,
        f.join(", "),
        r.spec.amplifier_hz
    );
    let _ = writeln!(
        s,
        "## 1. Factor on k_c = {} s (corner {} Hz) before the sampled piezo loop goes unstable (joints held; bold: unstable)\n",
        SHIPPED.k_c, SHIPPED.cutoff_hz
    );
    let ns: Vec<String> = (1..=r.spec.modes).map(|n| format!("N = {n}")).collect();
    let _ = writeln!(s, "| loop | {} |", ns.join(" | "));
    let _ = writeln!(s, "|---|{}", "---|".repeat(r.spec.modes));
    for (label, row) in &r.margins {
        let cells: Vec<String> = row.iter().map(|x| factor(*x)).collect();
        let _ = writeln!(s, "| {label} | {} |", cells.join(" | "));
    }
    let _ = writeln!(
        s,
        "\nThe shipped gain on the realistic board with {} modes damps mode 1 with ζ = {:.3} and mode 2 with ζ = {:.3} (structural: {}, {}).\n",
        r.spec.modes, r.shipped_zeta[0], r.shipped_zeta[1], r.spec.zeta[0], r.spec.zeta[1]
    );
    let _ = writeln!(
        s,
        "## 2. The gain and the corner (realistic board, {} modes): margin / ζ1 / ζ2\n",
        r.spec.modes
    );
    let _ = writeln!(
        s,
        "| k_c [s] | {} |",
        CORNERS
            .iter()
            .map(|c| format!("{c} Hz"))
            .collect::<Vec<_>>()
            .join(" | ")
    );
    let _ = writeln!(s, "|---|{}", "---|".repeat(CORNERS.len()));
    for k in gains().iter().step_by(5) {
        let cells: Vec<String> = CORNERS
            .iter()
            .map(|c| {
                r.scan
                    .iter()
                    .find(|p| p.cutoff_hz == *c && p.k_c == *k)
                    .map_or("".into(), |p| {
                        format!("{} / {:.3} / {:.3}", factor(p.margin), p.zeta[0], p.zeta[1])
                    })
            })
            .collect();
        let _ = writeln!(s, "| {k:.1} | {} |", cells.join(" | "));
    }
    let _ = writeln!(s, "\n## 3. The design rule\n");
    match r.recommended {
        Some(p) => {
            let _ = writeln!(
                s,
                "Of the gains 0.1 to 100 s (10 a decade) and the corners above, the one that damps the weaker of modes 1 and 2 most while keeping a factor of at least {MARGIN} with every mode: **k_c = {:.3} s, corner {} Hz**: factor {:.2}, ζ1 = {:.3}, ζ2 = {:.3}.\n",
                p.k_c, p.cutoff_hz, p.margin, p.zeta[0], p.zeta[1]
            );
        }
        None => {
            let _ = writeln!(
                s,
                "No gain of the scan keeps a factor of {MARGIN} with every mode.\n"
            );
        }
    }
    let _ = writeln!(
        s,
        "## 4. The paper's trapezoid on the truth plant ({} modes), Eq. 7 + piezo\n",
        r.spec.modes
    );
    let _ = writeln!(
        s,
        "| piezo gain, controller | Eq. 37 δ [√kg·m] | Eq. 37 tip [m] | residual: Eq. 38 mean \\|δ\\| over the last {RESIDUAL_WINDOW} s [√kg·m] | Eq. 37 θ̃ [rad] | max \\|V_a\\| [V] |\n|---|---|---|---|---|---|"
    );
    for run in &r.runs {
        match &run.summary {
            Ok(x) => {
                let _ = writeln!(
                    s,
                    "| {} | {:.3e} | {:.3e} | {:.2e}, {:.2e} | {:.3e} | {:.1} |",
                    run.label,
                    x.l2_delta,
                    x.l2_tip,
                    x.tail_delta_abs[0],
                    x.tail_delta_abs[1],
                    x.l2_error,
                    x.max_v_a
                );
            }
            Err(e) => {
                let _ = writeln!(s, "| {} | failed: {e} | | | | |", run.label);
            }
        }
    }
    markdown_comparison(&mut s, r);
    s
}

/// Question 5 as Markdown.
fn markdown_comparison(s: &mut String, r: &Report) {
    if r.comparison.is_empty() {
        return;
    }
    let ns: Vec<String> = r.comparison[0]
        .margins
        .iter()
        .map(|(n, _)| format!("N = {n}"))
        .collect();
    let _ = writeln!(
        s,
        "\n## 5. The laws against the film's feedthrough (realistic board: 10 kHz, {} Hz amplifier, film one period late)\n\nFactor on the actuator path's gain before instability (bold: below {MARGIN}), closed-loop ζ of modes 1 and 2 with {} modes, and the paper's trapezoid on the truth plant with {} modes and that bond (full state, realistic sensors, Eq. 7 + the law): Eq. 37 δ, the largest tip deflection, Eq. 38 mean \\|δ\\| over the last {RESIDUAL_WINDOW} s, the largest command, and the residual again with a noise-free film (no ADC, no noise).\n",
        r.spec.amplifier_hz, r.spec.modes, r.spec.modes
    );
    let _ = writeln!(
        s,
        "| law | β | {} | ζ1, ζ2 | Eq. 37 δ [√kg·m] | max \\|tip\\| [mm] | residual \\|δ\\| [√kg·m] | max \\|V_a\\| [V] | residual, noise-free film |\n|---|---|{}---|---|---|---|---|---|",
        ns.join(" | "),
        "---|".repeat(ns.len())
    );
    for row in &r.comparison {
        let cells: Vec<String> = row
            .margins
            .iter()
            .map(|(_, m)| {
                if m.is_infinite() {
                    "> 1e6".into()
                } else if *m < MARGIN {
                    format!("**{m:.2}**")
                } else {
                    format!("{m:.2}")
                }
            })
            .collect();
        let run = match &row.run {
            Ok(x) => format!(
                "{:.3e} | {:.2} | {:.2e}, {:.2e} | {:.1}",
                x.l2_delta,
                x.max_tip * 1e3,
                x.tail_delta_abs[0],
                x.tail_delta_abs[1],
                x.max_v_a
            ),
            Err(e) => format!("failed: {e} | | |"),
        };
        let clean = match &row.clean {
            Ok(x) => format!("{:.2e}, {:.2e}", x.tail_delta_abs[0], x.tail_delta_abs[1]),
            Err(e) => format!("failed: {e}"),
        };
        let z = |x: f64| {
            if x.is_nan() {
                "–".to_string()
            } else {
                format!("{x:.3}")
            }
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {}, {} | {run} | {clean} |",
            row.label,
            row.bond,
            cells.join(" | "),
            z(row.zeta[0]),
            z(row.zeta[1])
        );
    }
    let meet = meeting_the_goal(&r.comparison);
    let _ = writeln!(
        s,
        "\nLaws with a factor of at least {MARGIN} at every N and every bond factor, damping modes 1 and 2 at least as much as the rate law's rule without feedthrough: {}.",
        if meet.is_empty() {
            "none".to_string()
        } else {
            meet.join(", ")
        }
    );
}

/// The scan as CSV: `cutoff_hz,k_c,margin,zeta1,zeta2`.
pub fn csv(r: &Report) -> String {
    let mut s = String::from("cutoff_hz,k_c_s,margin,zeta1,zeta2\n");
    for p in &r.scan {
        let _ = writeln!(
            s,
            "{},{},{},{},{}",
            p.cutoff_hz, p.k_c, p.margin, p.zeta[0], p.zeta[1]
        );
    }
    s
}

/// Three panels: the shipped loop's margin against `N` (question 1); the margin and the
/// damping against `k_c` on the realistic board (question 2, the 100 Hz corner and the
/// recommended one); each law's factor against `N` by bond factor (question 5).
pub fn figure(path: &Path, r: &Report) -> Result<(), Box<dyn std::error::Error>> {
    let root = SVGBackend::new(path, (1800, 500)).into_drawing_area();
    root.fill(&WHITE)?;
    let (left, rest) = root.split_horizontally(600);
    let (right, third) = rest.split_horizontally(600);
    let colours = [BLUE, RED, GREEN, MAGENTA, CYAN];
    let clamp = |x: f64| x.clamp(1e-3, 1e4);

    let mut c = ChartBuilder::on(&left)
        .caption(
            format!("Factor on k_c = {} s before instability", SHIPPED.k_c),
            ("sans-serif", 18),
        )
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(1usize..r.spec.modes.max(2), (1e-3f64..1e4f64).log_scale())?;
    c.configure_mesh()
        .x_desc("modes of link 2, N")
        .y_desc("factor")
        .draw()?;
    c.draw_series(LineSeries::new(
        [(1, 1.0), (r.spec.modes.max(2), 1.0)],
        BLACK.stroke_width(1),
    ))?;
    for (k, (label, row)) in r.margins.iter().enumerate() {
        let col = colours[k % colours.len()];
        c.draw_series(LineSeries::new(
            row.iter().enumerate().map(|(i, m)| (i + 1, clamp(*m))),
            col.stroke_width(2),
        ))?
        .label(*label)
        .legend(move |(x, y)| PathElement::new([(x, y), (x + 15, y)], col.stroke_width(2)));
    }
    c.configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .draw()?;

    let mut c = ChartBuilder::on(&right)
        .caption(
            format!("Realistic board, N = {}: margin and damping", r.spec.modes),
            ("sans-serif", 18),
        )
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d((0.1f64..100f64).log_scale(), (1e-3f64..1e4f64).log_scale())?;
    c.configure_mesh()
        .x_desc("k_c [s]")
        .y_desc("factor; damping ratio")
        .draw()?;
    c.draw_series(LineSeries::new(
        [(0.1, MARGIN), (100.0, MARGIN)],
        BLACK.stroke_width(1),
    ))?;
    let mut corners = vec![SHIPPED.cutoff_hz];
    if let Some(p) = r.recommended
        && p.cutoff_hz != SHIPPED.cutoff_hz
    {
        corners.push(p.cutoff_hz);
    }
    for (k, corner) in corners.iter().enumerate() {
        let pts: Vec<&ScanPoint> = r.scan.iter().filter(|p| p.cutoff_hz == *corner).collect();
        let col = colours[k % colours.len()];
        for (what, f, style) in [
            ("margin", 0usize, col.stroke_width(2)),
            ("ζ1", 1, col.stroke_width(1)),
            ("ζ2", 2, col.mix(0.5).stroke_width(1)),
        ] {
            let v = |p: &ScanPoint| match f {
                0 => p.margin,
                1 => p.zeta[0],
                _ => p.zeta[1],
            };
            c.draw_series(LineSeries::new(
                pts.iter().map(|p| (p.k_c, clamp(v(p)))),
                style,
            ))?
            .label(format!("{what}, {corner} Hz"))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 15, y)], style));
        }
    }
    if let Some(p) = r.recommended {
        c.draw_series(std::iter::once(Circle::new(
            (p.k_c, p.margin),
            5,
            BLACK.filled(),
        )))?;
    }
    c.configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .draw()?;
    comparison_panel(&third, r, &colours)?;
    root.present()?;
    Ok(())
}

/// Question 5's panel: each law's factor against `N`, one line per bond factor (fainter for
/// smaller bonds).
fn comparison_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    r: &Report,
    colours: &[RGBColor],
) -> Result<(), Box<dyn std::error::Error>>
where
    DB::ErrorType: 'static,
{
    let Some(first) = r.comparison.first() else {
        return Ok(());
    };
    let n_max = first.margins.last().map_or(2, |m| m.0);
    let mut c = ChartBuilder::on(area)
        .caption(
            "Laws on the realistic board: factor against N, by bond",
            ("sans-serif", 18),
        )
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(2usize..n_max.max(3), (1e-2f64..1e2f64).log_scale())?;
    c.configure_mesh()
        .x_desc("modes of link 2, N")
        .y_desc("factor on the actuator path")
        .draw()?;
    c.draw_series(LineSeries::new(
        [(2, MARGIN), (n_max.max(3), MARGIN)],
        BLACK.stroke_width(1),
    ))?;
    let max_bond = r.comparison.iter().map(|x| x.bond).fold(0.0, f64::max);
    let mut kinds: Vec<&'static str> = Vec::new();
    for row in &r.comparison {
        let k = match kinds.iter().position(|k| *k == row.kind) {
            Some(k) => k,
            None => {
                kinds.push(row.kind);
                kinds.len() - 1
            }
        };
        let alpha = if max_bond > 0.0 {
            0.3 + 0.7 * row.bond / max_bond
        } else {
            1.0
        };
        let style = colours[k % colours.len()].mix(alpha).stroke_width(2);
        let series = c.draw_series(LineSeries::new(
            row.margins.iter().map(|(n, m)| (*n, m.clamp(1e-2, 1e2))),
            style,
        ))?;
        if row.bond == max_bond {
            series
                .label(format!("{} (β = {})", row.kind, row.bond))
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 15, y)], style));
        }
    }
    c.configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .draw()?;
    Ok(())
}

/// The study's own check of its settings (the CLI's `--modes`).
pub fn check_modes(n: usize) -> Result<(), String> {
    if (2..=MAX_MODES).contains(&n) {
        Ok(())
    } else {
        Err(format!("--modes {n} must be 2 to {MAX_MODES}"))
    }
}

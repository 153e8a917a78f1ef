//! The link's modes from any record with an input and the film: which inputs the record
//! holds, its spectra, the number of modes from a stabilization diagram, every resonance with
//! its uncertainty, and the controller's two (`docs/identification.md`).
//!
//! ## The model
//! Linearized at rest, mode `j` of link 2 obeys (`flexarm_core::model`, `B_δδ = I`)
//! `δ̈_j + 2ζ_jω_j δ̇_j + ω_j² δ_j = −(a1 cos θ2 · v_j + w_j) θ̈1 − w_j θ̈2 + k_a Δφ'_j V_a`,
//! and the film reads `V_f = k_s Σ_j Δφ'_j δ_j` through its amplifier's high-pass `HP(s)`. With
//! the joints held by a servo the hubs move with the link, and the film's response to the
//! patch alone has the poles of the *held* arm, the link's coupled with the hold (on the
//! paper's arm mode 1 moves by several per cent). The controller's model needs the *clamped*
//! link's. With the base's motion measured and taken as an input, the clamped poles are the
//! poles again: at `θ2 = ±π/2` the two joints' accelerations enter as one, `α̈ = θ̈1 + θ̈2`, and
//! `V_f = HP(s) Σ_j (g_j V_a − c_j α̈) / (s² + 2ζ_jω_j s + ω_j²)` with `g_j = k_a k_s Δφ'_j²`
//! (the piezo→film product per mode) and `c_j = k_s Δφ'_j w_j`. The base enters as the angle
//! `α` with a numerator from `s²` on.
//!
//! ## Which inputs
//! - the patch, when its command moves;
//! - the base, when the joints travel at least [`MIN_TRAVEL`] encoder steps *and* something
//!   other than the patch moved them: with the patch the only excitation, the base's motion is
//!   the patch's response through the hold and the two inputs cannot be told apart (a fit
//!   with both would split the response between them at will). The share of the base's power
//!   the patch explains (their coherence over 20 of Welch's segments of the record, weighted
//!   by the base's power) must stay under [`MAX_EXPLAINED`]; without the patch the base is the
//!   only input (torque taps).
//!
//! Without the base the modes are the held arm's, and the report and the model step say so.
//!
//! ## The band and the spectra
//! The band is what the inputs cover (the lines where the patch's power is within 30 dB of its
//! peak, where the base's is ten times the encoders' quantization noise), from the third line
//! up, to 0.4 of the sampling rate, or the user's. Spectra: [`super::spectra`].
//!
//! ## Five lengths
//! Where a record ends moves its whole-record spectrum, and a rational fit can spend a spare
//! order on what that leaves: on the truth plant's modes record, one cut in 36 listed a 5.79 Hz
//! resonance the arm does not have and kept it as mode 2. And it can settle on one of two
//! solutions a little apart: on the QEMU arm's modes record over the link, mode 2 came out at
//! 14.16 Hz at one length in ten and 14.35 Hz at the others, each with a standard deviation of
//! 0.09 Hz, and one length in fifteen refused outright (a spurious undamped pole beside a
//! mode). On 20 such records (`flexarm --qemu identify modes` and `cargo fw-link`), each
//! started at 14 different samples, three lengths (the whole, less 1 and 2 %, two confirming,
//! the first that agrees used) gave a mode 2 off by more than 1.5 % for 5 of the 280 and
//! refused 4; the rule below gave both modes within 1.5 % for all 280. The record is fitted
//! again less its last [`TRIMS`] (0.5 to 2 %, in the whole record's band), and a resonance
//! counts as the record's when most of the lengths that fit (at least two) find it (within `2
//! F_TOL`). The lengths that agree are those whose resonances up to their highest kept mode are
//! all the record's and that miss none of the record's there; of them the fit used is the
//! longest whose controller's modes lie within 1 % (`F_TOL`, a stable pole's tolerance) of
//! their median, else the one nearest it. The report says when a shorter copy's was used and
//! which resonances above the kept ones were found at one length only. When no length agrees,
//! the fit refuses (gate `consistency`, each length's resonances listed); when no shorter copy
//! fits, the whole record's stands, unchecked, and the report says so. A whole record's fit
//! that found the modes but does not resolve them (two resonances whose half-power bands meet,
//! a damping ratio as uncertain as itself, a product below) is a finding of one length too:
//! when at least three shorter copies fit, the choice is made among them and the report quotes
//! the refusal. Any other refusal of the whole record's stands: on the family's long arm, a
//! torque-tap record whose whole record saw no mode 2 has three shorter copies that agree on a
//! 6.79 Hz resonance the arm does not have.
//!
//! ## Three quarters
//! The five lengths differ by 2 % at most: they catch where a record ends, not a record too
//! short for its modes. A short record's whole-record window can fit resonances that are not
//! the arm's and vouch for them: on the QEMU arm (modes 4.716 and 14.395 Hz), a 7.1 s modes
//! record over the link (`flexarm --qemu --arm identify modes OUT --seconds 5`) gave mode 1 at
//! 5.017 ± 0.030 Hz, 6 % and ten standard deviations off, and passed every other gate. So the
//! record's first [`PART`] (three quarters) is fitted too, in its own band (one fit, and its
//! five lengths when that one does not vouch): when it is refused, or its controller's modes
//! are not the whole record's (within `2 F_TOL`), the fit refuses (gate `record length`, the
//! shortest record that could pass: four thirds of this one). On that record the three quarters
//! were refused (a mode 2 product known to 17 %; `host/tests/identify.rs` keeps the record);
//! records of 11.0, 13.6, 20.0 and 40.5 s of the same arm pass, their three quarters within 0.3
//! % of them, and those of 7.6, 9.5 and 10.2 s are refused the same way. The check costs a fit
//! more, and records: a record must be a third longer than the shortest whose fit is right. On
//! the family's random records (`Kind::Random`, 11 to 21 s) it refused four: three whose fits
//! were right (the patch arm's at 11 and 15 s, within 0.3 %, and the long arm's at 15 s, within
//! 0.5 %) and the payload arm's at 21 s (its three quarters refused by the gate `modes`),
//! asking for 15 to 28 s; the lab's records (60 to 120 s) all pass
//! (`host/tests/identify_family.rs`).
//!
//! # A faint patch
//!
//! A patch excited far below the amplifier's window (1 V or 10 mV of noise where the lab's
//! records use 100 V, the base's torque noise as usual) leaves its part of the film's reading
//! under the film's noise, and the fit, which has the film in its regressor, then gives
//! piezo→film products of noise: on the family's arms 1.7 to 95 times the truth's, some of
//! them negative (which the sign test above reads as a reversed film). Their spreads tell:
//! 9 % to 2.6 times the product on those records; on the kept modes of every fit `cargo sim
//! identify family` accepts, at most 4.6 % (3.1 % on its model-grade records). A kept mode
//! whose product's spread exceeds [`G_SPREAD`] (10 %, the bound the family's products are
//! checked to) is refused (gate `uncertainty`, a finding of one length: shorter copies that
//! resolve it outvote it, as above); `bad_records_are_refused_with_the_gate` in
//! `host/tests/identify_family.rs` has the case.

use rustfft::num_complex::Complex64;

use super::IdentifyError;
use super::order::{self, DiagramPole, Selection};
use super::record::{self, Layout, ModesRecord};
use super::spectra::{self, Method, Spectra};

/// Encoder steps the base must travel before it is an input.
pub const MIN_TRAVEL: f64 = 20.0;
/// Samples a window starts before its pulse.
const PRE: usize = 4;

/// How a record is fitted.
#[derive(Clone, Debug, PartialEq)]
pub struct FitSettings {
    /// The band [Hz]; `None`: from the record (module docs).
    pub band: Option<(f64, f64)>,
    /// The controller's modes, numbered from 1 upwards among those found.
    pub keep: Vec<usize>,
    /// Most modes the stabilization diagram makes room for.
    pub max_modes: usize,
    /// Welch's segment [s] for a stationary record; `None`: from the record.
    pub segment: Option<f64>,
}

impl Default for FitSettings {
    /// The band from the record, modes 1 and 2, room for 8, segments from the record.
    fn default() -> Self {
        Self {
            band: None,
            keep: vec![1, 2],
            max_modes: 8,
            segment: None,
        }
    }
}

/// An input of the fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Input {
    /// The patch's command `V_a` [V].
    Patch,
    /// The base's angle `α = θ1 + θ2` [rad] (its acceleration drives the link).
    Base,
}

impl Input {
    /// Its name in the reports.
    pub fn name(self) -> &'static str {
        match self {
            Input::Patch => "the patch's command v_a",
            Input::Base => "the base's angle theta1 + theta2",
        }
    }
}

/// One resonance the fit found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IdentifiedMode {
    /// `ω_j` [rad/s].
    pub omega: f64,
    /// `ζ_j` [-].
    pub zeta: f64,
    /// `g_j = k_a k_s Δφ'_j²`, the piezo→film product [V/V·(rad/s)²] (`NaN` without the patch).
    pub piezo_film: f64,
    /// `c_j = k_s Δφ'_j w_j` [V·s²/rad·(rad/s)²] (`NaN` without the base).
    pub base_film: f64,
    /// Standard deviations of `ω` [rad/s], `ζ`, `g` and `c` (module docs of `rational`).
    pub sigma: [f64; 4],
    /// Mean coherence over the mode's half-power band, where meaningful.
    pub coherence: Option<f64>,
    /// Orders of the stabilization diagram the mode was stable over.
    pub stable: usize,
}

impl IdentifiedMode {
    /// Frequency [Hz].
    pub fn hz(&self) -> f64 {
        self.omega / std::f64::consts::TAU
    }
}

/// The modes fit's result.
#[derive(Clone, Debug, PartialEq)]
pub struct ModesFit {
    /// Every resonance found, ascending.
    pub all: Vec<IdentifiedMode>,
    /// The controller's modes (numbers into `all`, from 1), in the order asked.
    pub kept: Vec<usize>,
    /// The controller's modes themselves.
    pub modes: Vec<IdentifiedMode>,
    /// The inputs fitted.
    pub inputs: Vec<Input>,
    /// Why the modes are the held arm's, when the base is not an input.
    pub held: Option<String>,
    /// The band fitted [Hz].
    pub band: (f64, f64),
    /// The film amplifier's high-pass corner the fit found [Hz], if any.
    pub highpass_hz: Option<f64>,
    /// The spectra fitted.
    pub spectra: Spectra,
    /// The rational fit at the chosen order.
    pub fit: super::rational::RationalFit,
    /// The stabilization diagram.
    pub diagram: Vec<DiagramPole>,
    /// Room for modes of the chosen fit.
    pub order: usize,
    /// What the record held and what the fit chose, one sentence each.
    pub notes: Vec<String>,
}

fn gate<E: From<IdentifyError>>(name: &str, msg: String) -> E {
    IdentifyError::Data(format!("gate `{name}`: {msg}")).into()
}

/// Why one length's fit refused, and whether it found the controller's modes but does not
/// resolve them (two resonances whose half-power bands meet, a damping ratio as uncertain as
/// itself, a piezo→film product's spread over [`G_SPREAD`]): that is a finding of the length,
/// which the others may outvote ("Five lengths").
#[derive(Debug)]
struct Refusal {
    error: IdentifyError,
    unresolved: bool,
}

impl From<IdentifyError> for Refusal {
    fn from(error: IdentifyError) -> Self {
        Self {
            error,
            unresolved: false,
        }
    }
}

/// The gate `name` of a fit that found the modes but does not resolve them.
fn unresolved(name: &str, msg: String) -> Refusal {
    Refusal {
        error: gate(name, msg),
        unresolved: true,
    }
}

/// `E(ω) = (e^{jωT} − 1)/(jωT)` at `f` [Hz]: how a command that changes at random instants
/// between samples `T` [s] apart shows in the record (`super::modes`' docs).
pub fn command_advance(f: f64, dt: f64) -> Complex64 {
    let x = std::f64::consts::TAU * f * dt;
    (Complex64::new(0.0, x).exp() - 1.0) / Complex64::new(0.0, x)
}

/// How much the output `y` of a window still rings at its end: the RMS of its last
/// twentieth (from its first value) over its largest excursion.
fn ringing(y: &[f64]) -> f64 {
    let Some(&rest) = y.first() else {
        return 0.0;
    };
    let peak = y.iter().map(|v| (v - rest).abs()).fold(0.0, f64::max);
    let tail = &y[y.len() - y.len() / 20..];
    let rms =
        (tail.iter().map(|v| (v - rest).powi(2)).sum::<f64>() / tail.len().max(1) as f64).sqrt();
    if peak > 0.0 { rms / peak } else { 0.0 }
}

/// A window rings at its end above this share of its peak: a transient term (a burst) or an
/// exponential window (taps) takes it.
const RINGING: f64 = 0.02;
/// Taps whose response rings above this share when the next comes are refused.
const MAX_RINGING: f64 = 0.1;

/// How the spectra are to be taken.
#[derive(Clone)]
enum Plan {
    /// Whole windows; `taps`: pulses at their starts.
    Windows {
        len: usize,
        starts: Vec<usize>,
        taps: bool,
    },
    /// Welch's segments.
    Welch { len: usize },
}

/// Whether `x` changes in steps (at most one sample in twenty differs from the one before).
fn changes_in_steps(x: &[f64]) -> bool {
    let changes = x.windows(2).filter(|w| w[1] != w[0]).count();
    changes > 0 && changes * 20 <= x.len()
}

/// The lines of `sp` inside `band`.
fn restrict(sp: &Spectra, band: (f64, f64)) -> Spectra {
    let keep: Vec<usize> = (0..sp.freq.len())
        .filter(|&k| sp.freq[k] >= band.0 && sp.freq[k] <= band.1)
        .collect();
    let pick = |v: &[Vec<Complex64>]| keep.iter().map(|&k| v[k].clone()).collect();
    Spectra {
        freq: keep.iter().map(|&k| sp.freq[k]).collect(),
        rows: keep.iter().map(|&k| sp.rows[k].clone()).collect(),
        h: pick(&sp.h),
        coherence: sp
            .coherence
            .as_ref()
            .map(|c| keep.iter().map(|&k| c[k]).collect()),
        input_power: sp
            .input_power
            .iter()
            .map(|p| keep.iter().map(|&k| p[k]).collect())
            .collect(),
        ..sp.clone()
    }
}

/// The band `[lo, hi]` [Hz] where `covered` holds densely: from the lowest covered line from
/// which four fifths of the next octave's lines are covered, to the highest covered line
/// below which four fifths of the octave before are.
fn dense_band(freq: &[f64], covered: &[bool]) -> Option<(f64, f64)> {
    // Covered lines before each index, for the share of any range at once.
    let mut before = vec![0usize; freq.len() + 1];
    for (k, ok) in covered.iter().enumerate() {
        before[k + 1] = before[k] + usize::from(*ok);
    }
    let share = |lo: f64, hi: f64| {
        let (a, b) = (
            freq.partition_point(|f| *f < lo),
            freq.partition_point(|f| *f <= hi),
        );
        if b > a {
            (before[b] - before[a]) as f64 / (b - a) as f64
        } else {
            0.0
        }
    };
    let lo = freq
        .iter()
        .zip(covered)
        .find(|(f, ok)| **ok && share(**f, 2.0 * **f) >= 0.8)?
        .0;
    let hi = freq
        .iter()
        .zip(covered)
        .rev()
        .find(|(f, ok)| **ok && **f > *lo && share(**f / 2.0, **f) >= 0.8)?
        .0;
    Some((*lo, *hi))
}

/// Shares of the record its shorter copies leave out at its end (module docs, "Five
/// lengths").
pub const TRIMS: [f64; 4] = [0.005, 0.01, 0.015, 0.02];

/// The largest spread of a kept mode's piezo→film product, as a share of the product
/// (module docs, "A faint patch").
pub const G_SPREAD: f64 = 0.1;

/// Fits the record: which inputs, the spectra, the band, the stabilization diagram, every
/// resonance and the controller's modes (module docs); then checks the modes up to the
/// controller's against the record's shorter copies ("Five lengths") and against its first
/// three quarters ("Three quarters"). Each refusal names its gate.
pub fn fit_modes(rec: &ModesRecord, set: &FitSettings) -> Result<ModesFit, IdentifyError> {
    let fit = fit_lengths(rec, set)?;
    let n = rec.v_f.len();
    let part = (PART * n as f64).round() as usize;
    let (seconds, longer) = (n as f64 * rec.dt, (n as f64 * rec.dt / PART).ceil());
    let refuse = |what: String| -> IdentifyError {
        gate(
            "record length",
            format!(
                "its first {:.0} % ({:.1} s) {what}: modes that the record's length decides are not the arm's; a record of {seconds:.1} s is too short for them: record at least {longer:.0} s",
                100.0 * PART,
                part as f64 * rec.dt
            ),
        )
    };
    let whole_hz = Found::of(&fit).kept;
    // Why the first part does not vouch for the whole record's modes, if it does not.
    let disagree = |shorter: Result<ModesFit, IdentifyError>| -> Option<String> {
        let shorter = match shorter {
            Ok(f) => f,
            Err(e) => {
                // The refusal's gate, not its advice, which is for a record of that length.
                let why = e.to_string();
                return Some(format!(
                    "are refused ({})",
                    why.split(": ").next().unwrap_or(&why)
                ));
            }
        };
        let part_hz = Found::of(&shorter).kept;
        let same = whole_hz.len() == part_hz.len()
            && whole_hz
                .iter()
                .zip(&part_hz)
                .all(|(a, b)| order::same_mode(*a, *b));
        (!same).then(|| {
            format!(
                "give the controller's modes at {} Hz, the whole record at {} Hz",
                listed(&part_hz),
                listed(&whole_hz)
            )
        })
    };
    // One fit of the part first; only when it does not vouch, its five lengths, which settle
    // where a single length's end decides (a record that passes pays one fit more, not five).
    let head = rec.head(part);
    if disagree(fit_at_length(&head, set).map_err(|r| r.error)).is_none() {
        return Ok(fit);
    }
    match disagree(fit_lengths(&head, set)) {
        None => Ok(fit),
        Some(why) => Err(refuse(why)),
    }
}

/// Share of the record its check for length keeps (module docs, "Three quarters").
pub const PART: f64 = 0.75;

/// [`fit_modes`] without the check for length: the five lengths.
fn fit_lengths(rec: &ModesRecord, set: &FitSettings) -> Result<ModesFit, IdentifyError> {
    let whole = fit_at_length(rec, set);
    let n = rec.v_f.len();
    let same_band = FitSettings {
        band: whole.as_ref().ok().map(|w| w.band).or(set.band),
        ..set.clone()
    };
    let shorter: Vec<(usize, ModesFit)> = TRIMS
        .iter()
        .filter_map(|share| {
            let dropped = ((share * n as f64).round() as usize).max(1);
            let fit = fit_at_length(&rec.head(n - dropped), &same_band).ok()?;
            Some((dropped, fit))
        })
        .collect();
    agree(whole, shorter, rec.dt)
}

/// One length's fit as [`choose`] compares it: its resonances and its kept modes [Hz].
#[derive(Clone, Debug, PartialEq)]
struct Found {
    hz: Vec<f64>,
    kept: Vec<f64>,
}

impl Found {
    fn of(fit: &ModesFit) -> Self {
        Self {
            hz: fit.all.iter().map(IdentifiedMode::hz).collect(),
            kept: fit.kept.iter().map(|k| fit.all[k - 1].hz()).collect(),
        }
    }

    /// Its highest kept mode [Hz].
    fn top(&self) -> f64 {
        self.kept.iter().copied().fold(0.0, f64::max)
    }

    /// Its resonances at or below `top` [Hz].
    fn below(&self, top: f64) -> impl Iterator<Item = f64> + '_ {
        self.hz.iter().copied().filter(move |h| *h <= top)
    }

    /// Whether it found a resonance at `hz` [Hz] ([`order::same_mode`]).
    fn sees(&self, hz: f64) -> bool {
        self.hz.iter().any(|f| order::same_mode(*f, hz))
    }
}

/// Frequencies [Hz] as a message lists them: `4.716, 14.395`.
fn listed(hz: &[f64]) -> String {
    hz.iter()
        .map(|h| format!("{h:.3}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Whether most of the lengths that fit (at least two) found a resonance at `hz` [Hz].
fn confirmed(found: &[Found], hz: f64) -> bool {
    found.iter().filter(|f| f.sees(hz)).count() >= (found.len() / 2 + 1).max(2)
}

/// The middle of `x` (the mean of the two middle values of an even count).
fn median(mut x: Vec<f64>) -> f64 {
    x.sort_by(f64::total_cmp);
    let m = x.len() / 2;
    if x.len() % 2 == 1 {
        x[m]
    } else {
        0.5 * (x[m - 1] + x[m])
    }
}

/// Among the lengths whose resonances up to their highest kept mode are all confirmed and
/// that miss none confirmed there, the first (the longest) whose kept modes lie within
/// `F_TOL` of the median of theirs, else the one nearest it (module docs, "Five
/// lengths"), if any.
fn choose(found: &[Found]) -> Option<usize> {
    let agreeing: Vec<usize> = (0..found.len())
        .filter(|&i| {
            let f = &found[i];
            let top = f.top() * (1.0 + 2.0 * order::F_TOL);
            f.below(top).all(|h| confirmed(found, h))
                && found.iter().all(|g| {
                    g.below(top)
                        .filter(|h| confirmed(found, *h))
                        .all(|h| f.sees(h))
                })
        })
        .collect();
    let first = *agreeing.first()?;
    let middle: Vec<f64> = (0..found[first].kept.len())
        .map(|k| median(agreeing.iter().map(|&i| found[i].kept[k]).collect()))
        .collect();
    // Each kept mode of length `i` over the median of its kind.
    let ratios = |i: usize| found[i].kept.iter().zip(&middle).map(|(f, m)| f / m);
    let off = |i: usize| -> f64 { ratios(i).map(|r| r.ln().abs()).sum() };
    let near = |i: usize| ratios(i).all(|r| (r - 1.0).abs() <= order::F_TOL);
    agreeing.iter().copied().find(|&i| near(i)).or_else(|| {
        agreeing
            .into_iter()
            .min_by(|&a, &b| off(a).total_cmp(&off(b)))
    })
}

/// The fit of the record's five lengths (the whole record's `whole`, then its copies less
/// `dropped` samples) that [`choose`] takes (module docs, "Five lengths").
fn agree(
    whole: Result<ModesFit, Refusal>,
    shorter: Vec<(usize, ModesFit)>,
    dt: f64,
) -> Result<ModesFit, IdentifyError> {
    let length = |d: usize| match d {
        0 => "the whole record".to_string(),
        d => format!("the record less its last {:.3} s", d as f64 * dt),
    };
    let (mut fits, refusal) = match whole {
        Ok(w) => (vec![(0, w)], None),
        // A whole record that found the modes but does not resolve them is outvoted when
        // most of the lengths fit; any other refusal stands.
        Err(r) if r.unresolved && shorter.len() > TRIMS.len() / 2 => (Vec::new(), Some(r.error)),
        Err(r) => return Err(r.error),
    };
    fits.extend(shorter);
    let list = |f: &Found| listed(&f.hz);
    if fits.len() == 1 {
        let mut f = fits.swap_remove(0).1;
        f.notes
            .push("its shorter copies gave no fit: the modes are not checked against them".into());
        return Ok(f);
    }
    let found: Vec<Found> = fits.iter().map(|(_, f)| Found::of(f)).collect();
    let Some(i) = choose(&found) else {
        return Err(gate(
            "consistency",
            format!(
                "the record's fits at {} lengths disagree on the controller's modes: {}; a fit that moves with where the record ends is not the arm's: record longer, or with more excitation",
                fits.len(),
                fits.iter()
                    .zip(&found)
                    .map(|((d, _), f)| format!("{} found {} Hz", length(*d), list(f)))
                    .collect::<Vec<_>>()
                    .join("; ")
            ),
        ));
    };
    let why = match (refusal, fits[i].0) {
        // A refusal at one length only is, like a resonance found at one length only, where
        // the record ends and not the arm.
        (Some(e), d) => Some(format!(
            "the whole record's fit refused ({e}); its shorter copies agree: the fit of {} is used",
            length(d)
        )),
        (None, 0) => None,
        (None, d) => Some(format!(
            "the whole record's fit found {} Hz, its controller's modes off the median of the lengths that agree: the fit of {} is used",
            list(&found[0]),
            length(d)
        )),
    };
    let lone: Vec<String> = found[i]
        .hz
        .iter()
        .filter(|h| !confirmed(&found, **h))
        .map(|h| format!("{h:.3}"))
        .collect();
    let mut fit = fits.swap_remove(i).1;
    fit.notes.extend(why);
    if !lone.is_empty() {
        fit.notes.push(format!(
            "above the controller's modes, {} Hz found at this length only: not confirmed by the record's other lengths",
            lone.join(", ")
        ));
    }
    Ok(fit)
}

/// Fits the record as it is (module docs).
fn fit_at_length(rec: &ModesRecord, set: &FitSettings) -> Result<ModesFit, Refusal> {
    record::check_channels(rec)?;
    if set.keep.is_empty() || set.keep.contains(&0) {
        return Err(
            IdentifyError::Data(format!("modes {:?} kept: number them from 1", set.keep)).into(),
        );
    }
    let dt = rec.dt;
    let n = rec.v_f.len();
    let top = 0.4 / dt;
    let mut notes = Vec::new();
    let alpha = rec.alpha();
    let steps = [0, 1].map(|j| record::resolution(&rec.theta[j]));
    let lsb = match steps {
        [a, b] if a > 0.0 && b > 0.0 => a.min(b),
        [a, b] => a.max(b),
    };
    let travel = if lsb > 0.0 {
        (record::span(alpha.iter().copied()) / lsb).round()
    } else {
        0.0
    };
    let patch = record::span(rec.v_a.iter().copied()) > 0.0;
    let base_moves = travel >= MIN_TRAVEL;
    if !patch && !base_moves {
        return Err(gate(
            "excitation",
            format!(
                "no input: the patch's command never changes and the base moved {travel} encoder steps (at least {MIN_TRAVEL} make it an input): nothing the film's response can be referred to; a hammer's record is fitted by `identify decay`"
            ),
        ));
    }
    // The layout, from the excitation the lab drove: the patch's command, else the torque
    // that moved most.
    let torque =
        if record::span(rec.tau[1].iter().copied()) >= record::span(rec.tau[0].iter().copied()) {
            &rec.tau[1]
        } else {
            &rec.tau[0]
        };
    let primary: &[f64] = if patch { &rec.v_a } else { torque };
    let layout = record::layout(&[(primary, 0.0)], dt);
    // The inputs: the base when something other than the patch moved it.
    let mut inputs = Vec::new();
    if patch {
        inputs.push(Input::Patch);
    }
    if base_moves {
        inputs.push(Input::Base);
    }
    let mut held = (!base_moves).then(|| {
        format!(
            "the base moved {travel} encoder steps (fewer than {MIN_TRAVEL}): its motion is not resolved, so it is not an input"
        )
    });
    if inputs.len() == 2 {
        // How much of the base's motion the patch explains, from Welch's averages of the
        // record (20 segments: a coherence that means something).
        let probe = spectra::welch(
            &rec.v_f,
            &[&rec.v_a, &alpha],
            dt,
            welch_len(n, 2),
            (0.0, top),
        )?;
        let (share, own) = base_explained(&probe, lsb, dt);
        if share > MAX_EXPLAINED || own < MIN_OWN_MOTION {
            inputs.pop();
            held = Some(if share > MAX_EXPLAINED {
                format!(
                    "the base moved with the patch ({:.0} % of its motion's power is the patch's): the two cannot be told apart, so the base is not an input",
                    100.0 * share
                )
            } else {
                format!(
                    "the base's motion apart from the patch's is {own:.3} of a white quantization noise (at least {MIN_OWN_MOTION}): nothing but the patch and the hold's jitter moved it, so it is not an input"
                )
            });
        }
    }
    if let Some(h) = &held {
        notes.push(format!("{h}; the modes are the held arm's"));
    }
    let series = |i: &Input| -> &[f64] {
        match i {
            Input::Patch => &rec.v_a,
            Input::Base => &alpha,
        }
    };
    let take = |plan: &Plan| -> Result<Spectra, IdentifyError> {
        let u: Vec<&[f64]> = inputs.iter().map(series).collect();
        let mut sp = match plan {
            Plan::Windows { len, starts, taps } => {
                let ring: Vec<f64> = starts
                    .iter()
                    .map(|s| ringing(&rec.v_f[*s..*s + len]))
                    .collect();
                let worst = ring.iter().copied().fold(0.0, f64::max);
                if *taps {
                    // No transient term for taps (`spectra`); an exponential window when
                    // the response still rings at a window's end.
                    if worst > MAX_RINGING {
                        return Err(gate(
                            "record length",
                            format!(
                                "taps {:.2} s apart: the film still rings at {:.0} % of its peak when the next one comes (at most {:.0} %): space them at least {:.1} s apart, or lengthen the record after the last",
                                *len as f64 * dt,
                                100.0 * worst,
                                100.0 * MAX_RINGING,
                                *len as f64 * dt * (1.0 / MAX_RINGING).ln() / (1.0 / worst).ln()
                            ),
                        ));
                    }
                    let a = if worst > RINGING {
                        (1.0 / RINGING).ln() / (*len as f64 * dt)
                    } else {
                        0.0
                    };
                    let none = vec![false; starts.len()];
                    spectra::windows(&rec.v_f, &u, dt, (*len, starts, &none, a), (0.0, top))?
                } else {
                    let ends: Vec<bool> = ring.iter().map(|r| *r > RINGING).collect();
                    spectra::windows(&rec.v_f, &u, dt, (*len, starts, &ends, 0.0), (0.0, top))?
                }
            }
            Plan::Welch { len } => spectra::welch(&rec.v_f, &u, dt, *len, (0.0, top))?,
        };
        // A command in steps at random instants between samples (module docs of `modes`).
        if let Some(p) = inputs.iter().position(|i| *i == Input::Patch)
            && changes_in_steps(&rec.v_a)
        {
            for (f, rows) in sp.freq.iter().zip(sp.rows.iter_mut()) {
                let e = command_advance(*f, dt);
                for r in rows {
                    r.u[p] *= e;
                }
            }
            for (f, h) in sp.freq.iter().zip(sp.h.iter_mut()) {
                h[p] /= command_advance(*f, dt);
            }
        }
        Ok(sp)
    };
    let whole = Plan::Windows {
        len: n,
        starts: vec![0],
        taps: false,
    };
    let m = inputs.len();
    let (plan, mut sp) = match &layout {
        Layout::Pulses(p) => {
            let starts: Vec<usize> = p.iter().map(|x| x.start.saturating_sub(PRE)).collect();
            let gaps: Vec<usize> = starts.windows(2).map(|w| w[1] - w[0]).collect();
            let last = n - starts.last().copied().unwrap_or(0);
            let mut len = gaps.iter().copied().min().unwrap_or(last);
            let mut starts = starts;
            if last < len {
                if 5 * last >= 4 * len || starts.len() == 1 {
                    len = last;
                } else {
                    starts.pop();
                }
            }
            notes.push(format!(
                "{} taps of {}: each tap's window of {:.2} s transformed whole",
                starts.len(),
                if patch { "the patch" } else { "a motor" },
                len as f64 * dt
            ));
            let plan = Plan::Windows {
                len,
                starts,
                taps: true,
            };
            let sp = take(&plan)?;
            if sp.shift > 0.0 {
                notes.push(format!(
                    "the film still rings when the next tap comes: an exponential window of {:.3} s⁻¹ (the fit evaluates at s = a + jω, so the poles need no correction)",
                    sp.shift
                ));
            }
            (plan, sp)
        }
        Layout::Burst { start, end } => {
            notes.push(format!(
                "one burst of excitation ({:.2}–{:.2} s) with rest after it: the whole record as one window",
                *start as f64 * dt,
                *end as f64 * dt
            ));
            let sp = take(&whole)?;
            (whole.clone(), sp)
        }
        Layout::Stationary => {
            // Welch where 10 m segments each resolve a mode of ζ = 0.02 at the band's bottom
            // with four lines (100 periods of it); else the record whole.
            let sp = take(&whole)?;
            let low = coverage(&sp, &inputs, lsb, dt).map_or(1.0, |b| b.0);
            let low = set.band.map_or(low, |b| b.0.max(low));
            let need = match set.segment {
                Some(s) => (s / dt).round() as usize,
                None => ((RESOLVE_PERIODS / low) / dt).ceil() as usize,
            };
            let segments = spectra::welch_segments(n, need);
            if set.segment.is_some() || segments >= spectra::COHERENCE_AVERAGES_PER_INPUT * m {
                let plan = Plan::Welch { len: need };
                let sp = take(&plan)?;
                if let Method::Welch { len, segments } = sp.method {
                    notes.push(format!(
                        "a stationary record: Welch's spectra over {segments} segments of {:.2} s (Hann, half overlap)",
                        len as f64 * dt
                    ));
                }
                (plan, sp)
            } else {
                notes.push(format!(
                    "a stationary record too short for Welch's segments ({} of {:.1} s would be needed to resolve the band's bottom, {low:.3} Hz, and average {} times): the whole record as one window, a transient term for its ends",
                    spectra::COHERENCE_AVERAGES_PER_INPUT * m,
                    need as f64 * dt,
                    spectra::COHERENCE_AVERAGES_PER_INPUT * m
                ));
                (whole.clone(), sp)
            }
        }
    };
    // The band.
    let covered_band = coverage(&sp, &inputs, lsb, dt);
    let band = match set.band {
        Some((lo, hi)) => {
            if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && hi > lo) {
                return Err(IdentifyError::Data(format!(
                    "a band of {lo}–{hi} Hz: give 0 < low < high"
                ))
                .into());
            }
            if let Some((clo, chi)) = covered_band
                && (lo < 0.5 * clo || hi > 2.0 * chi)
            {
                return Err(gate(
                    "excitation band",
                    format!(
                        "the inputs cover {clo:.3}–{chi:.1} Hz; the band asks {lo}–{hi} Hz: no excitation where the band reaches beyond it"
                    ),
                ));
            }
            (lo, hi.min(top))
        }
        None => {
            let (clo, chi) = covered_band.ok_or_else(|| {
                gate::<IdentifyError>(
                    "excitation band",
                    "no band where an input's power stands above its floor".into(),
                )
            })?;
            (clo.max(3.0 * sp.df()), chi.min(top))
        }
    };
    let low: Vec<usize> = inputs
        .iter()
        .map(|i| if *i == Input::Base { 2 } else { 0 })
        .collect();
    let mut selection = order::select(&restrict(&sp, band), &low, band, set.max_modes)?;
    // Welch's lines must resolve the modes' half-power bands (four lines each under the
    // Hann window); else the whole record as one window.
    if let Plan::Welch { .. } = plan {
        let narrowest = selection
            .modes_hz
            .iter()
            .filter_map(|f| mode_at(&selection, *f))
            .map(|(w, z)| 2.0 * z * w / std::f64::consts::TAU)
            .fold(f64::INFINITY, f64::min);
        if narrowest < 4.0 * sp.df() {
            notes.push(format!(
                "Welch's lines {:.3} Hz apart are too coarse for a half-power band of {narrowest:.3} Hz: the whole record as one window instead",
                sp.df()
            ));
            sp = take(&whole)?;
            selection = order::select(&restrict(&sp, band), &low, band, set.max_modes)?;
        }
    }
    // Why the band starts where it does: what a mode below it would need.
    let bottom = match (set.band, covered_band) {
        (Some(_), _) => Bottom::Asked,
        (None, Some((clo, _))) if clo >= RESOLVED_LINES * sp.df() => Bottom::Excitation,
        _ => Bottom::Length(n as f64 * dt, RESOLVED_LINES * sp.df()),
    };
    let resolved = RESOLVED_LINES * sp.df();
    let sp = restrict(&sp, band);
    let fit = finish(sp, selection, inputs, held, (band, resolved), set, notes)?;
    lowest_is_first(&fit, bottom)?;
    products_resolved(&fit)?;
    Ok(fit)
}

/// The gate `uncertainty` on the kept modes' piezo→film products: none known no better than
/// [`G_SPREAD`] of itself (module docs, "A faint patch"). After the band's and the length's
/// gates, whose diagnosis of a record that misses a mode is the more useful.
fn products_resolved(fit: &ModesFit) -> Result<(), Refusal> {
    let Some((k, m)) = fit
        .kept
        .iter()
        .zip(&fit.modes)
        .find(|(_, m)| m.sigma[2] > G_SPREAD * m.piezo_film)
    else {
        return Ok(());
    };
    Err(unresolved(
        "uncertainty",
        format!(
            "mode {k} at {:.3} Hz: a piezo→film product of {:.4e} ± {:.1e} V/V·s⁻², known no better than {:.0} %: the patch's excitation is too faint, or the record too short, for the film to show it; excite the patch near the amplifier's window, or record longer",
            m.hz(),
            m.piezo_film,
            m.sigma[2],
            G_SPREAD * 100.0
        ),
    ))
}

/// Where the band's bottom comes from.
enum Bottom {
    /// The user's `--band`.
    Asked,
    /// Where the excitation's power starts.
    Excitation,
    /// The record's resolution: its length [s], and the lowest mode it resolves [Hz].
    Length(f64, f64),
}

/// The lowest mode a record resolves is `RESOLVED_LINES` lines up: there a mode of `ζ = 0.05`
/// spans a line of its half-power band `2ζf`, and its period fits ten times in the record.
const RESOLVED_LINES: f64 = 10.0;

/// The gates `excitation band` and `record length`: mode 1 kept must be the link's first, and
/// the fit can only vouch for that when the band reaches an octave below it (a collocated
/// patch's response is flat below its first mode, so a mode there would have shown).
fn lowest_is_first(fit: &ModesFit, bottom: Bottom) -> Result<(), IdentifyError> {
    let (Some(first), true) = (fit.all.first(), fit.kept.contains(&1)) else {
        return Ok(());
    };
    let f1 = first.hz();
    let lo = match bottom {
        Bottom::Length(_, resolved) => resolved.max(fit.band.0),
        _ => fit.band.0,
    };
    if lo <= 0.5 * f1 {
        return Ok(());
    }
    match bottom {
        Bottom::Asked => Ok(()),
        Bottom::Excitation => Err(gate(
            "excitation band",
            format!(
                "the excitation covers the band from {lo:.3} Hz only: a mode below it would go unseen, so the lowest found ({f1:.3} Hz) is not known to be the link's first; excite down to {:.3} Hz (an octave below it), or name the band (--band) if no mode lies there",
                0.5 * f1
            ),
        )),
        Bottom::Length(seconds, _) => Err(gate(
            "record length",
            format!(
                "a record of {seconds:.1} s resolves from {lo:.3} Hz only: too short for modes down to {:.3} Hz (an octave below the lowest found, {f1:.3} Hz): record at least {:.0} s",
                0.5 * f1,
                seconds * lo / (0.5 * f1)
            ),
        )),
    }
}

/// Periods of the band's bottom a Welch segment must hold: four lines in the half-power band
/// `2ζf` of a mode of `ζ = 0.02` there.
const RESOLVE_PERIODS: f64 = 100.0;
/// Share of the base's motion the patch may explain for the base to stay an input.
const MAX_EXPLAINED: f64 = 0.9;
/// The base's own motion (the power the patch does not explain) over a white quantization
/// noise of `lsb²/12` a sample, at least, for the base to stay an input: a hold's jitter of a
/// count or two is not an excitation the fit can use. That floor overstates a slowly moving
/// encoder's noise, whose errors are not white: on the family a PD hold's jitter under a
/// patch's chirp gives 0.004 to 0.02 of it, noise of 2 N·m on joint 2's torque 0.57 to 0.68;
/// the threshold sits between.
const MIN_OWN_MOTION: f64 = 0.1;

/// Welch's segment for `n` samples and `m` inputs: the longest that still gives
/// `10 m` averages with half overlap, so that the coherence means something (`spectra`).
/// (Counted as [`spectra::welch_segments`] counts them, down from just above `2n/(10m + 1)`:
/// that length alone falls one segment short of `10 m` at one record length in twenty, and the
/// coherence it was for is then refused.)
fn welch_len(n: usize, m: usize) -> usize {
    let want = spectra::COHERENCE_AVERAGES_PER_INPUT * m.max(1);
    let mut len = (2 * n / (want + 1) + 2).max(16);
    while len > 16 && spectra::welch_segments(n, len) < want {
        len -= 1;
    }
    len
}

/// The share of the base's power the patch explains, `Σ |G_12|²/G_11 / Σ G_22` over the
/// lines, and the base's power the patch does not explain over the encoders' quantization
/// floor, from Welch's spectra `sp` of the patch and the base (1 and 0 without the averages
/// to tell: `spectra`).
fn base_explained(sp: &Spectra, lsb: f64, dt: f64) -> (f64, f64) {
    if sp.averages < spectra::COHERENCE_AVERAGES_PER_INPUT * 2 {
        return (1.0, 0.0);
    }
    let floor = Floor::of(sp, lsb, dt);
    // Welch's rows are G_{y u_j}, G_{u_i u_j} scaled by 1/√G_jj (`spectra`).
    let (mut explained, mut total, mut noise) = (0.0, 0.0, 0.0);
    for (rows, f) in sp.rows.iter().zip(&sp.freq) {
        if rows.len() != 2 {
            continue;
        }
        let g11 = rows[0].u[0].re.powi(2);
        let g22 = rows[1].u[1].re.powi(2);
        let g12 = rows[1].u[0] * rows[1].u[1].re;
        if g11 > 0.0 {
            explained += g12.norm_sqr() / g11;
            total += g22;
            noise += floor.at(*f);
        }
    }
    if total > 0.0 {
        (
            explained / total,
            (total - explained) / noise.max(f64::MIN_POSITIVE),
        )
    } else {
        (1.0, 0.0)
    }
}

/// The band the record's excitation covers (module docs): the patch's when it moves, else
/// the base's; `None` when it covers none.
fn coverage(sp: &Spectra, inputs: &[Input], lsb: f64, dt: f64) -> Option<(f64, f64)> {
    // The first input is the record's excitation (the patch's, when it moves).
    let input = inputs.first()?;
    let power = &sp.input_power[0];
    let peak = power.iter().copied().fold(0.0, f64::max);
    let floor = Floor::of(sp, lsb, dt);
    let covered: Vec<bool> = sp
        .freq
        .iter()
        .zip(power)
        .map(|(f, p)| match input {
            Input::Patch => *p >= 1e-3 * peak && *p > 0.0,
            Input::Base => *p >= 10.0 * floor.at(*f),
        })
        .collect();
    dense_band(&sp.freq, &covered)
}

/// The expected power of an encoder's quantization noise (white, `lsb²/12` a sample) on one
/// line of a record's spectra.
struct Floor {
    /// Per line, before the first difference Welch takes.
    level: f64,
    /// Welch's first difference (divided by the period `dt`): its gain at `f` scales `level`.
    differenced: Option<f64>,
}

impl Floor {
    fn of(sp: &Spectra, lsb: f64, dt: f64) -> Self {
        let var = lsb * lsb / 12.0;
        match &sp.method {
            Method::Windows { len, .. } => {
                // Σ of the exponential window's squares over a window.
                let r = (-2.0 * sp.shift * dt).exp();
                let taper = if r < 1.0 {
                    (1.0 - r.powi(*len as i32)) / (1.0 - r)
                } else {
                    *len as f64
                };
                Self {
                    level: sp.averages as f64 * taper * var,
                    differenced: None,
                }
            }
            // Hann-tapered: Σw² = 3 len / 8.
            Method::Welch { len, segments } => Self {
                level: *segments as f64 * 3.0 * *len as f64 / 8.0 * var,
                differenced: Some(dt),
            },
        }
    }

    fn at(&self, f: f64) -> f64 {
        match self.differenced {
            Some(dt) => {
                self.level * 2.0 * (1.0 - (std::f64::consts::TAU * f * dt).cos()) / (dt * dt)
            }
            None => self.level,
        }
    }
}

/// The chosen fit's pole nearest to `hz`, as `(ω, ζ)`.
fn mode_at(sel: &Selection, hz: f64) -> Option<(f64, f64)> {
    super::rational::modes(&sel.fit)
        .0
        .iter()
        .min_by(|a, b| {
            (a.omega / std::f64::consts::TAU - hz)
                .abs()
                .total_cmp(&(b.omega / std::f64::consts::TAU - hz).abs())
        })
        .map(|m| (m.omega, m.zeta))
}

/// The modes of the chosen fit, their products and spreads, and the controller's.
fn finish(
    sp: Spectra,
    sel: Selection,
    inputs: Vec<Input>,
    held: Option<String>,
    (band, resolved): ((f64, f64), f64),
    set: &FitSettings,
    mut notes: Vec<String>,
) -> Result<ModesFit, Refusal> {
    let fit = &sel.fit;
    let (found, other) = super::rational::modes(fit);
    let highpass_hz = other
        .iter()
        .filter(|p| p.re < 0.0)
        .map(|p| p.norm() / std::f64::consts::TAU)
        .filter(|f| *f < band.1)
        .reduce(f64::min);
    let hp = |p: Complex64| match highpass_hz {
        Some(f) => p / (p + std::f64::consts::TAU * f),
        None => Complex64::new(1.0, 0.0),
    };
    let tau = std::f64::consts::TAU;
    let patch = inputs.iter().position(|i| *i == Input::Patch);
    let base = inputs.iter().position(|i| *i == Input::Base);
    // Σ g/(s² + 2ζωs + ω²) has the residue g / (2j Im p) at p; the base's angle enters as
    // −s² c/(…): its residue is −p² c HP(p) / (2j Im p).
    let product = |i: usize, p: Complex64, r: Complex64| -> f64 {
        let k = Complex64::new(0.0, 2.0 * p.im) / hp(p);
        if Some(i) == base {
            (-r * k / (p * p)).re
        } else {
            (r * k).re
        }
    };
    // The same order at the other weight: how far each number moves with it is part of its
    // uncertainty (the residuals' covariance alone knows nothing of the model's own error).
    let other_tilt = order::TILTS
        .iter()
        .copied()
        .find(|t| *t != sel.tilt)
        .unwrap_or(sel.tilt);
    let other =
        super::rational::fit(&sp, &order::shape(sel.chosen, &fit.low, other_tilt, false)).ok();
    let other_modes = other
        .as_ref()
        .map_or(Vec::new(), |o| super::rational::modes(o).0);
    let mut all = Vec::new();
    for m in &found {
        let hz = m.omega / tau;
        if m.zeta <= 0.0 || !sel.modes_hz.iter().any(|f| order::same_mode(*f, hz)) {
            continue;
        }
        let stable = sel
            .diagram
            .iter()
            .filter(|p| order::same_mode(p.hz, hz))
            .map(|p| p.run + 1)
            .max()
            .unwrap_or(1);
        let value = |i: usize| product(i, m.pole, fit.residue(i, m.pole));
        let (sw, sz, sv) = fit.spread(m.pole, product);
        // The other weight's estimate of this mode, if it has one within the tolerance.
        let moved = other.as_ref().and_then(|o| {
            let q = other_modes.iter().min_by(|a, b| {
                (a.omega - m.omega)
                    .abs()
                    .total_cmp(&(b.omega - m.omega).abs())
            })?;
            order::same_mode(q.omega, m.omega).then(|| {
                let v = |i: usize| product(i, q.pole, o.residue(i, q.pole));
                (
                    (q.omega - m.omega).abs(),
                    (q.zeta - m.zeta).abs(),
                    (0..inputs.len())
                        .map(|i| (v(i) - value(i)).abs())
                        .collect::<Vec<_>>(),
                )
            })
        });
        let both = |a: f64, b: Option<f64>| (a * a + b.map_or(0.0, |b| b * b / 4.0)).sqrt();
        let half = (m.zeta * hz).max(sp.df());
        let coherence = sp.coherence.as_ref().map(|c| {
            let near: Vec<f64> = sp
                .freq
                .iter()
                .zip(c)
                .filter(|(x, _)| (**x - hz).abs() <= half)
                .map(|(_, c)| *c)
                .collect();
            near.iter().sum::<f64>() / near.len().max(1) as f64
        });
        all.push(IdentifiedMode {
            omega: m.omega,
            zeta: m.zeta,
            piezo_film: patch.map_or(f64::NAN, value),
            base_film: base.map_or(f64::NAN, value),
            sigma: [
                both(sw, moved.as_ref().map(|d| d.0)),
                both(sz, moved.as_ref().map(|d| d.1)),
                patch.map_or(f64::NAN, |i| both(sv[i], moved.as_ref().map(|d| d.2[i]))),
                base.map_or(f64::NAN, |i| both(sv[i], moved.as_ref().map(|d| d.2[i]))),
            ],
            coherence,
            stable,
        });
    }
    if patch.is_some() {
        let reversed = all.iter().filter(|m| m.piezo_film < 0.0).count();
        if reversed > 0 && reversed == all.len() {
            return Err(gate(
                "physical consistency",
                "every piezo→film product comes out negative: the film's sign is reversed (run `flexarm bringup`, or flip the recording's v_f), or the patch's excitation is too faint for the film to show it (the fit then gives the products of noise: excite the patch near the amplifier's window)".into(),
            ));
        }
        // A collocated patch and film make every mode's product `k_a k_s Δφ'²` positive:
        // a pole pair with a negative one is the fit's, not the link's.
        let artefacts = all.iter().filter(|m| m.piezo_film <= 0.0).count();
        if artefacts > 0 {
            notes.push(format!(
                "{artefacts} pole pair(s) with a negative piezo→film product left out (a collocated patch and film make it positive: the fit's, not the link's)"
            ));
        }
        all.retain(|m| m.piezo_film > 0.0);
    }
    all.sort_by(|a, b| a.omega.total_cmp(&b.omega));
    // Two resonances whose half-power bands (±ζf) meet cannot be told apart by any record:
    // such a pair is the fit splitting one response, or modes no record resolves.
    if let Some(w) = all
        .windows(2)
        .find(|w| w[1].hz() - w[0].hz() < w[0].zeta * w[0].hz() + w[1].zeta * w[1].hz())
    {
        return Err(unresolved(
            "modes",
            format!(
                "resonances at {:.3} Hz (ζ {:.4}) and {:.3} Hz (ζ {:.4}) overlap (their half-power bands meet): the record does not tell them apart; record longer, or excite the base and the patch at once",
                w[0].hz(),
                w[0].zeta,
                w[1].hz(),
                w[1].zeta
            ),
        ));
    }
    let list = all
        .iter()
        .map(|m| format!("{:.3} Hz", m.hz()))
        .collect::<Vec<_>>()
        .join(", ");
    let mut modes = Vec::new();
    for &k in &set.keep {
        let Some(m) = all.get(k - 1) else {
            return Err(gate(
                "modes",
                format!(
                    "mode {k} not seen: the fit found {} mode(s) in {:.3}–{:.1} Hz ({}); the excitation did not reach mode {k}, or it lies outside the band, or the record is too short for it (a record of {:.1} s resolves modes from {resolved:.2} Hz up)",
                    all.len(),
                    band.0,
                    band.1,
                    if list.is_empty() {
                        "none".into()
                    } else {
                        list.clone()
                    },
                    RESOLVED_LINES / resolved
                ),
            ));
        };
        // A damping ratio whose spread is as large as itself is not resolved.
        if m.sigma[1] >= m.zeta {
            return Err(unresolved(
                "uncertainty",
                format!(
                    "mode {k} at {:.3} Hz: a damping ratio of {:.4} ± {:.4}: the record does not resolve it; record longer, or excite the base and the patch at once",
                    m.hz(),
                    m.zeta,
                    m.sigma[1]
                ),
            ));
        }
        modes.push(*m);
    }
    notes.push(format!(
        "the stabilization diagram: {} mode(s) stable over at least {} orders; the fit with room for {} mode(s)",
        all.len(),
        order::RUN + 1,
        sel.chosen
    ));
    Ok(ModesFit {
        all,
        kept: set.keep.clone(),
        modes,
        inputs,
        held,
        band,
        highpass_hz,
        spectra: sp,
        fit: sel.fit,
        diagram: sel.diagram,
        order: sel.chosen,
        notes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A length's fit that found `hz` and kept its first two.
    fn found(hz: &[f64]) -> Found {
        Found {
            hz: hz.to_vec(),
            kept: hz[..2].to_vec(),
        }
    }

    /// The lengths' rule (module docs, "Five lengths"): the whole record's fit when the
    /// others confirm it; a shorter copy's when the whole record's holds a resonance below its
    /// kept modes that no other length finds (the truth plant's 5.79 Hz), or misses one the
    /// others find; none when every length keeps a mode of its own; a lone resonance above the
    /// kept modes does not count.
    #[test]
    fn the_lengths_confirm_each_other() {
        let arm = [4.55, 25.7];
        let agreeing = [found(&arm), found(&arm), found(&arm)];
        assert_eq!(choose(&agreeing), Some(0));
        let spurious = [found(&[4.55, 5.79, 25.7]), found(&arm), found(&arm)];
        assert_eq!(choose(&spurious), Some(1));
        let missed = [
            found(&arm),
            found(&[4.55, 14.0, 25.7]),
            found(&[4.55, 14.0, 25.7]),
        ];
        assert_eq!(choose(&missed), Some(1));
        let apart = [found(&[4.5, 6.0]), found(&[4.5, 7.0]), found(&[4.5, 8.0])];
        assert_eq!(choose(&apart), None);
        let above = [found(&[4.55, 25.7, 40.0]), found(&arm), found(&arm)];
        assert_eq!(choose(&above), Some(0));
        assert!(!confirmed(&above, 40.0) && confirmed(&above, 25.7 * 1.01));
    }

    /// Of five lengths a resonance takes three; of the lengths that agree, the longest near
    /// their median is used: the QEMU arm's record over the link, whose whole record found
    /// mode 2 at 14.16 Hz where most of its shorter copies found 14.35 (the two within
    /// `2 F_TOL`, one resonance to the vote).
    #[test]
    fn most_lengths_decide_and_the_median_one_is_used() {
        let link = [
            found(&[4.718, 14.164]),
            found(&[4.726, 14.345]),
            found(&[4.726, 14.346]),
            found(&[4.711, 14.174]),
            found(&[4.726, 14.344]),
        ];
        assert_eq!(choose(&link), Some(1), "the longest near the median");
        let mut missed_whole = link.clone();
        missed_whole.swap(0, 1);
        assert_eq!(
            choose(&missed_whole),
            Some(0),
            "the whole record's when it is near"
        );
        let two_of_five = [
            found(&[4.7, 9.0, 14.3]),
            found(&[4.7, 9.0, 14.3]),
            found(&[4.7, 14.3]),
            found(&[4.7, 14.3]),
            found(&[4.7, 14.3]),
        ];
        assert!(!confirmed(&two_of_five, 9.0) && confirmed(&two_of_five, 14.3));
        assert_eq!(choose(&two_of_five), Some(2));
    }

    /// Welch's segment leaves the probe its `10 m` averages at every record length (one
    /// length in twenty fell one short before it counted them as `spectra::welch` does).
    #[test]
    fn welch_segments_give_the_averages_asked() {
        for m in 1..=2 {
            let want = spectra::COHERENCE_AVERAGES_PER_INPUT * m;
            for n in 400..30_000 {
                let len = welch_len(n, m);
                assert!(
                    spectra::welch_segments(n, len) >= want,
                    "n {n}, m {m}: {len}"
                );
                // The longest that does: one sample more falls short.
                assert!(
                    spectra::welch_segments(n, len + 1) < want || len == 16,
                    "n {n}, m {m}"
                );
            }
        }
    }
}

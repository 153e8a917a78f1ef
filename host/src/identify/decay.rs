//! Free decay: taps on the link with the joints held, and the film's decay after each.
//!
//! ## The experiment
//! At the modes experiment's pose, the piezo loop off (`k_c = 0`), the patch gives the link
//! [`DecayPlan::taps`] short pulses of `±volts` (alternating signs), [`DecayPlan::spacing`]
//! seconds apart; between them the link rings down while the servo holds the joints. A tap
//! by the patch, not by a motor: the patch's moment acts on the link alone, a drive takes a
//! bias while holding (one parameter write on, one off), and the joints' servo would take a
//! torque pulse on a motor as a disturbance to reject. On a board the pulse's width is the
//! link's timing; only the decay after it is fitted, so its shape does not matter.
//!
//! ## What the decay shows
//! The held arm's modes, not the clamped link's: the servo holds the hubs, the link's vibration
//! moves them, and the decay's poles are those of the link coupled with the servo and the
//! controller's model (the first link mode lies near a mode of the servo holding the joints,
//! and the decay shares itself between them as the tap excites them; `docs/identification.md`).
//! So the decay is a check of a model, not a source of its parameters: the same experiment simulated on the controller
//! built from a model predicts the decay ([`predict`]), and the identified model must predict
//! what the arm does.
//!
//! ## The taps a record holds
//! A record's taps are found in it, whatever made them ([`Tapper`]): pulses of the patch's
//! command `v_a`; else torque pulses of a motor on top of the hold's torque (`tau1`, `tau2`),
//! which start with the film at rest; else the film's own onsets, where it starts to ring
//! after a second at rest (a hammer's strikes, which no channel records). The report says
//! which, how many, how wide, how far apart and how strong, as the record holds them.
//!
//! ## The fit
//! The film's decays after the taps, each sign-corrected, are averaged (noise falls as the
//! square root of their number); above 150 Hz of sampling the record is low-passed first (a
//! Hann-windowed sinc, linear in time: the decay's exponentials pass it unchanged, delayed)
//! and decimated. The averaged decay `y_k = Σ a_i z_i^k` goes through the matrix pencil (Hua
//! and Sarkar): the Hankel matrix of `y`, its `order` leading right singular vectors `V`, the
//! poles `z_i` the eigenvalues of `V₁⁺ V₂` (`V` without its last and its first row), the
//! amplitudes by least squares. A mode is a pole pair in the band with `0 < ζ < 1` whose
//! amplitude is at least 5 % of the largest; the film amplifier's high-pass shows as a real
//! pole. Every mode found is reported, ascending, with its amplitude.

use flexarm_core::Vector2;
use flexarm_core::control::piezo::PiezoPatch;
use flexarm_core::params::ArmParams;
use flexarm_core::trajectory::JointTrajectory;
use nalgebra::DMatrix;
use rustfft::num_complex::Complex64;

use super::IdentifyError;
use super::modes::Excitation;
use super::record::{MAX_TAP as MAX_RECORDED_TAP, ModesRecord, Pulse};
use crate::sim::{Sample, SimConfig};

/// The experiment's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DecayPlan {
    /// The held pose [rad].
    pub pose: Vector2<f64>,
    /// Number of taps.
    pub taps: usize,
    /// The patch's voltage during a tap [V].
    pub volts: f64,
    /// Length of a tap [s].
    pub width: f64,
    /// Time from one tap to the next [s].
    pub spacing: f64,
}

impl Default for DecayPlan {
    /// 10 taps of ±100 V for 20 ms, 3 s apart, at `(0, π/2)`.
    fn default() -> Self {
        Self {
            pose: Vector2::new(0.0, std::f64::consts::FRAC_PI_2),
            taps: 10,
            volts: 100.0,
            width: 0.02,
            spacing: 3.0,
        }
    }
}

/// Holding time before the first tap [s].
const LEAD: f64 = 0.5;
/// The longest tap a plan asks [s].
const MAX_TAP: f64 = 0.5;

impl DecayPlan {
    /// Length of the record [s].
    pub fn seconds(&self) -> f64 {
        LEAD + self.taps as f64 * self.spacing
    }

    /// The taps as the patch's bias schedule, joint 2 held at the pose throughout.
    pub fn excitation(&self) -> Result<Excitation, IdentifyError> {
        let bad = |m: String| Err(IdentifyError::Data(m));
        if !(1..=200).contains(&self.taps) {
            return bad(format!("{} taps: give 1 to 200", self.taps));
        }
        if !(self.volts.is_finite() && self.volts > 0.0) {
            return bad(format!("taps of {} V: give more than 0 V", self.volts));
        }
        if !(self.width.is_finite() && self.width > 0.0 && self.width <= MAX_TAP) {
            return bad(format!("taps of {} s: give 0 to {MAX_TAP} s", self.width));
        }
        if !(self.spacing.is_finite() && self.spacing >= 1.0 && self.spacing <= 60.0) {
            return bad(format!("taps {} s apart: give 1 to 60 s", self.spacing));
        }
        let mut bias = vec![(0.0, 0.0)];
        for k in 0..self.taps {
            let t = LEAD + k as f64 * self.spacing;
            let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
            bias.push((t, sign * self.volts));
            bias.push((t + self.width, 0.0));
        }
        Ok(Excitation {
            bias,
            moves: vec![(0.0, JointTrajectory::Hold(self.pose.cast::<f32>()))],
        })
    }
}

/// Runs the experiment on the simulator (`cfg`: its plant, controller and sensors; its piezo
/// loop is turned off), with the encoders' readings as a board records them.
pub fn decay_experiment(cfg: &SimConfig, plan: &DecayPlan) -> Result<Vec<Sample>, IdentifyError> {
    let ex = plan.excitation()?;
    super::modes::run_excitation(cfg, &ex, plan.seconds(), "the decay experiment")
}

/// How the decays are fitted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DecaySettings {
    /// Modes the decay must show (the link's, the strongest in the film).
    pub modes: usize,
    /// The band [Hz].
    pub band: (f64, f64),
    /// Length of each decay fitted [s] (shorter when the taps are closer).
    pub window: f64,
    /// Poles of the pencil.
    pub order: usize,
}

impl Default for DecaySettings {
    /// Two modes in 1.5–40 Hz, 2.5 s of each decay, 12 poles.
    fn default() -> Self {
        Self {
            modes: 2,
            band: (1.5, 40.0),
            window: 2.5,
            order: 12,
        }
    }
}

impl DecaySettings {
    /// The default settings for the band `(low, high)` [Hz] of a record sampled every `dt`
    /// [s]: each decay at least three periods of `low` long (a first mode of 0.5 Hz needs 6 s
    /// between taps), `high` at most 0.4 of the sampling rate. `None` is the default band, its
    /// top lowered to 0.4 of the rate. An error names `--band` and the limit it broke.
    pub fn for_band(band: Option<(f64, f64)>, dt: f64) -> Result<Self, String> {
        let d = Self::default();
        let top = 0.4 / dt;
        let Some((low, high)) = band else {
            return Ok(Self {
                band: (d.band.0, d.band.1.min(top)),
                ..d
            });
        };
        if !(low.is_finite() && high.is_finite() && low > 0.0 && high > low) {
            return Err(format!(
                "--band {low},{high}: give LOW,HIGH in Hz with 0 < LOW < HIGH"
            ));
        }
        if high > top {
            return Err(format!(
                "--band {low},{high}: the record's {:.0} samples a second reach {top:.1} Hz at most",
                1.0 / dt
            ));
        }
        Ok(Self {
            band: (low, high),
            // Three periods and a tenth more: the decimation's whole samples must not cut
            // the decay under the `record length` gate's three periods.
            window: d.window.max(3.3 / low),
            ..d
        })
    }
}

/// One mode of the held arm's decay.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DecayMode {
    /// `ω` [rad/s].
    pub omega: f64,
    /// `ζ` [-].
    pub zeta: f64,
    /// Amplitude in the averaged decay's first sample [V].
    pub amplitude: f64,
}

/// The decay fit's result.
#[derive(Clone, Debug, PartialEq)]
pub struct DecayFit {
    /// Every mode the pencil found in the band, ascending (see [`DecayFit::strongest`]).
    pub modes: Vec<DecayMode>,
    /// Taps averaged.
    pub taps: usize,
    /// Sampling period of the averaged decay [s].
    pub dt: f64,
    /// The averaged decay of the film [V].
    pub decay: Vec<f64>,
    /// The pencil's reconstruction of it [V].
    pub fitted: Vec<f64>,
    /// The taps the record held.
    pub held: Taps,
}

impl DecayFit {
    /// The `n` modes of largest amplitude, ascending in frequency: the link's, which the film
    /// sees best (the servo's modes of the held joints ring in it too, weakly).
    pub fn strongest(&self, n: usize) -> Vec<DecayMode> {
        let mut m = self.modes.clone();
        m.sort_by(|a, b| b.amplitude.total_cmp(&a.amplitude));
        m.truncate(n);
        m.sort_by(|a, b| a.omega.total_cmp(&b.omega));
        m
    }

    /// The mode nearest to `omega` [rad/s] in frequency ratio.
    pub fn nearest(&self, omega: f64) -> Option<DecayMode> {
        let gap = |m: &DecayMode| (m.omega / omega).ln().abs();
        self.modes
            .iter()
            .copied()
            .min_by(|a, b| gap(a).total_cmp(&gap(b)))
    }
}

/// A mode whose amplitude is under this share of the largest is the pencil's, not the arm's.
const ARTEFACT_SHARE: f64 = 0.05;
/// Samples per second above which the record is low-passed and decimated, at least: the
/// default band's top (40 Hz) is then under 0.27 of the decimated rate, below the low-pass's
/// cutoff (0.4 of it). A higher band keeps 3.75 times its top ([`decimation`]).
const DECIMATE_ABOVE: f64 = 150.0;

/// The decimation factor for a record sampled every `dt` [s] and a band up to `high` [Hz]:
/// down to about `max(150, 3.75 high)` samples a second, never below `3 high`.
fn decimation(dt: f64, high: f64) -> usize {
    let rate = 1.0 / dt;
    let mut factor = (rate / DECIMATE_ABOVE.max(3.75 * high)).ceil().max(1.0) as usize;
    while factor > 1 && rate / (factor as f64) < 3.0 * high {
        factor -= 1;
    }
    factor
}

/// Fits the film's decays (`v_f`) after the taps in `rec`: the patch's, a motor's or a
/// hammer's (module docs).
pub fn fit_decay(rec: &ModesRecord, set: &DecaySettings) -> Result<DecayFit, IdentifyError> {
    super::record::check_channels(rec)?;
    let bad = |m: String| Err(IdentifyError::Data(m));
    let (held, taps) = find_taps(rec)?;
    // The low-pass and decimation, when the record is fast.
    let factor = decimation(rec.dt, set.band.1);
    let (v_f, delay) = if factor > 1 {
        lowpass(&rec.v_f, rec.dt, factor)
    } else {
        (rec.v_f.clone(), 0)
    };
    // Each decay from two samples after its tap ended (the command returns between samples)
    // and the filter's delay, to two samples before the next tap (an amplifier's slew) or the
    // window's end.
    let skip = 2 + delay;
    let mut windows = Vec::new();
    for (i, tap) in taps.iter().enumerate() {
        let start = tap.end + skip;
        let stop = taps
            .get(i + 1)
            .map_or(rec.v_f.len(), |next| next.start.saturating_sub(2))
            .min(start + (set.window / rec.dt) as usize);
        if stop > start {
            windows.push((start, stop - start, tap.sign));
        }
    }
    let len = windows.iter().map(|w| w.1).min().unwrap_or(0) / factor;
    let dt = rec.dt * factor as f64;
    let lowest = set.band.0;
    if (len as f64) * dt < 3.0 / lowest {
        return bad(format!(
            "gate `record length`: decays of {:.2} s: too short for modes down to {lowest} Hz, which need {:.1} s between taps",
            len as f64 * dt,
            3.0 / lowest
        ));
    }
    let decay: Vec<f64> = (0..len)
        .map(|k| {
            windows
                .iter()
                .map(|(start, _, sign)| sign * v_f[start + k * factor])
                .sum::<f64>()
                / windows.len() as f64
        })
        .collect();
    if decay.iter().all(|v| *v == decay[0]) {
        return bad(
            "gate `excitation`: no decay: the film's voltage does not move after the taps".into(),
        );
    }
    let (poles, amplitudes) = pencil(&decay, set.order)?;
    let fitted: Vec<f64> = (0..len)
        .map(|k| {
            poles
                .iter()
                .zip(&amplitudes)
                .map(|(z, a)| (a * z.powu(k as u32)).re)
                .sum()
        })
        .collect();
    let mut modes: Vec<DecayMode> = poles
        .iter()
        .zip(&amplitudes)
        .filter(|(z, _)| z.im > 0.0)
        .map(|(z, a)| {
            let s = z.ln() / dt;
            DecayMode {
                omega: s.norm(),
                zeta: -s.re / s.norm(),
                amplitude: 2.0 * a.norm(),
            }
        })
        .filter(|m| {
            let f = m.omega / std::f64::consts::TAU;
            f >= set.band.0 && f <= set.band.1 && m.zeta > 0.0 && m.zeta < 1.0
        })
        .collect();
    let largest = modes.iter().map(|m| m.amplitude).fold(0.0, f64::max);
    modes.retain(|m| m.amplitude >= ARTEFACT_SHARE * largest);
    modes.sort_by(|a, b| a.omega.total_cmp(&b.omega));
    if modes.len() < set.modes {
        let k = modes.len() + 1;
        return bad(format!(
            "gate `modes`: mode {k} not seen in the decay: the pencil found {} mode(s) in {}–{} Hz; the taps did not reach mode {k}, or it lies outside the band",
            modes.len(),
            set.band.0,
            set.band.1
        ));
    }
    Ok(DecayFit {
        modes,
        taps: windows.len(),
        dt,
        decay,
        fitted,
        held,
    })
}

/// What tapped the arm in a record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tapper {
    /// Pulses of the patch's command `v_a`.
    Patch,
    /// Torque pulses of motor 0 or 1 on top of the hold's torque.
    Motor(usize),
    /// Strikes no channel recorded (a hammer's), found where the film starts to ring.
    Hammer,
}

impl std::fmt::Display for Tapper {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Tapper::Patch => f.write_str("taps of the patch (its command `v_a`)"),
            Tapper::Motor(j) => write!(
                f,
                "torque pulses on joint {} (`tau{}`, on top of the hold's)",
                j + 1,
                j + 1
            ),
            Tapper::Hammer => f.write_str(
                "strikes no channel recorded (a hammer's), found where the film starts to ring",
            ),
        }
    }
}

/// The taps a record held, as its fit found them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Taps {
    /// What tapped the arm.
    pub tapper: Tapper,
    /// Taps found.
    pub count: usize,
    /// The median tap's width [s] (0 for a hammer's strikes).
    pub width: f64,
    /// The median time from one tap to the next [s] (NaN for one tap).
    pub spacing: f64,
    /// The largest tap's level against the channel's rest [V or N·m] (NaN for a hammer's).
    pub level: f64,
}

impl std::fmt::Display for Taps {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} {}", self.count, self.tapper)?;
        match self.tapper {
            Tapper::Patch => write!(f, ", up to {:.3} V", self.level)?,
            Tapper::Motor(_) => write!(f, ", up to {:.3} N·m", self.level)?,
            Tapper::Hammer => {}
        }
        if self.tapper != Tapper::Hammer {
            write!(f, ", {:.3} s wide", self.width)?;
        }
        if self.spacing.is_finite() {
            write!(f, ", {:.2} s apart", self.spacing)?;
        }
        Ok(())
    }
}

/// The median of `x` (NaN when empty).
fn median(mut x: Vec<f64>) -> f64 {
    x.sort_by(f64::total_cmp);
    x.get(x.len() / 2).copied().unwrap_or(f64::NAN)
}

/// Share of the film's largest excursion under which it is at rest when a motor's pulse
/// starts: a motor's tap comes before the film rings, the hold's reaction to a strike after.
const FILM_AT_REST: f64 = 0.2;

/// The record's taps and what made them: the patch's pulses (refused when they last longer
/// than a tap), else a motor's torque pulses that start with the film at rest, else the film's
/// onsets (a hammer's strikes). Refused (gate `excitation`) when none is found.
fn find_taps(rec: &ModesRecord) -> Result<(Taps, Vec<Pulse>), IdentifyError> {
    let summary = |tapper, p: &[Pulse], level: f64| Taps {
        tapper,
        count: p.len(),
        width: median(
            p.iter()
                .map(|t| (t.end - t.start) as f64 * rec.dt)
                .collect(),
        ),
        spacing: median(
            p.windows(2)
                .map(|w| (w[1].start - w[0].start) as f64 * rec.dt)
                .collect(),
        ),
        level,
    };
    let patch = taps(&rec.v_a);
    if !patch.is_empty() {
        let longest = patch.iter().map(|t| t.end - t.start).max().unwrap_or(0) as f64 * rec.dt;
        if longest > MAX_RECORDED_TAP {
            return Err(IdentifyError::Data(format!(
                "gate `excitation`: no tap in `v_a`: its pulses last up to {longest:.2} s, a tap at most {MAX_RECORDED_TAP} s (is this a decay experiment's record?)"
            )));
        }
        let level = rec.v_a.iter().map(|v| v.abs()).fold(0.0, f64::max);
        return Ok((summary(Tapper::Patch, &patch, level), patch));
    }
    let film_rest = rec.v_f.first().copied().unwrap_or(0.0);
    let film_peak = rec
        .v_f
        .iter()
        .map(|v| (v - film_rest).abs())
        .fold(0.0, f64::max);
    for j in [1, 0] {
        let p = super::record::pulses(&rec.tau[j], rec.dt);
        let before_film =
            |t: &Pulse| (rec.v_f[t.start] - film_rest).abs() < FILM_AT_REST * film_peak;
        if !p.is_empty() && p.iter().all(before_film) {
            let rest = median(rec.tau[j].clone());
            let level = rec.tau[j]
                .iter()
                .map(|v| (v - rest).abs())
                .fold(0.0, f64::max);
            return Ok((summary(Tapper::Motor(j), &p, level), p));
        }
    }
    let strikes = onsets(&rec.v_f, rec.dt);
    if strikes.is_empty() {
        return Err(IdentifyError::Data(
            "gate `excitation`: no tap: the patch's command, the motors' torques and the film show none (a decay record holds taps of the patch, torque pulses or a hammer's strikes, seconds apart)".into(),
        ));
    }
    Ok((summary(Tapper::Hammer, &strikes, f64::NAN), strikes))
}

/// The film's onsets: where its excursion from rest (its first sample) first passes half its
/// largest after at least a second under [`FILM_AT_REST`] of it; each a tap of no width,
/// signed by the excursion.
fn onsets(v_f: &[f64], dt: f64) -> Vec<Pulse> {
    let rest = v_f.first().copied().unwrap_or(0.0);
    let peak = v_f.iter().map(|v| (v - rest).abs()).fold(0.0, f64::max);
    let quiet = (1.0 / dt) as usize;
    let mut out = Vec::new();
    let mut calm = 0;
    let mut armed = false;
    for (k, v) in v_f.iter().enumerate() {
        let e = (v - rest).abs();
        calm = if e < FILM_AT_REST * peak { calm + 1 } else { 0 };
        if calm >= quiet {
            armed = true;
        }
        if armed && e > 0.5 * peak {
            out.push(Pulse {
                start: k,
                end: k,
                sign: (v - rest).signum(),
            });
            armed = false;
        }
    }
    out
}

/// The pulses of `v_a`: from a sample beyond half its largest magnitude to the next sample at
/// (almost) zero (an amplifier slews in between).
fn taps(v_a: &[f64]) -> Vec<Pulse> {
    let peak = v_a.iter().map(|v| v.abs()).fold(0.0, f64::max);
    let (on, off) = (0.5 * peak, 1e-3 * peak);
    let mut out = Vec::new();
    let mut open: Option<(usize, f64)> = None;
    for (k, v) in v_a.iter().enumerate() {
        match open {
            None if v.abs() > on => open = Some((k, v.signum())),
            Some((start, sign)) if v.abs() <= off => {
                out.push(Pulse {
                    start,
                    end: k,
                    sign,
                });
                open = None;
            }
            _ => {}
        }
    }
    out
}

/// `x` (sampled every `dt` [s]) through a Hann-windowed sinc low-pass for decimation by
/// `factor`, its cutoff at 0.4 of the decimated rate (57 Hz from 1 kHz): the filtered signal
/// and the filter's length [samples] (causal, so a decay is free of the tap that many samples
/// later in it).
fn lowpass(x: &[f64], dt: f64, factor: usize) -> (Vec<f64>, usize) {
    let fc = 0.4 / (dt * factor as f64);
    // Taps for a transition about a fifth of the cutoff wide.
    let n = ((4.0 / (0.2 * fc * dt)).ceil() as usize) | 1;
    let mid = (n / 2) as f64;
    let mut h: Vec<f64> = (0..n)
        .map(|i| {
            let t = i as f64 - mid;
            let sinc = if t == 0.0 {
                2.0 * fc * dt
            } else {
                (std::f64::consts::TAU * fc * dt * t).sin() / (std::f64::consts::PI * t)
            };
            let w = 0.5 - 0.5 * (std::f64::consts::TAU * i as f64 / (n - 1) as f64).cos();
            sinc * w
        })
        .collect();
    let sum: f64 = h.iter().sum();
    h.iter_mut().for_each(|v| *v /= sum);
    let y = (0..x.len())
        .map(|k| {
            h.iter()
                .enumerate()
                .take(k + 1)
                .map(|(i, hi)| hi * x[k - i])
                .sum()
        })
        .collect();
    (y, n)
}

/// The matrix pencil of `y` with `order` poles: the poles `z_i` and their amplitudes `a_i`,
/// `y_k ≈ Σ a_i z_i^k`.
fn pencil(y: &[f64], order: usize) -> Result<(Vec<Complex64>, Vec<Complex64>), IdentifyError> {
    let n = y.len();
    let l = n / 3;
    if l <= order || n - l <= order {
        return Err(IdentifyError::Data(format!(
            "{n} samples of decay: too few for {order} poles"
        )));
    }
    let hankel = DMatrix::from_fn(n - l, l + 1, |i, j| y[i + j]);
    let svd = hankel.svd(false, true);
    let v_t = svd
        .v_t
        .ok_or_else(|| IdentifyError::Data("the decay's SVD failed".into()))?;
    // The leading right singular vectors as columns, (l + 1) × order.
    let v = v_t.rows(0, order).transpose();
    let v1 = v.rows(0, l).into_owned();
    let v2 = v.rows(1, l).into_owned();
    let a = v1
        .pseudo_inverse(1e-12)
        .map_err(|e| IdentifyError::Data(format!("the pencil: {e}")))?
        * v2;
    let poles: Vec<Complex64> = a.complex_eigenvalues().iter().copied().collect();
    // Amplitudes: least squares on the Vandermonde system.
    let vander = DMatrix::from_fn(n, order, |k, i| poles[i].powu(k as u32));
    let rhs = DMatrix::from_fn(n, 1, |k, _| Complex64::new(y[k], 0.0));
    let amplitudes = vander
        .svd(true, true)
        .solve(&rhs, 1e-12)
        .map_err(|e| IdentifyError::Data(format!("the decay's amplitudes: {e}")))?;
    Ok((poles, amplitudes.iter().copied().collect()))
}

/// The excitation a record shows: its patch command `v_a` as the bias, level by level, and a
/// hold at the record's first reference, for `(excitation, seconds)`: replayed on a model
/// ([`predict`]), the model sees the taps the arm saw, whatever their width (on a board, the
/// link's timing).
pub fn replay(trace: &[Sample]) -> Result<(Excitation, f64), IdentifyError> {
    let first = trace
        .first()
        .ok_or_else(|| IdentifyError::Data("the record is empty".into()))?;
    let dt = super::even_period(trace)?;
    let mut bias = vec![(0.0, first.v_a)];
    for w in trace.windows(2) {
        if w[1].v_a != w[0].v_a {
            bias.push((w[1].t - first.t, w[1].v_a));
        }
    }
    let pose = first.q_d.cast::<f32>();
    let seconds = trace.len() as f64 * dt;
    Ok((
        Excitation {
            bias,
            moves: vec![(0.0, JointTrajectory::Hold(pose))],
        },
        seconds,
    ))
}

/// The decay the controller built from `arm` and `patch` predicts for the excitation `ex` of
/// `seconds` (a plan's, or a record's [`replay`]): the same experiment on the simulator with
/// that model as the plant (`cfg`'s controller settings, rates and sensors), fitted the same
/// way.
pub fn predict(
    cfg: &SimConfig,
    arm: &ArmParams<f64>,
    patch: &PiezoPatch<f64>,
    (ex, seconds): (&Excitation, f64),
    set: &DecaySettings,
) -> Result<DecayFit, IdentifyError> {
    let model = SimConfig {
        arm: *arm,
        patch: *patch,
        plant: None,
        truth: None,
        ..*cfg
    };
    let trace = super::modes::run_excitation(&model, ex, seconds, "the predicted decay")?;
    let window = (f64::from(cfg.limits.v_a_min), f64::from(cfg.limits.v_a_max));
    let rec = ModesRecord::from_trace(&trace, cfg.sensors.adc_range, window)?;
    fit_decay(&rec, set)
}

//! The link's modes, with the joints held.
//!
//! ## What is measured, and why the base's motion is an input
//! Linearized at rest, mode `j` of link 2 obeys (`flexarm_core::model`, `B_δδ = I`)
//! `δ̈_j + 2ζ_jω_j δ̇_j + ω_j² δ_j = −(a1 cos θ2 · v_j + w_j) θ̈1 − w_j θ̈2 + k_a Δφ'_j V_a`,
//! and the film reads `V_f = k_s Σ_j Δφ'_j δ_j` through its amplifier's high-pass. The joints
//! are held by the servo, not clamped: the link's vibration moves the hubs, and the held
//! arm's modes are those of the link coupled with the servo (on the paper's arm the first one
//! is far from the clamped link's, which is what the controller's model needs). With the
//! hubs' motion measured and taken as an input, the clamped modes are the poles again: at
//! `θ2 = ±π/2` the two accelerations enter as one, the link's absolute angular acceleration
//! `α̈ = θ̈1 + θ̈2`, so the film is a two-input system
//! `V_f = Σ_j (g_j V_a − c_j α̈) HP(s) / (s² + 2ζ_jω_j s + ω_j²)` with
//! `g_j = k_a k_s Δφ'_j²` (the piezo→film product the issue asks per mode) and
//! `c_j = k_s Δφ'_j w_j`. The fit takes the encoders' `α = θ1 + θ2`, differenced twice, as
//! the second input.
//!
//! ## The experiment
//! At the pose `(θ1, θ2) = (0, π/2)` rad, the piezo loop off (`k_c = 0`), blocks of
//! [`ModesPlan::block`] seconds alternate: in one the arm holds while the patch's bias steps at
//! random between `±piezo_volts` (a new level every 20 to 120 ms: on a board each is one
//! parameter write, and a drive takes the bias only while holding); in the next the bias is 0
//! while joint 2's reference makes random small moves (`±tap` rad about the pose, 0.15 to
//! 0.5 s each, longer where a drive's acceleration limit asks, the last back to the pose): the
//! servo's torque pulses shake the link's base. The two inputs are then excited apart, and the
//! responses hold across the blocks (the system is the same). The record is the patch's command, the film ADC and both encoders at the motor
//! rate.
//!
//! ## The patch's command between samples
//! The bias changes at a piezo period, between two motor samples: a step shows at the next
//! sample, on average half a period after it happened. Over many steps at random instants the
//! recorded command relates to the applied one by the average of that advance,
//! `E(ω) = (e^{jωT} − 1)/(jωT)` (`T` the record's period), which the fit takes out of the
//! patch's response: at 25 Hz and 1 kHz a phase of 4.5°, at 14 Hz and 100 Hz (the QEMU board)
//! 26°.

use flexarm_core::Vector2;
use flexarm_core::trajectory::JointTrajectory;
use rustfft::num_complex::Complex64;

use super::IdentifyError;
use super::frf::{self, Frf};
use super::rational::{self, FittedMode, RationalFit};
use crate::sim::{Rng, Sample, SimConfig, simulate_excited};

/// The experiment's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModesPlan {
    /// The held pose [rad]; `θ2 = ±π/2` makes the base one input.
    pub pose: Vector2<f64>,
    /// Length of the record [s].
    pub seconds: f64,
    /// Amplitude of the patch's bias steps [V].
    pub piezo_volts: f64,
    /// Amplitude of joint 2's moves about the pose [rad].
    pub tap: f64,
    /// Length of each block, the patch's or the moves' [s].
    pub block: f64,
    /// Seed of the random steps.
    pub seed: u64,
}

impl Default for ModesPlan {
    /// 60 s at `(0, π/2)` in blocks of 5 s, ±100 V, ±0.05 rad.
    fn default() -> Self {
        Self {
            pose: Vector2::new(0.0, std::f64::consts::FRAC_PI_2),
            seconds: 60.0,
            piezo_volts: 100.0,
            tap: 0.05,
            block: 5.0,
            seed: 7,
        }
    }
}

/// The excitation of a [`ModesPlan`]: the patch's bias steps and joint 2's moves.
#[derive(Clone, Debug, PartialEq)]
pub struct Excitation {
    /// `(from [s], bias [V])`, in order, the first at 0 (0 V through the moves' blocks).
    pub bias: Vec<(f64, f64)>,
    /// `(start [s], trajectory)`, in order, the first at 0: a hold at the pose through the
    /// patch's blocks, trapezoids through the moves'.
    pub moves: Vec<(f64, JointTrajectory<f32>)>,
}

impl Excitation {
    /// The bias at `t` [s].
    pub fn bias_at(&self, t: f64) -> f64 {
        let i = self.bias.partition_point(|(from, _)| *from <= t);
        self.bias[i.saturating_sub(1)].1
    }
}

/// The random excitation of `plan`.
pub fn excitation(plan: &ModesPlan) -> Result<Excitation, IdentifyError> {
    let bad = |m: String| Err(IdentifyError::Data(m));
    if !(plan.seconds.is_finite() && plan.seconds > 0.0 && plan.seconds <= 3600.0) {
        return bad(format!("a record of {} s: give 0 to 3600 s", plan.seconds));
    }
    if !(plan.piezo_volts.is_finite() && plan.piezo_volts >= 0.0) {
        return bad(format!(
            "a bias of {} V: give 0 V or more",
            plan.piezo_volts
        ));
    }
    if !(plan.tap.is_finite() && plan.tap >= 0.0 && plan.tap <= 0.2) {
        return bad(format!("moves of {} rad: give 0 to 0.2 rad", plan.tap));
    }
    if !(plan.block.is_finite() && (1.0..=60.0).contains(&plan.block)) {
        return bad(format!("blocks of {} s: give 1 to 60 s", plan.block));
    }
    let mut rng = Rng::new(plan.seed);
    let pose = plan.pose;
    let (mut bias, mut moves) = (Vec::new(), Vec::new());
    let mut t = 0.0;
    let mut patch = true;
    while t < plan.seconds {
        let end = (t + plan.block).min(plan.seconds);
        if patch {
            moves.push((t, JointTrajectory::Hold(pose.cast::<f32>())));
            while t < end {
                let sign = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
                bias.push((t, sign * plan.piezo_volts));
                t += 0.02 + 0.1 * rng.uniform();
            }
        } else {
            bias.push((t, 0.0));
            let mut from = pose;
            loop {
                let time = 0.15 + 0.35 * rng.uniform();
                let last = t + time + 0.3 >= end;
                let to = if last {
                    pose
                } else {
                    Vector2::new(pose.x, pose.y + plan.tap * (2.0 * rng.uniform() - 1.0))
                };
                let time = if last { 0.3 } else { time }.max(super::least_time(from, to));
                moves.push((t, super::trapezoid(from, to, time)?));
                from = to;
                t += time;
                if last {
                    break;
                }
            }
        }
        patch = !patch;
    }
    Ok(Excitation { bias, moves })
}

/// What the experiment records, one sample per motor period.
#[derive(Clone, Debug, PartialEq)]
pub struct ModesRecord {
    /// Sampling period [s].
    pub dt: f64,
    /// The patch's command as applied `V_a` [V].
    pub v_a: Vec<f64>,
    /// The film's voltage as the ADC reads it `V_f` [V].
    pub v_f: Vec<f64>,
    /// The encoders' angles `θ1`, `θ2` [rad].
    pub theta: [Vec<f64>; 2],
    /// The film ADC's range `±v_f_range` [V]: readings at its ends are clipped.
    pub v_f_range: f64,
    /// The amplifier's window `[v_a_min, v_a_max]` [V]: commands at its ends are clipped.
    pub v_a_window: (f64, f64),
}

impl ModesRecord {
    /// The channels of a trace (`crate::output::read_csv`: a simulator's run or a board's
    /// recording, `flexarm record`): its angles, `v_a` and `v_f`, which must be sampled
    /// evenly (a gap, lost frames, is refused with its time).
    pub fn from_trace(
        trace: &[Sample],
        v_f_range: f64,
        v_a_window: (f64, f64),
    ) -> Result<Self, IdentifyError> {
        let dt = super::even_period(trace)?;
        Ok(Self {
            dt,
            v_a: trace.iter().map(|x| x.v_a).collect(),
            v_f: trace.iter().map(|x| x.v_f).collect(),
            theta: [
                trace.iter().map(|x| x.x.q.x).collect(),
                trace.iter().map(|x| x.x.q.y).collect(),
            ],
            v_f_range,
            v_a_window,
        })
    }
}

/// Runs the experiment on the simulator (`cfg`: its plant, controller and sensors; its piezo
/// loop is turned off). The trace's angles are the encoders' readings, as a board records
/// them.
pub fn modes_experiment(cfg: &SimConfig, plan: &ModesPlan) -> Result<Vec<Sample>, IdentifyError> {
    run_excitation(
        cfg,
        &excitation(plan)?,
        plan.seconds,
        "the modes experiment",
    )
}

/// Runs `seconds` of the excitation `ex` on the simulator (`cfg`, its piezo loop off; `what`
/// names the experiment in errors), with the encoders' readings as a board records them.
pub fn run_excitation(
    cfg: &SimConfig,
    ex: &Excitation,
    seconds: f64,
    what: &str,
) -> Result<Vec<Sample>, IdentifyError> {
    let run = SimConfig {
        piezo: None,
        duration: seconds,
        tail_window: seconds.min(1.0),
        ..*cfg
    };
    let (_, trace) = simulate_excited(&run, &ex.moves, &|t| ex.bias_at(t))
        .map_err(|e| IdentifyError::Sim(format!("{what}: {e}")))?;
    Ok(super::encoder_readings(&cfg.sensors, trace))
}

/// How the record is fitted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitSettings {
    /// Modes to find in the band (the controller's two).
    pub modes: usize,
    /// The band fitted [Hz].
    pub band: (f64, f64),
    /// Welch segment [s].
    pub segment: f64,
    /// Sanathanan–Koerner passes.
    pub iterations: usize,
}

impl Default for FitSettings {
    /// Two modes in 1.5–45 Hz, 8 s segments, 12 passes.
    fn default() -> Self {
        Self {
            modes: 2,
            band: (1.5, 45.0),
            segment: 8.0,
            iterations: 12,
        }
    }
}

/// One identified mode.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IdentifiedMode {
    /// `ω_j` [rad/s].
    pub omega: f64,
    /// `ζ_j` [-].
    pub zeta: f64,
    /// `g_j = k_a k_s Δφ'_j²`, the piezo→film product [V/V·(rad/s)²].
    pub piezo_film: f64,
    /// `c_j = k_s Δφ'_j w_j`, the film's response to the base's acceleration [V·s²/rad·(rad/s)²].
    pub base_film: f64,
    /// Mean coherence over the mode's half-power band [-].
    pub coherence: f64,
}

/// The modes fit's result.
#[derive(Clone, Debug, PartialEq)]
pub struct ModesFit {
    /// The modes, ascending.
    pub modes: Vec<IdentifiedMode>,
    /// The film amplifier's high-pass corner the fit found [Hz], if any.
    pub highpass_hz: Option<f64>,
    /// The measured responses (inputs: `V_a`, `α̈ = θ̈1 + θ̈2`).
    pub frf: Frf,
    /// The rational fit.
    pub fit: RationalFit,
}

/// Fits the record: the responses of `V_f` to `V_a` and to `α̈ = θ̈1 + θ̈2`, then `D` of
/// degree `2·modes + 1` (the modes and the film's high-pass) with numerators of degree
/// `2·modes + 3`, which carry the modes above the band.
pub fn fit_modes(rec: &ModesRecord, set: &FitSettings) -> Result<ModesFit, IdentifyError> {
    check(rec, set)?;
    // Every channel through the same first difference (it leaves the responses as they are and
    // whitens the records: the moves' power sits at low frequencies and would leak through
    // the window's sidelobes into the modes' lines); the base's angle twice more, to its
    // acceleration `α̈` [rad/s²].
    let diff = |x: &[f64]| -> Vec<f64> { x.windows(2).map(|w| (w[1] - w[0]) / rec.dt).collect() };
    let alpha: Vec<f64> = rec.theta[0]
        .iter()
        .zip(&rec.theta[1])
        .map(|(a, b)| a + b)
        .collect();
    let mut acc = diff(&diff(&diff(&alpha)));
    acc.splice(0..0, [0.0, 0.0]);
    let (y, va) = (diff(&rec.v_f), diff(&rec.v_a));
    let len = (set.segment / rec.dt).round() as usize;
    let mut frf = frf::estimate(&y, &[&va, &acc], rec.dt, len, set.band)?;
    for (f, h) in frf.freq.iter().zip(frf.h.iter_mut()) {
        h[0] /= command_advance(*f, rec.dt);
    }
    let order = 2 * set.modes + 1;
    let fit = rational::fit(&frf, order, &[order + 2, order + 2], set.iterations)?;
    let (found, other) = rational::modes(&fit);
    let highpass_hz = other
        .iter()
        .filter(|p| p.re < 0.0)
        .map(|p| p.norm() / std::f64::consts::TAU)
        .filter(|f| *f < set.band.0)
        .reduce(f64::min);
    let in_band: Vec<&FittedMode> = found
        .iter()
        .filter(|m| {
            let f = m.omega / std::f64::consts::TAU;
            f >= set.band.0 && f <= set.band.1
        })
        .collect();
    let poles = fit.poles();
    let hp = |p: Complex64| match highpass_hz {
        Some(f) => p / (p + std::f64::consts::TAU * f),
        None => Complex64::new(1.0, 0.0),
    };
    let modes: Vec<IdentifiedMode> = in_band
        .iter()
        .map(|m| {
            // Σ g/(s² + 2ζωs + ω²) has the residue g / (2j Im p) at p.
            let k = Complex64::new(0.0, 2.0 * m.pole.im) / hp(m.pole);
            let g = fit.residue(0, m.pole, &poles) * k;
            let c = -fit.residue(1, m.pole, &poles) * k;
            let f = m.omega / std::f64::consts::TAU;
            let half = (m.zeta * f).max(frf.freq[1] - frf.freq[0]);
            let near: Vec<f64> = frf
                .freq
                .iter()
                .zip(&frf.coherence)
                .filter(|(x, _)| (**x - f).abs() <= half)
                .map(|(_, c)| *c)
                .collect();
            IdentifiedMode {
                omega: m.omega,
                zeta: m.zeta,
                piezo_film: g.re,
                base_film: c.re,
                coherence: near.iter().sum::<f64>() / near.len().max(1) as f64,
            }
        })
        .collect();
    let modes = seen(modes, set)?;
    Ok(ModesFit {
        modes,
        highpass_hz,
        frf,
        fit,
    })
}

/// Shares of a channel's samples at the ends of its range above which the record is refused
/// as clipped.
const CLIPPED_SHARE: f64 = 1e-3;
/// A mode's coherence below which the fit says it was not excited enough.
pub const MIN_COHERENCE: f64 = 0.8;
/// A fitted pole pair whose static response `|g|/ω²` is under this share of the largest is
/// an artefact of the fit (a pole its numerator all but cancels), not a mode.
const ARTEFACT_SHARE: f64 = 0.02;

/// The record's checks before the modes fit: [`check_channels`], the base excited, long
/// enough for two segments.
fn check(rec: &ModesRecord, set: &FitSettings) -> Result<(), IdentifyError> {
    check_channels(rec)?;
    let bad = |m: String| Err(IdentifyError::Data(m));
    if span(rec.theta[0].iter().zip(&rec.theta[1]).map(|(a, b)| a + b)) == 0.0 {
        return bad("no excitation of the base: `theta1 + theta2` never changes, so the held arm's coupling cannot be taken out".into());
    }
    let n = rec.v_f.len();
    let seconds = n as f64 * rec.dt;
    let lowest = set.band.0;
    if seconds < 2.0 * set.segment {
        return bad(format!(
            "the record is {seconds:.1} s: too short for modes down to {lowest} Hz, which need two segments of {} s (at least {} s; {} s by default)",
            set.segment,
            2.0 * set.segment,
            ModesPlan::default().seconds
        ));
    }
    if set.segment * lowest < 4.0 {
        return bad(format!(
            "segments of {} s resolve {lowest} Hz in fewer than 4 lines: give segments of at least {:.1} s or a band from a higher frequency",
            set.segment,
            4.0 / lowest
        ));
    }
    Ok(())
}

/// The range a channel spans, largest minus smallest.
fn span(x: impl Iterator<Item = f64>) -> f64 {
    let (lo, hi) = x.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
        (l.min(v), h.max(v))
    });
    hi - lo
}

/// A record's checks before any fit (modes or decay): the sampling period, every channel
/// present, as long as the others and finite, the patch's command changing, the film and the
/// command not clipped.
pub fn check_channels(rec: &ModesRecord) -> Result<(), IdentifyError> {
    let bad = |m: String| Err(IdentifyError::Data(m));
    if !(rec.dt.is_finite() && rec.dt > 0.0) {
        return bad(format!("a sampling period of {} s", rec.dt));
    }
    let channels = [
        ("v_a", &rec.v_a),
        ("v_f", &rec.v_f),
        ("theta1", &rec.theta[0]),
        ("theta2", &rec.theta[1]),
    ];
    if let Some((name, _)) = channels.iter().find(|(_, ch)| ch.is_empty()) {
        return bad(format!("the channel `{name}` is missing (no samples)"));
    }
    let n = rec.v_f.len();
    for (name, ch) in channels {
        if ch.len() != n {
            return bad(format!(
                "the channel `{name}` holds {} samples, `v_f` {n}",
                ch.len()
            ));
        }
        if let Some(k) = ch.iter().position(|v| !v.is_finite()) {
            return bad(format!(
                "the channel `{name}` is not a finite number at sample {k}"
            ));
        }
    }
    if span(rec.v_a.iter().copied()) == 0.0 {
        return bad("no excitation: the patch's command `v_a` never changes, so no mode can be seen through it".into());
    }
    let clipped = |x: &[f64], lo: f64, hi: f64| {
        let tol = 1e-6 * (hi - lo);
        x.iter()
            .filter(|v| **v <= lo + tol || **v >= hi - tol)
            .count()
    };
    for (name, x, lo, hi, what) in [
        (
            "v_f",
            &rec.v_f,
            -rec.v_f_range,
            rec.v_f_range * (1.0 - 1e-3),
            "the film ADC's range",
        ),
        (
            "v_a",
            &rec.v_a,
            rec.v_a_window.0,
            rec.v_a_window.1,
            "the amplifier's window",
        ),
    ] {
        let c = clipped(x, lo, hi);
        if c as f64 > CLIPPED_SHARE * n as f64 {
            return bad(format!(
                "`{name}` is clipped: {c} of {n} samples at the ends of {what} [{lo}, {hi}]: lower the excitation"
            ));
        }
    }
    Ok(())
}

/// The modes the fit found, artefacts removed, checked against what the controller needs:
/// `set.modes` of them, each seen with enough coherence.
fn seen(
    mut modes: Vec<IdentifiedMode>,
    set: &FitSettings,
) -> Result<Vec<IdentifiedMode>, IdentifyError> {
    // A collocated patch and film make every mode's product `g = k_a k_s Δφ'²` positive, and
    // a mode is damped: a pole pair with `g ≤ 0` or `ζ ≤ 0` is the fit's, not the link's.
    let size = |m: &IdentifiedMode| m.piezo_film / (m.omega * m.omega);
    let largest = modes.iter().map(size).fold(0.0, f64::max);
    let reversed = modes.iter().map(|m| -size(m)).fold(0.0, f64::max);
    if reversed > largest {
        return Err(IdentifyError::Data(
            "the piezo→film products come out negative: the film's sign is reversed (run `flexarm bringup`, or flip the recording's v_f)".into(),
        ));
    }
    modes.retain(|m| m.zeta > 0.0 && size(m) > ARTEFACT_SHARE * largest);
    let hz = |m: &IdentifiedMode| format!("{:.2} Hz", m.omega / std::f64::consts::TAU);
    let list = modes.iter().map(hz).collect::<Vec<_>>().join(", ");
    if modes.len() < set.modes {
        let k = modes.len() + 1;
        return Err(IdentifyError::Data(format!(
            "mode {k} not seen: the fit found {} mode(s) in {}–{} Hz ({}); the excitation did not reach mode {k}, or it lies outside the band",
            modes.len(),
            set.band.0,
            set.band.1,
            if list.is_empty() { "none".into() } else { list }
        )));
    }
    modes.truncate(set.modes);
    for (j, m) in modes.iter().enumerate() {
        if m.coherence < MIN_COHERENCE {
            return Err(IdentifyError::Data(format!(
                "mode {} ({}) seen with a coherence of {:.2} (at least {MIN_COHERENCE}): the excitation barely reached it, or noise dominates there",
                j + 1,
                hz(m),
                m.coherence
            )));
        }
    }
    Ok(modes)
}

/// `E(ω) = (e^{jωT} − 1)/(jωT)` at `f` [Hz]: how a command that changes at random instants
/// between samples `T` [s] apart shows in the record (module docs).
pub fn command_advance(f: f64, dt: f64) -> Complex64 {
    let x = std::f64::consts::TAU * f * dt;
    (Complex64::new(0.0, x).exp() - 1.0) / Complex64::new(0.0, x)
}

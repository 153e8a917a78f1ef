//! A record's channels and what they hold, before any fit: which channels are there and sound,
//! how far the joints moved in encoder counts, and how the excitation is laid out in time
//! (pulses, one burst followed by rest, or a stationary signal), which decides how its spectra
//! are taken ([`super::spectra`]).
//!
//! The trace's columns each fit reads (`docs/identification.md` has the table): `t_s` (the
//! sampling, which must be even), `theta1_rad`, `theta2_rad` (the encoders), `tau1_Nm`,
//! `tau2_Nm` (the motors' commands), `v_a_V` (the patch's command), `v_f_V` (the film ADC). The
//! desired angles, the modal columns and the tip are not read.

use crate::sim::Sample;

use super::IdentifyError;

/// A record's channels, one sample per period.
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
    /// The motors' torques `τ1`, `τ2` [N·m].
    pub tau: [Vec<f64>; 2],
    /// The film ADC's range `±v_f_range` [V]: readings at its ends are clipped.
    pub v_f_range: f64,
    /// The amplifier's window `[v_a_min, v_a_max]` [V]: commands at its ends are clipped.
    pub v_a_window: (f64, f64),
}

impl ModesRecord {
    /// The channels of a trace (`crate::output::read_csv`: a simulator's run or a board's
    /// recording, `flexarm record`), which must be sampled evenly (a gap, lost frames, is
    /// refused with its time).
    pub fn from_trace(
        trace: &[Sample],
        v_f_range: f64,
        v_a_window: (f64, f64),
    ) -> Result<Self, IdentifyError> {
        let dt = super::even_period(trace)?;
        let ch = |f: &dyn Fn(&Sample) -> f64| trace.iter().map(f).collect::<Vec<f64>>();
        Ok(Self {
            dt,
            v_a: ch(&|x| x.v_a),
            v_f: ch(&|x| x.v_f),
            theta: [ch(&|x| x.x.q.x), ch(&|x| x.x.q.y)],
            tau: [ch(&|x| x.tau.x), ch(&|x| x.tau.y)],
            v_f_range,
            v_a_window,
        })
    }

    /// The record's length [s].
    pub fn seconds(&self) -> f64 {
        self.v_f.len() as f64 * self.dt
    }

    /// The record's first `n` samples.
    pub fn head(&self, n: usize) -> Self {
        let cut = |x: &Vec<f64>| x[..n.min(x.len())].to_vec();
        Self {
            v_a: cut(&self.v_a),
            v_f: cut(&self.v_f),
            theta: [cut(&self.theta[0]), cut(&self.theta[1])],
            tau: [cut(&self.tau[0]), cut(&self.tau[1])],
            ..*self
        }
    }

    /// The base's angle `α = θ1 + θ2` [rad].
    pub fn alpha(&self) -> Vec<f64> {
        self.theta[0]
            .iter()
            .zip(&self.theta[1])
            .map(|(a, b)| a + b)
            .collect()
    }
}

/// The range a channel spans, largest minus smallest.
pub fn span(x: impl Iterator<Item = f64>) -> f64 {
    let (lo, hi) = x.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
        (l.min(v), h.max(v))
    });
    hi - lo
}

/// Shares of a channel's samples at the ends of its range above which the record is refused
/// as clipped.
const CLIPPED_SHARE: f64 = 1e-3;

/// The gate every fit of a record passes first (`channels`): the sampling period, every
/// channel present, as long as the others and finite, the film moving, the film and the
/// patch's command not clipped.
pub fn check_channels(rec: &ModesRecord) -> Result<(), IdentifyError> {
    let bad = |m: String| Err(IdentifyError::Data(format!("gate `channels`: {m}")));
    if !(rec.dt.is_finite() && rec.dt > 0.0) {
        return bad(format!("a sampling period of {} s", rec.dt));
    }
    let channels = [
        ("v_a", &rec.v_a),
        ("v_f", &rec.v_f),
        ("theta1", &rec.theta[0]),
        ("theta2", &rec.theta[1]),
        ("tau1", &rec.tau[0]),
        ("tau2", &rec.tau[1]),
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
    if span(rec.v_f.iter().copied()) == 0.0 {
        return bad("the film's reading `v_f` never changes: a film that is not connected, or an arm that never moved".into());
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
            return Err(IdentifyError::Data(format!(
                "gate `clipping`: `{name}` is clipped: {c} of {n} samples at the ends of {what} [{lo}, {hi}]: lower the excitation"
            )));
        }
    }
    Ok(())
}

/// Share of a torque's samples at its drive's limit above which the record is refused as
/// saturated: a drive at its limit does not give what its command asks, and a fit that reads
/// the torque (the inertias') charges the difference to the arm. A tap at the limit is short
/// (five 20 ms taps are 0.1 % of a 100 s record) and the decay after it is free.
pub const SATURATED_SHARE: f64 = 0.01;

/// The gate `clipping` on the torques of `trace`: each joint's `tau` at its drive's limit
/// `±limit` [N·m] for at most [`SATURATED_SHARE`] of the samples.
pub fn check_torques(trace: &[Sample], limit: [f64; 2]) -> Result<(), IdentifyError> {
    let n = trace.len();
    for (j, l) in limit.iter().enumerate() {
        let at = trace
            .iter()
            .filter(|s| s.tau[j].abs() >= l * (1.0 - 1e-6))
            .count();
        if at as f64 > SATURATED_SHARE * n as f64 {
            return Err(IdentifyError::Data(format!(
                "gate `clipping`: `tau{}` is saturated: {at} of {n} samples ({:.1} %) at the drive's limit ±{l} N·m, at most {} %: lower the excitation or slow the moves",
                j + 1,
                100.0 * at as f64 / n as f64,
                100.0 * SATURATED_SHARE
            )));
        }
    }
    Ok(())
}

/// A record read from the trace CSV `path` (`crate::output::read_csv`), its header checked
/// first: a header that names some of the trace's columns but not all is refused with the
/// gate `channels` and the columns missing.
pub fn read_record(path: &std::path::Path) -> Result<Vec<Sample>, String> {
    use std::io::{BufRead, Read};
    let shown = path.display();
    let file = std::fs::File::open(path).map_err(|e| format!("{shown}: {e}"))?;
    let mut first = String::new();
    std::io::BufReader::new(file)
        .take(4096)
        .read_line(&mut first)
        .map_err(|e| format!("{shown}:1: {e}"))?;
    let names: Vec<&str> = first
        .trim_start_matches('\u{feff}')
        .trim()
        .split(',')
        .map(str::trim)
        .collect();
    let columns: Vec<&str> = crate::output::CSV_HEADER.split(',').collect();
    let missing: Vec<String> = columns
        .iter()
        .filter(|c| !names.contains(c))
        .map(|c| format!("`{c}`"))
        .collect();
    if !missing.is_empty() && missing.len() < columns.len() {
        return Err(format!(
            "{shown}:1: gate `channels`: the column(s) {} missing (a trace has {})",
            missing.join(", "),
            crate::output::CSV_HEADER
        ));
    }
    crate::output::read_csv(path)
}

/// An encoder's step [rad] as the record shows it: the smallest change between two samples
/// (0 when the angle never changes); changes under 1 µrad are the trace's rounding (eight
/// significant digits), not a step.
pub fn resolution(theta: &[f64]) -> f64 {
    let step = theta
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|d| *d > 1e-6)
        .fold(f64::INFINITY, f64::min);
    if step.is_finite() { step } else { 0.0 }
}

/// How far a joint's angle travels in its encoder's steps (0 when it never moves).
pub fn travel_counts(theta: &[f64]) -> f64 {
    let lsb = resolution(theta);
    if lsb > 0.0 {
        (span(theta.iter().copied()) / lsb).round()
    } else {
        0.0
    }
}

/// A pulse of a channel: its first sample, the first sample after it, its sign.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pulse {
    /// First sample.
    pub start: usize,
    /// First sample after it.
    pub end: usize,
    /// Its sign against the channel's rest.
    pub sign: f64,
}

/// How an excitation is laid out in time.
#[derive(Clone, Debug, PartialEq)]
pub enum Layout {
    /// Short pulses from rest (taps), in order.
    Pulses(Vec<Pulse>),
    /// One burst from the sample `start` to `end`, at rest after it to the record's end.
    Burst {
        /// Its first active sample.
        start: usize,
        /// The first sample after its last active one.
        end: usize,
    },
    /// A signal that never rests for long: noise, a multisine, steps.
    Stationary,
}

/// The longest pulse that counts as a tap [s]: a board's link times the taps and stretches
/// them (0.3 to 0.51 s for the plan's 20 ms under QEMU, whose clock outruns the host's); a
/// longer pulse is a step, and the arm's response to it is forced.
pub const MAX_TAP: f64 = 1.0;

/// The median of `x`.
fn median(x: &[f64]) -> f64 {
    let mut v = x.to_vec();
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(0.0)
}

/// The pulses of `x` (sampled every `dt` [s]) from its rest (its median): runs beyond half its
/// largest excursion, each at most [`MAX_TAP`], with the channel within a tenth of that
/// excursion for at least four fifths of the record; a run within [`SAME_TAP`] of the one
/// before is part of its tap. Empty when `x` is not a train of pulses.
pub fn pulses(x: &[f64], dt: f64) -> Vec<Pulse> {
    let rest = median(x);
    let peak = x.iter().map(|v| (v - rest).abs()).fold(0.0, f64::max);
    if peak == 0.0 {
        return Vec::new();
    }
    let quiet = x.iter().filter(|v| (*v - rest).abs() <= 0.1 * peak).count();
    if (quiet as f64) < 0.8 * x.len() as f64 {
        return Vec::new();
    }
    let mut out = Vec::new();
    let mut open: Option<(usize, f64)> = None;
    for (k, v) in x.iter().enumerate() {
        let d = v - rest;
        match open {
            None if d.abs() > 0.5 * peak => open = Some((k, d.signum())),
            Some((start, sign)) if d.abs() <= 0.5 * peak || d.signum() != sign => {
                out.push(Pulse {
                    start,
                    end: k,
                    sign,
                });
                open = if d.abs() > 0.5 * peak {
                    Some((k, d.signum()))
                } else {
                    None
                };
            }
            _ => {}
        }
    }
    if let Some((start, sign)) = open {
        out.push(Pulse {
            start,
            end: x.len(),
            sign,
        });
    }
    let longest = out.iter().map(|p| p.end - p.start).max().unwrap_or(0) as f64 * dt;
    if longest > MAX_TAP {
        return Vec::new();
    }
    // A pulse that starts within `SAME_TAP` of the one before's end is that tap's ringing.
    let mut taps: Vec<Pulse> = Vec::new();
    let mut last_end = None;
    for p in out {
        match last_end {
            Some(e) if (p.start - e) as f64 * dt < SAME_TAP => {}
            _ => taps.push(p),
        }
        last_end = Some(p.end);
    }
    taps
}

/// A pulse that starts less than this [s] after the one before ends belongs to the same tap:
/// the hold's reaction to a hammer's strike swings in the torque for about a second, its
/// swings under half a second apart.
const SAME_TAP: f64 = 0.5;

/// The samples where `x` is away from its rest (its first sample) by more than `floor`, as the
/// first and one past the last.
fn active_span(x: &[f64], floor: f64) -> Option<(usize, usize)> {
    let rest = x.first().copied()?;
    let first = x.iter().position(|v| (v - rest).abs() > floor)?;
    let last = x.iter().rposition(|v| (v - rest).abs() > floor)?;
    Some((first, last + 1))
}

/// Rest a burst must be followed by, at least [s] and at least this share of the record.
const BURST_REST: (f64, f64) = (2.0, 0.1);

/// The layout of the excitation channels `drive` (each with the excursion `floor` below which
/// it counts as at rest), sampled every `dt` [s]: pulses when the first channel is a train of
/// pulses and every other one rests, one burst when every channel starts and ends at rest
/// with enough rest after, stationary otherwise.
pub fn layout(drive: &[(&[f64], f64)], dt: f64) -> Layout {
    let Some(&(first, _)) = drive.first() else {
        return Layout::Stationary;
    };
    let n = first.len();
    let p = pulses(first, dt);
    if !p.is_empty()
        && drive[1..]
            .iter()
            .all(|(x, floor)| active_span(x, *floor).is_none())
    {
        return Layout::Pulses(p);
    }
    let spans: Vec<Option<(usize, usize)>> = drive
        .iter()
        .map(|(x, floor)| {
            let peak = x
                .first()
                .map_or(0.0, |r| x.iter().map(|v| (v - r).abs()).fold(0.0, f64::max));
            active_span(x, floor.max(0.05 * peak))
        })
        .collect();
    let start = spans.iter().flatten().map(|s| s.0).min();
    let end = spans.iter().flatten().map(|s| s.1).max();
    match (start, end) {
        (Some(start), Some(end))
            if start > 0
                && ((n - end) as f64 * dt) >= BURST_REST.0.max(BURST_REST.1 * n as f64 * dt) =>
        {
            Layout::Burst { start, end }
        }
        _ => Layout::Stationary,
    }
}

//! A lab's records of an arm (issue 32): what a user with a signal generator, a PD holding the
//! joints and a recorder brings to `cargo sim identify`, made on the simulator's plant and
//! written by its ordinary trace writer ([`crate::output::trace_csv`]). Not the identify
//! experiments: no drive, no observer, none of the project's controllers. The joints are held
//! at a pose by a plain PD on the encoders' angles (its speed a filtered difference), and one
//! or more excitations run at once: a chirp (linear or logarithmic in frequency), band-limited
//! noise, a multisine or taps, on the patch (volts), on a motor (N·m on top of the PD's
//! torque) or a hammer on the link (impulses [N·s] across its tip).
//!
//! The record is a trace ([`Sample`]) at the motor rate: the encoders' angles, the motors'
//! torques, the patch's command after the amplifier's slew (`v_a`), the film ADC's reading
//! (`v_f`); the desired angles are the pose; the modal columns are the plant's first two modes
//! (a board records none of them, and no fit reads them). Units SI; frames as in
//! `flexarm_core`.

use flexarm_core::Vector2;
use rustfft::FftPlanner;
use rustfft::num_complex::Complex64;

use crate::plant::State;
use crate::sim::{Rng, Sample, SimConfig};

/// The PD that holds the joints: `τ_i = K_p,i (θ_pose,i − θ_i) − K_d,i ω_i`, `θ_i` the
/// encoder's angle and `ω_i` its first difference through a first-order low-pass at
/// `speed_hz`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hold {
    /// Proportional gains [N·m/rad].
    pub kp: Vector2<f64>,
    /// Derivative gains [N·m·s/rad].
    pub kd: Vector2<f64>,
    /// Corner of the speed's low-pass [Hz].
    pub speed_hz: f64,
}

impl Default for Hold {
    /// `K_p = (100, 40)` N·m/rad, `K_d = (4, 1.6)` N·m·s/rad, speed filtered at 30 Hz: on
    /// the paper's arm a hold near 2 Hz damped about 0.25, a lab's first tuning.
    fn default() -> Self {
        Self {
            kp: Vector2::new(100.0, 40.0),
            kd: Vector2::new(4.0, 1.6),
            speed_hz: 30.0,
        }
    }
}

/// The waveform of an excitation, of peak 1 (its [`Excite::amplitude`] scales it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// A sine sweeping from `from` to `to` [Hz] in `seconds`, its frequency linear in time or
    /// (`log`) exponential.
    Chirp {
        /// Start frequency [Hz].
        from: f64,
        /// End frequency [Hz].
        to: f64,
        /// Sweep time [s].
        seconds: f64,
        /// Logarithmic sweep.
        log: bool,
    },
    /// Gaussian noise of flat spectrum in `from`–`to` [Hz] for `seconds`, scaled to peak 1.
    Random {
        /// Band [Hz].
        from: f64,
        /// Band [Hz].
        to: f64,
        /// Length [s].
        seconds: f64,
        /// Seed.
        seed: u64,
    },
    /// A multisine: every line `k/period` in `from`–`to` [Hz] at equal amplitude and random
    /// phase, `periods` periods, scaled to peak 1.
    Multisine {
        /// Band [Hz].
        from: f64,
        /// Band [Hz].
        to: f64,
        /// Period [s].
        period: f64,
        /// Periods.
        periods: usize,
        /// Seed of the phases.
        seed: u64,
    },
    /// `count` pulses of `width` seconds, `spacing` seconds apart, alternating in sign (a
    /// hammer's are impulses: its width is ignored).
    Taps {
        /// Pulses.
        count: usize,
        /// Width of each [s].
        width: f64,
        /// From one pulse's start to the next [s].
        spacing: f64,
    },
}

impl Shape {
    /// How long the excitation lasts [s].
    pub fn seconds(&self) -> f64 {
        match *self {
            Self::Chirp { seconds, .. } | Self::Random { seconds, .. } => seconds,
            Self::Multisine {
                period, periods, ..
            } => period * periods as f64,
            Self::Taps { count, spacing, .. } => count as f64 * spacing,
        }
    }
}

/// Where an excitation acts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Actuator {
    /// The patch's amplifier [V].
    Patch,
    /// Motor 0 or 1, on top of the hold's torque [N·m].
    Motor(usize),
    /// A hammer across the link's tip [N·s per strike].
    Hammer,
}

/// One excitation of a record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Excite {
    /// Where it acts.
    pub actuator: Actuator,
    /// Its waveform.
    pub shape: Shape,
    /// Its peak [V, N·m or N·s].
    pub amplitude: f64,
}

/// A reference the hold tracks instead of holding still: each joint a multisine of `band` [Hz]
/// (random phases) of peak `reach` [rad] about the pose, faded in and out over a second so
/// that the record starts and ends at rest (an inertia record).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Track {
    /// Each joint's peak excursion [rad].
    pub reach: Vector2<f64>,
    /// The band [Hz].
    pub band: (f64, f64),
    /// Length [s].
    pub seconds: f64,
    /// Seed of the phases (joint 2 takes the next).
    pub seed: u64,
}

impl Track {
    /// The reference's excursion from the pose, sampled every `dt` [s].
    fn table(&self, dt: f64) -> [Vec<f64>; 2] {
        let n = (self.seconds / dt).round() as usize;
        let fade = (1.0 / dt) as usize;
        [0, 1].map(|j| {
            band_noise(n, dt, self.band, self.seed + j as u64, false)
                .into_iter()
                .enumerate()
                .map(|(k, v)| {
                    let edge = k.min(n - 1 - k.min(n - 1));
                    let w = if edge < fade {
                        0.5 - 0.5 * (std::f64::consts::PI * edge as f64 / fade as f64).cos()
                    } else {
                        1.0
                    };
                    self.reach[j] * v * w
                })
                .collect()
        })
    }
}

/// A record's plan: the bench (`cfg`: plant, sensors, rates, limits), the pose held (or a
/// reference tracked about it), the hold, the excitations, and the rest before and after
/// them.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// Plant, sensors, rates and limits (its controller settings are not used).
    pub cfg: SimConfig,
    /// The pose [rad].
    pub pose: Vector2<f64>,
    /// The hold.
    pub hold: Hold,
    /// The excitations, all starting after `lead`.
    pub excite: Vec<Excite>,
    /// A reference the hold tracks, from `lead` on.
    pub track: Option<Track>,
    /// Rest before the excitation [s].
    pub lead: f64,
    /// Rest after it [s].
    pub tail: f64,
}

/// An excitation sampled every `dt` seconds from its start (zero after its end), or the times
/// of a hammer's strikes.
enum Table {
    Samples(Vec<f64>, f64),
    Strikes(Vec<(f64, f64)>),
}

impl Table {
    fn at(&self, t: f64) -> f64 {
        match self {
            Self::Samples(x, dt) if t >= 0.0 => x.get((t / dt) as usize).copied().unwrap_or(0.0),
            _ => 0.0,
        }
    }
}

/// `n` samples every `dt` [s] of noise with a flat spectrum in `from`–`to` [Hz] (random
/// amplitudes when `gaussian`, else equal ones: a multisine), random phases, peak 1.
fn band_noise(n: usize, dt: f64, (from, to): (f64, f64), seed: u64, gaussian: bool) -> Vec<f64> {
    let mut rng = Rng::new(seed);
    let df = 1.0 / (n as f64 * dt);
    let mut spec = vec![Complex64::new(0.0, 0.0); n];
    for (k, c) in spec.iter_mut().enumerate().take(n / 2).skip(1) {
        let f = k as f64 * df;
        if f >= from && f <= to {
            let a = if gaussian {
                (-2.0 * rng.uniform().ln()).sqrt()
            } else {
                1.0
            };
            *c = Complex64::from_polar(a, std::f64::consts::TAU * rng.uniform());
        }
    }
    let mut x = spec;
    FftPlanner::new().plan_fft_inverse(n).process(&mut x);
    let re: Vec<f64> = x.iter().map(|c| c.re).collect();
    let peak = re.iter().map(|v| v.abs()).fold(0.0, f64::max);
    re.iter()
        .map(|v| if peak > 0.0 { v / peak } else { 0.0 })
        .collect()
}

impl Excite {
    /// The excitation tabulated every `dt` seconds (a hammer's as strikes).
    fn table(&self, dt: f64) -> Table {
        let a = self.amplitude;
        let n = (self.shape.seconds() / dt).round() as usize;
        let pulses = |count: usize, width: f64, spacing: f64| {
            (0..count).map(move |k| {
                let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
                (k as f64 * spacing, width, sign)
            })
        };
        if let (Actuator::Hammer, Shape::Taps { count, spacing, .. }) = (self.actuator, self.shape)
        {
            return Table::Strikes(
                pulses(count, 0.0, spacing)
                    .map(|(t, _, s)| (t, s * a))
                    .collect(),
            );
        }
        let x = match self.shape {
            Shape::Chirp {
                from,
                to,
                seconds,
                log,
            } => (0..n)
                .map(|k| {
                    let t = k as f64 * dt;
                    // The phase is the integral of the frequency.
                    let phase = if log {
                        let r = (to / from).ln() / seconds;
                        from * ((r * t).exp() - 1.0) / r
                    } else {
                        from * t + 0.5 * (to - from) / seconds * t * t
                    };
                    a * (std::f64::consts::TAU * phase).sin()
                })
                .collect(),
            Shape::Random { from, to, seed, .. } => band_noise(n, dt, (from, to), seed, true)
                .into_iter()
                .map(|v| a * v)
                .collect(),
            Shape::Multisine {
                from,
                to,
                period,
                periods,
                seed,
            } => {
                let one = band_noise((period / dt).round() as usize, dt, (from, to), seed, false);
                (0..periods)
                    .flat_map(|_| one.iter().map(|v| a * v))
                    .collect()
            }
            Shape::Taps {
                count,
                width,
                spacing,
            } => {
                let mut x = vec![0.0; n];
                for (t0, w, s) in pulses(count, width, spacing) {
                    let (k0, k1) = ((t0 / dt).round() as usize, ((t0 + w) / dt).round() as usize);
                    for v in x.iter_mut().take(k1.max(k0 + 1)).skip(k0) {
                        *v = s * a;
                    }
                }
                x
            }
        };
        Table::Samples(x, dt)
    }
}

impl Plan {
    /// Length of the record [s].
    pub fn seconds(&self) -> f64 {
        self.lead
            + self
                .excite
                .iter()
                .map(|e| e.shape.seconds())
                .chain(self.track.map(|t| t.seconds))
                .fold(0.0, f64::max)
            + self.tail
    }
}

/// Runs the plan: one [`Sample`] per motor period. An error when the plan is not one the
/// bench can run (a rate, a motor index, a hammer on a plant that takes no strike) or the
/// plant diverges.
pub fn record(plan: &Plan) -> Result<Vec<Sample>, String> {
    let cfg = &plan.cfg;
    let (motor_div, piezo_div) = cfg.rates.divisors().map_err(|e| e.to_string())?;
    let dt = cfg.rates.plant_dt;
    let (motor_dt, piezo_dt) = (dt * motor_div as f64, dt * piezo_div as f64);
    let seconds = plan.seconds();
    if !(seconds.is_finite() && seconds > 0.0 && seconds <= 3600.0) {
        return Err(format!("a record of {seconds} s: give up to 3600 s"));
    }
    let mut plant = cfg.plant_at(plan.pose).map_err(|e| e.to_string())?;
    let tables: Vec<(Actuator, Table)> = plan
        .excite
        .iter()
        .map(|e| {
            let rate = if e.actuator == Actuator::Patch {
                piezo_dt
            } else {
                motor_dt
            };
            (e.actuator, e.table(rate))
        })
        .collect();
    if let Some((Actuator::Motor(j), _)) = tables
        .iter()
        .find(|(a, _)| matches!(a, Actuator::Motor(j) if *j > 1))
    {
        return Err(format!("motor {j}: the arm has motors 0 and 1"));
    }
    let mut strikes: Vec<(f64, f64)> = tables
        .iter()
        .flat_map(|(_, t)| match t {
            Table::Strikes(s) => s.iter().map(|(t, p)| (t + plan.lead, *p)).collect(),
            Table::Samples(..) => Vec::new(),
        })
        .collect();
    strikes.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut strikes = strikes.into_iter().peekable();
    let drive = |actuator: Actuator, t: f64| -> f64 {
        tables
            .iter()
            .filter(|(a, _)| *a == actuator)
            .map(|(_, table)| table.at(t - plan.lead))
            .sum()
    };
    let reference = plan.track.map(|t| t.table(motor_dt));
    let at = |t: f64| -> (Vector2<f64>, Vector2<f64>) {
        let Some(r) = &reference else {
            return (Vector2::zeros(), Vector2::zeros());
        };
        let k = ((t - plan.lead) / motor_dt).round();
        let get = |j: usize, k: f64| {
            if k < 0.0 {
                0.0
            } else {
                r[j].get(k as usize).copied().unwrap_or(0.0)
            }
        };
        let pos = Vector2::new(get(0, k), get(1, k));
        let next = Vector2::new(get(0, k + 1.0), get(1, k + 1.0));
        (pos, (next - pos) / motor_dt)
    };
    let s = &cfg.sensors;
    let mut rng = Rng::new(s.seed);
    let alpha = 1.0 - (-std::f64::consts::TAU * plan.hold.speed_hz * motor_dt).exp();
    let (mut speed, mut last) = (Vector2::<f64>::zeros(), None::<Vector2<f64>>);
    let tau_max = cfg.limits.tau_max.cast::<f64>();
    let (lo, hi) = (f64::from(cfg.limits.v_a_min), f64::from(cfg.limits.v_a_max));
    let (mut tau, mut v_a) = (Vector2::<f64>::zeros(), 0.0_f64);
    let steps = (seconds / dt).round() as u64;
    let mut trace = Vec::with_capacity((seconds / motor_dt) as usize + 1);
    for k in 0..steps {
        let t = k as f64 * dt;
        while let Some(&(at, p)) = strikes.peek() {
            if at > t {
                break;
            }
            strikes.next();
            if !plant.strike(p) {
                return Err("a hammer: this plant takes no strike (use the truth plant)".into());
            }
        }
        if k % piezo_div == 0 {
            let cmd = drive(Actuator::Patch, t).clamp(lo, hi);
            v_a = match s.piezo_slew {
                Some(rate) => v_a + (cmd - v_a).clamp(-rate * piezo_dt, rate * piezo_dt),
                None => cmd,
            };
        }
        if k % motor_div == 0 {
            let x = plant.state();
            let v_f = s.film(plant.film(), &mut rng);
            let theta = Vector2::new(s.angle(x.q.x), s.angle(x.q.y));
            if let Some(prev) = last {
                speed += ((theta - prev) / motor_dt - speed) * alpha;
            }
            last = Some(theta);
            let (r, r_dot) = at(t);
            let hold = plan.hold.kp.component_mul(&(plan.pose + r - theta))
                + plan.hold.kd.component_mul(&(r_dot - speed));
            let extra = Vector2::new(drive(Actuator::Motor(0), t), drive(Actuator::Motor(1), t));
            tau = (hold + extra).zip_map(&tau_max, |v, m| v.clamp(-m, m));
            let mut q = x.q;
            q.x = theta.x;
            q.y = theta.y;
            trace.push(Sample {
                t,
                x: State { q, qd: x.qd },
                q_d: plan.pose + r,
                delta_seen: Vector2::zeros(),
                tau,
                v_a,
                v_f,
                tip: plant.tip(),
            });
        }
        plant
            .step(&tau, v_a, dt)
            .map_err(|e| format!("at t = {t:.4} s: {e}"))?;
    }
    Ok(trace)
}

/// `plan` with its excitations' amplitudes scaled together so that the film's reading peaks
/// at `share` of its ADC's range, the patch's command within `share` of the amplifier's window
/// and a motor's excitation within `share` of its torque limit: a trial record at the plan's
/// amplitudes, then the scale (the arm is close to linear at these amplitudes).
pub fn sized(plan: &Plan, share: f64) -> Result<Plan, String> {
    let trial = record(plan)?;
    let peak = trial.iter().map(|s| s.v_f.abs()).fold(0.0, f64::max);
    if peak == 0.0 {
        return Err("the trial record's film never moved: nothing to scale".into());
    }
    let cfg = &plan.cfg;
    let mut k = share * cfg.sensors.adc_range / peak;
    for e in &plan.excite {
        let limit = match e.actuator {
            Actuator::Patch => f64::from(cfg.limits.v_a_max.min(-cfg.limits.v_a_min)),
            Actuator::Motor(j) => f64::from(cfg.limits.tau_max[j.min(1)]),
            Actuator::Hammer => f64::INFINITY,
        };
        k = k.min(share * limit / e.amplitude.abs().max(f64::MIN_POSITIVE));
    }
    let mut out = plan.clone();
    for e in &mut out.excite {
        e.amplitude *= k;
    }
    Ok(out)
}

//! Motion safety: the checks a drive runs on the motion itself, beyond the plausibility of each
//! sample (`crate::supervisor`). Per motor period, while the amplifiers are armed, from the
//! measured joint angles θ, the reference θ_d, the observer's joint speeds θ̇̂ and the torques
//! commanded τ:
//!
//! | check | trips when | fault | stop |
//! |---|---|---|---|
//! | following error | `\|θ_i − θ_d,i\| > following_i` | [`Fault::FollowingError`] | category 0 |
//! | runaway | for `runaway_periods` in a row: `\|θ̇̂_i\| ≥ runaway_speed` and not falling while `τ_i θ̇̂_i < 0` with `\|τ_i\| ≥ runaway_torque_i` (the joint speeds up against its torque), and `\|θ_i − θ_d,i\| ≥ runaway_error` | [`Fault::Runaway`] | category 0 |
//! | encoder plausibility | the reading has left the dead reckoning of the joint (below) by more than its slack plus `encoder_band`; or it stands still while the reference moves `frozen_reference_i` on, the reckoning off it by the band | [`Fault::FrozenEncoder`] (the reading the last period's) or [`Fault::EncoderMismatch`] (it moved) | category 0 |
//! | overspeed | `\|θ̇̂_i\| > speed_i` | [`Fault::Overspeed`] | category 0 |
//! | soft limit | a joint closer to the end of its range (`range_min`, `range_max`) than its stopping distance at `stop_accel` plus `range_margin`, moving towards it | [`Fault::SoftLimit`] | category 1 |
//! | motor overload | the I²t state of a motor reaches `thermal.trip` | [`Fault::Overload`] | category 1 |
//!
//! **Encoder plausibility, from the physics.** Each joint's reading is held to a dead reckoning
//! of the joint from the torques applied. From an anchor (a period's reading `y_0` and the
//! observer's speed `θ̇̂_0`), the model's joint accelerations under the torques and piezo force
//! applied (`θ̈_k`, the observer's prediction, `crate::observer::Observer::joint_acceleration`)
//! are integrated as a torque held through each period moves the joint: the observer's step
//! `s_{k+1} = s_k + θ̈_k T²` from `s_0 = θ̇̂_0 T` (its speed is already the period's end's), the
//! displacement `d_{k+1} = d_k + s_{k+1} − θ̈_k T²/2`. What the model does not know bounds how
//! far the joint may be from `d`, the slack `u`, integrated the same way from
//! `σ_0 = (speed_error + speed_error_rel |θ̇̂_0|) T` with the growth
//! `(model_error |θ̈_k| + (B⁻¹ f)_i) T²` a period, `f_k = coulomb_k + viscous_k |θ̇̂_k| +
//! disturbance_k` the friction and disturbance the model lacks, through the arm's largest
//! inverse inertia (`inertia_inv`, [`MotionLimits::for_arm`]).
//! The reading must follow: `|(y − y_0) − d| ≤ u + encoder_band` (the band at least a few
//! counts: a quantized reading is off its joint by up to half a count at either end). A reading
//! that stands still while the torques move the joint (a pulled cable, a joint stalled hard),
//! or moves where they do not move it (a slipping coupling, a reversed encoder), breaks it.
//! The anchor moves to the present once the slack reaches `encoder_slack`, if the reading has
//! changed since the anchor or still agrees with the reckoning within the band: a still reading
//! the torques should have moved keeps its anchor, so the evidence grows however slowly the
//! joint moves. Below the friction the reckoning cannot tell a stuck joint from a frozen
//! reading; the loop's stiffness can: a reading that stands still while the reference moves
//! `frozen_reference_i` on (the lag at which the law's torque `K_p Λ e` overcomes the friction,
//! and the band, [`MotionLimits::for_arm`]), with the reckoning off it by the band, is frozen.
//!
//! Stop categories (IEC 60204-1): **0**, the safe state now (zero torque and voltage, amplifiers
//! off), for every fault whose cause may be a sensor: a reversed, slipped or frozen encoder
//! cannot be trusted to brake with, and braking on it may push the wrong way. **1**, a
//! controlled stop to rest within the move limits' deceleration, then the safe state, for
//! faults whose sensors agree with the model: a joint at the end of its range, a motor running
//! hot. The drive (`crate::drive`) carries out the stop; this module only judges.
//!
//! The I²t model of each motor: a thermal state `h` in units of the continuous rating,
//! `dh/dt = ((τ/τ_c)² − h)/T_th`, so `h → 1` under the continuous torque `τ_c`. From
//! `h = thermal.derate` the torque limit falls linearly to `τ_c` at `h = thermal.floor`
//! ([`MotionMonitor::torque_limit`]); at `h = thermal.trip` the motor faults. A stall against an
//! obstacle at any torque above `τ_c` therefore ends in [`Fault::Overload`], and a duty whose
//! RMS torque stays below the continuous rating never does.
//!
//! Units SI: rad, rad/s, N·m, s; joint frames of `crate::model`.

use crate::fault::Fault;
use crate::model::Model;
use crate::real::Real;
use crate::{Vector2, Vector4};

/// One motor's thermal rating.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Thermal<T> {
    /// Continuous torque rating τ_c per joint [N·m].
    pub continuous: Vector2<T>,
    /// Winding's thermal time constant T_th [s].
    pub time_constant: T,
    /// Thermal state at which the torque limit starts to fall [units of the continuous rating].
    pub derate: T,
    /// Thermal state at which the limit has fallen to τ_c.
    pub floor: T,
    /// Thermal state that faults the motor.
    pub trip: T,
}

/// The thresholds of the motion checks (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionLimits<T> {
    /// Largest `|θ − θ_d|` per joint [rad].
    pub following: Vector2<T>,
    /// Largest `|θ̇̂|` per joint [rad/s].
    pub speed: Vector2<T>,
    /// Runaway: the speed above which a joint moving against its torque counts [rad/s].
    pub runaway_speed: T,
    /// Runaway: the torque magnitude that counts [N·m].
    pub runaway_torque: Vector2<T>,
    /// Runaway: the tracking error that counts [rad].
    pub runaway_error: T,
    /// Runaway: consecutive motor periods to trip.
    pub runaway_periods: u32,
    /// The motor period `T` [s].
    pub period: T,
    /// Encoder plausibility: how far a reading may be off the dead reckoning beyond its slack
    /// [rad] (a few counts of the encoder).
    pub encoder_band: T,
    /// Encoder plausibility: the observer's speed error at an anchor, `σ_a + σ_r |θ̇̂|`: its
    /// absolute part σ_a [rad/s].
    pub speed_error: T,
    /// Its relative part σ_r [-].
    pub speed_error_rel: T,
    /// Encoder plausibility: the model's relative error on the joint accelerations [-].
    pub model_error: T,
    /// Encoder plausibility: the friction and disturbance the model lacks on each joint, its
    /// direction unknown: `coulomb_i + viscous_i |θ̇̂_i|`: the constant part [N·m].
    pub coulomb: Vector2<T>,
    /// The part that grows with the joint's speed [N·m·s/rad].
    pub viscous: Vector2<T>,
    /// Encoder plausibility: the torque on each joint the model does not explain beyond the
    /// friction, its direction unknown [N·m] (the link's higher modes, the drives' lag and
    /// cogging, a model whose parameters are off).
    pub disturbance: Vector2<T>,
    /// The arm's inverse inertia on the joints, the largest magnitude of each element of
    /// `(B⁻¹)_θθ` (the modes free) over the poses [1/(kg·m²)] ([`Self::for_arm`]): how much
    /// acceleration a torque on one joint can give each.
    pub inertia_inv: crate::Matrix2<T>,
    /// Encoder plausibility: the slack at which the anchor moves on [rad].
    pub encoder_slack: T,
    /// Frozen reading: how far the reference may move while the reading stands still [rad]
    /// ([`Self::for_arm`]).
    pub frozen_reference: Vector2<T>,
    /// The ends of the joint ranges the soft limit keeps the joints from [rad] (the sensors'
    /// range check is the hard limit behind them).
    pub range_min: Vector2<T>,
    /// See [`Self::range_min`].
    pub range_max: Vector2<T>,
    /// The deceleration a stop is sure to reach [rad/s²] (the drive's stop uses it).
    pub stop_accel: Vector2<T>,
    /// Distance kept beyond the stopping distance [rad].
    pub range_margin: T,
    /// The motors' thermal model.
    pub thermal: Thermal<T>,
}

impl<T: Real> MotionLimits<T> {
    /// The defaults for the arm of `model` at a motor loop of `motor_hz` (docs/safety.md gives
    /// the evidence): following error 0.05 rad (the truth plant's worst closed-loop error over
    /// the paper's moves and their Monte Carlo, times a margin); overspeed 4 rad/s (the moves are
    /// limited to 3); runaway at 0.2 rad/s against a torque of 1 N·m with an error of 0.01 rad,
    /// for 10 ms (the error scaled up as `K_p` is scaled down on a slow loop,
    /// [`crate::params::Gains::default_for`]: healthy tracking errors grow as `1/K_p`, 0.022
    /// rad at 100 Hz); encoder plausibility with a band of 1.5 mrad (four counts of a
    /// 16384-count encoder), the observer's speed known to 0.01 rad/s + 4 %, the model's
    /// accelerations to 25 %, friction of [`COULOMB`] + [`VISCOUS`] `|θ̇̂|` and [`DISTURBANCE`]
    /// on each joint ([`Self::for_arm`]), the anchor moving on at 0.01 rad of slack; soft limits at the
    /// sensors' range (θ1 ±π, θ2 ±2.8 rad) with a 0.02 rad margin beyond the stopping distance
    /// at 10 rad/s²; motors rated 4 N·m continuous with a 20 s winding time constant, derating
    /// from 60 % of the rating's heat to the continuous torque at 90 %, faulting at 95 %.
    ///
    /// Inlined: with a constant rate (a board's) its `f64` arithmetic folds away, and a
    /// firmware links no double-precision routines for it.
    #[inline(always)]
    pub fn default_for(motor_hz: u32, model: &Model<T>) -> Self {
        // The windows in periods, a few samples whatever the rate. At the QEMU board's 100 Hz
        // 10 ms is one period, and one noisy speed estimate on the circle tripped the runaway
        // check: it takes two (two differences of the speed).
        let periods = |s: f64, min: u32| ((s * f64::from(motor_hz)) as u32).max(min);
        let both = |x: f64| Vector2::new(T::c(x), T::c(x));
        let gains = crate::params::Gains::<T>::default_for(motor_hz);
        Self {
            following: both(0.05),
            speed: both(4.0),
            runaway_speed: T::c(0.2),
            runaway_torque: both(1.0),
            runaway_error: T::c(0.01 / crate::params::gain_scale(motor_hz)),
            runaway_periods: periods(0.010, 2),
            period: T::c(1.0 / f64::from(motor_hz.max(1))),
            encoder_band: T::c(1.5e-3),
            speed_error: T::c(0.01),
            speed_error_rel: T::c(0.04),
            model_error: T::c(0.25),
            coulomb: both(COULOMB),
            viscous: both(VISCOUS),
            disturbance: both(DISTURBANCE),
            inertia_inv: crate::Matrix2::zeros(),
            encoder_slack: T::c(0.01),
            frozen_reference: Vector2::zeros(),
            range_min: Vector2::new(T::c(-core::f64::consts::PI), T::c(-2.8)),
            range_max: Vector2::new(T::c(core::f64::consts::PI), T::c(2.8)),
            stop_accel: both(10.0),
            range_margin: T::c(0.02),
            thermal: Thermal {
                continuous: both(4.0),
                time_constant: T::c(20.0),
                derate: T::c(0.6),
                floor: T::c(0.9),
                trip: T::c(0.95),
            },
        }
        .for_arm(model, gains.kp.xy().component_mul(&gains.lambda.xy()))
    }

    /// These limits for the arm of `model` under a position loop of stiffness `stiffness`
    /// [N·m/rad] (the law's `K_p Λ` on the joints), with the friction set (`coulomb`):
    /// - `inertia_inv`: `B⁻¹`'s joint rows with the modes free (`S⁻¹`, `crate::model`), the
    ///   largest magnitude of each element over 16 poses of joint 2;
    /// - `frozen_reference_i = coulomb_i / stiffness_i + encoder_band` [rad]: the lag at which
    ///   the law's torque overcomes the friction at rest, and the band the joint then moves
    ///   within before its reading must change.
    pub fn for_arm(mut self, model: &Model<T>, stiffness: Vector2<T>) -> Self {
        let mut inverse = crate::Matrix2::<T>::zeros();
        let mut pose = Vector4::zeros();
        for _ in 0..16 {
            if let Some(s) = model.terms(&pose).schur_inverse() {
                inverse = inverse.sup(&s.abs());
            }
            pose.y += T::c(core::f64::consts::TAU / 16.0);
        }
        self.inertia_inv = inverse;
        let band = Vector2::new(self.encoder_band, self.encoder_band);
        self.frozen_reference = self.coulomb.component_div(&stiffness) + band;
        self
    }
}

/// The friction the encoder plausibility check allows for on each joint by default, its
/// direction unknown: its Coulomb part [N·m]. The paper names no drives; the truth plant's
/// (`flexarm_sim::truth_plant`) have 0.05 N·m of Coulomb friction, and 0.02 N·m is left for
/// their spread.
pub const COULOMB: f64 = 0.07;
/// Its viscous part [N·m·s/rad]: the truth plant's drives' 0.02 N·m·s/rad and half as much
/// again.
pub const VISCOUS: f64 = 0.03;
/// The torque beyond the friction the check allows the model to miss on each joint by
/// default [N·m]: on the Monte Carlo of the controller's model with its parameters ±20 % off
/// (`cargo test -p flexarm-sim --test motion_checks`) the check's evidence reaches 0.75 of a
/// trip with it, and the batch trips 9 times in 1000 without it.
pub const DISTURBANCE: f64 = 0.1;

/// What a motor period's check found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Nothing.
    Clear,
    /// A category-0 fault: the safe state now.
    Trip(Fault),
    /// A category-1 fault: a controlled stop, then the safe state.
    Stop(Fault),
}

/// One motor period's motion, as the drive sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionSample<T> {
    /// Measured joint angles [rad].
    pub theta: Vector2<T>,
    /// Reference joint angles [rad].
    pub theta_d: Vector2<T>,
    /// The observer's joint speeds [rad/s].
    pub speed: Vector2<T>,
    /// Torques commanded [N·m].
    pub tau: Vector2<T>,
    /// The model's joint accelerations under the torques and piezo force applied [rad/s²]
    /// (the observer's prediction, `crate::observer::Observer::joint_acceleration`).
    pub accel: Vector2<T>,
}

/// One joint's dead reckoning since its anchor (module docs). Angles [rad].
#[derive(Clone, Copy, Debug, PartialEq)]
struct Reckoning<T> {
    /// The reading at the anchor, `y_0`.
    reading: T,
    /// The predicted displacement over the next period, `s`, and its slack.
    step: T,
    step_slack: T,
    /// The predicted displacement since the anchor, `d`, and its slack `u`.
    moved: T,
    slack: T,
    /// The reference when the reading last changed.
    reference: T,
}

/// What a joint's reckoning reads in a period (angles [rad], speed [rad/s], acceleration
/// [rad/s²]).
struct Joint<T> {
    theta: T,
    /// The last period's reading, `None` after a restart.
    previous: Option<T>,
    theta_d: T,
    speed: T,
    accel: T,
    unexplained: T,
    frozen_reference: T,
}

impl<T: Real> Reckoning<T> {
    /// One period (module docs): the fault the reading shows, if any, and the evidence
    /// `|(y − y_0) − d| / (u + encoder_band)`; then the reckoning moves on to the next period.
    /// Not inlined: one copy serves both joints (the QEMU board's flash).
    #[inline(never)]
    fn check(&mut self, l: &MotionLimits<T>, j: &Joint<T>) -> (Option<Fault>, T) {
        let mut found = None;
        let mut evidence = T::zero();
        let mut anchor = j.previous.is_none();
        if let Some(p) = j.previous {
            let off = ((j.theta - self.reading) - self.moved).abs();
            let allowed = self.slack + l.encoder_band;
            let still = j.theta == p;
            let frozen = still
                && off > l.encoder_band
                && (j.theta_d - self.reference).abs() > j.frozen_reference;
            if off > allowed || frozen {
                // Named by what the reading does: stands still, or moves where the torques do
                // not move the joint.
                found = Some(if still {
                    Fault::FrozenEncoder
                } else {
                    Fault::EncoderMismatch
                });
            }
            evidence = off / allowed;
            anchor =
                self.slack >= l.encoder_slack && (j.theta != self.reading || off <= l.encoder_band);
        }
        if j.previous.is_none_or(|p| j.theta != p) {
            self.reference = j.theta_d;
        }
        // The next period: the speed `θ̇̂` is the observer's for its end (it has taken this
        // period's `θ̈ T`); under a torque held through the period the joint moves
        // `θ̇̂ T − θ̈ T²/2`.
        let a = j.accel;
        let t2 = l.period * l.period;
        if anchor {
            self.anchor(l, j.theta, j.speed);
        } else {
            self.step += a * t2;
            self.step_slack += (l.model_error * a.abs() + j.unexplained) * t2;
        }
        self.moved += self.step - a * t2 * T::c(0.5);
        self.slack += self.step_slack;
        (found, evidence)
    }

    /// Anchored at the reading `y` and the observer's speed `v` [rad/s].
    fn anchor(&mut self, l: &MotionLimits<T>, y: T, v: T) {
        self.reading = y;
        self.step = v * l.period;
        self.step_slack = (l.speed_error + l.speed_error_rel * v.abs()) * l.period;
        self.moved = T::zero();
        self.slack = T::zero();
    }
}

/// The checks' state: counters, the previous sample, the motors' heat.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionMonitor<T> {
    runaway: [u32; 2],
    reckoning: [Reckoning<T>; 2],
    /// The encoder plausibility's largest evidence in the last period,
    /// `|(y − y_0) − d| / (u + encoder_band)` over the joints (1 trips).
    evidence: T,
    /// The previous period's sample.
    previous: Option<MotionSample<T>>,
    /// The motors' I²t states [units of the continuous rating].
    pub heat: Vector2<T>,
}

impl<T: Real> Default for MotionMonitor<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real> MotionMonitor<T> {
    /// Cold motors, no history.
    pub fn new() -> Self {
        Self {
            runaway: [0; 2],
            reckoning: [Reckoning {
                reading: T::zero(),
                step: T::zero(),
                step_slack: T::zero(),
                moved: T::zero(),
                slack: T::zero(),
                reference: T::zero(),
            }; 2],
            evidence: T::zero(),
            previous: None,
            heat: Vector2::zeros(),
        }
    }

    /// The last sample checked.
    pub fn last(&self) -> Option<&MotionSample<T>> {
        self.previous.as_ref()
    }

    /// The runaway check's current streaks per joint [motor periods]: how many periods in a
    /// row it has counted (it trips at its window).
    pub fn streaks(&self) -> [u32; 2] {
        self.runaway
    }

    /// The encoder plausibility check's evidence in the last period: the largest over the
    /// joints of `|(y − y_0) − d| / (u + encoder_band)` (module docs; above 1 it trips).
    pub fn encoder_evidence(&self) -> T {
        self.evidence
    }

    /// Forgets the motion's history (the motors' heat stays): after a disarm or a new arm.
    pub fn restart(&mut self) {
        self.runaway = [0; 2];
        self.previous = None;
    }

    /// The motors cool (or heat) by one period `dt` [s] under the torques `tau` [N·m]; called
    /// every motor period, armed or not (disarmed, `tau` is zero).
    pub fn update_heat(&mut self, limits: &MotionLimits<T>, tau: Vector2<T>, dt: T) {
        let th = &limits.thermal;
        let k = dt / th.time_constant;
        let load = tau.component_div(&th.continuous);
        self.heat += (load.component_mul(&load) - self.heat) * k;
    }

    /// The torque limit the motors' heat allows, at most `rated` [N·m] (module docs).
    pub fn torque_limit(&self, limits: &MotionLimits<T>, rated: Vector2<T>) -> Vector2<T> {
        let th = &limits.thermal;
        rated.zip_zip_map(&th.continuous, &self.heat, |r, c, h| {
            if h <= th.derate {
                return r;
            }
            let f = ((h - th.derate) / (th.floor - th.derate)).min(T::one());
            let derated = r - (r - c) * f;
            if derated < r { derated } else { r }
        })
    }

    /// One armed motor period (module docs): the first check that fails, category 0 before 1.
    pub fn check(&mut self, limits: &MotionLimits<T>, s: &MotionSample<T>) -> Verdict {
        let l = limits;
        let e = s.theta - s.theta_d;
        let previous = self.previous.replace(*s);
        let mut verdict = Verdict::Clear;
        let mut implausible = None;
        let heat = self.heat;
        self.evidence = T::zero();
        // The acceleration the friction and disturbance may give each joint [rad/s²].
        let f = l.coulomb + l.viscous.component_mul(&s.speed.abs()) + l.disturbance;
        let unexplained = l.inertia_inv * f;
        let joints = self.runaway.iter_mut().zip(self.reckoning.iter_mut());
        for (j, (runaway, r)) in joints.enumerate() {
            let pick = |v: &Vector2<T>| if j == 0 { v.x } else { v.y };
            let (ej, vj, tj, thj) = (pick(&e), pick(&s.speed), pick(&s.tau), pick(&s.theta));
            if ej.abs() > pick(&l.following) {
                return Verdict::Trip(Fault::FollowingError);
            }
            if vj.abs() > pick(&l.speed) {
                return Verdict::Trip(Fault::Overspeed);
            }
            // Runaway: speeding up against the torque, off the reference. (A joint braking, even
            // saturated and behind its reference, slows down.)
            let growing = previous.is_some_and(|p| vj.abs() >= pick(&p.speed).abs());
            let against = tj * vj < T::zero() && tj.abs() >= pick(&l.runaway_torque);
            let counts =
                against && growing && vj.abs() >= l.runaway_speed && ej.abs() >= l.runaway_error;
            *runaway = if counts { runaway.saturating_add(1) } else { 0 };
            if *runaway >= l.runaway_periods {
                return Verdict::Trip(Fault::Runaway);
            }
            // Encoder plausibility: the reading against the dead reckoning (module docs).
            let joint = Joint {
                theta: thj,
                previous: previous.map(|p| pick(&p.theta)),
                theta_d: pick(&s.theta_d),
                speed: vj,
                accel: pick(&s.accel),
                unexplained: pick(&unexplained),
                frozen_reference: pick(&l.frozen_reference),
            };
            let (found, evidence) = r.check(l, &joint);
            implausible = implausible.or(found);
            if evidence > self.evidence {
                self.evidence = evidence;
            }
            // Soft limit: moving towards an end closer than the stopping distance.
            // (`d ≤ v²/(2a) + margin`, multiplied out: no division.)
            let within = |d: T| (d - l.range_margin) * T::c(2.0) * pick(&l.stop_accel) <= vj * vj;
            let towards_max = vj > T::zero() && within(pick(&l.range_max) - thj);
            let towards_min = vj < T::zero() && within(thj - pick(&l.range_min));
            if (towards_max || towards_min) && verdict == Verdict::Clear {
                verdict = Verdict::Stop(Fault::SoftLimit);
            }
            if pick(&heat) >= l.thermal.trip && verdict == Verdict::Clear {
                verdict = Verdict::Stop(Fault::Overload);
            }
        }
        // The encoder's plausibility is the least direct diagnosis: it names the fault only when
        // no other category-0 check of either joint trips in the period (a reversed encoder on
        // joint 1 runs away, and its reaction holds joint 2 still against its torque).
        match implausible {
            Some(f) => Verdict::Trip(f),
            None => verdict,
        }
    }
}

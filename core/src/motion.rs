//! Motion safety: the checks a drive runs on the motion itself, beyond the plausibility of each
//! sample (`crate::supervisor`). Per motor period, while the amplifiers are armed, from the
//! measured joint angles θ, the reference θ_d, the observer's joint speeds θ̇̂ and the torques
//! commanded τ:
//!
//! | check | trips when | fault | stop |
//! |---|---|---|---|
//! | following error | `\|θ_i − θ_d,i\| > following_i` | [`Fault::FollowingError`] | category 0 |
//! | runaway | for `runaway_periods` in a row: `\|θ̇̂_i\| ≥ runaway_speed` and not falling while `τ_i θ̇̂_i < 0` with `\|τ_i\| ≥ runaway_torque_i` (the joint speeds up against its torque), and `\|θ_i − θ_d,i\| ≥ runaway_error` | [`Fault::Runaway`] | category 0 |
//! | frozen encoder | for `frozen_periods` in a row: `\|τ_i\| ≥ frozen_torque_i` of one sign, the reference moving by at least `frozen_step` a period, and the encoder's reading unchanged | [`Fault::FrozenEncoder`] | category 0 |
//! | overspeed | `\|θ̇̂_i\| > speed_i` | [`Fault::Overspeed`] | category 0 |
//! | soft limit | a joint closer to the end of its range (`range_min`, `range_max`) than its stopping distance at `stop_accel` plus `range_margin`, moving towards it | [`Fault::SoftLimit`] | category 1 |
//! | motor overload | the I²t state of a motor reaches `thermal.trip` | [`Fault::Overload`] | category 1 |
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

use crate::Vector2;
use crate::fault::Fault;
use crate::real::Real;

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

impl<T: Real> Thermal<T> {
    /// The I²t state a motor is assumed to be in when its stored state is lost (a power cycle,
    /// a torn store: `crate::retained`): `floor`, where the torque limit is the continuous
    /// rating. It is the hottest state a motor can be left in and still be armed (at `trip`
    /// the first armed period would stop it), and a hot motor is never treated as cooler than
    /// it may be: the full torque comes back as it cools to `derate`, after
    /// `T_th ln(floor/derate)` (8.1 s at the defaults).
    pub fn assumed_hot(&self) -> T {
        self.floor
    }
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
    /// Frozen encoder: the torque magnitude that should move the joint [N·m].
    pub frozen_torque: Vector2<T>,
    /// Frozen encoder: consecutive motor periods without a change of the reading.
    pub frozen_periods: u32,
    /// Frozen encoder: the least step of the reference in one motor period [rad] for the
    /// period to count. A joint turning round under a large torque stays on one encoder count
    /// for tens of milliseconds (the circle's joint 1: up to 23 ms at 3.5 N·m); its reference
    /// turns round too, and such periods do not count.
    pub frozen_step: T,
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
    /// The defaults for the paper's arm at a motor loop of `motor_hz` (docs/safety.md gives the
    /// evidence): following error 0.05 rad (the truth plant's worst closed-loop error over the
    /// paper's moves and their Monte Carlo, times a margin); overspeed 4 rad/s (the moves are
    /// limited to 3); runaway at 0.2 rad/s against a torque of 1 N·m with an error of 0.01 rad,
    /// for 10 ms (the error scaled up as `K_p` is scaled down on a slow loop,
    /// [`crate::params::Gains::default_for`]: healthy tracking errors grow as `1/K_p`, 0.022
    /// rad at 100 Hz); frozen encoder at 3 N·m of one sign for 20 ms while the reference moves at
    /// 0.1 rad/s or more (the windows at least 2 and 3 periods); soft limits at the sensors'
    /// range (θ1 ±π, θ2 ±2.8 rad) with a 0.02 rad margin beyond the stopping distance at
    /// 10 rad/s²; motors rated 4 N·m continuous with a 20 s winding time constant, derating from
    /// 60 % of the rating's heat to the continuous torque at 90 %, faulting at 95 %.
    pub fn default_for(motor_hz: u32) -> Self {
        // The windows in periods, a few samples whatever the rate. At the QEMU board's 100 Hz
        // 10 ms is one period, and one noisy speed estimate on the circle tripped the runaway
        // check: it takes two (two differences of the speed). Two periods on one reading are
        // ordinary there too (joint 2 held still by the reaction of joint 1 accelerating at
        // 10 N·m): the frozen-encoder check takes three.
        let periods = |s: f64, min: u32| ((s * f64::from(motor_hz)) as u32).max(min);
        let both = |x: f64| Vector2::new(T::c(x), T::c(x));
        Self {
            following: both(0.05),
            speed: both(4.0),
            runaway_speed: T::c(0.2),
            runaway_torque: both(1.0),
            runaway_error: T::c(0.01 / crate::params::gain_scale(motor_hz)),
            runaway_periods: periods(0.010, 2),
            frozen_torque: both(3.0),
            frozen_periods: periods(0.020, 3),
            frozen_step: T::c(0.1 / f64::from(motor_hz.max(1))),
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
    }
}

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
}

/// The checks' state: counters, the previous sample, the motors' heat.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionMonitor<T> {
    runaway: [u32; 2],
    frozen: [u32; 2],
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
            frozen: [0; 2],
            previous: None,
            heat: Vector2::zeros(),
        }
    }

    /// The last sample checked.
    pub fn last(&self) -> Option<&MotionSample<T>> {
        self.previous.as_ref()
    }

    /// The trend checks' current streaks, `(runaway, frozen)` per joint [motor periods]: how
    /// many periods in a row each has counted (it trips at its window).
    pub fn streaks(&self) -> ([u32; 2], [u32; 2]) {
        (self.runaway, self.frozen)
    }

    /// Forgets the motion's history (the motors' heat stays): after a disarm or a new arm.
    pub fn restart(&mut self) {
        self.runaway = [0; 2];
        self.frozen = [0; 2];
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
        // A frozen reading is the least direct diagnosis: it names the fault only when no other
        // category-0 check of either joint trips in the period (a reversed encoder on joint 1
        // runs away, and its reaction holds joint 2 still against its torque).
        let mut frozen_reading = false;
        let heat = self.heat;
        let counters = self.runaway.iter_mut().zip(self.frozen.iter_mut());
        for (j, (runaway, frozen)) in counters.enumerate() {
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
            // Frozen encoder: a torque of one sign that should move the joint and a reference
            // on the move, a reading that does not. (A hold that chatters, its torque flipping
            // sign every period, moves the joint less than a count and is not a frozen encoder;
            // nor is a joint turning round with its reference.)
            let counts = tj.abs() >= pick(&l.frozen_torque)
                && previous.is_some_and(|p| {
                    pick(&p.theta) == thj
                        && pick(&p.tau) * tj > T::zero()
                        && (pick(&s.theta_d) - pick(&p.theta_d)).abs() >= l.frozen_step
                });
            *frozen = if counts { frozen.saturating_add(1) } else { 0 };
            frozen_reading |= *frozen >= l.frozen_periods;
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
        if frozen_reading {
            return Verdict::Trip(Fault::FrozenEncoder);
        }
        verdict
    }
}

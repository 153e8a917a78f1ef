//! Motion safety: the checks a drive runs on the motion itself, beyond the plausibility of each
//! sample (`crate::supervisor`). Per motor period, while the amplifiers are armed, from the
//! measured joint angles θ, the reference θ_d, the observer's joint speeds θ̇̂ and the torques
//! commanded τ:
//!
//! | check | trips when | fault | stop |
//! |---|---|---|---|
//! | following error | `\|θ_i − θ_d,i\| > following_i` | [`Fault::FollowingError`] | category 0 |
//! | runaway | for `runaway_periods` in a row: `\|θ̇̂_i\| ≥ runaway_speed` and not falling while `τ_i θ̇̂_i < 0` with `\|τ_i\| ≥ runaway_torque_i` (the joint speeds up against its torque), and `\|θ_i − θ_d,i\| ≥ runaway_error` | [`Fault::Runaway`] | category 0 |
//! | frozen encoder (a stall) | the encoder's reading unchanged for longer than the joint can stay within one count under the acceleration the model predicts for the torques, or while the observer's travel covers three counts with the torques pushing on (below) | [`Fault::FrozenEncoder`] | category 0 |
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
//! **The stall check** judges a reading that does not change from the physics rather than from
//! a speed threshold. Over a stretch of `n` motor periods (period `T`) in which a joint's
//! acceleration is at least `a > 0` of one sign, its angle `x(t)` has a second difference
//! `x(nT) − 2x(nT/2) + x(0) ≥ a (nT)²/4`; a joint that stays within one count `c` of its encoder
//! has a second difference of at most `2c`. So a reading unchanged for `n` periods while the
//! acceleration is at least `a` means a frozen encoder (or a joint held by something the model
//! does not know: an obstacle, a brake) once `a (nT)² > 8c`. The least acceleration is the
//! model's: `θ̈ = [B⁻¹(u − C q̇ − K q − D q̇)]_θ` at the observer's estimate for the torques
//! commanded ([`MotionSample::new`]: the other joint's reaction, the link's elastic pull and the
//! centrifugal terms in it), less what `stall_friction` can explain (mapped through the hubs'
//! inverse inertia `S⁻¹`), divided by `stall_margin` for an arm heavier than its model. As the
//! acceleration varies, the check keeps [`STALL_LEVELS`] levels `a_k = stall_accel · 2^k`, each
//! with the periods since the acceleration last fell below it, and trips on the first level
//! whose window `sqrt(8c/a_k)` has passed (at least [`STALL_MIN_PERIODS`] periods). A joint
//! turning round stays on one count for at most `sqrt(8c/a)` at its true acceleration `a`
//! (23 ms for the circle's joint 1 at about 6 rad/s²), inside the window the margin leaves.
//!
//! The stall check's second bound is the observer's: while the reading stays, the observer's
//! speed summed over the stay, `Σ θ̇̂ T`, is its travel, and the joint's own travel is under one
//! count. Once the observer's travel, less `stall_speed_error` times the stay's length, covers
//! three counts (one for the joint, two for the observer), with the model's acceleration along
//! it (the loop pushing on after a reading that froze, not braking a joint that its observer
//! overshoots), the reading is frozen. It catches a frozen encoder on a moving joint within a
//! few periods, and on a slow one once its observer's speed leaves the error allowed
//! (docs/safety.md, the table by speed).
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
use crate::limits::lower;
use crate::model::Model;
use crate::real::Real;
use crate::{Matrix2, Vector2, Vector4};

/// Levels of the stall check's acceleration (module docs): `stall_accel · 2^k`,
/// `k = 0 … STALL_LEVELS − 1`.
pub const STALL_LEVELS: usize = 10;

/// The shortest stall window [motor periods]: a reading unchanged for one or two periods is
/// ordinary at a slow loop's rate whatever the model says.
pub const STALL_MIN_PERIODS: u16 = 3;

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
    /// Stall check: one count of the encoders [rad].
    pub count: T,
    /// Stall check: the torque per joint the model does not explain while a joint is held
    /// still: static and Coulomb friction, cogging [N·m].
    pub stall_friction: Vector2<T>,
    /// Stall check: how much heavier than its model the arm may be (payload) [-].
    pub stall_margin: T,
    /// Stall check: the lowest acceleration level `a_0` [rad/s²].
    pub stall_accel: T,
    /// Stall check: how far the observer's joint speed may be off the joint's [rad/s].
    pub stall_speed_error: T,
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
    /// The holding brakes' watch (`crate::brake`): how far a joint may move once its brake
    /// has settled [rad]; 0 on an arm without brakes (no watch).
    pub brake_travel: T,
    /// The holding brakes' watch: motor periods from the brake output's engagement to the
    /// held pose (the brake's grip and the stop it makes).
    pub brake_settle_periods: u32,
}

impl<T: Real> MotionLimits<T> {
    /// The defaults for the paper's arm at a motor loop of `motor_hz` (docs/safety.md gives the
    /// evidence): following error 0.05 rad (the truth plant's worst closed-loop error over the
    /// paper's moves and their Monte Carlo, times a margin); overspeed 4 rad/s (the moves are
    /// limited to 3); runaway at 0.2 rad/s against a torque of 1 N·m with an error of 0.01 rad,
    /// for 10 ms (the error scaled up as `K_p` is scaled down on a slow loop,
    /// [`crate::params::Gains::default_for`]: healthy tracking errors grow as `1/K_p`, 0.022
    /// rad at 100 Hz); the stall check on 16384-count encoders, with 0.2 N·m of friction per
    /// joint (four times the truth plant's Coulomb friction), an arm up to 3 times heavier than
    /// its model, and levels from 0.02 rad/s² (a window of 0.39 s) to 10.24 rad/s² (17 ms);
    /// soft limits at the sensors'
    /// range (θ1 ±π, θ2 ±2.8 rad) with a 0.02 rad margin beyond the stopping distance at
    /// 10 rad/s²; motors rated 4 N·m continuous with a 20 s winding time constant, derating from
    /// 60 % of the rating's heat to the continuous torque at 90 %, faulting at 95 %; holding
    /// brakes that settle within 0.2 s and then hold each joint within 0.02 rad (52 counts).
    pub fn default_for(motor_hz: u32) -> Self {
        // The windows in periods, a few samples whatever the rate. At the QEMU board's 100 Hz
        // 10 ms is one period, and one noisy speed estimate on the circle tripped the runaway
        // check: it takes two (two differences of the speed).
        let periods = |s: f64, min: u32| ((s * f64::from(motor_hz)) as u32).max(min);
        let both = |x: f64| Vector2::new(T::c(x), T::c(x));
        Self {
            following: both(0.05),
            speed: both(4.0),
            runaway_speed: T::c(0.2),
            runaway_torque: both(1.0),
            runaway_error: T::c(0.01 / crate::params::gain_scale(motor_hz)),
            runaway_periods: periods(0.010, 2),
            count: T::c(core::f64::consts::TAU / 16384.0),
            stall_friction: both(0.1),
            stall_margin: T::c(5.0),
            stall_accel: T::c(0.02),
            stall_speed_error: T::c(0.1),
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
            brake_travel: T::c(0.02),
            brake_settle_periods: periods(0.2, 2),
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
    /// The joints' accelerations the model predicts for `tau` at the observer's estimate
    /// [rad/s²] ([`Self::new`]).
    pub accel: Vector2<T>,
    /// The hubs' inverse inertia `S⁻¹` there [1/(kg·m²)]: what a torque the model leaves out
    /// (friction) does to the accelerations.
    pub inertia_inv: Matrix2<T>,
}

impl<T: Real> MotionSample<T> {
    /// The sample of a period: the encoders' angles `theta` [rad], the reference `theta_d`
    /// [rad], the torques commanded `tau` [N·m] and the state `(q, q̇)` the law ran on (the
    /// observer's, or the measured one), with the model's joint accelerations for `tau` there,
    /// `θ̈ = [B⁻¹(u − C q̇ − K q − D q̇)]_θ` with `u = (τ, 0)`, and the hubs' inverse inertia
    /// `S⁻¹ = (B_θθ − B_θδ B_δθ)⁻¹` (module docs, the stall check). Both zero (the stall check's
    /// acceleration bound counts nothing) when the state is not finite.
    pub fn new(
        model: &Model<T>,
        (theta, theta_d): (Vector2<T>, Vector2<T>),
        (q, qd): (&Vector4<T>, &Vector4<T>),
        tau: Vector2<T>,
    ) -> Self {
        let terms = model.terms(q);
        let u = Vector4::new(tau.x, tau.y, T::zero(), T::zero());
        let (accel, inertia_inv) = match (
            model.acceleration_with(&terms, q, qd, &u),
            terms.schur_inverse(),
        ) {
            (Some(a), Some(s_inv)) => (a.xy(), s_inv),
            _ => (Vector2::zeros(), Matrix2::zeros()),
        };
        Self {
            theta,
            theta_d,
            speed: qd.xy(),
            tau,
            accel,
            inertia_inv,
        }
    }
}

/// One joint's trend checks' state.
#[derive(Clone, Copy, Debug, PartialEq)]
struct JointTrends<T> {
    /// Runaway: the periods in a row it has counted.
    runaway: u32,
    /// Stall: per level, the periods the reading has stayed with the least acceleration at or
    /// above the level.
    levels: [u16; STALL_LEVELS],
    /// Stall: the sign of the counted acceleration (0: none).
    sign: i8,
    /// Stall: the periods the reading has stayed.
    stay: u16,
    /// Stall: the observer's travel `Σ θ̇̂ T` while the reading stays [rad].
    travel: T,
}

impl<T: Real> JointTrends<T> {
    fn new() -> Self {
        Self {
            runaway: 0,
            levels: [0; STALL_LEVELS],
            sign: 0,
            stay: 0,
            travel: T::zero(),
        }
    }
}

/// The checks' state: counters, the previous sample, the motors' heat.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionMonitor<T> {
    joints: [JointTrends<T>; 2],
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
            joints: [JointTrends::new(); 2],
            previous: None,
            heat: Vector2::zeros(),
        }
    }

    /// The last sample checked.
    pub fn last(&self) -> Option<&MotionSample<T>> {
        self.previous.as_ref()
    }

    /// The runaway check's current streaks per joint [motor periods]: how many periods in a row
    /// it has counted (it trips at its window).
    pub fn streaks(&self) -> [u32; 2] {
        self.joints.map(|j| j.runaway)
    }

    /// How far the stall check has got: the largest share of a window the reading has stayed,
    /// over both joints, every acceleration level and the travel bound (it trips at 1).
    pub fn stall_fill(&self, limits: &MotionLimits<T>, period: T) -> T {
        let mut fill = T::zero();
        for joint in &self.joints {
            let mut a = limits.stall_accel;
            for &n in &joint.levels {
                fill = fill.max(T::count(n) / stall_window(limits, a, period));
                a *= T::c(2.0);
            }
            let stayed = T::count(joint.stay) * period;
            let covered = joint.travel.abs() - limits.stall_speed_error * stayed;
            fill = fill.max(covered / stall_travel(limits));
        }
        fill
    }

    /// Forgets the motion's history (the motors' heat stays): after a disarm or a new arm.
    pub fn restart(&mut self) {
        self.joints = [JointTrends::new(); 2];
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
            // A NaN share gives 1, as `min` would.
            let f = lower((h - th.derate) / (th.floor - th.derate), T::one());
            lower(r - (r - c) * f, r)
        })
    }

    /// One armed motor period of `period` [s] (module docs): the first check that fails,
    /// category 0 before 1.
    pub fn check(&mut self, limits: &MotionLimits<T>, s: &MotionSample<T>, period: T) -> Verdict {
        let l = limits;
        let e = s.theta - s.theta_d;
        let previous = self.previous.replace(*s);
        let mut verdict = Verdict::Clear;
        // A frozen reading is the least direct diagnosis: it names the fault only when no other
        // category-0 check of either joint trips in the period (a reversed encoder on joint 1
        // runs away, and its reaction holds joint 2 still against its torque).
        let mut frozen_reading = false;
        let heat = self.heat;
        let friction = s.inertia_inv.abs() * l.stall_friction;
        for (j, trends) in self.joints.iter_mut().enumerate() {
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
            let runaway = &mut trends.runaway;
            *runaway = if counts { runaway.saturating_add(1) } else { 0 };
            if *runaway >= l.runaway_periods {
                return Verdict::Trip(Fault::Runaway);
            }
            // Stall (module docs), while the reading stays.
            let unchanged = previous.is_some_and(|p| pick(&p.theta) == thj);
            let a = pick(&s.accel);
            // Moving: the observer's travel over the stay, less what its speed error can
            // account for, covers more than three counts, and the torques push the joint on
            // along it. (An observer whose model is off runs on past a joint that brakes
            // harder than it thinks; a loop chasing its reference past a frozen reading
            // pushes on.)
            let (stay, travel) = (&mut trends.stay, &mut trends.travel);
            (*stay, *travel) = if unchanged {
                (stay.saturating_add(1), *travel + vj * period)
            } else {
                (0, T::zero())
            };
            let covered = travel.abs() - l.stall_speed_error * T::count(*stay) * period;
            frozen_reading |=
                *stay >= STALL_MIN_PERIODS && covered >= stall_travel(l) && *travel * a > T::zero();
            // The least acceleration the model and the allowances leave, of one sign.
            let least = (a.abs() - pick(&friction)) / l.stall_margin;
            let sign = if least <= T::zero() {
                0
            } else if a > T::zero() {
                1
            } else {
                -1
            };
            // A change of the reading or of the acceleration's sign starts a new stretch.
            let restart = !unchanged || sign == 0 || sign != trends.sign;
            trends.sign = sign;
            // A level trips once `a_k (nT)² ≥ 8c`.
            let (mut a_k, eight_c) = (l.stall_accel, T::c(8.0) * l.count);
            for n in trends.levels.iter_mut() {
                *n = if !restart && least >= a_k {
                    n.saturating_add(1)
                } else {
                    0
                };
                let stayed = T::count(*n) * period;
                frozen_reading |= *n >= STALL_MIN_PERIODS && a_k * stayed * stayed >= eight_c;
                a_k *= T::c(2.0);
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
        if frozen_reading {
            return Verdict::Trip(Fault::FrozenEncoder);
        }
        verdict
    }
}

/// The stall check's travel bound [rad]: a joint moves at most one count while its reading
/// stays, and the observer's travel may be off by two more.
fn stall_travel<T: Real>(l: &MotionLimits<T>) -> T {
    T::c(3.0) * l.count
}

/// The stall check's window at the acceleration `a` [motor periods of `period` s]:
/// `sqrt(8c/a)/T`.
fn stall_window<T: Real>(l: &MotionLimits<T>, a: T, period: T) -> T {
    (T::c(8.0) * l.count / a).lsqrt() / period
}

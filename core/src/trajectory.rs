//! Desired joint trajectories `θ_d(t)`, `θ̇_d(t)`, `θ̈_d(t)` (the joint part of `q_d`; the modal
//! part `δ_d` is zero: gravity is ignored, so the arm at rest is undeformed).
//!
//! Time `t` [s] counts from the start of the trajectory. Angles in rad, positions in m, in the
//! base frame.
//!
//! - [`Trapezoid`]: the paper's joint moves (Fig. 5), a trapezoidal velocity profile. The paper
//!   gives the amplitude (π/2) only; the default timing is ours: the move takes 2 s with 0.5 s
//!   of constant acceleration and 0.5 s of constant deceleration, leaving 3 s of rest in the
//!   5 s run (exactly the window of Eq. 38).
//! - [`Circle`]: the task-space circle of Eq. 36 through inverse kinematics. The printed circle
//!   (centre (0.4, 0), radius 0.2) leaves the reachable annulus; [`Circle::paper`] is the nearest
//!   reachable circle of the same radius, see `docs/model.md`.

use crate::kinematics::{Elbow, Planar2};
use crate::real::Real;
use crate::{Vector2, Vector4};

/// Why a trajectory was refused at construction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TrajectoryError {
    /// A point of the path is outside the reachable annulus (with its margin) [m]; the
    /// distances in `f32` whatever the arm's precision (the MCU links no `f64` code for them).
    Unreachable {
        /// Distance of the offending point from joint 1 [m].
        distance: f32,
        /// Smallest allowed distance [m].
        min: f32,
        /// Largest allowed distance [m].
        max: f32,
    },
    /// A timing parameter is non-positive, or the ramps are longer than half the move.
    InvalidTiming,
    /// A parameter is NaN or infinite.
    NotFinite,
}

impl core::fmt::Display for TrajectoryError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Unreachable { distance, min, max } => write!(
                f,
                "target unreachable: it passes {distance:.3} m from joint 1, the arm reaches {min:.3} m to {max:.3} m"
            ),
            Self::InvalidTiming => {
                write!(
                    f,
                    "invalid timing: need duration > 0 and 0 < ramp time <= duration/2"
                )
            }
            Self::NotFinite => write!(f, "trajectory parameter is NaN or infinite"),
        }
    }
}

/// One sample of the desired joint motion. Laid out as written (`repr(C)`: the bench's C
/// comparison reads it).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct JointTarget<T> {
    /// `θ_d` [rad].
    pub q: Vector2<T>,
    /// `θ̇_d` [rad/s].
    pub qd: Vector2<T>,
    /// `θ̈_d` [rad/s²].
    pub qdd: Vector2<T>,
}

impl<T: Real> JointTarget<T> {
    /// At rest at `q` [rad].
    pub fn rest(q: Vector2<T>) -> Self {
        Self {
            q,
            qd: Vector2::zeros(),
            qdd: Vector2::zeros(),
        }
    }

    /// The same sample, value by value (see [`JointTrajectory::sample`]).
    #[inline(always)]
    fn rebuilt(self) -> Self {
        let v = |x: Vector2<T>| Vector2::new(x.x, x.y);
        Self {
            q: v(self.q),
            qd: v(self.qd),
            qdd: v(self.qdd),
        }
    }

    /// The full desired state `(q_d, q̇_d, q̈_d)` with `δ_d = 0`.
    pub fn generalized(&self) -> (Vector4<T>, Vector4<T>, Vector4<T>) {
        let z = T::zero();
        (
            Vector4::new(self.q.x, self.q.y, z, z),
            Vector4::new(self.qd.x, self.qd.y, z, z),
            Vector4::new(self.qdd.x, self.qdd.y, z, z),
        )
    }
}

/// Normalized trapezoidal-velocity profile `s(t)` from 0 to 1 over `duration` [s] with
/// constant acceleration for `ramp` [s] at each end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Profile<T> {
    duration: T,
    ramp: T,
    /// Cruise rate `1/(T − t_a)` [1/s].
    rate: T,
    /// Acceleration `rate/t_a` [1/s²].
    accel: T,
    /// Start of the deceleration `T − t_a` [s].
    cruise_end: T,
    /// `s` at the end of the first ramp, `accel t_a²/2`.
    s_ramp: T,
}

impl<T: Real> Profile<T> {
    /// A profile over `duration` [s] with ramps of `ramp` [s], `0 < ramp ≤ duration/2`.
    pub fn new(duration: T, ramp: T) -> Result<Self, TrajectoryError> {
        if !duration.finite() || !ramp.finite() {
            return Err(TrajectoryError::NotFinite);
        }
        if duration <= T::zero() || ramp <= T::zero() || ramp * T::c(2.0) > duration {
            return Err(TrajectoryError::InvalidTiming);
        }
        Ok(Self::from_timing(duration, ramp))
    }

    /// The profile of timings that [`Self::new`] accepts.
    fn from_timing(duration: T, ramp: T) -> Self {
        let rate = T::one() / (duration - ramp);
        let accel = rate / ramp;
        Self {
            duration,
            ramp,
            rate,
            accel,
            cruise_end: duration - ramp,
            s_ramp: T::c(0.5) * accel * ramp * ramp,
        }
    }

    /// Total duration [s].
    pub fn duration(&self) -> T {
        self.duration
    }

    /// Time of each constant-acceleration ramp [s].
    pub fn ramp(&self) -> T {
        self.ramp
    }

    /// `(s, ṡ, s̈)` at time `t` [s]; rest at 0 before the start (and for a NaN time), rest at
    /// 1 after the end. Right-continuous at every breakpoint, the start included: at `t = 0`
    /// the acceleration is already the first ramp's, so a zero-order hold of the sample taken
    /// at `t = 0` feeds the first period its acceleration.
    #[inline(always)]
    pub fn sample(&self, t: T) -> (T, T, T) {
        let half = T::c(0.5);
        let z = T::zero();
        // One comparison for NaN and t < 0.
        #[allow(clippy::neg_cmp_op_on_partial_ord)] // deliberate: NaN must take this branch
        if !(t >= z) {
            (z, z, z)
        } else if t < self.ramp {
            (half * self.accel * t * t, self.accel * t, self.accel)
        } else if t < self.cruise_end {
            (self.s_ramp + self.rate * (t - self.ramp), self.rate, z)
        } else if t < self.duration {
            let r = self.duration - t;
            (
                T::one() - half * self.accel * r * r,
                self.accel * r,
                -self.accel,
            )
        } else {
            (T::one(), z, z)
        }
    }
}

/// Joint-space move from `start` to `start + amplitude` with a trapezoidal velocity profile.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Trapezoid<T> {
    /// Initial joint angles [rad].
    pub start: Vector2<T>,
    /// Joint displacement [rad].
    pub amplitude: Vector2<T>,
    /// Time profile.
    pub profile: Profile<T>,
}

impl<T: Real> Trapezoid<T> {
    /// The paper's move (Fig. 5): both joints from 0 to π/2 in 2 s with 0.5 s ramps.
    pub fn paper() -> Self {
        let half_pi = T::c(core::f64::consts::FRAC_PI_2);
        Self {
            start: Vector2::zeros(),
            amplitude: Vector2::new(half_pi, half_pi),
            // 0 < 0.5 ≤ 2/2: timings that `Profile::new` accepts.
            profile: Profile::from_timing(T::c(2.0), T::c(0.5)),
        }
    }

    /// Desired motion at `t` [s].
    #[inline(always)]
    pub fn sample(&self, t: T) -> JointTarget<T> {
        let (s, sd, sdd) = self.profile.sample(t);
        JointTarget {
            q: self.start + self.amplitude * s,
            qd: self.amplitude * sd,
            qdd: self.amplitude * sdd,
        }
    }

    /// [`Self::sample`], called ([`JointTrajectory::sample`]).
    #[inline(never)]
    fn sample_called(&self, t: T) -> JointTarget<T> {
        self.sample(t)
    }
}

/// A circle of the tip in the base frame, run once with a trapezoidal profile of its phase,
/// through the rigid arm's inverse kinematics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Circle<T> {
    kin: Planar2<T>,
    elbow: Elbow,
    /// Centre [m].
    pub centre: Vector2<T>,
    /// Radius [m].
    pub radius: T,
    /// Phase at the start [rad], measured counter-clockwise from +x about the centre.
    pub start_phase: T,
    /// `−1` clockwise, `+1` counter-clockwise.
    direction: T,
    /// Time profile of one revolution.
    pub profile: Profile<T>,
    /// Joint angles at the start point [rad].
    pub start: Vector2<T>,
}

impl<T: Real> Circle<T> {
    /// A circle of the given centre and radius [m], run once from `start_phase` [rad] in the
    /// given direction with the given profile. Every point must lie at least `margin` [m]
    /// inside the reachable annulus, away from the singular stretched and folded arm.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        kin: Planar2<T>,
        centre: Vector2<T>,
        radius: T,
        start_phase: T,
        clockwise: bool,
        profile: Profile<T>,
        elbow: Elbow,
        margin: T,
    ) -> Result<Self, TrajectoryError> {
        let c = centre.norm();
        if !c.finite() || !radius.finite() || !start_phase.finite() || !margin.finite() {
            return Err(TrajectoryError::NotFinite);
        }
        if radius <= T::zero() {
            return Err(TrajectoryError::InvalidTiming);
        }
        let (lo, hi) = kin.annulus();
        let (near, far) = ((c - radius).abs(), c + radius);
        // The closest point lies at |c − r| (on the ray through the centre); if the circle
        // surrounds the base the closest distance is r − c.
        for d in [near, far] {
            if d < lo + margin || d > hi - margin {
                return Err(TrajectoryError::Unreachable {
                    distance: d.to_f32(),
                    min: (lo + margin).to_f32(),
                    max: (hi - margin).to_f32(),
                });
            }
        }
        let direction = if clockwise { -T::one() } else { T::one() };
        let (s, c) = start_phase.lsin_cos();
        let start = kin.inverse(&(centre + Vector2::new(c, s) * radius), elbow, margin)?;
        Ok(Self {
            kin,
            elbow,
            centre,
            radius,
            start_phase,
            direction,
            profile,
            start,
        })
    }

    /// Eq. 36 made reachable: radius 0.2 m (diameter 0.4 m as printed), run clockwise from the
    /// top point as the text says, one revolution in 4 s with 0.5 s ramps, centre moved from
    /// the printed (0.4, 0) m to (0.65, 0) m: the nearest centre on the same axis that keeps
    /// the whole circle 0.05 m inside the annulus 0.4 m ≤ ‖p‖ ≤ 1.0 m of the paper's arm.
    pub fn paper(a1: T, a2: T) -> Result<Self, TrajectoryError> {
        Self::new(
            Planar2 { a1, a2 },
            Vector2::new(T::c(0.65), T::zero()),
            T::c(0.2),
            T::c(core::f64::consts::FRAC_PI_2),
            true,
            Profile::new(T::c(4.0), T::c(0.5))?,
            Elbow::Positive,
            T::c(0.05),
        )
    }

    /// The circle exactly as Eq. 36 prints it: centre (0.4, 0) m, radius 0.2 m. Unreachable
    /// for the paper's arm; kept so the error can be shown.
    pub fn as_printed(a1: T, a2: T) -> Result<Self, TrajectoryError> {
        Self::new(
            Planar2 { a1, a2 },
            Vector2::new(T::c(0.4), T::zero()),
            T::c(0.2),
            T::c(core::f64::consts::FRAC_PI_2),
            true,
            Profile::new(T::c(4.0), T::c(0.5))?,
            Elbow::Positive,
            T::zero(),
        )
    }

    /// Tip position, velocity and acceleration [m, m/s, m/s²] at `t` [s].
    pub fn tip(&self, t: T) -> (Vector2<T>, Vector2<T>, Vector2<T>) {
        let (s, sd, sdd) = self.profile.sample(t);
        let two_pi = T::c(core::f64::consts::TAU) * self.direction;
        let psi = self.start_phase + two_pi * s;
        let (psi_d, psi_dd) = (two_pi * sd, two_pi * sdd);
        let (sn, cs) = psi.lsin_cos();
        let radial = Vector2::new(cs, sn);
        let tangent = Vector2::new(-sn, cs);
        let r = self.radius;
        (
            self.centre + radial * r,
            tangent * (r * psi_d),
            tangent * (r * psi_dd) - radial * (r * psi_d * psi_d),
        )
    }

    /// Desired joint motion at `t` [s].
    #[inline(never)]
    pub fn sample(&self, t: T) -> JointTarget<T> {
        let (p, v, a) = self.tip(t);
        // Reachability with margin was proven at construction: the negative margin here only
        // disables the check against rounding at the boundary (`inverse` clamps cos θ2).
        let no_check = -(self.kin.a1 + self.kin.a2);
        let q = match self.kin.inverse(&p, self.elbow, no_check) {
            Ok(q) => q,
            Err(_) => return JointTarget::rest(self.start),
        };
        let j = self.kin.jacobian(&q);
        let Some(j_inv) = j.try_inverse() else {
            return JointTarget::rest(q);
        };
        let qd = j_inv * v;
        let qdd = j_inv * (a - self.kin.jacobian_dot_times(&q, &qd));
        JointTarget { q, qd, qdd }
    }
}

/// One segment of a joint path: the cubic Hermite curve from `start` at speed `v0` to `end` at
/// speed `v1` [rad, rad/s] in `duration` [s]. With `s = t/T` and `Δ = end − start`:
///
/// `θ_d = start + Δ (3s² − 2s³) + T v0 (s³ − 2s² + s) + T v1 (s³ − s²)`,
///
/// continuous in position and speed at its ends, so a chain of segments through waypoints
/// (`crate::drive`'s waypoint moves) is too; its acceleration is linear in `t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cubic<T> {
    /// Joint angles at `t = 0` [rad].
    pub start: Vector2<T>,
    /// Joint angles at `t = T` [rad].
    pub end: Vector2<T>,
    /// Joint speeds at `t = 0` [rad/s].
    pub v0: Vector2<T>,
    /// Joint speeds at `t = T` [rad/s].
    pub v1: Vector2<T>,
    /// `T` [s], positive.
    pub duration: T,
}

impl<T: Real> Cubic<T> {
    /// Desired motion at `t` [s]: the curve on `[0, T)`; `start` at its speed `v0` before (and
    /// for a NaN time), `end` at `v1` from `T` on, both without acceleration. Right-continuous
    /// at `t = 0` like [`Profile::sample`]: the sample the motor loop takes at the start (and
    /// holds for a period) already carries the curve's acceleration. Called, like the
    /// circle's: inlined into [`JointTrajectory::sample`]'s called function, its frame would
    /// sit under every kind's sample (the stack bound of the tasks that sample).
    #[inline(never)]
    pub fn sample(&self, t: T) -> JointTarget<T> {
        let z = T::zero();
        #[allow(clippy::neg_cmp_op_on_partial_ord)] // deliberate: NaN must take this branch
        if !(t >= z) {
            return JointTarget {
                q: self.start,
                qd: self.v0,
                qdd: Vector2::zeros(),
            };
        }
        if t >= self.duration {
            return JointTarget {
                q: self.end,
                qd: self.v1,
                qdd: Vector2::zeros(),
            };
        }
        let d = self.duration;
        let s = t / d;
        let s2 = s * s;
        let (two, three, four, six) = (T::c(2.0), T::c(3.0), T::c(4.0), T::c(6.0));
        let delta = self.end - self.start;
        let (m0, m1) = (self.v0 * d, self.v1 * d);
        let q = self.start
            + delta * (three * s2 - two * s2 * s)
            + m0 * (s2 * s - two * s2 + s)
            + m1 * (s2 * s - s2);
        let qd = (delta * (six * s - six * s2)
            + m0 * (three * s2 - four * s + T::one())
            + m1 * (three * s2 - two * s))
            / d;
        let qdd = (delta * (six - T::c(12.0) * s) + m0 * (six * s - four) + m1 * (six * s - two))
            / (d * d);
        JointTarget { q, qd, qdd }
    }

    /// The largest `|θ̇_d|` and `|θ̈_d|` of each joint on the segment [rad/s, rad/s²]: the speed
    /// is quadratic in `t` (its ends and its vertex), the acceleration linear (its ends).
    pub fn peaks(&self) -> (Vector2<T>, Vector2<T>) {
        let d = self.duration;
        let (two, three, four, six) = (T::c(2.0), T::c(3.0), T::c(4.0), T::c(6.0));
        // One joint: its displacement Δ and its end speeds times T, m0 and m1.
        let joint = |delta: T, m0: T, m1: T| {
            // d·θ̇ = α s² + β s + m0.
            let alpha = -six * delta + three * m0 + three * m1;
            let beta = six * delta - four * m0 - two * m1;
            let mut peak = m0.abs().max(m1.abs());
            if alpha != T::zero() {
                let s = -beta / (two * alpha);
                if s > T::zero() && s < T::one() {
                    peak = peak.max((alpha * s * s + beta * s + m0).abs());
                }
            }
            // d²·θ̈ at s = 0 and s = 1.
            let accel = beta.abs().max((-six * delta + two * m0 + four * m1).abs());
            (peak / d, accel / (d * d))
        };
        let delta = self.end - self.start;
        let (m0, m1) = (self.v0 * d, self.v1 * d);
        let (v1, a1) = joint(delta.x, m0.x, m1.x);
        let (v2, a2) = joint(delta.y, m0.y, m1.y);
        (Vector2::new(v1, v2), Vector2::new(a1, a2))
    }
}

/// A joint trajectory the controllers can follow (an enum, so the firmware needs no `dyn`).
/// A byte tag (`repr(u8)`): the motor step's match on it is a compare, where the niche's
/// decoding took six instructions and a jump table (docs/performance.md, issue 31's third round).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(u8)]
pub enum JointTrajectory<T> {
    /// Hold still at the given angles [rad].
    Hold(Vector2<T>),
    /// A trapezoidal joint move.
    Trapezoid(Trapezoid<T>),
    /// A task-space circle.
    Circle(Circle<T>),
    /// One segment of a joint path through waypoints.
    Cubic(Cubic<T>),
}

impl<T: Real> JointTrajectory<T> {
    /// The time from which it holds its end pose [s] (0 for a hold).
    pub fn duration(&self) -> T {
        match self {
            Self::Hold(_) => T::zero(),
            Self::Trapezoid(tr) => tr.profile.duration(),
            Self::Circle(c) => c.profile.duration(),
            Self::Cubic(c) => c.duration,
        }
    }

    /// Desired joint motion at `t` [s] since the start.
    ///
    /// The trapezoid, the paper's move, is sampled in place, the other kinds in one called
    /// function: the motor step's path with a trapezoid is one compare, where a jump table
    /// took it before, and it spills less (docs/performance.md, issue 31's fourth round); a
    /// hold pays a call.
    #[inline(always)]
    pub fn sample(&self, t: T) -> JointTarget<T> {
        match self {
            Self::Trapezoid(tr) => tr.sample(t),
            // Rebuilt from its values: the sample of a called function then reaches the caller
            // in registers like the trapezoid's, not through the stack slot the call wrote.
            _ => self.sample_other(t).rebuilt(),
        }
    }

    /// [`Self::sample`] of every kind, called; each arm a call too, so that its frame adds
    /// nothing to the stack of the tasks that sample.
    #[inline(never)]
    fn sample_other(&self, t: T) -> JointTarget<T> {
        match self {
            Self::Hold(q) => JointTarget::rest(*q),
            Self::Trapezoid(tr) => tr.sample_called(t),
            Self::Circle(c) => c.sample(t),
            Self::Cubic(c) => c.sample(t),
        }
    }
}

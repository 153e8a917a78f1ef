//! The drive: the modes a host commands over the link, around the [`Controller`].
//!
//! | mode | amplifiers | reference | leaves by |
//! |---|---|---|---|
//! | `Disarmed` | off (safe command; checks and observer run) | — | `arm` |
//! | `Armed` | on | holds the pose where it was armed or where the last move or stop ended | `start` (a move), `disarm`, a fault |
//! | `Moving` | on | the move | its end (→ `Armed`), `stop`, `disarm`, a fault |
//! | `Stopping` | on | a controlled stop at the move limits' deceleration ([`Drive::stop`]) | its end (→ `Armed`), `disarm`, a fault |
//! | `Fault` | off (latched) | — | `clear`, when the cause is gone (→ `Disarmed`) |
//!
//! The link watchdog: once a host has spoken ([`Drive::heard`]), a move that goes on for
//! [`Drive::link_timeout`] motor periods without hearing from it again is stopped as by
//! [`Drive::stop`], and counted ([`Drive::link_stops`]). A drive no host has spoken to (the QEMU
//! verdict runs' boot move) is not watched.
//!
//! Every move is validated whole before it starts and refused with a reason, never applied in
//! part: its timing, its poses within the joints' ranges, its peak speed and acceleration within
//! [`MoveLimits`], and its peak torque, estimated as `|B_θθ| q̈_max` plus the largest
//! centrifugal term `|h| v_max²`, within the torque limits with a margin for the feedback
//! ([`MoveLimits::torque_share`]). A trapezoid is checked in closed form at its start and end
//! poses; a circle of the tip, which must start where the tip is held, at 200 points of its
//! revolution. Times are move-local [s] from the
//! drive's [`MoveClock`] (the integer tick base of `crate::time`); angles in rad, in the core's
//! joint frames.

use crate::Vector2;
use crate::controller::{Controller, MotorReport};
use crate::fault::Fault;
use crate::kinematics::{Elbow, Planar2};
use crate::observer::Measurement;
use crate::real::Real;
use crate::time::{MoveClock, Ticks};
use crate::trajectory::{Circle, JointTrajectory, Profile, Trapezoid};

/// The drive's mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Amplifiers off.
    Disarmed,
    /// Amplifiers on, holding.
    Armed,
    /// A move runs.
    Moving,
    /// Decelerating to rest after a stop.
    Stopping,
    /// A fault is latched.
    Fault,
}

/// Why a command was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refused {
    /// A fault is latched: clear it first.
    Faulted,
    /// The drive is disarmed: arm it first.
    NotArmed,
    /// A move or a stop runs.
    Moving,
    /// Nothing to clear, or the fault's cause is still there.
    CauseActive,
    /// A time or a value is not finite or not positive, or the ramps do not fit the move.
    OutOfRange,
    /// The end of the move leaves a joint's range.
    Unreachable,
    /// The move asks for more speed, acceleration or torque than the limits.
    TooFast,
}

/// Limits on the moves a host may command.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MoveLimits<T> {
    /// Largest joint speed of a move [rad/s].
    pub speed_max: Vector2<T>,
    /// Largest joint acceleration of a move, and the deceleration of a stop [rad/s²].
    pub accel_max: Vector2<T>,
    /// Largest joint angles a move may end at [rad].
    pub theta_max: Vector2<T>,
    /// Smallest joint angles a move may end at [rad].
    pub theta_min: Vector2<T>,
    /// Share of the torque limit the feed-forward of a move may use; the rest is the
    /// feedback's and the unmodelled dynamics'.
    pub torque_share: T,
}

impl<T: Real> Default for MoveLimits<T> {
    /// 3 rad/s and 10 rad/s² per joint (the paper's trapezoid reaches 1.05 rad/s and
    /// 2.1 rad/s²), poses inside θ1 ∈ [−3, 3], θ2 ∈ [−2.7, 2.7] rad (0.14 and 0.1 rad inside
    /// the sensor ranges that trip a fault; the paper's circle reaches θ2 = 2.69), three
    /// quarters of the torque limit for the feed-forward estimate (it adds magnitudes, so it
    /// over-estimates: half the limit refused the paper's circle, which peaks at 3.9 N·m in
    /// closed loop, `cargo sim paper`).
    fn default() -> Self {
        Self {
            speed_max: Vector2::new(T::c(3.0), T::c(3.0)),
            accel_max: Vector2::new(T::c(10.0), T::c(10.0)),
            theta_max: Vector2::new(T::c(3.0), T::c(2.7)),
            theta_min: Vector2::new(T::c(-3.0), T::c(-2.7)),
            torque_share: T::c(0.75),
        }
    }
}

/// A move a host asks for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MoveRequest<T> {
    /// From the held pose to `target` [rad] in `move_time` [s] with `ramp_time` [s] of
    /// constant acceleration at each end.
    Trapezoid {
        /// Joint targets [rad].
        target: Vector2<T>,
        /// Duration [s].
        move_time: T,
        /// Ramp at each end [s].
        ramp_time: T,
    },
    /// One revolution of the tip around `centre` [m] of radius `radius` [m], starting where the
    /// tip is (the held pose must lie on the circle, within 1 mm), in `period` [s] with
    /// `ramp_time` [s] of constant phase acceleration at each end, on the held pose's elbow.
    Circle {
        /// Centre in the base frame [m].
        centre: Vector2<T>,
        /// Radius [m].
        radius: T,
        /// One revolution [s].
        period: T,
        /// Ramp at each end [s].
        ramp_time: T,
        /// Direction.
        clockwise: bool,
    },
}

impl<T: Real> MoveRequest<T> {
    /// How long the move lasts [s].
    pub fn duration(&self) -> T {
        match *self {
            Self::Trapezoid { move_time, .. } => move_time,
            Self::Circle { period, .. } => period,
        }
    }
}

/// Points at which a circle's speed, acceleration and torque are checked.
const CIRCLE_CHECKS: usize = 200;

/// The drive (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Drive<T> {
    mode: Mode,
    clock: MoveClock,
    /// The tick of the next motor step (the last step's, plus one).
    next: Ticks,
    /// Trajectory time at which the running move or stop ends [s].
    end: T,
    /// Trajectory time at the clock's start [s] (a stop enters its trapezoid at its
    /// deceleration ramp).
    offset: T,
    /// The move limits.
    pub limits: MoveLimits<T>,
    /// Motor periods a move may run without a word from the host; 0 disables the watchdog.
    pub link_timeout: u32,
    /// The tick of the host's last request.
    last_heard: Option<Ticks>,
    /// Moves the watchdog has stopped.
    link_stops: u32,
}

impl<T: Real> Drive<T> {
    /// A disarmed drive on a motor loop of `motor_hz`; disarms `ctrl`.
    pub fn new(ctrl: &mut Controller<T>, motor_hz: u32, now: Ticks, limits: MoveLimits<T>) -> Self {
        ctrl.set_armed(false);
        Self {
            mode: Mode::Disarmed,
            clock: MoveClock::new(now, motor_hz),
            next: now,
            end: T::zero(),
            offset: T::zero(),
            limits,
            link_timeout: 0,
            last_heard: None,
            link_stops: 0,
        }
    }

    /// The mode (a latched fault first).
    pub fn mode(&self, ctrl: &Controller<T>) -> Mode {
        if ctrl.fault().is_some() {
            Mode::Fault
        } else {
            self.mode
        }
    }

    /// Trajectory time at `now` [s]: what [`Controller::motor_step`] takes.
    pub fn time(&self, now: Ticks) -> T {
        T::c(f64::from(self.clock.local_time(now))) + self.offset
    }

    /// Restarts the clock at `now` with the trajectory time `offset` [s].
    fn restart(&mut self, now: Ticks, offset: T, end: T) {
        self.clock = MoveClock::new(now, self.clock.rate_hz());
        self.offset = offset;
        self.end = end;
    }

    /// One motor step at `now`: the law while armed ([`Controller::motor_step`] at the move's
    /// time), the checks and the observer alone while disarmed ([`Controller::idle_step`]);
    /// then a move or stop that has ended leaves the drive holding.
    pub fn step(
        &mut self,
        ctrl: &mut Controller<T>,
        now: Ticks,
        y: Option<&Measurement<T>>,
    ) -> MotorReport<T> {
        let report = if ctrl.armed() {
            ctrl.motor_step(self.time(now), y)
        } else {
            ctrl.idle_step(y)
        };
        self.tick(now);
        self.watch_link(ctrl, now);
        self.next = now.next();
        report
    }

    /// The host spoke at `now`: feeds the link watchdog.
    pub fn heard(&mut self, now: Ticks) {
        self.last_heard = Some(now);
    }

    /// Moves the link watchdog has stopped since boot.
    pub fn link_stops(&self) -> u32 {
        self.link_stops
    }

    /// The link watchdog (module docs).
    fn watch_link(&mut self, ctrl: &mut Controller<T>, now: Ticks) {
        let Some(heard) = self.last_heard else {
            return;
        };
        let silent = now.0.wrapping_sub(heard.0) > u64::from(self.link_timeout);
        if self.link_timeout > 0
            && silent
            && self.mode == Mode::Moving
            && self.stop(ctrl, now).is_ok()
        {
            self.link_stops = self.link_stops.saturating_add(1);
        }
    }

    /// The tick of the next motor step: where a command given between two steps starts.
    pub fn next_tick(&self) -> Ticks {
        self.next
    }

    /// A move or stop that has ended leaves the drive holding.
    fn tick(&mut self, now: Ticks) {
        if matches!(self.mode, Mode::Moving | Mode::Stopping) && self.time(now) >= self.end {
            self.mode = Mode::Armed;
        }
    }

    /// Enables the amplifiers, holding the estimated pose.
    pub fn arm(&mut self, ctrl: &mut Controller<T>, now: Ticks) -> Result<(), Refused> {
        if ctrl.fault().is_some() {
            return Err(Refused::Faulted);
        }
        if self.mode == Mode::Disarmed {
            let q = ctrl.estimate().0;
            ctrl.trajectory = JointTrajectory::Hold(Vector2::new(q.x, q.y));
            self.restart(now, T::zero(), T::zero());
            ctrl.set_armed(true);
            self.mode = Mode::Armed;
        }
        Ok(())
    }

    /// Disables the amplifiers now (the safe command); always accepted.
    pub fn disarm(&mut self, ctrl: &mut Controller<T>) {
        ctrl.set_armed(false);
        self.mode = Mode::Disarmed;
    }

    /// Starts `request` from the held pose, after validating it whole. Returns its duration [s].
    pub fn start(
        &mut self,
        ctrl: &mut Controller<T>,
        now: Ticks,
        request: &MoveRequest<T>,
    ) -> Result<T, Refused> {
        match self.mode(ctrl) {
            Mode::Fault => return Err(Refused::Faulted),
            Mode::Disarmed => return Err(Refused::NotArmed),
            Mode::Moving | Mode::Stopping => return Err(Refused::Moving),
            Mode::Armed => {}
        }
        let from = ctrl.trajectory.sample(self.time(now)).q;
        let trajectory = self.validate(ctrl, from, request)?;
        let duration = request.duration();
        ctrl.trajectory = trajectory;
        self.restart(now, T::zero(), duration);
        self.mode = Mode::Moving;
        Ok(duration)
    }

    /// The trajectory of `request` from `from` [rad], or why it is refused.
    pub fn validate(
        &self,
        ctrl: &Controller<T>,
        from: Vector2<T>,
        request: &MoveRequest<T>,
    ) -> Result<JointTrajectory<T>, Refused> {
        let (target, move_time, ramp_time) = match *request {
            MoveRequest::Trapezoid {
                target,
                move_time,
                ramp_time,
            } => (target, move_time, ramp_time),
            MoveRequest::Circle {
                centre,
                radius,
                period,
                ramp_time,
                clockwise,
            } => return self.circle(ctrl, from, centre, radius, period, ramp_time, clockwise),
        };
        let l = &self.limits;
        let finite = [target.x, target.y, move_time, ramp_time]
            .iter()
            .all(|x| x.finite());
        if !finite {
            return Err(Refused::OutOfRange);
        }
        let profile = Profile::new(move_time, ramp_time).map_err(|_| Refused::OutOfRange)?;
        let inside = |x: T, lo: T, hi: T| x >= lo && x <= hi;
        if !(inside(target.x, l.theta_min.x, l.theta_max.x)
            && inside(target.y, l.theta_min.y, l.theta_max.y))
        {
            return Err(Refused::Unreachable);
        }
        let amplitude = target - from;
        // Peak speed A/(T − t_r) and acceleration A/((T − t_r) t_r) of the trapezoid.
        let cruise = move_time - ramp_time;
        let v = amplitude.abs() / cruise;
        let a = v / ramp_time;
        if v.x > l.speed_max.x || v.y > l.speed_max.y || a.x > l.accel_max.x || a.y > l.accel_max.y
        {
            return Err(Refused::TooFast);
        }
        // The peak speed and acceleration at the start and end poses.
        for pose in [from, target] {
            self.torque_within(ctrl, pose, v, a)?;
        }
        Ok(JointTrajectory::Trapezoid(Trapezoid {
            start: from,
            amplitude,
            profile,
        }))
    }

    /// The feed-forward torque at `pose` for joint speeds `v` and accelerations `a` (their
    /// magnitudes): `|B_θθ| a + |h| v²` (the rigid part of `B` and the joints' centrifugal
    /// term, `|∂h/∂θ2| ≤ a1 m2 a2/2` at δ = 0), within a share of the torque limit.
    fn torque_within(
        &self,
        ctrl: &Controller<T>,
        pose: Vector2<T>,
        v: Vector2<T>,
        a: Vector2<T>,
    ) -> Result<(), Refused> {
        let l = &self.limits;
        let tau_max = ctrl.motor.limits.tau_max;
        let p = &ctrl.motor.model.params;
        let h = p.a1 * p.m2 * p.a2 * T::c(0.5);
        let q = crate::Vector4::new(pose.x, pose.y, T::zero(), T::zero());
        let b = ctrl.motor.model.inertia(&q);
        let (b11, b12, b22) = (b.m11.abs(), b.m12.abs(), b.m22.abs());
        let tau = Vector2::new(
            b11 * a.x + b12 * a.y + h * (v.y * v.y + T::c(2.0) * v.x * v.y),
            b12 * a.x + b22 * a.y + h * v.x * v.x,
        );
        if tau.x <= l.torque_share * tau_max.x && tau.y <= l.torque_share * tau_max.y {
            Ok(())
        } else {
            Err(Refused::TooFast)
        }
    }

    /// The circle of [`MoveRequest::Circle`] from the held pose `from`, checked at
    /// [`CIRCLE_CHECKS`] points of its revolution: every joint inside the move limits' range,
    /// speed and acceleration within them, the feed-forward torque within its share.
    #[allow(clippy::too_many_arguments)]
    fn circle(
        &self,
        ctrl: &Controller<T>,
        from: Vector2<T>,
        centre: Vector2<T>,
        radius: T,
        period: T,
        ramp_time: T,
        clockwise: bool,
    ) -> Result<JointTrajectory<T>, Refused> {
        let finite = [centre.x, centre.y, radius, period, ramp_time]
            .iter()
            .all(|x| x.finite());
        if !finite || radius <= T::zero() {
            return Err(Refused::OutOfRange);
        }
        let profile = Profile::new(period, ramp_time).map_err(|_| Refused::OutOfRange)?;
        let p = &ctrl.motor.model.params;
        let kin = Planar2 { a1: p.a1, a2: p.a2 };
        // It starts where the tip is held.
        let rel = kin.forward(&from) - centre;
        if (rel.norm() - radius).abs() > T::c(1e-3) {
            return Err(Refused::Unreachable);
        }
        let elbow = if from.y < T::zero() {
            Elbow::Negative
        } else {
            Elbow::Positive
        };
        let phase = rel.y.latan2(rel.x);
        let circle = Circle::new(
            kin,
            centre,
            radius,
            phase,
            clockwise,
            profile,
            elbow,
            T::c(0.05),
        )
        .map_err(|_| Refused::Unreachable)?;
        // The inverse kinematics' start must be the held pose (not, say, θ1 ± 2π).
        if (circle.start - from).abs().max() > T::c(1e-3) {
            return Err(Refused::Unreachable);
        }
        let l = &self.limits;
        let inside = |q: Vector2<T>| {
            q.x >= l.theta_min.x
                && q.x <= l.theta_max.x
                && q.y >= l.theta_min.y
                && q.y <= l.theta_max.y
        };
        // The step in `T` (an f64 division here would pull software f64 into the firmware).
        let step = period / T::c(CIRCLE_CHECKS as f64);
        let mut t = T::zero();
        for _ in 0..=CIRCLE_CHECKS {
            let r = circle.sample(t);
            if !inside(r.q) {
                return Err(Refused::Unreachable);
            }
            let (v, a) = (r.qd.abs(), r.qdd.abs());
            if v.x > l.speed_max.x
                || v.y > l.speed_max.y
                || a.x > l.accel_max.x
                || a.y > l.accel_max.y
            {
                return Err(Refused::TooFast);
            }
            self.torque_within(ctrl, r.q, v, a)?;
            t += step;
        }
        Ok(JointTrajectory::Circle(circle))
    }

    /// A controlled stop (IEC 60204-1 category 1): from the reference's pose and speed
    /// `(q0, v0)` now, every joint decelerates to rest in the same time
    /// `t_r = max_i |v0_i| / a_i` (`a` the move limits' acceleration, so no joint brakes harder
    /// than its limit), then holds; the amplifiers stay on. The stop is the deceleration half
    /// of a trapezoid of duration `2 t_r` and ramps `t_r` (amplitude `v0 t_r`, starting
    /// `v0 t_r / 2` behind `q0`), entered at `t_r`: the controller's trajectory type does not
    /// change, so neither does its hot path. Holding or stopping already: nothing to do.
    pub fn stop(&mut self, ctrl: &mut Controller<T>, now: Ticks) -> Result<(), Refused> {
        match self.mode(ctrl) {
            Mode::Fault => Err(Refused::Faulted),
            Mode::Disarmed => Err(Refused::NotArmed),
            Mode::Armed | Mode::Stopping => Ok(()),
            Mode::Moving => {
                let r = ctrl.trajectory.sample(self.time(now));
                let a = self.limits.accel_max;
                let (t1, t2) = (r.qd.x.abs() / a.x, r.qd.y.abs() / a.y);
                let t_r = if t1 > t2 { t1 } else { t2 };
                match Profile::new(t_r + t_r, t_r) {
                    Ok(profile) => {
                        let amplitude = r.qd * t_r;
                        ctrl.trajectory = JointTrajectory::Trapezoid(Trapezoid {
                            start: r.q - amplitude * T::c(0.5),
                            amplitude,
                            profile,
                        });
                        self.restart(now, t_r, t_r + t_r);
                        self.mode = Mode::Stopping;
                    }
                    // At rest already (or a speed that is not finite): hold where it is.
                    Err(_) => {
                        ctrl.trajectory = JointTrajectory::Hold(r.q);
                        self.restart(now, T::zero(), T::zero());
                        self.mode = Mode::Armed;
                    }
                }
                Ok(())
            }
        }
    }

    /// Clears the latched fault when its cause is gone, and returns it; the drive is then
    /// disarmed. The cause is judged on `y`, a fresh measurement, and `amplifier_fault`, the
    /// amplifiers' fault line now:
    /// - measurement faults (non-finite, out of range, encoder jump, stale): `y` passes the
    ///   range checks;
    /// - an amplifier fault: the line is released;
    /// - an overrun or a watchdog reset: the loops run again (the caller is one of them);
    /// - a clock failure, a disabled brown-out reset, an invalid configuration or a singular
    ///   inertia matrix: never from the link (a power cycle or a new build fixes those).
    pub fn clear(
        &mut self,
        ctrl: &mut Controller<T>,
        y: Option<&Measurement<T>>,
        amplifier_fault: bool,
    ) -> Result<Fault, Refused> {
        let fault = ctrl.fault().ok_or(Refused::CauseActive)?;
        let measured = y.filter(|y| ctrl.sensor_limits().check(y, None, T::one()).is_ok());
        let gone = match fault {
            Fault::NonFinite | Fault::OutOfRange | Fault::EncoderJump | Fault::Stale => {
                measured.is_some()
            }
            Fault::Amplifier => !amplifier_fault && measured.is_some(),
            Fault::Overrun | Fault::Watchdog => measured.is_some(),
            Fault::Clock | Fault::BrownOutDisabled | Fault::InvalidConfig | Fault::Singular => {
                false
            }
        };
        let Some(y) = measured.filter(|_| gone) else {
            return Err(Refused::CauseActive);
        };
        ctrl.reset(y.theta);
        self.disarm(ctrl);
        Ok(fault)
    }
}

//! The complete controller the firmware runs: checks, observer, motor law, piezo law, latch.
//!
//! Two entry points, one per loop, as on the block diagram:
//!
//! - [`Controller::motor_step`] (motor loop): plausibility of the encoder/film sample,
//!   observer correction, trajectory sample, Eq. 7 or Eq. 16 on the estimated state, saturation,
//!   observer prediction with the torques and piezo force just applied;
//! - [`Controller::piezo_step`] (piezo loop): `V_a = sat(−k_c V̇_f)` (Eq. 17) with the film
//!   voltage checked, or the law [`Controller::design_piezo`] chose instead
//!   (`crate::control::select`: none, IRC, PPF).
//!
//! Both loops read the [`SafetyLatch`]: after any fault they command the safe state (zero
//! torque, zero voltage, amplifiers disabled) until [`Controller::reset`]. Disarmed
//! ([`Controller::set_armed`], the drive's `crate::drive`), the piezo loop commands 0 V and the
//! motor loop runs [`Controller::idle_step`]: the checks and the observer, no law.

use crate::control::integral::Integral;
use crate::control::motor::{MotorController, MotorLaw, MotorOutput};
use crate::control::piezo::{PiezoGains, PiezoLaw, PiezoPatch};
use crate::control::select::{DesignError, PiezoLawKind, PiezoSelect, PiezoSetup};
use crate::fault::Fault;
use crate::model::Model;
use crate::observer::{Gain, Measurement, Observer, film_map};
use crate::params::{ArmParams, Gains, Limits};
use crate::real::{Real, all_finite};
use crate::supervisor::{Command, SafetyLatch, SensorLimits, Staleness};
use crate::trajectory::JointTrajectory;
use crate::{Vector2, Vector4};

/// Where the motor law takes its modal state from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StateSource {
    /// The observer's estimate (a real board).
    Observer,
    /// The full measured state passed to [`Controller::motor_step_full_state`] (the paper's
    /// assumption; simulation only).
    FullState,
}

/// What one motor step did, for telemetry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorReport<T> {
    /// What goes to the amplifiers.
    pub command: Command<T>,
    /// The law's output before gating, when it ran.
    pub law: Option<MotorOutput<T>>,
}

/// The controller: laws, observer and fault logic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Controller<T> {
    /// Motor law.
    pub motor: MotorController<T>,
    /// The paper's piezo law (Eq. 17), run when [`Self::selected`] is the rate law.
    pub piezo: PiezoLaw<T>,
    /// The piezo law that runs: the rate law above, or another (issue 35); changed only
    /// through [`Self::design_piezo`] (and `crate::tuning`).
    select: PiezoSelect<T>,
    /// The patch, for the piezo's modal force in the observer's prediction.
    pub patch: PiezoPatch<T>,
    /// State observer.
    pub observer: Observer<T>,
    /// Physical ranges of the measurements.
    sensors: SensorLimits<T>,
    /// The largest encoder step of one motor period, `speed_max × motor_period` [rad], and
    /// the patch's modal force per volt `C_a` (Eq. 18): computed at construction from
    /// `sensors`, `motor_period` and `patch`, which are construction parameters (the observer
    /// holds the patch's film map the same way).
    encoder_step: T,
    c_a: Vector2<T>,
    /// Desired motion.
    pub trajectory: JointTrajectory<T>,
    /// Motor-loop period [s].
    pub motor_period: T,
    latch: SafetyLatch,
    /// The piezo loop's one test: a film sample passes when `|V_f| < film_gate` [V], which is
    /// the film's range `v_f_max` while armed with the latch clear and the rate law selected,
    /// and −1 (nothing passes) otherwise, so neither the latch nor the choice of law costs the
    /// paper's law's hot path a test of its own (the other laws run on the closed gate's
    /// branch, [`Self::piezo_step_selected`]). Every trip goes through
    /// [`Self::trip`], which closes it; [`Self::reset`] opens it.
    film_gate: T,
    /// The amplifiers may be driven (the drive's `armed`); a new controller is armed.
    armed: bool,
    staleness: Staleness,
    /// Encoder angles of the previous sample [rad].
    previous: Option<Vector2<T>>,
    v_a: T,
    /// The joints' integral action (`crate::control::integral`; idle while `K_i = 0`).
    integral: Integral<T>,
}

impl<T: Real> Controller<T> {
    /// Assembles a controller; `stale_limit` is the number of motor periods tolerated without a
    /// new sample. Parameters that fail validation latch [`Fault::InvalidConfig`] at once.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        motor: MotorController<T>,
        piezo: PiezoLaw<T>,
        patch: PiezoPatch<T>,
        observer: Observer<T>,
        sensors: SensorLimits<T>,
        trajectory: JointTrajectory<T>,
        motor_period: T,
        stale_limit: u32,
    ) -> Self {
        let valid = motor.model.params.validate().is_ok()
            && motor.gains.validate().is_ok()
            && motor.limits.validate().is_ok()
            && patch.validate(motor.model.params.a2).is_ok()
            && piezo.is_valid()
            && observer.is_finite()
            && motor_period.finite()
            && motor_period > T::zero();
        let mut c = Self {
            motor,
            piezo,
            select: PiezoSelect::Rate,
            patch,
            observer,
            sensors,
            encoder_step: sensors.speed_max * motor_period,
            c_a: patch.c_a(),
            trajectory,
            motor_period,
            latch: SafetyLatch::default(),
            film_gate: sensors.v_f_max,
            armed: true,
            staleness: Staleness::new(stale_limit),
            previous: None,
            v_a: T::zero(),
            integral: Integral::new(),
        };
        if !valid {
            c.trip(Fault::InvalidConfig);
        }
        c
    }

    /// The paper's arm, gains and patch with our defaults (`docs/model.md`): the controller the
    /// firmware runs, for the given law, trajectory, loop periods [s] and observer gain (designed
    /// for `motor_period`, see [`crate::observer_gains`]). Three motor periods without a sample
    /// trip [`Fault::Stale`].
    pub fn paper(
        law: MotorLaw,
        trajectory: JointTrajectory<T>,
        piezo_period: T,
        motor_period: T,
        observer_gain: Gain<T>,
    ) -> Self {
        Self::with_model(
            ArmParams::default(),
            law,
            trajectory,
            piezo_period,
            motor_period,
            observer_gain,
            PiezoPatch::paper(),
            PiezoGains::default(),
            Limits::default(),
        )
    }

    /// [`Self::paper`] with another model of the arm, patch, piezo-loop gains and limits: the
    /// arm `arm` (an identified one, `docs/identification.md`) with the paper's motor gains,
    /// the patch `patch` (its film map `k_s Δφ'` is the observer's), the piezo law
    /// `V_a = sat(−k_c V̇_f)` with `piezo_gains`, and `limits` (torques, and the voltage the
    /// board's piezo output stage can deliver). `observer_gain` must be designed for this arm
    /// and this patch's film map at `motor_period` [s] (`flexarm-sim firmware-params` does it
    /// for the firmware). An arm that fails [`ArmParams::validate`], a patch that is not on its
    /// link 2, or a gain `k_c` [s] or filter corner [Hz] that is not finite and positive,
    /// latches [`Fault::InvalidConfig`].
    #[allow(clippy::too_many_arguments)]
    pub fn with_model(
        arm: ArmParams<T>,
        law: MotorLaw,
        trajectory: JointTrajectory<T>,
        piezo_period: T,
        motor_period: T,
        observer_gain: Gain<T>,
        patch: PiezoPatch<T>,
        piezo_gains: PiezoGains<T>,
        limits: Limits<T>,
    ) -> Self {
        let theta0 = trajectory.sample(T::zero()).q;
        Self::new(
            MotorController {
                model: Model::new(arm),
                gains: Gains::default(),
                limits,
                law,
            },
            PiezoLaw::with_window(&piezo_gains, piezo_period, limits.v_a_min, limits.v_a_max),
            patch,
            Observer::new(observer_gain, film_map(&patch), motor_period, theta0),
            SensorLimits::default(),
            trajectory,
            motor_period,
            3,
        )
    }

    /// The observer's estimate `(q, q̇)` after the last motor step: its prediction for the next
    /// period.
    pub fn estimate(&self) -> (Vector4<T>, Vector4<T>) {
        self.observer.state()
    }

    /// The coordinates `q̂` the last motor step ran on (corrected by that step's measurement):
    /// the prediction `q̂ + q̇̂' T` taken back by one period, exactly (the observer's step moves
    /// `q` by its new rate). What the law's error `θ̂ − θ_d` refers to, and what telemetry and
    /// the motion checks report; [`Self::estimate`] is one period ahead of it.
    pub fn step_estimate(&self) -> Vector4<T> {
        let (q, qd) = self.observer.state();
        q - qd * self.motor_period
    }

    /// The latched fault, if any.
    pub fn fault(&self) -> Option<Fault> {
        self.latch.fault()
    }

    /// Latches `fault` from outside (overrun, amplifier fault input, watchdog, bad
    /// configuration). Returns `true` if it is the first.
    pub fn trip(&mut self, fault: Fault) -> bool {
        crate::hint::cold();
        self.v_a = T::zero();
        self.film_gate = -T::one();
        self.latch.trip(fault)
    }

    /// `r`'s value, or `None` after latching its fault.
    fn check<X>(&mut self, r: Result<X, Fault>) -> Option<X> {
        r.map_err(|f| self.trip(f)).ok()
    }

    /// Arms (the laws drive the amplifiers) or disarms (the safe command; the checks and the
    /// observer go on, predicting with zero input; the piezo law restarts when re-armed).
    pub fn set_armed(&mut self, armed: bool) {
        if armed && !self.armed {
            self.piezo.reset();
            self.select.reset();
            self.integral.reset();
        }
        self.armed = armed;
        self.v_a = T::zero();
        self.open_gate();
    }

    /// The measurements' physical ranges.
    pub fn sensor_limits(&self) -> &SensorLimits<T> {
        &self.sensors
    }

    /// Whether the laws drive the amplifiers.
    pub fn armed(&self) -> bool {
        self.armed
    }

    /// This piezo period's command plus `bias` [V], within the amplifier's window (bring-up and
    /// identification: a step of the patch's voltage, the feedback law still running); the
    /// observer and the telemetry see the command as applied. Zero, the safe command, when
    /// disarmed or latched. Called after [`Self::piezo_step`], outside its hot path.
    pub fn bias_piezo(&mut self, bias: T) -> T {
        if !self.armed || self.latch.fault().is_some() {
            return T::zero();
        }
        let l = &self.motor.limits;
        self.v_a = (self.v_a + bias).clamp(l.v_a_min, l.v_a_max);
        self.v_a
    }

    /// The piezo law that runs.
    pub fn selected(&self) -> PiezoLawKind {
        self.select.kind()
    }

    /// Designs the law `setup` names ([`PiezoSelect::design`]) for this controller's arm
    /// model, patch and piezo window at the piezo `period` [s], and runs it from now on, at
    /// rest (the command 0 V until its next step). A law its design rule refuses leaves none
    /// running (0 V) and latches [`Fault::InvalidConfig`]. The caller sees that the piezo
    /// output is off while it changes (`crate::tuning`'s rule); a board calls it at start.
    pub fn design_piezo(&mut self, setup: &PiezoSetup<T>, period: T) -> Result<(), DesignError> {
        let l = &self.motor.limits;
        let modes = &self.motor.model.params.modes;
        match PiezoSelect::design(setup, modes, &self.patch, period, l.v_a_min, l.v_a_max) {
            Ok(law) => {
                self.install_piezo(law);
                Ok(())
            }
            Err(e) => {
                self.install_piezo(PiezoSelect::Off);
                self.trip(Fault::InvalidConfig);
                Err(e)
            }
        }
    }

    /// Runs `law`, a law [`PiezoSelect::design`] built (valid and at rest), from now on.
    pub(crate) fn install_piezo(&mut self, law: PiezoSelect<T>) {
        self.select = law;
        self.v_a = T::zero();
        self.open_gate();
    }

    /// The film gate: the film's range while armed with the latch clear and the rate law
    /// selected, closed otherwise.
    fn open_gate(&mut self) {
        self.film_gate = if self.armed
            && self.latch.fault().is_none()
            && matches!(self.select, PiezoSelect::Rate)
        {
            self.sensors.v_f_max
        } else {
            -T::one()
        };
    }

    /// Clears the latch and restarts the filters and the observer at the encoder angles
    /// `theta` [rad]. Angles that are not finite trip [`Fault::NonFinite`] at once.
    pub fn reset(&mut self, theta: Vector2<T>) {
        self.latch.reset();
        self.open_gate();
        self.piezo.reset();
        self.select.reset();
        self.integral.reset();
        self.v_a = T::zero();
        self.reset_observer(theta);
    }

    /// The encoders' frame moved by `delta` [rad] (homing, `crate::homing`): the estimate and
    /// the previous sample move with it, the motion's estimate stays, so neither the jump
    /// check nor the motion checks see a step that is not one. Angles that are not finite
    /// trip [`Fault::NonFinite`].
    pub fn shift_frame(&mut self, delta: Vector2<T>) {
        if !all_finite([delta.x, delta.y]) {
            self.trip(Fault::NonFinite);
            return;
        }
        self.observer.shift(delta);
        self.previous = self.previous.map(|p| p + delta);
    }

    /// Restarts the observer at rest at the encoder angles `theta` [rad], undeformed (at
    /// power-up, before the loops start). The latch is not cleared; angles that are not finite
    /// trip [`Fault::NonFinite`] and leave the estimate as it was.
    pub fn reset_observer(&mut self, theta: Vector2<T>) {
        self.previous = None;
        if all_finite([theta.x, theta.y]) {
            self.observer.reset(theta);
        } else {
            self.trip(Fault::NonFinite);
        }
    }

    /// One motor step at `t` [s] since the trajectory started. `y` is `None` when no new
    /// sample arrived this period. Inlined into its caller, which then builds only the parts of
    /// the report it reads (the firmware's drive has one call).
    #[inline(always)]
    pub fn motor_step(&mut self, t: T, y: Option<&Measurement<T>>) -> MotorReport<T> {
        let law = self.run_motor(t, y, None);
        self.report(law)
    }

    /// One motor step while disarmed (the drive calls it instead of [`Self::motor_step`]): the
    /// checks and the observer run, the observer predicting with zero input since the
    /// amplifiers are off; the command is the safe one.
    pub fn idle_step(&mut self, y: Option<&Measurement<T>>) -> MotorReport<T> {
        self.run_idle(y);
        self.report(None)
    }

    /// The motor period's sample: staleness, the plausibility checks, the observer's
    /// correction. `None` after latching the fault a check found.
    #[inline(always)]
    fn take(&mut self, y: Option<&Measurement<T>>) -> Option<()> {
        let stale = self.staleness.tick(y.is_some());
        self.check(stale)?;
        if let Some(y) = y {
            let checked = self
                .sensors
                .check_step(y, self.previous.as_ref(), self.encoder_step);
            self.check(checked)?;
            // The range check has rejected NaN and ±∞.
            self.observer.correct_finite(y);
            self.previous = Some(y.theta);
        }
        Some(())
    }

    fn run_idle(&mut self, y: Option<&Measurement<T>>) -> Option<()> {
        if self.latch.fault().is_some() {
            return None;
        }
        self.take(y)?;
        let terms = self.motor.model.terms(&self.observer.state().0);
        let predicted = self
            .observer
            .predict_with(&self.motor.model, &terms, &Vector4::zeros());
        self.check(predicted)
    }

    /// One motor step with the full state `(q, q̇)` measured (the paper's assumption), for
    /// comparing with the observer in simulation. The checks and the latch still apply.
    pub fn motor_step_full_state(
        &mut self,
        t: T,
        y: &Measurement<T>,
        q: &Vector4<T>,
        qd: &Vector4<T>,
    ) -> MotorReport<T> {
        let law = self.run_motor(t, Some(y), Some((q, qd)));
        self.report(law)
    }

    /// The step's command: the law's torques when it ran; the safe state otherwise (every path
    /// of [`Self::run_motor`] that returns `None` has latched a fault; [`Self::idle_step`]
    /// always commands it).
    fn report(&self, law: Option<MotorOutput<T>>) -> MotorReport<T> {
        let command = match law {
            Some(l) => Command {
                tau: l.tau,
                v_a: self.v_a,
                enable: true,
            },
            None => Command::safe(),
        };
        MotorReport { command, law }
    }

    #[inline(always)]
    fn run_motor(
        &mut self,
        t: T,
        y: Option<&Measurement<T>>,
        full: Option<(&Vector4<T>, &Vector4<T>)>,
    ) -> Option<MotorOutput<T>> {
        if self.latch.fault().is_some() {
            return None;
        }
        // The estimate is finite by construction (`Observer::is_finite`): of the law's inputs
        // only the caller's clock needs a check.
        if !t.finite() {
            self.trip(Fault::NonFinite);
            return None;
        }
        self.take(y)?;
        // The trajectory's sample before the terms of B(q̂): its branches then hold none of
        // them live.
        let target = self.trajectory.sample(t);
        let (q_hat, qd_hat) = self.observer.state();
        // One set of B(q) terms serves the law and the observer's prediction when the law runs
        // on the estimate.
        let terms_hat = self.motor.model.terms_inline(&q_hat);
        // The prediction solves with S⁻¹ (`Model::acceleration_with`): an estimate where it
        // does not exist trips now what the prediction would trip after the law. The law and
        // the prediction then run knowing that it does.
        if terms_hat.schur_inverse().is_none() {
            self.trip(Fault::Singular);
            return None;
        }
        // The joints' integral action, when the gains have it (the paper's have none: then
        // the law runs on the target itself). One test, the law in each branch: nothing of
        // the integral's stays live across the law of the other.
        let ki = self.motor.gains.ki;
        let estimate = (&q_hat, &qd_hat);
        let out = if ki.x != T::zero() || ki.y != T::zero() {
            let state = match full {
                Some((q, qd)) => (q.xy(), qd.xy()),
                None => (q_hat.xy(), qd_hat.xy()),
            };
            let measured = y.map(|y| y.theta);
            let law_target = self
                .integral
                .prepare(&self.motor.gains, &target, state, measured);
            let mut out = self.law(t, full, &terms_hat, estimate, &law_target)?;
            let limits = (out.tau, self.motor.limits.tau_max);
            self.integral
                .finish(&self.motor.gains, &mut out.error, limits, self.motor_period);
            out
        } else {
            self.law(t, full, &terms_hat, estimate, &target)?
        };
        // u = [τ, C_a V_a] (Eq. 18), written out: IEEE arithmetic cannot drop the `+ 0`s.
        let f = self.c_a * self.v_a;
        let u = Vector4::new(out.tau.x, out.tau.y, f.x, f.y);
        let predicted = self
            .observer
            .predict_with(&self.motor.model, &terms_hat, &u);
        self.check(predicted)?;
        Some(out)
    }

    /// The motor law on `target` at `t`: on the full state when given, else on the estimate
    /// with its terms; a fault it finds latched (`None`).
    #[inline(always)]
    fn law(
        &mut self,
        t: T,
        full: Option<(&Vector4<T>, &Vector4<T>)>,
        terms_hat: &crate::model::Terms<T>,
        (q_hat, qd_hat): (&Vector4<T>, &Vector4<T>),
        target: &crate::trajectory::JointTarget<T>,
    ) -> Option<MotorOutput<T>> {
        let out = match full {
            Some((q, qd)) => self.motor.step(t, q, qd, target),
            None => self.motor.law_with(terms_hat, t, q_hat, qd_hat, target),
        };
        self.check(out)
    }

    /// One piezo step with the film voltage `v_f` [V]; returns the amplifier command [V]
    /// (0 V in the safe state).
    pub fn piezo_step(&mut self, v_f: T) -> T {
        // One comparison rejects a latched or disarmed controller (the gate is closed) and NaN,
        // ±∞ and out-of-range samples; the cause is sorted out on the (rare) fault path.
        #[allow(clippy::neg_cmp_op_on_partial_ord)] // deliberate: NaN must take this branch
        if !(v_f.abs() < self.film_gate) {
            crate::hint::cold();
            return self.piezo_step_selected(v_f);
        }
        self.v_a = self.piezo.step_finite(v_f);
        self.v_a
    }

    /// The closed gate's branch of [`Self::piezo_step`]: 0 V when disarmed or latched; a
    /// sample out of the film's range or not finite trips its fault; otherwise the selected
    /// law other than the rate law runs (none: 0 V).
    #[inline(never)]
    fn piezo_step_selected(&mut self, v_f: T) -> T {
        if !self.armed || self.latch.fault().is_some() {
            return T::zero();
        }
        #[allow(clippy::neg_cmp_op_on_partial_ord)] // deliberate: NaN must take this branch
        if !(v_f.abs() < self.sensors.v_f_max) {
            self.trip(if v_f.finite() {
                Fault::OutOfRange
            } else {
                Fault::NonFinite
            });
            return T::zero();
        }
        self.v_a = self.select.step(v_f);
        self.v_a
    }
}

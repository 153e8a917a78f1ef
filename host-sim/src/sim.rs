//! The multi-rate closed loop: the plant integrated at `plant_dt`, the motor and piezo loops
//! sampled at their own rates with zero-order hold, exactly as the firmware runs them.

use flexarm_core::control::motor::{MotorController, MotorLaw};
use flexarm_core::control::piezo::{PiezoGains, PiezoLaw, PiezoPatch};
use flexarm_core::indices::{L2Norm, TailMean};
use flexarm_core::model::Model;
use flexarm_core::params::{ArmParams, Gains, Limits, ParamError};
use flexarm_core::trajectory::JointTrajectory;
use flexarm_core::{Fault, Vector2, Vector4};

use crate::plant::{PlantError, State, rk4_step};

/// Loop rates and the plant step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rates {
    /// Plant integration step [s].
    pub plant_dt: f64,
    /// Motor loop rate [Hz].
    pub motor_hz: f64,
    /// Piezo loop rate [Hz].
    pub piezo_hz: f64,
}

impl Default for Rates {
    /// Plant 0.1 ms, motor loop 1 kHz, piezo loop 10 kHz (the hardware rates).
    fn default() -> Self {
        Self {
            plant_dt: 1e-4,
            motor_hz: 1e3,
            piezo_hz: 1e4,
        }
    }
}

impl Rates {
    /// Plant steps per motor period and per piezo period; each period must be a whole number
    /// of plant steps.
    pub fn divisors(&self) -> Result<(u64, u64), SimError> {
        let div = |hz: f64, name: &'static str| {
            if !(hz.is_finite() && hz > 0.0 && self.plant_dt.is_finite() && self.plant_dt > 0.0) {
                return Err(SimError::Config(ParamError::InvalidRate(name)));
            }
            let n = 1.0 / (hz * self.plant_dt);
            let r = n.round();
            if r < 1.0 || (n - r).abs() > 1e-6 * r {
                return Err(SimError::Rates {
                    name,
                    hz,
                    plant_dt: self.plant_dt,
                });
            }
            Ok(r as u64)
        };
        Ok((
            div(self.motor_hz, "motor_hz")?,
            div(self.piezo_hz, "piezo_hz")?,
        ))
    }
}

/// Everything a closed-loop run needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimConfig {
    /// The plant's parameters (also the controller's model, cast to `f32`).
    pub arm: ArmParams<f64>,
    /// Motor-law gains.
    pub gains: Gains<f32>,
    /// Actuator limits.
    pub limits: Limits<f32>,
    /// Eq. 7 or Eq. 16.
    pub law: MotorLaw,
    /// The piezo patch (plant side, `f64`).
    pub patch: PiezoPatch<f64>,
    /// Piezo loop gains; `None` leaves the actuator at 0 V.
    pub piezo: Option<PiezoGains<f32>>,
    /// Rates.
    pub rates: Rates,
    /// Run length [s].
    pub duration: f64,
    /// Window of Eq. 38 [s] at the end of the run.
    pub tail_window: f64,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            arm: ArmParams::default(),
            gains: Gains::default(),
            limits: Limits::default(),
            law: MotorLaw::Tracking,
            patch: PiezoPatch::paper(),
            piezo: None,
            rates: Rates::default(),
            duration: 5.0,
            tail_window: 3.0,
        }
    }
}

/// Why a run could not be done.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SimError {
    /// A parameter is not physical.
    Config(ParamError),
    /// A loop period is not a whole number of plant steps.
    Rates {
        /// Which rate.
        name: &'static str,
        /// Its value [Hz].
        hz: f64,
        /// The plant step [s].
        plant_dt: f64,
    },
    /// The plant diverged.
    Plant(PlantError),
    /// The controller went to its safe state.
    Fault {
        /// Why.
        fault: Fault,
        /// When [s].
        t: f64,
    },
}

impl core::fmt::Display for SimError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Config(e) => write!(f, "invalid configuration: {e}"),
            Self::Rates { name, hz, plant_dt } => write!(
                f,
                "incompatible rates: {name} = {hz} Hz is not a whole number of plant steps of {plant_dt} s"
            ),
            Self::Plant(e) => write!(f, "{e}"),
            Self::Fault { fault, t } => write!(f, "controller fault at t = {t:.4} s: {fault}"),
        }
    }
}

impl std::error::Error for SimError {}

/// One recorded sample, taken at every motor period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Time [s].
    pub t: f64,
    /// Plant state.
    pub x: State,
    /// Desired joint angles [rad].
    pub q_d: Vector2<f64>,
    /// Motor torques applied [N·m].
    pub tau: Vector2<f64>,
    /// Piezo actuator voltage applied [V].
    pub v_a: f64,
    /// Film voltage [V].
    pub v_f: f64,
    /// Tip deflection [m].
    pub tip: f64,
}

/// The indices of one run (Eqs. 37, 38) and peak efforts.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Summary {
    /// Eq. 37 of the modal coordinates δ [√kg·m].
    pub l2_delta: f64,
    /// Eq. 37 of the joint error θ − θ_d [rad].
    pub l2_error: f64,
    /// Eq. 37 of the tip deflection [m].
    pub l2_tip: f64,
    /// Eq. 38 of the joint errors, signed [rad].
    pub tail_error: [f64; 2],
    /// Eq. 38 of the joint errors, mean absolute value [rad].
    pub tail_error_abs: [f64; 2],
    /// Eq. 38 of δ, mean absolute value [√kg·m].
    pub tail_delta_abs: [f64; 2],
    /// Largest |τ| per joint [N·m].
    pub max_tau: [f64; 2],
    /// Largest |V_a| [V].
    pub max_v_a: f64,
    /// Largest |tip deflection| [m].
    pub max_tip: f64,
}

/// Runs the closed loop from rest at `θ_d(0)`; `record` keeps one [`Sample`] per motor period.
pub fn simulate(
    cfg: &SimConfig,
    traj: &JointTrajectory<f32>,
    record: bool,
) -> Result<(Summary, Vec<Sample>), SimError> {
    cfg.arm.validate().map_err(SimError::Config)?;
    cfg.gains.validate().map_err(SimError::Config)?;
    cfg.limits.validate().map_err(SimError::Config)?;
    if !(cfg.duration.is_finite() && cfg.duration > 0.0) {
        return Err(SimError::Config(ParamError::NotPositive("duration")));
    }
    let (motor_div, piezo_div) = cfg.rates.divisors()?;
    let dt = cfg.rates.plant_dt;
    let plant = Model::new(cfg.arm);
    let motor = MotorController {
        model: Model::new(cfg.arm.cast::<f32>()),
        gains: cfg.gains,
        limits: cfg.limits,
        law: cfg.law,
    };
    let piezo_period = (dt * piezo_div as f64) as f32;
    let mut piezo = cfg
        .piezo
        .map(|g| PiezoLaw::new(&g, piezo_period, cfg.limits.v_a_max));

    let th0 = traj.sample(0.0).q;
    let mut x = State::rest(Vector4::new(f64::from(th0.x), f64::from(th0.y), 0.0, 0.0));
    let steps = (cfg.duration / dt).round() as u64;
    let motor_dt = dt * motor_div as f64;

    let mut sum = Summary::default();
    let (mut l2_delta, mut l2_error, mut l2_tip) =
        (L2Norm::default(), L2Norm::default(), L2Norm::default());
    let mut tail_err = TailMean::<f64, 2>::new(cfg.duration, cfg.tail_window);
    let mut tail_delta = TailMean::<f64, 2>::new(cfg.duration, cfg.tail_window);
    let mut trace = Vec::new();
    let (mut tau, mut v_a, mut v_f) = (Vector2::<f64>::zeros(), 0.0_f64, 0.0_f64);

    for k in 0..steps {
        let t = k as f64 * dt;
        if k % piezo_div == 0 {
            v_f = cfg.patch.film_voltage(&x.q);
            v_a = piezo
                .as_mut()
                .map_or(0.0, |p| f64::from(p.step(v_f as f32)));
        }
        if k % motor_div == 0 {
            let target = traj.sample(t as f32);
            let q = x.q.cast::<f32>();
            let qd = x.qd.cast::<f32>();
            let out = motor
                .step(t as f32, &q, &qd, &target)
                .map_err(|fault| SimError::Fault { fault, t })?;
            tau = out.tau.cast::<f64>();
            let err = out.error.cast::<f64>();
            let delta = Vector2::new(x.q.z, x.q.w);
            let tip = plant.tip_deflection(&x.q);
            l2_delta.add(&delta, motor_dt);
            l2_error.add(&err, motor_dt);
            l2_tip.add(&nalgebra::Vector1::new(tip), motor_dt);
            tail_err.add(t, &err, motor_dt);
            tail_delta.add(t, &delta, motor_dt);
            for i in 0..2 {
                sum.max_tau[i] = sum.max_tau[i].max(tau[i].abs());
            }
            sum.max_v_a = sum.max_v_a.max(v_a.abs());
            sum.max_tip = sum.max_tip.max(tip.abs());
            if record {
                trace.push(Sample {
                    t,
                    x,
                    q_d: target.q.cast::<f64>(),
                    tau,
                    v_a,
                    v_f,
                    tip,
                });
            }
        }
        let u = Vector4::new(tau.x, tau.y, 0.0, 0.0) + cfg.patch.generalized_force(v_a);
        x = rk4_step(&plant, &x, &u, dt).map_err(SimError::Plant)?;
    }
    sum.l2_delta = l2_delta.value();
    sum.l2_error = l2_error.value();
    sum.l2_tip = l2_tip.value();
    let (te, tea, tda) = (
        tail_err.signed(),
        tail_err.absolute(),
        tail_delta.absolute(),
    );
    sum.tail_error = [te.x, te.y];
    sum.tail_error_abs = [tea.x, tea.y];
    sum.tail_delta_abs = [tda.x, tda.y];
    Ok((sum, trace))
}

//! The multi-rate closed loop: the plant integrated at `plant_dt`, the motor and piezo loops
//! sampled at their own rates with zero-order hold.
//!
//! Two ways to feed the motor law:
//! - [`StateSource::Full`]: the true state `(q, q̇)`, as the paper assumes: the paper's laws
//!   alone (`MotorController`, `PiezoLaw`), no observer, no checks, no drive: not a board;
//! - [`StateSource::Observer`]: the firmware, exactly as a board runs it: the host's rig
//!   ([`crate::rig`]) runs the machine's periods (`flexarm_machine::period`: the controller's
//!   checks, observer and latch, the drive's motion checks, derating and controlled stops) from
//!   the run's [`BoardConfig`] ([`SimConfig::board_config`]) on the plant through modelled sensors
//!   ([`crate::rig::PlantBoard`]: quantized encoders, a quantized, noisy film ADC, [`Sensors`]).
//!   The trajectory runs as the drive's move (`Drive::follow`: a study's trajectory, not checked
//!   against the move limits).
//!
//! The indices use the true state, whatever the controller sees.

use flexarm_core::control::cancel::{CancelGains, FeedthroughCancel};
use flexarm_core::control::irc::{Irc, IrcGains};
use flexarm_core::control::motor::{MotorController, MotorLaw};
use flexarm_core::control::piezo::{PiezoGains, PiezoLaw, PiezoPatch};
use flexarm_core::control::ppf::{Ppf, PpfGains};
use flexarm_core::control::select::PiezoLawKind;
use flexarm_core::controller::Controller;
use flexarm_core::indices::{L2Norm, TailMean};
use flexarm_core::model::Model;
use flexarm_core::motion::{MotionLimits, MotionMonitor, MotionSample, Verdict};
use flexarm_core::observer::{NoiseModel, design, film_map};
use flexarm_core::params::{ArmParams, Gains, Limits, ParamError};
use flexarm_core::time::Ticks;
use flexarm_core::trajectory::{Circle, JointTrajectory, Trapezoid};
use flexarm_core::{Fault, Vector2, Vector4};
use flexarm_link::msg::{Board, Param, Reply};
use flexarm_machine::BoardConfig;
use flexarm_machine::config::{GainTable, model_film_static};

use crate::plant::{Diverged, ModelPlant, Plant, State};
use crate::rig::{PlantBoard, Rig};
use crate::truth_plant::{self, TruthSpec};

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
        if !(self.plant_dt.is_finite() && self.plant_dt > 0.0) {
            return Err(SimError::Config(ParamError::NotPositive("plant_dt")));
        }
        if !(PLANT_DT_RANGE.0..=PLANT_DT_RANGE.1).contains(&self.plant_dt) {
            return Err(SimError::Input {
                key: "rates.plant_dt",
                msg: format!(
                    "{} s is outside {} s to {} s",
                    self.plant_dt, PLANT_DT_RANGE.0, PLANT_DT_RANGE.1
                ),
            });
        }
        let div = |hz: f64, name: &'static str| {
            if !(hz.is_finite() && hz > 0.0) {
                return Err(SimError::Config(ParamError::NotPositive(name)));
            }
            let n = 1.0 / (hz * self.plant_dt);
            let r = n.round();
            if !(1.0..=MAX_DIVISOR).contains(&r) || (n - r).abs() > 1e-6 * r {
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

/// Where the motor law takes the state from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum StateSource {
    /// The true state (the paper's assumption).
    #[default]
    Full,
    /// The firmware's controller with its observer, fed by [`Sensors`].
    Observer,
}

/// Sensor and amplifier models.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sensors {
    /// Encoder counts per revolution; `None` = exact angles.
    pub encoder_counts: Option<f64>,
    /// Film ADC resolution [bits] over `±adc_range`; `None` = exact voltage.
    pub adc_bits: Option<u32>,
    /// Film ADC range [V].
    pub adc_range: f64,
    /// White noise on the film voltage, standard deviation [V].
    pub film_noise: f64,
    /// Every measurement reaches the controller one period late (the motor loop's: the piezo
    /// loop reads the film when it runs, unless `piezo_delay`).
    pub delay: bool,
    /// The film reaches the piezo loop one piezo period late (the spillover study's
    /// "realistic board"; off in [`Sensors::realistic`], whose published runs had it off; the
    /// full-state loop only: on the rig the board reads its film as the firmware does).
    pub piezo_delay: bool,
    /// Piezo amplifier slew-rate limit [V/s]; `None` = unlimited.
    pub piezo_slew: Option<f64>,
    /// Seed of the noise generator (runs are reproducible).
    pub seed: u64,
}

impl Default for Sensors {
    /// Ideal sensors (the paper's setting).
    fn default() -> Self {
        Self {
            encoder_counts: None,
            adc_bits: None,
            adc_range: 10.0,
            film_noise: 0.0,
            delay: false,
            piezo_delay: false,
            piezo_slew: None,
            seed: 1,
        }
    }
}

impl Sensors {
    /// A realistic board: 16384-count encoders, 12-bit ADC over ±10 V with 5 mV of noise, a
    /// one-sample delay, a piezo amplifier slewing at most 50 V/ms.
    pub fn realistic() -> Self {
        Self {
            encoder_counts: Some(16384.0),
            adc_bits: Some(12),
            adc_range: 10.0,
            film_noise: 5e-3,
            delay: true,
            piezo_delay: false,
            piezo_slew: Some(5e4),
            seed: 1,
        }
    }

    /// The encoder's reading of the angle `x` [rad].
    pub fn angle(&self, x: f64) -> f64 {
        match self.encoder_counts {
            Some(n) => {
                let lsb = std::f64::consts::TAU / n;
                (x / lsb).floor() * lsb
            }
            None => x,
        }
    }

    /// The film ADC's reading of the voltage `v` [V] (with the noise of `rng`).
    pub fn film(&self, v: f64, rng: &mut Rng) -> f64 {
        let v = v + self.film_noise * rng.normal();
        match self.adc_bits {
            Some(bits) => {
                let r = self.adc_range;
                let lsb = 2.0 * r / f64::from(1u32 << bits.min(24));
                (v.clamp(-r, r - lsb) / lsb).floor() * lsb
            }
            None => v,
        }
    }
}

/// A small deterministic generator (xorshift64*) with Box–Muller normals.
#[derive(Clone, Copy, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A generator from a seed (0 is replaced by a fixed non-zero value).
    pub fn new(seed: u64) -> Self {
        Self(if seed == 0 {
            0x9E37_79B9_7F4A_7C15
        } else {
            seed
        })
    }

    /// Uniform in (0, 1).
    pub fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let bits = self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11;
        (bits as f64 + 0.5) / (1u64 << 53) as f64
    }

    /// Standard normal.
    pub fn normal(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

/// Everything a closed-loop run needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimConfig {
    /// The arm the controller believes in (its model, cast to `f32`).
    pub arm: ArmParams<f64>,
    /// The arm that is simulated; `None` = the same as `arm` (Monte Carlo perturbs it). With a
    /// truth plant, its rigid parts (link 2's body comes from the truth's link).
    pub plant: Option<ArmParams<f64>>,
    /// The truth plant (issue 14); `None` = the controller's own model ([`ModelPlant`]).
    /// Set it with [`SimConfig::with_truth`], which gives the controller the truncation.
    pub truth: Option<TruthSpec>,
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
    /// A piezo law of issue 35 run instead of the paper's (`piezo`), full state only: the
    /// spillover study's time-domain checks (the controller's `piezo_step` runs `PiezoLaw`).
    pub piezo_law: Option<PiezoLawChoice>,
    /// Rates.
    pub rates: Rates,
    /// Where the law takes the state from.
    pub state: StateSource,
    /// Sensor and amplifier models.
    pub sensors: Sensors,
    /// The noise model the observer's gain is designed for (the firmware's: the default);
    /// more modal process noise, a faster modal estimate.
    pub observer_noise: NoiseModel,
    /// Run length [s].
    pub duration: f64,
    /// Window of Eq. 38 [s] at the end of the run.
    pub tail_window: f64,
    /// The board configuration the firmware's controller runs with ([`StateSource::Observer`]):
    /// `None` builds it from this run's arm, patch, law, gains, piezo gains, limits and rates
    /// ([`SimConfig::board_config`]); a board's own (a recording's, a firmware's generated
    /// one) runs that board's numbers, the rest of this configuration describing the plant.
    pub machine: Option<BoardConfig>,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            arm: ArmParams::default(),
            plant: None,
            truth: None,
            gains: Gains::default(),
            limits: Limits::default(),
            law: MotorLaw::Tracking,
            patch: PiezoPatch::paper(),
            piezo: None,
            piezo_law: None,
            rates: Rates::default(),
            state: StateSource::Full,
            sensors: Sensors::default(),
            observer_noise: NoiseModel::default(),
            duration: 5.0,
            tail_window: 3.0,
            machine: None,
        }
    }
}

/// Why a run could not be done.
#[derive(Clone, Debug, PartialEq)]
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
    /// The truth plant cannot be built.
    Truth(String),
    /// The plant diverged.
    Plant {
        /// When [s].
        t: f64,
    },
    /// The desired trajectory cannot be built.
    Trajectory(flexarm_core::TrajectoryError),
    /// The observer gain could not be designed for these rates and this arm.
    ObserverDesign,
    /// A value of the configuration, as the `f32` controller would run it, is refused.
    Input {
        /// The scenario key (or command-line option) it comes from.
        key: &'static str,
        /// What is wrong and what is allowed.
        msg: String,
    },
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
            Self::Input { key, msg } => write!(f, "`{key}`: {msg}"),
            Self::Rates { name, hz, plant_dt } => write!(
                f,
                "incompatible rates: {name} = {hz} Hz is not a whole number of plant steps of {plant_dt} s"
            ),
            Self::Truth(e) => write!(f, "the truth plant: {e}"),
            Self::Plant { t } => write!(f, "at t = {t:.4} s: {Diverged}"),
            Self::Trajectory(e) => write!(f, "{e}"),
            Self::ObserverDesign => {
                f.write_str("the observer gain could not be designed for this arm and motor rate")
            }
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
    /// True plant state.
    pub x: State<f64>,
    /// Desired joint angles [rad].
    pub q_d: Vector2<f64>,
    /// The modal coordinates the controller used (estimate or truth) [√kg·m].
    pub delta_seen: Vector2<f64>,
    /// Motor torques applied [N·m].
    pub tau: Vector2<f64>,
    /// Piezo amplifier command [V] (the patch voltage with an ideal amplifier).
    pub v_a: f64,
    /// Film voltage measured [V].
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
    /// Largest |θ − θ_d| over both joints [rad].
    pub max_error: f64,
    /// Largest |τ| per joint [N·m].
    pub max_tau: [f64; 2],
    /// Largest |V_a| [V].
    pub max_v_a: f64,
    /// Largest |tip deflection| [m].
    pub max_tip: f64,
    /// The first motion check (`flexarm_core::motion`, its defaults at the run's motor rate) that
    /// would have tripped, and when [s]: a false trip on a healthy run. The run goes on (the
    /// study's figures are the laws', not the checks').
    pub motion_trip: Option<(Fault, f64)>,
    /// The largest tracking error the motion checks saw, `|θ_measured − θ_d|` [rad], and the
    /// largest estimated joint speed [rad/s]: the evidence for their thresholds.
    pub motion_peaks: (f64, f64),
    /// How far the trend checks got: the runaway check's longest streak over both joints
    /// [motor periods], and the stall check's largest share of a window
    /// (`MotionMonitor::stall_fill`): a healthy run's must stay short of the windows.
    pub motion_streaks: (u32, f64),
}

/// A piezo law of issue 35 with its gains ([`SimConfig::piezo_law`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PiezoLawChoice {
    /// Positive position feedback.
    Ppf(PpfGains<f32>),
    /// Integral resonant control.
    Irc(IrcGains<f32>),
    /// Rate feedback with the identified feedthrough subtracted.
    Cancel(CancelGains<f32>),
}

/// The full-state loop's piezo law.
enum FullPiezo {
    Rate(PiezoLaw<f32>),
    Ppf(Ppf<f32>),
    Irc(Irc<f32>),
    Cancel(FeedthroughCancel<f32>),
}

impl FullPiezo {
    fn new(c: &PiezoLawChoice, period: f32, v_min: f32, v_max: f32) -> Result<Self, SimError> {
        let (law, ok) = match c {
            PiezoLawChoice::Ppf(g) => {
                let l = Ppf::new(g, period, v_min, v_max);
                (Self::Ppf(l), l.is_valid())
            }
            PiezoLawChoice::Irc(g) => {
                let l = Irc::new(g, period, v_min, v_max);
                (Self::Irc(l), l.is_valid())
            }
            PiezoLawChoice::Cancel(g) => {
                let l = FeedthroughCancel::new(g, period, v_min, v_max);
                (Self::Cancel(l), l.is_valid())
            }
        };
        if ok {
            Ok(law)
        } else {
            Err(SimError::Input {
                key: "piezo_law",
                msg: format!("{c:?} gives no valid law at the piezo period {period} s"),
            })
        }
    }

    fn step(&mut self, v_f: f32) -> f32 {
        match self {
            Self::Rate(l) => l.step(v_f),
            Self::Ppf(l) => l.step(v_f),
            Self::Irc(l) => l.step(v_f),
            Self::Cancel(l) => l.step(v_f),
        }
    }
}

impl SimConfig {
    /// The board configuration the firmware's controller runs with in this run: [`Self::machine`]
    /// when given (its rates must be this run's), else a board at this run's rates
    /// (`BoardConfig::for_board` for the hardware board) with this run's controller: its arm and
    /// patch (in `f32`), law, gains, piezo gains (the default ones when the loop is off:
    /// [`Self::run_board`] turns it off), limits, the motion checks of its motor rate, the
    /// observer gain designed for them ([`Self::observer_gain`]), and no link watchdog (no host
    /// watches a study's run).
    pub fn board_config(&self) -> Result<BoardConfig, SimError> {
        let (motor_div, piezo_div) = self.rates.divisors()?;
        if motor_div % piezo_div != 0 {
            return Err(SimError::Input {
                key: "rates.piezo_hz",
                msg: format!(
                    "{} Hz is not a whole multiple of the motor loop's {} Hz: a board runs a whole number of piezo periods per motor period",
                    self.rates.piezo_hz, self.rates.motor_hz
                ),
            });
        }
        let divider = (motor_div / piezo_div) as u32;
        let piezo_hz = self.rates.piezo_hz.round() as u32;
        if let Some(m) = self.machine {
            if m.piezo_hz != piezo_hz || m.motor_divider != divider {
                return Err(SimError::Input {
                    key: "rates",
                    msg: format!(
                        "the board runs its loops at {} and {} Hz, not {} and {} Hz",
                        m.piezo_hz,
                        m.motor_hz(),
                        self.rates.piezo_hz,
                        self.rates.motor_hz
                    ),
                });
            }
            return Ok(m);
        }
        let motor_hz = self.rates.motor_hz.round() as u32;
        let piezo = self.piezo.unwrap_or_default();
        let mut c = BoardConfig::for_board(
            Board::Hardware,
            self.arm.cast::<f32>(),
            self.patch.to_f32(),
            piezo.k_c,
            // A study explores gains: its board holds `set` to no rate-law ceiling.
            &flexarm_core::tuning::RateCeiling::NONE,
            self.observer_gain(self.rates.plant_dt * motor_div as f64)?,
        );
        c.law = self.law;
        c.gains = self.gains;
        c.piezo = piezo;
        // A study's board runs the paper's rate law with this run's gains (the hardware board
        // ships the loop off until commissioning, `BoardConfig::for_board`), and knows the
        // film's static gain its model predicts, so a run can select the other laws.
        c.piezo_law = PiezoLawKind::Rate;
        c.film_static = model_film_static(&c.arm, &c.patch);
        c.limits = self.limits;
        c.motion = MotionLimits {
            // The host's plants have no holding brakes (`PlantBoard::brake_damping` is 0: the
            // joints coast on their friction when the amplifiers are cut), so no brake watch.
            brake_travel: 0.0,
            ..MotionLimits::default_for(motor_hz)
        };
        c.piezo_hz = piezo_hz;
        c.motor_divider = divider;
        c.print_every = (motor_hz / 10).max(1);
        c.amplifier_settle = motor_hz / 100;
        // No host watches a study's run: the link watchdog is off.
        c.link_timeout_s = 0;
        Ok(c)
    }

    /// The observer gain for this run's arm and patch at the motor period `motor_period` [s]:
    /// the steady-state Kalman gain for [`Self::observer_noise`] at rest at `(0, π/4)` rad, as
    /// `cargo sim firmware-params` designs the firmware's.
    pub fn observer_gain(&self, motor_period: f64) -> Result<GainTable, SimError> {
        let gain = design(
            &Model::new(self.arm),
            &film_map(&self.patch),
            &Vector2::new(0.0, std::f64::consts::FRAC_PI_4),
            motor_period,
            &self.observer_noise,
        )
        .map_err(|_| SimError::ObserverDesign)?;
        Ok(core::array::from_fn(|i| {
            core::array::from_fn(|j| gain[(i, j)] as f32)
        }))
    }

    /// The controller a board would run for this configuration and trajectory: the
    /// observer-based [`Controller`] of [`Self::board_config`], holding `traj`, whatever `state`
    /// says (the drive's tests build a [`flexarm_core::drive::Drive`] around it).
    pub fn controller(&self, traj: &JointTrajectory<f32>) -> Result<Controller<f32>, SimError> {
        Ok(self.board_config()?.controller(*traj))
    }

    /// The host's rig of this run's board on its plant, at rest at `theta` [rad], booted
    /// ([`Rig::new`]), with the piezo loop off when [`Self::piezo`] is `None` (its gain set to
    /// 0 as the link's `set kc 0` does), disarmed, the encoders' frame declared the arm's
    /// (`Drive::declare_zero`).
    pub fn run_board(&self, theta: Vector2<f64>) -> Result<Rig<PlantBoard>, SimError> {
        let bc = self.board_config()?;
        let (_, piezo_div) = self.rates.divisors()?;
        let board = PlantBoard::new(
            self.plant_at(theta)?,
            self.sensors,
            self.rates.plant_dt,
            piezo_div,
        );
        let mut rig = Rig::new(bc, board, Ticks(0));
        if let Some(fault) = rig.control.ctrl.fault() {
            return Err(SimError::Fault { fault, t: 0.0 });
        }
        // The plant's encoders read its own angles: the arm's frame, declared (issue 33: a
        // host's explicit word, which a study can give and a board's first power-on cannot).
        if let Err(why) = rig.declare_encoders() {
            return Err(SimError::Input {
                key: "homing",
                msg: format!("the drive refused the declared pose: {why:?}"),
            });
        }
        if self.piezo.is_none() && self.machine.is_none() {
            let r = rig.answer(flexarm_link::Command::Set(Param::Kc, 0.0));
            if r != Reply::Done {
                return Err(SimError::Input {
                    key: "controller.k_c",
                    msg: format!("the piezo loop could not be turned off: {r:?}"),
                });
            }
        }
        Ok(rig)
    }
}

/// The plant step's range [s]: 0.1 µs (a thousandth of the 10 kHz piezo period) to 10 ms.
pub const PLANT_DT_RANGE: (f64, f64) = (1e-7, 1e-2);
/// Most plant steps in one loop period.
const MAX_DIVISOR: f64 = 1e6;
/// Most plant steps in one run: about a minute of computing at the default rates' 0.2 µs
/// per RK4 step and motor sample.
pub const MAX_PLANT_STEPS: f64 = 2e8;
/// Most motor samples a run keeps in memory (about 170 bytes each, so 170 MB): a longer run
/// is refused up front with the size it would need.
pub const MAX_RECORDED_SAMPLES: f64 = 1e6;

/// Motor periods a run must hold at least: fewer give indices of nothing.
pub const MIN_MOTOR_SAMPLES: f64 = 10.0;
/// Motor periods a trajectory's ramp must last at least, so that the motor loop samples its
/// acceleration.
pub const MIN_RAMP_SAMPLES: f64 = 2.0;

impl SimConfig {
    /// The firmware as a board runs it, on the controller's own model: motor loop `motor_hz`,
    /// piezo loop `piezo_hz` (the plant stepped at it) [Hz], the observer, 16384-count
    /// encoders and a 12-bit film ADC (the QEMU board's sensors), the paper's gains with the
    /// joints' `K_p` for that motor rate (`Gains::default_for`), the piezo loop off. The host's
    /// runs of a board's moves and experiments start from it.
    pub fn board(motor_hz: f64, piezo_hz: f64) -> Self {
        Self {
            state: StateSource::Observer,
            sensors: Sensors {
                encoder_counts: Some(16384.0),
                adc_bits: Some(12),
                ..Sensors::default()
            },
            rates: Rates {
                plant_dt: 1.0 / piezo_hz,
                motor_hz,
                piezo_hz,
            },
            gains: Gains::default_for(motor_hz.round() as u32),
            ..Self::default()
        }
    }

    /// This run on the truth plant `spec`: the arm given so far becomes the truth's rigid
    /// parts, and the controller gets the two-mode truncation of the truth's link
    /// ([`truth_plant::controller_model`]).
    /// With [`truth_plant::LinkSource::Arm`] the controller and the plant keep their arms.
    pub fn with_truth(mut self, spec: TruthSpec) -> Result<Self, SimError> {
        if spec.link == truth_plant::LinkSource::Beam {
            let rigid = self.plant.unwrap_or(self.arm);
            let (arm, patch) = truth_plant::controller_model(&spec, &rigid, &self.patch)
                .map_err(|e| SimError::Truth(e.to_string()))?;
            self.plant = Some(rigid);
            self.arm = arm;
            self.patch = patch;
        }
        self.truth = Some(spec);
        Ok(self)
    }

    /// The plant of this run at rest at the joint angles `theta` [rad].
    pub fn plant_at(&self, theta: Vector2<f64>) -> Result<Box<dyn Plant + Send>, SimError> {
        let arm = self.plant.unwrap_or(self.arm);
        match &self.truth {
            None => Ok(Box::new(ModelPlant::new(
                Model::new(arm),
                self.patch,
                State::rest(Vector4::new(theta.x, theta.y, 0.0, 0.0)),
            ))),
            Some(spec) => truth_plant::build(
                spec,
                &arm,
                &self.patch,
                self.limits.tau_max.cast::<f64>(),
                theta,
            )
            .map_err(|e| SimError::Truth(e.to_string())),
        }
    }

    /// The one check of a run's configuration, on the values the `f32` controller will really
    /// run: the scenario loader applies it to the file, the command line again after its
    /// overrides, and [`simulate`] before it starts.
    pub fn validate(&self, traj: &JointTrajectory<f32>) -> Result<(), SimError> {
        let input = |key: &'static str, msg: String| Err(SimError::Input { key, msg });
        self.arm.validate().map_err(SimError::Config)?;
        self.arm
            .cast::<f32>()
            .validate()
            .map_err(SimError::Config)?;
        if let Some(p) = &self.plant {
            p.validate().map_err(SimError::Config)?;
        }
        if let Some(t) = &self.truth {
            t.validate()
                .map_err(|(key, msg)| SimError::Input { key, msg })?;
        }
        self.gains.validate().map_err(SimError::Config)?;
        self.limits.validate().map_err(SimError::Config)?;
        let (motor_div, piezo_div) = self.rates.divisors()?;
        let motor_dt = self.rates.plant_dt * motor_div as f64;
        let piezo_dt = self.rates.plant_dt * piezo_div as f64;
        for (key, v) in [
            ("duration", self.duration),
            ("tail_window", self.tail_window),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return input(key, format!("{v} s must be a finite number > 0"));
            }
        }
        if self.tail_window > self.duration {
            return input(
                "tail_window",
                format!(
                    "{} s is longer than `duration` = {} s",
                    self.tail_window, self.duration
                ),
            );
        }
        let steps = self.duration / self.rates.plant_dt;
        if steps > MAX_PLANT_STEPS {
            return input(
                "duration",
                format!(
                    "{} s at a plant step of {} s is {steps:.3e} steps; at most {MAX_PLANT_STEPS:e}",
                    self.duration, self.rates.plant_dt
                ),
            );
        }
        let samples = self.duration / motor_dt;
        if samples > MAX_RECORDED_SAMPLES {
            return input(
                "duration",
                format!(
                    "{} s at {} Hz keeps {samples:.3e} motor samples ({:.0} MB); at most {MAX_RECORDED_SAMPLES:e}",
                    self.duration,
                    self.rates.motor_hz,
                    samples * std::mem::size_of::<Sample>() as f64 / 1e6
                ),
            );
        }
        if self.duration < MIN_MOTOR_SAMPLES * motor_dt {
            return input(
                "duration",
                format!(
                    "{} s holds fewer than {MIN_MOTOR_SAMPLES} motor periods of {motor_dt} s",
                    self.duration
                ),
            );
        }
        if self.tail_window < motor_dt {
            return input(
                "tail_window",
                format!(
                    "{} s is shorter than one motor period ({motor_dt} s)",
                    self.tail_window
                ),
            );
        }
        if let JointTrajectory::Trapezoid(Trapezoid { profile, .. })
        | JointTrajectory::Circle(Circle { profile, .. }) = traj
            && f64::from(profile.ramp()) < MIN_RAMP_SAMPLES * motor_dt
        {
            return input(
                "trajectory.ramp_time",
                format!(
                    "{} s is shorter than {MIN_RAMP_SAMPLES} motor periods of {motor_dt} s: the motor loop would not sample the move's acceleration",
                    profile.ramp()
                ),
            );
        }
        if let Some(g) = self.piezo {
            let law = PiezoLaw::with_window(
                &g,
                piezo_dt as f32,
                self.limits.v_a_min,
                self.limits.v_a_max,
            );
            if !(g.k_c.is_finite() && g.k_c > 0.0) {
                return input(
                    "controller.k_c",
                    format!(
                        "rounds to {} s in f32, the controller's type; it must be a finite number > 0",
                        g.k_c
                    ),
                );
            }
            if !law.is_valid() {
                return input(
                    "controller.cutoff_hz",
                    format!(
                        "{} Hz gives no usable derivative filter at the piezo period {piezo_dt} s (as f32)",
                        g.cutoff_hz
                    ),
                );
            }
        }
        let patch = self.patch.to_f32();
        patch
            .validate(self.arm.a2 as f32)
            .map_err(|e| SimError::Input {
                key: "piezo",
                msg: format!("the patch as f32: {e}"),
            })?;
        Ok(())
    }
}

/// One motor period of the motion checks: the first verdict that is not clear, and the peaks.
fn watch(
    sum: &mut Summary,
    monitor: &mut MotionMonitor<f32>,
    limits: &MotionLimits<f32>,
    s: &MotionSample<f32>,
    t: f64,
    dt: f64,
) {
    let verdict = monitor.check(limits, s, dt as f32);
    monitor.update_heat(limits, s.tau, dt as f32);
    if let (Verdict::Trip(f) | Verdict::Stop(f), None) = (verdict, sum.motion_trip) {
        sum.motion_trip = Some((f, t));
    }
    let e = f64::from((s.theta - s.theta_d).abs().max());
    let v = f64::from(s.speed.abs().max());
    sum.motion_peaks = (sum.motion_peaks.0.max(e), sum.motion_peaks.1.max(v));
    let runaway = monitor.streaks();
    sum.motion_streaks = (
        sum.motion_streaks.0.max(runaway[0].max(runaway[1])),
        sum.motion_streaks
            .1
            .max(f64::from(monitor.stall_fill(limits, dt as f32))),
    );
}

/// The indices of a trace (Eqs. 37 and 38 over its whole length, the means over its last
/// `tail_window` seconds, the peaks), each sample weighted by the time to the next: what
/// [`simulate`] computes as it runs, for a trace from elsewhere (a recording of the firmware,
/// `flexarm record`). The motion checks' fields stay empty.
pub fn summarize(trace: &[Sample], tail_window: f64) -> Summary {
    let mut sum = Summary::default();
    let (Some(first), Some(last)) = (trace.first(), trace.last()) else {
        return sum;
    };
    let dt = if trace.len() > 1 {
        (last.t - first.t) / (trace.len() - 1) as f64
    } else {
        0.0
    };
    // Half a sample of slack: the sample at the window's start counts, whatever the rounding
    // of its time (one sample of a decaying δ moves Eq. 38 by 0.5 %).
    let mut indices = Indices::new(last.t - first.t + dt, tail_window + dt / 2.0);
    for p in trace {
        indices.add(&mut sum, p, p.t - first.t, dt);
    }
    indices.finish(&mut sum);
    sum
}

/// The running indices of a trace (Eqs. 37 and 38, the peaks): what [`simulate`] and
/// [`summarize`] both accumulate.
struct Indices {
    l2_delta: L2Norm<f64>,
    l2_error: L2Norm<f64>,
    l2_tip: L2Norm<f64>,
    tail_err: TailMean<f64, 2>,
    tail_delta: TailMean<f64, 2>,
}

impl Indices {
    /// For a trace of `duration` [s], Eq. 38 over its last `tail_window` [s].
    fn new(duration: f64, tail_window: f64) -> Self {
        Self {
            l2_delta: L2Norm::default(),
            l2_error: L2Norm::default(),
            l2_tip: L2Norm::default(),
            tail_err: TailMean::new(duration, tail_window),
            tail_delta: TailMean::new(duration, tail_window),
        }
    }

    /// The sample `p` at `t` [s], held for `dt` [s]; the peaks go straight into `sum`.
    fn add(&mut self, sum: &mut Summary, p: &Sample, t: f64, dt: f64) {
        let err = Vector2::new(p.x.q.x, p.x.q.y) - p.q_d;
        let delta = Vector2::new(p.x.q.z, p.x.q.w);
        self.l2_delta.add(&delta, dt);
        self.l2_error.add(&err, dt);
        self.l2_tip.add(&nalgebra::Vector1::new(p.tip), dt);
        self.tail_err.add(t, &err, dt);
        self.tail_delta.add(t, &delta, dt);
        sum.max_error = sum.max_error.max(err.abs().max());
        for i in 0..2 {
            sum.max_tau[i] = sum.max_tau[i].max(p.tau[i].abs());
        }
        sum.max_v_a = sum.max_v_a.max(p.v_a.abs());
        sum.max_tip = sum.max_tip.max(p.tip.abs());
    }

    /// Writes the integral indices into `sum`.
    fn finish(&self, sum: &mut Summary) {
        sum.l2_delta = self.l2_delta.value();
        sum.l2_error = self.l2_error.value();
        sum.l2_tip = self.l2_tip.value();
        let (te, tea, tda) = (
            self.tail_err.signed(),
            self.tail_err.absolute(),
            self.tail_delta.absolute(),
        );
        sum.tail_error = [te.x, te.y];
        sum.tail_error_abs = [tea.x, tea.y];
        sum.tail_delta_abs = [tda.x, tda.y];
    }
}

/// Runs the closed loop from rest at `θ_d(0)`; `record` keeps one [`Sample`] per motor period.
pub fn simulate(
    cfg: &SimConfig,
    traj: &JointTrajectory<f32>,
    record: bool,
) -> Result<(Summary, Vec<Sample>), SimError> {
    simulate_segments(cfg, &[(0.0, *traj)], record)
}

/// [`simulate`] of a move made of segments, as the drive runs a waypoint path
/// (`flexarm_core::drive::Drive::path_segments`): `(start [s], trajectory)` in order, the first
/// at 0, each sampled from its own `t = 0` once the run's time has reached its start (the last
/// one holds its end after its duration).
pub fn simulate_segments(
    cfg: &SimConfig,
    segments: &[(f64, JointTrajectory<f32>)],
    record: bool,
) -> Result<(Summary, Vec<Sample>), SimError> {
    run(cfg, segments, record, None)
}

/// [`simulate`] with an excitation of the patch: `bias(t)` [V] added to the piezo loop's
/// command each piezo period (the command is 0 V with the loop off, `piezo: None`), as a drive
/// applies its `va_bias` (`Controller::bias_piezo`: within the amplifier's window, the observer
/// predicting with the command as applied). The identification experiments' runs
/// (`crate::identify`); the observer-based controller only.
pub fn simulate_excited(
    cfg: &SimConfig,
    segments: &[(f64, JointTrajectory<f32>)],
    bias: &dyn Fn(f64) -> f64,
) -> Result<(Summary, Vec<Sample>), SimError> {
    if cfg.state != StateSource::Observer {
        return Err(SimError::Input {
            key: "state",
            msg: "an excited run needs the observer-based controller".into(),
        });
    }
    run(cfg, segments, true, Some(bias))
}

fn run(
    cfg: &SimConfig,
    segments: &[(f64, JointTrajectory<f32>)],
    record: bool,
    bias: Option<&dyn Fn(f64) -> f64>,
) -> Result<(Summary, Vec<Sample>), SimError> {
    let Some(&(_, first)) = segments.first() else {
        return Err(SimError::Input {
            key: "trajectory",
            msg: "no segment to run".into(),
        });
    };
    cfg.validate(&first)?;
    if cfg.state == StateSource::Observer && cfg.piezo_law.is_some() {
        return Err(SimError::Input {
            key: "piezo_law",
            msg: "runs with the full state only (the board's controller runs the paper's law)"
                .into(),
        });
    }
    match cfg.state {
        StateSource::Full => run_paper(cfg, segments, record),
        StateSource::Observer => run_firmware(cfg, segments, record, bias),
    }
}

/// The segment of `segments` at `t` [s], and the time into it.
fn segment_at(
    segments: &[(f64, JointTrajectory<f32>)],
    t: f64,
) -> (usize, JointTrajectory<f32>, f64) {
    let i = segments
        .partition_point(|(start, _)| *start <= t)
        .saturating_sub(1);
    let (start, seg) = segments[i];
    (i, seg, t - start)
}

/// [`StateSource::Observer`]: the firmware on the host's rig ([`SimConfig::run_board`]), the
/// segments run as the drive's moves, each from the motor period its start falls in; `bias`
/// sets the link's piezo bias before each piezo period. The time of the run (the samples', the
/// segments', the bias's) is the motor periods': the first motor period samples at 0.
fn run_firmware(
    cfg: &SimConfig,
    segments: &[(f64, JointTrajectory<f32>)],
    record: bool,
    bias: Option<&dyn Fn(f64) -> f64>,
) -> Result<(Summary, Vec<Sample>), SimError> {
    let (_, first) = segments[0];
    let mut rig = cfg.run_board(first.sample(0.0).q.cast::<f64>())?;
    let motor_dt = 1.0 / f64::from(rig.cfg.motor_hz());
    let refused = |why| SimError::Input {
        key: "trajectory",
        msg: format!("the drive refused the run: {why:?}"),
    };
    // The plant starts at rest at the trajectory's start, and so does the estimate (the
    // study's convention: a board resets its observer at its encoders' reading instead).
    rig.control.ctrl.reset_observer(first.sample(0.0).q);
    rig.arm().map_err(refused)?;
    rig.follow(first, 0.0).map_err(refused)?;
    let mut current = 0;
    let mut sum = Summary::default();
    let mut indices = Indices::new(cfg.duration, cfg.tail_window);
    let mut trace = Vec::new();
    let mut monitor = MotionMonitor::<f32>::new();
    // The run's time is the motor periods': the motor period `k` samples at `k T_m`, with the
    // last of its `N` piezo periods (`PlantBoard`), the one before it at `k T_m − T_p`, ...
    let periods = (cfg.duration / motor_dt).round() as u64;
    let n = rig.cfg.motor_divider;
    let piezo_dt = motor_dt / f64::from(n);
    for k in 0..periods {
        let t = k as f64 * motor_dt;
        let (i, seg, local) = segment_at(segments, t);
        if i != current {
            current = i;
            rig.follow(seg, local as f32).map_err(refused)?;
        }
        let p = rig.period_with(n, |c, i| {
            if let Some(b) = bias {
                c.piezo_bias = b(t - f64::from(n - 1 - i) * piezo_dt) as f32;
            }
        });
        if rig.board.diverged.is_some() {
            return Err(SimError::Plant { t });
        }
        if let Some(fault) = p.fault {
            return Err(SimError::Fault { fault, t });
        }
        let ctrl = &rig.control.ctrl;
        let qd = ctrl.estimate().1;
        let sample = MotionSample::new(
            &ctrl.motor.model,
            (p.y.theta, p.q.xy() - p.error),
            (&p.q, &qd),
            p.command.tau,
        );
        watch(
            &mut sum,
            &mut monitor,
            &rig.cfg.motion,
            &sample,
            t,
            motor_dt,
        );
        let reference = ctrl.trajectory.sample(rig.drive.time(p.tick)).q;
        let sample = Sample {
            t,
            x: rig.board.state(),
            q_d: reference.cast::<f64>(),
            delta_seen: Vector2::new(f64::from(p.q.z), f64::from(p.q.w)),
            tau: p.command.tau.cast::<f64>(),
            v_a: rig.board.v_a(),
            v_f: rig.board.v_f(),
            tip: rig.board.plant().tip(),
        };
        indices.add(&mut sum, &sample, t, motor_dt);
        if record {
            trace.push(sample);
        }
    }
    indices.finish(&mut sum);
    Ok((sum, trace))
}

/// [`StateSource::Full`]: the paper's laws on the true state, the piezo law on the measured
/// film, at their rates; no observer, no checks, no drive (the paper's assumption, not a
/// board).
fn run_paper(
    cfg: &SimConfig,
    segments: &[(f64, JointTrajectory<f32>)],
    record: bool,
) -> Result<(Summary, Vec<Sample>), SimError> {
    let (_, first) = segments[0];
    let (motor_div, piezo_div) = cfg.rates.divisors()?;
    let dt = cfg.rates.plant_dt;
    let (motor_dt, piezo_dt) = (dt * motor_div as f64, dt * piezo_div as f64);
    let motor = MotorController {
        model: Model::new(cfg.arm.cast::<f32>()),
        gains: cfg.gains,
        limits: cfg.limits,
        law: cfg.law,
    };
    let (v_min, v_max) = (cfg.limits.v_a_min, cfg.limits.v_a_max);
    let mut piezo = match &cfg.piezo_law {
        Some(c) => Some(FullPiezo::new(c, piezo_dt as f32, v_min, v_max)?),
        None => cfg
            .piezo
            .map(|g| FullPiezo::Rate(PiezoLaw::with_window(&g, piezo_dt as f32, v_min, v_max))),
    };
    let mut rng = Rng::new(cfg.sensors.seed);
    let mut plant = cfg.plant_at(first.sample(0.0).q.cast::<f64>())?;
    let steps = (cfg.duration / dt).round() as u64;
    let mut sum = Summary::default();
    let mut indices = Indices::new(cfg.duration, cfg.tail_window);
    let mut trace = Vec::new();
    let (mut tau, mut v_a, mut v_f) = (Vector2::<f64>::zeros(), 0.0_f64, 0.0_f64);
    // Measurements held back one period when `sensors.delay`.
    let mut held: Option<(State<f64>, f64)> = None;
    let motion = MotionLimits::<f32>::default_for(cfg.rates.motor_hz.round() as u32);
    let mut monitor = MotionMonitor::<f32>::new();
    let mut integral = flexarm_core::control::integral::Integral::<f32>::new();
    let mut film_held: Option<f64> = None;
    for k in 0..steps {
        let t = k as f64 * dt;
        if k % piezo_div == 0 {
            v_f = cfg.sensors.film(plant.film(), &mut rng);
            // The sample the piezo law reads: this one, or the last period's.
            let v_read = match (cfg.sensors.piezo_delay, film_held.replace(v_f)) {
                (true, Some(old)) => old,
                _ => v_f,
            };
            let cmd = piezo
                .as_mut()
                .map_or(0.0, |p| f64::from(p.step(v_read as f32)));
            v_a = match cfg.sensors.piezo_slew {
                Some(rate) => v_a + (cmd - v_a).clamp(-rate * piezo_dt, rate * piezo_dt),
                None => cmd,
            };
        }
        if k % motor_div == 0 {
            let x = plant.state();
            let (_, seg, local) = segment_at(segments, t);
            let target = seg.sample(local as f32);
            let seen = if cfg.sensors.delay {
                held.replace((x, v_f)).unwrap_or((x, v_f)).0
            } else {
                x
            };
            let (q32, qd32) = (seen.q.cast::<f32>(), seen.qd.cast::<f32>());
            // The joints' integral action, as the controller runs it (none with the paper's
            // gains), the true state its measurement.
            let shifted = integral.prepare(&motor.gains, &target, (q32.xy(), qd32.xy()), None);
            let mut out = motor
                .step(local as f32, &q32, &qd32, &shifted)
                .map_err(|fault| SimError::Fault { fault, t })?;
            let limits = (out.tau, motor.limits.tau_max);
            integral.finish(&motor.gains, &mut out.error, limits, motor_dt as f32);
            let sample =
                MotionSample::new(&motor.model, (q32.xy(), target.q), (&q32, &qd32), out.tau);
            watch(&mut sum, &mut monitor, &motion, &sample, t, motor_dt);
            tau = out.tau.cast::<f64>();
            let sample = Sample {
                t,
                x,
                q_d: target.q.cast::<f64>(),
                delta_seen: Vector2::new(seen.q.z, seen.q.w),
                tau,
                v_a,
                v_f,
                tip: plant.tip(),
            };
            indices.add(&mut sum, &sample, t, motor_dt);
            if record {
                trace.push(sample);
            }
        }
        plant
            .step(&tau, v_a, dt)
            .map_err(|_| SimError::Plant { t })?;
    }
    indices.finish(&mut sum);
    Ok((sum, trace))
}

//! Scenario files (TOML): what to simulate, in SI units, every key optional but the trajectory.
//!
//! ```toml
//! name = "trapezoid"              # used for output file names
//! duration = 5.0                  # run length [s]
//!
//! [trajectory]                    # kind = "trapezoid" | "circle" | "hold"
//! kind = "trapezoid"
//! start = [0.0, 0.0]              # θ(0) [rad]
//! amplitude = [1.5708, 1.5708]    # joint displacement [rad]
//! move_time = 2.0                 # duration of the move [s]
//! ramp_time = 0.5                 # constant-acceleration time at each end [s]
//!
//! [controller]
//! law = "tracking"                # "tracking" (Eq. 7) | "robust" (Eq. 16)
//! piezo = true                    # piezo loop on (Eq. 17)
//! k_c = 30.0                      # piezo gain [s]
//! state = "full"                  # "full" (true state) | "observer" (firmware controller)
//! ```
//!
//! The full list of keys, with units, is in `host-sim/scenarios/README.md`; unknown keys are
//! refused with the line they stand on.

use std::path::Path;

use flexarm_core::control::motor::MotorLaw;
use flexarm_core::control::piezo::PiezoGains;
use flexarm_core::kinematics::{Elbow, Planar2};
use flexarm_core::params::{ArmParams, ModalData};
use flexarm_core::trajectory::{Circle, JointTrajectory, Profile, Trapezoid};
use flexarm_core::{Vector2, Vector4};
use serde::Deserialize;

use flexarm_beam::toml_at::{de_error, number, option_array, outside};

use crate::sim::{Rates, SimConfig, SimError, StateSource};
use crate::truth_plant::{MAX_MODES, TruthSpec};

/// A readable, one-line error about a scenario file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ScenarioError(pub String);

impl core::fmt::Display for ScenarioError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ScenarioError {}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    name: Option<String>,
    duration: Option<f64>,
    tail_window: Option<f64>,
    trajectory: TrajectorySpec,
    #[serde(default)]
    controller: ControllerSpec,
    #[serde(default)]
    rates: RatesSpec,
    #[serde(default)]
    limits: LimitsSpec,
    #[serde(default)]
    arm: ArmSpec,
    #[serde(default)]
    sensors: SensorsSpec,
    /// A `[piezo]` table as written by `flexarm-sim optimize` (read by `flexarm_beam`).
    piezo: Option<toml::Table>,
    plant: Option<PlantSpec>,
}

/// The `[plant]` table: the controller's own model (default) or the truth plant.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PlantSpec {
    kind: PlantKind,
    link: Option<LinkSpec>,
    controller: Option<ControllerModelSpec>,
    modes: Option<usize>,
    thickness: Option<f64>,
    tip_mass: Option<f64>,
    tip_inertia: Option<f64>,
    zeta: Option<Vec<f64>>,
    ideal: Option<bool>,
    #[serde(default, deserialize_with = "option_array")]
    current_tau: Option<[f64; 2]>,
    #[serde(default, deserialize_with = "option_array")]
    gear_ratio: Option<[f64; 2]>,
    #[serde(default, deserialize_with = "option_array")]
    rotor_inertia: Option<[f64; 2]>,
    #[serde(default, deserialize_with = "option_array")]
    viscous: Option<[f64; 2]>,
    #[serde(default, deserialize_with = "option_array")]
    coulomb: Option<[f64; 2]>,
    #[serde(default, deserialize_with = "option_array")]
    coulomb_speed: Option<[f64; 2]>,
    amplifier_hz: Option<f64>,
    #[serde(default, deserialize_with = "option_array")]
    amplifier_window: Option<[f64; 2]>,
    amplifier_current: Option<f64>,
    capacitance: Option<f64>,
    film_corner_hz: Option<f64>,
    film_bond: Option<f64>,
}

#[derive(Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
enum PlantKind {
    Model,
    Truth,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum LinkSpec {
    Beam,
    Arm,
}

/// What the controller's model is on a truth plant.
#[derive(Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
enum ControllerModelSpec {
    /// The truncation of the truth's link (its first two modes).
    Truncation,
    /// The scenario's `[arm]` and patch as given: a model error on purpose.
    Arm,
}

impl PlantSpec {
    /// The truth plant this table describes (`None`: the controller's own model).
    fn truth(&self) -> Result<Option<TruthSpec>, ScenarioError> {
        if self.kind == PlantKind::Model {
            let scalars = [
                self.thickness,
                self.tip_mass,
                self.tip_inertia,
                self.amplifier_hz,
                self.amplifier_current,
                self.capacitance,
                self.film_corner_hz,
                self.film_bond,
            ];
            let pairs = [
                self.current_tau,
                self.gear_ratio,
                self.rotor_inertia,
                self.viscous,
                self.coulomb,
                self.coulomb_speed,
                self.amplifier_window,
            ];
            return match self.link.is_some()
                || self.controller.is_some()
                || self.modes.is_some()
                || self.zeta.is_some()
                || self.ideal.is_some()
                || scalars.iter().any(Option::is_some)
                || pairs.iter().any(Option::is_some)
            {
                true => err(
                    "`plant.kind` = \"model\" takes no other key of `[plant]`: set `kind = \"truth\"`",
                ),
                false => Ok(None),
            };
        }
        let mut t = TruthSpec::default();
        if let Some(LinkSpec::Arm) = self.link {
            t = TruthSpec::model();
        }
        if self.ideal == Some(true) {
            t = t.ideal_actuators();
        }
        if let Some(n) = self.modes {
            if !(1..=MAX_MODES).contains(&n) {
                return err(format!("`plant.modes` = {n} must be 1 to {MAX_MODES}"));
            }
            t.modes = n;
        }
        let set = |dst: &mut f64, v: Option<f64>| {
            if let Some(v) = v {
                *dst = v;
            }
        };
        set(&mut t.thickness, self.thickness);
        set(&mut t.tip_mass, self.tip_mass);
        set(&mut t.tip_inertia, self.tip_inertia);
        set(&mut t.amplifier_hz, self.amplifier_hz);
        set(&mut t.amplifier_current, self.amplifier_current);
        set(&mut t.capacitance, self.capacitance);
        set(&mut t.film_corner_hz, self.film_corner_hz);
        set(&mut t.film_bond, self.film_bond);
        if let Some(w) = self.amplifier_window {
            t.amplifier_window = w;
        }
        if let Some(z) = &self.zeta {
            if z.is_empty() || z.len() > t.modes {
                return err(format!(
                    "`plant.zeta` has {} values: give 1 to `modes` = {} (the last one serves the modes after it)",
                    z.len(),
                    t.modes
                ));
            }
            for j in 0..MAX_MODES {
                t.zeta[j] = z[j.min(z.len() - 1)];
            }
        }
        for (i, m) in t.motors.iter_mut().enumerate() {
            for (dst, src) in [
                (&mut m.current_tau, self.current_tau),
                (&mut m.gear_ratio, self.gear_ratio),
                (&mut m.rotor_inertia, self.rotor_inertia),
                (&mut m.viscous, self.viscous),
                (&mut m.coulomb, self.coulomb),
                (&mut m.coulomb_speed, self.coulomb_speed),
            ] {
                if let Some(v) = src {
                    *dst = v[i];
                }
            }
        }
        t.validate()
            .map_err(|(key, msg)| ScenarioError(format!("`{key}`: {msg}")))?;
        Ok(Some(t))
    }
}

/// The `[trajectory]` table: a plain struct (not a tagged enum) so that TOML errors keep the
/// line of the key they are about; keys of another `kind` are refused after reading.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TrajectorySpec {
    kind: KindSpec,
    #[serde(default, deserialize_with = "option_array")]
    start: Option<[f64; 2]>,
    #[serde(default, deserialize_with = "option_array")]
    amplitude: Option<[f64; 2]>,
    move_time: Option<f64>,
    ramp_time: Option<f64>,
    #[serde(default, deserialize_with = "option_array")]
    centre: Option<[f64; 2]>,
    radius: Option<f64>,
    period: Option<f64>,
    start_phase: Option<f64>,
    clockwise: Option<bool>,
    elbow: Option<ElbowSpec>,
    margin: Option<f64>,
    #[serde(default, deserialize_with = "option_array")]
    angles: Option<[f64; 2]>,
}

#[derive(Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
enum KindSpec {
    Trapezoid,
    Circle,
    Hold,
}

impl TrajectorySpec {
    /// Refuses a key that belongs to another kind of trajectory.
    fn keys_fit(&self) -> Result<(), ScenarioError> {
        let set = [
            ("start", self.start.is_some(), KindSpec::Trapezoid),
            ("amplitude", self.amplitude.is_some(), KindSpec::Trapezoid),
            ("move_time", self.move_time.is_some(), KindSpec::Trapezoid),
            ("centre", self.centre.is_some(), KindSpec::Circle),
            ("radius", self.radius.is_some(), KindSpec::Circle),
            ("period", self.period.is_some(), KindSpec::Circle),
            ("start_phase", self.start_phase.is_some(), KindSpec::Circle),
            ("clockwise", self.clockwise.is_some(), KindSpec::Circle),
            ("elbow", self.elbow.is_some(), KindSpec::Circle),
            ("margin", self.margin.is_some(), KindSpec::Circle),
            ("angles", self.angles.is_some(), KindSpec::Hold),
        ];
        for (key, present, kind) in set {
            if present && kind != self.kind {
                return err(format!(
                    "`trajectory.{key}` is not a key of this `kind` of trajectory"
                ));
            }
        }
        if self.ramp_time.is_some() && self.kind == KindSpec::Hold {
            return err("`trajectory.ramp_time` is not a key of a `hold` trajectory");
        }
        if self.kind == KindSpec::Hold && self.angles.is_none() {
            return err("`trajectory.angles`: a `hold` trajectory needs its angles [rad]");
        }
        Ok(())
    }
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum ElbowSpec {
    Positive,
    Negative,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct ControllerSpec {
    law: Option<LawSpec>,
    piezo: Option<bool>,
    k_c: Option<f64>,
    cutoff_hz: Option<f64>,
    #[serde(default, deserialize_with = "option_array")]
    kp: Option<[f64; 4]>,
    #[serde(default, deserialize_with = "option_array")]
    lambda: Option<[f64; 4]>,
    #[serde(default, deserialize_with = "option_array")]
    d_delta: Option<[f64; 2]>,
    state: Option<StateSpec>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum LawSpec {
    Tracking,
    Robust,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum StateSpec {
    Full,
    Observer,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RatesSpec {
    plant_dt: Option<f64>,
    motor_hz: Option<f64>,
    piezo_hz: Option<f64>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct LimitsSpec {
    #[serde(default, deserialize_with = "option_array")]
    tau_max: Option<[f64; 2]>,
    v_a_max: Option<f64>,
    v_a_min: Option<f64>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct ArmSpec {
    a1: Option<f64>,
    a2: Option<f64>,
    m1: Option<f64>,
    m2: Option<f64>,
    m_h2: Option<f64>,
    i_1: Option<f64>,
    i_h1: Option<f64>,
    i_h2: Option<f64>,
    i_2_extra: Option<f64>,
    #[serde(default, deserialize_with = "option_array")]
    frequency_hz: Option<[f64; 2]>,
    #[serde(default, deserialize_with = "option_array")]
    zeta: Option<[f64; 2]>,
}

impl ArmSpec {
    /// The arm: the paper's, with the values the table gives; modes of a uniform link of the
    /// table's `m2` and `a2` at its `frequency_hz` and `zeta` when it gives any of those four.
    fn params(&self) -> Result<ArmParams<f64>, ScenarioError> {
        arm_ranges(self)?;
        let a = self;
        let mut arm = ArmParams::<f64>::default();
        for (dst, src) in [
            (&mut arm.a1, a.a1),
            (&mut arm.a2, a.a2),
            (&mut arm.m1, a.m1),
            (&mut arm.m2, a.m2),
            (&mut arm.m_h2, a.m_h2),
            (&mut arm.i_1, a.i_1),
            (&mut arm.i_h1, a.i_h1),
            (&mut arm.i_h2, a.i_h2),
            (&mut arm.i_2_extra, a.i_2_extra),
        ] {
            if let Some(v) = src {
                *dst = v;
            }
        }
        let omega = a.frequency_hz.map_or(arm.modes.omega, |f| {
            Vector2::new(f[0], f[1]) * std::f64::consts::TAU
        });
        let zeta = a.zeta.map_or(arm.modes.zeta, |z| Vector2::new(z[0], z[1]));
        if a.m2.is_some() || a.a2.is_some() || a.frequency_hz.is_some() || a.zeta.is_some() {
            if !(arm.m2 > 0.0 && arm.a2 > 0.0) {
                return err("`arm.m2` and `arm.a2` must be > 0");
            }
            arm.modes = ModalData::uniform(arm.m2, arm.a2, omega, zeta);
        }
        arm.validate().map_err(|e| param("arm", e))?;
        Ok(arm)
    }
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct SensorsSpec {
    realistic: Option<bool>,
    encoder_counts: Option<f64>,
    adc_bits: Option<u32>,
    adc_range: Option<f64>,
    film_noise: Option<f64>,
    delay: Option<bool>,
    piezo_slew: Option<f64>,
    seed: Option<u64>,
}

/// A loaded scenario.
#[derive(Clone, Debug)]
pub struct Scenario {
    /// Name for output files.
    pub name: String,
    /// The run's configuration.
    pub config: SimConfig,
    /// The desired motion.
    pub trajectory: JointTrajectory<f32>,
}

/// Reads and checks a scenario file. Errors read `<file>:<line>: <key>: <what is wrong>`, the
/// line being the key's (or its table's) when the error names one.
pub fn load(path: &Path) -> Result<Scenario, ScenarioError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| ScenarioError(format!("{}: {e}", path.display())))?;
    parse(&text).map_err(|e| ScenarioError(flexarm_beam::toml_at::at_line(path, &text, &e.0)))
}

/// A model of the arm on its own (`cargo sim identify` writes one; `cargo sim firmware-params`
/// reads it): an optional `[arm]` table and a `[piezo]` table, nothing else. Returns the arm
/// (the paper's where `[arm]` leaves a value out, its modes those of `[piezo.computed]` when
/// `piezo.modes = "computed"`) and the patch as read. Errors name the key, as a scenario's do.
pub fn read_model(
    text: &str,
) -> Result<(ArmParams<f64>, flexarm_beam::fragment::PiezoChoice), ScenarioError> {
    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct ModelFile {
        #[serde(default)]
        arm: ArmSpec,
        // Read by `read_piezo`; named here so that no other table passes.
        piezo: Option<toml::Table>,
        // The board's homing, read by `crate::board_homing` (`flexarm-sim firmware-params`):
        // let through, not kept.
        #[serde(rename = "homing")]
        _homing: Option<serde::de::IgnoredAny>,
    }
    let f: ModelFile = toml::from_str(text).map_err(|e| ScenarioError(de_error(text, &e)))?;
    if f.piezo.is_none() {
        return err("no [piezo] table: a model needs the patch (`cargo sim identify` writes one)");
    }
    let mut arm = f.arm.params()?;
    let choice = flexarm_beam::fragment::read_piezo(text, arm.a2)
        .map_err(|e| ScenarioError(e.to_string()))?;
    if let Some(md) = choice.modal_data {
        arm.modes = md;
        arm.validate().map_err(|e| param("piezo.computed", e))?;
    }
    Ok((arm, choice))
}

/// A refusal of the simulator's check as `` `key`: what is wrong ``, the key the file's.
fn sim_error(e: SimError) -> ScenarioError {
    ScenarioError(match e {
        SimError::Rates { name, .. } => format!("`rates.{name}`: {e}"),
        SimError::Config(flexarm_core::ParamError::NotPositive("plant_dt")) => {
            "`rates.plant_dt` must be a finite number > 0".into()
        }
        _ => e.to_string(),
    })
}

/// A parameter error of one table as `` `table.key`: what is wrong `` (the `[arm]` table
/// gives the modal frequencies in Hz, as `frequency_hz`).
fn param(table: &str, e: flexarm_core::ParamError) -> ScenarioError {
    use flexarm_core::ParamError as P;
    let key = |n: &str| match (table, n.strip_prefix("omega")) {
        ("arm", Some(index)) => format!("frequency_hz{index}"),
        _ => n.to_string(),
    };
    ScenarioError(match e {
        P::NotFinite(n) => format!("`{table}.{}`: must be a finite number", key(n)),
        P::NotPositive(n) => format!("`{table}.{}`: must be a finite number > 0", key(n)),
        P::Negative(n) => format!("`{table}.{}`: must be >= 0", key(n)),
        P::FrequenciesNotIncreasing => {
            format!("`{table}.frequency_hz`: the modal frequencies must increase")
        }
        P::PatchOutsideLink => {
            "`piezo`: the patch must lie on link 2 (0 <= x_a, 0 < l_a, x_a + l_a <= a2)".into()
        }
    })
}

fn err<T>(msg: impl Into<String>) -> Result<T, ScenarioError> {
    Err(ScenarioError(msg.into()))
}

fn positive(name: &str, x: f64) -> Result<f64, ScenarioError> {
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        err(format!(
            "`{name}` = {} must be a finite number > 0",
            number(x)
        ))
    }
}

/// `lo ≤ v ≤ hi` for a value the file gives, naming its key.
fn within(key: &str, v: Option<f64>, lo: f64, hi: f64, unit: &str) -> Result<(), ScenarioError> {
    match v {
        Some(x) if !(x.is_finite() && x >= lo && x <= hi) => err(outside(key, x, lo, hi, unit)),
        _ => Ok(()),
    }
}

/// [`within`] for each value of a list the file gives, naming its index.
fn each_within<const N: usize>(
    key: &str,
    list: Option<[f64; N]>,
    lo: f64,
    hi: f64,
    unit: &str,
) -> Result<(), ScenarioError> {
    list.iter()
        .flatten()
        .enumerate()
        .try_for_each(|(i, v)| within(&format!("{key}[{i}]"), Some(*v), lo, hi, unit))
}

/// The `[arm]` table's values within their physical ranges (SI).
fn arm_ranges(a: &ArmSpec) -> Result<(), ScenarioError> {
    for (key, v) in [("arm.a1", a.a1), ("arm.a2", a.a2)] {
        within(key, v, 1e-2, 10.0, "m")?;
    }
    for (key, v) in [("arm.m1", a.m1), ("arm.m2", a.m2), ("arm.m_h2", a.m_h2)] {
        within(key, v, 0.0, 1e3, "kg")?;
    }
    for (key, v) in [
        ("arm.i_1", a.i_1),
        ("arm.i_h1", a.i_h1),
        ("arm.i_h2", a.i_h2),
        ("arm.i_2_extra", a.i_2_extra),
    ] {
        within(key, v, 0.0, 1e3, "kg m^2")?;
    }
    each_within("arm.frequency_hz", a.frequency_hz, 1e-2, 1e3, "Hz")?;
    each_within("arm.zeta", a.zeta, 0.0, 1.0, "")?;
    Ok(())
}

/// Physical ranges of the values a file gives (SI): beyond them the model, the numerics or
/// the `f32` controller stop being meaningful. The finer rules (f32 conversion, the rates'
/// relations, the run's size) are `SimConfig::validate`'s.
fn ranges(f: &File) -> Result<(), ScenarioError> {
    let c = &f.controller;
    within("controller.k_c", c.k_c, 0.0, 1e6, "s")?;
    within("controller.cutoff_hz", c.cutoff_hz, 1e-2, 1e6, "Hz")?;
    each_within("controller.kp", c.kp, 0.0, 1e6, "")?;
    each_within("controller.lambda", c.lambda, 0.0, 1e6, "")?;
    each_within("controller.d_delta", c.d_delta, 0.0, 1e6, "1/s")?;
    let r = &f.rates;
    within("rates.motor_hz", r.motor_hz, 1e-3, 1e6, "Hz")?;
    within("rates.piezo_hz", r.piezo_hz, 1e-3, 1e7, "Hz")?;
    each_within("limits.tau_max", f.limits.tau_max, 0.0, 1e4, "N m")?;
    within("limits.v_a_max", f.limits.v_a_max, 0.0, 1e5, "V")?;
    within("limits.v_a_min", f.limits.v_a_min, -1e5, 0.0, "V")?;
    let s = &f.sensors;
    within(
        "sensors.encoder_counts",
        s.encoder_counts,
        4.0,
        1e9,
        "counts/rev",
    )?;
    within("sensors.adc_range", s.adc_range, 1e-3, 1e3, "V")?;
    within("sensors.film_noise", s.film_noise, 0.0, 1e3, "V")?;
    within("sensors.piezo_slew", s.piezo_slew, 1.0, 1e12, "V/s")?;
    let t = &f.trajectory;
    for (key, v) in [
        ("trajectory.move_time", t.move_time),
        ("trajectory.ramp_time", t.ramp_time),
        ("trajectory.period", t.period),
    ] {
        within(key, v, 0.0, 1e5, "s")?;
    }
    for (key, list) in [
        ("trajectory.start", t.start),
        ("trajectory.amplitude", t.amplitude),
        ("trajectory.angles", t.angles),
    ] {
        each_within(key, list, -100.0, 100.0, "rad")?;
    }
    within(
        "trajectory.start_phase",
        t.start_phase,
        -100.0,
        100.0,
        "rad",
    )?;
    each_within("trajectory.centre", t.centre, -100.0, 100.0, "m")?;
    within("trajectory.radius", t.radius, 0.0, 100.0, "m")?;
    within("trajectory.margin", t.margin, 0.0, 10.0, "m")?;
    within("duration", f.duration, 0.0, 1e7, "s")?;
    within("tail_window", f.tail_window, 0.0, 1e7, "s")?;
    Ok(())
}

/// The poses a run on the observer holds or moves between lie within the encoder range its
/// controller accepts (`SensorLimits`, the firmware's): outside it the controller refuses its
/// first measurement and the run ends at t = 0.
fn observer_range(trajectory: &JointTrajectory<f32>) -> Result<(), ScenarioError> {
    let l = flexarm_core::supervisor::SensorLimits::<f64>::default();
    let poses = match trajectory {
        JointTrajectory::Hold(q) => vec![("trajectory.angles", *q)],
        JointTrajectory::Trapezoid(t) => vec![
            ("trajectory.start", t.start),
            ("trajectory.amplitude", t.start + t.amplitude),
        ],
        _ => Vec::new(),
    };
    for (key, pose) in poses {
        for j in 0..2 {
            let (v, lo, hi) = (f64::from(pose[j]), l.theta_min[j], l.theta_max[j]);
            if !(lo..=hi).contains(&v) {
                return err(format!(
                    "`{key}[{j}]`: joint {} at {} rad is outside {} to {} rad, the encoder range the observer's controller accepts",
                    j + 1,
                    number(v),
                    number(lo),
                    number(hi)
                ));
            }
        }
    }
    Ok(())
}

/// Parses a scenario from TOML text.
pub fn parse(text: &str) -> Result<Scenario, ScenarioError> {
    let f: File = toml::from_str(text).map_err(|e| ScenarioError(de_error(text, &e)))?;
    let mut cfg = SimConfig::default();

    ranges(&f)?;

    // Arm.
    cfg.arm = f.arm.params()?;
    let arm = &cfg.arm;
    cfg.patch = flexarm_core::control::piezo::PiezoPatch::uniform(
        &flexarm_core::control::piezo::PiezoMaterial::default(),
        arm.m2,
        arm.a2,
        cfg.patch.x_a,
        cfg.patch.l_a,
    );

    // Piezo fragment from the optimizer.
    let mut k_c = PiezoGains::<f32>::default().k_c as f64;
    if f.piezo.is_some() {
        let choice = flexarm_beam::fragment::read_piezo(text, cfg.arm.a2)
            .map_err(|e| ScenarioError(e.to_string()))?;
        cfg.patch = choice.patch;
        k_c = choice.controller_k_c();
        if let Some(md) = choice.modal_data {
            cfg.arm.modes = md;
        }
    }

    // Controller.
    let c = &f.controller;
    cfg.law = match c.law {
        Some(LawSpec::Robust) => MotorLaw::Robust,
        _ => MotorLaw::Tracking,
    };
    cfg.state = match c.state {
        Some(StateSpec::Observer) => StateSource::Observer,
        _ => StateSource::Full,
    };
    let v4 = |v: [f64; 4]| Vector4::new(v[0] as f32, v[1] as f32, v[2] as f32, v[3] as f32);
    if let Some(kp) = c.kp {
        cfg.gains.kp = v4(kp);
    }
    if let Some(l) = c.lambda {
        cfg.gains.lambda = v4(l);
    }
    if let Some(d) = c.d_delta {
        cfg.gains.d_delta = Vector2::new(d[0] as f32, d[1] as f32);
    }
    cfg.gains.validate().map_err(|e| param("controller", e))?;
    let k_c = c.k_c.unwrap_or(k_c);
    let cutoff = c
        .cutoff_hz
        .unwrap_or(PiezoGains::<f32>::default().cutoff_hz as f64);
    positive("controller.k_c", k_c)?;
    positive("controller.cutoff_hz", cutoff)?;
    cfg.piezo = c.piezo.unwrap_or(false).then_some(PiezoGains {
        k_c: k_c as f32,
        cutoff_hz: cutoff as f32,
    });

    // Rates, limits, timing.
    let r = &f.rates;
    let d = Rates::default();
    cfg.rates = Rates {
        plant_dt: r.plant_dt.unwrap_or(d.plant_dt),
        motor_hz: r.motor_hz.unwrap_or(d.motor_hz),
        piezo_hz: r.piezo_hz.unwrap_or(d.piezo_hz),
    };
    cfg.rates.divisors().map_err(sim_error)?;
    if let Some(t) = f.limits.tau_max {
        cfg.limits.tau_max = Vector2::new(t[0] as f32, t[1] as f32);
    }
    // The window: `v_a_max` alone keeps it symmetric; `v_a_min` sets its bottom.
    if let Some(v) = f.limits.v_a_max {
        cfg.limits.v_a_max = v as f32;
        cfg.limits.v_a_min = -(v as f32);
    }
    if let Some(v) = f.limits.v_a_min {
        cfg.limits.v_a_min = v as f32;
    }
    cfg.limits.validate().map_err(|e| param("limits", e))?;
    cfg.duration = positive("duration", f.duration.unwrap_or(cfg.duration))?;
    cfg.tail_window = positive("tail_window", f.tail_window.unwrap_or(cfg.tail_window))?;
    if cfg.tail_window > cfg.duration {
        return err(format!(
            "`tail_window` = {} s is longer than `duration` = {} s",
            cfg.tail_window, cfg.duration
        ));
    }

    // Sensors.
    let s = &f.sensors;
    let mut sens = if s.realistic.unwrap_or(false) {
        crate::sim::Sensors::realistic()
    } else {
        crate::sim::Sensors::default()
    };
    if let Some(n) = s.encoder_counts {
        sens.encoder_counts = Some(positive("sensors.encoder_counts", n)?);
    }
    if let Some(b) = s.adc_bits {
        if !(1..=24).contains(&b) {
            return err(format!("`sensors.adc_bits` = {b} must be 1 to 24"));
        }
        sens.adc_bits = Some(b);
    }
    if let Some(r) = s.adc_range {
        sens.adc_range = positive("sensors.adc_range", r)?;
    }
    if let Some(n) = s.film_noise {
        if !(n.is_finite() && n >= 0.0) {
            return err(format!("`sensors.film_noise` = {n} must be >= 0"));
        }
        sens.film_noise = n;
    }
    if let Some(dl) = s.delay {
        sens.delay = dl;
    }
    if let Some(r) = s.piezo_slew {
        sens.piezo_slew = Some(positive("sensors.piezo_slew", r)?);
    }
    if let Some(seed) = s.seed {
        sens.seed = seed;
    }
    cfg.sensors = sens;

    // Trajectory.
    let kin = Planar2 {
        a1: cfg.arm.a1 as f32,
        a2: cfg.arm.a2 as f32,
    };
    let terr = |e: flexarm_core::TrajectoryError| {
        ScenarioError(match e {
            flexarm_core::TrajectoryError::Unreachable { .. } => format!(
                "`trajectory.centre`: {e} (the circle of this `centre`, `radius` and `margin`)"
            ),
            _ => format!("[trajectory]: {e}"),
        })
    };
    let tspec = &f.trajectory;
    tspec.keys_fit()?;
    let TrajectorySpec {
        start,
        amplitude,
        move_time,
        ramp_time,
        centre,
        radius,
        period,
        start_phase,
        clockwise,
        elbow,
        margin,
        angles,
        ..
    } = *tspec;
    let trajectory = match tspec.kind {
        KindSpec::Trapezoid => {
            let p = Trapezoid::<f32>::paper();
            let v2 = |v: [f64; 2]| Vector2::new(v[0] as f32, v[1] as f32);
            let move_time = positive("trajectory.move_time", move_time.unwrap_or(2.0))?;
            let ramp = positive("trajectory.ramp_time", ramp_time.unwrap_or(0.5))?;
            if 2.0 * ramp > move_time {
                return err(format!(
                    "`trajectory.ramp_time` = {ramp} s must be at most half the `move_time` = {move_time} s"
                ));
            }
            let profile = Profile::new(move_time as f32, ramp as f32).map_err(terr)?;
            let tr = Trapezoid {
                start: start.map_or(p.start, v2),
                amplitude: amplitude.map_or(p.amplitude, v2),
                profile,
            };
            if !(tr
                .start
                .iter()
                .chain(tr.amplitude.iter())
                .all(|x| x.is_finite()))
            {
                return err("[trajectory]: `start` and `amplitude` must be finite");
            }
            JointTrajectory::Trapezoid(tr)
        }
        KindSpec::Circle => {
            let centre = centre.unwrap_or([0.65, 0.0]);
            let radius = positive("trajectory.radius", radius.unwrap_or(0.2))?;
            let period = positive("trajectory.period", period.unwrap_or(4.0))?;
            let ramp = positive("trajectory.ramp_time", ramp_time.unwrap_or(0.5))?;
            if 2.0 * ramp > period {
                return err(format!(
                    "`trajectory.ramp_time` = {ramp} s must be at most half the `period` = {period} s"
                ));
            }
            let margin = margin.unwrap_or(0.05);
            if !(margin.is_finite() && margin >= 0.0) {
                return err(format!(
                    "`trajectory.margin` = {margin} m must be a finite distance >= 0 inside the reachable annulus"
                ));
            }
            let circle = Circle::new(
                kin,
                Vector2::new(centre[0] as f32, centre[1] as f32),
                radius as f32,
                start_phase.unwrap_or(std::f64::consts::FRAC_PI_2) as f32,
                clockwise.unwrap_or(true),
                Profile::new(period as f32, ramp as f32).map_err(terr)?,
                match elbow {
                    Some(ElbowSpec::Negative) => Elbow::Negative,
                    _ => Elbow::Positive,
                },
                margin as f32,
            )
            .map_err(terr)?;
            JointTrajectory::Circle(circle)
        }
        KindSpec::Hold => {
            let a = angles.unwrap_or_default();
            let held = Vector2::new(a[0] as f32, a[1] as f32);
            if !held.iter().all(|x| x.is_finite()) {
                return err("`trajectory.angles` must be finite [rad]");
            }
            JointTrajectory::Hold(held)
        }
    };
    if cfg.state == StateSource::Observer {
        observer_range(&trajectory)?;
    }
    if let Some(p) = &f.plant
        && let Some(t) = p.truth()?
    {
        let given = (cfg.arm, cfg.patch);
        cfg = cfg
            .with_truth(t)
            .map_err(|e| ScenarioError(format!("[plant]: {e}")))?;
        if p.controller == Some(ControllerModelSpec::Arm) {
            (cfg.arm, cfg.patch) = given;
        }
    }
    cfg.validate(&trajectory).map_err(sim_error)?;
    crate::plant::check_step(&cfg, trajectory.sample(0.0).q.cast()).map_err(sim_error)?;
    let name = f.name.unwrap_or_else(|| "scenario".into());
    crate::outdir::check_file_name(&name)
        .map_err(|e| ScenarioError(format!("`name`: {e}: it names the output files")))?;
    Ok(Scenario {
        name,
        config: cfg,
        trajectory,
    })
}

//! The optimizer's configuration file (TOML). Every field has a default (the paper's value
//! where it gives one); unknown keys are refused so that a typo cannot pass silently.
//! `beam/examples/optimize.toml` lists every key with its unit.

use crate::design::{Amplifier, DesignModel, Normalization, Objective, Weights};
use crate::section::Layers;
use crate::toml_at::number as num;
use flexarm_core::control::piezo::PiezoMaterial;
use serde::Deserialize;
use std::fmt;

/// Largest tip mass, in bare-beam masses, that the configuration accepts: the exact solution's
/// root bracketing is checked against the finite elements up to it
/// (`fem::payload_range`). Beyond it the first mode's root can fall below the scan's start.
pub const MAX_TIP_MASS_RATIO: f64 = 100.0;
/// Largest tip rotary inertia, in units of the bare beam's `m L²`, likewise checked.
pub const MAX_TIP_INERTIA_RATIO: f64 = 10.0;

/// Most patches in the grid.
const MAX_PATCHES: f64 = 50_000.0;
/// Most `(patch, gain)` evaluations of the grid.
const MAX_EVALUATIONS: f64 = 5e6;

/// A refused configuration: the message names the key and the rule.
#[derive(Debug, Clone, PartialEq)]
pub struct ConfigError(pub String);

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ConfigError {}

/// Link 2 as a beam.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BeamConfig {
    /// Length `a2` [m].
    pub length: f64,
    /// Young's modulus `E_b` [Pa].
    pub e_b: f64,
    /// Thickness `t_b` [m].
    pub t_b: f64,
    /// Width `b` of beam, ceramic and film [m].
    pub width: f64,
    /// Density `ρ_b` [kg/m³].
    pub rho_b: f64,
    /// Tip point mass [kg].
    pub tip_mass: f64,
    /// Tip rotary inertia [kg·m²].
    pub tip_inertia: f64,
    /// Modal damping ratios, one per mode kept (1 to 4 modes) [-].
    pub zeta: Vec<f64>,
    /// Whether the patch's mass and stiffness change the modes.
    pub patch_structure: bool,
}

impl Default for BeamConfig {
    fn default() -> Self {
        let m = PiezoMaterial::<f64>::default();
        Self {
            length: 0.7,
            e_b: m.e_b,
            t_b: m.t_b,
            width: m.b,
            rho_b: 2700.0,
            tip_mass: 0.0,
            tip_inertia: 0.0,
            zeta: vec![0.07, 0.03],
            patch_structure: true,
        }
    }
}

/// Ceramic actuator and film sensor.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PiezoConfig {
    /// Ceramic modulus `E_c` [Pa].
    pub e_c: f64,
    /// Ceramic thickness `t_c` [m].
    pub t_c: f64,
    /// Ceramic density `ρ_c` [kg/m³].
    pub rho_c: f64,
    /// Ceramic strain constant `d31` [m/V] (sign ignored).
    pub d31: f64,
    /// Film modulus `E_f` [Pa].
    pub e_f: f64,
    /// Film thickness `t_f` [m].
    pub t_f: f64,
    /// Film density `ρ_f` [kg/m³].
    pub rho_f: f64,
    /// Film voltage constant `g31` [V·m/N].
    pub g31: f64,
    /// Film capacitance per area [F/m²] (380 pF/cm² = 3.8e-6 F/m²).
    pub c_area: f64,
}

impl Default for PiezoConfig {
    fn default() -> Self {
        let m = PiezoMaterial::<f64>::default();
        Self {
            e_c: m.e_c,
            t_c: m.t_c,
            rho_c: 7700.0,
            d31: m.d31,
            e_f: m.e_f,
            t_f: m.t_f,
            rho_f: 1780.0,
            g31: m.g31,
            c_area: m.c_area,
        }
    }
}

/// The search.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OptimizeConfig {
    /// Material cost `α` [units of J0 per m²].
    pub alpha: f64,
    /// Gain cost `β_c` [units of J0 per s].
    pub beta_c: f64,
    /// Initial-state weights `λ_j` (Eq. 32), one per mode [units of δ].
    pub lambda: Vec<f64>,
    /// Grid step of `x_a` and `l_a` [m].
    pub step: f64,
    /// Gains `k_c` of the grid [s], ascending, each in `(0, k_max]`.
    pub k_c: Vec<f64>,
    /// Largest admissible gain `K_max` [s] (Eq. 35).
    pub k_max: f64,
    /// Smallest admissible patch length [m].
    pub min_length: f64,
    /// Mode normalization: "unit_modal_mass", "unit_tip" or "paper_tip".
    pub normalization: Normalization,
    /// Objective: "paper" (`− J0`) or "fraction" (`− J0/W0`).
    pub objective: Objective,
    /// Refine the best grid point by a bounded pattern search over `(x_a, l_a, k_c)`.
    pub refine: bool,
}

/// The default gain grid: 1 s to 1000 s, 31 geometric steps.
pub fn default_gains() -> Vec<f64> {
    (0..=30).map(|i| 10f64.powf(i as f64 / 10.0)).collect()
}

impl Default for OptimizeConfig {
    fn default() -> Self {
        Self {
            alpha: 300.0,
            beta_c: 3.0,
            lambda: vec![20.0, 10.0],
            step: 0.01,
            k_c: default_gains(),
            k_max: 1000.0,
            min_length: 0.01,
            normalization: Normalization::UnitModalMass,
            objective: Objective::Paper,
            refine: true,
        }
    }
}

/// The piezo amplifier and the reference vibration it must serve
/// ([`crate::design::Amplifier`]).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AmplifierConfig {
    /// Top of the output window `V_max` [V].
    pub v_max: f64,
    /// Bottom of the window `V_min` [V] (negative; default `−v_max`).
    pub v_min: Option<f64>,
    /// Tip speed of each mode in the reference vibration [m/s], one per mode kept.
    pub reference_tip_speed: Vec<f64>,
    /// Keep `k_c` within what the amplifier can serve (`false`: the paper's problem).
    pub enforce: bool,
}

impl Default for AmplifierConfig {
    fn default() -> Self {
        let a = Amplifier::default();
        Self {
            v_max: a.v_max,
            v_min: None,
            reference_tip_speed: a.reference_tip_speed,
            enforce: a.enforce,
        }
    }
}

/// Which sensitivity studies to run (each re-optimizes with one value changed).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SensitivityConfig {
    /// Run them at all.
    pub enabled: bool,
    /// Values of `α` to try [units of J0 per m²].
    pub alpha: Vec<f64>,
    /// Values of `β_c` to try [units of J0 per s].
    pub beta_c: Vec<f64>,
    /// Beam densities to try [kg/m³].
    pub rho_b: Vec<f64>,
    /// Gain limits `K_max` to try [s].
    pub k_max: Vec<f64>,
    /// Tip masses to try [kg].
    pub tip_mass: Vec<f64>,
}

impl Default for SensitivityConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            alpha: vec![0.0, 300.0, 3e3, 3e4, 3e5],
            beta_c: vec![0.0, 3.0, 30.0, 300.0],
            // Aluminium; and the density that gives the paper's m2 = 0.3 kg over 0.7 m with
            // the printed 25 mm × 0.8 mm section.
            rho_b: vec![2700.0, 0.3 / (0.7 * 25e-3 * 0.8e-3)],
            k_max: vec![30.0, 100.0],
            // The bare beam's own mass (0.0378 kg) and a 0.1 kg payload.
            tip_mass: vec![0.0378, 0.1],
        }
    }
}

/// The whole file.
#[derive(Clone, Debug, PartialEq, Default, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Config {
    /// Link 2.
    pub beam: BeamConfig,
    /// Piezo layers.
    pub piezo: PiezoConfig,
    /// The search.
    pub optimize: OptimizeConfig,
    /// The amplifier constraint.
    pub amplifier: AmplifierConfig,
    /// Sensitivity studies.
    pub sensitivity: SensitivityConfig,
}

fn check(cond: bool, msg: impl FnOnce() -> String) -> Result<(), ConfigError> {
    if cond {
        Ok(())
    } else {
        Err(ConfigError(msg()))
    }
}

fn positive(name: &str, v: f64) -> Result<(), ConfigError> {
    check(v.is_finite() && v > 0.0, || {
        format!("`{name}` = {} must be a finite number > 0", num(v))
    })
}

/// `lo ≤ v ≤ hi` (physical ranges: beyond them the model's assumptions or its numerics end).
fn within(name: &str, v: f64, lo: f64, hi: f64, unit: &str) -> Result<(), ConfigError> {
    within_because(name, v, lo, hi, unit, "")
}

/// [`within`] with the reason for the range.
fn within_because(
    name: &str,
    v: f64,
    lo: f64,
    hi: f64,
    unit: &str,
    why: &str,
) -> Result<(), ConfigError> {
    check(v.is_finite() && v >= lo && v <= hi, || {
        format!("{}{why}", crate::toml_at::outside(name, v, lo, hi, unit))
    })
}

/// Physical ranges, SI: moduli from soft polymers to diamond, thicknesses from a film to a
/// plate, densities from foams to tungsten, piezo constants around the known materials'.
const MODULUS: (f64, f64) = (1e6, 1.2e12);
const THICKNESS: (f64, f64) = (1e-6, 0.05);
const DENSITY: (f64, f64) = (10.0, 25_000.0);

impl Config {
    /// Parses and validates a TOML text.
    pub fn from_toml(text: &str) -> Result<Self, ConfigError> {
        let c: Config =
            toml::from_str(text).map_err(|e| ConfigError(crate::toml_at::de_error(text, &e)))?;
        c.validate()?;
        Ok(c)
    }

    /// Reads, parses and validates a file. Errors read `<file>:<line>: <key>: <what is wrong>`.
    pub fn load(path: &std::path::Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| ConfigError(format!("cannot read {}: {e}", path.display())))?;
        Self::from_toml(&text).map_err(|e| ConfigError(crate::toml_at::at_line(path, &text, &e.0)))
    }

    /// Checks every value.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let b = &self.beam;
        within("beam.length", b.length, 0.01, 10.0, "m")?;
        within("beam.e_b", b.e_b, MODULUS.0, MODULUS.1, "Pa")?;
        within("beam.t_b", b.t_b, THICKNESS.0, THICKNESS.1, "m")?;
        within("beam.width", b.width, 1e-4, 1.0, "m")?;
        within("beam.rho_b", b.rho_b, DENSITY.0, DENSITY.1, "kg/m^3")?;
        let beam_mass = b.rho_b * b.width * b.t_b * b.length;
        within_because(
            "beam.tip_mass",
            b.tip_mass,
            0.0,
            MAX_TIP_MASS_RATIO * beam_mass,
            "kg",
            " (100 times the bare beam's mass: the range the mode solver is verified on)",
        )?;
        within_because(
            "beam.tip_inertia",
            b.tip_inertia,
            0.0,
            MAX_TIP_INERTIA_RATIO * beam_mass * b.length * b.length,
            "kg m^2",
            " (10 m L^2 of the bare beam: the range the mode solver is verified on)",
        )?;
        check((1..=4).contains(&b.zeta.len()), || {
            format!(
                "`beam.zeta` needs 1 to 4 damping ratios, got {}",
                b.zeta.len()
            )
        })?;
        for (i, z) in b.zeta.iter().enumerate() {
            check(z.is_finite() && *z > 0.0 && *z < 1.0, || {
                format!(
                    "`beam.zeta[{i}]` = {}: each ratio must lie in (0, 1)",
                    num(*z)
                )
            })?;
        }
        let p = &self.piezo;
        within("piezo.e_c", p.e_c, MODULUS.0, MODULUS.1, "Pa")?;
        within("piezo.e_f", p.e_f, MODULUS.0, MODULUS.1, "Pa")?;
        within("piezo.t_c", p.t_c, THICKNESS.0, THICKNESS.1, "m")?;
        within("piezo.t_f", p.t_f, THICKNESS.0, THICKNESS.1, "m")?;
        within("piezo.rho_c", p.rho_c, DENSITY.0, DENSITY.1, "kg/m^3")?;
        within("piezo.rho_f", p.rho_f, DENSITY.0, DENSITY.1, "kg/m^3")?;
        within("piezo.g31", p.g31, 1e-4, 10.0, "V m/N")?;
        within("piezo.c_area", p.c_area, 1e-9, 1e-1, "F/m^2")?;
        // In magnitude: the sign is the poling direction.
        within("piezo.d31", p.d31.abs(), 1e-13, 1e-8, "m/V")?;
        let o = &self.optimize;
        within("optimize.alpha", o.alpha, 0.0, 1e12, "")?;
        within("optimize.beta_c", o.beta_c, 0.0, 1e12, "")?;
        check(o.lambda.len() == b.zeta.len(), || {
            format!(
                "`optimize.lambda` has {} weights but `beam.zeta` keeps {} modes",
                o.lambda.len(),
                b.zeta.len()
            )
        })?;
        for (i, l) in o.lambda.iter().enumerate() {
            let key = format!("optimize.lambda[{i}]");
            positive(&key, *l)?;
            within(&key, *l, 0.0, 1e6, "")?;
        }
        positive("optimize.step", o.step)?;
        check(o.step <= b.length / 2.0, || {
            format!(
                "`optimize.step` = {} is more than half the beam",
                num(o.step)
            )
        })?;
        check(b.length / o.step <= 2000.0, || {
            format!(
                "`optimize.step` = {} gives more than 2000 points per axis",
                o.step
            )
        })?;
        // Bounded work: the modes are solved once per patch (about 80 µs), `J0` once per patch
        // and gain (about 1 µs).
        let n = (b.length / o.step + 1e-9).floor();
        let patches = n * (n + 1.0) / 2.0;
        check(patches <= MAX_PATCHES, || {
            format!(
                "`optimize.step` = {} gives {patches:.0} patches; at most {MAX_PATCHES} (about 4 s of mode solving)",
                o.step
            )
        })?;
        check(patches * o.k_c.len() as f64 <= MAX_EVALUATIONS, || {
            format!(
                "`optimize.k_c` has {} gains: {:.0} evaluations with {patches:.0} patches; at most {MAX_EVALUATIONS}",
                o.k_c.len(),
                patches * o.k_c.len() as f64
            )
        })?;
        within("optimize.k_max", o.k_max, 1e-6, 1e7, "s")?;
        positive("optimize.min_length", o.min_length)?;
        check(o.min_length < b.length, || {
            "`optimize.min_length` must be below `beam.length`".into()
        })?;
        check(!o.k_c.is_empty(), || "`optimize.k_c` is empty".into())?;
        for (i, k) in o.k_c.iter().enumerate() {
            check(k.is_finite() && *k >= 1e-6 && *k <= o.k_max, || {
                format!(
                    "`optimize.k_c[{i}]` = {} must lie in [1e-6, k_max = {}] s",
                    num(*k),
                    num(o.k_max)
                )
            })?;
        }
        let a = &self.amplifier;
        within("amplifier.v_max", a.v_max, 1e-3, 1e5, "V")?;
        if let Some(v) = a.v_min {
            within("amplifier.v_min", -v, 1e-3, 1e5, "V (negated)")?;
        }
        check(a.reference_tip_speed.len() == b.zeta.len(), || {
            format!(
                "`amplifier.reference_tip_speed` has {} speeds but `beam.zeta` keeps {} modes",
                a.reference_tip_speed.len(),
                b.zeta.len()
            )
        })?;
        for (i, r) in a.reference_tip_speed.iter().enumerate() {
            let key = format!("amplifier.reference_tip_speed[{i}]");
            positive(&key, *r)?;
            within(&key, *r, 0.0, 100.0, "m/s")?;
        }
        let s = &self.sensitivity;
        for (name, list) in [
            ("sensitivity.alpha", &s.alpha),
            ("sensitivity.beta_c", &s.beta_c),
            ("sensitivity.rho_b", &s.rho_b),
            ("sensitivity.k_max", &s.k_max),
            ("sensitivity.tip_mass", &s.tip_mass),
        ] {
            // Each value re-optimizes (the density and tip-mass rows sweep the grid again).
            check(list.len() <= 20, || {
                format!("`{name}` has {} values; at most 20", list.len())
            })?;
        }
        let each = |name: &str, list: &[f64], lo: f64, hi: f64, unit: &str| {
            list.iter()
                .enumerate()
                .try_for_each(|(i, v)| within(&format!("{name}[{i}]"), *v, lo, hi, unit))
        };
        each("sensitivity.alpha", &s.alpha, 0.0, 1e12, "")?;
        each("sensitivity.beta_c", &s.beta_c, 0.0, 1e12, "")?;
        each(
            "sensitivity.rho_b",
            &s.rho_b,
            DENSITY.0,
            DENSITY.1,
            "kg/m^3",
        )?;
        each("sensitivity.k_max", &s.k_max, 1e-6, 1e7, "s")?;
        for (i, v) in s.tip_mass.iter().enumerate() {
            within_because(
                &format!("sensitivity.tip_mass[{i}]"),
                *v,
                0.0,
                MAX_TIP_MASS_RATIO * b.rho_b * b.width * b.t_b * b.length,
                "kg",
                " (100 times the bare beam's mass)",
            )?;
        }
        Ok(())
    }

    /// The design model this file describes.
    pub fn model(&self) -> DesignModel {
        let (b, p) = (&self.beam, &self.piezo);
        DesignModel {
            layers: Layers {
                material: PiezoMaterial {
                    e_b: b.e_b,
                    e_c: p.e_c,
                    e_f: p.e_f,
                    t_b: b.t_b,
                    t_c: p.t_c,
                    t_f: p.t_f,
                    b: b.width,
                    d31: p.d31,
                    g31: p.g31,
                    c_area: p.c_area,
                },
                rho_b: b.rho_b,
                rho_c: p.rho_c,
                rho_f: p.rho_f,
            },
            length: b.length,
            tip_mass: b.tip_mass,
            tip_inertia: b.tip_inertia,
            zeta: b.zeta.clone(),
            patch_structure: b.patch_structure,
            normalization: self.optimize.normalization,
            lambda: self.optimize.lambda.clone(),
            amplifier: Amplifier {
                v_max: self.amplifier.v_max,
                v_min: self.amplifier.v_min.unwrap_or(-self.amplifier.v_max),
                reference_tip_speed: self.amplifier.reference_tip_speed.clone(),
                enforce: self.amplifier.enforce,
            },
        }
    }

    /// The objective's weights.
    pub fn weights(&self) -> Weights {
        Weights {
            alpha: self.optimize.alpha,
            beta_c: self.optimize.beta_c,
            objective: self.optimize.objective,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_file_gives_the_defaults() {
        assert_eq!(Config::from_toml(""), Ok(Config::default()));
        assert_eq!(Config::default().model(), DesignModel::default());
    }

    #[test]
    fn example_file_states_the_defaults() {
        // The example documents every key with its default: it must stay equal to them.
        let text = include_str!("../examples/optimize.toml");
        let Ok(c) = Config::from_toml(text) else {
            unreachable!("example does not parse")
        };
        let d = Config::default();
        assert_eq!(c.beam, d.beam);
        // 380 pF/cm² is 3.8e-6 F/m² up to the last bit of the core's `380e-12 / 1e-4`.
        assert!((c.piezo.c_area / d.piezo.c_area - 1.0).abs() < 1e-12);
        let p = PiezoConfig {
            c_area: d.piezo.c_area,
            ..c.piezo.clone()
        };
        assert_eq!(p, d.piezo);
        assert_eq!(c.optimize, d.optimize);
        assert_eq!(c.sensitivity.alpha, d.sensitivity.alpha);
        assert_eq!(c.sensitivity.k_max, d.sensitivity.k_max);
        assert_eq!(c.sensitivity.tip_mass, d.sensitivity.tip_mass);
        for (a, b) in c.sensitivity.rho_b.iter().zip(&d.sensitivity.rho_b) {
            assert!((a / b - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn bad_input_is_a_readable_error() {
        for (text, needle) in [
            ("[beam]\nlength = -1.0", "beam.length"),
            ("[beam]\nlenght = 0.7", "lenght"),
            ("[optimize]\nstep = \"small\"", "step"),
            ("[optimize]\nk_c = [10.0, 5000.0]", "k_c[1]"),
            ("[optimize]\nlambda = [1.0]", "optimize.lambda"),
            ("[optimize]\nnormalization = \"max\"", "normalization"),
            ("[beam]\nzeta = [0.1, 1.5]", "beam.zeta"),
            ("[optimize]\nstep = 0.00001", "2000"),
            ("[amplifier]\nv_max = 0.0", "amplifier.v_max"),
            ("[amplifier]\nv_min = 30.0", "amplifier.v_min"),
            ("[amplifier]\nv_min = nan", "amplifier.v_min"),
            ("[amplifier]\nv_max = nan", "amplifier.v_max"),
            (
                "[amplifier]\nreference_tip_speed = [0.2]",
                "amplifier.reference_tip_speed",
            ),
            (
                "[amplifier]\nreference_tip_speed = [0.2, -0.1]",
                "amplifier.reference_tip_speed[1]",
            ),
            ("[amplifier]\nenforce = 1", "enforce"),
            ("[beam]\nrho_b = 1e30", "beam.rho_b"),
            ("[beam]\ne_b = 1e30", "beam.e_b"),
            ("[beam]\ntip_mass = 1e9", "beam.tip_mass"),
            ("[beam]\ntip_inertia = 1.0", "beam.tip_inertia"),
            ("[piezo]\nd31 = 1.0", "piezo.d31"),
            ("[optimize]\nstep = 0.001", "patches"),
            ("[optimize]\nk_c = [1e-9]", "k_c[0]"),
            ("[optimize]\nk_max = 1e300", "optimize.k_max"),
            (
                "[sensitivity]\nalpha = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0, 13.0, 14.0, 15.0, 16.0, 17.0, 18.0, 19.0, 20.0]",
                "sensitivity.alpha",
            ),
            ("[beam", "TOML"),
        ] {
            match Config::from_toml(text) {
                Ok(_) => unreachable!("accepted: {text}"),
                Err(e) => {
                    let msg = e.to_string();
                    assert!(
                        msg.contains(needle) || (needle == "TOML" && !msg.is_empty()),
                        "{text}: {msg}"
                    );
                }
            }
        }
    }

    #[test]
    fn missing_file_is_an_error() {
        let e = Config::load(std::path::Path::new("/nonexistent/optimize.toml"));
        assert!(e.is_err_and(|e| e.to_string().contains("cannot read")));
    }
}

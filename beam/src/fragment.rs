//! The chosen patch as a `[piezo]` TOML fragment that a scenario file can include, and the
//! computed modal data in the core's [`ModalData`] form.
//!
//! Keys (all SI; `docs/optimization.md` repeats them):
//!
//! | key | unit | meaning |
//! |---|---|---|
//! | `piezo.x_a` | m | patch start from joint 2 |
//! | `piezo.l_a` | m | patch length |
//! | `piezo.k_c` | s | rate-feedback gain of `V_a = −k_c V̇_f` |
//! | `piezo.k_a` | N·m/V | actuator moment per volt |
//! | `piezo.k_s` | V/rad | film volts per radian of slope difference |
//! | `piezo.c_s` | V²/(N·m) | `k_s / k_a` (Eq. 19) |
//! | `piezo.k_c_paper_modes` | s | the gain that gives mode 1 of the paper's modes (uniform shapes of the arm's `m2`, `a2`, `ω1 = 2π·4.716`) the same control damping ratio `k_c k_s k_a Δφ'₁² / (2 ω₁)` as `k_c` gives the design beam, capped by the amplifier's gain limit on those modes ([`paper_modes_gain_limit`]) |
//! | `piezo.modes` | – | `"paper"` (default): the controller and plant keep the paper's frequencies and uniform-link shapes; `"computed"`: use `[piezo.computed]` |
//! | `piezo.slope_diff` | 1/(m·√kg) | `Δφ'` of the uniform arm shapes (`m2`, `a2` of the arm), used with `modes = "paper"` |
//! | `piezo.computed.omega` | rad/s | frequencies of the patched design beam |
//! | `piezo.computed.frequency_hz` | Hz | the same in Hz |
//! | `piezo.computed.zeta` | – | damping ratios used by the optimizer |
//! | `piezo.computed.slope_diff` | 1/(m·√kg) | `Δφ'` of the patched beam's unit-modal-mass modes |
//! | `piezo.computed.c_a` | N/(V·√kg) | `k_a Δφ'` (Eq. 18) |
//! | `piezo.computed.mass_integral` | √kg·m | `∫ρφ dx` (+ tip mass term) |
//! | `piezo.computed.moment_integral` | √kg·m² | `∫ρxφ dx` (+ tip terms) |
//! | `piezo.computed.tip` | 1/√kg | `φ(a2)` |
//! | `piezo.computed.beam_mass` | kg | mass of the design beam with the patch |

use crate::config::ConfigError;
use crate::design::{DesignModel, PatchModes, reference_volts_per_gain};
use crate::point::Optimum;
use crate::toml_at::{array, de_error, number, option_array};
use flexarm_core::Vector2;
use flexarm_core::control::piezo::PiezoPatch;
use flexarm_core::modes::UniformMode;
use flexarm_core::params::{ArmParams, ModalData};

/// Modal integrals of the patched beam: `(∫ρφ + M φ(L), ∫ρxφ + M L φ(L) + J φ'(L), φ(L))`
/// per mode.
pub fn integrals(model: &DesignModel, pm: &PatchModes) -> Vec<(f64, f64, f64)> {
    let l = model.length;
    pm.modes
        .iter()
        .map(|m| {
            let (tip, tip_s) = (m.phi(l), m.slope(l));
            (
                m.integrate(|_, p| p) + model.tip_mass * tip,
                m.integrate(|x, p| x * p) + model.tip_mass * l * tip + model.tip_inertia * tip_s,
                tip,
            )
        })
        .collect()
}

/// The computed modes as the core's [`ModalData`] (needs exactly two modes).
pub fn modal_data(model: &DesignModel, pm: &PatchModes) -> Option<ModalData<f64>> {
    if pm.modes.len() != 2 || model.zeta.len() != 2 {
        return None;
    }
    let ints = integrals(model, pm);
    let v = |f: &dyn Fn(usize) -> f64| Vector2::new(f(0), f(1));
    Some(ModalData {
        omega: v(&|j| pm.modes[j].omega),
        zeta: v(&|j| model.zeta[j]),
        mass_integral: v(&|j| ints[j].0),
        moment_integral: v(&|j| ints[j].1),
        tip: v(&|j| ints[j].2),
    })
}

/// The patch in the core's form with the computed slope differences (needs two modes), for a
/// simulation that uses the computed modes.
pub fn core_patch(pm: &PatchModes) -> Option<PiezoPatch<f64>> {
    match pm.slope_diff.as_slice() {
        [a, b] => Some(PiezoPatch {
            x_a: pm.x_a,
            l_a: pm.l_a,
            slope_diff: Vector2::new(*a, *b),
            k_a: pm.k_a,
            k_s: pm.k_s,
        }),
        _ => None,
    }
}

fn list(v: &[f64]) -> String {
    let items: Vec<String> = v.iter().map(|x| format!("{x:?}")).collect();
    format!("[{}]", items.join(", "))
}

/// The largest gain [s] with which the paper's modes (uniform shapes of the arm's `m2`, `a2`)
/// ask at most `V_max` for the model's reference vibration ([`crate::design::Amplifier`]);
/// infinite when the amplifier is not enforced.
pub fn paper_modes_gain_limit(
    model: &DesignModel,
    uniform: &PiezoPatch<f64>,
    arm: &ArmParams<f64>,
) -> f64 {
    let a = &model.amplifier;
    if !a.enforce {
        return f64::INFINITY;
    }
    let tip = [0, 1].map(|j| UniformMode::new(j, arm.m2, arm.a2).phi(arm.a2));
    let per_gain: f64 = reference_volts_per_gain(
        uniform.k_s,
        &[uniform.slope_diff.x, uniform.slope_diff.y],
        &tip,
        &a.reference_tip_speed,
    )
    .iter()
    .sum();
    a.headroom() / per_gain
}

/// The `[piezo]` fragment for the design point `opt` on the arm `arm`.
pub fn piezo_fragment(model: &DesignModel, opt: &Optimum, arm: &ArmParams<f64>) -> String {
    let pm = &opt.modes;
    let uniform = PiezoPatch::uniform(
        &model.layers.material,
        arm.m2,
        arm.a2,
        opt.x_a,
        opt.l_a.min(arm.a2 - opt.x_a).max(0.0),
    );
    let ints = integrals(model, pm);
    let omega = pm.omega();
    let hz: Vec<f64> = omega.iter().map(|w| w / std::f64::consts::TAU).collect();
    let c_a: Vec<f64> = pm.slope_diff.iter().map(|d| d * pm.k_a).collect();
    let col = |f: fn(&(f64, f64, f64)) -> f64| ints.iter().map(f).collect::<Vec<f64>>();
    // Same control-added damping ratio of mode 1 on the paper's modes, within what the
    // amplifier allows on those modes for the same reference vibration.
    let k_c_paper = {
        let d = pm.slope_diff.first().copied().unwrap_or(f64::NAN);
        let w = pm.modes.first().map_or(f64::NAN, |m| m.omega);
        let du = uniform.slope_diff.x;
        let equal_damping = opt.k_c * (d * d / w) / (du * du / arm.modes.omega.x);
        equal_damping.min(paper_modes_gain_limit(model, &uniform, arm))
    };
    let beam_mass = model.beam(opt.x_a, opt.l_a).map_or(f64::NAN, |b| b.mass());
    format!(
        "# Piezo patch chosen by `flexarm-sim optimize` (flexarm-beam). Keys: docs/optimization.md.\n\
         [piezo]\n\
         x_a = {:?}   # patch start from joint 2 [m]\n\
         l_a = {:?}   # patch length [m]\n\
         k_c = {:?}   # rate-feedback gain, V_a = -k_c dV_f/dt [s]\n\
         k_a = {:?}   # actuator moment per volt [N m/V]\n\
         k_s = {:?}   # film volts per radian of slope difference [V/rad]\n\
         c_s = {:?}   # k_s / k_a (Eq. 19) [V^2/(N m)]\n\
         k_c_paper_modes = {:?}   # gain giving the paper's mode 1 the same control damping ratio, within the amplifier [s]\n\
         modes = \"paper\"   # \"paper\": paper's frequencies, uniform shapes; \"computed\": [piezo.computed]\n\
         slope_diff = {}   # delta phi' of the uniform arm shapes (m2 = {:?} kg, a2 = {:?} m) [1/(m sqrt(kg))]\n\
         \n\
         [piezo.computed]   # the segmented design beam with this patch, unit modal mass\n\
         omega = {}   # [rad/s]\n\
         frequency_hz = {}   # [Hz]\n\
         zeta = {}   # [-]\n\
         slope_diff = {}   # [1/(m sqrt(kg))]\n\
         c_a = {}   # k_a * slope_diff (Eq. 18) [N/(V sqrt(kg))]\n\
         mass_integral = {}   # int rho phi dx [sqrt(kg) m]\n\
         moment_integral = {}   # int rho x phi dx [sqrt(kg) m^2]\n\
         tip = {}   # phi(a2) [1/sqrt(kg)]\n\
         beam_mass = {:?}   # design beam with the patch [kg]\n",
        opt.x_a,
        opt.l_a,
        opt.k_c,
        pm.k_a,
        pm.k_s,
        pm.k_s / pm.k_a,
        k_c_paper,
        list(&[uniform.slope_diff.x, uniform.slope_diff.y]),
        arm.m2,
        arm.a2,
        list(&omega),
        list(&hz),
        list(&model.zeta),
        list(&pm.slope_diff),
        list(&c_a),
        list(&col(|t| t.0)),
        list(&col(|t| t.1)),
        list(&col(|t| t.2)),
        beam_mass,
    )
}

/// Which modal data a scenario's `[piezo]` table selects.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ModesChoice {
    /// The paper's frequencies with uniform-link shapes (the controller's default).
    #[default]
    Paper,
    /// The segmented design beam's modes from `[piezo.computed]`.
    Computed,
}

#[derive(Clone, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Computed {
    #[serde(deserialize_with = "array")]
    omega: [f64; 2],
    #[serde(default, deserialize_with = "option_array")]
    frequency_hz: Option<[f64; 2]>,
    #[serde(deserialize_with = "array")]
    zeta: [f64; 2],
    #[serde(deserialize_with = "array")]
    slope_diff: [f64; 2],
    #[serde(default, deserialize_with = "option_array")]
    c_a: Option<[f64; 2]>,
    #[serde(deserialize_with = "array")]
    mass_integral: [f64; 2],
    #[serde(deserialize_with = "array")]
    moment_integral: [f64; 2],
    #[serde(deserialize_with = "array")]
    tip: [f64; 2],
    #[serde(default)]
    beam_mass: Option<f64>,
}

#[derive(Clone, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Section {
    x_a: f64,
    l_a: f64,
    k_c: f64,
    k_a: f64,
    k_s: f64,
    #[serde(default)]
    c_s: Option<f64>,
    #[serde(default)]
    k_c_paper_modes: Option<f64>,
    #[serde(default)]
    modes: ModesChoice,
    #[serde(deserialize_with = "array")]
    slope_diff: [f64; 2],
    #[serde(default)]
    computed: Option<Computed>,
}

/// A document's `[piezo]` table; its other tables are its reader's (a scenario's, a model's).
#[derive(serde::Deserialize)]
struct WithPiezo {
    piezo: Option<Section>,
}

/// A `[piezo]` table read back into the core's types.
#[derive(Clone, Debug, PartialEq)]
pub struct PiezoChoice {
    /// The patch with the slope differences of the selected mode set.
    pub patch: PiezoPatch<f64>,
    /// The rate-feedback gain `k_c` [s] as written (for the design beam).
    pub k_c: f64,
    /// `k_c_paper_modes` [s] if present.
    pub k_c_paper_modes: Option<f64>,
    /// Which mode set was selected.
    pub modes: ModesChoice,
    /// The computed modal data when `modes = "computed"` (replace `ArmParams::modes` with it).
    pub modal_data: Option<ModalData<f64>>,
}

impl PiezoChoice {
    /// The gain `k_c` [s] a controller runs with this choice: with the paper's modes,
    /// `k_c_paper_modes` when present (same control damping ratio of mode 1 as `k_c` gives the
    /// design beam), otherwise `k_c`. `flexarm-sim run` and the firmware's generated parameters
    /// both use it.
    pub fn controller_k_c(&self) -> f64 {
        match (self.modes, self.k_c_paper_modes) {
            (ModesChoice::Paper, Some(k)) => k,
            _ => self.k_c,
        }
    }
}

/// Reads the `[piezo]` table of a TOML document (a scenario file or the fragment alone) and
/// checks it against link 2 of length `a2` [m]. Errors name the key.
pub fn read_piezo(text: &str, a2: f64) -> Result<PiezoChoice, ConfigError> {
    let doc: WithPiezo = toml::from_str(text).map_err(|e| ConfigError(de_error(text, &e)))?;
    let s = doc
        .piezo
        .ok_or_else(|| ConfigError("no [piezo] table".into()))?;
    let fin = |name: &str, v: f64| {
        if v.is_finite() {
            Ok(())
        } else {
            Err(ConfigError(format!("`piezo.{name}` = {v} is not finite")))
        }
    };
    for (n, v) in [
        ("x_a", s.x_a),
        ("l_a", s.l_a),
        ("k_c", s.k_c),
        ("k_a", s.k_a),
        ("k_s", s.k_s),
    ] {
        fin(n, v)?;
    }
    if !(s.x_a >= 0.0 && s.l_a > 0.0 && s.x_a + s.l_a <= a2 + 1e-9) {
        return Err(ConfigError(format!(
            "`piezo.x_a` = {}, `piezo.l_a` = {}: the patch must lie on link 2 (0 <= x_a, 0 < l_a, x_a + l_a <= {a2})",
            number(s.x_a),
            number(s.l_a)
        )));
    }
    // Physical ranges (SI); the f32 controller runs these values.
    for (n, v, hi) in [
        ("k_c", Some(s.k_c), 1e6),
        ("k_c_paper_modes", s.k_c_paper_modes, 1e6),
        ("k_a", Some(s.k_a), 1.0),
        ("k_s", Some(s.k_s), 1e6),
    ] {
        if let Some(v) = v
            && !(v.is_finite() && v > 0.0 && v <= hi)
        {
            return Err(ConfigError(format!(
                "`piezo.{n}` = {} must be > 0 and at most {hi:e}",
                number(v)
            )));
        }
    }
    for (i, d) in s.slope_diff.iter().enumerate() {
        if !(d.is_finite() && d.abs() <= 1e4) {
            return Err(ConfigError(format!(
                "`piezo.slope_diff[{i}]` = {} must be finite, at most 1e4 1/(m sqrt(kg)) in magnitude",
                number(*d)
            )));
        }
    }
    // Derived keys, when present, must agree with the ones they derive from (a hand-edited
    // fragment that changed one and not the other is refused).
    let agree = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs());
    if let Some(c_s) = s.c_s
        && !agree(c_s, s.k_s / s.k_a)
    {
        return Err(ConfigError(format!(
            "`piezo.c_s` = {} disagrees with k_s / k_a = {}",
            number(c_s),
            number(s.k_s / s.k_a)
        )));
    }
    if let Some(c) = &s.computed {
        let tau = std::f64::consts::TAU;
        if let Some(f) = c.frequency_hz
            && !(agree(f[0] * tau, c.omega[0]) && agree(f[1] * tau, c.omega[1]))
        {
            return Err(ConfigError(
                "`piezo.computed.frequency_hz` disagrees with `omega`".into(),
            ));
        }
        if let Some(ca) = c.c_a
            && !(agree(ca[0], s.k_a * c.slope_diff[0]) && agree(ca[1], s.k_a * c.slope_diff[1]))
        {
            return Err(ConfigError(
                "`piezo.computed.c_a` disagrees with k_a * slope_diff".into(),
            ));
        }
        if let Some(m) = c.beam_mass
            && !(m.is_finite() && m > 0.0)
        {
            return Err(ConfigError(format!(
                "`piezo.computed.beam_mass` = {} must be > 0",
                number(m)
            )));
        }
    }
    let (slope, modal_data) = match s.modes {
        ModesChoice::Paper => (s.slope_diff, None),
        ModesChoice::Computed => {
            let c = s.computed.as_ref().ok_or_else(|| {
                ConfigError("`piezo.modes = \"computed\"` needs a [piezo.computed] table".into())
            })?;
            let v = |a: [f64; 2]| Vector2::new(a[0], a[1]);
            let md = ModalData {
                omega: v(c.omega),
                zeta: v(c.zeta),
                mass_integral: v(c.mass_integral),
                moment_integral: v(c.moment_integral),
                tip: v(c.tip),
            };
            if !(c.omega[0] > 0.0 && c.omega[0] < c.omega[1]) {
                return Err(ConfigError(
                    "`piezo.computed.omega` must be positive and increasing".into(),
                ));
            }
            (c.slope_diff, Some(md))
        }
    };
    for (i, v) in slope.iter().enumerate() {
        let key = match s.modes {
            ModesChoice::Paper => format!("slope_diff[{i}]"),
            ModesChoice::Computed => format!("computed.slope_diff[{i}]"),
        };
        fin(&key, *v)?;
    }
    Ok(PiezoChoice {
        patch: PiezoPatch {
            x_a: s.x_a,
            l_a: s.l_a,
            slope_diff: Vector2::new(slope[0], slope[1]),
            k_a: s.k_a,
            k_s: s.k_s,
        },
        k_c: s.k_c,
        k_c_paper_modes: s.k_c_paper_modes,
        modes: s.modes,
        modal_data,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::Weights;
    use crate::point::evaluate;

    #[test]
    fn fragment_is_valid_toml_with_the_design_values() {
        // The amplifier not enforced: the paper-mode gain is the equal-damping one.
        let enforced = DesignModel::default();
        let m = DesignModel {
            amplifier: crate::design::Amplifier {
                enforce: false,
                ..enforced.amplifier.clone()
            },
            ..enforced.clone()
        };
        let Some(opt) = evaluate(&m, &Weights::default(), 0.09, 0.35, 30.0) else {
            unreachable!("feasible")
        };
        let text = piezo_fragment(&m, &opt, &ArmParams::default());
        let t: Result<toml::Table, _> = toml::from_str(&text);
        let Ok(t) = t else {
            unreachable!("invalid TOML: {text}")
        };
        let p = t.get("piezo").and_then(|v| v.as_table());
        let get = |k: &str| p.and_then(|p| p.get(k)).and_then(|v| v.as_float());
        assert_eq!(get("x_a"), Some(0.09));
        assert_eq!(get("l_a"), Some(0.35));
        assert_eq!(get("k_c"), Some(30.0));
        // Equal control damping ratio of mode 1 on both mode sets.
        let arm = ArmParams::<f64>::default();
        let core = PiezoPatch::<f64>::paper();
        let kp = get("k_c_paper_modes").unwrap_or(f64::NAN);
        let zeta_arm =
            kp * core.k_s * core.k_a * core.slope_diff.x.powi(2) / (2.0 * arm.modes.omega.x);
        let pm = &opt.modes;
        let zeta_design =
            30.0 * pm.k_s * pm.k_a * pm.slope_diff[0].powi(2) / (2.0 * pm.modes[0].omega);
        assert!(
            (zeta_arm / zeta_design - 1.0).abs() < 1e-12,
            "{zeta_arm} {zeta_design}"
        );
        // Enforced, the equal-damping gain asks more than ±200 V of the paper's
        // modes for the reference vibration: capped where it asks exactly 200 V.
        let capped = piezo_fragment(&enforced, &opt, &arm);
        let kc = read_piezo(&capped, arm.a2).map(|c| c.controller_k_c());
        let limit = paper_modes_gain_limit(&enforced, &core, &arm);
        assert!(limit < kp, "{limit} vs {kp}");
        assert_eq!(kc, Ok(limit));
        let tip = [0, 1].map(|j| UniformMode::new(j, arm.m2, arm.a2).phi(arm.a2));
        let volts: f64 = [0, 1]
            .map(|j| limit * core.k_s * core.slope_diff[j].abs() * [0.2, 0.02][j] / tip[j].abs())
            .iter()
            .sum();
        assert!((volts - 200.0).abs() < 1e-9, "{volts}");
        // The uniform slope differences are the core's for the paper's patch.
        let sd = p
            .and_then(|p| p.get("slope_diff"))
            .and_then(|v| v.as_array())
            .map(|a| a.iter().filter_map(|x| x.as_float()).collect::<Vec<_>>());
        assert_eq!(sd, Some(vec![core.slope_diff.x, core.slope_diff.y]));
        let c = p
            .and_then(|p| p.get("computed"))
            .and_then(|v| v.as_table())
            .and_then(|c| c.get("omega"))
            .and_then(|v| v.as_array())
            .map(|a| a.len());
        assert_eq!(c, Some(2));
    }

    #[test]
    fn core_patch_reproduces_the_modal_damping() {
        let m = DesignModel::default();
        let Ok(pm) = m.patch_modes(0.2, 0.3) else {
            unreachable!("modes")
        };
        let Some(cp) = core_patch(&pm) else {
            unreachable!("two modes")
        };
        // k_c c_s C_a C_aᵀ from the core equals the Q block the optimizer uses.
        let (_, q, _) = m.loop_matrices(&pm, 7.0);
        let ca = cp.c_a();
        let g = 7.0 * cp.c_s();
        for (i, j) in [(0, 0), (0, 1), (1, 1)] {
            let core = g * ca[i] * ca[j];
            assert!((core - q[(2 + i, 2 + j)]).abs() <= 1e-12 * core.abs().max(1e-300));
        }
    }

    #[test]
    fn modal_data_of_a_bare_uniform_beam_is_the_core_closed_form() {
        let m = DesignModel {
            patch_structure: false,
            ..DesignModel::default()
        };
        let Ok(pm) = m.patch_modes(0.1, 0.2) else {
            unreachable!("modes")
        };
        let Some(md) = modal_data(&m, &pm) else {
            unreachable!("two modes")
        };
        let mass = m.layers.bare().rho_a * 0.7;
        let u = ModalData::uniform(mass, 0.7, md.omega, md.zeta);
        assert!((md.mass_integral - u.mass_integral).norm() < 1e-9);
        assert!((md.moment_integral - u.moment_integral).norm() < 1e-9);
        assert!((md.tip - u.tip).norm() < 1e-8);
    }

    #[test]
    fn fragment_reads_back_into_core_types() {
        let m = DesignModel::default();
        let Some(opt) = evaluate(&m, &Weights::default(), 0.12, 0.3, 40.0) else {
            unreachable!("feasible")
        };
        let arm = ArmParams::<f64>::default();
        let text = piezo_fragment(&m, &opt, &arm);
        // Default: the paper's modes, the core's uniform patch.
        let Ok(p) = read_piezo(&text, arm.a2) else {
            unreachable!("valid fragment")
        };
        assert_eq!(p.modes, ModesChoice::Paper);
        assert!(p.modal_data.is_none());
        let u = PiezoPatch::uniform(&m.layers.material, arm.m2, arm.a2, 0.12, 0.3);
        assert_eq!(p.patch, u);
        assert_eq!(p.k_c, 40.0);
        // The controller on the paper's modes runs the converted gain, which differs.
        let kp = p.k_c_paper_modes.unwrap_or(f64::NAN);
        assert!(kp.is_finite() && (kp - 40.0).abs() > 1.0, "{kp}");
        assert_eq!(p.controller_k_c(), kp);
        let bare = text
            .lines()
            .filter(|l| !l.starts_with("k_c_paper_modes"))
            .collect::<Vec<_>>()
            .join("\n");
        assert_eq!(
            read_piezo(&bare, arm.a2).map(|p| p.controller_k_c()),
            Ok(40.0)
        );
        // Switched to the computed modes.
        let text = text.replace("modes = \"paper\"", "modes = \"computed\"");
        let Ok(c) = read_piezo(&text, arm.a2) else {
            unreachable!("valid fragment")
        };
        assert_eq!(Some(c.patch), core_patch(&opt.modes));
        assert_eq!(c.modal_data, modal_data(&m, &opt.modes));
        assert_eq!(c.controller_k_c(), 40.0);
        // Inside a larger scenario file, after other tables.
        let scenario = format!("[arm]\nm2 = 0.3\n\n{text}");
        assert!(read_piezo(&scenario, arm.a2).is_ok());
    }

    #[test]
    fn bad_piezo_tables_are_readable_errors() {
        for (text, needle) in [
            ("[arm]\nm2 = 1.0", "no [piezo]"),
            (
                "[piezo]\nx_a = 0.5\nl_a = 0.3\nk_c = 1.0\nk_a = 1.0\nk_s = 1.0\nslope_diff = [1.0, 2.0]",
                "lie on link 2",
            ),
            (
                "[piezo]\nx_a = 0.1\nl_a = 0.3\nk_c = -1.0\nk_a = 1.0\nk_s = 1.0\nslope_diff = [1.0, 2.0]",
                "piezo.k_c",
            ),
            (
                "[piezo]\nx_a = 0.1\nl_a = 0.3\nk_c = 1.0\nk_a = 1.0\nk_s = 1.0\nslope_diff = [1.0, 2.0]\nmodes = \"computed\"",
                "[piezo.computed]",
            ),
            ("[piezo]\nx_a = 0.1", "missing field"),
            (
                "[piezo]\nx_a = 0.1\nl_a = 0.3\nk_c = 1.0\nk_a = 1.0\nk_s = 2.0\nc_s = 3.0\nslope_diff = [1.0, 2.0]",
                "piezo.c_s",
            ),
            (
                "[piezo]\nx_a = 0.1\nl_a = 0.3\nk_c = 1.0\nk_a = 1.0\nk_s = 1.0\nslope_diff = [1.0]",
                "slope_diff",
            ),
        ] {
            match read_piezo(text, 0.7) {
                Ok(_) => unreachable!("accepted: {text}"),
                Err(e) => assert!(e.to_string().contains(needle), "{text}: {e}"),
            }
        }
    }
}

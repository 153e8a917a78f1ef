//! The identified model: the controller's parameters from the fits and the arm's geometry, as
//! a file the simulator reads, and the closed-loop check against the controller built from the
//! true parameters.
//!
//! ## What comes from where
//! - The rigid combinations `A`, `J`, `S` ([`super::inertia`]): `m2` from `S` and the
//!   geometry's lengths, the inertias' sums from `A` and `J` ([`Rigid::apply`]).
//! - `ω_j`, `ζ_j` of the clamped link ([`super::modal`]): a fit whose base was not an input
//!   found the held arm's, and is refused (gate `clamped modes`).
//! - `|Δφ'_j| = √(g_j / (k_a k_s))` from the piezo→film products, with `k_a` and `k_s` the
//!   geometry's (their data sheets: only the product per mode is measured); the sign the
//!   shapes give.
//! - The mode shapes' integrals `v_j`, `w_j`, `φ_j(a2)`: of the link with the first moment
//!   the inertias leave it, its patched stretch as the geometry describes it and the
//!   geometry's payload as a tip body ([`super::geometry::Geometry::shapes`]): one film
//!   cannot measure shapes, and the
//!   controller's law and observer need them. What the film sees of the base
//!   (`c_j = k_s Δφ'_j w_j`, in the modes report) bears on them; the model does not use it.
//! - The joints' friction ([`super::friction`]) goes to the simulator's plant description;
//!   the paper's controller has no friction term.

use flexarm_core::Vector2;
use flexarm_core::control::piezo::PiezoPatch;
use flexarm_core::params::{ArmParams, ModalData};

use super::IdentifyError;
use super::geometry::Geometry;
use super::inertia::Rigid;
use super::modal::ModesFit;

fn gate(name: &str, msg: String) -> IdentifyError {
    IdentifyError::Data(format!("gate `{name}`: {msg}"))
}

/// A mode shape's integrals with the geometry's tip body: `(v, w, φ(a2))`,
/// `v = ∫ρφ + M φ(a2)`, `w = ∫ρxφ + M a2 φ(a2) + J_t φ'(a2)`.
fn integrals(geometry: &Geometry, s: &flexarm_beam::segmented::Mode) -> (f64, f64, f64) {
    let (l, mt, jt) = (geometry.a2, geometry.tip_mass, geometry.tip_inertia);
    let (tip, tip_s) = (s.phi(l), s.slope(l));
    (
        s.integrate(|_, p| p) + mt * tip,
        s.integrate(|x, p| x * p) + mt * l * tip + jt * tip_s,
        tip,
    )
}

/// The modes `fit` found, as the joints feel them through the shapes of the link that the
/// geometry and the inertia fit's `S` [kg·m²] give ([`super::inertia::fit_inertia_flexible`]).
pub fn coupling(
    geometry: &Geometry,
    fit: &ModesFit,
    s: f64,
) -> Result<Vec<super::inertia::FlexMode>, IdentifyError> {
    let m_link = 2.0 * s / (geometry.a1 * geometry.a2) - 2.0 * geometry.tip_mass;
    let Some(first) = fit.all.first() else {
        return Ok(Vec::new());
    };
    let shapes = geometry.shapes(m_link, first.omega, fit.all.len())?;
    Ok(fit
        .all
        .iter()
        .zip(&shapes)
        .map(|(m, shape)| {
            let (v, w, _) = integrals(geometry, shape);
            super::inertia::FlexMode {
                omega: m.omega,
                zeta: m.zeta,
                v,
                w,
            }
        })
        .collect())
}

/// An identified model: the arm, the patch and what the step assumed or checked, one sentence
/// each.
pub type Identified = (ArmParams<f64>, PiezoPatch<f64>, Vec<String>);

/// The controller's model from the fits on the `geometry` (the rest of the rigid parts from
/// `nominal`, which only their sums reach): the arm, the patch and what the step assumed or
/// checked, one sentence each.
pub fn identified_model(
    geometry: &Geometry,
    nominal: &ArmParams<f64>,
    rigid: &Rigid,
    fit: &ModesFit,
) -> Result<Identified, IdentifyError> {
    if let Some(why) = &fit.held {
        return Err(gate(
            "clamped modes",
            format!(
                "the modes record's base was not an input ({why}): its modes are the held arm's, and its first mode lies several per cent from the clamped link's the controller needs; record the base excited on its own too (noise or taps on joint 2's torque during the patch's excitation)"
            ),
        ));
    }
    let [m1, m2] = fit.modes.as_slice() else {
        return Err(IdentifyError::Data(format!(
            "{} modes kept: the controller needs two",
            fit.modes.len()
        )));
    };
    rigid.check()?;
    for (k, m) in fit.kept.iter().zip([m1, m2]) {
        if !(m.zeta > 0.0 && m.zeta < 1.0) {
            return Err(gate(
                "physical consistency",
                format!(
                    "mode {k}: a damping ratio of {:.4}: it must lie in (0, 1)",
                    m.zeta
                ),
            ));
        }
        if m.piezo_film.is_nan() || m.piezo_film <= 0.0 {
            return Err(gate(
                "physical consistency",
                format!(
                    "mode {k}: a piezo→film product of {:.3e}: it must be positive (the film's sign is wrong: run `flexarm bringup`; or the record had no patch excitation)",
                    m.piezo_film
                ),
            ));
        }
    }
    let mut arm = rigid.apply(&geometry.arm(nominal));
    let m_link = arm.m2 - 2.0 * geometry.tip_mass;
    let top = fit.kept.iter().copied().max().unwrap_or(2);
    let shapes = geometry.shapes(m_link, m1.omega, top)?;
    let (l, mt, jt) = (geometry.a2, geometry.tip_mass, geometry.tip_inertia);
    let shape = |k: usize| &shapes[k - 1];
    let ints = |k: usize| integrals(geometry, shape(k));
    let (k1, k2) = (fit.kept[0], fit.kept[1]);
    let (i1, i2) = (ints(k1), ints(k2));
    arm.modes = ModalData {
        omega: Vector2::new(m1.omega, m2.omega),
        zeta: Vector2::new(m1.zeta, m2.zeta),
        mass_integral: Vector2::new(i1.0, i2.0),
        moment_integral: Vector2::new(i1.1, i2.1),
        tip: Vector2::new(i1.2, i2.2),
    };
    let mut notes = vec![format!(
        "the shapes of a link over {l} m with the first moment of a uniform {m_link:.4} kg, a tip body of {mt} kg and {jt} kg·m² (the geometry's payload), {}",
        if geometry.mass_ratio == 1.0 && geometry.stiffness_ratio == 1.0 {
            "uniform: the patch's own mass and stiffness are not in them (the geometry's `patch.mass_ratio` and `patch.stiffness_ratio` put them in)".to_string()
        } else {
            format!(
                "the patched stretch {} times the bare link's mass per length and {} times its stiffness (the geometry's)",
                geometry.mass_ratio, geometry.stiffness_ratio
            )
        }
    )];
    let mut slope = Vector2::zeros();
    for (j, (k, m)) in fit.kept.iter().zip([m1, m2]).enumerate() {
        let s = shape(*k);
        let predicted = s.slope(geometry.x_a + geometry.l_a) - s.slope(geometry.x_a);
        let measured = (m.piezo_film / (geometry.k_a * geometry.k_s)).sqrt();
        slope[j] = measured.copysign(predicted);
        notes.push(format!(
            "mode {k}: the film measures |Δφ'| = {measured:.4} 1/(m·√kg), the shapes predict {:.4} ({:+.0} %)",
            predicted.abs(),
            (measured / predicted.abs() - 1.0) * 100.0
        ));
    }
    let patch = geometry.patch(slope);
    arm.validate()
        .map_err(|e| gate("physical consistency", format!("the identified arm: {e}")))?;
    patch
        .validate(arm.a2)
        .map_err(|e| gate("physical consistency", format!("the identified patch: {e}")))?;
    Ok((arm, patch, notes))
}

/// The model as scenario tables the simulator reads (`host-sim/scenarios/README.md`): `[arm]`
/// and `[piezo]` with its `[piezo.computed]` modes, the piezo gain `k_c`.
pub fn model_fragment(arm: &ArmParams<f64>, p: &PiezoPatch<f64>, k_c: f64) -> String {
    let tau = std::f64::consts::TAU;
    let md = &arm.modes;
    let v = |x: Vector2<f64>| format!("[{:e}, {:e}]", x.x, x.y);
    format!(
        "# The controller's model identified by `cargo sim identify` (docs/identification.md).\n\
         # Paste these tables into a scenario (host-sim/scenarios/README.md).\n\
         [arm]\n\
         a1 = {:e}   # m (measured)\n\
         a2 = {:e}   # m (measured)\n\
         m1 = {:e}   # kg\n\
         m2 = {:e}   # kg, from S = a1 m2 a2 / 2\n\
         m_h2 = {:e}   # kg\n\
         i_1 = {:e}   # kg m^2\n\
         i_h1 = {:e}   # kg m^2, with i_1 and the masses: A\n\
         i_h2 = {:e}   # kg m^2\n\
         i_2_extra = {:e}   # kg m^2, with i_h2 and m2: J\n\
         frequency_hz = {}\n\
         zeta = {}\n\
         \n\
         [piezo]\n\
         x_a = {:e}   # m\n\
         l_a = {:e}   # m\n\
         k_c = {:e}   # s\n\
         k_a = {:e}   # N m/V (data sheet)\n\
         k_s = {:e}   # V/rad (data sheet)\n\
         modes = \"computed\"\n\
         slope_diff = {}   # 1/(m sqrt(kg)), from the piezo->film products\n\
         \n\
         [piezo.computed]\n\
         omega = {}   # rad/s\n\
         zeta = {}\n\
         slope_diff = {}\n\
         mass_integral = {}   # the geometry's link, patched stretch and payload\n\
         moment_integral = {}\n\
         tip = {}\n",
        arm.a1,
        arm.a2,
        arm.m1,
        arm.m2,
        arm.m_h2,
        arm.i_1,
        arm.i_h1,
        arm.i_h2,
        arm.i_2_extra,
        v(md.omega / tau),
        v(md.zeta),
        p.x_a,
        p.l_a,
        k_c,
        p.k_a,
        p.k_s,
        v(p.slope_diff),
        v(md.omega),
        v(md.zeta),
        v(p.slope_diff),
        v(md.mass_integral),
        v(md.moment_integral),
        v(md.tip),
    )
}

/// One controller's run of the check.
#[derive(Clone, Debug, PartialEq)]
pub struct LoopRun {
    /// Which model the controller was built from.
    pub name: String,
    /// The run's indices.
    pub summary: crate::sim::Summary,
}

/// The paper's trapezoid on `truth` (a configuration [`crate::sim::SimConfig::with_truth`]
/// made: its controller the true parameters' truncation) with the controller built from each
/// of `models` instead, after the true parameters' own run (the first row).
pub fn closed_loop(
    truth: &crate::sim::SimConfig,
    models: &[(&str, ArmParams<f64>, PiezoPatch<f64>)],
) -> Result<Vec<LoopRun>, IdentifyError> {
    use flexarm_core::trajectory::{JointTrajectory, Trapezoid};
    let traj = JointTrajectory::Trapezoid(Trapezoid::paper());
    let mut runs = Vec::new();
    let all =
        std::iter::once(("true parameters", truth.arm, truth.patch)).chain(models.iter().copied());
    for (name, arm, patch) in all {
        let cfg = crate::sim::SimConfig {
            arm,
            patch,
            ..*truth
        };
        let (summary, _) = crate::sim::simulate(&cfg, &traj, false)
            .map_err(|e| IdentifyError::Sim(format!("the closed loop with the {name}: {e}")))?;
        runs.push(LoopRun {
            name: name.into(),
            summary,
        });
    }
    Ok(runs)
}

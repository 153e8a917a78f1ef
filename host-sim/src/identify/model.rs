//! The identified model: the controller's parameters from the fits, as a file the simulator
//! reads, and the closed-loop check against the controller built from the true parameters.
//!
//! ## What comes from where
//! - The rigid combinations `A`, `J`, `S` ([`super::inertia`]): `m2` from `S` and the
//!   measured lengths, the inertias' sums from `A` and `J` ([`Rigid::apply`]).
//! - `ω_j`, `ζ_j` of the clamped link ([`super::modes`]).
//! - `|Δφ'_j| = √(g_j / (k_a k_s))` from the piezo→film products, with `k_a` and `k_s` the
//!   patch's and film's constants (their data sheets; only the product per mode is
//!   measured), the sign the nominal shapes give.
//! - The mode shapes' integrals `v_j`, `w_j`, `φ_j(a2)` of a uniform link of the identified
//!   mass: one sensor cannot measure shapes, and the controller's law and observer need them.
//!   What the film sees of the base (`c_j = k_s Δφ'_j w_j`, in the modes report) bears on them
//!   where the encoders resolve it (mode 1); the model does not use it.
//! - The joints' friction ([`super::friction`]) goes to the simulator's plant description;
//!   the paper's controller has no friction term.

use flexarm_core::Vector2;
use flexarm_core::control::piezo::PiezoPatch;
use flexarm_core::params::{ArmParams, ModalData};

use super::IdentifyError;
use super::inertia::Rigid;
use super::modal::IdentifiedMode;

/// The controller's model from the fits, on the `nominal` arm and patch (lengths, patch
/// place and constants, the shapes' signs).
pub fn identified_model(
    nominal: &ArmParams<f64>,
    patch: &PiezoPatch<f64>,
    rigid: &Rigid,
    modes: &[IdentifiedMode],
) -> Result<(ArmParams<f64>, PiezoPatch<f64>), IdentifyError> {
    let [m1, m2] = modes else {
        return Err(IdentifyError::Data(format!(
            "{} modes identified: the controller needs two",
            modes.len()
        )));
    };
    let mut arm = rigid.apply(nominal);
    let omega = Vector2::new(m1.omega, m2.omega);
    let zeta = Vector2::new(m1.zeta, m2.zeta);
    arm.modes = ModalData::uniform(arm.m2, arm.a2, omega, zeta);
    let mut p = *patch;
    for (j, m) in [m1, m2].iter().enumerate() {
        if m.piezo_film.is_nan() || m.piezo_film <= 0.0 {
            return Err(IdentifyError::Data(format!(
                "mode {}: a piezo→film product of {:.3e}: it must be positive (the film's sign is wrong: run `flexarm bringup`)",
                j + 1,
                m.piezo_film
            )));
        }
        let size = (m.piezo_film / (patch.k_a * patch.k_s)).sqrt();
        p.slope_diff[j] = size.copysign(patch.slope_diff[j]);
    }
    arm.validate()
        .map_err(|e| IdentifyError::Data(format!("the identified arm: {e}")))?;
    p.validate(arm.a2)
        .map_err(|e| IdentifyError::Data(format!("the identified patch: {e}")))?;
    Ok((arm, p))
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
         mass_integral = {}   # uniform link of mass m2\n\
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

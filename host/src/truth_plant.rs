//! The truth plant (issue 14): the arm of [`crate::truth`] with `N` modes on link 2, behind the
//! actuators and transducers of [`crate::actuators`]. Host side, `f64`, SI units, the core's
//! frames. What the controller does not know: the modes past its two, the motors' current
//! loops, friction and rotors, the piezo amplifier's bandwidth, window and current limit, and
//! the film amplifier's high-pass.
//!
//! ## One step of `dt`
//! 1. The amplifier moves the patch voltage toward the command (lag, window, slew
//!    `I_max / C_p`); each motor's current loop moves its torque toward the command.
//! 2. RK4 over `dt` of `B q̈ + C q̇ + D q̇ + K q = u`, with the patch voltage and the motor
//!    torques held and the friction evaluated at every stage (it depends on `θ̇`):
//!    `u = (τ1 − F1(θ̇1), τ2 − F2(θ̇2), k_a Δφ'_1 V_p, …, k_a Δφ'_N V_p)`.
//! 3. The film's open-circuit voltage `V_f = k_s Σ_j Δφ'_j δ_j + β F V_p` (every mode, and the
//!    ceramic's membrane strain with the bond factor `β`: `docs/model.md`, "The film's
//!    feedthrough") through the film amplifier's high-pass.
//!
//! ## The controller's model is the truncation
//! [`controller_model`] gives the two-mode model of the same link: the first two modes of the
//! same beam (exact modes: the first two of an `N`-mode solution are the two-mode solution),
//! and the core's rigid parameters chosen so that the core's `B(q)` equals the truth's on
//! those coordinates. The core writes link 2's rigid part as a uniform rod (`m2 a2/2`,
//! `m2 a2²/3`); the truth's link has mass `m`, first moment `S1` and second moment `S2`, so
//! `m2 = 2 S1/a2`, `m_h2 ← m_h2 + m − m2` (the same `(m_h2 + m2) a1²`) and
//! `I_h2 + I_2x ← I_h2 + I_2x + S2 − m2 a2²/3` (only the sum enters). The rotors are not in the
//! controller's model, nor a tip payload's rotary inertia in the deflection's second moment
//! (the core's `δᵀδ` against the truth's `δᵀ(I − J_t φ'(L)φ'(L)ᵀ)δ`, second order in `δ`).
//!
//! ## Integration
//! RK4 at the simulator's plant step (default 0.1 ms) is adequate to N = 10 on the default
//! link (tested against a step ten times finer); the stiffest mode kept sets the limit
//! `ω_N dt ≲ 1` for its accuracy.

use flexarm_beam::design::DesignModel;
use flexarm_core::control::piezo::{PiezoMaterial, PiezoPatch};
use flexarm_core::params::{ArmParams, ModalData};
use flexarm_core::{Vector2, Vector4};

use crate::actuators::{FilmAmplifier, Motor, PiezoAmplifier};
use crate::plant::{Diverged, Plant, StableStep, State, stable_step_over_poses};
use crate::truth::{Coords, LinkBody, TruthArm, TruthError};
use nalgebra::DMatrix;

/// Most modes of link 2 the truth plant keeps.
pub const MAX_MODES: usize = 10;

/// Where link 2's body and modes come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LinkSource {
    /// The segmented beam of `flexarm_beam` (the design section with the patch's mass and
    /// stiffness in its segment, an optional tip body), `modes` exact modes.
    Beam,
    /// The scenario's own `[arm]`: the controller's two modes on a uniform link (`modes = 2`).
    /// With ideal actuators this is the controller's model itself.
    Arm,
}

/// One joint's drive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorSpec {
    /// Current-loop time constant `τ_i` [s]; 0 = ideal torque source.
    pub current_tau: f64,
    /// Gear ratio `n` (motor turns per joint turn) [-].
    pub gear_ratio: f64,
    /// Rotor inertia `J_r` at the motor [kg·m²]; the joint sees `n² J_r`.
    pub rotor_inertia: f64,
    /// Viscous friction at the joint [N·m·s/rad].
    pub viscous: f64,
    /// Coulomb friction at the joint [N·m].
    pub coulomb: f64,
    /// Speed over which the Coulomb term changes sign (`F_c tanh(θ̇/v_s)`) [rad/s].
    pub coulomb_speed: f64,
}

impl MotorSpec {
    /// An ideal torque source.
    pub const IDEAL: Self = Self {
        current_tau: 0.0,
        gear_ratio: 1.0,
        rotor_inertia: 0.0,
        viscous: 0.0,
        coulomb: 0.0,
        coulomb_speed: 0.01,
    };

    /// A servo drive of this arm's size (docs/results.md, "On the truth plant"): a 0.5 ms
    /// current loop, 0.02 N·m·s/rad viscous and 0.05 N·m Coulomb friction at
    /// the joint (0.5 % of the 10 N·m limit), smoothed over 0.01 rad/s. The rotors are in the
    /// paper's hub inertias, so none is added.
    pub const DRIVE: Self = Self {
        current_tau: 5e-4,
        gear_ratio: 1.0,
        rotor_inertia: 0.0,
        viscous: 0.02,
        coulomb: 0.05,
        coulomb_speed: 0.01,
    };
}

/// The truth plant's configuration (a `[plant]` table of a scenario).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TruthSpec {
    /// Modes of link 2, 1 to [`MAX_MODES`].
    pub modes: usize,
    /// Where they come from.
    pub link: LinkSource,
    /// Thickness of the beam `t_b` [m] ([`LinkSource::Beam`]).
    pub thickness: f64,
    /// Tip payload mass [kg] ([`LinkSource::Beam`]).
    pub tip_mass: f64,
    /// Tip payload rotary inertia [kg·m²].
    pub tip_inertia: f64,
    /// Structural damping ratio of each mode [-].
    pub zeta: [f64; MAX_MODES],
    /// Factor on each natural frequency (1 = the beam's; the Monte Carlo perturbs it).
    pub omega_scale: [f64; MAX_MODES],
    /// The joints' drives.
    pub motors: [MotorSpec; 2],
    /// Piezo amplifier bandwidth [Hz] (infinite = ideal).
    pub amplifier_hz: f64,
    /// Piezo amplifier output window `[v_min, v_max]` [V].
    pub amplifier_window: [f64; 2],
    /// Piezo amplifier current limit [A] (infinite = ideal).
    pub amplifier_current: f64,
    /// Capacitance of the patch [F].
    pub capacitance: f64,
    /// High-pass corner of the film amplifier [Hz] (0 = DC-coupled).
    pub film_corner_hz: f64,
    /// Bond factor `β` of the film's feedthrough `β F V_p` [-], 0 to 1: the fraction of the
    /// perfect bond's membrane strain ([`PiezoMaterial::film_feedthrough`]) that reaches the film
    /// through the adhesive's shear lag. Default 0 ([`TruthSpec::default`] says why).
    pub film_bond: f64,
}

/// Damping ratios: the paper's 0.07 and 0.03 for the first two modes, 0.02 above.
const ZETA: [f64; MAX_MODES] = [0.07, 0.03, 0.02, 0.02, 0.02, 0.02, 0.02, 0.02, 0.02, 0.02];

impl TruthSpec {
    /// The controller's own model as a truth plant: the scenario's arm, two modes, ideal
    /// actuators and film.
    pub fn model() -> Self {
        Self {
            modes: 2,
            link: LinkSource::Arm,
            ..Self::default()
        }
        .ideal_actuators()
    }

    /// The same plant with ideal actuators and film (its mechanics only: no feedthrough).
    pub fn ideal_actuators(self) -> Self {
        Self {
            amplifier_hz: f64::INFINITY,
            amplifier_current: f64::INFINITY,
            film_corner_hz: 0.0,
            film_bond: 0.0,
            motors: [MotorSpec::IDEAL; 2],
            ..self
        }
    }

    /// Checks every value; the error names the scenario key (`plant.…`).
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        let bad = |key, msg: String| Err((key, msg));
        if !(1..=MAX_MODES).contains(&self.modes) {
            return bad(
                "plant.modes",
                format!("{} must be 1 to {MAX_MODES}", self.modes),
            );
        }
        if self.link == LinkSource::Arm && self.modes != 2 {
            return bad(
                "plant.modes",
                format!(
                    "{}: the scenario's `[arm]` link has the controller's 2 modes",
                    self.modes
                ),
            );
        }
        let range = |key, v: f64, lo: f64, hi: f64, unit: &str| {
            if v.is_finite() && v >= lo && v <= hi {
                Ok(())
            } else {
                bad(key, flexarm_beam::toml_at::outside_range(v, lo, hi, unit))
            }
        };
        range("plant.thickness", self.thickness, 1e-4, 2e-2, "m")?;
        range("plant.tip_mass", self.tip_mass, 0.0, 100.0, "kg")?;
        range("plant.tip_inertia", self.tip_inertia, 0.0, 10.0, "kg m^2")?;
        for z in &self.zeta[..self.modes] {
            range("plant.zeta", *z, 0.0, 1.0, "")?;
        }
        for s in &self.omega_scale[..self.modes] {
            range("plant.omega_scale", *s, 0.1, 10.0, "")?;
        }
        for m in &self.motors {
            range("plant.current_tau", m.current_tau, 0.0, 1.0, "s")?;
            range("plant.gear_ratio", m.gear_ratio, 1e-3, 1e4, "")?;
            range("plant.rotor_inertia", m.rotor_inertia, 0.0, 1.0, "kg m^2")?;
            range("plant.viscous", m.viscous, 0.0, 1e3, "N m s/rad")?;
            range("plant.coulomb", m.coulomb, 0.0, 1e3, "N m")?;
            range("plant.coulomb_speed", m.coulomb_speed, 1e-6, 10.0, "rad/s")?;
        }
        if self.amplifier_hz.is_nan() || self.amplifier_hz <= 0.0 {
            return bad(
                "plant.amplifier_hz",
                format!("{} Hz must be > 0 (inf: ideal)", self.amplifier_hz),
            );
        }
        if self.amplifier_current.is_nan() || self.amplifier_current <= 0.0 {
            return bad(
                "plant.amplifier_current",
                format!("{} A must be > 0 (inf: ideal)", self.amplifier_current),
            );
        }
        let [lo, hi] = self.amplifier_window;
        if !(lo.is_finite() && hi.is_finite() && lo <= 0.0 && hi > 0.0 && hi - lo <= 2e4) {
            return bad(
                "plant.amplifier_window",
                format!("[{lo}, {hi}] V must hold 0 inside a finite window of at most 20 kV"),
            );
        }
        range("plant.capacitance", self.capacitance, 1e-12, 1e-3, "F")?;
        range("plant.film_corner_hz", self.film_corner_hz, 0.0, 1e3, "Hz")?;
        range("plant.film_bond", self.film_bond, 0.0, 1.0, "")?;
        Ok(())
    }

    /// Link 2 with its patch: the body and the patch's coupling (`slope_diff` has every mode).
    /// `arm` gives the link's length `a2` (and, for [`LinkSource::Arm`], the link itself);
    /// `patch` the patch's place (and, for [`LinkSource::Arm`], its coupling).
    pub fn link(
        &self,
        arm: &ArmParams<f64>,
        patch: &PiezoPatch<f64>,
    ) -> Result<(LinkBody, Coupling), TruthError> {
        self.validate()
            .map_err(|(key, msg)| TruthError(format!("`{key}`: {msg}")))?;
        let (mut body, slope_diff, k_a, k_s, feedthrough) = match self.link {
            LinkSource::Arm => (
                LinkBody::from_params(arm),
                vec![patch.slope_diff.x, patch.slope_diff.y],
                patch.k_a,
                patch.k_s,
                PiezoMaterial::<f64>::default().film_feedthrough(),
            ),
            LinkSource::Beam => {
                let mut model = DesignModel {
                    length: arm.a2,
                    tip_mass: self.tip_mass,
                    tip_inertia: self.tip_inertia,
                    zeta: self.zeta[..self.modes].to_vec(),
                    lambda: vec![1.0; self.modes],
                    ..DesignModel::default()
                };
                model.layers.material.t_b = self.thickness;
                let pm = model
                    .patch_modes(patch.x_a, patch.l_a)
                    .map_err(|e| TruthError(format!("the truth link: {e}")))?;
                (
                    LinkBody::from_design(&model, &pm)?,
                    pm.slope_diff.clone(),
                    pm.k_a,
                    pm.k_s,
                    model.layers.material.film_feedthrough(),
                )
            }
        };
        for (w, s) in body.omega.iter_mut().zip(&self.omega_scale) {
            *w *= s;
        }
        Ok((
            body,
            Coupling {
                slope_diff,
                k_a,
                k_s,
                feedthrough: self.film_bond * feedthrough,
            },
        ))
    }
}

/// The patch's coupling to every mode of the link (Eqs. 18–19).
#[derive(Clone, Debug, PartialEq)]
pub struct Coupling {
    /// `Δφ'_j` [1/(m·√kg)].
    pub slope_diff: Vec<f64>,
    /// Actuator moment per volt `k_a` [N·m/V].
    pub k_a: f64,
    /// Film volts per radian `k_s` [V/rad].
    pub k_s: f64,
    /// The film's direct response to the patch voltage, `β F` [V/V] (negative: opposite to the
    /// bending path's static gain).
    pub feedthrough: f64,
}

impl Default for TruthSpec {
    /// Six modes of the design beam at the thickness of docs/results.md, the paper's patch,
    /// servo drives ([`MotorSpec::DRIVE`]), a 5 kHz ±200 V amplifier with 0.1 A into the
    /// patch's 170 nF, a film amplifier with a 0.5 Hz high-pass, and no film feedthrough
    /// (`film_bond = 0`): the truth plant's published runs (the paper's study, the Monte Carlo,
    /// identification) were measured without it and the identification's rational fit has no
    /// direct term yet. A scenario's `plant.film_bond = 1` is the perfect bond that `k_a` and
    /// `k_s` assume; the spillover study runs 0, 0.5 and 1 (`--bond`).
    fn default() -> Self {
        Self {
            modes: 6,
            link: LinkSource::Beam,
            thickness: DEFAULT_THICKNESS,
            tip_mass: 0.0,
            tip_inertia: 0.0,
            zeta: ZETA,
            omega_scale: [1.0; MAX_MODES],
            motors: [MotorSpec::DRIVE; 2],
            amplifier_hz: 5e3,
            amplifier_window: [-200.0, 200.0],
            amplifier_current: 0.1,
            capacitance: 170e-9,
            film_corner_hz: 0.5,
            film_bond: 0.0,
        }
    }
}

/// The default beam thickness [m] (docs/results.md: the consistent arm).
pub const DEFAULT_THICKNESS: f64 = 2.5e-3;

/// The two-mode model the controller runs for this truth plant (module docs): the core's
/// arm and patch, from the rigid parts `arm` and the patch's place `patch`. For
/// [`LinkSource::Arm`], `arm` and `patch` themselves.
pub fn controller_model(
    spec: &TruthSpec,
    arm: &ArmParams<f64>,
    patch: &PiezoPatch<f64>,
) -> Result<(ArmParams<f64>, PiezoPatch<f64>), TruthError> {
    if spec.link == LinkSource::Arm {
        return Ok((*arm, *patch));
    }
    // The first two modes of the exact solution, at their nominal frequencies.
    let two = TruthSpec {
        modes: 2,
        omega_scale: [1.0; MAX_MODES],
        ..*spec
    };
    let (body, coupling) = two.link(arm, patch)?;
    let m2 = 2.0 * body.first_moment / arm.a2;
    let mut c = *arm;
    c.m2 = m2;
    c.m_h2 = arm.m_h2 + body.mass - m2;
    // Only I_h2 + I_2x enters the core's model: the correction goes to I_2x, and to I_h2 for
    // the part that would make I_2x negative.
    let j = arm.i_h2 + arm.i_2_extra + body.second_moment - m2 * arm.a2 * arm.a2 / 3.0;
    c.i_2_extra = (arm.i_2_extra + body.second_moment - m2 * arm.a2 * arm.a2 / 3.0).max(0.0);
    c.i_h2 = j - c.i_2_extra;
    let v2 = |v: &[f64]| Vector2::new(v[0], v[1]);
    c.modes = ModalData {
        omega: v2(&body.omega),
        zeta: v2(&body.zeta),
        mass_integral: v2(&body.v),
        moment_integral: v2(&body.w),
        tip: v2(&body.tip),
    };
    let p = PiezoPatch {
        x_a: patch.x_a,
        l_a: patch.l_a,
        slope_diff: v2(&coupling.slope_diff),
        k_a: coupling.k_a,
        k_s: coupling.k_s,
    };
    c.validate()
        .map_err(|e| TruthError(format!("the controller's model of the truth link: {e}")))?;
    Ok((c, p))
}

/// The truth arm with `D − 2` modes behind its actuators.
#[derive(Clone, Debug)]
pub struct TruthPlant<const D: usize> {
    arm: TruthArm<D>,
    /// `φ_j(L)`, `k_a Δφ'_j`, `k_s Δφ'_j` in the modal entries.
    tip: Coords<D>,
    input: Coords<D>,
    film_map: Coords<D>,
    /// `β F` [V/V].
    feedthrough: f64,
    motors: [Motor; 2],
    amplifier: PiezoAmplifier,
    film: FilmAmplifier,
    /// The joints' reach `(a1, a2)` [m]: where a strike at the tip acts.
    reach: (f64, f64),
    q: Coords<D>,
    qd: Coords<D>,
}

impl<const D: usize> TruthPlant<D> {
    /// The plant of `spec` (whose `modes` must be `D − 2`) at rest at the joint angles
    /// `theta` [rad]; the arguments as for [`build`].
    pub fn new(
        spec: &TruthSpec,
        arm: &ArmParams<f64>,
        patch: &PiezoPatch<f64>,
        tau_max: Vector2<f64>,
        theta: Vector2<f64>,
    ) -> Result<Self, TruthError> {
        let (body, coupling) = spec.link(arm, patch)?;
        let input: Vec<f64> = coupling
            .slope_diff
            .iter()
            .map(|d| coupling.k_a * d)
            .collect();
        let film: Vec<f64> = coupling
            .slope_diff
            .iter()
            .map(|d| coupling.k_s * d)
            .collect();
        let m = &spec.motors;
        let truth = TruthArm::<D>::new(arm, &body)?.with_rotors(
            [m[0].gear_ratio, m[1].gear_ratio],
            [m[0].rotor_inertia, m[1].rotor_inertia],
        );
        let modal = |v: &[f64]| {
            let mut c = Coords::<D>::zeros();
            for (j, x) in v.iter().enumerate() {
                c[2 + j] = *x;
            }
            c
        };
        let motor = |s: &MotorSpec, limit: f64| {
            Motor::new(s.current_tau, limit, s.viscous, s.coulomb, s.coulomb_speed)
        };
        let mut q = Coords::<D>::zeros();
        q[0] = theta.x;
        q[1] = theta.y;
        Ok(Self {
            arm: truth,
            tip: modal(&body.tip),
            input: modal(&input),
            film_map: modal(&film),
            feedthrough: coupling.feedthrough,
            motors: [motor(&m[0], tau_max.x), motor(&m[1], tau_max.y)],
            amplifier: PiezoAmplifier::new(
                spec.amplifier_hz,
                (spec.amplifier_window[0], spec.amplifier_window[1]),
                spec.amplifier_current,
                spec.capacitance,
            ),
            film: FilmAmplifier::new(spec.film_corner_hz, 0.0),
            reach: (arm.a1, arm.a2),
            q,
            qd: Coords::<D>::zeros(),
        })
    }

    /// All coordinates `(θ1, θ2, δ1 … δN)` and their rates.
    pub fn coordinates(&self) -> (Coords<D>, Coords<D>) {
        (self.q, self.qd)
    }

    /// The mechanics.
    pub fn arm(&self) -> &TruthArm<D> {
        &self.arm
    }

    /// Friction torques at the joint speeds `qd` [N·m].
    pub fn friction(&self, qd: &Coords<D>) -> Vector2<f64> {
        Vector2::new(
            self.motors[0].friction(qd[0]),
            self.motors[1].friction(qd[1]),
        )
    }
}

impl<const D: usize> Plant for TruthPlant<D> {
    fn state(&self) -> State<f64> {
        let four = |c: &Coords<D>| Vector4::new(c[0], c[1], c[2], if D > 3 { c[3] } else { 0.0 });
        State {
            q: four(&self.q),
            qd: four(&self.qd),
        }
    }

    fn tip(&self) -> f64 {
        self.tip.dot(&self.q)
    }

    fn film(&self) -> f64 {
        self.film.output()
    }

    fn step(&mut self, tau: &Vector2<f64>, v_a: f64, dt: f64) -> Result<(), Diverged> {
        let v_p = self.amplifier.step(v_a, dt);
        let t1 = self.motors[0].step(tau.x, dt);
        let t2 = self.motors[1].step(tau.y, dt);
        let piezo = self.input * v_p;
        let (m1, m2) = (self.motors[0], self.motors[1]);
        let u = |qd: &Coords<D>| {
            let mut u = piezo;
            u[0] = t1 - m1.friction(qd[0]);
            u[1] = t2 - m2.friction(qd[1]);
            u
        };
        let (q, qd) = self
            .arm
            .rk4_with(&self.q, &self.qd, dt, u)
            .ok_or(Diverged)?;
        self.q = q;
        self.qd = qd;
        self.film
            .step(self.film_map.dot(&q) + self.feedthrough * v_p, dt);
        Ok(())
    }

    fn stable_step(&self) -> StableStep {
        let (k, mut c) = self.arm.stiffness_damping();
        // The viscous friction damps the joints. The Coulomb term `F_c tanh(v / v_s)` is as
        // stiff as `F_c / v_s` at rest but saturates: a step past that slope's limit chatters
        // within about `v_s` of rest instead of diverging, so it sets no limit here.
        for (j, m) in self.motors.iter().enumerate() {
            c[j] += m.viscous;
        }
        stable_step_over_poses(
            |t2| {
                let mut q = Coords::<D>::zeros();
                q[1] = t2;
                let b = self.arm.inertia(&q);
                DMatrix::from_iterator(D, D, b.iter().copied())
            },
            c.as_slice(),
            k.as_slice(),
        )
    }

    fn strike(&mut self, p: f64) -> bool {
        let (a1, a2) = self.reach;
        let mut impulse = self.tip * p;
        impulse[0] = p * (a1 * self.q[1].cos() + a2);
        impulse[1] = p * a2;
        match self.arm.inertia(&self.q).cholesky() {
            Some(b) => {
                self.qd += b.solve(&impulse);
                true
            }
            None => false,
        }
    }
}

/// The truth plant of `spec` at rest at the joint angles `theta` [rad]: the rigid parts of
/// `arm`, the patch's place (and, for [`LinkSource::Arm`], its coupling) from `patch`, the
/// motors limited to `tau_max` [N·m].
pub fn build(
    spec: &TruthSpec,
    arm: &ArmParams<f64>,
    patch: &PiezoPatch<f64>,
    tau_max: Vector2<f64>,
    theta: Vector2<f64>,
) -> Result<Box<dyn Plant + Send>, TruthError> {
    macro_rules! sized {
        ($($n:literal => $d:literal),*) => {
            match spec.modes {
                $($n => Ok(Box::new(TruthPlant::<$d>::new(spec, arm, patch, tau_max, theta)?)),)*
                n => Err(TruthError(format!("`plant.modes`: {n} must be 1 to {MAX_MODES}"))),
            }
        };
    }
    sized!(1 => 3, 2 => 4, 3 => 5, 4 => 6, 5 => 7, 6 => 8, 7 => 9, 8 => 10, 9 => 11, 10 => 12)
}

//! Parameters of the arm, the piezo patch, the gains and the limits, with the paper's values as
//! defaults (SI units, field by field) and a validation that returns a typed error.
//!
//! Where the paper's parameter list is inconsistent (see `docs/model.md`), the default says
//! which reading it takes.

use crate::modes::UniformMode;
use crate::real::Real;
use crate::{Vector2, Vector4};

/// Why a parameter set was refused. The `&'static str` names the field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamError {
    /// The field must be finite.
    NotFinite(&'static str),
    /// The field must be strictly positive.
    NotPositive(&'static str),
    /// The field must be zero or positive.
    Negative(&'static str),
    /// The modal frequencies must be strictly increasing: `ω1 < ω2`.
    FrequenciesNotIncreasing,
    /// The piezo patch must lie on link 2: `0 ≤ x_a`, `0 < l_a`, `x_a + l_a ≤ a2`.
    PatchOutsideLink,
}

impl core::fmt::Display for ParamError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NotFinite(n) => write!(f, "parameter `{n}` is not a finite number"),
            Self::NotPositive(n) => write!(f, "parameter `{n}` must be strictly positive"),
            Self::Negative(n) => write!(f, "parameter `{n}` must not be negative"),
            Self::FrequenciesNotIncreasing => {
                write!(f, "modal frequencies must increase: omega[0] < omega[1]")
            }
            Self::PatchOutsideLink => {
                write!(
                    f,
                    "piezo patch must lie on link 2: 0 <= x_a, 0 < l_a, x_a + l_a <= a2"
                )
            }
        }
    }
}

fn positive<T: Real>(name: &'static str, x: T) -> Result<(), ParamError> {
    if !x.finite() {
        Err(ParamError::NotFinite(name))
    } else if x <= T::zero() {
        Err(ParamError::NotPositive(name))
    } else {
        Ok(())
    }
}

fn non_negative<T: Real>(name: &'static str, x: T) -> Result<(), ParamError> {
    if !x.finite() {
        Err(ParamError::NotFinite(name))
    } else if x < T::zero() {
        Err(ParamError::Negative(name))
    } else {
        Ok(())
    }
}

fn finite<T: Real>(name: &'static str, x: T) -> Result<(), ParamError> {
    if x.finite() {
        Ok(())
    } else {
        Err(ParamError::NotFinite(name))
    }
}

/// Modal data of link 2 (two assumed modes, unit modal mass: `∫ρ φ_j φ_k dx = δ_jk`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModalData<T> {
    /// Natural angular frequencies `ω_j` [rad/s] of link 2 clamped at joint 2.
    pub omega: Vector2<T>,
    /// Modal damping ratios `ζ_j` [-].
    pub zeta: Vector2<T>,
    /// `v_j = ∫₀^a2 ρ φ_j dx` [√kg·m]: couples link 1's motion to the modes.
    pub mass_integral: Vector2<T>,
    /// `w_j = ∫₀^a2 ρ x φ_j dx` [√kg·m²]: couples the absolute rotation of link 2 to the modes.
    pub moment_integral: Vector2<T>,
    /// Tip values `φ_j(a2)` [1/√kg] (tip deflection `w(a2) = Σ φ_j(a2) δ_j` in metres).
    pub tip: Vector2<T>,
}

impl<T: Real> ModalData<T> {
    /// Clamped-free modes of a uniform link of mass `m2` [kg] and length `a2` [m], with the
    /// given frequencies [rad/s] and damping ratios (the shapes, not the frequencies, come from
    /// the uniform beam: the paper's frequencies are kept, see `docs/model.md`).
    pub fn uniform(m2: T, a2: T, omega: Vector2<T>, zeta: Vector2<T>) -> Self {
        let m = [UniformMode::new(0, m2, a2), UniformMode::new(1, m2, a2)];
        let v = |f: &dyn Fn(&UniformMode<T>) -> T| Vector2::new(f(&m[0]), f(&m[1]));
        Self {
            omega,
            zeta,
            mass_integral: v(&|m| m.mass_integral()),
            moment_integral: v(&|m| m.moment_integral()),
            tip: v(&|m| m.phi(a2)),
        }
    }
}

/// Physical parameters of the arm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArmParams<T> {
    /// Length of link 1 (rigid), joint 1 to joint 2 [m].
    pub a1: T,
    /// Length of link 2 (flexible), joint 2 to tip [m].
    pub a2: T,
    /// Mass of link 1 [kg].
    pub m1: T,
    /// Mass of link 2, spread uniformly over `a2` [kg].
    pub m2: T,
    /// Mass of motor 2, a point mass at the tip of link 1 [kg]. (Motor 1 sits on the fixed
    /// base, so its mass `m_h1` does not enter the model.)
    pub m_h2: T,
    /// Moment of inertia of link 1 about its centre of mass at `a1/2` [kg·m²].
    pub i_1: T,
    /// Rotor inertia of motor 1, turning with θ1 [kg·m²].
    pub i_h1: T,
    /// Rotor inertia of motor 2, turning with θ1 + θ2 [kg·m²].
    pub i_h2: T,
    /// Extra rotary inertia of link 2 about joint 2 beyond its distributed mass
    /// (`m2 a2²/3`) [kg·m²]. Default 0.
    pub i_2_extra: T,
    /// Modes of link 2.
    pub modes: ModalData<T>,
}

impl<T: Real> Default for ArmParams<T> {
    /// The paper's arm (Results section): `a1 = 0.3`, `a2 = 0.7`, `m1 = 0.2`, `m2 = 0.3`,
    /// `m_h2 = 1.0`, `I_1 = 0.170`, `I_h1 = 0.230`, `I_h2 = 0.198`, `ω = 2π·(4.716, 14.395)`,
    /// `ζ = (0.07, 0.03)`; mode shapes of a uniform clamped-free link.
    fn default() -> Self {
        let two_pi = T::c(core::f64::consts::TAU);
        let m2 = T::c(0.3);
        let a2 = T::c(0.7);
        Self {
            a1: T::c(0.3),
            a2,
            m1: T::c(0.2),
            m2,
            m_h2: T::c(1.0),
            i_1: T::c(0.170),
            i_h1: T::c(0.230),
            i_h2: T::c(0.198),
            i_2_extra: T::zero(),
            modes: ModalData::uniform(
                m2,
                a2,
                Vector2::new(two_pi * T::c(4.716), two_pi * T::c(14.395)),
                Vector2::new(T::c(0.07), T::c(0.03)),
            ),
        }
    }
}

impl<T: Real> ArmParams<T> {
    /// Checks that every value is physical.
    pub fn validate(&self) -> Result<(), ParamError> {
        positive("a1", self.a1)?;
        positive("a2", self.a2)?;
        non_negative("m1", self.m1)?;
        positive("m2", self.m2)?;
        non_negative("m_h2", self.m_h2)?;
        non_negative("i_1", self.i_1)?;
        non_negative("i_h1", self.i_h1)?;
        non_negative("i_h2", self.i_h2)?;
        non_negative("i_2_extra", self.i_2_extra)?;
        let md = &self.modes;
        positive("omega[0]", md.omega.x)?;
        positive("omega[1]", md.omega.y)?;
        if md.omega.x >= md.omega.y {
            return Err(ParamError::FrequenciesNotIncreasing);
        }
        non_negative("zeta[0]", md.zeta.x)?;
        non_negative("zeta[1]", md.zeta.y)?;
        for (name, v) in [
            ("mass_integral", md.mass_integral),
            ("moment_integral", md.moment_integral),
            ("tip", md.tip),
        ] {
            finite(name, v.x)?;
            finite(name, v.y)?;
        }
        Ok(())
    }

    /// The same parameters in another precision.
    pub fn cast<U: Real>(&self) -> ArmParams<U> {
        let c = |x: T| U::c(x.to_f64());
        let v = |x: Vector2<T>| Vector2::new(c(x.x), c(x.y));
        ArmParams {
            a1: c(self.a1),
            a2: c(self.a2),
            m1: c(self.m1),
            m2: c(self.m2),
            m_h2: c(self.m_h2),
            i_1: c(self.i_1),
            i_h1: c(self.i_h1),
            i_h2: c(self.i_h2),
            i_2_extra: c(self.i_2_extra),
            modes: ModalData {
                omega: v(self.modes.omega),
                zeta: v(self.modes.zeta),
                mass_integral: v(self.modes.mass_integral),
                moment_integral: v(self.modes.moment_integral),
                tip: v(self.modes.tip),
            },
        }
    }
}

/// Gains of the motor laws (Eqs. 7, 11, 16). Diagonal matrices are stored as their diagonals.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gains<T> {
    /// `Λ` [1/s], diagonal over `q`: `q̇_r = q̇_d − Λ q̃`.
    pub lambda: Vector4<T>,
    /// `K_p`, diagonal over `q` [N·m·s/rad on the joints]. Only the joint rows reach the
    /// motors; the modal rows are kept for completeness and have no effect (`docs/model.md`).
    pub kp: Vector4<T>,
    /// `D_Δ` [1/s] (modal damping per unit modal mass) of the robust term (Eq. 11).
    pub d_delta: Vector2<T>,
    /// `ε` of the robust term's boundary layer `ε e^{−φ t}` [(√kg·m/s)²].
    pub epsilon: Vector2<T>,
    /// `φ` of the boundary layer [1/s].
    pub phi: Vector2<T>,
    /// Floor of the boundary layer, so it never collapses to a discontinuous switch
    /// [(√kg·m/s)²].
    pub epsilon_floor: T,
    /// Relative regularization `μ` of the damped least-squares map from the requested modal
    /// acceleration to joint torques [-].
    pub mu: T,
    /// Integral rate `K_i` per joint [1/s] (`crate::control::integral`: the reference shifted
    /// by `K_i ∫ θ̃ dt`); 0: no integral action (Eq. 7 / Eq. 16 as printed).
    pub ki: Vector2<T>,
    /// The most the integral may shift each joint's reference, `|K_i z|` [rad].
    pub integral_limit: Vector2<T>,
}

impl<T: Real> Default for Gains<T> {
    /// `Λ = I`, `K_p = diag(90, 14, 0, 0)` (the paper's printed values moved to the joint rows,
    /// see `docs/model.md`), `D_Δ = (20, 20)`, `ε = 0.1`, `φ = 0.01`, `μ = 0.1`; no integral
    /// action (`K_i = 0`, as the paper; its limit 0.02 rad for a `K_i` set later).
    fn default() -> Self {
        let one = T::one();
        Self {
            lambda: Vector4::new(one, one, one, one),
            kp: Vector4::new(T::c(90.0), T::c(14.0), T::zero(), T::zero()),
            d_delta: Vector2::new(T::c(20.0), T::c(20.0)),
            epsilon: Vector2::new(T::c(0.1), T::c(0.1)),
            phi: Vector2::new(T::c(0.01), T::c(0.01)),
            epsilon_floor: T::c(1e-4),
            mu: T::c(0.1),
            ki: Vector2::zeros(),
            integral_limit: Vector2::new(T::c(0.02), T::c(0.02)),
        }
    }
}

/// The integral rate `K_i` [1/s] the boards run on both joints (`crate::control::integral`,
/// `flexarm_machine::BoardConfig::for_board`; docs/results.md gives the evidence). The paper's
/// gains ([`Gains::default`]) have none.
pub const DEFAULT_KI: f64 = 5.0;

/// The fastest rate of the joints' velocity loop under the paper's `K_p`: the largest
/// eigenvalue of `M_θθ(θ2)⁻¹ K_p` over every `θ2`, for the paper's arm [1/s] (220.4 at
/// `θ2 = 0`; test `the_velocity_loop_rate_is_the_models`).
pub const PAPER_VELOCITY_LOOP_RATE: f64 = 220.5;

/// The factor [`Gains::default_for`] scales the paper's joint `K_p` by at a motor loop of
/// `motor_hz`: `min(1, motor_hz / PAPER_VELOCITY_LOOP_RATE)` (0.4535 at 100 Hz, 1 from
/// 220.5 Hz up).
pub fn gain_scale(motor_hz: u32) -> f64 {
    (f64::from(motor_hz.max(1)) / PAPER_VELOCITY_LOOP_RATE).min(1.0)
}

impl<T: Real> Gains<T> {
    /// The paper's gains for a motor loop of `motor_hz`: its joint `K_p` scaled down, when the
    /// loop is slow, until the velocity loop's fastest rate times the period is at most 1
    /// ([`PAPER_VELOCITY_LOOP_RATE`], [`gain_scale`]). The sampled loop `ṽ ← (1 − λT) ṽ`
    /// diverges for `λT > 2`: at 100 Hz the paper's gains give `λT = 2.2`, and the QEMU
    /// board's hold settled into a limit cycle, its joint-1 torque flipping by about ±4 N·m
    /// every period. At 1 kHz (`λT = 0.22`) and above the gains are the paper's.
    pub fn default_for(motor_hz: u32) -> Self {
        let scale = gain_scale(motor_hz);
        let mut g = Self::default();
        g.kp.x *= T::c(scale);
        g.kp.y *= T::c(scale);
        g
    }

    /// Checks signs: `Λ > 0`, `K_p ≥ 0` (zero joint rows are allowed to reproduce the paper's
    /// printed gains, but leave the joints without proportional feedback), `D_Δ ≥ 0`, `ε > 0`, `φ ≥ 0`.
    pub fn validate(&self) -> Result<(), ParamError> {
        for i in 0..4 {
            positive("lambda", self.lambda.get(i).copied().unwrap_or(T::zero()))?;
            non_negative("kp", self.kp.get(i).copied().unwrap_or(T::zero()))?;
        }
        for i in 0..2 {
            let g = |v: &Vector2<T>| v.get(i).copied().unwrap_or(T::zero());
            non_negative("d_delta", g(&self.d_delta))?;
            positive("epsilon", g(&self.epsilon))?;
            non_negative("phi", g(&self.phi))?;
        }
        positive("epsilon_floor", self.epsilon_floor)?;
        for i in 0..2 {
            let g = |v: &Vector2<T>| v.get(i).copied().unwrap_or(T::zero());
            non_negative("ki", g(&self.ki))?;
            non_negative("integral_limit", g(&self.integral_limit))?;
        }
        positive("mu", self.mu)
    }
}

/// Actuator limits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits<T> {
    /// Largest motor torque per joint [N·m].
    pub tau_max: Vector2<T>,
    /// Largest piezo amplifier output [V]: the top of the window.
    pub v_a_max: T,
    /// Smallest (most negative) piezo amplifier output [V]: the bottom of the window. A
    /// piezoceramic is rated for less reverse than forward voltage (it depolarizes), so the
    /// window may be asymmetric; `−v_a_max` is the symmetric one.
    pub v_a_min: T,
}

impl<T: Real> Default for Limits<T> {
    /// ±10 N·m per joint (several times the peak of the paper's moves, `docs/model.md`),
    /// ±200 V on the piezo amplifier (the symmetric window; a patch's datasheet gives its own).
    fn default() -> Self {
        Self {
            tau_max: Vector2::new(T::c(10.0), T::c(10.0)),
            v_a_max: T::c(200.0),
            v_a_min: T::c(-200.0),
        }
    }
}

impl<T: Real> Limits<T> {
    /// The torque limits strictly positive; the piezo window around 0 V
    /// (`v_a_min < 0 < v_a_max`, both finite).
    pub fn validate(&self) -> Result<(), ParamError> {
        positive("tau_max[0]", self.tau_max.x)?;
        positive("tau_max[1]", self.tau_max.y)?;
        positive("v_a_max", self.v_a_max)?;
        positive("v_a_min (negated)", -self.v_a_min)
    }
}

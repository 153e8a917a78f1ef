//! Assumed modes of link 2: the clamped-free modes of a uniform Euler–Bernoulli beam,
//! normalized to unit modal mass (Eqs. 2–3 with one segment).
//!
//! Link 2 is clamped at joint 2 (`φ(0) = φ'(0) = 0`) and free at the tip. With the
//! dimensionless shape `Φ_j(ξ) = cosh β_jξ − cos β_jξ − σ_j (sinh β_jξ − sin β_jξ)`,
//! `ξ = x/a2`, `∫₀¹ Φ_j² dξ = 1`, the unit-modal-mass shape of a link of mass `m2` and
//! length `a2` is `φ_j(x) = Φ_j(x/a2)/√m2` [1/√kg], so that `∫ρ φ_j φ_k dx = δ_jk`.
//!
//! The segmented beam with the piezo patch (Eqs. 1–4, Table 1) is solved on the host
//! (`flexarm-sim`); its results enter the controller through [`crate::params::ModalData`].

use crate::real::Real;

/// `β_j L` of the first two clamped-free modes (roots of `1 + cos β cosh β = 0`).
pub const BETA_L: [f64; 2] = [1.875_104_068_711_961, 4.694_091_132_974_175];

/// One clamped-free mode of a uniform link with unit modal mass.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UniformMode<T> {
    /// `β_j a2`, dimensionless.
    pub beta_l: T,
    /// `σ_j = (sinh β − sin β)/(cosh β + cos β)`, dimensionless.
    pub sigma: T,
    /// Link length `a2` [m].
    pub length: T,
    /// Link mass `m2` [kg].
    pub mass: T,
}

impl<T: Real> UniformMode<T> {
    /// Mode `j` (0 or 1) of a uniform link of mass `m2` [kg] and length `a2` [m].
    /// Indices above 1 are clamped to the second mode.
    pub fn new(j: usize, mass: T, length: T) -> Self {
        let beta_l = T::c(if j == 0 { BETA_L[0] } else { BETA_L[1] });
        let sigma = (beta_l.lsinh() - beta_l.lsin_cos().0) / (beta_l.lcosh() + beta_l.lsin_cos().1);
        Self {
            beta_l,
            sigma,
            length,
            mass,
        }
    }

    fn scale(&self) -> T {
        T::one() / self.mass.lsqrt()
    }

    /// Deflection shape `φ_j(x)` [1/√kg] at `x` ∈ [0, a2] from joint 2.
    pub fn phi(&self, x: T) -> T {
        let b = self.beta_l * x / self.length;
        let (s, c) = b.lsin_cos();
        (b.lcosh() - c - self.sigma * (b.lsinh() - s)) * self.scale()
    }

    /// Slope `φ'_j(x)` [1/(m·√kg)] at `x` ∈ [0, a2].
    pub fn slope(&self, x: T) -> T {
        let beta = self.beta_l / self.length;
        let b = beta * x;
        let (s, c) = b.lsin_cos();
        beta * (b.lsinh() + s - self.sigma * (b.lcosh() - c)) * self.scale()
    }

    /// `∫₀^a2 ρ φ_j dx = √m2 · 2σ_j/β_j` [√kg·m].
    pub fn mass_integral(&self) -> T {
        self.mass.lsqrt() * T::c(2.0) * self.sigma / self.beta_l
    }

    /// `∫₀^a2 ρ x φ_j dx = √m2 · a2 · 2/β_j²` [√kg·m²].
    pub fn moment_integral(&self) -> T {
        self.mass.lsqrt() * self.length * T::c(2.0) / (self.beta_l * self.beta_l)
    }
}

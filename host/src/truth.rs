//! The truth plant's mechanics: the arm with link 2 carrying `N` modes instead of the
//! controller's two (issue 14, first slice). Host side, `f64`, `D = 2 + N` coordinates
//! `q = (θ1, θ2, δ1 … δN)` (SI; frames as in `flexarm_core::model`).
//!
//! ## Kinetic energy
//! The core's assumed-modes Lagrangian (`flexarm_core::model`, De Luca–Siciliano form) holds for
//! any number of modes once link 2 is described by its mass distribution and its modes instead of
//! a uniform 0.3 kg strip. With `m` the link's mass, `S1 = ∫ρx`, `S2 = ∫ρx²` (a tip body of mass
//! `M` and rotary inertia `J_t` included: `+M`, `+M L`, `+M L² + J_t`), and per mode
//! `v_j = ∫ρφ_j + M φ_j(L)`, `w_j = ∫ρxφ_j + M L φ_j(L) + J_t φ_j'(L)` (unit modal mass, the tip
//! body included in the normalization, so `B_δδ = I`):
//!
//! - `b11 = A + J(δ) + 2h`, `b12 = J(δ) + h`, `b22 = J(δ)`,
//! - `b1,2+j = a1 cos θ2 · v_j + w_j`, `b2,2+j = w_j`, `B_δδ = I`,
//!
//! `A = I_h1 + I_1 + m1 a1²/4 + (m_h2 + m) a1²`, `J(δ) = I_h2 + I_2x + S2 + δᵀGδ`,
//! `h = a1 (cos θ2 · S1 − sin θ2 · vᵀδ)`. `K = diag(ω_j²)`, `D = diag(2 ζ_j ω_j)`.
//!
//! `δᵀGδ` is the link's second moment of the deflection, `∫ρw² + M w(L)²`. The tip body turns
//! with the tip's slope, `½ J_t (α̇ + φ'(L)ᵀδ̇)²`: it gives `J_t` in `S2`, `J_t φ'_j(L)` in `w_j`
//! and `J_t φ'(L)φ'(L)ᵀ` in the modal mass, but no `α̇² δ²` term. With the unit modal mass taken
//! over all three, `G = I − r rᵀ` with `r = √J_t φ'(L)` (`G = I` without a rotary inertia, the
//! core's uniform link).
//!
//! ## Coriolis and centrifugal forces
//! `C(q, q̇) q̇ = Ḃ q̇ − ½ ∇_q (q̇ᵀ B q̇)`, the Christoffel form, in closed form: with
//! `σ = θ̇1 + θ̇2`, `j = δᵀGδ̇`, `e_k = −a1 v_k sin θ2`, `E = eᵀδ̇`,
//! `∂h/∂θ2 = −a1 (sin θ2 · S1 + cos θ2 · vᵀδ)` and `H = ∂h/∂θ2 · θ̇2 + E`:
//! `c_0 = ∂h/∂θ2 (2θ̇1θ̇2 + θ̇2²) + 2(j + E)σ`, `c_1 = 2jσ − ∂h/∂θ2 · θ̇1²`,
//! `c_{2+k} = −e_k θ̇1² − (Gδ)_k σ²` (the core's closed forms for two modes, where `G = I`).
//!
//! Neglected, as in the controller's model: axial foreshortening and the geometric
//! (centrifugal) stiffening of the link; both are of order `(spin/ω1)²` and
//! `(deflection/length)²` (`../shared/notes/model-notes.md` §14 sizes them).

use flexarm_beam::design::{DesignModel, PatchModes};
use flexarm_beam::fragment::integrals;
use flexarm_core::params::ArmParams;
use nalgebra::{SMatrix, SVector};

/// Link 2 as a body: its mass distribution and its modes (unit modal mass).
#[derive(Clone, Debug, PartialEq)]
pub struct LinkBody {
    /// Mass `m` [kg] (tip body included).
    pub mass: f64,
    /// First moment about joint 2, `S1 = ∫ρx (+ M L)` [kg·m].
    pub first_moment: f64,
    /// Second moment about joint 2, `S2 = ∫ρx² (+ M L² + J_t)` [kg·m²].
    pub second_moment: f64,
    /// `v_j = ∫ρφ_j (+ M φ_j(L))` [√kg].
    pub v: Vec<f64>,
    /// `w_j = ∫ρxφ_j (+ M L φ_j(L) + J_t φ_j'(L))` [√kg·m].
    pub w: Vec<f64>,
    /// Natural frequencies `ω_j` [rad/s].
    pub omega: Vec<f64>,
    /// Damping ratios `ζ_j` [-].
    pub zeta: Vec<f64>,
    /// Tip values `φ_j(L)` [1/√kg]: the tip deflection is `Σ φ_j(L) δ_j`.
    pub tip: Vec<f64>,
    /// `r_j = √J_t φ'_j(L)` [-]: the tip body's rotary inertia `J_t` turning with
    /// the tip's slope (module docs: `G = I − r rᵀ`); empty or zero without one.
    pub tip_rotary: Vec<f64>,
}

impl LinkBody {
    /// The design beam of `model` with the patch of `pm` (its modes and tip body), damped by
    /// `model.zeta`: the modal integrals are `flexarm_beam::fragment::integrals`, the ones the
    /// optimizer's fragment carries.
    pub fn from_design(model: &DesignModel, pm: &PatchModes) -> Result<Self, TruthError> {
        let beam = model
            .beam(pm.x_a, pm.l_a)
            .map_err(|e| TruthError(format!("the design beam: {e}")))?;
        let (l, m_t, j_t) = (beam.length(), beam.tip_mass, beam.tip_inertia);
        // ∫ρ, ∫ρx, ∫ρx² of piecewise-constant ρA, segment by segment.
        let (mut m, mut s1, mut s2, mut x0) = (0.0, 0.0, 0.0, 0.0);
        for s in beam.segments() {
            let x1 = x0 + s.length;
            m += s.rho_a * (x1 - x0);
            s1 += s.rho_a * (x1 * x1 - x0 * x0) / 2.0;
            s2 += s.rho_a * (x1.powi(3) - x0.powi(3)) / 3.0;
            x0 = x1;
        }
        let ints = integrals(model, pm);
        Ok(Self {
            mass: m + m_t,
            first_moment: s1 + m_t * l,
            second_moment: s2 + m_t * l * l + j_t,
            v: ints.iter().map(|i| i.0).collect(),
            w: ints.iter().map(|i| i.1).collect(),
            omega: pm.omega(),
            zeta: model.zeta.clone(),
            tip: ints.iter().map(|i| i.2).collect(),
            tip_rotary: pm.modes.iter().map(|m| j_t.sqrt() * m.slope(l)).collect(),
        })
    }

    /// The controller's own two-mode link (`ArmParams`): a uniform link of mass `m2` over `a2`
    /// with the given modal data. With it the truth plant is the core's model.
    pub fn from_params(arm: &ArmParams<f64>) -> Self {
        let md = &arm.modes;
        Self {
            mass: arm.m2,
            first_moment: arm.m2 * arm.a2 / 2.0,
            second_moment: arm.m2 * arm.a2 * arm.a2 / 3.0,
            v: vec![md.mass_integral.x, md.mass_integral.y],
            w: vec![md.moment_integral.x, md.moment_integral.y],
            omega: vec![md.omega.x, md.omega.y],
            zeta: vec![md.zeta.x, md.zeta.y],
            tip: vec![md.tip.x, md.tip.y],
            tip_rotary: Vec::new(),
        }
    }

    /// Number of modes.
    pub fn modes(&self) -> usize {
        self.omega.len()
    }
}

/// Why a truth arm cannot be built.
#[derive(Clone, Debug, PartialEq)]
pub struct TruthError(pub String);

impl core::fmt::Display for TruthError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for TruthError {}

/// Generalized coordinates or velocities of the `D`-coordinate arm.
pub type Coords<const D: usize> = SVector<f64, D>;

/// The arm with `D − 2` modes on link 2.
#[derive(Clone, Debug, PartialEq)]
pub struct TruthArm<const D: usize> {
    a_const: f64,
    j_const: f64,
    a1: f64,
    s1: f64,
    /// `v_j`, `w_j` in the modal entries (`2..D`), zero in the joint entries.
    v: Coords<D>,
    w: Coords<D>,
    /// `r = √J_t φ'(L)` in the modal entries (`G = I − r rᵀ`, module docs).
    r: Coords<D>,
    /// `ω_j²` and `2 ζ_j ω_j` in the modal entries.
    k: Coords<D>,
    d: Coords<D>,
    /// The motors' rotors: `(b11, b12, b22)` added to the joint block (see [`Self::with_rotors`]).
    rotor: [f64; 3],
}

impl<const D: usize> TruthArm<D> {
    /// The rigid parts of `rigid` (link 1, the hubs, `a1`, the extra inertia of link 2) with
    /// link 2 the body `link`, whose mode count must be `D − 2`.
    pub fn new(rigid: &ArmParams<f64>, link: &LinkBody) -> Result<Self, TruthError> {
        let n = D.saturating_sub(2);
        if D < 3
            || link.modes() != n
            || link.v.len() != n
            || link.w.len() != n
            || link.zeta.len() != n
            || link.tip.len() != n
            || !(link.tip_rotary.is_empty() || link.tip_rotary.len() == n)
        {
            return Err(TruthError(format!(
                "the link has {} modes, the arm {} coordinates: need modes = coordinates − 2 ≥ 1",
                link.modes(),
                D
            )));
        }
        let all = [link.mass, link.first_moment, link.second_moment]
            .into_iter()
            .chain(link.v.iter().copied())
            .chain(link.w.iter().copied())
            .chain(link.omega.iter().copied())
            .chain(link.zeta.iter().copied())
            .chain(link.tip.iter().copied())
            .chain(link.tip_rotary.iter().copied());
        if !all.clone().all(f64::is_finite) || link.omega.iter().any(|w| *w <= 0.0) {
            return Err(TruthError("the link's data must be finite, ω > 0".into()));
        }
        let p = rigid;
        let mut v = Coords::<D>::zeros();
        let mut w = Coords::<D>::zeros();
        let mut k = Coords::<D>::zeros();
        let mut d = Coords::<D>::zeros();
        let mut r = Coords::<D>::zeros();
        for (j, x) in link.tip_rotary.iter().enumerate() {
            r[2 + j] = *x;
        }
        for j in 0..n {
            v[2 + j] = link.v[j];
            w[2 + j] = link.w[j];
            k[2 + j] = link.omega[j] * link.omega[j];
            d[2 + j] = 2.0 * link.zeta[j] * link.omega[j];
        }
        Ok(Self {
            a_const: p.i_h1 + p.i_1 + p.m1 * p.a1 * p.a1 / 4.0 + (p.m_h2 + link.mass) * p.a1 * p.a1,
            j_const: p.i_h2 + p.i_2_extra + link.second_moment,
            a1: p.a1,
            s1: link.first_moment,
            v,
            w,
            r,
            k,
            d,
            rotor: [0.0; 3],
        })
    }

    /// The arm with the motors' rotors: rotor `i` of inertia `J_ri` [kg·m²] behind a gear of
    /// ratio `n_i` (motor turns per joint turn). Rotor 1 spins at `n1 θ̇1`; rotor 2 sits on
    /// link 1 and spins at `θ̇1 + n2 θ̇2`, so the joint block gains
    /// `b11 += n1² J_r1 + J_r2`, `b12 += n2 J_r2`, `b22 += n2² J_r2` (constant: no Coriolis
    /// term; the rotors' masses are in the hubs' `m_h2`, `I_h`).
    pub fn with_rotors(mut self, n: [f64; 2], j_r: [f64; 2]) -> Self {
        self.rotor = [
            n[0] * n[0] * j_r[0] + j_r[1],
            n[1] * j_r[1],
            n[1] * n[1] * j_r[1],
        ];
        self
    }

    /// `K` and `D` of the mechanics, diagonal: `ω_j²` and `2 ζ_j ω_j` in the modal entries,
    /// zero in the joint entries [1/s², 1/s].
    pub fn stiffness_damping(&self) -> (Coords<D>, Coords<D>) {
        (self.k, self.d)
    }

    /// The modal part `δ` of `q` (joint entries zero).
    fn modal(q: &Coords<D>) -> Coords<D> {
        let mut m = *q;
        m[0] = 0.0;
        m[1] = 0.0;
        m
    }

    /// `G x = x − r (rᵀx)` of a modal vector `x` (module docs).
    fn g_times(&self, x: &Coords<D>) -> Coords<D> {
        x - self.r * self.r.dot(x)
    }

    /// `(sin θ2, cos θ2, vᵀδ)`.
    fn angles(&self, q: &Coords<D>) -> (f64, f64, f64) {
        let (s2, c2) = q[1].sin_cos();
        (s2, c2, self.v.dot(&Self::modal(q)))
    }

    /// Inertia matrix `B(q)`.
    pub fn inertia(&self, q: &Coords<D>) -> SMatrix<f64, D, D> {
        let (s2, c2, vd) = self.angles(q);
        let delta = Self::modal(q);
        let jd = self.j_const + delta.dot(&self.g_times(&delta));
        let h = self.a1 * (c2 * self.s1 - s2 * vd);
        let mut b = SMatrix::<f64, D, D>::identity();
        b[(0, 0)] = self.a_const + jd + 2.0 * h + self.rotor[0];
        b[(0, 1)] = jd + h + self.rotor[1];
        b[(1, 0)] = b[(0, 1)];
        b[(1, 1)] = jd + self.rotor[2];
        for j in 2..D {
            let b1 = self.a1 * c2 * self.v[j] + self.w[j];
            b[(0, j)] = b1;
            b[(j, 0)] = b1;
            b[(1, j)] = self.w[j];
            b[(j, 1)] = self.w[j];
        }
        b
    }

    /// `∂B/∂q_k` for every `k` (`∂B/∂θ1 = 0`), for checks.
    pub fn inertia_partials(&self, q: &Coords<D>) -> Vec<SMatrix<f64, D, D>> {
        let (s2, c2, vd) = self.angles(q);
        let dh = -self.a1 * (s2 * self.s1 + c2 * vd);
        // ∂J/∂δ_k = 2 (Gδ)_k.
        let g = self.g_times(&Self::modal(q));
        let mut out = vec![SMatrix::<f64, D, D>::zeros(); D];
        let t = &mut out[1];
        t[(0, 0)] = 2.0 * dh;
        t[(0, 1)] = dh;
        t[(1, 0)] = dh;
        for j in 2..D {
            t[(0, j)] = -self.a1 * s2 * self.v[j];
            t[(j, 0)] = t[(0, j)];
        }
        for (k, p) in out.iter_mut().enumerate().skip(2) {
            let e = -self.a1 * s2 * self.v[k];
            p[(0, 0)] = 2.0 * g[k] + 2.0 * e;
            p[(0, 1)] = 2.0 * g[k] + e;
            p[(1, 0)] = p[(0, 1)];
            p[(1, 1)] = 2.0 * g[k];
        }
        out
    }

    /// Coriolis and centrifugal forces `C(q, q̇) q̇` (module docs).
    pub fn coriolis(&self, q: &Coords<D>, qd: &Coords<D>) -> Coords<D> {
        let (s2, c2, vd) = self.angles(q);
        let (delta, delta_d) = (Self::modal(q), Self::modal(qd));
        let g_delta = self.g_times(&delta);
        let dh = -self.a1 * (s2 * self.s1 + c2 * vd);
        let e = self.v * (-self.a1 * s2);
        let (j, big_e) = (g_delta.dot(&delta_d), e.dot(&delta_d));
        let sigma = qd[0] + qd[1];
        let mut c = Coords::<D>::zeros();
        c[0] = dh * (2.0 * qd[0] * qd[1] + qd[1] * qd[1]) + 2.0 * (j + big_e) * sigma;
        c[1] = 2.0 * j * sigma - dh * qd[0] * qd[0];
        for k in 2..D {
            c[k] = -e[k] * qd[0] * qd[0] - g_delta[k] * sigma * sigma;
        }
        c
    }

    /// `q̈` for the generalized forces `u`: `B q̈ = u − C q̇ − K q − D q̇`. `None` if `B` is not
    /// positive definite (a state outside the model).
    ///
    /// `B = [[P, Q], [Qᵀ, I]]` (unit modal mass) is solved through the 2×2 Schur complement
    /// `S = P − Q Qᵀ`, positive definite exactly when `B` is:
    /// `S q̈_θ = r_θ − Q r_δ`, `q̈_δ = r_δ − Qᵀ q̈_θ`.
    pub fn acceleration(&self, q: &Coords<D>, qd: &Coords<D>, u: &Coords<D>) -> Option<Coords<D>> {
        let mut r = u - self.coriolis(q, qd) - self.k.component_mul(q) - self.d.component_mul(qd);
        let b = self.inertia(q);
        // Rows 0 and 1 of Q are b[(0, 2..)] and b[(1, 2..)]; their joint entries are skipped.
        let (mut s11, mut s12, mut s22) = (b[(0, 0)], b[(0, 1)], b[(1, 1)]);
        let (mut r0, mut r1) = (r[0], r[1]);
        for j in 2..D {
            let (q0, q1) = (b[(0, j)], b[(1, j)]);
            s11 -= q0 * q0;
            s12 -= q0 * q1;
            s22 -= q1 * q1;
            r0 -= q0 * r[j];
            r1 -= q1 * r[j];
        }
        let det = s11 * s22 - s12 * s12;
        if !(s11 > 0.0 && det > 0.0) {
            return None;
        }
        let a0 = (s22 * r0 - s12 * r1) / det;
        let a1 = (s11 * r1 - s12 * r0) / det;
        for j in 2..D {
            r[j] -= b[(0, j)] * a0 + b[(1, j)] * a1;
        }
        r[0] = a0;
        r[1] = a1;
        r.iter().all(|x| x.is_finite()).then_some(r)
    }

    /// Kinetic plus elastic energy `½ q̇ᵀ B q̇ + ½ δᵀ Ω² δ` [J].
    pub fn energy(&self, q: &Coords<D>, qd: &Coords<D>) -> f64 {
        0.5 * qd.dot(&(self.inertia(q) * qd)) + 0.5 * q.dot(&self.k.component_mul(q))
    }

    /// Power dissipated by the modal damping, `q̇ᵀ D q̇` [W].
    pub fn damping_power(&self, qd: &Coords<D>) -> f64 {
        qd.dot(&self.d.component_mul(qd))
    }

    /// One RK4 step of `dt` [s] with `u` held. `None` if the state leaves the model.
    pub fn rk4(
        &self,
        q: &Coords<D>,
        qd: &Coords<D>,
        u: &Coords<D>,
        dt: f64,
    ) -> Option<(Coords<D>, Coords<D>)> {
        self.rk4_with(q, qd, dt, |_| *u)
    }

    /// One RK4 step of `dt` [s] with the generalized forces `u(q̇)` (friction depends on the
    /// joint speeds). `None` if the state leaves the model.
    pub fn rk4_with(
        &self,
        q: &Coords<D>,
        qd: &Coords<D>,
        dt: f64,
        u: impl Fn(&Coords<D>) -> Coords<D>,
    ) -> Option<(Coords<D>, Coords<D>)> {
        let f = |q: &Coords<D>, qd: &Coords<D>| Some((*qd, self.acceleration(q, qd, &u(qd))?));
        let (k1q, k1v) = f(q, qd)?;
        let (k2q, k2v) = f(&(q + k1q * (dt / 2.0)), &(qd + k1v * (dt / 2.0)))?;
        let (k3q, k3v) = f(&(q + k2q * (dt / 2.0)), &(qd + k2v * (dt / 2.0)))?;
        let (k4q, k4v) = f(&(q + k3q * dt), &(qd + k3v * dt))?;
        Some((
            q + (k1q + k2q * 2.0 + k3q * 2.0 + k4q) * (dt / 6.0),
            qd + (k1v + k2v * 2.0 + k3v * 2.0 + k4v) * (dt / 6.0),
        ))
    }
}

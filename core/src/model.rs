//! The Lagrangian model of the arm (Eqs. 5–6):
//! `B(q) q̈ + C(q, q̇) q̇ + K_e q + D q̇ = u`, gravity ignored, `u` the generalized forces.
//!
//! ## Kinetic energy (assumed modes, De Luca–Siciliano form)
//! A point at distance `x` along link 2, deflected by `w(x) = Σ φ_j(x) δ_j`, moves, in the
//! frame of link 2 (angle `α = θ1 + θ2`), with velocity
//! `(a1 θ̇1 sin θ2 − α̇ w,  a1 θ̇1 cos θ2 + α̇ x + ẇ)`. Integrating `½ρ|v|²` over the link and
//! adding link 1, motor 2 (point mass `m_h2` at joint 2) and the rotor inertias gives
//!
//! - `b11 = A + J(δ) + 2h`,  `b12 = J(δ) + h`,  `b22 = J(δ)`,
//! - `b1,2+j = a1 cos θ2 · v_j + w_j`,  `b2,2+j = w_j`,  `B_δδ = I`,
//!
//! with `A = I_h1 + I_1 + m1 a1²/4 + (m_h2 + m2) a1²`, `J(δ) = I_h2 + I_2x + m2 a2²/3 + δᵀδ`,
//! `h(θ2, δ) = a1 (cos θ2 · m2 a2/2 − sin θ2 · vᵀδ)`, `v_j = ∫ρφ_j`, `w_j = ∫ρxφ_j`.
//! All second-order terms in δ are kept; axial foreshortening is neglected.
//!
//! `C` comes from the Christoffel symbols of `B`, written as `C = ½(Ḃ + Y − Yᵀ)` with
//! `Y_ij = Σ_k ∂b_ik/∂q_j q̇_k`, so `Ḃ − 2C = Yᵀ − Y` is skew-symmetric by construction.
//!
//! ## Closed forms of `C` on the hot path
//! Indices from 0 here: `x = (x0, x1, x2, x3)` along `(θ1, θ2, δ1, δ2)`. Only `θ2` and `δ`
//! enter `B`, and `∂h/∂δ_k = ∂b1,2+k/∂θ2 = −a1 v_k sin θ2 =: e_k`. The derivative of `B` along
//! any vector `x`, `Σ_k ∂B/∂q_k x_k`, is therefore the joint block
//! `[[J_x + 2H_x, J_x + H_x], [J_x + H_x, J_x]]` plus `e_k x1` in the entries `(0, 2+k)` and
//! `(2+k, 0)` (the `b1,2+k` above), with `J_x = 2δᵀx_δ` and `H_x = ∂h/∂θ2 · x1 + eᵀx_δ`. Put
//! into the Christoffel sums, most products cancel; with `σ = q̇0 + q̇1`, `j = δᵀq̇_δ`,
//! `a = j + eᵀq̇_δ` and the same `(σ_v, j_v, a_v)` of a vector `v`:
//!
//! - `(C v)_0 = a σ_v + a_v σ + ∂h/∂θ2 · (q̇1 σ_v + q̇0 v1)`,
//! - `(C v)_1 = j σ_v + j_v σ − ∂h/∂θ2 · q̇0 v0`,
//! - `(C q̇)_{2+k} = −e_k q̇0² − δ_k σ²` (the centripetal forces on the modes).
//!
//! For the rigid arm (`δ = 0`) the joint rows reduce to the textbook `C = [[−hθ̇2, −h(θ̇1+θ̇2)],
//! [hθ̇1, 0]]` with `h = −∂h/∂θ2`. These are what the motor law and the forward dynamics
//! evaluate (about 20 operations each); `core/tests/model.rs` checks them against the full
//! Christoffel matrix.

use crate::params::ArmParams;
use crate::real::Real;
use crate::{Matrix2, Matrix4, Vector2, Vector4};

/// The arm model: parameters plus the constants of `B(q)` computed once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Model<T> {
    /// The parameters the model was built from.
    pub params: ArmParams<T>,
    /// `A = I_h1 + I_1 + m1 a1²/4 + (m_h2 + m2) a1²` [kg·m²].
    pub(crate) a_const: T,
    /// `J(0) = I_h2 + I_2x + m2 a2²/3` [kg·m²].
    pub(crate) j_const: T,
    /// `a1 · m2 a2/2` [kg·m²].
    pub(crate) a1_s2: T,
    /// `a1 v_j` [√kg·m²].
    pub(crate) a1_v: Vector2<T>,
    /// `wᵀw = w1² + w2²` [kg·m²], the constant part of the Schur complement's `s22`.
    w_sq: T,
    /// `K = diag(ω_j²)` [1/s²].
    k: Vector2<T>,
    /// `D = diag(2 ζ_j ω_j)` [1/s].
    d: Vector2<T>,
}

impl<T: Real> Model<T> {
    /// Builds the model; call [`ArmParams::validate`] first for user-supplied values.
    pub fn new(params: ArmParams<T>) -> Self {
        let p = &params;
        let half = T::c(0.5);
        let a_const =
            p.i_h1 + p.i_1 + p.m1 * p.a1 * p.a1 * T::c(0.25) + (p.m_h2 + p.m2) * p.a1 * p.a1;
        let j_const = p.i_h2 + p.i_2_extra + p.m2 * p.a2 * p.a2 / T::c(3.0);
        let w = p.modes.omega;
        let m = p.modes.moment_integral;
        Self {
            a_const,
            j_const,
            a1_s2: p.a1 * p.m2 * p.a2 * half,
            a1_v: p.modes.mass_integral * p.a1,
            w_sq: m.x * m.x + m.y * m.y,
            k: w.component_mul(&w),
            d: (p.modes.zeta * T::c(2.0)).component_mul(&w),
            params,
        }
    }

    /// Inertia matrix `B(q)` [kg·m² on the joints, mixed units elsewhere].
    pub fn inertia(&self, q: &Vector4<T>) -> Matrix4<T> {
        let (s2, c2) = q.y.lsin_cos();
        self.inertia_sc(s2, c2, q)
    }

    /// [`Self::inertia`] with `(sin θ2, cos θ2)` already computed.
    pub fn inertia_sc(&self, s2: T, c2: T, q: &Vector4<T>) -> Matrix4<T> {
        self.terms_sc(s2, c2, q).inertia()
    }

    /// The fastest rate of the joints' velocity loop under the joint gains `kp` [N·m·s/rad]:
    /// the largest eigenvalue of `M(θ2)⁻¹ diag(kp)` over every `θ2`, `M` the rigid joints'
    /// block of `B` with the link at rest, `M = M₀ + cos θ2 M₁` (`m11 = A + J + 2 S cos θ2`,
    /// `m12 = J + S cos θ2`, `m22 = J`) [1/s]. It is the larger of its values at
    /// `cos θ2 = ±1`: `λ_max = max_x xᵀKx / xᵀM x`, and for each `x` the ratio is monotonic in
    /// `cos θ2` (its denominator is linear in it and positive), so its largest value over
    /// `[−1, 1]` is at an end (checked against a scan of 361 poses, `core/tests/model.rs`). The
    /// sampled loop `ṽ ← (1 − λT) ṽ` diverges for `λT > 2`; the gains keep `λT ≤ 1`
    /// (`crate::params::Gains::default_for`, `crate::tuning`).
    pub fn velocity_loop_rate(&self, kp: Vector2<T>) -> T {
        let at = |c2: T| {
            let h = self.a1_s2 * c2;
            let (m11, m12, m22) = (
                self.a_const + self.j_const + h + h,
                self.j_const + h,
                self.j_const,
            );
            // det(K − λ M) = 0: det(M) λ² − (k1 m22 + k2 m11) λ + k1 k2 = 0, the larger root.
            let a = m11 * m22 - m12 * m12;
            let b = kp.x * m22 + kp.y * m11;
            let disc = b * b - T::c(4.0) * a * (kp.x * kp.y);
            let disc = if disc > T::zero() { disc } else { T::zero() };
            (b + disc.lsqrt()) / (T::c(2.0) * a)
        };
        let (lo, hi) = (at(-T::one()), at(T::one()));
        if lo > hi { lo } else { hi }
    }

    /// The configuration-dependent terms of `B(q)` and `∂B/∂q`, computed once per step.
    #[inline(always)]
    pub fn terms(&self, q: &Vector4<T>) -> Terms<T> {
        let (s2, c2) = q.y.lsin_cos();
        self.terms_sc(s2, c2, q)
    }

    /// [`Self::terms`] with the `sin`/`cos` of θ2 inlined ([`Real::lsin_cos_inline`]): the
    /// motor step's and Eq. 7's, where the call, its register moves and the registers it
    /// clobbers cost more than its code; elsewhere the call saves flash.
    #[inline(always)]
    pub fn terms_inline(&self, q: &Vector4<T>) -> Terms<T> {
        let (s2, c2) = q.y.lsin_cos_inline();
        self.terms_sc(s2, c2, q)
    }

    /// [`Self::terms`] with `(sin θ2, cos θ2)` already computed.
    #[inline(always)]
    pub fn terms_sc(&self, s2: T, c2: T, q: &Vector4<T>) -> Terms<T> {
        let (d1, d2) = (q.z, q.w);
        let jd = self.j_const + d1 * d1 + d2 * d2;
        let a1v_delta = self.a1_v.x * d1 + self.a1_v.y * d2;
        let h = self.a1_s2 * c2 - s2 * a1v_delta;
        let w = self.params.modes.moment_integral;
        let (b11, b12, b22) = (self.a_const + jd + h + h, jd + h, jd);
        let (b13, b14) = (self.a1_v.x * c2 + w.x, self.a1_v.y * c2 + w.y);
        Terms {
            b11,
            b12,
            b22,
            b13,
            b14,
            w1: w.x,
            w2: w.y,
            dh: -self.a1_s2 * s2 - c2 * a1v_delta,
            d13: -self.a1_v.x * s2,
            d14: -self.a1_v.y * s2,
            d1,
            d2,
            s_inv: schur_inverse(
                b11 - b13 * b13 - b14 * b14,
                b12 - b13 * w.x - b14 * w.y,
                b22 - self.w_sq,
            ),
        }
    }

    /// Partial derivatives `∂B/∂q_k`, k = 0..3 (`∂B/∂θ1 = 0`).
    pub fn inertia_partials(&self, q: &Vector4<T>) -> [Matrix4<T>; 4] {
        let (s2, c2) = q.y.lsin_cos();
        let delta = Vector2::new(q.z, q.w);
        let z = T::zero();
        let two = T::c(2.0);
        // ∂/∂θ2: only h and b1,2+j depend on θ2.
        let dh = -self.a1_s2 * s2 - c2 * self.a1_v.dot(&delta);
        let d13 = -self.a1_v.x * s2;
        let d14 = -self.a1_v.y * s2;
        let d_theta2 = Matrix4::new(
            two * dh,
            dh,
            d13,
            d14, //
            dh,
            z,
            z,
            z, //
            d13,
            z,
            z,
            z, //
            d14,
            z,
            z,
            z,
        );
        // ∂/∂δ_j: J(δ) gives 2δ_j, h gives −a1 sin θ2 v_j.
        let d_delta = |dj: T, a1vj: T| {
            let dj2 = two * dj;
            let dhj = -s2 * a1vj;
            Matrix4::new(
                dj2 + two * dhj,
                dj2 + dhj,
                z,
                z, //
                dj2 + dhj,
                dj2,
                z,
                z, //
                z,
                z,
                z,
                z, //
                z,
                z,
                z,
                z,
            )
        };
        [
            Matrix4::zeros(),
            d_theta2,
            d_delta(q.z, self.a1_v.x),
            d_delta(q.w, self.a1_v.y),
        ]
    }

    /// Coriolis and centrifugal matrix `C(q, q̇)` from the Christoffel symbols of `B`.
    pub fn coriolis(&self, q: &Vector4<T>, qd: &Vector4<T>) -> Matrix4<T> {
        let db = self.inertia_partials(q);
        let mut b_dot = Matrix4::zeros();
        let mut y = Matrix4::zeros();
        for (k, dbk) in db.iter().enumerate() {
            let qk = qd.get(k).copied().unwrap_or(T::zero());
            b_dot += dbk * qk;
            y.set_column(k, &(dbk * qd));
        }
        (b_dot + y - y.transpose()) * T::c(0.5)
    }

    /// `C(q, q̇) v` without forming `C`: the same Christoffel product, `½(Ḃv + Yv − Yᵀv)`,
    /// using the sparsity of `∂B/∂q` (only `θ2` and `δ` enter `B`; `∂B/∂δ_j` is zero outside the
    /// joint block). This is what the control laws and the forward dynamics call.
    pub fn coriolis_times(&self, q: &Vector4<T>, qd: &Vector4<T>, v: &Vector4<T>) -> Vector4<T> {
        let (s2, c2) = q.y.lsin_cos();
        self.coriolis_times_sc(s2, c2, q, qd, v)
    }

    /// [`Self::coriolis_times`] with `(sin θ2, cos θ2)` already computed.
    pub fn coriolis_times_sc(
        &self,
        s2: T,
        c2: T,
        q: &Vector4<T>,
        qd: &Vector4<T>,
        v: &Vector4<T>,
    ) -> Vector4<T> {
        self.terms_sc(s2, c2, q).c_times(qd, v)
    }

    /// Modal stiffness `K = diag(ω1², ω2²)` [1/s²] (the lower block of `K_e`).
    pub fn modal_stiffness(&self) -> Vector2<T> {
        self.k
    }

    /// Modal damping `D = diag(2ζ1ω1, 2ζ2ω2)` [1/s] (the lower block of the 4×4 `D`).
    pub fn modal_damping(&self) -> Vector2<T> {
        self.d
    }

    /// `K_e q`: elastic forces (zero on the joint rows).
    pub fn elastic_force(&self, q: &Vector4<T>) -> Vector4<T> {
        Vector4::new(T::zero(), T::zero(), self.k.x * q.z, self.k.y * q.w)
    }

    /// `D q̇`: structural damping forces (zero on the joint rows).
    pub fn damping_force(&self, qd: &Vector4<T>) -> Vector4<T> {
        Vector4::new(T::zero(), T::zero(), self.d.x * qd.z, self.d.y * qd.w)
    }

    /// Kinetic energy `½ q̇ᵀ B(q) q̇` [J].
    pub fn kinetic_energy(&self, q: &Vector4<T>, qd: &Vector4<T>) -> T {
        qd.dot(&(self.inertia(q) * qd)) * T::c(0.5)
    }

    /// Elastic potential energy `½ δᵀ K δ` [J].
    pub fn potential_energy(&self, q: &Vector4<T>) -> T {
        (self.k.x * q.z * q.z + self.k.y * q.w * q.w) * T::c(0.5)
    }

    /// Forward dynamics: `q̈ = B⁻¹ (u − C q̇ − K_e q − D q̇)`, solved through the 2×2 Schur
    /// complement of the identity modal block ([`Terms::solve`]).
    /// `None` if `B` is not numerically positive definite (non-finite state).
    pub fn acceleration(
        &self,
        q: &Vector4<T>,
        qd: &Vector4<T>,
        u: &Vector4<T>,
    ) -> Option<Vector4<T>> {
        self.acceleration_with(&self.terms(q), q, qd, u)
    }

    /// [`Self::acceleration`] with the terms of `B(q)` already computed.
    #[inline(always)]
    pub fn acceleration_with(
        &self,
        terms: &Terms<T>,
        q: &Vector4<T>,
        qd: &Vector4<T>,
        u: &Vector4<T>,
    ) -> Option<Vector4<T>> {
        let rhs = u - terms.coriolis_vector(qd) - self.elastic_force(q) - self.damping_force(qd);
        terms.solve(&rhs)
    }

    /// Tip deflection `w(a2) = Σ φ_j(a2) δ_j` [m], normal to the undeformed link 2.
    pub fn tip_deflection(&self, q: &Vector4<T>) -> T {
        self.params.modes.tip.dot(&Vector2::new(q.z, q.w))
    }
}

/// The entries of `B(q)` and `∂B/∂q` at one configuration.
///
/// `B` has the block form `[[B_θθ, B_θδ], [B_θδᵀ, I]]` (unit modal mass), so it is solved
/// through the 2×2 Schur complement `S = B_θθ − B_θδ B_θδᵀ` (positive definite whenever `B` is):
/// no square root, no 4×4 factorization. `S⁻¹` is computed once with the terms and serves the
/// forward dynamics and the robust term alike. `∂B/∂q` has three non-zero slices (`θ2`, `δ1`, `δ2`),
/// whose entries are `dh`, `d13`, `d14` and `2δ_j`, `e_j = d1,2+j`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Terms<T> {
    /// `b11 = A + J(δ) + 2h`.
    pub b11: T,
    /// `b12 = J(δ) + h`.
    pub b12: T,
    /// `b22 = J(δ)`.
    pub b22: T,
    /// `b13 = a1 cos θ2 v1 + w1`.
    pub b13: T,
    /// `b14 = a1 cos θ2 v2 + w2`.
    pub b14: T,
    /// `b23 = w1`.
    pub w1: T,
    /// `b24 = w2`.
    pub w2: T,
    /// `∂h/∂θ2`.
    pub dh: T,
    /// `∂b13/∂θ2 = −a1 v1 sin θ2` (also `∂h/∂δ1`).
    pub d13: T,
    /// `∂b14/∂θ2 = −a1 v2 sin θ2` (also `∂h/∂δ2`).
    pub d14: T,
    /// `δ1`.
    pub d1: T,
    /// `δ2`.
    pub d2: T,
    /// `S⁻¹`; `None` unless `S` is numerically positive definite.
    s_inv: Option<Matrix2<T>>,
}

/// Inverse of the symmetric 2×2 matrix `[[s11, s12], [s12, s22]]`; `None` unless it is
/// numerically positive definite.
fn schur_inverse<T: Real>(s11: T, s12: T, s22: T) -> Option<Matrix2<T>> {
    let det = s11 * s22 - s12 * s12;
    let inv = T::one() / det;
    let m22 = s11 * inv;
    // `det > 0` rejects NaN and det ≤ 0. Then `s11/det > 0` holds exactly when `s11 > 0` and
    // `det < +∞` (where `1/det = 0`): with `det > 0`, the test for positive definiteness.
    if !(det > T::zero() && m22 > T::zero()) {
        return None;
    }
    let off = -s12 * inv;
    Some(Matrix2::new(s22 * inv, off, off, m22))
}

impl<T: Real> Terms<T> {
    /// `B(q)` as a matrix.
    pub fn inertia(&self) -> Matrix4<T> {
        let (o, z) = (T::one(), T::zero());
        Matrix4::new(
            self.b11, self.b12, self.b13, self.b14, //
            self.b12, self.b22, self.w1, self.w2, //
            self.b13, self.w1, o, z, //
            self.b14, self.w2, z, o,
        )
    }

    /// `B v`.
    pub fn b_times(&self, v: &Vector4<T>) -> Vector4<T> {
        let j = self.b_times_joints(v);
        Vector4::new(
            j.x,
            j.y,
            self.b13 * v.x + self.w1 * v.y + v.z,
            self.b14 * v.x + self.w2 * v.y + v.w,
        )
    }

    /// The joint rows of `B v`.
    #[inline(always)]
    pub fn b_times_joints(&self, v: &Vector4<T>) -> Vector2<T> {
        Vector2::new(
            self.b11 * v.x + self.b12 * v.y + self.b13 * v.z + self.b14 * v.w,
            self.b12 * v.x + self.b22 * v.y + self.w1 * v.z + self.w2 * v.w,
        )
    }

    /// `∂B/∂δj` restricted to the joint block, times `(x0, x1)`: `[[2δj + 2e_j, 2δj + e_j],
    /// [2δj + e_j, 2δj]]`.
    fn q_block(dj: T, e: T, x0: T, x1: T) -> (T, T) {
        let two = T::c(2.0);
        let (m00, m01, m11) = (two * (dj + e), two * dj + e, two * dj);
        (m00 * x0 + m01 * x1, m01 * x0 + m11 * x1)
    }

    /// `∂B/∂θ2 · x`.
    fn p_times(&self, x: &Vector4<T>) -> Vector4<T> {
        let two = T::c(2.0);
        Vector4::new(
            two * self.dh * x.x + self.dh * x.y + self.d13 * x.z + self.d14 * x.w,
            self.dh * x.x,
            self.d13 * x.x,
            self.d14 * x.x,
        )
    }

    /// `C(q, q̇) v = ½(Ḃv + Yv − Yᵀv)` (Christoffel symbols), `Y = [0, ∂B/∂θ2 q̇, ∂B/∂δ1 q̇, ∂B/∂δ2 q̇]`.
    pub fn c_times(&self, qd: &Vector4<T>, v: &Vector4<T>) -> Vector4<T> {
        let (w0, w1, w2, w3) = (qd.x, qd.y, qd.z, qd.w);
        let (v0, v1, v2, v3) = (v.x, v.y, v.z, v.w);
        let pv = self.p_times(v);
        let q1v = Self::q_block(self.d1, self.d13, v0, v1);
        let q2v = Self::q_block(self.d2, self.d14, v0, v1);
        let b_dot_v = pv * w1
            + Vector4::new(
                q1v.0 * w2 + q2v.0 * w3,
                q1v.1 * w2 + q2v.1 * w3,
                T::zero(),
                T::zero(),
            );
        let pq = self.p_times(qd);
        let g1 = Self::q_block(self.d1, self.d13, w0, w1);
        let g2 = Self::q_block(self.d2, self.d14, w0, w1);
        let y_v = pq * v1
            + Vector4::new(
                g1.0 * v2 + g2.0 * v3,
                g1.1 * v2 + g2.1 * v3,
                T::zero(),
                T::zero(),
            );
        let yt_v = Vector4::new(
            T::zero(),
            pq.dot(v),
            g1.0 * v0 + g1.1 * v1,
            g2.0 * v0 + g2.1 * v1,
        );
        (b_dot_v + y_v - yt_v) * T::c(0.5)
    }

    /// The three scalars of a velocity-like vector `x` that the closed forms of `C` need:
    /// `σ = x0 + x1` (the rate of `α = θ1 + θ2`), `j = δᵀ x_δ` and
    /// `a = j + (∂b13/∂θ2) x2 + (∂b14/∂θ2) x3`.
    #[inline(always)]
    fn rates(&self, x: &Vector4<T>) -> (T, T, T) {
        let j = self.d1 * x.z + self.d2 * x.w;
        (x.x + x.y, j, j + (self.d13 * x.z + self.d14 * x.w))
    }

    /// The Coriolis and centrifugal forces `C(q, q̇) q̇` (forward dynamics), in closed form
    /// (module docs): with `(σ, j, a)` of `q̇` ([`Self::rates`]),
    /// `[2σa + ∂h/∂θ2 · θ̇2 (σ + θ̇1),  2σj − ∂h/∂θ2 · θ̇1²,  −∂b1,2+k/∂θ2 · θ̇1² − δ_k σ²]`.
    #[inline(always)]
    pub fn coriolis_vector(&self, qd: &Vector4<T>) -> Vector4<T> {
        let (s, j, a) = self.rates(qd);
        let two_s = s + s;
        let w0_sq = qd.x * qd.x;
        let s_sq = s * s;
        Vector4::new(
            two_s * a + self.dh * qd.y * (s + qd.x),
            two_s * j - self.dh * w0_sq,
            -(self.d13 * w0_sq + self.d1 * s_sq),
            -(self.d14 * w0_sq + self.d2 * s_sq),
        )
    }

    /// The joint rows of `C(q, q̇) v`, all the motors need, in closed form (module docs): with
    /// `(σ, j, a)` of `q̇` and `(σ_v, j_v, a_v)` of `v` ([`Self::rates`]),
    /// `[a σ_v + a_v σ + ∂h/∂θ2 (θ̇2 σ_v + θ̇1 v1),  j σ_v + j_v σ − ∂h/∂θ2 · θ̇1 v0]`.
    #[inline(always)]
    pub fn c_times_joints(&self, qd: &Vector4<T>, v: &Vector4<T>) -> Vector2<T> {
        let (s, j, a) = self.rates(qd);
        let (s_v, j_v, a_v) = self.rates(v);
        Vector2::new(
            a * s_v + a_v * s + self.dh * (qd.y * s_v + qd.x * v.y),
            j * s_v + j_v * s - self.dh * qd.x * v.x,
        )
    }

    /// `S⁻¹`, the inverse of the Schur complement `S = B_θθ − B_θδ B_θδᵀ`; `None` unless `S` is
    /// numerically positive definite.
    pub fn schur_inverse(&self) -> Option<Matrix2<T>> {
        self.s_inv
    }

    /// Solves `B x = r` (forward dynamics).
    pub fn solve(&self, r: &Vector4<T>) -> Option<Vector4<T>> {
        let s_inv = self.s_inv?;
        let rt = Vector2::new(
            r.x - self.b13 * r.z - self.b14 * r.w,
            r.y - self.w1 * r.z - self.w2 * r.w,
        );
        let xt = s_inv * rt;
        Some(Vector4::new(
            xt.x,
            xt.y,
            r.z - self.b13 * xt.x - self.w1 * xt.y,
            r.w - self.b14 * xt.x - self.w2 * xt.y,
        ))
    }

    /// `M = (B⁻¹)_δθ = −B_δθ S⁻¹`: how joint torques move the modal accelerations.
    pub fn modal_input_map(&self) -> Option<Matrix2<T>> {
        let s_inv = self.s_inv?;
        Some(-Matrix2::new(self.b13, self.w1, self.b14, self.w2) * s_inv)
    }
}

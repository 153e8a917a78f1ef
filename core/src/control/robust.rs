//! Robust modal damping (Eqs. 11, 16) and its realization through the joint motors.
//!
//! ## Our reading of Eq. 11
//! As printed, Eq. 11 multiplies `δ̇_d`, the desired deflection rate, which is zero when
//! gravity is ignored, so the term would do nothing. We apply it to the measured (or
//! estimated) deflection rate `δ̇` and the modal rows of the reference error
//! `s_δ = δ̇ + Λ_δ δ`, and request the modal acceleration
//!
//! `a_Δ = −D'_Δ δ̇`,  `D'_Δ = D_Δ (I + diag|f_j|)`,
//! `f_j = δ̇_j s_j / (|δ̇_j s_j| + max(ε_j e^{−φ_j t}, ε_floor))`,
//!
//! a nominal damping `D_Δ` plus a smooth, bounded robust boost (Yao–Tomizuka boundary layer
//! `ε e^{−φ t}`; the paper prints `e^{−φ}`, we read the missing `t`). Since `0 ≤ |f_j| < 1`,
//! `D_Δ ≤ D'_Δ < 2 D_Δ`: the request always removes energy from the modes
//! (`δ̇ᵀ a_Δ ≤ 0`). The printed minus sign, `D_Δ − diag(f)`, could cancel the damping whenever
//! `δ̇ s > 0`; we do not use it (see `docs/model.md`).
//!
//! ## Realization
//! The motors cannot apply a modal force. An extra joint torque `Δτ` changes the modal
//! accelerations by `Δδ̈ = M Δτ` with `M = (B⁻¹)_δθ`, the modal-by-joint block of `B(q)⁻¹`.
//! The torque that best delivers `a_Δ` is the damped least-squares solution
//! `Δτ = Mᵀ (M Mᵀ + μ² σ² I)⁻¹ a_Δ`, `σ² = ‖M‖²_F / 2`, which stays bounded where `M` loses rank.

use crate::Vector2;
use crate::limits::upper;
use crate::model::Terms;
use crate::params::Gains;
use crate::real::Real;

/// Requested modal acceleration `a_Δ = −D'_Δ δ̇` [√kg·m/s² per unit modal mass] at time `t` [s].
/// Inlined into the motor law, its one caller on the hot path.
#[inline(always)]
pub fn modal_damping_accel<T: Real>(
    gains: &Gains<T>,
    t: T,
    delta_dot: &Vector2<T>,
    s_delta: &Vector2<T>,
) -> Vector2<T> {
    // e^{−φ_j t}; one exponential when both modes share φ (the paper's φ_ij = 0.01).
    let e1 = (-gains.phi.x * t).lexp();
    let e2 = if gains.phi.y == gains.phi.x {
        e1
    } else {
        (-gains.phi.y * t).lexp()
    };
    // The boundary layer, floored.
    let layer = |eps: T, decay: T| upper(eps * decay, gains.epsilon_floor);
    let (dd1, dd2) = (delta_dot.x, delta_dot.y);
    let p1 = (dd1 * s_delta.x).abs();
    let p2 = (dd2 * s_delta.y).abs();
    let n1 = p1 + layer(gains.epsilon.x, e1);
    let n2 = p2 + layer(gains.epsilon.y, e2);
    // f_j = p_j / n_j with one division (14 cycles on the M4F) for both: 1/(n1 n2). Both
    // denominators are at least the floor; their product overflows only where |δ̇ s| passes
    // 1e19, and then f = 0 (nominal damping) or NaN, which trips a fault downstream.
    let r = T::one() / (n1 * n2);
    let f1 = p1 * n2 * r;
    let f2 = p2 * n1 * r;
    Vector2::new(
        -gains.d_delta.x * (T::one() + f1) * dd1,
        -gains.d_delta.y * (T::one() + f2) * dd2,
    )
}

/// Damped least-squares joint torque `Δτ` [N·m] that best produces the modal acceleration `a`,
/// with `M = (B⁻¹)_δθ` from the terms of `B(q)` ([`Terms::modal_input_map`]).
///
/// `G = M Mᵀ + μ² σ² I` is symmetric, and `σ² = ‖M‖²_F / 2 = tr(M Mᵀ)/2` comes from its
/// diagonal; `G⁻¹ a` is solved in closed form. `M = 0` (no authority) gives `Δτ = 0`.
pub fn joint_torque_for_modal_accel<T: Real>(
    terms: &Terms<T>,
    a: &Vector2<T>,
    mu: T,
) -> Vector2<T> {
    let Some(m) = terms.modal_input_map() else {
        return Vector2::zeros();
    };
    let (m11, m12, m21, m22) = (m.m11, m.m12, m.m21, m.m22);
    let g11 = m11 * m11 + m12 * m12;
    let g12 = m11 * m21 + m12 * m22;
    let g22 = m21 * m21 + m22 * m22;
    let reg = mu * mu * (g11 + g22) * T::c(0.5);
    let (g11, g22) = (g11 + reg, g22 + reg);
    let det = g11 * g22 - g12 * g12;
    // NaN passes on (and trips a fault downstream); only a vanishing map gives zero.
    if det <= T::zero() {
        return Vector2::zeros();
    }
    let inv = T::one() / det;
    let y1 = (g22 * a.x - g12 * a.y) * inv;
    let y2 = (g11 * a.y - g12 * a.x) * inv;
    Vector2::new(m11 * y1 + m21 * y2, m12 * y1 + m22 * y2)
}

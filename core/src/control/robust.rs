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

use crate::model::Terms;
use crate::params::Gains;
use crate::real::Real;
use crate::{Matrix2, Vector2};

/// Requested modal acceleration `a_Δ = −D'_Δ δ̇` [√kg·m/s² per unit modal mass] at time `t` [s].
pub fn modal_damping_accel<T: Real>(
    gains: &Gains<T>,
    t: T,
    delta_dot: &Vector2<T>,
    s_delta: &Vector2<T>,
) -> Vector2<T> {
    let one = |dd: T, s: T, d: T, eps: T, phi: T| {
        let layer = (eps * (-phi * t).lexp()).max(gains.epsilon_floor);
        let p = dd * s;
        let f = p.abs() / (p.abs() + layer);
        -d * (T::one() + f) * dd
    };
    Vector2::new(
        one(
            delta_dot.x,
            s_delta.x,
            gains.d_delta.x,
            gains.epsilon.x,
            gains.phi.x,
        ),
        one(
            delta_dot.y,
            s_delta.y,
            gains.d_delta.y,
            gains.epsilon.y,
            gains.phi.y,
        ),
    )
}

/// Damped least-squares joint torque `Δτ` [N·m] that best produces the modal acceleration `a`,
/// with `M = (B⁻¹)_δθ` from the terms of `B(q)` ([`Terms::modal_input_map`]).
pub fn joint_torque_for_modal_accel<T: Real>(
    terms: &Terms<T>,
    a: &Vector2<T>,
    mu: T,
) -> Vector2<T> {
    let Some(m) = terms.modal_input_map() else {
        return Vector2::zeros();
    };
    let sigma2 = m.norm_squared() * T::c(0.5);
    let g = m * m.transpose() + Matrix2::identity() * (mu * mu * sigma2);
    match g.try_inverse() {
        Some(g_inv) => m.transpose() * (g_inv * a),
        None => Vector2::zeros(),
    }
}

//! Passivity-based tracking with dynamics compensation (Eq. 7):
//!
//! `u = B(q) q̈_r + C(q, q̇) q̇_r + K_e q_d + D q̇_r − K_p s`,
//!
//! with the tracking error `q̃ = q − q_d`, the reference velocity `q̇_r = q̇_d − Λ q̃`, its
//! derivative `q̈_r = q̈_d − Λ (q̇ − q̇_d)`, and the reference error `s = q̇ − q̇_r`. Gravity is
//! ignored (`g = 0`). Eqs. 16 and 20 print `C(q, q̇) q̇` where Eq. 7 has `C(q, q̇) q̇_r`; the
//! Lyapunov argument of Eqs. 8–10 needs `q̇_r`, which we use throughout.

use crate::model::{Model, Terms};
use crate::params::Gains;
use crate::real::Real;
use crate::trajectory::JointTarget;
use crate::{Matrix4, Vector2, Vector4};

/// The reference signals of Eq. 7.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reference<T> {
    /// Tracking error `q̃ = q − q_d`.
    pub q_tilde: Vector4<T>,
    /// Reference velocity `q̇_r = q̇_d − Λ q̃`.
    pub qd_r: Vector4<T>,
    /// Reference acceleration `q̈_r = q̈_d − Λ (q̇ − q̇_d)`.
    pub qdd_r: Vector4<T>,
    /// Reference error `s = q̇ − q̇_r = (q̇ − q̇_d) + Λ q̃`.
    pub s: Vector4<T>,
}

impl<T: Real> Reference<T> {
    /// Reference signals for the state `(q, q̇)` and the target (`δ_d = 0`).
    #[inline(always)]
    pub fn new(
        lambda: &Vector4<T>,
        q: &Vector4<T>,
        qd: &Vector4<T>,
        target: &JointTarget<T>,
    ) -> Self {
        // δ_d = δ̇_d = δ̈_d = 0: the modal rows are written out rather than computed from zeros
        // (IEEE arithmetic cannot drop `0 − x`).
        let l = lambda;
        let q_tilde = Vector4::new(q.x - target.q.x, q.y - target.q.y, q.z, q.w);
        let qd_r = Vector4::new(
            target.qd.x - l.x * q_tilde.x,
            target.qd.y - l.y * q_tilde.y,
            -(l.z * q.z),
            -(l.w * q.w),
        );
        let qdd_r = Vector4::new(
            target.qdd.x - l.x * (qd.x - target.qd.x),
            target.qdd.y - l.y * (qd.y - target.qd.y),
            -(l.z * qd.z),
            -(l.w * qd.w),
        );
        Self {
            q_tilde,
            qd_r,
            qdd_r,
            s: qd - qd_r,
        }
    }
}

/// Eq. 7: the generalized force over all four coordinates, given `B(q)` and `C(q, q̇) q̇_r`.
pub fn eq7_with<T: Real>(
    model: &Model<T>,
    b: &Matrix4<T>,
    c_qd_r: &Vector4<T>,
    kp: &Vector4<T>,
    r: &Reference<T>,
) -> Vector4<T> {
    // K_e q_d = 0: the desired deflections are zero.
    b * r.qdd_r + c_qd_r + model.damping_force(&r.qd_r) - kp.component_mul(&r.s)
}

/// The joint rows of Eq. 7, the motor torques: `τ = (B q̈_r + C q̇_r − K_p s)_θ` (`K_e` and `D`
/// vanish on the joint rows). Only these rows reach an actuator, so only these are computed.
#[inline(always)]
pub fn eq7_joints<T: Real>(
    terms: &Terms<T>,
    qd: &Vector4<T>,
    kp: &Vector4<T>,
    r: &Reference<T>,
) -> Vector2<T> {
    let b = terms.b_times_joints(&r.qdd_r);
    joint_rows(b, terms.c_times_joints(qd, &r.qd_r), kp, r)
}

/// `τ = (B q̈_r)_θ + (C q̇_r)_θ − (K_p s)_θ` from the first two.
#[inline(always)]
fn joint_rows<T: Real>(
    b: Vector2<T>,
    c: Vector2<T>,
    kp: &Vector4<T>,
    r: &Reference<T>,
) -> Vector2<T> {
    b + c - Vector2::new(kp.x * r.s.x, kp.y * r.s.y)
}

/// The motor torques of Eq. 7 from the state: what a plain implementation of the law computes,
/// `(q, q̇, q_d, q̇_d, q̈_d) → (τ1, τ2)`, with one `sin`/`cos` of θ2 and the structure of `B`.
/// Inlined, like its parts, into its callers.
#[inline(always)]
pub fn eq7_torques<T: Real>(
    model: &Model<T>,
    gains: &Gains<T>,
    q: &Vector4<T>,
    qd: &Vector4<T>,
    target: &JointTarget<T>,
) -> Vector2<T> {
    // The terms first: their sin/cos of θ2 needs only θ2, so the reference's inputs are not
    // loaded into registers (and saved across the polynomial) before it.
    let terms = model.terms_inline(q);
    let r = Reference::new(&gains.lambda, q, qd, target);
    // `C q̇_r` before `B q̈_r` (the same operations, so the same result): LLVM then holds five
    // values in the callee-saved FP registers instead of seven (`VPUSH {d8-d12}`, 4 cycles
    // less on entry and on return). The motor law keeps `eq7_joints`' order, which spills less
    // there.
    let c = terms.c_times_joints(qd, &r.qd_r);
    joint_rows(terms.b_times_joints(&r.qdd_r), c, &gains.kp, &r)
}

/// Eq. 7 from the state: `u = B q̈_r + C q̇_r + K_e q_d + D q̇_r − K_p s`.
pub fn eq7<T: Real>(
    model: &Model<T>,
    gains: &Gains<T>,
    q: &Vector4<T>,
    qd: &Vector4<T>,
    target: &JointTarget<T>,
) -> Vector4<T> {
    let r = Reference::new(&gains.lambda, q, qd, target);
    let (s2, c2) = q.y.lsin_cos();
    let b = model.inertia_sc(s2, c2, q);
    let c_qd_r = model.coriolis_times_sc(s2, c2, q, qd, &r.qd_r);
    eq7_with(model, &b, &c_qd_r, &gains.kp, &r)
}

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
/// `(q, q̇, q_d, q̇_d, q̈_d) → (τ1, τ2)`, with one `sin`/`cos` of θ2 and the structure of `B`:
/// the joint rows `τ = (B q̈_r)_θ + (C q̇_r)_θ − (K_p s)_θ`, one scalar at a time.
///
/// The same operations, with the same roundings, as [`Terms`](crate::model::Terms),
/// [`Reference`], [`eq7_joints`] and `firmware/c/steps.c` (the bench checks that the last
/// agrees to the bit). Only the order of the statements and of the operands of each sum and
/// product differs, and neither changes a result: IEEE addition and multiplication commute
/// exactly. The order is the fastest that a search over orders found (docs/performance.md,
/// "sixth round"): with it LLVM saves five double registers on entry, where most orders make it
/// save seven or eight. Reorder nothing without `cargo fw-bench`.
///
/// Names: `v0..v3` = `q̇_r`, `dv0..dv3` = `q̈_r` (`δ_d = 0`); `(σ, j, a)` and `(σ_v, j_v, a_v)`,
/// the rates of `q̇` and `q̇_r` (`Terms::c_times_joints`); `jd` = `J(δ)`, `h`, `dh` = `∂h/∂θ2`,
/// `b11`…`b14`, `d13`, `d14` as in [`Terms`](crate::model::Terms); `b0, b1` = `(B q̈_r)_θ`,
/// `c0, c1` = `(C q̇_r)_θ`.
#[inline(always)]
pub fn eq7_torques<T: Real>(
    model: &Model<T>,
    gains: &Gains<T>,
    q: &Vector4<T>,
    qd: &Vector4<T>,
    target: &JointTarget<T>,
) -> Vector2<T> {
    let (l, kp, m) = (&gains.lambda, &gains.kp, model);
    let w = m.params.modes.moment_integral;
    // scripts/eq7-orders rewrites the lines from here to the `Vector2` in the order it tries.
    let (s2, c2) = q.y.lsin_cos_inline();
    let d13 = s2 * -m.a1_v.x;
    let d1 = q.z;
    let dv2 = -(qd.z * l.z);
    let v3 = -(q.w * l.w);
    let sigma = qd.x + qd.y;
    let d14 = s2 * -m.a1_v.y;
    let b13 = w.x + m.a1_v.x * c2;
    let v0 = target.qd.x - (l.x * (q.x - target.q.x));
    let d2 = q.w;
    let v2 = -(q.z * l.z);
    let j_v = v2 * d1 + v3 * d2;
    let a_v = v3 * d14 + v2 * d13 + j_v;
    let a1v_delta = d1 * m.a1_v.x + d2 * m.a1_v.y;
    let dv3 = -(qd.w * l.w);
    let b14 = c2 * m.a1_v.y + w.y;
    let v1 = target.qd.y - (l.y * (q.y - target.q.y));
    let j = qd.w * d2 + d1 * qd.z;
    let jd = d2 * d2 + (d1 * d1 + m.j_const);
    let a = j + (d14 * qd.w + qd.z * d13);
    let dv0 = target.qdd.x - (l.x * (qd.x - target.qd.x));
    let dh = s2 * -m.a1_s2 - (c2 * a1v_delta);
    let h = c2 * m.a1_s2 - (a1v_delta * s2);
    let dv1 = target.qdd.y - (l.y * (qd.y - target.qd.y));
    let b12 = h + jd;
    let b11 = h + (m.a_const + jd) + h;
    let b0 = dv3 * b14 + (dv2 * b13 + (b11 * dv0 + dv1 * b12));
    let b1 = b12 * dv0 + dv1 * jd + w.x * dv2 + dv3 * w.y;
    let sigma_v = v1 + v0;
    let c1 = j_v * sigma + sigma_v * j - (v0 * (qd.x * dh));
    let c0 = dh * (v1 * qd.x + qd.y * sigma_v) + (a_v * sigma + a * sigma_v);
    Vector2::new(
        c0 + b0 - (kp.x * (qd.x - v0)),
        b1 + c1 - ((qd.y - v1) * kp.y),
    )
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

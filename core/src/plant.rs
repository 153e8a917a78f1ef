//! The arm as a plant to integrate: fixed-step RK4 of `B q̈ + C q̇ + K_e q + D q̇ = u` (the
//! paper's integrator), generic over the scalar so that the simulator runs it in `f64` and the
//! firmware's QEMU board in `f32`.

use crate::Vector4;
use crate::model::Model;
use crate::real::Real;

/// State `x = (q, q̇)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct State<T> {
    /// Generalized coordinates `(θ1, θ2, δ1, δ2)` [rad, rad, √kg·m, √kg·m].
    pub q: Vector4<T>,
    /// Their rates.
    pub qd: Vector4<T>,
}

impl<T: Real> State<T> {
    /// At rest at `q`.
    pub fn rest(q: Vector4<T>) -> Self {
        Self {
            q,
            qd: Vector4::zeros(),
        }
    }

    /// Total mechanical energy `½ q̇ᵀ B q̇ + ½ δᵀ K δ` [J].
    pub fn energy(&self, model: &Model<T>) -> T {
        model.kinetic_energy(&self.q, &self.qd) + model.potential_energy(&self.q)
    }
}

/// One RK4 step over `dt` [s] with `u` held. `None` if the state left the model's domain
/// (`B` not positive definite, or a non-finite result).
pub fn rk4_step<T: Real>(
    model: &Model<T>,
    x: &State<T>,
    u: &Vector4<T>,
    dt: T,
) -> Option<State<T>> {
    let f = |s: &State<T>| {
        model
            .acceleration(&s.q, &s.qd, u)
            .map(|qdd| State { q: s.qd, qd: qdd })
    };
    let add = |s: &State<T>, k: &State<T>, h: T| State {
        q: s.q + k.q * h,
        qd: s.qd + k.qd * h,
    };
    let half = dt * T::c(0.5);
    let k1 = f(x)?;
    let k2 = f(&add(x, &k1, half))?;
    let k3 = f(&add(x, &k2, half))?;
    let k4 = f(&add(x, &k3, dt))?;
    let w = dt / T::c(6.0);
    let two = T::c(2.0);
    let next = State {
        q: x.q + (k1.q + k2.q * two + k3.q * two + k4.q) * w,
        qd: x.qd + (k1.qd + k2.qd * two + k3.qd * two + k4.qd) * w,
    };
    next.q
        .iter()
        .chain(next.qd.iter())
        .all(|v| v.finite())
        .then_some(next)
}

//! The plant: the core's model in `f64` with fixed-step RK4 (the paper's integrator).

use flexarm_core::Vector4;
use flexarm_core::model::Model;

/// State `x = (q, q̇)` of the plant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct State {
    /// Generalized coordinates `(θ1, θ2, δ1, δ2)` [rad, rad, √kg·m, √kg·m].
    pub q: Vector4<f64>,
    /// Their rates.
    pub qd: Vector4<f64>,
}

impl State {
    /// At rest at `q`.
    pub fn rest(q: Vector4<f64>) -> Self {
        Self {
            q,
            qd: Vector4::zeros(),
        }
    }
}

/// Why the integration stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlantError {
    /// `B(q)` lost positive definiteness: the state diverged.
    Diverged,
}

impl core::fmt::Display for PlantError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("the plant state diverged (inertia matrix not positive definite)")
    }
}

impl std::error::Error for PlantError {}

/// One RK4 step of `B q̈ + C q̇ + K_e q + D q̇ = u` over `dt` [s] with `u` held.
pub fn rk4_step(
    model: &Model<f64>,
    x: &State,
    u: &Vector4<f64>,
    dt: f64,
) -> Result<State, PlantError> {
    let f = |s: &State| -> Result<State, PlantError> {
        let qdd = model
            .acceleration(&s.q, &s.qd, u)
            .ok_or(PlantError::Diverged)?;
        Ok(State { q: s.qd, qd: qdd })
    };
    let add = |s: &State, k: &State, h: f64| State {
        q: s.q + k.q * h,
        qd: s.qd + k.qd * h,
    };
    let k1 = f(x)?;
    let k2 = f(&add(x, &k1, dt / 2.0))?;
    let k3 = f(&add(x, &k2, dt / 2.0))?;
    let k4 = f(&add(x, &k3, dt))?;
    let next = State {
        q: x.q + (k1.q + k2.q * 2.0 + k3.q * 2.0 + k4.q) * (dt / 6.0),
        qd: x.qd + (k1.qd + k2.qd * 2.0 + k3.qd * 2.0 + k4.qd) * (dt / 6.0),
    };
    if next.q.iter().chain(next.qd.iter()).all(|v| v.is_finite()) {
        Ok(next)
    } else {
        Err(PlantError::Diverged)
    }
}

/// Total mechanical energy `½ q̇ᵀ B q̇ + ½ δᵀ K δ` [J].
pub fn energy(model: &Model<f64>, x: &State) -> f64 {
    model.kinetic_energy(&x.q, &x.qd) + model.potential_energy(&x.q)
}

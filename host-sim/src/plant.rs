//! The plant: what the simulator's loop drives ([`Plant`]). Two implement it:
//! - [`ModelPlant`]: the core's model in `f64` (the controller's own two modes, ideal torque
//!   sources and film), integrated with the core's fixed-step RK4 (the paper's integrator), the
//!   same code the firmware's QEMU board runs in `f32`;
//! - `crate::truth_plant::TruthPlant`: link 2 with more modes, motors, amplifiers (issue 14).
//!
//! And an adaptive Dormand–Prince 5(4) integrator to cross-check the RK4 plant.

pub use flexarm_core::plant::{State, rk4_step};

use flexarm_core::control::piezo::PiezoPatch;
use flexarm_core::model::Model;
use flexarm_core::{Vector2, Vector4};

/// A simulated arm as the simulator's loop sees it: commands in, measurable quantities out.
/// Units SI; joint angles in the core's frames (`flexarm_core::model`).
pub trait Plant {
    /// `(θ1, θ2, δ1, δ2)` and their rates: the coordinates the controller's model has (the
    /// first two modes of a plant with more).
    fn state(&self) -> State<f64>;
    /// Tip deflection of link 2 [m], every mode of the plant included.
    fn tip(&self) -> f64;
    /// What the film's amplifier puts out now [V] (the ADC is the simulator's).
    fn film(&self) -> f64;
    /// Advances by `dt` [s] with the motor torque commands `tau` [N·m] and the piezo amplifier
    /// command `v_a` [V] held.
    fn step(&mut self, tau: &Vector2<f64>, v_a: f64, dt: f64) -> Result<(), Diverged>;
    /// A hammer's strike: an impulse `p` [N·s] across link 2 at its tip, counter-clockwise
    /// positive. The generalized impulse is `p (a1 cos θ2 + a2, a2, φ_1(a2) … φ_N(a2))` and the
    /// rates jump by `B(q)⁻¹` of it. `false` when the plant cannot take one (the controller's
    /// own model: [`ModelPlant`]).
    fn strike(&mut self, _p: f64) -> bool {
        false
    }
}

/// The controller's own model as the plant: ideal torque sources, an ideal amplifier (the
/// patch gets the command) and the film's open-circuit voltage (Eq. 19).
#[derive(Clone, Debug, PartialEq)]
pub struct ModelPlant {
    model: Model<f64>,
    patch: PiezoPatch<f64>,
    x: State<f64>,
}

impl ModelPlant {
    /// The plant at the state `x`.
    pub fn new(model: Model<f64>, patch: PiezoPatch<f64>, x: State<f64>) -> Self {
        Self { model, patch, x }
    }
}

impl Plant for ModelPlant {
    fn state(&self) -> State<f64> {
        self.x
    }

    fn tip(&self) -> f64 {
        self.model.tip_deflection(&self.x.q)
    }

    fn film(&self) -> f64 {
        self.patch.film_voltage(&self.x.q)
    }

    fn step(&mut self, tau: &Vector2<f64>, v_a: f64, dt: f64) -> Result<(), Diverged> {
        let u = Vector4::new(tau.x, tau.y, 0.0, 0.0) + self.patch.generalized_force(v_a);
        self.x = rk4_step(&self.model, &self.x, &u, dt).ok_or(Diverged)?;
        Ok(())
    }
}

/// Why the integration stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Diverged;

impl core::fmt::Display for Diverged {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(
            "the plant state diverged (inertia matrix not positive definite or non-finite state)",
        )
    }
}

impl std::error::Error for Diverged {}

/// Adaptive Dormand–Prince 5(4) integration of the plant from `x` over `span` [s] with `u`
/// held, to the mixed tolerance `atol + rtol·|x|` per component. A cross-check of the RK4
/// plant (see the physics tests); returns the final state and the number of accepted steps.
pub fn dopri45(
    model: &Model<f64>,
    x: &State<f64>,
    u: &Vector4<f64>,
    span: f64,
    rtol: f64,
    atol: f64,
) -> Result<(State<f64>, usize), Diverged> {
    type V8 = nalgebra::SVector<f64, 8>;
    let pack = |s: &State<f64>| V8::from_iterator(s.q.iter().chain(s.qd.iter()).copied());
    let unpack = |v: &V8| State {
        q: v.fixed_rows::<4>(0).into_owned(),
        qd: v.fixed_rows::<4>(4).into_owned(),
    };
    let f = |v: &V8| -> Result<V8, Diverged> {
        let s = unpack(v);
        let a = model.acceleration(&s.q, &s.qd, u).ok_or(Diverged)?;
        Ok(V8::from_iterator(s.qd.iter().chain(a.iter()).copied()))
    };
    // Butcher tableau (the nodes c_i are not needed: the system is autonomous while u is held).
    const A: [&[f64]; 6] = [
        &[1.0 / 5.0],
        &[3.0 / 40.0, 9.0 / 40.0],
        &[44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0],
        &[
            19372.0 / 6561.0,
            -25360.0 / 2187.0,
            64448.0 / 6561.0,
            -212.0 / 729.0,
        ],
        &[
            9017.0 / 3168.0,
            -355.0 / 33.0,
            46732.0 / 5247.0,
            49.0 / 176.0,
            -5103.0 / 18656.0,
        ],
        &[
            35.0 / 384.0,
            0.0,
            500.0 / 1113.0,
            125.0 / 192.0,
            -2187.0 / 6784.0,
            11.0 / 84.0,
        ],
    ];
    // Error weights: 5th-order minus embedded 4th-order solution.
    const E: [f64; 7] = [
        71.0 / 57600.0,
        0.0,
        -71.0 / 16695.0,
        71.0 / 1920.0,
        -17253.0 / 339200.0,
        22.0 / 525.0,
        -1.0 / 40.0,
    ];
    let mut y = pack(x);
    let mut t = 0.0;
    let mut h = (span / 100.0).min(1e-3);
    let mut k1 = f(&y)?;
    let mut accepted = 0;
    while t < span {
        h = h.min(span - t);
        let mut k = [
            k1,
            V8::zeros(),
            V8::zeros(),
            V8::zeros(),
            V8::zeros(),
            V8::zeros(),
            V8::zeros(),
        ];
        for (i, row) in A.iter().enumerate() {
            let mut yi = y;
            for (j, a) in row.iter().enumerate() {
                yi += k[j] * (h * a);
            }
            k[i + 1] = f(&yi)?;
        }
        // Row 6 of A is the 5th-order solution (FSAL: k[6] = f(y_new)).
        let mut y_new = y;
        for (j, a) in A[5].iter().enumerate() {
            y_new += k[j] * (h * a);
        }
        let mut err = V8::zeros();
        for (j, e) in E.iter().enumerate() {
            err += k[j] * (h * e);
        }
        let norm = err
            .iter()
            .zip(y.iter().zip(y_new.iter()))
            .map(|(e, (a, b))| (e / (atol + rtol * a.abs().max(b.abs()))).powi(2))
            .sum::<f64>()
            .sqrt()
            / (8.0_f64).sqrt();
        if !norm.is_finite() {
            return Err(Diverged);
        }
        if norm <= 1.0 {
            t += h;
            y = y_new;
            k1 = k[6];
            accepted += 1;
        }
        let factor = if norm == 0.0 {
            5.0
        } else {
            0.9 * norm.powf(-0.2)
        };
        h *= factor.clamp(0.2, 5.0);
        if h < 1e-12 {
            return Err(Diverged);
        }
    }
    Ok((unpack(&y), accepted))
}

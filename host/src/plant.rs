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
use nalgebra::{Complex, DMatrix};

use crate::sim::SimError;

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
    /// The largest step [s] at which [`Self::step`]'s RK4 is stable on this plant: that of its
    /// mechanics linearized at rest over the poses of joint 2 ([`rk4_stable_step`],
    /// [`STABILITY_POSES`]), the joints damped by their viscous friction. Coarser, the fastest
    /// of its rates grows without bound.
    fn stable_step(&self) -> StableStep;
    /// A hammer's strike: an impulse `p` [N·s] across link 2 at its tip, counter-clockwise
    /// positive. The generalized impulse is `p (a1 cos θ2 + a2, a2, φ_1(a2) … φ_N(a2))` and the
    /// rates jump by `B(q)⁻¹` of it. `false` when the plant cannot take one (the controller's
    /// own model: [`ModelPlant`]).
    fn strike(&mut self, _p: f64) -> bool {
        false
    }
}

/// A plant's largest stable RK4 step and what sets it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StableStep {
    /// The step [s].
    pub dt: f64,
    /// The eigenvalue `λ` of the linearized plant that sets it [1/s].
    pub rate: Complex<f64>,
    /// The angle of joint 2 at which it is fastest [rad].
    pub theta2: f64,
}

/// Poses of joint 2 [rad] at which [`Plant::stable_step`] linearizes (the inertia depends on
/// `θ2` alone; `θ1` does not enter it).
pub const STABILITY_POSES: [f64; 5] = [
    0.0,
    core::f64::consts::FRAC_PI_4,
    core::f64::consts::FRAC_PI_2,
    3.0 * core::f64::consts::FRAC_PI_4,
    core::f64::consts::PI,
];

/// Refuses a configuration whose plant step is coarser than its plant's stable RK4 step
/// ([`Plant::stable_step`], the plant built at rest at `theta` [rad]), naming the step to give.
/// The commands check what a user gives (`run`, `paper`, a scenario's `plant_dt`); the
/// studies that run at the default step (0.1 ms, inside every plant's: 4.25e-4 s for the truth
/// plant's ten modes) do not pay for the eigenvalues every run.
pub fn check_step(cfg: &crate::sim::SimConfig, theta: Vector2<f64>) -> Result<(), SimError> {
    let stable = cfg.plant_at(theta)?.stable_step();
    match cfg.rates.plant_dt > stable.dt {
        true => Err(SimError::Input {
            key: "rates.plant_dt",
            msg: too_coarse(cfg.rates.plant_dt, &stable),
        }),
        false => Ok(()),
    }
}

/// Why a plant step `dt` [s] coarser than `stable` is refused, with the step to give.
fn too_coarse(dt: f64, stable: &StableStep) -> String {
    // Two significant digits, rounded down.
    let scale = 10f64.powf(stable.dt.log10().floor() - 1.0);
    let give = (stable.dt / scale).floor() * scale;
    let what = match stable.rate.im.abs() > stable.rate.re.abs() {
        true => format!(
            "its fastest mode ({:.0} Hz)",
            stable.rate.im.abs() / core::f64::consts::TAU
        ),
        false => format!("its fastest decay ({:.0} 1/s)", -stable.rate.re),
    };
    format!(
        "{dt:e} s is too coarse for this plant: {what} makes RK4 diverge above {:.3e} s; give --plant-dt (`rates.plant_dt`) {give:.1e} s or less",
        stable.dt
    )
}

/// RK4's amplification `R(z) = 1 + z + z²/2 + z³/6 + z⁴/24` over one step of `ẋ = λ x`,
/// `z = λ h`.
fn rk4_gain(z: Complex<f64>) -> f64 {
    (1.0 + z * (1.0 + z * (0.5 + z * (1.0 / 6.0 + z / 24.0)))).norm()
}

/// The largest step `h` [s] for which RK4 is stable on `ẋ = λ x` for every `λ` of `rates`
/// (`|R(λ h')| ≤ 1` for every `h' ≤ h`), and the `λ` that sets it. Rates of (numerically)
/// zero modulus (the rigid joints) set none; a positive real part is taken as zero (the
/// mechanics are passive). RK4's region lies within `|z| < 3`: 2.785 on the negative real
/// axis, `2√2` on the imaginary one.
pub fn rk4_stable_step(rates: &[Complex<f64>]) -> StableStep {
    let largest = rates.iter().map(|l| l.norm()).fold(0.0, f64::max);
    let mut out = StableStep {
        dt: f64::INFINITY,
        rate: Complex::new(0.0, 0.0),
        theta2: 0.0,
    };
    for l in rates.iter().filter(|l| l.norm() > 1e-9 * largest) {
        let l = Complex::new(l.re.min(0.0), l.im);
        // The first step along the ray at which |R| exceeds 1, scanned then bisected.
        let far = 3.0 / l.norm();
        let scan = 64;
        let Some(i) = (1..=scan).find(|i| rk4_gain(l * (far * *i as f64 / scan as f64)) > 1.0)
        else {
            continue;
        };
        let (mut lo, mut hi) = (
            far * (i - 1) as f64 / scan as f64,
            far * i as f64 / scan as f64,
        );
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if rk4_gain(l * mid) > 1.0 {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        if lo < out.dt {
            out = StableStep {
                dt: lo,
                rate: l,
                theta2: 0.0,
            };
        }
    }
    out
}

/// The eigenvalues `λ` of `B q̈ + C q̇ + K q = 0` (`C`, `K` diagonal): those of
/// `[[0, I], [−B⁻¹K, −B⁻¹C]]`. Empty when `B` is singular or the decomposition does not converge.
pub fn mechanical_rates(b: &DMatrix<f64>, c: &[f64], k: &[f64]) -> Vec<Complex<f64>> {
    let n = b.nrows();
    let Some(inv) = b.clone().try_inverse() else {
        return Vec::new();
    };
    let mut a = DMatrix::<f64>::zeros(2 * n, 2 * n);
    for i in 0..n {
        a[(i, n + i)] = 1.0;
        for j in 0..n {
            a[(n + i, j)] = -inv[(i, j)] * k[j];
            a[(n + i, n + j)] = -inv[(i, j)] * c[j];
        }
    }
    nalgebra::linalg::Schur::try_new(a, f64::EPSILON, 10_000)
        .map(|s| s.complex_eigenvalues().iter().copied().collect())
        .unwrap_or_default()
}

/// [`rk4_stable_step`] of the plant whose inertia at joint 2's angle `θ2` is `inertia(θ2)`,
/// over [`STABILITY_POSES`].
pub fn stable_step_over_poses(
    inertia: impl Fn(f64) -> DMatrix<f64>,
    c: &[f64],
    k: &[f64],
) -> StableStep {
    STABILITY_POSES
        .iter()
        .map(|&theta2| StableStep {
            theta2,
            ..rk4_stable_step(&mechanical_rates(&inertia(theta2), c, k))
        })
        .fold(rk4_stable_step(&[]), |a, b| if b.dt < a.dt { b } else { a })
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

    fn stable_step(&self) -> StableStep {
        let (k, d) = (self.model.modal_stiffness(), self.model.modal_damping());
        stable_step_over_poses(
            |t2| {
                let b = self.model.inertia(&Vector4::new(0.0, t2, 0.0, 0.0));
                DMatrix::from_iterator(4, 4, b.iter().copied())
            },
            &[0.0, 0.0, d.x, d.y],
            &[0.0, 0.0, k.x, k.y],
        )
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

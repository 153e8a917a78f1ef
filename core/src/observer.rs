//! State observer: estimates `q = (θ, δ)` and `q̇` from what a board measures, the two joint
//! encoders and the film voltage (`y = (θ1, θ2, V_f)`, `V_f = k_s Δφ'ᵀ δ`, Eq. 19).
//!
//! The paper assumes δ and δ̇ are measured; on a real arm they are not. This observer runs in
//! the motor loop at period `h`:
//!
//! - **correct**: `x̂ = x̂⁻ + L (y − C x̂⁻)`, `x = (q, q̇)`, `C = [[1,0,0,0,0…], [0,1,0,0,0…],
//!   [0,0,c_f1,c_f2,0…]]`, `c_f = k_s Δφ'`;
//! - **predict**: the full nonlinear model, `q̈ = B⁻¹(u − Cq̇ − K_e q − D q̇)` with the torques and
//!   the piezo force just applied, one semi-implicit Euler step (`q̇⁺ = q̇ + h q̈`,
//!   `q⁺ = q + h q̇⁺`), which keeps the undamped modes on their orbits for `ω h < 2`.
//!
//! The gain `L` (8×3) is the steady-state Kalman gain of that discrete model linearized at rest
//! at a nominal configuration ([`design`]), with white acceleration disturbances on the joints
//! and the modes and white measurement noise (encoder quantization, film-voltage noise).
//! `design` is `no_std` and allocation-free, but iterates the Riccati equation in `f64`: run it on
//! the host. `observer_gains.rs` holds the `f32` gains for the paper's patch, written by
//! `FLEXARM_BLESS=1 cargo test -p flexarm-core --test observer`, which also checks that the
//! checked-in gains are the design's. The firmware takes the gains designed for its own patch
//! from `firmware/src/generated.rs` (`cargo sim firmware-params`, `docs/firmware.md`).

use nalgebra::{SMatrix, SVector};

use crate::fault::Fault;
use crate::model::{Model, Terms};
use crate::real::{Real, all_finite};
use crate::{Vector2, Vector4};

/// The observer's gain `L`: 8 states `(q, q̇)` by 3 measurements `(θ1, θ2, V_f)`.
pub type Gain<T> = SMatrix<T, 8, 3>;

/// One sample of the sensors. Laid out as written (`repr(C)`: the bench's C comparison reads
/// it).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Measurement<T> {
    /// Encoder angles `(θ1, θ2)` [rad].
    pub theta: Vector2<T>,
    /// Film voltage `V_f` [V].
    pub v_f: T,
}

/// The steady-state observer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Observer<T> {
    q: Vector4<T>,
    qd: Vector4<T>,
    /// `Lᵀ`: each state's three gains side by side in memory.
    gain_t: SMatrix<T, 3, 8>,
    /// `c_f = k_s Δφ'` [V per √kg·m]: `V_f = c_fᵀ δ`.
    c_f: Vector2<T>,
    period: T,
}

impl<T: Real> Observer<T> {
    /// An observer with gain `gain` for the motor period `period` [s] and film map `c_f`,
    /// starting at rest at the encoder angles `theta` [rad], undeformed.
    pub fn new(gain: Gain<T>, c_f: Vector2<T>, period: T, theta: Vector2<T>) -> Self {
        let z = T::zero();
        Self {
            q: Vector4::new(theta.x, theta.y, z, z),
            qd: Vector4::zeros(),
            gain_t: gain.transpose(),
            c_f,
            period,
        }
    }

    /// `true` if the estimate, the gain, the film map and the period are all finite. The
    /// [`crate::controller::Controller`] checks it at construction and keeps it true: the
    /// correction then only adds finite terms (its samples are range-checked) and the
    /// prediction refuses a non-finite result.
    pub fn is_finite(&self) -> bool {
        let (q, qd) = (&self.q, &self.qd);
        all_finite([q.x, q.y, q.z, q.w, qd.x, qd.y, qd.z, qd.w])
            && self.gain_t.iter().all(|g| g.finite())
            && all_finite([self.c_f.x, self.c_f.y, self.period])
    }

    /// Estimated `(q, q̇)`.
    pub fn state(&self) -> (Vector4<T>, Vector4<T>) {
        (self.q, self.qd)
    }

    /// Measurement residual `y − C x̂` (innovation).
    pub fn residual(&self, y: &Measurement<T>) -> SVector<T, 3> {
        SVector::<T, 3>::new(
            y.theta.x - self.q.x,
            y.theta.y - self.q.y,
            y.v_f - self.c_f.dot(&Vector2::new(self.q.z, self.q.w)),
        )
    }

    /// Correction with the new measurement. A non-finite measurement is refused and leaves the
    /// estimate unchanged.
    pub fn correct(&mut self, y: &Measurement<T>) -> Result<(), Fault> {
        if !all_finite([y.theta.x, y.theta.y, y.v_f]) {
            return Err(Fault::NonFinite);
        }
        self.correct_finite(y);
        Ok(())
    }

    /// [`Self::correct`] for a measurement the caller has already checked to be finite (the
    /// controller's range check rejects NaN and ±∞).
    #[inline(always)]
    pub fn correct_finite(&mut self, y: &Measurement<T>) {
        let r = self.residual(y);
        let l = &self.gain_t;
        // x̂ += L r, row by row (no temporary 8-vector).
        let row = |i: usize| l[(0, i)] * r.x + l[(1, i)] * r.y + l[(2, i)] * r.z;
        self.q += Vector4::new(row(0), row(1), row(2), row(3));
        self.qd += Vector4::new(row(4), row(5), row(6), row(7));
    }

    /// Prediction over one period with the generalized force `u` just applied (joint torques
    /// and the piezo's modal force).
    pub fn predict(&mut self, model: &Model<T>, u: &Vector4<T>) -> Result<(), Fault> {
        self.predict_with(model, &model.terms(&self.q), u)
    }

    /// [`Self::predict`] with the terms of `B(q̂)` already computed (the motor law used them at
    /// the same estimate).
    #[inline(always)]
    pub fn predict_with(
        &mut self,
        model: &Model<T>,
        terms: &Terms<T>,
        u: &Vector4<T>,
    ) -> Result<(), Fault> {
        let qdd = model
            .acceleration_with(terms, &self.q, &self.qd, u)
            .ok_or(Fault::Singular)?;
        let qd = self.qd + qdd * self.period;
        let q = self.q + qd * self.period;
        if all_finite([q.x, q.y, q.z, q.w, qd.x, qd.y, qd.z, qd.w]) {
            self.q = q;
            self.qd = qd;
            Ok(())
        } else {
            Err(Fault::Singular)
        }
    }

    /// Moves the joint angles' estimate by `delta` [rad], the speeds and the modes as they
    /// are: the encoders' frame changed (homing, `crate::homing`), not the motion.
    pub fn shift(&mut self, delta: Vector2<T>) {
        self.q.x += delta.x;
        self.q.y += delta.y;
    }

    /// Restarts at rest at `theta` [rad] (after a fault reset).
    pub fn reset(&mut self, theta: Vector2<T>) {
        *self = Self::new(self.gain_t.transpose(), self.c_f, self.period, theta);
    }
}

/// Disturbance and noise levels the gain is designed for (standard deviations).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseModel {
    /// Unmodelled joint acceleration (friction, torque ripple) [rad/s²].
    pub accel_joint: f64,
    /// Unmodelled modal acceleration [√kg·m/s²].
    pub accel_modal: f64,
    /// Encoder noise; quantization of `n` counts per revolution gives `2π/n/√12` [rad].
    pub encoder: f64,
    /// Film-voltage noise [V].
    pub film: f64,
}

impl Default for NoiseModel {
    /// 0.5 rad/s² on the joints, 0.5 √kg·m/s² on the modes, a 16384-count encoder
    /// (1.1e-4 rad), 10 mV on the film.
    fn default() -> Self {
        Self {
            accel_joint: 0.5,
            accel_modal: 0.5,
            encoder: core::f64::consts::TAU / 16384.0 / libm::sqrt(12.0),
            film: 0.01,
        }
    }
}

/// Why [`design`] failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DesignError {
    /// The inertia matrix at the nominal configuration could not be factored.
    Singular,
    /// The Riccati iteration did not converge.
    NoConvergence,
}

/// The discrete model of the observer linearized at rest at `theta` [rad]: `x⁺ = A x`,
/// `y = C x`.
pub fn linearization(
    model: &Model<f64>,
    c_f: &Vector2<f64>,
    theta: &Vector2<f64>,
    period: f64,
) -> Result<(SMatrix<f64, 8, 8>, SMatrix<f64, 3, 8>), DesignError> {
    let q0 = Vector4::new(theta.x, theta.y, 0.0, 0.0);
    let b_inv = model
        .inertia(&q0)
        .try_inverse()
        .ok_or(DesignError::Singular)?;
    let k = model.modal_stiffness();
    let d = model.modal_damping();
    let m = -b_inv * nalgebra::Matrix4::from_diagonal(&Vector4::new(0.0, 0.0, k.x, k.y));
    let n = -b_inv * nalgebra::Matrix4::from_diagonal(&Vector4::new(0.0, 0.0, d.x, d.y));
    let i4 = nalgebra::Matrix4::<f64>::identity();
    let h = period;
    // q̇⁺ = q̇ + h(Mq + Nq̇);  q⁺ = q + h q̇⁺.
    let mut a = SMatrix::<f64, 8, 8>::zeros();
    a.fixed_view_mut::<4, 4>(0, 0)
        .copy_from(&(i4 + m * (h * h)));
    a.fixed_view_mut::<4, 4>(0, 4)
        .copy_from(&(i4 * h + n * (h * h)));
    a.fixed_view_mut::<4, 4>(4, 0).copy_from(&(m * h));
    a.fixed_view_mut::<4, 4>(4, 4).copy_from(&(i4 + n * h));
    #[rustfmt::skip]
    let c = SMatrix::<f64, 3, 8>::from_row_slice(&[
        1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
        0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
        0.0, 0.0, c_f.x, c_f.y, 0.0, 0.0, 0.0, 0.0,
    ]);
    Ok((a, c))
}

/// Steady-state Kalman gain (filter form, `x̂ = x̂⁻ + L(y − Cx̂⁻)`) of the observer's model
/// linearized at rest at `theta` [rad], for the motor period `period` [s].
pub fn design(
    model: &Model<f64>,
    c_f: &Vector2<f64>,
    theta: &Vector2<f64>,
    period: f64,
    noise: &NoiseModel,
) -> Result<Gain<f64>, DesignError> {
    let (a, c) = linearization(model, c_f, theta, period)?;
    // Acceleration disturbances enter as q̇ += h w, q += h² w.
    let h = period;
    let g = SMatrix::<f64, 8, 4>::from_fn(|i, j| {
        let s = if j < 2 {
            noise.accel_joint
        } else {
            noise.accel_modal
        };
        if i == j {
            h * h * s
        } else if i == j + 4 {
            h * s
        } else {
            0.0
        }
    });
    let q = g * g.transpose();
    let r = SMatrix::<f64, 3, 3>::from_diagonal(&nalgebra::Vector3::new(
        noise.encoder * noise.encoder,
        noise.encoder * noise.encoder,
        noise.film * noise.film,
    ));
    let mut p = q;
    let mut gain = Gain::<f64>::zeros();
    for _ in 0..200_000 {
        let p_prior = a * p * a.transpose() + q;
        let s = c * p_prior * c.transpose() + r;
        let s_inv = s.try_inverse().ok_or(DesignError::Singular)?;
        let next_gain = p_prior * c.transpose() * s_inv;
        let next_p = (SMatrix::<f64, 8, 8>::identity() - next_gain * c) * p_prior;
        let change = (next_gain - gain).abs().max();
        gain = next_gain;
        p = (next_p + next_p.transpose()) * 0.5;
        if change <= 1e-13 * gain.abs().max() {
            return Ok(gain);
        }
    }
    Err(DesignError::NoConvergence)
}

/// The film map `c_f = k_s Δφ'` of a patch [V per √kg·m].
pub fn film_map<T: Real>(patch: &crate::control::piezo::PiezoPatch<T>) -> Vector2<T> {
    patch.slope_diff * patch.k_s
}

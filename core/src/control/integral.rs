//! Integral action for the joints (issue 35, "joints that settle"), beside Eq. 7 / Eq. 16.
//!
//! Coulomb friction holds a joint where Eq. 7's restoring torque `K_p Λ θ̃` stops overcoming
//! it: 1.6 mrad on the truth plant's joint 2 (docs/results.md). The integral acts through the
//! reference, so Eq. 7 itself is unchanged: the law tracks the shifted target
//!
//! `θ_d' = θ_d − K_i z`, `θ̇_d' = θ̇_d − K_i ż`, `θ̈_d' = θ̈_d − K_i z̈`, with `ż = θ̃ = θ − θ_d`,
//!
//! so its reference error becomes `s' = θ̃̇ + (Λ + K_i) θ̃ + Λ K_i z` and `s' → 0` gives
//! `(p + Λ)(p + K_i) θ̃ = 0` for any constant disturbance, which `z` absorbs: the joint settles
//! on its reference. (`z̈ = θ̃̇` is the estimate's.) Anti-windup: `z` stops growing while the
//! joint's torque is at its limit and pushing the same way, and `|K_i z|` stays within
//! `integral_limit` [rad] (through the restoring gain, at most `K_p Λ · integral_limit` of
//! torque: 0.28 N·m on joint 2 with the paper's gains at the default 0.02 rad). The modal rows
//! have no integral.
//!
//! Units SI: rad, s; joint frames of `crate::model`.

use crate::Vector2;
use crate::limits::saturate;
use crate::params::Gains;
use crate::real::Real;
use crate::trajectory::JointTarget;

/// The integral state `z = ∫ θ̃ dt` per joint [rad·s].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Integral<T> {
    z: Vector2<T>,
    /// The error this period's [`Self::finish`] integrates, set by [`Self::prepare`] [rad].
    pending: Vector2<T>,
}

impl<T: Real> Default for Integral<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real> Integral<T> {
    /// No integral yet.
    pub fn new() -> Self {
        Self {
            z: Vector2::zeros(),
            pending: Vector2::zeros(),
        }
    }

    /// Forgets it (a new arm, a reset).
    pub fn reset(&mut self) {
        *self = Self::new();
    }

    /// The integral's share of the reference, `K_i z` [rad]: the law's error `θ − θ_d'` less
    /// it is the joint's `θ − θ_d`.
    fn offset(&self, gains: &Gains<T>) -> Vector2<T> {
        gains.ki.component_mul(&self.z)
    }

    /// The target the law tracks (module docs) for the joints' estimate `θ` [rad], `θ̇`
    /// [rad/s]: `target` itself when `K_i = 0`.
    fn shift(
        &self,
        gains: &Gains<T>,
        target: &JointTarget<T>,
        theta: Vector2<T>,
        theta_dot: Vector2<T>,
    ) -> JointTarget<T> {
        let k = gains.ki;
        JointTarget {
            q: target.q - k.component_mul(&self.z),
            qd: target.qd - k.component_mul(&(theta - target.q)),
            qdd: target.qdd - k.component_mul(&(theta_dot - target.qd)),
        }
    }

    /// One period, before the law: the target it tracks ([`Self::shift`]) for the estimate
    /// `θ`, `θ̇`, and the error the period integrates, the encoders' `measured − θ_d` when a
    /// sample came (the estimate carries the friction the observer's model lacks as a bias,
    /// 3.4e-4 rad on the truth plant; the encoders do not), else the estimate's.
    pub fn prepare(
        &mut self,
        gains: &Gains<T>,
        target: &JointTarget<T>,
        (theta, theta_dot): (Vector2<T>, Vector2<T>),
        measured: Option<Vector2<T>>,
    ) -> JointTarget<T> {
        self.pending = measured.unwrap_or(theta) - target.q;
        self.shift(gains, target, theta, theta_dot)
    }

    /// One period, after the law: takes the law's error `θ − θ_d'` back to `θ − θ_d` and
    /// integrates the prepared error over `dt` [s] with the torques commanded `tau` against
    /// their limits `tau_max` [N·m] ([`Self::update`]).
    pub fn finish(
        &mut self,
        gains: &Gains<T>,
        error: &mut Vector2<T>,
        (tau, tau_max): (Vector2<T>, Vector2<T>),
        dt: T,
    ) {
        *error -= self.offset(gains);
        let e = self.pending;
        self.update(gains, e, tau, tau_max, dt);
    }

    /// Integrates one period `dt` [s] of the joint error `error = θ − θ_d` [rad] with the
    /// torques commanded `tau` against their limits `tau_max` [N·m] (module docs).
    fn update(
        &mut self,
        gains: &Gains<T>,
        error: Vector2<T>,
        tau: Vector2<T>,
        tau_max: Vector2<T>,
        dt: T,
    ) {
        for j in 0..2 {
            let pick = |v: &Vector2<T>| if j == 0 { v.x } else { v.y };
            let (k, e, t, limit) = (
                pick(&gains.ki),
                pick(&error),
                pick(&tau),
                pick(&gains.integral_limit),
            );
            // Saturated and pushing the way the error asks (a joint behind its reference, θ̃ <
            // 0, is pushed with τ > 0): more integral would only wind up.
            let winding = t.abs() >= pick(&tau_max) && e * t < T::zero();
            let z = if j == 0 { &mut self.z.x } else { &mut self.z.y };
            if k <= T::zero() || winding {
                continue;
            }
            // `|K_i z| ≤ integral_limit` by the actuators' saturation (compares, where `max`
            // and `min` are calls to `fmaxf`/`fminf` on the Cortex-M4F; a NaN, which no path
            // makes, gives 0).
            *z = saturate(*z + e * dt, limit / k);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A joint held off its reference (joint 1 behind, joint 2 ahead) with torques inside their
    /// limits: `z` grows by `θ̃ dt` a period until `|K_i z|` reaches `integral_limit`, and stays
    /// there, exactly, with the error's sign.
    #[test]
    fn integral_grows_by_the_error_then_stops_at_its_bound() {
        let gains = Gains::<f32> {
            ki: Vector2::new(5.0, 2.0),
            integral_limit: Vector2::new(0.02, 0.01),
            ..Default::default()
        };
        let target = JointTarget::rest(Vector2::new(0.5, -0.25));
        let error = Vector2::new(-0.01, 0.03);
        let theta = target.q + error;
        let (dt, tau, tau_max) = (1e-3, Vector2::new(1.0, -1.0), Vector2::new(10.0, 10.0));
        let mut integral = Integral::new();
        let step = |i: &mut Integral<f32>| {
            i.prepare(&gains, &target, (theta, Vector2::zeros()), Some(theta));
            let mut law_error = theta - target.q + i.offset(&gains);
            i.finish(&gains, &mut law_error, (tau, tau_max), dt);
            // The law's error taken back to θ − θ_d.
            assert!((law_error - error).abs().max() < 1e-6);
        };
        step(&mut integral);
        assert!((integral.z - error * dt).abs().max() < 1e-9);
        for _ in 0..2000 {
            step(&mut integral);
        }
        let bound = gains.integral_limit.component_div(&gains.ki);
        assert_eq!(integral.z, Vector2::new(-bound.x, bound.y));
    }

    /// Saturated and pushing the way the error asks: no more integral (anti-windup).
    #[test]
    fn a_saturated_joint_does_not_wind_up() {
        let gains = Gains::<f32> {
            ki: Vector2::new(5.0, 5.0),
            ..Default::default()
        };
        let target = JointTarget::rest(Vector2::zeros());
        // Joint 1 behind (θ̃ < 0) pushed with +τ_max; joint 2 behind pushed against.
        let theta = Vector2::new(-0.01, -0.01);
        let tau_max = Vector2::new(2.0, 2.0);
        let mut integral = Integral::new();
        integral.prepare(&gains, &target, (theta, Vector2::zeros()), Some(theta));
        let mut law_error = theta;
        integral.finish(
            &gains,
            &mut law_error,
            (Vector2::new(2.0, -2.0), tau_max),
            1e-3,
        );
        assert_eq!(integral.z.x, 0.0);
        assert!(integral.z.y < 0.0);
    }
}

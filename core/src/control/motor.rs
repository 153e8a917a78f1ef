//! The complete motor step shared by the firmware and the simulator: checks, Eq. 7 or Eq. 16,
//! saturation.

use crate::control::robust::{joint_torque_for_modal_accel, modal_damping_accel};
use crate::control::tracking::{Reference, eq7_joints};
use crate::fault::Fault;
use crate::limits::saturate2;
use crate::model::{Model, Terms};
use crate::params::{Gains, Limits};
use crate::real::{Real, all_finite};
use crate::trajectory::JointTarget;
use crate::{Vector2, Vector4};

/// Which motor law runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum MotorLaw {
    /// Eq. 7 alone.
    #[default]
    Tracking,
    /// Eq. 16: Eq. 7 plus the robust modal damping of Eq. 11, realized through the joints.
    Robust,
}

/// What the motor step returns besides the torques.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorOutput<T> {
    /// Saturated motor torques `τ` [N·m].
    pub tau: Vector2<T>,
    /// Joint tracking error `θ − θ_d` [rad].
    pub error: Vector2<T>,
}

/// The motor controller: model, gains and limits, no other state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorController<T> {
    /// The model used for compensation.
    pub model: Model<T>,
    /// Gains of Eqs. 7 and 11.
    pub gains: Gains<T>,
    /// Actuator limits.
    pub limits: Limits<T>,
    /// Eq. 7 or Eq. 16.
    pub law: MotorLaw,
}

impl<T: Real> MotorController<T> {
    /// One motor step at time `t` [s] for the state `(q, q̇)` (measured or estimated).
    /// A non-finite input is a [`Fault::NonFinite`]; the caller then applies the safe state.
    pub fn step(
        &self,
        t: T,
        q: &Vector4<T>,
        qd: &Vector4<T>,
        target: &JointTarget<T>,
    ) -> Result<MotorOutput<T>, Fault> {
        if !all_finite([t, q.x, q.y, q.z, q.w, qd.x, qd.y, qd.z, qd.w]) {
            return Err(Fault::NonFinite);
        }
        self.law_with(&self.model.terms(q), t, q, qd, target)
    }

    /// The law of [`Self::step`] with the terms of `B(q)` already computed (shared with the
    /// observer), for a time and a state the caller already knows to be finite (the
    /// [`crate::controller::Controller`] keeps its estimate finite). A torque that is not
    /// finite all the same (an overflow) is a [`Fault::Singular`].
    #[inline(always)]
    pub fn law_with(
        &self,
        terms: &Terms<T>,
        t: T,
        q: &Vector4<T>,
        qd: &Vector4<T>,
        target: &JointTarget<T>,
    ) -> Result<MotorOutput<T>, Fault> {
        let r = Reference::new(&self.gains.lambda, q, qd, target);
        let mut tau = eq7_joints(terms, qd, &self.gains.kp, &r);
        if self.law == MotorLaw::Robust {
            let a = modal_damping_accel(
                &self.gains,
                t,
                &Vector2::new(qd.z, qd.w),
                &Vector2::new(r.s.z, r.s.w),
            );
            tau += joint_torque_for_modal_accel(terms, &a, self.gains.mu);
        }
        if !all_finite([tau.x, tau.y]) {
            crate::hint::cold();
            return Err(Fault::Singular);
        }
        Ok(MotorOutput {
            tau: saturate2(&tau, &self.limits.tau_max),
            error: Vector2::new(r.q_tilde.x, r.q_tilde.y),
        })
    }
}

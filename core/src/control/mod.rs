//! Control laws. Each is a pure function or a small struct with explicit state.
//!
//! - [`tracking`]: passivity-based tracking with dynamics compensation (Eq. 7).
//! - [`robust`]: robust modal damping (Eqs. 11, 16) and how its modal force reaches the motors.
//! - [`piezo`]: the piezo patch (Eqs. 17–19) and its rate-feedback law.
//! - [`motor`]: the complete motor step the firmware and the simulator both call.
//! - Piezo laws beside the paper's, robust to the film's feedthrough and to the modes the
//!   controller does not know (issue 35; which one runs: [`select`]): [`ppf`] (positive
//!   position feedback), [`irc`] (integral resonant control), [`cancel`] (rate feedback with the
//!   identified feedthrough subtracted); [`linear`] has what they share (their linear form and
//!   the identified loop their design rules start from).
//!
//! Underactuation: the laws produce a generalized force over all four coordinates, but the
//! motors act on the joint rows only (`u = [τ, 0]`, Eq. 6). The joint rows of Eq. 7 become the
//! motor torques; the modal rows of Eq. 7 are not applied (no actuator acts on them). The robust
//! term, written by the paper into the modal rows, is realized through the joints
//! ([`robust::joint_torque_for_modal_accel`]); the piezo patch adds its own modal force
//! `C_a V_a`.

pub mod cancel;
pub mod integral;
pub mod irc;
pub mod linear;
pub mod motor;
pub mod piezo;
pub mod ppf;
pub mod robust;
pub mod select;
pub mod tracking;

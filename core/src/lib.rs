//! # flexarm-core
//!
//! The model and every control law of a planar two-link arm whose second link is flexible,
//! driven by two joint motors and a piezoceramic patch, after Bottega, Pergher and Fonseca,
//! *Simultaneous control and piezoelectric insert optimization for manipulators with flexible
//! link*. `docs/model.md` at the repository root says, equation by equation, what the paper
//! prints, what this crate implements and why.
//!
//! ## Conventions (the whole crate)
//! - SI units everywhere: m, kg, s, rad, N·m, V.
//! - Generalized coordinates `q = (θ1, θ2, δ1, δ2)`: θ1 is the absolute angle of link 1 from
//!   the base x axis, θ2 the angle of link 2 relative to link 1 (both counter-clockwise
//!   positive); δ1, δ2 are the modal coordinates of link 2 in units of √kg·m (the mode shapes
//!   are normalized to unit modal mass, so `φ_j(x) δ_j` is a deflection in metres).
//! - The base frame is fixed at joint 1, x along θ1 = 0, y such that z points up out of the
//!   plane. Gravity is ignored (the arm moves in a horizontal plane), as in the paper.
//! - The model is generic over [`Real`] (`f32` on the controller, `f64` in the simulator's
//!   plant), and every transcendental function goes through `libm`, so both sides compute the
//!   same bits for the same type.
//!
//! No heap, no panics on the control path: errors are values ([`Fault`], [`ParamError`],
//! [`TrajectoryError`]).
#![no_std]
// No panics on the control path: errors are values.
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

pub mod brake;
pub mod control;
pub mod controller;
pub mod drive;
pub mod fastmath;
pub mod fault;
mod hint;
pub mod homing;
pub mod indices;
pub mod kinematics;
pub mod limits;
pub mod model;
pub mod modes;
pub mod motion;
pub mod observer;
pub mod observer_gains;
pub mod params;
pub mod plant;
pub mod real;
pub mod recorder;
pub mod retained;
pub mod simarm;
pub mod supervisor;
pub mod time;
pub mod trajectory;
pub mod tuning;

pub use fault::Fault;
pub use params::{ArmParams, ParamError};
pub use real::Real;
pub use trajectory::TrajectoryError;

/// Generalized coordinates or velocities `(θ1, θ2, δ1, δ2)`.
pub type Vector4<T> = nalgebra::Vector4<T>;
/// Joint-space 2-vector `(θ1, θ2)` or modal 2-vector `(δ1, δ2)`.
pub type Vector2<T> = nalgebra::Vector2<T>;
/// 4×4 matrix over the generalized coordinates.
pub type Matrix4<T> = nalgebra::Matrix4<T>;
/// 2×2 matrix over the joints or the modes.
pub type Matrix2<T> = nalgebra::Matrix2<T>;

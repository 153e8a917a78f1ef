//! # flexarm-machine
//!
//! What a flexarm board does every period, once, for every board: the firmware's RTIC tasks
//! lock their resources and call these functions; the host's rig (`flexarm_host::rig`) calls
//! the same functions in the same order on a simulated board. `no_std`, `f32`, no heap, no
//! `unsafe`; what stays in the firmware is the hardware: registers, clocks, the USART, the
//! emergency paths, the stack and the fault injection.
//!
//! - [`board`]: the [`Board`] trait, the arm's I/O;
//! - [`config`]: [`BoardConfig`], every number a board boots with, and its hash;
//! - [`period`]: the phases of a piezo and a motor period, each over the resources it needs;
//! - [`telemetry`]: the motor loop's record and the stream's channels;
//! - [`session`]: the command link's session and its conversions between the link's
//!   messages and the core's types;
//! - [`store`]: the settings saved on the board (issue 36), over a NOR flash;
//! - [`simulated`]: the QEMU board's simulated arm, which the host's rig runs too.
//!
//! Units SI and frames as in `flexarm_core`; ticks in motor periods.
#![no_std]
// No panics on the control path: errors are values.
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

pub mod board;
pub mod config;
pub mod period;
pub mod session;
pub mod simulated;
pub mod store;
pub mod telemetry;

pub use board::Board;
pub use config::BoardConfig;
pub use period::{Control, MotorLoop, Period};
pub use session::Session;
pub use telemetry::Record;

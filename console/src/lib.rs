//! # flexarm-console
//!
//! The operator's side of the command link (`flexarm-link`, docs/link.md): a [`Client`] that
//! speaks to a board over a serial port or to the QEMU firmware over its TCP socket, and the
//! `flexarm` command-line tool built on it (`src/main.rs`, docs/console.md).
//!
//! Every failure is a [`ConsoleError`] whose `Display` is one line naming what failed and
//! where; the tool prints it and exits with status 1. Nothing here panics on what the line
//! brings: a peer that is not our firmware, a firmware of another protocol version, silence,
//! and frames that fail their CRC are errors, not crashes.
//!
//! Units are the link's (SI; angles in rad, torques in N·m, voltages in V, times in s).

pub mod bringup;
pub mod check;
pub mod client;
pub mod config;
pub mod home;
pub mod identify;
pub mod interrupt;
pub mod live;
pub mod params;
pub mod qemu;
pub mod record;
pub mod shell;
pub mod transport;
pub mod tree;
pub mod waypoints;

pub use client::{Client, ConsoleError};

/// A fault's name from its stable number (docs/safety.md).
pub fn fault_name(code: u8) -> &'static str {
    flexarm_core::Fault::from_code(code)
        .map_or("unknown to this console", flexarm_core::Fault::as_str)
}

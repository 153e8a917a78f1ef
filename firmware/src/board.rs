//! The boards: the hardware's registers (`hw`) and the QEMU board's simulated arm (`sim`), each
//! behind `flexarm_machine::Board` (the arm's I/O, the trait the control tasks call), and how
//! the arm is wired to them ([`wiring`]). Digital lines go through `embedded-hal` 1.0 pin traits.

#[cfg(any(feature = "hw", feature = "inject-no-crystal"))]
#[allow(unsafe_code)]
pub mod clocks;
#[cfg(feature = "hw")]
#[allow(unsafe_code)]
pub mod hw;
#[cfg(any(feature = "hw", feature = "inject-no-crystal"))]
pub mod pll;
#[cfg(feature = "hw")]
#[allow(unsafe_code)]
mod pre_init;
#[cfg(feature = "qemu")]
pub mod sim;

/// How the arm is wired to the board: what `flexarm bringup` checks (docs/console.md) and, when
/// a check fails, names the line to change here. Both boards apply these to their readings: the
/// hardware's encoders and ADC, and the QEMU board's simulated ones (so a QEMU test build of a
/// miswired arm is put right here too).
pub mod wiring {
    /// Per axis, `true` reverses the encoder's counting direction (on the hardware board the
    /// timer's input polarity), for an encoder mounted or wired the other way round: angles
    /// must grow counter-clockwise.
    pub const ENCODER_REVERSED: [bool; 2] = [false, false];
    /// Encoder counts per joint revolution, per axis (4096-line encoders, ×4 quadrature; an
    /// encoder on the motor side of a gear counts the gear ratio times more).
    pub const COUNTS_PER_REV: [f32; 2] = [16384.0, 16384.0];
    /// `true` when the film's charge amplifier inverts: the film voltage the controller sees
    /// must rise when the patch's voltage rises (`docs/console.md`, bring-up).
    pub const FILM_INVERTED: bool = false;
}

pub use flexarm_machine::Board;

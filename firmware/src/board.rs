//! The board: everything the control tasks read and write, behind one small trait, so that the
//! tasks never touch a register. Digital lines go through `embedded-hal` 1.0 pin traits.
//!
//! Units: angles in rad, film voltage in V (at the sensor, before any gain), torques in N·m,
//! piezo command in V (at the amplifier's output).

use flexarm_core::Vector2;

#[cfg(any(feature = "hw", feature = "inject-no-crystal"))]
pub mod clocks;
#[cfg(feature = "hw")]
pub mod hw;
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

/// The I/O of the arm.
pub trait Board {
    /// Joint angles from the encoders [rad].
    fn encoders(&mut self) -> Vector2<f32>;
    /// Film voltage [V], sampled for the piezo loop.
    fn film_voltage(&mut self) -> f32;
    /// Film voltage [V] for the motor loop: the hardware board's latest piezo-loop sample (one
    /// converter, one sampling instant); the simulated board reads its plant now.
    fn latest_film_voltage(&mut self) -> f32 {
        self.film_voltage()
    }
    /// Motor torque commands [N·m].
    fn set_torques(&mut self, tau: Vector2<f32>);
    /// Piezo amplifier command [V].
    fn set_piezo(&mut self, v_a: f32);
    /// Amplifier enable line (all three amplifiers).
    fn set_enable(&mut self, on: bool);
    /// `true` while an amplifier reports a fault.
    fn amplifier_fault(&mut self) -> bool;
    /// Called once per piezo period after the outputs are written: the simulated board
    /// advances its plant here; a real board does nothing.
    fn tick(&mut self) {}
    /// Called once per motor period with the time `t` [s] since the boot move's start: the
    /// QEMU board's verdict runs measure the plant against the move here (`crate::verdict`);
    /// a real board does nothing.
    fn motor_period(&mut self, _t: f32) {}
}

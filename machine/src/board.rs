//! The board: everything the control loops read and write, behind one small trait, so that
//! the loops never touch a register. The firmware's boards implement it (the hardware's
//! registers, the QEMU board's simulated arm), and so do the host's (`flexarm_host::rig`: a
//! simulated plant with its sensors).
//!
//! Units: angles in rad, film voltage in V (at the sensor, before any gain), torques in N·m,
//! piezo command in V (at the amplifier's output).

use flexarm_core::Vector2;
use flexarm_core::homing::Inputs;

/// The I/O of the arm.
pub trait Board {
    /// Joint angles from the encoders [rad].
    fn encoders(&mut self) -> Vector2<f32>;
    /// Film voltage [V], sampled for the piezo loop.
    fn film_voltage(&mut self) -> f32;
    /// Film voltage [V] for the motor loop: the hardware board's latest piezo-loop sample (one
    /// converter, one sampling instant); a simulated board reads its plant now.
    fn latest_film_voltage(&mut self) -> f32 {
        self.film_voltage()
    }
    /// Motor torque commands [N·m].
    fn set_torques(&mut self, tau: Vector2<f32>);
    /// Piezo amplifier command [V].
    fn set_piezo(&mut self, v_a: f32);
    /// Amplifier enable line (all three amplifiers).
    fn set_enable(&mut self, on: bool);
    /// The joints' holding brakes (safe brake control, issue 33): `true` engages them. A
    /// fail-safe brake holds unless its release line is driven, so every path that cuts the
    /// amplifiers engages it too, and it is released only while the amplifiers are enabled
    /// (`crate::period::actuate`).
    fn set_brake(&mut self, engaged: bool);
    /// The brake output as last written (`true`: engaged), read back from the output for the
    /// link's status.
    fn brake_engaged(&mut self) -> bool;
    /// `true` while an amplifier reports a fault.
    fn amplifier_fault(&mut self) -> bool;
    /// The homing inputs (issue 33, `flexarm_core::homing`): per joint, the encoder reading
    /// [rad] latched at an index pulse (or a limit switch's edge) since the last call, NaN
    /// when none came. A board without them returns none.
    fn homing_inputs(&mut self) -> Inputs<f32> {
        Inputs::default()
    }
    /// Called once per piezo period after the outputs are written: a simulated board advances
    /// its plant here; a real board does nothing.
    fn tick(&mut self) {}
    /// Called once per motor period with the time `t` [s] since the boot move's start: the
    /// QEMU board's verdict runs measure the plant against the move here; a real board does
    /// nothing.
    fn motor_period(&mut self, _t: f32) {}
}

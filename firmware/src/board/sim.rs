//! The QEMU board: the arm simulated inside the firmware (the core's model in `f32`, RK4, one
//! step per piezo period), with quantized encoders and film ADC. Its enable and fault lines are
//! in-memory `embedded-hal` pins, so the same pin logic runs as on hardware.

use core::convert::Infallible;

use embedded_hal::digital::{ErrorType, InputPin, OutputPin};
use flexarm_core::Vector2;
use flexarm_core::simarm::SimArm;

use super::Board;

/// A pin that lives in memory.
#[derive(Default)]
pub struct SimPin(bool);

impl ErrorType for SimPin {
    type Error = Infallible;
}

impl OutputPin for SimPin {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.0 = false;
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Infallible> {
        self.0 = true;
        Ok(())
    }
}

impl InputPin for SimPin {
    fn is_high(&mut self) -> Result<bool, Infallible> {
        Ok(self.0)
    }
    fn is_low(&mut self) -> Result<bool, Infallible> {
        Ok(!self.0)
    }
}

/// The simulated arm and its lines.
pub struct SimBoard {
    /// The plant and its sensors.
    pub arm: SimArm<f32>,
    /// Plant step: one piezo period [s].
    pub dt: f32,
    enable: SimPin,
    /// Amplifier fault line, active low (high = healthy).
    fault_n: SimPin,
    /// Set when the plant left its domain (a failed run).
    pub diverged: bool,
}

impl SimBoard {
    /// A board around `arm`, stepped every `dt` [s].
    pub fn new(arm: SimArm<f32>, dt: f32) -> Self {
        Self {
            arm,
            dt,
            enable: SimPin(false),
            fault_n: SimPin(true),
            diverged: false,
        }
    }
}

impl Board for SimBoard {
    fn encoders(&mut self) -> Vector2<f32> {
        self.arm.encoders()
    }
    fn film_voltage(&mut self) -> f32 {
        self.arm.film_voltage()
    }
    fn set_torques(&mut self, tau: Vector2<f32>) {
        self.arm.set_torques(tau);
    }
    fn set_piezo(&mut self, v_a: f32) {
        self.arm.set_piezo(v_a);
    }
    fn set_enable(&mut self, on: bool) {
        let Ok(()) = if on {
            self.enable.set_high()
        } else {
            self.enable.set_low()
        };
        let Ok(level) = self.enable.is_high();
        self.arm.set_enable(level);
    }
    fn amplifier_fault(&mut self) -> bool {
        let Ok(low) = self.fault_n.is_low();
        low
    }
    fn tick(&mut self) {
        if !self.arm.step(self.dt) {
            self.diverged = true;
        }
    }
}

//! The QEMU board's arm: the core's simulated arm (`flexarm_core::simarm::SimArm`, in `f32`:
//! RK4 with held inputs, quantized encoders and film ADC) stepped one piezo period at a time,
//! its joints braking while the amplifiers are off. The QEMU firmware's board runs it (adding
//! its wiring, its test builds' injections and its clock); the host's rig runs the same code
//! as a [`Board`] of its own, so a host run of "the QEMU board" is the firmware's arithmetic.
//!
//! Units SI; the plant's state in the core's coordinates `q = (θ1, θ2, δ1, δ2)`.

use flexarm_core::control::piezo::PiezoPatch;
use flexarm_core::model::Model;
use flexarm_core::params::ArmParams;
use flexarm_core::simarm::{SensorModel, SimArm};
use flexarm_core::{Vector2, Vector4};

use crate::board::Board;

/// Time constant of the joints' brakes while the amplifiers are off [s].
pub const BRAKE_TAU: f32 = 0.05;

/// The simulated arm and its step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimulatedArm {
    /// The plant and its sensors.
    pub arm: SimArm<f32>,
    /// Plant step: one piezo period [s].
    pub dt: f32,
    /// Set when the plant left its domain (the state then stays where it was).
    pub diverged: bool,
}

impl SimulatedArm {
    /// `arm`, stepped every `dt` [s].
    pub const fn new(arm: SimArm<f32>, dt: f32) -> Self {
        Self {
            arm,
            dt,
            diverged: false,
        }
    }

    /// The QEMU board's arm: the paper's (`ArmParams::default()`) whatever model the controller
    /// runs, carrying `patch`, at rest at `q`, with the core's sensors (`SensorModel::default()`),
    /// stepped every `dt` [s], amplifiers off.
    #[inline]
    pub fn paper(patch: PiezoPatch<f32>, q: Vector4<f32>, dt: f32) -> Self {
        let model = Model::new(ArmParams::default());
        Self::new(SimArm::new(model, patch, q, SensorModel::default()), dt)
    }

    /// One plant step of [`Self::dt`]. With the amplifiers off the joints brake, as geared
    /// drives with holding brakes do: their speeds decay with a [`BRAKE_TAU`] time constant, so
    /// a disarmed or faulted arm comes to rest instead of coasting forever on the model's
    /// frictionless joints.
    #[inline]
    pub fn step(&mut self) {
        if !self.arm.step(self.dt) {
            self.diverged = true;
        }
        if !self.arm.enabled() {
            let keep = 1.0 - self.dt / BRAKE_TAU;
            self.arm.x.qd.x *= keep;
            self.arm.x.qd.y *= keep;
        }
    }
}

impl Board for SimulatedArm {
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
        self.arm.set_enable(on);
    }
    fn amplifier_fault(&mut self) -> bool {
        false
    }
    /// One piezo period: one plant step.
    fn tick(&mut self) {
        self.step();
    }
}

//! The QEMU board's arm: the core's simulated arm (`flexarm_core::simarm::SimArm`, in `f32`:
//! RK4 with held inputs, quantized encoders and film ADC) stepped one piezo period at a time,
//! its joints held by their brakes while the brake output is engaged (issue 33: the board's
//! brake pin, engaged whenever the amplifiers are cut). The QEMU firmware's board runs it (adding
//! its wiring, its test builds' injections and its clock); the host's rig runs the same code
//! as a [`Board`] of its own, so a host run of "the QEMU board" is the firmware's arithmetic.
//!
//! Units SI; the plant's state in the core's coordinates `q = (θ1, θ2, δ1, δ2)`.

use flexarm_core::control::piezo::PiezoPatch;
use flexarm_core::homing::Inputs;
use flexarm_core::model::Model;
use flexarm_core::params::ArmParams;
use flexarm_core::simarm::{SensorModel, SimArm};
use flexarm_core::{Vector2, Vector4};

use crate::board::Board;

/// Time constant of the joints' brakes while engaged [s].
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
    /// The plant's joint angles at which the encoders count 0 [rad]: the pose at power-up on a
    /// real arm (issue 33). 0: the encoders read the plant's angles (a pose declared at boot).
    pub zero: [f32; 2],
    /// Rigid end stops per joint, at the plant's angles [rad] (±∞: none): a joint that reaches
    /// one stops there, its speed into the stop zeroed.
    pub stop_min: [f32; 2],
    /// See [`Self::stop_min`].
    pub stop_max: [f32; 2],
    /// The encoders' index marks, at the plant's angles [rad] (∞: none): crossing one latches
    /// the encoder's count ([`Board::homing_inputs`]).
    pub index: [f32; 2],
    /// The counts latched at index pulses since the last [`Board::homing_inputs`] [rad]; NaN:
    /// none.
    latched: [f32; 2],
    /// The brake output ([`Board::set_brake`]): `true` engaged, as at power-up.
    pub brake: bool,
    /// A brake stuck released (a test's failure: a broken coil driver or a worn lining): the
    /// output is written but the joints coast.
    pub brake_stuck_released: bool,
}

impl SimulatedArm {
    /// `arm`, stepped every `dt` [s].
    pub const fn new(arm: SimArm<f32>, dt: f32) -> Self {
        Self {
            arm,
            dt,
            diverged: false,
            zero: [0.0; 2],
            stop_min: [f32::NEG_INFINITY; 2],
            stop_max: [f32::INFINITY; 2],
            index: [f32::INFINITY; 2],
            latched: [f32::NAN; 2],
            brake: true,
            brake_stuck_released: false,
        }
    }

    /// The encoders' reading of the plant angle `q` of a joint [rad]: whole counts from
    /// [`Self::zero`] (`SimArm::encoders` when the zero is 0).
    #[inline]
    fn count(&self, q: f32, zero: f32) -> f32 {
        let lsb = core::f32::consts::TAU / self.arm.sensors.counts_per_rev;
        nalgebra::ComplexField::floor((q - zero) / lsb) * lsb
    }

    /// The end stops and the index marks after a plant step from the joint angles `before`.
    #[inline(never)]
    fn stops_and_marks(&mut self, before: [f32; 2]) {
        let x = &mut self.arm.x;
        for j in 0..2 {
            let (lo, hi) = (
                self.stop_min.get(j).copied().unwrap_or(f32::NEG_INFINITY),
                self.stop_max.get(j).copied().unwrap_or(f32::INFINITY),
            );
            let (Some(q), Some(qd)) = (x.q.get(j).copied(), x.qd.get(j).copied()) else {
                continue;
            };
            let (q, qd) = if q > hi {
                (hi, qd.min(0.0))
            } else if q < lo {
                (lo, qd.max(0.0))
            } else {
                continue;
            };
            if let Some(a) = x.q.get_mut(j) {
                *a = q;
            }
            if let Some(v) = x.qd.get_mut(j) {
                *v = qd;
            }
        }
        let now = [self.arm.x.q.x, self.arm.x.q.y];
        for j in 0..2 {
            let (Some(&mark), Some(&a), Some(&b), Some(&zero)) = (
                self.index.get(j),
                before.get(j),
                now.get(j),
                self.zero.get(j),
            ) else {
                continue;
            };
            if (a < mark) != (b < mark) {
                let count = self.count(mark, zero);
                if let Some(l) = self.latched.get_mut(j) {
                    *l = count;
                }
            }
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

    /// One plant step of [`Self::dt`]. While the brake output is engaged (whenever the
    /// amplifiers are cut) the joints brake, as geared drives with holding brakes do: their
    /// speeds decay with a [`BRAKE_TAU`] time constant, so a disarmed or faulted arm comes to
    /// rest. A brake stuck released ([`Self::brake_stuck_released`]) lets them coast on the
    /// model's frictionless joints.
    #[inline]
    pub fn step(&mut self) {
        let before = [self.arm.x.q.x, self.arm.x.q.y];
        if !self.arm.step(self.dt) {
            self.diverged = true;
        }
        self.stops_and_marks(before);
        if self.brake && !self.brake_stuck_released {
            let keep = 1.0 - self.dt / BRAKE_TAU;
            self.arm.x.qd.x *= keep;
            self.arm.x.qd.y *= keep;
        }
    }
}

impl Board for SimulatedArm {
    fn encoders(&mut self) -> Vector2<f32> {
        let q = self.arm.x.q;
        Vector2::new(self.count(q.x, self.zero[0]), self.count(q.y, self.zero[1]))
    }
    fn homing_inputs(&mut self) -> Inputs<f32> {
        Inputs {
            latched: core::mem::replace(&mut self.latched, [f32::NAN; 2]),
        }
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
    fn set_brake(&mut self, engaged: bool) {
        self.brake = engaged;
    }
    fn brake_engaged(&mut self) -> bool {
        self.brake
    }
    fn amplifier_fault(&mut self) -> bool {
        false
    }
    /// One piezo period: one plant step.
    fn tick(&mut self) {
        self.step();
    }
}

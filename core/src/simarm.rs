//! A simulated arm with the sensors and amplifiers of a board: the plant ([`crate::plant`]) with
//! held inputs, quantized encoders and a quantized film-voltage ADC.
//!
//! The firmware's QEMU board is this struct (in `f32`), stepped once per piezo period inside the
//! piezo loop; the host tests run the same code at the same rates.

use crate::control::piezo::PiezoPatch;
use crate::model::Model;
use crate::plant::{State, rk4_step};
use crate::real::Real;
use crate::{Vector2, Vector4};

/// Sensor resolution of the simulated board.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorModel<T> {
    /// Encoder counts per revolution (after quadrature).
    pub counts_per_rev: T,
    /// ADC full-scale range of the film channel, symmetric [V].
    pub adc_range: T,
    /// ADC resolution [bits].
    pub adc_bits: u32,
}

impl<T: Real> Default for SensorModel<T> {
    /// 16384 counts/rev encoders; a 12-bit ADC over ±10 V (4.9 mV per LSB).
    fn default() -> Self {
        Self {
            counts_per_rev: T::c(16384.0),
            adc_range: T::c(10.0),
            adc_bits: 12,
        }
    }
}

/// The plant plus its sensors and amplifiers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimArm<T> {
    /// The plant's model.
    pub model: Model<T>,
    /// The piezo patch.
    pub patch: PiezoPatch<T>,
    /// True state.
    pub x: State<T>,
    /// Sensor resolution.
    pub sensors: SensorModel<T>,
    tau: Vector2<T>,
    v_a: T,
    enabled: bool,
}

impl<T: Real> SimArm<T> {
    /// At rest at `q`, amplifiers disabled.
    pub fn new(
        model: Model<T>,
        patch: PiezoPatch<T>,
        q: Vector4<T>,
        sensors: SensorModel<T>,
    ) -> Self {
        Self {
            model,
            patch,
            x: State::rest(q),
            sensors,
            tau: Vector2::zeros(),
            v_a: T::zero(),
            enabled: false,
        }
    }

    /// Encoder angles [rad], quantized to whole counts.
    pub fn encoders(&self) -> Vector2<T> {
        let lsb = T::c(core::f64::consts::TAU) / self.sensors.counts_per_rev;
        let quantize = |x: T| (x / lsb).floor() * lsb;
        Vector2::new(quantize(self.x.q.x), quantize(self.x.q.y))
    }

    /// Film voltage [V] through the ADC: clipped to its range, quantized.
    pub fn film_voltage(&self) -> T {
        let r = self.sensors.adc_range;
        let lsb = T::c(2.0) * r / T::c(f64::from(1u32 << self.sensors.adc_bits.min(24)));
        let v = self.patch.film_voltage(&self.x.q).clamp(-r, r - lsb);
        (v / lsb).floor() * lsb
    }

    /// Motor torque commands [N·m], held until the next call.
    pub fn set_torques(&mut self, tau: Vector2<T>) {
        self.tau = tau;
    }

    /// Piezo amplifier command [V], held until the next call.
    pub fn set_piezo(&mut self, v_a: T) {
        self.v_a = v_a;
    }

    /// Amplifier enable: when off, the arm receives no torque and no voltage.
    pub fn set_enable(&mut self, on: bool) {
        self.enabled = on;
    }

    /// Whether the amplifiers are enabled.
    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// Advances the plant by `dt` [s] with the held inputs; `false` if it diverged (the state
    /// is then left unchanged).
    pub fn step(&mut self, dt: T) -> bool {
        let u = if self.enabled {
            Vector4::new(self.tau.x, self.tau.y, T::zero(), T::zero())
                + self.patch.generalized_force(self.v_a)
        } else {
            Vector4::zeros()
        };
        match rk4_step(&self.model, &self.x, &u, dt) {
            Some(x) => {
                self.x = x;
                true
            }
            None => false,
        }
    }
}

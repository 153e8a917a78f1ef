//! Integral resonant control (Aphale, Fleming and Moheimani, Smart Mater. Struct. 16, 2007):
//! add a chosen feedthrough `d` to the film signal and integrate it back to the actuator,
//!
//! `V_a = Γ/(s + ω_l) · (V_f + d V_a)`, `d < 0`, `Γ > 0`.
//!
//! The loop then sees `G̃(s) = G(s) + d`. With `d + G(0) < 0` every zero of `G̃` on the
//! imaginary axis lies below its pole (`z_1 < ω_1 < z_2 < ω_2 < …`, whatever the film's own
//! feedthrough `F` and however many modes), and an integrator around such a plant is stable for
//! every `Γ` (its root locus loops from each pole into the left half-plane back to the zero
//! below it). The leak `ω_l` keeps a film offset from winding the integrator up. The stability
//! limit on the actuator path's gain is the static one: the controller is
//! `Γ/(s + ω_l + Γ|d|)`, so a factor `|d|/G(0) + ω_l/(Γ G(0))`.
//!
//! Sampled at `T`, the command is the integrator itself, clamped to the amplifier's window
//! (which is the anti-windup): with `x_{k−1}` the last command,
//!
//! `x_k = sat(e^{−ω_l T} x_{k−1} + Γ T (y_k + d x_{k−1}))`, `V_a = x_k`.

use super::linear::{IdentifiedLoop, StateSpace, clamp, window_ok};
use crate::real::Real;
use nalgebra::{SMatrix, SVector};

/// The law's gains.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IrcGains<T> {
    /// Integrator gain `Γ` [1/s].
    pub gamma: T,
    /// Added feedthrough `d` [V/V], negative.
    pub feedthrough: T,
    /// Leak of the integrator `ω_l/2π` [Hz].
    pub leak_hz: T,
}

/// The design rule's factor on the static stability limit, `|d| = MARGIN · G(0)`.
pub const MARGIN: f64 = 2.5;

impl<T: Real> IrcGains<T> {
    /// The design rule from the identified loop: `d = −MARGIN · G(0)`, `Γ = ω_1 / |D̂ + d|` (the
    /// integrator's corner on the loop's high-frequency gain at the first mode), leak a tenth of
    /// the first mode's frequency. `None` unless `id` is valid.
    pub fn design(id: &IdentifiedLoop<T>) -> Option<Self> {
        if !id.is_valid() {
            return None;
        }
        let d = -T::c(MARGIN) * id.static_gain();
        Some(Self {
            gamma: id.omega.x / (id.direct + d).abs(),
            feedthrough: d,
            leak_hz: id.omega.x / T::c(10.0 * core::f64::consts::TAU),
        })
    }
}

/// Integral resonant control: the command is the leaky integral of `V_f + d V_a` (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Irc<T> {
    /// `e^{−ω_l T} + Γ T d`: the command's weight in the next.
    p: T,
    /// `Γ T`.
    q: T,
    x: T,
    v_min: T,
    v_max: T,
}

impl<T: Real> Irc<T> {
    /// The law for `gains`, sampled every `period` [s], saturating at `[v_min, v_max]` [V].
    pub fn new(gains: &IrcGains<T>, period: T, v_min: T, v_max: T) -> Self {
        let leak = (-T::c(core::f64::consts::TAU) * gains.leak_hz * period).lexp();
        let q = gains.gamma * period;
        Self {
            p: leak + q * gains.feedthrough,
            q,
            x: T::zero(),
            v_min,
            v_max,
        }
    }

    /// `true` if the law is stable by itself (`|p| < 1`), integrates with a positive gain and
    /// the window holds 0 V: what a controller is built with.
    pub fn is_valid(&self) -> bool {
        self.p.finite()
            && self.q.finite()
            && self.p.abs() < T::one()
            && self.q > T::zero()
            && window_ok(self.v_min, self.v_max)
    }

    /// One step: the film voltage `v_f` [V] in, the actuator command [V] out. A non-finite
    /// `v_f` commands 0 V and empties the integrator.
    pub fn step(&mut self, v_f: T) -> T {
        if !v_f.finite() {
            self.reset();
            return T::zero();
        }
        self.x = clamp(self.p * self.x + self.q * v_f, self.v_min, self.v_max);
        self.x
    }

    /// Empties the integrator.
    pub fn reset(&mut self) {
        self.x = T::zero();
    }

    /// The law without saturation as a state space: the state is the last command.
    pub fn linear(&self) -> StateSpace<T, 1> {
        StateSpace {
            a: SMatrix::<T, 1, 1>::new(self.p),
            b: SVector::<T, 1>::new(self.q),
            c: SVector::<T, 1>::new(self.p),
            d: self.q,
        }
    }
}

//! The paper's rate feedback (Eq. 17) on the film signal with its identified feedthrough
//! subtracted: `V_a = −k_c d/dt (V_f − F̂ V_a(t − L T))`.
//!
//! The film reads `F V_p` on top of the bending path, `V_p` the patch voltage: the command of
//! the previous period through the amplifier, sampled one period late on the realistic board,
//! so the law subtracts `F̂` times its own command `L` periods back (`L = 2` there). The
//! derivative is the rate law's: Tustin's `s/(1 + s/ω_c)` with `−k_c` folded in,
//! `r_k = a r_{k−1} + b (ỹ_k − ỹ_{k−1})`, `a = (2 − ω_c T)/(2 + ω_c T)`,
//! `b = −2 k_c ω_c/(2 + ω_c T)`, `ỹ_k = y_k − F̂ u_{k−L}`, `u_k = sat(r_k)`. The first sample
//! after a reset only primes `ỹ_{k−1}` (command 0 V).
//!
//! What it cannot remove: the part of `F V_p` that the delayed command does not match (the
//! amplifier's lag, the hold within the period), and the error of `F̂` itself. The actuator
//! path's gain scales `F` but not `F̂`, so a factor `g` on it leaves `(g − 1) F` in the loop.

use super::linear::{IdentifiedLoop, StateSpace, clamp, window_ok};
use super::piezo::PiezoGains;
use crate::real::Real;
use nalgebra::{SMatrix, SVector};

/// The law's gains.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CancelGains<T> {
    /// The rate law's gain and corner.
    pub rate: PiezoGains<T>,
    /// The identified feedthrough `F̂` [V/V].
    pub feedthrough: T,
    /// `L`: how many periods back the subtracted command is, 1 or 2.
    pub lag: u8,
}

impl<T: Real> CancelGains<T> {
    /// `rate` around the identified `F̂`, subtracted two periods back (the realistic board: the
    /// held command reaches the film's sample one period later, which is read one period late).
    pub fn design(id: &IdentifiedLoop<T>, rate: PiezoGains<T>) -> Option<Self> {
        id.is_valid().then_some(Self {
            rate,
            feedthrough: id.feedthrough,
            lag: 2,
        })
    }
}

/// Rate feedback on the film with the feedthrough subtracted (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FeedthroughCancel<T> {
    a: T,
    b: T,
    f: T,
    lag2: bool,
    /// `r_{k−1}`, `ỹ_{k−1}` (`None` before the first sample), `u_{k−1}`, `u_{k−2}`.
    r: T,
    y_prev: Option<T>,
    u1: T,
    u2: T,
    v_min: T,
    v_max: T,
}

impl<T: Real> FeedthroughCancel<T> {
    /// The law for `gains`, sampled every `period` [s], saturating at `[v_min, v_max]` [V].
    pub fn new(gains: &CancelGains<T>, period: T, v_min: T, v_max: T) -> Self {
        let wc = T::c(core::f64::consts::TAU) * gains.rate.cutoff_hz;
        let den = T::c(2.0) + wc * period;
        Self {
            a: (T::c(2.0) - wc * period) / den,
            b: -gains.rate.k_c * T::c(2.0) * wc / den,
            f: gains.feedthrough,
            lag2: gains.lag >= 2,
            r: T::zero(),
            y_prev: None,
            u1: T::zero(),
            u2: T::zero(),
            v_min,
            v_max,
        }
    }

    /// `true` for a stable derivative filter, `k_c > 0`, a finite `F̂`, a lag of 1 or 2 and a
    /// window that holds 0 V.
    pub fn is_valid(&self) -> bool {
        self.a.abs() < T::one()
            && self.b < T::zero()
            && self.b.finite()
            && self.f.finite()
            && window_ok(self.v_min, self.v_max)
    }

    /// One step: the film voltage `v_f` [V] in, the actuator command [V] out. A non-finite
    /// `v_f` commands 0 V and restarts the filter.
    pub fn step(&mut self, v_f: T) -> T {
        if !v_f.finite() {
            self.reset();
            return T::zero();
        }
        let back = if self.lag2 { self.u2 } else { self.u1 };
        let y = v_f - self.f * back;
        let u = match self.y_prev {
            Some(prev) => {
                self.r = self.a * self.r + self.b * (y - prev);
                clamp(self.r, self.v_min, self.v_max)
            }
            None => T::zero(),
        };
        self.y_prev = Some(y);
        self.u2 = self.u1;
        self.u1 = u;
        u
    }

    /// Forgets the history: the next sample primes the filter.
    pub fn reset(&mut self) {
        self.r = T::zero();
        self.y_prev = None;
        self.u1 = T::zero();
        self.u2 = T::zero();
    }

    /// The law without saturation as a state space, states `(u_{k−1}, ỹ_{k−1}, u_{k−2})` (with
    /// no saturation the filter's output is the command).
    pub fn linear(&self) -> StateSpace<T, 3> {
        let (a, b, f, z) = (self.a, self.b, self.f, T::zero());
        // The subtracted command: u_{k−2} (state 2) or u_{k−1} (state 0).
        let (f0, f2) = if self.lag2 { (z, f) } else { (f, z) };
        // u_k = a u_{k−1} + b (y_k − F̂ u_{k−L} − ỹ_{k−1}).
        let c = SVector::<T, 3>::new(a - b * f0, -b, -b * f2);
        StateSpace {
            a: SMatrix::<T, 3, 3>::new(
                c.x,
                c.y,
                c.z, //
                -f0,
                z,
                -f2, //
                T::one(),
                z,
                z,
            ),
            b: SVector::<T, 3>::new(b, T::one(), z),
            c,
            d: b,
        }
    }
}

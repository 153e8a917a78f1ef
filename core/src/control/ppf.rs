//! Positive position feedback (Goh and Caughey, 1985; Fanson and Caughey, AIAA J. 28(4), 1990):
//! one second-order low-pass per mode, fed back with a positive sign,
//!
//! `V_a = Σ_i k_i ω_i² / (s² + 2ζ_i ω_i s + ω_i²) · V_f`,
//!
//! each filter tuned near a mode (`ω_i`, `ζ_i`), gain `k_i` [V/V]. Below its tuning a filter
//! passes the film in phase and softens the mode; near it the filter lags by 90° and the mode
//! sees damping; above it the filter rolls off as `1/ω²`, so the modes the controller does not
//! know, the film's feedthrough `F` and the sampling see a loop gain that falls with frequency.
//! The collocated film path plus any constant `F` is a negative-imaginary system, and positive
//! feedback through strictly negative-imaginary filters is stable exactly when the static loop
//! gain is below one (Lanzon and Petersen, IEEE TAC 53(4), 2008):
//!
//! `(Σ_i k_i) · G(0) < 1`, `G(0) = Σ_j g_j/ω_j² + F` (every mode).
//!
//! So the design rule spends a chosen fraction of that budget: [`PpfGains::design`].
//!
//! Each filter is discretized with the bilinear transform prewarped at `ω_i` (its peak stays at
//! `ω_i`), as a biquad in transposed direct form II with the gain folded into its numerator:
//! with `K = ω_i / tan(ω_i T/2)` and `a₀ = K² + 2ζ_i ω_i K + ω_i²`,
//! `b = k_i ω_i² (1, 2, 1)/a₀`, `a₁ = 2(ω_i² − K²)/a₀`, `a₂ = (K² − 2ζ_i ω_i K + ω_i²)/a₀`;
//! `y = b₀ x + z₁`, `z₁ ← b₁ x − a₁ y + z₂`, `z₂ ← b₂ x − a₂ y`.
//! The sum is saturated to the amplifier's window; the filters are stable, so nothing winds up.

use super::linear::{IdentifiedLoop, StateSpace, clamp, window_ok};
use crate::real::Real;
use nalgebra::{SMatrix, SVector};

/// One filter of the law.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PpfFilter<T> {
    /// Gain `k_i` [V/V] (positive: positive feedback).
    pub gain: T,
    /// Tuning frequency `ω_i/2π` [Hz].
    pub freq_hz: T,
    /// Damping ratio `ζ_i` [-].
    pub zeta: T,
}

/// The law's gains: one filter per controller mode.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PpfGains<T> {
    /// The filters, for modes 1 and 2.
    pub filters: [PpfFilter<T>; 2],
}

/// The design rule's tuning: each filter at `1.2 ω_j` (PPF filters are tuned at or a little
/// above their mode), with `ζ = 0.3`, and a static loop gain of `1/MARGIN` of the stability
/// limit. Chosen from a coarse look at `1.0–1.3 ω_j` and `ζ` 0.3–0.7 on the 2.5 mm link, not
/// optimized; `docs/results.md` shows they meet issue 35's goal there.
pub const TUNING: f64 = 1.2;
/// Damping ratio of the design rule's filters.
pub const FILTER_ZETA: f64 = 0.3;
/// The design rule's factor on the static stability limit: 2.5, so that the factor of 2 the
/// study asks for survives a static gain identified 20 % low.
pub const MARGIN: f64 = 2.5;

impl<T: Real> PpfGains<T> {
    /// The design rule from the identified loop: `Σ k_i = 1 / (MARGIN · G(0))`, shared in
    /// proportion to each mode's static contribution `g_j/ω_j²`; filter `i` at `TUNING · ω_i`
    /// with `ζ = FILTER_ZETA`. `None` unless `id` is valid ([`IdentifiedLoop::is_valid`]).
    pub fn design(id: &IdentifiedLoop<T>) -> Option<Self> {
        if !id.is_valid() {
            return None;
        }
        let total = T::one() / (T::c(MARGIN) * id.static_gain());
        let (w, g) = (&id.omega, &id.film_gain);
        let statics = crate::Vector2::new(g.x / (w.x * w.x), g.y / (w.y * w.y));
        let sum = statics.x + statics.y;
        let filter = |s: T, w: T| PpfFilter {
            gain: total * s / sum,
            freq_hz: T::c(TUNING) * w / T::c(core::f64::consts::TAU),
            zeta: T::c(FILTER_ZETA),
        };
        Some(Self {
            filters: [filter(statics.x, id.omega.x), filter(statics.y, id.omega.y)],
        })
    }
}

/// One biquad, gain folded in.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Biquad<T> {
    b0: T,
    b1: T,
    b2: T,
    a1: T,
    a2: T,
    z1: T,
    z2: T,
}

impl<T: Real> Biquad<T> {
    fn new(f: &PpfFilter<T>, period: T) -> Self {
        let w = T::c(core::f64::consts::TAU) * f.freq_hz;
        let (s, c) = (w * period * T::c(0.5)).lsin_cos();
        let k = w * c / s;
        let (w2, k2, two) = (w * w, k * k, T::c(2.0));
        let a0 = k2 + two * f.zeta * w * k + w2;
        let g = f.gain * w2 / a0;
        Self {
            b0: g,
            b1: two * g,
            b2: g,
            a1: two * (w2 - k2) / a0,
            a2: (k2 - two * f.zeta * w * k + w2) / a0,
            z1: T::zero(),
            z2: T::zero(),
        }
    }

    #[inline(always)]
    fn step(&mut self, x: T) -> T {
        let y = self.b0 * x + self.z1;
        self.z1 = self.b1 * x - self.a1 * y + self.z2;
        self.z2 = self.b2 * x - self.a2 * y;
        y
    }

    fn stable(&self) -> bool {
        // Both poles inside the unit circle (the stability triangle of z² + a₁z + a₂).
        self.a2.abs() < T::one() && self.a1.abs() < T::one() + self.a2
    }
}

/// Positive position feedback: `V_a = sat(Σ_i PPF_i(V_f))` (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ppf<T> {
    sections: [Biquad<T>; 2],
    v_min: T,
    v_max: T,
}

impl<T: Real> Ppf<T> {
    /// The law for `gains`, sampled every `period` [s], saturating at `[v_min, v_max]` [V].
    pub fn new(gains: &PpfGains<T>, period: T, v_min: T, v_max: T) -> Self {
        let [f1, f2] = &gains.filters;
        Self {
            sections: [Biquad::new(f1, period), Biquad::new(f2, period)],
            v_min,
            v_max,
        }
    }

    /// `true` if the coefficients are finite, both filters stable, the gains not negative and
    /// the window holds 0 V: what a controller is built with.
    pub fn is_valid(&self) -> bool {
        self.sections.iter().all(|s| {
            [s.b0, s.b1, s.b2, s.a1, s.a2].iter().all(|v| v.finite())
                && s.b0 >= T::zero()
                && s.stable()
        }) && window_ok(self.v_min, self.v_max)
    }

    /// One step: the film voltage `v_f` [V] in, the actuator command [V] out. A non-finite
    /// `v_f` commands 0 V and clears the filters.
    pub fn step(&mut self, v_f: T) -> T {
        if !v_f.finite() {
            self.reset();
            return T::zero();
        }
        let [a, b] = &mut self.sections;
        clamp(a.step(v_f) + b.step(v_f), self.v_min, self.v_max)
    }

    /// Clears the filters' states.
    pub fn reset(&mut self) {
        for s in &mut self.sections {
            s.z1 = T::zero();
            s.z2 = T::zero();
        }
    }

    /// The law without saturation as a state space, four states (two per filter): per
    /// biquad `z₁' = (b₁ − a₁b₀) x − a₁ z₁ + z₂`, `z₂' = (b₂ − a₂b₀) x − a₂ z₁`,
    /// `y = b₀ x + z₁`.
    pub fn linear(&self) -> StateSpace<T, 4> {
        let [p, q] = &self.sections;
        let (o, z) = (T::one(), T::zero());
        StateSpace {
            a: SMatrix::<T, 4, 4>::new(
                -p.a1, o, z, z, //
                -p.a2, z, z, z, //
                z, z, -q.a1, o, //
                z, z, -q.a2, z,
            ),
            b: SVector::<T, 4>::new(
                p.b1 - p.a1 * p.b0,
                p.b2 - p.a2 * p.b0,
                q.b1 - q.a1 * q.b0,
                q.b2 - q.a2 * q.b0,
            ),
            c: SVector::<T, 4>::new(o, z, o, z),
            d: p.b0 + q.b0,
        }
    }
}

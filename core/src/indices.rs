//! Performance indices of the paper, as allocation-free accumulators fed one sample at a time.
//!
//! - Eq. 37: `L²[x] = ( (1/T_f) ∫₀^T_f ‖x(t)‖² dt )^½`, an RMS over the whole run.
//! - Eq. 38: `L[x_i] = (1/3) ∫_{T_f−3}^{T_f} x_i(t) dt`, the signed mean of each component over
//!   the last 3 s (the window is configurable); since a signed mean lets an oscillation cancel
//!   itself, the mean absolute value is reported beside it.
//!
//! Integrals use the rectangle rule with the sample's hold time `dt` (the sample covers
//! `[t, t + dt)`).

use crate::real::Real;
use nalgebra::SVector;

/// Eq. 37 accumulator for an `N`-vector signal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct L2Norm<T> {
    integral: T,
    time: T,
}

impl<T: Real> Default for L2Norm<T> {
    fn default() -> Self {
        Self {
            integral: T::zero(),
            time: T::zero(),
        }
    }
}

impl<T: Real> L2Norm<T> {
    /// Adds a sample `x` held for `dt` [s].
    pub fn add<const N: usize>(&mut self, x: &SVector<T, N>, dt: T) {
        self.integral += x.norm_squared() * dt;
        self.time += dt;
    }

    /// The index, in the units of `x`; zero before any sample.
    pub fn value(&self) -> T {
        if self.time > T::zero() {
            (self.integral / self.time).lsqrt()
        } else {
            T::zero()
        }
    }
}

/// Eq. 38 accumulator: signed and absolute means of each component over `[t_end − window, t_end]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TailMean<T, const N: usize> {
    start: T,
    signed: SVector<T, N>,
    absolute: SVector<T, N>,
    time: T,
}

impl<T: Real, const N: usize> TailMean<T, N> {
    /// Averages the samples taken at or after `t_end − window` [s] (the paper: window 3 s).
    pub fn new(t_end: T, window: T) -> Self {
        Self {
            start: t_end - window,
            signed: SVector::zeros(),
            absolute: SVector::zeros(),
            time: T::zero(),
        }
    }

    /// Adds the sample `x` taken at `t` [s] and held for `dt` [s].
    pub fn add(&mut self, t: T, x: &SVector<T, N>, dt: T) {
        if t >= self.start {
            self.signed += x * dt;
            self.absolute += x.abs() * dt;
            self.time += dt;
        }
    }

    /// Signed mean per component (Eq. 38 as printed); zero before any sample in the window.
    pub fn signed(&self) -> SVector<T, N> {
        if self.time > T::zero() {
            self.signed / self.time
        } else {
            SVector::zeros()
        }
    }

    /// Mean absolute value per component.
    pub fn absolute(&self) -> SVector<T, N> {
        if self.time > T::zero() {
            self.absolute / self.time
        } else {
            SVector::zeros()
        }
    }
}

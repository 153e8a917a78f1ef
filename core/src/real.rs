//! The scalar trait: nalgebra's [`RealField`] plus the few transcendental functions the model
//! needs, routed through `libm` so the firmware (no_std) and the simulator (std) get the same
//! results bit for bit.

use nalgebra::RealField;

/// A real scalar (`f32` or `f64`) with `libm` transcendental functions.
///
/// The methods carry an `l` prefix (for libm) so they never shadow nalgebra's own methods of the
/// same name, which on `std` builds go to the platform's math library.
pub trait Real: RealField + Copy {
    /// `(sin x, cos x)`.
    fn lsin_cos(self) -> (Self, Self);
    /// [`Self::lsin_cos`] inlined into its caller (the hot path's one `sin`/`cos`,
    /// [`crate::model::Model::terms_inline`]); elsewhere the call saves flash.
    #[inline(always)]
    fn lsin_cos_inline(self) -> (Self, Self) {
        self.lsin_cos()
    }
    /// `eˣ`.
    fn lexp(self) -> Self;
    /// `acos x`, NaN outside [-1, 1].
    fn lacos(self) -> Self;
    /// `atan2(self, x)`.
    fn latan2(self, x: Self) -> Self;
    /// `sinh x`.
    fn lsinh(self) -> Self;
    /// `cosh x`.
    fn lcosh(self) -> Self;
    /// `√x` (IEEE correctly rounded on every platform).
    fn lsqrt(self) -> Self;
    /// Converts an `f64` constant, rounding to nearest.
    fn c(x: f64) -> Self;
    /// Converts a count exactly (no `f64` code on the MCU).
    fn count(n: u16) -> Self;
    /// Converts to `f64` exactly.
    fn to_f64(self) -> f64;
    /// Converts to `f32`, rounding to nearest (for reports: no `f64` code on the MCU).
    fn to_f32(self) -> f32;
    /// `true` unless NaN or ±∞.
    fn finite(self) -> bool;
    /// `true` for NaN.
    fn is_nan_(self) -> bool;
}

impl Real for f32 {
    /// Float-only ([`crate::fastmath::sin_cos`]): no software `f64` on the Cortex-M4F. One
    /// copy, called ([`Self::lsin_cos_inline`] is the inlined one).
    #[inline(never)]
    fn lsin_cos(self) -> (Self, Self) {
        crate::fastmath::sin_cos(self)
    }
    #[inline(always)]
    fn lsin_cos_inline(self) -> (Self, Self) {
        crate::fastmath::sin_cos(self)
    }
    /// Float-only ([`crate::fastmath::exp`]), like `lsin_cos`.
    #[inline(always)]
    fn lexp(self) -> Self {
        crate::fastmath::exp(self)
    }
    fn lacos(self) -> Self {
        libm::acosf(self)
    }
    fn latan2(self, x: Self) -> Self {
        libm::atan2f(self, x)
    }
    fn lsinh(self) -> Self {
        libm::sinhf(self)
    }
    fn lcosh(self) -> Self {
        libm::coshf(self)
    }
    fn lsqrt(self) -> Self {
        libm::sqrtf(self)
    }
    fn c(x: f64) -> Self {
        x as f32
    }
    fn count(n: u16) -> Self {
        Self::from(n)
    }
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
    fn to_f32(self) -> f32 {
        self
    }
    fn finite(self) -> bool {
        self.is_finite()
    }
    fn is_nan_(self) -> bool {
        self.is_nan()
    }
}

impl Real for f64 {
    fn lsin_cos(self) -> (Self, Self) {
        libm::sincos(self)
    }
    fn lexp(self) -> Self {
        libm::exp(self)
    }
    fn lacos(self) -> Self {
        libm::acos(self)
    }
    fn latan2(self, x: Self) -> Self {
        libm::atan2(self, x)
    }
    fn lsinh(self) -> Self {
        libm::sinh(self)
    }
    fn lcosh(self) -> Self {
        libm::cosh(self)
    }
    fn lsqrt(self) -> Self {
        libm::sqrt(self)
    }
    fn c(x: f64) -> Self {
        x
    }
    fn count(n: u16) -> Self {
        Self::from(n)
    }
    fn to_f64(self) -> f64 {
        self
    }
    fn to_f32(self) -> f32 {
        self as f32
    }
    fn finite(self) -> bool {
        self.is_finite()
    }
    fn is_nan_(self) -> bool {
        self.is_nan()
    }
}

/// `true` if every value is finite, with one comparison: any NaN or ±∞ makes the sum NaN or ±∞.
/// The sum of finite values overflows only beyond `3.4e38` (in `f32`), far past any physical
/// quantity of the arm, and that too reads as not finite: the check errs on the safe side.
/// The sum starts from the first value, not from 0 (`0 + x` is one addition IEEE arithmetic
/// cannot drop); no values are all finite.
pub fn all_finite<T: Real, const N: usize>(xs: [T; N]) -> bool {
    xs.into_iter()
        .reduce(|acc, x| acc + x)
        .is_none_or(|s| s.finite())
}

//! Saturation to the actuator limits. Total functions: NaN maps to zero (the safe output),
//! ±∞ to the limit of its sign.

use crate::Vector2;
use crate::real::Real;

/// `x` clamped to `[−limit, limit]`; NaN gives 0. `limit` must be positive.
pub fn saturate<T: Real>(x: T, limit: T) -> T {
    // One comparison on the common path; NaN fails every comparison and ends at zero.
    if x.abs() <= limit {
        x
    } else if x > T::zero() {
        limit
    } else if x < T::zero() {
        -limit
    } else {
        T::zero()
    }
}

/// The smaller of `a` and `b` by one ordered comparison: `a` if `a < b`, else `b` (so a NaN `a`
/// gives `b`). Not `min`: on the Cortex-M4F `f32::min` is a call to `fminf`.
#[inline(always)]
pub fn lower<T: Real>(a: T, b: T) -> T {
    if a < b { a } else { b }
}

/// The larger of `a` and `b` by one ordered comparison: `a` if `a > b`, else `b` (so a NaN `a`
/// gives `b`). Not `max`: on the Cortex-M4F `f32::max` is a call to `fmaxf`.
#[inline(always)]
pub fn upper<T: Real>(a: T, b: T) -> T {
    if a > b { a } else { b }
}

/// Component-wise [`saturate`].
pub fn saturate2<T: Real>(x: &Vector2<T>, limit: &Vector2<T>) -> Vector2<T> {
    Vector2::new(saturate(x.x, limit.x), saturate(x.y, limit.y))
}

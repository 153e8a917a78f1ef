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

/// Component-wise [`saturate`].
pub fn saturate2<T: Real>(x: &Vector2<T>, limit: &Vector2<T>) -> Vector2<T> {
    Vector2::new(saturate(x.x, limit.x), saturate(x.y, limit.y))
}

//! Saturation to the actuator limits. Total functions: NaN maps to zero (the safe output),
//! ±∞ to the limit of its sign.

use crate::Vector2;
use crate::real::Real;

/// `x` clamped to `[−limit, limit]`; NaN gives 0. `limit` must be positive.
pub fn saturate<T: Real>(x: T, limit: T) -> T {
    if x.is_nan_() {
        T::zero()
    } else if x > limit {
        limit
    } else if x < -limit {
        -limit
    } else {
        x
    }
}

/// Component-wise [`saturate`].
pub fn saturate2<T: Real>(x: &Vector2<T>, limit: &Vector2<T>) -> Vector2<T> {
    Vector2::new(saturate(x.x, limit.x), saturate(x.y, limit.y))
}

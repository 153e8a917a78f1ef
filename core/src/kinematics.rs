//! Planar kinematics of the rigid arm (`δ = 0`) and the tip of the deflected arm.
//!
//! Base frame at joint 1 (see the crate docs). Link lengths `a1`, `a2` [m]; the rigid arm
//! reaches the closed annulus `|a1 − a2| ≤ ‖p‖ ≤ a1 + a2`.

use crate::real::Real;
use crate::trajectory::TrajectoryError;
use crate::{Matrix2, Vector2, Vector4};

/// Which of the two inverse-kinematics solutions to take.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Elbow {
    /// `θ2 ≥ 0` (elbow clockwise from the line base–tip when viewed from +z).
    #[default]
    Positive,
    /// `θ2 ≤ 0`.
    Negative,
}

/// Rigid two-link kinematics with link lengths `a1`, `a2` [m].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Planar2<T> {
    /// Length of link 1 [m].
    pub a1: T,
    /// Length of link 2 [m].
    pub a2: T,
}

impl<T: Real> Planar2<T> {
    /// Position of the rigid tip [m] for joint angles `θ` [rad].
    pub fn forward(&self, theta: &Vector2<T>) -> Vector2<T> {
        let (s1, c1) = theta.x.lsin_cos();
        let (s12, c12) = (theta.x + theta.y).lsin_cos();
        Vector2::new(self.a1 * c1 + self.a2 * c12, self.a1 * s1 + self.a2 * s12)
    }

    /// Position of the deflected tip [m]: the rigid tip moved by `w` [m] normal to link 2.
    pub fn forward_deflected(&self, theta: &Vector2<T>, w: T) -> Vector2<T> {
        let (s12, c12) = (theta.x + theta.y).lsin_cos();
        self.forward(theta) + Vector2::new(-s12 * w, c12 * w)
    }

    /// Jacobian `∂p/∂θ` [m/rad].
    pub fn jacobian(&self, theta: &Vector2<T>) -> Matrix2<T> {
        let (s1, c1) = theta.x.lsin_cos();
        let (s12, c12) = (theta.x + theta.y).lsin_cos();
        Matrix2::new(
            -self.a1 * s1 - self.a2 * s12,
            -self.a2 * s12,
            self.a1 * c1 + self.a2 * c12,
            self.a2 * c12,
        )
    }

    /// `J̇ θ̇` [m/s²], the velocity-product term of the tip acceleration.
    pub fn jacobian_dot_times(&self, theta: &Vector2<T>, theta_dot: &Vector2<T>) -> Vector2<T> {
        let (s1, c1) = theta.x.lsin_cos();
        let (s12, c12) = (theta.x + theta.y).lsin_cos();
        let w1 = theta_dot.x;
        let w12 = theta_dot.x + theta_dot.y;
        Vector2::new(
            -self.a1 * c1 * w1 * w1 - self.a2 * c12 * w12 * w12,
            -self.a1 * s1 * w1 * w1 - self.a2 * s12 * w12 * w12,
        )
    }

    /// Inverse kinematics of the rigid arm: the joint angles that put the tip at `p` [m].
    /// A point outside the annulus `|a1 − a2| + margin ≤ ‖p‖ ≤ a1 + a2 − margin` is an error,
    /// never a NaN.
    pub fn inverse(
        &self,
        p: &Vector2<T>,
        elbow: Elbow,
        margin: T,
    ) -> Result<Vector2<T>, TrajectoryError> {
        let r2 = p.dot(p);
        let r = r2.lsqrt();
        let (lo, hi) = self.annulus();
        if !r.finite() {
            return Err(TrajectoryError::NotFinite);
        }
        if r < lo + margin || r > hi - margin {
            return Err(TrajectoryError::Unreachable {
                distance: r.to_f32(),
                min: (lo + margin).to_f32(),
                max: (hi - margin).to_f32(),
            });
        }
        let c2 = (r2 - self.a1 * self.a1 - self.a2 * self.a2) / (T::c(2.0) * self.a1 * self.a2);
        let c2 = c2.clamp(-T::one(), T::one());
        let mut t2 = c2.lacos();
        if elbow == Elbow::Negative {
            t2 = -t2;
        }
        let (s2, c2) = t2.lsin_cos();
        let t1 = p.y.latan2(p.x) - (self.a2 * s2).latan2(self.a1 + self.a2 * c2);
        Ok(Vector2::new(t1, t2))
    }

    /// Inner and outer radius of the reachable annulus [m].
    pub fn annulus(&self) -> (T, T) {
        ((self.a1 - self.a2).abs(), self.a1 + self.a2)
    }
}

/// Joint angles of the generalized coordinates.
pub fn joints<T: Real>(q: &Vector4<T>) -> Vector2<T> {
    Vector2::new(q.x, q.y)
}

/// Modal coordinates of the generalized coordinates.
pub fn modes<T: Real>(q: &Vector4<T>) -> Vector2<T> {
    Vector2::new(q.z, q.w)
}

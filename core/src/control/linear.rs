//! What the piezo laws beside the paper's rate feedback share: their linear form, for the
//! host's stability analysis, and the identified loop their design rules start from.
//!
//! Signals (SI): `y = V_f` the film sample [V] a law reads each period `T` [s], `u = V_a` the
//! actuator command [V] it writes. Between them, on the arm with the joints held, the loop sees
//! (`docs/model.md`, "Eqs. 17–19" and "The film's feedthrough")
//!
//! `G(s) = V_f/V_a = Σ_j g_j / (s² + 2ζ_j ω_j s + ω_j²) + F`, `g_j = k_a k_s Δφ'_j² > 0`,
//!
//! with `F ≤ 0` the film's direct response to the ceramic's membrane strain.

use crate::Vector2;
use crate::real::Real;
use nalgebra::{SMatrix, SVector};

/// A sampled law without its saturation: `z_{k+1} = A z_k + B y_k`, `u_k = C z_k + D y_k`,
/// `S` states. Each law's `linear()` gives the form of the coefficients it runs, so the host's
/// eigen-analysis studies exactly what the controller computes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StateSpace<T, const S: usize> {
    /// `A`.
    pub a: SMatrix<T, S, S>,
    /// `B`.
    pub b: SVector<T, S>,
    /// `C` (as a column).
    pub c: SVector<T, S>,
    /// `D` [V/V].
    pub d: T,
}

/// The piezo loop as commissioning identifies it: the controller's two modes, their film gains,
/// and the film's direct terms.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IdentifiedLoop<T> {
    /// `ω_j` [rad/s].
    pub omega: Vector2<T>,
    /// `ζ_j` [-].
    pub zeta: Vector2<T>,
    /// `g_j = k_a k_s Δφ'_j²` [V/V·s⁻²]: each mode's residue in `V_f/V_a` (the identification's
    /// `piezo_film`).
    pub film_gain: Vector2<T>,
    /// `D̂` [V/V]: the constant of a fit of `V_f/V_a` over the band of the two modes, the film's
    /// feedthrough plus the quasi-static response of the modes above the band
    /// (`F + Σ_{j>2} g_j/ω_j²`).
    pub direct: T,
    /// `F̂` [V/V]: the film's jump right after a fast step of `V_a`, before any mode moves.
    pub feedthrough: T,
}

impl<T: Real> IdentifiedLoop<T> {
    /// The loop's static gain `G(0) = Σ_j g_j/ω_j² + D̂` [V/V]: what the film reads per
    /// actuator volt held still.
    pub fn static_gain(&self) -> T {
        // Written out (the firmware designs its laws from it in the link's idle task, whose
        // stack the iterator adapters deepened).
        let (w, g) = (&self.omega, &self.film_gain);
        g.x / (w.x * w.x) + g.y / (w.y * w.y) + self.direct
    }

    /// Every value finite, `ω_j > 0`, `g_j > 0` (a collocated pair), `G(0) > 0`.
    pub fn is_valid(&self) -> bool {
        let (w, z, g) = (&self.omega, &self.zeta, &self.film_gain);
        let finite = [w.x, w.y, z.x, z.y, g.x, g.y, self.direct, self.feedthrough]
            .into_iter()
            .all(|v| v.finite());
        finite
            && w.x > T::zero()
            && w.y > T::zero()
            && g.x > T::zero()
            && g.y > T::zero()
            && self.static_gain() > T::zero()
    }
}

/// `x` clamped to `[lo, hi]`.
#[inline(always)]
pub(crate) fn clamp<T: Real>(x: T, lo: T, hi: T) -> T {
    if x > hi {
        hi
    } else if x < lo {
        lo
    } else {
        x
    }
}

/// The window `[v_min, v_max]` holds 0 V inside, finite.
pub(crate) fn window_ok<T: Real>(v_min: T, v_max: T) -> bool {
    v_min.finite() && v_max.finite() && v_min < T::zero() && v_max > T::zero()
}

//! The piezo patch on link 2 and its vibration-damping law (Eqs. 17–19).
//!
//! A piezoceramic actuator on the top face and a PVDF film sensor on the bottom face cover the
//! same span `[x_a, x_a + l_a]` of link 2. Both couple to the modes through the difference of
//! the mode-shape slopes across the patch, `Δφ'_j = φ'_j(x_a + l_a) − φ'_j(x_a)` [1/(m·√kg)]:
//!
//! - actuator (Eq. 18): a voltage `V_a` [V] bends the patch with a moment `k_a V_a` [N·m]; the
//!   modal force is `C_a V_a` with `C_a = k_a Δφ'`;
//! - sensor (Eq. 19): the film voltage is `V_f = k_s Δφ'ᵀ δ` [V], so `V_f = c_s C_aᵀ δ` with
//!   `c_s = k_s / k_a`;
//! - law (Eq. 17): `V_a = −k_c V̇_f`, with `V̇_f` from a filtered derivative ([`RateFilter`]).
//!   The modal force is then `−k_c c_s C_a C_aᵀ δ̇`, the dissipation term `C_a K_c C_aᵀ c_s` of
//!   Eq. 24 with the scalar gain `K_c = k_c` [s]; the power it injects into the modes,
//!   `δ̇ᵀ C_a V_a = −k_c c_s (C_aᵀ δ̇)²`, is never positive.
//!
//! Polarities: the amplifier and the film are wired so that `k_a > 0` and `k_s > 0`; the sign of
//! the physical `d31` is absorbed there.
//!
//! Constants the paper leaves out, and our choices (`docs/model.md`). Both transducers sit on
//! the patched section, the three-layer composite film + beam + ceramic (bottom to top, width
//! `b`), whose modulus-weighted neutral axis lies `z_n = Σ E_i t_i z_i / Σ E_i t_i` above the
//! film's bottom face (`z_i` the mid-plane height of layer `i`). One definition serves the
//! controller, the placement optimizer (`flexarm-beam`, whose patched-section `EI` is taken about
//! the same axis) and the firmware's generated parameters:
//! - `k_a = E_c b |d31| (z_c − z_n)`: the moment about the composite neutral axis of the
//!   ceramic's induced stress `E_c d31 V/t_c` over its area `b t_c`, acting on the composite
//!   section (`z_c` the ceramic's mid-plane). The paper's Eq. 18 denominator belongs to the
//!   pin-force model, whose moment acts on the bare beam's `EI`; its `1/(ρ_b A_b)` belongs to
//!   another mode normalization;
//! - `k_s = g31 E_f t_f (z_n − z_f) / l_a`, the open-circuit voltage of a film of capacitance
//!   `C` per area whose mid-plane `z_f` lies `z_n − z_f` below the composite neutral axis:
//!   charge `e31 b (z_n − z_f) Δw'` over capacitance `C b l_a`, with `e31/C = g31 E_f t_f`.
//!
//! The ceramic's induced axial strain, which the film also sees (a direct `V_a → V_f`
//! feedthrough of collocated pairs on one section), is [`PiezoMaterial::film_feedthrough`]; the
//! controller's model and the paper's law leave it out, the truth plant carries it. Neglected:
//! the bond layers.

use crate::modes::UniformMode;
use crate::real::Real;
use crate::{Vector2, Vector4};

/// Material and section data of the beam and the piezo layers (the paper's table, SI units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PiezoMaterial<T> {
    /// Young's modulus of the beam `E_b` [Pa].
    pub e_b: T,
    /// Young's modulus of the piezoceramic `E_c` [Pa].
    pub e_c: T,
    /// Young's modulus of the film `E_f` [Pa].
    pub e_f: T,
    /// Beam thickness `t_b` [m].
    pub t_b: T,
    /// Ceramic thickness `t_c` [m].
    pub t_c: T,
    /// Film thickness `t_f` [m].
    pub t_f: T,
    /// Width of beam, ceramic and film `b` [m].
    pub b: T,
    /// Ceramic strain constant `d31` [m/V] (sign ignored, see the module docs).
    pub d31: T,
    /// Film voltage constant `g31` [V·m/N].
    pub g31: T,
    /// Film capacitance per area `C` [F/m²].
    pub c_area: T,
}

impl<T: Real> Default for PiezoMaterial<T> {
    /// The paper's values: `E_b = 65 GPa`, `E_c = 64 GPa`, `E_f = 2 GPa`, `t_b = t_c = 0.8 mm`,
    /// `t_f = 28 µm`, `b = 25 mm`, `d31 = −300 pm/V`, `g31 = 0.216 V·m/N`, `C = 380 pF/cm²`.
    fn default() -> Self {
        Self {
            e_b: T::c(65e9),
            e_c: T::c(64e9),
            e_f: T::c(2e9),
            t_b: T::c(0.8e-3),
            t_c: T::c(0.8e-3),
            t_f: T::c(0.028e-3),
            b: T::c(25e-3),
            d31: T::c(-300e-12),
            g31: T::c(216e-3),
            c_area: T::c(380e-12 / 1e-4),
        }
    }
}

impl<T: Real> PiezoMaterial<T> {
    /// Height of the patched section's modulus-weighted neutral axis above the film's bottom
    /// face, `z_n = Σ E_i t_i z_i / Σ E_i t_i` over film, beam and ceramic [m].
    pub fn neutral_axis(&self) -> T {
        let half = T::c(0.5);
        let layers = [
            (self.e_f, self.t_f, half * self.t_f),
            (self.e_b, self.t_b, self.t_f + half * self.t_b),
            (self.e_c, self.t_c, self.t_f + self.t_b + half * self.t_c),
        ];
        let (mut num, mut den) = (T::zero(), T::zero());
        for (e, t, z) in layers {
            num += e * t * z;
            den += e * t;
        }
        num / den
    }

    /// Lever arm of the ceramic, `z_c − z_n`: its mid-plane above the composite neutral
    /// axis [m].
    pub fn actuator_lever_arm(&self) -> T {
        self.t_f + self.t_b + T::c(0.5) * self.t_c - self.neutral_axis()
    }

    /// Lever arm of the film, `z_n − z_f`: its mid-plane below the composite neutral axis [m].
    pub fn film_lever_arm(&self) -> T {
        self.neutral_axis() - T::c(0.5) * self.t_f
    }

    /// Bending moment per actuator volt `k_a = E_c b |d31| (z_c − z_n)` [N·m/V].
    pub fn moment_per_volt(&self) -> T {
        self.e_c * self.b * self.d31.abs() * self.actuator_lever_arm()
    }

    /// Film voltage per radian of slope difference across a patch of length `l_a`,
    /// `k_s = g31 E_f t_f (z_n − z_f) / l_a` [V/rad].
    pub fn film_volts_per_slope(&self, l_a: T) -> T {
        self.g31 * self.e_f * self.t_f * self.film_lever_arm() / l_a
    }

    /// The film's direct response to the actuator through the section's membrane strain, with
    /// a perfect bond: `F = −g31 E_f t_f · E_c |d31| / Σ E_i t_i` [V/V] (`docs/model.md`,
    /// "The film's feedthrough"). About the composite axis the laminate has no membrane-bending
    /// coupling, so the ceramic's free strain `d31 V/t_c` splits into a bending moment
    /// (`k_a V`, the modes' input) and a uniform axial strain `ε₀ = E_c b d31 V / Σ E_i b t_i`
    /// of the whole patched section (no axial load: the link's tip is free). The film reads
    /// `g31 E_f t_f` volts per unit strain, and on the face opposite the ceramic the bending
    /// stretches it the other way: in the polarity where `k_a, k_s > 0`, `F < 0`.
    pub fn film_feedthrough(&self) -> T {
        let axial = self.e_f * self.t_f + self.e_b * self.t_b + self.e_c * self.t_c;
        -(self.g31 * self.e_f * self.t_f * self.e_c * self.d31.abs() / axial)
    }
}

/// A collocated actuator/film pair on link 2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PiezoPatch<T> {
    /// Start of the patch from joint 2 `x_a` [m].
    pub x_a: T,
    /// Length of the patch `l_a` [m].
    pub l_a: T,
    /// `Δφ'_j` across the patch [1/(m·√kg)].
    pub slope_diff: Vector2<T>,
    /// Actuator moment per volt `k_a` [N·m/V].
    pub k_a: T,
    /// Film volts per radian of slope difference `k_s` [V/rad].
    pub k_s: T,
}

impl<T: Real> PiezoPatch<T> {
    /// A patch at `[x_a, x_a + l_a]` [m] on a uniform link of mass `m2` [kg] and length `a2` [m]
    /// (the controller's default mode shapes).
    pub fn uniform(material: &PiezoMaterial<T>, m2: T, a2: T, x_a: T, l_a: T) -> Self {
        let m = [UniformMode::new(0, m2, a2), UniformMode::new(1, m2, a2)];
        let d = |m: &UniformMode<T>| m.slope(x_a + l_a) - m.slope(x_a);
        Self {
            x_a,
            l_a,
            slope_diff: Vector2::new(d(&m[0]), d(&m[1])),
            k_a: material.moment_per_volt(),
            k_s: material.film_volts_per_slope(l_a),
        }
    }

    /// The paper's optimum `x_a = 0.09 m`, `l_a = 0.35 m` on the paper's link 2.
    pub fn paper() -> Self {
        Self::uniform(
            &PiezoMaterial::default(),
            T::c(0.3),
            T::c(0.7),
            T::c(0.09),
            T::c(0.35),
        )
    }

    /// Checks that the patch lies on a link 2 of length `a2` [m] and that its constants are
    /// finite and positive.
    pub fn validate(&self, a2: T) -> Result<(), crate::params::ParamError> {
        use crate::params::ParamError;
        let finite = [
            self.x_a,
            self.l_a,
            self.k_a,
            self.k_s,
            self.slope_diff.x,
            self.slope_diff.y,
        ]
        .iter()
        .all(|v| v.finite());
        if !finite {
            return Err(ParamError::NotFinite("piezo patch"));
        }
        if !(self.x_a >= T::zero() && self.l_a > T::zero() && self.x_a + self.l_a <= a2) {
            return Err(ParamError::PatchOutsideLink);
        }
        if !(self.k_a > T::zero() && self.k_s > T::zero()) {
            return Err(ParamError::NotPositive("k_a, k_s"));
        }
        Ok(())
    }

    /// Input vector `C_a = k_a Δφ'` (Eq. 18): modal force per actuator volt.
    pub fn c_a(&self) -> Vector2<T> {
        self.slope_diff * self.k_a
    }

    /// Sensor constant `c_s = k_s/k_a` of Eq. 19 (`V_f = c_s C_aᵀ δ`).
    pub fn c_s(&self) -> T {
        self.k_s / self.k_a
    }

    /// Film voltage `V_f = k_s Δφ'ᵀ δ` [V] (Eq. 19) for the generalized coordinates `q`.
    pub fn film_voltage(&self, q: &Vector4<T>) -> T {
        self.k_s * self.slope_diff.dot(&Vector2::new(q.z, q.w))
    }

    /// Generalized force `[0, 0, C_a V_a]` of an actuator voltage `v_a` [V].
    pub fn generalized_force(&self, v_a: T) -> Vector4<T> {
        let f = self.c_a() * v_a;
        Vector4::new(T::zero(), T::zero(), f.x, f.y)
    }
}

impl PiezoPatch<f64> {
    /// The patch rounded to `f32`, as the controller runs it.
    pub fn to_f32(&self) -> PiezoPatch<f32> {
        PiezoPatch {
            x_a: self.x_a as f32,
            l_a: self.l_a as f32,
            slope_diff: self.slope_diff.cast::<f32>(),
            k_a: self.k_a as f32,
            k_s: self.k_s as f32,
        }
    }
}

/// Filtered derivative `H(s) = s / (1 + s/ω_c)`, discretized with the bilinear (Tustin)
/// transform at period `T`:
/// `y_k = a y_{k−1} + b (x_k − x_{k−1})`, `a = (2 − ω_c T)/(2 + ω_c T)`, `b = 2 ω_c/(2 + ω_c T)`.
/// The first sample only initializes `x_{k−1}` (output 0), so switching on gives no spike.
///
/// "No previous sample" is marked by `x_{k−1} = NaN` rather than by a flag: the first
/// difference is then NaN, which the hot path of [`PiezoLaw`] sends to its (rare) saturation
/// branch, where it restarts the output at 0. No test of a flag on the common path.
#[derive(Clone, Copy, Debug)]
pub struct RateFilter<T> {
    a: T,
    b: T,
    x_prev: T,
    y: T,
}

impl<T: PartialEq> PartialEq for RateFilter<T> {
    /// Equal coefficients and state; two filters without a previous sample are equal.
    fn eq(&self, o: &Self) -> bool {
        #[allow(clippy::eq_op)] // `x != x`: NaN, the "no previous sample" mark
        let unset = |x: &T| x != x;
        let same_prev = self.x_prev == o.x_prev || (unset(&self.x_prev) && unset(&o.x_prev));
        self.a == o.a && self.b == o.b && self.y == o.y && same_prev
    }
}

impl<T: Real> RateFilter<T> {
    /// A filter with corner `cutoff_hz` [Hz] sampled every `period` [s].
    pub fn new(cutoff_hz: T, period: T) -> Self {
        Self::with_gain(cutoff_hz, period, T::one())
    }

    /// The same filter followed by a constant `gain`, folded into its coefficient (one
    /// multiplication less per sample).
    pub fn with_gain(cutoff_hz: T, period: T, gain: T) -> Self {
        let wc = T::c(core::f64::consts::TAU) * cutoff_hz;
        let den = T::c(2.0) + wc * period;
        let mut f = Self {
            a: (T::c(2.0) - wc * period) / den,
            b: gain * T::c(2.0) * wc / den,
            x_prev: T::zero(),
            y: T::zero(),
        };
        f.reset();
        f
    }

    /// Feeds the sample `x` and returns the filtered rate [units of x per s]; 0 for the first
    /// sample after a reset. A NaN sample restarts the filter.
    pub fn update(&mut self, x: T) -> T {
        if self.advance(x).is_nan_() {
            self.y = T::zero();
        }
        self.y
    }

    /// One step of the recursion: NaN for the first sample after a reset (see the type's docs).
    #[inline(always)]
    fn advance(&mut self, x: T) -> T {
        self.y = self.a * self.y + self.b * (x - self.x_prev);
        self.x_prev = x;
        self.y
    }

    /// Forgets the history (after a fault or a reset): the next sample gives 0.
    pub fn reset(&mut self) {
        self.x_prev = T::c(f64::NAN);
        self.y = T::zero();
    }
}

/// Gains of the piezo loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PiezoGains<T> {
    /// Rate-feedback gain `k_c` [s] (V of actuator per V/s of film).
    pub k_c: T,
    /// Corner of the derivative filter [Hz].
    pub cutoff_hz: T,
}

impl<T: Real> Default for PiezoGains<T> {
    /// `k_c = 30 s` (the paper's `K_c = 30`, here with units that make it damp the second mode
    /// within the ±200 V amplifier range), corner 100 Hz (7 times the second mode);
    /// `docs/model.md` gives the evidence.
    fn default() -> Self {
        Self {
            k_c: T::c(30.0),
            cutoff_hz: T::c(100.0),
        }
    }
}

/// The piezo loop: `V_a = sat(−k_c V̇_f)` (Eq. 17); the gain `−k_c` is folded into the
/// derivative filter. The saturation is the amplifier's window `[v_min, v_max]`: a piezoceramic
/// depolarizes under a reverse field, so a patch is rated for less negative than positive
/// voltage (for example −30 V … +150 V).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PiezoLaw<T> {
    filter: RateFilter<T>,
    v_min: T,
    v_max: T,
}

impl<T: Real> PiezoLaw<T> {
    /// A law sampled every `period` [s], saturating at `±v_max` [V].
    pub fn new(gains: &PiezoGains<T>, period: T, v_max: T) -> Self {
        Self::with_window(gains, period, -v_max, v_max)
    }

    /// A law sampled every `period` [s], saturating at the window `[v_min, v_max]` [V]
    /// (`v_min < 0 < v_max`, [`Self::is_valid`]).
    pub fn with_window(gains: &PiezoGains<T>, period: T, v_min: T, v_max: T) -> Self {
        Self {
            filter: RateFilter::with_gain(gains.cutoff_hz, period, -gains.k_c),
            v_min,
            v_max,
        }
    }

    /// The saturation window `(v_min, v_max)` [V].
    pub fn window(&self) -> (T, T) {
        (self.v_min, self.v_max)
    }

    /// One step: the film voltage `v_f` [V] in, the actuator command [V] out.
    /// A non-finite `v_f` commands 0 V and restarts the filter.
    pub fn step(&mut self, v_f: T) -> T {
        if !v_f.finite() {
            self.filter.reset();
            return T::zero();
        }
        self.step_finite(v_f)
    }

    /// [`Self::step`] for a sample the caller has already checked to be finite and bounded
    /// (the filter is stable, so its output is finite too).
    #[inline(always)]
    pub fn step_finite(&mut self, v_f: T) -> T {
        let v = self.filter.advance(v_f);
        // The window's top, then its bottom, each one ordered comparison: a saturated output
        // runs no other test. What is left is inside the window or unordered (NaN), sorted out
        // by a third comparison (docs/performance.md: the bench's random film samples saturate
        // nearly always).
        if v > self.v_max {
            return self.v_max;
        }
        if v < self.v_min {
            return self.v_min;
        }
        if v >= self.v_min {
            return v;
        }
        // NaN: the first sample after a reset. The filter restarts from it with output 0.
        crate::hint::cold();
        self.filter.y = T::zero();
        T::zero()
    }

    /// Forgets the filter's history.
    pub fn reset(&mut self) {
        self.filter.reset();
    }

    /// `true` if the law damps: a stable derivative filter (`|a| < 1`), a negative folded gain
    /// (`b < 0`, i.e. `k_c > 0`) and a finite window around 0 V (`v_min < 0 < v_max`: 0 V is
    /// the safe state). With a positive period this holds exactly when `k_c` and the corner are
    /// finite and positive. What a controller is built with.
    pub fn is_valid(&self) -> bool {
        self.filter.b < T::zero() && self.is_valid_or_off()
    }

    /// [`Self::is_valid`], or the loop off: `k_c = 0` (`b = 0`, `V_a = 0`), which a running
    /// drive may be set to (`flexarm bringup` runs so until the film's sign is known).
    pub fn is_valid_or_off(&self) -> bool {
        let f = &self.filter;
        f.a.abs() < T::one()
            && f.b <= T::zero()
            && f.b.finite()
            && self.v_max > T::zero()
            && self.v_max.finite()
            && self.v_min < T::zero()
            && self.v_min.finite()
    }
}

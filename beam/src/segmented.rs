//! Exact modes of a segmented Euler–Bernoulli beam (Eqs. 1–4, Table 1).
//!
//! Link 2 is clamped at the hub (`w = w' = 0`) and free at the tip, where an optional point
//! mass `M` and rotary inertia `J` sit. Between the hub and the tip the beam is a chain of
//! uniform segments (before, under and after the patch), each with its own `EI_k` and `ρA_k`;
//! across every interface `w`, `w'`, `EI w''` and `(EI w'')'` are continuous (Table 1 with
//! `α⁴ = EI_{k+1}/EI_k`). The tip conditions, from the variation of the Lagrangian, are
//! `EI w''(L) = J ω² w'(L)` and `(EI w'')'(L) = −M ω² w(L)`.
//!
//! In segment `k` (local coordinate `s ∈ [0, L_k]`, `β_k⁴ = ω² ρA_k / EI_k`) the shape is
//! written in the bounded basis
//! `w = c₁ cos β s + c₂ sin β s + c₃ e^{−β s} + c₄ e^{−β (L_k − s)}`,
//! whose four functions never exceed 1 on the segment, so nothing overflows however high the
//! frequency (the textbook cosh/sinh basis loses every digit past `βL ≈ 40`). The `4N`
//! conditions form a matrix `A(ω)`; every row is scaled by its largest entry, which keeps the
//! determinant's sign and makes it O(1). Eigenfrequencies are sign changes of that scaled
//! determinant, found by scanning `√ω` in steps much finer than the root spacing and refined by
//! the Illinois variant of regula falsi inside the bracket (no bare Newton step anywhere). The
//! mode shape is the null vector of `A(ω_j)` (right singular vector of the smallest singular
//! value), normalized to unit modal mass `∫ρA φ² dx + M φ(L)² + J φ'(L)² = 1`, with the sign
//! fixed by `φ''(0) > 0` (the core's uniform modes follow the same rule).

use nalgebra::DMatrix;

/// One uniform segment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    /// Length [m].
    pub length: f64,
    /// Flexural rigidity [N·m²].
    pub ei: f64,
    /// Mass per length [kg/m].
    pub rho_a: f64,
}

/// A clamped beam made of uniform segments, with an optional tip body.
#[derive(Clone, Debug, PartialEq)]
pub struct SegmentedBeam {
    segments: Vec<Segment>,
    /// Tip point mass `M` [kg].
    pub tip_mass: f64,
    /// Tip rotary inertia `J` [kg·m²].
    pub tip_inertia: f64,
}

/// Why a beam or its eigen-solution was refused.
#[derive(Clone, Debug, PartialEq)]
pub enum BeamError {
    /// A segment or tip value is not finite or has the wrong sign.
    InvalidData(String),
    /// Fewer roots than asked for were bracketed below the scan limit.
    RootsNotFound {
        /// Modes asked for.
        wanted: usize,
        /// Modes found.
        found: usize,
    },
}

impl std::fmt::Display for BeamError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::InvalidData(s) => write!(f, "invalid beam data: {s}"),
            Self::RootsNotFound { wanted, found } => write!(
                f,
                "found only {found} of {wanted} eigenfrequencies below the scan limit"
            ),
        }
    }
}

impl std::error::Error for BeamError {}

/// One mode of the segmented beam, unit modal mass.
#[derive(Clone, Debug, PartialEq)]
pub struct Mode {
    /// Angular frequency `ω` [rad/s].
    pub omega: f64,
    /// Coefficients `(c₁..c₄)` per segment, already normalized.
    coeffs: Vec<[f64; 4]>,
    /// `β_k` per segment [1/m].
    betas: Vec<f64>,
    /// Start of each segment [m].
    starts: Vec<f64>,
    /// The segments.
    segments: Vec<Segment>,
}

/// Largest number of segments (hub side, patch, tip side).
const MAX_SEG: usize = 3;
const MAX_N: usize = 4 * MAX_SEG;

/// `[f, f', f'', f''']` of the four basis functions at `s` of a segment of length `l`.
#[inline]
fn basis(beta: f64, l: f64, s: f64) -> [[f64; 4]; 4] {
    let (sn, cs) = (beta * s).sin_cos();
    let e1 = (-beta * s).exp();
    let e2 = (-beta * (l - s)).exp();
    let (b, b2) = (beta, beta * beta);
    let b3 = b2 * b;
    // Row = derivative order, column = basis function.
    [
        [cs, sn, e1, e2],
        [-b * sn, b * cs, -b * e1, b * e2],
        [-b2 * cs, -b2 * sn, b2 * e1, b2 * e2],
        [b3 * sn, -b3 * cs, -b3 * e1, b3 * e2],
    ]
}

impl SegmentedBeam {
    /// A beam from its segments, hub to tip. Segments shorter than 1 nm are dropped (a patch
    /// at the hub or reaching the tip leaves two segments).
    pub fn new(segments: &[Segment], tip_mass: f64, tip_inertia: f64) -> Result<Self, BeamError> {
        let segs: Vec<Segment> = segments
            .iter()
            .copied()
            .filter(|s| s.length > 1e-9)
            .collect();
        if segs.is_empty() || segs.len() > MAX_SEG {
            return Err(BeamError::InvalidData(format!(
                "need 1 to {MAX_SEG} segments of positive length, got {}",
                segs.len()
            )));
        }
        for (i, s) in segs.iter().enumerate() {
            for (name, v) in [("length", s.length), ("EI", s.ei), ("rho_a", s.rho_a)] {
                if !(v.is_finite() && v > 0.0) {
                    return Err(BeamError::InvalidData(format!(
                        "segment {i}: {name} = {v} must be finite and positive"
                    )));
                }
            }
        }
        for (name, v) in [("tip_mass", tip_mass), ("tip_inertia", tip_inertia)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(BeamError::InvalidData(format!(
                    "{name} = {v} must be finite and not negative"
                )));
            }
        }
        Ok(Self {
            segments: segs,
            tip_mass,
            tip_inertia,
        })
    }

    /// A uniform beam (one segment).
    pub fn uniform(length: f64, ei: f64, rho_a: f64) -> Result<Self, BeamError> {
        Self::new(&[Segment { length, ei, rho_a }], 0.0, 0.0)
    }

    /// The segments actually used, hub to tip.
    pub fn segments(&self) -> &[Segment] {
        &self.segments
    }

    /// Total length [m].
    pub fn length(&self) -> f64 {
        self.segments.iter().map(|s| s.length).sum()
    }

    /// Total mass of the beam (without the tip body) [kg].
    pub fn mass(&self) -> f64 {
        self.segments.iter().map(|s| s.length * s.rho_a).sum()
    }

    fn betas(&self, omega: f64) -> [f64; MAX_SEG] {
        let mut b = [0.0; MAX_SEG];
        for (bk, s) in b.iter_mut().zip(&self.segments) {
            *bk = (omega * omega * s.rho_a / s.ei).sqrt().sqrt();
        }
        b
    }

    /// Fills the row-scaled characteristic matrix at `ω` into `a` (row-major, `n × n`,
    /// `n = 4 × segments`) and returns `n`.
    fn matrix(&self, omega: f64, a: &mut [[f64; MAX_N]; MAX_N]) -> usize {
        let ns = self.segments.len();
        let n = 4 * ns;
        let betas = self.betas(omega);
        for row in a.iter_mut().take(n) {
            row.iter_mut().take(n).for_each(|x| *x = 0.0);
        }
        // Clamp: w(0) = 0, w'(0) = 0 on segment 0.
        let s0 = &self.segments[0];
        let f0 = basis(betas[0], s0.length, 0.0);
        for c in 0..4 {
            a[0][c] = f0[0][c];
            a[1][c] = f0[1][c];
        }
        // Interfaces.
        for k in 0..ns - 1 {
            let (sl, sr) = (&self.segments[k], &self.segments[k + 1]);
            let fl = basis(betas[k], sl.length, sl.length);
            let fr = basis(betas[k + 1], sr.length, 0.0);
            let r0 = 2 + 4 * k;
            for d in 0..4 {
                // w and w' plain; EI w'' and EI w''' carry the rigidities.
                let (el, er) = if d < 2 { (1.0, 1.0) } else { (sl.ei, sr.ei) };
                for c in 0..4 {
                    a[r0 + d][4 * k + c] = el * fl[d][c];
                    a[r0 + d][4 * (k + 1) + c] = -er * fr[d][c];
                }
            }
        }
        // Tip: EI w'' − J ω² w' = 0, EI w''' + M ω² w = 0.
        let k = ns - 1;
        let sl = &self.segments[k];
        let ft = basis(betas[k], sl.length, sl.length);
        let w2 = omega * omega;
        for c in 0..4 {
            a[n - 2][4 * k + c] = sl.ei * ft[2][c] - self.tip_inertia * w2 * ft[1][c];
            a[n - 1][4 * k + c] = sl.ei * ft[3][c] + self.tip_mass * w2 * ft[0][c];
        }
        // Row equilibration: positive, continuous in ω, so the determinant keeps its sign.
        for row in a.iter_mut().take(n) {
            let m = row.iter().take(n).fold(0.0f64, |m, x| m.max(x.abs()));
            if m > 0.0 {
                row.iter_mut().take(n).for_each(|x| *x /= m);
            }
        }
        n
    }

    /// The scaled characteristic determinant at `ω` [rad/s].
    pub fn scaled_determinant(&self, omega: f64) -> f64 {
        let mut a = [[0.0; MAX_N]; MAX_N];
        let n = self.matrix(omega, &mut a);
        det_in_place(&mut a, n)
    }

    /// `√(EI_max / (ρA_min L⁴))` [rad/s]: a uniform beam of the stiffest section and the
    /// lightest mass per length has `ω = scale · (β L)²`.
    fn omega_scale(&self) -> f64 {
        let l = self.length();
        let (ei_max, ra_min) = self
            .segments
            .iter()
            .fold((0.0f64, f64::INFINITY), |(e, r), s| {
                (e.max(s.ei), r.min(s.rho_a))
            });
        (ei_max / (ra_min * l.powi(4))).sqrt()
    }

    /// The first `count` eigenfrequencies [rad/s], ascending.
    pub fn frequencies(&self, count: usize) -> Result<Vec<f64>, BeamError> {
        // Scan x = β L of a reference beam (the stiffest section with the lightest mass per
        // length over the whole length), ω = scale · x². Roots are about π apart in the β L of
        // every section; the step is 1/16 of that spacing, shrunk by the section contrast
        // (how much larger β L can be in another section at the same ω).
        let scale = self.omega_scale();
        let fold = |f: fn(f64, f64) -> f64, init: f64, g: fn(&Segment) -> f64| {
            self.segments.iter().fold(init, |a, s| f(a, g(s)))
        };
        let ei_min = fold(f64::min, f64::INFINITY, |s| s.ei);
        let ei_max = fold(f64::max, 0.0, |s| s.ei);
        let ra_min = fold(f64::min, f64::INFINITY, |s| s.rho_a);
        let ra_max = fold(f64::max, 0.0, |s| s.rho_a);
        let contrast = ((ra_max / ei_min) / (ra_min / ei_max)).sqrt().sqrt();
        let step = 0.2 / contrast;
        let bl_start = 0.01;
        let bl_max = (count as f64 + 2.0) * std::f64::consts::PI * 1.5 + 10.0;
        let omega_of = |bl: f64| scale * bl * bl;
        let mut roots = Vec::with_capacity(count);
        let mut x0 = bl_start;
        let mut f0 = self.scaled_determinant(omega_of(x0));
        while roots.len() < count && x0 < bl_max {
            let x1 = x0 + step;
            let f1 = self.scaled_determinant(omega_of(x1));
            if f0 == 0.0 {
                roots.push(omega_of(x0));
            } else if f0 * f1 < 0.0 {
                let x = illinois(|x| self.scaled_determinant(omega_of(x)), x0, x1, f0, f1);
                roots.push(omega_of(x));
            }
            x0 = x1;
            f0 = f1;
        }
        if roots.len() < count {
            return Err(BeamError::RootsNotFound {
                wanted: count,
                found: roots.len(),
            });
        }
        Ok(roots)
    }

    /// The first `count` modes, unit modal mass.
    pub fn modes(&self, count: usize) -> Result<Vec<Mode>, BeamError> {
        self.frequencies(count)?
            .into_iter()
            .map(|w| self.mode_at(w))
            .collect()
    }

    /// The mode shape at an eigenfrequency `omega` [rad/s].
    fn mode_at(&self, omega: f64) -> Result<Mode, BeamError> {
        let mut a = [[0.0; MAX_N]; MAX_N];
        let n = self.matrix(omega, &mut a);
        let m = DMatrix::from_fn(n, n, |i, j| a[i][j]);
        let svd = m.svd(false, true);
        let v_t = svd
            .v_t
            .as_ref()
            .ok_or_else(|| BeamError::InvalidData("SVD failed".into()))?;
        let (imin, _) =
            svd.singular_values
                .iter()
                .enumerate()
                .fold(
                    (0, f64::INFINITY),
                    |(bi, bv), (i, &v)| {
                        if v < bv { (i, v) } else { (bi, bv) }
                    },
                );
        let ns = self.segments.len();
        let betas = self.betas(omega);
        let mut coeffs = vec![[0.0; 4]; ns];
        for (k, ck) in coeffs.iter_mut().enumerate() {
            for (c, x) in ck.iter_mut().enumerate() {
                *x = v_t[(imin, 4 * k + c)];
            }
        }
        let mut starts = Vec::with_capacity(ns);
        let mut x = 0.0;
        for s in &self.segments {
            starts.push(x);
            x += s.length;
        }
        let mut mode = Mode {
            omega,
            coeffs,
            betas: betas[..ns].to_vec(),
            starts,
            segments: self.segments.clone(),
        };
        // Unit modal mass and sign.
        let l = self.length();
        let (tip_w, tip_s) = (mode.phi(l), mode.slope(l));
        let mm = mode.integrate(|_, p| p * p)
            + self.tip_mass * tip_w * tip_w
            + self.tip_inertia * tip_s * tip_s;
        let sign = {
            let c = mode.derivative(0.0, 2);
            if c.abs() > 1e-9 * mode.derivative(0.0, 3).abs().max(1e-300) {
                c.signum()
            } else {
                mode.derivative(0.0, 3).signum()
            }
        };
        let scale = sign / mm.sqrt();
        if !scale.is_finite() {
            return Err(BeamError::InvalidData("degenerate mode shape".into()));
        }
        mode.coeffs
            .iter_mut()
            .for_each(|c| c.iter_mut().for_each(|x| *x *= scale));
        Ok(mode)
    }
}

impl Mode {
    fn locate(&self, x: f64) -> usize {
        let mut k = 0;
        for (i, &s) in self.starts.iter().enumerate() {
            if x >= s {
                k = i;
            }
        }
        k
    }

    /// `d`-th derivative of the shape at `x` [m from the hub] (`d` ≤ 3).
    pub fn derivative(&self, x: f64, d: usize) -> f64 {
        let k = self.locate(x);
        let s = &self.segments[k];
        let f = basis(self.betas[k], s.length, x - self.starts[k]);
        let c = &self.coeffs[k];
        let row = &f[d.min(3)];
        row.iter().zip(c).map(|(a, b)| a * b).sum()
    }

    /// `φ(x)` [1/√kg].
    pub fn phi(&self, x: f64) -> f64 {
        self.derivative(x, 0)
    }

    /// `φ'(x)` [1/(m·√kg)].
    pub fn slope(&self, x: f64) -> f64 {
        self.derivative(x, 1)
    }

    /// `∫ ρA(x) g(x, φ(x)) dx` over the beam (composite 5-point Gauss–Legendre on panels of at
    /// most 1/40 of the length, aligned with the segments).
    pub fn integrate(&self, g: impl Fn(f64, f64) -> f64) -> f64 {
        const X: [f64; 5] = [
            0.0,
            -0.538_469_310_105_683_1,
            0.538_469_310_105_683_1,
            -0.906_179_845_938_664,
            0.906_179_845_938_664,
        ];
        const W: [f64; 5] = [
            0.568_888_888_888_888_9,
            0.478_628_670_499_366_5,
            0.478_628_670_499_366_5,
            0.236_926_885_056_189_1,
            0.236_926_885_056_189_1,
        ];
        let total: f64 = self.segments.iter().map(|s| s.length).sum();
        let h_max = total / 40.0;
        let mut acc = 0.0;
        for (k, s) in self.segments.iter().enumerate() {
            let panels = (s.length / h_max).ceil().max(1.0) as usize;
            let h = s.length / panels as f64;
            for p in 0..panels {
                let mid = h * (p as f64 + 0.5);
                for (xi, wi) in X.iter().zip(W) {
                    let sl = mid + 0.5 * h * xi;
                    let f = basis(self.betas[k], s.length, sl);
                    let phi: f64 = f[0].iter().zip(&self.coeffs[k]).map(|(a, b)| a * b).sum();
                    acc += wi * 0.5 * h * s.rho_a * g(self.starts[k] + sl, phi);
                }
            }
        }
        acc
    }
}

/// Determinant by Gaussian elimination with partial pivoting (destroys `a`).
fn det_in_place(a: &mut [[f64; MAX_N]; MAX_N], n: usize) -> f64 {
    let mut det = 1.0;
    for col in 0..n {
        let mut p = col;
        let mut best = a[col][col].abs();
        for (r, row) in a.iter().enumerate().take(n).skip(col + 1) {
            if row[col].abs() > best {
                best = row[col].abs();
                p = r;
            }
        }
        if best == 0.0 {
            return 0.0;
        }
        if p != col {
            a.swap(p, col);
            det = -det;
        }
        let piv = a[col][col];
        det *= piv;
        let pivot_row = a[col];
        for row in a.iter_mut().take(n).skip(col + 1) {
            let f = row[col] / piv;
            if f != 0.0 {
                for (x, y) in row.iter_mut().zip(pivot_row.iter()).take(n).skip(col) {
                    *x -= f * y;
                }
            }
        }
    }
    det
}

/// Root of `f` in `[a, b]` with `f(a) f(b) < 0`: regula falsi, Illinois modification. The
/// iterate never leaves the bracket.
fn illinois(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64, mut fa: f64, mut fb: f64) -> f64 {
    let mut side = 0i8;
    for _ in 0..200 {
        let c = (a * fb - b * fa) / (fb - fa);
        if (b - a).abs() <= 4.0 * f64::EPSILON * b.abs() {
            return c;
        }
        let fc = f(c);
        if fc == 0.0 {
            return c;
        }
        if fc * fb < 0.0 {
            a = b;
            fa = fb;
            side = 0;
        } else {
            if side == 1 {
                fa *= 0.5;
            }
            side = 1;
        }
        b = c;
        fb = fc;
        if (b - a).abs() <= 1e-14 * b.abs() {
            return b;
        }
    }
    b
}

#[cfg(test)]
mod tests {
    use super::*;

    fn uniform() -> SegmentedBeam {
        // Any data: β L is dimensionless.
        SegmentedBeam::uniform(0.7, 2.0, 0.5).unwrap_or_else(|e| unreachable!("{e}"))
    }

    fn beta_l(b: &SegmentedBeam, w: f64) -> f64 {
        let s = b.segments()[0];
        b.length() * (w * w * s.rho_a / s.ei).sqrt().sqrt()
    }

    #[test]
    fn uniform_clamped_free_anchors() {
        let b = uniform();
        let w = b.frequencies(4).unwrap_or_default();
        assert_eq!(w.len(), 4);
        let expect = [1.875_104_068_7, 4.694_091_133, 7.854_757_438, 10.995_540_73];
        for (wi, e) in w.iter().zip(expect) {
            assert!(
                (beta_l(&b, *wi) - e).abs() < 1e-8,
                "{} vs {e}",
                beta_l(&b, *wi)
            );
        }
    }

    #[test]
    fn tip_mass_equal_to_beam_mass_anchors() {
        let u = uniform();
        let b =
            SegmentedBeam::new(u.segments(), u.mass(), 0.0).unwrap_or_else(|e| unreachable!("{e}"));
        let w = b.frequencies(2).unwrap_or_default();
        assert!(
            (beta_l(&b, w[0]) - 1.247_917).abs() < 2e-6,
            "{}",
            beta_l(&b, w[0])
        );
        assert!(
            (beta_l(&b, w[1]) - 4.031_139).abs() < 2e-6,
            "{}",
            beta_l(&b, w[1])
        );
    }

    #[test]
    fn splitting_a_uniform_beam_changes_nothing() {
        let s = Segment {
            length: 0.2,
            ei: 2.0,
            rho_a: 0.5,
        };
        let b3 = SegmentedBeam::new(
            &[
                s,
                Segment { length: 0.35, ..s },
                Segment { length: 0.15, ..s },
            ],
            0.0,
            0.0,
        )
        .unwrap_or_else(|e| unreachable!("{e}"));
        let w1 = uniform().frequencies(3).unwrap_or_default();
        let w3 = b3.frequencies(3).unwrap_or_default();
        assert_eq!((w1.len(), w3.len()), (3, 3), "three frequencies from each");
        for (a, b) in w1.iter().zip(&w3) {
            assert!((a / b - 1.0).abs() < 1e-11);
        }
    }

    #[test]
    fn modes_match_core_uniform_shapes() {
        // Unit modal mass for a link of 0.3 kg over 0.7 m: the core's closed form.
        let b = SegmentedBeam::uniform(0.7, 3.0, 0.3 / 0.7).unwrap_or_else(|e| unreachable!("{e}"));
        let modes = b.modes(2).unwrap_or_default();
        assert_eq!(modes.len(), 2);
        for (j, m) in modes.iter().enumerate() {
            let u = flexarm_core::modes::UniformMode::<f64>::new(j, 0.3, 0.7);
            for x in [0.0, 0.1, 0.33, 0.5, 0.7] {
                assert!((m.phi(x) - u.phi(x)).abs() < 1e-8, "mode {j} x {x}");
                assert!((m.slope(x) - u.slope(x)).abs() < 1e-7, "mode {j} x {x}");
            }
            let v = m.integrate(|_, p| p);
            let w = m.integrate(|x, p| x * p);
            assert!((v - u.mass_integral()).abs() < 1e-9);
            assert!((w - u.moment_integral()).abs() < 1e-9);
        }
    }

    #[test]
    fn high_modes_do_not_overflow() {
        // β L up to ~ 60: cosh would be 1e26 and lose every digit of the determinant.
        let b = uniform();
        let w = b.frequencies(20).unwrap_or_default();
        assert_eq!(w.len(), 20);
        let bl = beta_l(&b, w[19]);
        // Asymptote (2j − 1) π / 2.
        assert!(
            (bl - 39.0 * std::f64::consts::FRAC_PI_2).abs() < 1e-6,
            "{bl}"
        );
    }

    #[test]
    fn bad_data_is_an_error() {
        assert!(SegmentedBeam::uniform(0.7, -1.0, 0.5).is_err());
        assert!(SegmentedBeam::uniform(f64::NAN, 1.0, 0.5).is_err());
        assert!(SegmentedBeam::new(&[], 0.0, 0.0).is_err());
        let s = Segment {
            length: 0.7,
            ei: 1.0,
            rho_a: 1.0,
        };
        assert!(SegmentedBeam::new(&[s], -1.0, 0.0).is_err());
    }
}

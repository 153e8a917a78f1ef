//! Eigenvalues of a small dense real matrix (the spillover study's closed loops, at most a few
//! dozen states). Host side, `f64`.
//!
//! nalgebra's `complex_eigenvalues` is not reliable on these matrices: on the loop "10 kHz, 5 kHz
//! amplifier, no delay" it returned a spectral radius of 1.070 where the eigenvalues of the same
//! matrix to 40 digits give 1.00004 (issue 35). The loops mix entries from 1e-12 (the patch's
//! modal force over one period) to 1e4 (the rate filter's gain), and their eigenvalues cluster
//! near `z = 1` (the modes sampled at 10 kHz). This module does what LAPACK's `dgeev` does for
//! eigenvalues only, written for these sizes:
//!
//! 1. **Balancing** (Parlett–Reinsch): a diagonal similarity by powers of two, exact in floating
//!    point, that makes each row's and column's off-diagonal 1-norms comparable;
//! 2. **Hessenberg form** by Householder reflections (an orthogonal similarity);
//! 3. **Francis's implicit double-shift QR** on the active window, deflating a subdiagonal
//!    entry when it is negligible by the Ahues–Tisseur test (the one LAPACK's `dlahqr` uses,
//!    conservative on graded and non-normal matrices), with exceptional shifts after 10 and 20
//!    sweeps without deflation;
//! 4. the eigenvalues of the 1×1 and 2×2 diagonal blocks of the quasi-triangular result, the 2×2
//!    ones in a form without cancellation.
//!
//! **Accuracy.** Each step is backward stable: the eigenvalues returned are exact for a matrix
//! `M + E` with `‖E‖` a small multiple of `ε‖M‖` (balanced). How far that moves an eigenvalue
//! depends on its condition; [`backward_error`] measures `‖(M − λI)x‖ / (‖M‖ ‖x‖)` for a vector
//! `x` from one step of inverse iteration, an upper bound of the smallest `‖E‖/‖M‖` that makes
//! `λ` exact. `host/tests/eigen.rs` checks known spectra (well-conditioned, scaled over 16
//! decades, non-normal and clustered), the loop against 40-digit references, and the
//! backward error of every eigenvalue of the study's loops (below 1e-15 of `‖M‖_F`).

use nalgebra::{Complex, DMatrix, DVector};

/// Why the eigenvalues could not be computed.
#[derive(Clone, Debug, PartialEq)]
pub enum EigenError {
    /// The matrix is not square.
    NotSquare,
    /// An entry is NaN or infinite.
    NotFinite,
    /// The QR iteration did not converge in `30 n` sweeps.
    NoConvergence,
}

impl core::fmt::Display for EigenError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::NotSquare => "the matrix is not square",
            Self::NotFinite => "the matrix has a NaN or infinite entry",
            Self::NoConvergence => "the QR iteration did not converge",
        })
    }
}

impl std::error::Error for EigenError {}

/// The eigenvalues of the real square matrix `m` (in no particular order; complex ones in
/// conjugate pairs).
pub fn eigenvalues(m: &DMatrix<f64>) -> Result<Vec<Complex<f64>>, EigenError> {
    let n = m.nrows();
    if m.ncols() != n {
        return Err(EigenError::NotSquare);
    }
    if !m.iter().all(|x| x.is_finite()) {
        return Err(EigenError::NotFinite);
    }
    let mut h = m.clone();
    balance(&mut h);
    hessenberg(&mut h);
    hqr(&mut h)
}

/// The largest `|λ|` of `m`.
pub fn spectral_radius(m: &DMatrix<f64>) -> Result<f64, EigenError> {
    Ok(eigenvalues(m)?.iter().map(|l| l.norm()).fold(0.0, f64::max))
}

/// Diagonal similarity `D⁻¹ A D` by powers of two until no row/column pair's off-diagonal
/// 1-norms change their sum by more than 5 %.
fn balance(a: &mut DMatrix<f64>) {
    const RADIX: f64 = 2.0;
    let n = a.nrows();
    let mut done = false;
    while !done {
        done = true;
        for i in 0..n {
            let (mut c, mut r) = (0.0, 0.0);
            for j in (0..n).filter(|j| *j != i) {
                c += a[(j, i)].abs();
                r += a[(i, j)].abs();
            }
            if c == 0.0 || r == 0.0 {
                continue;
            }
            let s = c + r;
            let mut f = 1.0;
            // Bring the column norm within a factor RADIX of the row norm.
            let (mut cc, lo, hi) = (c, r / RADIX, r * RADIX);
            while cc < lo {
                f *= RADIX;
                cc *= RADIX * RADIX;
            }
            while cc > hi {
                f /= RADIX;
                cc /= RADIX * RADIX;
            }
            if (cc + r) / f < 0.95 * s {
                done = false;
                // Column i times f, row i divided by f.
                for j in 0..n {
                    a[(j, i)] *= f;
                    a[(i, j)] /= f;
                }
            }
        }
    }
}

/// A Householder reflection `P = I − τ u uᵀ` (`u[0] = 1`) with `P x = β e₁`; `None` when `x` is
/// already a multiple of `e₁`.
fn householder(x: &[f64]) -> Option<(Vec<f64>, f64)> {
    let tail: f64 = x[1..].iter().map(|v| v * v).sum();
    if tail == 0.0 {
        return None;
    }
    let norm = (x[0] * x[0] + tail).sqrt();
    let beta = if x[0] >= 0.0 { -norm } else { norm };
    let u0 = x[0] - beta;
    let mut u = Vec::with_capacity(x.len());
    u.push(1.0);
    u.extend(x[1..].iter().map(|v| v / u0));
    let tau = (beta - x[0]) / beta;
    Some((u, tau))
}

/// Applies `P = I − τ u uᵀ` from the left to rows `r0 .. r0 + u.len()`, columns `cols`.
fn reflect_rows(
    a: &mut DMatrix<f64>,
    u: &[f64],
    tau: f64,
    r0: usize,
    cols: core::ops::Range<usize>,
) {
    for j in cols {
        let s: f64 = u
            .iter()
            .enumerate()
            .map(|(k, uk)| uk * a[(r0 + k, j)])
            .sum();
        for (k, uk) in u.iter().enumerate() {
            a[(r0 + k, j)] -= tau * uk * s;
        }
    }
}

/// Applies `P` from the right to columns `c0 .. c0 + u.len()`, rows `rows`.
fn reflect_cols(
    a: &mut DMatrix<f64>,
    u: &[f64],
    tau: f64,
    c0: usize,
    rows: core::ops::Range<usize>,
) {
    for i in rows {
        let s: f64 = u
            .iter()
            .enumerate()
            .map(|(k, uk)| uk * a[(i, c0 + k)])
            .sum();
        for (k, uk) in u.iter().enumerate() {
            a[(i, c0 + k)] -= tau * uk * s;
        }
    }
}

/// Upper Hessenberg form by Householder similarities.
fn hessenberg(a: &mut DMatrix<f64>) {
    let n = a.nrows();
    for k in 0..n.saturating_sub(2) {
        let x: Vec<f64> = (k + 1..n).map(|i| a[(i, k)]).collect();
        if let Some((u, tau)) = householder(&x) {
            reflect_rows(a, &u, tau, k + 1, k..n);
            reflect_cols(a, &u, tau, k + 1, 0..n);
            for i in k + 2..n {
                a[(i, k)] = 0.0;
            }
        }
    }
}

/// Whether the subdiagonal entry `h[k, k−1]` is negligible (Ahues–Tisseur): against its
/// diagonal neighbours, and, when that passes, against the 2×2 block's own scale, so that
/// deflating changes no eigenvalue by more than a rounding of the block.
fn negligible(h: &DMatrix<f64>, k: usize, norm: f64) -> bool {
    let ulp = f64::EPSILON;
    let small = f64::MIN_POSITIVE * (h.nrows() as f64 / ulp);
    let sub = h[(k, k - 1)].abs();
    if sub <= small {
        return true;
    }
    let mut tst = h[(k - 1, k - 1)].abs() + h[(k, k)].abs();
    if tst == 0.0 {
        tst = norm;
    }
    if sub > ulp * tst {
        return false;
    }
    let sup = h[(k - 1, k)].abs();
    let (ab, ba) = (sub.max(sup), sub.min(sup));
    let diff = (h[(k - 1, k - 1)] - h[(k, k)]).abs();
    let hkk = h[(k, k)].abs();
    let (aa, bb) = (hkk.max(diff), hkk.min(diff));
    let s = aa + ab;
    ba * (ab / s) <= small.max(ulp * (bb * (aa / s)))
}

/// The eigenvalues of `[[a, b], [c, d]]`, without cancellation in the real case.
fn block2(a: f64, b: f64, c: f64, d: f64) -> [Complex<f64>; 2] {
    let p = 0.5 * (a - d);
    let bc = b * c;
    let disc = p * p + bc;
    if disc >= 0.0 {
        let z = p + disc.sqrt().copysign(p);
        if z == 0.0 {
            return [Complex::new(d, 0.0); 2];
        }
        [Complex::new(d + z, 0.0), Complex::new(d - bc / z, 0.0)]
    } else {
        let (re, im) = (d + p, (-disc).sqrt());
        [Complex::new(re, im), Complex::new(re, -im)]
    }
}

/// Francis double-shift QR on the upper Hessenberg `h` (eigenvalues only: the transformations
/// are applied to the active window).
fn hqr(h: &mut DMatrix<f64>) -> Result<Vec<Complex<f64>>, EigenError> {
    let n = h.nrows();
    let mut out = Vec::with_capacity(n);
    let norm = h
        .iter()
        .map(|x| x.abs())
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    let mut budget = 30 * n.max(1);
    let mut m = n; // the active window is l ..= m − 1
    let mut its = 0;
    while m > 0 {
        // The lowest negligible subdiagonal entry splits the window.
        let mut l = m - 1;
        while l > 0 && !negligible(h, l, norm) {
            l -= 1;
        }
        if l > 0 {
            h[(l, l - 1)] = 0.0;
        }
        let size = m - l;
        if size == 1 {
            out.push(Complex::new(h[(m - 1, m - 1)], 0.0));
            m -= 1;
            its = 0;
            continue;
        }
        if size == 2 {
            let (a, b, c, d) = (
                h[(m - 2, m - 2)],
                h[(m - 2, m - 1)],
                h[(m - 1, m - 2)],
                h[(m - 1, m - 1)],
            );
            out.extend(block2(a, b, c, d));
            m -= 2;
            its = 0;
            continue;
        }
        if budget == 0 {
            return Err(EigenError::NoConvergence);
        }
        budget -= 1;
        its += 1;
        let e = m - 1;
        // The shifts: the eigenvalues of the trailing 2×2 block (their sum s and product t),
        // or exceptional ones after 10 and 20 sweeps without a deflation.
        let (s, t) = if its % 10 == 0 {
            let w = h[(e, e - 1)].abs() + h[(e - 1, e - 2)].abs();
            (1.5 * w, w * w)
        } else {
            (
                h[(e - 1, e - 1)] + h[(e, e)],
                h[(e - 1, e - 1)] * h[(e, e)] - h[(e - 1, e)] * h[(e, e - 1)],
            )
        };
        // First column of (H − μ1 I)(H − μ2 I), rows l .. l + 2.
        let mut x = h[(l, l)] * h[(l, l)] + h[(l, l + 1)] * h[(l + 1, l)] - s * h[(l, l)] + t;
        let mut y = h[(l + 1, l)] * (h[(l, l)] + h[(l + 1, l + 1)] - s);
        let mut z = h[(l + 1, l)] * h[(l + 2, l + 1)];
        for k in l..e - 1 {
            if let Some((u, tau)) = householder(&[x, y, z]) {
                let c0 = if k > l { k - 1 } else { l };
                reflect_rows(h, &u, tau, k, c0..m);
                reflect_cols(h, &u, tau, k, l..(k + 4).min(m));
                if k > l {
                    h[(k + 1, k - 1)] = 0.0;
                    h[(k + 2, k - 1)] = 0.0;
                }
            }
            x = h[(k + 1, k)];
            y = h[(k + 2, k)];
            if k + 3 < m {
                z = h[(k + 3, k)];
            }
        }
        // The last 2×2 reflection, rows e − 1, e.
        if let Some((u, tau)) = householder(&[x, y]) {
            reflect_rows(h, &u, tau, e - 1, e - 2..m);
            reflect_cols(h, &u, tau, e - 1, l..m);
            h[(e, e - 2)] = 0.0;
        }
    }
    Ok(out)
}

/// The backward error of `lambda` as an eigenvalue of `m`: `‖(M − λI)x‖ / (‖M‖_F ‖x‖)` for `x`
/// from one step of inverse iteration (LU with partial pivoting) from a fixed start. It bounds
/// the relative size of the smallest perturbation `E` for which `λ` is an exact eigenvalue of
/// `M + E`.
pub fn backward_error(m: &DMatrix<f64>, lambda: Complex<f64>) -> f64 {
    let n = m.nrows();
    let a = m.map(|v| Complex::new(v, 0.0)) - DMatrix::<Complex<f64>>::identity(n, n) * lambda;
    // A start with every component, not aligned with anything in particular.
    let b = DVector::<Complex<f64>>::from_fn(n, |i, _| {
        Complex::new(1.0 + 0.37 * i as f64, 0.5 - 0.11 * i as f64)
    });
    let x = match a.clone().lu().solve(&b) {
        Some(x) if x.iter().all(|v| v.re.is_finite() && v.im.is_finite()) && x.norm() > 0.0 => x,
        // Singular to working precision: λ is an eigenvalue of M itself.
        _ => return 0.0,
    };
    (&a * &x).norm() / (m.norm() * x.norm())
}

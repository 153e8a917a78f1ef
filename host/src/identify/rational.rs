//! The common-denominator rational fit of a record's spectra, and the modes it finds.
//!
//! Every path from an input to the output shares the system's poles, so the output is fitted
//! as `Y = Σ_i N_i(s)/D(s) · U_i` with one monic denominator `D` of degree `n` and a numerator
//! per input (of higher degree than `D`: it carries the quasi-static part of the modes above
//! the band). Why this fit: it is linear once `D` is fixed, it uses every line and every input
//! of the band together, and the poles, hence frequencies and damping ratios, come out of one
//! polynomial; ERA or a matrix pencil need an impulse response or a free decay, which a record
//! excited through a servo loop does not give.
//!
//! The fit is Levy's linearization of each of the spectra's equations
//! ([`super::spectra::Row`]): `D(s_k) y − Σ_i N_i(s_k) u_i − T_w(s_k) ≈ 0`, least squares over
//! the lines `s_k = j 2π f_k`, with a transient polynomial `T_w` per whole window, refined by
//! Sanathanan–Koerner iterations: each pass divides the equations by `|D(s_k)|` of the pass
//! before, so that the error it minimizes tends to the output's own `Y − Σ N_i U_i/D`. `s` is
//! scaled by the band's top and every column of the least squares to unit norm, so that the
//! polynomials stay well conditioned. An input's numerator can start at `s²` (an angle whose
//! acceleration is what drives the link).
//!
//! ## Uncertainty
//! The last pass is a linear least squares `A x ≈ b` whose residuals estimate the equations'
//! noise, `σ² = |r|²/(rows − unknowns)`; the coefficients' covariance is `σ² (AᵀA)⁻¹`. Each
//! pole's and residue's spread is that covariance carried through the roots: the fit is
//! redone for [`SAMPLES`] coefficient vectors drawn from it (the poles of each draw matched to
//! the nominal ones) and the standard deviations taken.

use nalgebra::{DMatrix, DVector};
use rustfft::num_complex::Complex64;

use super::IdentifyError;
use super::spectra::Spectra;

/// `D`, the `N_i` and the transient polynomials in the scaled variable `σ = s / scale`,
/// coefficients from `σ⁰` up, and the coefficients' covariance.
#[derive(Clone, Debug, PartialEq)]
pub struct RationalFit {
    /// The denominator's coefficients `d_0 … d_{n−1}` (monic: `d_n = 1` is implied).
    pub den: Vec<f64>,
    /// Each input's numerator coefficients, from `σ^low[i]` up.
    pub num: Vec<Vec<f64>>,
    /// Each input's numerator's lowest power.
    pub low: Vec<usize>,
    /// The frequency scale [rad/s].
    pub scale: f64,
    /// Draws of `(den, num)` from the coefficients' covariance (module docs).
    pub draws: Vec<(Vec<f64>, Vec<Vec<f64>>)>,
    /// RMS of the last pass's weighted residuals over RMS of its right-hand side [-].
    pub residual: f64,
}

fn poly(c: &[f64], x: Complex64) -> Complex64 {
    c.iter()
        .rev()
        .fold(Complex64::new(0.0, 0.0), |acc, &a| acc * x + a)
}

/// Draws from the covariance per fit.
pub const SAMPLES: usize = 48;

/// The roots of the monic polynomial `σⁿ + Σ den_k σᵏ`, times `scale`.
fn roots(den: &[f64], scale: f64) -> Vec<Complex64> {
    let n = den.len();
    let mut c = DMatrix::<f64>::zeros(n, n);
    for k in 0..n {
        c[(0, k)] = -den[n - 1 - k];
        if k + 1 < n {
            c[(k + 1, k)] = 1.0;
        }
    }
    c.complex_eigenvalues().iter().map(|p| p * scale).collect()
}

impl RationalFit {
    fn d_of(den: &[f64], sigma: Complex64) -> Complex64 {
        poly(den, sigma) + sigma.powu(den.len() as u32)
    }

    fn n_of(&self, num: &[f64], i: usize, sigma: Complex64) -> Complex64 {
        poly(num, sigma) * sigma.powu(self.low[i] as u32)
    }

    /// Input `i`'s fitted response at `f` [Hz].
    pub fn eval(&self, i: usize, f: f64) -> Complex64 {
        let sigma = Complex64::new(0.0, std::f64::consts::TAU * f / self.scale);
        self.n_of(&self.num[i], i, sigma) / Self::d_of(&self.den, sigma)
    }

    /// The poles [rad/s] (the roots of `D`, from its companion matrix's eigenvalues).
    pub fn poles(&self) -> Vec<Complex64> {
        roots(&self.den, self.scale)
    }

    /// The residue of input `i`'s response at the simple pole `p` [rad/s] of `poles` (in the
    /// response's units times rad/s), for the numerators `num`.
    fn residue_of(
        &self,
        num: &[Vec<f64>],
        i: usize,
        p: Complex64,
        poles: &[Complex64],
    ) -> Complex64 {
        let sigma = p / self.scale;
        let others: Complex64 = poles
            .iter()
            .filter(|q| (**q - p).norm() > 1e-9 * p.norm().max(1.0))
            .map(|q| sigma - q / self.scale)
            .product();
        self.n_of(&num[i], i, sigma) / others * self.scale
    }

    /// The residue of input `i`'s response at the simple pole `p` [rad/s]: `N_i(p) / D'(p)`.
    pub fn residue(&self, i: usize, p: Complex64) -> Complex64 {
        self.residue_of(&self.num, i, p, &self.poles())
    }

    /// The standard deviations of the pole `p`'s natural frequency [rad/s] and damping ratio,
    /// and of `f(residue_i(p))` for each input `i` (module docs), over the draws.
    pub fn spread(
        &self,
        p: Complex64,
        value: impl Fn(usize, Complex64, Complex64) -> f64,
    ) -> (f64, f64, Vec<f64>) {
        let m = self.num.len();
        let (mut w, mut z, mut v) = (Vec::new(), Vec::new(), vec![Vec::new(); m]);
        for (den, num) in &self.draws {
            let poles = roots(den, self.scale);
            let Some(q) = poles
                .iter()
                .copied()
                .min_by(|a, b| (a - p).norm().total_cmp(&(b - p).norm()))
            else {
                continue;
            };
            w.push(q.norm());
            z.push(-q.re / q.norm().max(f64::MIN_POSITIVE));
            for (i, vi) in v.iter_mut().enumerate() {
                vi.push(value(i, q, self.residue_of(num, i, q, &poles)));
            }
        }
        (
            std_dev(&w),
            std_dev(&z),
            v.iter().map(|x| std_dev(x)).collect(),
        )
    }
}

fn std_dev(x: &[f64]) -> f64 {
    let x: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
    if x.len() < 2 {
        return f64::NAN;
    }
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (x.len() - 1) as f64).sqrt()
}

/// The fit's shape: the denominator's degree, each input's numerator powers `low..=high`, the
/// transient polynomials' degree, the Sanathanan–Koerner passes.
#[derive(Clone, Debug, PartialEq)]
pub struct Shape {
    /// Degree of `D`.
    pub order: usize,
    /// Per input, its numerator's lowest and highest power.
    pub num: Vec<(usize, usize)>,
    /// Degree of each window's transient polynomial.
    pub transient: usize,
    /// Passes.
    pub iterations: usize,
    /// Draw the coefficients' spread ([`RationalFit::draws`]).
    pub spread: bool,
    /// Each line's equations are divided by its frequency to this power (module docs).
    pub tilt: f64,
}

/// Fits `sp` with the shape `shape`. The transient polynomials, when the spectra have
/// windows, are projected out window by window (each pass's rows of a window onto the
/// complement of its polynomial's columns): the least squares left has the denominator's and
/// numerators' coefficients only, with the same solution. An error when the equations are too
/// few for the unknowns or the least squares fail.
pub fn fit(sp: &Spectra, shape: &Shape) -> Result<RationalFit, IdentifyError> {
    let order = shape.order;
    let m = shape.num.len();
    let lines: Vec<usize> = (0..sp.freq.len())
        .filter(|&k| {
            sp.rows[k].iter().all(|r| {
                r.y.re.is_finite() && r.u.len() == m && r.u.iter().all(|u| u.re.is_finite())
            })
        })
        .collect();
    let num_cols: usize = shape.num.iter().map(|(lo, hi)| hi + 1 - lo).sum();
    let t_len = shape.transient + 1;
    let unknowns = order + num_cols;
    let rows: usize = lines.iter().map(|&k| 2 * sp.rows[k].len()).sum();
    // Each window's rows, for its transient polynomial.
    let mut by_window: Vec<Vec<usize>> = vec![Vec::new(); sp.windows];
    let mut r = 0;
    for &k in &lines {
        for row in &sp.rows[k] {
            if let Some(w) = row.window.filter(|w| *w < sp.windows) {
                by_window[w].extend([r, r + 1]);
            }
            r += 2;
        }
    }
    let t_cols = by_window.iter().filter(|w| !w.is_empty()).count() * t_len;
    if rows < 2 * (unknowns + t_cols) {
        return Err(IdentifyError::Data(format!(
            "{} lines for {} coefficients: give a longer record or a wider band",
            lines.len(),
            unknowns + t_cols
        )));
    }
    let scale = std::f64::consts::TAU * sp.freq.last().copied().unwrap_or(1.0);
    let mut current = RationalFit {
        den: vec![0.0; order],
        num: shape
            .num
            .iter()
            .map(|(lo, hi)| vec![0.0; hi + 1 - lo])
            .collect(),
        low: shape.num.iter().map(|(lo, _)| *lo).collect(),
        scale,
        draws: Vec::new(),
        residual: f64::NAN,
    };
    let top = order
        .max(shape.num.iter().map(|x| x.1).max().unwrap_or(0))
        .max(shape.transient);
    let mut a = DMatrix::<f64>::zeros(rows, unknowns);
    let mut t = DMatrix::<f64>::zeros(rows, t_len);
    let mut b = DVector::<f64>::zeros(rows);
    for pass in 0..shape.iterations.max(1) {
        let mut r = 0;
        for &k in &lines {
            let sigma = Complex64::new(sp.shift, std::f64::consts::TAU * sp.freq[k]) / scale;
            let w = if pass == 0 {
                1.0
            } else {
                1.0 / RationalFit::d_of(&current.den, sigma).norm()
            };
            // Each octave counts alike: a mode's lines grow with its frequency.
            let w = w * sp.freq[k].powf(-shape.tilt);
            let pw: Vec<Complex64> = (0..=top).map(|p| sigma.powu(p as u32)).collect();
            for row in &sp.rows[k] {
                let put = |m: &mut DMatrix<f64>, c: usize, x: Complex64| {
                    m[(r, c)] = x.re * w;
                    m[(r + 1, c)] = x.im * w;
                };
                for (l, p) in pw.iter().enumerate().take(order) {
                    put(&mut a, l, row.y * p);
                }
                let mut col = order;
                for (i, (lo, hi)) in shape.num.iter().enumerate() {
                    for x in &pw[*lo..=*hi] {
                        put(&mut a, col, -row.u[i] * x);
                        col += 1;
                    }
                }
                for (p, x) in pw.iter().enumerate().take(t_len) {
                    put(&mut t, p, -*x);
                }
                let rhs = -row.y * pw[order];
                b[r] = rhs.re * w;
                b[r + 1] = rhs.im * w;
                r += 2;
            }
        }
        // The transient polynomials out, window by window.
        for idx in by_window.iter().filter(|w| !w.is_empty()) {
            let q = t.select_rows(idx.iter()).qr().q();
            let aw = a.select_rows(idx.iter());
            let aw = &aw - &q * (q.transpose() * &aw);
            let bw = b.select_rows(idx.iter());
            let bw = &bw - &q * (q.transpose() * &bw);
            for (i, &row) in idx.iter().enumerate() {
                a.row_mut(row).copy_from(&aw.row(i));
                b[row] = bw[i];
            }
        }
        // Columns to unit norm: the solution's scale does not change, its conditioning does.
        let norms: Vec<f64> = (0..unknowns)
            .map(|c| a.column(c).norm().max(f64::MIN_POSITIVE))
            .collect();
        let mut scaled = a.clone();
        for (c, n) in norms.iter().enumerate() {
            scaled.column_mut(c).scale_mut(1.0 / n);
        }
        // The tall problem reduced to its triangle first: the QR of [A | b] gives
        // [[R, r], [0, ρ]], whose small R the SVD solves, ρ² the residual's share beyond it.
        let mut ab = DMatrix::<f64>::zeros(rows, unknowns + 1);
        ab.view_mut((0, 0), (rows, unknowns)).copy_from(&scaled);
        ab.column_mut(unknowns).copy_from(&b);
        let tri = ab.qr().r();
        let r11 = tri.view((0, 0), (unknowns, unknowns)).into_owned();
        let r12 = tri
            .view((0, unknowns), (unknowns, 1))
            .column(0)
            .into_owned();
        let r22 = tri[(unknowns, unknowns)];
        let svd = r11.clone().svd(true, true);
        let y = svd
            .solve(&r12, 1e-12)
            .map_err(|e| IdentifyError::Data(format!("the rational fit's least squares: {e}")))?;
        if y.iter().any(|v| !v.is_finite()) {
            return Err(IdentifyError::Data(
                "the rational fit did not converge to finite coefficients".into(),
            ));
        }
        let x = DVector::from_iterator(unknowns, y.iter().zip(&norms).map(|(v, n)| v / n));
        current.den = x.rows(0, order).iter().copied().collect();
        let mut col = order;
        for (num, (lo, hi)) in current.num.iter_mut().zip(&shape.num) {
            *num = x.rows(col, hi + 1 - lo).iter().copied().collect();
            col += hi + 1 - lo;
        }
        if pass + 1 == shape.iterations.max(1) {
            let res2 = r22 * r22 + (&r11 * &y - &r12).norm_squared();
            current.residual = (res2 / b.norm_squared().max(f64::MIN_POSITIVE)).sqrt();
            if shape.spread {
                let dof = rows.saturating_sub(unknowns + t_cols).max(1) as f64;
                let sigma2 = res2 / dof;
                current.draws = draws(&svd, &norms, sigma2, &current, order, &shape.num);
            }
        }
    }
    Ok(current)
}

/// [`SAMPLES`] coefficient vectors from `N(x, σ² (AᵀA)⁻¹)` (`A = U S Vᵀ` of the column-scaled
/// problem, `norms` its column scales), as `(den, num)`.
fn draws(
    svd: &nalgebra::SVD<f64, nalgebra::Dyn, nalgebra::Dyn>,
    norms: &[f64],
    sigma2: f64,
    x: &RationalFit,
    order: usize,
    num: &[(usize, usize)],
) -> Vec<(Vec<f64>, Vec<Vec<f64>>)> {
    let (Some(v_t), s) = (&svd.v_t, &svd.singular_values) else {
        return Vec::new();
    };
    let smax = s.max();
    let sigma = sigma2.sqrt();
    let mut rng = crate::sim::Rng::new(0x5eed);
    (0..SAMPLES)
        .map(|_| {
            // δy = σ V S⁻¹ z over the singular values the solve kept.
            let mut dy = DVector::<f64>::zeros(norms.len());
            for (k, sk) in s.iter().enumerate() {
                if *sk > 1e-12 * smax {
                    let z = rng.normal() * sigma / sk;
                    dy += v_t.row(k).transpose() * z;
                }
            }
            let d: Vec<f64> = (0..order).map(|c| x.den[c] + dy[c] / norms[c]).collect();
            let mut col = order;
            let n: Vec<Vec<f64>> = num
                .iter()
                .zip(&x.num)
                .map(|((lo, hi), base)| {
                    let out = (0..=hi - lo)
                        .map(|p| base[p] + dy[col + p] / norms[col + p])
                        .collect();
                    col += hi + 1 - lo;
                    out
                })
                .collect();
            (d, n)
        })
        .collect()
}

/// A mode the fit found.
#[derive(Clone, Debug, PartialEq)]
pub struct FittedMode {
    /// Natural frequency `ω` [rad/s].
    pub omega: f64,
    /// Damping ratio `ζ` [-].
    pub zeta: f64,
    /// The pole `−ζω + jω√(1−ζ²)` [rad/s].
    pub pole: Complex64,
}

/// The fit's lightly damped poles (upper half plane, `ζ < 0.5`) in ascending frequency, and the
/// real (or overdamped) ones.
pub fn modes(fit: &RationalFit) -> (Vec<FittedMode>, Vec<Complex64>) {
    let mut modes = Vec::new();
    let mut other = Vec::new();
    for p in fit.poles() {
        let omega = p.norm();
        let zeta = -p.re / omega.max(f64::MIN_POSITIVE);
        if p.im > 0.0 && zeta < 0.5 {
            modes.push(FittedMode {
                omega,
                zeta,
                pole: p,
            });
        } else if (p.im.abs() < 1e-9 * omega.max(1.0) || zeta >= 0.5) && p.im >= 0.0 {
            other.push(p);
        }
    }
    modes.sort_by(|a, b| a.omega.total_cmp(&b.omega));
    (modes, other)
}

//! The common-denominator rational fit of frequency responses, and the modes it finds.
//!
//! Every response of one output shares the system's poles, so all of them are fitted at once
//! as `H_i(s) = N_i(s) / D(s)` with one monic denominator `D` of degree `n` and a numerator of
//! its own degree per input (a numerator of higher degree than `D` carries the quasi-static
//! part of the modes above the band). Why this fit: it is linear once `D` is fixed, it uses
//! every line and every input of the band together, and the poles, hence frequencies and
//! damping ratios, come out of one polynomial; ERA or a matrix pencil would need an impulse
//! response, which a record excited through a servo loop does not give.
//!
//! The fit is Levy's linearization `D(s_k) H_ik − N_i(s_k) ≈ 0`, least squares over the lines
//! `s_k = j 2π f_k`, refined by Sanathanan–Koerner iterations: each pass divides the equations
//! by `|D(s_k)|` of the pass before, so that the error it minimizes tends to the responses'
//! own `H − N/D`. Each input's equations are scaled by its response's RMS over the band so
//! that the inputs count alike, each line is weighted by its coherence, and `s` is scaled by
//! the band's top so that the polynomials stay well conditioned.

use nalgebra::{DMatrix, DVector};
use rustfft::num_complex::Complex64;

use super::IdentifyError;
use super::frf::Frf;

/// `D` and the `N_i` in the scaled variable `σ = s / scale`, coefficients from `σ⁰` up.
#[derive(Clone, Debug, PartialEq)]
pub struct RationalFit {
    /// The denominator's coefficients `d_0 … d_{n−1}` (monic: `d_n = 1` is implied).
    pub den: Vec<f64>,
    /// Each input's numerator coefficients.
    pub num: Vec<Vec<f64>>,
    /// The frequency scale [rad/s].
    pub scale: f64,
}

fn poly(c: &[f64], x: Complex64) -> Complex64 {
    c.iter()
        .rev()
        .fold(Complex64::new(0.0, 0.0), |acc, &a| acc * x + a)
}

impl RationalFit {
    fn d(&self, sigma: Complex64) -> Complex64 {
        poly(&self.den, sigma) + sigma.powu(self.den.len() as u32)
    }

    /// Input `i`'s fitted response at `f` [Hz].
    pub fn eval(&self, i: usize, f: f64) -> Complex64 {
        let sigma = Complex64::new(0.0, std::f64::consts::TAU * f / self.scale);
        poly(&self.num[i], sigma) / self.d(sigma)
    }

    /// The poles [rad/s] (the roots of `D`, from its companion matrix's eigenvalues).
    pub fn poles(&self) -> Vec<Complex64> {
        let n = self.den.len();
        let mut c = DMatrix::<f64>::zeros(n, n);
        for k in 0..n {
            c[(0, k)] = -self.den[n - 1 - k];
            if k + 1 < n {
                c[(k + 1, k)] = 1.0;
            }
        }
        c.complex_eigenvalues()
            .iter()
            .map(|p| p * self.scale)
            .collect()
    }

    /// The residue of input `i`'s response at the simple pole `p` [rad/s] (in the response's
    /// units times rad/s): `N_i(p) / D'(p)`, with `D'(p)` the product over the other poles.
    pub fn residue(&self, i: usize, p: Complex64, poles: &[Complex64]) -> Complex64 {
        let sigma = p / self.scale;
        let others: Complex64 = poles
            .iter()
            .filter(|q| (**q - p).norm() > 1e-9 * p.norm().max(1.0))
            .map(|q| sigma - q / self.scale)
            .product();
        poly(&self.num[i], sigma) / others * self.scale
    }
}

/// Fits `frf` with a denominator of degree `order` and numerators of `num_degree[i]`, over
/// `iterations` Sanathanan–Koerner passes. An error when the lines are too few for the
/// unknowns or the least squares fail.
pub fn fit(
    frf: &Frf,
    order: usize,
    num_degree: &[usize],
    iterations: usize,
) -> Result<RationalFit, IdentifyError> {
    let m = num_degree.len();
    let lines: Vec<usize> = (0..frf.freq.len())
        .filter(|&k| frf.coherence[k] > 0.0 && frf.h[k].iter().all(|h| h.re.is_finite()))
        .collect();
    let unknowns = order + num_degree.iter().map(|d| d + 1).sum::<usize>();
    if lines.len() * m * 2 < 2 * unknowns {
        return Err(IdentifyError::Data(format!(
            "{} usable lines for {unknowns} coefficients: give a longer record or a wider band",
            lines.len()
        )));
    }
    let scale = std::f64::consts::TAU * frf.freq.last().copied().unwrap_or(1.0);
    let rms: Vec<f64> = (0..m)
        .map(|i| {
            let s: f64 = lines.iter().map(|&k| frf.h[k][i].norm_sqr()).sum();
            (s / lines.len() as f64).sqrt().max(f64::MIN_POSITIVE)
        })
        .collect();
    let mut current = RationalFit {
        den: vec![0.0; order],
        num: num_degree.iter().map(|d| vec![0.0; d + 1]).collect(),
        scale,
    };
    let mut first = true;
    for _ in 0..iterations.max(1) {
        let rows = lines.len() * m * 2;
        let mut a = DMatrix::<f64>::zeros(rows, unknowns);
        let mut b = DVector::<f64>::zeros(rows);
        let mut r = 0;
        for &k in &lines {
            let sigma = Complex64::new(0.0, std::f64::consts::TAU * frf.freq[k] / scale);
            let sk = if first {
                1.0
            } else {
                1.0 / current.d(sigma).norm()
            };
            let w = frf.coherence[k].sqrt() * sk;
            let mut col0 = order;
            for i in 0..m {
                let h = frf.h[k][i] / rms[i];
                let mut row = vec![Complex64::new(0.0, 0.0); unknowns];
                for (l, x) in row.iter_mut().enumerate().take(order) {
                    *x = h * sigma.powu(l as u32);
                }
                for l in 0..=num_degree[i] {
                    row[col0 + l] = -sigma.powu(l as u32) / rms[i];
                }
                col0 += num_degree[i] + 1;
                let rhs = -h * sigma.powu(order as u32);
                for (c, x) in row.iter().enumerate() {
                    a[(r, c)] = x.re * w;
                    a[(r + 1, c)] = x.im * w;
                }
                b[r] = rhs.re * w;
                b[r + 1] = rhs.im * w;
                r += 2;
            }
        }
        let x = a
            .svd(true, true)
            .solve(&b, 1e-12)
            .map_err(|e| IdentifyError::Data(format!("the rational fit's least squares: {e}")))?;
        if x.iter().any(|v| !v.is_finite()) {
            return Err(IdentifyError::Data(
                "the rational fit did not converge to finite coefficients".into(),
            ));
        }
        current.den = x.rows(0, order).iter().copied().collect();
        let mut col0 = order;
        for (num, &d) in current.num.iter_mut().zip(num_degree) {
            *num = x.rows(col0, d + 1).iter().copied().collect();
            col0 += d + 1;
        }
        first = false;
    }
    Ok(current)
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

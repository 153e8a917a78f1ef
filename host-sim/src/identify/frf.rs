//! Frequency responses of a record with several inputs and one output: Welch's averaged
//! spectra and the H1 estimator.
//!
//! The record is cut into segments of `len` samples that overlap by half. Each segment of
//! each channel has its mean removed, is multiplied by a Hann window and transformed
//! (`rustfft`). Per frequency line the spectra are summed over the segments:
//! `G_uu = Σ U Uᴴ` (inputs × inputs), `G_yu = Σ Y Uᴴ`, `G_yy = Σ |Y|²`; the responses are
//! `H = G_yu G_uu⁻¹` (H1: noise on the output averages out; noise on an input biases its
//! response low by the input's signal-to-noise ratio), and the multiple coherence
//! `γ² = G_yu G_uu⁻¹ G_uy / G_yy` is the share of the output's power the inputs explain at that
//! line (noise, an unmeasured input or a nonlinearity lower it).
//!
//! Resolution and leakage: the lines are `1/(len·dt)` apart, and the Hann window's main lobe
//! is four lines wide; a mode's half-power width `2ζf` should span several lines for its
//! damping not to be widened by the window (docs/identification.md sizes the segment).

use rustfft::FftPlanner;
use rustfft::num_complex::Complex64;

use super::IdentifyError;
use nalgebra::{DMatrix, DVector};

/// Estimated frequency responses on the lines of a band.
#[derive(Clone, Debug, PartialEq)]
pub struct Frf {
    /// Line frequencies [Hz].
    pub freq: Vec<f64>,
    /// Per line, the response to each input (output units per input unit).
    pub h: Vec<Vec<Complex64>>,
    /// Per line, the multiple coherence `γ²` [0, 1].
    pub coherence: Vec<f64>,
    /// Segments averaged.
    pub segments: usize,
}

/// The Hann window of `n` points (periodic form, for spectral averaging).
fn hann(n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| 0.5 - 0.5 * (std::f64::consts::TAU * k as f64 / n as f64).cos())
        .collect()
}

/// The responses of `y` to `inputs` (each as long as `y`, sampled every `dt` seconds) on the
/// lines inside `band` [Hz], from segments of `len` samples overlapping by half. An error
/// when the record holds fewer than two segments, a channel is not finite or the band holds
/// no line.
pub fn estimate(
    y: &[f64],
    inputs: &[&[f64]],
    dt: f64,
    len: usize,
    band: (f64, f64),
) -> Result<Frf, IdentifyError> {
    let data = |m: String| Err(IdentifyError::Data(m));
    let n = y.len();
    if inputs.is_empty() || inputs.iter().any(|u| u.len() != n) {
        return data("every input must be as long as the output".into());
    }
    if y.iter()
        .chain(inputs.iter().flat_map(|u| u.iter()))
        .any(|v| !v.is_finite())
    {
        return data("the record holds a value that is not a finite number".into());
    }
    if len < 16 || n < 2 * len {
        return data(format!(
            "the record holds {n} samples ({:.2} s): at least two segments of {len} samples ({:.2} s) are needed",
            n as f64 * dt,
            len as f64 * dt
        ));
    }
    let df = 1.0 / (len as f64 * dt);
    let lines: Vec<usize> = (1..len / 2)
        .filter(|&k| {
            let f = k as f64 * df;
            f >= band.0 && f <= band.1
        })
        .collect();
    if lines.is_empty() {
        return data(format!(
            "no line of {df:.3} Hz spacing inside {:.2}–{:.2} Hz",
            band.0, band.1
        ));
    }
    let m = inputs.len();
    let window = hann(len);
    let fft = FftPlanner::new().plan_fft_forward(len);
    let spectrum = |x: &[f64]| -> Vec<Complex64> {
        let mean = x.iter().sum::<f64>() / x.len() as f64;
        let mut buf: Vec<Complex64> = x
            .iter()
            .zip(&window)
            .map(|(v, w)| Complex64::new((v - mean) * w, 0.0))
            .collect();
        fft.process(&mut buf);
        buf
    };
    let nl = lines.len();
    let mut guu = vec![DMatrix::<Complex64>::zeros(m, m); nl];
    let mut gyu = vec![DVector::<Complex64>::zeros(m); nl];
    let mut gyy = vec![0.0; nl];
    let mut segments = 0;
    let mut start = 0;
    while start + len <= n {
        let ys = spectrum(&y[start..start + len]);
        let us: Vec<Vec<Complex64>> = inputs
            .iter()
            .map(|u| spectrum(&u[start..start + len]))
            .collect();
        for (l, &k) in lines.iter().enumerate() {
            for i in 0..m {
                gyu[l][i] += ys[k] * us[i][k].conj();
                for j in 0..m {
                    guu[l][(i, j)] += us[i][k] * us[j][k].conj();
                }
            }
            gyy[l] += ys[k].norm_sqr();
        }
        segments += 1;
        start += len / 2;
    }
    let mut h = Vec::with_capacity(nl);
    let mut coherence = Vec::with_capacity(nl);
    for l in 0..nl {
        // H Guu = Gyu  ⇔  Guuᵀ Hᵀ = Gyuᵀ (Guu is Hermitian: Guuᵀ = conj(Guu)).
        match guu[l].clone().transpose().lu().solve(&gyu[l]) {
            Some(hl) if hl.iter().all(|c| c.re.is_finite() && c.im.is_finite()) => {
                let explained: Complex64 = (0..m).map(|i| hl[i] * gyu[l][i].conj()).sum();
                coherence.push((explained.re / gyy[l]).clamp(0.0, 1.0));
                h.push(hl.iter().copied().collect());
            }
            _ => {
                coherence.push(0.0);
                h.push(vec![Complex64::new(f64::NAN, f64::NAN); m]);
            }
        }
    }
    Ok(Frf {
        freq: lines.iter().map(|&k| k as f64 * df).collect(),
        h,
        coherence,
        segments,
    })
}

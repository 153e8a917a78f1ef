//! The spectra a modal fit reads, chosen for the record: whole windows for transients, Welch's
//! averages for stationary records.
//!
//! ## Windows: transients
//! A record whose excitation is a burst or a train of pulses (a chirp followed by rest, taps)
//! is cut into windows of `n` samples, one per pulse (or the whole record for one burst),
//! each transformed whole: no taper, so a transient that starts and ends at rest has no
//! leakage at all and the lines are `1/(n·dt)` apart, the finest the record allows. What
//! still rings at a window's ends (the next tap came early, the record stopped) is not
//! leakage to hide but a known term: over a window `[0, T]` the transforms of a linear
//! system's input and output satisfy `D(s) Y(s) − N(s) U(s) = T(s)` exactly at the lines
//! `s = j2πk/T`, with `T(s)` a polynomial set by the states at the window's two ends
//! (Pintelon and Schoukens, *System Identification: A Frequency Domain Approach*, ch. 6). The
//! fit takes one such polynomial per window ([`Row::window`]) — but not for taps: a pulse at a
//! window's start is itself nearly a polynomial in `s`, and the fit could no longer tell the
//! input's share from the transient's. Taps whose response still rings when the next one
//! comes are windowed instead by `e^{−a t}`, which makes the windows' transforms the signals'
//! Laplace transforms at `s = a + j2πf`: a linear system's relation `D(s) Y = N(s) U` holds
//! there exactly, and the fit evaluates its polynomials at those `s` ([`Spectra::shift`]), so
//! the poles and residues it finds need no correction for the window.
//!
//! ## Welch: stationary records
//! Noise, multisines, the modes experiment's steps: segments of `n` samples overlapping by
//! half, each with its mean removed and a Hann taper, every channel first differenced (a
//! filter common to every input and the output leaves their relation as it is and whitens
//! records whose power sits at low frequencies, which the taper's sidelobes would leak into the
//! modes' lines). Per line the cross-spectra are summed, `G_uu = Σ U Uᴴ`, `G_yu = Σ Y Uᴴ`,
//! and the fit reads them as the `m` equations `D G_{y u_j} − Σ_i N_i G_{u_i u_j} = 0`
//! (`j` over the inputs), each scaled by `1/√G_{u_j u_j}`: no inverse of `G_uu` is taken, so
//! inputs excited together (whose `G_uu` is near singular line by line) do not blow up.
//!
//! ## The nonparametric responses and their coherence
//! Beside the rows, each line's `H1 = G_yu G_uu⁻¹` (over segments or windows) when there are at
//! least as many averages as inputs, and the multiple coherence `γ² = G_yu G_uu⁻¹ G_uy / G_yy`
//! only where it means something: from `n` averages of `m` inputs an estimate of `γ²` is
//! biased up by `(1 − γ²) m/n` (it is 1 by construction when `n = m`), so it is reported
//! only with `n ≥ 10 m` averages (a floor of 0.1).

use nalgebra::{DMatrix, DVector};
use rustfft::FftPlanner;
use rustfft::num_complex::Complex64;

use super::IdentifyError;

/// One equation of a line: `D(s) y − Σ_i N_i(s) u_i − T_w(s) = 0`.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// The output's transform (or cross-spectrum).
    pub y: Complex64,
    /// The inputs' transforms (or cross-spectra).
    pub u: Vec<Complex64>,
    /// The window whose transient polynomial `T_w` enters, if any.
    pub window: Option<usize>,
}

/// How the spectra were taken.
#[derive(Clone, Debug, PartialEq)]
pub enum Method {
    /// Whole windows of `len` samples starting at `starts`.
    Windows {
        /// Samples per window.
        len: usize,
        /// Each window's first sample.
        starts: Vec<usize>,
        /// Whether each still rings at its end (its rows then carry a transient polynomial).
        ringing: Vec<bool>,
    },
    /// Welch's segments of `len` samples, half overlap.
    Welch {
        /// Samples per segment.
        len: usize,
        /// Segments averaged.
        segments: usize,
    },
}

/// The spectra of a record on the lines of a band.
#[derive(Clone, Debug, PartialEq)]
pub struct Spectra {
    /// Line frequencies [Hz].
    pub freq: Vec<f64>,
    /// Per line, its equations.
    pub rows: Vec<Vec<Row>>,
    /// Windows with a transient polynomial (0 with Welch).
    pub windows: usize,
    /// How they were taken.
    pub method: Method,
    /// Averages behind each line's `H1` (segments or windows).
    pub averages: usize,
    /// Per line, `H1` per input (`NaN` when the averages are fewer than the inputs).
    pub h: Vec<Vec<Complex64>>,
    /// Per line, the multiple coherence, when meaningful (module docs).
    pub coherence: Option<Vec<f64>>,
    /// Per input, per line, its power `G_uu` [input units² per line].
    pub input_power: Vec<Vec<f64>>,
    /// The exponential window's rate `a` [1/s] (0: none): the windows' transforms are the
    /// signals' Laplace transforms at `s = a + j2πf`, where the fit evaluates its polynomials
    /// (module docs).
    pub shift: f64,
}

/// Averages per input below which a coherence estimate is not reported (module docs).
pub const COHERENCE_AVERAGES_PER_INPUT: usize = 10;

impl Spectra {
    /// The line spacing [Hz].
    pub fn df(&self) -> f64 {
        match self.freq.as_slice() {
            [a, b, ..] => b - a,
            _ => f64::NAN,
        }
    }
}

fn finite(y: &[f64], inputs: &[&[f64]]) -> Result<(), IdentifyError> {
    let n = y.len();
    if inputs.is_empty() || inputs.iter().any(|u| u.len() != n) {
        return Err(IdentifyError::Data(
            "every input must be as long as the output".into(),
        ));
    }
    if y.iter()
        .chain(inputs.iter().flat_map(|u| u.iter()))
        .any(|v| !v.is_finite())
    {
        return Err(IdentifyError::Data(
            "the record holds a value that is not a finite number".into(),
        ));
    }
    Ok(())
}

/// The line indices `k` of an `n`-point transform at `dt` inside `band` [Hz].
fn band_lines(n: usize, dt: f64, band: (f64, f64)) -> Result<Vec<usize>, IdentifyError> {
    let df = 1.0 / (n as f64 * dt);
    let lines: Vec<usize> = (1..n.div_ceil(2))
        .filter(|&k| {
            let f = k as f64 * df;
            f >= band.0 && f <= band.1
        })
        .collect();
    if lines.is_empty() {
        return Err(IdentifyError::Data(format!(
            "no line of {df:.4} Hz spacing inside {:.3}–{:.2} Hz",
            band.0, band.1
        )));
    }
    Ok(lines)
}

/// Per line: `H1` where `G_uu` can be inverted, and `γ²`.
fn responses(
    guu: &[DMatrix<Complex64>],
    gyu: &[DVector<Complex64>],
    gyy: &[f64],
) -> (Vec<Vec<Complex64>>, Vec<f64>) {
    let m = gyu.first().map_or(0, |g| g.len());
    let mut h = Vec::with_capacity(gyu.len());
    let mut coh = Vec::with_capacity(gyu.len());
    for ((g_uu, g_yu), g_yy) in guu.iter().zip(gyu).zip(gyy) {
        // H Guu = Gyu  ⇔  Guuᵀ Hᵀ = Gyuᵀ (Guu is Hermitian: Guuᵀ = conj(Guu)).
        match g_uu.clone().transpose().lu().solve(g_yu) {
            Some(hl) if hl.iter().all(|c| c.re.is_finite() && c.im.is_finite()) => {
                let explained: Complex64 = (0..m).map(|i| hl[i] * g_yu[i].conj()).sum();
                coh.push((explained.re / g_yy).clamp(0.0, 1.0));
                h.push(hl.iter().copied().collect());
            }
            _ => {
                coh.push(0.0);
                h.push(vec![Complex64::new(f64::NAN, f64::NAN); m]);
            }
        }
    }
    (h, coh)
}

/// Whole-window spectra of `y` and `inputs` (sampled every `dt` [s]): windows of `len`
/// samples from each of `starts`, each multiplied by `e^{−a t}` from its start (`a` [1/s], 0
/// for none), on the lines inside `band` [Hz]; the rows of each window that does not end at
/// rest (`ringing`) carry its transient polynomial (module docs).
pub fn windows(
    y: &[f64],
    inputs: &[&[f64]],
    dt: f64,
    (len, starts, ringing, a): (usize, &[usize], &[bool], f64),
    band: (f64, f64),
) -> Result<Spectra, IdentifyError> {
    finite(y, inputs)?;
    if len < 16 || starts.is_empty() || starts.iter().any(|s| s + len > y.len()) {
        return Err(IdentifyError::Data(format!(
            "windows of {len} samples from {starts:?} do not fit a record of {} samples",
            y.len()
        )));
    }
    let lines = band_lines(len, dt, band)?;
    let fft = FftPlanner::new().plan_fft_forward(len);
    let taper: Vec<f64> = (0..len).map(|k| (-a * k as f64 * dt).exp()).collect();
    // Each window from its first sample: a rest value held under the taper would be a
    // transient of its own.
    let transform = |x: &[f64]| -> Vec<Complex64> {
        let rest = x.first().copied().unwrap_or(0.0);
        let mut buf: Vec<Complex64> = x
            .iter()
            .zip(&taper)
            .map(|(v, w)| Complex64::new((v - rest) * w, 0.0))
            .collect();
        fft.process(&mut buf);
        buf
    };
    let m = inputs.len();
    let nl = lines.len();
    let mut rows = vec![Vec::with_capacity(starts.len()); nl];
    let mut guu = vec![DMatrix::<Complex64>::zeros(m, m); nl];
    let mut gyu = vec![DVector::<Complex64>::zeros(m); nl];
    let mut gyy = vec![0.0; nl];
    for (w, &s) in starts.iter().enumerate() {
        let ys = transform(&y[s..s + len]);
        let us: Vec<Vec<Complex64>> = inputs.iter().map(|u| transform(&u[s..s + len])).collect();
        for (l, &k) in lines.iter().enumerate() {
            let u: Vec<Complex64> = us.iter().map(|x| x[k]).collect();
            accumulate(&mut guu[l], &mut gyu[l], &mut gyy[l], ys[k], &u);
            rows[l].push(Row {
                y: ys[k],
                u,
                window: ringing.get(w).copied().unwrap_or(true).then_some(w),
            });
        }
    }
    let averages = starts.len();
    let mut sp = finish(
        &lines,
        1.0 / (len as f64 * dt),
        rows,
        (guu, gyu, gyy),
        averages,
        starts.len(),
        Method::Windows {
            len,
            starts: starts.to_vec(),
            ringing: ringing.to_vec(),
        },
    );
    sp.shift = a;
    Ok(sp)
}

fn accumulate(
    guu: &mut DMatrix<Complex64>,
    gyu: &mut DVector<Complex64>,
    gyy: &mut f64,
    y: Complex64,
    u: &[Complex64],
) {
    for (i, ui) in u.iter().enumerate() {
        gyu[i] += y * ui.conj();
        for (j, uj) in u.iter().enumerate() {
            guu[(i, j)] += ui * uj.conj();
        }
    }
    *gyy += y.norm_sqr();
}

type Sums = (Vec<DMatrix<Complex64>>, Vec<DVector<Complex64>>, Vec<f64>);

fn finish(
    lines: &[usize],
    df: f64,
    rows: Vec<Vec<Row>>,
    (guu, gyu, gyy): Sums,
    averages: usize,
    windows: usize,
    method: Method,
) -> Spectra {
    let m = gyu.first().map_or(0, |g| g.len());
    let (mut h, coh) = responses(&guu, &gyu, &gyy);
    if averages < m {
        h.iter_mut()
            .for_each(|x| x.fill(Complex64::new(f64::NAN, f64::NAN)));
    }
    let coherence = (averages >= COHERENCE_AVERAGES_PER_INPUT * m).then_some(coh);
    let input_power = (0..m)
        .map(|i| guu.iter().map(|g| g[(i, i)].re).collect())
        .collect();
    Spectra {
        freq: lines.iter().map(|&k| k as f64 * df).collect(),
        rows,
        windows,
        method,
        averages,
        h,
        coherence,
        input_power,
        shift: 0.0,
    }
}

/// The Hann window of `n` points (periodic form, for spectral averaging).
fn hann(n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| 0.5 - 0.5 * (std::f64::consts::TAU * k as f64 / n as f64).cos())
        .collect()
}

/// How many of Welch's half-overlapping segments of `len` samples [`welch`] takes from a
/// record of `n` samples (it differences the record first: `n − 1` of them).
pub fn welch_segments(n: usize, len: usize) -> usize {
    let hop = (len / 2).max(1);
    match n.checked_sub(1) {
        Some(d) if len > 0 && d >= len => (d - len) / hop + 1,
        _ => 0,
    }
}

/// Welch's spectra of `y` and `inputs` (sampled every `dt` [s], each first differenced) from
/// segments of `len` samples overlapping by half, on the lines inside `band` [Hz] (module
/// docs). An error when the record holds fewer than two segments.
pub fn welch(
    y: &[f64],
    inputs: &[&[f64]],
    dt: f64,
    len: usize,
    band: (f64, f64),
) -> Result<Spectra, IdentifyError> {
    finite(y, inputs)?;
    let diff = |x: &[f64]| -> Vec<f64> { x.windows(2).map(|w| (w[1] - w[0]) / dt).collect() };
    let y = diff(y);
    let inputs: Vec<Vec<f64>> = inputs.iter().map(|u| diff(u)).collect();
    let n = y.len();
    if len < 16 || n < 2 * len {
        return Err(IdentifyError::Data(format!(
            "the record holds {n} samples ({:.2} s): at least two segments of {len} samples ({:.2} s) are needed",
            n as f64 * dt,
            len as f64 * dt
        )));
    }
    let lines = band_lines(len, dt, band)?;
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
            let u: Vec<Complex64> = us.iter().map(|x| x[k]).collect();
            accumulate(&mut guu[l], &mut gyu[l], &mut gyy[l], ys[k], &u);
        }
        segments += 1;
        start += len / 2;
    }
    // The rows: D G_{y u_j} − Σ_i N_i G_{u_i u_j} = 0, scaled by 1/√G_{u_j u_j}.
    let rows = (0..nl)
        .map(|l| {
            (0..m)
                .filter(|&j| guu[l][(j, j)].re > 0.0)
                .map(|j| {
                    let s = 1.0 / guu[l][(j, j)].re.sqrt();
                    Row {
                        y: gyu[l][j] * s,
                        u: (0..m).map(|i| guu[l][(i, j)] * s).collect(),
                        window: None,
                    }
                })
                .collect()
        })
        .collect();
    Ok(finish(
        &lines,
        1.0 / (len as f64 * dt),
        rows,
        (guu, gyu, gyy),
        segments,
        0,
        Method::Welch { len, segments },
    ))
}

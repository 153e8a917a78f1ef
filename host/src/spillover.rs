//! Spillover of the piezo loop into the modes the controller does not know (issue 14): the
//! sampled, filtered rate feedback `V_a = −k_c V̇_f` of the firmware on link 2 with `N` modes,
//! joints held, linearized, and its stability margin (the factor on `k_c` before the loop goes
//! unstable). Host side, `f64`.
//!
//! Continuous rate feedback from a collocated pair is passive for any gain and any number of
//! modes; sampled with a zero-order hold (and a one-sample delay, with realistic sensors) it is
//! not: the gain limit behaves like `2/(T cᵀc)` with `c` the modes' slope differences across the
//! patch, and `cᵀc` grows with every mode kept (`../shared/notes/model-notes.md` §13).
//!
//! ## The loop
//! Plant, joints held, unit modal mass: `ẋ = A x + B V_a`, `x = (δ, δ̇)`,
//! `A = [[0, I], [−Ω², −2ζΩ]]`, `B = (0, k_a Δφ')`; film `V_f = k_s Δφ'ᵀ δ`. With an amplifier
//! of bandwidth `ω_a` the patch sees `V̇_p = ω_a (V_a − V_p)`, a state appended to `x`; the film
//! also reads the patch voltage directly, `V_f = k_s Δφ'ᵀ δ + β F V_p` (the feedthrough,
//! `ModalLink::feedthrough`). Discretized exactly for a zero-order hold over the piezo period `T`
//! (`e^{AT}` of the augmented matrix). A law is linear without its saturation ([`LinearLaw`]):
//! the core's `PiezoLaw` is `u_k = a u_{k−1} + b (V_{f,k} − V_{f,k−1})`,
//! `a = (2 − ω_c T)/(2 + ω_c T)`, `b = −k_c 2ω_c/(2 + ω_c T)`; the laws of issue 35 give their
//! own form (`linear()`). The command is held for the next period, the film read one period
//! late with `delay`. The closed loop is linear in the state ([`closed_loop_with`]); it is
//! stable when every eigenvalue of its matrix lies inside the unit circle.

use flexarm_core::control::linear::StateSpace;
use nalgebra::{DMatrix, DVector};

use crate::eigen::EigenError;

/// The piezo loop as the firmware runs it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PiezoLoop {
    /// Rate-feedback gain `k_c` [s].
    pub k_c: f64,
    /// Corner of the derivative filter [Hz].
    pub cutoff_hz: f64,
    /// Loop period `T` [s].
    pub period: f64,
    /// The film sample is one period old (the realistic sensors' delay).
    pub delay: bool,
    /// Bandwidth of the piezo amplifier [Hz], a first-order lag between the command and the
    /// patch voltage; `None` for an ideal amplifier.
    pub amplifier_hz: Option<f64>,
}

/// The link as the loop sees it: per mode `ω_j`, `ζ_j` and the patch's slope difference `Δφ'_j`;
/// the actuator's moment per volt `k_a` and the film's volts per radian `k_s`.
#[derive(Clone, Debug, PartialEq)]
pub struct ModalLink {
    /// Natural frequencies [rad/s].
    pub omega: Vec<f64>,
    /// Damping ratios [-].
    pub zeta: Vec<f64>,
    /// `Δφ'_j` [1/(m·√kg)].
    pub slope_diff: Vec<f64>,
    /// `k_a` [N·m/V].
    pub k_a: f64,
    /// `k_s` [V/rad].
    pub k_s: f64,
    /// The film's direct response to the patch voltage `β F` [V/V] (`TruthSpec::film_bond`).
    pub feedthrough: f64,
}

impl ModalLink {
    /// The truth plant's link 2 as the piezo loop sees it (joints held): every mode of `spec`
    /// on the arm `arm` with the patch `patch` (`TruthSpec::link`).
    pub fn from_truth(
        spec: &crate::truth_plant::TruthSpec,
        arm: &flexarm_core::params::ArmParams<f64>,
        patch: &flexarm_core::control::piezo::PiezoPatch<f64>,
    ) -> Result<Self, crate::truth::TruthError> {
        let (body, c) = spec.link(arm, patch)?;
        Ok(Self {
            omega: body.omega,
            zeta: body.zeta,
            slope_diff: c.slope_diff,
            k_a: c.k_a,
            k_s: c.k_s,
            feedthrough: c.feedthrough,
        })
    }

    /// The first `n` modes only (the controller's truncation, for comparison).
    pub fn truncated(&self, n: usize) -> Self {
        Self {
            omega: self.omega[..n].to_vec(),
            zeta: self.zeta[..n].to_vec(),
            slope_diff: self.slope_diff[..n].to_vec(),
            ..*self
        }
    }
}

/// A sampled law without saturation, `z_{k+1} = A z_k + B y_k`, `u_k = C z_k + D y_k` (`y` the
/// film sample it reads): a core law's `linear()` ([`LinearLaw::from`]) or the rate law
/// ([`LinearLaw::rate`]).
#[derive(Clone, Debug, PartialEq)]
pub struct LinearLaw {
    /// `A`.
    pub a: DMatrix<f64>,
    /// `B`.
    pub b: DVector<f64>,
    /// `C`.
    pub c: DVector<f64>,
    /// `D`.
    pub d: f64,
}

impl<const S: usize> From<&StateSpace<f64, S>> for LinearLaw {
    fn from(ss: &StateSpace<f64, S>) -> Self {
        Self {
            a: DMatrix::from_fn(S, S, |i, j| ss.a[(i, j)]),
            b: DVector::from_fn(S, |i, _| ss.b[i]),
            c: DVector::from_fn(S, |i, _| ss.c[i]),
            d: ss.d,
        }
    }
}

impl LinearLaw {
    /// The core's `PiezoLaw` (Eq. 17) without its saturation: `u_k = a u_{k−1} + b (y_k −
    /// y_{k−1})`, states `(u_{k−1}, y_{k−1})` (module docs).
    pub fn rate(k_c: f64, cutoff_hz: f64, period: f64) -> Self {
        let wc = std::f64::consts::TAU * cutoff_hz;
        let a = (2.0 - wc * period) / (2.0 + wc * period);
        let b = -k_c * 2.0 * wc / (2.0 + wc * period);
        Self {
            a: DMatrix::from_row_slice(2, 2, &[a, -b, 0.0, 0.0]),
            b: DVector::from_column_slice(&[b, 1.0]),
            c: DVector::from_column_slice(&[a, -b]),
            d: b,
        }
    }
}

/// Where a law runs: its period, whether the film sample is one period old, the amplifier.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Board {
    /// Loop period `T` [s].
    pub period: f64,
    /// The film sample is one period old.
    pub delay: bool,
    /// Bandwidth of the piezo amplifier [Hz]; `None` for an ideal one.
    pub amplifier_hz: Option<f64>,
}

impl PiezoLoop {
    /// The board this loop runs on.
    pub fn board(&self) -> Board {
        Board {
            period: self.period,
            delay: self.delay,
            amplifier_hz: self.amplifier_hz,
        }
    }
}

/// The closed loop's matrix (module docs) for the rate law of `law`.
pub fn closed_loop(link: &ModalLink, law: &PiezoLoop) -> DMatrix<f64> {
    closed_loop_with(
        link,
        &law.board(),
        &LinearLaw::rate(law.k_c, law.cutoff_hz, law.period),
        1.0,
    )
}

/// The closed loop of the linear `law` on `board`, the actuator path's gain multiplied by
/// `gain` (the law's own copy of its command is not: what an amplifier's or a patch's gain
/// error does). The state is `(x_k, u_{k−1}, z_k [, y_{k−1}])`: the plant's (modes, and the
/// patch voltage behind a real amplifier), the command applied during the last period, the
/// law's, and the film sample held back one period with `board.delay`. The film reads
/// `y_k = k_s Δφ'ᵀδ_k + β F V_p` with `V_p` the amplifier's state, or `u_{k−1}` behind an ideal
/// amplifier (the hold of the last period).
pub fn closed_loop_with(
    link: &ModalLink,
    board: &Board,
    law: &LinearLaw,
    gain: f64,
) -> DMatrix<f64> {
    let n = link.omega.len();
    let t = board.period;
    let amp = board.amplifier_hz.is_some();
    // Continuous plant states: δ, δ̇ and, with a real amplifier, the patch voltage.
    let nx = 2 * n + usize::from(amp);
    // Augmented continuous system [[A, B], [0, 0]] for the zero-order hold of the command.
    let mut aug = DMatrix::<f64>::zeros(nx + 1, nx + 1);
    let drive = if amp { 2 * n } else { nx };
    for j in 0..n {
        aug[(j, n + j)] = 1.0;
        aug[(n + j, j)] = -link.omega[j] * link.omega[j];
        aug[(n + j, n + j)] = -2.0 * link.zeta[j] * link.omega[j];
        aug[(n + j, drive)] = link.k_a * link.slope_diff[j];
    }
    if let Some(f) = board.amplifier_hz {
        let wa = std::f64::consts::TAU * f;
        aug[(2 * n, 2 * n)] = -wa;
        aug[(2 * n, nx)] = wa;
    }
    let e = (aug * t).exp();
    let ad = e.view((0, 0), (nx, nx)).into_owned();
    let bd = e.view((0, nx), (nx, 1)).into_owned();
    let nz = law.a.nrows();
    let (iu, iz, ih) = (nx, nx + 1, nx + 1 + nz);
    let m = ih + usize::from(board.delay);
    // The film sample y_k as a row over the state.
    let mut y = DVector::<f64>::zeros(m);
    for j in 0..n {
        y[j] = link.k_s * link.slope_diff[j];
    }
    y[if amp { 2 * n } else { iu }] += link.feedthrough;
    // The sample the law reads at k.
    let s = if board.delay {
        let mut s = DVector::<f64>::zeros(m);
        s[ih] = 1.0;
        s
    } else {
        y.clone()
    };
    // The command applied: u_k = gain (C z_k + D s_k).
    let mut u = &s * (gain * law.d);
    for i in 0..nz {
        u[iz + i] += gain * law.c[i];
    }
    let mut z = DMatrix::<f64>::zeros(m, m);
    for i in 0..nx {
        for j in 0..nx {
            z[(i, j)] = ad[(i, j)];
        }
        for j in 0..m {
            z[(i, j)] += bd[(i, 0)] * u[j];
        }
    }
    for j in 0..m {
        z[(iu, j)] = u[j];
        for i in 0..nz {
            z[(iz + i, j)] = law.b[i] * s[j];
        }
        if board.delay {
            z[(ih, j)] = y[j];
        }
    }
    for i in 0..nz {
        for k in 0..nz {
            z[(iz + i, iz + k)] += law.a[(i, k)];
        }
    }
    z
}

/// Spectral radius of the closed loop: below 1 is stable ([`crate::eigen`]).
pub fn spectral_radius(link: &ModalLink, law: &PiezoLoop) -> Result<f64, EigenError> {
    crate::eigen::spectral_radius(&closed_loop(link, law))
}

/// The factor on `k_c` at which the loop becomes unstable (bisection on the spectral radius,
/// to 0.1 %), searched up to `max_factor`; `None` if it is stable up to there.
pub fn gain_margin(
    link: &ModalLink,
    law: &PiezoLoop,
    max_factor: f64,
) -> Result<Option<f64>, EigenError> {
    gain_margin_with(
        link,
        &law.board(),
        &LinearLaw::rate(law.k_c, law.cutoff_hz, law.period),
        max_factor,
    )
}

/// The factor on the actuator path's gain ([`closed_loop_with`]) at which the loop becomes
/// unstable (bisection to 0.1 %), searched up to `max_factor`; `None` if it is stable up to
/// there, `Some(0)` if it is unstable at any gain.
pub fn gain_margin_with(
    link: &ModalLink,
    board: &Board,
    law: &LinearLaw,
    max_factor: f64,
) -> Result<Option<f64>, EigenError> {
    let stable = |g: f64| {
        crate::eigen::spectral_radius(&closed_loop_with(link, board, law, g)).map(|r| r < 1.0)
    };
    if stable(max_factor)? {
        return Ok(None);
    }
    let (mut lo, mut hi) = (0.0, max_factor);
    while hi - lo > 1e-3 * hi {
        let mid = 0.5 * (lo + hi);
        if stable(mid)? {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(Some(lo))
}

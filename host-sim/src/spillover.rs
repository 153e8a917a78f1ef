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
//! of bandwidth `ω_a` the patch sees `V̇_p = ω_a (V_a − V_p)`, a state appended to `x`. Discretized exactly
//! for a zero-order hold over the piezo period `T` (`e^{AT}` of the augmented matrix). The law is
//! the core's `PiezoLaw` without its saturation: `u_k = a u_{k−1} + b (V_{f,k} − V_{f,k−1})`,
//! `a = (2 − ω_c T)/(2 + ω_c T)`, `b = −k_c 2ω_c/(2 + ω_c T)`, held for the next period (and read
//! one period late with `delay`). The closed loop is linear in the state
//! `(x_k, V_{f,k−1}, u_{k−1} [, V_{f,k−1} held])`; it is stable when every eigenvalue of its
//! matrix lies inside the unit circle.

use nalgebra::DMatrix;

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

/// The closed loop's matrix (module docs) for the gain `k_c`.
pub fn closed_loop(link: &ModalLink, law: &PiezoLoop) -> DMatrix<f64> {
    let n = link.omega.len();
    let t = law.period;
    // Continuous plant states: δ, δ̇ and, with a real amplifier, the patch voltage.
    let nx = 2 * n + usize::from(law.amplifier_hz.is_some());
    // Augmented continuous system [[A, B], [0, 0]] for the zero-order hold of the command.
    let mut aug = DMatrix::<f64>::zeros(nx + 1, nx + 1);
    let drive = if law.amplifier_hz.is_some() {
        2 * n
    } else {
        nx
    };
    for j in 0..n {
        aug[(j, n + j)] = 1.0;
        aug[(n + j, j)] = -link.omega[j] * link.omega[j];
        aug[(n + j, n + j)] = -2.0 * link.zeta[j] * link.omega[j];
        aug[(n + j, drive)] = link.k_a * link.slope_diff[j];
    }
    if let Some(f) = law.amplifier_hz {
        let wa = std::f64::consts::TAU * f;
        aug[(2 * n, 2 * n)] = -wa;
        aug[(2 * n, nx)] = wa;
    }
    let e = (aug * t).exp();
    let ad = e.view((0, 0), (nx, nx)).into_owned();
    let bd = e.view((0, nx), (nx, 1)).into_owned();
    let wc = std::f64::consts::TAU * law.cutoff_hz;
    let a = (2.0 - wc * t) / (2.0 + wc * t);
    let b = -law.k_c * 2.0 * wc / (2.0 + wc * t);
    // c: the film voltage from x (δ entries only).
    let mut c = DMatrix::<f64>::zeros(1, nx);
    for j in 0..n {
        c[(0, j)] = link.k_s * link.slope_diff[j];
    }
    // State z = (x, p = previous film sample used, u = previous command [, h = held sample]).
    // Without delay the sample used at k is c x_k; with delay it is h_k = c x_{k−1}.
    let extra = if law.delay { 3 } else { 2 };
    let m = nx + extra;
    let (ip, iu, ih) = (nx, nx + 1, nx + 2);
    // u_k = a u_{k−1} + b (s_k − p_k), s_k the sample used at k.
    let mut u_row = DMatrix::<f64>::zeros(1, m);
    u_row[(0, iu)] = a;
    u_row[(0, ip)] = -b;
    if law.delay {
        u_row[(0, ih)] += b;
    } else {
        for j in 0..nx {
            u_row[(0, j)] += b * c[(0, j)];
        }
    }
    let mut z = DMatrix::<f64>::zeros(m, m);
    // x_{k+1} = Ad x_k + Bd u_k.
    for i in 0..nx {
        for j in 0..nx {
            z[(i, j)] = ad[(i, j)];
        }
        for j in 0..m {
            z[(i, j)] += bd[(i, 0)] * u_row[(0, j)];
        }
    }
    // p_{k+1} = s_k; u_{k+1 − 1} = u_k; h_{k+1} = c x_k.
    if law.delay {
        z[(ip, ih)] = 1.0;
        for j in 0..nx {
            z[(ih, j)] = c[(0, j)];
        }
    } else {
        for j in 0..nx {
            z[(ip, j)] = c[(0, j)];
        }
    }
    for j in 0..m {
        z[(iu, j)] = u_row[(0, j)];
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
    let stable = |g: f64| {
        spectral_radius(
            link,
            &PiezoLoop {
                k_c: law.k_c * g,
                ..*law
            },
        )
        .map(|r| r < 1.0)
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

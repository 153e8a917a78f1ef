//! The rigid inertias, by least squares on the regressor.
//!
//! ## What can be identified
//! Without gravity (the arm is planar) the rigid model enters the joint torques through three
//! combinations of the masses and inertias (`flexarm_core::model`, link 2's rigid part):
//! - `A = I_h1 + I_1 + m1 a1²/4 + (m_h2 + m2) a1²`, joint 1's own inertia [kg·m²];
//! - `J = I_h2 + I_2x + m2 a2²/3`, link 2's inertia about joint 2 [kg·m²];
//! - `S = a1 m2 a2/2`, the coupling [kg·m²];
//!
//! so that, with the joints' friction,
//! `τ1 = A θ̈1 + J(θ̈1+θ̈2) + S[cos θ2 (2θ̈1+θ̈2) − sin θ2 (2θ̇1θ̇2 + θ̇2²)] + F_c1 sgn θ̇1 + F_v1 θ̇1`,
//! `τ2 = J(θ̈1+θ̈2) + S[cos θ2 θ̈1 + sin θ2 θ̇1²] + F_c2 sgn θ̇2 + F_v2 θ̇2`.
//! The individual masses and inertias are not identifiable from the torques: only these
//! sums reach them. The link's modes add torques of order `(f/f_1)²` of the inertial ones, so
//! the experiment stays well below the first mode.
//!
//! ## The experiment and the fit
//! Both joints follow sums of sines (0.15 to 0.9 Hz, phases spread, faded in and out over
//! 2 s) about a pose: the regressor's columns are then independent. The encoders' angles are
//! differentiated in the frequency domain (the record starts and ends at rest, so its
//! periodic extension is smooth), and the angles' derivatives and the torques pass the same
//! low-pass (a raised-cosine taper from 2 to 4 Hz) to remove the encoders' quantization
//! and the link's ringing. The seven parameters `(A, J, S, F_c1, F_v1, F_c2, F_v2)` come from one least-squares
//! fit of both joints' equations over every sample.

use flexarm_core::Vector2;
use flexarm_core::params::ArmParams;
use flexarm_core::trajectory::{Cubic, JointTrajectory};
use nalgebra::{DMatrix, DVector};
use rustfft::FftPlanner;
use rustfft::num_complex::Complex64;

use super::IdentifyError;
use crate::sim::{Sample, SimConfig, simulate_segments};

/// The identifiable rigid combinations [kg·m²].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rigid {
    /// `A`.
    pub a: f64,
    /// `J`.
    pub j: f64,
    /// `S`.
    pub s: f64,
}

impl Rigid {
    /// The combinations of `arm`.
    pub fn of(arm: &ArmParams<f64>) -> Self {
        Self {
            a: arm.i_h1
                + arm.i_1
                + arm.m1 * arm.a1 * arm.a1 / 4.0
                + (arm.m_h2 + arm.m2) * arm.a1 * arm.a1,
            j: arm.i_h2 + arm.i_2_extra + arm.m2 * arm.a2 * arm.a2 / 3.0,
            s: arm.a1 * arm.m2 * arm.a2 / 2.0,
        }
    }

    /// `nominal` with its rigid parameters changed to give these combinations: `m2` from `S`
    /// (the lengths are measured), `I_h1` takes `A`'s change and `I_2x` `J`'s (only the sums
    /// enter; a part that would turn negative goes to `I_1` and `I_h2`).
    pub fn apply(&self, nominal: &ArmParams<f64>) -> ArmParams<f64> {
        let mut arm = *nominal;
        arm.m2 = 2.0 * self.s / (arm.a1 * arm.a2);
        let rest_a =
            self.a - arm.m1 * arm.a1 * arm.a1 / 4.0 - (arm.m_h2 + arm.m2) * arm.a1 * arm.a1;
        arm.i_h1 = (rest_a - arm.i_1).max(0.0);
        arm.i_1 = rest_a - arm.i_h1;
        let rest_j = self.j - arm.m2 * arm.a2 * arm.a2 / 3.0;
        arm.i_2_extra = (rest_j - arm.i_h2).max(0.0);
        arm.i_h2 = rest_j - arm.i_2_extra;
        arm
    }
}

/// The fit: the combinations, each joint's friction `(F_c, F_v)` and the residual.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InertiaFit {
    /// The rigid combinations.
    pub rigid: Rigid,
    /// `(F_c [N·m], F_v [N·m·s/rad])` per joint.
    pub friction: [(f64, f64); 2],
    /// RMS of the torque residuals [N·m].
    pub residual: f64,
    /// RMS of the fitted torques [N·m].
    pub torque_rms: f64,
}

/// The exciting motion's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InertiaPlan {
    /// The pose the sines are about [rad].
    pub pose: Vector2<f64>,
    /// Each joint's amplitude scale [rad].
    pub amplitude: f64,
    /// Length [s].
    pub seconds: f64,
}

impl Default for InertiaPlan {
    /// ±0.4 rad about `(0, 0.5)` for 40 s.
    fn default() -> Self {
        Self {
            pose: Vector2::new(0.0, 0.5),
            amplitude: 0.4,
            seconds: 40.0,
        }
    }
}

/// The sines' frequencies [Hz] and phases [rad] per joint.
const SINES: [[(f64, f64); 4]; 2] = [
    [(0.15, 0.0), (0.35, 1.3), (0.6, 2.9), (0.9, 4.1)],
    [(0.2, 0.7), (0.45, 2.2), (0.75, 3.6), (0.85, 5.0)],
];
/// Fade in and out [s].
const FADE: f64 = 2.0;
/// Knots of the cubic segments [s].
const KNOT: f64 = 0.05;

/// The exciting motion's angle at `t` [s].
pub fn excitation(plan: &InertiaPlan, t: f64) -> Vector2<f64> {
    let env = |t: f64| {
        let u = (t.min(plan.seconds - t) / FADE).clamp(0.0, 1.0);
        (std::f64::consts::FRAC_PI_2 * u).sin().powi(2)
    };
    let tau = std::f64::consts::TAU;
    let joint = |j: usize| {
        SINES[j]
            .iter()
            .map(|(f, p)| (tau * f * t + p).sin() - p.sin())
            .sum::<f64>()
            * plan.amplitude
            / 4.0
    };
    plan.pose + Vector2::new(joint(0), joint(1)) * env(t)
}

/// The exciting motion as cubic segments every [`KNOT`] seconds, each from its own `t = 0`.
pub fn segments(plan: &InertiaPlan) -> Result<Vec<(f64, JointTrajectory<f32>)>, IdentifyError> {
    if !(plan.seconds.is_finite() && (2.0 * FADE + 5.0..=600.0).contains(&plan.seconds)) {
        return Err(IdentifyError::Data(format!(
            "an excitation of {} s: give {} to 600 s",
            plan.seconds,
            2.0 * FADE + 5.0
        )));
    }
    if !(plan.amplitude.is_finite() && plan.amplitude > 0.0 && plan.amplitude <= 1.0) {
        return Err(IdentifyError::Data(format!(
            "an amplitude of {} rad: give (0, 1] rad",
            plan.amplitude
        )));
    }
    let h = 1e-5;
    let speed = |t: f64| (excitation(plan, t + h) - excitation(plan, t - h)) / (2.0 * h);
    let n = (plan.seconds / KNOT).round() as usize;
    Ok((0..n)
        .map(|k| {
            let (t0, t1) = (k as f64 * KNOT, (k + 1) as f64 * KNOT);
            let c = Cubic {
                start: excitation(plan, t0).cast::<f32>(),
                end: excitation(plan, t1).cast::<f32>(),
                v0: speed(t0).cast::<f32>(),
                v1: speed(t1).cast::<f32>(),
                duration: KNOT as f32,
            };
            (t0, JointTrajectory::Cubic(c))
        })
        .collect())
}

/// Runs the exciting motion on the simulator; the trace's angles are the encoders' readings.
pub fn inertia_experiment(
    cfg: &SimConfig,
    plan: &InertiaPlan,
) -> Result<Vec<Sample>, IdentifyError> {
    let segs = segments(plan)?;
    let run = SimConfig {
        duration: plan.seconds,
        tail_window: 1.0,
        ..*cfg
    };
    let (_, trace) = simulate_segments(&run, &segs, true)
        .map_err(|e| IdentifyError::Sim(format!("the inertia experiment: {e}")))?;
    let s = &cfg.sensors;
    Ok(trace
        .into_iter()
        .map(|mut x| {
            x.x.q.x = s.angle(x.x.q.x);
            x.x.q.y = s.angle(x.x.q.y);
            x
        })
        .collect())
}

/// The low-pass's taper [Hz].
const PASS: (f64, f64) = (2.0, 4.0);

/// `x`'s `order`-th derivative through the low-pass (frequency domain, periodic extension).
fn derivative(x: &[f64], dt: f64, order: u32) -> Vec<f64> {
    let n = x.len();
    let mut planner = FftPlanner::new();
    let mut buf: Vec<Complex64> = x.iter().map(|v| Complex64::new(*v, 0.0)).collect();
    planner.plan_fft_forward(n).process(&mut buf);
    for (k, c) in buf.iter_mut().enumerate() {
        let kk = if k <= n / 2 {
            k as f64
        } else {
            k as f64 - n as f64
        };
        let f = kk / (n as f64 * dt);
        let g = if f.abs() <= PASS.0 {
            1.0
        } else if f.abs() >= PASS.1 {
            0.0
        } else {
            0.5 + 0.5 * (std::f64::consts::PI * (f.abs() - PASS.0) / (PASS.1 - PASS.0)).cos()
        };
        let jw = Complex64::new(0.0, std::f64::consts::TAU * f);
        *c *= jw.powu(order) * g;
    }
    planner.plan_fft_inverse(n).process(&mut buf);
    buf.iter().map(|c| c.re / n as f64).collect()
}

/// The least-squares fit of a trace of the exciting motion (evenly sampled; angles, torques).
pub fn fit_inertia(trace: &[Sample]) -> Result<InertiaFit, IdentifyError> {
    if trace.len() < 1000 {
        return Err(IdentifyError::Data(format!(
            "the record holds {} samples: at least 1000 are needed",
            trace.len()
        )));
    }
    let dt = (trace[trace.len() - 1].t - trace[0].t) / (trace.len() - 1) as f64;
    let ch = |f: &dyn Fn(&Sample) -> f64| -> Vec<f64> { trace.iter().map(f).collect() };
    let th = [ch(&|s| s.x.q.x), ch(&|s| s.x.q.y)];
    if th
        .iter()
        .flatten()
        .chain(trace.iter().flat_map(|s| [&s.tau.x, &s.tau.y]))
        .any(|v| !v.is_finite())
    {
        return Err(IdentifyError::Data(
            "the record holds a value that is not a finite number".into(),
        ));
    }
    let tau = [
        derivative(&ch(&|s| s.tau.x), dt, 0),
        derivative(&ch(&|s| s.tau.y), dt, 0),
    ];
    let pos = [derivative(&th[0], dt, 0), derivative(&th[1], dt, 0)];
    let vel = [derivative(&th[0], dt, 1), derivative(&th[1], dt, 1)];
    let acc = [derivative(&th[0], dt, 2), derivative(&th[1], dt, 2)];
    // The fade's ends, where the filters' periodic extension joins, are left out.
    let skip = (1.0 / dt) as usize;
    let rows: Vec<usize> = (skip..trace.len().saturating_sub(skip)).collect();
    let mut a = DMatrix::<f64>::zeros(2 * rows.len(), 7);
    let mut b = DVector::<f64>::zeros(2 * rows.len());
    for (r, &k) in rows.iter().enumerate() {
        let (c2, s2) = (pos[1][k].cos(), pos[1][k].sin());
        let (v1, v2, a1, a2) = (vel[0][k], vel[1][k], acc[0][k], acc[1][k]);
        let sg = |v: f64| (v / 0.01).tanh();
        let r1 = [
            a1,
            a1 + a2,
            c2 * (2.0 * a1 + a2) - s2 * (2.0 * v1 * v2 + v2 * v2),
            sg(v1),
            v1,
            0.0,
            0.0,
        ];
        let r2 = [0.0, a1 + a2, c2 * a1 + s2 * v1 * v1, 0.0, 0.0, sg(v2), v2];
        for c in 0..7 {
            a[(2 * r, c)] = r1[c];
            a[(2 * r + 1, c)] = r2[c];
        }
        b[2 * r] = tau[0][k];
        b[2 * r + 1] = tau[1][k];
    }
    let x = a
        .clone()
        .svd(true, true)
        .solve(&b, 1e-12)
        .map_err(|e| IdentifyError::Data(format!("the inertia least squares: {e}")))?;
    let res = &b - &a * &x;
    let rms = |v: &DVector<f64>| (v.norm_squared() / v.len() as f64).sqrt();
    Ok(InertiaFit {
        rigid: Rigid {
            a: x[0],
            j: x[1],
            s: x[2],
        },
        friction: [(x[3], x[4]), (x[5], x[6])],
        residual: rms(&res),
        torque_rms: rms(&b),
    })
}

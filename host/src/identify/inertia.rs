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
//! ## The link's modes
//! With the modes known ([`FlexMode`]: `ω_j`, `ζ_j`, `v_j = ∫ρφ_j`, `w_j = ∫ρxφ_j`), their
//! torques are taken out of the record before the fit, from the core model's Lagrangian to
//! first order in `δ` (`flexarm_core::model`: the coupling `h = a1 (S1 cos θ2 − sin θ2 V)`,
//! `V = vᵀδ` the deflection's first moment across the link). Each mode is driven by the base's
//! transverse acceleration and the link's angular one,
//! `δ̈_j + 2ζ_jω_j δ̇_j + ω_j² δ_j = −a1 v_j (cos θ2 θ̈1 + sin θ2 θ̇1²) − w_j (θ̈1 + θ̈2)`
//! (solved in the frequency domain), and the joints feel
//! - `τ1 ⊃ (a1 cos θ2 v + w)ᵀδ̈ − a1 V [sin θ2 (2θ̈1 + θ̈2) + cos θ2 θ̇2 (2θ̇1 + θ̇2)]
//!   − 2 a1 sin θ2 (θ̇1 + θ̇2) V̇`,
//! - `τ2 ⊃ wᵀδ̈ − a1 V (sin θ2 θ̈1 − cos θ2 θ̇1²)`:
//!
//! the rigid coupling's terms turned by a quarter turn, with `V` for `S1`. Without them the
//! arm whose swing bends its link most (the identification family's slow arm: a 0.5 Hz first
//! mode, a 0.22 kg tip body) came out with `S` 5.5 % high even with its true modes; with them
//! within 3 % (`host/tests/identify_family.rs`). The terms of second order in `δ` (`δᵀδ` in
//! `J`) are left out.
//!
//! ## The experiment and the fit
//! Both joints move together through random rest-to-rest trapezoids about a pose (joint 1
//! within ±0.5 rad, joint 2 within ±1 rad, so that `cos θ2` varies; 1 to 2.5 s each, within a
//! drive's acceleration limit): the regressor's columns are then independent, and a drive runs
//! each move as any `move trapezoid`, the simulator the same moves with a hold of [`GAP`]
//! between them as a host's round trips leave. The encoders' angles are differentiated in the
//! frequency domain (the record starts and ends at rest at the pose, so its periodic extension
//! is smooth) through a low-pass from 4 to 8 Hz against the encoders' quantization; the
//! regressor's columns and the torques then pass the same low-pass, a raised-cosine taper from
//! 2 to 4 Hz against the link's ringing, so that the equation holds between the filtered
//! sides. The seven
//! parameters `(A, J, S, F_c1, F_v1, F_c2, F_v2)` come from one least-squares fit of both
//! joints' equations over every sample.

use flexarm_core::Vector2;
use flexarm_core::params::ArmParams;
use flexarm_core::trajectory::JointTrajectory;
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

    /// The gate `physical consistency`: `A`, `J`, `S` positive and the rigid mass matrix
    /// `[[A + J + 2S cos θ2, J + S cos θ2], [J + S cos θ2, J]]` positive definite at every
    /// `θ2`: its determinant is `A J − S² cos² θ2`, so `A J > S²`.
    pub fn check(&self) -> Result<(), IdentifyError> {
        let bad = |m: String| {
            Err(IdentifyError::Data(format!(
                "gate `physical consistency`: {m}"
            )))
        };
        for (name, v) in [("A", self.a), ("J", self.j), ("S", self.s)] {
            if !(v.is_finite() && v > 0.0) {
                return bad(format!(
                    "{name} = {v:.4e} kg·m²: an inertia must be positive (torques of the wrong sign, or a record that does not determine it)"
                ));
            }
        }
        if self.a * self.j <= self.s * self.s {
            return bad(format!(
                "A J = {:.4e} ≤ S² = {:.4e}: the rigid mass matrix would not be positive definite at θ2 = 0",
                self.a * self.j,
                self.s * self.s
            ));
        }
        Ok(())
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
    /// The combinations' uncertainty [kg·m²]: half the difference of the record's two halves'
    /// fits.
    pub sigma: Rigid,
    /// The column-scaled regressor's condition number.
    pub condition: f64,
}

/// Encoder steps each joint must travel for the inertia fit.
pub const MIN_TRAVEL: f64 = 200.0;
/// The column-scaled regressor's condition number above which the record does not tell the
/// parameters apart (the experiment's record: 9; a record where `θ2` barely moves: thousands).
pub const MAX_CONDITION: f64 = 100.0;
/// Relative uncertainty of a combination above which the fit is refused.
pub const MAX_SPREAD: f64 = 0.1;

/// The exciting motion's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InertiaPlan {
    /// The pose the moves are about [rad].
    pub pose: Vector2<f64>,
    /// Joint 1's reach about the pose [rad] (joint 2's is [`JOINT2_SCALE`] times it).
    pub amplitude: f64,
    /// Moves.
    pub moves: usize,
    /// Seed of the random targets and durations.
    pub seed: u64,
}

impl Default for InertiaPlan {
    /// 30 moves within ±0.5 rad (joint 2 ±1 rad) of `(0, 0.5)`.
    fn default() -> Self {
        Self {
            pose: Vector2::new(0.0, 0.5),
            amplitude: 0.5,
            moves: 30,
            seed: 11,
        }
    }
}

/// Joint 2's reach against joint 1's: a wide swing of `θ2` makes `cos θ2` vary, which tells
/// `S` from `A` and `J`.
pub const JOINT2_SCALE: f64 = 2.0;
/// The simulator's hold between two moves [s] (a host's round trips).
pub const GAP: f64 = 0.3;

/// One move of the experiment: its target [rad] and duration [s] (ramps of a third).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InertiaMove {
    /// Where it ends [rad].
    pub target: Vector2<f64>,
    /// How long it takes [s].
    pub time: f64,
}

impl InertiaMove {
    /// Its ramps [s]: a third of the move.
    pub fn ramp(&self) -> f64 {
        super::ramp_of(self.time)
    }
}

/// The moves: random targets about the pose, 1 to 2.5 s each (longer where the acceleration
/// limit asks), the last back to the pose.
pub fn moves(plan: &InertiaPlan) -> Result<Vec<InertiaMove>, IdentifyError> {
    if !(2..=200).contains(&plan.moves) {
        return Err(IdentifyError::Data(format!(
            "{} moves: give 2 to 200",
            plan.moves
        )));
    }
    if !(plan.amplitude.is_finite() && plan.amplitude > 0.0 && plan.amplitude <= 1.2) {
        return Err(IdentifyError::Data(format!(
            "a reach of {} rad: give (0, 1.2] rad",
            plan.amplitude
        )));
    }
    let mut rng = crate::sim::Rng::new(plan.seed);
    let reach = Vector2::new(plan.amplitude, JOINT2_SCALE * plan.amplitude);
    let mut from = plan.pose;
    Ok((0..plan.moves)
        .map(|k| {
            let target = if k + 1 == plan.moves {
                plan.pose
            } else {
                plan.pose + reach.map(|r| r * (2.0 * rng.uniform() - 1.0))
            };
            let time = (1.0 + 1.5 * rng.uniform()).max(super::least_time(from, target));
            from = target;
            InertiaMove { target, time }
        })
        .collect())
}

/// The trajectories the drive runs for the moves from the pose, each from its own `t = 0`,
/// with [`GAP`] of hold after each.
pub fn segments(plan: &InertiaPlan) -> Result<Vec<(f64, JointTrajectory<f32>)>, IdentifyError> {
    let mut from = plan.pose;
    let mut t = 0.0;
    let mut out = Vec::new();
    for m in moves(plan)? {
        out.push((t, super::trapezoid(from, m.target, m.time)?));
        t += m.time;
        out.push((t, JointTrajectory::Hold(m.target.cast::<f32>())));
        t += GAP;
        from = m.target;
    }
    Ok(out)
}

/// Runs the exciting motion on the simulator; the trace's angles are the encoders' readings.
pub fn inertia_experiment(
    cfg: &SimConfig,
    plan: &InertiaPlan,
) -> Result<Vec<Sample>, IdentifyError> {
    let segs = segments(plan)?;
    let end = segs.last().map_or(0.0, |s| s.0) + GAP;
    let run = SimConfig {
        duration: end,
        tail_window: 1.0,
        ..*cfg
    };
    let (_, trace) = simulate_segments(&run, &segs, true)
        .map_err(|e| IdentifyError::Sim(format!("the inertia experiment: {e}")))?;
    Ok(super::encoder_readings(&cfg.sensors, trace))
}

/// The fit's low-pass taper [Hz]: the torques and the regressor's columns pass it.
const PASS: (f64, f64) = (2.0, 4.0);
/// The derivatives' low-pass taper [Hz]: against the encoders' quantization only, wide enough
/// to be flat wherever [`PASS`] lets anything through, so that a linear column filtered by
/// [`PASS`] is the torque's filter exactly.
const PASS_DERIVATIVES: (f64, f64) = (4.0, 8.0);

/// `δ`, `δ̇`, `δ̈` of `δ̈ + 2ζω δ̇ + ω² δ = f` for the forcing `f` sampled every `dt` [s]
/// (frequency domain, periodic extension).
fn modal_response(f: &[f64], dt: f64, omega: f64, zeta: f64) -> [Vec<f64>; 3] {
    let n = f.len();
    let mut planner = FftPlanner::new();
    let mut x: Vec<Complex64> = f.iter().map(|v| Complex64::new(*v, 0.0)).collect();
    planner.plan_fft_forward(n).process(&mut x);
    let inverse = planner.plan_fft_inverse(n);
    let w: Vec<f64> = (0..n)
        .map(|k| {
            let fk = if k <= n / 2 {
                k as f64
            } else {
                k as f64 - n as f64
            } / (n as f64 * dt);
            std::f64::consts::TAU * fk
        })
        .collect();
    [0, 1, 2].map(|order| {
        let mut y: Vec<Complex64> = x
            .iter()
            .zip(&w)
            .map(|(c, &w)| {
                let h = Complex64::new(omega * omega - w * w, 2.0 * zeta * omega * w).inv();
                c * h * Complex64::new(0.0, w).powu(order)
            })
            .collect();
        inverse.process(&mut y);
        y.iter().map(|c| c.re / n as f64).collect()
    })
}

/// `x`'s derivatives of `orders` through the raised-cosine low-pass `pass` [Hz] (frequency
/// domain, periodic extension; one forward transform).
fn derivatives<const N: usize>(
    x: &[f64],
    dt: f64,
    pass: (f64, f64),
    orders: [u32; N],
) -> [Vec<f64>; N] {
    let n = x.len();
    let mut planner = FftPlanner::new();
    let mut spectrum: Vec<Complex64> = x.iter().map(|v| Complex64::new(*v, 0.0)).collect();
    planner.plan_fft_forward(n).process(&mut spectrum);
    let inverse = planner.plan_fft_inverse(n);
    let gain = |k: usize| {
        let f = (if k <= n / 2 {
            k as f64
        } else {
            k as f64 - n as f64
        }) / (n as f64 * dt);
        let g = if f.abs() <= pass.0 {
            1.0
        } else if f.abs() >= pass.1 {
            0.0
        } else {
            0.5 + 0.5 * (std::f64::consts::PI * (f.abs() - pass.0) / (pass.1 - pass.0)).cos()
        };
        (Complex64::new(0.0, std::f64::consts::TAU * f), g)
    };
    orders.map(|order| {
        let mut buf: Vec<Complex64> = spectrum
            .iter()
            .enumerate()
            .map(|(k, c)| {
                let (jw, g) = gain(k);
                c * jw.powu(order) * g
            })
            .collect();
        inverse.process(&mut buf);
        buf.iter().map(|c| c.re / n as f64).collect()
    })
}

/// One mode of the link as the joints feel it: `ω` [rad/s], `ζ`, and its coupling to the
/// joints, `v` [√kg] and `w` [√kg·m] (`flexarm_core::model`: the mass matrix's
/// `b_{1,2+j} = a1 cos θ2 v_j + w_j`, `b_{2,2+j} = w_j`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlexMode {
    /// `ω` [rad/s].
    pub omega: f64,
    /// `ζ`.
    pub zeta: f64,
    /// `v_j` [√kg].
    pub v: f64,
    /// `w_j` [√kg·m].
    pub w: f64,
}

/// The least-squares fit of a trace of the exciting motion (evenly sampled; angles, torques)
/// with the link rigid.
pub fn fit_inertia(trace: &[Sample]) -> Result<InertiaFit, IdentifyError> {
    fit_inertia_with(trace, 0.0, &[])
}

/// The fit with the link's modes `flex` taken out of the torques, `a1` [m] link 1's length: a
/// link whose first mode lies near the motion's band is no rigid body, and its modes' reaction
/// `τ1 += Σ (a1 cos θ2 v_j + w_j) δ̈_j`, `τ2 += Σ w_j δ̈_j` is what a rigid fit would charge to
/// the inertias. `δ_j` follows from the measured joints' accelerations through the mode's own
/// equation, `δ̈_j + 2ζ_jω_j δ̇_j + ω_j² δ_j = −(a1 cos θ2 v_j + w_j) θ̈1 − w_j θ̈2`, solved in
/// the frequency domain (the record starts and ends at rest).
pub fn fit_inertia_with(
    trace: &[Sample],
    a1: f64,
    flex: &[FlexMode],
) -> Result<InertiaFit, IdentifyError> {
    solve_inertia(trace, a1, flex, true)
}

/// The link's modes' coupling from `S` [kg·m²]: what the model step knows of the link's mass
/// once `S` is known ([`fit_inertia_flexible`]).
pub type Coupling<'a> = &'a dyn Fn(f64) -> Result<Vec<FlexMode>, IdentifyError>;

/// [`fit_inertia_with`] where the modes' coupling depends on `S` itself: three passes, each
/// with the coupling of the pass before's `S`, at least `s_floor` [kg·m²] (what a payload
/// alone gives: a rigid fit of a flexible link may find less); the first with the link rigid,
/// the first two with the gates waived (a flexible link's rigid fit may well fail them).
pub fn fit_inertia_flexible(
    trace: &[Sample],
    a1: f64,
    s_floor: f64,
    coupling: Coupling,
) -> Result<InertiaFit, IdentifyError> {
    let mut s = solve_inertia(trace, a1, &[], false)?.rigid.s;
    for _ in 0..2 {
        s = solve_inertia(trace, a1, &coupling(s.max(s_floor))?, false)?
            .rigid
            .s;
    }
    fit_inertia_with(trace, a1, &coupling(s.max(s_floor))?)
}

fn solve_inertia(
    trace: &[Sample],
    a1: f64,
    flex: &[FlexMode],
    gates: bool,
) -> Result<InertiaFit, IdentifyError> {
    if trace.len() < 1000 {
        return Err(IdentifyError::Data(format!(
            "gate `record length`: the record holds {} samples: at least 1000 are needed",
            trace.len()
        )));
    }
    let dt = super::even_period(trace)?;
    let ch = |f: &dyn Fn(&Sample) -> f64| -> Vec<f64> { trace.iter().map(f).collect() };
    let th = [ch(&|s| s.x.q.x), ch(&|s| s.x.q.y)];
    if th
        .iter()
        .flatten()
        .chain(trace.iter().flat_map(|s| [&s.tau.x, &s.tau.y]))
        .any(|v| !v.is_finite())
    {
        return Err(IdentifyError::Data(
            "gate `channels`: the record holds a value that is not a finite number".into(),
        ));
    }
    let excitation = |m: String| Err(IdentifyError::Data(format!("gate `excitation`: {m}")));
    for (j, theta) in th.iter().enumerate() {
        let torque = trace.iter().map(|s| s.tau[j]);
        if super::record::span(torque) == 0.0 {
            return excitation(format!(
                "joint {}'s torque `tau{}` never changes (a disarmed board records zeros): the inertias cannot be seen",
                j + 1,
                j + 1
            ));
        }
        let travel = super::record::travel_counts(theta);
        if travel < MIN_TRAVEL {
            return excitation(format!(
                "joint {} moved {travel} encoder steps (at least {MIN_TRAVEL}): move both joints through the experiment's trapezoids",
                j + 1
            ));
        }
    }
    let lowpass = |x: &[f64]| {
        let [y] = derivatives(x, dt, PASS, [0]);
        y
    };
    let [pos1, vel1, acc1] = derivatives(&th[0], dt, PASS_DERIVATIVES, [0, 1, 2]);
    let [pos2, vel2, acc2] = derivatives(&th[1], dt, PASS_DERIVATIVES, [0, 1, 2]);
    let (pos, vel, acc) = ([pos1, pos2], [vel1, vel2], [acc1, acc2]);
    let mut raw = [ch(&|s| s.tau.x), ch(&|s| s.tau.y)];
    let (cos2, sin2): (Vec<f64>, Vec<f64>) = pos[1].iter().map(|p| (p.cos(), p.sin())).unzip();
    for m in flex {
        // The mode's forcing: the base's transverse acceleration `a1 (cos θ2 θ̈1 + sin θ2 θ̇1²)`
        // through `v`, the link's angular acceleration through `w` (module docs).
        let force: Vec<f64> = (0..raw[0].len())
            .map(|k| {
                -a1 * m.v * (cos2[k] * acc[0][k] + sin2[k] * vel[0][k] * vel[0][k])
                    - m.w * (acc[0][k] + acc[1][k])
            })
            .collect();
        let [d, dd, ddd] = modal_response(&force, dt, m.omega, m.zeta);
        for k in 0..raw[0].len() {
            let (c2, s2) = (cos2[k], sin2[k]);
            let (w1, w2, a_1, a_2) = (vel[0][k], vel[1][k], acc[0][k], acc[1][k]);
            // The deflection's first moment `V = v δ` turns the rigid coupling's terms by a
            // quarter turn (module docs).
            let (v, vd) = (m.v * d[k], m.v * dd[k]);
            raw[0][k] -= (a1 * c2 * m.v + m.w) * ddd[k]
                - a1 * s2 * (2.0 * a_1 + a_2) * v
                - a1 * c2 * w2 * (2.0 * w1 + w2) * v
                - 2.0 * a1 * s2 * (w1 + w2) * vd;
            raw[1][k] -= m.w * ddd[k] - a1 * s2 * a_1 * v + a1 * c2 * w1 * w1 * v;
        }
    }
    let tau = [lowpass(&raw[0]), lowpass(&raw[1])];
    // The regressor's columns, each through the low-pass the torques took: its products of
    // angles, speeds and accelerations reach past the band, and the equation holds only when
    // both sides are filtered alike.
    let n = trace.len();
    let sg = |v: f64| (v / 0.01).tanh();
    let column = |f: &dyn Fn(usize) -> f64| lowpass(&(0..n).map(f).collect::<Vec<_>>());
    let zero = vec![0.0; n];
    let y1: [Vec<f64>; 7] = [
        column(&|k| acc[0][k]),
        column(&|k| acc[0][k] + acc[1][k]),
        column(&|k| {
            let (c2, s2) = (pos[1][k].cos(), pos[1][k].sin());
            c2 * (2.0 * acc[0][k] + acc[1][k])
                - s2 * (2.0 * vel[0][k] * vel[1][k] + vel[1][k] * vel[1][k])
        }),
        column(&|k| sg(vel[0][k])),
        column(&|k| vel[0][k]),
        zero.clone(),
        zero.clone(),
    ];
    let y2: [Vec<f64>; 7] = [
        zero.clone(),
        y1[1].clone(),
        column(&|k| pos[1][k].cos() * acc[0][k] + pos[1][k].sin() * vel[0][k] * vel[0][k]),
        zero.clone(),
        zero,
        column(&|k| sg(vel[1][k])),
        column(&|k| vel[1][k]),
    ];
    // The record's ends, where the filters' periodic extension joins, are left out.
    let skip = (1.0 / dt) as usize;
    let rows: Vec<usize> = (skip..n.saturating_sub(skip)).collect();
    let mut a = DMatrix::<f64>::zeros(2 * rows.len(), 7);
    let mut b = DVector::<f64>::zeros(2 * rows.len());
    for (r, &k) in rows.iter().enumerate() {
        for c in 0..7 {
            a[(2 * r, c)] = y1[c][k];
            a[(2 * r + 1, c)] = y2[c][k];
        }
        b[2 * r] = tau[0][k];
        b[2 * r + 1] = tau[1][k];
    }
    let solve = |a: &DMatrix<f64>, b: &DVector<f64>| {
        a.clone()
            .svd(true, true)
            .solve(b, 1e-12)
            .map_err(|e| IdentifyError::Data(format!("the inertia least squares: {e}")))
    };
    // The regressor's conditioning, columns scaled to unit norm.
    let mut scaled = a.clone();
    for mut c in scaled.column_iter_mut() {
        let n = c.norm();
        if n > 0.0 {
            c /= n;
        }
    }
    let sv = scaled.singular_values();
    let condition = sv.max() / sv.min().max(f64::MIN_POSITIVE);
    if gates && (condition.is_nan() || condition > MAX_CONDITION) {
        return Err(IdentifyError::Data(format!(
            "gate `regressor condition`: the regressor's condition number is {condition:.3e} (at most {MAX_CONDITION}): the record's motion does not tell A, J, S and the friction apart (θ2 must swing widely, both joints move both ways at several speeds)"
        )));
    }
    let x = solve(&a, &b)?;
    // The record's two halves, fitted alone: their difference is the uncertainty.
    let half = a.nrows() / 4 * 2;
    let xa = solve(&a.rows(0, half).into_owned(), &b.rows(0, half).into_owned())?;
    let xb = solve(
        &a.rows(half, a.nrows() - half).into_owned(),
        &b.rows(half, b.nrows() - half).into_owned(),
    )?;
    let sigma = Rigid {
        a: (xa[0] - xb[0]).abs() / 2.0,
        j: (xa[1] - xb[1]).abs() / 2.0,
        s: (xa[2] - xb[2]).abs() / 2.0,
    };
    let rigid = Rigid {
        a: x[0],
        j: x[1],
        s: x[2],
    };
    if gates {
        rigid.check()?;
    }
    for (name, v, s) in [
        ("A", rigid.a, sigma.a),
        ("J", rigid.j, sigma.j),
        ("S", rigid.s, sigma.s),
    ] {
        if gates && s > MAX_SPREAD * v {
            return Err(IdentifyError::Data(format!(
                "gate `uncertainty`: {name} = {v:.4e} ± {s:.1e} kg·m² (the record's halves disagree by more than {:.0} %): a longer record, or wider moves",
                MAX_SPREAD * 100.0
            )));
        }
    }
    let res = &b - &a * &x;
    let rms = |v: &DVector<f64>| (v.norm_squared() / v.len() as f64).sqrt();
    Ok(InertiaFit {
        rigid,
        friction: [(x[3], x[4]), (x[5], x[6])],
        residual: rms(&res),
        torque_rms: rms(&b),
        sigma,
        condition,
    })
}

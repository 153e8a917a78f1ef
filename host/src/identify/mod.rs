//! Identifying an arm from measured data (issue 17, docs/identification.md): excite, record,
//! fit, generate, verify. Units SI; joint frames and modal coordinates as in `flexarm_core`.
//!
//! - [`friction`]: the joints' Coulomb and viscous friction from constant-speed moves;
//! - [`frf`]: frequency responses of a multiple-input record (Welch, Hann, H1);
//! - [`rational`]: the common-denominator rational fit of those responses, and its modes;
//! - [`modes`]: the link's modes experiment with the joints held, and the piezo→film products;
//! - [`inertia`]: the rigid inertias' identifiable combinations by least squares;
//! - [`model`]: the controller's model from the fits, its file, the closed-loop check;
//! - [`report`], [`workflow`]: the reports and the `cargo sim identify` steps.

pub mod decay;
pub mod family;
pub mod friction;
pub mod geometry;
pub mod inertia;
pub mod modal;
pub mod model;
pub mod modes;
pub mod order;
pub mod rational;
pub mod record;
pub mod report;
pub mod spectra;
pub mod workflow;

pub use friction::*;

use flexarm_core::Vector2;
use flexarm_core::trajectory::{JointTrajectory, Profile, Trapezoid};

use crate::sim::Sample;

/// What an identification can refuse.
#[derive(Clone, Debug, PartialEq)]
pub enum IdentifyError {
    /// The data cannot determine the parameters, and why.
    Data(String),
    /// The simulation of an experiment failed.
    Sim(String),
}

impl std::fmt::Display for IdentifyError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Data(m) | Self::Sim(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for IdentifyError {}

/// The sampling period of `trace` [s], which must be even: a gap (lost frames) is refused with
/// its time.
pub fn even_period(trace: &[Sample]) -> Result<f64, IdentifyError> {
    let (Some(a), Some(b)) = (trace.first(), trace.get(1)) else {
        return Err(IdentifyError::Data(
            "the record holds fewer than two samples".into(),
        ));
    };
    let dt = b.t - a.t;
    if let Some(w) = trace.windows(2).find(|w| {
        let gap = w[1].t - w[0].t;
        gap.is_nan() || (gap - dt).abs() > 0.25 * dt
    }) {
        return Err(IdentifyError::Data(format!(
            "the record is not sampled evenly: {:.4} s between the samples at {:.4} s and {:.4} s, {dt:.4} s elsewhere (lost frames?)",
            w[1].t - w[0].t,
            w[0].t,
            w[1].t
        )));
    }
    Ok(dt)
}

/// The experiments' moves' peak acceleration at most [rad/s²]: a drive refuses more than 10
/// (`flexarm_core::drive::MoveLimits`).
const ACCEL_MAX: f64 = 8.0;

/// The ramps of an experiment's trapezoid of `time` seconds [s]: a third of it.
pub fn ramp_of(time: f64) -> f64 {
    time / 3.0
}

/// The shortest time [s] a trapezoid with ramps of a third takes from `from` to `to` [rad]
/// within [`ACCEL_MAX`]: it peaks at `4.5 |Δθ| / T²`.
pub fn least_time(from: Vector2<f64>, to: Vector2<f64>) -> f64 {
    (4.5 * (to - from).abs().max() / ACCEL_MAX).sqrt()
}

/// The experiments' rest-to-rest trapezoid from `from` to `to` [rad] in `time` [s], ramps of a
/// third.
pub fn trapezoid(
    from: Vector2<f64>,
    to: Vector2<f64>,
    time: f64,
) -> Result<JointTrajectory<f32>, IdentifyError> {
    let profile = Profile::new(time as f32, ramp_of(time) as f32)
        .map_err(|e| IdentifyError::Data(format!("a move of {time} s: {e:?}")))?;
    Ok(JointTrajectory::Trapezoid(Trapezoid {
        start: from.cast::<f32>(),
        amplitude: (to - from).cast::<f32>(),
        profile,
    }))
}

/// A simulated trace as a board records it: the angles the encoders of `sensors` read.
pub fn encoder_readings(sensors: &crate::sim::Sensors, trace: Vec<Sample>) -> Vec<Sample> {
    trace
        .into_iter()
        .map(|mut x| {
            x.x.q.x = sensors.angle(x.x.q.x);
            x.x.q.y = sensors.angle(x.x.q.y);
            x
        })
        .collect()
}

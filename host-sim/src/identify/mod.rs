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

pub mod frf;
pub mod friction;
pub mod inertia;
pub mod model;
pub mod modes;
pub mod rational;
pub mod report;
pub mod workflow;

pub use friction::*;

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
pub fn even_period(trace: &[crate::sim::Sample]) -> Result<f64, IdentifyError> {
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

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

//! # flexarm-sim
//!
//! The plants (the core's model in `f64`, integrated with RK4, and the truth plant: link 2 with
//! up to ten modes behind real drives and transducers), the controllers (the core's `f32` code,
//! exactly what the firmware runs, sampled with zero-order hold at their own rates), the paper's
//! scenarios, scenario files, outputs (CSV, SVG figures, Markdown tables), the Monte Carlo
//! robustness study and the spillover study.

pub mod actuators;
pub mod cli;
pub mod eigen;
pub mod firmware_params;
pub mod identify;
pub mod lab;
pub mod montecarlo;
pub mod outdir;
pub mod output;
pub mod plant;
pub mod rig;
pub mod scenario;
pub mod sim;
pub mod spillover;
pub mod spillover_study;
pub mod study;
pub mod truth;
pub mod truth_plant;

//! # flexarm-sim
//!
//! The plant (the core's model in `f64`, integrated with RK4), the controllers (the core's `f32`
//! code, exactly what the firmware runs, sampled with zero-order hold at their own rates), the
//! paper's scenarios, scenario files, outputs (CSV, SVG figures, Markdown tables) and the Monte
//! Carlo robustness study.

pub mod actuators;
pub mod firmware_params;
pub mod montecarlo;
pub mod outdir;
pub mod output;
pub mod plant;
pub mod scenario;
pub mod sim;
pub mod spillover;
pub mod spillover_study;
pub mod study;
pub mod truth;
pub mod truth_plant;

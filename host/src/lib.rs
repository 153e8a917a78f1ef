//! # flexarm-host
//!
//! The host library under the simulator's command (`flexarm-sim`, `host-sim/`) and the
//! operator's console (`flexarm`, `console/`): the plants (the core's model in `f64`,
//! integrated with RK4, and the truth plant: link 2 with up to ten modes behind real drives and
//! transducers), the host rig that runs the board's period on them (`flexarm_machine`), the
//! paper's controllers on the true state, the paper's scenarios, scenario files, outputs (CSV, SVG figures, Markdown tables), the Monte Carlo
//! robustness study and the spillover study, the identification's experiments and fits, and
//! the firmware's generated parameters. The placement optimization's search is not here
//! (`flexarm-placement`, which only the simulator's command uses): `docs/architecture.md`.

pub mod actuators;
pub mod board_homing;
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

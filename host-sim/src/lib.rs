//! # flexarm-sim
//!
//! The plant (the core's model in `f64`, integrated with RK4), the controllers (the core's `f32`
//! code, exactly what the firmware runs, sampled with zero-order hold at their own rates), and
//! the paper's scenarios.

pub mod plant;
pub mod sim;

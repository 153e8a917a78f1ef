//! The plant: the core's model in `f64`, integrated with the core's fixed-step RK4 (the paper's
//! integrator), the same code the firmware's QEMU board runs in `f32`.

pub use flexarm_core::plant::{State, rk4_step};

/// Why the integration stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Diverged;

impl core::fmt::Display for Diverged {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(
            "the plant state diverged (inertia matrix not positive definite or non-finite state)",
        )
    }
}

impl std::error::Error for Diverged {}

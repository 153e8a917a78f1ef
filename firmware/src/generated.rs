//! The arm model, piezo patch and observer gains the firmware runs.
//!
//! Generated: do not edit. Source: `firmware/piezo.toml`. Regenerate with
//! `cargo sim firmware-params firmware/piezo.toml --out firmware/src/generated.rs`
//! (host-sim/src/firmware_params.rs). `cargo test -p flexarm-sim --test firmware_params`
//! checks that `firmware/src/generated.rs` is what `firmware/piezo.toml` gives.
//!
//! Observer gains: steady-state Kalman gains (`flexarm_core::observer::design`,
//! `NoiseModel::default()`) of [`ARM`] at rest at `THETA_NOMINAL`, for this patch's
//! film map `c_f = k_s Δφ' = [1.2745437e2, -6.4355585e2]` V/(√kg·m).

use flexarm_core::Vector2;
use flexarm_core::params::{ArmParams, ModalData};

/// The controller's model of the arm (SI; `flexarm_core::params::ArmParams`): the
/// source's `[arm]` (the paper's values where it has none); its modes:
/// the paper's frequencies and damping, a uniform link's shapes.
pub const ARM: ArmParams<f32> = ArmParams {
    a1: 3e-1,
    a2: 7e-1,
    m1: 2e-1,
    m2: 3e-1,
    m_h2: 1e0,
    i_1: 1.7e-1,
    i_h1: 2.3e-1,
    i_h2: 1.98e-1,
    i_2_extra: 0e0,
    modes: ModalData {
        omega: Vector2::new(2.9631502e1, 9.044645e1),
        zeta: Vector2::new(7e-2, 3e-2),
        mass_integral: Vector2::new(4.2886224e-1, 2.3767647e-1),
        moment_integral: Vector2::new(2.1809109e-1, 3.480051e-2),
        tip: Vector2::new(3.6514838e0, -3.6514838e0),
    },
};

/// Patch start from joint 2 `x_a` [m].
pub const X_A: f32 = 9e-2;
/// Patch length `l_a` [m].
pub const L_A: f32 = 3.5e-1;
/// Slope differences `Δφ'_j` across the patch, the modes of [`ARM`] [1/(m·√kg)].
pub const SLOPE_DIFF: [f32; 2] = [4.550401e0, -2.297636e1];
/// Slope differences across the patch on the QEMU board's simulated arm (the paper's
/// arm, uniform link 2, whatever [`ARM`] is) [1/(m·√kg)].
pub const QEMU_SLOPE_DIFF: [f32; 2] = [4.550401e0, -2.297636e1];
/// Actuator moment per volt `k_a` [N·m/V].
pub const K_A: f32 = 1.9369947e-4;
/// Film volts per radian of slope difference `k_s` [V/rad].
pub const K_S: f32 = 2.8009478e1;
/// Rate-feedback gain `k_c` of `V_a = −k_c V̇_f` [s] (the fragment's `piezo.k_c`).
pub const K_C: f32 = 3e1;

/// Observer gain `L` (8×3, row-major; rows `(q, q̇)`, columns `(θ1, θ2, V_f)`) for a
/// motor period of 0.001 s.
pub const GAIN_1KHZ: [[f32; 3]; 8] = [
    [9.137317e-2, 2.1025278e-3, 3.467516e-5],
    [2.1025278e-3, 9.716001e-2, 1.1341266e-4],
    [1.12311235e-2, 3.622902e-2, 9.310465e-4],
    [1.784655e-3, 5.737126e-3, -1.567264e-4],
    [4.3820505e0, 2.3371364e-1, 3.851551e-3],
    [2.2588529e-1, 5.017633e0, 1.4322112e-2],
    [-1.2056367e-1, -2.997437e-1, 1.472669e-2],
    [-1.3119152e-1, -3.820097e-1, -3.9991565e-2],
];

/// Observer gain `L` (8×3, row-major; rows `(q, q̇)`, columns `(θ1, θ2, V_f)`) for a
/// motor period of 0.01 s.
pub const GAIN_100HZ: [[f32; 3]; 8] = [
    [6.2269074e-1, 8.483343e-3, 6.5637214e-5],
    [8.483343e-3, 6.461399e-1, 2.090568e-4],
    [6.4264044e-2, 2.0846997e-1, 2.6034452e-3],
    [1.1895112e-2, 3.8636304e-2, -9.4900816e-4],
    [2.8147875e1, 9.404061e-1, 8.118351e-3],
    [9.062325e-1, 3.0699615e1, 2.6195984e-2],
    [-7.181042e-1, -1.8183345e0, 4.2715035e-2],
    [-2.8407267e-1, -6.703157e-1, -1.2712683e-1],
];

//! The piezo patch and observer gains the firmware runs (paper's arm, modes = "paper").
//!
//! Generated: do not edit. Source: `firmware/piezo.toml`. Regenerate with
//! `cargo sim firmware-params firmware/piezo.toml --out firmware/src/generated.rs`
//! (host-sim/src/firmware_params.rs). `cargo test -p flexarm-sim --test firmware_params`
//! checks that `firmware/src/generated.rs` is what `firmware/piezo.toml` gives.
//!
//! Observer gains: steady-state Kalman gains (`flexarm_core::observer::design`,
//! `NoiseModel::default()`) of the paper's arm at rest at `THETA_NOMINAL`, for this patch's
//! film map `c_f = k_s Δφ' = [6.5106415e1, -3.2874207e2]` V/(√kg·m).

/// Patch start from joint 2 `x_a` [m].
pub const X_A: f32 = 9e-2;
/// Patch length `l_a` [m].
pub const L_A: f32 = 3.5e-1;
/// Slope differences `Δφ'_j` across the patch, paper's modes [1/(m·√kg)].
pub const SLOPE_DIFF: [f32; 2] = [4.550401e0, -2.297636e1];
/// Actuator moment per volt `k_a` [N·m/V].
pub const K_A: f32 = 2.77951e-5;
/// Film volts per radian of slope difference `k_s` [V/rad].
pub const K_S: f32 = 1.430784e1;
/// Rate-feedback gain `k_c` of `V_a = −k_c V̇_f` [s] (the fragment's `piezo.k_c`).
pub const K_C: f32 = 3e1;

/// Observer gain `L` (8×3, row-major; rows `(q, q̇)`, columns `(θ1, θ2, V_f)`) for a
/// motor period of 0.001 s.
pub const GAIN_1KHZ: [[f32; 3]; 8] = [
    [9.14238e-2, 2.2541177e-3, 3.5899564e-5],
    [2.2541177e-3, 9.779328e-2, 1.2262794e-4],
    [1.22776255e-2, 4.0556993e-2, 9.771589e-4],
    [1.5405121e-3, 4.988539e-3, -2.6636728e-4],
    [4.3874545e0, 2.500051e-1, 3.363433e-3],
    [2.4360876e-1, 5.0888643e0, 1.4731292e-2],
    [-1.11713156e-1, -2.8732136e-1, 1.28681455e-2],
    [-1.8250103e-1, -5.087598e-1, -3.6482364e-2],
];

/// Observer gain `L` (8×3, row-major; rows `(q, q̇)`, columns `(θ1, θ2, V_f)`) for a
/// motor period of 0.01 s.
pub const GAIN_100HZ: [[f32; 3]; 8] = [
    [6.2283856e-1, 8.872485e-3, 1.05164014e-4],
    [8.872485e-3, 6.4794827e-1, 3.4362066e-4],
    [6.807142e-2, 2.2611853e-1, 4.2204973e-3],
    [1.08711505e-2, 3.625337e-2, -1.7369172e-3],
    [2.8169178e1, 9.950439e-1, 1.20739e-2],
    [9.542679e-1, 3.0902418e1, 4.2063445e-2],
    [-6.798981e-1, -1.7940838e0, 6.472808e-2],
    [-5.451445e-1, -1.186313e0, -1.9801463e-1],
];

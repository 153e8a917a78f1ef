//! The arm model, piezo patch and observer gains the firmware runs, in each board's configuration.
//!
//! Generated: do not edit. Source: `firmware/piezo.toml`. Regenerate with
//! `cargo sim firmware-params firmware/piezo.toml --out firmware/src/generated.rs`
//! (host/src/firmware_params.rs). `cargo test -p flexarm-host --test firmware_params`
//! checks that `firmware/src/generated.rs` is what `firmware/piezo.toml` gives.
//!
//! Observer gains: steady-state Kalman gains (`flexarm_core::observer::design`,
//! `NoiseModel::default()`) of [`ARM`] at rest at `THETA_NOMINAL`, for this patch's
//! film map `c_f = k_s Δφ' = [1.2745437e2, -6.4355585e2]` V/(√kg·m).

use flexarm_core::control::motor::MotorLaw;
use flexarm_core::control::piezo::{PiezoGains, PiezoPatch};
use flexarm_core::control::select::PiezoLawKind;
use flexarm_core::drive::MoveLimits;
use flexarm_core::homing::{Config as HomingConfig, JointHoming, Method};
use flexarm_core::motion::{MotionLimits, Thermal};
use flexarm_core::tuning::RateCeiling;
use flexarm_core::params::{ArmParams, Gains, Limits, ModalData};
use flexarm_core::{Vector2, Vector4};
use flexarm_link::msg::Board;
use flexarm_machine::BoardConfig;

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

/// The piezo patch on link 2 (`flexarm_core::control::piezo::PiezoPatch`): its start
/// from joint 2 `x_a` [m], its length `l_a` [m], the slope differences `Δφ'_j` across it
/// on the modes of [`ARM`] [1/(m·√kg)], the actuator's moment per volt `k_a` [N·m/V] and
/// the film's volts per radian of slope difference `k_s` [V/rad].
pub const PATCH: PiezoPatch<f32> = PiezoPatch {
    x_a: 9e-2,
    l_a: 3.5e-1,
    slope_diff: Vector2::new(4.550401e0, -2.297636e1),
    k_a: 1.9369947e-4,
    k_s: 2.8009478e1,
};
/// Slope differences across the patch on the QEMU board's simulated arm (the paper's
/// arm, uniform link 2, whatever [`ARM`] is) [1/(m·√kg)].
pub const QEMU_SLOPE_DIFF: [f32; 2] = [4.550401e0, -2.297636e1];
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

/// The rate law's `k_c` ceiling by filter corner on the hardware board (`[f_c [Hz], k_c,max [s]]`,
/// `flexarm_core::tuning::RateCeiling`; `firmware_params::rate_ceilings`).
pub const HARDWARE_RATE_CEILING: RateCeiling<f32> = RateCeiling {
    rows: [[1e0, 9.6197716e1], [1.8374357e0, 9.632204e1], [3.37617e0, 9.644699e1], [6.203495e0, 9.666741e1], [1.1398522e1, 9.704111e1], [2.0944052e1, 9.780699e1], [3.848335e1, 9.929084e1], [7.071068e1, 1.0212625e2], [1e2, 1.0796912e2], [1.2992632e2, 1.14142944e2], [2.3873126e2, 1.22409744e2], [4.3865332e2, 1.469597e2], [8.0599725e2, 1.6938556e2], [1.4809681e3, 2.4051703e2], [2.7211836e3, 4.8188934e2], [5e3, 1.2729407e3]],
};

/// Everything the hardware board boots with (`flexarm_machine::BoardConfig::for_board` on this
/// model): its hash is [`HARDWARE_HASH`].
pub const HARDWARE: BoardConfig = BoardConfig {
    board: Board::Hardware,
    arm: ARM,
    patch: PATCH,
    law: MotorLaw::Tracking,
    gains: Gains {
        lambda: Vector4::new(1e0, 1e0, 1e0, 1e0),
        kp: Vector4::new(9e1, 1.4e1, 0e0, 0e0),
        d_delta: Vector2::new(2e1, 2e1),
        epsilon: Vector2::new(1e-1, 1e-1),
        phi: Vector2::new(1e-2, 1e-2),
        epsilon_floor: 1e-4,
        mu: 1e-1,
        ki: Vector2::new(5e0, 5e0),
        integral_limit: Vector2::new(2e-2, 2e-2),
    },
    piezo: PiezoGains {
        k_c: K_C,
        cutoff_hz: 1e2,
    },
    piezo_law: PiezoLawKind::Off,
    rate_ceiling: &HARDWARE_RATE_CEILING,
    film_static: 0e0,
    film_feedthrough: 0e0,
    limits: Limits {
        tau_max: Vector2::new(1e1, 1e1),
        v_a_max: 1.75e2,
        v_a_min: -1.75e2,
    },
    motion: MotionLimits {
        following: Vector2::new(5e-2, 5e-2),
        speed: Vector2::new(4e0, 4e0),
        runaway_speed: 2e-1,
        runaway_torque: Vector2::new(1e0, 1e0),
        runaway_error: 1e-2,
        runaway_periods: 10,
        count: 3.834952e-4,
        stall_friction: Vector2::new(1e-1, 1e-1),
        stall_margin: 5e0,
        stall_accel: 2e-2,
        stall_speed_error: 1e-1,
        range_min: Vector2::new(-3.1415927e0, -2.8e0),
        range_max: Vector2::new(3.1415927e0, 2.8e0),
        stop_accel: Vector2::new(1e1, 1e1),
        range_margin: 2e-2,
        thermal: Thermal {
            continuous: Vector2::new(4e0, 4e0),
            time_constant: 2e1,
            derate: 6e-1,
            floor: 9e-1,
            trip: 9.5e-1,
        },
        brake_travel: 2e-2,
        brake_settle_periods: 200,
    },
    moves: MoveLimits {
        speed_max: Vector2::new(3e0, 3e0),
        accel_max: Vector2::new(1e1, 1e1),
        theta_max: Vector2::new(3e0, 2.7e0),
        theta_min: Vector2::new(-3e0, -2.7e0),
        torque_share: 7.5e-1,
    },
    observer_gain: GAIN_1KHZ,
    piezo_hz: 10000,
    motor_divider: 10,
    print_every: 100,
    record_every: 2,
    link_timeout_s: 1,
    amplifier_settle: 10,
    amplifier_debounce: 3,
    homing: HomingConfig {
        joints: [JointHoming { method: Method::Index, angle: 0e0, speed: 2e-1, torque: 1e0, travel: 6.5e0 }, JointHoming { method: Method::Index, angle: 0e0, speed: 2e-1, torque: 1e0, travel: 6.5e0 }],
        stall_travel: 2e-3,
        stall_time: 2e-1,
        stall_share: 9e-1,
        tolerance: 1e-2,
    },
};
/// `BoardConfig::hash` of [`HARDWARE`], the handshake's `params_hash`.
pub const HARDWARE_HASH: u32 = 0x10aac87e;

/// The rate law's `k_c` ceiling by filter corner on the QEMU board (`[f_c [Hz], k_c,max [s]]`,
/// `flexarm_core::tuning::RateCeiling`; `firmware_params::rate_ceilings`).
pub const QEMU_RATE_CEILING: RateCeiling<f32> = RateCeiling {
    rows: [[1e0, 3.371879e2], [1.5587755e0, 5.2072076e2], [2.429781e0, 6.8159454e2], [3.7874832e0, 9.49217e2], [5.9038363e0, 1.3841571e3], [9.202755e0, 2.0789792e3], [1.4345029e1, 3.175017e3], [2.236068e1, 4.8877437e3], [3.4855278e1, 7.5710444e3], [5.433156e1, 1.1751833e4], [8.46907e1, 1.8266795e4], [1e2, 2.7944254e4], [1.320138e2, 3.3203016e4], [2.0577986e2, 4.4258758e4], [3.207646e2, 6.898947e4], [5e2, 1.0746282e5]],
};

/// Everything the QEMU board boots with (`flexarm_machine::BoardConfig::for_board` on this
/// model): its hash is [`QEMU_HASH`].
pub const QEMU: BoardConfig = BoardConfig {
    board: Board::Qemu,
    arm: ARM,
    patch: PATCH,
    law: MotorLaw::Tracking,
    gains: Gains {
        lambda: Vector4::new(1e0, 1e0, 1e0, 1e0),
        kp: Vector4::new(4.0816326e1, 6.349206e0, 0e0, 0e0),
        d_delta: Vector2::new(2e1, 2e1),
        epsilon: Vector2::new(1e-1, 1e-1),
        phi: Vector2::new(1e-2, 1e-2),
        epsilon_floor: 1e-4,
        mu: 1e-1,
        ki: Vector2::new(5e0, 5e0),
        integral_limit: Vector2::new(2e-2, 2e-2),
    },
    piezo: PiezoGains {
        k_c: K_C,
        cutoff_hz: 1e2,
    },
    piezo_law: PiezoLawKind::Rate,
    rate_ceiling: &QEMU_RATE_CEILING,
    film_static: 4.780624e-4,
    film_feedthrough: 0e0,
    limits: Limits {
        tau_max: Vector2::new(1e1, 1e1),
        v_a_max: 2e2,
        v_a_min: -2e2,
    },
    motion: MotionLimits {
        following: Vector2::new(5e-2, 5e-2),
        speed: Vector2::new(4e0, 4e0),
        runaway_speed: 2e-1,
        runaway_torque: Vector2::new(1e0, 1e0),
        runaway_error: 2.205e-2,
        runaway_periods: 2,
        count: 3.834952e-4,
        stall_friction: Vector2::new(1e-1, 1e-1),
        stall_margin: 5e0,
        stall_accel: 2e-2,
        stall_speed_error: 1e-1,
        range_min: Vector2::new(-3.1415927e0, -2.8e0),
        range_max: Vector2::new(3.1415927e0, 2.8e0),
        stop_accel: Vector2::new(1e1, 1e1),
        range_margin: 2e-2,
        thermal: Thermal {
            continuous: Vector2::new(4e0, 4e0),
            time_constant: 2e1,
            derate: 6e-1,
            floor: 9e-1,
            trip: 9.5e-1,
        },
        brake_travel: 2e-2,
        brake_settle_periods: 20,
    },
    moves: MoveLimits {
        speed_max: Vector2::new(3e0, 3e0),
        accel_max: Vector2::new(1e1, 1e1),
        theta_max: Vector2::new(3e0, 2.7e0),
        theta_min: Vector2::new(-3e0, -2.7e0),
        torque_share: 7.5e-1,
    },
    observer_gain: GAIN_100HZ,
    piezo_hz: 1000,
    motor_divider: 10,
    print_every: 10,
    record_every: 1,
    link_timeout_s: 5,
    amplifier_settle: 1,
    amplifier_debounce: 3,
    homing: HomingConfig {
        joints: [JointHoming { method: Method::Index, angle: 0e0, speed: 2e-1, torque: 1e0, travel: 6.5e0 }, JointHoming { method: Method::Index, angle: 0e0, speed: 2e-1, torque: 1e0, travel: 6.5e0 }],
        stall_travel: 2e-3,
        stall_time: 2e-1,
        stall_share: 9e-1,
        tolerance: 1e-2,
    },
};
/// `BoardConfig::hash` of [`QEMU`], the handshake's `params_hash`.
pub const QEMU_HASH: u32 = 0x8ae7982b;

//! Loop rates and run settings per board.
//!
//! QEMU clocks TIM2–TIM5 at 1 GHz whatever RCC says, and its timers lose accuracy above about
//! 1 kHz, so the QEMU board runs the loops ten times slower than the hardware (piezo 1 kHz,
//! motor 100 Hz) with the plant stepped at the piezo period and the observer gain designed for
//! 100 Hz. The hardware runs at 168 MHz with the APB1 timers at 84 MHz.
//!
//! The arm model, the piezo patch, its gain `k_c` and the observer gains come from
//! `firmware/piezo.toml` (or an identified model) through `generated.rs` (`cargo sim
//! firmware-params`, docs/firmware.md).

use flexarm_core::Vector2;
use flexarm_core::control::piezo::{PiezoGains, PiezoPatch};
use flexarm_core::params::{ArmParams, Limits};
use flexarm_core::time::Ticks;

use crate::generated;

/// Timer input clock [Hz].
#[cfg(feature = "qemu")]
pub const TIMER_CLOCK_HZ: u32 = 1_000_000_000;
/// Timer input clock [Hz].
#[cfg(not(feature = "qemu"))]
pub const TIMER_CLOCK_HZ: u32 = 84_000_000;

/// Piezo loop rate [Hz].
#[cfg(feature = "qemu")]
pub const PIEZO_HZ: u32 = 1_000;
/// Piezo loop rate [Hz].
#[cfg(not(feature = "qemu"))]
pub const PIEZO_HZ: u32 = 10_000;

/// Piezo periods per motor period (motor loop 100 Hz under QEMU, 1 kHz on hardware).
pub const MOTOR_DIVIDER: u32 = 10;
/// Motor loop rate [Hz].
pub const MOTOR_HZ: u32 = PIEZO_HZ / MOTOR_DIVIDER;
/// Supervisor rate [Hz].
pub const SUPERVISOR_HZ: u32 = 10;

/// Observer gain table for the motor rate, designed for the patch of `firmware/piezo.toml`.
#[cfg(feature = "qemu")]
pub const OBSERVER_GAIN: &[[f32; 3]; 8] = &generated::GAIN_100HZ;
/// Observer gain table for the motor rate, designed for the patch of `firmware/piezo.toml`.
#[cfg(not(feature = "qemu"))]
pub const OBSERVER_GAIN: &[[f32; 3]; 8] = &generated::GAIN_1KHZ;

/// The controller's model of the arm (`firmware/piezo.toml` or an identified `model.toml`,
/// through `generated.rs`).
pub const ARM: ArmParams<f32> = generated::ARM;

/// The piezo patch on link 2 (`firmware/piezo.toml`, through `generated.rs`): the controller's,
/// on the modes of [`ARM`]. The QEMU board's simulated arm carries the same patch on the paper's
/// arm ([`generated::QEMU_SLOPE_DIFF`]).
pub fn patch() -> PiezoPatch<f32> {
    PiezoPatch {
        x_a: generated::X_A,
        l_a: generated::L_A,
        slope_diff: Vector2::new(generated::SLOPE_DIFF[0], generated::SLOPE_DIFF[1]),
        k_a: generated::K_A,
        k_s: generated::K_S,
    }
}

/// The patch on the QEMU board's simulated arm, which plays the physical arm: the paper's,
/// whatever model the controller runs, so its slope differences are the paper's link's at the
/// patch ([`generated::QEMU_SLOPE_DIFF`]).
#[cfg(feature = "qemu")]
pub fn qemu_patch() -> PiezoPatch<f32> {
    let [d1, d2] = generated::QEMU_SLOPE_DIFF;
    PiezoPatch {
        slope_diff: Vector2::new(d1, d2),
        ..patch()
    }
}

/// The controller's limits: the core's torque limits, and the piezo window the board's output
/// stage can deliver (±175 V on the hardware board, whose DAC buffer does not reach its rails;
/// the QEMU board's ideal output keeps the core's ±200 V). A patch rated for less reverse
/// voltage (a piezoceramic depolarizes) takes its own `v_a_min` here, or over the link
/// (`Set(VaMin, v)`, within the stage's −175 V).
pub fn limits() -> Limits<f32> {
    #[cfg(feature = "hw")]
    let v_a_max = crate::board::hw::PIEZO_V_MAX;
    #[cfg(not(feature = "hw"))]
    let v_a_max = Limits::<f32>::default().v_a_max;
    Limits {
        v_a_max,
        v_a_min: -v_a_max,
        ..Limits::default()
    }
}

/// The motion checks' thresholds and the motors' I²t model (`docs/safety.md`): the core's
/// defaults for the paper's arm at this board's motor rate. A real arm's motors take their
/// datasheet's continuous torque and winding time constant here (`thermal`), and its joints'
/// ranges (`range_min`, `range_max`).
pub fn motion() -> flexarm_core::motion::MotionLimits<f32> {
    flexarm_core::motion::MotionLimits::default_for(MOTOR_HZ)
}

/// The motor law's gains: the core's (the paper's), with the joints' `K_p` slowed for a slow
/// motor loop (`Gains::default_for`: the QEMU board's 100 Hz).
#[inline(always)]
pub fn motor_gains() -> flexarm_core::params::Gains<f32> {
    flexarm_core::params::Gains::default_for(MOTOR_HZ)
}

/// The piezo loop's gains: `k_c` [s] from `firmware/piezo.toml`, the core's filter corner.
pub fn piezo_gains() -> PiezoGains<f32> {
    PiezoGains {
        k_c: generated::K_C,
        ..PiezoGains::default()
    }
}

/// The motor loop's tick count at boot: 0, except in the uptime test builds.
pub const START_TICK: Ticks = Ticks(if cfg!(feature = "start-before-wrap") {
    u64::MAX - 299
} else if cfg!(feature = "start-at-30-days") {
    30 * 86_400 * MOTOR_HZ as u64
} else {
    0
});

/// The paper's trapezoid from power-on (the QEMU verdict runs). A board boots disarmed and
/// waits for a host (`docs/link.md`), as does the QEMU `link-session` build.
pub const BOOT_MOVE: bool = cfg!(feature = "qemu") && !cfg!(feature = "link-session");

/// The link watchdog [s]: a move stops when the host has been silent this long (after it first
/// spoke). QEMU runs a virtual second in a few tens of milliseconds of the host's, so its session
/// build allows more virtual time for the same host.
#[cfg(feature = "qemu")]
pub const LINK_TIMEOUT_S: u32 = 5;
/// The link watchdog [s] (see the QEMU board's).
#[cfg(not(feature = "qemu"))]
pub const LINK_TIMEOUT_S: u32 = 1;

/// Motor periods the amplifier fault line is ignored after each enable (10 ms).
pub const AMPLIFIER_SETTLE: u32 = MOTOR_HZ / 100;
/// Consecutive motor periods the fault line must stay asserted (3 ms on hardware).
pub const AMPLIFIER_DEBOUNCE: u32 = 3;

/// Samples the fault recorder holds: 500 of 48 bytes (24 KB of RAM).
pub const RECORDER_LEN: usize = 500;
/// Motor periods per recorded sample: every second period on the hardware board (500 Hz, so
/// the recorder holds the last second); every period under QEMU (100 Hz: the last 5 s).
#[cfg(not(feature = "qemu"))]
pub const RECORD_EVERY: u64 = 2;
/// Motor periods per recorded sample (see the hardware board's).
#[cfg(feature = "qemu")]
pub const RECORD_EVERY: u64 = 1;

/// Motor steps between two telemetry samples.
pub const TELEMETRY_EVERY: u32 = MOTOR_HZ / 10;

/// Length of the QEMU run [s]: the paper's 5 s trapezoid plus 1 s.
#[cfg(feature = "qemu")]
pub const RUN_SECONDS: f32 = 6.0;

/// Bounds the QEMU run checks. The host runs the same code at the same rates
/// (`cargo test -p flexarm-tests --test firmware_loop -- --nocapture`: max error 4.5e-3 rad,
/// last-3-s mean 2.8e-4 rad, max tip 7.9e-3 m, final tip 1.9e-6 m); the bounds leave a
/// factor of about 3 or more over those figures (the final tip, a residual oscillation whose
/// value depends on the phase at the last sample, gets more).
#[cfg(feature = "qemu")]
pub mod bounds {
    /// Largest joint tracking error over the run [rad].
    pub const MAX_ERROR: f32 = 0.015;
    /// Mean joint tracking error over the last 3 s [rad].
    pub const TAIL_ERROR: f32 = 1e-3;
    /// Largest tip deflection over the run [m].
    pub const MAX_TIP: f32 = 0.03;
    /// Tip deflection at the end of the run [m].
    pub const FINAL_TIP: f32 = 5e-4;
}

//! The board's configuration and run settings.
//!
//! Every number the board boots with is one `flexarm_machine::BoardConfig` ([`CONFIG`]): the
//! arm model, the piezo patch, its gain `k_c` and the observer gains from `firmware/piezo.toml`
//! (or an identified model) through `generated.rs` (`cargo sim firmware-params`,
//! docs/firmware.md), and the board's rates, limits and decimations
//! (`BoardConfig::for_board`: QEMU clocks TIM2–TIM5 at 1 GHz whatever RCC says and its timers
//! lose accuracy above about 1 kHz, so the QEMU board runs the loops ten times slower, piezo
//! 1 kHz and motor 100 Hz, with the plant stepped at the piezo period; the hardware runs at
//! 168 MHz with the APB1 timers at 84 MHz). What stays here: the timers' clock, the build's
//! features (the boot move, the uptime runs' start tick), the fault recorder's size and the
//! QEMU verdict's bounds.

#[cfg(feature = "qemu")]
use flexarm_core::Vector2;
#[cfg(feature = "qemu")]
use flexarm_core::control::piezo::PiezoPatch;
use flexarm_core::time::Ticks;
use flexarm_machine::BoardConfig;

use crate::generated;

/// Timer input clock [Hz].
#[cfg(feature = "qemu")]
pub const TIMER_CLOCK_HZ: u32 = 1_000_000_000;
/// Timer input clock [Hz].
#[cfg(not(feature = "qemu"))]
pub const TIMER_CLOCK_HZ: u32 = 84_000_000;

/// Everything this board boots with (`flexarm_machine::BoardConfig`): the generated model
/// (`firmware/piezo.toml` or an identified `model.toml`) in this board's configuration,
/// generated whole with its hash by `cargo sim firmware-params`, so the firmware computes
/// neither.
#[cfg(all(feature = "qemu", not(feature = "piezo-ppf")))]
pub const CONFIG: BoardConfig = generated::QEMU;
/// [`CONFIG`]'s hash (`BoardConfig::hash`): the handshake's and the boot log's.
#[cfg(all(feature = "qemu", not(feature = "piezo-ppf")))]
pub const CONFIG_HASH: u32 = generated::QEMU_HASH;
/// The QEMU board's configuration with positive position feedback as its boot law (the
/// `piezo-ppf` build, issue 35), designed from the model's film static gain.
#[cfg(feature = "piezo-ppf")]
pub const CONFIG: BoardConfig = BoardConfig {
    piezo_law: flexarm_core::control::select::PiezoLawKind::Ppf,
    ..generated::QEMU
};
/// [`CONFIG`]'s hash: the generated one names the paper's law, so this build has none of its
/// own (0: no host configuration matches it).
#[cfg(feature = "piezo-ppf")]
pub const CONFIG_HASH: u32 = 0;
/// Everything this board boots with (see the QEMU board's).
#[cfg(not(feature = "qemu"))]
pub const CONFIG: BoardConfig = generated::HARDWARE;
/// [`CONFIG`]'s hash (`BoardConfig::hash`).
#[cfg(not(feature = "qemu"))]
pub const CONFIG_HASH: u32 = generated::HARDWARE_HASH;

/// Piezo loop rate [Hz].
pub const PIEZO_HZ: u32 = CONFIG.piezo_hz;
/// Motor loop rate [Hz] (100 Hz under QEMU, 1 kHz on hardware).
pub const MOTOR_HZ: u32 = CONFIG.motor_hz();
/// Supervisor rate [Hz].
pub const SUPERVISOR_HZ: u32 = 10;

/// The patch on the QEMU board's simulated arm, which plays the physical arm: the paper's,
/// whatever model the controller runs, so its slope differences are the paper's link's at the
/// patch ([`generated::QEMU_SLOPE_DIFF`]).
#[cfg(feature = "qemu")]
pub fn qemu_patch() -> PiezoPatch<f32> {
    let [d1, d2] = generated::QEMU_SLOPE_DIFF;
    PiezoPatch {
        slope_diff: Vector2::new(d1, d2),
        ..CONFIG.patch
    }
}

/// The motor loop's tick count at boot: 0, except in the uptime test builds.
pub const START_TICK: Ticks = Ticks(if cfg!(feature = "start-before-wrap") {
    // The wrap 1 s into the 2 s boot move, at its peak speed (issue 33: after the move's end a
    // time base that jumps at the wrap would not show).
    u64::MAX - 99
} else if cfg!(feature = "start-at-30-days") {
    30 * 86_400 * MOTOR_HZ as u64
} else {
    0
});

/// The paper's trapezoid from power-on (the QEMU verdict runs). A board boots disarmed and
/// waits for a host (`docs/link.md`), as does the QEMU `link-session` build.
pub const BOOT_MOVE: bool = cfg!(feature = "qemu") && !cfg!(feature = "link-session");

/// Length of the QEMU run [s]: the paper's 5 s trapezoid plus 1 s.
#[cfg(feature = "qemu")]
pub const RUN_SECONDS: f32 = 6.0;

/// Bounds the QEMU run checks. The host runs the same code at the same rates
/// (`cargo test -p flexarm-tests --test firmware_loop -- --nocapture`: max error 4.8e-3 rad,
/// last-3-s mean 3.1e-4 rad, max tip 7.9e-3 m, final tip 4.6e-5 m); the bounds leave a
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

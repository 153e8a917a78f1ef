//! A free-running clock for execution-time measurement.
//!
//! - QEMU: TIM5, 32 bits, prescaler 1, clocked at 1 GHz; with `-icount shift=0` one count is
//!   one executed instruction, so the counts are exact and repeatable (DWT CYCCNT reads 0 there).
//! - Hardware: the DWT cycle counter (core cycles at 168 MHz).

/// Counts per second: one per executed instruction under QEMU (1 ns each), the core clock on
/// the board.
pub const HZ: u32 = if cfg!(feature = "qemu") {
    1_000_000_000
} else {
    168_000_000
};

/// Current count; differences are taken with `wrapping_sub`.
#[cfg(feature = "qemu")]
pub fn now() -> u32 {
    // SAFETY: a read of TIM5's counter register, which has no side effects; TIM5 is configured
    // once in `init` and never written again.
    unsafe { (*stm32f4::stm32f405::TIM5::ptr()).cnt().read().bits() }
}

/// Current count; differences are taken with `wrapping_sub`.
#[cfg(not(feature = "qemu"))]
pub fn now() -> u32 {
    cortex_m::peripheral::DWT::cycle_count()
}

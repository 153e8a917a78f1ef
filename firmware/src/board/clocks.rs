//! Clock start-up of the STM32F405 (RM0090 §6): the crystal, the PLL, the bus dividers, the
//! clock security system, and what the chip reports about its last reset and its brown-out
//! setting. Every wait is bounded, so a crystal that never starts cannot hang the start-up with
//! the outputs undefined.
//!
//! The hardware board calls it first thing in `init`. The QEMU board normally does not (QEMU
//! models no RCC: its registers read 0); the `inject-no-crystal` build calls it there to run
//! the fallback path on a crystal that never becomes ready.

use stm32f4::stm32f405::{FLASH, RCC};

/// Read-modify-write of the bits under `mask`.
macro_rules! set_bits {
    ($reg:expr, $mask:expr, $value:expr) => {
        // SAFETY: the value is a documented field setting of this register (RM0090).
        $reg.modify(|r, w| unsafe { w.bits((r.bits() & !($mask)) | ($value)) })
    };
}

/// The crystal (HSE) on this board [Hz]. The PLL is derived from it and checked at compile time.
pub const HSE_HZ: u32 = 8_000_000;
/// `true` for an oscillator module driving OSC_IN (HSE bypass) instead of a crystal.
pub const HSE_BYPASS: bool = false;
/// PLL input after the /M divider [Hz]: 2 MHz, the value RM0090 recommends against jitter.
const PLL_IN_HZ: u32 = 2_000_000;
/// PLL /M, ×N, /P, /Q: VCO 336 MHz, SYSCLK 168 MHz, 48 MHz for USB.
const PLL_M: u32 = HSE_HZ / PLL_IN_HZ;
const PLL_N: u32 = 336_000_000 / PLL_IN_HZ;
const PLL_P: u32 = 2;
const PLL_Q: u32 = 7;
const _: () = {
    assert!(
        HSE_HZ.is_multiple_of(PLL_IN_HZ),
        "HSE_HZ must be a multiple of 2 MHz"
    );
    assert!(
        PLL_M >= 2 && PLL_M <= 63,
        "PLL /M out of range (RM0090 6.3.2)"
    );
    assert!(PLL_N >= 50 && PLL_N <= 432, "PLL ×N out of range");
    assert!(
        HSE_HZ >= 4_000_000 && HSE_HZ <= 26_000_000,
        "HSE must be 4–26 MHz"
    );
    assert!(PLL_IN_HZ * PLL_N / PLL_P == 168_000_000);
    assert!(PLL_IN_HZ * PLL_N / PLL_Q == 48_000_000);
};
/// Polls of a ready flag before giving up: 5 to 10 cycles each at the 16 MHz internal
/// oscillator, so 30 to 60 ms, many times the crystal's and the PLL's start-up time (datasheet:
/// 2 ms typical).
const READY_POLLS: u32 = 100_000;

/// Why the clocks could not be brought up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClockError {
    /// The crystal (or oscillator module) never became ready.
    Hse,
    /// The PLL never locked.
    Pll,
}

/// How the chip came up.
pub struct Startup {
    /// The last reset came from the independent watchdog (the flag is then cleared).
    pub reset_by_watchdog: bool,
    /// `Err` if the chip stays on its 16 MHz internal oscillator: the loop rates are then
    /// wrong, and the amplifiers must never be enabled.
    pub clocks: Result<(), ClockError>,
    /// The brown-out reset level in the option bytes is not off (`BOR_LEV ≠ 0b11`).
    pub brown_out_reset_on: bool,
}

/// Sets the system clock to 168 MHz from the crystal (`HSE_HZ`; PLL /M ×N /P /Q derived above;
/// AHB 168 MHz, APB1 42 MHz with its timers at 84 MHz, APB2 84 MHz; 5 flash wait states), with
/// the clock security system on, and reads the reset cause and the brown-out setting. Every wait
/// is bounded: a crystal or PLL that does not start leaves the chip on the internal oscillator
/// and reports it.
pub fn start(rcc: &RCC, flash: &FLASH) -> Startup {
    let reset_by_watchdog = rcc.csr().read().wdgrstf().bit_is_set();
    rcc.csr().modify(|_, w| w.rmvf().set_bit());
    // FLASH_OPTCR BOR_LEV (bits 2–3): 0b11 is "off".
    let brown_out_reset_on = (flash.optcr().read().bits() >> 2) & 0b11 != 0b11;
    let ready = |done: &dyn Fn() -> bool| (0..READY_POLLS).any(|_| done());
    rcc.cr()
        .modify(|_, w| w.hsebyp().bit(HSE_BYPASS).hseon().set_bit());
    if !ready(&|| rcc.cr().read().hserdy().bit_is_set()) {
        rcc.cr().modify(|_, w| w.hseon().clear_bit());
        return Startup {
            reset_by_watchdog,
            clocks: Err(ClockError::Hse),
            brown_out_reset_on,
        };
    }
    // PLLCFGR: PLLM (bits 0–5), PLLN (6–14), PLLP = /2 (16–17 = 0), PLLSRC = HSE (22),
    // PLLQ (24–27).
    set_bits!(
        rcc.pllcfgr(),
        0x0F43_7FFF,
        PLL_M | (PLL_N << 6) | ((PLL_P / 2 - 1) << 16) | (1 << 22) | (PLL_Q << 24)
    );
    rcc.cr().modify(|_, w| w.pllon().set_bit());
    if !ready(&|| rcc.cr().read().pllrdy().bit_is_set()) {
        return Startup {
            reset_by_watchdog,
            clocks: Err(ClockError::Pll),
            brown_out_reset_on,
        };
    }
    // FLASH ACR: LATENCY = 5 WS, prefetch, instruction and data caches on.
    set_bits!(
        flash.acr(),
        0x0000_070F,
        5 | (1 << 8) | (1 << 9) | (1 << 10)
    );
    // CFGR: HPRE = /1 (bits 4–7 = 0), PPRE1 = /4 (10–12 = 0b101), PPRE2 = /2 (13–15 = 0b100).
    set_bits!(rcc.cfgr(), 0x0000_FCF0, (0b101 << 10) | (0b100 << 13));
    // SW = PLL (bits 0–1 = 0b10), wait for SWS = PLL (bits 2–3).
    set_bits!(rcc.cfgr(), 0x3, 0b10);
    if !ready(&|| (rcc.cfgr().read().bits() >> 2) & 0x3 == 0b10) {
        return Startup {
            reset_by_watchdog,
            clocks: Err(ClockError::Pll),
            brown_out_reset_on,
        };
    }
    // The clock security system: if the crystal stops, the chip falls back to the internal
    // oscillator and raises the NMI (`crate::emergency`).
    rcc.cr().modify(|_, w| w.csson().set_bit());
    Startup {
        reset_by_watchdog,
        clocks: Ok(()),
        brown_out_reset_on,
    }
}

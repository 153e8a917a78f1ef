//! Clock start-up of the STM32F405 (RM0090, RCC): the crystal, the PLL, the bus dividers, the
//! clock security system, and what the chip reports about its last reset and its brown-out
//! setting. Every wait is bounded, so a crystal that never starts cannot hang the start-up with
//! the outputs undefined.
//!
//! A crystal that does not start is a hardware fault, but the chip need not run slow for it:
//! the PLL is then fed from the internal oscillator (HSI, 16 MHz, factory-trimmed to 1 % at
//! 25 °C), so the core still runs at 168 MHz and every rate derived from it (the loops, the
//! supervisor against the watchdog, the link's baud rate) is nominal within the HSI's
//! tolerance; the start-up reports it, `init` latches `Fault::Clock`, and the amplifiers are
//! never enabled, while the link answers (`docs/firmware.md`, "After a crystal failure"). Only
//! if the PLL does not lock on either oscillator does the chip stay at 16 MHz.
//!
//! The start-up runs on [`Regs`]: the chip's registers on the hardware board ([`Chip`]); under
//! QEMU, which models no RCC, the `inject-no-crystal` build runs it on a model of an RCC whose
//! crystal never starts (`crate::board::sim::DeadCrystal`).

use super::pll::{self, HSI_HZ, Pll};

/// The crystal (HSE) on this board [Hz]: any whole number of MHz from 4 to 26 builds (the PLL's
/// dividers are computed at compile time; another value stops the build with the constraint).
pub const HSE_HZ: u32 = 8_000_000;
/// `true` for an oscillator module driving OSC_IN (HSE bypass) instead of a crystal.
pub const HSE_BYPASS: bool = false;
/// The PLL's dividers from the crystal and from the internal oscillator.
const HSE_PLL: Pll = pll::expect(pll::pll_for_hse(HSE_HZ));
const HSI_PLL: Pll = pll::expect(pll::pll_for(HSI_HZ));
/// Polls of a ready flag before giving up: 5 to 10 cycles each at the 16 MHz internal
/// oscillator, so 30 to 60 ms, many times the crystal's and the PLL's start-up time (datasheet:
/// 2 ms typical).
const READY_POLLS: u32 = 100_000;

/// The registers of the start-up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reg {
    /// RCC_CR: oscillators and PLL on, their ready flags.
    RccCr,
    /// RCC_PLLCFGR: the PLL's source and dividers.
    RccPllcfgr,
    /// RCC_CFGR: system clock switch and bus prescalers.
    RccCfgr,
    /// RCC_CSR: reset flags.
    RccCsr,
    /// FLASH_ACR: wait states and caches.
    FlashAcr,
    /// FLASH_OPTCR: the option bytes (brown-out level).
    FlashOptcr,
}

/// Word access to the start-up's registers.
pub trait Regs {
    /// The register's value.
    fn read(&self, reg: Reg) -> u32;
    /// Writes the register.
    fn write(&mut self, reg: Reg, value: u32);
    /// Read-modify-write: the bits under `clear` cleared, `set` set.
    fn modify(&mut self, reg: Reg, clear: u32, set: u32) {
        let v = self.read(reg);
        self.write(reg, (v & !clear) | set);
    }
}

/// The chip's RCC and flash interface.
#[cfg(feature = "hw")]
pub struct Chip<'a> {
    /// The RCC.
    pub rcc: &'a stm32f4::stm32f405::RCC,
    /// The flash interface.
    pub flash: &'a stm32f4::stm32f405::FLASH,
}

#[cfg(feature = "hw")]
impl Regs for Chip<'_> {
    fn read(&self, reg: Reg) -> u32 {
        match reg {
            Reg::RccCr => self.rcc.cr().read().bits(),
            Reg::RccPllcfgr => self.rcc.pllcfgr().read().bits(),
            Reg::RccCfgr => self.rcc.cfgr().read().bits(),
            Reg::RccCsr => self.rcc.csr().read().bits(),
            Reg::FlashAcr => self.flash.acr().read().bits(),
            Reg::FlashOptcr => self.flash.optcr().read().bits(),
        }
    }
    fn write(&mut self, reg: Reg, value: u32) {
        // SAFETY: `start` writes only documented field settings of these registers (RM0090).
        unsafe {
            match reg {
                Reg::RccCr => self.rcc.cr().write(|w| w.bits(value)),
                Reg::RccPllcfgr => self.rcc.pllcfgr().write(|w| w.bits(value)),
                Reg::RccCfgr => self.rcc.cfgr().write(|w| w.bits(value)),
                Reg::RccCsr => self.rcc.csr().write(|w| w.bits(value)),
                Reg::FlashAcr => self.flash.acr().write(|w| w.bits(value)),
                Reg::FlashOptcr => self.flash.optcr().write(|w| w.bits(value)),
            };
        }
    }
}

/// RCC_CR bits.
const HSEON: u32 = 1 << 16;
const HSERDY: u32 = 1 << 17;
const HSEBYP: u32 = 1 << 18;
const CSSON: u32 = 1 << 19;
const PLLON: u32 = 1 << 24;
const PLLRDY: u32 = 1 << 25;
/// RCC_PLLCFGR: PLLSRC (bit 22, 1 = HSE) and the divider fields.
const PLLSRC_HSE: u32 = 1 << 22;
const PLLCFGR_FIELDS: u32 = 0x0F43_7FFF;
/// RCC_CSR: WDGRSTF (bit 29), RMVF (bit 24).
const WDGRSTF: u32 = 1 << 29;
const RMVF: u32 = 1 << 24;

/// Which oscillator the chip runs from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// 168 MHz through the PLL from the crystal: the normal case.
    Crystal,
    /// 168 MHz through the PLL from the internal oscillator: the crystal (or the PLL on it) did
    /// not start.
    Internal,
    /// 16 MHz from the internal oscillator, no PLL: the PLL locked on neither oscillator. The
    /// loops run at 16/84 of their rates (the timers' dividers assume 84 MHz), the link at
    /// 16/84 of its baud rate.
    InternalNoPll,
}

impl Source {
    /// The APB1 timers' clock [Hz] (the loops' and the supervisor's timers).
    #[cfg_attr(not(feature = "hw"), allow(dead_code))]
    pub const fn timer_clock_hz(self) -> u32 {
        // APB1 at SYSCLK / 4, its timers at twice that; on HSI without the PLL the prescalers
        // stay at their reset value /1.
        match self {
            Self::Crystal | Self::Internal => pll::SYSCLK_HZ / 2,
            Self::InternalNoPll => HSI_HZ,
        }
    }
    /// What the log and the docs call it.
    pub const fn as_str(self) -> &'static str {
        match self {
            Self::Crystal => "168 MHz from the crystal",
            Self::Internal => "168 MHz from the internal oscillator: the crystal did not start",
            Self::InternalNoPll => {
                "16 MHz from the internal oscillator: neither the crystal nor the PLL started"
            }
        }
    }
}

/// How the chip came up.
pub struct Startup {
    /// The last reset came from the independent watchdog (the flag is then cleared).
    pub reset_by_watchdog: bool,
    /// What the chip runs from; anything but [`Source::Crystal`] is a clock fault, and the
    /// amplifiers must never be enabled.
    pub source: Source,
    /// The brown-out reset level in the option bytes is not off (`BOR_LEV ≠ 0b11`).
    pub brown_out_reset_on: bool,
}

/// Whether `reg & mask` reads `value` within [`READY_POLLS`] polls.
fn ready(regs: &impl Regs, reg: Reg, mask: u32, value: u32) -> bool {
    (0..READY_POLLS).any(|_| regs.read(reg) & mask == value)
}

/// Runs the PLL from the selected oscillator with `cfg`'s dividers, then switches the system
/// clock to it (5 flash wait states, AHB 168 MHz, APB1 42 MHz with its timers at 84 MHz, APB2
/// 84 MHz). `false` if it does not lock or the switch does not take; the chip is then still on
/// the oscillator it ran from.
#[inline(never)]
fn run_pll(regs: &mut impl Regs, from_hse: bool, cfg: Pll) -> bool {
    // PLLCFGR is written only while the PLL is off (RM0090, RCC_PLLCFGR).
    regs.modify(Reg::RccCr, PLLON, 0);
    if !ready(regs, Reg::RccCr, PLLRDY, 0) {
        return false;
    }
    let src = if from_hse { PLLSRC_HSE } else { 0 };
    regs.modify(Reg::RccPllcfgr, PLLCFGR_FIELDS, cfg.pllcfgr() | src);
    regs.modify(Reg::RccCr, 0, PLLON);
    if !ready(regs, Reg::RccCr, PLLRDY, PLLRDY) {
        return false;
    }
    // FLASH ACR: LATENCY = 5 WS, prefetch, instruction and data caches on; before the clock
    // rises.
    regs.modify(
        Reg::FlashAcr,
        0x0000_070F,
        5 | (1 << 8) | (1 << 9) | (1 << 10),
    );
    // CFGR: HPRE = /1 (bits 4–7 = 0), PPRE1 = /4 (10–12 = 0b101), PPRE2 = /2 (13–15 = 0b100).
    regs.modify(Reg::RccCfgr, 0x0000_FCF0, (0b101 << 10) | (0b100 << 13));
    // SW = PLL (bits 0–1 = 0b10), wait for SWS = PLL (bits 2–3).
    regs.modify(Reg::RccCfgr, 0x3, 0b10);
    ready(regs, Reg::RccCfgr, 0b11 << 2, 0b10 << 2)
}

/// Sets the system clock to 168 MHz from the crystal (`HSE_HZ`), or from the internal
/// oscillator if the crystal does not start, with the clock security system on while the
/// crystal runs; reads the reset cause and the brown-out setting. Every wait is bounded.
pub fn start(regs: &mut impl Regs) -> Startup {
    let reset_by_watchdog = regs.read(Reg::RccCsr) & WDGRSTF != 0;
    regs.modify(Reg::RccCsr, 0, RMVF);
    // FLASH_OPTCR BOR_LEV (bits 2–3): 0b11 is "off".
    let brown_out_reset_on = (regs.read(Reg::FlashOptcr) >> 2) & 0b11 != 0b11;
    // HSEBYP may change only while the HSE is off (RM0090, RCC_CR): turn it off, select the
    // bypass in its own write, then turn the HSE on.
    regs.modify(Reg::RccCr, HSEON, 0);
    if HSE_BYPASS {
        regs.modify(Reg::RccCr, 0, HSEBYP);
    } else {
        regs.modify(Reg::RccCr, HSEBYP, 0);
    }
    regs.modify(Reg::RccCr, 0, HSEON);
    let source = if ready(regs, Reg::RccCr, HSERDY, HSERDY) && run_pll(regs, true, HSE_PLL) {
        // The clock security system: if the crystal stops, the chip falls back to the internal
        // oscillator and raises the NMI (`crate::emergency`).
        regs.modify(Reg::RccCr, 0, CSSON);
        Source::Crystal
    } else {
        // Back on the internal oscillator (SW = HSI), the crystal off, then the PLL from the
        // internal oscillator.
        regs.modify(Reg::RccCfgr, 0x3, 0);
        let on_hsi = ready(regs, Reg::RccCfgr, 0b11 << 2, 0);
        regs.modify(Reg::RccCr, HSEON, 0);
        if on_hsi && run_pll(regs, false, HSI_PLL) {
            Source::Internal
        } else {
            // The bus prescalers back to /1: the timers at 16 MHz, as `Source` says.
            regs.modify(Reg::RccCfgr, 0xFFF3, 0);
            Source::InternalNoPll
        }
    };
    Startup {
        reset_by_watchdog,
        source,
        brown_out_reset_on,
    }
}

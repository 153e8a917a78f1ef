//! The STM32F405's main PLL (RM0090, RCC_PLLCFGR): the dividers that give the core
//! 168 MHz and the USB/SDIO clock 48 MHz from an oscillator, computed at compile time.
//!
//! `f_VCO_in = f_in / M`, `f_VCO = f_VCO_in · N`, `SYSCLK = f_VCO / P`, `f_48 = f_VCO / Q`, with
//! `2 ≤ M ≤ 63`, `1 MHz ≤ f_VCO_in ≤ 2 MHz` (2 MHz recommended against jitter),
//! `50 ≤ N ≤ 432`, `100 MHz ≤ f_VCO ≤ 432 MHz`, `P ∈ {2, 4, 6, 8}`, `2 ≤ Q ≤ 15`. Frequencies in
//! Hz. Plain integer `const fn`s, no registers: the host's tests run them too
//! (`cargo test -p flexarm-tests --test pll`).

/// The core clock every board runs at [Hz].
pub const SYSCLK_HZ: u32 = 168_000_000;
/// The USB/SDIO clock [Hz], which must be exact.
pub const CLK48_HZ: u32 = 48_000_000;
/// The internal RC oscillator (HSI) [Hz].
pub const HSI_HZ: u32 = 16_000_000;

/// The PLL's dividers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pll {
    /// Input divider `M`.
    pub m: u32,
    /// VCO multiplier `N`.
    pub n: u32,
    /// System clock divider `P`.
    pub p: u32,
    /// 48 MHz divider `Q`.
    pub q: u32,
}

impl Pll {
    /// RCC_PLLCFGR's PLLM (bits 0–5), PLLN (6–14), PLLP (16–17: `P/2 − 1`) and PLLQ (24–27)
    /// fields; PLLSRC (bit 22) is the caller's.
    pub const fn pllcfgr(&self) -> u32 {
        self.m | (self.n << 6) | ((self.p / 2 - 1) << 16) | (self.q << 24)
    }
}

/// The dividers that give exactly [`SYSCLK_HZ`] and [`CLK48_HZ`] from `input_hz`, with the
/// highest VCO input (the least jitter) among them; `Err` names the constraint no setting
/// meets.
pub const fn pll_for(input_hz: u32) -> Result<Pll, &'static str> {
    let mut m = 2;
    while m <= 63 {
        // f_VCO_in = input / M in [1, 2] MHz, M rising: the highest input first.
        if input_hz <= 2_000_000 * m && input_hz >= 1_000_000 * m {
            let mut p = 2;
            while p <= 8 {
                // N = SYSCLK · P · M / input must be a whole number (u64: 168e6 · 8 · 63
                // overflows u32).
                let num = SYSCLK_HZ as u64 * p as u64 * m as u64;
                let vco = SYSCLK_HZ as u64 * p as u64;
                if num.is_multiple_of(input_hz as u64) && vco >= 100_000_000 && vco <= 432_000_000 {
                    let n = (num / input_hz as u64) as u32;
                    let q = (vco / CLK48_HZ as u64) as u32;
                    if n >= 50
                        && n <= 432
                        && vco.is_multiple_of(CLK48_HZ as u64)
                        && q >= 2
                        && q <= 15
                    {
                        return Ok(Pll { m, n, p, q });
                    }
                }
                p += 2;
            }
        }
        m += 1;
    }
    Err(
        "no PLL setting gives 168 MHz and 48 MHz from this clock (RM0090, RCC_PLLCFGR: VCO input 1-2 MHz with M 2..63, N 50..432, VCO 100-432 MHz, P 2/4/6/8, Q 2..15)",
    )
}

/// The dividers for a crystal or oscillator module of `hse_hz`: the HSE range first
/// (datasheet: 4 to 26 MHz), then [`pll_for`].
pub const fn pll_for_hse(hse_hz: u32) -> Result<Pll, &'static str> {
    if hse_hz < 4_000_000 || hse_hz > 26_000_000 {
        return Err("HSE_HZ must be 4 to 26 MHz (the STM32F405's HSE oscillator range)");
    }
    pll_for(hse_hz)
}

/// `pll` unwrapped at compile time: a build stops with the constraint's message.
pub const fn expect(pll: Result<Pll, &'static str>) -> Pll {
    match pll {
        Ok(p) => p,
        Err(e) => panic!("{}", e),
    }
}

//! The outputs made safe before RAM is initialized: cortex-m-rt's reset handler calls
//! `__pre_init` first, before it zeroes `.bss` and copies `.data` (about 3 ms at the 16 MHz
//! internal oscillator the chip resets to: `scripts/fw-elf-check` prints the figure), so the
//! amplifiers' inputs are driven safe within microseconds of reset instead of floating until
//! `init`.
//!
//! It is written in assembly, as cortex-m-rt 0.7.7 asks (its `#[pre_init]` attribute is
//! deprecated: Rust code may not run before RAM is initialized); it uses r0–r2 and no memory but
//! the registers it writes and its own literal pool in flash. Each register is read, its field
//! cleared and set, and written back (RM0090), so that a debugger's pins (PA13/PA14) and the
//! reset values keep their other bits. In order:
//!
//! 1. GPIOA and GPIOB clocks on; the enable line PB12 and the brake-release line PB11 reset
//!    (one BSRR store), then made outputs: the amplifiers are disabled and the brakes engaged
//!    the moment the pins drive;
//! 2. DAC and TIM12 clocks on; PA4 analog, then the DAC's channel 1 at mid-scale
//!    ([`DAC_MID`](super::hw::DAC_MID), 0 V at the piezo) with its buffer, then enabled
//!    (RM0090, DAC: the pin analog first, before the channel connects it to its output);
//! 3. TIM12 in PWM mode 1 on both channels at 50 % duty (zero torque), preloads loaded by an
//!    update event, counting; then PB14/PB15 handed to it (AF9). Until the crystal runs the
//!    timer counts at 16 MHz (3.8 kHz PWM instead of 20 kHz), still at 50 %.
//!
//! `scripts/fw-elf-check` checks in the built ELF that the reset handler calls this first and
//! that its first store after the GPIO clocks is the enable's (and the brake's) reset.

use super::hw::{DAC_MID, PWM_PERIOD};

/// Register addresses (RM0090's memory map and each peripheral's register map).
const RCC: u32 = 0x4002_3800;
const RCC_AHB1ENR: u32 = RCC + 0x30;
const RCC_APB1ENR: u32 = RCC + 0x40;
const GPIOA_MODER: u32 = 0x4002_0000;
const GPIOB: u32 = 0x4002_0400;
const GPIOB_MODER: u32 = GPIOB;
const GPIOB_BSRR: u32 = GPIOB + 0x18;
const GPIOB_AFRH: u32 = GPIOB + 0x24;
const DAC: u32 = 0x4000_7400;
const DAC_CR: u32 = DAC;
const DAC_DHR12R1: u32 = DAC + 0x08;
const TIM12: u32 = 0x4000_1800;
const TIM12_CR1: u32 = TIM12;
const TIM12_EGR: u32 = TIM12 + 0x14;
const TIM12_CCMR1: u32 = TIM12 + 0x18;
const TIM12_CCER: u32 = TIM12 + 0x20;
const TIM12_ARR: u32 = TIM12 + 0x2C;
const TIM12_CCR1: u32 = TIM12 + 0x34;
const TIM12_CCR2: u32 = TIM12 + 0x38;

/// Field values.
const GPIOAEN_GPIOBEN: u32 = 0b11;
const TIM12EN_DACEN: u32 = (1 << 6) | (1 << 29);
/// PB12 (the enable) and PB11 (the brake release): BSRR reset bits; MODER 0b01 (output).
const PB12_RESET: u32 =
    (1 << (16 + super::hw::ENABLE_PIN as u32)) | (1 << (16 + super::hw::BRAKE_PIN as u32));
const PB12_MODER_MASK: u32 =
    (0b11 << (2 * super::hw::ENABLE_PIN as u32)) | (0b11 << (2 * super::hw::BRAKE_PIN as u32));
const PB12_OUTPUT: u32 =
    (0b01 << (2 * super::hw::ENABLE_PIN as u32)) | (0b01 << (2 * super::hw::BRAKE_PIN as u32));
/// PA4: MODER 0b11 (analog).
const PA4_ANALOG: u32 = 0b11 << 8;
/// DAC_CR: EN1 (bit 0) on, BOFF1 (bit 1) clear: the output buffer on.
const DAC_CR_MASK: u32 = 0b11;
const DAC_EN1: u32 = 1;
/// TIM12_CCMR1: OC1M = OC2M = 0b110 (PWM mode 1), OC1PE, OC2PE (preload).
const CCMR1_MASK: u32 = 0x7878;
const CCMR1_PWM: u32 = (0b110 << 4) | (1 << 3) | (0b110 << 12) | (1 << 11);
/// TIM12_CCER: CC1E, CC2E; CR1: CEN, ARPE.
const CCER_CC12E: u32 = 0x11;
const CR1_ARPE_CEN: u32 = 0x81;
/// PB14/PB15: AFRH AF9 and MODER 0b10 (alternate function).
const PB14_15_AF_MASK: u32 = 0xFF << 24;
const PB14_15_AF9: u32 = 0x99 << 24;
const PB14_15_MODER_MASK: u32 = 0xF << 28;
const PB14_15_ALTERNATE: u32 = 0b1010 << 28;

/// The safe outputs before RAM is initialized (module doc). Called by cortex-m-rt's `Reset`.
#[unsafe(no_mangle)]
#[unsafe(naked)]
pub unsafe extern "C" fn __pre_init() {
    core::arch::naked_asm!(
        // rmw ADDR, CLEAR, SET: *ADDR = (*ADDR & !CLEAR) | SET; put ADDR, VALUE: *ADDR = VALUE.
        ".macro rmw addr, clear, set",
        "ldr r0, =\\addr",
        "ldr r1, [r0]",
        "ldr r2, =\\clear",
        "bic r1, r1, r2",
        "ldr r2, =\\set",
        "orr r1, r1, r2",
        "str r1, [r0]",
        ".endm",
        ".macro put addr, value",
        "ldr r0, =\\addr",
        "ldr r1, =\\value",
        "str r1, [r0]",
        ".endm",
        // 1. The enable and brake-release lines low, then driven.
        "rmw {ahb1enr}, 0, {gpio_en}",
        "dsb",
        "put {bsrr}, {pb12_reset}",
        "rmw {gpiob_moder}, {pb12_mask}, {pb12_output}",
        // 2. PA4 analog, the DAC at mid-scale, then enabled.
        "rmw {apb1enr}, 0, {apb1_en}",
        "dsb",
        "rmw {gpioa_moder}, {pa4_analog}, {pa4_analog}",
        "put {dhr12r1}, {dac_mid}",
        "rmw {dac_cr}, {dac_cr_mask}, {dac_en1}",
        // 3. TIM12 at 50 %, counting, then its pins.
        "put {arr}, {arr_value}",
        "rmw {ccmr1}, {ccmr1_mask}, {ccmr1_pwm}",
        "put {ccr1}, {half}",
        "put {ccr2}, {half}",
        "put {egr}, 1",
        "rmw {ccer}, {ccer_cc12e}, {ccer_cc12e}",
        "rmw {cr1}, {cr1_arpe_cen}, {cr1_arpe_cen}",
        "rmw {gpiob_afrh}, {af_mask}, {af9}",
        "rmw {gpiob_moder}, {pb1415_mask}, {pb1415_alternate}",
        "bx lr",
        ".ltorg",
        ".purgem rmw",
        ".purgem put",
        ahb1enr = const RCC_AHB1ENR,
        gpio_en = const GPIOAEN_GPIOBEN,
        bsrr = const GPIOB_BSRR,
        pb12_reset = const PB12_RESET,
        gpiob_moder = const GPIOB_MODER,
        pb12_mask = const PB12_MODER_MASK,
        pb12_output = const PB12_OUTPUT,
        apb1enr = const RCC_APB1ENR,
        apb1_en = const TIM12EN_DACEN,
        gpioa_moder = const GPIOA_MODER,
        pa4_analog = const PA4_ANALOG,
        dhr12r1 = const DAC_DHR12R1,
        dac_mid = const DAC_MID as u32,
        dac_cr = const DAC_CR,
        dac_cr_mask = const DAC_CR_MASK,
        dac_en1 = const DAC_EN1,
        arr = const TIM12_ARR,
        arr_value = const PWM_PERIOD - 1,
        ccmr1 = const TIM12_CCMR1,
        ccmr1_mask = const CCMR1_MASK,
        ccmr1_pwm = const CCMR1_PWM,
        ccr1 = const TIM12_CCR1,
        ccr2 = const TIM12_CCR2,
        half = const PWM_PERIOD / 2,
        egr = const TIM12_EGR,
        ccer = const TIM12_CCER,
        ccer_cc12e = const CCER_CC12E,
        cr1 = const TIM12_CR1,
        cr1_arpe_cen = const CR1_ARPE_CEN,
        gpiob_afrh = const GPIOB_AFRH,
        af_mask = const PB14_15_AF_MASK,
        af9 = const PB14_15_AF9,
        pb1415_mask = const PB14_15_MODER_MASK,
        pb1415_alternate = const PB14_15_ALTERNATE,
    )
}

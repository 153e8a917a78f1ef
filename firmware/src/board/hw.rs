//! The hardware board: an STM32F405 (168 MHz from an 8 MHz crystal) wired to two servo
//! amplifiers in torque (current) mode, a high-voltage piezo amplifier and the PVDF film's
//! charge amplifier. Pin map (also in the README):
//!
//! | signal | pin | peripheral | scaling |
//! |---|---|---|---|
//! | encoder 1 A/B | PA8 / PA9 | TIM1 CH1/CH2, encoder mode (AF1), pull-ups, 1.5 µs filter | 16384 counts/rev |
//! | encoder 2 A/B | PC6 / PC7 | TIM8 CH1/CH2, encoder mode (AF3), pull-ups, 1.5 µs filter | 16384 counts/rev |
//! | film voltage | PA0 | ADC1 IN0, 12 bit, started by TIM2's update | 0–3.3 V ↔ −10…+10 V at the film |
//! | piezo command | PA4 | DAC channel 1, 12 bit, output buffer on | 0–3.3 V ↔ −200…+200 V at the amplifier; the buffer swings 0.2–3.1 V, so ±175 V |
//! | motor 1 torque | PB14 | TIM12 CH1 PWM, 20 kHz (AF9) | duty 0–100 % ↔ −τ_max…+τ_max |
//! | motor 2 torque | PB15 | TIM12 CH2 PWM, 20 kHz (AF9) | duty 0–100 % ↔ −τ_max…+τ_max |
//! | amplifier enable | PB12 | GPIO output, active high, external 10 kΩ pull-down | all three amplifiers |
//! | brake release | PB11 | GPIO output, active high, external 10 kΩ pull-down | both joints' fail-safe holding brakes (through their coil drivers): low or floating = engaged |
//! | amplifier fault | PB13 | GPIO input, pull-up, active low | wired-OR of the three |
//!
//! Register values follow RM0090 (STM32F405 reference manual); each write says what it sets.
//! The enable, brake-release and fault lines go through `embedded-hal` 1.0 pin traits.

use core::convert::Infallible;
use core::f32::consts::TAU;

use embedded_hal::digital::{ErrorType, InputPin, OutputPin, StatefulOutputPin};
use flexarm_core::Vector2;
use flexarm_core::homing;
use flexarm_core::params::Limits;
use stm32f4::stm32f405::{ADC1, DAC, GPIOA, GPIOB, GPIOC, IWDG, RCC, TIM1, TIM8, TIM12};

use super::Board;

/// The enable line's pin number on port B.
pub const ENABLE_PIN: u8 = 12;
/// The brake-release line's pin number on port B (issue 33): high releases both joints'
/// brakes, low (and floating, by its pull-down) engages them. On the enable's port, so the
/// safe-state paths reset both with one BSRR store.
pub const BRAKE_PIN: u8 = 11;
/// DAC code of a 0 V piezo command, at boot and in the safe state: codes `DAC_MID ± 2047` span
/// the amplifier's input range symmetrically.
pub const DAC_MID: u16 = 2048;

/// Polls of the ADC's end of conversion before giving up. The conversion, started by TIM2's
/// update, takes 84 + 12 ADC clocks at 21 MHz, 4.6 µs (770 core cycles), from which the
/// interrupt's entry and the work before the read are already gone; a poll (an APB2 read and a
/// branch) takes 5 to 10 cycles, so 300 polls wait 9 to 18 µs: a stuck converter, not a slow one.
const ADC_POLLS: u32 = 300;

/// The piezo amplifier's input range: 0–3.3 V at its input is −200…+200 V at the patch.
const PIEZO_FULL_SCALE_V: f32 = 200.0;
// What the DAC's output buffer can reach, ±175 V at the patch, is the controller's piezo window
// on this board: `flexarm_machine::config::HARDWARE_PIEZO_V_MAX`.

use super::wiring::{COUNTS_PER_REV, ENCODER_REVERSED, FILM_INVERTED};

/// Film channel: ±10 V at the film maps to 0–3.3 V at the ADC.
const FILM_RANGE: f32 = 10.0;
/// TIM12 input clock (APB1 timers) [Hz] and PWM rate [Hz].
const TIM12_CLOCK_HZ: u32 = 84_000_000;
const PWM_HZ: u32 = 20_000;
/// The PWM period in TIM12 counts (ARR + 1), set by `super::pre_init`.
pub const PWM_PERIOD: u32 = TIM12_CLOCK_HZ / PWM_HZ;

/// Read-modify-write of the bits under `mask`.
macro_rules! set_bits {
    ($reg:expr, $mask:expr, $value:expr) => {
        // SAFETY: the value is a documented field setting of this register (RM0090).
        $reg.modify(|r, w| unsafe { w.bits((r.bits() & !($mask)) | ($value)) })
    };
}

/// The watchdog's reload value: a timeout of `IWDG_RELOAD · divider / f_LSI`.
const IWDG_RELOAD: u16 = 500;
/// The LSI's fastest (datasheet: 17 to 47 kHz, 32 kHz typical) [Hz]: the shortest timeout.
const LSI_MAX_HZ: u64 = 47_000;
/// Polls of the watchdog's status bits: the LSI's start (at most 40 µs) and 5 of its periods
/// (294 µs at 17 kHz), with a poll of 5 to 10 cycles, are 56 000 cycles at 168 MHz at most.
const IWDG_POLLS: u32 = 40_000;

/// The watchdog's prescaler code (divider `4 · 2^PR`) whose timeout is, even on the fastest
/// LSI, at least twice the supervisor's period `supervisor_us` [µs] (the supervisor feeds it):
/// 3 (/32, 0.5 s; 0.34 to 0.94 s across the LSI's range) for the 0.1 s period at 168 MHz, 5
/// (/128, 2 s; 1.36 to 3.76 s) for the 0.525 s the supervisor's timer gives at 16 MHz.
pub const fn watchdog_prescaler(supervisor_us: u64) -> u8 {
    let mut pr = 0;
    while pr < 6 && (4 << pr) * IWDG_RELOAD as u64 * 1_000_000 / LSI_MAX_HZ < 2 * supervisor_us {
        pr += 1;
    }
    pr
}

/// Starts the independent watchdog with a timeout that fits the supervisor's period
/// ([`watchdog_prescaler`]). RM0090, IWDG: the start (KR = 0xCCCC) turns the LSI on and counts
/// from 0xFFF; PR and RLR are written after the unlock (0x5555) and reach the LSI's domain
/// within 5 of its periods, shown by the status bits PVU and RVU; the first reload (0xAAAA)
/// waits for them to clear, or it would load the old value (0xFFF: 4 s at /32). `false` if
/// they did not clear within the bounded wait (the first timeout may then be longer).
pub fn start_watchdog(iwdg: &IWDG, supervisor_us: u64) -> bool {
    iwdg.kr().write(|w| w.key().start());
    iwdg.kr().write(|w| w.key().unlock());
    iwdg.pr()
        .write(|w| w.pr().set(watchdog_prescaler(supervisor_us)));
    iwdg.rlr().write(|w| w.rl().set(IWDG_RELOAD));
    let updated = (0..IWDG_POLLS).any(|_| iwdg.sr().read().bits() & 0b11 == 0);
    iwdg.kr().write(|w| w.key().feed());
    updated
}

/// Reloads the watchdog counter.
pub fn feed_watchdog(iwdg: &mut IWDG) {
    iwdg.kr().write(|w| w.key().feed());
}

/// A GPIOB pin, accessed through the atomic BSRR (set/reset), IDR and ODR (reads).
pub struct PortBPin<const N: u8>;

impl<const N: u8> PortBPin<N> {
    fn regs() -> &'static stm32f4::stm32f405::gpioa::RegisterBlock {
        // SAFETY: only BSRR (atomic, write-only), IDR and ODR (read) are used, so concurrent
        // use of different pins of the port cannot race; GPIOB's configuration is done once in
        // `HwBoard::new` before any pin is used.
        unsafe { &*GPIOB::ptr().cast() }
    }
}

impl<const N: u8> ErrorType for PortBPin<N> {
    type Error = Infallible;
}

impl<const N: u8> OutputPin for PortBPin<N> {
    fn set_low(&mut self) -> Result<(), Infallible> {
        // SAFETY: BSRR bit 16 + N resets pin N only.
        Self::regs()
            .bsrr()
            .write(|w| unsafe { w.bits(1 << (16 + u32::from(N))) });
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Infallible> {
        // SAFETY: BSRR bit N sets pin N only.
        Self::regs().bsrr().write(|w| unsafe { w.bits(1 << N) });
        Ok(())
    }
}

impl<const N: u8> StatefulOutputPin for PortBPin<N> {
    /// The output data register's bit (the level the pin drives as an output).
    fn is_set_high(&mut self) -> Result<bool, Infallible> {
        Ok(Self::regs().odr().read().bits() & (1 << N) != 0)
    }
    fn is_set_low(&mut self) -> Result<bool, Infallible> {
        Ok(Self::regs().odr().read().bits() & (1 << N) == 0)
    }
}

impl<const N: u8> InputPin for PortBPin<N> {
    fn is_high(&mut self) -> Result<bool, Infallible> {
        Ok(Self::regs().idr().read().bits() & (1 << N) != 0)
    }
    fn is_low(&mut self) -> Result<bool, Infallible> {
        Ok(Self::regs().idr().read().bits() & (1 << N) == 0)
    }
}

/// The board's peripherals.
pub struct HwBoard {
    tim1: TIM1,
    tim8: TIM8,
    tim12: TIM12,
    adc: ADC1,
    dac: DAC,
    enable: PortBPin<12>,
    brake_release: PortBPin<11>,
    fault_n: PortBPin<13>,
    /// Last raw counts and accumulated counts of each encoder (16-bit timers, unwrapped).
    raw: [u16; 2],
    counts: [i32; 2],
    tau_max: Vector2<f32>,
    pwm_period: u32,
    /// The piezo loop's latest film sample [V].
    film: f32,
}

impl HwBoard {
    /// Configures the pins and peripherals of the pin map, outputs at zero, amplifiers off.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        gpioa: GPIOA,
        gpiob: GPIOB,
        gpioc: GPIOC,
        tim1: TIM1,
        tim8: TIM8,
        tim12: TIM12,
        adc: ADC1,
        dac: DAC,
        rcc: &RCC,
    ) -> Self {
        // Clocks: GPIOA/B/C (AHB1ENR bits 0–2); TIM1, TIM8, ADC1 (APB2ENR bits 0, 1, 8). TIM12
        // and the DAC are already on and at their safe outputs, PB12 low, PA4 analog, PB14/PB15
        // on TIM12: `super::pre_init`, before RAM was initialized.
        set_bits!(rcc.ahb1enr(), 0x7, 0x7);
        set_bits!(
            rcc.apb2enr(),
            1 | (1 << 1) | (1 << 8),
            1 | (1 << 1) | (1 << 8)
        );

        // GPIOA: PA0 analog (ADC), PA8/PA9 AF1 (TIM1 CH1/CH2: encoder 1's A/B), PA10 AF1
        // (TIM1 CH3: encoder 1's index, issue 33).
        set_bits!(
            gpioa.moder(),
            3 | (3 << 16) | (3 << 18) | (3 << 20),
            3 | (2 << 16) | (2 << 18) | (2 << 20)
        );
        set_bits!(gpioa.afrh(), 0xFFF, 0x111);
        // Encoder inputs pulled up (PUPDR = 0b01): open-collector encoders need it, line
        // receivers with push-pull outputs do not mind it.
        set_bits!(
            gpioa.pupdr(),
            (3 << 16) | (3 << 18) | (3 << 20),
            (1 << 16) | (1 << 18) | (1 << 20)
        );
        // GPIOC: PC6/PC7 AF3 (TIM8 CH1/CH2), PC8 AF3 (TIM8 CH3: encoder 2's index), pulled up
        // as well.
        set_bits!(
            gpioc.moder(),
            (3 << 12) | (3 << 14) | (3 << 16),
            (2 << 12) | (2 << 14) | (2 << 16)
        );
        set_bits!(gpioc.afrl(), 0xFF << 24, 0x33 << 24);
        set_bits!(gpioc.afrh(), 0xF, 0x3);
        set_bits!(
            gpioc.pupdr(),
            (3 << 12) | (3 << 14) | (3 << 16),
            (1 << 12) | (1 << 14) | (1 << 16)
        );
        // GPIOB: PB13 input (MODER 0b00, its reset value) with pull-up; PB12 (the enable) and
        // PB11 (the brake release), outputs driven low, and PB14/PB15 (TIM12) are
        // `super::pre_init`'s.
        set_bits!(gpiob.moder(), 3 << 26, 0);
        set_bits!(gpiob.pupdr(), 3 << 26, 1 << 26);
        // PB6/PB7 AF7: USART1 TX/RX, the command link (`crate::link`); RX pulled up so an
        // unplugged cable reads idle.
        set_bits!(gpiob.afrl(), 0xFF << 24, 0x77 << 24);
        set_bits!(gpiob.moder(), 0xF << 12, (2 << 12) | (2 << 14));
        set_bits!(gpiob.pupdr(), 3 << 14, 1 << 14);

        // Encoders: SMCR SMS = 0b011 (count on both edges of both inputs), CCMR1 CC1S = CC2S =
        // 0b01 (TI1, TI2), input filter 0b1111 (f_DTS/32, 8 samples: 1.5 µs at the 168 MHz
        // timer clock, against PWM noise on the cables; the fastest edge spacing, 20 rad/s on
        // a 4096-line encoder, is 19 µs), CCER CC1P inverted for a reversed axis
        // (`ENCODER_REVERSED`), ARR = 0xFFFF, counter on.
        macro_rules! encoder {
            ($t:expr, $reversed:expr) => {{
                set_bits!($t.smcr(), 0x7, 0b011);
                set_bits!(
                    $t.ccmr1_input(),
                    0xF3F3,
                    0x0101 | (0b1111 << 4) | (0b1111 << 12)
                );
                set_bits!($t.ccer(), 1 << 1, u32::from($reversed) << 1);
                // The index (issue 33): CCMR2 CC3S = 0b01 (IC3 on TI3), the same filter;
                // CCER CC3E: the counter captured into CCR3 at the index's rising edge
                // (CC3IF set until CCR3 is read).
                set_bits!($t.ccmr2_input(), 0xF3, 0x01 | (0b1111 << 4));
                set_bits!($t.ccer(), 1 << 8, 1 << 8);
                set_bits!($t.arr(), 0xFFFF, 0xFFFF);
                set_bits!($t.cr1(), 1, 1);
            }};
        }
        encoder!(tim1, ENCODER_REVERSED[0]);
        encoder!(tim8, ENCODER_REVERSED[1]);

        // ADC common clock: ADCPRE = /4 (ADC_CCR bits 16–17 = 0b01), 84 MHz / 4 = 21 MHz, within
        // the 36 MHz maximum. ADC1: 12 bit, IN0 first in the sequence, 84-cycle sampling,
        // conversions started by TIM2's TRGO (EXTSEL = 0b0110, bits 24–27; EXTEN = rising,
        // bits 28–29), i.e. at each piezo period's update event, on.
        // SAFETY: ADC_CCR is shared by the three ADCs, of which this board uses ADC1 only.
        let common = unsafe { &*stm32f4::stm32f405::ADC_COMMON::ptr() };
        set_bits!(common.ccr(), 0b11 << 16, 0b01 << 16);
        set_bits!(adc.sqr3(), 0x1F, 0);
        set_bits!(adc.smpr2(), 0x7, 0b100);
        set_bits!(
            adc.cr2(),
            (0xF << 24) | (0b11 << 28),
            (0b0110 << 24) | (0b01 << 28)
        );
        set_bits!(adc.cr2(), 1, 1);

        let limits = Limits::<f32>::default();
        let pwm_period = PWM_PERIOD;
        let raw = [
            tim1.cnt().read().bits() as u16,
            tim8.cnt().read().bits() as u16,
        ];
        Self {
            tim1,
            tim8,
            tim12,
            adc,
            dac,
            enable: PortBPin,
            brake_release: PortBPin,
            fault_n: PortBPin,
            raw,
            counts: [0; 2],
            tau_max: limits.tau_max,
            pwm_period,
            film: 0.0,
        }
    }

    /// Duty count for `x` in [−1, 1] (50 % at 0).
    fn duty(&self, x: f32) -> u32 {
        let x = if x.is_nan() { 0.0 } else { x.clamp(-1.0, 1.0) };
        ((x + 1.0) * 0.5 * self.pwm_period as f32) as u32
    }
}

impl Board for HwBoard {
    /// The counts the encoder timers captured at an index pulse (TIM1/TIM8 CH3, PA10/PC8)
    /// since the last call, as angles from the accumulated counts of the last
    /// [`Board::encoders`] (which the motor loop reads just before).
    fn homing_inputs(&mut self) -> homing::Inputs<f32> {
        let captured = [
            (self.tim1.sr().read().bits() & (1 << 3) != 0)
                .then(|| self.tim1.ccr3().read().bits() as u16),
            (self.tim8.sr().read().bits() & (1 << 3) != 0)
                .then(|| self.tim8.ccr3().read().bits() as u16),
        ];
        let mut latched = [f32::NAN; 2];
        for (j, c) in captured.iter().enumerate() {
            if let (Some(c), Some(raw), Some(count), Some(per_rev), Some(slot)) = (
                c,
                self.raw.get(j),
                self.counts.get(j),
                COUNTS_PER_REV.get(j),
                latched.get_mut(j),
            ) {
                let at = count.wrapping_add(i32::from(c.wrapping_sub(*raw) as i16));
                *slot = at as f32 * (TAU / per_rev);
            }
        }
        homing::Inputs { latched }
    }

    fn encoders(&mut self) -> Vector2<f32> {
        let now = [
            self.tim1.cnt().read().bits() as u16,
            self.tim8.cnt().read().bits() as u16,
        ];
        for ((n, raw), count) in now
            .iter()
            .zip(self.raw.iter_mut())
            .zip(self.counts.iter_mut())
        {
            // The 16-bit counter wraps; the signed difference is right for moves below half a
            // turn of the counter per period (32768 counts = 2 rev per motor period).
            let step = n.wrapping_sub(*raw) as i16;
            *count = count.wrapping_add(i32::from(step));
            *raw = *n;
        }
        Vector2::new(
            self.counts[0] as f32 * (TAU / COUNTS_PER_REV[0]),
            self.counts[1] as f32 * (TAU / COUNTS_PER_REV[1]),
        )
    }

    /// The conversion TIM2's update started at the beginning of this piezo period (the
    /// sampling instant is the timer's, not the task's), waited for at most `ADC_POLLS`; NaN if
    /// it does not end (the controller then latches `NonFinite` and commands the safe state).
    /// Called by the piezo loop; the result is kept for the motor loop.
    fn film_voltage(&mut self) -> f32 {
        let eoc = (0..ADC_POLLS).any(|_| self.adc.sr().read().bits() & (1 << 1) != 0);
        self.film = if eoc {
            let code = (self.adc.dr().read().bits() & 0xFFF) as f32; // clears EOC
            let v = (code / 4095.0 * 2.0 - 1.0) * FILM_RANGE;
            if FILM_INVERTED { -v } else { v }
        } else {
            f32::NAN
        };
        self.film
    }

    /// The piezo loop's latest sample: the motor loop starts no conversion of its own.
    fn latest_film_voltage(&mut self) -> f32 {
        self.film
    }

    fn set_torques(&mut self, tau: Vector2<f32>) {
        let d1 = self.duty(tau.x / self.tau_max.x);
        let d2 = self.duty(tau.y / self.tau_max.y);
        set_bits!(self.tim12.ccr1(), 0xFFFF, d1);
        set_bits!(self.tim12.ccr2(), 0xFFFF, d2);
    }

    fn set_piezo(&mut self, v_a: f32) {
        let x = if v_a.is_nan() {
            0.0
        } else {
            (v_a / PIEZO_FULL_SCALE_V).clamp(-1.0, 1.0)
        };
        // DAC_MID ± 2047: 0 V is exactly mid-scale, as at boot and in the safe state.
        let code = (f32::from(DAC_MID) + x * 2047.0 + 0.5) as u32;
        set_bits!(self.dac.dhr12r1(), 0xFFF, code);
    }

    fn set_enable(&mut self, on: bool) {
        let Ok(()) = if on {
            self.enable.set_high()
        } else {
            self.enable.set_low()
        };
    }

    fn set_brake(&mut self, engaged: bool) {
        let Ok(()) = if engaged {
            self.brake_release.set_low()
        } else {
            self.brake_release.set_high()
        };
    }

    fn brake_engaged(&mut self) -> bool {
        let Ok(low) = self.brake_release.is_set_low();
        low
    }

    fn amplifier_fault(&mut self) -> bool {
        let Ok(low) = self.fault_n.is_low();
        low
    }
}

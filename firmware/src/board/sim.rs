//! The QEMU board: the arm simulated inside the firmware (`flexarm_machine::simulated`: the
//! core's model in `f32`, RK4, quantized encoders and film ADC, held by its brakes while the
//! brake output is engaged), stepped once per piezo period, with the wiring of `super::wiring`
//! and the test builds' injections. Its enable, brake-release and fault lines are in-memory
//! `embedded-hal` pins, so the same pin logic runs as on hardware.

use core::convert::Infallible;
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering::Relaxed};

use embedded_hal::digital::{ErrorType, InputPin, OutputPin};
use flexarm_core::Vector2;
use flexarm_machine::simulated::SimulatedArm;

use super::{Board, wiring};

/// The board's outputs as last written, readable from any context: the emergency handlers
/// force and read them (`crate::emergency`), the injection runs judge them.
pub struct OutputRecord {
    enable: AtomicBool,
    /// The brake-release line (high: released).
    brake_release: AtomicBool,
    was_enabled: AtomicBool,
    tau: [AtomicU32; 2],
    v_a: AtomicU32,
}

/// A copy of the [`OutputRecord`].
#[derive(Clone, Copy, Debug)]
pub struct Outputs {
    /// Amplifier enable line.
    pub enable: bool,
    /// Whether the enable line was ever high.
    pub was_enabled: bool,
    /// The brake-release line: `false` is the brake engaged.
    pub brake_release: bool,
    /// Motor torque commands [N·m].
    pub tau: [f32; 2],
    /// Piezo command [V].
    pub v_a: f32,
}

impl Outputs {
    /// Amplifiers off, brake engaged, zero torque, zero voltage.
    pub fn is_safe(&self) -> bool {
        !self.enable && !self.brake_release && self.tau == [0.0; 2] && self.v_a == 0.0
    }
}

impl OutputRecord {
    const fn new() -> Self {
        Self {
            enable: AtomicBool::new(false),
            brake_release: AtomicBool::new(false),
            was_enabled: AtomicBool::new(false),
            tau: [AtomicU32::new(0), AtomicU32::new(0)],
            v_a: AtomicU32::new(0),
        }
    }

    fn set_enable(&self, on: bool) {
        self.enable.store(on, Relaxed);
        if on {
            self.was_enabled.store(true, Relaxed);
        }
    }

    fn set_torques(&self, tau: Vector2<f32>) {
        self.tau[0].store(tau.x.to_bits(), Relaxed);
        self.tau[1].store(tau.y.to_bits(), Relaxed);
    }

    /// The safe state, written as the hardware board's emergency path writes it: enable first,
    /// with the brake.
    pub fn force_safe(&self) {
        self.enable.store(false, Relaxed);
        self.brake_release.store(false, Relaxed);
        self.set_torques(Vector2::zeros());
        self.v_a.store(0, Relaxed);
    }

    /// The outputs now.
    pub fn snapshot(&self) -> Outputs {
        Outputs {
            enable: self.enable.load(Relaxed),
            was_enabled: self.was_enabled.load(Relaxed),
            brake_release: self.brake_release.load(Relaxed),
            tau: [
                f32::from_bits(self.tau[0].load(Relaxed)),
                f32::from_bits(self.tau[1].load(Relaxed)),
            ],
            v_a: f32::from_bits(self.v_a.load(Relaxed)),
        }
    }
}

/// The QEMU board's outputs.
pub static OUTPUTS: OutputRecord = OutputRecord::new();

/// A pin that lives in memory.
#[derive(Default)]
pub struct SimPin(bool);

impl ErrorType for SimPin {
    type Error = Infallible;
}

impl OutputPin for SimPin {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.0 = false;
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Infallible> {
        self.0 = true;
        Ok(())
    }
}

impl InputPin for SimPin {
    fn is_high(&mut self) -> Result<bool, Infallible> {
        Ok(self.0)
    }
    fn is_low(&mut self) -> Result<bool, Infallible> {
        Ok(!self.0)
    }
}

/// The simulated arm and its lines.
pub struct SimBoard {
    /// The plant, its sensors and its step.
    pub sim: SimulatedArm,
    enable: SimPin,
    /// Brake-release line, active high (low = engaged), as the hardware board's.
    brake_release: SimPin,
    /// Amplifier fault line, active low (high = healthy).
    fault_n: SimPin,
    /// The verdict run's measurements.
    pub run: crate::verdict::RunCheck,
    /// Plant steps since boot (the injection builds' clock).
    steps: u32,
    /// Joint 2's reading once frozen (`inject-frozen-encoder`).
    #[cfg_attr(not(feature = "inject-frozen-encoder"), allow(dead_code))]
    frozen: Option<f32>,
}

impl SimBoard {
    /// A board around `sim`.
    pub fn new(sim: SimulatedArm) -> Self {
        Self {
            sim,
            enable: SimPin(false),
            brake_release: SimPin(false),
            fault_n: SimPin(true),
            run: crate::verdict::RunCheck::default(),
            steps: 0,
            frozen: None,
        }
    }
}

impl SimBoard {
    /// One plant step (one copy in flash).
    #[inline(never)]
    fn step_plant(&mut self) {
        self.steps = self.steps.saturating_add(1);
        self.sim.step();
    }

    /// Asserts (`true`) or releases the simulated amplifiers' fault line (the link-session
    /// build's test command).
    pub fn inject_amplifier_fault(&mut self, asserted: bool) {
        self.fault_n = SimPin(!asserted);
    }
}

impl Board for SimBoard {
    fn encoders(&mut self) -> Vector2<f32> {
        #[allow(unused_mut)]
        let mut theta = self.sim.arm.encoders();
        #[cfg(feature = "inject-reversed-encoder")]
        {
            theta.x = -theta.x;
        }
        #[cfg(feature = "inject-frozen-encoder")]
        if self.steps as f32 * self.sim.dt >= 1.0 {
            theta.y = *self.frozen.get_or_insert(theta.y);
        }
        // The configured wiring, as the hardware board applies it: the simulated encoders
        // count `counts_per_rev` (16384) a revolution.
        let counts = self.sim.arm.sensors.counts_per_rev;
        let sign = |r: bool| if r { -1.0 } else { 1.0 };
        Vector2::new(
            theta.x * sign(wiring::ENCODER_REVERSED[0]) * (counts / wiring::COUNTS_PER_REV[0]),
            theta.y * sign(wiring::ENCODER_REVERSED[1]) * (counts / wiring::COUNTS_PER_REV[1]),
        )
    }
    fn film_voltage(&mut self) -> f32 {
        let v = self.sim.arm.film_voltage();
        // A film wired the other way round (a test build), then the configured wiring.
        let v = if cfg!(feature = "inject-film-reversed") {
            -v
        } else {
            v
        };
        if wiring::FILM_INVERTED { -v } else { v }
    }
    fn set_torques(&mut self, tau: Vector2<f32>) {
        OUTPUTS.set_torques(tau);
        self.sim.arm.set_torques(tau);
    }
    fn set_piezo(&mut self, v_a: f32) {
        OUTPUTS.v_a.store(v_a.to_bits(), Relaxed);
        self.sim.arm.set_piezo(v_a);
    }
    fn set_enable(&mut self, on: bool) {
        let Ok(()) = if on {
            self.enable.set_high()
        } else {
            self.enable.set_low()
        };
        let Ok(level) = self.enable.is_high();
        OUTPUTS.set_enable(level);
        self.sim.arm.set_enable(level);
    }
    fn set_brake(&mut self, engaged: bool) {
        let Ok(()) = if engaged {
            self.brake_release.set_low()
        } else {
            self.brake_release.set_high()
        };
        let Ok(released) = self.brake_release.is_high();
        OUTPUTS.brake_release.store(released, Relaxed);
        Board::set_brake(&mut self.sim, !released);
    }
    fn brake_engaged(&mut self) -> bool {
        let Ok(low) = self.brake_release.is_low();
        low
    }
    fn amplifier_fault(&mut self) -> bool {
        let Ok(low) = self.fault_n.is_low();
        low
    }
    /// The simulated arm's index pulses (the link session's arm has marks). The counts are
    /// the plant's encoder's: the link session's wiring is the identity (`wiring`: not
    /// reversed, 16384 counts a revolution); its miswired bring-up builds boot declared and do
    /// not home.
    #[cfg(feature = "link-session")]
    fn homing_inputs(&mut self) -> flexarm_core::homing::Inputs<f32> {
        Board::homing_inputs(&mut self.sim)
    }
    fn motor_period(&mut self, t: f32) {
        self.run.observe(&self.sim.arm, self.sim.diverged, t);
    }
    /// One plant step per piezo period. The board's motor period is ten of its piezo periods
    /// (the piezo loop starts it, `crate::app::piezo_loop`), so the plant, the piezo loop and
    /// the motor loop keep one time: the plant's.
    fn tick(&mut self) {
        self.step_plant();
    }
}

/// A model of the RCC and flash interface with a crystal that never starts, for the QEMU
/// `inject-no-crystal` run (QEMU models no RCC: its registers read 0, so no oscillator, the
/// internal one included, would ever report ready). The internal oscillator runs; the PLL locks
/// when it is fed from it (PLLSRC = HSI) and never from the dead crystal; the system clock
/// switch follows SW to a source that is ready. The option bytes have brown-out level 3, as a
/// commissioned board's.
#[cfg(feature = "inject-no-crystal")]
struct DeadCrystal {
    regs: [u32; 6],
}

#[cfg(feature = "inject-no-crystal")]
impl DeadCrystal {
    /// The registers at reset (RM0090): CR HSION | HSIRDY | HSITRIM = 16, PLLCFGR 0x24003010,
    /// CSR with the pin and power-on reset flags, OPTCR with BOR_LEV = 0b00 (level 3).
    const fn new() -> Self {
        Self {
            regs: [0x0000_0083, 0x2400_3010, 0, 0x0C00_0000, 0, 0x0FFF_AAE1],
        }
    }

    /// 168 MHz from the internal oscillator, as the model's registers were left: PLL on and
    /// locked, fed from HSI with `pll`'s dividers, the system clock switched to it, 5 flash
    /// wait states, the crystal off.
    fn on_internal_pll(&self, pll: super::pll::Pll) -> bool {
        use super::clocks::Reg;
        let [cr, pllcfgr, cfgr, acr] = [Reg::RccCr, Reg::RccPllcfgr, Reg::RccCfgr, Reg::FlashAcr]
            .map(|r| super::clocks::Regs::read(self, r));
        cr & (1 << 25) != 0
            && cr & (1 << 16) == 0
            && pllcfgr & 0x0F43_7FFF == pll.pllcfgr()
            && (cfgr >> 2) & 0b11 == 0b10
            && acr & 0xF == 5
    }
}

#[cfg(feature = "inject-no-crystal")]
impl super::clocks::Regs for DeadCrystal {
    fn read(&self, reg: super::clocks::Reg) -> u32 {
        self.regs[reg as usize]
    }
    fn write(&mut self, reg: super::clocks::Reg, value: u32) {
        use super::clocks::Reg;
        let v = match reg {
            Reg::RccCr => {
                // HSIRDY follows HSION, HSERDY never sets, PLLRDY follows PLLON from HSI.
                let hsi = value & 1;
                let pll_from_hsi = self.regs[Reg::RccPllcfgr as usize] & (1 << 22) == 0;
                let pll = u32::from(value & (1 << 24) != 0 && pll_from_hsi);
                (value & !((1 << 1) | (1 << 17) | (1 << 25))) | (hsi << 1) | (pll << 25)
            }
            Reg::RccCfgr => {
                // SWS (bits 2–3) follows SW (bits 0–1) to a ready source.
                let cr = self.regs[Reg::RccCr as usize];
                let sw = value & 0b11;
                let ready = match sw {
                    0b00 => true,
                    0b01 => cr & (1 << 17) != 0,
                    _ => cr & (1 << 25) != 0,
                };
                let sws = if ready {
                    sw
                } else {
                    (self.regs[reg as usize] >> 2) & 0b11
                };
                (value & !0b1100) | (sws << 2)
            }
            // RMVF clears the reset flags.
            Reg::RccCsr if value & (1 << 24) != 0 => value & 0x00FF_FFFF,
            _ => value,
        };
        self.regs[reg as usize] = v;
    }
}

/// Whether the `inject-no-crystal` run's start-up left its model at 168 MHz from the internal
/// oscillator (`verdict::judge` requires it).
#[cfg(feature = "inject-no-crystal")]
pub static ON_INTERNAL_PLL: AtomicBool = AtomicBool::new(false);

/// The clock start-up on [`DeadCrystal`]: what it reports, and what it left in the model's
/// registers ([`ON_INTERNAL_PLL`]).
#[cfg(feature = "inject-no-crystal")]
pub fn start_on_dead_crystal() -> super::clocks::Startup {
    let mut rcc = DeadCrystal::new();
    let startup = super::clocks::start(&mut rcc);
    let pll = super::pll::expect(super::pll::pll_for(super::pll::HSI_HZ));
    ON_INTERNAL_PLL.store(rcc.on_internal_pll(pll), Relaxed);
    startup
}

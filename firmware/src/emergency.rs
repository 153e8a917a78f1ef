//! The last line of defence: what runs when the firmware itself fails.
//!
//! A panic, a HardFault, a non-maskable interrupt (the clock security system's, when the crystal
//! stops) and any interrupt nobody handles all end here. Each handler first masks interrupts (so
//! no control task can run again and re-enable anything), then forces the safe outputs through
//! [`force_safe_outputs`], a few register writes with no lock, no RAM state and no call into the
//! controller, and only then logs. It then stops: on the hardware board the watchdog, no longer
//! fed, resets the chip within its timeout, and the firmware boots with the amplifiers disabled
//! and [`flexarm_core::Fault::Watchdog`] latched; under QEMU it exits through semihosting.
//!
//! On the hardware board the reset handler drives the same outputs safe before RAM is
//! initialized (`board::pre_init`), and `init` calls [`force_safe_outputs`] before anything
//! else too (an external pull-down holds the enable low while the chip is in reset:
//! `docs/firmware.md`). `scripts/fw-elf-check` checks in the built hardware ELF that the reset
//! handler calls `__pre_init` first and that every handler and `init` call
//! [`force_safe_outputs`] first.

use core::sync::atomic::{Ordering::SeqCst, compiler_fence};

use flexarm_core::Fault;

/// Masks interrupts and forces the safe outputs: amplifiers disabled, brakes engaged, both
/// motor commands at 50 % duty (zero torque), the piezo command at mid-scale (0 V).
#[inline(always)]
pub fn stop_outputs() {
    cortex_m::interrupt::disable();
    compiler_fence(SeqCst);
    force_safe_outputs();
}

/// The safe outputs of the hardware board, written to the registers directly (RM0090).
#[cfg(feature = "hw")]
#[inline(never)]
pub fn force_safe_outputs() {
    use crate::board::hw::{BRAKE_PIN, DAC_MID, ENABLE_PIN};
    use stm32f4::stm32f405::{DAC, GPIOB, RCC, TIM12};
    // SAFETY: plain writes to documented fields, valid in any state of the peripherals: with a
    // peripheral's clock off its writes are ignored, and the GPIOB clock is turned on first.
    // Nothing else runs meanwhile (interrupts are masked, or this is the first line of `init`).
    unsafe {
        let (rcc, gpiob) = (&*RCC::ptr(), &*GPIOB::ptr());
        // GPIOB clock on (AHB1ENR bit 1), then the enable and brake-release pins low (BSRR
        // reset bits, one store), then the pins outputs (MODER = 0b01), so that they are
        // driven low the moment they drive: amplifiers off, brakes engaged.
        rcc.ahb1enr().modify(|r, w| w.bits(r.bits() | (1 << 1)));
        gpiob.bsrr().write(|w| {
            w.bits((1 << (16 + u32::from(ENABLE_PIN))) | (1 << (16 + u32::from(BRAKE_PIN))))
        });
        let (e, b) = (2 * u32::from(ENABLE_PIN), 2 * u32::from(BRAKE_PIN));
        gpiob.moder().modify(|r, w| {
            w.bits((r.bits() & !((0b11 << e) | (0b11 << b))) | (0b01 << e) | (0b01 << b))
        });
        // Motor commands at 50 % duty: half the period ARR + 1.
        let tim12 = &*TIM12::ptr();
        let half = tim12.arr().read().bits().div_ceil(2);
        tim12.ccr1().write(|w| w.bits(half));
        tim12.ccr2().write(|w| w.bits(half));
        // Piezo command at mid-scale.
        (*DAC::ptr())
            .dhr12r1()
            .write(|w| w.bits(u32::from(DAC_MID)));
    }
}

/// The safe outputs of the QEMU board: its output record (the simulated plant is not reached
/// from here; the run ends right after).
#[cfg(feature = "qemu")]
#[inline(never)]
pub fn force_safe_outputs() {
    crate::board::sim::OUTPUTS.force_safe();
}

/// What a failed run ends with: the fault recorder frozen and sealed for the reset (its first
/// fault kept, else [`Fault::Watchdog`], the fault the board boots with after the reset), the
/// outputs logged, then the stop.
fn stop(what: &str) -> ! {
    crate::retained::freeze(Fault::Watchdog);
    // The reset run (`inject-reset`): QEMU has no watchdog; a system reset instead, whose RAM
    // the next boot finds the recorder in.
    #[cfg(feature = "inject-reset")]
    {
        defmt::warn!("{=str}: recorder frozen; system reset", what);
        cortex_m::peripheral::SCB::sys_reset();
    }
    #[cfg(all(feature = "qemu", not(feature = "inject-reset")))]
    {
        use cortex_m_semihosting::debug::{EXIT_FAILURE, EXIT_SUCCESS, exit};
        let o = crate::board::sim::OUTPUTS.snapshot();
        defmt::error!(
            "{=str}: outputs forced safe: enable {=bool}, brake released {=bool}, tau = ({=f32}, {=f32}) N*m, V_a = {=f32} V",
            what,
            o.enable,
            o.brake_release,
            o.tau[0],
            o.tau[1],
            o.v_a
        );
        // The injection builds pass when a live arm (enabled before) ended with safe outputs.
        let expected = cfg!(feature = "inject-panic")
            || cfg!(feature = "inject-hardfault")
            || cfg!(feature = "inject-stack-overflow");
        let ok = expected && o.was_enabled && o.is_safe();
        if ok {
            defmt::info!(
                "PASS: {=str} forced the safe outputs before anything else",
                what
            );
        }
        exit(if ok { EXIT_SUCCESS } else { EXIT_FAILURE });
    }
    #[cfg(feature = "hw")]
    defmt::error!(
        "{=str}: outputs forced safe; halting until the watchdog resets",
        what
    );
    #[allow(unreachable_code)]
    loop {
        cortex_m::asm::wfi();
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    stop_outputs();
    // The message only when it is a plain string, and the location: formatting the arguments
    // would link `core::fmt` (about 3 KiB of flash) for a message the location already points
    // to.
    let message = info.message().as_str().unwrap_or("(formatted message)");
    match info.location() {
        Some(l) => defmt::error!(
            "panic: {=str} at {=str}:{=u32}",
            message,
            l.file(),
            l.line()
        ),
        None => defmt::error!("panic: {=str}", message),
    }
    stop("panic")
}

unsafe extern "C" {
    /// Top of the stack (cortex-m-rt).
    static _stack_start: u32;
}

/// The HardFault vector. A stack overflow runs the stack pointer off the bottom of RAM (flip-link
/// puts the stack there), so the handler must not push anything on the faulting stack: it first
/// moves the stack pointer back to the top of the stack (whatever was there is lost with the
/// fault) and only then enters Rust, with the old stack pointer as its argument.
#[unsafe(no_mangle)]
#[unsafe(naked)]
pub unsafe extern "C" fn HardFault() -> ! {
    core::arch::naked_asm!(
        "mrs r0, msp",
        "ldr r1, ={top}",
        "msr msp, r1",
        "b {handler}",
        top = sym _stack_start,
        handler = sym hard_fault,
    )
}

/// The HardFault handler proper, on a fresh stack; `sp` is the stack pointer at the fault.
extern "C" fn hard_fault(sp: u32) -> ! {
    stop_outputs();
    // The exception frame's PC is at sp + 24, if the frame was written inside RAM.
    let (bottom, top) = crate::stack::bounds();
    let sp = sp as usize;
    if sp >= bottom && sp + 32 <= top {
        // SAFETY: a word of the stack region, word-aligned (exception frames are).
        let pc = unsafe { core::ptr::read_volatile((sp + 24) as *const u32) };
        defmt::error!("HardFault at pc {=u32:#x}", pc);
    } else {
        defmt::error!("HardFault: stack overflow (sp {=u32:#x})", sp as u32);
    }
    stop("HardFault")
}

#[cortex_m_rt::exception]
unsafe fn NonMaskableInt() {
    stop_outputs();
    // The clock security system: acknowledge (RCC_CIR.CSSC) so the NMI does not repeat.
    // SAFETY: CSSC is a write-1-to-clear bit; the other bits written 0 change nothing.
    #[cfg(feature = "hw")]
    unsafe {
        (*stm32f4::stm32f405::RCC::ptr())
            .cir()
            .write(|w| w.bits(1 << 23));
    }
    defmt::error!("NMI: the crystal stopped (clock security system)");
    stop("NMI")
}

#[cortex_m_rt::exception]
unsafe fn DefaultHandler(irqn: i16) {
    stop_outputs();
    defmt::error!("unexpected interrupt {=i16}", irqn);
    stop("unexpected interrupt")
}

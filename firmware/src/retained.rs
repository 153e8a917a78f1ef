//! State that survives a reset (`flexarm_core::retained`): the fault recorder and the motors'
//! heat store, in RAM that the start-up does not zero (cortex-m-rt's `.uninit` section, after
//! `.bss`; `docs/firmware.md`, "What survives a reset"). Only the statics are here; what is
//! valid after a reset, the magic numbers and the checksums are the core's
//! (`Recorder::restore`, `Drive::restore_heat`).

use core::mem::MaybeUninit;

use flexarm_core::Fault;
use flexarm_core::retained::HeatStore;
use flexarm_machine::period::FaultRecorder;

/// The fault recorder, sealed when it freezes.
#[unsafe(link_section = ".uninit.flexarm.recorder")]
static mut RECORDER: MaybeUninit<FaultRecorder> = MaybeUninit::uninit();

/// The motors' I²t states, written every motor period.
#[unsafe(link_section = ".uninit.flexarm.heat")]
static mut HEAT: MaybeUninit<HeatStore> = MaybeUninit::uninit();

/// Both stores, as RAM holds them (whatever the last run or the power-on left): `init` takes
/// them once and restores or empties them.
pub fn take() -> (&'static mut FaultRecorder, &'static mut HeatStore) {
    // SAFETY: called once, by `init`, before any task runs; the emergency handlers' `freeze`
    // is the only other access, after they masked the interrupts, and never returns to the
    // code it interrupted. Every bit pattern is a value of both types (every field is an
    // integer or a float: `flexarm_core::recorder`, `flexarm_core::retained`), so the RAM is
    // initialized whatever it holds.
    unsafe {
        (
            (*opaque(&raw mut RECORDER)).assume_init_mut(),
            (*opaque(&raw mut HEAT)).assume_init_mut(),
        )
    }
}

/// `p`, with the compiler no longer knowing what it points to. A `MaybeUninit` static's initial
/// value is undefined to the compiler, which may then take it for whatever the program stores:
/// the heat store's magic, only ever written as `HEAT_MAGIC`, was folded to it and its check
/// removed (seen in the release build: the static split into its other three words). Behind an
/// opaque pointer every read is a read of the RAM.
fn opaque<T>(p: *mut T) -> *mut T {
    core::hint::black_box(p)
}

/// An emergency path's freeze, before the reset it ends in: the recorder keeps its first fault
/// (the one the motor loop froze it with), else takes `fault`, and is sealed.
pub fn freeze(fault: Fault) {
    // SAFETY: interrupts are masked (the caller's first act) and the interrupted code never
    // runs again; a record torn by the interruption is sealed as it is (its samples' values,
    // whatever they are, are values).
    unsafe { (*opaque(&raw mut RECORDER)).assume_init_mut().freeze(fault) }
}

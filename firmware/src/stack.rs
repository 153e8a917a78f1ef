//! The stack's high-water mark. With flip-link the stack sits at the bottom of RAM, below the
//! statics, so an overflow faults instead of corrupting them; this module measures how close
//! the firmware comes. `idle` paints the stack below itself with a pattern when it starts; the
//! deepest word that no longer holds it marks the most stack any task has used since (every
//! handler runs on the one main stack, below `idle`'s frame).
//!
//! Why `idle` and not `init`: whatever lies below `idle`'s stack pointer is dead whenever `idle`
//! runs (a handler that preempts it pushes its frames there and pops them before `idle` resumes),
//! so `idle` may paint it at any time, with the timers already running. Painting 127 KiB in
//! `init` would delay the timers' start, which under QEMU changes its timers' relative rates.

use core::ptr::{addr_of, read_volatile, write_volatile};

/// The paint.
const PAINT: u32 = 0x5AA5_C33C;
/// Bytes left unpainted below the stack pointer at the time of painting (the caller's frames).
const MARGIN: usize = 64;

unsafe extern "C" {
    /// Lowest address the stack may reach (cortex-m-rt; the bottom of RAM with flip-link).
    static _stack_end: u32;
    /// Top of the stack, where it starts (cortex-m-rt).
    static _stack_start: u32;
}

/// `(bottom, top)` of the stack region [addresses].
pub fn bounds() -> (usize, usize) {
    // Only the addresses of the linker symbols are taken, never their contents.
    (
        addr_of!(_stack_end) as usize,
        addr_of!(_stack_start) as usize,
    )
}

/// Size of the stack region [bytes].
pub fn size() -> u32 {
    let (bottom, top) = bounds();
    (top - bottom) as u32
}

/// Paints the stack from its bottom up to `MARGIN` below the current stack pointer. Call once,
/// from `idle` (module docs).
pub fn paint() {
    let (bottom, _) = bounds();
    let sp = cortex_m::register::msp::read() as usize;
    let mut p = bottom;
    while p + 4 <= sp.saturating_sub(MARGIN) {
        // SAFETY: every word in [bottom, sp − MARGIN) is stack below `idle`'s live frames: no
        // frame lives there while `idle` runs (module docs); word-aligned (both bounds are).
        unsafe { write_volatile(p as *mut u32, PAINT) };
        p += 4;
    }
}

/// The most stack used since `paint` [bytes]: from the top down to the deepest word whose paint
/// was overwritten.
pub fn used() -> u32 {
    let (bottom, top) = bounds();
    let mut p = bottom;
    // SAFETY: reads of words inside the stack region, word-aligned.
    while p < top && unsafe { read_volatile(p as *const u32) } == PAINT {
        p += 4;
    }
    (top - p) as u32
}

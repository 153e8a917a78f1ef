//! The QEMU run's verdict: the bounds of `config::bounds`, no deadline miss, and the fault the
//! run was built to inject (none for a plain run).

use flexarm_core::Fault;

use crate::config::bounds;
use crate::stats;

include!(concat!(env!("OUT_DIR"), "/budgets.rs"));

/// The fault an injection build expects; `None` for the plain run.
const EXPECTED_FAULT: Option<Fault> = if cfg!(feature = "inject-nan") {
    Some(Fault::NonFinite)
} else if cfg!(feature = "inject-overrun") || cfg!(feature = "inject-piezo-stall") {
    Some(Fault::Overrun)
} else if cfg!(feature = "inject-no-crystal") {
    Some(Fault::Clock)
} else {
    None
};

/// Logs the figures and returns whether the run passed.
pub fn judge(
    max_error: f32,
    tail_error: f32,
    max_tip: f32,
    final_tip: f32,
    fault: Option<Fault>,
    enabled: bool,
) -> bool {
    let misses = stats::PIEZO.misses() + stats::MOTOR.misses();
    let stack = crate::stack::used();
    let stack_ok = stack <= BUDGET_STACK_QEMU;
    defmt::info!(
        "stack: {=u32} of {=u32} bytes used (budget {=u32}, firmware/budgets.txt)",
        stack,
        crate::stack::size(),
        BUDGET_STACK_QEMU
    );
    if !stack_ok {
        defmt::error!("FAIL: the stack used more than its budget");
        return false;
    }
    defmt::info!(
        "run: max |θ − θ_d| {=f32} rad (bound {=f32}), last-3-s mean {=f32} rad (bound {=f32}), max |tip| {=f32} m (bound {=f32}), final |tip| {=f32} m (bound {=f32}), deadline misses {=u32}",
        max_error,
        bounds::MAX_ERROR,
        tail_error,
        bounds::TAIL_ERROR,
        max_tip,
        bounds::MAX_TIP,
        final_tip,
        bounds::FINAL_TIP,
        misses
    );
    match (EXPECTED_FAULT, fault) {
        (None, None) => {
            let ok = max_error <= bounds::MAX_ERROR
                && tail_error <= bounds::TAIL_ERROR
                && max_tip <= bounds::MAX_TIP
                && final_tip <= bounds::FINAL_TIP
                && misses == 0;
            if ok {
                defmt::info!("PASS: tracking and vibration within bounds, no deadline missed");
            } else {
                defmt::error!("FAIL: a bound was exceeded or a deadline missed");
            }
            ok
        }
        // A clock failure is latched before the first motor step: the amplifiers must never
        // have been enabled at all.
        (Some(Fault::Clock), Some(Fault::Clock))
            if crate::board::sim::OUTPUTS.snapshot().was_enabled =>
        {
            defmt::error!("FAIL: clock fault latched, but the amplifiers were enabled");
            false
        }
        (Some(want), Some(got)) if want == got && !enabled => {
            defmt::info!(
                "PASS: injected fault latched as {=str}; outputs held safe",
                got.as_str()
            );
            true
        }
        (want, got) => {
            defmt::error!(
                "FAIL: expected fault {=str}, got {=str}",
                want.map_or("none", Fault::as_str),
                got.map_or("none", Fault::as_str)
            );
            false
        }
    }
}

//! The QEMU verdict runs (`cargo fw-qemu`, the injection and uptime runs): the QEMU board
//! measures its plant against the boot move every motor period ([`RunCheck`]); at the end the
//! verdict is the bounds of `config::bounds`, no deadline miss, and the fault the run was built
//! to inject (none for a plain run). The application only starts the move and, at the end,
//! exits with the verdict; a link session (`link-session`) has neither: its host judges it.

use flexarm_core::Fault;
use flexarm_core::simarm::SimArm;

use crate::config::{self, bounds};
use crate::stats;

include!(concat!(env!("OUT_DIR"), "/budgets.rs"));

/// The fault an injection build expects; `None` for the plain run.
const EXPECTED_FAULT: Option<Fault> = if cfg!(feature = "inject-nan") {
    Some(Fault::NonFinite)
} else if cfg!(feature = "inject-overrun") || cfg!(feature = "inject-piezo-stall") {
    Some(Fault::Overrun)
} else if cfg!(feature = "inject-no-crystal") {
    Some(Fault::Clock)
} else if cfg!(feature = "inject-reversed-encoder") {
    Some(Fault::Runaway)
} else if cfg!(feature = "inject-frozen-encoder") {
    Some(Fault::FrozenEncoder)
} else if cfg!(feature = "inject-brake-stuck") {
    Some(Fault::BrakeSlip)
} else {
    None
};

/// What the verdict run measures of the plant (the true arm, not the controller's estimate).
#[derive(Default)]
pub struct RunCheck {
    max_error: f32,
    tail_error_sum: f32,
    tail_samples: u32,
    max_tip: f32,
    final_tip: f32,
    /// The run's time is up.
    pub finished: bool,
}

impl RunCheck {
    /// One motor period at `t` [s] since the boot move's start (the paper's trapezoid).
    pub fn observe(&mut self, arm: &SimArm<f32>, diverged: bool, t: f32) {
        let x = arm.x;
        let desired = flexarm_core::trajectory::Trapezoid::<f32>::paper()
            .sample(t)
            .q;
        let err = (flexarm_core::Vector2::new(x.q.x, x.q.y) - desired)
            .abs()
            .max();
        self.max_error = self.max_error.max(err);
        if t >= config::RUN_SECONDS - 3.0 {
            self.tail_error_sum += err;
            self.tail_samples += 1;
        }
        let tip = arm.model.tip_deflection(&x.q).abs();
        self.max_tip = self.max_tip.max(tip);
        self.final_tip = tip;
        if diverged {
            self.max_error = f32::INFINITY;
        }
        if t >= config::RUN_SECONDS {
            self.finished = true;
        }
    }
}

/// Logs the figures and returns whether the run passed, given the latched fault, whether the
/// outputs are live now (the enable line on or the brake released) and the fault recorder's
/// fault and seal.
pub fn judge(
    c: &RunCheck,
    fault: Option<Fault>,
    enabled: bool,
    recorded: (Option<Fault>, bool),
) -> bool {
    // A stalled loop's overrun is latched by the supervisor, not by the motor loop that freezes
    // the recorder: the supervisor must have frozen and sealed it (issue 33).
    if cfg!(feature = "inject-piezo-stall") && recorded != (EXPECTED_FAULT, true) {
        defmt::error!(
            "FAIL: the fault recorder was not frozen and sealed with the overrun (it holds {=str}, sealed {=bool})",
            recorded.0.map_or("none", Fault::as_str),
            recorded.1
        );
        return false;
    }
    let (max_error, max_tip, final_tip) = (c.max_error, c.max_tip, c.final_tip);
    let tail_error = c.tail_error_sum / c.tail_samples.max(1) as f32;
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
        // On a dead crystal the chip must still reach 168 MHz, from its internal oscillator.
        #[cfg(feature = "inject-no-crystal")]
        (Some(Fault::Clock), Some(Fault::Clock))
            if !crate::board::sim::ON_INTERNAL_PLL.load(core::sync::atomic::Ordering::Relaxed) =>
        {
            defmt::error!(
                "FAIL: clock fault latched, but the start-up did not run the PLL from the internal oscillator at 168 MHz"
            );
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

/// The reset run's second boot (`inject-reset`): the first boot panicked in the motor loop at
/// t = 1 s, whose handler froze the recorder ([`Fault::Watchdog`]: no fault had latched) and
/// reset the system. Reads the recorder as a host would, through the link's replies to
/// `Faults` (`Session::answer`), and passes only if it holds the pre-reset fault and every
/// sample up to the panic's period (ticks 0 to 100, one a period at 100 Hz), and the motors'
/// heat was restored from its store (the first boot's motors were assumed hot, 0.9, and
/// cooled: a restored heat is below that and above 0). Then exits.
#[cfg(feature = "inject-reset")]
pub fn after_reset(
    session: &mut flexarm_machine::session::Session,
    control: &mut flexarm_machine::period::Control,
    drive: &mut flexarm_core::drive::Drive<f32>,
    recorder: &mut flexarm_machine::period::FaultRecorder,
    heat_restored: bool,
) -> ! {
    use cortex_m_semihosting::debug::{EXIT_FAILURE, EXIT_SUCCESS, exit};
    use flexarm_link::{Command, Reply};
    let io = flexarm_machine::session::Io {
        y: flexarm_core::observer::Measurement {
            theta: flexarm_core::Vector2::zeros(),
            v_f: 0.0,
        },
        amplifier_fault: false,
        ticks: 0,
        dropped: 0,
        rx_bytes: 0,
        rx_lost: 0,
        rx_line: Default::default(),
        stack_used: 0,
        loads: [flexarm_link::msg::Load::default(); 2],
        brake_engaged: true,
    };
    let mut page =
        |from: u16| match session.answer(Command::Faults { from }, control, drive, recorder, &io) {
            Reply::Faults(p) => Some((
                p.fault,
                p.total,
                p.samples.first().map(|s| s.tick),
                p.samples.last().map(|s| s.tick),
            )),
            _ => None,
        };
    let first = page(0);
    let total = first.map_or(0, |p| p.1);
    let last = page(total.saturating_sub(1));
    let expected_last = u64::from(config::MOTOR_HZ);
    let heat = drive.monitor().heat;
    let hot = drive.motion.thermal.assumed_hot();
    defmt::info!(
        "after the reset: the link's fault page: fault {=?}, {=u16} samples, ticks {=?} to {=?}; motor heat restored {=bool}: ({=f32}, {=f32})",
        first.and_then(|p| p.0),
        total,
        first.and_then(|p| p.2),
        last.and_then(|p| p.3),
        heat_restored,
        heat.x,
        heat.y
    );
    let ok = first.and_then(|p| p.0) == Some(Fault::Watchdog as u8)
        && u64::from(total) == expected_last + 1
        && first.and_then(|p| p.2) == Some(0)
        && last.and_then(|p| p.3) == Some(expected_last)
        && heat_restored
        && heat.x > 0.0
        && heat.x < hot
        && heat.y > 0.0
        && heat.y < hot;
    if ok {
        defmt::info!("PASS: the fault recorder and the motors' heat survived the reset");
    } else {
        defmt::error!("FAIL: the fault recorder or the heat did not survive the reset");
    }
    exit(if ok { EXIT_SUCCESS } else { EXIT_FAILURE });
    #[allow(clippy::empty_loop)]
    loop {}
}

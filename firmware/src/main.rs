//! # flexarm firmware
//!
//! RTIC 2 application for an STM32F405. The tasks follow the block diagram:
//!
//! | task | trigger | priority | does |
//! |---|---|---|---|
//! | `piezo_loop` | TIM2 (10 kHz; 1 kHz under QEMU) | 3 | film voltage → `V_a = sat(−k_c V̇_f)` → piezo amplifier |
//! | `motor_loop` | TIM3 (1 kHz; 100 Hz under QEMU) | 2 | encoders + film → observer → Eq. 7/16 → motor amplifiers |
//! | `supervisor` | TIM4 (10 Hz) | 1 | liveness of both loops, watchdog, enable line, load report |
//! | `link_rx` | USART1 | 1 | QEMU: moves the command link's bytes into a queue; hardware: counts the line errors, and its return after the line's idle event wakes `idle` to read the DMA buffer |
//! | `link_halves` | DMA2 stream 2 (hardware) | 4 | counts the receive DMA's half-buffer events (`link::dma`) |
//! | `idle` | — | 0 | telemetry to defmt; the command link: decodes, answers, streams (`link`); the hardware board's stack report |
//!
//! What the tasks do each period is `flexarm-machine`'s: the phases of a piezo and a motor
//! period (`flexarm_machine::period`) over `flexarm-core`'s controller and drive, the telemetry
//! record, the link session (`flexarm_machine::session`) and the board's configuration
//! (`config::board`). Each task locks what its phase needs and calls it; what stays here is the
//! hardware: registers, clocks, the USART, the emergency paths, the stack and fault injection.
#![no_std]
#![no_main]
// The QEMU link-session build has no boot move and no end-of-run verdict: the verdict's code
// (`verdict`, the stack report) is compiled but unused there; the reset run (`inject-reset`)
// leaves the emergency path's output log unused.
#![cfg_attr(
    any(feature = "link-session", feature = "inject-reset"),
    allow(dead_code)
)]

// The register code: the only `unsafe` of the workspace (its lints deny it everywhere else).
mod board;
#[allow(unsafe_code)]
mod clock;
mod config;
#[allow(unsafe_code)]
mod emergency;
#[allow(unsafe_code)]
mod stack;
/// The generated parameters (`cargo sim firmware-params`): `src/generated.rs`, from
/// `firmware/piezo.toml`, or the file `FLEXARM_PARAMS` names at build time (build.rs copies it
/// in). Each board uses one of its two observer gain tables.
#[allow(dead_code)]
mod generated {
    include!(concat!(env!("OUT_DIR"), "/generated.rs"));
}
#[allow(unsafe_code)]
mod link;
#[allow(unsafe_code)]
mod retained;
mod settings;
mod stats;
mod telemetry;

#[cfg(feature = "hw")]
use defmt_rtt as _;
#[cfg(feature = "qemu")]
use defmt_semihosting as _;

#[cfg(not(any(feature = "qemu", feature = "hw")))]
compile_error!("select a board: feature `hw` (default) or `qemu` (with --no-default-features)");
#[cfg(all(feature = "qemu", feature = "hw"))]
compile_error!(
    "features `qemu` and `hw` exclude each other: build `qemu` with --no-default-features"
);

#[rtic::app(device = stm32f4::stm32f405, peripherals = true)]
mod app {
    use core::sync::atomic::{AtomicU32, Ordering::Relaxed};

    use flexarm_core::drive::{Drive, MoveRequest};
    use flexarm_core::retained::HeatStore;
    use flexarm_core::time::MoveClock;
    use flexarm_core::trajectory::{JointTrajectory, Trapezoid};
    use flexarm_core::{Fault, Vector2};
    use flexarm_machine::period::{self, Control, FaultRecorder, MotorLoop};
    use flexarm_machine::session::{self, Identity, Session, Snapshot};
    use heapless::spsc::{Consumer, Producer};
    #[cfg(feature = "qemu")]
    use rtic::Mutex;
    use stm32f4::stm32f405::{TIM2, TIM3, TIM4};

    use crate::board::Board;
    use crate::config::{self, MOTOR_HZ, PIEZO_HZ, SUPERVISOR_HZ, TIMER_CLOCK_HZ};
    use crate::telemetry::{self, Record};
    use crate::{clock, stats};

    #[cfg(feature = "hw")]
    use crate::board::hw::HwBoard as BoardImpl;
    #[cfg(feature = "qemu")]
    use crate::board::sim::SimBoard as BoardImpl;

    /// Motor steps done, for the supervisor's liveness check.
    static MOTOR_HEARTBEAT: AtomicU32 = AtomicU32::new(0);
    /// Piezo steps done, for the supervisor's liveness check.
    static PIEZO_HEARTBEAT: AtomicU32 = AtomicU32::new(0);
    /// Link bytes lost because the receive queue was full (QEMU), or because the receive DMA
    /// overtook the reader or had stopped (hardware: `link::dma`, `flexarm_link::ring`).
    static RX_OVERFLOWS: AtomicU32 = AtomicU32::new(0);
    /// The hardware board's stack report is due (the supervisor asks each second, `idle`
    /// scans: issue 34, the scan's millisecond at the link's priority cost received bytes).
    #[cfg(feature = "hw")]
    static STACK_REPORT_DUE: core::sync::atomic::AtomicBool =
        core::sync::atomic::AtomicBool::new(false);
    /// Link bytes received.
    static RX_BYTES: AtomicU32 = AtomicU32::new(0);
    /// The receiver's line errors (`flexarm_link::msg::LineErrors`): overruns, framing or
    /// parity errors, noise.
    static RX_OVERRUNS: AtomicU32 = AtomicU32::new(0);
    static RX_FRAMING: AtomicU32 = AtomicU32::new(0);
    static RX_NOISE: AtomicU32 = AtomicU32::new(0);
    /// Telemetry records the motor loop could not queue.
    static TELEMETRY_DROPS: AtomicU32 = AtomicU32::new(0);

    #[shared]
    struct Shared {
        control: Control,
        drive: Drive<f32>,
        recorder: &'static mut FaultRecorder,
        board: BoardImpl,
    }

    #[local]
    struct Local {
        tim2: TIM2,
        tim3: TIM3,
        tim4: TIM4,
        producer: Producer<'static, Record>,
        consumer: Consumer<'static, Record>,
        #[cfg(feature = "qemu")]
        rx_producer: Producer<'static, u8>,
        #[cfg(feature = "qemu")]
        rx_consumer: Consumer<'static, u8>,
        #[cfg(feature = "qemu")]
        rx: crate::link::Receiver,
        #[cfg(feature = "hw")]
        rx_ring: crate::link::dma::Ring,
        #[cfg(feature = "hw")]
        dma2: stm32f4::stm32f405::DMA2,
        serial: crate::link::Serial,
        session: Session,
        store: Option<crate::settings::BoardStore>,
        snapshot: Snapshot,
        piezo_ticks: u32,
        motor: MotorLoop,
        heat_store: &'static mut HeatStore,
        move_clock: MoveClock,
        last_heartbeat: u32,
        supervisor_ticks: u32,
        reported_fault: bool,
        last_piezo_beat: u32,
        #[cfg(feature = "hw")]
        iwdg: stm32f4::stm32f405::IWDG,
    }

    /// Configures a timer to raise its update interrupt every `period` input-clock counts.
    /// CNT is written last (a QEMU timer pitfall); nothing touches CNT or EGR afterwards.
    macro_rules! periodic {
        ($tim:expr, $period:expr, $psc:expr) => {{
            let tim = &$tim;
            tim.cr1().write(|w| w.cen().clear_bit());
            tim.psc().write(|w| w.psc().set(($psc - 1) as u16));
            tim.arr()
                .write(|w| w.arr().set((($period / $psc) - 1) as _));
            tim.egr().write(|w| w.ug().set_bit());
            tim.sr().write(|w| w.uif().clear_bit());
            tim.dier().write(|w| w.uie().set_bit());
            tim.cr1().write(|w| w.cen().set_bit());
            tim.cnt().write(|w| w.cnt().set(0));
        }};
    }

    #[init(local = [
        queue: telemetry::Queue = telemetry::Queue::new(),
        #[cfg(feature = "qemu")]
        rx_queue: crate::link::RxQueue = crate::link::RxQueue::new(),
    ])]
    fn init(cx: init::Context) -> (Shared, Local) {
        let dp = cx.device;
        // The mutation scripts/fw-elf-check must reject: the clock start-up first.
        #[cfg(feature = "mutant-clocks-first")]
        let startup = crate::board::clocks::start(&mut crate::board::clocks::Chip {
            rcc: &dp.RCC,
            flash: &dp.FLASH,
        });
        // Before anything else (the crystal wait included): amplifiers disabled, commands safe.
        crate::emergency::force_safe_outputs();
        // The crystal, the PLL and the reset cause. The QEMU board models no RCC and runs at
        // the timers' fixed rate; its `inject-no-crystal` build runs the start-up on a model of
        // an RCC whose crystal never starts.
        #[cfg(all(feature = "hw", not(feature = "mutant-clocks-first")))]
        let startup = crate::board::clocks::start(&mut crate::board::clocks::Chip {
            rcc: &dp.RCC,
            flash: &dp.FLASH,
        });
        #[cfg(feature = "inject-no-crystal")]
        let startup = crate::board::sim::start_on_dead_crystal();

        // Timers: TIM2 piezo, TIM3 motor, TIM4 supervisor, TIM5 free-running clock.
        dp.RCC.apb1enr().modify(|_, w| {
            w.tim2en()
                .set_bit()
                .tim3en()
                .set_bit()
                .tim4en()
                .set_bit()
                .tim5en()
                .set_bit()
        });
        #[cfg(feature = "qemu")]
        {
            dp.TIM5.psc().write(|w| w.psc().set(0));
            dp.TIM5.arr().write(|w| w.arr().set(u32::MAX));
            dp.TIM5.cr1().write(|w| w.cen().set_bit());
            dp.TIM5.cnt().write(|w| w.cnt().set(0));
        }
        #[cfg(not(feature = "qemu"))]
        {
            let mut cp = cx.core;
            cp.DCB.enable_trace();
            cp.DWT.enable_cycle_counter();
        }

        let cfg = config::CONFIG;
        let mut ctrl = cfg.controller(JointTrajectory::Trapezoid(Trapezoid::paper()));
        // The first cause is kept: a clock failure explains a watchdog reset, not the reverse.
        #[cfg(any(feature = "hw", feature = "inject-no-crystal"))]
        {
            if startup.source != crate::board::clocks::Source::Crystal {
                ctrl.trip(Fault::Clock);
                defmt::error!(
                    "clock: {=str}; the amplifiers stay off",
                    startup.source.as_str()
                );
            }
            if !startup.brown_out_reset_on {
                ctrl.trip(Fault::BrownOutDisabled);
            }
            if startup.reset_by_watchdog {
                ctrl.trip(Fault::Watchdog);
            }
        }

        #[cfg(feature = "qemu")]
        // The simulated arm plays the physical arm: the paper's, with the firmware's patch on
        // it, whatever model the controller runs (the paper's by default, or one identified on
        // this arm, docs/identification.md).
        let board = BoardImpl::new({
            #[allow(unused_mut)]
            let mut sim = flexarm_machine::simulated::SimulatedArm::paper(
                config::qemu_patch(),
                flexarm_core::Vector4::zeros(),
                cfg.piezo_period(),
            );
            // The link session's arm has index marks, which its console session homes on
            // (scripts/qemu-link, issue 33): at 0.5 and 2.0 rad, ahead of the pose the
            // session leaves the arm at, (0, π/2).
            #[cfg(feature = "link-session")]
            {
                sim.index = [0.5, 2.0];
            }
            #[cfg(feature = "inject-brake-stuck")]
            {
                sim.brake_stuck_released = true;
            }
            sim
        });
        #[cfg(feature = "hw")]
        let board = BoardImpl::new(
            dp.GPIOA, dp.GPIOB, dp.GPIOC, dp.TIM1, dp.TIM8, dp.TIM12, dp.ADC1, dp.DAC, &dp.RCC,
        );

        // The observer starts where the encoders are.
        let mut board = board;
        ctrl.reset_observer(board.encoders());
        if let Some(f) = ctrl.fault() {
            defmt::error!("starting in the safe state: {=str}", f.as_str());
        }

        // The watchdog's timeout fits the supervisor's period on the clock that runs.
        #[cfg(feature = "hw")]
        let iwdg = {
            let supervisor_us = u64::from(TIMER_CLOCK_HZ / SUPERVISOR_HZ) * 1_000_000
                / u64::from(startup.source.timer_clock_hz());
            if !crate::board::hw::start_watchdog(&dp.IWDG, supervisor_us) {
                defmt::warn!("watchdog: PVU/RVU did not clear; its first timeout may be 4 s");
            }
            dp.IWDG
        };

        // Piezo first, then motor, then supervisor: at common instants the update events come in
        // that order, so the motor loop sees the plant the piezo loop just advanced.
        // TIM2's update event is also the film ADC's trigger (CR2 MMS = 0b010: TRGO = update),
        // set before the timer generates its first update event (RM0090, TIMx_CR2: the master
        // mode first).
        #[cfg(feature = "hw")]
        dp.TIM2.cr2().write(|w| w.mms().update());
        periodic!(dp.TIM2, TIMER_CLOCK_HZ / PIEZO_HZ, 1u32);
        // That first update event (EGR UG) started a conversion too: read it now, so that the
        // first piezo period does not take it for its own (and every later one the previous
        // period's).
        #[cfg(feature = "hw")]
        let _ = board.film_voltage();
        // The QEMU board's motor loop runs every tenth piezo period, started by the piezo loop
        // (`piezo_loop`): QEMU's timers drift against each other (its TIM2 comes 3 % late), and
        // on one clock the plant, both loops and the host's rig keep the same time.
        #[cfg(not(feature = "qemu"))]
        periodic!(
            dp.TIM3,
            TIMER_CLOCK_HZ / MOTOR_HZ,
            TIMER_CLOCK_HZ / 1_000_000
        );
        periodic!(
            dp.TIM4,
            TIMER_CLOCK_HZ / SUPERVISOR_HZ,
            TIMER_CLOCK_HZ / 100_000
        );

        // Disarmed until a host arms it; the QEMU verdict runs start the paper's move at boot.
        // After the timers start: code before them shifts the QEMU timers' phase, and with it
        // the uptime runs' equality (scripts/qemu-uptime), by its tick-dependent length.
        let mut drive = cfg.drive(&mut ctrl, config::START_TICK);
        // What survived the reset: the recorder frozen before it, and the motors' heat (or,
        // after a power cycle or a torn write, the motors assumed hot).
        let (recorder, heat_store) = crate::retained::take();
        let restored = recorder.restore();
        if restored {
            defmt::warn!(
                "fault recorder kept across the reset: {=str}, {=usize} samples",
                recorder.fault().map_or("?", |f| f.as_str()),
                recorder.len()
            );
        }
        let heat_restored = drive.restore_heat(heat_store);
        if !heat_restored {
            defmt::warn!(
                "motor heat: no valid store (power-on or a torn write): assumed hot, {=f32}; full torque once cool",
                drive.monitor().heat.x
            );
        }
        let params_hash = config::CONFIG_HASH;
        #[cfg_attr(not(feature = "inject-reset"), allow(unused_mut))]
        let mut control = Control::new(ctrl);
        #[cfg_attr(not(feature = "inject-reset"), allow(unused_mut))]
        let mut session = Session::new(
            cfg.tuning(),
            Identity {
                board: cfg.board,
                build: concat!("flexarm-firmware ", env!("CARGO_PKG_VERSION")),
                params_hash,
                motor_hz: MOTOR_HZ,
                piezo_hz: PIEZO_HZ,
                test_commands: cfg!(feature = "link-session"),
            },
        );
        // The store of the settings saved on the board: read and applied by the idle task
        // (`settings::boot`), value by value between the loops' periods.
        let store = crate::settings::take();
        // The QEMU board's simulated arm: its encoders read the plant's own angles, the arm's
        // frame, declared (issue 33; status shows it declared, not homed).
        #[cfg(feature = "qemu")]
        let _ = drive.declare_zero(&mut control.ctrl);
        if config::BOOT_MOVE && control.ctrl.fault().is_none() {
            let half_pi = core::f32::consts::FRAC_PI_2;
            let boot = MoveRequest::Trapezoid {
                target: Vector2::new(half_pi, half_pi),
                move_time: 2.0,
                ramp_time: 0.5,
            };
            let started = drive
                .arm(&mut control.ctrl, config::START_TICK)
                .and_then(|()| drive.start(&mut control.ctrl, config::START_TICK, &boot));
            if started.is_err() {
                defmt::error!("the boot move was refused by the drive's limits");
            }
        }
        let (producer, consumer) = cx.local.queue.split();
        #[cfg(feature = "qemu")]
        let (rx_producer, rx_consumer) = cx.local.rx_queue.split();
        // The hardware board receives by DMA: the stream runs before the USART requests it.
        #[cfg(feature = "hw")]
        crate::link::dma::start(&dp.DMA2, &dp.RCC);
        let serial = crate::link::Serial::new(dp.USART1, &dp.RCC);
        defmt::info!(
            "flexarm firmware: piezo loop {=u32} Hz, motor loop {=u32} Hz, supervisor {=u32} Hz; the arm model's modes {=f32} and {=f32} Hz, parameters {=u32:08x}",
            PIEZO_HZ,
            MOTOR_HZ,
            SUPERVISOR_HZ,
            cfg.arm.modes.omega.x / core::f32::consts::TAU,
            cfg.arm.modes.omega.y / core::f32::consts::TAU,
            params_hash
        );
        let snapshot = session::snapshot(&control.ctrl, &drive);
        // The reset run's second boot: the recorder read over the link's reply, then the
        // verdict (the first boot runs the move, panics at 1 s and resets).
        #[cfg(feature = "inject-reset")]
        if restored {
            crate::verdict::after_reset(
                &mut session,
                &mut control,
                &mut drive,
                recorder,
                heat_restored,
            );
        }
        (
            Shared {
                control,
                drive,
                recorder,
                board,
            },
            Local {
                tim2: dp.TIM2,
                tim3: dp.TIM3,
                tim4: dp.TIM4,
                producer,
                consumer,
                #[cfg(feature = "qemu")]
                rx_producer,
                #[cfg(feature = "qemu")]
                rx_consumer,
                #[cfg(feature = "qemu")]
                rx: crate::link::Receiver,
                #[cfg(feature = "hw")]
                rx_ring: crate::link::dma::Ring::new(),
                #[cfg(feature = "hw")]
                dma2: dp.DMA2,
                serial,
                snapshot,
                session,
                store,
                piezo_ticks: 0,
                motor: MotorLoop::new(&cfg, config::START_TICK),
                heat_store,
                // The boot move starts with the first motor period.
                move_clock: MoveClock::new(config::START_TICK, MOTOR_HZ),
                last_heartbeat: 0,
                supervisor_ticks: 0,
                reported_fault: false,
                last_piezo_beat: 0,
                #[cfg(feature = "hw")]
                iwdg,
            },
        )
    }

    /// The loops' loads: the mean execution time of the last supervisor window over the period
    /// [fraction].
    fn loads() -> [f32; 2] {
        let load = |s: &stats::TaskStats, hz: u32| s.mean() as f32 / (clock::HZ / hz) as f32;
        [load(&stats::PIEZO, PIEZO_HZ), load(&stats::MOTOR, MOTOR_HZ)]
    }

    /// Telemetry and the command link: prints queued records and streams the subscribed ones;
    /// answers the link's requests; at the end of a QEMU run, checks the bounds and exits.
    #[idle(local = [consumer, #[cfg(feature = "qemu")] rx_consumer, #[cfg(feature = "hw")] rx_ring, serial, session, store, last_tick: u64 = 0, overflows_seen: u32 = 0, stops_seen: u32 = 0, snapshot], shared = [control, drive, recorder, board])]
    fn idle(mut cx: idle::Context) -> ! {
        use crate::link;
        crate::stack::paint();
        crate::settings::boot(
            cx.local.store,
            cx.local.session,
            &mut cx.shared.control,
            &mut cx.shared.drive,
        );
        loop {
            while let Some(r) = cx.local.consumer.dequeue() {
                if !matches!(r, Record::Sample { print: false, .. }) {
                    telemetry::print(&r);
                }
                if let Record::Sample { tick, .. } = r {
                    *cx.local.last_tick = tick;
                }
                if let Some(t) = cx.local.session.telemetry(&r, loads())
                    && !link::send(
                        cx.local.serial,
                        &flexarm_link::msg::DeviceMsgRef::Telemetry(&t),
                    )
                {
                    cx.local.session.dropped();
                }
            }
            let stops = cx.shared.drive.lock(|d| d.link_stops());
            if stops != *cx.local.stops_seen {
                *cx.local.stops_seen = stops;
                defmt::warn!(
                    "link watchdog: the host fell silent during a move; stopped ({=u32} so far)",
                    stops
                );
            }
            #[cfg(feature = "hw")]
            if STACK_REPORT_DUE.swap(false, Relaxed) {
                defmt::info!(
                    "stack: {=u32} of {=u32} bytes used",
                    crate::stack::used(),
                    crate::stack::size()
                );
            }
            let overflows = RX_OVERFLOWS.load(Relaxed);
            if overflows != *cx.local.overflows_seen {
                *cx.local.overflows_seen = overflows;
                defmt::warn!(
                    "link: {=u32} received bytes lost (receive buffer full)",
                    overflows
                );
            }
            // At most a queue's worth of bytes, then the telemetry again: a flood on the line
            // must not starve the stream.
            #[cfg(feature = "qemu")]
            for _ in 0..crate::link::RX_CAPACITY {
                let Some(byte) = cx.local.rx_consumer.dequeue() else {
                    break;
                };
                receive(&mut cx, byte);
            }
            // The hardware board: the DMA buffer's new bytes, a chunk at a time (copied out and
            // checked against the DMA's position before they are decoded), a buffer's worth.
            #[cfg(feature = "hw")]
            for _ in 0..crate::link::RX_CAPACITY / crate::link::dma::CHUNK {
                let chunk = crate::link::dma::read(cx.local.rx_ring);
                if chunk.is_empty() {
                    break;
                }
                if chunk.lost > 0 {
                    RX_OVERFLOWS.fetch_add(chunk.lost, Relaxed);
                }
                RX_BYTES.fetch_add(chunk.lost + chunk.bytes().len() as u32, Relaxed);
                for &byte in chunk.bytes() {
                    receive(&mut cx, byte);
                }
            }
            #[cfg(all(feature = "qemu", not(feature = "link-session")))]
            if cx.shared.board.lock(|b| b.run.finished) {
                finish(&mut cx);
            }
            #[cfg(feature = "qemu")]
            let pending = cx.local.rx_consumer.ready();
            #[cfg(feature = "hw")]
            let pending = crate::link::dma::pending(cx.local.rx_ring);
            if !pending {
                cortex_m::asm::wfi();
            }
        }
    }

    /// One received byte into the session's decoder; a complete request is served.
    fn receive(cx: &mut idle::Context, byte: u8) {
        match cx.local.session.receive(byte) {
            None => {}
            Some(Ok(request)) => serve(cx, request),
            Some(Err(e)) => {
                defmt::warn!("link: frame dropped: {=str}", crate::link::frame_error(e));
            }
        }
    }

    /// Answers one request of the command link (not inlined: its frame, with the request and
    /// the reply, is on the stack only while it runs, not under every other path of `idle`).
    #[inline(never)]
    fn serve(cx: &mut idle::Context, request: flexarm_link::Request) {
        use crate::link;
        use rtic::mutex::prelude::*;
        // A retried request (its reply was lost) gets the first answer, not applied again.
        if let Some(reply) = cx.local.session.repeated(&request) {
            let reply = flexarm_link::msg::DeviceMsgRef::Reply {
                id: request.id,
                reply: &reply,
            };
            link::send(cx.local.serial, &reply);
            return;
        }
        let (sensed, brake_engaged) = cx
            .shared
            .board
            .lock(|b| (period::sense(b), b.brake_engaged()));
        let load = |s: &stats::TaskStats| flexarm_link::msg::Load {
            mean_cycles: s.mean(),
            worst_cycles: s.worst(),
            misses: s.misses(),
        };
        let io = session::Io {
            y: sensed.y,
            amplifier_fault: sensed.amplifier_fault,
            ticks: *cx.local.last_tick,
            dropped: TELEMETRY_DROPS.load(Relaxed),
            rx_bytes: RX_BYTES.load(Relaxed),
            rx_lost: RX_OVERFLOWS.load(Relaxed),
            rx_line: flexarm_link::msg::LineErrors {
                overrun: RX_OVERRUNS.load(Relaxed),
                framing: RX_FRAMING.load(Relaxed),
                noise: RX_NOISE.load(Relaxed),
            },
            // A scan of the stack region, for a status only (outside every lock).
            stack_used: match request.command {
                flexarm_link::Command::Status => crate::stack::used(),
                _ => 0,
            },
            loads: [load(&stats::PIEZO), load(&stats::MOTOR)],
            brake_engaged,
        };
        #[cfg(feature = "link-session")]
        if let flexarm_link::Command::TestAmplifierFault(on) = request.command {
            cx.shared.board.lock(|b| b.inject_amplifier_fault(on));
        }
        let session = &mut cx.local.session;
        let kind = session::Kind::of(&request.command);
        let reply = match request.command {
            flexarm_link::Command::Move(m) => session::start_move(
                m,
                &mut cx.shared.control,
                &mut cx.shared.drive,
                cx.local.snapshot,
            ),
            // Not through `answer`: a `Set` of the piezo law designs it (the idle task's deepest
            // call chain), and `answer`'s frame need not be under it.
            flexarm_link::Command::Set(p, v) => (&mut cx.shared.control, &mut cx.shared.drive)
                .lock(|c, d| {
                    d.heard(d.next_tick());
                    session.set(p, v, c, d)
                }),
            flexarm_link::Command::ConfigSave | flexarm_link::Command::ConfigErase => {
                let save = request.command == flexarm_link::Command::ConfigSave;
                crate::settings::serve(
                    save,
                    session,
                    &mut cx.shared.control,
                    &mut cx.shared.drive,
                    cx.local.store,
                )
            }
            command => (
                &mut cx.shared.control,
                &mut cx.shared.drive,
                &mut cx.shared.recorder,
            )
                .lock(|c, d, r| session.answer(command, c, d, r, &io)),
        };
        session.remember(request.id, kind, &reply);
        link::send(
            cx.local.serial,
            &flexarm_link::msg::DeviceMsgRef::Reply {
                id: request.id,
                reply: &reply,
            },
        );
    }

    #[cfg(feature = "qemu")]
    fn finish(cx: &mut idle::Context) {
        use cortex_m_semihosting::debug::{EXIT_FAILURE, EXIT_SUCCESS, exit};
        let fault = cx.shared.control.lock(|c| c.ctrl.fault());
        let recorded = cx.shared.recorder.lock(|r| (r.fault(), r.sealed()));
        let ok = cx.shared.board.lock(|b| {
            crate::verdict::judge(&b.run, fault, b.sim.arm.enabled() || !b.sim.brake, recorded)
        });
        exit(if ok { EXIT_SUCCESS } else { EXIT_FAILURE });
    }

    /// Piezo loop: film voltage in, actuator voltage out (Eq. 17).
    #[task(binds = TIM2, priority = 3, local = [tim2, piezo_ticks], shared = [control, board])]
    fn piezo_loop(mut cx: piezo_loop::Context) {
        let start = clock::now();
        cx.local.tim2.sr().write(|w| w.uif().clear_bit());
        *cx.local.piezo_ticks = cx.local.piezo_ticks.wrapping_add(1);
        #[allow(unused_mut)]
        let mut v_f = cx.shared.board.lock(|b| b.film_voltage());
        #[cfg(feature = "inject-nan")]
        if *cx.local.piezo_ticks == PIEZO_HZ {
            defmt::warn!("injecting a NaN film sample at t = 1 s");
            v_f = f32::NAN;
        }
        let v_a = cx.shared.control.lock(|c| period::piezo_tick(c, v_f));
        cx.shared.board.lock(|b| period::piezo_out(b, v_a));
        PIEZO_HEARTBEAT.fetch_add(1, Relaxed);
        // The QEMU board's motor period: every tenth piezo period (at init's comment).
        #[cfg(feature = "qemu")]
        if cx
            .local
            .piezo_ticks
            .is_multiple_of(config::CONFIG.motor_divider)
        {
            rtic::pend(stm32f4::stm32f405::Interrupt::TIM3);
        }
        let missed = cx.local.tim2.sr().read().uif().bit_is_set();
        stats::PIEZO.record(clock::now().wrapping_sub(start), missed);
        if missed {
            cx.shared.control.lock(|c| c.ctrl.trip(Fault::Overrun));
            cx.shared.board.lock(safe_outputs);
        }
    }

    /// Motor loop: encoders and film in, the drive's step (observer, Eq. 7, motion checks),
    /// torques out, the fault recorder, telemetry.
    #[task(binds = TIM3, priority = 2, local = [tim3, producer, move_clock, motor, heat_store], shared = [control, drive, recorder, board])]
    fn motor_loop(mut cx: motor_loop::Context) {
        let start = clock::now();
        cx.local.tim3.sr().write(|w| w.uif().clear_bit());
        let sensed = cx.shared.board.lock(period::sense);
        let motor = cx.local.motor;
        let (p, heat) = (&mut cx.shared.control, &mut cx.shared.drive).lock(|c, d| {
            let p = period::motor_step(motor, c, d, &sensed);
            (p, d.monitor().heat)
        });
        // The heat survives a reset (a reset in the middle of this write finds it invalid).
        cx.local.heat_store.store(heat);
        // The time since boot (the boot move's time, which the QEMU board's verdict measures
        // against), from the integer tick difference; the telemetry carries the move time
        // (`Period::t`).
        #[cfg(not(feature = "link-session"))]
        let t = cx.local.move_clock.local_time(p.tick);
        cx.shared.board.lock(|b| {
            period::actuate(b, &p.command);
            #[cfg(not(feature = "link-session"))]
            b.motor_period(t);
        });
        MOTOR_HEARTBEAT.fetch_add(1, Relaxed);
        if let Some(s) = period::recorded(&p, config::CONFIG.record_every) {
            cx.shared.recorder.lock(|r| r.record(&s, p.fault));
        }
        let producer = cx.local.producer;
        motor.sample(&p, |r| {
            if producer.enqueue(r).is_err() {
                let _ = TELEMETRY_DROPS.fetch_update(Relaxed, Relaxed, |n| n.checked_add(1));
            }
        });

        #[cfg(any(feature = "inject-panic", feature = "inject-reset"))]
        if cx.local.move_clock.elapsed(p.tick) == MOTOR_HZ {
            panic!("injected panic in the motor loop at t = 1 s");
        }
        #[cfg(feature = "inject-hardfault")]
        if cx.local.move_clock.elapsed(p.tick) == MOTOR_HZ {
            defmt::warn!("injecting an undefined instruction in the motor loop at t = 1 s");
            cortex_m::asm::udf();
        }
        #[cfg(feature = "inject-stack-overflow")]
        if cx.local.move_clock.elapsed(p.tick) == MOTOR_HZ {
            defmt::warn!("injecting unbounded recursion in the motor loop at t = 1 s");
            /// Uses 1 KiB of stack per level, forever.
            #[allow(unconditional_recursion)]
            fn deeper(n: u32) -> u32 {
                let buf = core::hint::black_box([n; 256]);
                deeper(buf[0].wrapping_add(1)).wrapping_add(buf[255])
            }
            core::hint::black_box(deeper(0));
        }
        // At rest after the move: during it, the stalled plant (the QEMU board steps its arm in
        // the piezo loop) would freeze the encoders under the move's torque, and the drive's
        // frozen-encoder check would latch before the supervisor's liveness check.
        #[cfg(feature = "inject-piezo-stall")]
        if cx.local.move_clock.elapsed(p.tick) == 3 * MOTOR_HZ {
            defmt::warn!("injecting a stalled piezo loop (TIM2 masked) at t = 3 s");
            cortex_m::peripheral::NVIC::mask(stm32f4::stm32f405::Interrupt::TIM2);
        }
        #[cfg(feature = "inject-brake-stuck")]
        if cx.local.move_clock.elapsed(p.tick) == MOTOR_HZ {
            defmt::warn!("injecting a disarm at t = 1 s mid-move, the brake stuck released");
            (&mut cx.shared.control, &mut cx.shared.drive).lock(|c, d| d.disarm(&mut c.ctrl));
        }
        #[cfg(feature = "inject-overrun")]
        if cx.local.move_clock.elapsed(p.tick) == MOTOR_HZ {
            defmt::warn!("injecting an overrun at t = 1 s");
            cortex_m::asm::delay(3 * (TIMER_CLOCK_HZ / MOTOR_HZ));
        }
        // The next period began before this one ended: on the QEMU board, the piezo loop has
        // started it (pended the interrupt) again.
        #[cfg(not(feature = "qemu"))]
        let missed = cx.local.tim3.sr().read().uif().bit_is_set();
        #[cfg(feature = "qemu")]
        let missed = cortex_m::peripheral::NVIC::is_pending(stm32f4::stm32f405::Interrupt::TIM3);
        stats::MOTOR.record(clock::now().wrapping_sub(start), missed);
        if missed {
            cx.shared.control.lock(|c| c.ctrl.trip(Fault::Overrun));
            cx.shared.board.lock(safe_outputs);
        }
    }

    /// The command link's receive interrupt. QEMU board: bytes from USART1 into the queue,
    /// nothing else. Hardware board (`link::dma`): the line events, the line idle after a frame
    /// (the interrupt's return wakes `idle`, which reads the DMA buffer) and the line errors,
    /// counted.
    #[task(binds = USART1, priority = 1, local = [#[cfg(feature = "qemu")] rx, #[cfg(feature = "qemu")] rx_producer])]
    fn link_rx(cx: link_rx::Context) {
        #[cfg(feature = "qemu")]
        {
            use crate::link::Received;
            while let Some(r) = cx.local.rx.read() {
                RX_BYTES.fetch_add(1, Relaxed);
                let b = match r {
                    Received::Byte(b) => b,
                    Received::AfterOverrun(b) => {
                        RX_OVERRUNS.fetch_add(1, Relaxed);
                        b
                    }
                    Received::Framing => {
                        RX_FRAMING.fetch_add(1, Relaxed);
                        continue;
                    }
                    Received::Noise => {
                        RX_NOISE.fetch_add(1, Relaxed);
                        continue;
                    }
                };
                if cx.local.rx_producer.enqueue(b).is_err() {
                    RX_OVERFLOWS.fetch_add(1, Relaxed);
                }
            }
        }
        #[cfg(feature = "hw")]
        {
            let _ = cx;
            let e = crate::link::dma::line_events();
            if e.overrun {
                RX_OVERRUNS.fetch_add(1, Relaxed);
            }
            if e.framing {
                RX_FRAMING.fetch_add(1, Relaxed);
            }
            if e.noise {
                RX_NOISE.fetch_add(1, Relaxed);
            }
            if e.taken {
                RX_OVERFLOWS.fetch_add(1, Relaxed);
            }
        }
    }

    /// The receive DMA's half-buffer events, counted for the ring's reader: above the control
    /// loops, so that no lock or loop holds it off for the half lap (2.8 ms at 921 600 baud)
    /// that would merge two events; it shares nothing, so no lock masks it.
    #[cfg(feature = "hw")]
    #[task(binds = DMA2_STREAM2, priority = 4, local = [dma2])]
    fn link_halves(cx: link_halves::Context) {
        crate::link::dma::count_halves(cx.local.dma2);
    }

    /// Supervisor: liveness of both loops, watchdog, enable line, fault report,
    /// load report once a second.
    #[task(binds = TIM4, priority = 1, local = [tim4, last_heartbeat, last_piezo_beat, supervisor_ticks, reported_fault, #[cfg(feature = "hw")] iwdg], shared = [control, board, recorder])]
    fn supervisor(mut cx: supervisor::Context) {
        cx.local.tim4.sr().write(|w| w.uif().clear_bit());
        // Both control loops must have run since the last check.
        let (motor, piezo) = (MOTOR_HEARTBEAT.load(Relaxed), PIEZO_HEARTBEAT.load(Relaxed));
        let alive = motor != *cx.local.last_heartbeat && piezo != *cx.local.last_piezo_beat;
        *cx.local.last_heartbeat = motor;
        *cx.local.last_piezo_beat = piezo;
        let fault = cx.shared.control.lock(|c| {
            if !alive {
                c.ctrl.trip(Fault::Overrun);
            }
            c.ctrl.fault()
        });
        if fault.is_some() {
            cx.shared.board.lock(safe_outputs);
        }
        // A stalled loop: the motor loop, which freezes the recorder with the faulting sample,
        // may be the one that stopped. Frozen here (its first fault kept), and sealed before
        // the watchdog's reset.
        if let (Some(f), false) = (fault, alive) {
            cx.shared.recorder.lock(|r| r.freeze(f));
        }
        // Feed the watchdog only while both loops run: a stalled loop resets the chip.
        #[cfg(feature = "hw")]
        if alive {
            crate::board::hw::feed_watchdog(cx.local.iwdg);
        }
        if let (Some(f), false) = (fault, *cx.local.reported_fault) {
            *cx.local.reported_fault = true;
            defmt::error!("safe state: {=str} (latched until reset)", f.as_str());
        }
        *cx.local.supervisor_ticks = cx.local.supervisor_ticks.wrapping_add(1);
        // A verdict run ends a second after its time on the supervisor's own clock too: the
        // motor loop, which measures the run, stops with the piezo loop on the QEMU board
        // (`inject-piezo-stall`).
        #[cfg(all(feature = "qemu", not(feature = "link-session")))]
        if *cx.local.supervisor_ticks == (config::RUN_SECONDS as u32 + 1) * SUPERVISOR_HZ {
            cx.shared.board.lock(|b| b.run.finished = true);
        }
        if cx.local.supervisor_ticks.is_multiple_of(SUPERVISOR_HZ) {
            let (pr, pm, px) = stats::PIEZO.take_window();
            let (mr, mm, mx) = stats::MOTOR.take_window();
            defmt::info!(
                "load: piezo {=u32} runs, mean {=u32} max {=u32} counts, {=u32} missed; motor {=u32} runs, mean {=u32} max {=u32} counts, {=u32} missed",
                pr,
                pm,
                px,
                stats::PIEZO.misses(),
                mr,
                mm,
                mx,
                stats::MOTOR.misses()
            );
            // The stack's mark: a scan of the whole stack region, about 1 ms at 168 MHz, left to
            // `idle` (below the link's receive interrupt, which it would otherwise hold off for
            // about 85 byte times); the QEMU board reports it at the end of its run instead,
            // since the scan disturbs its timers' relative rates.
            #[cfg(feature = "hw")]
            STACK_REPORT_DUE.store(true, Relaxed);
        }
    }

    /// The safe state on the outputs: zero torque, zero voltage, amplifiers disabled, brakes
    /// engaged.
    fn safe_outputs(b: &mut BoardImpl) {
        b.set_torques(Vector2::zeros());
        b.set_piezo(0.0);
        b.set_enable(false);
        b.set_brake(true);
    }
}

#[cfg(feature = "qemu")]
mod verdict;

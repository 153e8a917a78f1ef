//! Instruction counts of the hot-path functions on the Cortex-M4F, under QEMU
//! (`cargo fw-bench`, whose runner `scripts/fw-cycles` also estimates their cycles).
//!
//! With `-icount shift=0` QEMU advances TIM5 (clocked at 1 GHz) by one count per executed
//! instruction, so a count difference around a call is the number of instructions it executed:
//! exact and repeatable. Each function is called through a wrapper that is never inlined, with
//! its state in memory, the way an interrupt handler calls it: the count is the function's own
//! work, the loads and stores of its state included. The timed region is built so that it
//! cannot flatter itself (see [`timed`]): inputs handed in after the opening read, every value
//! of the result consumed before the closing one, and the cost of the two reads measured on an
//! empty region and checked against 32 `NOP`s before it is subtracted. On hardware, the same
//! code would read the DWT cycle counter instead.
//!
//! States: 200 recorded along the paper's trapezoid move (the simulated arm under the complete
//! controller, the same code as the QEMU board) and 200 random ones; the complete motor step
//! in steady state (a previous sample, every check running) and as the first step after a
//! reset. Each mean over the random states is checked against `firmware/budgets.txt`; the run
//! exits non-zero on a regression or a failed calibration.
#![no_std]
#![no_main]
// The counter register and the timed region's `asm!` barriers (the register code: the
// workspace's lints deny `unsafe` everywhere else).
#![allow(unsafe_code)]

use core::hint::black_box;
use core::sync::atomic::Ordering::{Acquire, Relaxed, Release};
use core::sync::atomic::{AtomicU8, AtomicU16, AtomicU32};

use cortex_m_semihosting::debug::{EXIT_FAILURE, EXIT_SUCCESS, exit};
use defmt_semihosting as _;
use flexarm_core::control::motor::{MotorController, MotorLaw};
use flexarm_core::control::piezo::PiezoPatch;
use flexarm_core::control::tracking::eq7_torques;
use flexarm_core::controller::Controller;
use flexarm_core::model::Model;
use flexarm_core::motion::{MotionLimits, MotionMonitor, MotionSample, Verdict};
use flexarm_core::observer::Measurement;
use flexarm_core::observer_gains::{GAIN_1KHZ, gain};
use flexarm_core::params::{ArmParams, DEFAULT_KI, Gains, Limits};
use flexarm_core::trajectory::{JointTarget, JointTrajectory, Trapezoid};
use flexarm_core::{Vector2, Vector4};

include!(concat!(env!("OUT_DIR"), "/budgets.rs"));

/// The like-for-like comparison with C.
#[path = "bench/like.rs"]
mod like;

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    defmt::error!("panic: {}", defmt::Display2Format(info));
    exit(EXIT_FAILURE);
    loop {
        cortex_m::asm::bkpt();
    }
}

/// One benchmark state.
#[derive(Clone, Copy)]
struct State {
    t: f32,
    q: Vector4<f32>,
    qd: Vector4<f32>,
    target: JointTarget<f32>,
    y: Measurement<f32>,
}

const N: usize = 200;

/// The piezo loop's period [s] (10 kHz).
const PIEZO_PERIOD: f32 = 1e-4;

/// Min, mean and max of a set of counts.
struct Stat {
    min: u32,
    max: u32,
    sum: u32,
    n: u32,
}

impl Stat {
    fn new() -> Self {
        Self {
            min: u32::MAX,
            max: 0,
            sum: 0,
            n: 0,
        }
    }
    fn add(&mut self, c: u32) {
        self.min = self.min.min(c);
        self.max = self.max.max(c);
        self.sum += c;
        self.n += 1;
    }
    /// The mean in tenths, rounded half up: printed with one decimal.
    fn mean_tenths(&self) -> u32 {
        (self.sum * 10 + self.n / 2) / self.n.max(1)
    }
    /// Whether the exact mean `sum / n` is at most `budget` (no rounding in its favour).
    fn within(&self, budget: u32) -> bool {
        u64::from(self.sum) <= u64::from(budget) * u64::from(self.n)
    }
}

// The measured calls. Each wrapper is never inlined and reads the counter itself around the
// call. Nothing can move across the reads: after the first, an `asm!` barrier takes the inputs
// (so no load or arithmetic on them is hoisted above it); before the second, an `asm!` block
// takes every value of the result in a core register (a data dependency: the work must be done)
// and, like the first, may read memory (so every store of the call is done too). The blocks are
// empty; the only instructions they cause are the result's transfers, one `VMOV` per value,
// counted as part of the call.

/// Reads TIM5's counter: the register's address built in the block itself, so the opening and
/// the closing read cost the same wherever the compiler keeps its registers, then `LDREX`, an
/// instruction no measured function executes, which marks the edges of the timed region in
/// QEMU's execution trace (`scripts/fw-cycles`). On the M4 it costs what an `LDR` does.
#[inline(always)]
fn now() -> u32 {
    let v: u32;
    // SAFETY: a load of TIM5's counter register, configured once in `main` (an exclusive load:
    // it also sets the local monitor, which nothing in this program uses).
    unsafe {
        core::arch::asm!(
            "movw {p}, #0x0c24",
            "movt {p}, #0x4000",
            "ldrex {v}, [{p}]",
            p = out(reg) _,
            v = out(reg) v,
            options(nostack, preserves_flags)
        );
    }
    v
}

/// Values whose computation must be finished before the closing counter read: each `f32` of
/// the result goes into an empty `asm!` block in a core register, one `VMOV` per value, which
/// stands in for the store of the result that the firmware does (`rustc` offers no FP register
/// class to an `asm!` operand on this target without the double-precision `vfp2` feature).
/// The blocks may read memory, so every store of the call is done before the closing read too.
trait Consume {
    fn consume(&self);
}

impl Consume for f32 {
    #[inline(always)]
    fn consume(&self) {
        // SAFETY: an empty block that only takes the value.
        unsafe {
            core::arch::asm!("/* {0} */", in(reg) self.to_bits(), options(nostack, preserves_flags))
        }
    }
}

impl Consume for Vector2<f32> {
    #[inline(always)]
    fn consume(&self) {
        self.x.consume();
        self.y.consume();
    }
}

impl Consume for flexarm_core::supervisor::Command<f32> {
    #[inline(always)]
    fn consume(&self) {
        self.tau.consume();
        self.v_a.consume();
        // SAFETY: an empty block that only takes the value.
        unsafe {
            core::arch::asm!("/* {0} */", in(reg) u32::from(self.enable), options(nostack, preserves_flags))
        }
    }
}

impl Consume for () {
    #[inline(always)]
    fn consume(&self) {
        // SAFETY: an empty block (a compiler barrier: it may read and write memory).
        unsafe { core::arch::asm!("", options(nostack, preserves_flags)) }
    }
}

impl<R: Consume> Consume for Option<R> {
    #[inline(always)]
    fn consume(&self) {
        match self {
            Some(r) => r.consume(),
            None => ().consume(),
        }
    }
}

/// The inputs of a timed call, handed through an empty `asm!` block after the opening read:
/// every load of them, and every computation on them, comes after it.
trait Launder {
    fn launder(self) -> Self;
}

impl<P> Launder for &P {
    #[inline(always)]
    fn launder(self) -> Self {
        let mut p: *const P = self;
        // SAFETY: an empty block that may read and write memory; the pointer comes back
        // unchanged, so the reference stays valid.
        unsafe {
            core::arch::asm!("/* {0} */", inout(reg) p, options(nostack, preserves_flags));
            &*p
        }
    }
}

impl<P> Launder for &mut P {
    #[inline(always)]
    fn launder(self) -> Self {
        let mut p: *mut P = self;
        // SAFETY: as above; the unique reference was moved in and comes back.
        unsafe {
            core::arch::asm!("/* {0} */", inout(reg) p, options(nostack, preserves_flags));
            &mut *p
        }
    }
}

impl<A: Launder, B: Launder> Launder for (A, B) {
    #[inline(always)]
    fn launder(self) -> Self {
        (self.0.launder(), self.1.launder())
    }
}

impl<A: Launder, B: Launder, C: Launder> Launder for (A, B, C) {
    #[inline(always)]
    fn launder(self) -> Self {
        (self.0.launder(), self.1.launder(), self.2.launder())
    }
}

/// Runs `f` on `inputs` between two counter reads; returns its result and the count.
#[inline(always)]
fn timed<P: Launder, R: Consume>(inputs: P, f: impl FnOnce(P) -> R) -> (R, u32) {
    let t0 = now();
    let r = f(inputs.launder());
    r.consume();
    let t1 = now();
    (r, t1.wrapping_sub(t0))
}

/// The timed region with nothing in it: the cost of the reads themselves (calibration).
#[inline(never)]
fn call_empty(s: &State) -> ((), u32) {
    timed(s, |_| ())
}

/// The timed region around 32 `NOP`s: must measure the empty region's count plus 32
/// (calibration: the subtracted overhead is verified, not assumed).
#[inline(never)]
fn call_nops(s: &State) -> ((), u32) {
    timed(s, |_| {
        // SAFETY: 32 no-operations.
        unsafe {
            core::arch::asm!(
                ".rept 32",
                "nop",
                ".endr",
                options(nostack, preserves_flags)
            )
        }
    })
}

#[inline(never)]
fn call_eq7(model: &Model<f32>, gains: &Gains<f32>, s: &State) -> (Vector2<f32>, u32) {
    timed((model, gains, s), |(m, g, s)| {
        eq7_torques(m, g, &s.q, &s.qd, &s.target)
    })
}

#[inline(never)]
fn call_motor_law(motor: &MotorController<f32>, s: &State) -> (Option<Vector2<f32>>, u32) {
    timed((motor, s), |(m, s)| {
        m.step(s.t, &s.q, &s.qd, &s.target).ok().map(|o| o.tau)
    })
}

#[inline(never)]
fn call_motor_step(c: &mut Controller<f32>, t: &f32, y: &Measurement<f32>) -> (Vector2<f32>, u32) {
    timed((c, t, y), |(c, t, y)| c.motor_step(*t, Some(y)).command.tau)
}

/// [`call_motor_step`] for the controller with the boards' integral action (issue 35,
/// `flexarm_core::control::integral`), taking the whole command (torques, piezo voltage,
/// enable: a few instructions more than the torques alone), so its body, and with it its
/// symbol and its timed regions, are its own (identical functions are merged).
#[inline(never)]
fn call_motor_step_integral(
    c: &mut Controller<f32>,
    t: &f32,
    y: &Measurement<f32>,
) -> (flexarm_core::supervisor::Command<f32>, u32) {
    timed((c, t, y), |(c, t, y)| c.motor_step(*t, Some(y)).command)
}

#[inline(never)]
fn call_piezo_step(c: &mut Controller<f32>, v_f: &f32) -> (f32, u32) {
    timed((c, v_f), |(c, v_f)| c.piezo_step(*v_f))
}

/// The motion checks of one motor period (`flexarm_core::motion`, run by the drive after the
/// motor step): the model's predicted accelerations for the stall check, every check and the
/// I²t update, on the state's angles, reference and speeds.
#[inline(never)]
fn call_motion(
    m: &mut MotionMonitor<f32>,
    l: &MotionLimits<f32>,
    model: &Model<f32>,
    s: &State,
) -> (f32, u32) {
    timed(((m, l), model, s), |((m, l), model, s)| {
        let tau = Vector2::new(s.qd.x, -s.qd.y);
        let sample = MotionSample::new(model, (s.q.xy(), s.target.q), (&s.q, &s.qd), tau);
        let v = m.check(l, &sample, 1e-3);
        m.update_heat(l, tau, 1e-3);
        if v == Verdict::Clear { m.heat.x } else { -1.0 }
    })
}

/// The command link's receive path as the firmware runs it: the receive interrupt's queue (512
/// bytes, the firmware's `link::RX_CAPACITY`) and the idle task's decoder. The interrupt's two
/// register reads are not in it (QEMU's USART is not the board's).
struct Rx {
    queue: heapless::spsc::Queue<u8, 512>,
    decoder: flexarm_link::Decoder,
}

/// One request frame on the wire.
struct Frame {
    bytes: [u8; flexarm_link::MAX_FRAME],
    len: usize,
}

/// A move request of the state's pose, framed: every one is [`RX_FRAME`] bytes long (postcard's
/// floats are 4 bytes, the id is fixed, and COBS adds one byte to any body under 254).
fn rx_frame(s: &State) -> Frame {
    let request = flexarm_link::Request {
        id: 0x1234,
        command: flexarm_link::Command::Move(flexarm_link::msg::Move::Trapezoid {
            target: [s.q.x, s.q.y],
            move_time: 2.0 + s.t,
            ramp_time: 0.5,
        }),
    };
    let mut f = Frame {
        bytes: [0; flexarm_link::MAX_FRAME],
        len: 0,
    };
    f.len = flexarm_link::encode(&request, &mut f.bytes).map_or(0, <[u8]>::len);
    f
}

/// Bytes of [`rx_frame`]'s frames.
const RX_FRAME: usize = 26;

/// Each byte of `frame` through the receive interrupt's queue into the decoder, as the idle task
/// takes them; the result is the decoded move's first target.
#[inline(never)]
fn call_rx_frame(rx: &mut Rx, frame: &Frame) -> (f32, u32) {
    timed((rx, frame), |(rx, frame)| {
        let mut out = f32::NAN;
        for &b in frame.bytes.iter().take(frame.len) {
            let _ = rx.queue.enqueue(b);
            while let Some(b) = rx.queue.dequeue() {
                if let Some(Ok(r)) = rx.decoder.push_request(b)
                    && let flexarm_link::Command::Move(flexarm_link::msg::Move::Trapezoid {
                        target,
                        ..
                    }) = r.command
                {
                    out = target[0];
                }
            }
        }
        out
    })
}

/// The hardware board's receive path (issue 34) as its idle task runs it: the frame's bytes
/// are in the receive DMA's circular buffer already (the DMA's writes take no instruction),
/// the reader (`flexarm_link::ring::DmaRing`, chunks of 32 bytes: the firmware's
/// `link::dma::read`) finds them from the stream's position, copies them out, checks them
/// against the position again, and the decoder takes them. QEMU has no DMA: the position is
/// read from RAM (an `Acquire` load of the event count, as on the board, then the index where
/// the board reads NDTR) and written by [`RxDma::deliver`] outside the timed region.
struct RxDma {
    ring: flexarm_link::ring::DmaRing<RX_DMA_LEN>,
    decoder: flexarm_link::Decoder,
    /// Bytes the simulated DMA has written.
    written: u32,
}

/// The firmware's `link::RX_CAPACITY`: the hardware board's DMA buffer.
const RX_DMA_LEN: usize = 512;
/// The simulated DMA's buffer and position (the stream's event count and NDTR).
static RX_DMA_BUFFER: [AtomicU8; RX_DMA_LEN] = [const { AtomicU8::new(0) }; RX_DMA_LEN];
static RX_DMA_HALVES: AtomicU32 = AtomicU32::new(0);
static RX_DMA_REMAINING: AtomicU16 = AtomicU16::new(RX_DMA_LEN as u16);

impl RxDma {
    /// The simulated DMA writes `frame` into the buffer and moves its position on.
    fn deliver(&mut self, frame: &Frame) {
        for &b in frame.bytes.iter().take(frame.len) {
            if let Some(slot) = RX_DMA_BUFFER.get(self.written as usize % RX_DMA_LEN) {
                slot.store(b, Relaxed);
            }
            self.written = self.written.wrapping_add(1);
        }
        RX_DMA_HALVES.store(self.written / (RX_DMA_LEN as u32 / 2), Release);
        RX_DMA_REMAINING.store(
            (RX_DMA_LEN as u32 - self.written % RX_DMA_LEN as u32) as u16,
            Relaxed,
        );
    }
}

/// The stream's position as the firmware's `link::dma::position` reads it.
fn rx_dma_position() -> flexarm_link::ring::Position {
    let halves = RX_DMA_HALVES.load(Acquire);
    flexarm_link::ring::Position {
        halves,
        remaining: RX_DMA_REMAINING.load(Relaxed),
    }
}

/// The frame [`RxDma::deliver`] wrote, read out of the DMA buffer and decoded; the result is
/// the decoded move's first target (NaN if a byte was lost: the check of the row).
#[inline(never)]
fn call_rx_dma_frame(rx: &mut RxDma) -> (f32, u32) {
    timed(rx, |rx| {
        let mut out = f32::NAN;
        loop {
            let chunk = rx.ring.read::<32>(&RX_DMA_BUFFER, rx_dma_position);
            if chunk.is_empty() {
                break;
            }
            if chunk.lost > 0 {
                out = f32::INFINITY;
            }
            for &b in chunk.bytes() {
                if let Some(Ok(r)) = rx.decoder.push_request(b)
                    && let flexarm_link::Command::Move(flexarm_link::msg::Move::Trapezoid {
                        target,
                        ..
                    }) = r.command
                    && out.is_nan()
                {
                    out = target[0];
                }
            }
        }
        out
    })
}

/// Counts of `f` (a timed call) over `states`, overhead subtracted.
fn measure<R>(states: &[State], overhead: u32, mut f: impl FnMut(&State) -> (R, u32)) -> Stat {
    let mut s = Stat::new();
    for st in states {
        let (r, n) = f(black_box(st));
        black_box(r);
        s.add(n.saturating_sub(overhead));
    }
    s
}

/// A receive path's instructions per byte, to a tenth, of its frames of `RX_FRAME` bytes.
fn print_per_byte(set: &str, path: &str, frames: &Stat) {
    let per_byte =
        (frames.sum * 10 + frames.n * RX_FRAME as u32 / 2) / (frames.n.max(1) * RX_FRAME as u32);
    defmt::info!(
        "BENCH {=str} {=str}: {=u32}.{=u32} instructions per byte (frames of {=usize} bytes)",
        set,
        path,
        per_byte / 10,
        per_byte % 10,
        RX_FRAME
    );
}

fn controller(law: MotorLaw) -> Controller<f32> {
    Controller::paper(
        law,
        JointTrajectory::Trapezoid(Trapezoid::paper()),
        PIEZO_PERIOD,
        1e-3,
        gain(&GAIN_1KHZ),
    )
}

/// 200 states along the paper's move: the hardware board's firmware (1 kHz motor, 10 kHz piezo;
/// `flexarm_machine::period::board_period`, the drive running the move) on the QEMU board's
/// simulated arm, one state every 25 ms.
fn recorded() -> [State; N] {
    use flexarm_machine::period::{Control, MotorLoop, board_period};
    use flexarm_machine::simulated::SimulatedArm;
    let mut out = [State {
        t: 0.0,
        q: Vector4::zeros(),
        qd: Vector4::zeros(),
        target: JointTarget::rest(Vector2::zeros()),
        y: Measurement {
            theta: Vector2::zeros(),
            v_f: 0.0,
        },
    }; N];
    let cfg = flexarm_machine::BoardConfig::for_board(
        flexarm_link::msg::Board::Hardware,
        ArmParams::default(),
        PiezoPatch::paper(),
        30.0,
        &flexarm_core::tuning::RateCeiling::NONE,
        GAIN_1KHZ,
    );
    let mut arm = SimulatedArm::paper(cfg.patch, Vector4::zeros(), cfg.piezo_period());
    let mut control = Control::new(controller(MotorLaw::Tracking));
    let now = flexarm_core::time::Ticks(0);
    let mut drive = cfg.drive(&mut control.ctrl, now);
    let mut motor = MotorLoop::new(&cfg, now);
    let traj = Trapezoid::<f32>::paper();
    // The simulated arm's encoders read its own angles: the arm's frame, declared.
    let _ = drive.declare_zero(&mut control.ctrl);
    let started = drive.arm(&mut control.ctrl, now).and_then(|()| {
        let boot = flexarm_core::drive::MoveRequest::Trapezoid {
            target: traj.start + traj.amplitude,
            move_time: traj.profile.duration(),
            ramp_time: traj.profile.ramp(),
        };
        drive.start(&mut control.ctrl, now, &boot)
    });
    if started.is_err() {
        defmt::error!("the drive refused the paper's move");
    }
    let mut i = 0;
    for k in 0..5000u32 {
        let p = board_period(
            &mut arm,
            &mut control,
            &mut drive,
            &mut motor,
            10,
            |_, _| {},
        );
        if k % 25 == 0 && i < N {
            let t = k as f32 * 1e-3;
            let (q, qd) = control.ctrl.estimate();
            out[i] = State {
                t,
                q,
                qd,
                target: traj.sample(t),
                y: p.y,
            };
            i += 1;
        }
    }
    out
}

/// 200 random states over the workspace (a fixed LCG).
fn random() -> [State; N] {
    let mut seed = 0x2545_f491u32;
    let mut r = move |s: f32| {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        ((seed >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0) * s
    };
    core::array::from_fn(|_| {
        let q = Vector4::new(r(3.0), r(2.5), r(0.01), r(0.001));
        State {
            t: 1.0 + r(0.5),
            q,
            qd: Vector4::new(r(2.0), r(2.0), r(0.3), r(0.1)),
            target: JointTarget {
                q: Vector2::new(q.x + r(0.01), q.y + r(0.01)),
                qd: Vector2::new(r(1.0), r(1.0)),
                qdd: Vector2::new(r(2.0), r(2.0)),
            },
            y: Measurement {
                theta: Vector2::new(q.x, q.y),
                v_f: r(1.0),
            },
        }
    })
}

/// The counts of the timed region empty and around 32 `NOP`s: the overhead to subtract, after
/// checking that a known sequence of 32 instructions measures 32.
fn calibrate() -> Option<u32> {
    let s = random()[0];
    let empty = (0..8).map(|_| call_empty(black_box(&s)).1).min()?;
    let nops = (0..8).map(|_| call_nops(black_box(&s)).1).min()?;
    defmt::info!(
        "calibration: empty region {=u32}, 32 NOPs {=u32} (must be {=u32})",
        empty,
        nops,
        empty + 32
    );
    (nops == empty + 32).then_some(empty)
}

/// Prints one row and checks it against its budget (the random states only): the mean with
/// one decimal and exactly, as `sum/n`, which the gate compares.
fn report(set: &str, name: &str, s: &Stat, budget: Option<u32>) -> bool {
    let within = budget.is_none_or(|b| s.within(b));
    let tenths = s.mean_tenths();
    defmt::info!(
        "BENCH {=str} {=str}: min {=u32} mean {=u32}.{=u32} max {=u32} instructions ({=u32}/{=u32}){=str}",
        set,
        name,
        s.min,
        tenths / 10,
        tenths % 10,
        s.max,
        s.sum,
        s.n,
        match budget {
            None => "",
            Some(_) if within => " (within budget)",
            Some(_) => " OVER BUDGET",
        }
    );
    within
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let dp = stm32f4::stm32f405::Peripherals::take()
        .unwrap_or_else(|| panic!("peripherals taken twice"));
    dp.RCC.apb1enr().modify(|_, w| w.tim5en().set_bit());
    dp.TIM5.psc().write(|w| w.psc().set(0));
    dp.TIM5.arr().write(|w| w.arr().set(u32::MAX));
    dp.TIM5.cr1().write(|w| w.cen().set_bit());
    dp.TIM5.cnt().write(|w| w.cnt().set(0));

    let Some(overhead) = calibrate() else {
        defmt::error!("calibration failed: the timed region does not count what it holds");
        exit(EXIT_FAILURE);
        loop {
            cortex_m::asm::wfi();
        }
    };
    defmt::info!(
        "measurement overhead: {=u32} instructions (subtracted)",
        overhead
    );
    if !like::calibrate(overhead) {
        defmt::error!("calibration failed: a call of an empty function does not count its return");
        exit(EXIT_FAILURE);
    }

    let sets = [("recorded", recorded()), ("random", random())];
    let model = Model::new(ArmParams::<f32>::default());
    let gains = Gains::default();
    let motor = MotorController {
        model,
        gains,
        limits: Limits::default(),
        law: MotorLaw::Robust,
    };
    let base = controller(MotorLaw::Robust);
    let mut ok = true;
    for (set, states) in &sets {
        let gated = |b: u32| (*set == "random").then_some(b);
        let eq7 = measure(states, overhead, |s| {
            call_eq7(black_box(&model), black_box(&gains), s)
        });
        ok &= report(set, "eq7", &eq7, gated(BUDGET_EQ7_MEAN));
        let law = measure(states, overhead, |s| call_motor_law(black_box(&motor), s));
        ok &= report(set, "motor_step", &law, gated(BUDGET_MOTOR_STEP_MEAN));
        // The complete motor step in steady state: a previous sample one period earlier, so
        // every check runs (the encoder-jump check included). Gated.
        let mut steady = Stat::new();
        // The same step as the first after a reset (no previous sample): reported.
        let mut first = Stat::new();
        for s in states.iter() {
            let mut c = base;
            c.reset_observer(s.y.theta);
            let (tau, n) = call_motor_step(black_box(&mut c), &s.t, &s.y);
            black_box(tau);
            first.add(n.saturating_sub(overhead));
            let (tau, n) = call_motor_step(black_box(&mut c), &(s.t + 1e-3), &s.y);
            black_box(tau);
            steady.add(n.saturating_sub(overhead));
        }
        ok &= report(
            set,
            "controller_motor",
            &steady,
            gated(BUDGET_CONTROLLER_MOTOR_MEAN),
        );
        report(set, "controller_motor_first", &first, None);
        // The same steady step with the boards' integral action (`K_i` = DEFAULT_KI on both
        // joints, one untimed step before to start it): what the firmware runs. The C of the
        // like-for-like comparison has no integral; this row is the integral's cost. Gated.
        let mut integral = Stat::new();
        for s in states.iter() {
            let mut c = base;
            c.motor.gains.ki = Vector2::repeat(DEFAULT_KI as f32);
            c.reset_observer(s.y.theta);
            black_box(c.motor_step(s.t, Some(&s.y)));
            let (tau, n) = call_motor_step_integral(black_box(&mut c), &(s.t + 1e-3), &s.y);
            black_box(tau);
            integral.add(n.saturating_sub(overhead));
        }
        ok &= report(
            set,
            "controller_motor_integral",
            &integral,
            gated(BUDGET_CONTROLLER_MOTOR_INTEGRAL_MEAN),
        );
        let mut c = base;
        let piezo = measure(states, overhead, |s| {
            call_piezo_step(black_box(&mut c), &s.y.v_f)
        });
        ok &= report(set, "piezo_step", &piezo, gated(BUDGET_PIEZO_STEP_MEAN));
        // The motion checks, in steady state (a previous sample, counters running).
        let limits = MotionLimits::default_for(1000);
        let mut monitor = MotionMonitor::new();
        let motion = measure(states, overhead, |s| {
            call_motion(black_box(&mut monitor), black_box(&limits), &model, s)
        });
        ok &= report(
            set,
            "motion_check",
            &motion,
            gated(BUDGET_MOTION_CHECK_MEAN),
        );
        // Eq. 7, the piezo step and the complete motor step as whole functions, in Rust and C.
        ok &= like::run(set, states, overhead, &model, &gains, &base);
        // The link's receive path, a whole request frame; its cost per byte is the figure.
        let mut rx = Rx {
            queue: heapless::spsc::Queue::new(),
            decoder: flexarm_link::Decoder::new(),
        };
        let mut wrong = 0u32;
        let mut frames = Stat::new();
        for s in states.iter() {
            let frame = rx_frame(s);
            wrong += u32::from(frame.len != RX_FRAME);
            let (x, n) = call_rx_frame(black_box(&mut rx), &frame);
            wrong += u32::from(x != s.q.x);
            frames.add(n.saturating_sub(overhead));
        }
        if wrong > 0 {
            defmt::error!(
                "link_rx_frame: {=u32} frames not of {=usize} bytes or not decoded",
                wrong,
                RX_FRAME
            );
            ok = false;
        }
        ok &= report(
            set,
            "link_rx_frame",
            &frames,
            gated(BUDGET_LINK_RX_FRAME_MEAN),
        );
        print_per_byte(set, "link receive path", &frames);
        // The hardware board's DMA receive path, the same frames (the buffer wraps every
        // 512 / 26 frames, so some frames are read in two chunks, as on the board).
        let mut rx = RxDma {
            ring: flexarm_link::ring::DmaRing::at(rx_dma_position()),
            decoder: flexarm_link::Decoder::new(),
            written: flexarm_link::ring::DmaRing::<RX_DMA_LEN>::written(rx_dma_position()),
        };
        let mut wrong = 0u32;
        let mut frames = Stat::new();
        for s in states.iter() {
            let frame = rx_frame(s);
            rx.deliver(&frame);
            let (x, n) = call_rx_dma_frame(black_box(&mut rx));
            wrong += u32::from(x != s.q.x);
            frames.add(n.saturating_sub(overhead));
        }
        if wrong > 0 {
            defmt::error!(
                "link_rx_dma_frame: {=u32} frames not decoded or bytes lost",
                wrong
            );
            ok = false;
        }
        ok &= report(
            set,
            "link_rx_dma_frame",
            &frames,
            gated(BUDGET_LINK_RX_DMA_FRAME_MEAN),
        );
        print_per_byte(set, "link DMA receive path", &frames);
    }
    exit(if ok { EXIT_SUCCESS } else { EXIT_FAILURE });
    loop {
        cortex_m::asm::wfi();
    }
}

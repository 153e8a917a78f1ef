//! The command link's firmware side: USART1 carries the frames of
//! `flexarm-link`. The receive interrupt only moves bytes from the data register into a queue;
//! the idle task decodes them, answers, and streams the telemetry the host subscribed to. Both
//! run below the control loops, so nothing on the link can delay them.
//!
//! The commands act on the drive (`flexarm_core::drive`): arm, disarm, estop, trapezoid,
//! circle and waypoint moves (the waypoints uploaded in chunks), stop, clear; `get`/`set` on the
//! tunable parameters (`flexarm_core::tuning`) and the link watchdog's timeout; the fault
//! recorder's pages. A move is validated outside the control loops' locks ([`start_move`]).
//!
//! The idle task calls these functions from several places; none is inlined (`#[inline(never)]`),
//! which keeps each in flash once: 3.4 KiB less than letting the optimizer copy them.
//!
//! Hardware board: USART1 on PB6 (TX) and PB7 (RX) (the board configures the pins), 921 600
//! baud, 8N1. QEMU board: the same USART, exposed by QEMU as a TCP socket
//! (`scripts/qemu-link`).

use core::sync::atomic::{AtomicU32, Ordering::Relaxed};
use flexarm_core::Vector2;
use flexarm_core::control::motor::MotorController;
use flexarm_core::controller::Controller;
use flexarm_core::drive::{self, Drive, MoveRequest, Refused, Waypoint};
use flexarm_core::observer::Measurement;
use flexarm_core::tuning::{Tunable, TuneError, Tuning};
use flexarm_link::msg::{
    Board, Channels, Command, DeviceMsgRef, FaultPage, Hello, Load, MAX_CHANNELS, Mode, Move,
    Param, RecordedSample, Refusal, Reply, SAMPLES_PER_PAGE, Status, Telemetry,
};
use flexarm_link::{Request, VERSION};

use stm32f4::stm32f405::USART1;

use crate::config::{MOTOR_HZ, PIEZO_HZ};
use crate::telemetry::Record;

/// Baud rate of the hardware board's link.
pub const BAUD: u32 = 921_600;

/// Motor periods per telemetry frame of the subscription; 0 while nobody subscribed. Written by
/// the idle task, read by the motor loop, which queues a record every this many periods.
pub static STREAM_EVERY: AtomicU32 = AtomicU32::new(0);

/// The piezo bias `Param::VaBias` [V, f32 bits]: set by the idle task while the drive holds,
/// added by the piezo loop (`Controller::bias_piezo`), cleared by the motor loop the period the
/// drive leaves holding.
pub static PIEZO_BIAS: AtomicU32 = AtomicU32::new(0);

/// Whether a stream of `channels` every `decimation` motor periods fits in 80 % of the line
/// (the rest for replies): `frame bytes · MOTOR_HZ / decimation ≤ 0.8 · BAUD / 10` (8N1).
/// The QEMU board's socket has no baud rate; the same rule holds there, at its 100 Hz loop.
fn fits_the_line(decimation: u16, channels: Channels) -> bool {
    // At most 87 bytes × 1000 Hz × 100 and 8 × 921 600: both within a u32.
    let per_second = channels.frame_bytes() as u32 * MOTOR_HZ / u32::from(decimation.max(1));
    per_second * 100 <= 8 * BAUD
}

/// Bytes received and not yet decoded.
pub const RX_CAPACITY: usize = 512;
/// The queue between the receive interrupt and the idle task.
pub type RxQueue = heapless::spsc::Queue<u8, RX_CAPACITY>;

/// USART1's transmit side (the idle task's), with its frame encoder.
pub struct Serial {
    usart: USART1,
    encoder: flexarm_link::Encoder,
}

/// USART1's receive side (the receive interrupt's).
pub struct Receiver;

impl Receiver {
    /// The byte in the data register, if one arrived (clears the interrupt); a byte with a
    /// framing or parity error is dropped (the frame's CRC then refuses the frame).
    pub fn read(&mut self) -> Option<u8> {
        // SAFETY: the receiver only reads SR and DR; the transmitter ([`Serial`]) only reads
        // SR and writes DR. Reading SR has no side effect; reading DR clears RXNE and ORE,
        // which only the receiver does.
        let usart = unsafe { &*USART1::ptr() };
        let sr = usart.sr().read();
        if sr.rxne().bit_is_set() || sr.ore().bit_is_set() {
            let byte = usart.dr().read().dr().bits() as u8;
            return (sr.fe().bit_is_clear() && sr.pe().bit_is_clear()).then_some(byte);
        }
        None
    }
}

impl Serial {
    /// Enables USART1 at [`BAUD`] (from the 84 MHz APB2 clock on hardware; QEMU ignores the
    /// rate) with its receive interrupt.
    pub fn new(usart: USART1, rcc: &stm32f4::stm32f405::RCC) -> Self {
        rcc.apb2enr().modify(|_, w| w.usart1en().set_bit());
        // 84 MHz / 921 600 = 91.1: 0.1 % fast, well inside a UART's tolerance.
        let brr = ((84_000_000 + BAUD / 2) / BAUD) as u16;
        // SAFETY: BRR takes any 16-bit divider; 91 is within it.
        usart.brr().write(|w| unsafe { w.bits(brr) });
        usart.cr1().write(|w| {
            w.ue()
                .set_bit()
                .te()
                .set_bit()
                .re()
                .set_bit()
                .rxneie()
                .set_bit()
        });
        Self {
            usart,
            encoder: flexarm_link::Encoder::new(),
        }
    }
}

/// Sends `bytes`, waiting for the transmit register (idle task only).
fn write_all(usart: &USART1, bytes: &[u8]) {
    for b in bytes {
        while usart.sr().read().txe().bit_is_clear() {}
        // SAFETY: DR takes any 9-bit value; a byte is within it.
        usart.dr().write(|w| unsafe { w.dr().bits(u16::from(*b)) });
    }
}

/// What the idle task read for an answer besides the controller and the drive.
#[derive(Clone, Copy, Debug)]
pub struct Io {
    /// A fresh measurement (for `clear`).
    pub y: Measurement<f32>,
    /// The amplifiers' fault line.
    pub amplifier_fault: bool,
    /// Motor periods since boot (the last telemetry sample's).
    pub ticks: u64,
    /// Telemetry records the motor loop could not queue.
    pub dropped: u32,
    /// Bytes received since boot.
    pub rx_bytes: u32,
    /// Bytes lost because the receive queue was full.
    pub rx_lost: u32,
    /// The stack's high-water mark [bytes] (measured for a status request only).
    pub stack_used: u32,
}

/// One host session: the decoder, the subscription and the tunable parameters.
pub struct Session {
    decoder: flexarm_link::Decoder,
    tuning: Tuning<f32>,
    /// The channels while subscribed (the decimation is [`STREAM_EVERY`]).
    subscription: Option<Channels>,
    seq: u32,
    dropped: u32,
}

impl Session {
    /// No host yet; `tuning` holds the parameters in force.
    pub const fn new(tuning: Tuning<f32>) -> Self {
        Self {
            decoder: flexarm_link::Decoder::new(),
            tuning,
            subscription: None,
            seq: 0,
            dropped: 0,
        }
    }

    /// Takes one received byte; returns a complete request. A frame that does not decode is
    /// dropped (it has no id to answer) and logged.
    #[inline(never)]
    pub fn receive(&mut self, byte: u8) -> Option<Request> {
        match self.decoder.push_request(byte)? {
            Ok(req) => Some(req),
            Err(e) => {
                defmt::warn!("link: frame dropped: {=str}", frame_error(e));
                None
            }
        }
    }

    /// The answer to `command`, applied to the controller and the drive (the caller holds
    /// both for the duration: a few microseconds). Moves are [`start_move`]'s.
    #[inline(never)]
    pub fn answer(
        &mut self,
        command: Command,
        ctrl: &mut Controller<f32>,
        drive: &mut Drive<f32>,
        recorder: &mut crate::app::FaultRecorder,
        io: &Io,
    ) -> Reply {
        let done = |r: Result<(), Refused>| match r {
            Ok(()) => Reply::Done,
            Err(e) => Reply::Refused(refusal(e)),
        };
        let now = drive.next_tick();
        drive.heard(now);
        match command {
            Command::Hello { version } if version != VERSION => Reply::Refused(Refusal::Version),
            Command::Hello { .. } => Reply::Hello(hello()),
            Command::Status => Reply::Status(Status {
                mode: mode(drive.mode(ctrl)),
                fault: ctrl.fault().map(|f| f as u8),
                ticks: io.ticks,
                loads: [load(&crate::stats::PIEZO), load(&crate::stats::MOTOR)],
                telemetry_dropped: io.dropped.saturating_add(self.dropped),
                link_stops: drive.link_stops(),
                rx_bytes: io.rx_bytes,
                rx_lost: io.rx_lost,
                stack_used: io.stack_used,
            }),
            Command::Ping => Reply::Done,
            Command::Arm => done(drive.arm(ctrl, now)),
            Command::Disarm | Command::Estop => {
                drive.disarm(ctrl);
                Reply::Done
            }
            Command::Stop => done(drive.stop(ctrl, now)),
            Command::Clear => match drive.clear(ctrl, Some(&io.y), io.amplifier_fault) {
                Ok(f) => {
                    recorder.restart();
                    Reply::Cleared(f as u8)
                }
                Err(e) => Reply::Refused(refusal(e)),
            },
            Command::Faults { from } => {
                let total = recorder.len();
                let from = usize::from(from);
                if from > total {
                    return Reply::Refused(Refusal::NoRecord);
                }
                let mut samples = heapless::Vec::new();
                for i in from..total.min(from + SAMPLES_PER_PAGE) {
                    if let Some(s) = recorder.get(i) {
                        let _ = samples.push(RecordedSample {
                            tick: s.tick,
                            theta: s.theta,
                            error: s.error,
                            delta: s.delta,
                            tau: s.tau,
                            v_f: s.v_f,
                        });
                    }
                }
                Reply::Faults(FaultPage {
                    fault: recorder.fault().map(|f| f as u8),
                    total: total as u16,
                    from: from as u16,
                    samples,
                })
            }
            // Done by the caller on the QEMU link-session build, which owns the board.
            Command::TestAmplifierFault(_) if cfg!(feature = "link-session") => Reply::Done,
            // The caller's (start_move), outside this lock.
            Command::Move(_) => Reply::Refused(Refusal::Unsupported),
            Command::Waypoints { first, points } => {
                let mut w = [Waypoint {
                    theta: Vector2::zeros(),
                    dt: 0.0,
                }; flexarm_link::msg::WAYPOINTS_PER_CHUNK];
                for (w, p) in w.iter_mut().zip(&points) {
                    *w = Waypoint {
                        theta: Vector2::new(p.theta[0], p.theta[1]),
                        dt: p.dt,
                    };
                }
                let w = w.get(..points.len()).unwrap_or(&[]);
                done(drive.load_waypoints(ctrl, usize::from(first), w))
            }
            Command::Subscribe {
                decimation,
                channels,
            } => {
                if decimation == 0
                    || !channels.is_valid()
                    || channels.values() > MAX_CHANNELS
                    || !fits_the_line(decimation, channels)
                {
                    Reply::Refused(Refusal::OutOfRange)
                } else {
                    self.subscription = Some(channels);
                    STREAM_EVERY.store(u32::from(decimation), Relaxed);
                    Reply::Done
                }
            }
            Command::Unsubscribe => {
                self.subscription = None;
                STREAM_EVERY.store(0, Relaxed);
                Reply::Done
            }
            Command::Get(Param::VaBias) => Reply::Value(f32::from_bits(PIEZO_BIAS.load(Relaxed))),
            Command::Set(Param::VaBias, v) => match drive.mode(ctrl) {
                drive::Mode::Armed => {
                    let l = &ctrl.motor.limits;
                    if (l.v_a_min..=l.v_a_max).contains(&v) {
                        PIEZO_BIAS.store(v.to_bits(), Relaxed);
                        Reply::Done
                    } else {
                        Reply::Refused(Refusal::OutOfRange)
                    }
                }
                drive::Mode::Moving | drive::Mode::Stopping => Reply::Refused(Refusal::Moving),
                drive::Mode::Fault => Reply::Refused(Refusal::Faulted),
                drive::Mode::Disarmed => Reply::Refused(Refusal::NotArmed),
            },
            Command::Get(Param::LinkTimeout) => {
                Reply::Value(drive.link_timeout as f32 / MOTOR_HZ as f32)
            }
            Command::Set(Param::LinkTimeout, v) => {
                if matches!(
                    drive.mode(ctrl),
                    drive::Mode::Moving | drive::Mode::Stopping
                ) {
                    Reply::Refused(Refusal::Moving)
                } else if (0.0..=3600.0).contains(&v) {
                    drive.link_timeout = (v * MOTOR_HZ as f32) as u32;
                    Reply::Done
                } else {
                    Reply::Refused(Refusal::OutOfRange)
                }
            }
            Command::Get(p) => match tunable(p).and_then(|p| self.tuning.get(ctrl, p)) {
                Ok(v) => Reply::Value(v),
                Err(e) => Reply::Refused(tune_refusal(e)),
            },
            Command::Set(p, v) => {
                let mode = drive.mode(ctrl);
                match tunable(p).and_then(|p| self.tuning.set(ctrl, mode, p, v)) {
                    Ok(()) => Reply::Done,
                    Err(e) => Reply::Refused(tune_refusal(e)),
                }
            }
            Command::TestAmplifierFault(_) => Reply::Refused(Refusal::Unsupported),
        }
    }

    /// The telemetry frame of a motor-loop record the motor loop marked for the stream (at the
    /// subscription's decimation, [`STREAM_EVERY`]), while subscribed.
    #[inline(never)]
    pub fn telemetry(&mut self, r: &Record) -> Option<Telemetry> {
        let Record::Sample {
            tick,
            error,
            theta,
            delta,
            tau,
            v_a,
            v_f,
            stream: true,
            ..
        } = *r
        else {
            return None;
        };
        let channels = self.subscription?;
        let mut values = heapless::Vec::<f32, MAX_CHANNELS>::new();
        let c = channels.0;
        let load =
            |s: &crate::stats::TaskStats, hz: u32| s.mean() as f32 / (crate::clock::HZ / hz) as f32;
        let loads = [
            load(&crate::stats::PIEZO, PIEZO_HZ),
            load(&crate::stats::MOTOR, MOTOR_HZ),
        ];
        for (bit, v) in [
            (Channels::ERROR, &error[..]),
            (Channels::THETA, &theta[..]),
            (Channels::DELTA, &delta[..]),
            (Channels::TAU, &tau[..]),
            (Channels::V_A, &[v_a][..]),
            (Channels::V_F, &[v_f][..]),
            (Channels::LOAD, &loads[..]),
        ] {
            if c & bit != 0 {
                let _ = values.extend_from_slice(v);
            }
        }
        let seq = self.seq;
        self.seq = self.seq.wrapping_add(1);
        Some(Telemetry {
            seq,
            tick,
            channels,
            values,
        })
    }

    /// A telemetry frame could not be sent (counted; its sequence number is spent).
    pub fn dropped(&mut self) {
        self.dropped = self.dropped.saturating_add(1);
    }
}

/// A copy of what a move's validation reads: the drive (its limits and waypoints) and the motor
/// law (its model and torque limits), with the pose held. A static (the idle task's), not on
/// the stack: it is about 700 bytes.
pub type Snapshot = (Drive<f32>, MotorController<f32>, Vector2<f32>);

/// Validates and starts a move. The drive and the motor law are copied into `snapshot` under a
/// short lock; the plan is made outside every lock (a circle's 200 checked points take about a
/// motor period on the board, which the motor loop must not wait for); then one short lock
/// starts it, if the drive still holds the pose it was planned from.
#[inline(never)]
pub fn start_move(
    m: Move,
    ctrl: &mut impl rtic::Mutex<T = Controller<f32>>,
    drive: &mut impl rtic::Mutex<T = Drive<f32>>,
    snapshot: &mut Snapshot,
) -> Reply {
    let request = match m {
        Move::Trapezoid {
            target,
            move_time,
            ramp_time,
        } => MoveRequest::Trapezoid {
            target: Vector2::new(target[0], target[1]),
            move_time,
            ramp_time,
        },
        Move::Circle {
            centre,
            radius,
            period,
            ramp_time,
            clockwise,
        } => MoveRequest::Circle {
            centre: Vector2::new(centre[0], centre[1]),
            radius,
            period,
            ramp_time,
            clockwise,
        },
        Move::Waypoints { count } => MoveRequest::Waypoints {
            count: usize::from(count),
        },
    };
    ctrl.lock(|c| {
        drive.lock(|d| {
            d.heard(d.next_tick());
            snapshot.0 = *d;
            snapshot.1 = c.motor;
            snapshot.2 = d.held(c, d.next_tick());
        })
    });
    let (d, motor, from) = snapshot;
    let plan = match d.plan(motor, *from, &request) {
        Ok(p) => p,
        Err(e) => return Reply::Refused(refusal(e)),
    };
    ctrl.lock(|c| drive.lock(|d| d.begin(c, d.next_tick(), &plan)))
        .map_or_else(|e| Reply::Refused(refusal(e)), |_| Reply::Done)
}

fn load(s: &crate::stats::TaskStats) -> Load {
    Load {
        mean_cycles: s.mean(),
        worst_cycles: s.worst(),
        misses: s.misses(),
    }
}

fn mode(m: drive::Mode) -> Mode {
    match m {
        drive::Mode::Disarmed => Mode::Disarmed,
        drive::Mode::Armed => Mode::Armed,
        drive::Mode::Moving => Mode::Moving,
        drive::Mode::Stopping => Mode::Stopping,
        drive::Mode::Fault => Mode::Fault,
    }
}

fn refusal(r: Refused) -> Refusal {
    match r {
        Refused::Faulted => Refusal::Faulted,
        Refused::NotArmed => Refusal::NotArmed,
        Refused::Moving => Refusal::Moving,
        Refused::CauseActive => Refusal::CauseActive,
        Refused::OutOfRange => Refusal::OutOfRange,
        Refused::Unreachable => Refusal::Unreachable,
        Refused::TooFast => Refusal::TooFast,
        Refused::Waypoints => Refusal::Waypoints,
    }
}

/// The core's name of a link parameter (the link timeout is the drive's, not here).
fn tunable(p: Param) -> Result<Tunable, TuneError> {
    Ok(match p {
        Param::Kp(i) => Tunable::Kp(usize::from(i)),
        Param::Lambda(i) => Tunable::Lambda(usize::from(i)),
        Param::DDelta(i) => Tunable::DDelta(usize::from(i)),
        Param::Kc => Tunable::Kc,
        Param::CutoffHz => Tunable::CutoffHz,
        Param::TauMax(i) => Tunable::TauMax(usize::from(i)),
        Param::VaMax => Tunable::VaMax,
        Param::VaMin => Tunable::VaMin,
        Param::LinkTimeout | Param::VaBias => return Err(TuneError::Unknown),
    })
}

fn tune_refusal(e: TuneError) -> Refusal {
    match e {
        TuneError::Unknown => Refusal::UnknownParam,
        TuneError::OutOfRange => Refusal::OutOfRange,
        TuneError::Moving => Refusal::Moving,
    }
}

#[inline(never)]
fn hello() -> Hello {
    Hello {
        version: VERSION,
        board: if cfg!(feature = "qemu") {
            Board::Qemu
        } else {
            Board::Hardware
        },
        build: heapless::String::try_from(concat!("flexarm-firmware ", env!("CARGO_PKG_VERSION")))
            .unwrap_or_default(),
        params_hash: params_hash(),
        motor_hz: MOTOR_HZ,
        piezo_hz: PIEZO_HZ,
    }
}

/// FNV-1a over the bits of the parameters the firmware boots with: the arm model, the patch,
/// the motor law's gains, the piezo gains, the limits and the observer gain table. Two
/// firmwares with the same hash boot with the same controller numbers (a `Set` over the link
/// changes them afterwards).
pub fn params_hash() -> u32 {
    let a = crate::config::ARM;
    let md = a.modes;
    let p = crate::config::patch();
    let m = crate::config::motor_gains();
    let g = crate::config::piezo_gains();
    let l = crate::config::limits();
    let mut h: u32 = 0x811c_9dc5;
    let mut add = |x: f32| {
        for b in x.to_bits().to_le_bytes() {
            h = (h ^ u32::from(b)).wrapping_mul(0x0100_0193);
        }
    };
    for x in [
        a.a1,
        a.a2,
        a.m1,
        a.m2,
        a.m_h2,
        a.i_1,
        a.i_h1,
        a.i_h2,
        a.i_2_extra,
    ] {
        add(x);
    }
    for v in [
        md.omega,
        md.zeta,
        md.mass_integral,
        md.moment_integral,
        md.tip,
    ] {
        add(v.x);
        add(v.y);
    }
    for x in [p.x_a, p.l_a, p.slope_diff.x, p.slope_diff.y, p.k_a, p.k_s] {
        add(x);
    }
    for x in [
        m.kp.x,
        m.kp.y,
        m.lambda.x,
        m.lambda.y,
        m.lambda.z,
        m.lambda.w,
        m.d_delta.x,
        m.d_delta.y,
    ] {
        add(x);
    }
    for x in [
        g.k_c,
        g.cutoff_hz,
        l.tau_max.x,
        l.tau_max.y,
        l.v_a_max,
        l.v_a_min,
    ] {
        add(x);
    }
    for row in crate::config::OBSERVER_GAIN {
        for x in row {
            add(*x);
        }
    }
    h
}

fn frame_error(e: flexarm_link::FrameError) -> &'static str {
    use flexarm_link::FrameError as E;
    match e {
        E::TooLarge => "too large",
        E::Oversized => "oversized",
        E::Cobs => "bad COBS",
        E::Truncated => "truncated",
        E::Crc => "bad CRC",
        E::Malformed => "malformed",
    }
}

/// Encodes and sends one message (the encoder's buffers are the [`Serial`]'s, not the stack's).
#[inline(never)]
pub fn send(serial: &mut Serial, msg: &DeviceMsgRef<'_>) -> bool {
    let Serial { usart, encoder } = serial;
    match encoder.device(msg) {
        Ok(frame) => {
            write_all(usart, frame);
            true
        }
        Err(_) => false,
    }
}

//! The command link's session, the board's side: requests decoded from the line's bytes, each
//! answered on the controller, the drive and the fault recorder; the telemetry the host
//! subscribed to; and the conversions between the link's messages (`flexarm_link::msg`) and
//! the core's types. The transport (a USART, a socket) is the caller's.
//!
//! The commands act on the drive (`flexarm_core::drive`): arm, disarm, estop, trapezoid,
//! circle and waypoint moves (the waypoints uploaded in chunks), stop, clear; `get`/`set` on the
//! tunable parameters (`flexarm_core::tuning`), the link watchdog's timeout and the piezo bias;
//! the fault recorder's pages. A move is validated outside the control loops' locks
//! ([`start_move`]).
//!
//! The firmware calls these from several places of its idle task; none is inlined
//! (`#[inline(never)]`), which keeps each in flash once.

use flexarm_core::Vector2;
use flexarm_core::control::motor::MotorController;
use flexarm_core::controller::Controller;
use flexarm_core::drive::{self, Drive, MoveRequest, Refused, Waypoint};
use flexarm_core::observer::Measurement;
use flexarm_core::tuning::{Tunable, TuneError, Tuning};
use flexarm_link::msg::{
    Board, Channels, Command, FaultPage, Hello, HomeState, Load, MAX_CHANNELS, Mode, Move, Param,
    RecordedSample, Refusal, Reply, SAMPLES_PER_PAGE, Settings, Status, Telemetry,
};
use flexarm_link::params::PARAMS;
use flexarm_link::{FrameError, Request, VERSION};
use rtic_core::Mutex;

use crate::period::{Control, FaultRecorder};
use crate::store;
use crate::telemetry::{self, Record};

/// The line's rate [baud] (8N1): the hardware board's USART. A stream must fit in 80 % of it.
pub const BAUD: u32 = 921_600;

/// Who answers the handshake.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Identity {
    /// Which board.
    pub board: Board,
    /// The build's name.
    pub build: &'static str,
    /// The configuration's hash (`BoardConfig::hash`).
    pub params_hash: u32,
    /// Motor loop rate [Hz].
    pub motor_hz: u32,
    /// Piezo loop rate [Hz].
    pub piezo_hz: u32,
    /// The build answers the test commands (`Command::TestAmplifierFault`: the QEMU
    /// link-session build, whose caller owns the simulated fault line); others refuse them.
    pub test_commands: bool,
}

/// What the caller read for an answer besides the controller, the drive and the recorder.
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
    /// The receiver's line errors.
    pub rx_line: flexarm_link::msg::LineErrors,
    /// The stack's high-water mark [bytes] (measured for a status request only).
    pub stack_used: u32,
    /// The piezo and motor loops' loads (for a status request only).
    pub loads: [Load; 2],
    /// The brake output as the board reads it back (`Board::brake_engaged`).
    pub brake_engaged: bool,
}

/// One host session: the decoder, the subscription and the tunable parameters.
pub struct Session {
    decoder: flexarm_link::Decoder,
    tuning: Tuning<f32>,
    identity: Identity,
    /// The channels while subscribed (the decimation is `Control::stream_every`).
    subscription: Option<Channels>,
    seq: u32,
    dropped: u32,
    /// Request frames that did not decode.
    malformed: u32,
    /// The last request that acts on the arm or its settings, and its answer: the same id
    /// again (a host's retry after a lost reply) gets this answer, the request not applied a
    /// second time. A handshake forgets it (a new host counts its ids from the start).
    applied: Option<(u16, Answer)>,
    /// The board's saved settings as this session found and changed them (the handshake's).
    settings: Settings,
}

/// The answer to a request that acts (the only kinds it has), kept for a repeat.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Answer {
    Done,
    Cleared(u8),
    Refused(Refusal),
}

impl Answer {
    fn of(reply: &Reply) -> Option<Self> {
        match *reply {
            Reply::Done => Some(Self::Done),
            Reply::Cleared(f) => Some(Self::Cleared(f)),
            Reply::Refused(r) => Some(Self::Refused(r)),
            _ => None,
        }
    }

    fn reply(self) -> Reply {
        match self {
            Self::Done => Reply::Done,
            Self::Cleared(f) => Reply::Cleared(f),
            Self::Refused(r) => Reply::Refused(r),
        }
    }
}

/// What a request does, for its repeats ([`Session::repeated`], [`Session::remember`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// The handshake: a new host, which counts its ids from the start.
    Handshake,
    /// Acts on the arm, the drive, the recorder or the settings: applying it twice is not
    /// applying it once (a second `Move` would be refused as moving or start again, a second
    /// `Clear` be refused as having nothing to clear).
    Acts,
    /// Only reads (status, a value, a page of the recorder, a ping): a repeat reads again.
    Reads,
}

impl Kind {
    /// The kind of `command`.
    pub fn of(command: &Command) -> Self {
        match command {
            Command::Hello { .. } => Self::Handshake,
            Command::Status | Command::Get(_) | Command::Faults { .. } | Command::Ping => {
                Self::Reads
            }
            _ => Self::Acts,
        }
    }
}

/// Whether a stream of `channels` every `decimation` motor periods of a `motor_hz` loop fits
/// in 80 % of the line (the rest for replies): `frame bytes · motor_hz / decimation ≤
/// 0.8 · BAUD / 10` (8N1). The QEMU board's socket has no baud rate; the same rule holds
/// there, at its own loop rate.
fn fits_the_line(decimation: u16, channels: Channels, motor_hz: u32) -> bool {
    // At most 87 bytes × 10 kHz × 100 and 8 × 921 600: both within a u32.
    let per_second = channels.frame_bytes() as u32 * motor_hz / u32::from(decimation.max(1));
    per_second * 100 <= 8 * BAUD
}

impl Session {
    /// No host yet; `tuning` holds the parameters in force.
    pub const fn new(tuning: Tuning<f32>, identity: Identity) -> Self {
        Self {
            decoder: flexarm_link::Decoder::new(),
            tuning,
            identity,
            subscription: None,
            seq: 0,
            dropped: 0,
            malformed: 0,
            applied: None,
            settings: Settings::Defaults,
        }
    }

    /// What the handshake says of the board's saved settings.
    pub fn set_settings(&mut self, settings: Settings) {
        self.settings = settings;
    }

    /// The running value of every parameter a save keeps ([`store::Values::saved`]).
    #[inline(never)]
    pub fn values(&self, control: &Control, drive: &Drive<f32>) -> store::Values {
        let mut values = store::Values::none();
        for (slot, info) in values.0.iter_mut().zip(PARAMS) {
            if store::Values::saved(info.param)
                && let Some(v) = self.get(info.param, control, drive)
            {
                *slot = v;
            }
        }
        values
    }

    /// Applies saved `values` at boot, each through a `Set`'s checks (its range, the
    /// controller's rules, the drive's), in the wire's order, those refused tried once more
    /// after the others (a rule between two parameters). When one is still refused, every
    /// value applied is set back, last first, and the refused parameter is returned: the
    /// build's defaults run. Each value is read and written under its own short lock, as a
    /// host's `Get` and `Set` are (all of them under one lock held the loops off for longer
    /// than a period: a latched overrun on the QEMU board).
    #[inline(never)]
    pub fn apply(
        &mut self,
        values: &store::Values,
        control: &mut impl Mutex<T = Control>,
        drive: &mut impl Mutex<T = Drive<f32>>,
    ) -> Result<(), Param> {
        let mut old = [None; store::COUNT];
        let mut done = [false; store::COUNT];
        let mut order = [0u8; store::COUNT];
        let mut applied = 0;
        for pass in 0..2 {
            for (i, info) in PARAMS.iter().enumerate() {
                let (Some(v), Some(false)) = (values.get(i), done.get(i).copied()) else {
                    continue;
                };
                let (before, reply) = control.lock(|c| {
                    drive.lock(|d| (self.get(info.param, c, d), self.set(info.param, v, c, d)))
                });
                match reply {
                    Reply::Done => {
                        if let (Some(o), Some(d), Some(slot)) =
                            (old.get_mut(i), done.get_mut(i), order.get_mut(applied))
                        {
                            *o = before;
                            *d = true;
                            *slot = i as u8;
                            applied += 1;
                        }
                    }
                    _ if pass == 1 => {
                        for &j in order.get(..applied).unwrap_or(&[]).iter().rev() {
                            let j = usize::from(j);
                            if let (Some(Some(o)), Some(p)) = (old.get(j), PARAMS.get(j)) {
                                control.lock(|c| {
                                    drive.lock(|d| {
                                        let _ = self.set(p.param, *o, c, d);
                                    })
                                });
                            }
                        }
                        return Err(info.param);
                    }
                    _ => {}
                }
            }
        }
        Ok(())
    }

    /// A `Set` of `p` to `v`: its range, the rule while moving, the controller's and the
    /// drive's checks. The caller calls it for the link's `Set` (not [`Self::answer`]: the
    /// piezo law's design, under it, is the idle task's deepest call chain), with the drive
    /// told it heard the host.
    #[inline(never)]
    pub fn set(
        &mut self,
        p: Param,
        v: f32,
        control: &mut Control,
        drive: &mut Drive<f32>,
    ) -> Reply {
        let id = &self.identity;
        let ctrl = &mut control.ctrl;
        let mode = drive.mode(ctrl);
        let ((min, max), while_moving) = rule(p);
        if !while_moving
            && matches!(
                mode,
                drive::Mode::Moving | drive::Mode::Stopping | drive::Mode::Homing
            )
        {
            return Reply::Refused(Refusal::Moving);
        }
        // Written so that NaN is refused too.
        if !(min..=max).contains(&v) {
            return Reply::Refused(Refusal::OutOfRange);
        }
        match home(p) {
            Home::Tuning(t) => match self.tuning.set(ctrl, mode, t, v) {
                Ok(()) => Reply::Done,
                Err(e) => Reply::Refused(tune_refusal(e)),
            },
            // 0 turns the watchdog off; any other value is at least
            // MIN_LINK_TIMEOUT_PERIODS motor periods (a shorter one rounded to 0 and
            // turned it off unasked, issue 36).
            Home::LinkTimeout => {
                let periods = v * id.motor_hz as f32;
                if v != 0.0 && periods < MIN_LINK_TIMEOUT_PERIODS as f32 {
                    return Reply::Refused(Refusal::OutOfRange);
                }
                drive.link_timeout = periods as u32;
                Reply::Done
            }
            Home::StallSpeedError => {
                drive.motion.stall_speed_error = v;
                Reply::Done
            }
            // Within the amplifier's window, while the drive holds.
            Home::Bias => match mode {
                drive::Mode::Armed => {
                    let l = &ctrl.motor.limits;
                    if (l.v_a_min..=l.v_a_max).contains(&v) {
                        control.piezo_bias = v;
                        Reply::Done
                    } else {
                        Reply::Refused(Refusal::OutOfRange)
                    }
                }
                drive::Mode::Fault => Reply::Refused(Refusal::Faulted),
                _ => Reply::Refused(Refusal::NotArmed),
            },
        }
    }

    /// The running value of `p` (a `Get`'s).
    fn get(&self, p: Param, control: &Control, drive: &Drive<f32>) -> Option<f32> {
        match home(p) {
            // The rated limit, not the one the motors' heat derates it to now: what a `Set`
            // sets and a configuration's dump keeps (issue 33: after a power-on the motors
            // are assumed hot, and a dump read the derating of the moment).
            Home::Tuning(Tunable::TauMax(i)) => drive.rated_torque().get(i).copied(),
            Home::Tuning(t) => self.tuning.get(&control.ctrl, t).ok(),
            Home::LinkTimeout => Some(drive.link_timeout as f32 / self.identity.motor_hz as f32),
            Home::StallSpeedError => Some(drive.motion.stall_speed_error),
            Home::Bias => Some(control.piezo_bias),
        }
    }

    /// Takes one received byte; returns a complete request, or the error of a frame that did
    /// not decode (it has no id to answer; counted in `Status::rx_malformed`, the caller logs
    /// it).
    #[inline(never)]
    pub fn receive(&mut self, byte: u8) -> Option<Result<Request, FrameError>> {
        let r = self.decoder.push_request(byte);
        if let Some(Err(_)) = r {
            self.malformed = self.malformed.saturating_add(1);
        }
        r
    }

    /// The answer already given to `request` when it repeats the last request that acted, by
    /// its id: the host retried after losing the reply, and the request is not applied again.
    /// `None`: answer it ([`Self::answer`], [`start_move`]), then [`Self::remember`] it.
    pub fn repeated(&self, request: &Request) -> Option<Reply> {
        match self.applied {
            Some((id, answer)) if id == request.id && Kind::of(&request.command) == Kind::Acts => {
                Some(answer.reply())
            }
            _ => None,
        }
    }

    /// Keeps `reply`, the answer to the request `id` of kind `kind`, for a repeat (a request
    /// that acts), or forgets the last one (a handshake: a new host).
    pub fn remember(&mut self, id: u16, kind: Kind, reply: &Reply) {
        match kind {
            Kind::Handshake => self.applied = None,
            Kind::Acts => self.applied = Answer::of(reply).map(|a| (id, a)),
            Kind::Reads => {}
        }
    }

    /// The answer to `command`, applied to the controller, the drive and the fault recorder
    /// (the caller holds them for the duration: a few microseconds). Moves are
    /// [`start_move`]'s, a `Set` is [`Self::set`]'s.
    #[inline(never)]
    pub fn answer(
        &mut self,
        command: Command,
        control: &mut Control,
        drive: &mut Drive<f32>,
        recorder: &mut FaultRecorder,
        io: &Io,
    ) -> Reply {
        let done = |r: Result<(), Refused>| match r {
            Ok(()) => Reply::Done,
            Err(e) => Reply::Refused(refusal(e)),
        };
        let id = &self.identity;
        let ctrl = &mut control.ctrl;
        let now = drive.next_tick();
        drive.heard(now);
        match command {
            Command::Hello { version } if version != VERSION => Reply::Refused(Refusal::Version),
            Command::Hello { .. } => Reply::Hello(hello(id, self.settings)),
            Command::Status => Reply::Status(Status {
                mode: mode(drive.mode(ctrl)),
                fault: ctrl.fault().map(|f| f as u8),
                ticks: io.ticks,
                loads: io.loads,
                telemetry_dropped: io.dropped.saturating_add(self.dropped),
                link_stops: drive.link_stops(),
                rx_bytes: io.rx_bytes,
                rx_lost: io.rx_lost,
                rx_malformed: self.malformed,
                rx_line: io.rx_line,
                stack_used: io.stack_used,
                homing: drive.homing().states().map(home_state),
                homing_failed: drive.homing().failed(),
                brake_engaged: io.brake_engaged,
            }),
            Command::Ping => Reply::Done,
            Command::Arm => done(drive.arm(ctrl, now)),
            Command::Home => done(drive.home(ctrl, now)),
            Command::DeclareHome { theta } => {
                done(drive.declare(ctrl, Vector2::new(theta[0], theta[1])))
            }
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
            Command::Faults { from } => fault_page(recorder, from),
            // Done by the caller on a build that answers test commands (it owns the board).
            Command::TestAmplifierFault(_) if id.test_commands => Reply::Done,
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
                    || !fits_the_line(decimation, channels, id.motor_hz)
                {
                    Reply::Refused(Refusal::OutOfRange)
                } else {
                    self.subscription = Some(channels);
                    control.stream_every = u32::from(decimation);
                    Reply::Done
                }
            }
            Command::Unsubscribe => {
                self.subscription = None;
                control.stream_every = 0;
                Reply::Done
            }
            Command::Get(p) => match self.get(p, control, drive) {
                Some(v) => Reply::Value(v),
                None => Reply::Refused(Refusal::UnknownParam),
            },
            // The caller's, [`Self::set`] (a `Set` of the piezo law designs it, the idle
            // task's deepest call chain, which need not run under this function's frame).
            Command::Set(..) => Reply::Refused(Refusal::Unsupported),
            // The caller's (outside every lock: a flash write stalls the CPU), through
            // [`Self::values`] and `store::Store`.
            Command::ConfigSave | Command::ConfigErase => Reply::Refused(Refusal::Unsupported),
            Command::TestAmplifierFault(_) => Reply::Refused(Refusal::Unsupported),
        }
    }

    /// The telemetry frame of a record the motor loop marked for the stream (at the
    /// subscription's decimation), while subscribed; `loads` gives the loops' loads [fraction
    /// of their periods] for the load channel.
    #[inline(never)]
    pub fn telemetry(&mut self, r: &Record, loads: [f32; 2]) -> Option<Telemetry> {
        let Record::Sample {
            tick,
            brake,
            stream: true,
            ..
        } = *r
        else {
            return None;
        };
        let channels = self.subscription?;
        let seq = self.seq;
        self.seq = self.seq.wrapping_add(1);
        Some(Telemetry {
            seq,
            tick,
            brake_engaged: brake,
            channels,
            values: telemetry::values(r, channels, loads),
        })
    }

    /// A telemetry frame could not be sent (counted; its sequence number is spent).
    pub fn dropped(&mut self) {
        self.dropped = self.dropped.saturating_add(1);
    }
}

/// A page of the fault recorder from sample `from`.
fn fault_page(recorder: &FaultRecorder, from: u16) -> Reply {
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

/// A copy of what a move's validation reads: the drive (its limits and waypoints) and the motor
/// law (its model and torque limits), with the pose held. The firmware keeps it in a static
/// (about 700 bytes), not on the stack.
pub type Snapshot = (Drive<f32>, MotorController<f32>, Vector2<f32>);

/// A first snapshot, of `drive` and `ctrl`'s motor law.
pub fn snapshot(ctrl: &Controller<f32>, drive: &Drive<f32>) -> Snapshot {
    (*drive, ctrl.motor, Vector2::zeros())
}

/// The core's request for a move of the link.
pub fn move_request(m: &Move) -> MoveRequest<f32> {
    match *m {
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
    }
}

/// Validates and starts a move. The drive and the motor law are copied into `snapshot` under a
/// short lock; the plan is made outside every lock (a circle's 200 checked points take about a
/// motor period on the board, which the motor loop must not wait for); then one short lock
/// starts it, if the drive still holds the pose it was planned from.
#[inline(never)]
pub fn start_move(
    m: Move,
    control: &mut impl Mutex<T = Control>,
    drive: &mut impl Mutex<T = Drive<f32>>,
    snapshot: &mut Snapshot,
) -> Reply {
    let request = move_request(&m);
    control.lock(|c| {
        drive.lock(|d| {
            d.heard(d.next_tick());
            snapshot.0 = *d;
            snapshot.1 = c.ctrl.motor;
            snapshot.2 = d.held(&c.ctrl, d.next_tick());
        })
    });
    let (d, motor, from) = snapshot;
    let plan = match d.plan(motor, *from, &request) {
        Ok(p) => p,
        Err(e) => return Reply::Refused(refusal(e)),
    };
    control
        .lock(|c| drive.lock(|d| d.begin(&mut c.ctrl, d.next_tick(), &plan)))
        .map_or_else(|e| Reply::Refused(refusal(e)), |_| Reply::Done)
}

/// The link's mode of the drive's.
pub fn mode(m: drive::Mode) -> Mode {
    match m {
        drive::Mode::Disarmed => Mode::Disarmed,
        drive::Mode::Armed => Mode::Armed,
        drive::Mode::Moving => Mode::Moving,
        drive::Mode::Stopping => Mode::Stopping,
        drive::Mode::Fault => Mode::Fault,
        drive::Mode::Homing => Mode::Homing,
    }
}

/// The link's homing state of a joint's.
pub fn home_state(s: flexarm_core::homing::State) -> HomeState {
    use flexarm_core::homing::State;
    match s {
        State::Unhomed => HomeState::Unhomed,
        State::Searching => HomeState::Searching,
        State::Homed => HomeState::Homed,
        State::Declared => HomeState::Declared,
    }
}

/// The link's refusal of the drive's.
pub fn refusal(r: Refused) -> Refusal {
    match r {
        Refused::Faulted => Refusal::Faulted,
        Refused::NotArmed => Refusal::NotArmed,
        Refused::Moving => Refusal::Moving,
        Refused::CauseActive => Refusal::CauseActive,
        Refused::OutOfRange => Refusal::OutOfRange,
        Refused::Unreachable => Refusal::Unreachable,
        Refused::TooFast => Refusal::TooFast,
        Refused::Waypoints => Refusal::Waypoints,
        Refused::NotHomed => Refusal::NotHomed,
    }
}

/// The shortest link watchdog a `Set` gives [motor periods]: the watchdog counts whole motor
/// periods, and a host's requests come a few periods apart at best.
pub const MIN_LINK_TIMEOUT_PERIODS: u32 = 3;

/// Where the running board keeps a parameter (its declaration's home,
/// `flexarm_link::for_each_param!`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Home {
    /// The controller's, through `flexarm_core::tuning`.
    Tuning(Tunable),
    /// The drive's link watchdog.
    LinkTimeout,
    /// The stall check's speed error (`flexarm_core::motion::MotionLimits::stall_speed_error`).
    StallSpeedError,
    /// The piezo bias ([`Control::piezo_bias`]).
    Bias,
}

/// `home` and `rule` from the parameters' declaration.
macro_rules! session_params {
    ($($variant:ident $name:literal $unit:literal ($min:expr, $max:expr) $moving:ident
       {$($field:tt)*} $home:ident $(($($h:tt)*))? $doc:literal;)*) => {
        /// Where the running board keeps `p`.
        pub fn home(p: Param) -> Home {
            match p {
                $(Param::$variant => session_params!(@home $home $(($($h)*))?),)*
            }
        }

        /// The range a `Set` of `p` must fall in, and whether it is accepted while moving.
        pub fn rule(p: Param) -> ((f32, f32), bool) {
            match p {
                $(Param::$variant => (($min, $max), session_params!(@moving $moving)),)*
            }
        }
    };
    (@home tuning ($($t:tt)*)) => { Home::Tuning(Tunable::$($t)*) };
    (@home drive (link_timeout)) => { Home::LinkTimeout };
    (@home drive (stall_speed_error)) => { Home::StallSpeedError };
    (@home bias) => { Home::Bias };
    (@moving moving) => { true };
    (@moving fixed) => { false };
}

flexarm_link::for_each_param!(session_params);

fn tune_refusal(e: TuneError) -> Refusal {
    match e {
        TuneError::Unknown => Refusal::UnknownParam,
        TuneError::OutOfRange => Refusal::OutOfRange,
        TuneError::Moving => Refusal::Moving,
        TuneError::Armed => Refusal::Armed,
        TuneError::Unidentified => Refusal::Unidentified,
        TuneError::Unstable => Refusal::Unstable,
    }
}

#[inline(never)]
fn hello(id: &Identity, settings: Settings) -> Hello {
    Hello {
        version: VERSION,
        board: id.board,
        build: heapless::String::try_from(id.build).unwrap_or_default(),
        params_hash: id.params_hash,
        motor_hz: id.motor_hz,
        piezo_hz: id.piezo_hz,
        settings,
    }
}

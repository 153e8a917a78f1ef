//! A session with the firmware: the handshake, then requests and their replies, with the
//! telemetry that arrives meanwhile kept.

use std::time::{Duration, Instant};

use flexarm_link::msg::{Channels, Hello, Param, Refusal, Status, Telemetry};
use flexarm_link::{Command, Decoder, DeviceMsg, MAX_FRAME, Reply, Request, VERSION};

use crate::transport::Link;

/// What went wrong, as one line.
#[derive(Clone, Debug, PartialEq)]
pub enum ConsoleError {
    /// The port or socket could not be opened, read or written.
    Io(String),
    /// Bytes came back, none of them a frame of our firmware.
    NotOurFirmware {
        /// Bytes received during the handshake.
        bytes: usize,
    },
    /// Frames of our firmware came back, none of them the handshake's answer: replies to an
    /// earlier session's requests or its telemetry still draining, or a firmware far behind
    /// real time (an emulator on a loaded host), not a dead board (issue 36).
    Backlogged {
        /// Frames received during the handshake.
        frames: usize,
    },
    /// Nothing came back.
    Silent,
    /// The firmware refused the handshake: another protocol version.
    Version,
    /// No reply to a request in time.
    Timeout(String),
    /// The firmware refused a request.
    Refused {
        /// What was asked.
        what: String,
        /// Why it was refused.
        why: Refusal,
    },
    /// The firmware answered with something the request does not expect.
    Unexpected(String),
    /// A command line or file the tool cannot use.
    Usage(String),
    /// Ctrl-C: what was done about it.
    Interrupted(String),
    /// A check failed (bring-up): which, and what to do.
    Failed(String),
}

impl std::fmt::Display for ConsoleError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Io(e) => write!(f, "{e}"),
            Self::NotOurFirmware { bytes } => write!(
                f,
                "{bytes} bytes came back but not one frame of the flexarm firmware: is this the right port and baud rate?"
            ),
            Self::Backlogged { frames } => write!(
                f,
                "{frames} frames of the flexarm firmware came back but no answer to the handshake in its time: the line is still busy with earlier traffic (another session's requests or telemetry) or the firmware runs far behind real time (an emulator on a loaded host); wait a few seconds and try again"
            ),
            Self::Silent => write!(
                f,
                "no answer from the firmware within the handshake's time: is the board powered and booted, the port the right one, and no other program on it?"
            ),
            Self::Version => write!(
                f,
                "the firmware refused protocol version {VERSION}: it was built from another version of flexarm-link; flash the firmware of this checkout or use its console"
            ),
            Self::Timeout(what) => write!(f, "no reply to {what} in time"),
            Self::Refused { what, why } => write!(f, "{what} refused: {}", refusal(*why)),
            Self::Unexpected(what) => write!(f, "unexpected answer: {what}"),
            Self::Usage(what) => write!(f, "{what}"),
            Self::Interrupted(what) => write!(f, "interrupted: {what}"),
            Self::Failed(what) => write!(f, "{what}"),
        }
    }
}

impl std::error::Error for ConsoleError {}

/// What the handshake says of the board's saved settings, in words.
pub fn settings(s: flexarm_link::msg::Settings) -> String {
    use flexarm_link::msg::{Settings, SettingsRefusal};
    match s {
        Settings::Defaults => "the build's defaults (nothing saved)".into(),
        Settings::Loaded => "the settings saved on the board (loaded at boot)".into(),
        Settings::Saved => "the settings saved on the board (saved since boot)".into(),
        Settings::Erased => {
            "erased since boot: the values running now stay until the board resets, then the build's defaults".into()
        }
        Settings::Refused(r) => format!(
            "the build's defaults: the saved settings were refused at boot, {}",
            match r {
                SettingsRefusal::Unreadable =>
                    "the store cannot be read (`flexarm config erase` formats it)".into(),
                SettingsRefusal::Corrupt => "their record fails its CRC".into(),
                SettingsRefusal::Version =>
                    "saved by a firmware of another record layout or protocol version".into(),
                SettingsRefusal::Hash =>
                    "saved by a firmware of another configuration (parameters hash)".into(),
                SettingsRefusal::Value(p) => format!(
                    "the board's checks refused the saved {} (`flexarm config save` or `config erase` replaces them)",
                    p.info().name
                ),
            }
        ),
    }
}

/// A refusal in words.
pub fn refusal(r: Refusal) -> &'static str {
    match r {
        Refusal::Version => "another protocol version",
        Refusal::Moving => "a move or a stop is running",
        Refusal::Faulted => "a fault is latched (read `status`, fix the cause, then `clear`)",
        Refusal::NotArmed => "the drive is disarmed (`arm` first)",
        Refusal::CauseActive => "the fault's cause is still there (or no fault is latched)",
        Refusal::OutOfRange => "a value is out of its range or not finite",
        Refusal::Unstable => {
            "outside what the board's model says is stable at its loop rates, with a factor of 2 (the motor gains' sampled-loop rule; the rate law's k_c ceiling at its filter corner, docs/console.md)"
        }
        Refusal::Unreachable => "the move leaves the arm's reach or the joints' ranges",
        Refusal::TooFast => "the move asks more speed, acceleration or torque than the limits",
        Refusal::Waypoints => {
            "the waypoint list has a gap, is too long, or is not the length named"
        }
        Refusal::UnknownParam => "no such parameter",
        Refusal::NoRecord => "nothing recorded there",
        Refusal::Unsupported => "this firmware does not implement it",
        Refusal::Armed => {
            "only while disarmed: `disarm` first (a change of the piezo law, or of what a law beside the paper's rate law is designed from; a save or an erase of the board's settings)"
        }
        Refusal::Storage => {
            "the board's settings store failed (a flash error, or a store it cannot read: `flexarm config erase` formats it)"
        }
        Refusal::Unidentified => {
            "the law's design rule needs the film's static gain measured: run `flexarm bringup` (its film step writes it) or `set film_static` first"
        }
        Refusal::NotHomed => {
            "a joint is not homed: its encoder counts from where it was at power-up, so no \
             limit holds in the arm's frame (`flexarm home` first; `flexarm home --declare` \
             only when you know the pose)"
        }
    }
}

/// How long the handshake keeps asking.
pub const HANDSHAKE: Duration = Duration::from_secs(3);
/// How a request is retried: sent again with its id (the firmware answers a repeat of a
/// request that acts with its first answer, without applying it again) after each wait of
/// `first`, doubled each time, `attempts` sends in all. A request none of whose sends is
/// answered is reported failed, never taken as done.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Timing {
    /// The first wait for a reply.
    pub first: Duration,
    /// Sends in all.
    pub attempts: u32,
}

impl Default for Timing {
    /// 0.5, 1 and 2 s: a board answers in well under a millisecond plus the line's time; the
    /// QEMU board within a few milliseconds (`docs/link.md`); 3.5 s in all.
    fn default() -> Self {
        Self {
            first: Duration::from_millis(500),
            attempts: 3,
        }
    }
}

/// How long one read of the line waits for bytes: the longest a caller's loop (the live view's
/// keys) waits on a silent line.
const POLL: Duration = Duration::from_millis(10);

/// A session with the firmware.
pub struct Client {
    link: Box<dyn Link>,
    decoder: Decoder,
    next_id: u16,
    /// The firmware's handshake.
    pub hello: Hello,
    /// Telemetry frames received since the last [`Client::take_telemetry`].
    telemetry: Vec<Telemetry>,
    /// Bytes read from the line and not yet decoded (`buffer[at..filled]`).
    buffer: [u8; 512],
    at: usize,
    filled: usize,
    /// How requests are retried.
    pub timing: Timing,
    /// Requests sent again because their reply did not come in time.
    pub retries: u32,
}

/// What one read of the line gave (a frame is short-lived: not boxed).
#[allow(clippy::large_enum_variant)]
enum Read {
    Frame(DeviceMsg),
    /// A byte that did not end a valid frame.
    Byte,
    /// Nothing within [`POLL`].
    Quiet,
}

impl Client {
    /// Opens a session on `link`: `Hello` every 100 ms until the firmware answers, for at most
    /// `timeout` (bytes sent before a board has booted are lost; QEMU waits for the connection).
    pub fn connect(mut link: Box<dyn Link>, timeout: Duration) -> Result<Self, ConsoleError> {
        link.set_timeout(POLL)?;
        let mut c = Self {
            link,
            decoder: Decoder::new(),
            next_id: 0,
            hello: Hello {
                version: 0,
                board: flexarm_link::msg::Board::Qemu,
                build: heapless::String::new(),
                params_hash: 0,
                motor_hz: 0,
                piezo_hz: 0,
                settings: flexarm_link::msg::Settings::Defaults,
            },
            telemetry: Vec::new(),
            buffer: [0; 512],
            at: 0,
            filled: 0,
            timing: Timing::default(),
            retries: 0,
        };
        let (mut received, mut frames) = (0usize, 0usize);
        let start = Instant::now();
        while start.elapsed() < timeout {
            c.next_id = c.next_id.wrapping_add(1);
            send(
                &mut *c.link,
                &Request {
                    id: c.next_id,
                    command: Command::Hello { version: VERSION },
                },
            )?;
            let sent = Instant::now();
            while sent.elapsed() < Duration::from_millis(100) {
                match c.read()? {
                    Read::Frame(DeviceMsg::Reply {
                        reply: Reply::Hello(hello),
                        ..
                    }) => {
                        c.hello = hello;
                        return Ok(c);
                    }
                    Read::Frame(DeviceMsg::Reply {
                        reply: Reply::Refused(Refusal::Version),
                        ..
                    }) => return Err(ConsoleError::Version),
                    Read::Frame(_) => frames += 1,
                    Read::Byte => received += 1,
                    Read::Quiet => {}
                }
            }
        }
        Err(if frames > 0 {
            ConsoleError::Backlogged { frames }
        } else if received > 0 {
            ConsoleError::NotOurFirmware { bytes: received }
        } else {
            ConsoleError::Silent
        })
    }

    /// One byte from the line through the decoder, reading the line when the buffer is empty.
    fn read(&mut self) -> Result<Read, ConsoleError> {
        if self.at == self.filled {
            match self.link.read(&mut self.buffer) {
                Ok(0) => return Err(ConsoleError::Io("the firmware closed the line".into())),
                Ok(n) => (self.at, self.filled) = (0, n),
                // A signal (Ctrl-C) interrupting the wait is a quiet read too: the caller's loop
                // then sees the request.
                Err(e) if is_timeout(&e) || e.kind() == std::io::ErrorKind::Interrupted => {
                    return Ok(Read::Quiet);
                }
                Err(e) => return Err(ConsoleError::Io(format!("receive: {e}"))),
            }
        }
        let byte = self.buffer[self.at];
        self.at += 1;
        Ok(match self.decoder.push::<DeviceMsg>(byte) {
            Some(Ok(m)) => Read::Frame(m),
            _ => Read::Byte,
        })
    }

    /// Sends `command` and returns its reply; telemetry arriving meanwhile is kept.
    pub fn ask(&mut self, command: Command) -> Result<Reply, ConsoleError> {
        let what = format!("{command:?}");
        self.next_id = self.next_id.wrapping_add(1);
        if self.next_id == 0 {
            self.next_id = 1;
        }
        let request = Request {
            id: self.next_id,
            command,
        };
        let mut wait = self.timing.first;
        for attempt in 0..self.timing.attempts.max(1) {
            if attempt > 0 {
                self.retries = self.retries.saturating_add(1);
            }
            send(&mut *self.link, &request)?;
            let start = Instant::now();
            while start.elapsed() < wait {
                match self.read()? {
                    Read::Frame(DeviceMsg::Reply { id, reply }) if id == request.id => {
                        return Ok(reply);
                    }
                    Read::Frame(DeviceMsg::Telemetry(t)) => self.telemetry.push(t),
                    // A late answer to a handshake repeat or to an earlier request, or a frame
                    // damaged on the line: skipped.
                    _ => {}
                }
            }
            wait *= 2;
        }
        Err(ConsoleError::Timeout(what))
    }

    /// Reads what the line brings for at most `budget` (less when it falls quiet), keeping the
    /// telemetry: a flood of frames cannot hold the caller longer than `budget` plus one read.
    /// Returns the frames kept so far.
    pub fn pump(&mut self, budget: Duration) -> Result<usize, ConsoleError> {
        let start = Instant::now();
        while start.elapsed() < budget {
            match self.read()? {
                Read::Frame(DeviceMsg::Telemetry(t)) => self.telemetry.push(t),
                Read::Quiet => break,
                _ => {}
            }
        }
        Ok(self.telemetry.len())
    }

    /// [`Self::ask`], a refusal turned into an error naming `what` was asked.
    pub fn request(&mut self, what: &str, command: Command) -> Result<Reply, ConsoleError> {
        match self.ask(command)? {
            Reply::Refused(why) => Err(ConsoleError::Refused {
                what: what.into(),
                why,
            }),
            r => Ok(r),
        }
    }

    /// The firmware's status.
    pub fn status(&mut self) -> Result<Status, ConsoleError> {
        match self.request("status", Command::Status)? {
            Reply::Status(s) => Ok(s),
            r => Err(ConsoleError::Unexpected(format!("{r:?}"))),
        }
    }

    /// A parameter's value.
    pub fn get(&mut self, p: Param) -> Result<f32, ConsoleError> {
        match self.request(&format!("get {p:?}"), Command::Get(p))? {
            Reply::Value(v) => Ok(v),
            r => Err(ConsoleError::Unexpected(format!("{r:?}"))),
        }
    }

    /// Writes a parameter.
    pub fn set(&mut self, p: Param, v: f32) -> Result<(), ConsoleError> {
        self.done(&format!("set {p:?} = {v}"), Command::Set(p, v))
    }

    /// A request whose answer is `Done`.
    pub fn done(&mut self, what: &str, command: Command) -> Result<(), ConsoleError> {
        match self.request(what, command)? {
            Reply::Done => Ok(()),
            r => Err(ConsoleError::Unexpected(format!("{r:?}"))),
        }
    }

    /// Subscribes to every channel at `decimation`, doubled until the firmware accepts the
    /// rate; returns the decimation accepted.
    pub fn subscribe_fastest(&mut self, decimation: u16) -> Result<u16, ConsoleError> {
        let mut d = decimation.max(1);
        loop {
            let channels = Channels(Channels::ALL);
            match self.ask(Command::Subscribe {
                decimation: d,
                channels,
            })? {
                Reply::Done => return Ok(d),
                Reply::Refused(Refusal::OutOfRange) if d < 1000 => d = d.saturating_mul(2),
                Reply::Refused(why) => {
                    return Err(ConsoleError::Refused {
                        what: format!("subscribe (every {d} motor periods)"),
                        why,
                    });
                }
                r => return Err(ConsoleError::Unexpected(format!("{r:?}"))),
            }
        }
    }

    /// The telemetry received so far, handed over.
    pub fn take_telemetry(&mut self) -> Vec<Telemetry> {
        std::mem::take(&mut self.telemetry)
    }
}

fn is_timeout(e: &std::io::Error) -> bool {
    matches!(
        e.kind(),
        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
    )
}

fn send(link: &mut dyn Link, request: &Request) -> Result<(), ConsoleError> {
    let mut buf = [0u8; MAX_FRAME];
    let frame = flexarm_link::encode(request, &mut buf)
        .map_err(|e| ConsoleError::Usage(format!("the request does not fit a frame: {e}")))?;
    link.write_all(frame)
        .and_then(|()| link.flush())
        .map_err(|e| ConsoleError::Io(format!("send: {e}")))
}

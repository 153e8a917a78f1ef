//! The messages (crate docs for units and frames). Host to firmware: [`Request`]; firmware to
//! host: [`DeviceMsg`], a [`Reply`] to a request or a [`Telemetry`] frame. Every collection is a
//! `heapless::Vec` with a stated capacity, so every message has a bounded size.

use heapless::Vec;
use serde::{Deserialize, Serialize};

/// Waypoints per upload chunk.
pub const WAYPOINTS_PER_CHUNK: usize = 8;
/// Values per telemetry frame (one per selected [`Channels`] bit).
pub const MAX_CHANNELS: usize = 16;
/// Fault-recorder samples per reply page.
pub const SAMPLES_PER_PAGE: usize = 4;
/// Bytes of the firmware's build name in the handshake.
pub const BUILD_NAME: usize = 32;

/// A request from the host: the firmware answers with a [`Reply`] of the same `id`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Request {
    /// Chosen by the host, echoed in the reply.
    pub id: u16,
    /// What to do.
    pub command: Command,
}

/// What the host can ask.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Command {
    /// Handshake: the host's protocol version; the reply is [`Reply::Hello`] or a refusal.
    Hello {
        /// The host's [`crate::VERSION`].
        version: u16,
    },
    /// The firmware's [`Status`].
    Status,
    /// Enable the amplifiers once the checks pass.
    Arm,
    /// Disable the amplifiers (always accepted).
    Disarm,
    /// Start a move, validated whole first.
    Move(Move),
    /// One chunk of a waypoint list, before [`Move::Waypoints`].
    Waypoints {
        /// Index of the first waypoint of this chunk in the list.
        first: u16,
        /// The waypoints.
        points: Vec<Waypoint, WAYPOINTS_PER_CHUNK>,
    },
    /// Controlled deceleration to hold.
    Stop,
    /// The safe state now: zero torque, zero piezo voltage, amplifiers disabled.
    Estop,
    /// Clear the latched fault if its cause is gone.
    Clear,
    /// Read a tunable parameter.
    Get(Param),
    /// Write a tunable parameter (validated; refused while moving).
    Set(Param, f32),
    /// Stream telemetry: every `decimation`-th motor period, the `channels` selected. Refused
    /// when the stream would take more than 80 % of the line (on the board: 921 600 baud).
    Subscribe {
        /// Motor periods per frame, at least 1.
        decimation: u16,
        /// Which values each frame carries.
        channels: Channels,
    },
    /// Stop the telemetry stream.
    Unsubscribe,
    /// A page of the fault recorder, from sample `from` (oldest first).
    Faults {
        /// Index of the first sample of the page.
        from: u16,
    },
    /// Keeps the link watchdog fed without doing anything.
    Ping,
    /// Test builds only (the QEMU `link-session` firmware): assert (`true`) or release the
    /// simulated amplifiers' fault line. Every other build refuses it as `Unsupported`.
    TestAmplifierFault(bool),
    /// Home every joint (issue 33): each joint's search at a low torque limit, one at a time;
    /// the drive then holds, armed, in the arm's frame. `arm` and moves are refused
    /// ([`Refusal::NotHomed`]) until every joint is homed or declared.
    Home,
    /// Declare the pose now to be `theta` [rad] in the arm's frame without homing (disarmed
    /// only): the host's word, not a measurement; status shows the joints as
    /// [`HomeState::Declared`], never as homed.
    DeclareHome {
        /// θ1, θ2 of the pose now [rad].
        theta: [f32; 2],
    },
    /// Store the running values of every parameter a board's configuration holds (all but
    /// `va_bias`) in the board's non-volatile store, with this build's protocol version and
    /// configuration hash (issue 36); the board boots with them. Disarmed only (the hardware
    /// board's flash stalls the CPU while it erases): refused as [`Refusal::Armed`] otherwise.
    ConfigSave,
    /// Mark the board's saved settings erased (a record that says so, written as a save is):
    /// the values running now stay until the next boot, which runs the build's defaults.
    /// Disarmed only.
    ConfigErase,
}

/// A move, in the core's joint frames.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Move {
    /// From the current joint angles to `target` [rad] in `move_time` [s], constant
    /// acceleration during `ramp_time` [s] at each end.
    Trapezoid {
        /// Joint targets θ1, θ2 [rad].
        target: [f32; 2],
        /// Duration [s].
        move_time: f32,
        /// Ramp at each end [s].
        ramp_time: f32,
    },
    /// The tip around a circle in the base frame.
    Circle {
        /// Centre [m].
        centre: [f32; 2],
        /// Radius [m].
        radius: f32,
        /// One revolution [s].
        period: f32,
        /// Ramp of the phase at each end [s].
        ramp_time: f32,
        /// Direction.
        clockwise: bool,
    },
    /// Through the uploaded waypoints `0 … count − 1`.
    Waypoints {
        /// How many of the uploaded waypoints.
        count: u16,
    },
}

/// One joint waypoint.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Waypoint {
    /// Joint angles θ1, θ2 [rad].
    pub theta: [f32; 2],
    /// Time to reach it from the previous one [s].
    pub dt: f32,
}

pub use crate::params::Param;

/// A telemetry channel, described: a frame of [`Telemetry`] carries the values of the channels
/// its [`Channels`] name, in the order of [`CHANNELS`]; a host reads them by name
/// ([`Telemetry::value`]), never by position, so a frame of a subset reads right.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChannelInfo {
    /// Its bit in [`Channels`].
    pub bit: u16,
    /// Its name.
    pub name: &'static str,
    /// The unit of its values.
    pub unit: &'static str,
    /// How many values a frame carries for it.
    pub width: usize,
    /// What it is.
    pub doc: &'static str,
}

/// Every channel, in the order a frame carries their values (bit `i` is entry `i`).
pub const CHANNELS: [ChannelInfo; 7] = [
    ChannelInfo {
        bit: Channels::ERROR,
        name: "error",
        unit: "rad",
        width: 2,
        doc: "joint tracking errors θ̂ − θ_d of the motor step",
    },
    ChannelInfo {
        bit: Channels::THETA,
        name: "theta",
        unit: "rad",
        width: 2,
        doc: "estimated joint angles θ̂, the estimate the motor step ran on",
    },
    ChannelInfo {
        bit: Channels::DELTA,
        name: "delta",
        unit: "√kg·m",
        width: 2,
        doc: "estimated modal coordinates δ̂, as θ̂",
    },
    ChannelInfo {
        bit: Channels::TAU,
        name: "tau",
        unit: "N·m",
        width: 2,
        doc: "motor torque commands τ",
    },
    ChannelInfo {
        bit: Channels::V_A,
        name: "v_a",
        unit: "V",
        width: 1,
        doc: "piezo command V_a",
    },
    ChannelInfo {
        bit: Channels::V_F,
        name: "v_f",
        unit: "V",
        width: 1,
        doc: "film voltage V_f, the motor step's sample",
    },
    ChannelInfo {
        bit: Channels::LOAD,
        name: "load",
        unit: "fraction of the period",
        width: 2,
        doc: "the piezo and motor loops' mean execution time over the last supervisor window",
    },
];

/// The channels' widths, in their order (from [`CHANNELS`], at compile time).
const WIDTHS: [usize; CHANNELS.len()] = {
    let mut w = [0; CHANNELS.len()];
    let mut i = 0;
    while i < w.len() {
        w[i] = CHANNELS[i].width;
        i += 1;
    }
    w
};

/// Telemetry channels, one bit each (described in [`CHANNELS`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Channels(pub u16);

impl Channels {
    /// Joint tracking errors θ − θ_d [rad] (2 values).
    pub const ERROR: u16 = 1 << 0;
    /// Estimated joint angles θ̂ [rad], the estimate the motor step ran on (2).
    pub const THETA: u16 = 1 << 1;
    /// Estimated modal coordinates δ̂ [√kg·m], as θ̂ (2).
    pub const DELTA: u16 = 1 << 2;
    /// Motor torque commands τ [N·m] (2).
    pub const TAU: u16 = 1 << 3;
    /// Piezo command V_a [V] (1).
    pub const V_A: u16 = 1 << 4;
    /// Film voltage V_f [V] (1).
    pub const V_F: u16 = 1 << 5;
    /// Loads of the piezo and motor loops: the mean execution time of the last supervisor
    /// window over the period [fraction] (2).
    pub const LOAD: u16 = 1 << 6;
    /// Every channel.
    pub const ALL: u16 = (1 << CHANNELS.len()) - 1;

    /// Values a frame carries for these channels.
    pub const fn values(self) -> usize {
        let mut n = 0;
        let mut i = 0;
        while i < WIDTHS.len() {
            if self.0 & (1 << i) != 0 {
                n += WIDTHS[i];
            }
            i += 1;
        }
        n
    }

    /// Where the values of the channel `bit` start in a frame of these channels; `None` when
    /// the frame does not carry it.
    pub const fn offset(self, bit: u16) -> Option<usize> {
        if self.0 & bit == 0 || bit.count_ones() != 1 {
            return None;
        }
        Some(Self(self.0 & (bit - 1)).values())
    }

    /// The longest frame of a [`Telemetry`] message with these channels, on the wire [bytes]:
    /// the message's tag (1), the sequence number (5 as a varint at most), the tick (7: ticks
    /// below 2⁴⁹, 17 800 years of a 1 kHz loop), the brake (1), the channel bits (3), the
    /// values' count (1)
    /// and the values (4 each), then the CRC (4), COBS's overhead (1 for a frame under 254
    /// bytes) and the terminator (1). Tested to be exact for the largest sequence number and a
    /// tick of 2⁴⁹ − 1.
    pub const fn frame_bytes(self) -> usize {
        1 + 5 + 7 + 1 + 3 + 1 + 4 * self.values() + 4 + 1 + 1
    }

    /// Whether these channels name only known bits.
    pub const fn is_valid(self) -> bool {
        self.0 & !Self::ALL == 0
    }
}

/// [`DeviceMsg`] by reference, for a sender that should not copy a reply or a frame into a new
/// message (the firmware, short of stack): the same bytes on the wire (tested).
#[derive(Clone, Copy, Debug, Serialize)]
pub enum DeviceMsgRef<'a> {
    /// [`DeviceMsg::Reply`].
    Reply {
        /// The request's id.
        id: u16,
        /// The answer.
        reply: &'a Reply,
    },
    /// [`DeviceMsg::Telemetry`].
    Telemetry(&'a Telemetry),
}

/// From the firmware.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum DeviceMsg {
    /// The answer to the request `id`.
    Reply {
        /// The request's id.
        id: u16,
        /// The answer.
        reply: Reply,
    },
    /// One telemetry frame.
    Telemetry(Telemetry),
}

/// An answer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Reply {
    /// The handshake.
    Hello(Hello),
    /// The status.
    Status(Status),
    /// Done.
    Done,
    /// A parameter's value (its unit in [`Param`]).
    Value(f32),
    /// A fault was cleared: its code.
    Cleared(u8),
    /// A page of the fault recorder.
    Faults(FaultPage),
    /// Refused, and why.
    Refused(Refusal),
}

/// Why a request was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Refusal {
    /// The host speaks another protocol version.
    Version,
    /// Not while a move runs.
    Moving,
    /// Not while a fault is latched.
    Faulted,
    /// Needs the amplifiers armed.
    NotArmed,
    /// The fault's cause is still there.
    CauseActive,
    /// A value is outside its allowed range (or not finite).
    OutOfRange,
    /// The move leaves the arm's reach or range.
    Unreachable,
    /// The move asks more speed, acceleration or torque than the limits.
    TooFast,
    /// The waypoint list is incomplete or too long.
    Waypoints,
    /// No such parameter (or index).
    UnknownParam,
    /// Nothing recorded at that index.
    NoRecord,
    /// This firmware does not implement the command yet.
    Unsupported,
    /// A joint is neither homed nor declared: `Home` (or `DeclareHome`) first.
    NotHomed,
    /// Only while the piezo output is off: disarm first (a change of the piezo law or of
    /// what a law beside the paper's is designed from).
    Armed,
    /// The piezo law's design rule needs the film's static gain measured first.
    Unidentified,
    /// The board's settings store failed (a flash error, or a store it cannot read: a
    /// `ConfigErase` formats it).
    Storage,
    /// Outside the region the board's model says is stable with margin at its loop rates:
    /// the motor gains past the sampled loop's rule, or the rate law's `k_c` past its ceiling
    /// at the filter's corner (`flexarm_core::tuning`).
    Unstable,
}

/// The handshake's answer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Hello {
    /// The firmware's [`crate::VERSION`].
    pub version: u16,
    /// Which board runs.
    pub board: Board,
    /// The build: crate version and features, as text.
    pub build: heapless::String<BUILD_NAME>,
    /// Hash of the running parameters (gains, limits, patch, observer), to tell two
    /// configurations apart.
    pub params_hash: u32,
    /// Motor loop rate [Hz].
    pub motor_hz: u32,
    /// Piezo loop rate [Hz].
    pub piezo_hz: u32,
    /// Whether the board runs settings saved on it, and why not.
    pub settings: Settings,
}

/// The board's saved settings (`ConfigSave`), as this session found them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Settings {
    /// Nothing saved: the build's defaults run.
    Defaults,
    /// The saved settings were loaded at boot and run.
    Loaded,
    /// The saved settings were refused at boot, for this reason: the build's defaults run.
    Refused(SettingsRefusal),
    /// Saved since boot (`ConfigSave`): the running values are the saved ones.
    Saved,
    /// Erased since boot (`ConfigErase`): the running values stay until the next boot, which
    /// runs the build's defaults.
    Erased,
}

/// Why saved settings were refused at boot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum SettingsRefusal {
    /// The store could not be read (a flash error, or contents that are no store: a
    /// `ConfigErase` formats it).
    Unreadable,
    /// The record fails its CRC or does not parse.
    Corrupt,
    /// Saved by a build of another record layout or protocol version.
    Version,
    /// Saved by a build of another configuration (its hash differs from this build's).
    Hash,
    /// A value was refused by the board's checks (those of a `Set`).
    Value(Param),
}

/// Which board.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Board {
    /// STM32F405 with real amplifiers.
    Hardware,
    /// QEMU with the simulated arm.
    Qemu,
}

/// The drive's mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Mode {
    /// Amplifiers disabled.
    Disarmed,
    /// Amplifiers enabled, holding, ready for a move.
    Armed,
    /// A move runs.
    Moving,
    /// Decelerating to hold after a stop.
    Stopping,
    /// In the safe state with a latched fault.
    Fault,
    /// A homing search runs (amplifiers on at the search torque).
    Homing,
}

/// A joint's homing state (`flexarm_core::homing::State`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum HomeState {
    /// The encoder counts from the power-up pose: not known in the arm's frame.
    Unhomed,
    /// Its search runs.
    Searching,
    /// Its reference was found.
    Homed,
    /// A host declared the pose (`DeclareHome`): trusted, not measured.
    Declared,
}

/// One task's load.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Load {
    /// Mean execution time over the last supervisor period [clock cycles].
    pub mean_cycles: u32,
    /// Worst execution time since boot [clock cycles].
    pub worst_cycles: u32,
    /// Deadline misses since boot.
    pub misses: u32,
}

/// The receiver's line errors since boot, as the UART flags them (issue 34). A board's
/// receiver counts them; QEMU's USART never raises them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct LineErrors {
    /// Overruns: a byte arrived while the data register still held the one before, which was
    /// lost (each counts one or more lost bytes; the one read is kept).
    pub overrun: u32,
    /// Framing (or parity) errors: a byte without its stop bit (a wrong baud rate, a break, a
    /// glitch), dropped.
    pub framing: u32,
    /// Noise: a byte whose bits the receiver's oversampling saw disagree, dropped.
    pub noise: u32,
}

/// The status.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Status {
    /// Mode.
    pub mode: Mode,
    /// The latched fault's code (`flexarm_core::Fault`'s stable number), if any.
    pub fault: Option<u8>,
    /// Motor periods since boot.
    pub ticks: u64,
    /// Piezo loop, motor loop.
    pub loads: [Load; 2],
    /// Telemetry frames dropped because the link could not keep up.
    pub telemetry_dropped: u32,
    /// Moves the link watchdog stopped because the host fell silent.
    pub link_stops: u32,
    /// Bytes the link has received since boot.
    pub rx_bytes: u32,
    /// Received bytes lost because the receive queue was full.
    pub rx_lost: u32,
    /// Request frames that did not decode (damaged or cut on the line: each a lost request,
    /// which has no id to answer).
    pub rx_malformed: u32,
    /// The receiver's line errors.
    pub rx_line: LineErrors,
    /// The stack's high-water mark since boot [bytes].
    pub stack_used: u32,
    /// Each joint's homing state.
    pub homing: [HomeState; 2],
    /// The last homing search failed (travelled its limit without finding its reference).
    pub homing_failed: bool,
    /// The joints' holding brake output (issue 33): `true` engaged (whenever the amplifiers
    /// are cut), `false` released (only while they are enabled).
    pub brake_engaged: bool,
}

/// One telemetry frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Telemetry {
    /// Increments by one per frame sent or dropped: a gap is a loss.
    pub seq: u32,
    /// Motor period of the sample.
    pub tick: u64,
    /// The joints' holding brake output after the sample's motor step (issue 33): `true`
    /// engaged (the amplifiers cut), `false` released. In every frame, whatever the channels.
    pub brake_engaged: bool,
    /// What the values are.
    pub channels: Channels,
    /// The selected channels' values, in [`Channels`] order.
    pub values: Vec<f32, MAX_CHANNELS>,
}

impl Telemetry {
    /// The `j`-th value (from 0) of the channel `bit` in this frame, by its place among the
    /// channels the frame names; `None` when it does not carry it.
    pub fn value(&self, bit: u16, j: usize) -> Option<f32> {
        let width = CHANNELS.iter().find(|c| c.bit == bit)?.width;
        if j >= width {
            return None;
        }
        let at = self.channels.offset(bit)? + j;
        self.values.get(at).copied()
    }
}

/// One sample of the fault recorder (one per motor period before the fault).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RecordedSample {
    /// Motor period.
    pub tick: u64,
    /// Measured joint angles [rad].
    pub theta: [f32; 2],
    /// Joint tracking errors [rad].
    pub error: [f32; 2],
    /// Estimated modal coordinates [√kg·m].
    pub delta: [f32; 2],
    /// Torque commands [N·m].
    pub tau: [f32; 2],
    /// Film voltage [V].
    pub v_f: f32,
}

/// A page of the fault recorder.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FaultPage {
    /// The fault recorded (its code).
    pub fault: Option<u8>,
    /// Samples held.
    pub total: u16,
    /// Index of the first sample of this page.
    pub from: u16,
    /// The samples.
    pub samples: Vec<RecordedSample, SAMPLES_PER_PAGE>,
}

//! One board period, phase by phase, as the firmware's tasks run it: each phase is a function
//! of the separate resources it needs, so a task locks only what its phase touches (RTIC's
//! ceilings stay as fine as the phases), and the host's rig calls the same phases in the same
//! order.
//!
//! Every piezo period (the piezo loop, the highest priority):
//! 1. the board's film voltage `V_f` [V];
//! 2. [`piezo_tick`] on the [`Control`]: `V_a = sat(−k_c V̇_f)` (Eq. 17), plus the link's bias;
//! 3. [`piezo_out`] on the board: the command to the amplifier, and a simulated board's plant
//!    advances.
//!
//! Every motor period (the motor loop, after the piezo period of the same instant):
//! 1. [`sense`] on the board: encoders, the film, the amplifiers' fault line;
//! 2. [`motor_step`] on the [`MotorLoop`], the [`Control`] and the drive: the fault line's
//!    monitor, the drive's step (checks, observer, law, motion checks, derating, stops), the
//!    bias's end, the telemetry's decimations;
//! 3. [`actuate`] on the board: torques, the enable line and the brake;
//! 4. [`recorded`] and the fault recorder;
//! 5. [`MotorLoop::sample`]: the telemetry records of the period.
//!
//! [`board_period`] is the whole of it between two motor periods, for a caller that owns every
//! resource (the host's rig, the firmware's benchmark).

use flexarm_core::controller::Controller;
use flexarm_core::drive::{Drive, Mode};
use flexarm_core::fault::Fault;
use flexarm_core::observer::Measurement;
use flexarm_core::recorder;
use flexarm_core::supervisor::{AmplifierMonitor, Command};
use flexarm_core::time::Ticks;
use flexarm_core::{Vector2, Vector4};

use crate::board::Board;
use crate::config::BoardConfig;
use crate::telemetry::Record;

/// Samples the fault recorder holds: 500 of 44 bytes (22 KB of RAM): the last second on the
/// hardware board (which records every second period), the last 5 s under QEMU
/// (`BoardConfig::record_every`).
pub const RECORDER_LEN: usize = 500;

/// The fault recorder (`flexarm_core::recorder`) of every board.
pub type FaultRecorder = recorder::Recorder<RECORDER_LEN>;

/// What both control loops and the link share: the controller, and what the link sets for the
/// loops. The piezo loop's resource (the highest ceiling).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Control {
    /// The controller: checks, observer, laws, latch.
    pub ctrl: Controller<f32>,
    /// A constant added to the piezo command [V] (the link's `VaBias`): set by the link while
    /// the drive holds, added by [`piezo_tick`], back to 0 in the motor period the drive
    /// leaves holding ([`motor_step`]).
    pub piezo_bias: f32,
    /// Motor periods per telemetry frame of the link's subscription; 0 while nobody
    /// subscribed. Set by the link, read by [`motor_step`].
    pub stream_every: u32,
}

impl Control {
    /// Around `ctrl`, no bias, no subscription.
    pub const fn new(ctrl: Controller<f32>) -> Self {
        Self {
            ctrl,
            piezo_bias: 0.0,
            stream_every: 0,
        }
    }
}

/// The piezo loop's step: the film voltage `v_f` [V] in, the amplifier command [V] out
/// (`Controller::piezo_step`, then the link's bias when one is set).
#[inline(always)]
pub fn piezo_tick(c: &mut Control, v_f: f32) -> f32 {
    let v_a = c.ctrl.piezo_step(v_f);
    if c.piezo_bias == 0.0 {
        v_a
    } else {
        c.ctrl.bias_piezo(c.piezo_bias)
    }
}

/// The piezo loop's output: the amplifier command `v_a` [V], then the board's piezo period
/// (a simulated board advances its plant).
#[inline(always)]
pub fn piezo_out(b: &mut impl Board, v_a: f32) {
    b.set_piezo(v_a);
    b.tick();
}

/// What the motor loop reads from the board.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sensed {
    /// Encoder angles [rad] (the encoders' own frame: the drive maps them to the arm's,
    /// `flexarm_core::homing`) and the film voltage [V].
    pub y: Measurement<f32>,
    /// The amplifiers' fault line.
    pub amplifier_fault: bool,
    /// The homing inputs: index pulses, limit switches (`flexarm_core::homing`).
    pub homing: flexarm_core::homing::Inputs<f32>,
}

/// The motor loop's reading of the board.
#[inline(always)]
pub fn sense(b: &mut impl Board) -> Sensed {
    Sensed {
        y: Measurement {
            theta: b.encoders(),
            v_f: b.latest_film_voltage(),
        },
        amplifier_fault: b.amplifier_fault(),
        homing: b.homing_inputs(),
    }
}

/// The motor loop's own state (its task-local resource): the tick count, the amplifiers'
/// fault-line monitor, and the telemetry's decimations.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorLoop {
    /// The tick of the next motor step.
    now: Ticks,
    amplifier: AmplifierMonitor,
    /// The enable line as the last step commanded it.
    enabled: bool,
    print_every: u32,
    print_countdown: u32,
    stream_countdown: u32,
    /// The fault record has been queued.
    fault_sent: bool,
}

/// What one motor period did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Period {
    /// Its tick.
    pub tick: Ticks,
    /// The move time of the period [s] (`Drive::time`): since the start of the move, stop,
    /// search or hold that runs (or ran last, disarmed), from the integer tick difference, so
    /// it is the same after any uptime. What the telemetry records carry.
    pub t: f32,
    /// The measurement it ran on, in the arm's frame (`Drive::arm_frame`).
    pub y: Measurement<f32>,
    /// What goes to the amplifiers.
    pub command: Command<f32>,
    /// The law's tracking error `θ̂ − θ_d` [rad] (0 when the law did not run).
    pub error: Vector2<f32>,
    /// The estimate `q̂` the step ran on (`Controller::step_estimate`).
    pub q: Vector4<f32>,
    /// The fault latched, if any.
    pub fault: Option<Fault>,
    /// A sample is printed to the log this period.
    pub print: bool,
    /// A sample is streamed on the link this period.
    pub stream: bool,
}

impl MotorLoop {
    /// The first step at `start`, amplifiers disabled, with `cfg`'s fault-line monitor and
    /// print decimation.
    #[inline(always)]
    pub fn new(cfg: &BoardConfig, start: Ticks) -> Self {
        Self {
            now: start,
            amplifier: cfg.amplifier_monitor(),
            enabled: false,
            print_every: cfg.print_every,
            print_countdown: 0,
            stream_countdown: 0,
            fault_sent: false,
        }
    }

    /// The tick of the next motor step.
    pub fn now(&self) -> Ticks {
        self.now
    }

    /// The period's telemetry records, handed to `push`: the fault event the period the latch
    /// is first seen, then a sample when it is printed or streamed, each with the period's
    /// move time [`Period::t`].
    #[inline(always)]
    pub fn sample(&mut self, p: &Period, mut push: impl FnMut(Record)) {
        let t = p.t;
        if let (Some(fault), false) = (p.fault, self.fault_sent) {
            self.fault_sent = true;
            push(Record::Fault {
                tick: p.tick.0,
                t,
                fault,
            });
        }
        if p.print || p.stream {
            push(Record::Sample {
                tick: p.tick.0,
                t,
                error: [p.error.x, p.error.y],
                theta: [p.q.x, p.q.y],
                delta: [p.q.z, p.q.w],
                tau: [p.command.tau.x, p.command.tau.y],
                v_a: p.command.v_a,
                v_f: p.y.v_f,
                brake: !p.command.enable,
                print: p.print,
                stream: p.stream,
            });
        }
    }
}

/// Counts down from `every − 1` to 0; `true` at 0.
#[inline(always)]
fn due(countdown: &mut u32, every: u32) -> bool {
    let now = *countdown == 0;
    *countdown = match *countdown {
        0 => every.saturating_sub(1),
        n => n - 1,
    };
    now
}

/// The motor loop's step on the sample `s`: the amplifiers' fault line (counted only while
/// they are enabled, debounced, after settling), the drive's step (`Drive::step`: the law
/// while armed, the motion checks, derating and stops; the checks and the observer alone
/// while disarmed), the piezo bias's end when the drive no longer holds, and whether this
/// period's sample is printed or streamed.
#[inline(always)]
pub fn motor_step(m: &mut MotorLoop, c: &mut Control, d: &mut Drive<f32>, s: &Sensed) -> Period {
    let tick = m.now;
    m.now = tick.next();
    let print = due(&mut m.print_countdown, m.print_every);
    let stream = due(&mut m.stream_countdown, c.stream_every) && c.stream_every != 0;
    if let Err(f) = m.amplifier.update(m.enabled, s.amplifier_fault) {
        c.ctrl.trip(f);
    }
    d.homing_inputs(s.homing);
    let report = d.step(&mut c.ctrl, tick, Some(&s.y));
    // The piezo bias lives while the drive holds, not a period longer.
    if d.mode(&c.ctrl) != Mode::Armed {
        c.piezo_bias = 0.0;
    }
    m.enabled = report.command.enable;
    Period {
        tick,
        t: d.time(tick),
        y: d.arm_frame(&s.y),
        command: report.command,
        error: report.law.map_or(Vector2::zeros(), |l| l.error),
        q: c.ctrl.step_estimate(),
        fault: c.ctrl.fault(),
        print,
        stream,
    }
}

/// One whole motor period on `board` as the firmware's tasks run it: `piezo` piezo periods
/// ([`piezo_tick`], [`piezo_out`]; `before(control, i)` runs before the `i`-th, for a host that
/// sets the link's values between them), then the motor period ([`sense`], [`motor_step`],
/// [`actuate`]). The fault recorder's sample and the telemetry are the caller's ([`recorded`],
/// [`MotorLoop::sample`]).
#[inline]
pub fn board_period(
    board: &mut impl Board,
    control: &mut Control,
    drive: &mut Drive<f32>,
    motor: &mut MotorLoop,
    piezo: u32,
    mut before: impl FnMut(&mut Control, u32),
) -> Period {
    for i in 0..piezo {
        before(control, i);
        let v_f = board.film_voltage();
        let v_a = piezo_tick(control, v_f);
        piezo_out(board, v_a);
    }
    let s = sense(board);
    let p = motor_step(motor, control, drive, &s);
    actuate(board, &p.command);
    p
}

/// The motor loop's outputs: the torques, the enable line, and the brake (safe brake control:
/// released only while the amplifiers are enabled, engaged in the period they are cut).
#[inline(always)]
pub fn actuate(b: &mut impl Board, command: &Command<f32>) {
    b.set_torques(command.tau);
    b.set_enable(command.enable);
    b.set_brake(!command.enable);
}

/// The fault recorder's sample of the period: every `every`-th period, and the period a fault
/// latched.
#[inline(always)]
pub fn recorded(p: &Period, every: u32) -> Option<recorder::Sample> {
    (p.tick.0.is_multiple_of(u64::from(every)) || p.fault.is_some()).then(|| recorder::Sample {
        tick: p.tick.0,
        theta: [p.y.theta.x, p.y.theta.y],
        error: [p.error.x, p.error.y],
        delta: [p.q.z, p.q.w],
        tau: [p.command.tau.x, p.command.tau.y],
        v_f: p.y.v_f,
    })
}

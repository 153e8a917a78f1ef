//! The host's rig: one whole board period, as the firmware runs it, on any board (the
//! `flexarm_machine::Board` trait): the same phases of `flexarm_machine::period` in the same
//! order on the same resources (the controller and its link-set values, the drive, the motor
//! loop's state, the fault recorder), the same link session, from the same
//! `flexarm_machine::BoardConfig`. Every host run of "what the board does" runs it: the
//! simulator's runs of the firmware's controller ([`crate::sim`], on the controller's model or
//! the truth plant through [`PlantBoard`]), the tests of the drive, the motion checks, the time
//! base and the link session, the host's predictions of a QEMU run (on the QEMU board's own
//! simulated arm, `flexarm_machine::simulated::SimulatedArm`), and the console's `compare`.
//!
//! A motor period is `cfg.motor_divider` piezo periods, then the motor period, as on a board
//! whose timers start together (the piezo loop's interrupt comes first at a common instant).
//! Units SI; ticks in motor periods.

use flexarm_core::Vector2;
use flexarm_core::drive::{Drive, Refused};
use flexarm_core::time::{MoveClock, Ticks};
use flexarm_core::trajectory::JointTrajectory;
use flexarm_link::msg::{Reply, Telemetry};
use flexarm_link::{Command, Request};
use flexarm_machine::period::{self, Control, FaultRecorder, MotorLoop, Period};
use flexarm_machine::session::{self, Identity, Io, Session, Snapshot};
use flexarm_machine::{Board, BoardConfig, Record};
use rtic_core::Exclusive;

use crate::plant::{Plant, State};
use crate::sim::{Rng, Sensors};

/// The telemetry queue's capacity, as the firmware's: 64 records.
pub const QUEUE: usize = 64;

/// A board and the machine around it.
pub struct Rig<B> {
    /// The configuration it booted with.
    pub cfg: BoardConfig,
    /// The board: its I/O.
    pub board: B,
    /// The controller and what the link sets for the loops.
    pub control: Control,
    /// The drive.
    pub drive: Drive<f32>,
    /// The motor loop's own state.
    pub motor: MotorLoop,
    /// The fault recorder.
    pub recorder: Box<FaultRecorder>,
    /// The link session.
    pub session: Session,
    snapshot: Box<Snapshot>,
    /// The boot's clock: the time `Board::motor_period` gets (the QEMU board's verdict runs).
    clock: MoveClock,
    /// The records the motor loop queued and nobody took yet (at most [`QUEUE`]).
    queue: std::collections::VecDeque<Record>,
    /// Records that did not fit the queue.
    dropped: u32,
    /// The last queued sample's tick.
    last_tick: u64,
}

impl<B: Board> Rig<B> {
    /// `board` booted with `cfg` at tick `start`, as the firmware's `init`: the controller built
    /// from the configuration, its observer started at the encoders, the drive disarmed.
    pub fn new(cfg: BoardConfig, mut board: B, start: Ticks) -> Self {
        let theta = board.encoders();
        let mut ctrl = cfg.controller(JointTrajectory::Hold(theta));
        ctrl.reset_observer(theta);
        let drive = cfg.drive(&mut ctrl, start);
        let snapshot = Box::new(session::snapshot(&ctrl, &drive));
        let identity = Identity {
            board: cfg.board,
            build: "flexarm-sim rig",
            params_hash: cfg.hash(),
            motor_hz: cfg.motor_hz(),
            piezo_hz: cfg.piezo_hz,
            test_commands: false,
        };
        Self {
            cfg,
            board,
            control: Control::new(ctrl),
            drive,
            motor: MotorLoop::new(&cfg, start),
            recorder: Box::new(FaultRecorder::new()),
            session: Session::new(cfg.tuning(), identity),
            snapshot,
            clock: MoveClock::new(start, cfg.motor_hz()),
            queue: std::collections::VecDeque::with_capacity(QUEUE),
            dropped: 0,
            last_tick: start.0,
        }
    }

    /// One whole motor period (`flexarm_machine::period::board_period`):
    /// `cfg.motor_divider` piezo periods, then the motor period, then the fault recorder and the
    /// telemetry records (queued as the firmware queues them: a full queue drops the record).
    pub fn period(&mut self) -> Period {
        self.period_with(self.cfg.motor_divider, |_, _| {})
    }

    /// [`Self::period`] after `piezo` piezo periods (a board whose piezo timer ran late or early,
    /// recorded), `before(control, i)` before the `i`-th (a study's patch excitation: the
    /// link's bias set between them).
    pub fn period_with(&mut self, piezo: u32, before: impl FnMut(&mut Control, u32)) -> Period {
        let p = period::board_period(
            &mut self.board,
            &mut self.control,
            &mut self.drive,
            &mut self.motor,
            piezo,
            before,
        );
        let t = self.clock.local_time(p.tick);
        self.board.motor_period(t);
        if let Some(s) = period::recorded(&p, self.cfg.record_every) {
            self.recorder.record(&s, p.fault);
        }
        let (queue, dropped) = (&mut self.queue, &mut self.dropped);
        self.motor.sample(&p, |r| {
            if queue.len() < QUEUE {
                queue.push_back(r);
            } else {
                *dropped = dropped.saturating_add(1);
            }
        });
        p
    }

    /// The tick of the next motor period.
    pub fn now(&self) -> Ticks {
        self.motor.now()
    }

    /// The drive's mode.
    pub fn mode(&self) -> flexarm_core::drive::Mode {
        self.drive.mode(&self.control.ctrl)
    }

    /// Arms the drive (as the link's `Arm`).
    pub fn arm(&mut self) -> Result<(), Refused> {
        let now = self.drive.next_tick();
        self.drive.arm(&mut self.control.ctrl, now)
    }

    /// Homes every joint (as the link's `Home`, `Drive::home`).
    pub fn home(&mut self) -> Result<(), Refused> {
        let now = self.drive.next_tick();
        self.drive.home(&mut self.control.ctrl, now)
    }

    /// Declares the pose now to be `theta` [rad] in the arm's frame (as the link's
    /// `DeclareHome`, `Drive::declare`).
    pub fn declare(&mut self, theta: Vector2<f32>) -> Result<(), Refused> {
        self.drive.declare(&mut self.control.ctrl, theta)
    }

    /// Declares the encoders' reading now to be the arm's pose: a host's run whose board reads
    /// the plant's own angles (a simulated plant, whose frame is the arm's), so the offset is 0.
    pub fn declare_encoders(&mut self) -> Result<(), Refused> {
        self.drive.declare_zero(&mut self.control.ctrl)
    }

    /// Starts a move after validating it (as the link's moves).
    pub fn start(
        &mut self,
        request: &flexarm_core::drive::MoveRequest<f32>,
    ) -> Result<f32, Refused> {
        let now = self.drive.next_tick();
        self.drive.start(&mut self.control.ctrl, now, request)
    }

    /// Starts a controlled stop (as the link's `Stop`).
    pub fn stop(&mut self) -> Result<(), Refused> {
        let now = self.drive.next_tick();
        self.drive.stop(&mut self.control.ctrl, now)
    }

    /// Runs `trajectory` from its time `offset` [s] without the move limits' validation
    /// (`Drive::follow`: a study's own trajectory).
    pub fn follow(&mut self, trajectory: JointTrajectory<f32>, offset: f32) -> Result<(), Refused> {
        let now = self.drive.next_tick();
        self.drive
            .follow(&mut self.control.ctrl, now, trajectory, offset)
    }

    /// The answer to a command of the link, as the firmware's idle task gives it between two
    /// periods: a move validated and started ([`session::start_move`]), anything else answered
    /// by the session on the controller, the drive and the recorder.
    pub fn answer(&mut self, command: Command) -> Reply {
        let sensed = period::sense(&mut self.board);
        let brake_engaged = self.board.brake_engaged();
        let io = Io {
            y: sensed.y,
            amplifier_fault: sensed.amplifier_fault,
            ticks: self.last_tick,
            dropped: self.dropped,
            rx_bytes: 0,
            rx_lost: 0,
            rx_line: Default::default(),
            stack_used: 0,
            loads: Default::default(),
            brake_engaged,
        };
        match command {
            Command::Move(m) => session::start_move(
                m,
                &mut Exclusive(&mut self.control),
                &mut Exclusive(&mut self.drive),
                &mut self.snapshot,
            ),
            Command::Set(p, v) => {
                self.drive.heard(self.drive.next_tick());
                self.session.set(p, v, &mut self.control, &mut self.drive)
            }
            command => self.session.answer(
                command,
                &mut self.control,
                &mut self.drive,
                &mut self.recorder,
                &io,
            ),
        }
    }

    /// The answer to a request of the link as the firmware's idle task gives it: the first
    /// answer again for a repeat of the last request that acted ([`Session::repeated`]), else
    /// [`Self::answer`], remembered.
    pub fn request(&mut self, request: &Request) -> Reply {
        if let Some(reply) = self.session.repeated(request) {
            return reply;
        }
        let reply = self.answer(request.command.clone());
        let kind = session::Kind::of(&request.command);
        self.session.remember(request.id, kind, &reply);
        reply
    }

    /// The queued records, oldest first, as the idle task takes them, with the telemetry frames
    /// the session makes of them (the loads channel reads 0).
    pub fn take(&mut self) -> Vec<(Record, Option<Telemetry>)> {
        self.queue
            .drain(..)
            .map(|r| {
                if let Record::Sample { tick, .. } = r {
                    self.last_tick = tick;
                }
                (r, self.session.telemetry(&r, [0.0; 2]))
            })
            .collect()
    }
}

/// A host plant as a board: its sensors (`crate::sim::Sensors`: encoders, the film's ADC and
/// noise, a delay of one motor period, the piezo amplifier's slew rate) and its integration
/// (`steps` plant steps of `dt` [s] per piezo period), the amplifiers cutting torque and
/// voltage while disabled, and the joints' holding brakes, a viscous torque of
/// [`PlantBoard::brake_damping`] while the brake output is engaged (0 by default: no brake).
///
/// As on the hardware board, at the instant a motor period shares with a piezo period both
/// loops sample the plant at that instant, the motor loop taking the piezo loop's film sample
/// (one converter), and both commands hold from it: the plant advances one piezo period when
/// the next piezo period samples it (the QEMU board advances its own at the end of each piezo
/// period, so its motor loop samples one piezo period later).
pub struct PlantBoard {
    plant: Box<dyn Plant + Send>,
    sensors: Sensors,
    rng: Rng,
    dt: f64,
    steps: u64,
    tau: Vector2<f64>,
    /// The piezo amplifier's output [V] (the command through the slew limit).
    v_a: f64,
    enabled: bool,
    /// The brake output (`true` engaged, as at power-up).
    brake: bool,
    /// The holding brakes' viscous torque per joint speed while engaged [N·m·s/rad]; 0: the
    /// plant has no brakes (the joints coast on their friction).
    pub brake_damping: f64,
    /// The last film sample [V].
    v_f: f64,
    /// The reading the motor loop gets when the sensors are delayed: the previous period's.
    held: Option<(Vector2<f64>, f64)>,
    /// A piezo period ended that the plant has not advanced yet.
    owed: bool,
    /// Plant time [s].
    t: f64,
    /// The plant's divergence, and when [s].
    pub diverged: Option<f64>,
}

impl PlantBoard {
    /// `plant` read through `sensors`, integrated `steps` times by `dt` [s] per piezo period.
    pub fn new(plant: Box<dyn Plant + Send>, sensors: Sensors, dt: f64, steps: u64) -> Self {
        Self {
            plant,
            sensors,
            rng: Rng::new(sensors.seed),
            dt,
            steps,
            tau: Vector2::zeros(),
            v_a: 0.0,
            enabled: false,
            brake: true,
            brake_damping: 0.0,
            v_f: 0.0,
            held: None,
            owed: false,
            t: 0.0,
            diverged: None,
        }
    }

    /// The plant.
    pub fn plant(&self) -> &dyn Plant {
        self.plant.as_ref()
    }

    /// The plant's state.
    pub fn state(&self) -> State<f64> {
        self.plant.state()
    }

    /// Plant time [s].
    pub fn time(&self) -> f64 {
        self.t
    }

    /// The piezo amplifier's output [V].
    pub fn v_a(&self) -> f64 {
        self.v_a
    }

    /// The last film sample [V].
    pub fn v_f(&self) -> f64 {
        self.v_f
    }

    /// The piezo period owed, with the commands held: `steps` plant steps.
    fn advance(&mut self) {
        if !std::mem::take(&mut self.owed) {
            return;
        }
        let (tau, v_a) = if self.enabled {
            (self.tau, self.v_a)
        } else {
            (Vector2::zeros(), 0.0)
        };
        let brake = if self.brake { self.brake_damping } else { 0.0 };
        for _ in 0..self.steps {
            if self.diverged.is_some() {
                return;
            }
            let tau = if brake > 0.0 {
                let qd = self.plant.state().qd;
                tau - Vector2::new(qd.x, qd.y) * brake
            } else {
                tau
            };
            if self.plant.step(&tau, v_a, self.dt).is_err() {
                self.diverged = Some(self.t);
            }
            self.t += self.dt;
        }
    }

    /// The encoders' reading of the plant now [rad].
    fn angles(&self) -> Vector2<f64> {
        let q = self.plant.state().q;
        Vector2::new(self.sensors.angle(q.x), self.sensors.angle(q.y))
    }

    /// What the motor loop reads: now, or one period ago when delayed.
    fn reading(&self) -> (Vector2<f64>, f64) {
        match (self.sensors.delay, self.held) {
            (true, Some(h)) => h,
            _ => (self.angles(), self.v_f),
        }
    }
}

impl Board for PlantBoard {
    fn encoders(&mut self) -> Vector2<f32> {
        self.reading().0.cast::<f32>()
    }
    fn film_voltage(&mut self) -> f32 {
        self.advance();
        self.v_f = self.sensors.film(self.plant.film(), &mut self.rng);
        self.v_f as f32
    }
    fn latest_film_voltage(&mut self) -> f32 {
        self.reading().1 as f32
    }
    fn set_torques(&mut self, tau: Vector2<f32>) {
        self.tau = tau.cast::<f64>();
    }
    fn set_piezo(&mut self, v_a: f32) {
        let cmd = f64::from(v_a);
        let piezo_dt = self.dt * self.steps as f64;
        self.v_a = match self.sensors.piezo_slew {
            Some(rate) => self.v_a + (cmd - self.v_a).clamp(-rate * piezo_dt, rate * piezo_dt),
            None => cmd,
        };
    }
    fn set_enable(&mut self, on: bool) {
        self.enabled = on;
    }
    fn set_brake(&mut self, engaged: bool) {
        self.brake = engaged;
    }
    fn brake_engaged(&mut self) -> bool {
        self.brake
    }
    fn amplifier_fault(&mut self) -> bool {
        false
    }
    fn tick(&mut self) {
        self.owed = true;
    }
    fn motor_period(&mut self, _t: f32) {
        if self.sensors.delay {
            self.held = Some((self.angles(), self.v_f));
        }
    }
}

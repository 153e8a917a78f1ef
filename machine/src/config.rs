//! [`BoardConfig`]: every number a board boots with, in one value: the controller's model of
//! the arm, the piezo patch, the motor law and its gains, the piezo gains, the actuator limits,
//! the motion checks' thresholds, the move limits, the observer gain, the loop rates, the
//! decimations of the print, stream and fault recorder, the link watchdog and the amplifiers'
//! fault line. The firmware builds its controller, drive and link session from it; the host
//! builds the same ones from the same value ([`BoardConfig::for_board`] on the same model file
//! gives the same bits), and [`BoardConfig::hash`] tells two configurations apart over the link
//! (the handshake's `params_hash`).
//!
//! Units SI as in `flexarm_core::params`; rates in Hz, decimations in motor periods.

use flexarm_core::control::motor::{MotorController, MotorLaw};
use flexarm_core::control::piezo::{PiezoGains, PiezoLaw, PiezoPatch};
use flexarm_core::control::select::{PiezoLawKind, PiezoSetup, identified_loop};
use flexarm_core::controller::Controller;
use flexarm_core::drive::{Drive, MoveLimits};
use flexarm_core::homing;
use flexarm_core::model::Model;
use flexarm_core::motion::MotionLimits;
use flexarm_core::observer::{Observer, film_map};
use flexarm_core::observer_gains::gain;
use flexarm_core::params::{ArmParams, DEFAULT_KI, Gains, Limits};
use flexarm_core::supervisor::{AmplifierMonitor, SensorLimits};
use flexarm_core::time::Ticks;
use flexarm_core::trajectory::JointTrajectory;
use flexarm_core::tuning::{RateCeiling, Tuning};
use flexarm_core::{Vector2, Vector4};
use flexarm_link::msg::{Board, Param};

/// An observer gain table: `L` (8×3, row-major; rows `(q, q̇)`, columns `(θ1, θ2, V_f)`).
pub type GainTable = [[f32; 3]; 8];

/// Motor periods a controller tolerates without a new sample before it trips `Stale`.
const STALE_LIMIT: u32 = 3;

/// Everything a board boots with (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoardConfig {
    /// Which board this is.
    pub board: Board,
    /// The controller's model of the arm.
    pub arm: ArmParams<f32>,
    /// The piezo patch on link 2, on the modes of [`Self::arm`].
    pub patch: PiezoPatch<f32>,
    /// Eq. 7 or Eq. 16.
    pub law: MotorLaw,
    /// The motor law's gains.
    pub gains: Gains<f32>,
    /// The piezo loop's gains (`k_c` [s], the rate filter's corner [Hz]).
    pub piezo: PiezoGains<f32>,
    /// The piezo law the board runs (`flexarm_core::control::select`).
    pub piezo_law: PiezoLawKind,
    /// The rate law's gain ceiling by filter corner on this board's loop and the model's
    /// modes, which a `Set` is held to (computed on the host: `cargo sim firmware-params`).
    pub rate_ceiling: &'static RateCeiling<f32>,
    /// The film's static gain `G(0)` [V/V] measured on the arm (0: not measured), which the
    /// laws beside the rate law are designed from.
    pub film_static: f32,
    /// The film's feedthrough `F̂` [V/V] measured on the arm.
    pub film_feedthrough: f32,
    /// The torque limits and the piezo window; also the ceilings a `Set` over the link may
    /// not exceed.
    pub limits: Limits<f32>,
    /// The motion checks' thresholds and the motors' I²t model (`flexarm_core::motion`).
    pub motion: MotionLimits<f32>,
    /// The limits on the moves a host may command (`flexarm_core::drive`).
    pub moves: MoveLimits<f32>,
    /// The observer's gain, designed for this arm, patch and motor period.
    pub observer_gain: GainTable,
    /// Piezo loop rate [Hz].
    pub piezo_hz: u32,
    /// Piezo periods per motor period.
    pub motor_divider: u32,
    /// Motor periods between two samples printed to the log.
    pub print_every: u32,
    /// Motor periods between two samples of the fault recorder.
    pub record_every: u32,
    /// The link watchdog [s]: a move stops when the host has been silent this long.
    pub link_timeout_s: u32,
    /// Motor periods the amplifiers' fault line is ignored after each enable.
    pub amplifier_settle: u32,
    /// Consecutive motor periods the fault line must stay asserted.
    pub amplifier_debounce: u32,
    /// How each joint homes (issue 33, `flexarm_core::homing`): its method, its reference's
    /// angle in the arm's frame, its search's speed, torque limit and travel.
    pub homing: homing::Config<f32>,
}

/// The hardware board's piezo output: what the DAC's output buffer can reach (0.2 V to
/// VDDA − 0.2 V, datasheet), in volts at the patch through the ±200 V amplifier:
/// (3.1 − 1.65) / 1.65 × 200 V = 175.8 V, rounded down.
pub const HARDWARE_PIEZO_V_MAX: f32 = 175.0;

/// Piezo loop rate of `board` [Hz] (see [`BoardConfig::for_board`]).
pub const fn piezo_hz(board: Board) -> u32 {
    match board {
        Board::Hardware => 10_000,
        Board::Qemu => 1_000,
    }
}

/// Piezo periods per motor period, on every board.
pub const MOTOR_DIVIDER: u32 = 10;

impl BoardConfig {
    /// The configuration `board` runs with the arm model `arm`, its patch `patch`, the piezo
    /// gain `k_c` [s], the rate law's ceiling `rate_ceiling` on that board and the observer
    /// gain `observer_gain` designed for that board's motor period (what `cargo sim
    /// firmware-params` generates from a model file).
    ///
    /// The boards differ in rates and output stage. The hardware runs the piezo loop at 10 kHz
    /// and the motor loop at 1 kHz, its piezo window is ±[`HARDWARE_PIEZO_V_MAX`], its fault
    /// recorder takes every second period (500 Hz: the last second), its link watchdog is 1 s.
    /// QEMU's timers lose accuracy above about 1 kHz, so the QEMU board runs the loops ten
    /// times slower (piezo 1 kHz, motor 100 Hz) with the core's ±200 V window, records every
    /// period (the last 5 s), and allows 5 s of the host's silence (a virtual second passes in
    /// a few tens of milliseconds of the host's).
    ///
    /// The piezo law: the QEMU board keeps the paper's rate law on the paper's two-mode arm
    /// (its simulated arm has no other mode and no feedthrough), with the film's static gain
    /// that arm has (`G(0) = Σ_j k_a k_s Δφ'_j²/ω_j²` of the model, [`model_film_static`]) and
    /// no feedthrough, so the other laws can be selected over the link and designed for it.
    /// The hardware board ships the piezo loop off, with nothing measured: the spillover study
    /// (`docs/results.md`, "The film's feedthrough and the laws that survive it") shows the
    /// paper's law at its shipped gain unstable on a realistic link at every bond factor, and
    /// the law it recommends (PPF) stable only with a static gain identified on that arm (the
    /// rule's factor 2.5 is 2.5 times the identified `G(0)` over the true one), which only
    /// commissioning gives (`flexarm bringup`, its film step, then `set piezo_law ppf`; `flexarm
    /// bringup` says so).
    ///
    /// Both: the core's motor gains with the joints' `K_p` slowed for a slow motor loop
    /// (`Gains::default_for`), its filter corner, torque limits, motion checks
    /// (`MotionLimits::default_for`) and move limits; ten printed samples a second; the
    /// amplifiers' fault line ignored for 10 ms after an enable and debounced over 3 periods.
    #[inline(always)]
    pub fn for_board(
        board: Board,
        arm: ArmParams<f32>,
        patch: PiezoPatch<f32>,
        k_c: f32,
        rate_ceiling: &'static RateCeiling<f32>,
        observer_gain: GainTable,
    ) -> Self {
        let (v_a_max, record_every, link_timeout_s) = match board {
            Board::Hardware => (HARDWARE_PIEZO_V_MAX, 2, 1),
            Board::Qemu => (Limits::<f32>::default().v_a_max, 1, 5),
        };
        let (piezo_hz, motor_divider) = (piezo_hz(board), MOTOR_DIVIDER);
        let motor_hz = piezo_hz / motor_divider;
        Self {
            board,
            arm,
            patch,
            law: MotorLaw::Tracking,
            // The paper's gains for the loop's rate, with the joints' integral action
            // (issue 35: the settled error against friction; docs/results.md).
            gains: Gains {
                ki: Vector2::repeat(DEFAULT_KI as f32),
                ..Gains::default_for(motor_hz)
            },
            piezo: PiezoGains {
                k_c,
                ..PiezoGains::default()
            },
            piezo_law: match board {
                Board::Hardware => PiezoLawKind::Off,
                Board::Qemu => PiezoLawKind::Rate,
            },
            rate_ceiling,
            film_static: match board {
                Board::Hardware => 0.0,
                Board::Qemu => model_film_static(&arm, &patch),
            },
            film_feedthrough: 0.0,
            limits: Limits {
                v_a_max,
                v_a_min: -v_a_max,
                ..Limits::default()
            },
            motion: MotionLimits::default_for(motor_hz),
            moves: MoveLimits::default(),
            observer_gain,
            piezo_hz,
            motor_divider,
            print_every: motor_hz / 10,
            record_every,
            link_timeout_s,
            amplifier_settle: motor_hz / 100,
            amplifier_debounce: 3,
            homing: homing::Config::default(),
        }
    }

    /// Motor loop rate [Hz].
    #[inline(always)]
    pub const fn motor_hz(&self) -> u32 {
        self.piezo_hz / self.motor_divider
    }

    /// Piezo loop period [s].
    #[inline(always)]
    pub fn piezo_period(&self) -> f32 {
        1.0 / self.piezo_hz as f32
    }

    /// Motor loop period [s].
    #[inline(always)]
    pub fn motor_period(&self) -> f32 {
        1.0 / self.motor_hz() as f32
    }

    /// What the piezo law is built from.
    pub fn piezo_setup(&self) -> PiezoSetup<f32> {
        PiezoSetup {
            law: self.piezo_law,
            rate: self.piezo,
            film_static: self.film_static,
            film_feedthrough: self.film_feedthrough,
        }
    }

    /// The controller this board runs, holding `trajectory`: the checks, the observer started
    /// at rest at the trajectory's start, the motor law and the piezo law. A configuration that
    /// fails validation (a piezo law its design rule refuses included) latches `InvalidConfig`
    /// (`Controller::new`, `Controller::design_piezo`).
    #[inline(always)]
    pub fn controller(&self, trajectory: JointTrajectory<f32>) -> Controller<f32> {
        let (piezo_period, motor_period) = (self.piezo_period(), self.motor_period());
        let l = &self.limits;
        let mut ctrl = Controller::new(
            MotorController {
                model: Model::new(self.arm),
                gains: self.gains,
                limits: *l,
                law: self.law,
            },
            PiezoLaw::with_window(&self.piezo, piezo_period, l.v_a_min, l.v_a_max),
            self.patch,
            Observer::new(
                gain(&self.observer_gain),
                film_map(&self.patch),
                motor_period,
                trajectory.sample(0.0).q,
            ),
            SensorLimits::default(),
            trajectory,
            motor_period,
            STALE_LIMIT,
        );
        if self.piezo_law != PiezoLawKind::Rate {
            // A law its rule refuses: none runs, and the controller latches InvalidConfig.
            let _ = ctrl.design_piezo(&self.piezo_setup(), piezo_period);
        }
        ctrl
    }

    /// The drive around `ctrl` (which it disarms), its clock at `now`, with this board's move
    /// limits, motion checks and link watchdog.
    #[inline(always)]
    pub fn drive(&self, ctrl: &mut Controller<f32>, now: Ticks) -> Drive<f32> {
        let motor_hz = self.motor_hz();
        let mut drive = Drive::new(ctrl, motor_hz, now, self.moves);
        drive.link_timeout = self.link_timeout_s * motor_hz;
        drive.motion = self.motion;
        // A search not yet running: the configuration is always taken.
        let _ = drive.configure_homing(self.homing);
        drive
    }

    /// What a `Set` over the link checks against: the piezo gains in force, the piezo period,
    /// and the board's ceilings (its limits).
    #[inline(always)]
    pub fn tuning(&self) -> Tuning<f32> {
        Tuning {
            piezo: self.piezo,
            law: self.piezo_law,
            film_static: self.film_static,
            film_feedthrough: self.film_feedthrough,
            piezo_period: self.piezo_period(),
            tau_ceiling: self.limits.tau_max,
            v_a_ceiling: self.limits.v_a_max,
            rate_ceiling: self.rate_ceiling,
        }
    }

    /// The amplifiers' fault-line monitor.
    #[inline(always)]
    pub const fn amplifier_monitor(&self) -> AmplifierMonitor {
        AmplifierMonitor::new(self.amplifier_settle, self.amplifier_debounce)
    }

    /// Every number of the configuration, in a fixed order, as `u32` words (an `f32` as its
    /// bits; the board as 0 for the hardware and 1 for QEMU, the law as 0 for Eq. 7 and 1 for
    /// Eq. 16): what [`Self::hash`] hashes.
    pub fn words(&self, mut f: impl FnMut(u32)) {
        let mut x = |v: f32| f(v.to_bits());
        let a = &self.arm;
        for v in [
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
            x(v);
        }
        let m = &a.modes;
        for v in [m.omega, m.zeta, m.mass_integral, m.moment_integral, m.tip] {
            x(v.x);
            x(v.y);
        }
        let p = &self.patch;
        for v in [p.x_a, p.l_a, p.slope_diff.x, p.slope_diff.y, p.k_a, p.k_s] {
            x(v);
        }
        let g = &self.gains;
        for v in [g.lambda, g.kp] {
            v4(&mut x, &v);
        }
        for v in [g.d_delta, g.epsilon, g.phi] {
            v2(&mut x, &v);
        }
        v2(&mut x, &g.ki);
        v2(&mut x, &g.integral_limit);
        for v in [g.epsilon_floor, g.mu, self.piezo.k_c, self.piezo.cutoff_hz] {
            x(v);
        }
        let l = &self.limits;
        for v in [l.tau_max.x, l.tau_max.y, l.v_a_max, l.v_a_min] {
            x(v);
        }
        let c = &self.motion;
        for v in [c.following, c.speed] {
            v2(&mut x, &v);
        }
        x(c.runaway_speed);
        v2(&mut x, &c.runaway_torque);
        x(c.runaway_error);
        x(c.count);
        v2(&mut x, &c.stall_friction);
        for v in [c.stall_margin, c.stall_accel, c.stall_speed_error] {
            x(v);
        }
        for v in [c.range_min, c.range_max, c.stop_accel] {
            v2(&mut x, &v);
        }
        x(c.range_margin);
        let t = &c.thermal;
        v2(&mut x, &t.continuous);
        for v in [t.time_constant, t.derate, t.floor, t.trip, c.brake_travel] {
            x(v);
        }
        let mv = &self.moves;
        for v in [mv.speed_max, mv.accel_max, mv.theta_max, mv.theta_min] {
            v2(&mut x, &v);
        }
        x(mv.torque_share);
        for row in &self.observer_gain {
            for v in row {
                x(*v);
            }
        }
        for w in [
            self.board as u32,
            self.law as u32,
            c.runaway_periods,
            c.brake_settle_periods,
            self.piezo_hz,
            self.motor_divider,
            self.print_every,
            self.record_every,
            self.link_timeout_s,
            self.amplifier_settle,
            self.amplifier_debounce,
        ] {
            f(w);
        }
        let h = &self.homing;
        for j in &h.joints {
            f(j.method as u32);
            for v in [j.angle, j.speed, j.torque, j.travel] {
                f(v.to_bits());
            }
        }
        for v in [h.stall_travel, h.stall_time, h.stall_share, h.tolerance] {
            f(v.to_bits());
        }
        f(u32::from(self.piezo_law.code()));
        for v in [self.film_static, self.film_feedthrough] {
            f(v.to_bits());
        }
        for v in self.rate_ceiling.rows.as_flattened() {
            f(v.to_bits());
        }
    }

    /// FNV-1a over the little-endian bytes of [`Self::words`]: two boards with the same hash
    /// boot with the same numbers (a `Set` over the link changes some afterwards).
    pub fn hash(&self) -> u32 {
        let mut h: u32 = 0x811c_9dc5;
        self.words(|w| {
            for b in w.to_le_bytes() {
                h = (h ^ u32::from(b)).wrapping_mul(0x0100_0193);
            }
        });
        h
    }
}

/// A configuration field a parameter's declaration names: an `f32`, or the link watchdog's
/// whole seconds.
trait Field {
    fn value(&self) -> f32;
    fn set(&mut self, v: f32);
}

impl Field for f32 {
    fn value(&self) -> f32 {
        *self
    }
    fn set(&mut self, v: f32) {
        *self = v;
    }
}

impl Field for PiezoLawKind {
    fn value(&self) -> f32 {
        f32::from(self.code())
    }
    /// A code that names no law leaves the law as it was.
    fn set(&mut self, v: f32) {
        if let Some(k) = PiezoLawKind::from_code(v) {
            *self = k;
        }
    }
}

impl Field for u32 {
    fn value(&self) -> f32 {
        *self as f32
    }
    fn set(&mut self, v: f32) {
        *self = v as u32;
    }
}

/// `BoardConfig::param` and `set_param` from the parameters' declaration
/// (`flexarm_link::for_each_param!`): each one's configuration field.
macro_rules! config_params {
    ($($variant:ident $name:literal $unit:literal ($min:expr, $max:expr) $moving:ident
       {$($field:tt)*} $home:ident $(($($h:tt)*))? $doc:literal;)*) => {
        impl BoardConfig {
            /// The value the link's parameter `p` boots with on this board (`Get` before any
            /// `Set`), or `None` for one the configuration does not hold (the piezo bias,
            /// which boots at 0).
            pub fn param(&self, p: Param) -> Option<f32> {
                match p {
                    $(Param::$variant => config_params!(@get self {$($field)*}),)*
                }
            }

            /// Sets the link's parameter `p` to `value` in this configuration (as a `Set` at
            /// boot would, without its checks: a controller built from a bad value latches
            /// `InvalidConfig`); `false` for one the configuration does not hold.
            pub fn set_param(&mut self, p: Param, value: f32) -> bool {
                match p {
                    $(Param::$variant => config_params!(@set self value {$($field)*}),)*
                }
            }
        }
    };
    (@get $s:ident {}) => { None };
    (@get $s:ident {$($f:tt)+}) => { Some(Field::value(&$s.$($f)+)) };
    (@set $s:ident $v:ident {}) => { false };
    (@set $s:ident $v:ident {$($f:tt)+}) => {{ Field::set(&mut $s.$($f)+, $v); true }};
}

flexarm_link::for_each_param!(config_params);

/// The film's static gain `G(0) = Σ_j k_a k_s Δφ'_j²/ω_j²` [V/V] the controller's model of the
/// arm (`arm`'s two modes, `patch`) predicts: no other mode, no feedthrough (the QEMU board's
/// simulated arm).
pub fn model_film_static(arm: &ArmParams<f32>, patch: &PiezoPatch<f32>) -> f32 {
    -identified_loop(&arm.modes, patch, 0.0, 0.0).direct
}

fn v2(x: &mut impl FnMut(f32), v: &Vector2<f32>) {
    x(v.x);
    x(v.y);
}

fn v4(x: &mut impl FnMut(f32), v: &Vector4<f32>) {
    for i in v.iter() {
        x(*i);
    }
}

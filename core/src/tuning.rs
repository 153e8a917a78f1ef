//! The parameters a host may read and change on a running controller (the link's `get`/`set`):
//! the motor gains `K_p`, `Λ`, `D_Δ`, the piezo gain `k_c` and its filter corner, the torque and
//! voltage limits. A change is validated with the rules of [`Controller::new`], against the
//! board's ceilings (and the torque limits against a floor, [`TAU_FLOOR_SHARE`]), with the filter corner below the piezo loop's Nyquist rate and the motor
//! gains inside the sampled loop's stable region at the motor period and the rate law's `k_c`
//! within the board's [`RateCeiling`] (both refused as [`TuneError::Unstable`]), before
//! anything is written, refused while a move runs, and written whole
//! between two control steps (the caller holds the controller, so neither loop sees half of it).
//! Units as in `crate::params` and `crate::control::piezo`.
//!
//! The piezo law (issue 35, `crate::control::select`): which one runs, and the film's measured
//! static gain and feedthrough its design rules read. A change of law, and any change that
//! redesigns a law other than the paper's rate law (the measured static gain, the window), is
//! taken only while the piezo output is off: the drive
//! disarmed (amplifiers disabled, 0 V) or in its fault state ([`TuneError::Armed`] otherwise).
//! The new law then starts at rest, and arming restarts it at rest again: its first command
//! is its response to one film sample from zero state (0 V for the rate law, a fraction of a
//! volt for IRC and PPF), not a step from whatever the old law was commanding. Switching
//! while armed has no bumpless form in general: the laws' states mean different things (a
//! filtered derivative, two filtered positions, an integral), so no state of the new law
//! reproduces the old one's command, and a zero-state start would step the patch's voltage
//! from the holding command to about 0 V, exciting the modes the law is there to damp, on a
//! law that has not yet run on this arm. The rate law's own gains keep their rule (changed
//! while holding, the filter restarting at rest), which bring-up relies on.

use crate::control::piezo::{PiezoGains, PiezoLaw};
use crate::control::select::{DesignError, PiezoLawKind, PiezoSelect, PiezoSetup};
use crate::controller::Controller;
use crate::drive::Mode;
use crate::real::Real;
use crate::{Vector2, Vector4};

/// A tunable parameter; indices count from 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tunable {
    /// `K_p` diagonal entry (0–3) [N·m·s/rad on the joints].
    Kp(usize),
    /// `Λ` diagonal entry (0–3) [1/s].
    Lambda(usize),
    /// `D_Δ` entry (0–1) [1/s].
    DDelta(usize),
    /// Integral rate `K_i` of a joint (0–1) [1/s] (`crate::control::integral`).
    Ki(usize),
    /// Piezo gain `k_c` [s].
    Kc,
    /// Piezo rate-filter corner [Hz].
    CutoffHz,
    /// Torque limit of a joint (0–1) [N·m].
    TauMax(usize),
    /// Top of the piezo amplifier's window [V].
    VaMax,
    /// Bottom of the piezo amplifier's window [V] (negative).
    VaMin,
    /// The piezo law, by its code (`PiezoLawKind`).
    PiezoLaw,
    /// The film's measured static gain `G(0)` [V/V] (0: not measured).
    FilmStatic,
    /// The film's measured feedthrough `F̂` [V/V].
    FilmFeedthrough,
}

/// Why a parameter cannot be read or written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TuneError {
    /// No such parameter or index.
    Unknown,
    /// The value is not finite, breaks a rule of [`Controller::new`] or exceeds the board's
    /// ceiling.
    OutOfRange,
    /// Not while a move or a stop runs.
    Moving,
    /// Only while the piezo output is off (the drive disarmed or faulted): a change of the
    /// piezo law or of the numbers a law other than the rate law is designed from (module
    /// docs).
    Armed,
    /// The law's design rule needs the film's static gain measured (`film_static`, larger
    /// than the controller's two modes' share; `flexarm bringup`'s film step).
    Unidentified,
    /// Outside the region the model says is stable with margin at the loop's rate: the motor
    /// gains past the sampled loop's rule, or the rate law's `k_c` past its
    /// [`RateCeiling`] at the filter's corner.
    Unstable,
}

/// Rows of a [`RateCeiling`].
pub const RATE_CEILING_ROWS: usize = 16;

/// The paper's rate law's gain ceiling by filter corner on one board (issue 36: `set`
/// validated for stability). Rows `[f_i, g_i]`, corners `f_i` ascending [Hz], `g_i` a bound on
/// the product `k_c f_c` [s·Hz]: a corner `f_c` in `(f_{i−1}, f_i]` allows
/// `k_c ≤ g_i / f_c`; a corner past the last row's is refused.
///
/// `B(f_c)`, the bound, is half the gain at which the sampled loop (Tustin-filtered derivative,
/// zero-order hold, the board's film delay and amplifier) goes unstable on the link the board
/// drives: a stability factor of 2, the spillover study's rule (`docs/results.md`,
/// "Spillover"). Each `g_i` is the least `B(f) f` over corners sampled between `f_{i−1}` and
/// `f_i`, less a few per cent for what varies between the samples: above the filter's corner
/// the law acts on the modes with a gain near `k_c ω_c`, so `B(f) f` varies slowly and the
/// step costs little, and a corner between rows is held to no more than the loop allows
/// there. Computed on the host from the model file (`cargo sim firmware-params`,
/// `firmware_params::rate_ceilings`, which says which link each board's is computed on).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RateCeiling<T> {
    /// `[f_i, g_i]`, `f_i` ascending [Hz, s·Hz].
    pub rows: [[T; 2]; RATE_CEILING_ROWS],
}

impl RateCeiling<f32> {
    /// No ceiling: a host's check before it knows the board, a study's board.
    pub const NONE: Self = Self {
        rows: [[f32::INFINITY; 2]; RATE_CEILING_ROWS],
    };
}

impl<T: Real> RateCeiling<T> {
    /// The largest `k_c` [s] allowed at the corner `cutoff_hz` (0 past the last row's corner).
    pub fn k_c_max(&self, cutoff_hz: T) -> T {
        self.rows
            .iter()
            .find(|[f, _]| cutoff_hz <= *f)
            .map_or(T::zero(), |[_, g]| *g / cutoff_hz)
    }

    /// Whether the rate law's `gains` are within the ceiling.
    pub fn allows(&self, gains: &PiezoGains<T>) -> bool {
        gains.k_c <= self.k_c_max(gains.cutoff_hz)
    }
}

/// The smallest torque limit [`Tuning::set`] accepts, as a share of the board's ceiling: 1 %
/// (0.1 N·m on the boards' 10 N·m drives). A limit under it leaves a joint unable to follow any
/// move against its own drive's friction (the truth plant's drives carry 0.05 N·m of Coulomb
/// friction), so the following-error check would stop every move; and `1e-30` is a typo, not a
/// setting (issue 36).
pub const TAU_FLOOR_SHARE: f64 = 0.01;

/// The entry an index names, or [`TuneError::Unknown`].
fn slot<X>(v: Option<&mut X>) -> Result<&mut X, TuneError> {
    v.ok_or(TuneError::Unknown)
}

/// The tunable parameters' state besides the controller: the piezo gains (the law keeps them
/// folded into its filter), its period, and the board's ceilings on the limits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tuning<T: 'static> {
    /// The piezo gains in force.
    pub piezo: PiezoGains<T>,
    /// The piezo law in force and the film's measured numbers its design reads (`rate` is
    /// [`Self::piezo`]'s copy, ignored: [`Self::setup`]).
    pub law: PiezoLawKind,
    /// The film's measured static gain `G(0)` [V/V] (0: not measured).
    pub film_static: T,
    /// The film's measured feedthrough `F̂` [V/V].
    pub film_feedthrough: T,
    /// The piezo loop's period [s].
    pub piezo_period: T,
    /// Largest torque limit the drives allow [N·m].
    pub tau_ceiling: Vector2<T>,
    /// Largest voltage magnitude the board's piezo output stage delivers, either sign [V].
    pub v_a_ceiling: T,
    /// The rate law's gain ceiling on this board (held whenever the rate law is selected).
    pub rate_ceiling: &'static RateCeiling<T>,
}

impl<T: Real + 'static> Tuning<T> {
    /// The value of `p`.
    pub fn get(&self, ctrl: &Controller<T>, p: Tunable) -> Result<T, TuneError> {
        let g = &ctrl.motor.gains;
        let l = &ctrl.motor.limits;
        let at4 = |v: &Vector4<T>, i: usize| v.get(i).copied().ok_or(TuneError::Unknown);
        let at2 = |v: &Vector2<T>, i: usize| v.get(i).copied().ok_or(TuneError::Unknown);
        match p {
            Tunable::Kp(i) => at4(&g.kp, i),
            Tunable::Lambda(i) => at4(&g.lambda, i),
            Tunable::DDelta(i) => at2(&g.d_delta, i),
            Tunable::Ki(i) => at2(&g.ki, i),
            Tunable::Kc => Ok(self.piezo.k_c),
            Tunable::CutoffHz => Ok(self.piezo.cutoff_hz),
            Tunable::TauMax(i) => at2(&l.tau_max, i),
            Tunable::VaMax => Ok(l.v_a_max),
            Tunable::VaMin => Ok(l.v_a_min),
            Tunable::PiezoLaw => Ok(T::c(f64::from(self.law.code()))),
            Tunable::FilmStatic => Ok(self.film_static),
            Tunable::FilmFeedthrough => Ok(self.film_feedthrough),
        }
    }

    /// What the piezo law is built from.
    pub fn setup(&self) -> PiezoSetup<T> {
        PiezoSetup {
            law: self.law,
            rate: self.piezo,
            film_static: self.film_static,
            film_feedthrough: self.film_feedthrough,
        }
    }

    /// Whether a change of `K_p`, `Λ` or `K_i` keeps the sampled motor loop where the model says it
    /// is stable with margin: the velocity loop's fastest rate
    /// ([`crate::model::Model::velocity_loop_rate`]) and every `λ_i` times the motor period at
    /// most 1, and so every `K_i` (the rule [`crate::params::Gains::default_for`] builds the
    /// boards' gains by; the
    /// sampled loops diverge above 2: `K_p = 1e6` flipped the holding torque by ±4 N·m every
    /// period, issue 36). 1e-3 of slack for `f32` rounding: the QEMU board's gains sit at
    /// 0.9996. Other parameters do not move it and are not held to it.
    fn sampled_stable(
        &self,
        ctrl: &Controller<T>,
        p: Tunable,
        gains: &crate::params::Gains<T>,
    ) -> bool {
        if !matches!(p, Tunable::Kp(_) | Tunable::Lambda(_) | Tunable::Ki(_)) {
            return true;
        }
        let bound = T::c(1.0 + 1e-3);
        let period = ctrl.motor_period;
        let rate = ctrl
            .motor
            .model
            .velocity_loop_rate(Vector2::new(gains.kp.x, gains.kp.y));
        rate * period <= bound
            && gains.lambda.iter().all(|l| *l * period <= bound)
            && gains.ki.iter().all(|k| *k * period <= bound)
    }

    /// Sets `p` to `value` when the drive is in `mode` (anything but moving or stopping).
    pub fn set(
        &mut self,
        ctrl: &mut Controller<T>,
        mode: Mode,
        p: Tunable,
        value: T,
    ) -> Result<(), TuneError> {
        if matches!(mode, Mode::Moving | Mode::Stopping) {
            return Err(TuneError::Moving);
        }
        if !value.finite() {
            return Err(TuneError::OutOfRange);
        }
        let (mut gains, mut limits, mut piezo) = (ctrl.motor.gains, ctrl.motor.limits, self.piezo);
        let mut setup = self.setup();
        match p {
            Tunable::Kp(i) => *slot(gains.kp.get_mut(i))? = value,
            Tunable::Lambda(i) => *slot(gains.lambda.get_mut(i))? = value,
            Tunable::DDelta(i) => *slot(gains.d_delta.get_mut(i))? = value,
            Tunable::Ki(i) => *slot(gains.ki.get_mut(i))? = value,
            Tunable::Kc => piezo.k_c = value,
            Tunable::CutoffHz => piezo.cutoff_hz = value,
            Tunable::TauMax(i) => *slot(limits.tau_max.get_mut(i))? = value,
            Tunable::VaMax => limits.v_a_max = value,
            Tunable::VaMin => limits.v_a_min = value,
            Tunable::PiezoLaw => {
                setup.law = PiezoLawKind::from_code(value.to_f32()).ok_or(TuneError::OutOfRange)?
            }
            Tunable::FilmStatic => setup.film_static = value,
            Tunable::FilmFeedthrough => setup.film_feedthrough = value,
        }
        setup.rate = piezo;
        let law = PiezoLaw::with_window(&piezo, self.piezo_period, limits.v_a_min, limits.v_a_max);
        // The board's ceilings and the torque limits' floor, and a filter corner below the
        // piezo loop's Nyquist rate.
        // (An infinite ceiling, a host's check before it knows the board, sets no floor.)
        let floor = self.tau_ceiling.map(|c| {
            if c.finite() {
                c * T::c(TAU_FLOOR_SHARE)
            } else {
                T::zero()
            }
        });
        let within = limits.tau_max.x <= self.tau_ceiling.x
            && limits.tau_max.y <= self.tau_ceiling.y
            && limits.tau_max.x >= floor.x
            && limits.tau_max.y >= floor.y
            && limits.v_a_max <= self.v_a_ceiling
            && -limits.v_a_min <= self.v_a_ceiling
            && piezo.cutoff_hz * self.piezo_period < T::c(0.5);
        if gains.validate().is_err()
            || limits.validate().is_err()
            || !law.is_valid_or_off()
            || !within
        {
            return Err(TuneError::OutOfRange);
        }
        let rate_held = matches!(p, Tunable::Kc | Tunable::CutoffHz | Tunable::PiezoLaw);
        if !self.sampled_stable(ctrl, p, &gains)
            || (rate_held && setup.law == PiezoLawKind::Rate && !self.rate_ceiling.allows(&piezo))
        {
            return Err(TuneError::Unstable);
        }
        // The selected law, redesigned when what it is built from changed.
        let old = self.setup();
        let kind = setup.law;
        let window = matches!(p, Tunable::VaMax | Tunable::VaMin);
        let redesign = kind != old.law
            || (kind.needs_identification() && (setup.film_static != old.film_static || window));
        let selected = if redesign {
            if !matches!(mode, Mode::Disarmed | Mode::Fault) {
                return Err(TuneError::Armed);
            }
            let modes = &ctrl.motor.model.params.modes;
            Some(
                PiezoSelect::design(
                    &setup,
                    modes,
                    &ctrl.patch,
                    self.piezo_period,
                    limits.v_a_min,
                    limits.v_a_max,
                )
                .map_err(|e| match e {
                    DesignError::Unidentified => TuneError::Unidentified,
                    DesignError::Invalid => TuneError::OutOfRange,
                })?,
            )
        } else {
            None
        };
        ctrl.motor.gains = gains;
        ctrl.motor.limits = limits;
        if piezo != self.piezo || window {
            ctrl.piezo = law;
            self.piezo = piezo;
        }
        if let Some(l) = selected {
            ctrl.install_piezo(l);
        }
        self.law = kind;
        self.film_static = setup.film_static;
        self.film_feedthrough = setup.film_feedthrough;
        Ok(())
    }
}

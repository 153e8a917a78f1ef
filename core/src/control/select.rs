//! Which piezo law the controller runs (issue 35): the paper's rate feedback (Eq. 17), integral
//! resonant control ([`super::irc`]), positive position feedback ([`super::ppf`]), or none
//! (0 V). Rate feedback with the feedthrough cancelled ([`super::cancel`]) is a study law, not a
//! board's: the spillover study finds its factor 1.4–1.6 at bond factors of 0.5 and more
//! (`docs/results.md`), below the goal of 2, and its margin rests on `F̂` and the actuator
//! path's gain being right (a gain `g` leaves `(g − 1) F` in the loop), which nothing on the
//! board checks. A board offers only laws whose stability the study supports.
//!
//! A board boots with one ([`PiezoSetup::law`], its configuration's `piezo_law`) and a host
//! switches over the link (`set piezo_law ppf`, `flexarm_core::tuning`). The laws beside the
//! paper's are designed on the board, by their design rules, from the loop commissioning
//! identifies ([`identified_loop`]): the controller's two modes (`ω_j`, `ζ_j` of its arm model),
//! their film gains from its patch (`g_j = k_a k_s Δφ'_j²`), and two measured numbers,
//! the film's static gain `G(0) = V_f/V_a` held still ([`PiezoSetup::film_static`]) and its
//! jump right after a step `F̂` ([`PiezoSetup::film_feedthrough`]). A static gain of 0 means
//! "not measured": the design refuses it ([`DesignError::Unidentified`]), so an arm whose
//! patch was never commissioned runs only the rate law or none.
//!
//! Units SI: volts, V/V, Hz, s.

use super::irc::{Irc, IrcGains};
use super::linear::IdentifiedLoop;
use super::piezo::{PiezoGains, PiezoPatch};
use super::ppf::{Ppf, PpfGains};
use crate::params::ModalData;
use crate::real::Real;

/// A piezo law, by its wire code (the link's `piezo_law` parameter carries the code as a
/// number).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum PiezoLawKind {
    /// No law: the piezo command is 0 V (the patch still takes the bias of bring-up).
    Off = 0,
    /// The paper's rate feedback `V_a = −k_c V̇_f` (Eq. 17), gains `kc`, `cutoff_hz`.
    Rate = 1,
    /// Integral resonant control, designed by [`IrcGains::design`].
    Irc = 2,
    /// Positive position feedback, designed by [`PpfGains::design`].
    Ppf = 3,
}

/// Every law, in code order.
pub const LAWS: [PiezoLawKind; 4] = [
    PiezoLawKind::Off,
    PiezoLawKind::Rate,
    PiezoLawKind::Irc,
    PiezoLawKind::Ppf,
];

impl PiezoLawKind {
    /// The law whose code is `code` (a whole number 0–3), or `None`.
    pub fn from_code(code: f32) -> Option<Self> {
        LAWS.iter().copied().find(|k| *k as u8 as f32 == code)
    }

    /// Its code.
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The name an operator types (`set piezo_law ppf`).
    pub const fn name(self) -> &'static str {
        match self {
            Self::Off => "off",
            Self::Rate => "rate",
            Self::Irc => "irc",
            Self::Ppf => "ppf",
        }
    }

    /// The law an operator calls `name`.
    pub fn named(name: &str) -> Option<Self> {
        LAWS.iter().copied().find(|k| k.name() == name)
    }

    /// Whether its design reads the film's measured static gain.
    pub const fn needs_identification(self) -> bool {
        matches!(self, Self::Irc | Self::Ppf)
    }
}

/// What a board's piezo law is built from besides its arm model and patch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PiezoSetup<T> {
    /// The law that runs.
    pub law: PiezoLawKind,
    /// The rate law's gains.
    pub rate: PiezoGains<T>,
    /// The film's static gain `G(0)` [V/V] measured on the arm (`flexarm bringup`'s film step); 0
    /// when not measured.
    pub film_static: T,
    /// The film's feedthrough `F̂` [V/V]: its jump right after a step of `V_a`, per volt
    /// (recorded with the static gain; no law on the board reads it).
    pub film_feedthrough: T,
}

/// Why a law cannot be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DesignError {
    /// The law's design rule needs the film's static gain measured, larger than the
    /// controller's two modes' share and finite (`IdentifiedLoop::is_valid`).
    Unidentified,
    /// The designed (or given) gains give no valid law at this period and window.
    Invalid,
}

/// The identified loop of the controller's arm: its modes `modes`, the film gains of `patch`,
/// the measured static gain `film_static` and feedthrough `film_feedthrough`:
/// `D̂ = G(0) − Σ_j g_j/ω_j²` (what the static gain holds besides the two modes).
pub fn identified_loop<T: Real>(
    modes: &ModalData<T>,
    patch: &PiezoPatch<T>,
    film_static: T,
    film_feedthrough: T,
) -> IdentifiedLoop<T> {
    let (d, w, k) = (&patch.slope_diff, &modes.omega, patch.k_a * patch.k_s);
    let g = crate::Vector2::new(d.x * d.x * k, d.y * d.y * k);
    IdentifiedLoop {
        omega: modes.omega,
        zeta: modes.zeta,
        film_gain: g,
        direct: film_static - (g.x / (w.x * w.x) + g.y / (w.y * w.y)),
        feedthrough: film_feedthrough,
    }
}

/// The law the controller runs besides the rate law it keeps on its own
/// (`Controller::piezo`): [`Self::Rate`] runs that one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PiezoSelect<T> {
    /// No law: 0 V.
    Off,
    /// The controller's rate law (Eq. 17).
    Rate,
    /// Integral resonant control.
    Irc(Irc<T>),
    /// Positive position feedback.
    Ppf(Ppf<T>),
}

impl<T: Real> PiezoSelect<T> {
    /// The law `setup` names for the arm's `modes` and `patch`, sampled every `period` [s],
    /// within `[v_min, v_max]` [V]. The rate law and none need no identification. Not
    /// inlined: one copy serves a board's start and the link's `Set` (flash).
    #[inline(never)]
    pub fn design(
        setup: &PiezoSetup<T>,
        modes: &ModalData<T>,
        patch: &PiezoPatch<T>,
        period: T,
        v_min: T,
        v_max: T,
    ) -> Result<Self, DesignError> {
        let irc = match setup.law {
            PiezoLawKind::Off => return Ok(Self::Off),
            PiezoLawKind::Rate => return Ok(Self::Rate),
            PiezoLawKind::Irc => true,
            PiezoLawKind::Ppf => false,
        };
        let id = identified_loop(modes, patch, setup.film_static, setup.film_feedthrough);
        if !id.is_valid() {
            return Err(DesignError::Unidentified);
        }
        let (law, valid) = if irc {
            let g = IrcGains::design(&id).ok_or(DesignError::Unidentified)?;
            let l = Irc::new(&g, period, v_min, v_max);
            (Self::Irc(l), l.is_valid())
        } else {
            let g = PpfGains::design(&id).ok_or(DesignError::Unidentified)?;
            let l = Ppf::new(&g, period, v_min, v_max);
            (Self::Ppf(l), l.is_valid())
        };
        if valid {
            Ok(law)
        } else {
            Err(DesignError::Invalid)
        }
    }

    /// Which law this is.
    pub fn kind(&self) -> PiezoLawKind {
        match self {
            Self::Off => PiezoLawKind::Off,
            Self::Rate => PiezoLawKind::Rate,
            Self::Irc(_) => PiezoLawKind::Irc,
            Self::Ppf(_) => PiezoLawKind::Ppf,
        }
    }

    /// One step of a law other than the rate law (`Rate` and `Off` give 0 V here: the
    /// controller runs its rate law itself). `v_f` [V] checked finite by the caller.
    #[inline(always)]
    pub fn step(&mut self, v_f: T) -> T {
        match self {
            Self::Off | Self::Rate => T::zero(),
            Self::Irc(l) => l.step(v_f),
            Self::Ppf(l) => l.step(v_f),
        }
    }

    /// Clears the law's state (its next command starts from rest).
    pub fn reset(&mut self) {
        match self {
            Self::Off | Self::Rate => {}
            Self::Irc(l) => l.reset(),
            Self::Ppf(l) => l.reset(),
        }
    }

    /// Whether the law is one a controller may run (each law's own `is_valid`).
    pub fn is_valid(&self) -> bool {
        match self {
            Self::Off | Self::Rate => true,
            Self::Irc(l) => l.is_valid(),
            Self::Ppf(l) => l.is_valid(),
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::params::ArmParams;

    fn setup(law: PiezoLawKind, film_static: f32) -> PiezoSetup<f32> {
        PiezoSetup {
            law,
            rate: PiezoGains::default(),
            film_static,
            film_feedthrough: -1e-3,
        }
    }

    fn paper() -> (ModalData<f32>, PiezoPatch<f32>) {
        (ArmParams::<f32>::default().modes, PiezoPatch::paper())
    }

    /// The codes round-trip, the names are unique, and only whole codes 0–4 name a law.
    #[test]
    fn codes_and_names() {
        for k in LAWS {
            assert_eq!(PiezoLawKind::from_code(f32::from(k.code())), Some(k));
            assert_eq!(PiezoLawKind::named(k.name()), Some(k));
        }
        for bad in [-1.0, 0.5, 4.0, f32::NAN, f32::INFINITY] {
            assert_eq!(PiezoLawKind::from_code(bad), None, "{bad}");
        }
    }

    /// The identified loop's static gain is the measured one, whatever the model's modes.
    #[test]
    fn the_identified_loop_keeps_the_measured_static_gain() {
        let (m, p) = paper();
        let id = identified_loop(&m, &p, 2e-3, -1e-3);
        assert!((id.static_gain() - 2e-3).abs() < 1e-8);
        assert_eq!(id.feedthrough, -1e-3);
    }

    /// Every law builds with a measured static gain; the laws that need one refuse 0 (not
    /// measured), a negative or a non-finite one, and the rate law and none need none.
    #[test]
    fn designs_need_the_measured_static_gain() {
        let (m, p) = paper();
        let two_modes = -identified_loop(&m, &p, 0.0, 0.0).direct;
        assert!(two_modes > 0.0);
        for k in LAWS {
            let l = PiezoSelect::design(&setup(k, two_modes), &m, &p, 1e-4, -30.0, 175.0);
            assert_eq!(l.map(|l| l.kind()), Ok(k), "{k:?}");
            for bad in [0.0, -1e-3, f32::NAN] {
                let l = PiezoSelect::design(&setup(k, bad), &m, &p, 1e-4, -30.0, 175.0);
                if k.needs_identification() {
                    assert_eq!(l, Err(DesignError::Unidentified), "{k:?} at {bad}");
                } else {
                    assert!(l.is_ok(), "{k:?}");
                }
            }
        }
        // A window without 0 V inside gives no law.
        let l = PiezoSelect::design(&setup(PiezoLawKind::Ppf, two_modes), &m, &p, 1e-4, 1.0, 2.0);
        assert_eq!(l, Err(DesignError::Invalid));
    }

    /// A designed PPF law responds to the film and its reset returns it to rest.
    #[test]
    fn steps_and_resets() {
        let (m, p) = paper();
        let s = setup(PiezoLawKind::Ppf, -identified_loop(&m, &p, 0.0, 0.0).direct);
        let mut l = PiezoSelect::design(&s, &m, &p, 1e-4, -30.0, 175.0).unwrap();
        let first = l.step(1.0);
        let mut last = first;
        for _ in 0..100 {
            last = l.step(1.0);
        }
        assert!(last > first && last > 0.0, "{first} {last}");
        l.reset();
        assert_eq!(l.step(1.0), first);
    }
}

//! The test family (issue 32): truth-plant arms that differ from the paper's in the ways a lab's
//! arm does, and the records a lab makes of them ([`crate::lab`]). What the identification
//! claims about arms is measured on this family, not on the paper's arm alone
//! (`docs/identification.md`, `cargo sim identify family`).
//!
//! | arm | how it differs | its modes [Hz] |
//! |---|---|---|
//! | `slow` | a 1 mm link with a 0.22 kg tip body: first mode 0.5 Hz | 0.505, 5.46, 14.8, 30.6, 63.9, 97.2 |
//! | `payload` | the 2.5 mm link with a 0.5 kg tip payload | 1.16, 14.7, 36.8, 74.9, 146, 236 |
//! | `patch` | the patch and film at 0.30–0.50 m instead of 0.09–0.44 m | 3.76, 26.6, 72.8, 143, 236, 353 |
//! | `light` | the first mode damped at ζ1 = 0.01 | 4.54, 25.7, 70.0, 143, 233, 354 |
//! | `long` | a 1 m link of 1.5 mm: four resonances under 50 Hz | 1.53, 6.87, 21.2, 40.9, 69.3, 105 |
//!
//! Each keeps the truth plant's six modes, drives with friction, amplifiers and the film's
//! 0.5 Hz high-pass, and a realistic board's sensors ([`Sensors::realistic`]).

use flexarm_core::Vector2;
use flexarm_core::control::piezo::PiezoPatch;
use flexarm_core::params::ArmParams;

use crate::lab::{Actuator, Excite, Hold, Plan, Shape};
use crate::sim::{Sensors, SimConfig, StateSource};
use crate::truth_plant::TruthSpec;

/// One arm of the family.
#[derive(Clone, Debug, PartialEq)]
pub struct FamilyArm {
    /// Its name.
    pub name: &'static str,
    /// How it differs from the paper's arm.
    pub differs: &'static str,
    /// Its link, drives and amplifiers.
    pub spec: TruthSpec,
    /// Its rigid parts (link 2's length `a2` among them).
    pub rigid: ArmParams<f64>,
    /// The patch's place (`x_a`, `l_a`; its coupling is the truth link's).
    pub patch: PiezoPatch<f64>,
}

/// One of the truth link's modes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrueMode {
    /// Frequency [Hz].
    pub hz: f64,
    /// Damping ratio [-].
    pub zeta: f64,
    /// The piezo→film product `g = k_a k_s Δφ'²` [V/V·s⁻²].
    pub gain: f64,
}

impl FamilyArm {
    /// The bench the arm's records are made on: the truth plant, a realistic board.
    pub fn bench(&self) -> Result<SimConfig, String> {
        SimConfig {
            arm: self.rigid,
            patch: self.patch,
            state: StateSource::Observer,
            sensors: Sensors::realistic(),
            ..SimConfig::default()
        }
        .with_truth(self.spec)
        .map_err(|e| format!("the {} arm: {e}", self.name))
    }

    /// Every mode of the truth link, ascending.
    pub fn modes(&self) -> Result<Vec<TrueMode>, String> {
        let (body, c) = self
            .spec
            .link(&self.rigid, &self.patch)
            .map_err(|e| e.to_string())?;
        Ok(body
            .omega
            .iter()
            .zip(&body.zeta)
            .zip(&c.slope_diff)
            .map(|((w, z), d)| TrueMode {
                hz: w / std::f64::consts::TAU,
                zeta: *z,
                gain: c.k_a * c.k_s * d * d,
            })
            .collect())
    }
}

/// The family (module docs).
pub fn family() -> Vec<FamilyArm> {
    let d = TruthSpec::default();
    let paper = ArmParams::default();
    let arm = |name, differs, spec, a2: f64, place: (f64, f64)| FamilyArm {
        name,
        differs,
        spec,
        rigid: ArmParams { a2, ..paper },
        patch: PiezoPatch {
            x_a: place.0,
            l_a: place.1,
            ..PiezoPatch::paper()
        },
    };
    let mut light = d.zeta;
    light[0] = 0.01;
    vec![
        arm(
            "slow",
            "first mode 0.5 Hz: a 1 mm link with a 0.22 kg tip body",
            TruthSpec {
                thickness: 1.0e-3,
                tip_mass: 0.22,
                tip_inertia: 2.2e-4,
                ..d
            },
            0.7,
            (0.09, 0.35),
        ),
        arm(
            "payload",
            "a 0.5 kg tip payload on the 2.5 mm link",
            TruthSpec {
                tip_mass: 0.5,
                tip_inertia: 5e-4,
                ..d
            },
            0.7,
            (0.09, 0.35),
        ),
        arm(
            "patch",
            "the patch and film at 0.30–0.50 m",
            d,
            0.7,
            (0.30, 0.20),
        ),
        arm(
            "light",
            "ζ1 = 0.01",
            TruthSpec { zeta: light, ..d },
            0.7,
            (0.09, 0.35),
        ),
        arm(
            "long",
            "a 1 m link of 1.5 mm: four resonances under 50 Hz",
            TruthSpec {
                thickness: 1.5e-3,
                ..d
            },
            1.0,
            (0.09, 0.35),
        ),
    ]
}

/// The kinds of record a lab makes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// A linear chirp on the patch, 0.1–60 Hz in 60 s, the joints held by the PD.
    ChirpLinear,
    /// A logarithmic chirp on the patch, 0.1–60 Hz in 60 s.
    ChirpLog,
    /// The logarithmic chirp with band-limited noise on joint 2's torque at once, 0.1–60 Hz.
    ChirpNoise,
    /// Taps of the patch, 20 ms each, 20 s apart.
    PatchTaps,
    /// Torque pulses on joint 2, 20 ms each, 20 s apart.
    TorqueTaps,
    /// A hammer's strikes across the tip, 20 s apart.
    HammerTaps,
    /// Band-limited noise on the patch and on joint 2 at once, independent, 0.1–60 Hz, 120 s.
    Random,
}

impl Kind {
    /// Every kind.
    pub const ALL: [Kind; 7] = [
        Kind::ChirpLinear,
        Kind::ChirpLog,
        Kind::ChirpNoise,
        Kind::PatchTaps,
        Kind::TorqueTaps,
        Kind::HammerTaps,
        Kind::Random,
    ];

    /// Its name in tables and file names.
    pub fn name(self) -> &'static str {
        match self {
            Kind::ChirpLinear => "chirp",
            Kind::ChirpLog => "log-chirp",
            Kind::ChirpNoise => "chirp+noise",
            Kind::PatchTaps => "patch-taps",
            Kind::TorqueTaps => "torque-taps",
            Kind::HammerTaps => "hammer",
            Kind::Random => "random",
        }
    }

    /// The record's plan on `bench` at the pose `(0, π/2)` (amplitudes before
    /// [`crate::lab::sized`]).
    pub fn plan(self, bench: &SimConfig) -> Plan {
        let band = (0.1, 60.0);
        let chirp = |log| Shape::Chirp {
            from: band.0,
            to: band.1,
            seconds: 60.0,
            log,
        };
        let taps = Shape::Taps {
            count: 5,
            width: 0.02,
            spacing: 20.0,
        };
        let one = |actuator, shape, amplitude| Excite {
            actuator,
            shape,
            amplitude,
        };
        let noise = |seed, seconds| Shape::Random {
            from: band.0,
            to: band.1,
            seconds,
            seed,
        };
        let (excite, tail) = match self {
            Kind::ChirpLinear => (vec![one(Actuator::Patch, chirp(false), 100.0)], 20.0),
            Kind::ChirpLog => (vec![one(Actuator::Patch, chirp(true), 100.0)], 20.0),
            Kind::ChirpNoise => (
                vec![
                    one(Actuator::Patch, chirp(true), 100.0),
                    one(Actuator::Motor(1), noise(5, 60.0), 2.0),
                ],
                20.0,
            ),
            Kind::PatchTaps => (vec![one(Actuator::Patch, taps, 100.0)], 0.0),
            Kind::TorqueTaps => (vec![one(Actuator::Motor(1), taps, 2.0)], 0.0),
            Kind::HammerTaps => (vec![one(Actuator::Hammer, taps, 0.05)], 0.0),
            Kind::Random => (
                vec![
                    one(Actuator::Patch, noise(3, 120.0), 100.0),
                    one(Actuator::Motor(1), noise(5, 120.0), 2.0),
                ],
                0.0,
            ),
        };
        Plan {
            cfg: *bench,
            pose: Vector2::new(0.0, std::f64::consts::FRAC_PI_2),
            hold: Hold::default(),
            excite,
            lead: 1.0,
            tail,
        }
    }
}

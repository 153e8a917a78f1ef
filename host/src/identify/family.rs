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

use std::path::Path;

use flexarm_core::Vector2;
use flexarm_core::control::piezo::PiezoPatch;
use flexarm_core::params::ArmParams;

use super::decay::{DecayFit, DecaySettings, Tapper, fit_decay};
use super::geometry::Geometry;
use super::inertia::{InertiaFit, Rigid, fit_inertia, fit_inertia_flexible};
use super::modal::{self, FitSettings, ModesFit};
use super::model::{LoopRun, closed_loop, coupling, identified_model};
use super::record::ModesRecord;
use super::workflow::CHECK_PIEZO;
use crate::lab::{self, Actuator, Excite, Hold, Plan, Shape, Track};
use crate::output::{read_csv, trace_csv};
use crate::sim::{Sample, Sensors, SimConfig, StateSource};
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

    /// A record of taps (the decay fit reads it too).
    pub fn taps(self) -> bool {
        matches!(self, Kind::PatchTaps | Kind::TorqueTaps | Kind::HammerTaps)
    }

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
            track: None,
            lead: 1.0,
            tail,
        }
    }
}

/// A lab's inertia record on `bench`: the hold tracks a multisine on both joints about
/// `(0, 0.5)` (joint 2 the wider, so that `cos θ2` varies), faded in and out, from
/// 0.05 Hz to 0.5 Hz or half the link's first mode `f1` [Hz], whichever is lower (a lab keeps
/// its swings below the link's first mode, which its modes record told it): ±0.3 and ±0.8 rad
/// and 60 s to 0.5 Hz, further and longer for slower swings (at most ±1 and ±1.2 rad, 120 s).
pub fn swing(bench: &SimConfig, f1: f64) -> Plan {
    let top = (0.5 * f1).min(0.5);
    // Slower swings reach further (within the joints' ranges), for accelerations alike.
    let k = (0.5 / top).powi(2);
    Plan {
        cfg: *bench,
        pose: Vector2::new(0.0, 0.5),
        hold: Hold::default(),
        excite: Vec::new(),
        track: Some(Track {
            reach: Vector2::new((0.3 * k).min(1.0), (0.8 * k).min(1.2)),
            band: (0.05, top),
            seconds: 60.0 * k.sqrt().min(2.0),
            seed: 17,
        }),
        lead: 1.0,
        tail: 1.0,
    }
}

impl FamilyArm {
    /// The arm's geometry as its user would write it (`--arm`): its lengths, payload, the
    /// patch's place and the truth link's transducer constants, the realistic board's ranges.
    pub fn geometry(&self) -> Result<Geometry, String> {
        let (_, c) = self
            .spec
            .link(&self.rigid, &self.patch)
            .map_err(|e| e.to_string())?;
        // The lab knows its layers: the truth link's stack at its thickness.
        let mut layers = flexarm_beam::section::Layers::default();
        layers.material.t_b = self.spec.thickness;
        let (bare, patched) = (layers.bare(), layers.patched());
        Ok(Geometry {
            a1: self.rigid.a1,
            a2: self.rigid.a2,
            tip_mass: self.spec.tip_mass,
            tip_inertia: self.spec.tip_inertia,
            x_a: self.patch.x_a,
            l_a: self.patch.l_a,
            mass_ratio: patched.rho_a / bare.rho_a,
            stiffness_ratio: patched.ei / bare.ei,
            k_a: c.k_a,
            k_s: c.k_s,
            torque_limit: self.bench()?.limits.tau_max.cast::<f64>().into(),
            ..Geometry::default()
        })
    }
}

/// A record made by the lab (sized to [`FILM_SHARE`] of the film's range), written by the
/// simulator's trace writer into `dir` as `<arm>_<name>.csv` and read back as a user's file
/// is; the file is removed after unless `keep`.
pub fn lab_record(
    dir: &Path,
    (arm, name): (&str, &str),
    plan: &Plan,
    keep: bool,
) -> Result<Vec<Sample>, String> {
    let sized = if plan.excite.is_empty() {
        plan.clone()
    } else {
        lab::sized(plan, FILM_SHARE)?
    };
    let trace = lab::record(&sized)?;
    let path = dir.join(format!("{arm}_{name}.csv"));
    std::fs::write(&path, trace_csv(&trace))
        .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    let back = read_csv(&path);
    if !keep {
        let _ = std::fs::remove_file(&path);
    }
    back
}

/// Below this share of the truth's second mode a decay's modes are the held arm's first mode
/// and the hold's, not the clamped link's: a decay is compared with the truth from there up.
pub const HELD_BELOW: f64 = 0.75;

/// The share of the film ADC's range the lab's excitations are sized to.
pub const FILM_SHARE: f64 = 0.4;

/// One arm's identification from its lab's records.
#[derive(Clone, Debug)]
pub struct ArmResult {
    /// The arm.
    pub arm: FamilyArm,
    /// Its true modes.
    pub truth: Vec<TrueMode>,
    /// Per kind of record, the modes fit (or its refusal).
    pub modes: Vec<(Kind, Result<ModesFit, String>)>,
    /// Per kind of tap record, the decay fit (or its refusal).
    pub decays: Vec<(Kind, Result<DecayFit, String>)>,
    /// The inertia fit of its swing (or its refusal), and the true combinations.
    pub inertia: (Result<InertiaFit, String>, Rigid),
    /// The model from the first kind whose fit found the clamped modes, and its closed-loop
    /// check (the true parameters' run first), or why not.
    pub check: Result<(Kind, Vec<LoopRun>), String>,
}

/// Identifies `arm` from its lab's records of `kinds` and its swing, written into `dir` (and
/// kept there with `keep`); the model from the first kind that found the clamped modes, and
/// the closed-loop check of it on the truth plant.
pub fn identify_arm(
    arm: &FamilyArm,
    kinds: &[Kind],
    dir: &Path,
    keep: bool,
) -> Result<ArmResult, String> {
    let bench = arm.bench()?;
    let geometry = arm.geometry()?;
    let truth = arm.modes()?;
    let mut modes = Vec::new();
    let mut decays = Vec::new();
    for &kind in kinds {
        let trace = lab_record(dir, (arm.name, kind.name()), &kind.plan(&bench), keep)?;
        let rec = ModesRecord::from_trace(&trace, geometry.film_range, geometry.amplifier_window)
            .map_err(|e| e.to_string());
        if kind.taps() {
            let fit = rec
                .as_ref()
                .map_err(Clone::clone)
                .and_then(|r| fit_decay(r, &DecaySettings::default()).map_err(|e| e.to_string()));
            decays.push((kind, fit));
        }
        let fit = rec
            .and_then(|r| modal::fit_modes(&r, &FitSettings::default()).map_err(|e| e.to_string()));
        modes.push((kind, fit));
    }
    let swing_trace = lab_record(dir, (arm.name, "swing"), &swing(&bench, truth[0].hz), keep)?;
    // The model from the first record that found the clamped modes; the inertias with its
    // modes taken out of the torques.
    let clamped = modes.iter().find_map(|(k, f)| {
        f.as_ref()
            .ok()
            .filter(|f| f.held.is_none())
            .map(|f| (*k, f))
    });
    let inertia = super::record::check_torques(&swing_trace, geometry.torque_limit)
        .and_then(|()| match clamped {
            Some((_, fit)) => {
                fit_inertia_flexible(&swing_trace, geometry.a1, geometry.s_floor(), &|s| {
                    coupling(&geometry, fit, s)
                })
            }
            None => fit_inertia(&swing_trace),
        })
        .map_err(|e| e.to_string());
    let check = (|| {
        let (kind, fit) = clamped.ok_or("no record found the clamped modes")?;
        let inertia = inertia
            .as_ref()
            .map_err(|e| format!("the inertia fit: {e}"))?;
        let (a, p, _) = identified_model(&geometry, &bench.arm, &inertia.rigid, fit)
            .map_err(|e| e.to_string())?;
        let check = SimConfig {
            piezo: Some(CHECK_PIEZO),
            ..bench
        };
        let runs = closed_loop(&check, &[("identified model", a, p)]).map_err(|e| e.to_string())?;
        Ok((kind, runs))
    })();
    Ok(ArmResult {
        arm: arm.clone(),
        truth,
        modes,
        decays,
        inertia: (inertia, Rigid::of(&bench.arm)),
        check,
    })
}

/// The true mode nearest in frequency to `hz`, and its number (from 1).
pub fn nearest(truth: &[TrueMode], hz: f64) -> Option<(usize, TrueMode)> {
    truth
        .iter()
        .copied()
        .enumerate()
        .min_by(|a, b| {
            (a.1.hz / hz)
                .ln()
                .abs()
                .total_cmp(&(b.1.hz / hz).ln().abs())
        })
        .map(|(j, m)| (j + 1, m))
}

/// Every arm's fit (`pick` of its results) of the records of `kind`.
fn of_kind<'a, T>(
    results: &'a [ArmResult],
    kind: Kind,
    pick: impl Fn(&'a ArmResult) -> &'a [(Kind, T)],
) -> Vec<(&'a ArmResult, &'a T)> {
    results
        .iter()
        .flat_map(|r| {
            pick(r)
                .iter()
                .filter(|(k, _)| *k == kind)
                .map(move |(_, f)| (r, f))
        })
        .collect()
}

/// Per kind of record, over the family: how many arms' records gave the clamped modes (or
/// the held arm's, or were refused), and the worst error of the controller's modes (the
/// kept ones, against the truth's of the same number) in frequency, damping and the
/// piezo→film product; per kind of tap record, the worst error of the link's modes the decay
/// shows (from [`HELD_BELOW`] of the truth's second mode up).
pub fn summary(results: &[ArmResult]) -> String {
    let worst = |x: &mut dyn Iterator<Item = f64>| {
        let w = x.fold(f64::NAN, |a, b| {
            if a.is_nan() || b.abs() > a.abs() {
                b
            } else {
                a
            }
        });
        if w.is_nan() {
            "—".to_string()
        } else {
            format!("{:+.2} %", 100.0 * w)
        }
    };
    let mut s = String::from(
        "| record | clamped modes | held arm's | refused | worst error f | worst error ζ | worst error g |\n|---|---|---|---|---|---|---|\n",
    );
    for kind in Kind::ALL {
        let fits = of_kind(results, kind, |r| &r.modes);
        if fits.is_empty() {
            continue;
        }
        let clamped: Vec<(&ArmResult, &ModesFit)> = fits
            .iter()
            .filter_map(|(r, f)| {
                f.as_ref()
                    .ok()
                    .filter(|f| f.held.is_none())
                    .map(|f| (*r, f))
            })
            .collect();
        let held = fits
            .iter()
            .filter(|(_, f)| f.as_ref().is_ok_and(|f| f.held.is_some()))
            .count();
        let refused = fits.iter().filter(|(_, f)| f.is_err()).count();
        let errors = |e: fn(&super::modal::IdentifiedMode, &TrueMode) -> f64| {
            let mut v = Vec::new();
            for (r, f) in &clamped {
                for (m, t) in f.modes.iter().zip(&r.truth) {
                    v.push(e(m, t));
                }
            }
            v
        };
        s += &format!(
            "| {} | {} | {held} | {refused} | {} | {} | {} |\n",
            kind.name(),
            clamped.len(),
            worst(&mut errors(|m, t| m.hz() / t.hz - 1.0).into_iter()),
            worst(&mut errors(|m, t| m.zeta / t.zeta - 1.0).into_iter()),
            worst(&mut errors(|m, t| m.piezo_film / t.gain - 1.0).into_iter()),
        );
    }
    s += "\n| tap record | decays fitted | refused | link modes found | worst error f | worst error ζ |\n|---|---|---|---|---|---|\n";
    for kind in Kind::ALL.into_iter().filter(|k| k.taps()) {
        let fits = of_kind(results, kind, |r| &r.decays);
        if fits.is_empty() {
            continue;
        }
        let mut e = Vec::new();
        for (r, f) in &fits {
            let Ok(f) = f else { continue };
            for m in &f.modes {
                let hz = m.omega / std::f64::consts::TAU;
                if r.truth.len() > 1
                    && hz >= HELD_BELOW * r.truth[1].hz
                    && let Some((_, t)) = nearest(&r.truth, hz)
                {
                    e.push((hz / t.hz - 1.0, m.zeta / t.zeta - 1.0));
                }
            }
        }
        let ok = fits.iter().filter(|(_, f)| f.is_ok()).count();
        s += &format!(
            "| {} | {ok} | {} | {} | {} | {} |\n",
            kind.name(),
            fits.len() - ok,
            e.len(),
            worst(&mut e.iter().map(|x| x.0)),
            worst(&mut e.iter().map(|x| x.1)),
        );
    }
    s
}

/// The family's tables (Markdown): every mode each kind of record found against the truth,
/// every mode each tap record's decay shows (the held arm's: from three quarters of the
/// truth's second mode up against the truth's modes, below it the held first mode and the
/// hold's, marked `held`), the inertias, the closed-loop check.
pub fn report(results: &[ArmResult]) -> String {
    let pct = |x: f64, t: f64| format!("{:+.2} %", (x / t - 1.0) * 100.0);
    let mut s = String::from(
        "| arm | record | inputs | mode | f [Hz] | error f | ±σ f | ζ | error ζ | ±σ ζ | g | error g | ±σ g |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in results {
        for (kind, fit) in &r.modes {
            match fit {
                Ok(f) => {
                    let names: Vec<&str> = f
                        .inputs
                        .iter()
                        .map(|i| match i {
                            modal::Input::Patch => "patch",
                            modal::Input::Base => "base",
                        })
                        .collect();
                    let inputs = format!(
                        "{}{}",
                        names.join(", "),
                        if f.held.is_some() { " (held arm)" } else { "" }
                    );
                    for m in &f.all {
                        let Some((j, t)) = nearest(&r.truth, m.hz()) else {
                            continue;
                        };
                        let rel = |s: f64, x: f64| format!("{:.2} %", s / x * 100.0);
                        s += &format!(
                            "| {} | {} | {inputs} | {j} | {:.4} | {} | {} | {:.4} | {} | {} | {} |\n",
                            r.arm.name,
                            kind.name(),
                            m.hz(),
                            pct(m.hz(), t.hz),
                            rel(m.sigma[0], m.omega),
                            m.zeta,
                            pct(m.zeta, t.zeta),
                            rel(m.sigma[1], m.zeta),
                            // Without the patch as an input there is no piezo→film product.
                            if m.piezo_film.is_finite() {
                                format!(
                                    "{:.4e} | {} | {}",
                                    m.piezo_film,
                                    pct(m.piezo_film, t.gain),
                                    rel(m.sigma[2], m.piezo_film)
                                )
                            } else {
                                "— | — | —".to_string()
                            },
                        );
                    }
                }
                Err(e) => {
                    s += &format!(
                        "| {} | {} | — | refused: {} | | | | | | | | | |\n",
                        r.arm.name,
                        kind.name(),
                        e.replace('|', "/")
                    );
                }
            }
        }
    }
    s += "\n| arm | record | tapped by | mode | f [Hz] | error f | ζ | error ζ | amplitude [V] |\n|---|---|---|---|---|---|---|---|---|\n";
    for r in results {
        for (kind, fit) in &r.decays {
            match fit {
                Ok(f) => {
                    let by = match f.held.tapper {
                        Tapper::Patch => "patch".to_string(),
                        Tapper::Motor(j) => format!("motor {}", j + 1),
                        Tapper::Hammer => "hammer".to_string(),
                    };
                    for m in &f.modes {
                        let hz = m.omega / std::f64::consts::TAU;
                        let Some((j, t)) = nearest(&r.truth, hz) else {
                            continue;
                        };
                        // The held arm's first mode and the hold's ring below the link's
                        // second: not the clamped link's (docs/identification.md).
                        let (mode, ef, ez) = if r.truth.len() > 1 && hz < HELD_BELOW * r.truth[1].hz
                        {
                            ("held".to_string(), "—".to_string(), "—".to_string())
                        } else {
                            (j.to_string(), pct(hz, t.hz), pct(m.zeta, t.zeta))
                        };
                        s += &format!(
                            "| {} | {} | {by} | {mode} | {hz:.4} | {ef} | {:.4} | {ez} | {:.2e} |\n",
                            r.arm.name,
                            kind.name(),
                            m.zeta,
                            m.amplitude
                        );
                    }
                }
                Err(e) => {
                    s += &format!(
                        "| {} | {} | — | refused: {} | | | | | |\n",
                        r.arm.name,
                        kind.name(),
                        e.replace('|', "/")
                    );
                }
            }
        }
    }
    s += "\n| arm | A error | ±σ | J error | ±σ | S error | ±σ | condition |\n|---|---|---|---|---|---|---|---|\n";
    for r in results {
        let (fit, t) = &r.inertia;
        match fit {
            Ok(f) => {
                let rel = |s: f64, x: f64| format!("{:.2} %", s / x * 100.0);
                s += &format!(
                    "| {} | {} | {} | {} | {} | {} | {} | {:.1} |\n",
                    r.arm.name,
                    pct(f.rigid.a, t.a),
                    rel(f.sigma.a, t.a),
                    pct(f.rigid.j, t.j),
                    rel(f.sigma.j, t.j),
                    pct(f.rigid.s, t.s),
                    rel(f.sigma.s, t.s),
                    f.condition
                );
            }
            Err(e) => {
                s += &format!(
                    "| {} | refused: {} | | | | | | |\n",
                    r.arm.name,
                    e.replace('|', "/")
                )
            }
        }
    }
    s += "\n| arm | model from | Eq. 37 ‖θ − θ_d‖ vs true | Eq. 37 ‖tip‖ vs true |\n|---|---|---|---|\n";
    for r in results {
        match &r.check {
            Ok((kind, runs)) => {
                let (t, m) = (runs[0].summary, runs[1].summary);
                s += &format!(
                    "| {} | {} | {} | {} |\n",
                    r.arm.name,
                    kind.name(),
                    pct(m.l2_error, t.l2_error),
                    pct(m.l2_tip, t.l2_tip)
                );
            }
            Err(e) => {
                s += &format!(
                    "| {} | not built: {} | | |\n",
                    r.arm.name,
                    e.replace('|', "/")
                )
            }
        }
    }
    s
}

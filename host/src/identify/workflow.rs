//! `cargo sim identify friction | modes | inertia | decay | all | model`: each step's
//! experiment (or a recording), fit, files and report; `all` then generates the model and
//! runs the closed-loop and decay checks, `model` generates it from a board's records.

use std::path::Path;

use flexarm_core::Vector2;
use flexarm_core::control::piezo::{PiezoGains, PiezoPatch};
use flexarm_core::params::ArmParams;

use super::decay::{self, DecayFit, DecayPlan, DecaySettings, Tapper};
use super::geometry::Geometry;
use super::inertia::{self, InertiaFit, InertiaPlan, Rigid};
use super::modal::{self, FitSettings, ModesFit};
use super::model::{self, closed_loop, identified_model};
use super::modes::{self, ModesPlan};
use super::record::ModesRecord;
use super::report;
use crate::output::trace_csv;
use crate::sim::{Sample, SimConfig};

/// Where the experiments run and what is known of the plant.
pub struct Bench<'a> {
    /// The simulator's configuration (plant, controller, sensors).
    pub cfg: &'a SimConfig,
    /// Whether `cfg`'s controller model is the plant's truth (the truth plant's truncation):
    /// the reports then give the errors.
    pub known: bool,
    /// The folder the files go to (an output folder's staging area).
    pub dir: &'a Path,
    /// Draw the figures.
    pub plots: bool,
    /// The arm's geometry (lengths, payload, patch, transducers, the board's ranges).
    pub geometry: &'a Geometry,
}

fn write(dir: &Path, name: &str, text: &str) -> Result<(), String> {
    std::fs::write(dir.join(name), text).map_err(|e| format!("cannot write {name}: {e}"))
}

/// An error about the recording `record`, when there is one, names its file.
fn naming(record: Option<&Path>) -> impl Fn(String) -> String + '_ {
    move |e| match record {
        Some(p) => format!("{}: {e}", p.display()),
        None => e,
    }
}

/// The film ADC's range and the amplifier's window [V]: a record's the geometry's, the
/// simulator's its own.
fn ranges(b: &Bench, record: Option<&Path>) -> (f64, (f64, f64)) {
    match record {
        Some(_) => (b.geometry.film_range, b.geometry.amplifier_window),
        None => (
            b.cfg.sensors.adc_range,
            (
                f64::from(b.cfg.limits.v_a_min),
                f64::from(b.cfg.limits.v_a_max),
            ),
        ),
    }
}

/// The record: read from `record`, or the experiment `run` on the simulator (saved as
/// `<name>_record.csv`).
fn record_or_run(
    b: &Bench,
    record: Option<&Path>,
    name: &str,
    run: impl FnOnce() -> Result<Vec<Sample>, super::IdentifyError>,
) -> Result<Vec<Sample>, String> {
    match record {
        Some(p) => super::record::read_record(p),
        None => {
            let trace = run().map_err(|e| e.to_string())?;
            save_record(b.dir, name, &trace)?;
            Ok(trace)
        }
    }
}

/// The modes step: `modes.md`, `modes_frf.csv`, `modes_stability.csv`, `modes.svg` (and the
/// record when simulated).
pub fn modes_step(
    b: &Bench,
    record: Option<&Path>,
    seconds: f64,
    set: &FitSettings,
) -> Result<(ModesFit, String), String> {
    let plan = ModesPlan {
        seconds,
        ..ModesPlan::default()
    };
    let trace = record_or_run(b, record, "modes", || modes::modes_experiment(b.cfg, &plan))?;
    let (range, window) = ranges(b, record);
    let truth = b.known.then_some((&b.cfg.arm, &b.cfg.patch));
    let source = match record {
        Some(p) => format!("The record {}", p.display()),
        None => format!(
            "The modes experiment on the simulator ({seconds} s at (0, π/2) rad: blocks of the patch's bias stepping at random and of joint 2 moving about the pose)"
        ),
    };
    save_modes(
        b.dir,
        (&source, &trace),
        (range, window),
        set,
        truth,
        b.plots,
    )
    .map_err(naming(record))
}

/// Fits the record `trace` (described by `source`; film ADC range `±v_f_range` [V],
/// amplifier window [V]) with `set` and writes `modes.md`, `modes_frf.csv`,
/// `modes_stability.csv` and, with `plots`, `modes.svg` into `dir`. Returns the fit and the
/// report.
pub fn save_modes(
    dir: &Path,
    (source, trace): (&str, &[Sample]),
    (v_f_range, v_a_window): (f64, (f64, f64)),
    set: &FitSettings,
    truth: Option<(&ArmParams<f64>, &PiezoPatch<f64>)>,
    plots: bool,
) -> Result<(ModesFit, String), String> {
    let rec = ModesRecord::from_trace(trace, v_f_range, v_a_window).map_err(|e| e.to_string())?;
    let fit = modal::fit_modes(&rec, set).map_err(|e| e.to_string())?;
    let text = format!(
        "# The link's modes\n\n{source}: a common-denominator fit of its spectra, the modes from a stabilization diagram (`docs/identification.md`).\n\n{}",
        report::modes_report(&fit, truth)
    );
    write(dir, "modes.md", &text)?;
    write(dir, "modes_frf.csv", &report::frf_csv(&fit))?;
    write(dir, "modes_stability.csv", &report::stability_csv(&fit))?;
    if plots {
        report::frf_figure(&dir.join("modes.svg"), &fit)
            .map_err(|e| format!("cannot draw the figure: {e}"))?;
    }
    Ok((fit, text))
}

/// The inertia step: `inertia.md` (and the record when simulated).
/// The inertia step, with the link's modes of `modes` (a modes fit of the same arm) taken out
/// of the torques when given: `inertia.md` (and the record when simulated).
pub fn inertia_step(
    b: &Bench,
    record: Option<&Path>,
    modes: Option<&ModesFit>,
) -> Result<(InertiaFit, String), String> {
    let trace = record_or_run(b, record, "inertia", || {
        inertia::inertia_experiment(b.cfg, &InertiaPlan::default())
    })?;
    let truth = b.known.then(|| Rigid::of(&b.cfg.arm));
    let geometry = match record {
        Some(_) => *b.geometry,
        None => Geometry {
            torque_limit: b.cfg.limits.tau_max.cast::<f64>().into(),
            ..*b.geometry
        },
    };
    save_inertia(b.dir, &trace, truth, &geometry, modes).map_err(naming(record))
}

/// Fits the inertia record `trace` of an arm of geometry `g` (its torques within the drives'
/// limits, `super::record::check_torques`; with the modes of a modes fit taken out of the
/// torques, when given) and writes `inertia.md` into `dir` (against `truth` when known).
/// Returns the fit and the report.
pub fn save_inertia(
    dir: &Path,
    trace: &[Sample],
    truth: Option<Rigid>,
    g: &Geometry,
    modes: Option<&ModesFit>,
) -> Result<(InertiaFit, String), String> {
    super::record::check_torques(trace, g.torque_limit).map_err(|e| e.to_string())?;
    let (fit, how) = match modes {
        Some(m) => (
            inertia::fit_inertia_flexible(trace, g.a1, g.s_floor(), &|s| model::coupling(g, m, s)),
            format!(
                "the link's {} mode(s) the modes fit found taken out of the torques through the geometry's shapes",
                m.all.len()
            ),
        ),
        None => (
            inertia::fit_inertia(trace),
            "the link taken as rigid (`identify model` takes its modes out)".to_string(),
        ),
    };
    let fit = fit.map_err(|e| e.to_string())?;
    let text = format!(
        "# The rigid inertias\n\nLeast squares on the regressor, {how} (`docs/identification.md`).\n\n{}",
        report::inertia_report(&fit, truth)
    );
    write(dir, "inertia.md", &text)?;
    Ok((fit, text))
}

/// The piezo gain of the closed-loop check and of the generated model: the spillover study's
/// design rule for the truth plant's link (`host-sim/scenarios/trapezoid_truth.toml`).
pub const CHECK_PIEZO: PiezoGains<f32> = PiezoGains {
    k_c: CHECK_K_C as f32,
    cutoff_hz: 30.0,
};
/// [`CHECK_PIEZO`]'s `k_c` [s], as the model file writes it.
pub const CHECK_K_C: f64 = 3.162;

/// The friction step: the experiment on the simulator at `speeds` [rad/s] with `cruise`
/// seconds averaged (its record saved as `friction_record.csv`), or the cruises found in
/// `record` ([`super::find_cruises`]); the fit and `friction.*`. Returns the report.
pub fn friction_step(
    b: &Bench,
    record: Option<&Path>,
    speeds: &[f64],
    cruise: f64,
) -> Result<String, String> {
    let (cruises, source) = match record {
        Some(p) => {
            let trace = super::record::read_record(p)?;
            let cruises = super::find_cruises(&trace).map_err(|e| naming(record)(e.to_string()))?;
            let n = cruises.len();
            (
                cruises,
                format!(
                    "the record {}: {n} cruises found in it (constant-speed stretches of one joint, the other still; `identify::find_cruises`)",
                    p.display()
                ),
            )
        }
        None => {
            let held = Vector2::from(super::HELD);
            let (cruises, trace) = super::friction_experiment(b.cfg, held, speeds, cruise)
                .map_err(|e| e.to_string())?;
            save_record(b.dir, "friction", &trace)?;
            let truth = b.cfg.truth.filter(|_| b.known);
            let plant = match truth {
                Some(t) => format!(
                    "the truth plant (link 2 with {} modes, geared drives with friction, a realistic board)",
                    t.modes
                ),
                None => "the controller's own model (no friction: the fit should find none)".into(),
            };
            let source = format!(
                "{plant}: each joint at {} rad/s, both ways, {cruise} s of cruise averaged after {} s of settling",
                speeds
                    .iter()
                    .map(|v| v.to_string())
                    .collect::<Vec<_>>()
                    .join(", "),
                super::SETTLE
            );
            (cruises, source)
        }
    };
    let fits = super::fit_joints(&cruises).map_err(|e| naming(record)(e.to_string()))?;
    let truth = b.cfg.truth.filter(|_| b.known);
    let known = truth.map(|t| [0, 1].map(|j| (t.motors[j].coulomb, t.motors[j].viscous)));
    let heading =
        format!("Identified on {source} (`cargo sim identify friction`, docs/identification.md).");
    super::save_friction(b.dir, &heading, &cruises, &fits, known, b.plots)
}

/// The controller's model from the fits on the bench's geometry (the rest of the rigid parts
/// from `nominal`), written to `model.toml`, with what the step assumed (`model.md`).
fn write_model(
    b: &Bench,
    nominal: &ArmParams<f64>,
    modes: &ModesFit,
    inertia: &InertiaFit,
) -> Result<(ArmParams<f64>, PiezoPatch<f64>, String), String> {
    let (arm, patch, notes) = identified_model(b.geometry, nominal, &inertia.rigid, modes)
        .map_err(|e| format!("the model from the modes and inertia fits: {e}"))?;
    let text = format!(
        "# The identified model\n\n{}\n",
        notes
            .iter()
            .map(|n| format!("- {n}."))
            .collect::<Vec<_>>()
            .join("\n")
    );
    write(b.dir, "model.md", &text)?;
    write(
        b.dir,
        "model.toml",
        &model::model_fragment(&arm, &patch, CHECK_K_C),
    )?;
    Ok((arm, patch, text))
}

/// Every step on the simulator, from the `nominal` arm and patch a user starts from; then
/// `model.toml`, the closed-loop check (`verify.md`) and the free decay against each model's
/// prediction (`decay.md`). Returns the report.
pub fn all(
    b: &Bench,
    nominal: (&ArmParams<f64>, &PiezoPatch<f64>),
    seconds: f64,
) -> Result<String, String> {
    let f_text = friction_step(b, None, &super::SPEEDS, super::CRUISE)?;
    let (modes, m_text) = modes_step(b, None, seconds, &FitSettings::default())?;
    let (inertia, i_text) = inertia_step(b, None, Some(&modes))?;
    let (arm, patch, _) = write_model(b, nominal.0, &modes, &inertia)?;
    let check = SimConfig {
        piezo: Some(CHECK_PIEZO),
        ..*b.cfg
    };
    let runs = closed_loop(
        &check,
        &[
            ("identified model", arm, patch),
            ("nominal model", *nominal.0, *nominal.1),
        ],
    )
    .map_err(|e| e.to_string())?;
    let v_text = format!(
        "# The closed-loop check\n\nThe paper's trapezoid on the simulated plant, the observer-based controller with the piezo loop (k_c = {} s, corner {} Hz), built from each model.\n\n{}",
        CHECK_PIEZO.k_c,
        CHECK_PIEZO.cutoff_hz,
        report::loop_report(&runs)
    );
    write(b.dir, "verify.md", &v_text)?;
    let (_, d_text) = decay_step(
        b,
        None,
        &[
            ("identified model", arm, patch),
            ("nominal model", *nominal.0, *nominal.1),
        ],
        None,
    )?;
    Ok(format!("{f_text}\n{m_text}\n{i_text}\n{v_text}\n{d_text}"))
}

/// The model from a board's records: the modes fit of `modes_record` (with `set`) and the
/// inertia fit of `inertia_record` (trace CSVs, `flexarm identify modes|inertia` or any
/// record of the kinds docs/identification.md lists), on the bench's geometry (the rest of
/// the rigid parts from `nominal`); writes their reports and `model.toml`. An error names the
/// fit it could not use. Returns the report.
pub fn model_from_records(
    b: &Bench,
    modes_record: &Path,
    inertia_record: &Path,
    nominal: &ArmParams<f64>,
    set: &FitSettings,
) -> Result<String, String> {
    let (modes, m_text) =
        modes_step(b, Some(modes_record), 0.0, set).map_err(|e| format!("the modes fit: {e}"))?;
    let (inertia, i_text) = inertia_step(b, Some(inertia_record), Some(&modes))
        .map_err(|e| format!("the inertia fit: {e}"))?;
    let (_, _, model) = write_model(b, nominal, &modes, &inertia)?;
    Ok(format!("{m_text}\n{i_text}\n{model}"))
}

/// A model the decay check predicts with: its name in the report, arm and patch.
pub type Model<'a> = (&'a str, ArmParams<f64>, PiezoPatch<f64>);

/// The decay step: the experiment on the simulator (or `record`), its fit and each model's
/// prediction (the true parameters first when known): `decay.md`, `decay.csv`, `decay.svg`
/// (and the record when simulated). A record is predicted on a board of its rate
/// ([`SimConfig::board`]). `band` [Hz]: [`DecaySettings::for_band`].
pub fn decay_step(
    b: &Bench,
    record: Option<&Path>,
    models: &[Model],
    band: Option<(f64, f64)>,
) -> Result<(DecayFit, String), String> {
    let plan = DecayPlan::default();
    let trace = record_or_run(b, record, "decay", || decay::decay_experiment(b.cfg, &plan))?;
    let board = match record {
        Some(_) => {
            let dt = super::even_period(&trace).map_err(|e| naming(record)(e.to_string()))?;
            // A board's piezo loop runs ten times its motor loop.
            SimConfig::board(1.0 / dt, 10.0 / dt)
        }
        None => *b.cfg,
    };
    let truth = b
        .known
        .then_some(("true parameters", b.cfg.arm, b.cfg.patch));
    let all: Vec<Model> = truth.into_iter().chain(models.iter().copied()).collect();
    save_decay(
        b.dir,
        &trace,
        ranges(b, record),
        (&plan, band),
        &board,
        &all,
        b.plots,
    )
    .map_err(naming(record))
}

/// Fits the decay record `trace` (its film ADC's range [V] and amplifier window [V]; tapped by
/// the patch, a motor or a hammer), predicts each of `models` on `board` (the same experiment
/// on the controller built from the model, the model its plant: the record's patch command
/// replayed, or `plan`'s taps at the record's pose when a motor or a hammer tapped it) and
/// writes `decay.md`, `decay.csv`
/// and, with `plots`, `decay.svg` into `dir`; fitted in `band` ([`DecaySettings::for_band`]),
/// `plan` the taps the models are tapped with when the record's are not the patch's.
/// Returns the fit and the report.
pub fn save_decay(
    dir: &Path,
    trace: &[Sample],
    (v_f_range, v_a_window): (f64, (f64, f64)),
    (plan, band): (&DecayPlan, Option<(f64, f64)>),
    board: &SimConfig,
    models: &[Model],
    plots: bool,
) -> Result<(DecayFit, String), String> {
    let rec = ModesRecord::from_trace(trace, v_f_range, v_a_window).map_err(|e| e.to_string())?;
    let set = DecaySettings::for_band(band, rec.dt)?;
    let measured = decay::fit_decay(&rec, &set).map_err(|e| e.to_string())?;
    // The patch's taps are replayed on each model; a motor's pulses or a hammer's strikes
    // cannot be (the model's controller holds the joints, and the truth plant alone takes a
    // strike): the models are tapped by the plan's patch taps at the record's pose instead.
    let (replayed, how) = match measured.held.tapper {
        Tapper::Patch => (
            decay::replay(trace).map_err(|e| e.to_string())?,
            "each model's row is the same experiment on the controller built from it (the record's patch command replayed), the model its plant".to_string(),
        ),
        _ => {
            let pose = trace.first().map_or(plan.pose, |x| x.q_d);
            let taps = DecayPlan { pose, ..*plan };
            (
                (taps.excitation().map_err(|e| e.to_string())?, taps.seconds()),
                format!(
                    "the record's taps are not the patch's, so each model's row taps the controller built from it with the patch instead ({} taps of ±{} V for {} s, {} s apart), the model its plant: the poles are the model's whatever taps them, the amplitudes are not",
                    taps.taps, taps.volts, taps.width, taps.spacing
                ),
            )
        }
    };
    let mut predictions = Vec::new();
    for (name, arm, patch) in models {
        let p = decay::predict(board, arm, patch, (&replayed.0, replayed.1), &set)
            .map_err(|e| format!("predicting with the {name}: {e}"))?;
        predictions.push((*name, p));
    }
    let text = format!(
        "# The held arm's free decay

The record held {}; {} decays averaged, fitted by the matrix pencil in {}–{:.0} Hz (`docs/identification.md`); every mode found is listed. These are the held arm's modes, the link's coupled with the hold: {how}, and its error against the measured decay.

{}",
        measured.held,
        measured.taps,
        set.band.0,
        set.band.1,
        report::decay_report(&measured, &predictions)
    );
    write(dir, "decay.md", &text)?;
    write(dir, "decay.csv", &report::decay_csv(&measured))?;
    if plots {
        report::decay_figure(&dir.join("decay.svg"), &measured)
            .map_err(|e| format!("cannot draw the figure: {e}"))?;
    }
    Ok((measured, text))
}

/// Writes a record `trace` as `<name>_record.csv` (the trace CSV `--record` reads back).
pub fn save_record(dir: &Path, name: &str, trace: &[Sample]) -> Result<(), String> {
    write(dir, &format!("{name}_record.csv"), &trace_csv(trace))
}

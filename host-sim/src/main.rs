//! `flexarm-sim`: the paper's study, your own scenarios, the piezo placement and the Monte
//! Carlo robustness study, from one command. Errors are one readable line and a non-zero exit.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};
use flexarm_host::outdir::{OutDir, write_atomic};
use flexarm_host::sim::{Rates, Sensors, SimConfig, StateSource};
use flexarm_host::study::{self, Case, Options, Outcome};
use flexarm_host::truth_plant::TruthSpec;
use flexarm_host::{firmware_params, montecarlo, output, plant, scenario, spillover_study};

#[derive(Parser)]
#[command(
    name = "flexarm-sim",
    version,
    about = "Simulate the flexible two-link arm under the flexarm controllers"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// The paper's study: trapezoid and circle under Eq. 7, Eq. 7 + piezo, Eq. 16, Eq. 16 + piezo.
    Paper(Common),
    /// One scenario file (TOML; see host-sim/scenarios/).
    Run {
        /// The scenario file.
        scenario: PathBuf,
        #[command(flatten)]
        common: Common,
    },
    /// The piezo placement optimization (Eqs. 21–35).
    Optimize {
        /// Configuration (TOML; see beam/examples/optimize.toml); defaults to the paper's.
        config: Option<PathBuf>,
        /// Output folder.
        #[arg(long, default_value = "out/optimize")]
        out: PathBuf,
        /// Skip the figures.
        #[arg(long)]
        no_plots: bool,
        /// Replace files of the same names that no flexarm command wrote.
        #[arg(long)]
        force: bool,
    },
    /// The firmware's generated parameters (patch, k_c, observer gains) from a [piezo] fragment.
    FirmwareParams {
        /// The fragment (TOML, as written by `optimize`); defaults to firmware/piezo.toml.
        fragment: Option<PathBuf>,
        /// The generated Rust file.
        #[arg(long, default_value = firmware_params::DEFAULT_OUT)]
        out: PathBuf,
        /// First (over)write the fragment with the paper's patch (x_a = 0.09 m, l_a = 0.35 m, k_c = 30 s).
        #[arg(long)]
        paper_fragment: bool,
        /// Replace an output or fragment that flexarm did not generate.
        #[arg(long)]
        force: bool,
    },
    /// Spillover: the piezo loop's margin and damping on the truth plant against the number of
    /// modes, the gain, the filter corner and the loop rate; the design rule; closed-loop runs.
    Spillover {
        /// Modes of the truth plant's link 2 (the largest N studied), 2 to 10.
        #[arg(long, default_value_t = 10)]
        modes: usize,
        /// Length of the closed-loop runs [s].
        #[arg(long, default_value_t = 5.0)]
        duration: f64,
        /// Bond factors of the film's feedthrough the laws are compared at, 0 to 1.
        #[arg(long, value_delimiter = ',', default_values_t = flexarm_host::spillover_study::BONDS)]
        bond: Vec<f64>,
        /// Output folder.
        #[arg(long, default_value = "out/spillover")]
        out: PathBuf,
        /// Skip the figure.
        #[arg(long)]
        no_plots: bool,
        /// Replace files of the same names that no flexarm command wrote.
        #[arg(long)]
        force: bool,
    },
    /// Identification of an arm from measured data (docs/identification.md). `friction`: each
    /// joint's Coulomb and viscous friction from constant-speed moves, on the simulator's plant.
    Identify {
        /// The experiment: `friction`, `modes` (the link's, joints held), `inertia` (the rigid
        /// combinations), `decay` (the held arm's free decay, against each model's
        /// prediction), or `all` of them and then the identified model and its closed-loop
        /// and decay checks; or `model`: the model from a board's two records
        /// (`--modes-record`, `--inertia-record`); or `family`: the test family's arms, each
        /// identified from its lab's records, against their truth (docs/identification.md).
        #[arg(value_parser = ["friction", "modes", "inertia", "decay", "all", "model", "family"])]
        experiment: String,
        /// `decay`: a model file (`model.toml`) whose prediction of the decay is checked too.
        #[arg(long)]
        model: Option<PathBuf>,
        /// The arm's geometry (TOML: lengths, payload, patch place and constants, the board's
        /// ranges; docs/identification.md); default the paper's arm on the project's board.
        #[arg(long)]
        arm: Option<PathBuf>,
        /// `model`: the modes experiment's record (`flexarm identify modes`).
        #[arg(long)]
        modes_record: Option<PathBuf>,
        /// `model`: the inertia experiment's record (`flexarm identify inertia`).
        #[arg(long)]
        inertia_record: Option<PathBuf>,
        /// Fit this recording instead of running the experiment (`friction`, `modes`, `inertia`, `decay`): a trace
        /// CSV (a run's, or a board's `flexarm record`), evenly sampled.
        #[arg(long)]
        record: Option<PathBuf>,
        /// Length of the modes experiment's record [s].
        #[arg(long, default_value_t = 60.0)]
        seconds: f64,
        /// `modes`, `model`: the band fitted, `LOW,HIGH` [Hz] (default: what the record's inputs
        /// cover); `decay`: the band the decay's modes are read in (default 1.5,40).
        #[arg(long, value_delimiter = ',')]
        band: Option<Vec<f64>>,
        /// `modes`, `model`: the controller's modes, numbered from 1 upwards among those found (default 1,2).
        #[arg(long, value_delimiter = ',')]
        keep: Option<Vec<usize>>,
        /// `modes`, `model`: most modes the stabilization diagram makes room for.
        #[arg(long, default_value_t = 8)]
        max_modes: usize,
        /// `modes`, `model`: Welch's segment for a stationary record [s] (default: from the record).
        #[arg(long)]
        segment: Option<f64>,
        /// Cruise speeds [rad/s], both directions each.
        #[arg(long, value_delimiter = ',', default_values_t = flexarm_host::identify::SPEEDS)]
        speeds: Vec<f64>,
        /// Seconds of each cruise averaged.
        #[arg(long, default_value_t = flexarm_host::identify::CRUISE)]
        cruise: f64,
        /// Output folder.
        #[arg(long, default_value = "out/identify")]
        out: PathBuf,
        /// Skip the figure.
        #[arg(long)]
        no_plots: bool,
        /// Replace files of the same names that no flexarm command wrote.
        #[arg(long)]
        force: bool,
        #[command(flatten)]
        plant: PlantArgs,
    },
    /// Monte Carlo: the plant's masses, inertias, frequencies and damping perturbed by ±10 % and ±20 %.
    Montecarlo {
        /// Runs per perturbation level.
        #[arg(long, default_value_t = 1000)]
        runs: usize,
        /// Seed of the perturbations.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output folder.
        #[arg(long, default_value = "out/montecarlo")]
        out: PathBuf,
        /// Skip the figure.
        #[arg(long)]
        no_plots: bool,
        /// Replace files of the same names that no flexarm command wrote.
        #[arg(long)]
        force: bool,
        #[command(flatten)]
        plant: PlantArgs,
    },
}

#[derive(Args)]
struct Common {
    /// Output folder.
    #[arg(long, default_value = "out")]
    out: PathBuf,
    /// Skip the figures (CSV and tables are still written).
    #[arg(long)]
    no_plots: bool,
    /// Replace files of the same names that no flexarm command wrote.
    #[arg(long)]
    force: bool,
    /// Plant integration step [s].
    #[arg(long)]
    plant_dt: Option<f64>,
    /// Motor loop rate [Hz].
    #[arg(long)]
    motor_hz: Option<f64>,
    /// Piezo loop rate [Hz].
    #[arg(long)]
    piezo_hz: Option<f64>,
    /// Run length [s].
    #[arg(long)]
    duration: Option<f64>,
    #[command(flatten)]
    plant: PlantArgs,
}

/// Which plant the study runs on.
#[derive(Args)]
struct PlantArgs {
    /// `model`: the controller's own two-mode model; `truth`: the truth plant (link 2 with
    /// --modes modes, real drives and amplifiers), next to the controller's model of that arm.
    #[arg(long, value_enum, default_value_t = PlantKind::Model)]
    plant: PlantKind,
    /// Modes of the truth plant's link 2, 1 to 10 [default: 6].
    #[arg(long)]
    modes: Option<usize>,
    /// Bond factor of the truth plant's film feedthrough, 0 to 1 [default: 0]
    /// (`plant.film_bond`).
    #[arg(long)]
    film_bond: Option<f64>,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum PlantKind {
    Model,
    Truth,
}

impl PlantArgs {
    /// The truth plant asked for, checked.
    fn truth(&self) -> Result<Option<TruthSpec>> {
        if self.plant == PlantKind::Model {
            return match (self.modes, self.film_bond) {
                (Some(_), _) => Err("--modes needs --plant truth".into()),
                (_, Some(_)) => Err("--film-bond needs --plant truth".into()),
                (None, None) => Ok(None),
            };
        }
        let d = TruthSpec::default();
        let t = TruthSpec {
            modes: self.modes.unwrap_or(d.modes),
            film_bond: self.film_bond.unwrap_or(d.film_bond),
            ..d
        };
        t.validate().map_err(|(key, msg)| {
            let option = if key == "plant.film_bond" {
                "--film-bond"
            } else {
                "--modes"
            };
            format!("{option}: {msg}")
        })?;
        Ok(Some(t))
    }
}

impl Common {
    /// Whether any option overrides the file or the defaults.
    fn overrides(&self) -> bool {
        self.plant_dt.is_some()
            || self.motor_hz.is_some()
            || self.piezo_hz.is_some()
            || self.duration.is_some()
    }

    fn apply(&self, rates: &mut Rates, duration: &mut f64) {
        rates.plant_dt = self.plant_dt.unwrap_or(rates.plant_dt);
        rates.motor_hz = self.motor_hz.unwrap_or(rates.motor_hz);
        rates.piezo_hz = self.piezo_hz.unwrap_or(rates.piezo_hz);
        *duration = self.duration.unwrap_or(*duration);
    }
}

type Result<T> = std::result::Result<T, String>;

/// Writes the runs' CSV, figures and the indices table (`report`) through the output folder's
/// staging; returns the table.
fn write_outputs(
    out: &OutDir,
    outcomes: &[Outcome],
    plots: bool,
    preamble: &str,
    report: &str,
) -> Result<String> {
    let dir = out.staging();
    for o in outcomes {
        output::write_csv(dir, o)
            .map_err(|e| format!("cannot write CSV in {}: {e}", out.dir().display()))?;
        if plots {
            output::write_figure(dir, o).map_err(|e| {
                format!(
                    "cannot draw the figure of {}/{}: {e}",
                    o.case.scenario, o.case.controller
                )
            })?;
        }
    }
    let table = output::indices_table(outcomes);
    let md = format!("# flexarm-sim: indices (Eqs. 37, 38)\n\n{preamble}{table}");
    let path = dir.join(report);
    std::fs::write(&path, &md).map_err(|e| format!("cannot write {report}: {e}"))?;
    Ok(table)
}

/// Runs the cases and writes them into `--out` as the command `command`, with the indices in
/// `report`.
fn run_cases(
    cases: Vec<Case>,
    common: &Common,
    preamble: &str,
    command: &str,
    report: &str,
) -> Result<()> {
    let outcomes = study::run(cases, true, true).map_err(|(case, e)| format!("{case}: {e}"))?;
    let out = OutDir::open(&common.out, command, common.force)?;
    let table = write_outputs(&out, &outcomes, !common.no_plots, preamble, report)?;
    let files = out.commit()?;
    println!("{preamble}{table}");
    println!("Wrote {}: {}.", common.out.display(), files.join(", "));
    Ok(())
}

fn main_result(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Paper(common) => {
            let mut opts = Options {
                truth: common.plant.truth()?,
                ..Options::default()
            };
            common.apply(&mut opts.rates, &mut opts.duration);
            let cases = study::paper_cases(&opts).map_err(|e| e.to_string())?;
            for c in &cases {
                c.config
                    .validate(&c.trajectory)
                    .and_then(|()| plant::check_step(&c.config, start(&c.trajectory)))
                    .map_err(|e| {
                        if common.overrides() {
                            format!("with the command-line options: {e}")
                        } else {
                            e.to_string()
                        }
                    })?;
            }
            let note = study::printed_circle_error()
                .map(|e| format!("{e}; the study runs the nearest reachable circle of the same radius, centre (0.65, 0) m (docs/model.md).\n\n"))
                .unwrap_or_default();
            run_cases(cases, &common, &note, "paper", "indices.md")
        }
        Command::Run { scenario, common } => {
            let sc = scenario::load(&scenario).map_err(|e| e.to_string())?;
            let mut config = sc.config;
            if let Some(t) = common.plant.truth()? {
                if config.truth.is_some() {
                    return Err(format!(
                        "{}: the file's [plant] table chooses the plant: drop --plant",
                        scenario.display()
                    ));
                }
                config = config
                    .with_truth(t)
                    .map_err(|e| format!("{}: --plant truth: {e}", scenario.display()))?;
            }
            common.apply(&mut config.rates, &mut config.duration);
            // The overrides go through the same check as the file.
            config
                .validate(&sc.trajectory)
                .and_then(|()| plant::check_step(&config, start(&sc.trajectory)))
                .map_err(|e| {
                    format!("{}: with the command-line options: {e}", scenario.display())
                })?;
            let report = format!("{}_indices.md", sc.name);
            let command = format!("run:{}", sc.name);
            let name: &'static str = Box::leak(sc.name.into_boxed_str());
            run_cases(
                vec![Case {
                    scenario: name,
                    controller: "scenario",
                    config,
                    trajectory: sc.trajectory,
                }],
                &common,
                "",
                &command,
                &report,
            )
        }
        Command::Optimize {
            config,
            out,
            no_plots,
            force,
        } => {
            let dir = OutDir::open(&out, "optimize", force)?;
            let summary =
                flexarm_placement::cli::run_optimize(config.as_deref(), dir.staging(), !no_plots)
                    .map_err(|e| e.to_string())?;
            let files = dir.commit()?;
            println!("{summary}\nWrote {}: {}.", out.display(), files.join(", "));
            Ok(())
        }
        Command::FirmwareParams {
            fragment,
            out,
            paper_fragment,
            force,
        } => {
            let path = fragment.unwrap_or_else(|| PathBuf::from(firmware_params::DEFAULT_FRAGMENT));
            if same_file(&path, &out) {
                return Err(format!(
                    "--out {} is the fragment itself: choose another output",
                    out.display()
                ));
            }
            if paper_fragment {
                refuse_foreign(&path, force, firmware_params::is_generated_fragment)?;
                let text = firmware_params::paper_fragment().map_err(|e| e.to_string())?;
                write_atomic(&path, text.as_bytes())?;
            }
            let text = std::fs::read_to_string(&path).map_err(|e| {
                format!(
                    "cannot read {}: {e} (run from the repository root or name the fragment)",
                    path.display()
                )
            })?;
            let (fragment_name, out_name) = (path.display().to_string(), out.display().to_string());
            let names = firmware_params::Names {
                fragment: &fragment_name,
                out: &out_name,
            };
            let p = firmware_params::design(&text)
                .map_err(|e| flexarm_beam::toml_at::at_line(&path, &text, &e.0))?;
            let source = firmware_params::source(&p, &names);
            refuse_foreign(&out, force, firmware_params::is_generated_source)?;
            write_atomic(&out, source.as_bytes())?;
            println!(
                "Wrote {out_name} from {fragment_name}: {} arm (modes {:.4} and {:.4} Hz), x_a = {} m, l_a = {} m, k_c = {} s; observer gains for 1 kHz and 100 Hz.",
                if p.arm == flexarm_core::params::ArmParams::default() {
                    "the paper's"
                } else {
                    "the file's"
                },
                p.arm.modes.omega.x / std::f64::consts::TAU,
                p.arm.modes.omega.y / std::f64::consts::TAU,
                p.patch.x_a,
                p.patch.l_a,
                p.k_c
            );
            Ok(())
        }
        Command::Spillover {
            modes,
            duration,
            bond,
            out,
            no_plots,
            force,
        } => {
            spillover_study::check_modes(modes)?;
            if !(duration.is_finite() && (0.05..=60.0).contains(&duration)) {
                return Err(format!("--duration {duration} s must lie in 0.05 to 60 s"));
            }
            let spec = TruthSpec {
                modes,
                ..TruthSpec::default()
            };
            if let Some(b) = bond.iter().find(|b| !(0.0..=1.0).contains(*b)) {
                return Err(format!("--bond {b} must lie in 0 to 1"));
            }
            let report = spillover_study::run(&spec, &bond, duration).map_err(|e| e.to_string())?;
            let md = spillover_study::markdown(&report);
            let dir = OutDir::open(&out, "spillover", force)?;
            for (name, text) in [
                (
                    "spillover.md",
                    format!("# Spillover on the truth plant\n\n{md}"),
                ),
                ("spillover.csv", spillover_study::csv(&report)),
            ] {
                std::fs::write(dir.staging().join(name), text)
                    .map_err(|e| format!("cannot write {name}: {e}"))?;
            }
            if !no_plots {
                spillover_study::figure(&dir.staging().join("spillover.svg"), &report)
                    .map_err(|e| format!("cannot draw the figure: {e}"))?;
            }
            let files = dir.commit()?;
            println!("{md}\nWrote {}: {}.", out.display(), files.join(", "));
            Ok(())
        }
        Command::Identify {
            experiment,
            model,
            arm,
            modes_record,
            inertia_record,
            record,
            seconds,
            band,
            keep,
            max_modes,
            segment,
            speeds,
            cruise,
            out,
            no_plots,
            force,
            plant,
        } => {
            let truth = plant.truth()?;
            let mut cfg = SimConfig {
                state: StateSource::Observer,
                sensors: Sensors::realistic(),
                ..SimConfig::default()
            };
            if let Some(t) = truth {
                cfg = cfg.with_truth(t).map_err(|e| e.to_string())?;
            }
            if experiment != "model" && (modes_record.is_some() || inertia_record.is_some()) {
                return Err(format!(
                    "--modes-record and --inertia-record are for `identify model`, not `{experiment}` (it takes --record)"
                ));
            }
            if experiment != "decay" && model.is_some() {
                return Err(format!(
                    "--model is for `identify decay`, not `{experiment}`"
                ));
            }
            // The model file first: a bad one is named before anything runs.
            let model = match &model {
                Some(p) => {
                    let text = std::fs::read_to_string(p)
                        .map_err(|e| format!("cannot read {}: {e}", p.display()))?;
                    let (arm, choice) = flexarm_host::scenario::read_model(&text)
                        .map_err(|e| flexarm_beam::toml_at::at_line(p, &text, &e.0))?;
                    Some((arm, choice.patch))
                }
                None => None,
            };
            let geometry = match &arm {
                Some(p) => {
                    let text = std::fs::read_to_string(p)
                        .map_err(|e| format!("cannot read {}: {e}", p.display()))?;
                    flexarm_host::identify::geometry::Geometry::parse(&text)
                        .map_err(|e| flexarm_beam::toml_at::at_line(p, &text, &e))?
                }
                None => flexarm_host::identify::geometry::Geometry::default(),
            };
            use flexarm_host::identify::workflow;
            // Each experiment's files are its own: the steps share a folder.
            let dir = OutDir::open(&out, &format!("identify:{experiment}"), force)?;
            let b = workflow::Bench {
                cfg: &cfg,
                known: truth.is_some(),
                dir: dir.staging(),
                plots: !no_plots,
                geometry: &geometry,
            };
            let nominal = (
                &flexarm_core::params::ArmParams::default(),
                &flexarm_core::control::piezo::PiezoPatch::paper(),
            );
            if !(1..=12).contains(&max_modes) {
                return Err(format!("--max-modes {max_modes}: give 1 to 12"));
            }
            if let Some(s) = segment
                && !(s.is_finite() && s > 0.0)
            {
                return Err(format!("--segment {s}: give a length in seconds > 0"));
            }
            // One occurrence, `LOW,HIGH` (`num_args = 2` would want them as two words).
            let band = match band.as_deref() {
                None => None,
                Some(&[low, high]) => Some((low, high)),
                Some(b) => {
                    return Err(format!(
                        "--band: give LOW,HIGH in Hz, not {} value(s)",
                        b.len()
                    ));
                }
            };
            if let Some(k) = keep.as_deref()
                && k.len() != 2
            {
                return Err(format!(
                    "--keep: give two mode numbers, M,N, not {} value(s)",
                    k.len()
                ));
            }
            let fit_set = flexarm_host::identify::modal::FitSettings {
                band,
                keep: keep.unwrap_or_else(|| vec![1, 2]),
                max_modes,
                segment,
            };
            let report = match (experiment.as_str(), &record) {
                ("family", None) => {
                    use flexarm_host::identify::family::{self, Kind};
                    use rayon::prelude::*;
                    let kinds = Kind::ALL;
                    let results: Vec<_> = family::family()
                        .par_iter()
                        .map(|arm| family::identify_arm(arm, &kinds, dir.staging(), false))
                        .collect::<Result<_>>()?;
                    let text = format!(
                        "# The family\n\nEach arm of `flexarm_host::identify::family` recorded by `flexarm_host::lab` (a PD hold, the kinds below, sized to {} of the film's range), written and read back as a trace, fitted by `cargo sim identify`'s code (`cargo sim identify family`).\n\n## Per kind of record\n\n{}\n## Per arm\n\n{}",
                        family::FILM_SHARE,
                        family::summary(&results),
                        family::report(&results)
                    );
                    std::fs::write(dir.staging().join("family.md"), &text)
                        .map_err(|e| format!("cannot write family.md: {e}"))?;
                    text
                }
                ("family", Some(_)) => {
                    return Err("--record: `family` makes its own records".into());
                }
                ("model", _) => {
                    let (Some(m), Some(i)) = (&modes_record, &inertia_record) else {
                        return Err("model: give both --modes-record and --inertia-record".into());
                    };
                    workflow::model_from_records(&b, m, i, nominal.0, &fit_set)?
                }
                ("modes", r) => workflow::modes_step(&b, r.as_deref(), seconds, &fit_set)?.1,
                ("inertia", r) => workflow::inertia_step(&b, r.as_deref(), None)?.1,
                ("decay", r) => {
                    let models: Vec<workflow::Model> = model
                        .map(|(arm, patch)| ("model file", arm, patch))
                        .into_iter()
                        .chain([("nominal model", *nominal.0, *nominal.1)])
                        .collect();
                    workflow::decay_step(&b, r.as_deref(), &models, band)?.1
                }
                ("friction", r) => workflow::friction_step(&b, r.as_deref(), &speeds, cruise)?,
                (_, Some(_)) => {
                    return Err("--record: `all` runs every experiment itself; fit a recording with `friction`, `modes`, `inertia` or `decay`".into());
                }
                _ => workflow::all(&b, nominal, seconds)?,
            };
            let files = dir.commit()?;
            println!("{report}\nWrote {}: {}.", out.display(), files.join(", "));
            Ok(())
        }
        Command::Montecarlo {
            runs,
            seed,
            out,
            no_plots,
            force,
            plant,
        } => {
            let truth = plant.truth()?;
            // About 5 ms of computing per run: 100 000 runs per level take some 15 minutes.
            if !(1..=montecarlo::MAX_RUNS).contains(&runs) {
                return Err(format!(
                    "--runs {runs} must lie in 1 to {} (each run is a 5 s simulation)",
                    montecarlo::MAX_RUNS
                ));
            }
            let batches =
                montecarlo::run(&[0.1, 0.2], runs, seed, truth, true).map_err(|e| e.to_string())?;
            let report = montecarlo::report(&batches);
            let report = match truth {
                Some(t) => format!(
                    "On the truth plant: link 2 with {} modes, real drives and amplifiers (docs/results.md); every mode's frequency and damping perturbed too.\n\n{report}",
                    t.modes
                ),
                None => report,
            };
            let dir = OutDir::open(&out, "montecarlo", force)?;
            let path = dir.staging().join("montecarlo.md");
            std::fs::write(&path, format!("# Monte Carlo robustness\n\n{report}"))
                .map_err(|e| format!("cannot write montecarlo.md: {e}"))?;
            if !no_plots {
                montecarlo::figure(&dir.staging().join("montecarlo.svg"), &batches)
                    .map_err(|e| format!("cannot draw the figure: {e}"))?;
            }
            let files = dir.commit()?;
            println!("{report}\nWrote {}: {}.", out.display(), files.join(", "));
            Ok(())
        }
    }
}

/// Where a trajectory starts [rad].
fn start(t: &flexarm_core::trajectory::JointTrajectory<f32>) -> flexarm_core::Vector2<f64> {
    t.sample(0.0).q.cast()
}

/// Whether `a` and `b` name the same file (both existing, or the same path as written).
fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => a == b,
    }
}

/// Refuses to replace an existing `path` whose content `ours` does not recognize, unless `force`.
fn refuse_foreign(path: &Path, force: bool, ours: fn(&str) -> bool) -> Result<()> {
    if force || !path.exists() {
        return Ok(());
    }
    let text = std::fs::read_to_string(path).unwrap_or_default();
    if ours(&text) {
        Ok(())
    } else {
        Err(format!(
            "{} exists and was not generated by flexarm: not replaced (choose another path, or --force)",
            path.display()
        ))
    }
}

fn main() -> ExitCode {
    flexarm_host::cli::one_line_panics("flexarm-sim");
    // Help and version print as usual; a command-line error is one line and exit status 1,
    // like every other bad input.
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            let text = e.render().to_string();
            let first = text
                .lines()
                .next()
                .unwrap_or("invalid command line")
                .trim_start_matches("error: ");
            eprintln!("error: {first} (flexarm-sim --help lists the commands and options)");
            return ExitCode::FAILURE;
        }
    };
    match main_result(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

//! The paper's study: each scenario under each controller, run in parallel.

use flexarm_core::Vector4;
use flexarm_core::control::motor::MotorLaw;
use flexarm_core::control::piezo::PiezoGains;
use flexarm_core::trajectory::{Circle, JointTrajectory, Trapezoid};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;

use crate::sim::{Rates, Sample, Sensors, SimConfig, SimError, StateSource, Summary, simulate};
use crate::truth_plant::TruthSpec;

/// One run of the study.
#[derive(Clone, Debug)]
pub struct Case {
    /// Scenario name (file-name safe).
    pub scenario: &'static str,
    /// Controller label (file-name safe).
    pub controller: &'static str,
    /// Configuration.
    pub config: SimConfig,
    /// Desired motion.
    pub trajectory: JointTrajectory<f32>,
}

/// A finished run.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// The case.
    pub case: Case,
    /// Indices.
    pub summary: Summary,
    /// One sample per motor period.
    pub trace: Vec<Sample>,
}

/// Options common to every case.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    /// Rates.
    pub rates: Rates,
    /// Run length [s].
    pub duration: f64,
    /// Also run every case on this truth plant, next to the controller's own model of the same
    /// arm (its truncation).
    pub truth: Option<TruthSpec>,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            rates: Rates::default(),
            duration: 5.0,
            truth: None,
        }
    }
}

/// The printed circle of Eq. 36 and why it cannot run.
pub fn printed_circle_error() -> Option<String> {
    Circle::<f32>::as_printed(0.3, 0.7)
        .err()
        .map(|e| format!("Eq. 36 as printed (centre (0.4, 0) m, radius 0.2 m): {e}"))
}

/// The cases: trapezoid and (reachable) circle, each under Eq. 7, Eq. 7 + piezo, Eq. 16 and
/// Eq. 16 + piezo with the full state (the paper's setting); plus the paper's printed gains and
/// the firmware's observer with realistic sensors, for comparison. With `opts.truth` each case
/// runs twice instead: on the truth plant (scenario `…_truth`) and on the controller's own
/// model of that arm (`…_model`), so the difference is the truncation and the hardware.
pub fn paper_cases(opts: &Options) -> Result<Vec<Case>, SimError> {
    let cases = paper_arm_cases(opts)?;
    let Some(spec) = opts.truth else {
        return Ok(cases);
    };
    let mut out = Vec::with_capacity(2 * cases.len());
    for c in cases {
        let truth = c.config.with_truth(spec)?;
        let (model_name, truth_name) = match c.scenario {
            "trapezoid" => ("trapezoid_model", "trapezoid_truth"),
            _ => ("circle_model", "circle_truth"),
        };
        out.push(Case {
            scenario: model_name,
            config: SimConfig {
                truth: None,
                plant: None,
                ..truth
            },
            ..c
        });
        out.push(Case {
            scenario: truth_name,
            config: truth,
            ..c
        });
    }
    Ok(out)
}

fn paper_arm_cases(opts: &Options) -> Result<Vec<Case>, SimError> {
    let base = SimConfig {
        rates: opts.rates,
        duration: opts.duration,
        ..SimConfig::default()
    };
    let circle = Circle::paper(0.3, 0.7).map_err(SimError::Trajectory)?;
    let scenarios: [(&'static str, JointTrajectory<f32>); 2] = [
        ("trapezoid", JointTrajectory::Trapezoid(Trapezoid::paper())),
        ("circle", JointTrajectory::Circle(circle)),
    ];
    let piezo = Some(PiezoGains::default());
    let mut cases = Vec::new();
    for (scenario, trajectory) in scenarios {
        for (controller, law, piezo) in [
            ("eq7", MotorLaw::Tracking, None),
            ("eq7_piezo", MotorLaw::Tracking, piezo),
            ("eq16", MotorLaw::Robust, None),
            ("eq16_piezo", MotorLaw::Robust, piezo),
        ] {
            cases.push(Case {
                scenario,
                controller,
                config: SimConfig { law, piezo, ..base },
                trajectory,
            });
        }
        let mut printed = base;
        printed.gains.kp = Vector4::new(0.0, 0.0, 90.0, 14.0);
        cases.push(Case {
            scenario,
            controller: "eq7_printed_kp",
            config: printed,
            trajectory,
        });
        let observer = SimConfig {
            piezo,
            state: StateSource::Observer,
            sensors: Sensors::realistic(),
            ..base
        };
        cases.push(Case {
            scenario,
            controller: "eq7_piezo_observer",
            config: observer,
            trajectory,
        });
    }
    Ok(cases)
}

/// Human-readable label of a controller key.
pub fn label(controller: &str) -> &'static str {
    match controller {
        "eq7" => "Eq. 7",
        "eq7_piezo" => "Eq. 7 + piezo",
        "eq16" => "Eq. 16",
        "eq16_piezo" => "Eq. 16 + piezo",
        "eq7_printed_kp" => "Eq. 7, printed K_p = diag(0, 0, 90, 14)",
        "eq7_piezo_observer" => "Eq. 7 + piezo, observer and realistic sensors",
        _ => "custom",
    }
}

/// Runs the cases in parallel; `progress` draws a bar on the terminal.
pub fn run(
    cases: Vec<Case>,
    record: bool,
    progress: bool,
) -> Result<Vec<Outcome>, (String, SimError)> {
    let bar = if progress {
        ProgressBar::new(cases.len() as u64)
    } else {
        ProgressBar::hidden()
    };
    if let Ok(style) = ProgressStyle::with_template("{bar:40} {pos}/{len} runs {elapsed}") {
        bar.set_style(style);
    }
    let out: Result<Vec<Outcome>, (String, SimError)> = cases
        .into_par_iter()
        .map(|case| {
            let r = simulate(&case.config, &case.trajectory, record)
                .map(|(summary, trace)| Outcome {
                    case: case.clone(),
                    summary,
                    trace,
                })
                .map_err(|e| (format!("{}/{}", case.scenario, case.controller), e));
            bar.inc(1);
            r
        })
        .collect();
    bar.finish_and_clear();
    out
}

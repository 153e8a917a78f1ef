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

/// Most motor samples the traces of one study hold together (about 150 bytes each, so about
/// 300 MB): every run keeps its whole trace until the study writes them, so a study's memory
/// is the sum of its runs'. Each run alone is bounded by `sim::MAX_RECORDED_SAMPLES`.
pub const MAX_STUDY_SAMPLES: f64 = 2e6;

/// Refuses, before any of them runs, cases whose traces would hold more than
/// [`MAX_STUDY_SAMPLES`] together, with the size they would need and the longest `duration`
/// that fits.
pub fn check_memory(cases: &[Case]) -> Result<(), SimError> {
    let samples = |c: &Case| c.config.duration * c.config.rates.motor_hz;
    let total: f64 = cases.iter().map(samples).sum();
    if total <= MAX_STUDY_SAMPLES {
        return Ok(());
    }
    let bytes = std::mem::size_of::<Sample>() as f64;
    let longest = cases
        .iter()
        .map(|c| c.config.duration * MAX_STUDY_SAMPLES / total)
        .fold(f64::INFINITY, f64::min);
    Err(SimError::Input {
        key: "duration",
        msg: format!(
            "{} runs would hold {total:.3e} motor samples together ({:.1} GB); a study holds at most {MAX_STUDY_SAMPLES:e} ({:.0} MB): give a `duration` of at most {longest:.3} s",
            cases.len(),
            total * bytes / 1e9,
            MAX_STUDY_SAMPLES * bytes / 1e6
        ),
    })
}

/// Runs the cases in parallel; `progress` draws a bar on the terminal. With `record` (every
/// run's trace kept), cases over [`MAX_STUDY_SAMPLES`] are refused before any runs.
pub fn run(
    cases: Vec<Case>,
    record: bool,
    progress: bool,
) -> Result<Vec<Outcome>, (String, SimError)> {
    if record {
        check_memory(&cases).map_err(|e| ("the study".to_string(), e))?;
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_study_too_large_to_hold_is_refused_with_the_duration_that_fits() {
        let opts = |duration| Options {
            duration,
            truth: Some(TruthSpec {
                modes: 7,
                ..TruthSpec::default()
            }),
            ..Options::default()
        };
        let Ok(cases) = paper_cases(&opts(1000.0)) else {
            unreachable!("the study's cases")
        };
        let Err(SimError::Input { key, msg }) = check_memory(&cases) else {
            unreachable!("24 traces of 1e6 samples")
        };
        assert_eq!(key, "duration");
        assert!(
            msg.starts_with("24 runs would hold 2.400e7 motor samples"),
            "{msg}"
        );
        // The duration it names fits; a little more does not.
        let longest: f64 = msg
            .rsplit("at most ")
            .next()
            .and_then(|s| s.trim_end_matches(" s").parse().ok())
            .unwrap_or(f64::NAN);
        for (d, fits) in [(longest, true), (longest * 1.01, false)] {
            let Ok(cases) = paper_cases(&opts(d)) else {
                unreachable!("the study's cases")
            };
            assert_eq!(check_memory(&cases).is_ok(), fits, "{d} s");
        }
    }
}

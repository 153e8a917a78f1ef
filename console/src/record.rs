//! `record` and `compare`: telemetry to the simulator's CSV and figure, and a recording against
//! the simulator's run of the same move.
//!
//! A recording is three files in the output folder (written through `flexarm_host::outdir`:
//! staged, then moved into place; a file no flexarm command wrote is never replaced):
//! - `recording_firmware.csv`: the simulator's trace format (`flexarm_host::output::write_csv`),
//!   one row per telemetry frame. The firmware streams its *estimates*: θ̂ and δ̂ in the state
//!   columns, `θ_d = θ̂ − (θ̂ − θ_d)` from the error channel, the tip deflection computed from
//!   them with the paper's model; the modal rates, not streamed, are `NaN`.
//! - `recording_firmware.svg`: the simulator's figure of a run, of the recording.
//! - `recording_firmware.toml`: what `compare` needs: the firmware, its board and loop rates,
//!   the hash of the parameters it booted with (the handshake's) and the model file that gives
//!   them (its text, checked against the hash when recording), every tunable parameter's value
//!   when the recording started, the move and the pose it started from, the frames lost.
//!
//! `compare` rebuilds the board's configuration from the recorded model (`flexarm_machine::
//! BoardConfig`, as `cargo sim firmware-params` generates the firmware's), refuses a recording
//! whose hash it does not reproduce, applies the recorded parameters, plans the recorded move
//! with the drive, runs it on the host's rig (`flexarm_host::sim`: the firmware's controller and
//! drive at its rates, with its sensors; the QEMU board's arm for a QEMU recording, the model
//! for a board's), aligns the two on the reference θ_d, and prints the Eq. 37/38 indices of
//! both; `--within F` fails when the recording's tracking indices exceed `F` times the
//! simulation's.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use flexarm_beam::toml_at::{array, at_line, de_error, option_array};
use flexarm_core::Vector2;
use flexarm_core::drive::{MoveRequest, Waypoint};
use flexarm_core::plant::State;
use flexarm_core::time::Ticks;
use flexarm_core::trajectory::JointTrajectory;
use flexarm_host::outdir::OutDir;
use flexarm_host::sim::{Sample, SimConfig, Summary, simulate_segments, summarize};
use flexarm_host::study::{Case, Outcome};
use flexarm_link::Command;
use flexarm_link::msg::{Channels, Mode, Move, Telemetry};
use serde::{Deserialize, Serialize};

use crate::client::{Client, ConsoleError};
use crate::interrupt;

/// The recording's files' stem.
pub const STEM: &str = "recording_firmware";

/// What `compare` needs besides the trace (`recording_firmware.toml`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Info {
    /// The firmware's build name.
    pub build: String,
    /// Motor loop [Hz].
    pub motor_hz: u32,
    /// Piezo loop [Hz].
    pub piezo_hz: u32,
    /// Motor periods per frame.
    pub decimation: u16,
    /// The piezo gain the firmware ran [s].
    pub k_c: f32,
    /// The joints' `K_p` the firmware ran [N·m·s/rad] (absent from older recordings: then the
    /// core's `Gains::default_for(motor_hz)`).
    #[serde(default, deserialize_with = "option_array")]
    pub kp: Option<[f32; 2]>,
    /// Which board (absent from older recordings).
    #[serde(default)]
    pub board: Option<flexarm_link::msg::Board>,
    /// The hash of the parameters the firmware booted with (its handshake's).
    #[serde(default)]
    pub params_hash: Option<u32>,
    /// The model file the firmware was built from, its text: its configuration's hash is
    /// `params_hash` (absent when the console was not given it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model: Option<String>,
    /// Every tunable parameter's value when the recording started, by the console's names.
    #[serde(default)]
    pub params: std::collections::BTreeMap<String, f32>,
    /// Frames recorded.
    pub frames: usize,
    /// Frames lost on the way (gaps in the sequence numbers).
    pub lost: u64,
    /// The pose held when the move started (the drive's reference) [rad].
    #[serde(deserialize_with = "array")]
    pub from: [f32; 2],
    /// The move.
    #[serde(rename = "move")]
    pub mv: Option<Move>,
    /// A waypoint path's points, `[θ1, θ2, dt]` [rad, rad, s] (the move names only their count).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub waypoints: Option<Vec<[f32; 3]>>,
}

/// A finished recording.
pub struct Recording {
    /// One sample per frame.
    pub trace: Vec<Sample>,
    /// The sidecar.
    pub info: Info,
}

/// A telemetry frame's values read by name (`Telemetry::value`: the frame's own channels say
/// where each is, so a frame of any subset reads right): what `record`, `live`, `bringup` and
/// `identify` take from the stream. A value the frame lacks, or of no frame, reads NaN.
#[derive(Clone, Copy)]
pub struct Values<'a>(pub Option<&'a Telemetry>);

impl Values<'_> {
    fn at(&self, bit: u16, j: usize) -> f64 {
        self.0
            .and_then(|f| f.value(bit, j))
            .map_or(f64::NAN, f64::from)
    }
    /// Tracking error `θ_j − θ_d,j` [rad].
    pub fn error(&self, j: usize) -> f64 {
        self.at(Channels::ERROR, j)
    }
    /// Estimated angle `θ̂_j` [rad].
    pub fn theta(&self, j: usize) -> f64 {
        self.at(Channels::THETA, j)
    }
    /// Estimated modal coordinate `δ̂_j` [√kg·m].
    pub fn delta(&self, j: usize) -> f64 {
        self.at(Channels::DELTA, j)
    }
    /// Torque command `τ_j` [N·m].
    pub fn tau(&self, j: usize) -> f64 {
        self.at(Channels::TAU, j)
    }
    /// Piezo command [V].
    pub fn v_a(&self) -> f64 {
        self.at(Channels::V_A, 0)
    }
    /// Film voltage [V].
    pub fn v_f(&self) -> f64 {
        self.at(Channels::V_F, 0)
    }
    /// Load of the piezo (0) or motor (1) loop [fraction of its period].
    pub fn load(&self, i: usize) -> f64 {
        self.at(Channels::LOAD, i)
    }
    /// The reference `θ_d = θ̂ − (θ̂ − θ_d)` [rad].
    pub fn reference(&self, j: usize) -> f64 {
        self.theta(j) - self.error(j)
    }
    /// `q̂ = (θ̂, δ̂)`.
    pub fn q(&self) -> flexarm_core::Vector4<f64> {
        flexarm_core::Vector4::new(self.theta(0), self.theta(1), self.delta(0), self.delta(1))
    }
}

/// The frame's values by name.
pub fn values(f: &Telemetry) -> Values<'_> {
    Values(Some(f))
}

/// The channels a recording's sample needs.
const SAMPLED: u16 = Channels::ERROR
    | Channels::THETA
    | Channels::DELTA
    | Channels::TAU
    | Channels::V_A
    | Channels::V_F;

/// The frame as a sample at `t` [s]; `None` for a frame without the channels it needs
/// (`SAMPLED`).
pub(crate) fn sample(
    f: &Telemetry,
    t: f64,
    model: &flexarm_core::model::Model<f64>,
) -> Option<Sample> {
    if f.channels.0 & SAMPLED != SAMPLED {
        return None;
    }
    let v = values(f);
    let q = v.q();
    Some(Sample {
        t,
        x: State {
            q,
            qd: flexarm_core::Vector4::new(f64::NAN, f64::NAN, f64::NAN, f64::NAN),
        },
        q_d: Vector2::new(v.reference(0), v.reference(1)),
        delta_seen: Vector2::new(v.delta(0), v.delta(1)),
        tau: Vector2::new(v.tau(0), v.tau(1)),
        v_a: v.v_a(),
        v_f: v.v_f(),
        tip: model.tip_deflection(&q),
    })
}

/// Records `seconds` of telemetry at `decimation`, first starting `start` (a move, uploaded
/// and started by the caller's closure) if given. Keeps the link watchdog fed; after Ctrl-C
/// stops the arm and returns an error, writing nothing.
pub fn record(
    c: &mut Client,
    seconds: f64,
    decimation: u16,
    model: &Path,
    mv: Option<Move>,
    start: &mut dyn FnMut(&mut Client) -> Result<(), ConsoleError>,
) -> Result<Recording, ConsoleError> {
    let hello = c.hello.clone();
    let motor_hz = f64::from(hello.motor_hz);
    let model_text = model_of(model, &hello);
    let mut params = std::collections::BTreeMap::new();
    for p in flexarm_link::params::PARAMS {
        params.insert(p.name.to_string(), c.get(p.param)?);
    }
    let k_c = params.get("kc").copied().unwrap_or(f32::NAN);
    let kp = [
        params.get("kp0").copied().unwrap_or(f32::NAN),
        params.get("kp1").copied().unwrap_or(f32::NAN),
    ];
    let dropped_before = c.status()?.telemetry_dropped;
    c.done(
        "subscribe",
        Command::Subscribe {
            decimation,
            channels: Channels(Channels::ALL),
        },
    )?;
    // The first frame: the recording's time zero and the pose held.
    let mut frames = interrupt::collect(c, 0.0)?;
    let tick0 = frames[0].tick;
    // The pose held, where the drive plans the move from.
    let from = frames.last().map_or([0.0; 2], |f| {
        let v = values(f);
        [v.reference(0) as f32, v.reference(1) as f32]
    });
    if mv.is_some() {
        start(c)?;
    }
    let end_tick = tick0 + (seconds * motor_hz).round() as u64;
    let bar = progress(seconds);
    // Real time plus a margin: a board whose stream stops does not hang the recording.
    let deadline = Instant::now() + Duration::from_secs_f64(seconds * 1.5 + 5.0);
    while frames.last().is_none_or(|f| f.tick < end_tick) {
        if interrupt::requested() {
            bar.abandon();
            interrupt::stop_arm(c)?;
            return Err(ConsoleError::Interrupted(
                "the arm was stopped; nothing was written".into(),
            ));
        }
        if Instant::now() > deadline {
            bar.abandon();
            return Err(ConsoleError::Timeout(format!(
                "{seconds} s of telemetry (the stream stopped after {} frames)",
                frames.len()
            )));
        }
        std::thread::sleep(Duration::from_millis(50));
        c.ask(Command::Ping)?;
        frames.extend(c.take_telemetry());
        if let Some(f) = frames.last() {
            bar.set_position(((f.tick.saturating_sub(tick0)) as f64 / motor_hz * 10.0) as u64);
        }
    }
    c.request("unsubscribe", Command::Unsubscribe)?;
    frames.extend(c.take_telemetry());
    frames.retain(|f| f.tick <= end_tick);
    bar.finish_and_clear();
    // A move that outlasts the recording is not left running unwatched: stopped (the drive's
    // controlled stop), and said so.
    if mv.is_some() && matches!(c.status()?.mode, Mode::Moving | Mode::Stopping) {
        interrupt::stop_arm(c)?;
        eprintln!(
            "flexarm: record: the move outlasted the {seconds} s recording: stopped short of its end (record longer than the move to keep it whole)"
        );
    }
    let lost: u64 = frames
        .windows(2)
        .map(|w| u64::from(w[1].seq.wrapping_sub(w[0].seq).saturating_sub(1)))
        .sum();
    let dropped = c.status()?.telemetry_dropped.saturating_sub(dropped_before);
    let model = paper_model();
    let trace: Vec<Sample> = frames
        .iter()
        .filter_map(|f| sample(f, (f.tick - tick0) as f64 / motor_hz, &model))
        .collect();
    let info = Info {
        build: hello.build.to_string(),
        motor_hz: hello.motor_hz,
        piezo_hz: hello.piezo_hz,
        decimation,
        k_c,
        kp: Some(kp),
        board: Some(hello.board),
        params_hash: Some(hello.params_hash),
        model: model_text,
        params,
        frames: trace.len(),
        lost: lost + u64::from(dropped),
        from,
        mv,
        waypoints: None,
    };
    Ok(Recording { trace, info })
}

/// The text of the model file `path` when the parameters it gives the board `hello` names are
/// the ones the firmware runs (their hash, `hello.params_hash`); otherwise `None`, said on stderr
/// (the recording is kept; `compare` will refuse it).
fn model_of(path: &Path, hello: &flexarm_link::msg::Hello) -> Option<String> {
    let warn = |why: String| {
        eprintln!(
            "flexarm: warning: {}: {why}; `compare` will refuse this recording (give the model file the firmware was built from with --model)",
            path.display()
        );
        None
    };
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) => return warn(e.to_string()),
    };
    match flexarm_host::firmware_params::design(&text) {
        Ok(p) => {
            let hash = p.board(hello.board).hash();
            if hash == hello.params_hash {
                Some(text)
            } else {
                warn(format!(
                    "gives the parameters {hash:08x}, the firmware runs {:08x}",
                    hello.params_hash
                ))
            }
        }
        Err(e) => warn(e.to_string()),
    }
}

/// A progress bar in tenths of a second, on a terminal only.
fn progress(seconds: f64) -> indicatif::ProgressBar {
    if !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new((seconds * 10.0).round() as u64);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "recording [{bar:40}] {pos}/{len} tenths of a second",
    ) {
        bar.set_style(style);
    }
    bar
}

/// A trace as the study's outcome, for its CSV and figure writers.
fn outcome(trace: Vec<Sample>, scenario: &'static str) -> Outcome {
    outcome_of(trace, scenario, "firmware")
}

fn outcome_of(trace: Vec<Sample>, scenario: &'static str, controller: &'static str) -> Outcome {
    let summary = summarize(&trace, tail_window(&trace));
    Outcome {
        case: Case {
            scenario,
            controller,
            config: SimConfig::default(),
            trajectory: JointTrajectory::Hold(Vector2::zeros()),
        },
        summary,
        trace,
    }
}

/// Eq. 38's window: the paper's 3 s, or half of a shorter trace.
fn tail_window(trace: &[Sample]) -> f64 {
    let span = match (trace.first(), trace.last()) {
        (Some(a), Some(b)) => b.t - a.t,
        _ => 0.0,
    };
    3.0f64.min(span / 2.0)
}

/// Writes the recording's three files into `out`; returns their names.
pub fn save(r: Recording, out: &Path, force: bool) -> Result<Vec<String>, ConsoleError> {
    let dir = OutDir::open(out, "record", force).map_err(ConsoleError::Io)?;
    let text = toml::to_string(&r.info)
        .map_err(|e| ConsoleError::Io(format!("the recording's description: {e}")))?;
    let o = outcome(r.trace, "recording");
    let staged = dir.staging();
    std::fs::write(staged.join(format!("{STEM}.toml")), text)
        .and_then(|()| flexarm_host::output::write_csv(staged, &o))
        .map_err(|e| ConsoleError::Io(format!("{}: {e}", out.display())))?;
    flexarm_host::output::write_figure(staged, &o)
        .map_err(|e| ConsoleError::Io(format!("the figure: {e}")))?;
    dir.commit().map_err(ConsoleError::Io)
}

/// `flexarm plot`: the figure of a trace file already written (a recording, the fault
/// recorder's, a simulator's run: `flexarm_host::output`'s format) as `plot_trace.svg` in `out`,
/// the same panels as the recording's; returns the file's name.
pub fn plot(csv: &Path, out: &Path, force: bool) -> Result<Vec<String>, ConsoleError> {
    let trace = flexarm_host::output::read_csv(csv).map_err(ConsoleError::Usage)?;
    if trace.len() < 2 {
        return Err(ConsoleError::Usage(format!(
            "{}: {} samples: nothing to plot",
            csv.display(),
            trace.len()
        )));
    }
    let dir = OutDir::open(out, "plot", force).map_err(ConsoleError::Io)?;
    flexarm_host::output::write_figure(dir.staging(), &outcome_of(trace, "plot", "trace"))
        .map_err(|e| ConsoleError::Io(format!("the figure: {e}")))?;
    dir.commit().map_err(ConsoleError::Io)
}

/// Writes the fault recorder's samples (one per motor period before the fault, oldest first)
/// into `out` as `faults_firmware.csv` and `.svg`, in the trace format: the measured angles in
/// the state columns, `θ_d = θ − (θ − θ_d)`, the estimated δ̂, the torques and `V_f`; `V_a`, not
/// recorded, is `NaN` (and not drawn). Time 0 is the first sample.
pub fn save_faults(
    samples: &[flexarm_link::msg::RecordedSample],
    motor_hz: u32,
    out: &Path,
    force: bool,
) -> Result<Vec<String>, ConsoleError> {
    let Some(first) = samples.first() else {
        return Err(ConsoleError::Usage(
            "the fault recorder holds nothing: no fault since boot".into(),
        ));
    };
    let model = paper_model();
    let trace: Vec<Sample> = samples
        .iter()
        .map(|r| {
            let f = |x: [f32; 2]| Vector2::new(f64::from(x[0]), f64::from(x[1]));
            let (theta, delta) = (f(r.theta), f(r.delta));
            let q = flexarm_core::Vector4::new(theta.x, theta.y, delta.x, delta.y);
            Sample {
                t: (r.tick - first.tick) as f64 / f64::from(motor_hz.max(1)),
                x: State {
                    q,
                    qd: flexarm_core::Vector4::repeat(f64::NAN),
                },
                q_d: theta - f(r.error),
                delta_seen: delta,
                tau: f(r.tau),
                v_a: f64::NAN,
                v_f: f64::from(r.v_f),
                tip: model.tip_deflection(&q),
            }
        })
        .collect();
    let dir = OutDir::open(out, "faults", force).map_err(ConsoleError::Io)?;
    let o = outcome(trace, "faults");
    flexarm_host::output::write_csv(dir.staging(), &o)
        .map_err(|e| ConsoleError::Io(format!("{}: {e}", out.display())))?;
    flexarm_host::output::write_figure(dir.staging(), &o)
        .map_err(|e| ConsoleError::Io(format!("the figure: {e}")))?;
    dir.commit().map_err(ConsoleError::Io)
}

/// The paper's model in `f64` (the firmware's), for the tip deflection.
/// The paper's arm, as the firmware's controller models it (f64, for the host's figures).
pub fn paper_model() -> flexarm_core::model::Model<f64> {
    flexarm_core::model::Model::new(flexarm_core::params::ArmParams::default())
}

/// A recording compared with the simulator.
pub struct Comparison {
    /// The recording's indices over the move.
    pub recorded: Summary,
    /// The simulation's.
    pub simulated: Summary,
    /// The two traces from the move's start, aligned.
    pub traces: (Vec<Sample>, Vec<Sample>),
    /// The alignment's residual: mean |θ_d,recorded − θ_d,simulated| [rad].
    pub reference_gap: f64,
}

/// Reads `csv` and its `.toml`, simulates the same move and aligns the two.
pub fn compare(csv: &Path) -> Result<Comparison, ConsoleError> {
    let trace = flexarm_host::output::read_csv(csv).map_err(ConsoleError::Usage)?;
    let toml_path = csv.with_extension("toml");
    let shown = toml_path.display();
    let text = std::fs::read_to_string(&toml_path).map_err(|e| {
        ConsoleError::Usage(format!("{shown}: {e} (record writes it beside the CSV)"))
    })?;
    let info: Info = toml::from_str(&text)
        .map_err(|e| ConsoleError::Usage(at_line(&toml_path, &text, &de_error(&text, &e))))?;
    let Some(mv) = info.mv else {
        return Err(ConsoleError::Usage(format!(
            "{shown}: the recording started no move; record one with a move to compare (flexarm record … trapezoid …)"
        )));
    };
    let valid = info.motor_hz > 0 && info.piezo_hz >= info.motor_hz && info.k_c.is_finite();
    if !valid {
        return Err(ConsoleError::Usage(format!(
            "{shown}: motor_hz, piezo_hz or k_c out of range"
        )));
    }
    let (board, sim) = firmware_of(&info, &text, &shown.to_string())?;
    let request = flexarm_machine::session::move_request(&mv);
    // The drive's own plan of the move, from the pose recorded at its start.
    let mut ctrl = board.controller(JointTrajectory::Hold(Vector2::new(
        info.from[0],
        info.from[1],
    )));
    let mut drive = board.drive(&mut ctrl, Ticks(0));
    let from = Vector2::new(info.from[0], info.from[1]);
    if let MoveRequest::Waypoints { count } = request {
        let points: Vec<Waypoint<f32>> = info
            .waypoints
            .as_deref()
            .filter(|w| w.len() == count)
            .ok_or_else(|| {
                ConsoleError::Usage(format!(
                    "{shown}: a path of {count} waypoints without its points (`waypoints`; recorded by an older console?)"
                ))
            })?
            .iter()
            .map(|&[t1, t2, dt]| Waypoint {
                theta: Vector2::new(t1, t2),
                dt,
            })
            .collect();
        drive.load_waypoints(&ctrl, 0, &points).map_err(|why| {
            ConsoleError::Usage(format!("{shown}: the drive refuses the waypoints: {why:?}"))
        })?;
    }
    let plan = drive.plan(&ctrl.motor, from, &request).map_err(|why| {
        ConsoleError::Usage(format!("{shown}: the drive refuses the move: {why:?}"))
    })?;
    // The segments the drive runs, each from its start (one for a trapezoid or a circle).
    let segments: Vec<(f64, JointTrajectory<f32>)> = match request {
        MoveRequest::Waypoints { count } => {
            let mut start = 0.0;
            drive
                .path_segments(from, count)
                .map(|c| {
                    let s = (start, JointTrajectory::Cubic(c));
                    start += f64::from(c.duration);
                    s
                })
                .collect()
        }
        _ => vec![(0.0, plan.trajectory())],
    };
    let reference = |t: f64| {
        let i = segments.partition_point(|(s, _)| *s <= t).saturating_sub(1);
        let (s, seg) = segments[i];
        seg.sample((t - s) as f32).q
    };
    // The move's start: the last frame before the recorded reference leaves the held pose (the
    // console's own mark, taken before the request's round trip, can be many frames early under
    // QEMU's instruction clock). θ_d = θ̂ − (θ̂ − θ_d) is the step's reference to the float's
    // rounding (`Controller::step_estimate`); the alignment below settles the frame.
    let held = trace[0].q_d;
    let start_s = trace
        .windows(2)
        .find(|w| (w[1].q_d - held).abs().max() > 1e-6)
        .map_or(0.0, |w| w[0].t);
    let recorded: Vec<Sample> = trace
        .into_iter()
        .map(|mut s| {
            s.t -= start_s;
            s
        })
        .collect();
    let dt = f64::from(info.decimation) / f64::from(info.motor_hz);
    let duration = recorded.last().map_or(0.0, |s| s.t) + 2.0 * dt;
    if duration < f64::from(plan.duration) * 0.5 {
        return Err(ConsoleError::Usage(format!(
            "{}: {duration:.2} s of the move recorded, less than half of its {:.2} s",
            csv.display(),
            plan.duration
        )));
    }
    let cfg = SimConfig {
        duration: duration + 1.0 / f64::from(info.motor_hz),
        tail_window: 1.0,
        ..sim
    };
    let (_, simulated) = simulate_segments(&cfg, &segments, true)
        .map_err(|e| ConsoleError::Usage(format!("the simulation: {e}")))?;
    // Align on the reference: from two frames back to ten on. A path's cubic starts with no
    // acceleration, its reference growing as t³, so the 1e-6 rad threshold above finds its start
    // a few frames late and the recorded times come out early (3 frames on the QEMU arm's
    // console path: a run failed at the old ±2 with a mean gap of 9.6e-4 rad); a slower path,
    // later still.
    let gap = |shift: f64| {
        let sum: f64 = recorded
            .iter()
            .map(|s| {
                let r = reference(s.t + shift);
                (s.q_d.x - f64::from(r.x)).abs() + (s.q_d.y - f64::from(r.y)).abs()
            })
            .sum();
        sum / (2 * recorded.len()) as f64
    };
    let (shift, reference_gap) = (-2..=10)
        .map(|k| {
            let shift = f64::from(k) * dt;
            (shift, gap(shift))
        })
        .fold((0.0, f64::INFINITY), |a, b| if b.1 < a.1 { b } else { a });
    let recorded: Vec<Sample> = recorded
        .into_iter()
        .map(|mut s| {
            s.t += shift;
            s
        })
        .filter(|s| s.t >= 0.0)
        .collect();
    if reference_gap > 1e-4 {
        return Err(ConsoleError::Usage(format!(
            "{}: the recorded reference does not follow the move its description names (mean gap {reference_gap:.1e} rad after alignment)",
            csv.display()
        )));
    }
    // The same span for both.
    let mut simulated = simulated;
    let end = recorded.last().map_or(0.0, |s| s.t);
    simulated.retain(|s| s.t <= end + 1e-9);
    let window = tail_window(&recorded);
    Ok(Comparison {
        recorded: summarize(&recorded, window),
        simulated: summarize(&simulated, window),
        traces: (recorded, simulated),
        reference_gap,
    })
}

/// The firmware a recording ran, rebuilt: its board's configuration from the recorded model
/// (refused unless its hash is the recorded one), with the recorded parameters applied, and the
/// simulator's run of it: the QEMU board's arm (the paper's, the patch's slopes there) for a
/// QEMU recording, the model itself for a board's; the board's sensors. `shown` names the
/// description file in errors; `text` is its text, for the line of a key.
fn firmware_of(
    info: &Info,
    text: &str,
    shown: &str,
) -> Result<(flexarm_machine::BoardConfig, SimConfig), ConsoleError> {
    let line = |key: &str| {
        text.lines()
            .position(|l| l.trim_start().starts_with(key))
            .map_or(1, |i| i + 1)
    };
    let (Some(board), Some(hash), Some(model)) = (info.board, info.params_hash, &info.model) else {
        return Err(ConsoleError::Usage(format!(
            "{shown}:{}: params_hash: the recording does not carry the model its firmware was built from (recorded without it, or by an older console): record again with --model <the firmware's model file>",
            line("params_hash")
        )));
    };
    let p = flexarm_host::firmware_params::design(model)
        .map_err(|e| ConsoleError::Usage(format!("{shown}:{}: model: {e}", line("model"))))?;
    let mut config = p.board(board);
    if config.hash() != hash {
        return Err(ConsoleError::Usage(format!(
            "{shown}:{}: model: gives the parameters {:08x}, not the recording's {hash:08x}: this console cannot reproduce the firmware",
            line("model"),
            config.hash()
        )));
    }
    for (name, v) in &info.params {
        let (param, _) = crate::params::parse(name).map_err(|_| {
            ConsoleError::Usage(format!(
                "{shown}:{}: params.{name}: no such parameter",
                line(name)
            ))
        })?;
        config.set_param(param, *v);
    }
    let (mut arm, mut patch) = (p.arm, p.patch);
    if board == flexarm_link::msg::Board::Qemu {
        arm = flexarm_core::params::ArmParams::default();
        patch.slope_diff = p.qemu_slope_diff;
    }
    let sim = SimConfig {
        arm,
        patch,
        machine: Some(config),
        ..SimConfig::board(f64::from(config.motor_hz()), f64::from(config.piezo_hz))
    };
    Ok((config, sim))
}

/// The comparison's table: index, recording, simulation, ratio.
pub fn table(c: &Comparison) -> String {
    let (r, s) = (&c.recorded, &c.simulated);
    let rows = [
        ("Eq. 37 ‖θ̃‖ [rad]", r.l2_error, s.l2_error),
        ("Eq. 37 ‖δ‖ [√kg·m]", r.l2_delta, s.l2_delta),
        ("Eq. 37 ‖tip‖ [m]", r.l2_tip, s.l2_tip),
        (
            "Eq. 38 mean |θ̃1| [rad]",
            r.tail_error_abs[0],
            s.tail_error_abs[0],
        ),
        (
            "Eq. 38 mean |θ̃2| [rad]",
            r.tail_error_abs[1],
            s.tail_error_abs[1],
        ),
        (
            "Eq. 38 mean |δ1| [√kg·m]",
            r.tail_delta_abs[0],
            s.tail_delta_abs[0],
        ),
        ("max |θ̃| [rad]", r.max_error, s.max_error),
        ("max |tip| [m]", r.max_tip, s.max_tip),
        ("max |V_a| [V]", r.max_v_a, s.max_v_a),
    ];
    let mut out = format!(
        "{:26} {:>11} {:>11} {:>7}\n",
        "index", "recording", "simulation", "ratio"
    );
    for (name, a, b) in rows {
        let ratio = if b > 0.0 { a / b } else { f64::NAN };
        out += &format!("{name:26} {a:>11.3e} {b:>11.3e} {ratio:>7.2}\n");
    }
    out
}

/// Writes `compare.svg` (the two traces on the same axes) into `out`.
pub fn save_comparison(c: &Comparison, out: &Path, force: bool) -> Result<PathBuf, ConsoleError> {
    let dir = OutDir::open(out, "compare", force).map_err(ConsoleError::Io)?;
    flexarm_host::output::write_comparison(
        &dir.staging().join("compare.svg"),
        "The firmware's recording against the simulator's run of the same move",
        ("recording", &c.traces.0),
        ("simulation", &c.traces.1),
    )
    .map_err(|e| ConsoleError::Io(format!("the figure: {e}")))?;
    dir.commit().map_err(ConsoleError::Io)?;
    Ok(out.join("compare.svg"))
}

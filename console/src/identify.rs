//! `identify friction`, `modes`, `decay` and `inertia`: the simulator's experiments
//! (`flexarm_host::identify`, docs/identification.md) run on the arm over the link, with the
//! same fits and files. Friction: the same constant-speed trapezoids, out and back for each
//! joint from where the arm holds, the same cruise averages (the firmware's torque commands and
//! its estimated angles). Modes: the same blocks of bias steps and moves at the same pose.
//! Decay: the same taps by the patch at the same pose. Inertia: the same random trapezoids of
//! both joints about the same pose.

use std::path::Path;
use std::time::Duration;

use flexarm_core::Vector2;
use flexarm_core::trajectory::JointTrajectory;
use flexarm_host::identify::decay::DecayPlan;
use flexarm_host::identify::inertia::{self, InertiaPlan};
use flexarm_host::identify::modes::{Excitation, ModesPlan, excitation};
use flexarm_host::identify::{self, Cruise};
use flexarm_host::sim::Sample;
use flexarm_link::Command;
use flexarm_link::msg::{Mode, Move, Param, Telemetry};

use crate::client::{Client, ConsoleError};
use crate::{fault_name, interrupt, record};

/// The experiments start from a holding arm.
fn holding(c: &mut Client) -> Result<(), ConsoleError> {
    let s = c.status()?;
    if s.mode != Mode::Armed {
        return Err(ConsoleError::Usage(format!(
            "identify runs on a holding arm (the drive is {:?}): `flexarm arm` first",
            s.mode
        )));
    }
    Ok(())
}

/// The pose the drive holds in the last of `frames` [rad] (its reference).
fn held(frames: &[Telemetry]) -> Vector2<f64> {
    frames.last().map_or(Vector2::zeros(), |f| {
        let v = record::values(f);
        Vector2::new(v.reference(0), v.reference(1))
    })
}

/// `frames` from the tick `from` on as samples, their time from that tick.
fn samples(c: &Client, frames: &[Telemetry], from: u64) -> Vec<Sample> {
    let motor_hz = f64::from(c.hello.motor_hz.max(1));
    let model = record::paper_model();
    frames
        .iter()
        .filter(|f| f.tick >= from)
        .filter_map(|f| record::sample(f, (f.tick - from) as f64 / motor_hz, &model))
        .collect()
}

/// `frames` as the experiment's record, its time from the first frame.
fn record_of(c: &Client, frames: &[Telemetry]) -> Vec<Sample> {
    samples(c, frames, frames.first().map_or(0, |f| f.tick))
}

/// An experiment's outcome for its fit, once its record is written: whatever ended the
/// experiment (`run`), what it recorded is written to `dir` as `<name>_record.csv`, and its
/// error, if any, becomes the fit's, which keeps the record (`flexarm identify`). An
/// experiment that failed before it recorded anything is its own error.
pub fn recorded<T>(
    dir: &Path,
    name: &str,
    run: Result<T, ConsoleError>,
    record: &[Sample],
) -> Result<Result<T, String>, ConsoleError> {
    match run {
        Err(e) if record.is_empty() => Err(e),
        run => {
            identify::workflow::save_record(dir, name, record).map_err(ConsoleError::Io)?;
            Ok(run.map_err(|e| e.to_string()))
        }
    }
}

/// A trapezoid to `target` in `time` seconds with `ramp` seconds of acceleration at each end,
/// followed to its end with the telemetry kept in `frames`; an error unless the drive ends
/// holding.
fn run_move(
    c: &mut Client,
    what: &str,
    target: Vector2<f64>,
    (time, ramp): (f64, f64),
    frames: &mut Vec<Telemetry>,
) -> Result<(), ConsoleError> {
    let m = Move::Trapezoid {
        target: [target.x as f32, target.y as f32],
        move_time: time as f32,
        ramp_time: ramp as f32,
    };
    c.done(what, Command::Move(m))?;
    let ended = interrupt::follow_move(c, what, frames, Some(Duration::from_secs(60)))?;
    if ended.mode != Mode::Armed {
        return Err(ConsoleError::Unexpected(format!(
            "{what}: the move ended in {}",
            ended.fault.map_or("the drive disarmed".into(), |f| format!(
                "fault {f} ({})",
                fault_name(f)
            ))
        )));
    }
    Ok(())
}

/// Moves the holding arm to `pose` (at most 0.5 rad/s, at least 2 s, ramps of a third) and
/// returns the telemetry from half a second of holding there on (the caller has subscribed).
fn to_pose(c: &mut Client, pose: Vector2<f64>) -> Result<Vec<Telemetry>, ConsoleError> {
    let distance = (pose - held(&interrupt::collect(c, 0.0)?)).abs().max();
    if distance > 1e-3 {
        let time = (distance / 0.5).max(2.0);
        run_move(
            c,
            "the move to the pose",
            pose,
            (time, time / 3.0),
            &mut Vec::new(),
        )?;
    }
    interrupt::collect(c, 0.5)
}

/// Runs the friction experiment on the holding arm and returns every leg's cruise; `record`
/// receives every leg's telemetry on the board's clock, one sample per frame, as it comes,
/// a failed leg's too. A leg that fails (the move, its cruise, the link, an interrupt) ends
/// the experiment with its error and leaves `record` holding what was recorded
/// ([`recorded`]). A fit of the record (`cargo sim identify friction --record`) finds the same
/// cruises.
pub fn friction(
    c: &mut Client,
    speeds: &[f64],
    cruise: f64,
    record: &mut Vec<Sample>,
) -> Result<Vec<Cruise>, ConsoleError> {
    holding(c)?;
    identify::check_speeds(speeds).map_err(|e| ConsoleError::Usage(format!("--speeds: {e}")))?;
    c.subscribe_fastest(1)?;
    let mut frames = interrupt::collect(c, 0.0)?;
    let from = held(&frames);
    let mut cruises = Vec::new();
    for joint in 0..2 {
        for &v in speeds {
            for leg in identify::legs(from, joint, v, cruise)
                .map_err(|e| ConsoleError::Usage(e.to_string()))?
            {
                let what = format!("joint {} at {v} rad/s", joint + 1);
                frames.clear();
                let moved = run_move(c, &what, leg.target, (leg.time, leg.ramp), &mut frames);
                record.extend(samples(c, &frames, 0));
                moved?;
                // The move's start: the last frame before the reference leaves the start pose.
                let start = frames
                    .windows(2)
                    .find(|w| {
                        (record::values(&w[1]).reference(joint) - leg.start[joint]).abs() > 1e-6
                    })
                    .map_or(0, |w| w[0].tick);
                let cruise = identify::cruise_of(&samples(c, &frames, start), joint, leg.window)
                    .map_err(|e| ConsoleError::Failed(format!("{what}: {e}")))?;
                println!(
                    "identify: {what}: {:+.4} rad/s, {:+.5} N·m",
                    cruise.speed, cruise.torque
                );
                cruises.push(cruise);
            }
        }
    }
    let _ = c.ask(Command::Unsubscribe)?;
    Ok(cruises)
}

/// The modes experiment (`flexarm_host::identify::modes`) on the holding arm: a move to the
/// plan's pose, then its blocks (the patch's bias steps while holding, each one parameter
/// write; joint 2's moves, each one `move trapezoid`), the piezo loop off throughout (`k_c`
/// written back at the end, and the bias back to 0 on every path). Returns the amplifier's
/// window [V] the steps stayed inside; `record` receives the record, one sample per telemetry
/// frame (lost frames are refused by the fit), also when the experiment fails ([`recorded`]).
pub fn modes(
    c: &mut Client,
    plan: &ModesPlan,
    record: &mut Vec<Sample>,
) -> Result<(f64, f64), ConsoleError> {
    let ex = excitation(plan).map_err(|e| ConsoleError::Usage(e.to_string()))?;
    excite(c, plan.pose, &ex, (plan.seconds, plan.piezo_volts), record)
}

/// The free decay (`flexarm_host::identify::decay`) on the holding arm: a move to the plan's
/// pose, then its taps (two parameter writes each: the bias on, then off), the piezo loop off
/// throughout, as [`modes`]. Returns the amplifier's window [V]; `record` receives the record.
pub fn decay(
    c: &mut Client,
    plan: &DecayPlan,
    record: &mut Vec<Sample>,
) -> Result<(f64, f64), ConsoleError> {
    let ex = plan
        .excitation()
        .map_err(|e| ConsoleError::Usage(e.to_string()))?;
    excite(c, plan.pose, &ex, (plan.seconds(), plan.volts), record)
}

/// Runs `seconds` of the excitation `ex` at `pose` on the holding arm, its bias at most
/// `volts` [V] inside the amplifier's window; the piezo loop off throughout (`k_c` written
/// back, the bias back to 0 on every path).
fn excite(
    c: &mut Client,
    pose: Vector2<f64>,
    ex: &Excitation,
    (seconds, volts): (f64, f64),
    record: &mut Vec<Sample>,
) -> Result<(f64, f64), ConsoleError> {
    holding(c)?;
    let window = (c.get(Param::VaMin)?, c.get(Param::VaMax)?);
    let volts = volts as f32;
    if -volts <= window.0 || volts >= window.1 {
        return Err(ConsoleError::Usage(format!(
            "--volts {volts}: the excitation must stay inside the amplifier's window [{}, {}] V (a clipped command is refused by the fit)",
            window.0, window.1
        )));
    }
    c.subscribe_fastest(1)?;
    let k_c = c.get(Param::Kc)?;
    c.set(Param::Kc, 0.0)?;
    let mut frames = Vec::new();
    let outcome = timeline(c, pose, ex, seconds, &mut frames);
    *record = record_of(c, &frames);
    // The bias is cleared by the drive when it leaves holding; written back here otherwise.
    if c.status()?.mode == Mode::Armed {
        let _ = c.ask(Command::Set(Param::VaBias, 0.0))?;
    }
    let _ = c.ask(Command::Unsubscribe)?;
    c.set(Param::Kc, k_c)?;
    outcome.map(|()| (f64::from(window.0), f64::from(window.1)))
}

/// The excitation's bias writes and moves in its order, from a hold at `pose`, their
/// telemetry into `frames`.
fn timeline(
    c: &mut Client,
    pose: Vector2<f64>,
    ex: &Excitation,
    seconds: f64,
    frames: &mut Vec<Telemetry>,
) -> Result<(), ConsoleError> {
    frames.extend(to_pose(c, pose)?);
    let (mut b, mut m) = (0, 0);
    while b < ex.bias.len() || m < ex.moves.len() {
        let next_bias = ex.bias.get(b).map_or(f64::INFINITY, |x| x.0);
        let next_move = ex.moves.get(m).map_or(f64::INFINITY, |x| x.0);
        if next_bias <= next_move {
            let (t, v) = ex.bias[b];
            b += 1;
            c.set(Param::VaBias, v as f32)?;
            frames.extend(c.take_telemetry());
            let until = ex.bias.get(b).map_or(seconds, |x| x.0).min(next_move);
            // A short level (a tap) is timed closely; the rest in the usual slices.
            let budget = if until - t < 0.5 {
                Duration::from_micros(200)
            } else {
                Duration::from_millis(20)
            };
            frames.extend(interrupt::collect_within(c, until - t, budget)?);
        } else {
            let (_, traj) = ex.moves[m];
            m += 1;
            // The holds between the moves' blocks are the drive's own.
            if let JointTrajectory::Trapezoid(tr) = traj {
                let target = (tr.start + tr.amplitude).cast::<f64>();
                let timing = (
                    f64::from(tr.profile.duration()),
                    f64::from(tr.profile.ramp()),
                );
                let what = format!("move {m} of the experiment");
                run_move(c, &what, target, timing, frames)?;
            }
        }
    }
    Ok(())
}

/// The inertia experiment (`flexarm_host::identify::inertia`) on the holding arm: a move to the
/// plan's pose, then its moves one after another, each a `move trapezoid` the drive validates.
/// `record` receives the record, one sample per telemetry frame, also when a move fails
/// ([`recorded`]); lost frames are refused by the fit.
pub fn inertia(
    c: &mut Client,
    plan: &InertiaPlan,
    record: &mut Vec<Sample>,
) -> Result<(), ConsoleError> {
    holding(c)?;
    let moves = inertia::moves(plan).map_err(|e| ConsoleError::Usage(e.to_string()))?;
    c.subscribe_fastest(1)?;
    let mut frames = Vec::new();
    let outcome = inertia_moves(c, plan, &moves, &mut frames);
    *record = record_of(c, &frames);
    let _ = c.ask(Command::Unsubscribe)?;
    outcome
}

fn inertia_moves(
    c: &mut Client,
    plan: &InertiaPlan,
    moves: &[inertia::InertiaMove],
    frames: &mut Vec<Telemetry>,
) -> Result<(), ConsoleError> {
    frames.extend(to_pose(c, plan.pose)?);
    for (k, m) in moves.iter().enumerate() {
        let what = format!(
            "move {} of {} of the inertia experiment",
            k + 1,
            moves.len()
        );
        run_move(c, &what, m.target, (m.time, m.ramp()), frames)?;
    }
    frames.extend(interrupt::collect(c, 0.5)?);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use flexarm_core::Vector4;
    use flexarm_core::plant::State;

    fn sample(t: f64) -> Sample {
        Sample {
            t,
            x: State {
                q: Vector4::new(0.1, -0.2, 1e-4, 0.0),
                qd: Vector4::zeros(),
            },
            q_d: Vector2::new(0.1, -0.2),
            delta_seen: Vector2::zeros(),
            tau: Vector2::new(0.3, -0.1),
            v_a: 0.0,
            v_f: 0.01,
            tip: 0.0,
        }
    }

    /// An experiment that fails after it recorded (a move that ended in a fault, a lost link,
    /// an interrupt) leaves its record written, the error handed to the fit, which keeps it;
    /// one that failed before recording anything is its own error; a finished one is written
    /// the same way and goes on to its fit.
    #[test]
    fn a_failed_experiment_keeps_what_it_recorded() {
        let dir = std::env::temp_dir().join(format!("flexarm-recorded-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let record: Vec<Sample> = (0..50).map(|k| f64::from(k) * 1e-3).map(sample).collect();
        let written = dir.join("friction_record.csv");
        let failed: Result<(), _> = Err(ConsoleError::Failed("joint 2 at 0.5 rad/s: x".into()));
        let fit = recorded(&dir, "friction", failed, &record).unwrap();
        assert_eq!(fit, Err("joint 2 at 0.5 rad/s: x".into()));
        let back = flexarm_host::output::read_csv(&written).unwrap();
        assert_eq!(back.len(), record.len());
        assert_eq!(back.last().map(|s| s.tau), record.last().map(|s| s.tau));

        std::fs::remove_file(&written).unwrap();
        let silent: Result<(), _> = Err(ConsoleError::Silent);
        assert!(matches!(
            recorded(&dir, "friction", silent, &[]),
            Err(ConsoleError::Silent)
        ));
        assert!(!written.exists());

        assert_eq!(recorded(&dir, "modes", Ok(7), &record).unwrap(), Ok(7));
        assert!(dir.join("modes_record.csv").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

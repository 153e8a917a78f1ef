//! `identify friction`, `modes`, `decay` and `inertia`: the simulator's experiments
//! (`flexarm_host::identify`, docs/identification.md) run on the arm over the link, with the
//! same fits and files. Friction: the same constant-speed trapezoids, out and back for each
//! joint from where the arm holds, the same cruise averages (the firmware's torque commands and
//! its estimated angles). Modes: the same blocks of bias steps and moves at the same pose.
//! Decay: the same taps by the patch at the same pose. Inertia: the same random trapezoids of
//! both joints about the same pose.

use std::time::Duration;

use flexarm_core::Vector2;
use flexarm_core::trajectory::JointTrajectory;
use flexarm_host::identify::decay::DecayPlan;
use flexarm_host::identify::inertia::{self, InertiaPlan};
use flexarm_host::identify::modes::{Excitation, ModesPlan, excitation};
use flexarm_host::identify::{self, Cruise, Friction};
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

/// The friction experiment's outcome.
pub struct FrictionRun {
    /// Every leg's cruise.
    pub cruises: Vec<Cruise>,
    /// Each joint's fit.
    pub fits: [Friction; 2],
    /// The record: every leg's telemetry on the board's clock, one sample per frame.
    pub record: Vec<Sample>,
}

/// Runs the experiment on the holding arm: every joint's cruises, the fits and the record.
pub fn friction(c: &mut Client, speeds: &[f64], cruise: f64) -> Result<FrictionRun, ConsoleError> {
    holding(c)?;
    identify::check_speeds(speeds).map_err(|e| ConsoleError::Usage(format!("--speeds: {e}")))?;
    c.subscribe_fastest(1)?;
    let mut frames = interrupt::collect(c, 0.0)?;
    let from = held(&frames);
    let (mut cruises, mut record) = (Vec::new(), Vec::new());
    for joint in 0..2 {
        for &v in speeds {
            for leg in identify::legs(from, joint, v, cruise)
                .map_err(|e| ConsoleError::Usage(e.to_string()))?
            {
                let what = format!("joint {} at {v} rad/s", joint + 1);
                frames.clear();
                run_move(c, &what, leg.target, (leg.time, leg.ramp), &mut frames)?;
                // The move's start: the last frame before the reference leaves the start pose.
                let start = frames
                    .windows(2)
                    .find(|w| {
                        (record::values(&w[1]).reference(joint) - leg.start[joint]).abs() > 1e-6
                    })
                    .map_or(0, |w| w[0].tick);
                let cruise = identify::cruise_of(&samples(c, &frames, start), joint, leg.window)
                    .map_err(|e| ConsoleError::Unexpected(format!("{what}: {e}")))?;
                // The record on the board's clock (uptime), every leg's frames in order: a fit
                // of the record (`cargo sim identify friction --record`) finds the same cruises.
                record.extend(samples(c, &frames, 0));
                println!(
                    "identify: {what}: {:+.4} rad/s, {:+.5} N·m",
                    cruise.speed, cruise.torque
                );
                cruises.push(cruise);
            }
        }
    }
    let _ = c.ask(Command::Unsubscribe)?;
    let fits =
        identify::fit_joints(&cruises).map_err(|e| ConsoleError::Unexpected(e.to_string()))?;
    Ok(FrictionRun {
        cruises,
        fits,
        record,
    })
}

/// The modes experiment (`flexarm_host::identify::modes`) on the holding arm: a move to the
/// plan's pose, then its blocks (the patch's bias steps while holding, each one parameter
/// write; joint 2's moves, each one `move trapezoid`), the piezo loop off throughout (`k_c`
/// written back at the end, and the bias back to 0 on every path). Returns the record, one
/// sample per telemetry frame (lost frames are refused by the fit), and the amplifier's window
/// [V] the steps stayed inside.
pub fn modes(c: &mut Client, plan: &ModesPlan) -> Result<(Vec<Sample>, (f64, f64)), ConsoleError> {
    let ex = excitation(plan).map_err(|e| ConsoleError::Usage(e.to_string()))?;
    excite(c, plan.pose, &ex, plan.seconds, plan.piezo_volts)
}

/// The free decay (`flexarm_host::identify::decay`) on the holding arm: a move to the plan's
/// pose, then its taps (two parameter writes each: the bias on, then off), the piezo loop off
/// throughout, as [`modes`]. Returns the record and the amplifier's window [V].
pub fn decay(c: &mut Client, plan: &DecayPlan) -> Result<(Vec<Sample>, (f64, f64)), ConsoleError> {
    let ex = plan
        .excitation()
        .map_err(|e| ConsoleError::Usage(e.to_string()))?;
    excite(c, plan.pose, &ex, plan.seconds(), plan.volts)
}

/// Runs `seconds` of the excitation `ex` at `pose` on the holding arm, its bias at most
/// `volts` [V] inside the amplifier's window; the piezo loop off throughout (`k_c` written
/// back, the bias back to 0 on every path).
fn excite(
    c: &mut Client,
    pose: Vector2<f64>,
    ex: &Excitation,
    seconds: f64,
    volts: f64,
) -> Result<(Vec<Sample>, (f64, f64)), ConsoleError> {
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
    let outcome = timeline(c, pose, ex, seconds);
    // The bias is cleared by the drive when it leaves holding; written back here otherwise.
    if c.status()?.mode == Mode::Armed {
        let _ = c.ask(Command::Set(Param::VaBias, 0.0))?;
    }
    let _ = c.ask(Command::Unsubscribe)?;
    c.set(Param::Kc, k_c)?;
    Ok((outcome?, (f64::from(window.0), f64::from(window.1))))
}

/// The excitation's bias writes and moves in its order, from a hold at `pose`.
fn timeline(
    c: &mut Client,
    pose: Vector2<f64>,
    ex: &Excitation,
    seconds: f64,
) -> Result<Vec<Sample>, ConsoleError> {
    let mut frames = to_pose(c, pose)?;
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
                run_move(c, &what, target, timing, &mut frames)?;
            }
        }
    }
    let from = frames.first().map_or(0, |f| f.tick);
    Ok(samples(c, &frames, from))
}

/// The inertia experiment (`flexarm_host::identify::inertia`) on the holding arm: a move to the
/// plan's pose, then its moves one after another, each a `move trapezoid` the drive validates.
/// Returns the record, one sample per telemetry frame; lost frames are refused by the fit.
pub fn inertia(c: &mut Client, plan: &InertiaPlan) -> Result<Vec<Sample>, ConsoleError> {
    holding(c)?;
    let moves = inertia::moves(plan).map_err(|e| ConsoleError::Usage(e.to_string()))?;
    c.subscribe_fastest(1)?;
    let outcome = inertia_moves(c, plan, &moves);
    let _ = c.ask(Command::Unsubscribe)?;
    outcome
}

fn inertia_moves(
    c: &mut Client,
    plan: &InertiaPlan,
    moves: &[inertia::InertiaMove],
) -> Result<Vec<Sample>, ConsoleError> {
    let mut frames = to_pose(c, plan.pose)?;
    for (k, m) in moves.iter().enumerate() {
        let what = format!(
            "move {} of {} of the inertia experiment",
            k + 1,
            moves.len()
        );
        run_move(c, &what, m.target, (m.time, m.ramp()), &mut frames)?;
    }
    frames.extend(interrupt::collect(c, 0.5)?);
    let from = frames.first().map_or(0, |f| f.tick);
    Ok(samples(c, &frames, from))
}

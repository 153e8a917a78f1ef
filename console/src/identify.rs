//! `identify friction`: the simulator's friction experiment (`flexarm_sim::identify`, docs/
//! identification.md) run on the arm over the link: the same constant-speed trapezoids, out and
//! back for each joint from where the arm holds, the same cruise averages (the firmware's torque
//! commands and its estimated angles), the same fit and files.

use std::time::Duration;

use flexarm_core::Vector2;
use flexarm_link::Command;
use flexarm_link::msg::{Mode, Move};
use flexarm_sim::identify::{self, Cruise, Friction};

use crate::client::{Client, ConsoleError};
use crate::{fault_name, interrupt, record};

/// Runs the experiment on the holding arm: every joint's cruises and fits.
pub fn friction(
    c: &mut Client,
    speeds: &[f64],
    cruise: f64,
) -> Result<(Vec<Cruise>, [Friction; 2]), ConsoleError> {
    let s = c.status()?;
    if s.mode != Mode::Armed {
        return Err(ConsoleError::Usage(format!(
            "identify runs on a holding arm (the drive is {:?}): `flexarm arm` first",
            s.mode
        )));
    }
    if speeds.is_empty()
        || speeds
            .iter()
            .any(|v| !(v.is_finite() && *v > 0.0 && *v <= 3.0))
    {
        return Err(ConsoleError::Usage("--speeds: each in (0, 3] rad/s".into()));
    }
    let motor_hz = f64::from(c.hello.motor_hz.max(1));
    c.subscribe_fastest(1)?;
    let model = record::paper_model();
    let mut frames = interrupt::collect(c, 0.0)?;
    let held = frames.last().map_or(Vector2::zeros(), |f| {
        let v = record::values(f);
        Vector2::new(v.reference(0), v.reference(1))
    });
    let mut cruises = Vec::new();
    for joint in 0..2 {
        for &v in speeds {
            for leg in identify::legs(held, joint, v, cruise)
                .map_err(|e| ConsoleError::Usage(e.to_string()))?
            {
                let what = format!("joint {} at {v} rad/s", joint + 1);
                let m = Move::Trapezoid {
                    target: [leg.target.x as f32, leg.target.y as f32],
                    move_time: leg.time as f32,
                    ramp_time: leg.ramp as f32,
                };
                c.done(&what, Command::Move(m))?;
                frames.clear();
                let ended =
                    interrupt::follow_move(c, &what, &mut frames, Some(Duration::from_secs(60)))?;
                if ended.mode != Mode::Armed {
                    return Err(ConsoleError::Unexpected(format!(
                        "{what}: the move ended in {}",
                        ended.fault.map_or("the drive disarmed".into(), |f| format!(
                            "fault {f} ({})",
                            fault_name(f)
                        ))
                    )));
                }
                // The move's start: the last frame before the reference leaves the start pose.
                let start = frames
                    .windows(2)
                    .find(|w| {
                        (record::values(&w[1]).reference(joint) - leg.start[joint]).abs() > 1e-6
                    })
                    .map_or(0, |w| w[0].tick);
                let trace: Vec<_> = frames
                    .iter()
                    .filter(|f| f.tick >= start)
                    .filter_map(|f| record::sample(f, (f.tick - start) as f64 / motor_hz, &model))
                    .collect();
                cruises.push(
                    identify::cruise_of(&trace, joint, leg.window)
                        .map_err(|e| ConsoleError::Unexpected(format!("{what}: {e}")))?,
                );
                println!(
                    "identify: {what}: {:+.4} rad/s, {:+.5} N·m",
                    cruises.last().map_or(0.0, |c| c.speed),
                    cruises.last().map_or(0.0, |c| c.torque)
                );
            }
        }
    }
    let _ = c.ask(Command::Unsubscribe)?;
    let fits =
        identify::fit_joints(&cruises).map_err(|e| ConsoleError::Unexpected(e.to_string()))?;
    Ok((cruises, fits))
}

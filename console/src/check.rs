//! The console's arguments checked before any connection (a closed port, a QEMU not started, an
//! arm not armed): each against the rule the firmware or the core applies to it, from the core
//! itself, not a copy of its numbers: a move's poses against the drive's [`MoveLimits`], its
//! timing against [`Profile::new`], a parameter against its declared range and [`Tuning::set`]. What depends on the
//! board (its held pose, its ceilings, its rates) the firmware checks when it gets the request.

use flexarm_core::Vector2;
use flexarm_core::control::motor::MotorLaw;
use flexarm_core::controller::Controller;
use flexarm_core::drive::{MAX_MOVE_TIME, Mode, MoveLimits};
use flexarm_core::observer_gains::{GAIN_1KHZ, gain};
use flexarm_core::trajectory::{JointTrajectory, Profile};
use flexarm_core::tuning::{Tunable, Tuning};
use flexarm_link::msg::{Move, Param, Waypoint};
use flexarm_machine::session::{self, Home};

use crate::client::ConsoleError;

/// A value as a message shows it (`1e30`, not thirty-one digits).
fn num(v: f32) -> String {
    if v != 0.0 && v.is_finite() && !(1e-4..1e7).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

fn usage(msg: String) -> Result<(), ConsoleError> {
    Err(ConsoleError::Usage(msg))
}

/// `flag value` with `lo ≤ value ≤ hi` [unit] (NaN fails).
pub fn within(flag: &str, value: f64, lo: f64, hi: f64, unit: &str) -> Result<(), ConsoleError> {
    if value >= lo && value <= hi {
        Ok(())
    } else {
        usage(format!("{flag} {value}: give {lo} to {hi} {unit}"))
    }
}

/// `flag value` with `0 < value ≤ hi` [unit] (NaN fails).
pub fn up_to(flag: &str, value: f64, hi: f64, unit: &str) -> Result<(), ConsoleError> {
    if value > 0.0 && value <= hi {
        Ok(())
    } else {
        usage(format!(
            "{flag} {value}: give more than 0, at most {hi} {unit}"
        ))
    }
}

/// `flag value` finite and above 0.
pub fn positive(flag: &str, value: f64, unit: &str) -> Result<(), ConsoleError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        usage(format!("{flag} {value}: give a finite number > 0 {unit}"))
    }
}

/// The first joint (0-based) of `theta` [rad] outside the drive's joint ranges, with the range.
fn outside(theta: [f32; 2]) -> Option<(usize, f32, f32)> {
    let l = MoveLimits::<f32>::default();
    (0..2)
        .map(|j| (j, l.theta_min[j], l.theta_max[j]))
        .find(|&(j, lo, hi)| !(theta[j] >= lo && theta[j] <= hi))
}

/// Joint angles `theta` [rad] (given as `what`) within the drive's joint ranges: a move may
/// end nowhere else.
pub fn pose(what: &str, theta: [f32; 2]) -> Result<(), ConsoleError> {
    match outside(theta) {
        Some((j, lo, hi)) => usage(format!(
            "{what}: θ{} = {} rad is outside the drive's range {lo} to {hi} rad",
            j + 1,
            num(theta[j])
        )),
        None => Ok(()),
    }
}

/// A move's duration and ramps as the drive takes them: `0 < ramp ≤ time / 2`, finite.
fn timing(time_flag: &str, time: f32, ramp: f32) -> Result<(), ConsoleError> {
    if time > MAX_MOVE_TIME {
        return usage(format!(
            "{time_flag} {}: a move lasts at most {MAX_MOVE_TIME} s (the drive refuses longer ones)",
            num(time)
        ));
    }
    match Profile::new(time, ramp) {
        Ok(_) => Ok(()),
        Err(_) => usage(format!(
            "{time_flag} {time} --ramp {ramp}: give finite times with 0 < ramp <= {} / 2 [s]",
            &time_flag[2..]
        )),
    }
}

/// A move as the firmware will check it, in what does not depend on the held pose: a
/// trapezoid's targets within the drive's range and its timing; a circle's centre and radius
/// finite, the radius positive, its timing. A path's points are the waypoint file's
/// ([`crate::waypoints::parse`]).
pub fn movement(m: &Move) -> Result<(), ConsoleError> {
    match *m {
        Move::Trapezoid {
            target,
            move_time,
            ramp_time,
        } => {
            pose(&format!("--to {},{}", target[0], target[1]), target)?;
            timing("--time", move_time, ramp_time)
        }
        Move::Circle {
            centre,
            radius,
            period,
            ramp_time,
            ..
        } => {
            if !(centre.iter().all(|c| c.is_finite())) {
                return usage(format!(
                    "--centre {},{}: give a finite point [m]",
                    centre[0], centre[1]
                ));
            }
            positive("--radius", f64::from(radius), "[m]")?;
            timing("--period", period, ramp_time)
        }
        Move::Waypoints { .. } => Ok(()),
    }
}

/// A path's waypoints as the drive will check them, in what does not depend on the held pose:
/// every point within the joint ranges, every `dt` at least one motor period of the board's
/// 1 kHz loop (a shorter segment ends before the drive samples it), and between two
/// waypoints a mean speed within the drive's speed limit (a segment's peak is higher).
/// Returns the first waypoint (0-based) at fault and why.
pub fn path(points: &[Waypoint]) -> Result<(), (usize, String)> {
    let l = MoveLimits::<f32>::default();
    let shortest = 1.0 / flexarm_host::sim::Rates::default().motor_hz as f32;
    for (i, w) in points.iter().enumerate() {
        if let Some((j, lo, hi)) = outside(w.theta) {
            return Err((
                i,
                format!(
                    "column `theta{}`: {} rad is outside the drive's range {lo} to {hi} rad",
                    j + 1,
                    num(w.theta[j])
                ),
            ));
        }
        if !w.dt.is_finite() || w.dt < shortest {
            return Err((
                i,
                format!(
                    "column `dt`: {} s is shorter than one motor period ({shortest} s)",
                    num(w.dt)
                ),
            ));
        }
        if let Some(before) = i.checked_sub(1).and_then(|b| points.get(b)) {
            for j in 0..2 {
                let speed = (w.theta[j] - before.theta[j]).abs() / w.dt;
                if speed > l.speed_max[j] {
                    return Err((
                        i,
                        format!(
                            "θ{} moves {} rad/s on average from the waypoint before: more than the drive's {} rad/s",
                            j + 1,
                            num(speed),
                            l.speed_max[j]
                        ),
                    ));
                }
            }
        }
    }
    let total: f32 = points.iter().map(|w| w.dt).sum();
    if total > MAX_MOVE_TIME {
        return Err((
            points.len().saturating_sub(1),
            format!(
                "the path lasts {} s: a move lasts at most {MAX_MOVE_TIME} s",
                num(total)
            ),
        ));
    }
    Ok(())
}

/// The value of a `set` as the board judges it at rest, from the parameter's declaration
/// (`flexarm_link::for_each_param!`: its range, its home) and the core's [`Tuning::set`] on the
/// paper's controller at the board's rates with no ceilings (the board applies its own): finite,
/// inside the declared range, and of the sign and size its rule allows. The piezo bias's window
/// is the amplifier's, which the board checks.
pub fn set_value(name: &str, p: Param, value: f32) -> Result<(), ConsoleError> {
    let refused = || {
        usage(format!(
            "set {name} {value}: out of its range or not finite (the rule for `{name}`)"
        ))
    };
    let ((min, max), _) = session::rule(p);
    // Written so that NaN is refused too.
    if !(min..=max).contains(&value) {
        return refused();
    }
    let Home::Tuning(tunable) = session::home(p) else {
        return Ok(());
    };
    // The piezo law and the film's measured numbers: the board designs the law from its own
    // model and refuses what its rule refuses; here only a code that names a law.
    match tunable {
        Tunable::PiezoLaw => {
            return match flexarm_core::control::select::PiezoLawKind::from_code(value) {
                Some(_) => Ok(()),
                None => refused(),
            };
        }
        Tunable::FilmStatic | Tunable::FilmFeedthrough => return Ok(()),
        _ => {}
    }
    let rates = flexarm_host::sim::Rates::default();
    let (piezo, motor) = (1.0 / rates.piezo_hz as f32, 1.0 / rates.motor_hz as f32);
    let mut ctrl = Controller::<f32>::paper(
        MotorLaw::Tracking,
        JointTrajectory::Hold(Vector2::zeros()),
        piezo,
        motor,
        gain(&GAIN_1KHZ),
    );
    let mut tuning = Tuning {
        piezo: Default::default(),
        law: flexarm_core::control::select::PiezoLawKind::Rate,
        film_static: 0.0,
        film_feedthrough: 0.0,
        piezo_period: piezo,
        tau_ceiling: Vector2::repeat(f32::INFINITY),
        v_a_ceiling: f32::INFINITY,
        rate_ceiling: &flexarm_core::tuning::RateCeiling::NONE,
    };
    match tuning.set(&mut ctrl, Mode::Armed, tunable, value) {
        Ok(()) => Ok(()),
        Err(_) => refused(),
    }
}

//! The joints' friction.
//!
//! ## Friction: the experiment
//! Each joint in turn, the other holding, runs trapezoids at constant speeds `v` (default 0.1,
//! 0.2, 0.3 and 0.5 rad/s), out and back, with [`ACCEL`] ramps and a cruise of `cruise` seconds
//! (default 2) after a settling time [`SETTLE`]: the distance follows. Over the cruise the speed
//! is constant, so the joint's torque pays its friction alone: with the other
//! joint at rest, the arm's inertial and centrifugal torques on the moving joint vanish
//! (`b_ii` is constant in `θ_j`, and the Coriolis terms of joint i hold a factor `θ̇_j`). The
//! mean commanded torque over the cruise is one point `(v, τ_f(v))`. The settling and the long
//! cruise are what the link asks: its first mode (1.4 Hz, ζ = 0.07 on the paper's arm) rings
//! after each ramp and its reaction torque on the joint averages out only over whole periods.
//! On the truth plant, with 2 rad/s² ramps, 0.3 s of settling and the cruise 1 rad of motion at
//! 0.8 rad/s left (0.05 s), joint 1's viscous coefficient came out 22 % low; with 1 rad/s²,
//! 1 s and 2 s, within 4.2 % (`cargo test -p flexarm-host --test identify`).
//!
//! ## Friction: the fit
//! `τ_f(v) = F_c sign(v) + F_v v` per joint, Coulomb [N·m] and viscous [N·m·s/rad], by least
//! squares over every cruise of the joint (both directions: one direction alone cannot tell the
//! Coulomb level from a torque offset). The truth plant smooths the Coulomb step as
//! `F_c tanh(v/v_s)` over `v_s` = 0.01 rad/s, which at the slowest speed, 0.1 rad/s, is within
//! 5e-9 of its limit. Units SI; joint frames as in `flexarm_core`.

use flexarm_core::Vector2;
use flexarm_core::trajectory::{JointTrajectory, Profile, Trapezoid};

use super::IdentifyError;
use crate::sim::{Sample, SimConfig, simulate};

/// Time after the accelerating ramp before the cruise is averaged: the link's first mode and
/// the loop's following error settle [s] (module docs).
pub const SETTLE: f64 = 1.0;
/// Ramp acceleration of the experiment's moves [rad/s²].
pub const ACCEL: f64 = 1.0;
/// The experiment's default cruise speeds [rad/s], each both ways.
pub const SPEEDS: [f64; 4] = [0.1, 0.2, 0.3, 0.5];
/// The experiment's default cruise averaged [s].
pub const CRUISE: f64 = 2.0;
/// Where the simulator's experiment starts [rad] (the joints' ranges leave room for its moves).
pub const HELD: [f64; 2] = [-1.2, -1.2];

/// One cruise: a constant-speed stretch of one joint's move.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cruise {
    /// The moving joint, 0 or 1.
    pub joint: usize,
    /// Its mean measured speed [rad/s].
    pub speed: f64,
    /// Its mean torque [N·m].
    pub torque: f64,
    /// Samples averaged.
    pub samples: usize,
}

/// A joint's friction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Friction {
    /// Coulomb level `F_c` [N·m].
    pub coulomb: f64,
    /// Viscous coefficient `F_v` [N·m·s/rad].
    pub viscous: f64,
    /// RMS of the fit's residuals [N·m].
    pub residual: f64,
}

/// One move of the experiment and its cruise window (from the move's start) [s].
pub type Leg = (JointTrajectory<f32>, (f64, f64));

/// One move as a drive takes it: a trapezoid from where the arm holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LegSpec {
    /// Where it starts [rad].
    pub start: Vector2<f64>,
    /// Where it ends [rad].
    pub target: Vector2<f64>,
    /// Its duration [s].
    pub time: f64,
    /// Its ramps [s].
    pub ramp: f64,
    /// The cruise averaged, from the move's start [s].
    pub window: (f64, f64),
}

/// Joint ranges the experiment's moves stay in [rad] (the drive's move limits).
const RANGE: [f64; 2] = [3.0, 2.7];

/// The out-and-back trapezoids of joint `joint` from `held` at cruise speed `speed` [rad/s]
/// with `cruise` seconds averaged; an error when the cruise is under half a second or the move
/// leaves the joint's range.
pub fn legs(
    held: Vector2<f64>,
    joint: usize,
    speed: f64,
    cruise: f64,
) -> Result<[LegSpec; 2], IdentifyError> {
    if !(cruise.is_finite() && cruise >= 0.5) {
        return Err(IdentifyError::Data(format!(
            "a cruise of {cruise} s: give at least 0.5 s (the link's first mode must average out)"
        )));
    }
    let ramp = speed / ACCEL;
    let distance = speed * (SETTLE + cruise + ramp);
    let time = distance / speed + ramp;
    let window = (ramp + SETTLE, time - ramp);
    let end = held[joint] + distance;
    if held[joint].abs() > RANGE[joint] || end.abs() > RANGE[joint] {
        return Err(IdentifyError::Data(format!(
            "joint {} from {:.2} rad at {speed} rad/s for a {cruise} s cruise ends at {end:.2} rad, outside ±{} rad: start lower or ask less",
            joint + 1,
            held[joint],
            RANGE[joint]
        )));
    }
    let mut out = held;
    out[joint] += distance;
    let leg = |start, target| LegSpec {
        start,
        target,
        time,
        ramp,
        window,
    };
    Ok([leg(held, out), leg(out, held)])
}

/// [`legs`] as the trajectories the drive runs, with their cruise windows.
pub fn moves(
    held: Vector2<f64>,
    joint: usize,
    speed: f64,
    cruise: f64,
) -> Result<[Leg; 2], IdentifyError> {
    let [out, back] = legs(held, joint, speed, cruise)?;
    let leg = |l: LegSpec| -> Result<Leg, IdentifyError> {
        let profile = Profile::new(l.time as f32, l.ramp as f32)
            .map_err(|e| IdentifyError::Data(format!("the move at {speed} rad/s: {e:?}")))?;
        let t = Trapezoid {
            start: l.start.cast::<f32>(),
            amplitude: (l.target - l.start).cast::<f32>(),
            profile,
        };
        Ok((JointTrajectory::Trapezoid(t), l.window))
    };
    Ok([leg(out)?, leg(back)?])
}

/// The cruise of `joint` in `trace` over `window` [s]: mean measured speed (from the angle's
/// change) and mean torque.
pub fn cruise_of(
    trace: &[Sample],
    joint: usize,
    window: (f64, f64),
) -> Result<Cruise, IdentifyError> {
    let inside: Vec<&Sample> = trace
        .iter()
        .filter(|s| s.t >= window.0 && s.t <= window.1)
        .collect();
    let (Some(a), Some(b)) = (inside.first(), inside.last()) else {
        return Err(IdentifyError::Data(format!(
            "no sample of joint {} in its cruise {:.2}–{:.2} s",
            joint + 1,
            window.0,
            window.1
        )));
    };
    if inside.len() < 10 || b.t <= a.t {
        return Err(IdentifyError::Data(format!(
            "joint {}'s cruise {:.2}–{:.2} s holds {} samples: too short to average",
            joint + 1,
            window.0,
            window.1,
            inside.len()
        )));
    }
    let torque = inside.iter().map(|s| s.tau[joint]).sum::<f64>() / inside.len() as f64;
    Ok(Cruise {
        joint,
        speed: (b.x.q[joint] - a.x.q[joint]) / (b.t - a.t),
        torque,
        samples: inside.len(),
    })
}

/// `F_c sign(v) + F_v v` by least squares over `cruises` of one joint.
pub fn fit(cruises: &[Cruise]) -> Result<Friction, IdentifyError> {
    let joint = cruises.first().map_or(0, |c| c.joint) + 1;
    let (pos, neg) = (
        cruises.iter().filter(|c| c.speed > 0.0).count(),
        cruises.iter().filter(|c| c.speed < 0.0).count(),
    );
    if pos == 0 || neg == 0 {
        return Err(IdentifyError::Data(format!(
            "joint {joint}: cruises in {} direction only ({pos} forward, {neg} back): the Coulomb level cannot be told from an offset",
            if pos + neg == 0 { "no" } else { "one" }
        )));
    }
    let speeds: Vec<f64> = cruises.iter().map(|c| c.speed.abs()).collect();
    let spread = speeds.iter().copied().fold(0.0, f64::max)
        - speeds.iter().copied().fold(f64::INFINITY, f64::min);
    if spread < 0.05 {
        return Err(IdentifyError::Data(format!(
            "joint {joint}: every cruise at about the same speed: Coulomb and viscous friction cannot be told apart (give speeds at least 0.05 rad/s apart)"
        )));
    }
    // Normal equations of [sign v, v] [F_c, F_v]ᵀ = τ.
    let (mut a11, mut a12, mut a22, mut b1, mut b2) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for c in cruises {
        let s = c.speed.signum();
        a11 += s * s;
        a12 += s * c.speed;
        a22 += c.speed * c.speed;
        b1 += s * c.torque;
        b2 += c.speed * c.torque;
    }
    let det = a11 * a22 - a12 * a12;
    let coulomb = (b1 * a22 - b2 * a12) / det;
    let viscous = (a11 * b2 - a12 * b1) / det;
    let residual = (cruises
        .iter()
        .map(|c| (c.torque - coulomb * c.speed.signum() - viscous * c.speed).powi(2))
        .sum::<f64>()
        / cruises.len() as f64)
        .sqrt();
    Ok(Friction {
        coulomb,
        viscous,
        residual,
    })
}

/// The experiment's speeds must be given, each in (0, 3] rad/s.
pub fn check_speeds(speeds: &[f64]) -> Result<(), IdentifyError> {
    if speeds.is_empty()
        || speeds
            .iter()
            .any(|v| !(v.is_finite() && *v > 0.0 && *v <= 3.0))
    {
        return Err(IdentifyError::Data(
            "speeds must be given, each in (0, 3] rad/s".into(),
        ));
    }
    Ok(())
}

/// The friction experiment on the simulator (`cfg`: its plant, controller and sensors), from
/// rest at `held`: every joint's cruises, `cruise` seconds each, and the experiment's record
/// (its moves one after the other, the angles as the encoders read them: what
/// [`find_cruises`] reads back).
pub fn friction_experiment(
    cfg: &SimConfig,
    held: Vector2<f64>,
    speeds: &[f64],
    cruise: f64,
) -> Result<(Vec<Cruise>, Vec<Sample>), IdentifyError> {
    check_speeds(speeds)?;
    let mut cruises = Vec::new();
    let mut record: Vec<Sample> = Vec::new();
    for joint in 0..2 {
        for &v in speeds {
            for (traj, window) in moves(held, joint, v, cruise)? {
                let run = SimConfig {
                    duration: window.1 + v / ACCEL + 0.2,
                    tail_window: 0.1,
                    ..*cfg
                };
                let (_, trace) = simulate(&run, &traj, true).map_err(|e| {
                    IdentifyError::Sim(format!("joint {} at {v} rad/s: {e}", joint + 1))
                })?;
                cruises.push(cruise_of(&trace, joint, window)?);
                let dt = trace.get(1).map_or(0.0, |s| s.t) - trace[0].t;
                let t0 = record.last().map_or(0.0, |s| s.t + dt) - trace[0].t;
                record.extend(
                    super::encoder_readings(&cfg.sensors, trace)
                        .into_iter()
                        .map(|mut s| {
                            s.t += t0;
                            s
                        }),
                );
            }
        }
    }
    Ok((cruises, record))
}

/// A record's joint speeds are the encoders' central differences over this half-width [s].
const SPEED_SPAN: f64 = 0.25;
/// Share of a move's plateau speed within which it cruises. The difference sees the
/// decelerating ramp a span early and crosses this share `√(4 SPEED_SPAN (1 − PLATEAU) v /
/// ACCEL)` after that (0.24 s at 3 rad/s, the fastest the experiment runs): less than the
/// span and a half the cruise's window ends before that crossing, so it ends on the cruise.
const PLATEAU: f64 = 0.98;
/// The slowest cruise a record's moves are searched for [rad/s].
const SLOWEST: f64 = 0.02;
/// The other joint's speed while a joint cruises, at most, as a share of the cruise's.
const OTHER_STILL: f64 = 0.05;

/// The cruises in a record of constant-speed moves (a board's or the simulator's, any order
/// of joints, speeds and directions): each joint's speed as the encoders' central difference
/// over ±[`SPEED_SPAN`]; a move is a run of one sign above [`SLOWEST`] rad/s, its plateau the
/// median speed of its half above half its peak; its cruise from where the speed first
/// reaches [`PLATEAU`] of the plateau, plus [`SETTLE`], to where it last does, less half the
/// difference's span; kept when at least half a second long with the other joint still (under
/// [`OTHER_STILL`] of the cruise's speed: the arm's coupling torques vanish only then).
/// Refused (gate `excitation`) when a joint has none.
pub fn find_cruises(trace: &[Sample]) -> Result<Vec<Cruise>, IdentifyError> {
    let dt = super::even_period(trace)?;
    let h = ((SPEED_SPAN / dt).round() as usize).max(1);
    let n = trace.len();
    if n <= 2 * h {
        return Err(IdentifyError::Data(format!(
            "gate `record length`: {n} samples: too short for a cruise"
        )));
    }
    let speed = |j: usize| -> Vec<f64> {
        (0..n)
            .map(|k| {
                let (a, b) = (k.saturating_sub(h), (k + h).min(n - 1));
                (trace[b].x.q[j] - trace[a].x.q[j]) / ((b - a) as f64 * dt)
            })
            .collect()
    };
    let v = [speed(0), speed(1)];
    let mut cruises = Vec::new();
    for joint in 0..2 {
        let (mine, other) = (&v[joint], &v[1 - joint]);
        let mut k = 0;
        while k < n {
            if mine[k].abs() <= SLOWEST {
                k += 1;
                continue;
            }
            let sign = mine[k].signum();
            let start = k;
            while k < n && mine[k] * sign > SLOWEST {
                k += 1;
            }
            let run = &mine[start..k];
            let peak = run.iter().map(|x| x.abs()).fold(0.0, f64::max);
            let mut upper: Vec<f64> = run
                .iter()
                .map(|x| x.abs())
                .filter(|x| *x >= 0.5 * peak)
                .collect();
            upper.sort_by(f64::total_cmp);
            let plateau = upper[upper.len() / 2];
            let on = |x: &f64| x.abs() >= PLATEAU * plateau;
            let (Some(a), Some(b)) = (run.iter().position(on), run.iter().rposition(on)) else {
                continue;
            };
            let span = h as f64 * dt;
            let window = (trace[start + a].t + SETTLE, trace[start + b].t - 0.5 * span);
            if window.1 - window.0 < 0.5 {
                continue;
            }
            let inside = (start + a..=start + b)
                .filter(|&i| trace[i].t >= window.0 && trace[i].t <= window.1);
            let still = inside.map(|i| other[i].abs()).fold(0.0, f64::max);
            if still < OTHER_STILL * plateau {
                cruises.push(cruise_of(trace, joint, window)?);
            }
        }
        if !cruises.iter().any(|c| c.joint == joint) {
            return Err(IdentifyError::Data(format!(
                "gate `excitation`: joint {} has no cruise in the record (a move at constant speed of at least {SLOWEST} rad/s, {:.1} s long, the other joint still): record the friction experiment's moves",
                joint + 1,
                SETTLE + 1.5 * SPEED_SPAN + 0.5
            )));
        }
    }
    Ok(cruises)
}

/// The cruises as CSV: `joint,speed_rad_s,torque_Nm,samples`.
pub fn cruises_csv(cruises: &[Cruise]) -> String {
    let mut s = String::from("joint,speed_rad_s,torque_Nm,samples\n");
    for c in cruises {
        s += &format!(
            "{},{:.6},{:.7},{}\n",
            c.joint + 1,
            c.speed,
            c.torque,
            c.samples
        );
    }
    s
}

/// The fits as a `[plant]` fragment the simulator's scenarios read (`viscous`, `coulomb`;
/// host-sim/scenarios/README.md): paste it into a scenario's `[plant]` table.
pub fn plant_fragment(fits: &[Friction; 2]) -> String {
    format!(
        "# Joint friction identified by `cargo sim identify friction` (docs/identification.md):\n\
         # keys of a scenario's [plant] table (kind = \"truth\").\n\
         [plant]\n\
         coulomb = [{:.6}, {:.6}]   # N m\n\
         viscous = [{:.6}, {:.6}]   # N m s/rad\n",
        fits[0].coulomb, fits[1].coulomb, fits[0].viscous, fits[1].viscous
    )
}

/// The report: each joint's fit, against `truth` (Coulomb, viscous per joint) when known.
pub fn friction_report(fits: &[Friction; 2], truth: Option<[(f64, f64); 2]>) -> String {
    let mut s = String::from(
        "| joint | F_c [N·m] | F_v [N·m·s/rad] | residual RMS [N·m] | truth F_c | truth F_v | error F_c | error F_v |\n|---|---|---|---|---|---|---|---|\n",
    );
    for (j, f) in fits.iter().enumerate() {
        let (tc, tv) = truth.map_or((f64::NAN, f64::NAN), |t| t[j]);
        let pct = |x: f64, t: f64| {
            if t.is_finite() && t != 0.0 {
                format!("{:+.1} %", (x / t - 1.0) * 100.0)
            } else {
                "—".into()
            }
        };
        s += &format!(
            "| {} | {:.4} | {:.4} | {:.1e} | {} | {} | {} | {} |\n",
            j + 1,
            f.coulomb,
            f.viscous,
            f.residual,
            if tc.is_finite() {
                format!("{tc}")
            } else {
                "—".into()
            },
            if tv.is_finite() {
                format!("{tv}")
            } else {
                "—".into()
            },
            pct(f.coulomb, tc),
            pct(f.viscous, tv),
        );
    }
    s
}

/// Torque against speed per joint, measured points and fitted lines (SVG).
pub fn friction_figure(
    path: &std::path::Path,
    cruises: &[Cruise],
    fits: &[Friction; 2],
) -> Result<(), Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    let root = SVGBackend::new(path, (900, 420)).into_drawing_area();
    root.fill(&WHITE)?;
    let panels = root.split_evenly((1, 2));
    for (j, area) in panels.iter().enumerate() {
        let mine: Vec<&Cruise> = cruises.iter().filter(|c| c.joint == j).collect();
        let v = mine.iter().map(|c| c.speed.abs()).fold(0.1, f64::max) * 1.1;
        let t = mine.iter().map(|c| c.torque.abs()).fold(1e-3, f64::max) * 1.2;
        let mut chart = ChartBuilder::on(area)
            .caption(format!("joint {}: friction", j + 1), ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(-v..v, -t..t)?;
        chart
            .configure_mesh()
            .x_desc("speed [rad/s]")
            .y_desc("cruise torque [N·m]")
            .draw()?;
        chart.draw_series(
            mine.iter()
                .map(|c| Circle::new((c.speed, c.torque), 4, BLUE.filled())),
        )?;
        let f = fits[j];
        for side in [-1.0, 1.0] {
            let line = (0..=50).map(|k| {
                let s = side * v * f64::from(k) / 50.0;
                (s, f.coulomb * side + f.viscous * s)
            });
            chart.draw_series(LineSeries::new(line, RED.stroke_width(2)))?;
        }
    }
    root.present()?;
    Ok(())
}

/// Writes the friction identification's files into `dir` (an output folder's staging area):
/// `friction.md` (`heading` above the table), `.csv`, `.toml` and, with `plots`, `.svg`.
/// Returns the report.
pub fn save_friction(
    dir: &std::path::Path,
    heading: &str,
    cruises: &[Cruise],
    fits: &[Friction; 2],
    truth: Option<[(f64, f64); 2]>,
    plots: bool,
) -> Result<String, String> {
    let report = format!(
        "# Joint friction\n\n{heading}\n\n{}",
        friction_report(fits, truth)
    );
    let write = |name: &str, text: &str| {
        std::fs::write(dir.join(name), text).map_err(|e| format!("cannot write {name}: {e}"))
    };
    write("friction.md", &report)?;
    write("friction.csv", &cruises_csv(cruises))?;
    write("friction.toml", &plant_fragment(fits))?;
    if plots {
        friction_figure(&dir.join("friction.svg"), cruises, fits)
            .map_err(|e| format!("cannot draw the figure: {e}"))?;
    }
    Ok(report)
}

/// Each joint's fit over its cruises.
pub fn fit_joints(cruises: &[Cruise]) -> Result<[Friction; 2], IdentifyError> {
    let fit_joint = |j: usize| {
        let mine: Vec<Cruise> = cruises.iter().copied().filter(|c| c.joint == j).collect();
        fit(&mine)
    };
    Ok([fit_joint(0)?, fit_joint(1)?])
}

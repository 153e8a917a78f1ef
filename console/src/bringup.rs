//! `bringup`: a guided first power-on of a new arm (docs/console.md, "Bring-up").
//!
//! In order, each check only after the previous passed (a failed one ends the bring-up, with
//! the configuration line to change):
//!
//! 1. **state**: the drive is disarmed or holding, no fault latched.
//! 2. **loop loads**: over half a second of telemetry, each loop's mean load below 50 % and no
//!    deadline missed since boot.
//! 3. **homing** (issue 33): a drive whose joints are neither homed nor declared homes them
//!    (`crate::home`); a failed search ends the bring-up, the drive disarmed.
//! 4. **encoders**, joint 1 then joint 2, under the bring-up torque limit (`--torque`, default
//!    3 N·m, against the firmware's 10) and with the piezo loop off (`k_c = 0`: with a film
//!    that reads inverted, the rate feedback would pump the link's vibration; on the QEMU
//!    arm it drove the patch between its ±200 V limits): the drive arms (holding), then nudges the joint by
//!    `--nudge` rad (default 0.1) in a 1 s trapezoid with 0.25 s ramps while the other holds,
//!    and back. *Direction*: the joint's reading moves by the nudge; an encoder that counts the
//!    other way turns the hold into positive feedback, which the drive's runaway check cuts in
//!    category 0 (`docs/safety.md`) — the joint whose reading moved against its torque is the
//!    reversed one. *Counts per radian*: with a wrong scale `k` (reading = k × angle) the loop
//!    still makes the reading follow the reference, so the joint really moves 1/k as far and
//!    needs 1/k of the torque: the ratio `r` of the torque the nudge took (mean over the
//!    accelerating ramp minus mean over the decelerating one, which cancels friction) to the
//!    model's `2 b_ii a` estimates 1/k. It passes within 0.67–1.5: the model's inertia is not
//!    the arm's before identification, and a scale mistake (quadrature ×4, a gear ratio, 2π) is
//!    a factor of 2 or more.
//! 5. **film**, holding, the piezo loop still off: the patch's voltage stepped by `--bias` V
//!    (default 40) through `va_bias`, for one second. *Sign*: the film's static
//!    response must have the model's sign (`V_a = −k_c V̇_f` damps only then; inverted, the
//!    feedback would pump the vibration). *Gain*: its ratio to the model's static gain
//!    `k_a k_s Σ s_j²/ω_j²` within 0.5–2. The static level is fitted through the film
//!    amplifier's high-pass, whose corner it finds too ([`film_step`]): the settled level alone
//!    reads a tenth of it behind the truth plant's 0.5 Hz corner.
//!
//!    When both pass, the film's measured static gain is written to the board's `film_static`
//!    and its response in the first motor period after the step (over the step) to
//!    `film_feedthrough` (issue 35): what the design rules of the laws beside the paper's (IRC,
//!    PPF, `flexarm_core::control::select`) are built from.
//!
//! The piezo law (issue 35) is off during the checks (`piezo_law off` as well as `k_c = 0`: IRC
//! and PPF do not read `k_c`; changing it disarms a holding drive first). The report ends with
//! the law the board runs and, when it runs none, what commissioning one takes: the hardware
//! board ships the piezo loop off (`flexarm_machine::BoardConfig::for_board`).
//!
//! Whatever happens, the torque limits are written back, `k_c` and the piezo law too unless the
//! film failed (then the piezo loop stays off until it is fixed, `flexarm set kc …` after), and a drive that was
//! disarmed at the start is disarmed again (a latched fault is left latched: it is the safe
//! state, and `clear` is the operator's once the cause is fixed). Angles in rad, torques in N·m,
//! voltages in V, times in s.

use std::time::Duration;

use flexarm_core::Vector4;
use flexarm_core::control::piezo::PiezoPatch;
use flexarm_core::control::select::PiezoLawKind;
use flexarm_link::Command;
use flexarm_link::msg::{Mode, Move, Param, Reply, Status, Telemetry};

use crate::client::{Client, ConsoleError};
use crate::record::{Values, values};
use crate::{fault_name, interrupt};

/// The bring-up's settings.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// Torque limit of both joints during the bring-up [N·m].
    pub torque: f32,
    /// Joint nudge [rad].
    pub nudge: f32,
    /// Piezo voltage step [V].
    pub bias: f32,
}

impl Options {
    /// The settings within what a bring-up may ask of an unknown arm (checked before any
    /// connection too).
    pub fn check(&self) -> Result<(), ConsoleError> {
        if self.torque > 0.0
            && self.torque <= 100.0
            && self.nudge > 0.0
            && self.nudge <= 0.5
            && self.bias.abs() > 0.0
            && self.bias.abs() <= 200.0
        {
            Ok(())
        } else {
            Err(ConsoleError::Usage(
                "bringup takes --torque in (0, 100] N·m, --nudge in (0, 0.5] rad, --bias in (0, 200] V"
                    .into(),
            ))
        }
    }
}

impl Default for Options {
    fn default() -> Self {
        Self {
            torque: 3.0,
            nudge: 0.1,
            bias: 40.0,
        }
    }
}

/// A check's outcome.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Passed.
    Pass,
    /// Failed: the bring-up stopped here.
    Fail,
    /// Not reached.
    NotRun,
}

/// One row of the table.
#[derive(Clone, Debug)]
pub struct Check {
    /// What is checked.
    pub name: &'static str,
    /// The outcome.
    pub verdict: Verdict,
    /// What was measured.
    pub measured: String,
    /// What passes.
    pub expected: String,
    /// What to change when it failed: the configuration line, or the step to take.
    pub fix: String,
}

/// The checks, in the order they run.
pub const CHECKS: [&str; 9] = [
    "state",
    "loop loads",
    "homing",
    "encoder 1 direction",
    "encoder 1 counts/rad",
    "encoder 2 direction",
    "encoder 2 counts/rad",
    "film sign",
    "film gain",
];

/// Where the wiring is configured.
const WIRING: &str = "firmware/src/board.rs, mod wiring";

/// The bring-up's result: every check, run or not.
#[derive(Clone, Debug)]
pub struct Report {
    /// In [`CHECKS`] order.
    pub checks: Vec<Check>,
    /// The piezo law the board runs after the bring-up, and what commissioning one takes.
    pub piezo: String,
}

impl Report {
    fn new() -> Self {
        Self {
            checks: CHECKS
                .iter()
                .map(|&name| Check {
                    name,
                    verdict: Verdict::NotRun,
                    measured: String::new(),
                    expected: String::new(),
                    fix: String::new(),
                })
                .collect(),
            piezo: String::new(),
        }
    }

    /// Records check `name`; `true` when it passed.
    fn record(
        &mut self,
        name: &str,
        pass: bool,
        measured: String,
        expected: &str,
        fix: String,
    ) -> bool {
        if let Some(c) = self.checks.iter_mut().find(|c| c.name == name) {
            c.verdict = if pass { Verdict::Pass } else { Verdict::Fail };
            c.measured = measured;
            c.expected = expected.into();
            c.fix = if pass { String::new() } else { fix };
        }
        pass
    }

    /// The failed check, if any.
    pub fn failed(&self) -> Option<&Check> {
        self.checks.iter().find(|c| c.verdict == Verdict::Fail)
    }

    /// The pass/fail table, then each failure's fix.
    pub fn table(&self) -> String {
        let mut t = format!(
            "{:<22} {:<7} {:<46} {}\n",
            "check", "result", "measured", "passes when"
        );
        for c in &self.checks {
            let v = match c.verdict {
                Verdict::Pass => "pass",
                Verdict::Fail => "FAIL",
                Verdict::NotRun => "not run",
            };
            t += &format!(
                "{:<22} {:<7} {:<46} {}\n",
                c.name, v, c.measured, c.expected
            );
        }
        if let Some(c) = self.failed() {
            t += &format!("fix ({}): {}\n", c.name, c.fix);
        }
        if !self.piezo.is_empty() {
            t += &format!("piezo law: {}\n", self.piezo);
        }
        t
    }
}

/// Runs the bring-up on `c`; the report says what passed. An error is a failure of the line
/// or of the tool, not of a check.
pub fn run(c: &mut Client, o: &Options) -> Result<Report, ConsoleError> {
    o.check()?;
    let mut r = Report::new();
    let s = c.status()?;
    let ok = match (s.mode, s.fault) {
        (Mode::Fault, f) => {
            let name = f.map_or("?".into(), |f| format!("{f} ({})", fault_name(f)));
            r.record(
                "state",
                false,
                format!("fault {name} latched"),
                "disarmed or holding",
                "fix the fault's cause, then `flexarm clear`".into(),
            )
        }
        (Mode::Moving | Mode::Stopping, _) => r.record(
            "state",
            false,
            "a move runs".into(),
            "disarmed or holding",
            "`flexarm stop`, then start again".into(),
        ),
        (m, _) => r.record(
            "state",
            true,
            format!("{m:?}").to_lowercase(),
            "disarmed or holding",
            String::new(),
        ),
    };
    if !ok {
        return Ok(r);
    }
    let was_armed = s.mode == Mode::Armed;
    c.subscribe_fastest(1)?;
    let frames = interrupt::collect(c, 0.5)?;
    let s = c.status()?;
    if !loads(&mut r, &frames, &s) {
        return finish(c, r, None, was_armed);
    }
    let saved = Saved {
        tau_max: [c.get(Param::TauMax0)?, c.get(Param::TauMax1)?],
        k_c: c.get(Param::Kc)?,
        law: c.get(Param::PiezoLaw)?,
    };
    c.set(Param::TauMax0, o.torque.min(saved.tau_max[0]))?;
    c.set(Param::TauMax1, o.torque.min(saved.tau_max[1]))?;
    c.set(Param::Kc, 0.0)?;
    if law_of(saved.law).needs_identification() {
        // The law changes only while the piezo output is off: a holding drive disarms.
        if c.status()?.mode == Mode::Armed {
            c.done("disarm", Command::Disarm)?;
        }
        c.set(Param::PiezoLaw, f32::from(PiezoLawKind::Off.code()))?;
    }
    let outcome = experiments(c, o, &mut r);
    // The experiments' error first; the restore's only when they had none.
    let restored = finish(c, r, Some(saved), was_armed);
    outcome.and(restored)
}

/// What the bring-up changes and writes back.
struct Saved {
    tau_max: [f32; 2],
    k_c: f32,
    /// The piezo law's code.
    law: f32,
}

/// The law a code names (none for a code that names none).
fn law_of(code: f32) -> PiezoLawKind {
    PiezoLawKind::from_code(code).unwrap_or(PiezoLawKind::Off)
}

/// The encoder and film checks (the drive armed from here on).
fn experiments(c: &mut Client, o: &Options, r: &mut Report) -> Result<(), ConsoleError> {
    let model = crate::record::paper_model();
    // Homing first (issue 33): until then the encoders count from the power-up pose and no
    // limit holds in the arm's frame; the drive refuses to arm. A search that fails ends the
    // bring-up here, with the drive disarmed.
    let s = c.status()?;
    let homed = if crate::home::known(&s) {
        Ok(s)
    } else {
        crate::home::home(c)
    };
    let want = "every joint homed or declared";
    match homed {
        Ok(s) => {
            r.record(
                "homing",
                true,
                format!("{:?}", s.homing).to_lowercase(),
                want,
                String::new(),
            );
        }
        Err(e) => {
            r.record(
                "homing",
                false,
                e.to_string(),
                want,
                "the board's homing configuration (the [homing] table of the file the firmware \
                 is generated from, docs/firmware.md: method, angle, search direction) and the \
                 index, end stop or switch it names"
                    .into(),
            );
            return Ok(());
        }
    }
    if c.status()?.mode == Mode::Disarmed {
        c.done("arm", Command::Arm)?;
    }
    for joint in 0..2 {
        if !encoder(c, o, r, joint, &model)? {
            return Ok(());
        }
    }
    film(c, o, r, &model)?;
    Ok(())
}

/// Writes back what was changed (`k_c` only if the film passed or was not reached), and
/// disarms a drive found disarmed (a latched fault stays latched).
fn finish(
    c: &mut Client,
    r: Report,
    saved: Option<Saved>,
    was_armed: bool,
) -> Result<Report, ConsoleError> {
    let _ = c.ask(Command::Unsubscribe)?;
    let s = c.status()?;
    if s.mode == Mode::Armed {
        let _ = c.ask(Command::Set(Param::VaBias, 0.0))?;
    }
    let mut r = r;
    let mut mode = s.mode;
    if let Some(saved) = saved {
        c.set(Param::TauMax0, saved.tau_max[0])?;
        c.set(Param::TauMax1, saved.tau_max[1])?;
        if !r.failed().is_some_and(|f| f.name.starts_with("film")) {
            c.set(Param::Kc, saved.k_c)?;
            let law = law_of(saved.law);
            if law_of(c.get(Param::PiezoLaw)?) != law {
                if mode == Mode::Armed {
                    c.done("disarm", Command::Disarm)?;
                    mode = Mode::Disarmed;
                }
                if let Reply::Refused(why) =
                    c.ask(Command::Set(Param::PiezoLaw, f32::from(law.code())))?
                {
                    r.piezo = format!("{} refused ({}); ", law.name(), crate::client::refusal(why));
                }
                if was_armed {
                    c.done("arm", Command::Arm)?;
                    mode = Mode::Armed;
                }
            }
        }
    }
    if !was_armed && mode == Mode::Armed {
        c.done("disarm", Command::Disarm)?;
    }
    r.piezo += &piezo_summary(c)?;
    Ok(r)
}

/// The law the board runs, and what commissioning one takes when it runs none.
fn piezo_summary(c: &mut Client) -> Result<String, ConsoleError> {
    let law = law_of(c.get(Param::PiezoLaw)?);
    let g0 = c.get(Param::FilmStatic)?;
    let measured = if g0 > 0.0 {
        format!("film_static = {g0:.3e} V/V")
    } else {
        "film_static not measured (0)".into()
    };
    Ok(match law {
        PiezoLawKind::Off => format!(
            "off: no piezo law is commissioned on this arm ({measured}). The hardware board \
             ships the piezo loop off: the paper's rate law at its shipped gain is unstable on a \
             realistic link once the film sees any of the ceramic's strain, and the law the \
             spillover study supports, PPF, needs the film's static gain measured on this arm \
             (docs/results.md, \"The film's feedthrough and the laws that survive it\"). With \
             the film checks passed: `flexarm disarm`, `flexarm set piezo_law ppf`, then a \
             struck-link check (docs/console.md, \"Commissioning the piezo law\")."
        ),
        PiezoLawKind::Rate => format!(
            "rate (Eq. 17, k_c = {} s; {measured}): the paper's law, unstable on a realistic \
             link at the shipped 30 s once the film sees any feedthrough (docs/results.md); \
             PPF is the law the study supports (`flexarm set piezo_law ppf`, disarmed)",
            c.get(Param::Kc)?
        ),
        PiezoLawKind::Irc | PiezoLawKind::Ppf => {
            format!("{} ({measured})", law.name())
        }
    })
}

/// Starts `m` and follows it to its end: the frames meanwhile and a quarter second after, and
/// the status it ended in.
fn follow(c: &mut Client, what: &str, m: Move) -> Result<(Vec<Telemetry>, Status), ConsoleError> {
    c.done(what, Command::Move(m))?;
    let mut frames = Vec::new();
    let ended = interrupt::follow_move(c, what, &mut frames, Some(Duration::from_secs(30)))?;
    if ended.mode != Mode::Fault {
        frames.extend(interrupt::collect(c, 0.25)?);
    }
    Ok((frames, ended))
}

fn mean(x: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = x.fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    if n == 0 { f64::NAN } else { s / n as f64 }
}

/// Check 2.
fn loads(r: &mut Report, frames: &[Telemetry], s: &Status) -> bool {
    let load = |i: usize| mean(frames.iter().map(|f| values(f).load(i)));
    let (piezo, motor) = (load(0), load(1));
    let misses = [s.loads[0].misses, s.loads[1].misses];
    let pass = piezo < 0.5 && motor < 0.5 && misses == [0, 0];
    r.record(
        "loop loads",
        pass,
        format!(
            "piezo {:.2} %, motor {:.2} %; misses {}, {}",
            piezo * 100.0,
            motor * 100.0,
            misses[0],
            misses[1]
        ),
        "each below 50 %, no miss",
        "a loop too slow for its rate: lower PIEZO_HZ (the motor loop runs a tenth of it) in firmware/src/config.rs, or build with a higher optimization".into(),
    )
}

/// Check 3 for `joint` (0 or 1): the nudge out and back. `false` when a check failed.
fn encoder(
    c: &mut Client,
    o: &Options,
    r: &mut Report,
    joint: usize,
    model: &flexarm_core::model::Model<f64>,
) -> Result<bool, ConsoleError> {
    let (direction, scale) = match joint {
        0 => ("encoder 1 direction", "encoder 1 counts/rad"),
        _ => ("encoder 2 direction", "encoder 2 counts/rad"),
    };
    let before = interrupt::collect(c, 0.25)?;
    let Some(last) = before.last() else {
        return Err(ConsoleError::Timeout("telemetry".into()));
    };
    let held = [values(last).reference(0), values(last).reference(1)];
    let mut target = held;
    target[joint] += f64::from(o.nudge);
    let (time, ramp) = (1.0f32, 0.25f32);
    let nudge = Move::Trapezoid {
        target: [target[0] as f32, target[1] as f32],
        move_time: time,
        ramp_time: ramp,
    };
    let (frames, ended) = follow(c, &format!("nudge joint {}", joint + 1), nudge)?;
    let expected = format!("+{:.3} rad", o.nudge);
    if ended.mode == Mode::Fault {
        // The joint whose reading moved against its torque runs away: its encoder is reversed.
        let all: Vec<&Telemetry> = before.iter().chain(&frames).collect();
        let against = |j: usize| -> f64 {
            all.windows(2)
                .map(|w| values(w[0]).tau(j) * (values(w[1]).theta(j) - values(w[0]).theta(j)))
                .sum()
        };
        let k = if against(0) <= against(1) { 0 } else { 1 };
        let f = ended
            .fault
            .map_or("?".into(), |f| format!("{f} ({})", fault_name(f)));
        let name = if k == 0 {
            "encoder 1 direction"
        } else {
            "encoder 2 direction"
        };
        // The other joint's checks did not run.
        let mut flip = [false, false];
        flip[k] = true;
        r.record(
            name,
            false,
            format!("fault {f} nudging joint {}; joint {} moved against its torque", joint + 1, k + 1),
            &expected,
            format!(
                "encoder {} counts the other way: in {WIRING}, flip ENCODER_REVERSED[{k}] (from the default: `pub const ENCODER_REVERSED: [bool; 2] = [{}, {}];`), then `flexarm clear` and bring up again",
                k + 1,
                flip[0],
                flip[1]
            ),
        );
        return Ok(false);
    }
    let moved = frames
        .last()
        .map_or(f64::NAN, |f| values(f).theta(joint) - held[joint]);
    let nudge_rad = f64::from(o.nudge);
    let pass = (moved - nudge_rad).abs() <= 0.2 * nudge_rad;
    let ok = r.record(
        direction,
        pass,
        format!("{moved:+.3} rad"),
        &expected,
        format!(
            "joint {} did not follow the nudge within 20 %: check the encoder's cable and {WIRING}",
            joint + 1
        ),
    );
    if !ok {
        return Ok(false);
    }
    // The move's start: the first frame whose reference has left the held pose.
    let t0 = frames
        .iter()
        .find(|f| (values(f).reference(joint) - held[joint]).abs() > 1e-6)
        .map_or(0, |f| f.tick.saturating_sub(1));
    let motor_hz = f64::from(c.hello.motor_hz);
    let span = |from: f64, to: f64| {
        mean(frames.iter().filter_map(|f| {
            let t = f.tick.saturating_sub(t0) as f64 / motor_hz;
            (t >= from && t < to).then(|| values(f).tau(joint))
        }))
    };
    let (time, ramp) = (f64::from(time), f64::from(ramp));
    let push = span(0.0, ramp) - span(time - ramp, time);
    let a = nudge_rad / (ramp * (time - ramp));
    let t = model.terms(&Vector4::new(held[0], held[1], 0.0, 0.0));
    let b = if joint == 0 { t.b11 } else { t.b22 };
    let ratio = push / (2.0 * b * a);
    let ok = r.record(
        scale,
        (0.67..=1.5).contains(&ratio),
        format!("torque {ratio:.2} × the model's ({push:.3} N·m)"),
        "0.67–1.5 × the model's",
        format!(
            "the reading is about {:.2} × the angle: in {WIRING}, multiply COUNTS_PER_REV[{joint}] by about {:.2} (the likely factor is a whole one: ×4 quadrature, a gear ratio); if the scale is right, the arm's inertia is far from the model's, which the controller's model must then be made to match",
            1.0 / ratio,
            1.0 / ratio,
        ),
    );
    if !ok {
        return Ok(false);
    }
    let back = Move::Trapezoid {
        target: [held[0] as f32, held[1] as f32],
        move_time: time as f32,
        ramp_time: ramp as f32,
    };
    let (_, ended) = follow(c, &format!("joint {} back", joint + 1), back)?;
    if ended.mode == Mode::Fault {
        return Err(ConsoleError::Unexpected(format!(
            "fault {} moving joint {} back",
            ended
                .fault
                .map_or("?".into(), |f| format!("{f} ({})", fault_name(f))),
            joint + 1
        )));
    }
    Ok(true)
}

/// The film's static volts per volt of the patch, joints held (the model: the patch's modal
/// forces `c_a` over the modal stiffness, read by the film).
pub fn film_gain_model(model: &flexarm_core::model::Model<f64>, patch: &PiezoPatch<f64>) -> f64 {
    let (ca, k) = (patch.c_a(), model.modal_stiffness());
    patch.film_voltage(&Vector4::new(0.0, 0.0, ca.x / k.x, ca.y / k.y))
}

/// What a step of the patch's voltage tells of the film (check 4).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilmStep {
    /// The patch's step `V_a` [V].
    pub va: f64,
    /// The film's static gain `G(0)` [V/V], corrected for the film amplifier's high-pass.
    pub gain: f64,
    /// The high-pass's rate `1/τ` the fit found [1/s] (near 0 behind a DC-coupled amplifier).
    pub highpass: f64,
    /// The film's response in the first motor period with the step applied, over the step
    /// [V/V]: the feedthrough and the fast modes' share, before the modes have moved much.
    pub jump: f64,
}

/// The film's answer to a step of the patch's voltage: `base` the frames before it (the
/// settled second half taken as the level), `step` those from the step on, both carrying
/// `V_a` and `V_f`; `motor_hz` the frames' tick rate. `None` without a step or with fewer than
/// ten frames of it.
///
/// A film amplifier that high-passes its reading (a charge amplifier's corner, the truth
/// plant's 0.5 Hz) leaves the settled level of a step near 0 within a second: the level
/// itself reads low. With a first-order high-pass of time constant `τ`, the reading `y` of a
/// film whose response is `x` obeys `ẏ = ẋ − y/τ`, so from the step on
/// `x(t) − x(0⁻) = y(t) + (1/τ) ∫₀ᵗ y`. After the step `x = G V_a` plus the modes' ringing about
/// it, so `y(t) = G V_a − (1/τ) I(t)` plus that ringing, `I` the integral of `y` since the
/// step: linear in the two unknowns `G V_a` and `1/τ`, fitted by least squares over the
/// step's frames. Behind a DC-coupled amplifier the fit gives `1/τ` near 0 and `G V_a` near
/// the settled mean.
pub fn film_step(base: &[Telemetry], step: &[Telemetry], motor_hz: f64) -> Option<FilmStep> {
    let settled =
        |f: &[Telemetry], v: fn(Values) -> f64| mean(f[f.len() / 2..].iter().map(|f| v(values(f))));
    let (base_va, base_vf) = (settled(base, |v| v.v_a()), settled(base, |v| v.v_f()));
    let va = settled(step, |v| v.v_a()) - base_va;
    let first = step
        .iter()
        .position(|f| (values(f).v_a() - base_va).abs() > 0.5 * va.abs())?;
    let frames = &step[first..];
    if frames.len() < 10 || !va.is_normal() {
        return None;
    }
    // y_k and I_k (the trapezoidal integral from the first frame, taken at its middle).
    let t0 = frames[0].tick;
    let (mut integral, mut last) = (0.0, None::<(f64, f64)>);
    let points: Vec<(f64, f64)> = frames
        .iter()
        .map(|f| {
            let (t, y) = ((f.tick - t0) as f64 / motor_hz, values(f).v_f() - base_vf);
            integral += last.map_or(0.0, |(lt, ly)| 0.5 * (y + ly) * (t - lt));
            last = Some((t, y));
            (y, integral)
        })
        .collect();
    // Least squares of y = a − b I.
    let n = points.len() as f64;
    let (sy, si) = points
        .iter()
        .fold((0.0, 0.0), |(sy, si), (y, i)| (sy + y, si + i));
    let (my, mi) = (sy / n, si / n);
    let (sii, siy) = points.iter().fold((0.0, 0.0), |(sii, siy), (y, i)| {
        (sii + (i - mi) * (i - mi), siy + (i - mi) * (y - my))
    });
    let b = if sii > 0.0 { -siy / sii } else { 0.0 };
    let a = my + b * mi;
    Some(FilmStep {
        va,
        gain: a / va,
        highpass: b,
        jump: points[0].0 / va,
    })
}

/// Check 4: the patch's voltage stepped, the film's answer.
fn film(
    c: &mut Client,
    o: &Options,
    r: &mut Report,
    model: &flexarm_core::model::Model<f64>,
) -> Result<(), ConsoleError> {
    let base = interrupt::collect(c, 0.5)?;
    c.set(Param::VaBias, o.bias)?;
    let step = interrupt::collect(c, 1.0)?;
    c.set(Param::VaBias, 0.0)?;
    let Some(s) = film_step(&base, &step, f64::from(c.hello.motor_hz)) else {
        r.record(
            "film sign",
            false,
            "no step of the patch's voltage in the telemetry".into(),
            "the film's answer to the step",
            "the board did not apply `va_bias`: check that the drive holds and the piezo window"
                .into(),
        );
        return Ok(());
    };
    let (measured, va) = (s.gain, s.va);
    let expected = film_gain_model(model, &PiezoPatch::<f64>::paper());
    let ratio = measured / expected;
    // The high-pass named when the fit finds one well above the record's resolution.
    let highpass = if s.highpass > 0.1 {
        format!(
            ", the film amplifier's high-pass τ ≈ {:.2} s taken out",
            1.0 / s.highpass
        )
    } else {
        String::new()
    };
    let text = format!(
        "{:+.2e} V/V ({ratio:+.2} × the model's, V_a step {va:.1} V{highpass})",
        measured
    );
    if !r.record(
        "film sign",
        ratio > 0.0,
        text.clone(),
        &format!("{:+.2e} V/V: the model's sign", expected),
        format!(
            "the film reads inverted (the rate feedback would pump the vibration): in {WIRING}, flip FILM_INVERTED (from the default: `pub const FILM_INVERTED: bool = true;`); k_c is left at 0, the piezo loop off, until then"
        ),
    ) {
        return Ok(());
    }
    if r.record(
        "film gain",
        (0.5..=2.0).contains(&ratio),
        text,
        "0.5–2 × the model's",
        "the film's gain is off: check the charge amplifier's gain and FILM_RANGE (firmware/src/board/hw.rs), and k_s, c_s in firmware/piezo.toml; k_c is left at 0, the piezo loop off, until then".into(),
    ) {
        // What the laws' design rules are built from (issue 35).
        c.set(Param::FilmStatic, measured as f32)?;
        if s.jump.is_finite() && s.jump.abs() <= 1.0 {
            c.set(Param::FilmFeedthrough, s.jump as f32)?;
        }
    }
    Ok(())
}

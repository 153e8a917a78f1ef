//! The modes experiment: the joints held, the patch and the base excited apart, so that the
//! fit ([`super::modal`]) can take the base's motion as an input and find the clamped link's
//! modes.
//!
//! ## The experiment
//! At the pose `(θ1, θ2) = (0, π/2)` rad, the piezo loop off (`k_c = 0`), blocks of
//! [`ModesPlan::block`] seconds alternate: in one the arm holds while the patch's bias steps at
//! random between `±piezo_volts` (a new level every 20 to 120 ms: on a board each is one
//! parameter write, and a drive takes the bias only while holding); in the next the bias is 0
//! while joint 2's reference makes random small moves (`±tap` rad about the pose, 0.15 to
//! 0.5 s each, longer where a drive's acceleration limit asks, the last back to the pose): the
//! servo's torque pulses shake the link's base. The two inputs are then excited apart, and the
//! responses hold across the blocks (the system is the same). The record is the patch's command, the film ADC and both encoders at the motor
//! rate.
//!
//! ## The patch's command between samples
//! The bias changes at a piezo period, between two motor samples: a step shows at the next
//! sample, on average half a period after it happened. Over many steps at random instants the
//! recorded command relates to the applied one by the average of that advance,
//! `E(ω) = (e^{jωT} − 1)/(jωT)` (`T` the record's period), which the fit takes out of the
//! patch's response: at 25 Hz and 1 kHz a phase of 4.5°, at 14 Hz and 100 Hz (the QEMU board)
//! 26°.

use flexarm_core::Vector2;
use flexarm_core::trajectory::JointTrajectory;

use super::IdentifyError;
use crate::sim::{Rng, Sample, SimConfig, simulate_excited};

/// The experiment's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModesPlan {
    /// The held pose [rad]; `θ2 = ±π/2` makes the base one input.
    pub pose: Vector2<f64>,
    /// Length of the record [s].
    pub seconds: f64,
    /// Amplitude of the patch's bias steps [V].
    pub piezo_volts: f64,
    /// Amplitude of joint 2's moves about the pose [rad].
    pub tap: f64,
    /// Length of each block, the patch's or the moves' [s].
    pub block: f64,
    /// Seed of the random steps.
    pub seed: u64,
}

impl Default for ModesPlan {
    /// 60 s at `(0, π/2)` in blocks of 5 s, ±100 V, ±0.05 rad.
    fn default() -> Self {
        Self {
            pose: Vector2::new(0.0, std::f64::consts::FRAC_PI_2),
            seconds: 60.0,
            piezo_volts: 100.0,
            tap: 0.05,
            block: 5.0,
            seed: 7,
        }
    }
}

/// The excitation of a [`ModesPlan`]: the patch's bias steps and joint 2's moves.
#[derive(Clone, Debug, PartialEq)]
pub struct Excitation {
    /// `(from [s], bias [V])`, in order, the first at 0 (0 V through the moves' blocks).
    pub bias: Vec<(f64, f64)>,
    /// `(start [s], trajectory)`, in order, the first at 0: a hold at the pose through the
    /// patch's blocks, trapezoids through the moves'.
    pub moves: Vec<(f64, JointTrajectory<f32>)>,
}

impl Excitation {
    /// The bias at `t` [s].
    pub fn bias_at(&self, t: f64) -> f64 {
        let i = self.bias.partition_point(|(from, _)| *from <= t);
        self.bias[i.saturating_sub(1)].1
    }
}

/// The rest that ends every excitation [s], at most a tenth of the record: the patch at 0 V and
/// the arm held, so the record ends in the free decay its fit's transient term describes,
/// wherever the host's timing over the link put the last block's steps. (The failures of
/// `identify modes` on the QEMU arm first blamed on a step at the record's end, about one run
/// in eight, came from the Welch probe's segment count at some record lengths: `super::modal`,
/// issue 32.)
pub const REST: f64 = 2.0;

/// The random excitation of `plan`: alternate blocks of the patch's steps and of joint 2's
/// moves, then [`REST`] at rest.
pub fn excitation(plan: &ModesPlan) -> Result<Excitation, IdentifyError> {
    let bad = |m: String| Err(IdentifyError::Data(m));
    if !(plan.seconds.is_finite() && plan.seconds > 0.0 && plan.seconds <= 3600.0) {
        return bad(format!("a record of {} s: give 0 to 3600 s", plan.seconds));
    }
    if !(plan.piezo_volts.is_finite() && plan.piezo_volts >= 0.0) {
        return bad(format!(
            "a bias of {} V: give 0 V or more",
            plan.piezo_volts
        ));
    }
    if !(plan.tap.is_finite() && plan.tap >= 0.0 && plan.tap <= 0.2) {
        return bad(format!("moves of {} rad: give 0 to 0.2 rad", plan.tap));
    }
    if !(plan.block.is_finite() && (1.0..=60.0).contains(&plan.block)) {
        return bad(format!("blocks of {} s: give 1 to 60 s", plan.block));
    }
    let mut rng = Rng::new(plan.seed);
    let pose = plan.pose;
    let (mut bias, mut moves) = (Vec::new(), Vec::new());
    let mut t = 0.0;
    let mut patch = true;
    let active = plan.seconds - REST.min(0.1 * plan.seconds);
    while t < active {
        let end = (t + plan.block).min(active);
        if patch {
            moves.push((t, JointTrajectory::Hold(pose.cast::<f32>())));
            while t < end {
                let sign = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
                bias.push((t, sign * plan.piezo_volts));
                t += 0.02 + 0.1 * rng.uniform();
            }
        } else {
            bias.push((t, 0.0));
            let mut from = pose;
            loop {
                let time = 0.15 + 0.35 * rng.uniform();
                let last = t + time + 0.3 >= end;
                let to = if last {
                    pose
                } else {
                    Vector2::new(pose.x, pose.y + plan.tap * (2.0 * rng.uniform() - 1.0))
                };
                let time = if last { 0.3 } else { time }.max(super::least_time(from, to));
                moves.push((t, super::trapezoid(from, to, time)?));
                from = to;
                t += time;
                if last {
                    break;
                }
            }
        }
        patch = !patch;
    }
    // The rest: 0 V, the arm held at the pose where the last block left it.
    bias.push((t, 0.0));
    Ok(Excitation { bias, moves })
}

/// Runs the experiment on the simulator (`cfg`: its plant, controller and sensors; its piezo
/// loop is turned off). The trace's angles are the encoders' readings, as a board records
/// them.
pub fn modes_experiment(cfg: &SimConfig, plan: &ModesPlan) -> Result<Vec<Sample>, IdentifyError> {
    run_excitation(
        cfg,
        &excitation(plan)?,
        plan.seconds,
        "the modes experiment",
    )
}

/// Runs `seconds` of the excitation `ex` on the simulator (`cfg`, its piezo loop off; `what`
/// names the experiment in errors), with the encoders' readings as a board records them.
pub fn run_excitation(
    cfg: &SimConfig,
    ex: &Excitation,
    seconds: f64,
    what: &str,
) -> Result<Vec<Sample>, IdentifyError> {
    let run = SimConfig {
        piezo: None,
        duration: seconds,
        tail_window: seconds.min(1.0),
        ..*cfg
    };
    let (_, trace) = simulate_excited(&run, &ex.moves, &|t| ex.bias_at(t))
        .map_err(|e| IdentifyError::Sim(format!("{what}: {e}")))?;
    Ok(super::encoder_readings(&cfg.sensors, trace))
}

//! Plausibility checks of the measurements and the latch that holds the safe state.
//!
//! Every check that fails trips the [`SafetyLatch`]; from then on the controller commands
//! [`Command::safe`] (zero torque, zero piezo voltage, amplifiers disabled) whatever the laws
//! compute, until an explicit [`SafetyLatch::reset`]. The first fault is kept: later ones do not
//! overwrite the cause.

use crate::Vector2;
use crate::fault::Fault;
use crate::observer::Measurement;
use crate::real::Real;

/// What goes to the amplifiers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Command<T> {
    /// Motor torques [N·m].
    pub tau: Vector2<T>,
    /// Piezo amplifier voltage [V].
    pub v_a: T,
    /// Amplifier enable.
    pub enable: bool,
}

impl<T: Real> Command<T> {
    /// The safe state: zero torque, zero voltage, amplifiers disabled.
    pub fn safe() -> Self {
        Self {
            tau: Vector2::zeros(),
            v_a: T::zero(),
            enable: false,
        }
    }
}

/// Physical ranges of the measurements.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorLimits<T> {
    /// Smallest joint angles [rad].
    pub theta_min: Vector2<T>,
    /// Largest joint angles [rad].
    pub theta_max: Vector2<T>,
    /// Largest joint speed the arm can reach [rad/s]; an encoder moving farther than
    /// `speed_max × period` in one motor period has jumped.
    pub speed_max: T,
    /// The film ADC's input range [V]: a reading must lie strictly inside `±v_f_max`; one on
    /// the rail is saturated and refused.
    pub v_f_max: T,
}

impl<T: Real> Default for SensorLimits<T> {
    /// θ1 ∈ [−π, π], θ2 ∈ [−2.8, 2.8] rad (short of the folded arm's self-collision),
    /// 20 rad/s, film ±10 V.
    fn default() -> Self {
        let pi = T::c(core::f64::consts::PI);
        Self {
            theta_min: Vector2::new(-pi, T::c(-2.8)),
            theta_max: Vector2::new(pi, T::c(2.8)),
            speed_max: T::c(20.0),
            v_f_max: T::c(10.0),
        }
    }
}

impl<T: Real> SensorLimits<T> {
    /// Checks one sample against the ranges and, given the encoder angles of the previous
    /// sample taken `period` [s] earlier, against encoder jumps.
    pub fn check(
        &self,
        y: &Measurement<T>,
        previous: Option<&Vector2<T>>,
        period: T,
    ) -> Result<(), Fault> {
        self.check_step(y, previous, self.speed_max * period)
    }

    /// [`Self::check`] with the largest encoder step of one period, `speed_max × period`
    /// [rad], already computed (the controller computes it once).
    #[inline(always)]
    pub fn check_step(
        &self,
        y: &Measurement<T>,
        previous: Option<&Vector2<T>>,
        step: T,
    ) -> Result<(), Fault> {
        // Written so that NaN fails every comparison: the range test rejects NaN, ±∞ and
        // out-of-range samples at once, and the cause is sorted out on the (rare) fault path.
        let inside = y.theta.x >= self.theta_min.x
            && y.theta.x <= self.theta_max.x
            && y.theta.y >= self.theta_min.y
            && y.theta.y <= self.theta_max.y
            && y.v_f.abs() < self.v_f_max;
        if !inside {
            crate::hint::cold();
            return Err(
                if y.theta.x.finite() && y.theta.y.finite() && y.v_f.finite() {
                    Fault::OutOfRange
                } else {
                    Fault::NonFinite
                },
            );
        }
        if let Some(p) = previous
            && ((y.theta.x - p.x).abs() > step || (y.theta.y - p.y).abs() > step)
        {
            crate::hint::cold();
            return Err(Fault::EncoderJump);
        }
        Ok(())
    }
}

/// The fault latch.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct SafetyLatch {
    fault: Option<Fault>,
}

impl SafetyLatch {
    /// Records `fault` unless one is already latched. Returns `true` if this call tripped it.
    pub fn trip(&mut self, fault: Fault) -> bool {
        if self.fault.is_none() {
            self.fault = Some(fault);
            true
        } else {
            false
        }
    }

    /// The latched fault, if any.
    pub fn fault(&self) -> Option<Fault> {
        self.fault
    }

    /// Clears the latch (an explicit operator action).
    pub fn reset(&mut self) {
        self.fault = None;
    }
}

/// The amplifiers' fault line, debounced. Many amplifiers assert their fault output while
/// disabled, and a PWM-noisy cable glitches it, so the line counts only while the amplifiers
/// are enabled, after a settling time, and only when it stays asserted for `debounce`
/// consecutive samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AmplifierMonitor {
    /// Samples since the last enable (saturating).
    enabled_for: u32,
    /// Consecutive samples with the line asserted.
    asserted_for: u32,
    settle: u32,
    debounce: u32,
}

impl AmplifierMonitor {
    /// Ignores the line for `settle` samples after each enable; trips after `debounce ≥ 1`
    /// consecutive asserted samples.
    pub const fn new(settle: u32, debounce: u32) -> Self {
        Self {
            enabled_for: 0,
            asserted_for: 0,
            settle,
            debounce: if debounce == 0 { 1 } else { debounce },
        }
    }

    /// One sample: whether the amplifiers were enabled, and whether the fault line is
    /// asserted. Returns [`Fault::Amplifier`] once the fault is confirmed.
    pub fn update(&mut self, enabled: bool, asserted: bool) -> Result<(), Fault> {
        if !enabled {
            *self = Self::new(self.settle, self.debounce);
            return Ok(());
        }
        self.enabled_for = self.enabled_for.saturating_add(1);
        self.asserted_for = if asserted && self.enabled_for > self.settle {
            self.asserted_for.saturating_add(1)
        } else {
            0
        };
        if self.asserted_for >= self.debounce {
            Err(Fault::Amplifier)
        } else {
            Ok(())
        }
    }
}

/// Counts motor periods without a fresh sample; trips [`Fault::Stale`] past a limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Staleness {
    missed: u32,
    limit: u32,
}

impl Staleness {
    /// Allows `limit` consecutive periods without a new sample.
    pub fn new(limit: u32) -> Self {
        Self { missed: 0, limit }
    }

    /// Call once per period with whether a new sample arrived.
    pub fn tick(&mut self, fresh: bool) -> Result<(), Fault> {
        self.missed = if fresh {
            0
        } else {
            self.missed.saturating_add(1)
        };
        if self.missed > self.limit {
            crate::hint::cold();
            Err(Fault::Stale)
        } else {
            Ok(())
        }
    }
}

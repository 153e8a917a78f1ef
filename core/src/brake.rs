//! The holding brakes' watch (issue 33, safe brake control): a brake that does not hold.
//!
//! The brake output is engaged whenever the amplifiers are cut (`flexarm_machine::period`),
//! so a disarmed or faulted joint must stay where its brake caught it. After
//! [`crate::motion::MotionLimits::brake_settle_periods`] motor periods with the output engaged
//! (the brake's own engagement and the stop it makes: a spring-applied brake grips within a
//! few tens of milliseconds), the watch takes the encoders' reading as the held pose; a joint
//! whose reading then leaves it by more than [`crate::motion::MotionLimits::brake_travel`] has
//! a brake that does not hold: stuck released (a broken coil driver, a welded relay), a worn
//! lining, or an arm pushed harder than its brake's torque. The watch then stays tripped until
//! [`BrakeWatch::reset`], and the drive latches [`crate::Fault::BrakeSlip`] as soon as no other
//! fault is latched: after a category-0 cut the coast is the case that matters, and the
//! operator sees the brake's fault as the first one is cleared (`Drive::clear` latches it).
//!
//! The reading is the encoders' own (not the arm's frame), so homing does not move the held
//! pose. A board whose joints have no brakes sets `brake_travel` to 0: no watch.
//!
//! Units: rad, motor periods.

use crate::Vector2;
use crate::real::Real;

/// The watch's state (module docs). Twelve bytes in `f32`: the firmware's static RAM is tight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BrakeWatch<T> {
    /// The held pose once settled [rad, the encoders' frame].
    held: Vector2<T>,
    /// [`SLIPPED`] when a joint left the held pose (sticky until [`BrakeWatch::reset`]), and
    /// below it the consecutive motor periods with the brake output engaged, counted up to
    /// the settling time and one more once the pose is held.
    state: u32,
}

/// [`BrakeWatch::state`]'s sticky slip bit.
const SLIPPED: u32 = 1 << 31;

impl<T: Real> Default for BrakeWatch<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real> BrakeWatch<T> {
    /// Nothing held yet, nothing seen.
    pub fn new() -> Self {
        Self {
            held: Vector2::zeros(),
            state: 0,
        }
    }

    /// One motor period: `engaged` the brake output this period, `theta` the encoders'
    /// reading [rad]; after `settle` engaged periods a joint may move at most `travel` [rad]
    /// (0: no brakes, no watch). Returns whether a brake has slipped (sticky).
    #[inline]
    pub fn update(&mut self, engaged: bool, theta: Vector2<T>, settle: u32, travel: T) -> bool {
        let settle = settle.min(SLIPPED - 2);
        let slipped = self.state & SLIPPED;
        let periods = self.state & !SLIPPED;
        self.state = if !engaged || travel <= T::zero() {
            slipped
        } else if periods < settle {
            slipped | (periods + 1)
        } else if periods == settle {
            // Settled: the pose the brake holds.
            self.held = theta;
            slipped | (settle + 1)
        } else {
            let moved = theta - self.held;
            if moved.x.abs() > travel || moved.y.abs() > travel {
                // A new excursion is measured from here.
                self.held = theta;
                SLIPPED | periods
            } else {
                self.state
            }
        };
        self.slipped()
    }

    /// Whether a brake has slipped since the last [`Self::reset`].
    pub fn slipped(&self) -> bool {
        self.state & SLIPPED != 0
    }

    /// Forgets the slip and the held pose (the operator cleared the brake's fault): the watch
    /// starts again from the pose the brake holds now.
    pub fn reset(&mut self) {
        *self = Self::new();
    }
}

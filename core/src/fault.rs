//! Faults and the safe state.
//!
//! Every fault maps to the same safe state: zero motor torque, zero piezo voltage, amplifiers
//! disabled. The controller latches the first fault until an explicit reset.

/// Why the controller went to the safe state.
///
/// The codes start at 1 so that "no fault" (`Option::<Fault>::None`) is the zero byte: the
/// loops' test of the latch is one load and one compare-with-zero branch.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fault {
    /// A measurement was NaN or infinite.
    NonFinite = 1,
    /// A measurement was outside its physical range.
    OutOfRange,
    /// No new sample arrived in time.
    Stale,
    /// An encoder moved farther in one sample than the arm can.
    EncoderJump,
    /// The previous run ended in a watchdog reset.
    Watchdog,
    /// A control task overran its period.
    Overrun,
    /// An amplifier reported a fault.
    Amplifier,
    /// The configuration failed validation.
    InvalidConfig,
    /// The inertia matrix could not be factored (non-finite state).
    Singular,
    /// The crystal or the PLL did not start, or the clock security system saw the crystal
    /// stop: the chip runs on its internal oscillator (through the PLL at 168 MHz if it locks),
    /// whose tolerance is not the crystal's.
    Clock,
    /// The brown-out reset is off in the option bytes: a sagging supply could run the chip
    /// outside its specification with the amplifiers on.
    BrownOutDisabled,
    /// A joint is farther from its reference than the following-error limit (`crate::motion`).
    FollowingError,
    /// A joint runs away: fast, off its reference and moving against its torque (a reversed or
    /// slipped encoder).
    Runaway,
    /// An encoder's reading stood still under a torque that moves the joint (a pulled cable, or
    /// a joint stalled hard).
    FrozenEncoder,
    /// The observer's joint speed exceeds the overspeed limit.
    Overspeed,
    /// A joint came within its stopping distance of the end of its range.
    SoftLimit,
    /// A motor's I²t thermal state reached its limit.
    Overload,
    /// A joint moved while its holding brake was engaged (`crate::brake`): the brake does
    /// not hold.
    BrakeSlip,
    /// A homed joint's index or limit switch was seen where its encoder says the joint is not
    /// (`crate::homing`): a coupling that slipped, or counts lost.
    ReferenceMismatch,
}

impl Fault {
    /// Every fault, in the order of their stable numbers (1, 2, …).
    pub const ALL: [Fault; 19] = [
        Self::NonFinite,
        Self::OutOfRange,
        Self::Stale,
        Self::EncoderJump,
        Self::Watchdog,
        Self::Overrun,
        Self::Amplifier,
        Self::InvalidConfig,
        Self::Singular,
        Self::Clock,
        Self::BrownOutDisabled,
        Self::FollowingError,
        Self::Runaway,
        Self::FrozenEncoder,
        Self::Overspeed,
        Self::SoftLimit,
        Self::Overload,
        Self::BrakeSlip,
        Self::ReferenceMismatch,
    ];

    /// The fault of stable number `code` (`fault as u8`, what the command link reports).
    pub fn from_code(code: u8) -> Option<Self> {
        usize::from(code)
            .checked_sub(1)
            .and_then(|i| Self::ALL.get(i))
            .copied()
    }

    /// The stop category (IEC 60204-1) the drive applies: 0, the safe state at once; 1, a
    /// controlled stop, then the safe state (`crate::motion`). Only a fault whose sensors can
    /// still be trusted to brake with is stopped in category 1.
    pub fn stop_category(self) -> u8 {
        match self {
            Self::SoftLimit | Self::Overload => 1,
            _ => 0,
        }
    }

    /// A short, stable name for logs and telemetry.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::NonFinite => "non-finite measurement",
            Self::OutOfRange => "measurement out of range",
            Self::Stale => "stale measurement",
            Self::EncoderJump => "encoder jump",
            Self::Watchdog => "watchdog reset",
            Self::Overrun => "control task overrun",
            Self::Amplifier => "amplifier fault",
            Self::InvalidConfig => "invalid configuration",
            Self::Singular => "inertia matrix not positive definite",
            Self::Clock => "clock failure (crystal or PLL)",
            Self::BrownOutDisabled => "brown-out reset disabled in the option bytes",
            Self::FollowingError => "following error",
            Self::Runaway => "joint runaway (reversed or slipped encoder)",
            Self::FrozenEncoder => "frozen encoder or stalled joint",
            Self::Overspeed => "overspeed",
            Self::SoftLimit => "joint at the end of its range",
            Self::Overload => "motor overload (I2t)",
            Self::BrakeSlip => "holding brake slip (a joint moved while braked)",
            Self::ReferenceMismatch => {
                "joint reference off its angle (a slipped encoder coupling or lost counts)"
            }
        }
    }
}

impl core::fmt::Display for Fault {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}

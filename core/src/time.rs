//! The time base: an integer count of motor periods, and move-local time.
//!
//! A controller stays powered for days or weeks, so time is never kept as a float that grows
//! with uptime: `f32` has a spacing of 0.5 ms from about 1.1 hours on and of a whole 1 ms motor
//! period from about 2.3 hours, and a `u32` count of 1 kHz periods wraps after 49.7 days.
//!
//! - [`Ticks`]: motor periods since boot, `u64` (5.8e8 years at 1 kHz). The firmware's motor
//!   loop counts them; every task that needs time reads this count.
//! - [`MoveClock`]: the tick at which a move started. The trajectory is sampled at the move's
//!   own time `t − t_start` [s], computed from the integer difference of two tick counts, so a
//!   move started on day 30 (or across the counter's wrap) is sampled at exactly the same `f32`
//!   instants as one started at boot. After a move ends its reference holds the end pose for
//!   any later time, so holding does not depend on how long ago the move started.

/// Motor periods since boot.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Ticks(pub u64);

impl Ticks {
    /// The next period's count. Wraps (after 5.8e8 years at 1 kHz), which [`MoveClock`]
    /// handles like any other difference.
    #[must_use]
    pub const fn next(self) -> Self {
        Self(self.0.wrapping_add(1))
    }
}

/// The clock of one move: its start tick and the tick rate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MoveClock {
    start: Ticks,
    /// Tick period as a rate [Hz] (the motor loop's).
    rate_hz: u32,
}

impl MoveClock {
    /// A move that starts at `start`, on a clock of `rate_hz` ticks per second.
    pub const fn new(start: Ticks, rate_hz: u32) -> Self {
        Self { start, rate_hz }
    }

    /// The tick at which the move started.
    pub const fn start(&self) -> Ticks {
        self.start
    }

    /// The clock's rate [Hz].
    pub const fn rate_hz(&self) -> u32 {
        self.rate_hz
    }

    /// Periods since the start, `now − start` (wrapping, so a move that runs across the
    /// counter's wrap counts on), saturated to `u32::MAX`: 49.7 days at 1 kHz, past the end of
    /// any move, where the reference no longer depends on time.
    pub const fn elapsed(&self, now: Ticks) -> u32 {
        let n = now.0.wrapping_sub(self.start.0);
        // The mutant the wrap tests must reject (feature `mutant-wrap-jump`, never in a
        // product build): a time base that jumps half a second forward once the count has
        // wrapped since the start.
        #[cfg(feature = "mutant-wrap-jump")]
        let n = if now.0 < self.start.0 {
            n.wrapping_add(self.rate_hz as u64 / 2)
        } else {
            n
        };
        if n > u32::MAX as u64 {
            u32::MAX
        } else {
            n as u32
        }
    }

    /// Move-local time `t − t_start = elapsed / rate` [s]: a `u32 → f32` conversion and one
    /// division, the same bits for the same elapsed count whatever the start.
    pub fn local_time(&self, now: Ticks) -> f32 {
        self.elapsed(now) as f32 / self.rate_hz as f32
    }
}

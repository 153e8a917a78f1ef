//! Execution time and deadline misses of each periodic task, kept in atomics so that any task
//! can read them without a lock.
//!
//! Times are counts of the free-running clock ([`crate::clock`]): under QEMU with
//! `-icount shift=0` TIM5 advances one count per executed instruction; on hardware the DWT
//! cycle counter counts core cycles.

use core::sync::atomic::{AtomicU32, Ordering::Relaxed};

/// Statistics of one task.
pub struct TaskStats {
    runs: AtomicU32,
    total: AtomicU32,
    max: AtomicU32,
    misses: AtomicU32,
    /// The mean of the last window.
    last_mean: AtomicU32,
    /// The longest run since reset.
    worst: AtomicU32,
}

impl TaskStats {
    /// Zeroed statistics.
    pub const fn new() -> Self {
        Self {
            runs: AtomicU32::new(0),
            total: AtomicU32::new(0),
            max: AtomicU32::new(0),
            misses: AtomicU32::new(0),
            last_mean: AtomicU32::new(0),
            worst: AtomicU32::new(0),
        }
    }

    /// Records one run that took `counts` clock counts; `missed` if its next period had
    /// already begun when it finished.
    pub fn record(&self, counts: u32, missed: bool) {
        self.runs.fetch_add(1, Relaxed);
        self.total.fetch_add(counts, Relaxed);
        self.max.fetch_max(counts, Relaxed);
        self.worst.fetch_max(counts, Relaxed);
        if missed {
            // Saturating: a count that never wraps back to a small number.
            let _ = self
                .misses
                .fetch_update(Relaxed, Relaxed, |m| Some(m.saturating_add(1)));
        }
    }

    /// `(runs, mean, max)` since the last call, then starts a new window (so the sum never
    /// overflows on a long run).
    pub fn take_window(&self) -> (u32, u32, u32) {
        let runs = self.runs.swap(0, Relaxed);
        let mean = self.total.swap(0, Relaxed).checked_div(runs).unwrap_or(0);
        self.last_mean.store(mean, Relaxed);
        (runs, mean, self.max.swap(0, Relaxed))
    }

    /// The mean run of the last window [clock counts].
    pub fn mean(&self) -> u32 {
        self.last_mean.load(Relaxed)
    }

    /// The longest run since reset [clock counts].
    pub fn worst(&self) -> u32 {
        self.worst.load(Relaxed)
    }

    /// Deadline misses since reset.
    pub fn misses(&self) -> u32 {
        self.misses.load(Relaxed)
    }
}

/// The piezo loop.
pub static PIEZO: TaskStats = TaskStats::new();
/// The motor loop.
pub static MOTOR: TaskStats = TaskStats::new();

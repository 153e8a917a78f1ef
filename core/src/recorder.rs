//! The fault recorder: the motor loop's recent samples in a fixed ring, frozen when a fault
//! latches, so that what the arm did before the fault can be read out afterwards (the link's
//! `faults`). No heap: the capacity is a type parameter; a board picks it and the decimation
//! to hold at least the last second (`docs/link.md` states the sizes). Units as in the
//! telemetry: rad, √kg·m, N·m, V; `tick` in motor periods (`crate::time`).

use crate::fault::Fault;

/// One recorded motor period.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sample {
    /// Motor period.
    pub tick: u64,
    /// Measured joint angles [rad].
    pub theta: [f32; 2],
    /// Tracking errors θ − θ_d [rad] (0 while disarmed).
    pub error: [f32; 2],
    /// Estimated modal coordinates δ̂ [√kg·m].
    pub delta: [f32; 2],
    /// Torque commands [N·m].
    pub tau: [f32; 2],
    /// Film voltage [V].
    pub v_f: f32,
}

/// The last `N` samples before a fault.
#[derive(Clone, Debug)]
pub struct Recorder<const N: usize> {
    ring: [Sample; N],
    /// Index of the next write.
    next: usize,
    /// Samples held (≤ N).
    len: usize,
    /// The fault that froze it.
    frozen: Option<Fault>,
}

impl<const N: usize> Default for Recorder<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Recorder<N> {
    /// An empty recorder.
    pub const fn new() -> Self {
        Self {
            ring: [Sample {
                tick: 0,
                theta: [0.0; 2],
                error: [0.0; 2],
                delta: [0.0; 2],
                tau: [0.0; 2],
                v_f: 0.0,
            }; N],
            next: 0,
            len: 0,
            frozen: None,
        }
    }

    /// Records `s` unless frozen; `fault` (the controller's latch after the step) freezes the
    /// recorder with `s` as its last sample.
    pub fn record(&mut self, s: &Sample, fault: Option<Fault>) {
        if self.frozen.is_some() || N == 0 {
            return;
        }
        if let Some(slot) = self.ring.get_mut(self.next) {
            *slot = *s;
        }
        self.next = (self.next + 1) % N;
        self.len = (self.len + 1).min(N);
        self.frozen = fault;
    }

    /// The fault that froze it, if any.
    pub fn fault(&self) -> Option<Fault> {
        self.frozen
    }

    /// Samples held.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether it holds nothing.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Sample `i`, oldest first.
    pub fn get(&self, i: usize) -> Option<&Sample> {
        if i >= self.len {
            return None;
        }
        self.ring.get((self.next + N - self.len + i) % N)
    }

    /// Starts recording again, empty (after the fault was cleared).
    pub fn restart(&mut self) {
        self.next = 0;
        self.len = 0;
        self.frozen = None;
    }
}

//! The fault recorder: the motor loop's recent samples in a fixed ring, frozen when a fault
//! latches, so that what the arm did before the fault can be read out afterwards (the link's
//! `faults`). No heap: the capacity is a type parameter; a board picks it and the decimation
//! to hold at least the last second (`docs/link.md` states the sizes). Units as in the
//! telemetry: rad, √kg·m, N·m, V; `tick` in motor periods (`crate::time`).
//!
//! The recorder survives a reset (`crate::retained`): when it freezes it is sealed with a magic
//! number and a checksum of its words ([`Recorder::freeze`]), and after the reset
//! [`Recorder::restore`] keeps a sealed recorder whose checksum matches and empties any other.
//! Every field is an integer or a float, so any bit pattern of its RAM is a value: a firmware
//! keeps it in RAM that its start-up does not zero.

use crate::fault::Fault;
use crate::retained::{checksum, checksum_step};

/// The seal of a frozen recorder ("FRZN").
pub const SEAL_MAGIC: u32 = 0x4652_5a4e;

/// One recorded motor period. Packed to 4-byte alignment: 44 bytes, not the 48 that the `u64`'s
/// alignment would pad it to (2 KB of the boards' recorder of 500; a field is read by value,
/// `{ s.tick }` where a reference would be taken).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, packed(4))]
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
    /// The code of the fault that froze it (`Fault as u8`), 0 while it records.
    frozen: u8,
    /// [`SEAL_MAGIC`] while frozen and sealed, 0 otherwise.
    seal: u32,
    /// The checksum of the recorder's words when it was sealed.
    checksum: u32,
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
            frozen: 0,
            seal: 0,
            checksum: 0,
        }
    }

    /// Records `s` unless frozen; `fault` (the controller's latch after the step) freezes the
    /// recorder with `s` as its last sample.
    pub fn record(&mut self, s: &Sample, fault: Option<Fault>) {
        if self.frozen != 0 || N == 0 {
            return;
        }
        if let Some(slot) = self.ring.get_mut(self.next) {
            *slot = *s;
        }
        self.next = (self.next + 1) % N;
        self.len = (self.len + 1).min(N);
        if let Some(f) = fault {
            self.freeze(f);
        }
    }

    /// Freezes the recorder with `fault` as its cause, unless it is frozen already (the first
    /// cause is kept), and seals it: the magic number and the checksum of its words, so that it
    /// survives a reset ([`Self::restore`]). What an emergency path calls before the reset it
    /// ends in; [`Self::record`] calls it when a fault latches. Sealing reads every word of the
    /// ring once (about 5500 for 500 samples).
    #[inline(never)]
    pub fn freeze(&mut self, fault: Fault) {
        if self.frozen == 0 {
            self.frozen = fault as u8;
        }
        self.checksum = self.sum();
        self.seal = SEAL_MAGIC;
    }

    /// After a reset: keeps the recorder if it is sealed, its indices and fault are in range and
    /// its checksum matches (frozen, with the pre-reset fault and samples: returns `true`);
    /// otherwise empties it and returns `false` (RAM after a power cycle, a recorder that was
    /// still recording, a write torn by the reset).
    #[inline(never)]
    pub fn restore(&mut self) -> bool {
        let valid = self.seal == SEAL_MAGIC
            && self.next < N
            && self.len <= N
            && Fault::from_code(self.frozen).is_some()
            && self.checksum == self.sum();
        if !valid {
            self.restart();
        }
        valid
    }

    /// Whether it is sealed: frozen, with the checksum of its words (it survives a reset).
    pub fn sealed(&self) -> bool {
        self.seal == SEAL_MAGIC
    }

    /// The checksum of the recorder's words: its indices, its fault and every sample's fields.
    /// (One copy in a firmware's flash: the motor loop, the supervisor, the emergency paths
    /// and the start-up call it.)
    #[inline(never)]
    fn sum(&self) -> u32 {
        let mut h = checksum([self.next as u32, self.len as u32, u32::from(self.frozen)]);
        for s in &self.ring {
            let words = [
                s.tick as u32,
                (s.tick >> 32) as u32,
                s.theta[0].to_bits(),
                s.theta[1].to_bits(),
                s.error[0].to_bits(),
                s.error[1].to_bits(),
                s.delta[0].to_bits(),
                s.delta[1].to_bits(),
                s.tau[0].to_bits(),
                s.tau[1].to_bits(),
                s.v_f.to_bits(),
            ];
            for w in words {
                h = checksum_step(h, w);
            }
        }
        h
    }

    /// The fault that froze it, if any.
    pub fn fault(&self) -> Option<Fault> {
        Fault::from_code(self.frozen)
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
        self.seal = 0;
        self.next = 0;
        self.len = 0;
        self.frozen = 0;
    }
}

/// The seal against RAM that changed under it (the fields are private: these tests write them
/// as a reset or a power cycle would).
#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    fn frozen() -> Recorder<8> {
        let mut r = Recorder::<8>::new();
        for t in 0..11 {
            let s = Sample {
                tick: t,
                theta: [t as f32, -(t as f32)],
                tau: [0.5, 1.5],
                ..Sample::default()
            };
            r.record(&s, (t == 10).then_some(Fault::Overrun));
        }
        r
    }

    fn ticks(r: &Recorder<8>) -> [u64; 8] {
        core::array::from_fn(|i| r.get(i).map_or(u64::MAX, |s| s.tick))
    }

    #[test]
    fn a_sealed_recorder_is_restored_whole() {
        let mut r = frozen();
        assert!(r.sealed());
        let before = ticks(&r);
        assert!(r.restore());
        assert_eq!(r.fault(), Some(Fault::Overrun));
        assert_eq!(ticks(&r), before);
        assert_eq!(before, [3, 4, 5, 6, 7, 8, 9, 10]);
    }

    #[test]
    fn a_changed_word_empties_it() {
        // One bit of one sample, of the indices, of the fault: each is caught.
        let edits: [fn(&mut Recorder<8>); 4] = [
            |r| r.ring[2].tau[1] = f32::from_bits(r.ring[2].tau[1].to_bits() ^ 1),
            |r| r.ring[7].tick ^= 1 << 40,
            |r| r.len -= 1,
            |r| r.frozen = Fault::Amplifier as u8,
        ];
        for edit in edits {
            let mut r = frozen();
            edit(&mut r);
            assert!(!r.restore());
            assert!(r.is_empty() && r.fault().is_none() && !r.sealed());
        }
    }

    #[test]
    fn a_recorder_still_recording_or_torn_while_sealing_is_emptied() {
        // Still recording at the reset: never sealed.
        let mut r = Recorder::<8>::new();
        r.record(&Sample::default(), None);
        assert!(!r.restore() && r.is_empty());
        // The reset came between the checksum and the seal (`freeze` writes them in that
        // order): the fault is written, the seal is not.
        let mut r = frozen();
        r.seal = 0;
        assert!(!r.restore() && r.is_empty());
        // The reset came between the fault's write and the checksum's: the checksum is the
        // previous seal's (here none).
        let mut r = frozen();
        r.checksum = 0;
        assert!(!r.restore() && r.fault().is_none());
    }

    #[test]
    fn random_ram_is_emptied_without_panicking() {
        // What RAM holds after a power cycle: any bits (a simple generator's).
        let mut x: u32 = 0x1234_5678;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x
        };
        for _ in 0..200 {
            let mut r = frozen();
            for s in r.ring.iter_mut() {
                s.tick = u64::from(next()) << 32 | u64::from(next());
                s.v_f = f32::from_bits(next());
            }
            r.next = next() as usize;
            r.len = next() as usize;
            r.frozen = next() as u8;
            r.checksum = next();
            if next() & 1 == 1 {
                r.seal = SEAL_MAGIC;
            }
            assert!(!r.restore());
            assert!(r.is_empty() && r.get(0).is_none() && r.fault().is_none());
            r.record(&Sample::default(), None);
            assert_eq!(r.len(), 1);
        }
    }

    #[test]
    fn a_cleared_recorder_is_unsealed() {
        let mut r = frozen();
        r.restart();
        assert!(!r.sealed() && !r.restore());
    }
}

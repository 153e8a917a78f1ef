//! State that survives a reset: what a board keeps in RAM that its start-up does not zero, and
//! how it knows after the reset whether that RAM still holds what it wrote.
//!
//! Two stores, each with a magic number and a checksum:
//! - the fault recorder ([`crate::recorder::Recorder`]), sealed when it freezes (the fault, or
//!   an emergency path before the reset it ends in): after the reset a sealed recorder whose
//!   checksum matches is kept, frozen, with the pre-reset fault and its samples; any other is
//!   emptied;
//! - the motors' I²t state ([`HeatStore`]), written every motor period: after the reset the
//!   stored heat, or, when the store is not valid (a power cycle, which loses the RAM, or a
//!   reset in the middle of the write), the motors assumed hot
//!   (`crate::motion::Thermal::assumed_hot`).
//!
//! Both are plain integers and floats, so any bit pattern is a value: a firmware may keep them
//! in RAM that nothing initializes (`docs/firmware.md`, "What survives a reset"). The checksum
//! is FNV-1a over the stores' 32-bit words ([`checksum`]): a few instructions a word, so that
//! sealing the 22 KB recorder fits in a motor period and an emergency handler; it is there to
//! tell random or torn RAM from a finished write, not to resist an adversary.

use crate::Vector2;

/// FNV-1a's offset basis.
const FNV_OFFSET: u32 = 0x811c_9dc5;
/// FNV-1a's prime.
const FNV_PRIME: u32 = 0x0100_0193;

/// The checksum of a sequence of words: FNV-1a, one word at a time.
pub fn checksum(words: impl IntoIterator<Item = u32>) -> u32 {
    words.into_iter().fold(FNV_OFFSET, checksum_step)
}

/// One word `w` more into the checksum `h` so far ([`checksum`] of the words before it).
#[inline(always)]
pub fn checksum_step(h: u32, w: u32) -> u32 {
    (h ^ w).wrapping_mul(FNV_PRIME)
}

/// The heat store's magic number ("HEAT").
pub const HEAT_MAGIC: u32 = 0x4845_4154;

/// The motors' I²t states as RAM holds them across a reset: the raw words, written every motor
/// period by [`HeatStore::store`] in the order magic, heat, checksum.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
pub struct HeatStore {
    /// [`HEAT_MAGIC`] once written.
    pub magic: u32,
    /// The two motors' I²t states [units of the continuous rating], as `f32` bits.
    pub heat: [u32; 2],
    /// [`checksum`] of the three words above.
    pub checksum: u32,
}

impl Default for HeatStore {
    fn default() -> Self {
        Self::invalid()
    }
}

impl HeatStore {
    /// A store that holds nothing (what zeroed RAM holds).
    pub const fn invalid() -> Self {
        Self {
            magic: 0,
            heat: [0; 2],
            checksum: 0,
        }
    }

    /// The checksum the store's words should carry.
    fn sum(&self) -> u32 {
        checksum([self.magic, self.heat[0], self.heat[1]])
    }

    /// Writes `heat` (every motor period).
    pub fn store(&mut self, heat: Vector2<f32>) {
        self.magic = HEAT_MAGIC;
        self.heat = [heat.x.to_bits(), heat.y.to_bits()];
        self.checksum = self.sum();
    }

    /// The stored heat, if the store is valid: the magic number, the checksum, and both states
    /// finite and within `[0, max]` (`max`: the largest state the torque limit can drive a motor
    /// to, `(τ_max/τ_c)²`). `None` otherwise: the caller assumes the motors hot.
    pub fn load(&self, max: f32) -> Option<Vector2<f32>> {
        if self.magic != HEAT_MAGIC || self.checksum != self.sum() {
            return None;
        }
        let heat = Vector2::new(f32::from_bits(self.heat[0]), f32::from_bits(self.heat[1]));
        let plausible = |h: f32| h.is_finite() && (0.0..=max).contains(&h);
        (plausible(heat.x) && plausible(heat.y)).then_some(heat)
    }
}

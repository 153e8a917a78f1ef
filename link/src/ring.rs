//! The reader of a circular receive buffer that a DMA stream fills (issue 34: the hardware
//! board's USART1 receives into one): which bytes are new since the last read, where they wrap,
//! and which the DMA overwrote before they were read, all from the stream's observed position.
//! Pure, `no_std`, no panics: the firmware supplies the position (its registers) and the
//! buffer; the host tests (`link/tests/ring.rs`) supply a simulated DMA.
//!
//! ## Positions
//! A DMA stream in circular mode counts down its remaining transfers (NDTR) from `N` to 1 and
//! reloads `N`; the index it writes next is `N − remaining`. That index alone cannot tell a lap
//! from none, so the stream's half-transfer and transfer-complete events (one at each half of
//! the buffer) are counted by their interrupt: `halves`. A [`Position`] is `halves`, read
//! first, then `remaining`. The count may lag the index by one event: the event's interrupt is
//! still pending, or ran between the two reads. The index then lies in the other half than
//! `halves` says, and [`DmaRing::written`] counts the event itself; a count two events behind
//! (a full lap without the interrupt: interrupts masked for more than a lap) reads as a lap
//! less, and the reader resynchronizes and counts a lap lost ([`DmaRing::read`]).
//!
//! ## Overtaken bytes
//! The byte written `k`-th sits in slot `k mod N` until the DMA writes the `(k + N)`-th. A byte
//! is counted lost when the DMA may have written over it before it was copied out: when, at an
//! observation made after the copy, the DMA had written `N − 1` or more bytes since it (one
//! byte of guard for a write under way while the position was read). Every byte the DMA wrote
//! is either delivered once, in order, intact, or counted lost.

use core::sync::atomic::{AtomicU8, Ordering::Acquire, Ordering::Relaxed, fence};

/// One observation of the DMA stream: the half-buffer events counted so far (wrapping), read
/// before `remaining`, the stream's NDTR.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Position {
    /// Half-transfer and transfer-complete events counted by their interrupt (wrapping).
    pub halves: u32,
    /// The stream's remaining transfers (NDTR): `N` down to 1, then `N` again.
    pub remaining: u16,
}

/// The bytes one [`DmaRing::read`] copied out, with the losses found before them.
#[derive(Clone, Copy, Debug)]
pub struct Chunk<const C: usize> {
    bytes: [u8; C],
    start: usize,
    end: usize,
    /// Bytes lost before [`Self::bytes`]: overwritten by the DMA before they were copied.
    pub lost: u32,
}

impl<const C: usize> Chunk<C> {
    /// The intact bytes, in the order they were received.
    pub fn bytes(&self) -> &[u8] {
        self.bytes.get(self.start..self.end).unwrap_or(&[])
    }

    /// Nothing delivered and nothing lost: the reader has caught up with the DMA.
    pub fn is_empty(&self) -> bool {
        self.start >= self.end && self.lost == 0
    }
}

/// The reader of an `N`-byte circular DMA buffer (`N` a power of two from 4 to 32768: NDTR is
/// 16 bits, and the absolute counts wrap at 2³², a multiple of `N`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DmaRing<const N: usize> {
    /// Bytes read or counted lost since the stream started (wrapping at 2³²).
    read: u32,
}

impl<const N: usize> Default for DmaRing<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> DmaRing<N> {
    /// Checked at compile time: `N` is a power of two that NDTR can hold.
    const VALID: () = assert!(N.is_power_of_two() && N >= 4 && N <= 32768);
    /// Bytes a reader can be behind and still read the oldest intact: `N` less the guard byte.
    pub const CAPACITY: u32 = N as u32 - 1;

    /// A reader for a stream started at index 0 with its event count at 0.
    pub const fn new() -> Self {
        let () = Self::VALID;
        Self { read: 0 }
    }

    /// A reader that has read everything up to `at` (a stream observed running).
    pub fn at(at: Position) -> Self {
        let () = Self::VALID;
        Self {
            read: Self::written(at),
        }
    }

    /// Bytes read or counted lost so far (wrapping at 2³²).
    pub fn consumed(&self) -> u32 {
        self.read
    }

    /// Bytes the DMA has written since the stream started (wrapping at 2³²), from one
    /// observation: `halves` completed by the one event that the index shows is not counted
    /// yet, if any (module docs). `remaining` 0 (the instant of the reload) is index 0 of the
    /// next lap; a value above `N`, which the stream cannot hold, reads as index 0 too.
    pub fn written(at: Position) -> u32 {
        let n = N as u32;
        let index = n.saturating_sub(u32::from(at.remaining)) % n;
        let upper = index >= n / 2;
        let halves = if upper == (at.halves % 2 == 1) {
            at.halves
        } else {
            at.halves.wrapping_add(1)
        };
        (halves / 2).wrapping_mul(n).wrapping_add(index)
    }

    /// Copies out up to `C` new bytes of `buffer` (not past its end: the next read continues
    /// at its start), observing the stream with `position` before and after the copy, and
    /// advances past them. Bytes the DMA overtook are skipped and counted in [`Chunk::lost`],
    /// those before the copy and those it overwrote during the copy alike. An observation
    /// behind the reader (the event count a lap short) resynchronizes the reader at it and
    /// counts `N` bytes lost, at least a lap's worth. Empty when the reader has caught up.
    pub fn read<const C: usize>(
        &mut self,
        buffer: &[AtomicU8; N],
        mut position: impl FnMut() -> Position,
    ) -> Chunk<C> {
        let mut chunk = Chunk {
            bytes: [0; C],
            start: 0,
            end: 0,
            lost: 0,
        };
        let written = Self::written(position());
        // The copy's loads after the first observation's, and (below) before the second's: an
        // acquire fence orders the reads before it ahead of everything after it.
        fence(Acquire);
        let behind = written.wrapping_sub(self.read);
        if behind > u32::MAX / 2 {
            self.read = written;
            chunk.lost = N as u32;
            return chunk;
        }
        if behind > Self::CAPACITY {
            chunk.lost = behind - Self::CAPACITY;
            self.read = written.wrapping_sub(Self::CAPACITY);
        }
        let index = self.read as usize % N;
        let len = (written.wrapping_sub(self.read) as usize)
            .min(C)
            .min(N - index);
        for (slot, b) in chunk
            .bytes
            .iter_mut()
            .zip(buffer.iter().skip(index))
            .take(len)
        {
            *slot = b.load(Relaxed);
        }
        fence(Acquire);
        // What the DMA wrote over while the bytes were copied: the leading bytes that it had
        // come within the guard of by the second observation.
        let after = Self::written(position()).wrapping_sub(self.read);
        let overwritten = if after > u32::MAX / 2 {
            len
        } else {
            (after.saturating_sub(Self::CAPACITY) as usize).min(len)
        };
        chunk.lost = chunk.lost.saturating_add(overwritten as u32);
        chunk.start = overwritten;
        chunk.end = len;
        self.read = self.read.wrapping_add(len as u32);
        chunk
    }
}

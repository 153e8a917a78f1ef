//! The DMA ring reader (`flexarm_link::ring`) against a simulated DMA stream: every byte the
//! stream writes is delivered once, in order and intact, or counted lost; nothing else. The
//! stream writes between the reader's observations and during its copy (overtaking it), its
//! event count lags by the interrupt that has not run yet, and its counts wrap at 2³².

use core::sync::atomic::{AtomicU8, Ordering::Relaxed};

use flexarm_link::ring::{Chunk, DmaRing, Position};

/// A small deterministic generator (xorshift64*), seeded per case.
struct Rng(u64);

impl Rng {
    fn new(seed: u64) -> Self {
        Self(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: u64) -> u64 {
        if n == 0 { 0 } else { self.next() % n }
    }
}

/// The value of the `k`-th byte: a slot's next value (`k + N`) always differs from it (the
/// lap's term steps by 37, odd, so a slot's value repeats only after 256 laps).
fn value<const N: usize>(k: u64) -> u8 {
    ((k / N as u64) * 37 + (k % N as u64) * 5 + 11) as u8
}

/// The simulated stream: writes a circular buffer in order; its true byte count; the
/// interrupt's count of half-buffer events lags the truth by `lag` events.
struct Dma<'a, const N: usize> {
    buffer: &'a [AtomicU8; N],
    written: u64,
    lag: u64,
}

impl<'a, const N: usize> Dma<'a, N> {
    /// A stream that has written `written` bytes (the last lap's are in the buffer).
    fn new(buffer: &'a [AtomicU8; N], written: u64) -> Self {
        let start = written.saturating_sub(N as u64);
        let mut dma = Self {
            buffer,
            written: start,
            lag: 0,
        };
        dma.write(written - start);
        dma
    }
    fn write(&mut self, n: u64) {
        for _ in 0..n {
            let slot = (self.written % N as u64) as usize;
            self.buffer[slot].store(value::<N>(self.written), Relaxed);
            self.written += 1;
        }
    }
    /// What the firmware reads: the interrupt's event count (lagging by `lag`, never below
    /// zero), then NDTR (`N` down to 1).
    fn position(&self) -> Position {
        let halves = (self.written / (N as u64 / 2)).saturating_sub(self.lag);
        Position {
            halves: halves as u32,
            remaining: (N as u64 - self.written % N as u64) as u16,
        }
    }
}

/// The bookkeeping of the reader's output: the true index of the next byte to account for.
struct Check<const N: usize> {
    next: u64,
    delivered: u64,
    lost: u64,
}

impl<const N: usize> Check<N> {
    fn new(next: u64) -> Self {
        Self {
            next,
            delivered: 0,
            lost: 0,
        }
    }
    /// Lost bytes come before the chunk's bytes; each byte delivered is the next one, intact.
    fn take<const C: usize>(&mut self, chunk: &Chunk<C>) {
        self.next += u64::from(chunk.lost);
        self.lost += u64::from(chunk.lost);
        for &b in chunk.bytes() {
            assert_eq!(
                b,
                value::<N>(self.next),
                "byte {} delivered damaged or out of order",
                self.next
            );
            self.next += 1;
            self.delivered += 1;
        }
    }
}

/// One read: the stream writes `writes[0]` bytes before the reader's first observation,
/// `writes[1]` right after it (into the copy), `writes[2]` before the second observation; the
/// event count lags by one at the observations `lag` marks. The chunk, checked.
fn read_once<const N: usize, const C: usize>(
    dma: &mut Dma<'_, N>,
    ring: &mut DmaRing<N>,
    check: &mut Check<N>,
    writes: [u64; 3],
    lag: [bool; 2],
) -> Chunk<C> {
    dma.write(writes[0]);
    let buffer = dma.buffer;
    let mut call = 0;
    let chunk = ring.read::<C>(buffer, || {
        let p = if call == 0 {
            dma.lag = u64::from(lag[0]);
            let p = dma.position();
            dma.write(writes[1]);
            p
        } else {
            dma.write(writes[2]);
            dma.lag = u64::from(lag[1]);
            dma.position()
        };
        call += 1;
        p
    });
    assert_eq!(
        call, 2,
        "a read observes the stream before and after its copy"
    );
    check.take(&chunk);
    chunk
}

/// Reads until the reader has caught up with a stream that stopped: everything accounted.
fn drain<const N: usize, const C: usize>(
    dma: &mut Dma<'_, N>,
    ring: &mut DmaRing<N>,
    check: &mut Check<N>,
) {
    for _ in 0..=(N / C.min(N) + 2) {
        if read_once::<N, C>(dma, ring, check, [0; 3], [false; 2]).is_empty() {
            break;
        }
    }
    assert_eq!(
        check.next, dma.written,
        "every byte delivered or counted lost"
    );
    assert_eq!(ring.consumed(), dma.written as u32);
}

/// The position arithmetic alone: for every byte count over several laps, with the event
/// count exact or one event behind, and across the 2³² wrap of the event count.
#[test]
fn written_counts_every_byte_with_the_pending_event() {
    fn check<const N: usize>(base: u64) {
        let buffer: [AtomicU8; N] = core::array::from_fn(|_| AtomicU8::new(0));
        let mut dma = Dma::<N>::new(&buffer, base);
        for _ in 0..(6 * N) {
            for lag in [0, 1] {
                dma.lag = lag;
                assert_eq!(
                    DmaRing::<N>::written(dma.position()),
                    dma.written as u32,
                    "N = {N}, {} bytes written, event count {lag} behind",
                    dma.written
                );
            }
            dma.write(1);
        }
    }
    for base in [
        0,
        1,
        3,
        5,
        (1u64 << 32) - 10,
        (1u64 << 33) - 7,
        (1u64 << 40) + 3,
    ] {
        check::<4>(base + 4);
        check::<8>(base + 8);
        check::<64>(base + 64);
        check::<512>(base + 512);
    }
    // NDTR at 0 (the instant of the reload) and above N, which the stream cannot hold.
    for halves in [0u32, 1, 2, 3, u32::MAX] {
        let w = DmaRing::<8>::written(Position {
            halves,
            remaining: 0,
        });
        assert_eq!(w % 8, 0);
        let w = DmaRing::<8>::written(Position {
            halves,
            remaining: 9,
        });
        assert_eq!(w % 8, 0);
    }
}

/// Exhaustive on a small buffer: every start offset over two laps, every backlog up to three
/// laps, every overwrite during the copy up to a lap, every lag of the event count at either
/// observation, several chunk sizes; then drained.
#[test]
fn every_small_case_delivers_or_counts_each_byte() {
    fn all<const C: usize>() {
        const N: usize = 8;
        let mut cases = 0u32;
        for start in (N as u64)..(3 * N as u64) {
            for backlog in 0..(3 * N as u64) {
                for during in 0..=(N as u64) {
                    for after in [0, 1, N as u64] {
                        for lag in [[false, false], [true, false], [false, true], [true, true]] {
                            let buffer: [AtomicU8; N] = core::array::from_fn(|_| AtomicU8::new(0));
                            let mut dma = Dma::<N>::new(&buffer, start);
                            let mut ring = DmaRing::<N>::at(dma.position());
                            let mut check = Check::<N>::new(start);
                            read_once::<N, C>(
                                &mut dma,
                                &mut ring,
                                &mut check,
                                [backlog, during, after],
                                lag,
                            );
                            drain::<N, C>(&mut dma, &mut ring, &mut check);
                            // Nothing lost that was never at risk: a backlog within the
                            // capacity, not overwritten during the copy, is all delivered.
                            if backlog + during + after <= DmaRing::<N>::CAPACITY as u64 {
                                assert_eq!(check.lost, 0, "start {start} backlog {backlog}");
                            }
                            cases += 1;
                        }
                    }
                }
            }
        }
        assert!(cases > 10_000);
    }
    all::<1>();
    all::<3>();
    all::<8>();
    all::<32>();
}

/// Seeded random streams: bursts from nothing to three laps between reads, writes into the
/// copy, lagging event counts, counts starting near the 2³² wrap; every byte accounted for,
/// and a reader that keeps up loses nothing.
#[test]
fn random_streams_deliver_or_count_every_byte() {
    fn run<const N: usize, const C: usize>(seed: u64, start: u64, fast: bool) -> (u64, u64) {
        let mut rng = Rng::new(seed);
        let buffer: [AtomicU8; N] = core::array::from_fn(|_| AtomicU8::new(0));
        let mut dma = Dma::<N>::new(&buffer, start);
        let mut ring = DmaRing::<N>::at(dma.position());
        let mut check = Check::<N>::new(start);
        for _ in 0..2000 {
            let writes = if fast {
                // A reader that keeps up: under a chunk's worth between its observations.
                let n = (C as u64).min(N as u64 / 4);
                [rng.below(n), 0, rng.below(2)]
            } else {
                match rng.below(4) {
                    0 => [0, 0, 0],
                    1 => [rng.below(N as u64), rng.below(4), rng.below(4)],
                    2 => [
                        rng.below(3 * N as u64),
                        rng.below(N as u64),
                        rng.below(N as u64),
                    ],
                    _ => [rng.below(8), rng.below(8), 0],
                }
            };
            let lag = [rng.below(2) == 1, rng.below(2) == 1];
            read_once::<N, C>(&mut dma, &mut ring, &mut check, writes, lag);
        }
        drain::<N, C>(&mut dma, &mut ring, &mut check);
        assert_eq!(check.delivered + check.lost, dma.written - start);
        (check.delivered, check.lost)
    }
    let near_wrap = [
        0,
        (1u64 << 32) - 3000,
        (1u64 << 33) - 5000,
        (1u64 << 32) * 1000 + 17,
    ];
    let mut overtaken = 0;
    for seed in 0..40u64 {
        let start = near_wrap[seed as usize % near_wrap.len()] + 512;
        let (_, lost) = run::<512, 32>(seed, start, false);
        overtaken += lost;
        run::<64, 16>(seed, start, false);
        run::<16, 5>(seed, start, false);
        run::<4, 1>(seed, start, false);
        let (delivered, lost) = run::<512, 32>(seed, start, true);
        assert_eq!(lost, 0, "seed {seed}: a reader that keeps up lost bytes");
        assert!(delivered > 0);
        let (_, lost) = run::<64, 16>(seed, start, true);
        assert_eq!(lost, 0);
    }
    assert!(overtaken > 0, "the slow streams must overtake the reader");
}

/// The event count a lap short (its interrupt masked for more than a lap): the reader finds
/// the stream behind it, counts a lap lost, resynchronizes, and reads intact bytes after.
#[test]
fn a_lap_missed_by_the_event_count_is_counted_and_survived() {
    const N: usize = 16;
    let buffer: [AtomicU8; N] = core::array::from_fn(|_| AtomicU8::new(0));
    let mut dma = Dma::<N>::new(&buffer, 5 * N as u64 + 3);
    let mut ring = DmaRing::<N>::at(dma.position());
    let mut check = Check::<N>::new(dma.written);
    read_once::<N, 32>(&mut dma, &mut ring, &mut check, [4, 0, 0], [false; 2]);
    // From here on the interrupt's count stays two events (a lap) short.
    dma.write(2);
    let buffer = dma.buffer;
    let missed = |d: &Dma<'_, N>| Position {
        halves: ((d.written / (N as u64 / 2)) - 2) as u32,
        remaining: d.position().remaining,
    };
    let p = missed(&dma);
    let chunk = ring.read::<32>(buffer, || p);
    assert!(chunk.bytes().is_empty());
    assert_eq!(chunk.lost, N as u32, "a lap counted lost");
    // The reader now counts a lap behind the truth, consistently: what follows is intact.
    for burst in [3u64, 7, 1, 9] {
        dma.write(burst);
        let p = missed(&dma);
        let mut got = Vec::new();
        for _ in 0..3 {
            let chunk = ring.read::<32>(buffer, || p);
            assert_eq!(chunk.lost, 0);
            got.extend_from_slice(chunk.bytes());
        }
        let want: Vec<u8> = (dma.written - burst..dma.written).map(value::<N>).collect();
        assert_eq!(got, want);
    }
}

//! The command link's transport: USART1 carries the frames of `flexarm-link`. The idle task
//! decodes the received bytes and answers through the session (`flexarm_machine::session`), and
//! streams the telemetry the host subscribed to. Everything on the link runs below the control
//! loops, so nothing on it can delay them.
//!
//! How bytes arrive differs by board:
//! - hardware: DMA2 stream 2 (channel 4, USART1_RX) writes them into a circular buffer
//!   ([`dma`]); no interrupt per byte. The idle task reads the new bytes with
//!   `flexarm_link::ring::DmaRing` each time it wakes: after the line-event interrupt (the line
//!   idle after a frame, or a line error) and after every control-loop interrupt (the piezo
//!   loop's 10 kHz: a continuous stream, which raises no idle event, is polled at least every
//!   100 µs). The stream's half-buffer events are counted by their own interrupt, above the
//!   control loops; the line errors (overrun, framing, noise) by the line-event interrupt.
//! - QEMU: its USART has no DMA model; the receive interrupt moves each byte from the data
//!   register into a queue ([`RxQueue`]), which the idle task empties.
//!
//! Hardware board: USART1 on PB6 (TX) and PB7 (RX) (the board configures the pins), 921 600
//! baud (`flexarm_machine::session::BAUD`), 8N1. QEMU board: the same USART, exposed by QEMU as
//! a TCP socket (`scripts/qemu-link`).

use flexarm_link::msg::DeviceMsgRef;
use flexarm_machine::session::BAUD;
use stm32f4::stm32f405::USART1;

/// Bytes received and not yet decoded: the QEMU board's queue, the hardware board's DMA
/// buffer. The idle task takes at most this many at a time before it serves the telemetry.
pub const RX_CAPACITY: usize = 512;
/// The queue between the QEMU board's receive interrupt and the idle task.
#[cfg(feature = "qemu")]
pub type RxQueue = heapless::spsc::Queue<u8, RX_CAPACITY>;

/// USART1's transmit side (the idle task's), with its frame encoder.
pub struct Serial {
    usart: USART1,
    encoder: flexarm_link::Encoder,
}

/// USART1's receive side (the QEMU board's receive interrupt's; the hardware board's receive
/// interrupt has none: its bytes come by DMA).
#[cfg_attr(feature = "hw", allow(dead_code))]
pub struct Receiver;

/// What one read of the receiver found (QEMU board) (RM0090 §30.6.1: the flags belong to the byte in DR;
/// reading SR then DR clears them).
#[cfg(feature = "qemu")]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Received {
    /// A good byte.
    Byte(u8),
    /// A good byte, after one or more bytes lost because DR was not read in time (ORE).
    AfterOverrun(u8),
    /// A byte with a framing or parity error (FE, PE), dropped: the frame's CRC refuses the
    /// frame it belonged to.
    Framing,
    /// A byte with noise (NF), dropped likewise.
    Noise,
}

#[cfg(feature = "qemu")]
impl Receiver {
    /// What the data register holds, if a byte arrived (the read clears the interrupt).
    pub fn read(&mut self) -> Option<Received> {
        // SAFETY: the receiver only reads SR and DR; the transmitter ([`Serial`]) only reads
        // SR and writes DR. Reading SR has no side effect; reading DR clears RXNE and ORE,
        // which only the receiver does.
        let usart = unsafe { &*USART1::ptr() };
        let sr = usart.sr().read();
        if sr.rxne().bit_is_clear() && sr.ore().bit_is_clear() {
            return None;
        }
        let byte = usart.dr().read().dr().bits() as u8;
        Some(if sr.fe().bit_is_set() || sr.pe().bit_is_set() {
            Received::Framing
        } else if sr.nf().bit_is_set() {
            Received::Noise
        } else if sr.ore().bit_is_set() {
            Received::AfterOverrun(byte)
        } else {
            Received::Byte(byte)
        })
    }
}

impl Serial {
    /// Enables USART1 at [`BAUD`] (from the 84 MHz APB2 clock on hardware; QEMU ignores the
    /// rate): on the QEMU board with its receive interrupt; on the hardware board with its
    /// receive DMA ([`dma::start`], started first) and the line-event interrupt (idle line,
    /// and the errors: CR3 EIE, which raises it on ORE, FE and NF while DMAR is set).
    pub fn new(usart: USART1, rcc: &stm32f4::stm32f405::RCC) -> Self {
        rcc.apb2enr().modify(|_, w| w.usart1en().set_bit());
        // 84 MHz / 921 600 = 91.1: 0.1 % fast, well inside a UART's tolerance.
        let brr = ((84_000_000 + BAUD / 2) / BAUD) as u16;
        // SAFETY: BRR takes any 16-bit divider; 91 is within it.
        usart.brr().write(|w| unsafe { w.bits(brr) });
        #[cfg(feature = "hw")]
        usart
            .cr3()
            .write(|w| w.dmar().set_bit().dmat().set_bit().eie().set_bit());
        usart.cr1().write(|w| {
            let w = w.ue().set_bit().te().set_bit().re().set_bit();
            #[cfg(feature = "hw")]
            let w = w.idleie().set_bit();
            #[cfg(feature = "qemu")]
            let w = w.rxneie().set_bit();
            w
        });
        Self {
            usart,
            encoder: flexarm_link::Encoder::new(),
        }
    }
}

/// Sends `bytes`, waiting for the transmit register (idle task only; the QEMU board's: the
/// hardware board's transmitter is a DMA stream, [`dma::transmit`]).
#[cfg_attr(feature = "hw", allow(dead_code))]
fn write_all(usart: &USART1, bytes: &[u8]) {
    for b in bytes {
        while usart.sr().read().txe().bit_is_clear() {}
        // SAFETY: DR takes any 9-bit value; a byte is within it.
        usart.dr().write(|w| unsafe { w.dr().bits(u16::from(*b)) });
    }
}

/// What a frame that did not decode had wrong, for the log.
pub fn frame_error(e: flexarm_link::FrameError) -> &'static str {
    use flexarm_link::FrameError as E;
    match e {
        E::TooLarge => "too large",
        E::Oversized => "oversized",
        E::Cobs => "bad COBS",
        E::Truncated => "truncated",
        E::Crc => "bad CRC",
        E::Malformed => "malformed",
    }
}

/// Encodes and sends one message (the encoder's buffers are the [`Serial`]'s, not the stack's).
#[inline(never)]
pub fn send(serial: &mut Serial, msg: &DeviceMsgRef<'_>) -> bool {
    let Serial { usart, encoder } = serial;
    // The hardware board's DMA may still be reading the encoder's buffer: the last frame first.
    #[cfg(feature = "hw")]
    dma::transmitted();
    match encoder.device(msg) {
        Ok(frame) => {
            #[cfg(feature = "qemu")]
            write_all(usart, frame);
            #[cfg(feature = "hw")]
            {
                let _ = usart;
                dma::transmit(frame);
            }
            true
        }
        Err(_) => false,
    }
}

/// The hardware board's receive DMA: DMA2 stream 2, channel 4 (USART1_RX; RM0090 table 43),
/// circular over [`RX_BUFFER`], its half-transfer and transfer-complete events counted in
/// [`RX_HALVES`], and USART1's line events. The idle task reads the buffer with [`Ring`].
#[cfg(feature = "hw")]
pub mod dma {
    use core::sync::atomic::{AtomicU8, AtomicU32, Ordering};

    use flexarm_link::ring::{DmaRing, Position};
    use stm32f4::stm32f405::{DMA2, RCC, USART1};

    use super::RX_CAPACITY;

    /// The stream the DMA writes: USART1's received bytes, in order, circularly. Atomics so the
    /// idle task reads what the DMA writes without `unsafe` (a byte load each, `LDRB`).
    pub static RX_BUFFER: [AtomicU8; RX_CAPACITY] = [const { AtomicU8::new(0) }; RX_CAPACITY];
    /// The stream's half-buffer events (half transfer, transfer complete), counted by
    /// [`count_halves`] (wrapping).
    pub static RX_HALVES: AtomicU32 = AtomicU32::new(0);
    /// The idle task's reader of [`RX_BUFFER`].
    pub type Ring = DmaRing<RX_CAPACITY>;

    /// DMA2 stream 2's flags in LISR / LIFCR: FEIF2 (16), DMEIF2 (18), TEIF2 (19), HTIF2 (20),
    /// TCIF2 (21).
    const HTIF2: u32 = 1 << 20;
    const TCIF2: u32 = 1 << 21;
    const ALL2: u32 = 0b11_1101 << 16;
    /// The stream's index in DMA2's stream array.
    const STREAM: usize = 2;

    /// Starts the stream (RM0090 §10.3.17, the stream configuration procedure): DMA2's clock
    /// (AHB1ENR bit 22); the stream off; PAR = USART1's DR; M0AR = [`RX_BUFFER`]; NDTR =
    /// [`RX_CAPACITY`]; its flags cleared; FIFO off (direct mode: each byte is in memory when
    /// NDTR counts it); CR: channel 4, very high priority, bytes, memory incremented,
    /// circular, peripheral to memory, half-transfer and transfer-complete interrupts, on.
    /// Before USART1 sets DMAR ([`super::Serial::new`]).
    pub fn start(dma2: &DMA2, rcc: &RCC) {
        rcc.ahb1enr().modify(|_, w| w.dma2en().set_bit());
        let st = dma2.st(STREAM);
        st.cr().write(|w| w.en().clear_bit());
        // The stream was never on since reset; a bounded wait all the same (RM0090: EN reads 0
        // once the stream has stopped).
        let _ = (0..1000).any(|_| st.cr().read().en().bit_is_clear());
        // SAFETY: the data register's address, USART1's base + 4 (RM0090 §30.6.2).
        st.par()
            .write(|w| unsafe { w.bits(USART1::ptr() as u32 + 4) });
        // SAFETY: the buffer is a static in SRAM (DMA-reachable: memory.x leaves the CCM RAM
        // unused), RX_CAPACITY bytes long, and only the DMA writes it.
        st.m0ar()
            .write(|w| unsafe { w.bits(RX_BUFFER.as_ptr() as u32) });
        st.ndtr().write(|w| w.ndt().set(RX_CAPACITY as u16));
        // SAFETY: writing 1 to LIFCR's bits clears the flags; stream 2's only.
        dma2.lifcr().write(|w| unsafe { w.bits(ALL2) });
        // SAFETY: FCR's reset value with DMDIS = 0 (direct mode) and FEIE = 0.
        st.fcr().write(|w| unsafe { w.bits(0x21) });
        st.cr().write(|w| {
            w.chsel()
                .set(4)
                .pl()
                .very_high()
                .msize()
                .bits8()
                .psize()
                .bits8()
                .minc()
                .incremented()
                .pinc()
                .fixed()
                .circ()
                .enabled()
                .dir()
                .peripheral_to_memory()
                .pfctrl()
                .dma()
                .htie()
                .enabled()
                .tcie()
                .enabled()
        });
        st.cr().modify(|_, w| w.en().enabled());
    }

    /// The stream's interrupt: clears the half-transfer and transfer-complete flags it finds
    /// and counts each in [`RX_HALVES`] (both, when it ran late by more than half a lap).
    pub fn count_halves(dma2: &DMA2) {
        let flags = dma2.lisr().read().bits() & ALL2;
        // SAFETY: writing 1 to LIFCR's bits clears the flags; the ones just read only.
        dma2.lifcr().write(|w| unsafe { w.bits(flags) });
        let events = u32::from(flags & HTIF2 != 0) + u32::from(flags & TCIF2 != 0);
        RX_HALVES.fetch_add(events, Ordering::Release);
    }

    /// The stream's position: the event count first, then NDTR (`flexarm_link::ring`: in this
    /// order a late count shows as the index in the other half).
    pub fn position() -> Position {
        let halves = RX_HALVES.load(Ordering::Acquire);
        // SAFETY: a read of stream 2's NDTR, which has no side effect; the stream's owner
        // (the interrupt, [`count_halves`]) writes only LIFCR.
        let dma2 = unsafe { &*DMA2::ptr() };
        Position {
            halves,
            remaining: dma2.st(STREAM).ndtr().read().ndt().bits(),
        }
    }

    /// Bytes the idle task copies out of the buffer at a time (on its stack).
    pub const CHUNK: usize = 32;

    /// The next new bytes of [`RX_BUFFER`], at most [`CHUNK`], and the bytes lost before them
    /// (`flexarm_link::ring::DmaRing::read`). Not inlined: one copy of the reader, outside
    /// `idle`'s frame.
    #[inline(never)]
    pub fn read(ring: &mut Ring) -> flexarm_link::ring::Chunk<CHUNK> {
        ring.read::<CHUNK>(&RX_BUFFER, position)
    }

    /// DMA2 stream 7's flags in HISR / HIFCR: FEIF7 (22), DMEIF7 (24), TEIF7 (25), HTIF7 (26),
    /// TCIF7 (27).
    const ALL7: u32 = 0b11_1101 << 22;
    /// The transmit stream's index.
    const TX_STREAM: usize = 7;
    /// Polls of the transmit stream's enable bit before a frame is taken as sent: the largest
    /// frame (`flexarm_link::MAX_FRAME` bytes, 10.85 µs each) at a poll of at least 5 cycles at
    /// 168 MHz, twice over.
    const TX_POLLS: u32 = flexarm_link::MAX_FRAME as u32 * 1823 / 5 * 2;

    /// Waits (bounded, [`TX_POLLS`]) until the transmit stream has sent its frame: its enable
    /// bit clears at the end of a transfer (RM0090 §10.3.12). The transmitter then never reads
    /// USART1's SR: only the line-event interrupt does, so no read of SR by the transmitter can
    /// join the DMA's read of DR in clearing an error flag before the interrupt has counted it.
    pub fn transmitted() {
        // SAFETY: stream 7 is the transmitter's, used by the idle task only ([`transmit`]).
        let dma2 = unsafe { &*DMA2::ptr() };
        let st = dma2.st(TX_STREAM);
        let _ = (0..TX_POLLS).any(|_| st.cr().read().en().bit_is_clear());
    }

    /// Starts sending `frame` with DMA2 stream 7, channel 4 (USART1_TX; RM0090 table 43):
    /// memory to peripheral, bytes, memory incremented, high priority, no interrupt; USART1's
    /// DMAT requests a byte at each TXE. The caller keeps `frame` unchanged until
    /// [`transmitted`] (the encoder's buffer, which [`super::send`] rewrites only after it).
    pub fn transmit(frame: &[u8]) {
        // SAFETY: as in [`transmitted`]; HIFCR bits of stream 7 only.
        let dma2 = unsafe { &*DMA2::ptr() };
        let st = dma2.st(TX_STREAM);
        st.cr().write(|w| w.en().clear_bit());
        let _ = (0..1000).any(|_| st.cr().read().en().bit_is_clear());
        // SAFETY: writing 1 to HIFCR's bits clears the flags; stream 7's only.
        dma2.hifcr().write(|w| unsafe { w.bits(ALL7) });
        // SAFETY: the data register's address, USART1's base + 4 (RM0090 §30.6.2).
        st.par()
            .write(|w| unsafe { w.bits(USART1::ptr() as u32 + 4) });
        // SAFETY: the frame is in SRAM (the encoder's buffer, a static of the idle task) and
        // stays unchanged until the stream has sent it (the caller's contract above).
        st.m0ar()
            .write(|w| unsafe { w.bits(frame.as_ptr() as u32) });
        st.ndtr()
            .write(|w| w.ndt().set(frame.len().min(usize::from(u16::MAX)) as u16));
        st.cr().write(|w| {
            w.chsel()
                .set(4)
                .pl()
                .high()
                .msize()
                .bits8()
                .psize()
                .bits8()
                .minc()
                .incremented()
                .pinc()
                .fixed()
                .dir()
                .memory_to_peripheral()
                .pfctrl()
                .dma()
        });
        st.cr().modify(|_, w| w.en().enabled());
    }

    /// `true` if the DMA has written bytes that the reader has not read.
    pub fn pending(ring: &Ring) -> bool {
        Ring::written(position()) != ring.consumed()
    }

    /// What one line-event interrupt found (RM0090 §30.6.1, SR; with DMAR set, EIE raises it
    /// on ORE, FE and NF, IDLEIE on IDLE).
    #[derive(Clone, Copy, Debug, Default)]
    pub struct LineEvents {
        /// ORE: bytes lost because the DMA did not read DR in time.
        pub overrun: bool,
        /// FE or PE: a byte with a framing (or parity) error, which the DMA stored all the
        /// same; the frame's CRC refuses the frame it belongs to.
        pub framing: bool,
        /// NF: a byte with noise, stored likewise.
        pub noise: bool,
        /// The DMA had not taken a received byte within [`RXNE_POLLS`] (it stopped): the byte
        /// was read here to clear the flags, and is lost.
        pub taken: bool,
    }

    /// Polls of RXNE before the flags are cleared: a byte the DMA is about to take (its
    /// request is served within a few bus cycles) is left to it.
    const RXNE_POLLS: u32 = 100;

    /// The line-event interrupt: reads SR, and clears IDLE, ORE, FE, NF (and PE) with the
    /// sequence RM0090 gives (SR read, then DR read) once no received byte waits for the DMA.
    /// The one byte it can take from the DMA is one whose stop bit ends between those two
    /// reads, a few bus cycles: the bytes of a frame end at the idle event, and the next frame
    /// starts after the host has its answer.
    pub fn line_events() -> LineEvents {
        // SAFETY: the line-event interrupt is the only code that reads SR and DR; the DMA streams
        // read DR (receive) and write it (transmit, [`transmit`]). Reads of SR have no side
        // effect of their own.
        let usart = unsafe { &*USART1::ptr() };
        let mut sr = usart.sr().read();
        let mut polls = 0;
        while sr.rxne().bit_is_set() && polls < RXNE_POLLS {
            sr = usart.sr().read();
            polls += 1;
        }
        let events = LineEvents {
            overrun: sr.ore().bit_is_set(),
            framing: sr.fe().bit_is_set() || sr.pe().bit_is_set(),
            noise: sr.nf().bit_is_set(),
            taken: sr.rxne().bit_is_set(),
        };
        if sr.idle().bit_is_set()
            || events.overrun
            || events.framing
            || events.noise
            || events.taken
        {
            let _ = usart.dr().read();
        }
        events
    }
}

//! The command link's transport: USART1 carries the frames of `flexarm-link`. The receive
//! interrupt only moves bytes from the data register into a queue; the idle task decodes them
//! and answers through the session (`flexarm_machine::session`), and streams the telemetry the
//! host subscribed to. Both run below the control loops, so nothing on the link can delay them.
//!
//! Hardware board: USART1 on PB6 (TX) and PB7 (RX) (the board configures the pins), 921 600
//! baud (`flexarm_machine::session::BAUD`), 8N1. QEMU board: the same USART, exposed by QEMU as
//! a TCP socket (`scripts/qemu-link`).

use flexarm_link::msg::DeviceMsgRef;
use flexarm_machine::session::BAUD;
use stm32f4::stm32f405::USART1;

/// Bytes received and not yet decoded.
pub const RX_CAPACITY: usize = 512;
/// The queue between the receive interrupt and the idle task.
pub type RxQueue = heapless::spsc::Queue<u8, RX_CAPACITY>;

/// USART1's transmit side (the idle task's), with its frame encoder.
pub struct Serial {
    usart: USART1,
    encoder: flexarm_link::Encoder,
}

/// USART1's receive side (the receive interrupt's).
pub struct Receiver;

/// What one read of the receiver found (RM0090 §30.6.1: the flags belong to the byte in DR;
/// reading SR then DR clears them).
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
    /// rate) with its receive interrupt.
    pub fn new(usart: USART1, rcc: &stm32f4::stm32f405::RCC) -> Self {
        rcc.apb2enr().modify(|_, w| w.usart1en().set_bit());
        // 84 MHz / 921 600 = 91.1: 0.1 % fast, well inside a UART's tolerance.
        let brr = ((84_000_000 + BAUD / 2) / BAUD) as u16;
        // SAFETY: BRR takes any 16-bit divider; 91 is within it.
        usart.brr().write(|w| unsafe { w.bits(brr) });
        usart.cr1().write(|w| {
            w.ue()
                .set_bit()
                .te()
                .set_bit()
                .re()
                .set_bit()
                .rxneie()
                .set_bit()
        });
        Self {
            usart,
            encoder: flexarm_link::Encoder::new(),
        }
    }
}

/// Sends `bytes`, waiting for the transmit register (idle task only).
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
    match encoder.device(msg) {
        Ok(frame) => {
            write_all(usart, frame);
            true
        }
        Err(_) => false,
    }
}

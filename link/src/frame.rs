//! Framing: `COBS(postcard(message) ‖ CRC-32) ‖ 0x00` (crate docs). [`encode`] writes one
//! frame into a caller's buffer; [`Decoder`] takes bytes one at a time from a stream and yields
//! whole messages, rejecting bad frames with a [`FrameError`] and resynchronizing at the next
//! zero byte. Neither allocates nor panics, whatever the input.

use serde::Serialize;
use serde::de::DeserializeOwned;

/// Largest frame on the wire, the terminating zero included [bytes]. Every message of
/// [`crate::msg`] fits (tested); a receiver drops anything longer.
pub const MAX_FRAME: usize = 256;

/// Largest serialized message: the frame less the CRC, COBS's overhead and the terminator.
pub const MAX_MESSAGE: usize = MAX_FRAME - 4 - MAX_FRAME.div_ceil(254) - 1;

/// Bitwise, without a table: 1 KiB less flash on the board, eight steps a byte in the idle task.
const CRC: crc::Crc<u32, crc::NoTable> = crc::Crc::<u32, crc::NoTable>::new(&crc::CRC_32_ISO_HDLC);

/// Why a frame was not delivered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameError {
    /// The message does not fit in [`MAX_MESSAGE`] bytes, or the output buffer is too small.
    TooLarge,
    /// More than [`MAX_FRAME`] bytes without a terminator: dropped up to the next zero.
    Oversized,
    /// The bytes between two zeros are not valid COBS.
    Cobs,
    /// Shorter than a CRC.
    Truncated,
    /// The CRC does not match the message.
    Crc,
    /// The CRC matches but the bytes are not a message of this protocol version.
    Malformed,
}

impl core::fmt::Display for FrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::TooLarge => "message too large for a frame",
            Self::Oversized => "frame longer than the limit: dropped",
            Self::Cobs => "invalid COBS encoding",
            Self::Truncated => "frame shorter than its CRC",
            Self::Crc => "CRC mismatch",
            Self::Malformed => "not a message of this protocol version",
        })
    }
}

/// Writes `msg` as one frame into `out` and returns the frame (terminator included).
pub fn encode<'a, T: Serialize>(msg: &T, out: &'a mut [u8]) -> Result<&'a [u8], FrameError> {
    encode_with(msg, &mut [0u8; MAX_MESSAGE + 4], out)
}

/// [`encode`] with the serialized message in `raw`: a caller without the stack for it keeps
/// both buffers in static memory ([`Encoder`]).
fn encode_with<'a, T: Serialize>(
    msg: &T,
    raw: &mut [u8; MAX_MESSAGE + 4],
    out: &'a mut [u8],
) -> Result<&'a [u8], FrameError> {
    let n = postcard::to_slice(msg, &mut raw[..MAX_MESSAGE])
        .map_err(|_| FrameError::TooLarge)?
        .len();
    let crc = CRC.checksum(&raw[..n]);
    raw[n..n + 4].copy_from_slice(&crc.to_le_bytes());
    let body = &raw[..n + 4];
    if out.len() < cobs::max_encoding_length(body.len()) + 1 {
        return Err(FrameError::TooLarge);
    }
    let len = cobs::try_encode(body, out).map_err(|_| FrameError::TooLarge)?;
    let end = out.get_mut(len).ok_or(FrameError::TooLarge)?;
    *end = 0;
    Ok(&out[..len + 1])
}

/// Decodes one frame's bytes (between two zeros, terminator excluded) in place.
fn decode_frame<T: DeserializeOwned>(frame: &mut [u8]) -> Result<T, FrameError> {
    let n = cobs::decode_in_place(frame).map_err(|_| FrameError::Cobs)?;
    let body = frame.get(..n).ok_or(FrameError::Cobs)?;
    if body.len() < 4 {
        return Err(FrameError::Truncated);
    }
    let (msg, crc) = body.split_at(body.len() - 4);
    let want = u32::from_le_bytes([crc[0], crc[1], crc[2], crc[3]]);
    if CRC.checksum(msg) != want {
        return Err(FrameError::Crc);
    }
    match postcard::take_from_bytes::<T>(msg) {
        Ok((value, [])) => Ok(value),
        _ => Err(FrameError::Malformed),
    }
}

/// Stream decoder with a fixed buffer of [`MAX_FRAME`] bytes.
#[derive(Clone, Debug)]
pub struct Decoder {
    buf: [u8; MAX_FRAME],
    len: usize,
    /// Dropping an oversized frame up to its terminator.
    skipping: bool,
}

impl Default for Decoder {
    fn default() -> Self {
        Self::new()
    }
}

impl Decoder {
    /// An empty decoder.
    pub const fn new() -> Self {
        Self {
            buf: [0; MAX_FRAME],
            len: 0,
            skipping: false,
        }
    }

    /// Takes one byte; at a frame's end returns the message or why it was refused. Empty frames
    /// (consecutive zeros) are ignored.
    pub fn push<T: DeserializeOwned>(&mut self, byte: u8) -> Option<Result<T, FrameError>> {
        if byte != 0 {
            if self.skipping {
                return None;
            }
            if self.len == self.buf.len() {
                self.skipping = true;
                self.len = 0;
                return Some(Err(FrameError::Oversized));
            }
            self.buf[self.len] = byte;
            self.len += 1;
            return None;
        }
        let len = core::mem::take(&mut self.len);
        if core::mem::take(&mut self.skipping) || len == 0 {
            return None;
        }
        Some(decode_frame(&mut self.buf[..len]))
    }
}

/// The firmware's encoder: its two buffers (about 500 bytes) live wherever the encoder does, in
/// a static on the firmware, instead of on the stack of each call.
#[derive(Clone, Debug)]
pub struct Encoder {
    raw: [u8; MAX_MESSAGE + 4],
    out: [u8; MAX_FRAME],
}

impl Default for Encoder {
    fn default() -> Self {
        Self::new()
    }
}

impl Encoder {
    /// Empty buffers.
    pub const fn new() -> Self {
        Self {
            raw: [0; MAX_MESSAGE + 4],
            out: [0; MAX_FRAME],
        }
    }

    /// One frame of a firmware message (terminator included); compiled once, in this crate.
    #[inline(never)]
    pub fn device(&mut self, msg: &crate::msg::DeviceMsgRef<'_>) -> Result<&[u8], FrameError> {
        encode_with(msg, &mut self.raw, &mut self.out)
    }
}

impl Decoder {
    /// [`Decoder::push`] for requests, compiled once in this crate.
    #[inline(never)]
    pub fn push_request(&mut self, byte: u8) -> Option<Result<crate::Request, FrameError>> {
        self.push(byte)
    }
}

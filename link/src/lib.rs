//! # flexarm-link
//!
//! The command link between the flexarm firmware and a host: the typed messages ([`msg`]) and
//! their framing on a byte stream ([`frame`]). `no_std`, no allocation, no panics on any input:
//! one crate used by both ends, so a field cannot drift between the firmware and the console.
//!
//! ## On the wire
//! A frame is `COBS(postcard(message) ‖ CRC-32(postcard(message)))` followed by one `0x00`:
//! - [`postcard`] serializes the message (varints, enums by index): compact and `no_std`;
//! - the CRC-32 (ISO-HDLC, the Ethernet/zlib polynomial, little-endian) catches corruption that
//!   still decodes;
//! - COBS removes every zero byte, so `0x00` marks the end of a frame and a receiver that
//!   joins mid-stream, or loses bytes, resynchronizes at the next zero.
//!
//! The hardware board receives the stream into a circular DMA buffer; [`ring`] is its reader
//! (which bytes are new, which the DMA overtook), pure and tested on the host.
//!
//! Every message has a bounded size: the largest encodes to at most [`frame::MAX_FRAME`] bytes
//! (tested on the largest value of each message), so both ends use fixed buffers.
//!
//! ## Sessions
//! The host sends [`msg::Request`]s, each with an id; the firmware answers each with one
//! [`msg::Reply`] carrying the same id (done, a value, or refused with a [`msg::Refusal`]).
//! Telemetry is a stream the host subscribes to ([`msg::Command::Subscribe`]); each
//! [`msg::Telemetry`] frame carries a sequence number so the host counts losses. Units are SI
//! and frames are the core's (`flexarm_core::model`): angles in rad, torques in N·m, voltages in
//! V, modal coordinates in √kg·m, times in s (or in ticks where named).
#![no_std]
#![forbid(unsafe_code)]
#![deny(missing_docs)]

pub mod frame;
pub mod msg;
pub mod params;
pub mod ring;

pub use frame::{Decoder, Encoder, FrameError, MAX_FRAME, encode};
pub use msg::{Command, DeviceMsg, Reply, Request};

/// The protocol version: a host and a firmware talk only when they agree on it (the
/// handshake refuses otherwise). Bumped whenever a message changes shape.
pub const VERSION: u16 = 11;

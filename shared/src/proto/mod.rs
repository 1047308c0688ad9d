//! The wire protocol between the device and the host: frame types, framing, and a streaming decoder.
//!
//! This module is the interface control document (ICD) of octavar: the firmware and the host both depend on it,
//! so the two ends cannot disagree about a byte. Every message travels as one *frame*:
//!
//! ```text
//! COBS( seq: u32 little-endian | postcard(body) | CRC-32 little-endian ) 0x00
//! ```
//!
//! - `seq` counts frames per direction (wrapping at 2^32): the receiver sees every lost frame as a gap;
//! - `body` is a [`Frame`] (device -> host) or a [`Command`] (host -> device), serialised with postcard 1.x;
//! - the CRC is CRC-32/ISO-HDLC (the zlib and Ethernet CRC) over `seq` and `body`;
//! - COBS removes every 0x00 from the frame, so 0x00 marks its end and a receiver resynchronises at the next one.
//!
//! An encoded frame, delimiter included, never exceeds [`MAX_FRAME`] = 512 bytes: every frame type has a
//! worst-case size ([`MaxSize`]) checked at compile time against [`MAX_BODY`], and encoding returns an error
//! instead of panicking should a value not fit.
//!
//! # The protocol
//!
//! | frame                      | direction     | when sent                                                         |
//! |----------------------------|---------------|-------------------------------------------------------------------|
//! | [`Frame::Hello`]           | device → host | at start-up, on USB connect, and in reply to [`Command::Hello`]    |
//! | [`Frame::Samples`]         | device → host | while raw streaming is on ([`Command::StartRaw`]), every ≤ 160 codes |
//! | [`Frame::AllanSnapshot`]   | device → host | periodically, one or more parts ([`SnapshotPart`]) per channel     |
//! | [`Frame::Status`]          | device → host | periodically (about once a second)                                |
//! | [`Frame::Estimate`]        | device → host | after each snapshot round: onboard N and B per gyro channel       |
//! | [`Frame::FieldLog`]        | device → host | in reply to [`Command::ReadFieldLog`], one per stored part         |
//! | [`Frame::FieldLogEnd`]     | device → host | after the last [`Frame::FieldLog`] of a read-out                  |
//! | [`Command::StartRaw`]      | host → device | to stream raw codes of the channels in a mask                     |
//! | [`Command::StopRaw`]       | host → device | to stop raw streaming                                             |
//! | [`Command::Reset`]         | host → device | to reset every accumulator (sample counts restart at 0)           |
//! | [`Command::ReadFieldLog`]  | host → device | to read the snapshots stored in flash, from a checkpoint on        |
//! | [`Command::Hello`]         | host → device | to ask for a [`Frame::Hello`]                                     |
//!
//! # Versioning
//! There is no schema hash: [`PROTOCOL_VERSION`] travels in [`Hello`] and is bumped by hand on any change of the
//! wire format. The golden-bytes tests at the end of this module write out the exact bytes of every frame kind,
//! so a wire change made without a version bump fails them.
//!
//! # Files
//! - `frame.rs`: the device -> host frames; `snapshot.rs`: splitting an accumulator [`Snapshot`] into parts that
//!   fit a frame and joining them again; `command.rs`: the host -> device commands;
//! - `size.rs`: worst-case postcard sizes ([`MaxSize`]) and the compile-time proof that every frame fits;
//! - `framing.rs`: sequence number, CRC-32 and COBS ([`encode_frame`], [`Encoder`]);
//! - `decoder.rs`: the streaming [`Decoder`] with its [`DecoderStats`].
//!
//! # Examples
//! ```
//! use octavar_shared::proto::{Decoder, Encoder, Frame, Status, MAX_FRAME};
//!
//! let status = Frame::Status(Status {
//!     uptime_ms: 1_000,
//!     samples_per_channel: 2_000,
//!     adc_overruns: 0,
//!     frames_dropped: 0,
//!     temperature_c: Some(24.5),
//!     samples_lost: 0,
//!     stack_peak_bytes: Some(4_096),
//! });
//! let mut enc = Encoder::new();
//! let mut wire = [0u8; 2 * MAX_FRAME];
//! let a = enc.encode(&status, &mut wire).unwrap();
//! let b = enc.encode(&status, &mut wire[a..]).unwrap();
//!
//! let mut dec = Decoder::<Frame>::new();
//! let got: Vec<_> = dec.feed(&wire[..a + b]).filter_map(Result::ok).collect();
//! assert_eq!(got.len(), 2);
//! assert_eq!((got[0].seq, got[1].seq), (0, 1));
//! assert_eq!(got[1].msg, status);
//! assert_eq!(dec.stats().frames, 2);
//! ```
//!
//! [`Snapshot`]: crate::acc::Snapshot

mod command;
mod decoder;
mod frame;
pub(crate) mod framing;
mod size;
mod snapshot;

#[cfg(test)]
mod tests;

pub use command::Command;
pub use decoder::{DecodeError, Decoder, DecoderStats, Feed, Received};
pub use frame::{
    Ack, ChannelEstimate, ChannelInfo, CheckpointReport, Estimate, FieldLogEnd, FieldLogRecord, Frame, Hello, Samples,
    Status,
};
pub use framing::{crc32, encode_frame, encode_to_vec, EncodeError, Encoder, FrameBuf, RESYNC};
pub use size::{varint_max, MaxSize};
pub use snapshot::{SnapshotError, SnapshotPart, SnapshotParts};

/// The version of the wire format, sent in [`Hello`]. Bump it on any change a golden-bytes test catches.
pub const PROTOCOL_VERSION: u16 = 4;

/// The largest encoded frame in bytes, the 0x00 delimiter included: the receive buffer size.
pub const MAX_FRAME: usize = 512;
/// Bytes of the sequence number before the body.
pub const SEQ_LEN: usize = 4;
/// Bytes of the CRC-32 after the body.
pub const CRC_LEN: usize = 4;
/// The largest frame before COBS (sequence number + body + CRC) whose encoding plus delimiter fits [`MAX_FRAME`]:
/// COBS adds one byte per started run of 254 bytes.
pub const MAX_PACKET: usize = max_packet(MAX_FRAME);
/// The largest postcard body a frame can carry.
pub const MAX_BODY: usize = MAX_PACKET - SEQ_LEN - CRC_LEN;

/// Channels a device reports at most (a `u8` channel mask).
pub const MAX_CHANNELS: usize = 8;
/// Bytes of a channel name in [`ChannelInfo`].
pub const MAX_CHANNEL_NAME: usize = 16;
/// Bytes of the firmware version and of the board name in [`Hello`].
pub const MAX_IDENT: usize = 24;
/// Raw codes in one [`Samples`] frame at most (a code takes up to 3 bytes as a postcard varint).
pub const MAX_CODES: usize = 160;
/// Accumulator levels in one [`SnapshotPart`] at most: 16 levels of worst-case varints (10 + 19 bytes each)
/// fit one frame, so a full 32-level snapshot takes two parts.
pub const LEVELS_PER_PART: usize = 16;

/// The largest `n` with `n + ceil(n / 254) + 1 <= frame` (COBS worst case plus the delimiter).
const fn max_packet(frame: usize) -> usize {
    let mut n = frame;
    while n > 0 && n + n.div_ceil(254) + 1 > frame {
        n -= 1;
    }
    n
}

const _: () = assert!(MAX_PACKET == 508 && MAX_BODY == 500);

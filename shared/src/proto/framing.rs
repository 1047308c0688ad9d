//! Framing: sequence number, CRC-32 and COBS around a postcard body.
//!
//! ```text
//! COBS( seq: u32 LE | postcard(body) | CRC-32/ISO-HDLC(seq | body) LE ) 0x00
//! ```
//!
//! Encoding never panics: a body that does not fit [`MAX_BODY`] or an output buffer too small is an
//! [`EncodeError`]. The [`Encoder`] numbers frames; a frame that fails to encode does not use up a number, and a
//! frame encoded but then dropped (USB busy) leaves a gap the host counts.
//!
//! # Examples
//! ```
//! use octavar_shared::proto::{encode_frame, Command, MAX_FRAME};
//! let mut buf = [0u8; MAX_FRAME];
//! let n = encode_frame(7, &Command::StopRaw, &mut buf).unwrap();
//! assert_eq!(buf[n - 1], 0x00); // the delimiter
//! assert!(!buf[..n - 1].contains(&0x00));
//! ```

use heapless::Vec;
use serde::Serialize;

use super::{CRC_LEN, MAX_BODY, MAX_FRAME, MAX_PACKET, SEQ_LEN};

/// A lone delimiter. A sender writes it before the first frame of a connection and after any frame it could not
/// finish: whatever partial frame the receiver holds (a fragment left in a USB FIFO by the last session, a frame
/// cut by a timed-out write) ends there as one bad frame, and the next frame decodes on its own. A receiver takes
/// a delimiter with nothing before it as idle line ([`super::Decoder::push`]).
pub const RESYNC: [u8; 1] = [0x00];

/// CRC-32/ISO-HDLC: polynomial 0x04C11DB7, reflected, init and xorout 0xFFFFFFFF (zlib's `crc32`).
pub(crate) const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// The CRC-32 of `bytes` as frames use it (CRC-32/ISO-HDLC; `crc32(b"123456789") == 0xCBF43926`).
pub fn crc32(bytes: &[u8]) -> u32 {
    CRC.checksum(bytes)
}

/// One encoded frame, delimiter included.
pub type FrameBuf = Vec<u8, MAX_FRAME>;

/// Why a frame could not be encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EncodeError {
    /// The body is longer than [`MAX_BODY`]: the frame would exceed [`MAX_FRAME`].
    TooLarge,
    /// The output buffer is shorter than the encoded frame.
    BufferTooSmall,
    /// postcard could not serialise the value (a type outside this protocol).
    Serialize,
}

impl core::fmt::Display for EncodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            EncodeError::TooLarge => "frame body exceeds the frame size limit",
            EncodeError::BufferTooSmall => "output buffer too small for the encoded frame",
            EncodeError::Serialize => "value cannot be serialised",
        })
    }
}

impl core::error::Error for EncodeError {}

/// Encode `msg` as frame number `seq` into `out`: COBS-encoded, 0x00-terminated. Returns the bytes written
/// (at most [`MAX_FRAME`]).
///
/// # Errors
/// [`EncodeError::TooLarge`] when the body exceeds [`MAX_BODY`] (never for [`super::Frame`] or
/// [`super::Command`], whose worst case fits), [`EncodeError::BufferTooSmall`] when `out` is too short,
/// [`EncodeError::Serialize`] when postcard fails otherwise. `out` may have been written to.
pub fn encode_frame<M: Serialize + ?Sized>(seq: u32, msg: &M, out: &mut [u8]) -> Result<usize, EncodeError> {
    let mut packet = [0u8; MAX_PACKET];
    packet[..SEQ_LEN].copy_from_slice(&seq.to_le_bytes());
    let body_len = match postcard::to_slice(msg, &mut packet[SEQ_LEN..SEQ_LEN + MAX_BODY]) {
        Ok(body) => body.len(),
        Err(postcard::Error::SerializeBufferFull) => return Err(EncodeError::TooLarge),
        Err(_) => return Err(EncodeError::Serialize),
    };
    let crc_at = SEQ_LEN + body_len;
    let crc = crc32(&packet[..crc_at]);
    packet[crc_at..crc_at + CRC_LEN].copy_from_slice(&crc.to_le_bytes());
    let packet = &packet[..crc_at + CRC_LEN];

    // The delimiter needs one byte after the COBS output.
    let room = out.len().checked_sub(1).ok_or(EncodeError::BufferTooSmall)?;
    let n = cobs::try_encode(packet, &mut out[..room]).map_err(|_| EncodeError::BufferTooSmall)?;
    out[n] = 0x00;
    Ok(n + 1)
}

/// [`encode_frame`] into a new [`FrameBuf`].
///
/// # Errors
/// As [`encode_frame`], less [`EncodeError::BufferTooSmall`].
pub fn encode_to_vec<M: Serialize + ?Sized>(seq: u32, msg: &M) -> Result<FrameBuf, EncodeError> {
    let mut buf = [0u8; MAX_FRAME];
    let n = encode_frame(seq, msg, &mut buf)?;
    // Cannot fail: n <= MAX_FRAME.
    FrameBuf::from_slice(&buf[..n]).map_err(|_| EncodeError::BufferTooSmall)
}

/// Numbers and encodes the frames of one direction.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Encoder {
    next_seq: u32,
}

impl Encoder {
    /// An encoder whose first frame is number 0.
    pub const fn new() -> Self {
        Encoder { next_seq: 0 }
    }

    /// An encoder whose first frame is number `seq`.
    pub const fn starting_at(seq: u32) -> Self {
        Encoder { next_seq: seq }
    }

    /// The number the next frame gets.
    pub const fn next_seq(&self) -> u32 {
        self.next_seq
    }

    /// Encode `msg` into `out` with the next sequence number (see [`encode_frame`]); returns the bytes written.
    ///
    /// # Errors
    /// As [`encode_frame`]; the sequence number is then not used up.
    pub fn encode<M: Serialize + ?Sized>(&mut self, msg: &M, out: &mut [u8]) -> Result<usize, EncodeError> {
        let n = encode_frame(self.next_seq, msg, out)?;
        self.next_seq = self.next_seq.wrapping_add(1);
        Ok(n)
    }

    /// Encode `msg` into a new [`FrameBuf`] with the next sequence number.
    ///
    /// # Errors
    /// As [`encode_to_vec`]; the sequence number is then not used up.
    pub fn encode_to_vec<M: Serialize + ?Sized>(&mut self, msg: &M) -> Result<FrameBuf, EncodeError> {
        let v = encode_to_vec(self.next_seq, msg)?;
        self.next_seq = self.next_seq.wrapping_add(1);
        Ok(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proto::Command;

    #[test]
    fn crc_is_the_zlib_crc() {
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    }

    #[test]
    fn too_large_and_too_small_are_errors() {
        let big = [0x55u8; MAX_BODY]; // postcard adds a length prefix: one over the limit
        let mut out = [0u8; 2 * MAX_FRAME];
        assert_eq!(encode_frame(0, &big[..], &mut out), Err(EncodeError::TooLarge));
        let fits = [0x55u8; MAX_BODY - 2];
        let n = encode_frame(0, &fits[..], &mut out).unwrap();
        assert!(n <= MAX_FRAME, "{n}");
        for len in 0..n {
            assert_eq!(encode_frame(0, &fits[..], &mut out[..len]), Err(EncodeError::BufferTooSmall), "{len}");
        }
        assert_eq!(encode_frame(0, &fits[..], &mut out[..n]), Ok(n));
    }

    /// Bodies of every length, with and without zero bytes, across COBS's 254-byte group boundaries.
    #[test]
    fn every_body_length_round_trips() {
        use crate::proto::{Decoder, Received};
        type Bytes = heapless::Vec<u8, MAX_BODY>;
        let mut out = [0u8; MAX_FRAME];
        for len in 0..=MAX_BODY - 2 {
            for fill in [|i: usize| (i % 255 + 1) as u8, |i: usize| (i % 7) as u8, |_| 0] {
                let body: Bytes = (0..len).map(fill).collect();
                let n = encode_frame(len as u32, &body, &mut out).unwrap();
                assert!(n <= MAX_FRAME);
                let mut dec = Decoder::<Bytes>::new();
                let got: std::vec::Vec<_> = dec.feed(&out[..n]).collect();
                assert_eq!(got, [Ok(Received { seq: len as u32, lost: 0, msg: body })], "{len}");
            }
        }
    }

    #[test]
    fn encoder_counts_and_wraps() {
        let mut e = Encoder::starting_at(u32::MAX);
        let mut out = [0u8; MAX_FRAME];
        e.encode(&Command::Reset, &mut out).unwrap();
        assert_eq!(e.next_seq(), 0);
        assert!(e.encode(&Command::Reset, &mut out[..3]).is_err());
        assert_eq!(e.next_seq(), 0);
        let v = e.encode_to_vec(&Command::Reset).unwrap();
        assert_eq!(e.next_seq(), 1);
        assert_eq!(*v.last().unwrap(), 0);
    }
}

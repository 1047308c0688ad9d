//! The streaming decoder: bytes in any chunking, frames out, with their sequence numbers and loss counts.
//!
//! It keeps the bytes of the frame in progress in a fixed [`MAX_FRAME`] buffer (no allocation) until a 0x00
//! delimiter, then undoes COBS in place, checks length and CRC-32, and deserialises the body. Anything wrong
//! makes it drop that frame, count why in [`DecoderStats`] and carry on at the next delimiter: garbage costs at
//! most the frame it touches. A frame is accepted only with a matching CRC and a body that deserialises with no
//! byte left over; whatever the input, the decoder never panics.
//!
//! Sequence numbers: the first frame sets the baseline; after frame `s` the next is expected to be `s + 1`
//! (wrapping at 2^32). A jump forward by `d < 2^31` counts `d` lost frames (frames the sender sent that never
//! arrived intact, corrupted ones included); a jump backwards (the sender restarted) counts a restart and sets a
//! new baseline.
//!
//! # Examples
//! ```
//! use octavar_shared::proto::{encode_frame, Command, Decoder};
//! let mut wire = [0u8; 64];
//! let n = encode_frame(41, &Command::Hello, &mut wire).unwrap();
//! let mut dec = Decoder::<Command>::new();
//! let mut got = None;
//! for &b in &wire[..n] {
//!     if let Some(r) = dec.push(b) {
//!         got = Some(r.unwrap());
//!     }
//! }
//! let got = got.unwrap();
//! assert_eq!((got.seq, got.lost, got.msg), (41, 0, Command::Hello));
//! ```

use core::marker::PhantomData;

use serde::de::DeserializeOwned;

use super::{framing::crc32, CRC_LEN, MAX_FRAME, SEQ_LEN};

/// A frame that passed every check.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Received<M> {
    /// Its sequence number.
    pub seq: u32,
    /// Frames missing between the previous accepted frame and this one (0 for the first frame and after a
    /// restart).
    pub lost: u32,
    /// The body.
    pub msg: M,
}

/// Why a frame was dropped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DecodeError {
    /// More than [`MAX_FRAME`] bytes without a delimiter.
    Oversize,
    /// The bytes are not valid COBS.
    Cobs,
    /// Too short to hold a sequence number, a body and a CRC.
    Truncated,
    /// The CRC does not match: the frame was corrupted.
    Crc,
    /// The CRC matches but the body is not a valid message (or has bytes left over): a sender on another
    /// protocol version, or a message of the other direction.
    Body,
}

impl core::fmt::Display for DecodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            DecodeError::Oversize => "frame longer than the frame size limit",
            DecodeError::Cobs => "invalid COBS encoding",
            DecodeError::Truncated => "frame too short",
            DecodeError::Crc => "CRC mismatch",
            DecodeError::Body => "frame body does not decode",
        })
    }
}

impl core::error::Error for DecodeError {}

/// What the decoder has seen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DecoderStats {
    /// Bytes fed.
    pub bytes: u64,
    /// Frames accepted.
    pub frames: u64,
    /// Frames dropped for [`DecodeError::Oversize`].
    pub oversize: u64,
    /// Frames dropped for [`DecodeError::Cobs`].
    pub cobs_errors: u64,
    /// Frames dropped for [`DecodeError::Truncated`].
    pub truncated: u64,
    /// Frames dropped for [`DecodeError::Crc`].
    pub crc_errors: u64,
    /// Frames dropped for [`DecodeError::Body`].
    pub decode_errors: u64,
    /// Bytes of dropped frames (delimiters not counted), and of an unterminated tail dropped by
    /// [`Decoder::finish`].
    pub dropped_bytes: u64,
    /// Sequence numbers skipped: frames lost (never received, or dropped above).
    pub lost: u64,
    /// Times the sequence number went backwards (the sender restarted); no loss is counted then.
    pub restarts: u64,
}

impl DecoderStats {
    /// Frames dropped, all reasons together.
    pub fn errors(&self) -> u64 {
        self.oversize + self.cobs_errors + self.truncated + self.crc_errors + self.decode_errors
    }
}

/// The streaming decoder of messages `M` ([`super::Frame`] on the host, [`super::Command`] on the device).
pub struct Decoder<M> {
    buf: [u8; MAX_FRAME],
    /// Bytes of the frame in progress held in `buf`.
    len: usize,
    /// The frame in progress outgrew `buf`: drop it at the next delimiter.
    overflow: bool,
    /// Bytes of the frame in progress, counted even past the buffer.
    pending: u64,
    last_seq: Option<u32>,
    stats: DecoderStats,
    _msg: PhantomData<fn() -> M>,
}

impl<M> core::fmt::Debug for Decoder<M> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Decoder")
            .field("pending", &self.pending)
            .field("last_seq", &self.last_seq)
            .field("stats", &self.stats)
            .finish()
    }
}

impl<M> Default for Decoder<M> {
    fn default() -> Self {
        Self::new()
    }
}

impl<M> Decoder<M> {
    /// A decoder with nothing seen.
    pub const fn new() -> Self {
        Decoder {
            buf: [0; MAX_FRAME],
            len: 0,
            overflow: false,
            pending: 0,
            last_seq: None,
            stats: DecoderStats {
                bytes: 0,
                frames: 0,
                oversize: 0,
                cobs_errors: 0,
                truncated: 0,
                crc_errors: 0,
                decode_errors: 0,
                dropped_bytes: 0,
                lost: 0,
                restarts: 0,
            },
            _msg: PhantomData,
        }
    }

    /// The counters so far.
    pub fn stats(&self) -> &DecoderStats {
        &self.stats
    }

    /// The sequence number of the last accepted frame.
    pub fn last_seq(&self) -> Option<u32> {
        self.last_seq
    }

    /// Bytes of an unterminated frame held (a capture cut mid-frame leaves some).
    pub fn pending(&self) -> u64 {
        self.pending
    }

    /// Drop the unterminated frame in progress, if any (end of a capture, or a reconnect); returns its length
    /// in bytes, which [`DecoderStats::dropped_bytes`] counts. The sequence baseline is kept.
    pub fn finish(&mut self) -> u64 {
        let n = self.pending;
        self.stats.dropped_bytes += n;
        self.clear_frame();
        n
    }

    /// Forget the sequence baseline (a new session): the next frame counts no loss.
    pub fn reset_sequence(&mut self) {
        self.last_seq = None;
    }

    fn clear_frame(&mut self) {
        self.len = 0;
        self.overflow = false;
        self.pending = 0;
    }

    fn fail(&mut self, e: DecodeError, bytes: u64) -> DecodeError {
        let s = &mut self.stats;
        match e {
            DecodeError::Oversize => s.oversize += 1,
            DecodeError::Cobs => s.cobs_errors += 1,
            DecodeError::Truncated => s.truncated += 1,
            DecodeError::Crc => s.crc_errors += 1,
            DecodeError::Body => s.decode_errors += 1,
        }
        s.dropped_bytes += bytes;
        e
    }
}

impl<M: DeserializeOwned> Decoder<M> {
    /// Feed one byte; at a delimiter that ends a frame, the frame or why it was dropped.
    ///
    /// Delimiters with nothing before them (idle line, a sender's leading flush) yield nothing.
    pub fn push(&mut self, byte: u8) -> Option<Result<Received<M>, DecodeError>> {
        self.stats.bytes += 1;
        if byte != 0 {
            self.pending += 1;
            if self.len < MAX_FRAME - 1 {
                self.buf[self.len] = byte;
                self.len += 1;
            } else {
                self.overflow = true;
            }
            return None;
        }
        if self.pending == 0 {
            return None;
        }
        let bytes = self.pending;
        let overflow = self.overflow;
        let len = self.len;
        self.clear_frame();
        if overflow {
            return Some(Err(self.fail(DecodeError::Oversize, bytes)));
        }
        Some(self.frame(len).map_err(|e| self.fail(e, bytes)))
    }

    /// Feed a chunk of bytes: an iterator over the frames (and drop reasons) it completes. Bytes the iterator
    /// is not driven over are not fed.
    pub fn feed<'d, 'b>(&'d mut self, bytes: &'b [u8]) -> Feed<'d, 'b, M> {
        Feed { dec: self, rest: bytes }
    }

    /// Check and decode the `len` COBS bytes in `buf`.
    fn frame(&mut self, len: usize) -> Result<Received<M>, DecodeError> {
        let n = cobs::decode_in_place(&mut self.buf[..len]).map_err(|_| DecodeError::Cobs)?;
        let packet = self.buf.get(..n).ok_or(DecodeError::Cobs)?;
        if n < SEQ_LEN + 1 + CRC_LEN {
            return Err(DecodeError::Truncated);
        }
        let (head, crc) = packet.split_at(n - CRC_LEN);
        let mut crc_bytes = [0u8; CRC_LEN];
        crc_bytes.copy_from_slice(crc);
        if crc32(head) != u32::from_le_bytes(crc_bytes) {
            return Err(DecodeError::Crc);
        }
        let (seq, body) = head.split_at(SEQ_LEN);
        let mut seq_bytes = [0u8; SEQ_LEN];
        seq_bytes.copy_from_slice(seq);
        let seq = u32::from_le_bytes(seq_bytes);
        let msg = match postcard::take_from_bytes::<M>(body) {
            Ok((msg, [])) => msg,
            _ => return Err(DecodeError::Body),
        };
        let lost = match self.last_seq {
            None => 0,
            Some(last) => {
                let d = seq.wrapping_sub(last.wrapping_add(1));
                if d < 1 << 31 {
                    d
                } else {
                    self.stats.restarts += 1;
                    0
                }
            }
        };
        self.last_seq = Some(seq);
        self.stats.lost += u64::from(lost);
        self.stats.frames += 1;
        Ok(Received { seq, lost, msg })
    }
}

/// Iterator over what a chunk of bytes completes (see [`Decoder::feed`]).
pub struct Feed<'d, 'b, M> {
    dec: &'d mut Decoder<M>,
    rest: &'b [u8],
}

impl<M> Feed<'_, '_, M> {
    /// Bytes of the chunk not fed yet.
    pub fn remaining(&self) -> usize {
        self.rest.len()
    }
}

impl<M: DeserializeOwned> Iterator for Feed<'_, '_, M> {
    type Item = Result<Received<M>, DecodeError>;

    fn next(&mut self) -> Option<Self::Item> {
        while let Some((&b, rest)) = self.rest.split_first() {
            self.rest = rest;
            if let Some(r) = self.dec.push(b) {
                return Some(r);
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proto::{encode_frame, Command, EncodeError};

    fn wire(seqs: &[u32]) -> std::vec::Vec<u8> {
        let mut out = std::vec::Vec::new();
        for &s in seqs {
            let mut buf = [0u8; MAX_FRAME];
            let n = encode_frame(s, &Command::ReadFieldLog { from_checkpoint: s }, &mut buf).unwrap();
            out.extend_from_slice(&buf[..n]);
        }
        out
    }

    fn seqs(dec: &mut Decoder<Command>, bytes: &[u8]) -> std::vec::Vec<(u32, u32)> {
        dec.feed(bytes).filter_map(Result::ok).map(|r| (r.seq, r.lost)).collect()
    }

    #[test]
    fn gaps_wraps_and_restarts() {
        let mut dec = Decoder::<Command>::new();
        let got = seqs(&mut dec, &wire(&[u32::MAX - 1, u32::MAX, 0, 3, 4, 2, 3]));
        assert_eq!(got, [(u32::MAX - 1, 0), (u32::MAX, 0), (0, 0), (3, 2), (4, 0), (2, 0), (3, 0)]);
        assert_eq!((dec.stats().lost, dec.stats().restarts, dec.stats().frames), (2, 1, 7));
    }

    #[test]
    fn idle_delimiters_are_ignored_and_oversize_is_counted() {
        let mut dec = Decoder::<Command>::new();
        let mut bytes = std::vec![0u8; 5];
        bytes.extend(std::iter::repeat_n(0x11, 3 * MAX_FRAME));
        bytes.push(0);
        bytes.extend(wire(&[9]));
        let got: std::vec::Vec<_> = dec.feed(&bytes).collect();
        assert_eq!(got.len(), 2);
        assert_eq!(got[0], Err(DecodeError::Oversize));
        assert_eq!(got[1].as_ref().unwrap().seq, 9);
        assert_eq!(dec.stats().oversize, 1);
        assert_eq!(dec.stats().dropped_bytes, 3 * MAX_FRAME as u64);
        assert_eq!(dec.stats().bytes, bytes.len() as u64);
    }

    #[test]
    fn short_bad_and_foreign_frames() {
        let mut dec = Decoder::<Command>::new();
        // COBS of 8 bytes: too short for seq + body + crc.
        assert_eq!(dec.feed(&[9, 1, 2, 3, 4, 5, 6, 7, 8, 0]).next(), Some(Err(DecodeError::Truncated)));
        // A code byte pointing past the end: invalid COBS.
        assert_eq!(dec.feed(&[0x20, 1, 2, 0]).next(), Some(Err(DecodeError::Cobs)));
        // A valid frame whose body is not a Command (variant index 9).
        let mut buf = [0u8; 32];
        let n = encode_frame(1, &[9u8, 0, 0][..], &mut buf).map_err(|_: EncodeError| ()).unwrap();
        assert_eq!(dec.feed(&buf[..n]).next(), Some(Err(DecodeError::Body)));
        // Trailing bytes after a valid body.
        let n = encode_frame(1, &(Command::StopRaw, 5u8), &mut buf).unwrap();
        assert_eq!(dec.feed(&buf[..n]).next(), Some(Err(DecodeError::Body)));
        let s = dec.stats();
        assert_eq!((s.truncated, s.cobs_errors, s.decode_errors, s.frames), (1, 1, 2, 0));
        assert_eq!(s.errors(), 4);
    }

    #[test]
    fn finish_drops_the_tail() {
        let mut dec = Decoder::<Command>::new();
        let w = wire(&[1, 2]);
        let cut = w.len() - 3;
        assert_eq!(seqs(&mut dec, &w[..cut]), [(1, 0)]);
        assert!(dec.pending() > 0);
        let tail = dec.finish();
        assert_eq!(dec.pending(), 0);
        assert_eq!(dec.stats().dropped_bytes, tail);
        assert_eq!(seqs(&mut dec, &wire(&[3])), [(3, 1)]);
    }
}

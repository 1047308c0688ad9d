//! Decoding captures: bytes in any chunking, typed records out, with counts of everything that went wrong.
//!
//! A capture (see [`crate::capture`]) is decoded in a stream, in bounded memory, whatever its size:
//! [`StreamDecoder`] takes bytes and emits [`Decoded`] records (hello, raw samples, snapshots joined from their
//! parts, status, estimates, field-log snapshots), each with the sequence number and byte offset of its frame.
//! Damaged frames (CRC, COBS, length, body) and lost sequence numbers are counted in [`DecodeStats`], never
//! fatal; the first [`MAX_BAD_FRAMES_LISTED`] bad frames are listed with their byte offsets. A frame is accepted
//! only when its CRC-32 matches, so no corrupted frame ever comes out. [`CaptureReader`] wraps a reader.
//!
//! [`export`] writes the records as CSV files and gathers the [`DecodeSummary`] that `octavar decode` prints
//! and writes as JSON.
//!
//! # Examples
//! ```
//! use octavar_io::decode::{CaptureReader, Message};
//! use octavar_shared::proto::{Encoder, Frame, Status};
//! let mut enc = Encoder::new();
//! let status = Frame::Status(Status {
//!     uptime_ms: 1000, samples_per_channel: 2000, adc_overruns: 0, frames_dropped: 0, temperature_c: None,
//!     samples_lost: 0, stack_peak_bytes: Some(2048),
//! });
//! let mut bytes = enc.encode_to_vec(&status).unwrap().to_vec();
//! bytes.extend_from_slice(&[0x42, 0x13]); // a frame cut short at the end of the capture
//! let mut reader = CaptureReader::new(&bytes[..], "example");
//! let records: Vec<_> = reader.by_ref().collect::<Result<_, _>>().unwrap();
//! assert!(matches!(records[0].message, Message::Status(_)));
//! assert_eq!(reader.stats().frames, 1);
//! assert_eq!(reader.stats().truncated_tail, 2);
//! ```

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{self, BufWriter, Read};
use std::path::{Path, PathBuf};

use octavar_shared::acc::{Snapshot, LEVELS};
use octavar_shared::proto::{
    self, Ack, CheckpointReport, Decoder, Estimate, FieldLogEnd, FieldLogRecord, Frame, Hello, Samples, SnapshotError,
    SnapshotPart, Status, LEVELS_PER_PART, PROTOCOL_VERSION,
};
use serde::Serialize;

mod checkpoints;
mod export;
mod stream;
mod summary;

pub use checkpoints::{gyro_channels, Checkpoint, Checkpoints};

pub use export::{export, ExportOptions};
pub use stream::{open, CaptureReader, StreamDecoder};
pub use summary::{
    adev_codes_at, level_rows, ChannelEstimate, CheckpointSummary, DecodeSummary, EstimateSummary, LevelRow,
    SnapshotSummary, StatusSummary, Thinned,
};

/// Bad frames listed by offset in [`DecodeStats::bad_frames`]; the rest are only counted.
pub const MAX_BAD_FRAMES_LISTED: usize = 100;
/// Field-log snapshots waiting for their parts at most (beyond, the waiting ones are dropped and counted).
pub const MAX_PENDING_FIELD_LOG: usize = 64;
/// Statuses and estimates kept in a [`DecodeSummary`]: long captures are thinned evenly to this many (the CSV
/// files have them all).
pub const MAX_SERIES: usize = 4096;

/// What went wrong while decoding, and where.
#[derive(Debug, thiserror::Error)]
pub enum DecodeError {
    /// Reading the capture failed.
    #[error("reading {name} at byte {offset}: {source}")]
    Read {
        /// The capture.
        name: String,
        /// Bytes read before the error.
        offset: u64,
        /// The I/O error.
        source: io::Error,
    },
    /// The capture could not be opened.
    #[error(transparent)]
    Open(#[from] crate::capture::CaptureError),
    /// The capture is empty.
    #[error("{name} is empty (0 bytes): nothing was recorded")]
    Empty {
        /// The capture.
        name: String,
    },
    /// An output file could not be written.
    #[error("writing {}: {source}", path.display())]
    Write {
        /// The output file.
        path: PathBuf,
        /// The I/O error.
        source: io::Error,
    },
}

/// Where a record came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct FrameMeta {
    /// The frame's sequence number (for a joined snapshot: its last part's).
    pub seq: u32,
    /// Sequence numbers missing just before this frame.
    pub lost: u32,
    /// The sequence number went backwards just before this frame: the device restarted.
    pub restart: bool,
    /// Byte offset of the frame's first byte in the capture (for a joined snapshot: its first part's).
    pub offset: u64,
}

/// One channel's snapshot, joined from its parts.
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelSnapshot {
    /// Channel index.
    pub channel: u8,
    /// The counts and exact sums.
    pub snapshot: Snapshot,
}

/// One channel's snapshot of a field-log checkpoint, joined from its parts.
#[derive(Clone, Debug, PartialEq)]
pub struct FieldLogSnapshot {
    /// The checkpoint's number in the log.
    pub checkpoint: u32,
    /// Sampling time covered, s.
    pub time_s: u32,
    /// Power-on sessions pooled.
    pub sessions: u32,
    /// ADC overruns over those sessions.
    pub adc_overruns: u32,
    /// Channel index.
    pub channel: u8,
    /// The counts and exact sums.
    pub snapshot: Snapshot,
}

/// A decoded message: one frame's content, or a snapshot assembled from its parts.
#[derive(Clone, Debug, PartialEq)]
pub enum Message {
    /// The device introduced itself.
    Hello(Hello),
    /// Raw codes.
    Samples(Samples),
    /// A snapshot (all its parts arrived intact).
    Snapshot(ChannelSnapshot),
    /// Health counters.
    Status(Status),
    /// Onboard N and B.
    Estimate(Estimate),
    /// A snapshot read back from the field log.
    FieldLog(FieldLogSnapshot),
    /// The end of a field-log read-out.
    FieldLogEnd(FieldLogEnd),
    /// The device carried out the host command with this sequence number.
    Ack(Ack),
    /// What a checkpoint the host asked for cost.
    CheckpointReport(CheckpointReport),
}

/// A message and the frame it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct Decoded {
    /// Its frame.
    pub meta: FrameMeta,
    /// The message.
    pub message: Message,
}

/// Why a frame was dropped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BadReason {
    /// Longer than a frame can be, with no delimiter.
    Oversize,
    /// Invalid COBS.
    Cobs,
    /// Too short for a frame.
    Short,
    /// CRC mismatch: corrupted.
    Crc,
    /// The CRC matches but the body is not a frame this host knows.
    Body,
    /// An intact snapshot part whose sibling parts are missing or inconsistent.
    SnapshotParts,
}

impl BadReason {
    fn of(e: proto::DecodeError) -> Self {
        match e {
            proto::DecodeError::Oversize => BadReason::Oversize,
            proto::DecodeError::Cobs => BadReason::Cobs,
            proto::DecodeError::Truncated => BadReason::Short,
            proto::DecodeError::Crc => BadReason::Crc,
            proto::DecodeError::Body => BadReason::Body,
        }
    }

    /// A few words for people.
    pub fn describe(&self) -> &'static str {
        match self {
            BadReason::Oversize => "no delimiter within the frame size limit",
            BadReason::Cobs => "invalid COBS encoding",
            BadReason::Short => "frame too short",
            BadReason::Crc => "CRC mismatch",
            BadReason::Body => "intact frame of an unknown kind (another protocol version?)",
            BadReason::SnapshotParts => "snapshot part without its sibling parts",
        }
    }
}

/// A dropped frame and where it was.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct BadFrame {
    /// Byte offset of its first byte.
    pub offset: u64,
    /// Its length in bytes (delimiter not counted).
    pub len: u64,
    /// Why it was dropped.
    pub reason: BadReason,
}

/// Everything counted while decoding a capture.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct DecodeStats {
    /// Bytes decoded.
    pub bytes: u64,
    /// Frames accepted (intact).
    pub frames: u64,
    /// Sequence numbers missing: frames the device sent that did not arrive intact (dropped ones included).
    pub lost_frames: u64,
    /// Times the sequence number went backwards (the device restarted).
    pub restarts: u64,
    /// Frames dropped for a CRC mismatch.
    pub crc_errors: u64,
    /// Frames dropped for invalid COBS.
    pub cobs_errors: u64,
    /// Frames dropped as too short.
    pub short_frames: u64,
    /// Frames dropped for exceeding the size limit.
    pub oversize_frames: u64,
    /// Intact frames whose body did not decode.
    pub body_errors: u64,
    /// Bytes of dropped frames, the truncated tail included.
    pub bytes_dropped: u64,
    /// Bytes of an unterminated frame at the end (the capture was cut mid-frame).
    pub truncated_tail: u64,
    /// Hello frames.
    pub hellos: u64,
    /// Samples frames.
    pub samples_frames: u64,
    /// Sample sets (scans) in those frames.
    pub sample_sets: u64,
    /// Snapshot parts received.
    pub snapshot_parts: u64,
    /// Snapshots joined from their parts.
    pub snapshots: u64,
    /// Snapshots left incomplete (a part lost or inconsistent): their intact parts are dropped.
    pub incomplete_snapshots: u64,
    /// Status frames.
    pub statuses: u64,
    /// Estimate frames.
    pub estimates: u64,
    /// Field-log snapshots joined.
    pub field_log_snapshots: u64,
    /// Field-log end frames.
    pub field_log_ends: u64,
    /// Command acknowledgements.
    pub acks: u64,
    /// Reports of checkpoints the host asked for.
    pub checkpoint_reports: u64,
    /// A hello announced a protocol version this host does not know.
    pub unknown_protocol: Option<u16>,
    /// The first bad frames, with their offsets.
    pub bad_frames: Vec<BadFrame>,
}

impl DecodeStats {
    /// Frames dropped, all reasons together.
    pub fn bad_frame_count(&self) -> u64 {
        self.crc_errors + self.cobs_errors + self.short_frames + self.oversize_frames + self.body_errors
    }
}

#[cfg(test)]
mod tests;

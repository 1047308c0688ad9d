//! Decoding captures: bytes in any chunking, typed records out, with counts of everything that went wrong.
//!
//! A capture (see [`crate::io::capture`]) is decoded in a stream, in bounded memory, whatever its size:
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
//! use octavar::io::decode::{CaptureReader, Record};
//! use octavar_shared::proto::{Encoder, Frame, Status};
//! let mut enc = Encoder::new();
//! let status = Frame::Status(Status {
//!     uptime_ms: 1000, samples_per_channel: 2000, adc_overruns: 0, frames_dropped: 0, temperature_c: None,
//!     samples_lost: 0,
//! });
//! let mut bytes = enc.encode_to_vec(&status).unwrap().to_vec();
//! bytes.extend_from_slice(&[0x42, 0x13]); // a frame cut short at the end of the capture
//! let mut reader = CaptureReader::new(&bytes[..], "example");
//! let records: Vec<_> = reader.by_ref().collect::<Result<_, _>>().unwrap();
//! assert!(matches!(records[0].record, Record::Status(_)));
//! assert_eq!(reader.stats().frames, 1);
//! assert_eq!(reader.stats().truncated_tail, 2);
//! ```

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{self, BufWriter, Read, Write};
use std::path::{Path, PathBuf};

use octavar_shared::acc::{Snapshot, LEVELS};
use octavar_shared::proto::{
    self, Ack, Decoder, Estimate, FieldLogEnd, FieldLogRecord, Frame, Hello, Samples, SnapshotError, SnapshotPart,
    Status, LEVELS_PER_PART, PROTOCOL_VERSION,
};
use serde::Serialize;

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
    Open(#[from] crate::io::capture::CaptureError),
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

/// A decoded record.
#[derive(Clone, Debug, PartialEq)]
pub enum Record {
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
}

/// A record and where it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct Decoded {
    /// Its frame.
    pub meta: FrameMeta,
    /// The record.
    pub record: Record,
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

/// Parts of a snapshot waiting for their siblings.
#[derive(Debug, Default)]
struct Pending {
    parts: Vec<SnapshotPart>,
    /// Offset of the first part.
    offset: u64,
}

/// The streaming decoder of capture bytes into [`Decoded`] records.
pub struct StreamDecoder {
    dec: Decoder<Frame>,
    /// Bytes fed so far: the offset of the next byte.
    offset: u64,
    /// Offset of the first byte of the frame in progress.
    frame_start: u64,
    /// Snapshot parts waiting, per channel.
    snapshots: BTreeMap<u8, Pending>,
    /// Field-log parts waiting, per (checkpoint, channel).
    field_log: BTreeMap<(u32, u8), Pending>,
    stats: DecodeStats,
}

impl Default for StreamDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl StreamDecoder {
    /// A decoder at byte 0.
    pub fn new() -> Self {
        StreamDecoder {
            dec: Decoder::new(),
            offset: 0,
            frame_start: 0,
            snapshots: BTreeMap::new(),
            field_log: BTreeMap::new(),
            stats: DecodeStats::default(),
        }
    }

    /// The counts so far.
    pub fn stats(&self) -> &DecodeStats {
        &self.stats
    }

    /// Bytes fed so far.
    pub fn offset(&self) -> u64 {
        self.offset
    }

    /// Feed bytes; `emit` gets every record they complete, in order.
    pub fn feed(&mut self, bytes: &[u8], emit: &mut dyn FnMut(Decoded)) {
        for &b in bytes {
            let at = self.offset;
            self.offset += 1;
            self.stats.bytes += 1;
            if self.dec.pending() == 0 {
                self.frame_start = at;
            }
            let restarts = self.dec.stats().restarts;
            let Some(r) = self.dec.push(b) else { continue };
            let start = self.frame_start;
            match r {
                Ok(rx) => {
                    let meta = FrameMeta {
                        seq: rx.seq,
                        lost: rx.lost,
                        restart: self.dec.stats().restarts > restarts,
                        offset: start,
                    };
                    self.frame(meta, rx.msg, emit);
                }
                Err(e) => self.bad(start, at - start, BadReason::of(e)),
            }
            self.sync_counts();
        }
    }

    /// The end of the capture: an unterminated frame is dropped and counted as a truncated tail, and snapshot
    /// parts still waiting for siblings count as incomplete snapshots. Returns the tail's length.
    pub fn finish(&mut self) -> u64 {
        let start = self.frame_start;
        let tail = self.dec.finish();
        self.stats.truncated_tail += tail;
        if tail > 0 {
            self.list_bad(BadFrame { offset: start, len: tail, reason: BadReason::Short });
        }
        let waiting = self.snapshots.len() + self.field_log.len();
        self.stats.incomplete_snapshots += waiting as u64;
        self.snapshots.clear();
        self.field_log.clear();
        self.sync_counts();
        tail
    }

    fn sync_counts(&mut self) {
        let d = self.dec.stats();
        let s = &mut self.stats;
        s.frames = d.frames;
        s.lost_frames = d.lost;
        s.restarts = d.restarts;
        s.crc_errors = d.crc_errors;
        s.cobs_errors = d.cobs_errors;
        s.short_frames = d.truncated;
        s.oversize_frames = d.oversize;
        s.body_errors = d.decode_errors;
        s.bytes_dropped = d.dropped_bytes;
    }

    fn bad(&mut self, offset: u64, len: u64, reason: BadReason) {
        self.list_bad(BadFrame { offset, len, reason });
    }

    fn list_bad(&mut self, b: BadFrame) {
        if self.stats.bad_frames.len() < MAX_BAD_FRAMES_LISTED {
            self.stats.bad_frames.push(b);
        }
    }

    fn frame(&mut self, mut meta: FrameMeta, frame: Frame, emit: &mut dyn FnMut(Decoded)) {
        if meta.restart {
            // Parts from before a restart never get their siblings.
            self.stats.incomplete_snapshots += (self.snapshots.len() + self.field_log.len()) as u64;
            self.snapshots.clear();
            self.field_log.clear();
        }
        let record = match frame {
            Frame::Hello(h) => {
                self.stats.hellos += 1;
                if h.protocol_version != PROTOCOL_VERSION {
                    self.stats.unknown_protocol = Some(h.protocol_version);
                }
                Record::Hello(h)
            }
            Frame::Samples(s) => {
                self.stats.samples_frames += 1;
                self.stats.sample_sets += s.sets() as u64;
                Record::Samples(s)
            }
            Frame::Status(s) => {
                self.stats.statuses += 1;
                Record::Status(s)
            }
            Frame::Estimate(e) => {
                self.stats.estimates += 1;
                Record::Estimate(e)
            }
            Frame::FieldLogEnd(e) => {
                self.stats.field_log_ends += 1;
                Record::FieldLogEnd(e)
            }
            Frame::Ack(a) => {
                self.stats.acks += 1;
                Record::Ack(a)
            }
            Frame::AllanSnapshot(part) => {
                self.stats.snapshot_parts += 1;
                let channel = part.channel;
                match join_part(&mut self.snapshots, channel, part, meta.offset, &mut self.stats) {
                    Joined::Waiting => return,
                    Joined::Broken => {
                        self.bad(meta.offset, 0, BadReason::SnapshotParts);
                        return;
                    }
                    Joined::Done(snapshot, first_offset) => {
                        self.stats.snapshots += 1;
                        meta.offset = first_offset;
                        Record::Snapshot(ChannelSnapshot { channel, snapshot: *snapshot })
                    }
                }
            }
            Frame::FieldLog(rec) => {
                let key = (rec.checkpoint, rec.part.channel);
                if !self.field_log.contains_key(&key) && self.field_log.len() >= MAX_PENDING_FIELD_LOG {
                    // Bounded memory: a stream of first parts that never complete is dropped, counted.
                    self.stats.incomplete_snapshots += self.field_log.len() as u64;
                    self.field_log.clear();
                }
                let FieldLogRecord { checkpoint, time_s, sessions, adc_overruns, part } = rec;
                match join_part(&mut self.field_log, key, part, meta.offset, &mut self.stats) {
                    Joined::Waiting => return,
                    Joined::Broken => {
                        self.bad(meta.offset, 0, BadReason::SnapshotParts);
                        return;
                    }
                    Joined::Done(snapshot, first_offset) => {
                        self.stats.field_log_snapshots += 1;
                        meta.offset = first_offset;
                        Record::FieldLog(FieldLogSnapshot {
                            checkpoint,
                            time_s,
                            sessions,
                            adc_overruns,
                            channel: key.1,
                            snapshot: *snapshot,
                        })
                    }
                }
            }
        };
        emit(Decoded { meta, record });
    }
}

/// What joining one part gave.
enum Joined {
    /// More parts to come.
    Waiting,
    /// The part does not fit: the pending parts of its key are dropped (counted).
    Broken,
    /// The whole snapshot, and the stream offset of its first part.
    Done(Box<Snapshot>, u64),
}

/// Add `part` to the pending parts under `key` (snapshots by channel, field-log records by checkpoint and
/// channel), count the snapshots lost on the way, and forget the key once it is joined or broken.
fn join_part<K: Ord + Copy>(
    pending: &mut BTreeMap<K, Pending>,
    key: K,
    part: SnapshotPart,
    offset: u64,
    stats: &mut DecodeStats,
) -> Joined {
    let slot = pending.entry(key).or_default();
    let result = add_part(slot, part, offset);
    let first_offset = slot.offset;
    match result {
        PartResult::Waiting => Joined::Waiting,
        PartResult::Broken(lost) => {
            stats.incomplete_snapshots += lost;
            pending.remove(&key);
            Joined::Broken
        }
        PartResult::Done(snapshot, dropped) => {
            stats.incomplete_snapshots += dropped;
            pending.remove(&key);
            Joined::Done(snapshot, first_offset)
        }
    }
}

enum PartResult {
    /// More parts to come.
    Waiting,
    /// The part does not fit; this many snapshots are lost.
    Broken(u64),
    /// Joined; this many earlier incomplete snapshots were dropped on the way.
    Done(Box<Snapshot>, u64),
}

/// Add a part to the waiting ones of its channel; join when it is the last.
fn add_part(slot: &mut Pending, part: SnapshotPart, offset: u64) -> PartResult {
    let mut dropped = 0;
    if part.first_level == 0 {
        if !slot.parts.is_empty() {
            dropped += 1; // a new snapshot starts before the previous one was complete
            slot.parts.clear();
        }
        slot.offset = offset;
    } else {
        let follows = slot.parts.last().is_some_and(|p| {
            (p.stride, p.samples, p.level_count) == (part.stride, part.samples, part.level_count)
                && usize::from(p.first_level) + p.levels.len() == usize::from(part.first_level)
        });
        if !follows {
            let lost = u64::from(!slot.parts.is_empty()) + 1;
            slot.parts.clear();
            return PartResult::Broken(lost);
        }
    }
    let last = part.is_last();
    slot.parts.push(part);
    if !last {
        // A snapshot has at most LEVELS / LEVELS_PER_PART parts: more is a malformed stream.
        if slot.parts.len() > LEVELS / LEVELS_PER_PART {
            slot.parts.clear();
            return PartResult::Broken(dropped + 1);
        }
        return PartResult::Waiting;
    }
    let joined: Result<(u8, Snapshot), SnapshotError> = SnapshotPart::join(&slot.parts);
    slot.parts.clear();
    match joined {
        Ok((_, snap)) => PartResult::Done(Box::new(snap), dropped),
        Err(_) => PartResult::Broken(dropped + 1),
    }
}

/// Decodes a capture from a reader: an iterator of records; I/O errors end it.
pub struct CaptureReader<R> {
    reader: R,
    name: String,
    dec: StreamDecoder,
    queue: std::collections::VecDeque<Decoded>,
    buf: Vec<u8>,
    done: bool,
}

impl<R: Read> CaptureReader<R> {
    /// Decode `reader`, called `name` in errors.
    pub fn new(reader: R, name: &str) -> Self {
        CaptureReader {
            reader,
            name: name.to_string(),
            dec: StreamDecoder::new(),
            queue: Default::default(),
            buf: vec![0; 1 << 16],
            done: false,
        }
    }

    /// The counts so far (complete once the iterator returned `None`).
    pub fn stats(&self) -> &DecodeStats {
        self.dec.stats()
    }

    /// The capture's name.
    pub fn name(&self) -> &str {
        &self.name
    }
}

impl<R: Read> Iterator for CaptureReader<R> {
    type Item = Result<Decoded, DecodeError>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            if let Some(d) = self.queue.pop_front() {
                return Some(Ok(d));
            }
            if self.done {
                return None;
            }
            let n = match self.reader.read(&mut self.buf) {
                Ok(n) => n,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(source) => {
                    self.done = true;
                    return Some(Err(DecodeError::Read { name: self.name.clone(), offset: self.dec.offset(), source }));
                }
            };
            if n == 0 {
                self.done = true;
                self.dec.finish();
                if self.dec.offset() == 0 {
                    return Some(Err(DecodeError::Empty { name: self.name.clone() }));
                }
                continue;
            }
            let queue = &mut self.queue;
            self.dec.feed(&self.buf[..n], &mut |d| queue.push_back(d));
        }
    }
}

/// Open a capture (`-` for stdin) for decoding.
///
/// # Errors
/// [`DecodeError::Open`] naming the path.
pub fn open(path: &Path) -> Result<CaptureReader<Box<dyn Read + Send>>, DecodeError> {
    let input = crate::io::capture::open(path)?;
    Ok(CaptureReader::new(input.reader, &input.name))
}

/// Keeps at most `cap` items of a series, evenly spaced: when full, every other one is dropped and the
/// spacing doubles.
#[derive(Clone, Debug)]
pub struct Thinned<T> {
    items: Vec<T>,
    step: u64,
    seen: u64,
    cap: usize,
}

impl<T> Thinned<T> {
    /// An empty series keeping at most `cap` items (at least 2).
    pub fn new(cap: usize) -> Self {
        Thinned { items: Vec::new(), step: 1, seen: 0, cap: cap.max(2) }
    }

    /// Offer the next item of the series.
    pub fn push(&mut self, item: T) {
        if self.seen.is_multiple_of(self.step) {
            self.items.push(item);
            if self.items.len() > self.cap {
                let mut i = 0;
                self.items.retain(|_| {
                    i += 1;
                    i % 2 == 1
                });
                self.step *= 2;
            }
        }
        self.seen += 1;
    }

    /// Items offered.
    pub fn seen(&self) -> u64 {
        self.seen
    }

    /// The kept items, and the spacing between them.
    pub fn into_parts(self) -> (Vec<T>, u64) {
        (self.items, self.step)
    }
}

/// One level of a snapshot in the summary.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LevelRow {
    /// Level k: clusters of m = 2^k samples.
    pub level: u8,
    /// Cluster size, samples.
    pub m: u64,
    /// Averaging time, s (`None` without a hello giving the sample rate).
    pub tau_s: Option<f64>,
    /// Second differences.
    pub n: u64,
    /// Their exact sum of squares, codes^2 (a decimal string in JSON).
    #[serde(serialize_with = "decimal")]
    pub sum_sq: u128,
    /// Allan variance, codes^2.
    pub avar_codes2: f64,
    /// Allan deviation, codes.
    pub adev_codes: f64,
}

fn decimal<S: serde::Serializer>(v: &u128, s: S) -> Result<S::Ok, S::Error> {
    s.collect_str(v)
}

/// The rows of every level with n > 0.
pub fn level_rows(snap: &Snapshot, rate_hz: Option<f64>) -> Vec<LevelRow> {
    (0..LEVELS)
        .filter_map(|k| {
            let avar = snap.avar_codes2(k)?;
            let m = 1u64 << k;
            let l = snap.levels[k];
            Some(LevelRow {
                level: k as u8,
                m,
                tau_s: rate_hz.map(|r| m as f64 / r),
                n: l.n,
                sum_sq: l.sum_sq,
                avar_codes2: avar,
                adev_codes: avar.sqrt(),
            })
        })
        .collect()
}

/// Allan deviation in codes at `tau_s`, interpolated log-log between the octaves around it (`None` when the
/// snapshot does not reach both).
pub fn adev_codes_at(snap: &Snapshot, rate_hz: f64, tau_s: f64) -> Option<f64> {
    if !(rate_hz > 0.0 && tau_s > 0.0) {
        return None;
    }
    let x = (tau_s * rate_hz).log2(); // level, fractional
    if x < 0.0 {
        return None;
    }
    let lo = x.floor() as usize;
    let a = snap.adev_codes(lo)?;
    let frac = x - lo as f64;
    if frac == 0.0 {
        return Some(a);
    }
    let b = snap.adev_codes(lo + 1)?;
    if a <= 0.0 || b <= 0.0 {
        return Some(a + (b - a) * frac);
    }
    Some((a.ln() + (b.ln() - a.ln()) * frac).exp())
}

/// A snapshot in the summary.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SnapshotSummary {
    /// Sequence number of its last frame.
    pub frame_seq: u32,
    /// Channel index.
    pub channel: u8,
    /// Channel name from the hello.
    pub name: Option<String>,
    /// Stride S.
    pub stride: u8,
    /// Samples accumulated.
    pub samples: u64,
    /// Allan deviation at tau = 1 s, codes (interpolated between octaves; `None` without a rate or so long a
    /// record).
    pub adev_1s_codes: Option<f64>,
    /// Levels with n > 0.
    pub levels: Vec<LevelRow>,
}

/// A status in the summary.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StatusSummary {
    /// Frame sequence number.
    pub frame_seq: u32,
    /// The status.
    #[serde(flatten)]
    pub status: Status,
}

/// An estimate in the summary.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EstimateSummary {
    /// Frame sequence number.
    pub frame_seq: u32,
    /// The estimate.
    #[serde(flatten)]
    pub estimate: Estimate,
}

/// What `octavar decode` reports: the JSON document.
#[derive(Clone, Debug, Serialize)]
pub struct DecodeSummary {
    /// The capture.
    pub source: String,
    /// The last hello.
    pub hello: Option<Hello>,
    /// Every count.
    pub stats: DecodeStats,
    /// Sample sets received per channel index.
    pub samples_per_channel: BTreeMap<u8, u64>,
    /// The last snapshot of each channel.
    pub snapshots: Vec<SnapshotSummary>,
    /// Statuses (all of them up to [`MAX_SERIES`], evenly thinned beyond).
    pub statuses: Vec<StatusSummary>,
    /// Spacing of the kept statuses (1: all).
    pub statuses_every: u64,
    /// Estimates, kept as statuses are.
    pub estimates: Vec<EstimateSummary>,
    /// Spacing of the kept estimates.
    pub estimates_every: u64,
    /// The last field-log snapshot of each channel.
    pub field_log: Vec<SnapshotSummary>,
    /// CSV files written.
    pub csv_files: Vec<PathBuf>,
}

/// Options of [`export`].
#[derive(Clone, Debug, Default)]
pub struct ExportOptions {
    /// Write samples.csv, snapshots.csv, status.csv, estimates.csv and fieldlog.csv here (created if missing).
    pub csv_dir: Option<PathBuf>,
}

struct Csv {
    path: PathBuf,
    w: csv::Writer<BufWriter<File>>,
}

impl Csv {
    fn create(dir: &Path, name: &str, header: &[String]) -> Result<Self, DecodeError> {
        let path = dir.join(name);
        let file = File::create(&path).map_err(|source| DecodeError::Write { path: path.clone(), source })?;
        let w = csv::WriterBuilder::new().flexible(false).from_writer(BufWriter::new(file));
        let mut c = Csv { path, w };
        c.row(header)?;
        Ok(c)
    }

    fn row<I, T>(&mut self, fields: I) -> Result<(), DecodeError>
    where
        I: IntoIterator<Item = T>,
        T: AsRef<[u8]>,
    {
        self.w.write_record(fields).map_err(|e| csv_error(&self.path, e))
    }

    fn finish(mut self) -> Result<PathBuf, DecodeError> {
        self.w.flush().map_err(|source| DecodeError::Write { path: self.path.clone(), source })?;
        Ok(self.path)
    }
}

fn csv_error(path: &Path, e: csv::Error) -> DecodeError {
    let source = match e.into_kind() {
        csv::ErrorKind::Io(io) => io,
        other => io::Error::other(format!("{other:?}")),
    };
    DecodeError::Write { path: path.to_path_buf(), source }
}

fn opt<T: ToString>(v: Option<T>) -> String {
    v.map(|x| x.to_string()).unwrap_or_default()
}

fn header(cols: &[&str]) -> Vec<String> {
    cols.iter().map(|s| s.to_string()).collect()
}

/// The CSV outputs while they are being written.
struct CsvSet {
    dir: PathBuf,
    samples: Option<(Csv, usize)>,
    snapshots: Csv,
    status: Csv,
    estimates: Csv,
    field_log: Csv,
}

const SNAPSHOT_COLS: [&str; 10] =
    ["frame_seq", "channel", "samples", "level", "m", "tau_s", "n", "sum_sq", "avar_codes2", "adev_codes"];

impl CsvSet {
    fn create(dir: &Path) -> Result<Self, DecodeError> {
        std::fs::create_dir_all(dir).map_err(|source| DecodeError::Write { path: dir.to_path_buf(), source })?;
        let mut log_cols = header(&["frame_seq", "checkpoint", "time_s", "sessions", "adc_overruns"]);
        log_cols.extend(header(&SNAPSHOT_COLS[1..]));
        Ok(CsvSet {
            dir: dir.to_path_buf(),
            samples: None,
            snapshots: Csv::create(dir, "snapshots.csv", &header(&SNAPSHOT_COLS))?,
            status: Csv::create(
                dir,
                "status.csv",
                &header(&[
                    "frame_seq",
                    "uptime_ms",
                    "samples_per_channel",
                    "adc_overruns",
                    "frames_dropped",
                    "temperature_c",
                ]),
            )?,
            estimates: Csv::create(
                dir,
                "estimates.csv",
                &header(&["frame_seq", "samples", "channel", "n_dps_per_rt_s", "b_dps", "tau_b_s"]),
            )?,
            field_log: Csv::create(dir, "fieldlog.csv", &log_cols)?,
        })
    }

    fn snapshot_rows(csv: &mut Csv, prefix: &[String], snap: &Snapshot, rate: Option<f64>) -> Result<(), DecodeError> {
        for r in level_rows(snap, rate) {
            let mut row = prefix.to_vec();
            row.extend([
                snap.samples.to_string(),
                r.level.to_string(),
                r.m.to_string(),
                opt(r.tau_s),
                r.n.to_string(),
                r.sum_sq.to_string(),
                r.avar_codes2.to_string(),
                r.adev_codes.to_string(),
            ]);
            csv.row(&row)?;
        }
        Ok(())
    }

    fn record(&mut self, d: &Decoded, hello: Option<&Hello>) -> Result<(), DecodeError> {
        let seq = d.meta.seq.to_string();
        let rate = hello.map(|h| f64::from(h.sample_rate_hz));
        match &d.record {
            Record::Samples(s) => {
                if self.samples.is_none() {
                    // Columns: the hello's channels, or ch0..ch7 without one.
                    let names: Vec<String> = match hello {
                        Some(h) if !h.channels.is_empty() => h.channels.iter().map(|c| c.name.to_string()).collect(),
                        _ => (0..proto::MAX_CHANNELS).map(|i| format!("ch{i}")).collect(),
                    };
                    let mut cols = vec!["sample".to_string()];
                    let n = names.len();
                    cols.extend(names);
                    self.samples = Some((Csv::create(&self.dir, "samples.csv", &cols)?, n));
                }
                let (csv, columns) = self.samples.as_mut().expect("created above");
                let slots: Vec<usize> = s.mask_channels().collect();
                let mut row = vec![String::new(); *columns + 1];
                for set in 0..s.sets() {
                    row.iter_mut().for_each(String::clear);
                    row[0] = (s.first_sample + set as u64).to_string();
                    for (slot, &ch) in slots.iter().enumerate() {
                        if ch < *columns {
                            row[ch + 1] = s.code(set, slot).map(|c| c.to_string()).unwrap_or_default();
                        }
                    }
                    csv.row(&row)?;
                }
            }
            Record::Snapshot(c) => {
                Self::snapshot_rows(&mut self.snapshots, &[seq, c.channel.to_string()], &c.snapshot, rate)?;
            }
            Record::FieldLog(f) => {
                let prefix = [
                    seq,
                    f.checkpoint.to_string(),
                    f.time_s.to_string(),
                    f.sessions.to_string(),
                    f.adc_overruns.to_string(),
                    f.channel.to_string(),
                ];
                Self::snapshot_rows(&mut self.field_log, &prefix, &f.snapshot, rate)?;
            }
            Record::Status(s) => self.status.row([
                seq,
                s.uptime_ms.to_string(),
                s.samples_per_channel.to_string(),
                s.adc_overruns.to_string(),
                s.frames_dropped.to_string(),
                opt(s.temperature_c),
            ])?,
            Record::Estimate(e) => {
                for c in &e.channels {
                    self.estimates.row([
                        seq.clone(),
                        e.samples.to_string(),
                        c.channel.to_string(),
                        opt(c.n_dps_per_rt_s),
                        opt(c.b_dps),
                        opt(c.tau_b_s),
                    ])?;
                }
            }
            Record::Hello(_) | Record::FieldLogEnd(_) | Record::Ack(_) => {}
        }
        Ok(())
    }

    fn finish(self) -> Result<Vec<PathBuf>, DecodeError> {
        let mut files = Vec::new();
        if let Some((c, _)) = self.samples {
            files.push(c.finish()?);
        }
        for c in [self.snapshots, self.status, self.estimates, self.field_log] {
            files.push(c.finish()?);
        }
        Ok(files)
    }
}

/// Decode a whole capture: write the CSV files (if asked) as records come, and gather the summary.
///
/// # Errors
/// Reading the capture ([`DecodeError::Read`], [`DecodeError::Empty`]) or writing an output
/// ([`DecodeError::Write`]). Damaged frames are not errors: they are counted in the summary's stats.
pub fn export<R: Read>(mut reader: CaptureReader<R>, opts: &ExportOptions) -> Result<DecodeSummary, DecodeError> {
    let mut csv = opts.csv_dir.as_deref().map(CsvSet::create).transpose()?;
    let mut hello: Option<Hello> = None;
    let mut last: BTreeMap<u8, (u32, Snapshot)> = BTreeMap::new();
    let mut last_log: BTreeMap<u8, (u32, Snapshot)> = BTreeMap::new();
    let mut per_channel: BTreeMap<u8, u64> = BTreeMap::new();
    let mut statuses = Thinned::new(MAX_SERIES);
    let mut estimates = Thinned::new(MAX_SERIES);
    for d in reader.by_ref() {
        let d = d?;
        if let Some(csv) = csv.as_mut() {
            csv.record(&d, hello.as_ref())?;
        }
        let seq = d.meta.seq;
        match d.record {
            Record::Hello(h) => hello = Some(h),
            Record::Samples(s) => {
                for ch in s.mask_channels().map(|c| c as u8) {
                    *per_channel.entry(ch).or_default() += s.sets() as u64;
                }
            }
            Record::Snapshot(c) => {
                last.insert(c.channel, (seq, c.snapshot));
            }
            Record::FieldLog(f) => {
                last_log.insert(f.channel, (seq, f.snapshot));
            }
            Record::Status(status) => statuses.push(StatusSummary { frame_seq: seq, status }),
            Record::Estimate(estimate) => estimates.push(EstimateSummary { frame_seq: seq, estimate }),
            Record::FieldLogEnd(_) | Record::Ack(_) => {}
        }
    }
    let csv_files = csv.map(CsvSet::finish).transpose()?.unwrap_or_default();
    let rate = hello.as_ref().map(|h| f64::from(h.sample_rate_hz));
    let name_of = |ch: u8| hello.as_ref().and_then(|h| h.channels.get(usize::from(ch))).map(|c| c.name.to_string());
    let summarize = |m: BTreeMap<u8, (u32, Snapshot)>| -> Vec<SnapshotSummary> {
        m.into_iter()
            .map(|(channel, (frame_seq, s))| SnapshotSummary {
                frame_seq,
                channel,
                name: name_of(channel),
                stride: s.stride,
                samples: s.samples,
                adev_1s_codes: rate.and_then(|r| adev_codes_at(&s, r, 1.0)),
                levels: level_rows(&s, rate),
            })
            .collect()
    };
    let snapshots = summarize(last);
    let field_log = summarize(last_log);
    let (statuses, statuses_every) = statuses.into_parts();
    let (estimates, estimates_every) = estimates.into_parts();
    Ok(DecodeSummary {
        source: reader.name().to_string(),
        hello,
        stats: reader.stats().clone(),
        samples_per_channel: per_channel,
        snapshots,
        statuses,
        statuses_every,
        estimates,
        estimates_every,
        field_log,
        csv_files,
    })
}

/// Write the summary as pretty JSON to `path` (`-`: `out`).
///
/// # Errors
/// [`DecodeError::Write`] with the path.
pub fn write_json(summary: &DecodeSummary, path: &Path, out: &mut dyn Write) -> Result<(), DecodeError> {
    let err = |source| DecodeError::Write { path: path.to_path_buf(), source };
    if path == Path::new("-") {
        serde_json::to_writer_pretty(&mut *out, summary).map_err(|e| err(e.into()))?;
        return writeln!(out).map_err(err);
    }
    let file = File::create(path).map_err(err)?;
    let mut w = BufWriter::new(file);
    serde_json::to_writer_pretty(&mut w, summary).map_err(|e| err(e.into()))?;
    writeln!(w).and_then(|()| w.flush()).map_err(err)
}

#[cfg(test)]
mod tests {
    use super::*;
    use octavar_shared::acc::OctaveAllan;
    use octavar_shared::proto::{Encoder, Samples};

    fn snapshot(samples: u32) -> Snapshot {
        let mut acc = OctaveAllan::<8>::new();
        (0..samples).for_each(|i| acc.push((i.wrapping_mul(2654435761) >> 20) as u16));
        acc.snapshot()
    }

    fn records(bytes: &[u8]) -> (Vec<Decoded>, DecodeStats) {
        let mut r = CaptureReader::new(bytes, "t");
        let v = r.by_ref().collect::<Result<Vec<_>, _>>().unwrap();
        (v, r.stats().clone())
    }

    #[test]
    fn snapshot_parts_join_and_a_lost_part_is_counted() {
        let snap = snapshot(300_000); // 18 levels: two parts
        let parts: Vec<_> = SnapshotPart::split(2, &snap).collect();
        assert_eq!(parts.len(), 2);
        let mut enc = Encoder::new();
        let mut bytes = Vec::new();
        for p in &parts {
            bytes.extend_from_slice(&enc.encode_to_vec(&Frame::AllanSnapshot(p.clone())).unwrap());
        }
        // Second snapshot: only its second part arrives.
        enc.encode_to_vec(&Frame::AllanSnapshot(parts[0].clone())).unwrap();
        let second_at = bytes.len() as u64;
        bytes.extend_from_slice(&enc.encode_to_vec(&Frame::AllanSnapshot(parts[1].clone())).unwrap());
        let (recs, stats) = records(&bytes);
        assert_eq!(recs.len(), 1);
        assert_eq!(recs[0].record, Record::Snapshot(ChannelSnapshot { channel: 2, snapshot: snap }));
        assert_eq!(recs[0].meta.seq, 1);
        assert_eq!(recs[0].meta.offset, 0);
        assert_eq!((stats.snapshots, stats.snapshot_parts, stats.incomplete_snapshots), (1, 3, 1));
        assert_eq!(stats.lost_frames, 1);
        assert_eq!(stats.bad_frames, [BadFrame { offset: second_at, len: 0, reason: BadReason::SnapshotParts }]);
    }

    #[test]
    fn field_log_parts_join_with_their_checkpoint() {
        let snap = snapshot(300_000);
        let mut enc = Encoder::new();
        let mut bytes = Vec::new();
        for part in SnapshotPart::split(1, &snap) {
            let rec = FieldLogRecord { checkpoint: 3, time_s: 600, sessions: 2, adc_overruns: 1, part };
            bytes.extend_from_slice(&enc.encode_to_vec(&Frame::FieldLog(rec)).unwrap());
        }
        bytes.extend_from_slice(&enc.encode_to_vec(&Frame::FieldLogEnd(FieldLogEnd { checkpoints: 1 })).unwrap());
        let (recs, stats) = records(&bytes);
        let want =
            FieldLogSnapshot { checkpoint: 3, time_s: 600, sessions: 2, adc_overruns: 1, channel: 1, snapshot: snap };
        assert_eq!(recs[0].record, Record::FieldLog(want));
        assert_eq!(recs[1].record, Record::FieldLogEnd(FieldLogEnd { checkpoints: 1 }));
        assert_eq!((stats.field_log_snapshots, stats.field_log_ends, stats.incomplete_snapshots), (1, 1, 0));
    }

    #[test]
    fn offsets_locate_bad_frames_and_the_tail() {
        let mut enc = Encoder::new();
        let mut s = Samples::new(0, 1);
        s.push_set(&[7]).unwrap();
        let good = enc.encode_to_vec(&Frame::Samples(s.clone())).unwrap();
        let mut bad = enc.encode_to_vec(&Frame::Samples(s)).unwrap();
        bad[3] ^= 0x40;
        let mut bytes = good.to_vec();
        bytes.extend_from_slice(&bad);
        bytes.extend_from_slice(&good);
        bytes.extend_from_slice(&good[..5]);
        let (recs, stats) = records(&bytes);
        assert_eq!(recs.len(), 2);
        assert_eq!(recs[1].meta.offset, (good.len() + bad.len()) as u64);
        assert_eq!(stats.bad_frame_count(), 1);
        assert_eq!(stats.truncated_tail, 5);
        let first = stats.bad_frames[0];
        assert_eq!((first.offset, first.len), (good.len() as u64, bad.len() as u64 - 1));
        assert!(matches!(first.reason, BadReason::Crc | BadReason::Cobs), "{first:?}");
        assert_eq!(stats.bad_frames[1].offset, (2 * good.len() + bad.len()) as u64);
        assert_eq!(stats.bytes_dropped, bad.len() as u64 - 1 + 5);
    }

    #[test]
    fn an_empty_capture_is_an_error() {
        let mut r = CaptureReader::new(&[][..], "empty.cap");
        let e = r.next().unwrap().unwrap_err();
        assert_eq!(e.to_string(), "empty.cap is empty (0 bytes): nothing was recorded");
        assert!(r.next().is_none());
    }

    #[test]
    fn thinning_keeps_an_even_bounded_series() {
        let mut t = Thinned::new(8);
        (0..100u32).for_each(|i| t.push(i));
        let (items, step) = t.into_parts();
        assert!(items.len() <= 8);
        assert!(items.windows(2).all(|w| u64::from(w[1] - w[0]) == step), "{items:?} {step}");
        assert_eq!(items[0], 0);
    }

    #[test]
    fn adev_at_interpolates_between_octaves() {
        let snap = snapshot(1 << 16);
        let a = snap.adev_codes(10).unwrap();
        let b = snap.adev_codes(11).unwrap();
        assert_eq!(adev_codes_at(&snap, 1024.0, 1.0), Some(a));
        let mid = adev_codes_at(&snap, 2000.0, 1.0).unwrap();
        assert!(mid > a.min(b) && mid < a.max(b) || a == b, "{a} {mid} {b}");
        assert_eq!(adev_codes_at(&snap, 2000.0, 1e6), None);
    }
}

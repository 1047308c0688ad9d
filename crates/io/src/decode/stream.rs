//! The stream decoder: bytes in any chunking to [`Decoded`] records, snapshots joined from their parts, every
//! fault counted; and [`CaptureReader`], the decoder over a reader.

use super::*;

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
        let message = match frame {
            Frame::Hello(h) => {
                self.stats.hellos += 1;
                if h.protocol_version != PROTOCOL_VERSION {
                    self.stats.unknown_protocol = Some(h.protocol_version);
                }
                Message::Hello(h)
            }
            Frame::Samples(s) => {
                self.stats.samples_frames += 1;
                self.stats.sample_sets += s.sets() as u64;
                Message::Samples(s)
            }
            Frame::Status(s) => {
                self.stats.statuses += 1;
                Message::Status(s)
            }
            Frame::Estimate(e) => {
                self.stats.estimates += 1;
                Message::Estimate(e)
            }
            Frame::FieldLogEnd(e) => {
                self.stats.field_log_ends += 1;
                Message::FieldLogEnd(e)
            }
            Frame::Ack(a) => {
                self.stats.acks += 1;
                Message::Ack(a)
            }
            Frame::CheckpointReport(r) => {
                self.stats.checkpoint_reports += 1;
                Message::CheckpointReport(r)
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
                        Message::Snapshot(ChannelSnapshot { channel, snapshot: *snapshot })
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
                        Message::FieldLog(FieldLogSnapshot {
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
        emit(Decoded { meta, message });
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
    let input = crate::capture::open(path)?;
    Ok(CaptureReader::new(input.reader, &input.name))
}

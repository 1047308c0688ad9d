//! Verifying a capture: replay the raw samples through `shared::acc` and compare every device snapshot, bit for bit.
//!
//! The device accumulates its codes in `OctaveAllan<S>` and sends snapshots (n and the exact sum of squares per
//! level); while raw streaming is on it also sends the codes. The host replays those codes through the same
//! accumulator (the stride of the device's hello) and, for every snapshot, compares the replay at exactly the
//! snapshot's sample count with what the device sent: all 32 levels, n and sum_sq, and the stride.
//!
//! A snapshot can be checked only when the raw samples cover sample 0 up to its sample count. It cannot be
//! when raw streaming started after sampling began, when the channel was not streamed, when raw frames were
//! lost on the way (a sequence gap together with a jump in `first_sample`), after a device reset the raw stream
//! does not show, or when the capture ends first. Those snapshots are counted as not checked, with the reason.
//! A jump in `first_sample` without any lost frame is how the firmware reports samples lost on the device (an
//! ADC overrun): it pools its accumulators there, and so does the replay. Should the pooled replay not match
//! the next snapshot, the jump was something else (raw streaming paused and resumed), and the snapshots after
//! it are reported as not checkable rather than as mismatches. Everything else that differs is a [`Mismatch`].
//!
//! Memory is bounded: the replay keeps at most [`MAX_BUFFERED`] codes per channel ahead of the snapshots.
//!
//! # Examples
//! ```
//! use octavar::io::decode::CaptureReader;
//! use octavar::board::simulated::{device_frames, DeviceConfig};
//! let scans = (0..6_000u32).map(|i| [2048 + (i * 7 % 11) as u16, 2040, 2050, 2047, 1900]);
//! let wire = device_frames(DeviceConfig::F405, 0x1f, scans);
//! let report = octavar::board::verify::verify(CaptureReader::new(&wire[..], "run.cap")).unwrap();
//! assert_eq!((report.checked, report.matched, report.mismatched_snapshots), (12, 12, 0));
//! assert!(report.passed());
//! ```

use std::collections::{BTreeMap, VecDeque};
use std::io::Read;
use std::path::Path;

use octavar_shared::acc::{LevelSum, Snapshot, LEVELS};
use octavar_shared::proto::{Samples, PROTOCOL_VERSION};
use serde::Serialize;

use crate::board::accumulate::StridedAllan;
use crate::io::decode::{self, CaptureReader, DecodeError, DecodeStats, Decoded, FrameMeta, Message};

/// Codes per channel the replay holds ahead of the snapshots at most (beyond, it accumulates eagerly).
pub const MAX_BUFFERED: usize = 1 << 20;
/// Snapshots per channel waiting for their raw samples at most.
pub const MAX_PENDING: usize = 256;
/// Mismatches listed in the report; the rest are only counted.
pub const MAX_MISMATCHES_LISTED: usize = 1000;
/// The stride assumed when codes must be replayed before any hello or snapshot says (the firmware's).
const DEFAULT_STRIDE: usize = 8;

/// What went wrong, and where.
#[derive(Debug, thiserror::Error)]
pub enum VerifyError {
    /// The capture could not be read.
    #[error(transparent)]
    Decode(#[from] DecodeError),
    /// The device speaks a protocol version this host does not know.
    #[error("{name}: the hello frame at byte {offset} announces protocol version {version}; this octavar knows version {known}")]
    UnknownProtocol {
        /// The capture.
        name: String,
        /// The hello's byte offset.
        offset: u64,
        /// Its version.
        version: u16,
        /// The version this host knows.
        known: u16,
    },
}

/// Why a snapshot could not be checked.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Unchecked {
    /// No raw samples of the channel arrived (raw streaming off, or not for this channel).
    NotStreamed,
    /// Raw streaming started after sampling began.
    StartsLate {
        /// The first raw sample's index.
        first_sample: u64,
    },
    /// Raw frames were lost on the way (sequence gap): samples in between are missing.
    FramesLost {
        /// The first missing sample.
        from_sample: u64,
        /// The next sample received.
        to_sample: u64,
    },
    /// Raw samples jumped without any lost frame, and pooling there (a device-side gap) does not reproduce the
    /// device's snapshot: the samples in between were taken but not streamed.
    RawHole {
        /// The first missing sample.
        at_sample: u64,
        /// Samples missing.
        missing: u64,
    },
    /// The raw sample index went backwards (not to 0).
    Rewind {
        /// The index expected.
        expected: u64,
        /// The index received.
        first_sample: u64,
    },
    /// The device reset its accumulators (sample counts went back) and the raw stream does not show where.
    DeviceReset,
    /// The raw samples end before the snapshot's sample count.
    RawEnds {
        /// Samples replayed.
        raw_until: u64,
    },
    /// The replay had already gone past the snapshot (it arrived too late).
    TooLate,
}

impl std::fmt::Display for Unchecked {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Unchecked::NotStreamed => write!(f, "no raw samples of this channel"),
            Unchecked::StartsLate { first_sample } => {
                write!(f, "raw samples start at sample {first_sample}, after sampling began")
            }
            Unchecked::FramesLost { from_sample, to_sample } => {
                write!(f, "raw samples {from_sample}..{to_sample} lost on the way (frames missing)")
            }
            Unchecked::RawHole { at_sample, missing } => write!(
                f,
                "raw samples jump by {missing} at sample {at_sample} without a lost frame, and a device-side gap \
                 there does not reproduce the snapshot (raw streaming paused?)"
            ),
            Unchecked::Rewind { expected, first_sample } => {
                write!(f, "raw sample index went back from {expected} to {first_sample}")
            }
            Unchecked::DeviceReset => write!(f, "the device reset its accumulators where the raw stream does not show"),
            Unchecked::RawEnds { raw_until } => write!(f, "raw samples end at sample {raw_until}"),
            Unchecked::TooLate => write!(f, "the snapshot arrived after the replay had gone past it"),
        }
    }
}

/// Snapshots not checked for one reason on one channel.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct UncheckedGroup {
    /// Channel index.
    pub channel: u8,
    /// Why.
    pub reason: Unchecked,
    /// How many snapshots.
    pub count: u64,
    /// The first one's frame sequence number.
    pub first_seq: u32,
    /// The first one's byte offset.
    pub first_offset: u64,
}

/// What differs.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum MismatchField {
    /// The device's stride is not the replay's.
    Stride {
        /// The replay's (the hello's).
        expected: u8,
        /// The snapshot's.
        got: u8,
    },
    /// The sample counts differ.
    Samples {
        /// Replayed.
        expected: u64,
        /// The snapshot's.
        got: u64,
    },
    /// One level's n or sum of squares differs.
    Level {
        /// Level k (m = 2^k).
        level: u8,
        /// The replay's.
        expected: LevelSum,
        /// The device's.
        got: LevelSum,
    },
}

/// One value of one snapshot that differs from the replay.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Mismatch {
    /// Channel index.
    pub channel: u8,
    /// The snapshot's (last) frame sequence number.
    pub frame_seq: u32,
    /// Its byte offset.
    pub offset: u64,
    /// Its sample count.
    pub samples: u64,
    /// What differs.
    #[serde(flatten)]
    pub field: MismatchField,
}

impl std::fmt::Display for Mismatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "channel {}, snapshot at sample {} (frame {}, byte {}): ",
            self.channel, self.samples, self.frame_seq, self.offset
        )?;
        match &self.field {
            MismatchField::Stride { expected, got } => write!(f, "stride {got}, expected {expected}"),
            MismatchField::Samples { expected, got } => write!(f, "sample count {got}, expected {expected}"),
            MismatchField::Level { level, expected, got } => write!(
                f,
                "level {level}: n {} sum_sq {}, expected n {} sum_sq {}",
                got.n, got.sum_sq, expected.n, expected.sum_sq
            ),
        }
    }
}

/// Per-channel counts.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct ChannelVerify {
    /// Channel index.
    pub channel: u8,
    /// Its name from the hello.
    pub name: Option<String>,
    /// Snapshots received.
    pub snapshots: u64,
    /// Checked against the replay.
    pub checked: u64,
    /// Checked and identical.
    pub matched: u64,
    /// Not checkable.
    pub unchecked: u64,
    /// Raw samples received.
    pub raw_samples: u64,
}

/// The result of [`verify`].
#[derive(Clone, Debug, Default, Serialize)]
pub struct VerifyReport {
    /// The capture.
    pub source: String,
    /// The stride replayed.
    pub stride: Option<u8>,
    /// Snapshots received (all channels).
    pub snapshots: u64,
    /// Snapshots checked.
    pub checked: u64,
    /// Snapshots checked and identical in every level.
    pub matched: u64,
    /// Snapshots checked that differ.
    pub mismatched_snapshots: u64,
    /// Snapshots that could not be checked.
    pub unchecked: u64,
    /// Why, grouped by channel and reason.
    pub unchecked_why: Vec<UncheckedGroup>,
    /// Every differing value (the first [`MAX_MISMATCHES_LISTED`]).
    pub mismatches: Vec<Mismatch>,
    /// Differing values in all.
    pub mismatch_count: u64,
    /// Per channel.
    pub channels: Vec<ChannelVerify>,
    /// Samples the device lost, as jumps in the raw index that it pooled across (each confirmed or still to be
    /// confirmed by the next snapshot), in the order they came.
    pub device_gaps: Vec<DeviceGap>,
    /// Samples lost in all those gaps.
    pub device_samples_lost: u64,
    /// What the device's last status frame said it lost this session (`samples_lost`), to set beside
    /// [`VerifyReport::device_samples_lost`].
    pub status_samples_lost: Option<u64>,
    /// What the decoder counted.
    pub decode: DecodeStats,
}

/// A device-side gap: the raw samples jump, no frame was lost, and the device pooled its accumulators there.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct DeviceGap {
    /// The raw index (since the session began) of the first sample lost.
    pub at_sample: u64,
    /// Samples lost.
    pub lost: u64,
}

impl VerifyReport {
    /// True when at least one snapshot was checked and every checked snapshot matched.
    pub fn passed(&self) -> bool {
        self.checked > 0 && self.mismatched_snapshots == 0 && self.matched == self.checked
    }
}

/// A pooling point of the replay: a jump in the raw index taken for a device-side gap.
#[derive(Clone, Copy, Debug)]
struct Pool {
    /// Accumulated-sample index before which the accumulators pool.
    at: u64,
    /// Raw index where the jump starts.
    raw_at: u64,
    /// Raw samples skipped.
    missing: u64,
}

/// The replay of one channel within one session (since boot, reset or the start of the capture).
struct Replay {
    acc: Option<StridedAllan>,
    base: Option<Snapshot>,
    /// Codes accumulated (base + acc).
    consumed: u64,
    /// Codes received but not yet accumulated.
    buf: VecDeque<u16>,
    /// Pooling points ahead.
    pools: VecDeque<Pool>,
    /// Pooling points accumulated but not yet confirmed by a matching snapshot.
    tentative: Vec<Pool>,
    /// `Err`: snapshots of this session cannot be checked from here on, and why.
    state: Result<(), Unchecked>,
    /// Data is valid only up to this accumulated index, beyond it for this reason.
    hole: Option<(u64, Unchecked)>,
    /// The raw index expected next.
    next_raw: Option<u64>,
    /// Frames lost (in all) when this channel's last raw frame came.
    lost_mark: u64,
    last_snapshot_samples: Option<u64>,
    pending: VecDeque<(FrameMeta, Snapshot)>,
}

impl Replay {
    fn new(state: Result<(), Unchecked>) -> Self {
        Replay {
            acc: None,
            base: None,
            consumed: 0,
            buf: VecDeque::new(),
            pools: VecDeque::new(),
            tentative: Vec::new(),
            state,
            hole: None,
            next_raw: None,
            lost_mark: 0,
            last_snapshot_samples: None,
            pending: VecDeque::new(),
        }
    }

    fn available(&self) -> u64 {
        self.consumed + self.buf.len() as u64
    }

    fn accepting(&self) -> bool {
        self.state.is_ok() && self.hole.is_none()
    }

    fn ensure_acc(&mut self, stride: usize) {
        if self.acc.is_none() {
            let stride = if StridedAllan::new(stride).is_some() { stride } else { DEFAULT_STRIDE };
            self.acc = StridedAllan::new(stride);
            self.base = Snapshot::empty(stride).ok();
        }
    }

    /// Accumulate buffered codes until `consumed == target` (pooling where a pool point says).
    fn advance(&mut self, target: u64, stride: usize) {
        self.ensure_acc(stride);
        let acc = self.acc.as_mut().expect("created above");
        let base = self.base.as_mut().expect("created above");
        while self.consumed < target {
            while self.pools.front().is_some_and(|p| p.at <= self.consumed) {
                let p = self.pools.pop_front().expect("checked");
                let _ = base.merge(&acc.snapshot());
                *acc = StridedAllan::new(usize::from(base.stride)).expect("a valid stride");
                self.tentative.push(p);
            }
            let Some(code) = self.buf.pop_front() else { break };
            acc.push(code);
            self.consumed += 1;
        }
    }

    fn current(&self, stride: usize) -> Snapshot {
        match (&self.base, &self.acc) {
            (Some(b), Some(a)) => {
                let mut s = *b;
                let _ = s.merge(&a.snapshot());
                s
            }
            _ => Snapshot::empty(stride).unwrap_or_else(|_| Snapshot::empty(DEFAULT_STRIDE).expect("8 is valid")),
        }
    }
}

struct Verifier {
    report: VerifyReport,
    stride: Option<usize>,
    lost_total: u64,
    channels: BTreeMap<u8, Replay>,
    unchecked: BTreeMap<(u8, Unchecked), UncheckedGroup>,
    per_channel: BTreeMap<u8, ChannelVerify>,
    names: Vec<String>,
}

impl Verifier {
    fn new(source: &str) -> Self {
        Verifier {
            report: VerifyReport { source: source.to_string(), ..Default::default() },
            stride: None,
            lost_total: 0,
            channels: BTreeMap::new(),
            unchecked: BTreeMap::new(),
            per_channel: BTreeMap::new(),
            names: Vec::new(),
        }
    }

    fn chan(&mut self, c: u8) -> &mut ChannelVerify {
        self.per_channel.entry(c).or_insert_with(|| ChannelVerify { channel: c, ..Default::default() })
    }

    /// Take one decoded frame into the replay.
    fn take(&mut self, d: Decoded, name: &str) -> Result<(), VerifyError> {
        self.lost_total += u64::from(d.meta.lost);
        if d.meta.restart {
            // The device rebooted: every channel starts a new session.
            let chans: Vec<u8> = self.channels.keys().copied().collect();
            for c in chans {
                self.new_session(c, Err(Unchecked::NotStreamed));
            }
        }
        match d.message {
            Message::Hello(h) => {
                if h.protocol_version != PROTOCOL_VERSION {
                    return Err(VerifyError::UnknownProtocol {
                        name: name.to_string(),
                        offset: d.meta.offset,
                        version: h.protocol_version,
                        known: PROTOCOL_VERSION,
                    });
                }
                self.stride.get_or_insert(usize::from(h.stride));
                self.names = h.channels.iter().map(|c| c.name.to_string()).collect();
            }
            Message::Samples(s) => self.samples(&s),
            Message::Status(s) => self.report.status_samples_lost = Some(s.samples_lost),
            Message::Snapshot(c) => self.snapshot(d.meta, c.channel, c.snapshot),
            _ => {}
        }
        Ok(())
    }

    fn stride_for(&self, snap: Option<&Snapshot>) -> usize {
        self.stride.or(snap.map(|s| usize::from(s.stride))).unwrap_or(DEFAULT_STRIDE)
    }

    /// End channel `c`'s session (its waiting snapshots get what raw samples there are) and start another.
    fn new_session(&mut self, c: u8, state: Result<(), Unchecked>) {
        self.resolve(c, true);
        self.channels.insert(c, Replay::new(state));
    }

    fn samples(&mut self, s: &Samples) {
        let sets = s.sets();
        let first = s.first_sample;
        for (slot, c) in s.mask_channels().map(|c| c as u8).enumerate() {
            self.chan(c).raw_samples += sets as u64;
            let lost_total = self.lost_total;
            let r = self.channels.entry(c).or_insert_with(|| Replay::new(Err(Unchecked::NotStreamed)));
            let next = r.next_raw;
            match next {
                None => {
                    if r.state == Err(Unchecked::NotStreamed) {
                        r.state = if first == 0 { Ok(()) } else { Err(Unchecked::StartsLate { first_sample: first }) };
                    }
                }
                Some(e) if first == e => {}
                Some(e) if first > e => {
                    let at = r.available();
                    if lost_total > r.lost_mark {
                        if r.hole.is_none() {
                            r.hole = Some((at, Unchecked::FramesLost { from_sample: e, to_sample: first }));
                        }
                    } else if r.accepting() {
                        r.pools.push_back(Pool { at, raw_at: e, missing: first - e });
                        if slot == 0 {
                            self.report.device_gaps.push(DeviceGap { at_sample: e, lost: first - e });
                            self.report.device_samples_lost += first - e;
                        }
                    }
                }
                Some(e) => {
                    let state =
                        if first == 0 { Ok(()) } else { Err(Unchecked::Rewind { expected: e, first_sample: first }) };
                    self.new_session(c, state);
                }
            }
            let stride = self.stride_for(None);
            let r = self.channels.get_mut(&c).expect("inserted above");
            r.next_raw = Some(first + sets as u64);
            r.lost_mark = lost_total;
            if r.accepting() {
                r.buf.extend((0..sets).filter_map(|set| s.code(set, slot)));
                if r.buf.len() > MAX_BUFFERED {
                    let target = r.consumed + (r.buf.len() - MAX_BUFFERED / 2) as u64;
                    r.advance(target, stride);
                }
            }
            self.resolve(c, false);
        }
    }

    fn snapshot(&mut self, meta: FrameMeta, c: u8, snap: Snapshot) {
        self.report.snapshots += 1;
        self.chan(c).snapshots += 1;
        let r = self.channels.entry(c).or_insert_with(|| Replay::new(Err(Unchecked::NotStreamed)));
        if r.last_snapshot_samples.is_some_and(|l| snap.samples < l) {
            self.new_session(c, Err(Unchecked::DeviceReset));
        }
        let r = self.channels.get_mut(&c).expect("present");
        r.last_snapshot_samples = Some(snap.samples);
        r.pending.push_back((meta, snap));
        self.resolve(c, false);
        while self.channels[&c].pending.len() > MAX_PENDING {
            let r = self.channels.get_mut(&c).expect("present");
            let (meta, _) = r.pending.pop_front().expect("non-empty");
            let reason = Unchecked::RawEnds { raw_until: r.available() };
            self.not_checked(c, meta, reason);
        }
    }

    /// Check the waiting snapshots of channel `c` whose raw samples are in; with `last`, give up on the rest.
    fn resolve(&mut self, c: u8, last: bool) {
        let stride_default = self.stride;
        loop {
            let Some(r) = self.channels.get_mut(&c) else { return };
            let Some((meta, snap)) = r.pending.front().copied() else { return };
            let n = snap.samples;
            let reason = if let Err(why) = &r.state {
                Some(why.clone())
            } else if n < r.consumed {
                Some(Unchecked::TooLate)
            } else if let Some((_, why)) = r.hole.as_ref().filter(|(h, _)| n > *h) {
                Some(why.clone())
            } else if r.available() >= n {
                None
            } else if last {
                Some(Unchecked::RawEnds { raw_until: r.available() })
            } else {
                return; // wait for more raw samples
            };
            r.pending.pop_front();
            match reason {
                Some(why) => self.not_checked(c, meta, why),
                None => {
                    let stride = stride_default.unwrap_or(usize::from(snap.stride));
                    r.advance(n, stride);
                    let replay = r.current(stride);
                    let diffs = compare(&replay, &snap);
                    if diffs.is_empty() {
                        r.tentative.clear();
                        self.report.checked += 1;
                        self.report.matched += 1;
                        let ch = self.chan(c);
                        ch.checked += 1;
                        ch.matched += 1;
                    } else if let Some(p) = r.tentative.first().copied() {
                        // The jump was not a device-side gap: the replay is wrong from there on.
                        let why = Unchecked::RawHole { at_sample: p.raw_at, missing: p.missing };
                        r.state = Err(why.clone());
                        r.buf.clear();
                        r.pools.clear();
                        self.not_checked(c, meta, why);
                    } else {
                        self.report.checked += 1;
                        self.report.mismatched_snapshots += 1;
                        self.chan(c).checked += 1;
                        for field in diffs {
                            self.report.mismatch_count += 1;
                            if self.report.mismatches.len() < MAX_MISMATCHES_LISTED {
                                self.report.mismatches.push(Mismatch {
                                    channel: c,
                                    frame_seq: meta.seq,
                                    offset: meta.offset,
                                    samples: n,
                                    field,
                                });
                            }
                        }
                    }
                }
            }
        }
    }

    fn not_checked(&mut self, c: u8, meta: FrameMeta, reason: Unchecked) {
        self.report.unchecked += 1;
        self.chan(c).unchecked += 1;
        self.unchecked
            .entry((c, reason.clone()))
            .or_insert(UncheckedGroup { channel: c, reason, count: 0, first_seq: meta.seq, first_offset: meta.offset })
            .count += 1;
    }

    fn finish(mut self, decode: DecodeStats) -> VerifyReport {
        let chans: Vec<u8> = self.channels.keys().copied().collect();
        for c in chans {
            self.resolve(c, true);
        }
        let mut report = self.report;
        report.stride = self.stride.map(|s| s as u8);
        report.unchecked_why = self.unchecked.into_values().collect();
        let names = self.names;
        report.channels = self
            .per_channel
            .into_values()
            .map(|mut c| {
                c.name = names.get(usize::from(c.channel)).cloned();
                c
            })
            .collect();
        report.decode = decode;
        report
    }
}

/// Every difference between the replay and the device's snapshot.
fn compare(replay: &Snapshot, device: &Snapshot) -> Vec<MismatchField> {
    if replay.stride != device.stride {
        return vec![MismatchField::Stride { expected: replay.stride, got: device.stride }];
    }
    let mut out = Vec::new();
    if replay.samples != device.samples {
        out.push(MismatchField::Samples { expected: replay.samples, got: device.samples });
    }
    for k in 0..LEVELS {
        if replay.levels[k] != device.levels[k] {
            out.push(MismatchField::Level { level: k as u8, expected: replay.levels[k], got: device.levels[k] });
        }
    }
    out
}

/// Replay the raw samples of a capture and compare every snapshot.
///
/// # Errors
/// [`VerifyError::Decode`] when the capture cannot be read (missing, empty, an I/O error), or
/// [`VerifyError::UnknownProtocol`]. A mismatch is not an error: see [`VerifyReport::passed`].
pub fn verify<R: Read>(mut reader: CaptureReader<R>) -> Result<VerifyReport, VerifyError> {
    let name = reader.name().to_string();
    let mut v = Verifier::new(&name);
    for d in reader.by_ref() {
        v.take(d?, &name)?;
    }
    Ok(v.finish(reader.stats().clone()))
}

/// [`verify`] the capture at `path` (`-`: stdin).
///
/// # Errors
/// As [`verify`], and [`DecodeError::Open`] naming the path.
pub fn verify_path(path: &Path) -> Result<VerifyReport, VerifyError> {
    verify(decode::open(path)?)
}

#[cfg(test)]
mod tests;

//! Recording: bytes from a device (a serial port, a file or stdin) into a capture file, with live counts.
//!
//! [`record`] reads whatever arrives, appends it to the capture at once (see [`crate::io::capture`]), decodes it on
//! the fly for the live [`LiveStats`] (frames, lost frames, CRC errors, samples, and the ADEV at tau = 1 s of the
//! latest snapshot of each channel), and sends commands (raw streaming) through `proto::Encoder`. When the
//! device goes away (a port error: unplugged, reset), the capture is kept and the same port is opened again
//! every [`RecordOptions::retry_every`] until it comes back, unless [`RecordOptions::once`] says to stop or
//! [`RecordOptions::give_up_after`] has passed. A stop flag (Ctrl-C) ends the recording cleanly: the capture is
//! synced and the summary returned.
//!
//! The link is abstracted behind [`Source`] and [`Link`] (`super::link`), so the recovery loop is tested with a
//! fake port that fails and comes back.

use std::collections::BTreeMap;
use std::io;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use octavar_shared::proto::{Command, Encoder, Hello};
use serde::Serialize;

pub use super::link::{Link, PortSource, ReadOutcome, ReaderSource, SerialSource, Source, TcpSource};
use crate::io::capture::{CaptureError, CaptureSink, CaptureWriter};
use crate::io::decode::{adev_codes_at, DecodeStats, Message, StreamDecoder};
use octavar_shared::sensor::dps_per_code;

/// The averaging time of the live ADEV readout, s.
pub const LIVE_TAU_S: f64 = 1.0;

/// How [`record`] behaves.
#[derive(Clone, Debug)]
pub struct RecordOptions {
    /// Send [`Command::StartRaw`] with this channel mask on every (re)connect, and `StopRaw` at the end.
    pub raw_mask: Option<u8>,
    /// End at the first disconnect instead of waiting for the device.
    pub once: bool,
    /// Give up when the device has been gone this long (`None`: wait until stopped).
    pub give_up_after: Option<Duration>,
    /// How often to try the port again while the device is gone.
    pub retry_every: Duration,
    /// How often the progress callback is called.
    pub progress_every: Duration,
}

impl Default for RecordOptions {
    fn default() -> Self {
        RecordOptions {
            raw_mask: None,
            once: false,
            give_up_after: None,
            retry_every: Duration::from_millis(500),
            progress_every: Duration::from_millis(250),
        }
    }
}

/// The live ADEV of one channel.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LiveAdev {
    /// Channel index.
    pub channel: u8,
    /// Its name from the hello.
    pub name: Option<String>,
    /// Samples in the snapshot.
    pub samples: u64,
    /// ADEV at [`LIVE_TAU_S`], codes (`None` until the snapshot reaches it).
    pub adev_codes: Option<f64>,
    /// The same in deg/s, where the hello names a known gyro.
    pub adev_dps: Option<f64>,
}

/// The live counts.
#[derive(Clone, Debug, Default, Serialize)]
pub struct LiveStats {
    /// Bytes received (this run).
    pub bytes: u64,
    /// Bytes in the capture.
    pub capture_bytes: u64,
    /// Decoder counts (this run).
    pub decode: DecodeStats,
    /// Sample sets received in raw frames.
    pub sample_sets: u64,
    /// Connections made.
    pub connects: u64,
    /// Connections lost.
    pub disconnects: u64,
    /// The device is gone right now (waiting for it).
    pub waiting: bool,
    /// Why the connection was last lost.
    pub lost_because: Option<String>,
    /// The last error reopening the port (cleared on connect).
    pub last_error: Option<String>,
    /// Time since the start.
    pub elapsed_s: f64,
    /// The latest snapshot's ADEV at 1 s, per channel.
    pub adev_1s: Vec<LiveAdev>,
    /// The last hello.
    #[serde(skip)]
    pub hello: Option<Hello>,
}

/// Why the recording ended.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EndReason {
    /// The stop flag was raised (Ctrl-C).
    Stopped,
    /// The file or stdin ended.
    SourceEnded,
    /// The device went away and `once` was set.
    Disconnected,
    /// The device stayed away longer than `give_up_after`.
    GaveUp,
}

/// What [`record`] returns.
#[derive(Clone, Debug, Serialize)]
pub struct RecordSummary {
    /// The final counts.
    pub stats: LiveStats,
    /// Why it ended.
    pub ended: EndReason,
}

/// What went wrong, and where.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// The first connection failed (later ones are retried).
    #[error("cannot open {name}: {source}")]
    Connect {
        /// The port or file.
        name: String,
        /// The I/O error.
        source: io::Error,
    },
    /// A command could not be sent.
    #[error("sending {command} to {name}: {source}")]
    Send {
        /// The port.
        name: String,
        /// The command.
        command: &'static str,
        /// The I/O error.
        source: io::Error,
    },
    /// Reading a file or stdin failed.
    #[error("reading {name} at byte {offset}: {source}")]
    Read {
        /// The file.
        name: String,
        /// Bytes read before the error.
        offset: u64,
        /// The I/O error.
        source: io::Error,
    },
    /// The capture could not be written: the bytes before it are safe.
    #[error(transparent)]
    Capture(#[from] CaptureError),
}

/// Live state: the decoder and the latest snapshots.
struct Live {
    dec: StreamDecoder,
    stats: LiveStats,
    snapshots: BTreeMap<u8, octavar_shared::acc::Snapshot>,
}

impl Live {
    fn feed(&mut self, bytes: &[u8]) {
        let Live { dec, stats, snapshots } = self;
        dec.feed(bytes, &mut |d| match d.message {
            Message::Hello(h) => stats.hello = Some(h),
            Message::Samples(s) => stats.sample_sets += s.sets() as u64,
            Message::Snapshot(c) => {
                snapshots.insert(c.channel, c.snapshot);
            }
            _ => {}
        });
        self.stats.bytes += bytes.len() as u64;
    }

    fn refresh(&mut self, start: Instant, capture_bytes: u64) -> &LiveStats {
        self.stats.decode = self.dec.stats().clone();
        self.stats.capture_bytes = capture_bytes;
        self.stats.elapsed_s = start.elapsed().as_secs_f64();
        let hello = self.stats.hello.as_ref();
        let rate = hello.map_or(2000.0, |h| f64::from(h.rate_hz));
        self.stats.adev_1s = self
            .snapshots
            .iter()
            .map(|(&channel, snap)| {
                let info = hello.and_then(|h| h.channels.get(usize::from(channel)));
                let adev_codes = adev_codes_at(snap, rate, LIVE_TAU_S);
                LiveAdev {
                    channel,
                    name: info.map(|c| c.name.to_string()),
                    samples: snap.samples,
                    adev_codes,
                    adev_dps: info
                        .filter(|c| octavar_shared::sensor::GyroModel::of(c.kind).is_some())
                        .and_then(|c| adev_codes.map(|a| a * dps_per_code(c.kind))),
                }
            })
            .collect();
        &self.stats
    }
}

/// Message from `source` into `capture` until the source ends, `stop` is raised, or the device is gone for good.
/// `progress` is called every [`RecordOptions::progress_every`] and on every connect and disconnect.
///
/// # Errors
/// [`RecordError::Connect`] when the first connection fails, [`RecordError::Capture`] when the capture cannot
/// be written (everything before is in the file), [`RecordError::Read`] for a file or stdin that fails,
/// [`RecordError::Send`] when the first command cannot be sent. Lost connections to a port are not errors.
pub fn record<S: Source, W: CaptureSink>(
    source: &mut S,
    capture: &mut CaptureWriter<W>,
    opts: &RecordOptions,
    stop: &AtomicBool,
    progress: &mut dyn FnMut(&LiveStats),
) -> Result<RecordSummary, RecordError> {
    let start = Instant::now();
    let name = source.name();
    let mut live = Live { dec: StreamDecoder::new(), stats: LiveStats::default(), snapshots: BTreeMap::new() };
    let mut enc = Encoder::new();
    let mut buf = vec![0u8; 1 << 14];
    let mut next_link = Some(source.connect().map_err(|e| RecordError::Connect { name: name.clone(), source: e })?);
    let ended = 'session: loop {
        let Some(mut link) = next_link.take() else { unreachable!("the loop continues only with a link") };
        live.stats.connects += 1;
        live.stats.waiting = false;
        live.stats.last_error = None;
        if source.can_send() {
            let sent = send(&mut link, &mut enc, Command::Hello).and_then(|()| match opts.raw_mask {
                Some(mask) => send(&mut link, &mut enc, Command::StartRaw { channel_mask: mask }),
                None => Ok(()),
            });
            if let Err(e) = sent {
                if live.stats.connects == 1 {
                    return Err(RecordError::Send { name, command: "start commands", source: e });
                }
            }
        }
        progress(live.refresh(start, capture.written()));
        let mut last_progress = Instant::now();
        // Read until the link fails or ends.
        let lost = loop {
            if stop.load(Ordering::Relaxed) {
                if let (true, Some(_)) = (source.can_send(), opts.raw_mask) {
                    let _ = send(&mut link, &mut enc, Command::StopRaw);
                }
                break 'session EndReason::Stopped;
            }
            match link.read(&mut buf) {
                Ok(ReadOutcome::Data(n)) => {
                    capture.append(&buf[..n])?;
                    live.feed(&buf[..n]);
                }
                Ok(ReadOutcome::Idle) => {}
                Ok(ReadOutcome::End) => break 'session EndReason::SourceEnded,
                Err(e) if !source.can_reconnect() => {
                    return Err(RecordError::Read { name, offset: live.stats.bytes, source: e });
                }
                Err(e) => break e,
            }
            if last_progress.elapsed() >= opts.progress_every {
                progress(live.refresh(start, capture.written()));
                last_progress = Instant::now();
            }
        };
        // The device is gone: keep the capture, wait for it.
        drop(link);
        capture.sync()?;
        live.stats.disconnects += 1;
        live.stats.waiting = true;
        live.stats.lost_because = Some(lost.to_string());
        progress(live.refresh(start, capture.written()));
        if opts.once {
            break EndReason::Disconnected;
        }
        let gone = Instant::now();
        loop {
            if stop.load(Ordering::Relaxed) {
                break 'session EndReason::Stopped;
            }
            if opts.give_up_after.is_some_and(|limit| gone.elapsed() >= limit) {
                break 'session EndReason::GaveUp;
            }
            sleep_checking(opts.retry_every, stop);
            match source.connect() {
                Ok(l) => {
                    next_link = Some(l);
                    continue 'session;
                }
                Err(e) => {
                    live.stats.last_error = Some(e.to_string());
                    if last_progress.elapsed() >= opts.progress_every {
                        progress(live.refresh(start, capture.written()));
                        last_progress = Instant::now();
                    }
                }
            }
        }
    };
    capture.sync()?;
    live.dec.finish();
    let stats = live.refresh(start, capture.written()).clone();
    progress(&stats);
    Ok(RecordSummary { stats, ended })
}

/// Encode and send one command.
fn send<L: Link>(link: &mut L, enc: &mut Encoder, cmd: Command) -> io::Result<()> {
    let frame = enc.encode_to_vec(&cmd).map_err(|e| io::Error::new(io::ErrorKind::InvalidData, e))?;
    link.write_all(&frame)
}

/// Sleep `d`, waking early when `stop` is raised.
fn sleep_checking(d: Duration, stop: &AtomicBool) {
    let end = Instant::now() + d;
    while !stop.load(Ordering::Relaxed) {
        let now = Instant::now();
        if now >= end {
            break;
        }
        std::thread::sleep((end - now).min(Duration::from_millis(50)));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::board::simulated::{device_frames, DeviceConfig};
    use octavar_shared::proto::Decoder;
    use std::collections::VecDeque;
    use std::path::Path;
    use std::sync::{Arc, Mutex};

    /// One step of a fake connection.
    #[derive(Clone, Debug)]
    enum Step {
        Data(Vec<u8>),
        Fail(io::ErrorKind),
    }

    /// A port whose connections follow a script: each connect attempt takes the next entry (`None`: the port is
    /// not there). A connection that has played its steps stays idle.
    struct FakePort {
        script: VecDeque<Option<Vec<Step>>>,
        sent: Arc<Mutex<Vec<u8>>>,
        attempts: u32,
    }

    struct FakeLink {
        steps: VecDeque<Step>,
        sent: Arc<Mutex<Vec<u8>>>,
    }

    impl Link for FakeLink {
        fn read(&mut self, buf: &mut [u8]) -> io::Result<ReadOutcome> {
            match self.steps.pop_front() {
                Some(Step::Data(mut d)) => {
                    let n = d.len().min(buf.len());
                    buf[..n].copy_from_slice(&d[..n]);
                    if n < d.len() {
                        self.steps.push_front(Step::Data(d.split_off(n)));
                    }
                    Ok(ReadOutcome::Data(n))
                }
                Some(Step::Fail(kind)) => Err(io::Error::new(kind, "device unplugged")),
                None => {
                    std::thread::sleep(Duration::from_millis(1));
                    Ok(ReadOutcome::Idle)
                }
            }
        }

        fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
            self.sent.lock().unwrap().extend_from_slice(bytes);
            Ok(())
        }
    }

    impl Source for FakePort {
        type Link = FakeLink;
        fn name(&self) -> String {
            "/dev/ttyFAKE0".into()
        }
        fn connect(&mut self) -> io::Result<FakeLink> {
            self.attempts += 1;
            match self.script.pop_front().flatten() {
                Some(steps) => Ok(FakeLink { steps: steps.into(), sent: self.sent.clone() }),
                None => Err(io::Error::new(io::ErrorKind::NotFound, "No such file or directory")),
            }
        }
        fn can_reconnect(&self) -> bool {
            true
        }
    }

    fn port(script: Vec<Option<Vec<Step>>>) -> FakePort {
        FakePort { script: script.into(), sent: Arc::default(), attempts: 0 }
    }

    fn opts() -> RecordOptions {
        RecordOptions {
            raw_mask: Some(0x1f),
            retry_every: Duration::from_millis(2),
            progress_every: Duration::from_millis(1),
            ..Default::default()
        }
    }

    fn wire() -> Vec<u8> {
        let scans = (0..6100u32).map(|i| [2000 + (i % 17) as u16, 2010, 2020 + (i % 3) as u16, 2047, 1900]);
        device_frames(DeviceConfig::F405, 0x1f, scans)
    }

    fn commands(bytes: &[u8]) -> Vec<Command> {
        Decoder::<Command>::new().feed(bytes).map(|r| r.unwrap().msg).collect()
    }

    #[test]
    fn an_unplugged_device_is_waited_for_and_nothing_received_is_lost() {
        let w = wire();
        let cut = w.len() / 3 + 7; // mid-frame
                                   // The device comes back later: the bytes sent while it was away never arrive; it resumes at a frame start.
        let resume = cut + 500 + w[cut + 500..].iter().position(|&b| b == 0).unwrap() + 1;
        let mut p = port(vec![
            Some(vec![
                Step::Data(w[..100].to_vec()),
                Step::Data(w[100..cut].to_vec()),
                Step::Fail(io::ErrorKind::BrokenPipe),
            ]),
            None,
            None,
            Some(vec![Step::Data(w[resume..].to_vec())]),
        ]);
        let expected: Vec<u8> = [&w[..cut], &w[resume..]].concat();
        let mut cap = CaptureWriter::new(Vec::new(), Path::new("mem.cap"));
        let stop = AtomicBool::new(false);
        let mut saw_waiting = false;
        let total = expected.len() as u64;
        let summary = record(&mut p, &mut cap, &opts(), &stop, &mut |s| {
            saw_waiting |= s.waiting;
            if s.bytes == total {
                stop.store(true, Ordering::Relaxed);
            }
        })
        .unwrap();
        assert_eq!(summary.ended, EndReason::Stopped);
        assert!(saw_waiting);
        assert_eq!(cap.get_ref(), &expected, "the capture is exactly the bytes received");
        let s = &summary.stats;
        assert_eq!((s.connects, s.disconnects, p.attempts), (2, 1, 4));
        assert_eq!(s.lost_because.as_deref(), Some("device unplugged"));
        assert_eq!(s.last_error, None);
        // The live counts are those of decoding the capture afterwards: the cut frame and the one it runs into
        // are one bad frame; the frames in between are counted as lost.
        let mut offline = crate::io::decode::CaptureReader::new(&expected[..], "mem.cap");
        let offline_sets: u64 = offline
            .by_ref()
            .filter_map(|d| match d.unwrap().message {
                Message::Samples(x) => Some(x.sets() as u64),
                _ => None,
            })
            .sum();
        assert_eq!(s.sample_sets, offline_sets);
        assert!(s.sample_sets < 6100);
        assert_eq!(s.decode.bad_frame_count(), 1);
        assert_eq!(s.decode.lost_frames, offline.stats().lost_frames);
        assert!(s.decode.lost_frames >= 2);
        assert_eq!(s.adev_1s.len(), 4);
        assert!(s.adev_1s.iter().all(|a| a.samples == 6000 && a.adev_codes.is_some() && a.adev_dps.is_some()));
        assert_eq!(s.adev_1s[0].name.as_deref(), Some("IDG1215 X"));
        let sent = commands(&p.sent.lock().unwrap());
        let start = Command::StartRaw { channel_mask: 0x1f };
        assert_eq!(sent, [Command::Hello, start, Command::Hello, start, Command::StopRaw]);
    }

    /// The frame starts (offsets just past a delimiter) of `w`, and each frame's end (one past its delimiter).
    fn frame_spans(w: &[u8]) -> Vec<std::ops::Range<usize>> {
        let mut spans = Vec::new();
        let mut start = 0;
        for (i, &b) in w.iter().enumerate() {
            if b == 0 {
                if i > start {
                    spans.push(start..i + 1);
                }
                start = i + 1;
            }
        }
        spans
    }

    /// Record `bytes` from one connection of the fake port, stopping once they are all in.
    fn record_bytes(bytes: Vec<u8>) -> RecordSummary {
        let total = bytes.len() as u64;
        let mut p = port(vec![Some(vec![Step::Data(bytes)])]);
        let mut cap = CaptureWriter::new(Vec::new(), Path::new("mem.cap"));
        let stop = AtomicBool::new(false);
        record(&mut p, &mut cap, &opts(), &stop, &mut |s| {
            if s.bytes == total {
                stop.store(true, Ordering::Relaxed);
            }
        })
        .unwrap()
    }

    /// The firmware's lone delimiter (`proto::RESYNC`) before each connection's hello and after a frame it could
    /// not finish: a fragment the last session left in the USB FIFO, or a frame cut by a timed-out write, is one
    /// bad frame, and only the cut frame is lost. Without the delimiter, the fragment and the frame after it
    /// merge into one bad frame and both are lost.
    #[test]
    fn a_stale_fragment_or_a_cut_frame_costs_only_itself() {
        let w = wire();
        assert_eq!(w[0], 0, "the simulated device, like the firmware, starts with a lone delimiter");
        let spans = frame_spans(&w);
        let sets_of = |bytes: &[u8]| -> u64 {
            Decoder::<octavar_shared::proto::Frame>::new()
                .feed(bytes)
                .filter_map(|r| match r.ok()?.msg {
                    octavar_shared::proto::Frame::Samples(s) => Some(s.sets() as u64),
                    _ => None,
                })
                .sum()
        };
        let all_sets = sets_of(&w);
        // A stale fragment (half of a frame of the last session), then this session from its delimiter on.
        let stale = &w[spans[5].start..spans[5].start + spans[5].len() / 2];
        let s = record_bytes([stale, &w[..]].concat()).stats;
        assert!(s.hello.is_some(), "the hello decodes");
        assert_eq!((s.decode.bad_frame_count(), s.decode.lost_frames), (1, 0), "{:?}", s.decode);
        assert_eq!(s.sample_sets, all_sets);
        // Without the delimiter the fragment swallows the hello.
        let s = record_bytes([stale, &w[1..]].concat()).stats;
        assert!(s.hello.is_none(), "the hello is lost without the delimiter");

        // Frame 7 cut mid-way by a timeout, then the delimiter and the next frame.
        let cut = &spans[7];
        let mid = cut.start + cut.len() / 2;
        let bytes = [&w[..mid], &octavar_shared::proto::RESYNC[..], &w[cut.end..]].concat();
        let s = record_bytes(bytes).stats;
        let lost_sets = sets_of(&w[cut.clone()]);
        assert!(lost_sets > 0, "frame 7 carries samples");
        assert_eq!((s.decode.bad_frame_count(), s.decode.lost_frames), (1, 1), "{:?}", s.decode);
        assert_eq!(s.sample_sets, all_sets - lost_sets, "only the cut frame's samples are lost");
        // Without it, the cut frame and the next one are both lost.
        let s = record_bytes([&w[..mid], &w[cut.end..]].concat()).stats;
        assert_eq!((s.decode.bad_frame_count(), s.decode.lost_frames), (1, 2), "{:?}", s.decode);
    }

    #[test]
    fn once_and_give_up_end_the_wait() {
        let fail = || Some(vec![Step::Data(vec![1, 2, 3]), Step::Fail(io::ErrorKind::Other)]);
        let stop = AtomicBool::new(false);
        let mut cap = CaptureWriter::new(Vec::new(), Path::new("mem.cap"));
        let o = RecordOptions { once: true, ..opts() };
        let s = record(&mut port(vec![fail()]), &mut cap, &o, &stop, &mut |_| {}).unwrap();
        assert_eq!(s.ended, EndReason::Disconnected);
        assert_eq!(cap.get_ref(), &[1, 2, 3]);

        let mut p = port(vec![fail()]);
        let o = RecordOptions { give_up_after: Some(Duration::from_millis(30)), ..opts() };
        let t = Instant::now();
        let s = record(&mut p, &mut cap, &o, &stop, &mut |_| {}).unwrap();
        assert_eq!(s.ended, EndReason::GaveUp);
        assert!(t.elapsed() >= Duration::from_millis(30));
        assert!(p.attempts >= 3, "kept trying: {}", p.attempts);
        assert_eq!(cap.get_ref(), &[1, 2, 3, 1, 2, 3]);
    }

    #[test]
    fn a_missing_port_at_start_is_an_error_naming_it() {
        let stop = AtomicBool::new(false);
        let mut cap = CaptureWriter::new(Vec::new(), Path::new("mem.cap"));
        let e = record(&mut port(vec![None]), &mut cap, &opts(), &stop, &mut |_| {}).unwrap_err();
        assert_eq!(e.to_string(), "cannot open /dev/ttyFAKE0: No such file or directory");
    }

    #[test]
    fn a_file_is_read_to_its_end_and_a_full_disk_stops_with_the_count() {
        let w = wire();
        let stop = AtomicBool::new(false);
        let mut src = ReaderSource::new("in.cap", Box::new(io::Cursor::new(w.clone())), Duration::from_millis(5));
        let mut cap = CaptureWriter::new(Vec::new(), Path::new("mem.cap"));
        let s = record(&mut src, &mut cap, &opts(), &stop, &mut |_| {}).unwrap();
        assert_eq!(s.ended, EndReason::SourceEnded);
        assert_eq!(cap.get_ref(), &w);
        assert_eq!(s.stats.decode.bad_frame_count(), 0);
        assert_eq!(s.stats.connects, 1);

        if Path::new("/dev/full").exists() {
            let mut src = ReaderSource::new("in.cap", Box::new(io::Cursor::new(w)), Duration::from_millis(5));
            let mut full = CaptureWriter::create(Path::new("/dev/full"), true).unwrap();
            let e = record(&mut src, &mut full, &opts(), &stop, &mut |_| {}).unwrap_err();
            assert!(matches!(e, RecordError::Capture(CaptureError::DiskFull { written: 0, .. })), "{e:?}");
        }
    }
}

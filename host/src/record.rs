//! Recording: bytes from a device (a serial port, a file or stdin) into a capture file, with live counts.
//!
//! [`record`] reads whatever arrives, appends it to the capture at once (see [`crate::capture`]), decodes it on
//! the fly for the live [`LiveStats`] (frames, lost frames, CRC errors, samples, and the ADEV at tau = 1 s of the
//! latest snapshot of each channel), and sends commands (raw streaming) through `proto::Encoder`. When the
//! device goes away (a port error: unplugged, reset), the capture is kept and the same port is opened again
//! every [`RecordOptions::retry_every`] until it comes back, unless [`RecordOptions::once`] says to stop or
//! [`RecordOptions::give_up_after`] has passed. A stop flag (Ctrl-C) ends the recording cleanly: the capture is
//! synced and the summary returned.
//!
//! The link is abstracted behind [`Source`] and [`Link`], so the recovery loop is tested with a fake port that
//! fails and comes back; [`SerialSource`] is the real port (the `serialport` crate, no libudev), and
//! [`ReaderSource`] reads a file or stdin (`--from`).

use std::collections::BTreeMap;
use std::io::{self, Read};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use octavar_shared::proto::{Command, Encoder, Hello};
use serde::Serialize;

use crate::capture::{CaptureError, CaptureSink, CaptureWriter};
use crate::decode::{adev_codes_at, DecodeStats, Record, StreamDecoder};
use crate::device_sim::dps_per_code;

/// The averaging time of the live ADEV readout, s.
pub const LIVE_TAU_S: f64 = 1.0;

/// What one read from a link gave.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReadOutcome {
    /// Bytes arrived (at least one).
    Data(usize),
    /// Nothing arrived within the link's timeout; try again.
    Idle,
    /// The source has ended for good (the end of a file or of stdin).
    End,
}

/// An open connection to a device.
pub trait Link {
    /// Read what has arrived, waiting at most the link's timeout.
    ///
    /// # Errors
    /// Any error means the connection is lost (unplugged device, reset port).
    fn read(&mut self, buf: &mut [u8]) -> io::Result<ReadOutcome>;

    /// Send bytes to the device.
    ///
    /// # Errors
    /// The connection is lost, or the link cannot send (a file).
    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()>;
}

/// Where links come from: a port that can be opened again after a disconnect.
pub trait Source {
    /// The link type.
    type Link: Link;

    /// What to call the source in messages (the port path, the file name, `stdin`).
    fn name(&self) -> String;

    /// Open a connection.
    ///
    /// # Errors
    /// The port cannot be opened (not there, busy, no permission).
    fn connect(&mut self) -> io::Result<Self::Link>;

    /// Whether a lost connection can come back (a port can; a file or stdin cannot).
    fn can_reconnect(&self) -> bool;

    /// Whether commands can be sent.
    fn can_send(&self) -> bool {
        self.can_reconnect()
    }
}

/// A serial port (USB CDC-ACM or a UART) through the `serialport` crate.
#[derive(Clone, Debug)]
pub struct SerialSource {
    /// The port, for example `/dev/ttyACM0` or `COM3`.
    pub path: String,
    /// Baud rate (ignored by USB CDC-ACM, used by a UART).
    pub baud: u32,
    /// How long one read waits for bytes.
    pub timeout: Duration,
}

/// An open serial port.
pub struct SerialLink(Box<dyn serialport::SerialPort>);

impl Link for SerialLink {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<ReadOutcome> {
        match self.0.read(buf) {
            // A tty that reads 0 bytes was hung up: the device is gone.
            Ok(0) => Err(io::Error::new(io::ErrorKind::UnexpectedEof, "the port was closed (device gone)")),
            Ok(n) => Ok(ReadOutcome::Data(n)),
            Err(e) if matches!(e.kind(), io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock) => Ok(ReadOutcome::Idle),
            Err(e) if e.kind() == io::ErrorKind::Interrupted => Ok(ReadOutcome::Idle),
            Err(e) => Err(e),
        }
    }

    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        io::Write::write_all(&mut self.0, bytes)?;
        io::Write::flush(&mut self.0)
    }
}

impl Source for SerialSource {
    type Link = SerialLink;

    fn name(&self) -> String {
        self.path.clone()
    }

    fn connect(&mut self) -> io::Result<SerialLink> {
        let port = serialport::new(&self.path, self.baud).timeout(self.timeout).open().map_err(io::Error::from)?;
        Ok(SerialLink(port))
    }

    fn can_reconnect(&self) -> bool {
        true
    }
}

/// A file or stdin, read on a thread so that a stop request is seen even while nothing arrives.
pub struct ReaderSource {
    name: String,
    reader: Option<Box<dyn Read + Send>>,
    poll: Duration,
}

impl ReaderSource {
    /// Read `reader` (called `name` in messages), checking for a stop every `poll` while waiting.
    pub fn new(name: &str, reader: Box<dyn Read + Send>, poll: Duration) -> Self {
        ReaderSource { name: name.to_string(), reader: Some(reader), poll }
    }
}

/// The receiving end of a [`ReaderSource`]'s thread.
pub struct ReaderLink {
    rx: mpsc::Receiver<io::Result<Vec<u8>>>,
    pending: Vec<u8>,
    poll: Duration,
}

impl Link for ReaderLink {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<ReadOutcome> {
        if self.pending.is_empty() {
            match self.rx.recv_timeout(self.poll) {
                Ok(Ok(bytes)) => self.pending = bytes,
                Ok(Err(e)) => return Err(e),
                Err(mpsc::RecvTimeoutError::Timeout) => return Ok(ReadOutcome::Idle),
                Err(mpsc::RecvTimeoutError::Disconnected) => return Ok(ReadOutcome::End),
            }
        }
        let n = buf.len().min(self.pending.len());
        buf[..n].copy_from_slice(&self.pending[..n]);
        self.pending.drain(..n);
        Ok(ReadOutcome::Data(n))
    }

    fn write_all(&mut self, _bytes: &[u8]) -> io::Result<()> {
        Err(io::Error::new(io::ErrorKind::Unsupported, "cannot send commands to a file"))
    }
}

impl Source for ReaderSource {
    type Link = ReaderLink;

    fn name(&self) -> String {
        self.name.clone()
    }

    fn connect(&mut self) -> io::Result<ReaderLink> {
        let mut reader = self
            .reader
            .take()
            .ok_or_else(|| io::Error::new(io::ErrorKind::NotConnected, "the input was already read"))?;
        let (tx, rx) = mpsc::sync_channel(16);
        std::thread::spawn(move || {
            let mut buf = vec![0u8; 1 << 16];
            loop {
                match reader.read(&mut buf) {
                    Ok(0) => break,
                    Ok(n) => {
                        if tx.send(Ok(buf[..n].to_vec())).is_err() {
                            break;
                        }
                    }
                    Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                    Err(e) => {
                        let _ = tx.send(Err(e));
                        break;
                    }
                }
            }
        });
        Ok(ReaderLink { rx, pending: Vec::new(), poll: self.poll })
    }

    fn can_reconnect(&self) -> bool {
        false
    }
}

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
    /// The last connection error.
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
        dec.feed(bytes, &mut |d| match d.record {
            Record::Hello(h) => stats.hello = Some(h),
            Record::Samples(s) => stats.sample_sets += s.sets() as u64,
            Record::Snapshot(c) => {
                snapshots.insert(c.channel, c.snapshot);
            }
            _ => {}
        });
        self.stats.bytes += bytes.len() as u64;
    }

    fn refresh(&mut self, start: Instant, capture_bytes: u64) -> &LiveStats {
        self.stats.decode = self.dec.stats().clone();
        self.stats.decode.bad_frames.clear();
        self.stats.capture_bytes = capture_bytes;
        self.stats.elapsed_s = start.elapsed().as_secs_f64();
        let hello = self.stats.hello.as_ref();
        let rate = hello.map_or(2000.0, |h| f64::from(h.sample_rate_hz));
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

/// Record from `source` into `capture` until the source ends, `stop` is raised, or the device is gone for good.
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
        live.stats.last_error = Some(lost.to_string());
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

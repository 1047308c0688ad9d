//! Reading the field log back from a device: `Command::ReadFieldLog`, every byte that arrives appended to a
//! capture, until the read-out's end frame; resumed after a lost connection.
//!
//! The device answers with an acknowledgement, then the newest checkpoint in its flash (one frame per part of
//! each gyro channel's pooled snapshot), then `FieldLogEnd`. [`read_field_log`] sends the request, follows the
//! answer with [`Checkpoints`], and asks again (from the checkpoint it was reading) when the connection drops, a
//! part arrives damaged, or nothing comes for [`ReadOutOptions::answer_within`]. A capture that already holds a
//! whole checkpoint resumes after it: the device then sends only a newer one, or an empty read-out. `analyze`
//! and `decode` read the capture as any other; the newest whole checkpoint is the logged deployment.

use std::io;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use octavar_shared::proto::{Command, Encoder};
use serde::Serialize;

use super::link::{Link, ReadOutcome, Source};
use crate::io::capture::{CaptureError, CaptureSink, CaptureWriter};
use crate::io::decode::{Checkpoints, Message, StreamDecoder};

/// How [`read_field_log`] behaves.
#[derive(Clone, Debug)]
pub struct ReadOutOptions {
    /// Ask for checkpoints from this number on (0: the newest, whatever its number).
    pub from_checkpoint: u32,
    /// Ask again when the device has sent nothing of the read-out for this long.
    pub answer_within: Duration,
    /// Requests at most (the first and every retry) before giving up.
    pub attempts: u32,
    /// How often to try the port again while the device is gone.
    pub retry_every: Duration,
    /// Give up when the device has been gone this long.
    pub give_up_after: Duration,
}

impl Default for ReadOutOptions {
    fn default() -> Self {
        ReadOutOptions {
            from_checkpoint: 0,
            answer_within: Duration::from_secs(5),
            attempts: 5,
            retry_every: Duration::from_millis(500),
            give_up_after: Duration::from_secs(60),
        }
    }
}

/// What the read-out gave.
#[derive(Clone, Debug, Serialize)]
pub struct ReadOutSummary {
    /// The newest whole checkpoint now in the capture (`None`: the device's log had nothing from
    /// `from_checkpoint` on).
    pub checkpoint: Option<u32>,
    /// Its sampling time, s.
    pub time_s: Option<u32>,
    /// Power-on sessions it pools.
    pub sessions: Option<u32>,
    /// Sample losses over those sessions.
    pub adc_overruns: Option<u32>,
    /// Samples per gyro channel.
    pub samples: Option<u64>,
    /// Gyro channels it holds.
    pub channels: Vec<u8>,
    /// Requests sent.
    pub requests: u32,
    /// Connections made.
    pub connects: u32,
    /// Bytes received.
    pub bytes: u64,
    /// Damaged frames seen (CRC and others).
    pub bad_frames: u64,
}

/// What went wrong.
#[derive(Debug, thiserror::Error)]
pub enum ReadOutError {
    /// The first connection failed.
    #[error("cannot open {name}: {source}")]
    Connect {
        /// The port.
        name: String,
        /// The I/O error.
        source: io::Error,
    },
    /// The source cannot carry commands (a file or stdin).
    #[error("{name} cannot carry commands: read the field log from the device's port")]
    CannotSend {
        /// The source.
        name: String,
    },
    /// Every request went unanswered or came back incomplete.
    #[error("{name}: no whole field-log read-out after {requests} requests ({why})")]
    NoAnswer {
        /// The port.
        name: String,
        /// Requests sent.
        requests: u32,
        /// What the last attempt saw.
        why: String,
    },
    /// Stopped (Ctrl-C) before the read-out ended; the capture keeps what arrived.
    #[error("stopped before the read-out ended")]
    Stopped,
    /// The capture could not be written: the bytes before it are safe.
    #[error(transparent)]
    Capture(#[from] CaptureError),
}

/// Read the field log from `source` into `capture`. `known` holds what the capture already has (the checkpoints
/// of an earlier read-out, `Checkpoints::new()` for a new capture), so that this one resumes after them.
///
/// # Errors
/// See [`ReadOutError`]; a lost connection is retried, not an error.
pub fn read_field_log<S: Source, W: CaptureSink>(
    source: &mut S,
    capture: &mut CaptureWriter<W>,
    mut known: Checkpoints,
    opts: &ReadOutOptions,
    stop: &AtomicBool,
) -> Result<ReadOutSummary, ReadOutError> {
    let name = source.name();
    if !source.can_send() {
        return Err(ReadOutError::CannotSend { name });
    }
    let from = match known.newest_whole() {
        Some(cp) => opts.from_checkpoint.max(cp.number + 1),
        None => opts.from_checkpoint,
    };
    let mut dec = StreamDecoder::new();
    let mut enc = Encoder::new();
    let mut buf = vec![0u8; 1 << 14];
    let mut summary = ReadOutSummary {
        checkpoint: None,
        time_s: None,
        sessions: None,
        adc_overruns: None,
        samples: None,
        channels: Vec::new(),
        requests: 0,
        connects: 0,
        bytes: 0,
        bad_frames: 0,
    };
    let mut link = Some(source.connect().map_err(|e| ReadOutError::Connect { name: name.clone(), source: e })?);
    summary.connects = 1;
    let mut why = String::from("no answer");
    let mut gone_since = None;
    while summary.requests < opts.attempts {
        if stop.load(Ordering::Relaxed) {
            capture.sync()?;
            return Err(ReadOutError::Stopped);
        }
        let Some(mut l) = link.take() else {
            // The device is gone: try the port again until it comes back or the bound passes.
            let since = *gone_since.get_or_insert_with(Instant::now);
            if since.elapsed() >= opts.give_up_after {
                break;
            }
            std::thread::sleep(opts.retry_every);
            match source.connect() {
                Ok(l) => {
                    link = Some(l);
                    summary.connects += 1;
                    gone_since = None;
                }
                Err(e) => why = format!("reopening the port: {e}"),
            }
            continue;
        };
        // Resume from the checkpoint a broken read-out was in the middle of, if any.
        let resume = known.by_number.keys().next_back().copied().filter(|&n| n >= from).unwrap_or(from);
        summary.requests += 1;
        // A hello first, so the capture names the device's gyro channels (what makes a checkpoint whole).
        let mut request = Vec::new();
        let mut seq = 0;
        let encoded = [Command::Hello, Command::ReadFieldLog { from_checkpoint: resume }].iter().try_for_each(|c| {
            seq = enc.next_seq();
            request.extend_from_slice(&enc.encode_to_vec(c)?);
            Ok::<_, octavar_shared::proto::EncodeError>(())
        });
        let sent = encoded
            .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, e.to_string()))
            .and_then(|()| l.write_all(&request));
        if let Err(e) = sent {
            why = format!("sending the request: {e}");
            continue;
        }
        match follow(&mut l, seq, capture, &mut dec, &mut known, &mut buf, opts, stop, &mut summary)? {
            Outcome::Ended { empty } => {
                if empty || known.newest_whole().is_some_and(|cp| cp.number >= from) {
                    if let Some(cp) = known.newest_whole() {
                        summary.checkpoint = Some(cp.number);
                        summary.time_s = Some(cp.time_s);
                        summary.sessions = Some(cp.sessions);
                        summary.adc_overruns = Some(cp.adc_overruns);
                        summary.samples = Some(cp.samples());
                        summary.channels = cp.channels.keys().copied().collect();
                    }
                    summary.bad_frames = dec.stats().bad_frame_count();
                    capture.sync()?;
                    return Ok(summary);
                }
                why = "the read-out ended without a whole checkpoint (a damaged part)".into();
                link = Some(l);
            }
            Outcome::Silent => {
                why = format!("nothing for {} s", opts.answer_within.as_secs_f64());
                link = Some(l);
            }
            Outcome::Lost(e) => {
                why = format!("connection lost: {e}");
                capture.sync()?;
            }
        }
    }
    summary.bad_frames = dec.stats().bad_frame_count();
    capture.sync()?;
    Err(ReadOutError::NoAnswer { name, requests: summary.requests, why })
}

/// How one request went.
enum Outcome {
    /// The read-out's end frame arrived (`empty`: it carried no checkpoint).
    Ended { empty: bool },
    /// Nothing of the read-out arrived in time.
    Silent,
    /// The connection dropped.
    Lost(io::Error),
}

/// Read until the end frame of the read-out acknowledged as `seq`, the silence bound, or a lost connection.
#[allow(clippy::too_many_arguments)]
fn follow<L: Link, W: CaptureSink>(
    link: &mut L,
    seq: u32,
    capture: &mut CaptureWriter<W>,
    dec: &mut StreamDecoder,
    known: &mut Checkpoints,
    buf: &mut [u8],
    opts: &ReadOutOptions,
    stop: &AtomicBool,
    summary: &mut ReadOutSummary,
) -> Result<Outcome, ReadOutError> {
    let mut acked = false;
    let mut ended = None;
    let mut last_heard = Instant::now();
    loop {
        if stop.load(Ordering::Relaxed) {
            capture.sync()?;
            return Err(ReadOutError::Stopped);
        }
        match link.read(buf) {
            Ok(ReadOutcome::Data(n)) => {
                capture.append(&buf[..n])?;
                summary.bytes += n as u64;
                dec.feed(&buf[..n], &mut |d| {
                    match &d.message {
                        Message::Ack(a) if a.seq == seq => acked = true,
                        Message::FieldLogEnd(e) if acked => ended = Some(e.checkpoints == 0),
                        _ => {}
                    }
                    known.take(&d);
                });
                if acked {
                    last_heard = Instant::now();
                }
                if let Some(empty) = ended {
                    return Ok(Outcome::Ended { empty });
                }
            }
            Ok(ReadOutcome::Idle) => {}
            Ok(ReadOutcome::End) => return Ok(Outcome::Lost(io::ErrorKind::UnexpectedEof.into())),
            Err(e) => return Ok(Outcome::Lost(e)),
        }
        if last_heard.elapsed() >= opts.answer_within {
            return Ok(Outcome::Silent);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::decode::CaptureReader;
    use octavar_shared::acc::{OctaveAllan, Snapshot};
    use octavar_shared::proto::{Ack, Decoder, FieldLogEnd, FieldLogRecord, Frame, SnapshotPart};
    use std::collections::VecDeque;
    use std::path::Path;
    use std::sync::{Arc, Mutex};

    /// A device whose flash holds one checkpoint; it answers `ReadFieldLog` as the firmware does. Connection `i`
    /// breaks after `cut[i]` bytes of answer (`None`: never); `damage` flips a byte of the first answer.
    struct FakeDevice {
        state: Arc<Mutex<State>>,
    }

    struct State {
        number: u32,
        snaps: Vec<Snapshot>,
        cut: VecDeque<Option<usize>>,
        damage: bool,
        requests: Vec<u32>,
        enc: Encoder,
    }

    struct FakeLink {
        state: Arc<Mutex<State>>,
        out: VecDeque<u8>,
        left: Option<usize>,
    }

    impl Source for FakeDevice {
        type Link = FakeLink;
        fn name(&self) -> String {
            "fake".into()
        }
        fn connect(&mut self) -> io::Result<FakeLink> {
            let left = self.state.lock().unwrap().cut.pop_front().flatten();
            Ok(FakeLink { state: self.state.clone(), out: VecDeque::new(), left })
        }
        fn can_reconnect(&self) -> bool {
            true
        }
    }

    impl Link for FakeLink {
        fn read(&mut self, buf: &mut [u8]) -> io::Result<ReadOutcome> {
            if self.out.is_empty() {
                std::thread::sleep(Duration::from_millis(1));
                return Ok(ReadOutcome::Idle);
            }
            let mut n = buf.len().min(self.out.len()).min(100);
            if let Some(left) = self.left {
                if left == 0 {
                    return Err(io::Error::new(io::ErrorKind::BrokenPipe, "unplugged"));
                }
                n = n.min(left);
                self.left = Some(left - n);
            }
            for b in buf.iter_mut().take(n) {
                *b = self.out.pop_front().unwrap();
            }
            Ok(ReadOutcome::Data(n))
        }

        fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
            let mut st = self.state.lock().unwrap();
            for r in Decoder::<Command>::new().feed(bytes) {
                let r = r.unwrap();
                if r.msg == Command::Hello {
                    let hello = octavar_shared::device::DeviceConfig::F405.hello();
                    let bytes = st.enc.encode_to_vec(&hello).unwrap();
                    self.out.extend(bytes.iter());
                    continue;
                }
                let Command::ReadFieldLog { from_checkpoint } = r.msg else { continue };
                st.requests.push(from_checkpoint);
                let mut frames = vec![Frame::Ack(Ack { seq: r.seq })];
                let send = st.number >= from_checkpoint;
                if send {
                    for (c, snap) in st.snaps.iter().enumerate() {
                        for part in SnapshotPart::split(c as u8, snap) {
                            let rec = FieldLogRecord {
                                checkpoint: st.number,
                                time_s: 60,
                                sessions: 2,
                                adc_overruns: 1,
                                part,
                            };
                            frames.push(Frame::FieldLog(rec));
                        }
                    }
                }
                frames.push(Frame::FieldLogEnd(FieldLogEnd { checkpoints: u32::from(send) }));
                let mut answer = Vec::new();
                for f in &frames {
                    answer.extend_from_slice(&st.enc.encode_to_vec(f).unwrap());
                }
                if std::mem::take(&mut st.damage) {
                    let at = answer.len() / 2;
                    answer[at] ^= 0x55;
                }
                self.out.extend(answer);
            }
            Ok(())
        }
    }

    fn snaps() -> Vec<Snapshot> {
        (0..4u16)
            .map(|c| {
                let mut acc = OctaveAllan::<8>::new();
                (0..5000u32).for_each(|i| acc.push(2000 + c * 7 + (i * 7919 % 41) as u16));
                acc.snapshot()
            })
            .collect()
    }

    fn device(cut: &[Option<usize>], damage: bool) -> (FakeDevice, Arc<Mutex<State>>) {
        let state = Arc::new(Mutex::new(State {
            number: 7,
            snaps: snaps(),
            cut: cut.iter().copied().collect(),
            damage,
            requests: Vec::new(),
            enc: Encoder::new(),
        }));
        (FakeDevice { state: state.clone() }, state)
    }

    fn opts() -> ReadOutOptions {
        ReadOutOptions {
            answer_within: Duration::from_millis(200),
            retry_every: Duration::from_millis(1),
            ..Default::default()
        }
    }

    /// The checkpoints a capture holds, read back the way analyze reads them.
    fn in_capture(bytes: &[u8]) -> Checkpoints {
        let mut cps = Checkpoints::new();
        for d in CaptureReader::new(bytes, "mem") {
            cps.take(&d.unwrap());
        }
        cps
    }

    #[test]
    fn a_read_out_lands_whole_in_the_capture() {
        let (mut dev, state) = device(&[None], false);
        let mut cap = CaptureWriter::new(Vec::new(), Path::new("mem.cap"));
        let s = read_field_log(&mut dev, &mut cap, Checkpoints::new(), &opts(), &AtomicBool::new(false)).unwrap();
        assert_eq!((s.checkpoint, s.samples, s.sessions, s.requests), (Some(7), Some(5000), Some(2), 1));
        assert_eq!(s.channels, [0, 1, 2, 3]);
        assert_eq!(state.lock().unwrap().requests, [0]);
        let cps = in_capture(cap.get_ref());
        let cp = cps.newest_whole().expect("a whole checkpoint in the capture");
        assert_eq!(cp.channels[&1], snaps()[1], "the snapshot exactly as the device holds it");
    }

    /// The connection drops in the middle of the checkpoint: the port is opened again and the read-out asked for
    /// again from that checkpoint; the capture keeps the broken half and the whole copy after it.
    #[test]
    fn a_read_out_cut_by_a_disconnect_resumes_from_its_checkpoint() {
        let whole = {
            let (mut dev, _) = device(&[None], false);
            let mut cap = CaptureWriter::new(Vec::new(), Path::new("mem.cap"));
            read_field_log(&mut dev, &mut cap, Checkpoints::new(), &opts(), &AtomicBool::new(false)).unwrap();
            cap.get_ref().len()
        };
        let (mut dev, state) = device(&[Some(whole / 2), None], false);
        let mut cap = CaptureWriter::new(Vec::new(), Path::new("mem.cap"));
        let s = read_field_log(&mut dev, &mut cap, Checkpoints::new(), &opts(), &AtomicBool::new(false)).unwrap();
        assert_eq!((s.checkpoint, s.connects, s.requests), (Some(7), 2, 2));
        assert_eq!(state.lock().unwrap().requests, [0, 7], "the second request resumes at checkpoint 7");
        assert_eq!(in_capture(cap.get_ref()).newest_whole().map(|c| c.number), Some(7));
    }

    #[test]
    fn a_damaged_part_is_asked_for_again() {
        let (mut dev, state) = device(&[None], true);
        let mut cap = CaptureWriter::new(Vec::new(), Path::new("mem.cap"));
        let s = read_field_log(&mut dev, &mut cap, Checkpoints::new(), &opts(), &AtomicBool::new(false)).unwrap();
        assert_eq!((s.checkpoint, s.requests), (Some(7), 2));
        assert!(s.bad_frames >= 1);
        assert_eq!(state.lock().unwrap().requests.len(), 2);
    }

    /// A capture that already holds checkpoint 7 asks only for newer ones; the device has none, and the summary
    /// names the one the capture holds.
    #[test]
    fn a_capture_that_holds_a_checkpoint_asks_only_for_newer_ones() {
        let (mut dev, _) = device(&[None], false);
        let mut first = CaptureWriter::new(Vec::new(), Path::new("mem.cap"));
        read_field_log(&mut dev, &mut first, Checkpoints::new(), &opts(), &AtomicBool::new(false)).unwrap();
        let known = in_capture(first.get_ref());
        let (mut dev, state) = device(&[None], false);
        let mut cap = CaptureWriter::new(Vec::new(), Path::new("mem.cap"));
        let s = read_field_log(&mut dev, &mut cap, known, &opts(), &AtomicBool::new(false)).unwrap();
        assert_eq!(state.lock().unwrap().requests, [8]);
        assert_eq!(s.checkpoint, Some(7));
    }

    #[test]
    fn a_silent_device_is_an_error_naming_the_port_and_the_requests() {
        let (mut dev, state) = device(&[Some(0)], false);
        state.lock().unwrap().cut = VecDeque::from(vec![Some(0); 10]);
        let o = ReadOutOptions { attempts: 3, give_up_after: Duration::from_millis(50), ..opts() };
        let mut cap = CaptureWriter::new(Vec::new(), Path::new("mem.cap"));
        let e = read_field_log(&mut dev, &mut cap, Checkpoints::new(), &o, &AtomicBool::new(false)).unwrap_err();
        let text = e.to_string();
        assert!(text.starts_with("fake: no whole field-log read-out after 3 requests"), "{text}");
    }
}

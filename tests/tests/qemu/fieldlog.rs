//! The field log end to end on QEMU: the firmware checkpoints every 2 s of samples into the flash controller
//! model, the power fails half-way through a checkpoint's programming (the model leaves that word half
//! programmed and the firmware resets, as a power cycle would), the second session logs on, and the host reads
//! the log back over USART1's TCP socket with `octavar fieldlog`'s read-out (`device::log_readout`).
//!
//! Checked against the raw stream the firmware sent meanwhile: the newest checkpoint pools the first session up
//! to its last whole checkpoint and the second up to its own, and its integer sums equal the host's replay of
//! exactly those raw codes, pooled the same way, bit for bit; `analyze` of the read-out gives that replay's
//! deviations; and the cut cost only the checkpoint being written.

use std::io::Read;
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use octavar::analyze::streamed::{analyze_capture, CaptureData, StreamOptions};
use octavar::board::link::{Link, ReadOutcome, Source, TcpLink};
use octavar::board::log_readout::{read_field_log, ReadOutOptions};
use octavar::io::capture::CaptureWriter;
use octavar::io::decode::{CaptureReader, Checkpoints, Message, StreamDecoder};
use octavar_shared::acc::{OctaveAllan, Snapshot};
use octavar_shared::device::STRIDE;
use octavar_shared::fieldlog::{Checkpoint, OVERHEAD_WORDS};

use super::{build_firmware, qemu_available, start_qemu, wait_qemu, GYROS, RATE, SEED};
use crate::util::temp_dir;

/// Seconds of scans of each session (`OCTAVAR_QEMU_SECONDS`; the first is cut short by the power cut).
const SECONDS: u64 = 6;
/// QEMU's checkpoints: every 2 s of samples, the first one at the first snapshot round (1 s).
const FIRST_CHECKPOINT: u64 = RATE;
/// The host asks for the log once the second session has streamed this many scans.
const READ_AFTER: u64 = 4 * RATE;

/// The connection QEMU made to the test's listener, handed to the read-out as its port.
struct Accepted(Option<TcpStream>);

impl Source for Accepted {
    type Link = TcpLink;
    fn name(&self) -> String {
        "qemu usart1".into()
    }
    fn connect(&mut self) -> std::io::Result<TcpLink> {
        let stream = self.0.take().ok_or(std::io::ErrorKind::NotConnected)?;
        TcpLink::from_stream(stream, Duration::from_millis(50))
    }
    fn can_reconnect(&self) -> bool {
        true
    }
}

/// Each session's raw codes of the gyro channels, in scan order (sessions split at the device's restart).
fn raw_sessions(bytes: &[u8]) -> Vec<[Vec<u16>; GYROS as usize]> {
    let mut sessions: Vec<[Vec<u16>; GYROS as usize]> = Vec::new();
    let mut next = 0u64;
    for d in CaptureReader::new(bytes, "usart1") {
        let d = d.expect("decode");
        if sessions.is_empty() || d.meta.restart {
            sessions.push(Default::default());
            next = 0;
        }
        if let Message::Samples(s) = &d.message {
            assert_eq!(s.first_sample, next, "the raw stream of a session has no gap");
            next += s.sets() as u64;
            let cur = sessions.last_mut().unwrap();
            for (j, c) in s.mask_channels().enumerate() {
                if c < GYROS as usize {
                    cur[c].extend(s.slot_codes(j));
                }
            }
        }
    }
    sessions
}

/// The host's replay: the first `n` codes of each session through its own accumulator, pooled.
fn replay(sessions: &[[Vec<u16>; GYROS as usize]], spans: &[u64], channel: usize) -> Snapshot {
    let mut pooled: Option<Snapshot> = None;
    for (session, &n) in sessions.iter().zip(spans) {
        let codes = &session[channel];
        assert!(codes.len() as u64 >= n, "the raw stream holds {} scans of a session, the log pools {n}", codes.len());
        let mut acc = OctaveAllan::<STRIDE>::new();
        codes[..n as usize].iter().for_each(|&c| acc.push(c));
        let snap = acc.snapshot();
        match &mut pooled {
            Some(p) => p.merge(&snap).expect("pool the sessions"),
            None => pooled = Some(snap),
        }
    }
    pooled.expect("a session")
}

#[test]
fn the_field_log_read_back_after_a_power_cut_pools_the_raw_stream_exactly() {
    if !qemu_available() {
        return;
    }
    let dir = temp_dir("qemu-fieldlog");
    // The flash's steps from power-on: the empty log's erase, checkpoint 1, then half of checkpoint 2.
    let record = (Checkpoint::<{ GYROS as usize }>::WORDS + OVERHEAD_WORDS) as u64;
    let cut = 1 + record + record / 2;
    let elf = build_firmware(
        &[
            ("OCTAVAR_QEMU_SECONDS", SECONDS.to_string()),
            ("OCTAVAR_QEMU_SEED", SEED.to_string()),
            ("OCTAVAR_QEMU_POWER_CUT_STEP", cut.to_string()),
        ],
        &dir,
    );
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind a local port");
    let port = listener.local_addr().expect("local address").port();
    let stdout_file = dir.join("stdout.txt");
    let t0 = Instant::now();
    let child = start_qemu(&elf, &format!("tcp:127.0.0.1:{port}"), &stdout_file);
    let (mut socket, _) = listener.accept().expect("QEMU connects to USART1's socket");
    socket.set_read_timeout(Some(Duration::from_millis(50))).expect("read timeout");

    // Before the read-out: the stream until the second session has READ_AFTER scans.
    let mut before = Vec::new();
    let mut dec = StreamDecoder::new();
    let (mut session, mut scans) = (0, 0u64);
    let mut buf = [0u8; 4096];
    while session < 2 || scans < READ_AFTER {
        assert!(t0.elapsed() < Duration::from_secs(60), "the second session did not come");
        let n = match socket.read(&mut buf) {
            Ok(0) => panic!("QEMU closed the socket before the read-out"),
            Ok(n) => n,
            Err(_) => continue,
        };
        before.extend_from_slice(&buf[..n]);
        dec.feed(&buf[..n], &mut |d| {
            if d.meta.restart || session == 0 {
                session += 1;
                scans = 0;
            }
            if let Message::Samples(s) = &d.message {
                scans = s.first_sample + s.sets() as u64;
            }
        });
    }

    // The read-out, as `octavar fieldlog tcp:...` runs it.
    let mut capture = CaptureWriter::new(Vec::new(), &dir.join("fieldlog.capture"));
    let mut source = Accepted(Some(socket.try_clone().expect("clone the socket")));
    let summary = read_field_log(
        &mut source,
        &mut capture,
        Checkpoints::new(),
        &ReadOutOptions::default(),
        &AtomicBool::new(false),
    )
    .expect("read the field log");
    let read_out = capture.into_inner().expect("the read-out's bytes");

    // After it: the rest of the stream, until QEMU exits.
    let mut after = Vec::new();
    let mut link = TcpLink::from_stream(socket, Duration::from_millis(50)).expect("the socket");
    let reader = std::thread::spawn(move || {
        let mut buf = [0u8; 4096];
        while let Ok(r) = link.read(&mut buf) {
            if let ReadOutcome::Data(n) = r {
                after.extend_from_slice(&buf[..n]);
            }
        }
        after
    });
    let stdout = wait_qemu(child, &stdout_file, t0, || {});
    let after = reader.join().expect("the reader");
    assert!(stdout.contains(&format!("octavar-qemu: power cut at flash step {cut}")), "{stdout}");

    // The checkpoint read back: two sessions, the first up to its last whole checkpoint (the one being written
    // when the power failed is lost, nothing more), the second up to a checkpoint of its own.
    let mut cps = Checkpoints::new();
    for d in CaptureReader::new(&read_out[..], "fieldlog") {
        cps.take(&d.expect("decode the read-out"));
    }
    let cp = cps.newest_whole().expect("a whole checkpoint in the read-out").clone();
    assert_eq!(summary.checkpoint, Some(cp.number));
    assert_eq!(cp.sessions, 2, "{cp:?}");
    let second = cp.samples() - FIRST_CHECKPOINT;
    assert!(second >= FIRST_CHECKPOINT && second.is_multiple_of(RATE), "second session {second} scans");

    // Its integer sums are the replay of those raw codes, pooled, bit for bit.
    let stream: Vec<u8> = [before, read_out.clone(), after].concat();
    let sessions = raw_sessions(&stream);
    assert_eq!(sessions.len(), 2, "two sessions in the raw stream");
    for c in 0..GYROS as usize {
        let want = replay(&sessions, &[FIRST_CHECKPOINT, second], c);
        assert_eq!(cp.channels[&(c as u8)], want, "channel {c}: the checkpoint and the pooled replay differ");
    }

    // analyze of the read-out: the field log's deviations, which are the replay's.
    let opts = StreamOptions { capture_data: CaptureData::FieldLog, fit: None, ..Default::default() };
    let a = analyze_capture(CaptureReader::new(&read_out[..], "fieldlog"), &opts, &|_| {}).expect("analyze");
    assert_eq!(a.samples, cp.samples());
    assert!(a.method.starts_with(&format!("field-log checkpoint {}", cp.number)), "{}", a.method);
    let rate = RATE as f64;
    for (c, ch) in a.channels.iter().enumerate() {
        let want = replay(&sessions, &[FIRST_CHECKPOINT, second], c);
        let scale = octavar_shared::sensor::dps_per_code(octavar_shared::device::F405_CHANNELS[c].kind);
        let points = octavar::stats::strided::snapshot_points(&want, rate, scale, opts.confidence);
        let got: Vec<f64> = ch.fit_points.iter().map(|p| p.dev).collect();
        let want: Vec<f64> = points.iter().map(|p| p.dev).collect();
        assert_eq!(got, want, "channel {c}: analyze of the read-out");
    }
    // decode of the read-out: the checkpoint, and the onboard estimate from it near the simulated gyros' N.
    let opts = octavar::io::decode::ExportOptions::default();
    let d = octavar::io::decode::export(CaptureReader::new(&read_out[..], "fieldlog"), &opts).expect("decode");
    let summary_cp = d.field_log_checkpoint.expect("decode names the checkpoint");
    assert_eq!((summary_cp.checkpoint, summary_cp.sessions, summary_cp.samples), (cp.number, 2, cp.samples()));
    assert_eq!(summary_cp.estimates.len(), GYROS as usize);
    for (e, n_true) in summary_cp.estimates.iter().zip(super::TABLE1_N) {
        let n = f64::from(e.n_dps_per_rt_s.unwrap_or_else(|| panic!("no N for channel {}", e.channel)));
        assert!(
            (n / n_true - 1.0).abs() < 0.3,
            "channel {}: N {n:.3e} from the log, simulated {n_true:.3e}",
            e.channel
        );
    }
    println!(
        "qemu field log: power cut at flash step {cut}; checkpoint {} pools {FIRST_CHECKPOINT} + {second} scans of 2 \
         sessions, equal bit for bit to the raw stream's replay; read-out: {} request(s), {} bytes",
        cp.number, summary.requests, summary.bytes
    );
    let _ = std::fs::remove_dir_all(&dir);
}

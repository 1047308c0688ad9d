//! The reports, pinned by snapshots (`tests/snapshots/`): the key set of every JSON document `octavar` writes,
//! which users' scripts read (a key that disappears or is renamed fails here; adding keys shows up as a snapshot
//! change to review), and the text reports the README and the docs quote, whole, layout and figures, on fixed
//! inputs, so what they quote cannot drift unseen. A change is reviewed into the snapshot (`cargo insta review`,
//! or `INSTA_UPDATE=always` and read the diff) and committed.
//!
//! Every document comes from a run of the binary. The device commands (`bringup`, `fieldlog`) talk to a simulated
//! board on a local TCP port ([`board`]: the firmware's device core and field log, the code the board runs,
//! behind a socket, as `tcp:HOST:PORT` reaches QEMU's serial port); the capture commands (`decode`, `verify`,
//! `record --from`, `analyze` of a capture) read a capture that board wrote offline, byte for byte the same on
//! every run.
//!
//! The documents are chosen to fill every part of their type: a key under an optional object or in an array's
//! elements is listed only when the run gives it a value, and keys inside a tagged variant (a gap effect's
//! parameters, an unchecked snapshot's reason) only for the variants the run meets.

mod common;
use common::{octavar, sinusoid_record, stderr, stdout};

use std::path::Path;
use std::process::Output;

/// Every key path of `v`, sorted: `a.b` for an object's member, `a[].b` for a member of any element of an array.
fn key_paths(v: &serde_json::Value) -> String {
    fn walk(v: &serde_json::Value, prefix: &str, out: &mut std::collections::BTreeSet<String>) {
        match v {
            serde_json::Value::Object(m) => {
                for (k, child) in m {
                    let path = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
                    out.insert(path.clone());
                    walk(child, &path, out);
                }
            }
            serde_json::Value::Array(items) => {
                for item in items {
                    walk(item, &format!("{prefix}[]"), out);
                }
            }
            _ => {}
        }
    }
    let mut out = std::collections::BTreeSet::new();
    walk(v, "", &mut out);
    out.into_iter().collect::<Vec<_>>().join("\n")
}

/// White noise plus a 50 s sinusoid, 16384 samples at 10 Hz, in one column `g`.
fn record() -> String {
    sinusoid_record(7)
}

/// Run `args` with the record on stdin and `--json FILE` appended; the document.
fn json_of(args: &[&str]) -> serde_json::Value {
    let dir = tempfile::tempdir().expect("a temp dir");
    let json = dir.path().join("out.json");
    let all = [args, &["--json", json.to_str().unwrap()]].concat();
    let o = octavar(&all, Some(record().as_bytes()));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    read_json(&json)
}

/// The JSON document in the file at `path`.
fn read_json(path: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("reading {}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{} is not JSON: {e}", path.display()))
}

/// The JSON document a run printed on stdout.
fn stdout_json(o: &Output) -> serde_json::Value {
    serde_json::from_slice(&o.stdout).unwrap_or_else(|e| panic!("stdout is not JSON: {e}\n{}", stdout(o)))
}

/// Run `args` (no stdin) and check its exit code; what it printed.
fn run(args: &[&str], code: i32) -> Output {
    let o = octavar(args, None);
    assert_eq!(o.status.code(), Some(code), "octavar {}\n{}{}", args.join(" "), stdout(&o), stderr(&o));
    o
}

fn s(p: &Path) -> &str {
    p.to_str().expect("a UTF-8 temp path")
}

/// `analyze --json`: the statistics, the fit, the bias model and the record length of a CSV channel.
#[test]
fn analyze_json_keys() {
    let v = json_of(&["analyze", "-", "--column", "g", "--rate", "10"]);
    insta::assert_snapshot!("analyze", key_paths(&v));
}

/// `analyze --json --stats all --datasheet`: every statistic's name as a key of `stats`, and each channel's
/// `datasheet` rows (the comparison with the datasheet, absent without `--datasheet`).
#[test]
fn analyze_json_keys_with_every_statistic_and_a_datasheet() {
    let dir = tempfile::tempdir().expect("a temp dir");
    let sheet = dir.path().join("sheet.toml");
    // The gyro figures of docs/exports.md's example.
    std::fs::write(
        &sheet,
        "rate_hz = 10\n[gyro]\narw = \"0.3 deg/sqrt(h)\"\nbias_instability = \"4 deg/h\"\n\
         random_walk = \"0.1 deg/h/sqrt(h)\"\nbias_correlation_time = \"100 s\"\n",
    )
    .unwrap();
    let v = json_of(&["analyze", "-", "--column", "g", "--rate", "10", "--stats", "all", "--datasheet", s(&sheet)]);
    insta::assert_snapshot!("analyze_datasheet", key_paths(&v));
}

/// `analyze --json --no-fit`: the statistics alone; `fit` is `{"error"}` and `record_length` null, the shape a
/// script meets whenever a channel has no fit.
#[test]
fn analyze_json_keys_without_a_fit() {
    let v = json_of(&["analyze", "-", "--column", "g", "--rate", "10", "--no-fit"]);
    insta::assert_snapshot!("analyze_no_fit", key_paths(&v));
}

/// `gap --json`: the diagnosis of a record with a sinusoid (the base fit, the views, the candidates, the chain,
/// the held-out check).
#[test]
fn gap_json_keys() {
    let v = json_of(&["gap", "-", "--column", "g", "--rate", "10", "--seeds", "8"]);
    insta::assert_snapshot!("gap", key_paths(&v));
}

/// `gap --json --holdout-check predictive`: the same document with the predictive check's figures under
/// `holdout_predictive` and `holdout.predictive` (null without the check), which scripts judging a diagnosis read.
#[test]
fn gap_json_keys_with_the_predictive_check() {
    let v = json_of(&["gap", "-", "--column", "g", "--rate", "10", "--seeds", "8", "--holdout-check", "predictive"]);
    insta::assert_snapshot!("gap_predictive", key_paths(&v));
}

/// Mask a duration in seconds printed after `marker` (`diagnosed in 0.2 s` -> `diagnosed in [time]`).
fn mask_seconds(line: &str, marker: &str) -> String {
    match line.split_once(marker) {
        Some((head, tail)) => format!("{head}{marker}[time]{}", tail.split_once(" s").map_or("", |(_, r)| r)),
        None => line.to_string(),
    }
}

/// Run `args` with the record on stdin; what it printed, the run's own duration (`diagnosed in 0.2 s`) masked.
fn text_of(args: &[&str]) -> String {
    let o = octavar(args, Some(record().as_bytes()));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).expect("UTF-8");
    text.lines().map(|l| mask_seconds(l, "diagnosed in ")).collect::<Vec<_>>().join("\n")
}

/// The text reports, whole: their layout and every figure on a fixed record (README and the docs quote them).
#[test]
fn analyze_and_gap_text_reports() {
    insta::assert_snapshot!("analyze_text", text_of(&["analyze", "-", "--column", "g", "--rate", "10"]));
    insta::assert_snapshot!("gap_text", text_of(&["gap", "-", "--column", "g", "--rate", "10", "--seeds", "8"]));
}

/// `accumulate --json`: the octaves of the firmware's accumulator over integer codes (the NBS-14 set).
#[test]
fn accumulate_json_keys() {
    let o =
        octavar(&["accumulate", "-", "--json", "--rate", "1"], Some(b"892\n809\n823\n798\n671\n644\n883\n903\n677\n"));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v = stdout_json(&o);
    insta::assert_snapshot!("accumulate", key_paths(&v));
}

/// `decode --json`: the summary of a capture with every kind of frame (hello, raw samples, snapshots, estimates,
/// statuses, a field-log read-out) and a damaged frame, so that every array and optional object of the summary
/// has content.
#[test]
fn decode_json_keys() {
    let dir = tempfile::tempdir().expect("a temp dir");
    let cap = dir.path().join("bench.capture");
    std::fs::write(&cap, board::bench_capture()).unwrap();
    let json = dir.path().join("bench.json");
    let csv = dir.path().join("csv");
    let o = run(&["decode", s(&cap), "--csv", s(&csv), "--json", s(&json)], 0);
    assert!(stdout(&o).contains("CRC errors 1"), "{}", stdout(&o));
    let v = read_json(&json);
    assert!(v["field_log_checkpoint"].is_object(), "{v}");
    insta::assert_snapshot!("decode", key_paths(&v));
}

/// `verify --json`: the replay's report on the same capture, which has a checked channel, one never streamed raw
/// (not checked, with the reason), a device gap and a snapshot the replay does not reproduce, so that
/// `channels`, `unchecked_why`, `device_gaps` and `mismatches` all have elements. Exit 1: a snapshot differs.
#[test]
fn verify_json_keys() {
    let dir = tempfile::tempdir().expect("a temp dir");
    let cap = dir.path().join("bench.capture");
    std::fs::write(&cap, board::bench_capture()).unwrap();
    let o = run(&["verify", s(&cap), "--json"], 1);
    let v = stdout_json(&o);
    for array in ["channels", "unchecked_why", "device_gaps", "mismatches"] {
        assert!(v[array].as_array().is_some_and(|a| !a.is_empty()), "{array} is empty: {v}");
    }
    insta::assert_snapshot!("verify", key_paths(&v));
}

/// `record --json`: the summary of a recording (here replayed from the capture file, the same document a port
/// gives): its decode counts, the damaged frame listed with its offset, and the live ADEV at 1 s of each channel.
#[test]
fn record_json_keys() {
    let dir = tempfile::tempdir().expect("a temp dir");
    let cap = dir.path().join("bench.capture");
    std::fs::write(&cap, board::bench_capture()).unwrap();
    let out = dir.path().join("again.capture");
    let o = run(&["record", "--from", s(&cap), "-o", s(&out), "--json"], 0);
    let v = stdout_json(&o);
    assert_eq!(v["ended"], "source_ended", "{v}");
    let bad = v["stats"]["decode"]["bad_frames"].as_array().expect("a list of bad frames");
    assert_eq!(bad.len(), 1, "the capture's one damaged frame is listed: {v}");
    insta::assert_snapshot!("record", key_paths(&v));
}

/// `analyze --json` of a device capture: the streamed path (the newest field-log checkpoint, in deg/s through the
/// hello's channels), which writes the same document as a CSV's; pinned because `octavar analyze CAPTURE` is
/// what the README runs after `record` and `fieldlog`. The capture's 3 s have no bias region, so `bias_model` is
/// null and its keys are absent.
#[test]
fn analyze_json_keys_of_a_capture() {
    let dir = tempfile::tempdir().expect("a temp dir");
    let cap = dir.path().join("bench.capture");
    std::fs::write(&cap, board::bench_capture()).unwrap();
    let json = dir.path().join("bench.json");
    run(&["analyze", s(&cap), "--json", s(&json)], 0);
    let v = read_json(&json);
    insta::assert_snapshot!("analyze_capture", key_paths(&v));
}

/// `bringup --json FILE`: the checks against a live board (the simulated one, over TCP), with the figures behind
/// them: its hello, the clock, the first and last status, the forced checkpoint's report. The clock limit is wide
/// (as the QEMU test's) because the simulated board's clock is the test's own loop; every check passes.
#[test]
fn bringup_json_keys() {
    let dir = tempfile::tempdir().expect("a temp dir");
    let json = dir.path().join("bringup.json");
    let live = board::Live::start(board::Board::new());
    let args = ["bringup", &live.port, "--duration", "2s", "--clock-ppm", "20000", "--answer-within", "3"];
    let o = run(&[&args[..], &["--json", s(&json)]].concat(), 0);
    drop(live);
    assert!(stdout(&o).contains(": ready"), "{}", stdout(&o));
    let v = read_json(&json);
    for part in ["hello", "status_first", "status_last", "checkpoint"] {
        assert!(v[part].is_object(), "{part} is missing: {v}");
    }
    insta::assert_snapshot!("bringup", key_paths(&v));
}

/// `fieldlog --json`: the read-out's summary from a live board back from the field (two sessions logged across a
/// power cut), read over TCP into a capture.
#[test]
fn fieldlog_json_keys() {
    let dir = tempfile::tempdir().expect("a temp dir");
    let cap = dir.path().join("field.capture");
    let live = board::Live::start(board::Board::back_from_the_field(2, 6000));
    let o = run(&["fieldlog", &live.port, "-o", s(&cap), "--answer-within", "3", "--json"], 0);
    drop(live);
    let v = stdout_json(&o);
    assert!(v["checkpoint"].is_u64() && v["sessions"].as_u64() >= Some(2), "{v}");
    insta::assert_snapshot!("fieldlog", key_paths(&v));
}

/// `demo`: its JSON files, `table1.json` and the gap report of each channel (`gap_<channel>.json`, the document of
/// `gap --json`, here with a temperature channel and the effects the bench's channels show: one snapshot of the
/// key paths of all four together), and its text report, which docs/analysis.md quotes from this 4-hour run (the
/// recovered Table 1; the run's durations and its folder masked). 4 hours is the shortest run the docs quote; it
/// takes a few seconds.
#[test]
fn demo_json_keys_and_text_report() {
    let dir = tempfile::tempdir().expect("a temp dir");
    let out = dir.path().join("demo");
    let o = run(&["demo", "--hours", "4", "--out", s(&out)], 0);
    let table1 = read_json(&out.join("table1.json"));
    insta::assert_snapshot!("demo_table1", key_paths(&table1));

    let slugs = ["env_05h", "idg1215_y", "idg1215_x", "adxrs300"];
    let mut gap_keys = std::collections::BTreeSet::new();
    for slug in slugs {
        let keys = key_paths(&read_json(&out.join(format!("gap_{slug}.json"))));
        gap_keys.extend(keys.lines().map(str::to_string));
    }
    let mut written: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".json"))
        .collect();
    written.sort_unstable();
    let mut want: Vec<String> = slugs.iter().map(|s| format!("gap_{s}.json")).collect();
    want.push("table1.json".into());
    want.sort_unstable();
    assert_eq!(written, want, "the demo's JSON files");
    let gap_json_keys = gap_keys.into_iter().collect::<Vec<_>>().join("\n");
    insta::assert_snapshot!("demo_gap", gap_json_keys);

    let text = stdout(&o)
        .lines()
        .map(|l| mask_seconds(&mask_seconds(l, "samples per channel, "), "total "))
        .map(|l| l.replace(s(&out), "[out]"))
        .collect::<Vec<_>>()
        .join("\n");
    insta::assert_snapshot!("demo_text", text);
}

/// A simulated octavar board: the firmware's device core (`shared::device::Characterizer`: accumulators, snapshot
/// rounds, estimates, status, raw streaming, commands) and its field log (`shared::fieldlog`: the checkpoint
/// policy the store task runs, on a RAM model of the log's flash sectors), with the firmware's answers to the
/// field-log commands (`firmware/src/store.rs`). It runs offline into a byte vector ([`bench_capture`]), or live
/// on a local TCP port ([`Live`]), sampling in real time.
mod board {
    use std::io::{ErrorKind, Read, Write};
    use std::net::{TcpListener, TcpStream};
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;
    use std::thread::JoinHandle;
    use std::time::{Duration, Instant};

    use octavar_shared::acc::Snapshot;
    use octavar_shared::device::{Characterizer, DeviceConfig, FrameSink};
    use octavar_shared::fieldlog::{read_out_frame, Checkpoint, CheckpointPolicy, FieldLog, RamFlash, RoundOutcome};
    use octavar_shared::proto::{
        Ack, CheckpointReport, Command, Decoder, Encoder, FieldLogEnd, Frame, SnapshotPart, RESYNC,
    };

    const GYROS: usize = 4;
    const CFG: DeviceConfig<'static> = DeviceConfig::F405;
    /// One sector of the log's flash, in words: the board's 16 KiB.
    const SECTOR_WORDS: usize = 4096;
    type Flash = RamFlash<SECTOR_WORDS>;

    /// The scan at hardware index `i`: each gyro a few codes of noise about its own level, and a temperature.
    fn scan(i: u64) -> [u16; 5] {
        let x = (i.wrapping_mul(2_654_435_761) >> 13) as u16;
        [2000 + x % 97, 2040 + x % 13, 1900 + x % 301, 2048 + x % 5, 1950]
    }

    /// Microseconds since `t0`.
    fn micros(t0: Instant) -> u32 {
        t0.elapsed().as_micros().min(u128::from(u32::MAX)) as u32
    }

    /// The board's side of the link and its flash: frames numbered by one encoder into `out`, each snapshot round
    /// checkpointed (every round here; the board's every ten minutes), and a checkpoint the host asked for
    /// written at the next round and reported.
    struct Wire {
        enc: Encoder,
        out: Vec<u8>,
        log: FieldLog<Flash>,
        policy: CheckpointPolicy<GYROS>,
        words: Vec<u32>,
        /// The sequence number of a `Checkpoint` command not yet answered.
        forced: Option<u32>,
    }

    impl FrameSink for Wire {
        fn send(&mut self, frame: &Frame) {
            let bytes = self.enc.encode_to_vec(frame).expect("every frame fits");
            self.out.extend_from_slice(&bytes);
        }

        fn frames_dropped(&self) -> u32 {
            0
        }

        fn round(&mut self, snapshots: &[Snapshot], losses: u32, samples: u64) {
            let snaps: &[Snapshot; GYROS] = snapshots.try_into().expect("one snapshot per gyro");
            let t0 = Instant::now();
            let written = match self.forced {
                Some(_) => self.policy.round_now(&mut self.log, &mut self.words, snaps, losses, samples),
                None => self.policy.round(&mut self.log, &mut self.words, snaps, losses, samples),
            };
            let program_us = micros(t0);
            let t1 = Instant::now();
            let erase_us = if self.log.prepare_append().expect("the RAM flash erases") { micros(t1) } else { 0 };
            if let Some(seq) = self.forced.take() {
                let checkpoint = match written {
                    Ok(RoundOutcome::Written { seq, .. }) => seq,
                    _ => 0,
                };
                let report =
                    CheckpointReport { seq, checkpoint, program_us, erase_us, samples_lost: 0, flash_error: 0 };
                self.send(&Frame::CheckpointReport(report));
            }
        }
    }

    impl Wire {
        /// Answer `ReadFieldLog` as the store task does: the acknowledgement, every part of the newest checkpoint
        /// (if its number is at least `from`), the end frame.
        fn read_out(&mut self, seq: u32, from: u32) {
            self.send(&Frame::Ack(Ack { seq }));
            let mut i = 0;
            while let Some(frame) = read_out_frame::<_, GYROS>(&mut self.log, from, &mut self.words, i, CFG.rate_hz) {
                self.send(&frame);
                i += 1;
            }
            let sent = u32::from(i > 0);
            self.send(&Frame::FieldLogEnd(FieldLogEnd { checkpoints: sent }));
        }
    }

    /// The board: its core, its link and flash, and the hardware scan count.
    pub struct Board {
        core: Characterizer<'static, GYROS>,
        wire: Wire,
        /// Hardware index of the next scan (lost scans included).
        next_index: u64,
    }

    impl Board {
        /// A new board, its log empty, just powered on.
        pub fn new() -> Self {
            Board::power_on(Flash::new())
        }

        /// Power on over `flash` (the log as the last power-off left it): a new session pools the newest
        /// checkpoint. No raw streaming until the host asks.
        fn power_on(flash: Flash) -> Self {
            let mut log = FieldLog::open(flash, Checkpoint::<GYROS>::WORDS).expect("a sector holds a checkpoint");
            let mut words = vec![0; Checkpoint::<GYROS>::WORDS];
            let (policy, _) = CheckpointPolicy::open(&mut log, &mut words, CFG.snapshot_every);
            log.prepare_append().expect("the RAM flash erases");
            let wire = Wire { enc: Encoder::new(), out: Vec::new(), log, policy, words, forced: None };
            Board { core: Characterizer::new(CFG, 0), wire, next_index: 0 }
        }

        /// A board that logged `sessions` power-on sessions of `scans` scans each in the field, each ended by a
        /// power cut, and has just been powered on again.
        pub fn back_from_the_field(sessions: u32, scans: u64) -> Self {
            let mut flash = Flash::new();
            for _ in 0..sessions {
                let mut b = Board::power_on(flash);
                b.sample(scans);
                flash = b.wire.log.into_flash();
            }
            Board::power_on(flash)
        }

        /// The start of a connection, as the firmware starts each: a lone delimiter, then the hello.
        pub fn connect(&mut self) {
            self.wire.out.extend_from_slice(&RESYNC);
            let hello = self.core.hello();
            self.wire.send(&hello);
        }

        /// A host command in the frame numbered `seq`, routed as the firmware routes it.
        pub fn command(&mut self, seq: u32, cmd: Command) {
            match cmd {
                Command::Checkpoint => self.wire.forced = Some(seq),
                Command::ReadFieldLog { from_checkpoint } => self.wire.read_out(seq, from_checkpoint),
                other => self.core.command(seq, other, &mut self.wire),
            }
        }

        /// Sample `scans` more scans (whole blocks of 128, as the sampler hands them on).
        pub fn sample(&mut self, scans: u64) {
            self.sample_until(self.next_index + scans);
        }

        /// Sample whole blocks up to hardware index `index`.
        fn sample_until(&mut self, index: u64) {
            let block = CFG.block_scans as u64;
            while self.next_index + block <= index {
                let codes: Vec<u16> = (self.next_index..self.next_index + block).flat_map(scan).collect();
                self.core.feed(self.next_index, &codes, &mut self.wire);
                self.next_index += block;
            }
        }

        /// `n` scans lost (an overrun): the hardware index jumps.
        pub fn lose(&mut self, n: u64) {
            self.next_index += n;
        }

        /// Send a frame of the board's own (numbered in its sequence).
        pub fn send(&mut self, frame: &Frame) {
            self.wire.send(frame);
        }

        /// The pooled snapshot of gyro `g` now.
        pub fn snapshot(&self, g: usize) -> Snapshot {
            self.core.snapshot(g)
        }

        /// The bytes sent since the last call.
        pub fn take(&mut self) -> Vec<u8> {
            std::mem::take(&mut self.wire.out)
        }
    }

    /// A capture of a bench session with something in every part of the capture reports: raw streaming of every
    /// channel but gyro 3, three snapshot rounds with 300 scans lost between the second and the third, a snapshot
    /// of gyro 2 that its raw samples do not reproduce (level 5's count off by one), the field log read out, and
    /// a hello damaged on the way (one byte flipped: a CRC error). The same bytes on every run.
    pub fn bench_capture() -> Vec<u8> {
        let mut b = Board::new();
        b.connect();
        b.command(0, Command::StartRaw { channel_mask: 0x17 });
        b.sample(4096);
        b.lose(300);
        b.sample(2048);
        let mut bad = b.snapshot(2);
        bad.levels[5].n += 1;
        for part in SnapshotPart::split(2, &bad) {
            b.send(&Frame::AllanSnapshot(part));
        }
        b.command(1, Command::ReadFieldLog { from_checkpoint: 0 });
        let mut bytes = b.take();
        b.command(2, Command::Hello);
        let mut tail = b.take();
        // The hello is the first frame of the answer, tens of bytes long: a byte in its middle.
        tail[20] ^= 0x5a;
        bytes.extend_from_slice(&tail);
        bytes
    }

    /// A board live on `tcp:127.0.0.1:PORT`, sampling in real time from its start; one host at a time, as a
    /// serial port. Frames sent while no host is connected are lost. Stopped when dropped.
    pub struct Live {
        /// The port, as `octavar` takes it.
        pub port: String,
        stop: Arc<AtomicBool>,
        thread: Option<JoinHandle<()>>,
    }

    impl Live {
        pub fn start(mut board: Board) -> Live {
            let listener = TcpListener::bind("127.0.0.1:0").expect("a local port");
            listener.set_nonblocking(true).expect("a non-blocking listener");
            let port = format!("tcp:{}", listener.local_addr().expect("its address"));
            let stop = Arc::new(AtomicBool::new(false));
            let stopped = stop.clone();
            let thread = std::thread::spawn(move || serve(&mut board, &listener, &stopped));
            Live { port, stop, thread: Some(thread) }
        }
    }

    impl Drop for Live {
        fn drop(&mut self) {
            self.stop.store(true, Ordering::Relaxed);
            if let Some(t) = self.thread.take() {
                let _ = t.join();
            }
        }
    }

    /// The board's loop: take a host's connection, act on its commands, sample up to now, send.
    fn serve(board: &mut Board, listener: &TcpListener, stop: &AtomicBool) {
        let t0 = Instant::now();
        let first = board.next_index;
        let mut link: Option<(TcpStream, Decoder<Command>)> = None;
        let mut buf = [0u8; 4096];
        while !stop.load(Ordering::Relaxed) {
            if link.is_none() {
                match listener.accept() {
                    Ok((stream, _)) => {
                        let ready = stream.set_nonblocking(false).and_then(|()| {
                            stream.set_read_timeout(Some(Duration::from_millis(2)))?;
                            stream.set_nodelay(true)
                        });
                        if ready.is_ok() {
                            board.take();
                            board.connect();
                            link = Some((stream, Decoder::new()));
                        }
                    }
                    Err(_) => std::thread::sleep(Duration::from_millis(2)),
                }
            }
            let mut closed = false;
            if let Some((stream, dec)) = &mut link {
                match stream.read(&mut buf) {
                    Ok(0) => closed = true,
                    Ok(n) => {
                        for r in dec.feed(&buf[..n]).flatten() {
                            board.command(r.seq, r.msg);
                        }
                    }
                    Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
                    Err(_) => closed = true,
                }
            }
            board.sample_until(first + (t0.elapsed().as_secs_f64() * f64::from(CFG.rate_hz)) as u64);
            let out = board.take();
            if let Some((stream, _)) = &mut link {
                closed |= stream.write_all(&out).is_err();
            }
            if closed {
                link = None;
            }
        }
    }
}

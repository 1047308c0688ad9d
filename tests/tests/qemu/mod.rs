//! The firmware's `qemu` build on QEMU's netduinoplus2 (an STM32F405), end to end: build it, run it, capture
//! USART1, decode the bytes with the host decoder, and check every device snapshot bit for bit against the host's
//! replay of the same raw codes (`octavar::board::verify`).
//!
//! Three runs here; the field log's power cut and read-out in [`fieldlog`], and `octavar bringup` in [`bringup`]:
//! - [`SECONDS`] of simulated bench samples (the paper's four gyros, `shared::sim`) with USART1 on a TCP socket:
//!   the test is the host, and after [`RESET_AFTER`] scans have arrived it sends `Command::Reset` the way
//!   `octavar` would, through the firmware's real command decoder. The device acknowledges it, the raw index
//!   restarts with the accumulators, and the snapshots on both sides of the reset are checked.
//! - [`SECONDS`] with the field log on the flash controller model at the datasheet's worst-case timing: every
//!   erase and checkpoint stalls the CPU as the board's flash would, and no scan may be lost.
//! - [`STALL_SECONDS`] with the CPU stalled for [`STALL_MS`] every [`STALL_EVERY`] seconds, interrupts masked,
//!   as a flash erase stalls it, while the virtual converter runs on: the stalls outlast the 1.024 s sample ring,
//!   so scans are lost, and every one of them must come out as an exact gap that the device pooled across and
//!   that verify reports, with every snapshot still matching.
//!
//! Where `qemu-system-arm` is missing the tests print that they were skipped, except under CI (`CI` set), where
//! they fail: `.ci/run` installs QEMU. The firmware is a workspace of its own, built in its own target directory
//! (`firmware/target`), so the outer `cargo test`'s lock on the root target directory is no obstacle; the two
//! builds take turns (one lock) and each run keeps its own copy of its ELF.

use std::fs::File;
use std::io::{Read, Write};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use octavar::io::decode::{CaptureReader, Decoded, Message};
use octavar_shared::proto::{Encoder, Status};

use crate::util::temp_dir;

mod bringup;
mod fieldlog;

/// Seconds of samples of the command run (`OCTAVAR_QEMU_SECONDS`).
const SECONDS: u64 = 5;
/// The host resets the device once this many scans have arrived.
const RESET_AFTER: u64 = 4000;
/// The seed of the simulated bench (`OCTAVAR_QEMU_SEED`).
const SEED: u64 = 1;
/// The stall run: its length, and a stall of `STALL_MS` every `STALL_EVERY` seconds.
const STALL_SECONDS: u64 = 10;
const STALL_EVERY: u64 = 3;
const STALL_MS: u64 = 2000;
/// The datasheet's worst cases the QEMU flash model charges at x32 (DS8626 table 44), microseconds: a 16 KiB
/// sector's erase, and a word's programming (a checkpoint's payload is one sequence of its words).
const ERASE_WORST_US: u64 = 500_000;
const PROGRAM_WORD_WORST_US: u64 = 100;
/// The firmware's rates: scans per second, scans per sample block, scans in the sample ring.
const RATE: u64 = 2000;
const BLOCK: u64 = 128;
const RING: u64 = 2048;
const GYROS: u64 = 4;
/// The most frames one sample block makes, which the frame queue (16) must hold at once when the link drains it
/// between blocks: the block's raw frames (32 scans each) and, where it ends a round, a snapshot part per gyro,
/// the estimate and the status.
const QUEUE_PEAK_MAX: u32 = (BLOCK / 32 + GYROS + 2) as u32;
/// QEMU gets this long (runs are paced at real time) before it is killed.
const QEMU_TIMEOUT: Duration = Duration::from_secs(90);
/// The paper's Table 1 N (deg/sqrt(s)) of the simulated gyros, in channel order (IDG1215 X, Y, ADXRS300, ENV-05H).
const TABLE1_N: [f64; 4] = [3.2e-3, 3.0e-3, 46e-3, 4.0e-4];

/// One firmware build at a time: they share `firmware/target`.
static BUILD: Mutex<()> = Mutex::new(());

/// Kills the child if the test ends (or panics) while it still runs.
struct KillOnDrop(Child);

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        if let Ok(None) = self.0.try_wait() {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
}

/// Whether to run: QEMU installed, or a skip line (a failure under CI).
fn qemu_available() -> bool {
    if Command::new("qemu-system-arm").arg("--version").output().is_ok_and(|o| o.status.success()) {
        return true;
    }
    if std::env::var_os("CI").is_some() {
        panic!("CI must run the QEMU tests: qemu-system-arm is not installed (.ci/run installs it)");
    }
    println!("skipped: qemu-system-arm not installed");
    false
}

/// Build the firmware's qemu feature with the build variables `vars`; returns a copy of the ELF in `dir`.
fn build_firmware(vars: &[(&str, String)], dir: &Path) -> PathBuf {
    let _one_at_a_time = BUILD.lock().unwrap_or_else(|e| e.into_inner());
    let firmware = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../firmware");
    let target_dir = firmware.join("target");
    let mut cmd = Command::new("cargo");
    cmd.current_dir(&firmware)
        .args(["build", "--release", "--locked", "--features", "qemu"])
        .env("CARGO_TARGET_DIR", &target_dir)
        // What the outer cargo or the user set for host builds must not reach the MCU build.
        .env_remove("CARGO_BUILD_TARGET")
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_BUILD_RUSTFLAGS")
        .env_remove("CARGO_ENCODED_RUSTFLAGS")
        .env_remove("CARGO_MANIFEST_DIR")
        .env_remove("CARGO_PRIMARY_PACKAGE")
        .stdin(Stdio::null());
    for var in [
        "OCTAVAR_QEMU_SECONDS",
        "OCTAVAR_QEMU_SEED",
        "OCTAVAR_QEMU_STALL_EVERY",
        "OCTAVAR_QEMU_STALL_MS",
        "OCTAVAR_QEMU_FLASH_TIMING",
        "OCTAVAR_QEMU_POWER_CUT_STEP",
    ] {
        cmd.env_remove(var);
    }
    for (k, v) in vars {
        cmd.env(k, v);
    }
    let out = cmd.output().expect("run cargo");
    assert!(
        out.status.success(),
        "building the firmware's qemu feature failed ({}):\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    let elf = dir.join("octavar-firmware.elf");
    std::fs::copy(target_dir.join("thumbv7em-none-eabihf/release/octavar-firmware"), &elf).expect("copy the ELF");
    elf
}

/// Start QEMU on `elf` with USART1 on `serial` (a QEMU chardev spec); semihosting output to `stdout_file`.
fn start_qemu(elf: &Path, serial: &str, stdout_file: &Path) -> KillOnDrop {
    let child = Command::new("qemu-system-arm")
        .args(["-M", "netduinoplus2", "-nographic", "-monitor", "none"])
        .args(["-semihosting-config", "enable=on,target=native"])
        .args(["-serial", serial])
        .arg("-kernel")
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(File::create(stdout_file).expect("create the stdout file"))
        .stderr(Stdio::piped())
        .spawn()
        .expect("start qemu-system-arm");
    KillOnDrop(child)
}

/// Wait for QEMU to exit 0 within [`QEMU_TIMEOUT`], calling `tick` meanwhile; returns its semihosting output.
fn wait_qemu(mut child: KillOnDrop, stdout_file: &Path, t0: Instant, mut tick: impl FnMut()) -> String {
    let status = loop {
        if let Some(status) = child.0.try_wait().expect("wait for qemu") {
            break status;
        }
        if t0.elapsed() > QEMU_TIMEOUT {
            let _ = child.0.kill();
            let _ = child.0.wait();
            let out = std::fs::read_to_string(stdout_file).unwrap_or_default();
            panic!("qemu-system-arm did not exit within {QEMU_TIMEOUT:?} (killed); its output:\n{out}");
        }
        tick();
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut stderr = String::new();
    if let Some(mut e) = child.0.stderr.take() {
        let _ = e.read_to_string(&mut stderr);
    }
    let out = std::fs::read_to_string(stdout_file).unwrap_or_default();
    assert!(status.success(), "qemu-system-arm exited with {status}; stdout:\n{out}\nstderr:\n{stderr}");
    out
}

/// Every record of a capture; the capture must decode without damage.
fn decode_all(bytes: &[u8]) -> (Vec<Decoded>, octavar::io::decode::DecodeStats) {
    let mut reader = CaptureReader::new(bytes, "usart1");
    let records: Vec<_> = reader.by_ref().collect::<Result<_, _>>().expect("decode the capture");
    let stats = reader.stats().clone();
    assert!(matches!(records.first().map(|d| &d.message), Some(Message::Hello(_))), "the first record is not a hello");
    assert_eq!(stats.hellos, 1, "{stats:#?}");
    assert_eq!(stats.bad_frame_count(), 0, "{stats:#?}");
    assert_eq!((stats.crc_errors, stats.lost_frames, stats.restarts, stats.truncated_tail), (0, 0, 0, 0), "{stats:#?}");
    assert_eq!(stats.incomplete_snapshots, 0, "{stats:#?}");
    (records, stats)
}

/// The raw frames' first samples, in order.
fn raw_starts(records: &[Decoded]) -> Vec<(u64, u64)> {
    records
        .iter()
        .filter_map(|d| match &d.message {
            Message::Samples(s) => Some((s.first_sample, s.sets() as u64)),
            _ => None,
        })
        .collect()
}

fn last_status(records: &[Decoded]) -> Status {
    records
        .iter()
        .rev()
        .find_map(|d| match &d.message {
            Message::Status(s) => Some(s.clone()),
            _ => None,
        })
        .expect("a status frame")
}

/// Scans in a run of `seconds`: whole blocks.
fn run_scans(seconds: u64) -> u64 {
    (seconds * RATE).div_ceil(BLOCK) * BLOCK
}

#[test]
fn firmware_on_qemu_matches_the_host_replay_and_obeys_commands_over_usart() {
    if !qemu_available() {
        return;
    }
    let dir = temp_dir("qemu-commands");
    let t0 = Instant::now();
    let elf =
        build_firmware(&[("OCTAVAR_QEMU_SECONDS", SECONDS.to_string()), ("OCTAVAR_QEMU_SEED", SEED.to_string())], &dir);
    let built = t0.elapsed();

    // USART1 on a TCP socket: QEMU connects to the test, which reads every byte and writes the command.
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind a local port");
    let port = listener.local_addr().expect("local address").port();
    let stdout_file = dir.join("stdout.txt");
    let t1 = Instant::now();
    let child = start_qemu(&elf, &format!("tcp:127.0.0.1:{port}"), &stdout_file);
    listener.set_nonblocking(false).expect("blocking accept");
    let (mut socket, _) = listener.accept().expect("QEMU connects to USART1's socket");
    let bytes = Arc::new(Mutex::new(Vec::new()));
    let reader = {
        let bytes = Arc::clone(&bytes);
        let mut socket = socket.try_clone().expect("clone the socket");
        std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            while let Ok(n) = socket.read(&mut buf) {
                if n == 0 {
                    break;
                }
                bytes.lock().unwrap().extend_from_slice(&buf[..n]);
            }
        })
    };
    // The host: once RESET_AFTER scans have arrived, send Command::Reset as frame 0 of its command stream.
    let mut sent_at: Option<u64> = None;
    let stdout = wait_qemu(child, &stdout_file, t1, || {
        if sent_at.is_some() {
            return;
        }
        let seen = {
            let b = bytes.lock().unwrap();
            CaptureReader::new(&b[..], "usart1")
                .filter_map(|d| match d.ok()?.message {
                    Message::Samples(s) => Some(s.first_sample + s.sets() as u64),
                    _ => None,
                })
                .max()
                .unwrap_or(0)
        };
        if seen >= RESET_AFTER {
            let frame = Encoder::new().encode_to_vec(&octavar_shared::proto::Command::Reset).expect("encode");
            socket.write_all(&frame).expect("send the reset");
            sent_at = Some(seen);
        }
    });
    let ran = t1.elapsed();
    reader.join().expect("the reader thread");
    let bytes = std::mem::take(&mut *bytes.lock().unwrap());
    std::fs::write(dir.join("usart1.capture"), &bytes).expect("keep the capture");
    let sent_at = sent_at.expect("the reset was sent before the run ended");

    // Semihosting: the log flood with the RTT channel as an unplugged probe leaves it (block-if-full, no reader)
    // did not stop the boot; the benchmark line; the end-of-run line with nothing lost or dropped.
    let total = run_scans(SECONDS);
    assert!(stdout.contains("RTT channel block-if-full and no reader: boot goes on"), "{stdout}");
    assert!(stdout.contains("octavar-bench: Characterizer::feed"), "{stdout}");
    assert!(stdout.contains(&format!("octavar-qemu: {total} scans, 0 lost, 0 frames dropped")), "{stdout}");

    // Decode: the ack of command 0, and the raw index back to 0 at the reset, at a block boundary after the
    // scans the host had seen when it sent it.
    let (records, stats) = decode_all(&bytes);
    let acks: Vec<u32> = records
        .iter()
        .filter_map(|d| match &d.message {
            Message::Ack(a) => Some(a.seq),
            _ => None,
        })
        .collect();
    assert_eq!(acks, [0], "the reset is acknowledged once, with its sequence number");
    assert_eq!(stats.sample_sets, total, "{stats:#?}");
    let starts = raw_starts(&records);
    let zeros: Vec<usize> = starts.iter().enumerate().filter(|(_, (f, _))| *f == 0).map(|(i, _)| i).collect();
    assert_eq!(zeros.len(), 2, "the raw index starts at 0 at boot and again at the reset: {zeros:?}");
    let (last_first, last_sets) = starts[zeros[1] - 1];
    let reset_after = last_first + last_sets;
    assert!(
        reset_after >= sent_at && reset_after.is_multiple_of(BLOCK),
        "reset after {reset_after}, sent at {sent_at}"
    );
    let ack_at = records.iter().position(|d| matches!(d.message, Message::Ack(_))).expect("ack");
    let second_session = records
        .iter()
        .enumerate()
        .filter(|(_, d)| matches!(&d.message, Message::Samples(s) if s.first_sample == 0))
        .nth(1)
        .map(|(i, _)| i)
        .expect("raw frames after the reset");
    assert!(ack_at < second_session, "the ack comes before the new session's first raw frame");

    let snapshot_samples: Vec<u64> = records
        .iter()
        .filter_map(|d| match &d.message {
            Message::Snapshot(c) if c.channel == 0 => Some(c.snapshot.samples),
            _ => None,
        })
        .collect();
    let expect: Vec<u64> = (1..=reset_after / RATE).chain(1..=(total - reset_after) / RATE).map(|r| r * RATE).collect();
    assert_eq!(snapshot_samples, expect, "channel 0's snapshot sample counts (the reset restarts them)");
    let rounds = expect.len() as u64;

    // Status: the uptime is the hardware scan count, nothing lost.
    let status = last_status(&records);
    assert_eq!((status.samples_lost, status.adc_overruns, status.frames_dropped), (0, 0, 0), "{status:?}");
    assert_eq!(status.samples_per_channel, (total - reset_after) / RATE * RATE, "{status:?}");
    // The stack's high-water mark: reported, within the stack, and no deeper than the end of the run's reading.
    let (end_peak, stack_size) = stdout
        .lines()
        .find_map(|l| {
            let rest = l.split("; stack peak ").nth(1)?.split(';').next()?;
            let (peak, size) = rest.split_once(" of ")?;
            Some((peak.parse::<u32>().ok()?, size.strip_suffix(" bytes")?.parse::<u32>().ok()?))
        })
        .unwrap_or_else(|| panic!("no stack peak in the end-of-run line:\n{stdout}"));
    let peak = status.stack_peak_bytes.expect("the firmware measures its stack");
    // A tenth of the stack left: what lies below it (QEMU's flash model in .uninit) stays out of reach.
    assert!(
        peak > 256 && peak <= end_peak && end_peak * 10 < stack_size * 9,
        "peak {peak}, at the end {end_peak} of {stack_size}"
    );

    // Estimates: one per round, N and B of every gyro in the last; N near the simulated Table 1 values.
    let estimates: Vec<_> = records
        .iter()
        .filter_map(|d| match &d.message {
            Message::Estimate(e) => Some(e.clone()),
            _ => None,
        })
        .collect();
    assert_eq!(estimates.len() as u64, rounds);
    let last = estimates.last().expect("estimates");
    assert_eq!(last.channels.len() as u64, GYROS);
    for (c, n_true) in last.channels.iter().zip(TABLE1_N) {
        let n = f64::from(c.n_dps_per_rt_s.unwrap_or_else(|| panic!("no N for channel {}", c.channel)));
        assert!(c.b_dps.is_some_and(|b| b > 0.0), "no B for channel {}: {c:?}", c.channel);
        assert!((n / n_true - 1.0).abs() < 0.3, "channel {}: onboard N {n:.3e}, simulated {n_true:.3e}", c.channel);
    }

    // Every snapshot, before and after the reset, bit for bit equal to the host replay.
    let report = octavar::board::verify::verify(CaptureReader::new(&bytes[..], "usart1")).expect("verify the capture");
    assert!(report.passed(), "{report:#?}");
    assert_eq!((report.checked, report.matched, report.unchecked), (GYROS * rounds, GYROS * rounds, 0), "{report:#?}");
    assert!(report.device_gaps.is_empty(), "{:?}", report.device_gaps);

    println!(
        "qemu: firmware build {:.1} s, run {:.1} s, {} bytes on USART1, {} frames, reset sent after {sent_at} scans and \
         taken after {reset_after}, {} snapshots checked bit for bit",
        built.as_secs_f64(),
        ran.as_secs_f64(),
        stats.bytes,
        stats.frames,
        report.checked
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Build with `vars` and run, USART1 to a file; returns the semihosting output, the capture and the run's wall
/// time.
fn run_built_with(dir: &Path, vars: &[(&str, String)]) -> (String, Vec<u8>, Duration) {
    let elf = build_firmware(vars, dir);
    let serial = dir.join("usart1.capture");
    let stdout_file = dir.join("stdout.txt");
    let t0 = Instant::now();
    let child = start_qemu(&elf, &format!("file:{}", serial.display()), &stdout_file);
    let stdout = wait_qemu(child, &stdout_file, t0, || {});
    (stdout, std::fs::read(&serial).expect("read the capture"), t0.elapsed())
}

/// The most frames the firmware's frame queue held at once, and its size, from the end-of-run line.
fn frame_queue_peak(stdout: &str) -> (u32, u32) {
    stdout
        .lines()
        .find_map(|l| {
            let (peak, size) = l.split("; frame queue peak ").nth(1)?.split_once(" of ")?;
            Some((peak.parse().ok()?, size.trim().parse().ok()?))
        })
        .unwrap_or_else(|| panic!("no frame queue peak in the end-of-run line:\n{stdout}"))
}

/// Build and run `seconds` of scans with a stall of `stall_ms` every `every` seconds.
fn run_with_stalls(dir: &Path, seconds: u64, every: u64, stall_ms: u64) -> (String, Vec<u8>, Duration) {
    let vars = [
        ("OCTAVAR_QEMU_SECONDS", seconds.to_string()),
        ("OCTAVAR_QEMU_SEED", SEED.to_string()),
        ("OCTAVAR_QEMU_STALL_EVERY", every.to_string()),
        ("OCTAVAR_QEMU_STALL_MS", stall_ms.to_string()),
    ];
    run_built_with(dir, &vars)
}

/// The field log on the flash controller model at its worst-case timing: each erase stalls the CPU 0.5 s and
/// each checkpoint's programming 78.7 ms, interrupts masked, inside the store, exactly where the board's flash
/// would. The store lets the sampler drain the ring before each and never runs them back to back, so no scan
/// is lost, and verify (what `octavar verify` exits 0 on) passes with no gap.
#[test]
fn the_field_log_at_the_flash_worst_case_timing_loses_no_sample() {
    if !qemu_available() {
        return;
    }
    let dir = temp_dir("qemu-flash-worst");
    let vars = [
        ("OCTAVAR_QEMU_SECONDS", SECONDS.to_string()),
        ("OCTAVAR_QEMU_SEED", SEED.to_string()),
        ("OCTAVAR_QEMU_FLASH_TIMING", "worst".to_string()),
    ];
    let (stdout, bytes, _) = run_built_with(&dir, &vars);
    // Checkpoints at 1, 3 and 5 s; erases at boot (an empty log) and after the second (a full sector).
    let erases = stdout.matches(&format!("octavar-qemu: flash busy {ERASE_WORST_US} us")).count();
    let payload_us = octavar_shared::fieldlog::Checkpoint::<{ GYROS as usize }>::WORDS as u64 * PROGRAM_WORD_WORST_US;
    let programs = stdout.matches(&format!("octavar-qemu: flash busy {payload_us} us")).count();
    assert!(erases >= 2 && programs >= 2, "erases {erases}, checkpoints {programs}:\n{stdout}");
    assert!(!stdout.contains("broke"), "{stdout}");
    let total = run_scans(SECONDS);
    assert!(stdout.contains(&format!("octavar-qemu: {total} scans, 0 lost, 0 frames dropped")), "{stdout}");
    let (records, stats) = decode_all(&bytes);
    assert_eq!(stats.sample_sets, total, "{stats:#?}");
    assert_eq!(last_status(&records).samples_lost, 0);
    let report = octavar::board::verify::verify(CaptureReader::new(&bytes[..], "usart1")).expect("verify the capture");
    assert!(report.passed() && report.device_gaps.is_empty(), "{report:#?}");
    assert_eq!((report.checked, report.unchecked), (GYROS * (total / RATE), 0), "{report:#?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn stalls_longer_than_the_ring_become_exact_gaps_and_every_snapshot_still_matches() {
    if !qemu_available() {
        return;
    }
    let dir = temp_dir("qemu-stalls");
    let (stdout, bytes, ran) = run_with_stalls(&dir, STALL_SECONDS, STALL_EVERY, STALL_MS);

    // The stalls happened (at 3, 6 and 9 s of a run whose scans end after 10 s).
    let stalls = stdout.matches(&format!("octavar-qemu: stalled {STALL_MS} ms")).count();
    assert!(stalls >= 2, "{stdout}");
    let total = run_scans(STALL_SECONDS);
    let lost: u64 = stdout
        .lines()
        .find_map(|l| {
            let rest = l.strip_prefix(&format!("octavar-qemu: {total} scans, "))?;
            rest.split(" lost").next()?.parse().ok()
        })
        .unwrap_or_else(|| panic!("no end-of-run line: {stdout}"));

    let (records, stats) = decode_all(&bytes);
    // The raw stream: every scan either arrived or is inside a jump of the index, and the jumps are the stalls'.
    let starts = raw_starts(&records);
    let mut next = 0;
    let mut jumps = Vec::new();
    for &(first, sets) in &starts {
        assert!(first >= next, "the raw index never goes back: {first} after {next}");
        if first > next {
            jumps.push(first - next);
        }
        next = first + sets;
    }
    assert_eq!(stats.sample_sets + jumps.iter().sum::<u64>(), total, "arrived + lost = every scan");
    assert_eq!(jumps.iter().sum::<u64>(), lost, "the device's count of lost scans is the raw stream's");
    // Each stall loses at least what the ring cannot hold. It may lose more here than on a board: the virtual
    // converter simulates the scans of the stall when the CPU comes back, which takes time a DMA does not.
    // The last stall may be cut short by the end of the run.
    let stall_scans = STALL_MS * RATE / 1000;
    assert!(jumps.len() >= 2 && jumps.len() <= stalls, "gaps {jumps:?} for {stalls} stalls");
    for (i, j) in jumps.iter().enumerate() {
        let least = if i + 1 == jumps.len() { 1 } else { stall_scans - RING };
        assert!(
            (least..=stall_scans + RING / 2).contains(j),
            "a gap of {j} scans for a {STALL_MS} ms stall and a {RING}-scan ring (gaps {jumps:?})"
        );
    }
    let status = last_status(&records);
    assert_eq!(status.frames_dropped, 0, "{status:?}");
    // The ring's backlog after a stall comes out a block at a time, the link draining the frame queue between
    // blocks: a burst of one block's frames at most, never two blocks' (14 of the queue's 16, which dropped
    // frames where the host was loaded).
    let (queue_peak, queue) = frame_queue_peak(&stdout);
    assert!(queue_peak <= QUEUE_PEAK_MAX && QUEUE_PEAK_MAX < queue, "frame queue peak {queue_peak} of {queue}");
    assert!(status.samples_lost <= lost && status.samples_lost >= jumps[..jumps.len() - 1].iter().sum(), "{status:?}");

    // Verify: every snapshot checked and matching, the gaps reported with their exact sizes.
    let report = octavar::board::verify::verify(CaptureReader::new(&bytes[..], "usart1")).expect("verify the capture");
    assert!(report.passed(), "{report:#?}");
    assert_eq!((report.unchecked, report.mismatched_snapshots), (0, 0), "{report:#?}");
    assert_eq!(report.checked, report.snapshots, "{report:#?}");
    let reported: Vec<u64> = report.device_gaps.iter().map(|g| g.lost).collect();
    assert_eq!(reported, jumps, "verify reports each gap with its size");
    println!(
        "qemu stalls: {stalls} stalls of {STALL_MS} ms, gaps {jumps:?} ({lost} scans lost of {total}), {} snapshots \
         checked bit for bit, run {:.1} s",
        report.checked,
        ran.as_secs_f64()
    );
    let _ = std::fs::remove_dir_all(&dir);
}

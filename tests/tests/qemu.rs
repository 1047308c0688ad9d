//! The firmware's `qemu` build on QEMU's netduinoplus2 (an STM32F405), end to end: build it, run it, capture
//! USART1, decode the bytes with the host decoder, and check every device snapshot bit for bit against the host's
//! replay of the same raw codes (`octavar::verify`).
//!
//! The run is [`SECONDS`] of simulated bench samples (the paper's four gyros, `shared::sim`) with a host reset
//! after [`RESET_AT`] seconds, so it also shows that the raw sample index restarts with the accumulators at a
//! reset and that the snapshots after it are checked too. Where `qemu-system-arm` is missing the test prints that
//! it was skipped, except under CI (`CI` set), where it fails: `.ci/run` installs QEMU.
//!
//! The firmware is a workspace of its own, built in its own target directory (`firmware/target`), so the outer
//! `cargo test`'s lock on the root target directory is no obstacle.

use std::fs::File;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use octavar::decode::Record;

use crate::util::temp_dir;

/// Seconds of samples the firmware runs (`OCTAVAR_QEMU_SECONDS`).
const SECONDS: u64 = 5;
/// Seconds of samples after which the simulated host resets the device (`OCTAVAR_QEMU_RESET_AT`).
const RESET_AT: u64 = 2;
/// The seed of the simulated bench (`OCTAVAR_QEMU_SEED`).
const SEED: u64 = 1;
/// The firmware's rates: scans per second, scans per sample block, scans per snapshot round.
const RATE: u64 = 2000;
const BLOCK: u64 = 128;
const GYROS: u64 = 4;
/// QEMU gets this long (a 5 s run takes about 6 s of wall time) before it is killed.
const QEMU_TIMEOUT: Duration = Duration::from_secs(40);
/// The paper's Table 1 N (deg/sqrt(s)) of the simulated gyros, in channel order (IDG1215 X, Y, ADXRS300, ENV-05H).
const TABLE1_N: [f64; 4] = [3.2e-3, 3.0e-3, 46e-3, 4.0e-4];

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

fn qemu_installed() -> bool {
    Command::new("qemu-system-arm").arg("--version").output().is_ok_and(|o| o.status.success())
}

/// Build the firmware's qemu feature for this run; returns the ELF.
fn build_firmware(firmware: &Path) -> PathBuf {
    let target_dir = firmware.join("target");
    let out = Command::new("cargo")
        .current_dir(firmware)
        .args(["build", "--release", "--locked", "--features", "qemu"])
        .env("OCTAVAR_QEMU_SECONDS", SECONDS.to_string())
        .env("OCTAVAR_QEMU_RESET_AT", RESET_AT.to_string())
        .env("OCTAVAR_QEMU_SEED", SEED.to_string())
        .env("CARGO_TARGET_DIR", &target_dir)
        // What the outer cargo or the user set for host builds must not reach the MCU build.
        .env_remove("CARGO_BUILD_TARGET")
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_BUILD_RUSTFLAGS")
        .env_remove("CARGO_ENCODED_RUSTFLAGS")
        .env_remove("CARGO_MANIFEST_DIR")
        .env_remove("CARGO_PRIMARY_PACKAGE")
        .stdin(Stdio::null())
        .output()
        .expect("run cargo");
    assert!(
        out.status.success(),
        "building the firmware's qemu feature failed ({}):\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    target_dir.join("thumbv7em-none-eabihf/release/octavar-firmware")
}

/// Run the ELF on netduinoplus2 with USART1 to `serial`; returns the exit code and the semihosting output.
fn run_qemu(elf: &Path, serial: &Path, stdout_file: &Path) -> (i32, String, Duration) {
    let t0 = Instant::now();
    let child = Command::new("qemu-system-arm")
        .args(["-M", "netduinoplus2", "-nographic", "-monitor", "none"])
        .args(["-semihosting-config", "enable=on,target=native"])
        .arg("-serial")
        .arg(format!("file:{}", serial.display()))
        .arg("-kernel")
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(File::create(stdout_file).expect("create the stdout file"))
        .stderr(Stdio::piped())
        .spawn()
        .expect("start qemu-system-arm");
    let mut child = KillOnDrop(child);
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
        std::thread::sleep(Duration::from_millis(50));
    };
    let mut stderr = String::new();
    if let Some(mut e) = child.0.stderr.take() {
        let _ = std::io::Read::read_to_string(&mut e, &mut stderr);
    }
    let out = std::fs::read_to_string(stdout_file).unwrap_or_default();
    let code = status.code().unwrap_or(-1);
    assert_eq!(code, 0, "qemu-system-arm exited with {status}; stdout:\n{out}\nstderr:\n{stderr}");
    (code, out, t0.elapsed())
}

/// Snapshot rounds a run of `seconds` with a reset after `reset_at` seconds gives (per gyro).
fn expected_rounds(seconds: u64, reset_at: u64) -> u64 {
    let total = (seconds * RATE).div_ceil(BLOCK) * BLOCK;
    let before = if reset_at == 0 { 0 } else { ((reset_at * RATE).div_ceil(BLOCK) * BLOCK).min(total) };
    before / RATE + (total - before) / RATE
}

#[test]
fn firmware_on_qemu_matches_the_host_replay() {
    if !qemu_installed() {
        if std::env::var_os("CI").is_some() {
            panic!("CI must run the QEMU test: qemu-system-arm is not installed (.ci/run installs it)");
        }
        println!("skipped: qemu-system-arm not installed");
        return;
    }
    let t0 = Instant::now();
    let firmware = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../firmware");
    let elf = build_firmware(&firmware);
    let built = t0.elapsed();

    let dir = temp_dir("qemu");
    let serial = dir.join("usart1.capture");
    let (_, stdout, ran) = run_qemu(&elf, &serial, &dir.join("stdout.txt"));

    // Semihosting: the benchmark line, the reset, the end-of-run line with nothing dropped.
    let total = (SECONDS * RATE).div_ceil(BLOCK) * BLOCK;
    let reset_after = (RESET_AT * RATE).div_ceil(BLOCK) * BLOCK;
    assert!(stdout.contains("octavar-bench: OctaveAllan<8>::push"), "{stdout}");
    assert!(stdout.contains(&format!("octavar-qemu: reset after {reset_after} samples")), "{stdout}");
    assert!(
        stdout.contains(&format!("octavar-qemu: {total} samples per channel, 0 frames dropped, 0 ADC overruns")),
        "{stdout}"
    );

    // Decode: hello first, nothing damaged or lost, the raw index back to 0 at the reset.
    let rounds = expected_rounds(SECONDS, RESET_AT);
    let mut reader = octavar::decode::open(&serial).expect("open the capture");
    let records: Vec<_> = reader.by_ref().collect::<Result<_, _>>().expect("decode the capture");
    let stats = reader.stats().clone();
    assert!(matches!(records.first().map(|d| &d.record), Some(Record::Hello(_))), "the first record is not a hello");
    assert_eq!(stats.hellos, 1, "{stats:#?}");
    assert_eq!(stats.bad_frame_count(), 0, "{stats:#?}");
    assert_eq!((stats.crc_errors, stats.lost_frames, stats.restarts, stats.truncated_tail), (0, 0, 0, 0), "{stats:#?}");
    assert_eq!(stats.incomplete_snapshots, 0, "{stats:#?}");
    assert_eq!(stats.sample_sets, total, "{stats:#?}");
    let starts: Vec<u64> = records
        .iter()
        .filter_map(|d| match &d.record {
            Record::Samples(s) => Some(s.first_sample),
            _ => None,
        })
        .collect();
    let zeros: Vec<usize> = starts.iter().enumerate().filter(|(_, &f)| f == 0).map(|(i, _)| i).collect();
    assert_eq!(zeros.len(), 2, "the raw index starts at 0 at boot and again at the reset: {zeros:?}");
    assert_eq!(starts[zeros[1] - 1] + 32, reset_after, "the last raw frame before the reset");
    let snapshot_samples: Vec<u64> = records
        .iter()
        .filter_map(|d| match &d.record {
            Record::Snapshot(c) if c.channel == 0 => Some(c.snapshot.samples),
            _ => None,
        })
        .collect();
    let before = reset_after / RATE;
    let expect: Vec<u64> = (1..=before).chain(1..=(total - reset_after) / RATE).map(|r| r * RATE).collect();
    assert_eq!(snapshot_samples, expect, "channel 0's snapshot sample counts (the reset restarts them)");

    // Estimates: one per round, N and B of every gyro in the last; N near the simulated Table 1 values.
    let estimates: Vec<_> = records
        .iter()
        .filter_map(|d| match &d.record {
            Record::Estimate(e) => Some(e.clone()),
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
    let report = octavar::verify::verify_path(&serial).expect("verify the capture");
    assert!(report.passed(), "{report:#?}");
    assert_eq!(report.snapshots, GYROS * rounds, "{report:#?}");
    assert_eq!((report.checked, report.matched, report.unchecked), (GYROS * rounds, GYROS * rounds, 0), "{report:#?}");

    println!(
        "qemu: firmware build {:.1} s, run {:.1} s, {} bytes on USART1, {} frames, {} snapshots checked bit for bit",
        built.as_secs_f64(),
        ran.as_secs_f64(),
        stats.bytes,
        stats.frames,
        report.checked
    );
    let _ = std::fs::remove_dir_all(&dir);
}

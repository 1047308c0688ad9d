//! `octavar bringup` against the QEMU firmware over its TCP serial port (QEMU connects to the test, and again
//! after the reconnect check drops the connection): every check QEMU can answer passes,
//! with the figures a board would give (the clock against the host's, a checkpoint's stall at the flash's
//! worst-case timing, nothing lost), and the one it cannot (a hello first after a reconnect: TCP has no DTR) says
//! so instead of passing silently.

use std::time::{Duration, Instant};

use octavar::board::bringup::{bringup, BringupOptions, Outcome};
use std::net::TcpListener;

use octavar::board::link::{Source, TcpLink};

use super::{build_firmware, qemu_available, wait_qemu, KillOnDrop, SEED};
use crate::util::temp_dir;

/// Seconds of scans the firmware runs (the checks take about 10 s).
const SECONDS: u64 = 16;

/// The test's listener, which QEMU's USART1 connects to (and connects to again, a second after the test drops
/// the connection: `reconnect=1`). Holding the listener keeps the port the test's own while other tests run.
struct Listening(TcpListener);

impl Source for Listening {
    type Link = TcpLink;
    fn name(&self) -> String {
        format!("tcp:{}", self.0.local_addr().map(|a| a.to_string()).unwrap_or_default())
    }
    fn connect(&mut self) -> std::io::Result<TcpLink> {
        self.0.set_nonblocking(true)?;
        let t0 = Instant::now();
        loop {
            match self.0.accept() {
                Ok((stream, _)) => {
                    stream.set_nonblocking(false)?;
                    return TcpLink::from_stream(stream, Duration::from_millis(50));
                }
                Err(e) if e.kind() != std::io::ErrorKind::WouldBlock || t0.elapsed() > Duration::from_secs(20) => {
                    return Err(e)
                }
                Err(_) => std::thread::sleep(Duration::from_millis(20)),
            }
        }
    }
    fn can_reconnect(&self) -> bool {
        true
    }
}

#[test]
fn bringup_passes_every_check_qemu_can_answer() {
    if !qemu_available() {
        return;
    }
    let dir = temp_dir("qemu-bringup");
    let elf = build_firmware(
        &[
            ("OCTAVAR_QEMU_SECONDS", SECONDS.to_string()),
            ("OCTAVAR_QEMU_SEED", SEED.to_string()),
            ("OCTAVAR_QEMU_FLASH_TIMING", "worst".to_string()),
        ],
        &dir,
    );
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind a local port");
    let port = listener.local_addr().expect("local address").port();
    let stdout_file = dir.join("stdout.txt");
    let t0 = Instant::now();
    let child = std::process::Command::new("qemu-system-arm")
        .args(["-M", "netduinoplus2", "-nographic", "-monitor", "none"])
        .args(["-semihosting-config", "enable=on,target=native"])
        .args(["-serial", &format!("tcp:127.0.0.1:{port},reconnect=1")])
        .arg("-kernel")
        .arg(&elf)
        .stdin(std::process::Stdio::null())
        .stdout(std::fs::File::create(&stdout_file).expect("create the stdout file"))
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("start qemu-system-arm");
    let child = KillOnDrop(child);

    // The clock limit: QEMU's emulated converter against the host's clock, over a 4 s run with 0.5 s flash
    // stalls in it, reads within a few thousand ppm on an idle host (QEMU's timers are no crystal), and 25,000 ppm
    // on one whose two cores are busy with other work (QEMU's timers follow the host's scheduling); 5% still tells
    // any wrong clock setting (another crystal is 33-50% off).
    let opts = BringupOptions {
        duration: Duration::from_secs(4),
        clock_ppm_limit: 50_000.0,
        answer_within: Duration::from_secs(3),
        hello_on_connect: false,
        ..Default::default()
    };
    let mut source = Listening(listener);
    let report = bringup(&mut source, &opts).expect("connect to QEMU");
    let _ = wait_qemu(child, &stdout_file, t0, || {});

    let lines: Vec<String> =
        report.checks.iter().map(|c| format!("{:?} {}: {}", c.outcome, c.name, c.detail)).collect();
    let names: Vec<&str> = report.checks.iter().map(|c| c.name).collect();
    assert_eq!(names, ["hello", "clock", "gaps", "counters", "checkpoint", "reconnect", "reset"], "{lines:#?}");
    assert!(report.passed, "{lines:#?}");
    assert!(report.checks.iter().all(|c| c.outcome == Outcome::Pass), "{lines:#?}");
    let ppm = report.clock_ppm.expect("the clock was timed");
    assert!(ppm.abs() <= opts.clock_ppm_limit && report.clock_frames > 100, "{ppm} ppm, {lines:#?}");
    let cp = report.checkpoint.expect("the checkpoint's report");
    // The QEMU flash model stalls for the datasheet's worst case: 787 words at 100 us.
    assert!(cp.program_us >= 78_700 && cp.samples_lost == 0 && cp.flash_error == 0, "{cp:?}");
    assert!(report.checks[5].detail.contains("no DTR on this link"), "{lines:#?}");
    println!("qemu bringup:\n  {}", lines.join("\n  "));
    let _ = std::fs::remove_dir_all(&dir);
}

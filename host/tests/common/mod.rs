//! What the command-line tests share: running the `octavar` binary and reading what it printed.
#![allow(dead_code)] // each test crate uses some of these

use std::io::Write;
use std::process::{Command, Output, Stdio};

/// Run `octavar` with `args`, feeding `stdin` when given (else no stdin), and wait for it.
pub fn octavar(args: &[&str], stdin: Option<&[u8]>) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_octavar"))
        .args(args)
        .stdin(if stdin.is_some() { Stdio::piped() } else { Stdio::null() })
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run octavar");
    if let Some(bytes) = stdin {
        // A command that finds a fault early exits without reading the rest: its closed pipe is no test failure
        // (the exit code and message say what happened).
        if let Err(e) = child.stdin.take().unwrap().write_all(bytes) {
            assert_eq!(e.kind(), std::io::ErrorKind::BrokenPipe, "writing octavar's stdin: {e}");
        }
    }
    child.wait_with_output().unwrap()
}

/// What it wrote to stdout.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// What it wrote to stderr.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A one-column CSV (header `g`) of 16,384 samples at 10 Hz: white noise of sd 0.1 (a sum of twelve uniforms from
/// a linear congruential generator seeded with `seed`) plus a sinusoid of amplitude 0.05 and period 50 s, a gap
/// the diagnosis names `sinusoid`. Its bytes depend on nothing but `seed`.
pub fn sinusoid_record(seed: u64) -> String {
    let mut s = seed;
    let mut text = String::from("g\n");
    for i in 0..16_384 {
        let mut a = 0.0;
        for _ in 0..12 {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            a += (s >> 11) as f64 / (1u64 << 53) as f64;
        }
        let t = i as f64 / 10.0;
        text.push_str(&format!("{}\n", 0.1 * (a - 6.0) + 0.05 * (std::f64::consts::TAU * t / 50.0).sin()));
    }
    text
}

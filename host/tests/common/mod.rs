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

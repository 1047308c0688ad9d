//! Command-line definitions: one module per subcommand, each with `Args` and `run`.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

pub mod accumulate;
pub mod analyze;
pub mod bringup;
pub mod csv_args;
pub mod datasheet;
pub mod decode;
pub mod demo;
pub mod export_args;
pub mod fieldlog;
pub mod gap;
pub mod json_out;
pub mod progress;
pub mod record;
pub mod simulate;
pub mod verify;

/// octavar: how good is this gyroscope? Allan variance, noise terms, simulation and the sim-to-real gap.
#[derive(Debug, Parser)]
#[command(name = "octavar", version, about, propagate_version = true)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// The main job: the paper's gyro bench on the built-in virtual gyros, 72 h at 2 kS/s, Table 1 recovered.
    Demo(demo::Args),
    /// Run the exact octave Allan accumulator over integer ADC codes and print every octave.
    Accumulate(accumulate::Args),
    /// Analyse a rate recording: the Allan deviation family with confidence intervals, the IEEE 952 noise terms.
    Analyze(analyze::Args),
    /// Turn datasheet figures in any unit into octavar's units and the estimators' configs (--export).
    Datasheet(datasheet::Args),
    /// Simulate a gyro bench from a model (flags or model.toml): CSV of rates in deg/s, or raw ADC codes.
    Simulate(simulate::Args),
    /// Record a device's frames (serial port, file or stdin) into a capture file, with live counts; survives unplugging.
    Record(record::Args),
    /// Check a freshly flashed board: hello, clock in ppm, gaps, counters, a forced checkpoint, a reconnect, a reset.
    Bringup(bringup::Args),
    /// Read the field log a device kept without a PC (its checkpoints in flash) into a capture, resuming if cut.
    Fieldlog(fieldlog::Args),
    /// Decode a capture: summary, CSV (samples, snapshots, status, estimates) and JSON; damaged frames are counted.
    Decode(decode::Args),
    /// Replay a capture's raw samples through the accumulator and check every device snapshot bit for bit.
    Verify(verify::Args),
    /// Diagnose the sim-to-real gap: where the fitted model's simulation and the record part, which effect, and the held-out check.
    Gap(gap::Args),
}

impl Command {
    pub fn run(self) -> anyhow::Result<ExitCode> {
        match self {
            Command::Demo(a) => a.run(),
            Command::Accumulate(a) => a.run(),
            Command::Analyze(a) => a.run(),
            Command::Datasheet(a) => a.run(),
            Command::Simulate(a) => a.run(),
            Command::Record(a) => a.run(),
            Command::Fieldlog(a) => a.run(),
            Command::Bringup(a) => a.run(),
            Command::Decode(a) => a.run(),
            Command::Verify(a) => a.run(),
            Command::Gap(a) => a.run(),
        }
    }
}

/// True when the error is a closed stdout (`octavar ... | head`): that is a normal end, exit 0.
pub fn is_broken_pipe(err: &anyhow::Error) -> bool {
    err.chain()
        .any(|e| e.downcast_ref::<std::io::Error>().is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe))
}

/// The error as one line: each cause of the chain after the message, except a cause whose text the line already
/// holds (most of octavar's errors name their cause in their own message, and anyhow's `{:#}` would print it twice:
/// "training Allan deviation: too few valid samples: 0 ...: too few valid samples: 0 ...").
pub fn error_line(err: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in err.chain() {
        let text = cause.to_string();
        if line.is_empty() {
            line = text;
        } else if !line.contains(&text) {
            line.push_str(": ");
            line.push_str(&text);
        }
    }
    line
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, thiserror::Error)]
    #[error("training Allan deviation: {0}")]
    struct Wraps(#[from] std::io::Error);

    #[test]
    fn a_cause_already_in_the_message_is_not_repeated() {
        let io = || std::io::Error::other("too few valid samples: 0");
        let e = anyhow::Error::new(Wraps(io()));
        assert_eq!(format!("{e:#}"), "training Allan deviation: too few valid samples: 0: too few valid samples: 0");
        assert_eq!(error_line(&e), "training Allan deviation: too few valid samples: 0");
        // A context whose cause it does not name keeps the cause.
        let e = anyhow::Error::new(io()).context("writing gap.json");
        assert_eq!(error_line(&e), "writing gap.json: too few valid samples: 0");
    }
}

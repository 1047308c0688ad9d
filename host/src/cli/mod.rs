//! Command-line definitions: one module per subcommand, each with `Args` and `run`.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

pub mod accumulate;
pub mod analyze;
pub mod csv_args;
pub mod decode;
pub mod demo;
pub mod gap;
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
    /// Simulate a gyro bench from a model (flags or model.toml): CSV of rates in deg/s, or raw ADC codes.
    Simulate(simulate::Args),
    /// Record a device's frames (serial port, file or stdin) into a capture file, with live counts; survives unplugging.
    Record(record::Args),
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
            Command::Simulate(a) => a.run(),
            Command::Record(a) => a.run(),
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

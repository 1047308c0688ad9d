//! `octavar accumulate`: flags, then a table or JSON of every octave.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use octavar::board::accumulate::{accumulate, AccumulateOptions};

/// Run the exact octave Allan accumulator (the firmware's) over integer ADC codes and print every octave: m,
/// tau_s, n (number of differences), the exact integer sum of squares, avar and adev, in codes.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Codes, one integer per line, or a CSV with a header (with --column); .gz is read as such; - is stdin.
    pub input: PathBuf,
    /// Read this column of a CSV with a header.
    #[arg(long)]
    pub column: Option<String>,
    /// Sample rate in Hz.
    #[arg(long, default_value_t = 2000.0)]
    pub rate: f64,
    /// Stride S: clusters start every m/S samples (1 = non-overlapping, 8 = the firmware's).
    #[arg(long, default_value_t = 1)]
    pub stride: usize,
    /// Codes are signed 16-bit (-32768..=32767) rather than unsigned (0..=65535).
    #[arg(long)]
    pub signed: bool,
    /// Print JSON: {"octaves": [{"m", "tau_s", "n", "sum_sq", "avar", "adev"}]} (sum_sq as a decimal string).
    #[arg(long)]
    pub json: bool,
}

impl Args {
    pub fn run(self) -> anyhow::Result<ExitCode> {
        let input = octavar::io::input::open(&self.input)?;
        let opts =
            AccumulateOptions { column: self.column, rate_hz: self.rate, stride: self.stride, signed: self.signed };
        let report = accumulate(input.reader, &input.name, &opts)?;
        let mut out = std::io::stdout().lock();
        if self.json {
            serde_json::to_writer_pretty(&mut out, &report).context("writing JSON")?;
            writeln!(out)?;
        } else {
            writeln!(out, "# {} samples at {} Hz, stride {}", report.samples, report.rate_hz, report.stride)?;
            writeln!(
                out,
                "{:>12} {:>14} {:>14} {:>40} {:>14} {:>14}",
                "m", "tau_s", "n", "sum_sq", "avar_codes2", "adev_codes"
            )?;
            for r in &report.octaves {
                writeln!(
                    out,
                    "{:>12} {:>14.6e} {:>14} {:>40} {:>14.6e} {:>14.6e}",
                    r.m, r.tau_s, r.n, r.sum_sq, r.avar, r.adev
                )?;
            }
        }
        out.flush()?;
        Ok(ExitCode::SUCCESS)
    }
}

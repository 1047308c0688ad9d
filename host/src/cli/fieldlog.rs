//! `octavar fieldlog`: read the field log a device kept without a PC back into a capture.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use anyhow::Context;
use octavar::board::link::PortSource;
use octavar::board::log_readout::{read_field_log, ReadOutOptions};
use octavar::io::capture::CaptureWriter;
use octavar::io::decode::Checkpoints;

/// Raised by Ctrl-C: the read-out stops, the capture keeps what arrived.
static STOP: AtomicBool = AtomicBool::new(false);

/// Read a device's field log (the checkpoints it wrote to flash while logging without a PC) into a capture:
/// the request, then every byte that arrives, appended and synced. The newest checkpoint pools every session the
/// device logged, across power cuts; `octavar analyze CAPTURE` gives its Allan deviation family and noise terms,
/// `octavar decode CAPTURE` its tables. A dropped connection or a damaged part is asked for again; with --append
/// an existing capture resumes after the newest checkpoint it holds. Exit 0 when the capture holds a whole
/// checkpoint (or the log is empty), 1 when the device did not answer.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The device: a serial port (/dev/ttyACM0, /dev/cu.usbmodem1, COM3) or tcp:HOST:PORT (QEMU, ser2net).
    pub port: String,
    /// The capture file to write. An existing non-empty file is never overwritten (see --append).
    #[arg(short, long, value_name = "CAPTURE")]
    pub output: PathBuf,
    /// Add to an existing capture, asking only for checkpoints newer than the newest it holds.
    #[arg(long)]
    pub append: bool,
    /// Ask for checkpoints from this number on (0: the newest).
    #[arg(long, default_value_t = 0, value_name = "N")]
    pub from: u32,
    /// Ask again when the device has sent nothing of the read-out for this many seconds.
    #[arg(long, default_value_t = 5.0, value_name = "S")]
    pub answer_within: f64,
    /// Baud rate of a UART link (USB CDC-ACM ignores it).
    #[arg(long, default_value_t = 115_200)]
    pub baud: u32,
    /// Print the summary as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

impl Args {
    pub fn run(self) -> anyhow::Result<ExitCode> {
        if !(self.answer_within > 0.0 && self.answer_within.is_finite()) {
            anyhow::bail!("--answer-within {}: give a positive number of seconds", self.answer_within);
        }
        let mut known = Checkpoints::new();
        if self.append && self.output.exists() {
            let reader = octavar::io::decode::open(&self.output)?;
            for d in reader {
                known.take(&d.with_context(|| format!("reading {}", self.output.display()))?);
            }
        }
        let mut capture = CaptureWriter::create(&self.output, self.append)?;
        ctrlc::set_handler(|| STOP.store(true, Ordering::Relaxed)).context("installing the Ctrl-C handler")?;
        let opts = ReadOutOptions {
            from_checkpoint: self.from,
            answer_within: Duration::from_secs_f64(self.answer_within),
            ..Default::default()
        };
        let mut port = PortSource::parse(&self.port, self.baud, Duration::from_millis(100));
        let result = read_field_log(&mut port, &mut capture, known, &opts, &STOP);
        let bytes = capture.close()?;
        let s = match result {
            Ok(s) => s,
            Err(e) => {
                eprintln!("octavar: {e}; {} keeps the {bytes} bytes that arrived", self.output.display());
                return Ok(ExitCode::from(1));
            }
        };
        let mut out = std::io::stdout().lock();
        if self.json {
            serde_json::to_writer_pretty(&mut out, &s)?;
            writeln!(out)?;
            return Ok(ExitCode::SUCCESS);
        }
        match (s.checkpoint, s.samples) {
            (Some(n), Some(samples)) => writeln!(
                out,
                "{}: field-log checkpoint {n}: {} session(s), {} s, {samples} samples per gyro ({} channels), {} sample \
                 loss(es); {} request(s), {} bytes. Analyse it with: octavar analyze {}",
                self.output.display(),
                s.sessions.unwrap_or(0),
                s.time_s.unwrap_or(0),
                s.channels.len(),
                s.adc_overruns.unwrap_or(0),
                s.requests,
                s.bytes,
                self.output.display()
            )?,
            _ => writeln!(out, "{}: the device's field log holds no checkpoint from {} on", self.port, self.from)?,
        }
        Ok(ExitCode::SUCCESS)
    }
}

//! `octavar record`: a device (serial port, file or stdin) into a capture file, with a live status line.

use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::Context;
use octavar::board::recorder::{record, EndReason, LiveStats, PortSource, ReaderSource, RecordOptions};
use octavar::io::capture::CaptureWriter;

/// Raised by Ctrl-C (and by --duration): the recording ends cleanly.
static STOP: AtomicBool = AtomicBool::new(false);

/// Record the frames of an octavar device into a capture file: the exact bytes received, appended and synced as
/// they arrive, so a crash or a power cut loses nothing already received. A live line on stderr shows frames,
/// lost frames, CRC errors, samples and each channel's current ADEV at tau = 1 s. When the device is unplugged
/// the capture is kept and the port is reopened until it comes back (see --once, --timeout). Ctrl-C ends the
/// recording cleanly. Exit 0, or 1 when the device stayed away longer than --timeout.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The device's serial port, for example /dev/ttyACM0 (Linux), /dev/cu.usbmodem1 (macOS) or COM3, or
    /// tcp:HOST:PORT (QEMU's serial port, a ser2net bridge).
    #[arg(required_unless_present = "from")]
    pub port: Option<String>,
    /// Read the bytes from a file instead of a port (- is stdin): a replayed capture, or a pipe.
    #[arg(long, value_name = "FILE", conflicts_with = "port")]
    pub from: Option<PathBuf>,
    /// The capture file to write. An existing non-empty file is never overwritten (see --append).
    #[arg(short, long, value_name = "CAPTURE")]
    pub output: PathBuf,
    /// Append to an existing capture file.
    #[arg(long)]
    pub append: bool,
    /// Ask the device to stream the raw codes of every channel (what `octavar verify` replays).
    #[arg(long)]
    pub raw: bool,
    /// Baud rate of a UART link (USB CDC-ACM ignores it).
    #[arg(long, default_value_t = 115_200)]
    pub baud: u32,
    /// End at the first disconnect instead of waiting for the device to come back.
    #[arg(long)]
    pub once: bool,
    /// Give up when the device has been gone this long: seconds, or a number with s, m, h or d.
    #[arg(long, value_parser = parse_duration)]
    pub timeout: Option<Duration>,
    /// Stop recording after this long (for example 72h).
    #[arg(long, value_parser = parse_duration)]
    pub duration: Option<Duration>,
    /// Print the final summary as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

fn parse_duration(text: &str) -> Result<Duration, String> {
    octavar::simulate::parse_duration(text).map(Duration::from_secs_f64).map_err(|e| e.to_string())
}

impl Args {
    pub fn run(self) -> anyhow::Result<ExitCode> {
        let mut capture = CaptureWriter::create(&self.output, self.append)?;
        ctrlc::set_handler(|| {
            if STOP.swap(true, Ordering::Relaxed) {
                std::process::exit(130); // a second Ctrl-C: the capture is already synced up to the last chunk
            }
        })
        .context("installing the Ctrl-C handler")?;
        if let Some(d) = self.duration {
            std::thread::spawn(move || {
                std::thread::sleep(d);
                STOP.store(true, Ordering::Relaxed);
            });
        }
        let opts = RecordOptions {
            raw_mask: self.raw.then_some(0xff),
            once: self.once,
            give_up_after: self.timeout,
            ..Default::default()
        };
        let mut line = StatusLine::new();
        let summary = match (&self.from, &self.port) {
            (Some(path), _) => {
                let input = octavar::io::capture::open(path)?;
                let mut src = ReaderSource::new(&input.name, input.reader, Duration::from_millis(200));
                if self.raw {
                    eprintln!("octavar: --raw ignored: commands cannot be sent to {}", input.name);
                }
                record(&mut src, &mut capture, &opts, &STOP, &mut |s| line.show(s, &input.name))
            }
            (None, Some(port)) => {
                let mut src = PortSource::parse(port, self.baud, Duration::from_millis(200));
                record(&mut src, &mut capture, &opts, &STOP, &mut |s| line.show(s, port))
            }
            (None, None) => anyhow::bail!("give a serial port or --from FILE"),
        };
        line.end();
        let summary = summary.with_context(|| format!("recording into {}", self.output.display()))?;
        let bytes = capture.close()?;
        let s = &summary.stats;
        if self.json {
            let mut out = std::io::stdout().lock();
            serde_json::to_writer_pretty(&mut out, &summary)?;
            writeln!(out)?;
        } else {
            let why = match summary.ended {
                EndReason::Stopped => "stopped",
                EndReason::SourceEnded => "the input ended",
                EndReason::Disconnected => "the device disconnected (--once)",
                EndReason::GaveUp => "the device did not come back within --timeout",
            };
            let mut out = std::io::stdout().lock();
            writeln!(
                out,
                "{}: {bytes} bytes ({} this run): {} frames, {} lost, {} CRC errors, {} other bad frames, {} samples; {} connection(s), {} disconnect(s); {why}",
                self.output.display(),
                s.bytes,
                s.decode.frames,
                s.decode.lost_frames,
                s.decode.crc_errors,
                s.decode.bad_frame_count() - s.decode.crc_errors,
                s.sample_sets,
                s.connects,
                s.disconnects,
            )?;
        }
        Ok(if summary.ended == EndReason::GaveUp { ExitCode::from(1) } else { ExitCode::SUCCESS })
    }
}

/// The live line on stderr: redrawn in place on a terminal, a plain line every 10 s (and on every connect or
/// disconnect) otherwise.
struct StatusLine {
    tty: bool,
    last: Option<Instant>,
    last_state: (u64, bool),
    drawn: bool,
    /// The latest line not yet printed (non-terminal).
    unprinted: Option<String>,
}

impl StatusLine {
    fn new() -> Self {
        StatusLine {
            tty: std::io::stderr().is_terminal(),
            last: None,
            last_state: (0, false),
            drawn: false,
            unprinted: None,
        }
    }

    fn show(&mut self, s: &LiveStats, source: &str) {
        let state = (s.connects, s.waiting);
        let changed = state != self.last_state;
        self.last_state = state;
        let due = self.last.is_none_or(|t| t.elapsed() >= Duration::from_secs(10));
        let text = format_line(s, source);
        let mut err = std::io::stderr().lock();
        if self.tty {
            let _ = write!(err, "\r{text}\x1b[K");
            self.drawn = true;
        } else if changed || due {
            let _ = writeln!(err, "{text}");
            self.last = Some(Instant::now());
            self.unprinted = None;
        } else {
            self.unprinted = Some(text);
        }
        let _ = err.flush();
    }

    fn end(&mut self) {
        if self.drawn {
            eprintln!();
        }
        if let Some(text) = self.unprinted.take() {
            eprintln!("{text}");
        }
    }
}

fn format_line(s: &LiveStats, source: &str) -> String {
    let d = &s.decode;
    let mut line = format!(
        "{:>7.1} s  {} frames  {} lost  {} CRC  {} samples",
        s.elapsed_s, d.frames, d.lost_frames, d.crc_errors, s.sample_sets
    );
    for a in &s.adev_1s {
        let name = a.name.clone().unwrap_or_else(|| format!("ch{}", a.channel));
        let value = match (a.adev_dps, a.adev_codes) {
            (Some(v), _) => format!("{v:.2e} deg/s"),
            (None, Some(c)) => format!("{c:.2e} codes"),
            _ => "-".to_string(),
        };
        line.push_str(&format!("  {name}: ADEV(1 s) {value}"));
    }
    if s.waiting {
        let why = s.last_error.as_deref().or(s.lost_because.as_deref()).unwrap_or("");
        line.push_str(&format!("  [waiting for {source}: {why}]"));
    }
    line
}

//! `octavar bringup`: the firmware README's bring-up list as one command against a live board.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use octavar::board::bringup::{bringup, BringupOptions, Outcome};
use octavar::board::link::PortSource;

/// Check a freshly flashed board: its hello and serial number, its clock against the host's in ppm, no gaps and
/// no new losses over the run, a forced field-log checkpoint (its stalls, nothing lost), a reconnect (a DTR drop
/// on USB: the hello comes first and sampling went on), and an acknowledged reset. One pass/fail line per check;
/// --json writes the figures. Exit 0 when every check passed (or could not be answered on this link, and says
/// so), 1 when one failed.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The device: a serial port (/dev/ttyACM0, /dev/cu.usbmodem1, COM3) or tcp:HOST:PORT (QEMU).
    pub port: String,
    /// How long to watch the raw stream for the clock, gaps and counters: seconds, or a number with s, m or h.
    #[arg(long, default_value = "30s", value_parser = parse_duration)]
    pub duration: Duration,
    /// The clock check's limit, ppm (a wrong crystal setting is off by percent; a crystal by tens of ppm).
    #[arg(long, default_value_t = 1000.0, value_name = "PPM")]
    pub clock_ppm: f64,
    /// How long to wait for each answer, s.
    #[arg(long, default_value_t = 5.0, value_name = "S")]
    pub answer_within: f64,
    /// Baud rate of a UART link (USB CDC-ACM ignores it).
    #[arg(long, default_value_t = 115_200)]
    pub baud: u32,
    /// Write the report as JSON to this file (- for stdout, instead of the lines).
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
}

fn parse_duration(text: &str) -> Result<Duration, String> {
    octavar::simulate::parse_duration(text).map(Duration::from_secs_f64).map_err(|e| e.to_string())
}

/// The USB serial number of a serial port, from the system's port list.
fn usb_serial_number(port: &str) -> Option<String> {
    serialport::available_ports().ok()?.into_iter().find(|p| p.port_name == port).and_then(|p| match p.port_type {
        serialport::SerialPortType::UsbPort(info) => info.serial_number,
        _ => None,
    })
}

impl Args {
    pub fn run(self) -> anyhow::Result<ExitCode> {
        if !(self.clock_ppm > 0.0 && self.answer_within > 0.0 && self.answer_within.is_finite()) {
            anyhow::bail!("--clock-ppm and --answer-within must be positive");
        }
        let tcp = self.port.starts_with("tcp:");
        let opts = BringupOptions {
            duration: self.duration,
            clock_ppm_limit: self.clock_ppm,
            answer_within: Duration::from_secs_f64(self.answer_within),
            serial_number: if tcp { None } else { usb_serial_number(&self.port) },
            hello_on_connect: !tcp,
        };
        let mut port = PortSource::parse(&self.port, self.baud, Duration::from_millis(50));
        let report = bringup(&mut port, &opts)?;
        let to_stdout = super::json_out::to_stdout(self.json.as_deref());
        let mut out = std::io::stdout().lock();
        if !to_stdout {
            for c in &report.checks {
                let word = match c.outcome {
                    Outcome::Pass => "pass",
                    Outcome::Fail => "FAIL",
                    Outcome::Skipped => "skip",
                };
                writeln!(out, "{word}  {:<10} {}", c.name, c.detail)?;
            }
            let failed = report.checks.iter().filter(|c| c.outcome == Outcome::Fail).count();
            writeln!(
                out,
                "{}: {}",
                report.port,
                if failed == 0 { "ready".to_string() } else { format!("{failed} check(s) failed") }
            )?;
        }
        if let Some(path) = &self.json {
            super::json_out::write(path, &report, &mut out)?;
        }
        Ok(if report.passed { ExitCode::SUCCESS } else { ExitCode::from(1) })
    }
}

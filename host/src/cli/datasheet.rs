//! `octavar datasheet`: a datasheet's figures (TOML, any customary unit) -> octavar's units and the estimators'
//! configs, as `analyze --export` writes them from a record.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::bail;
use octavar::datasheet::{Datasheet, SensorSheet};
use octavar::export::ImuNoise;
use octavar::fit::Term;
use octavar::quantity::Quantity;

use super::export_args::ExportArgs;

/// Turn datasheet figures (deg/sqrt(h), deg/h, mdps/sqrt(Hz), ug/sqrt(Hz), mg, m/s/sqrt(h), ...) into octavar's
/// units and into the configs `analyze --export` writes.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The datasheet: TOML with [gyro] and [accel] figures as "VALUE UNIT" strings (docs/exports.md).
    pub sheet: PathBuf,
    /// The configs to write: --export FORMAT=FILE, --kalibr FILE, --inflate X.
    #[command(flatten)]
    pub export: ExportArgs,
    /// The update rate the configs name, Hz (default: the sheet's rate_hz).
    #[arg(long, value_name = "HZ")]
    pub rate: Option<f64>,
    /// The ROS topic the configs name (default: the sheet's topic, else /imu0).
    #[arg(long, value_name = "TOPIC")]
    pub topic: Option<String>,
}

impl Args {
    pub fn run(self) -> anyhow::Result<ExitCode> {
        let sheet = Datasheet::read(&self.sheet)?;
        let mut out = std::io::stdout().lock();
        writeln!(out, "# {}: the figures in octavar's units", self.sheet.display())?;
        for (q, s) in [(Quantity::AngularRate, &sheet.gyro), (Quantity::Acceleration, &sheet.accel)] {
            if let Some(s) = s {
                print_sensor(&mut out, q, s)?;
            }
        }
        if self.export.requests()?.is_empty() {
            return Ok(ExitCode::SUCCESS);
        }
        let Some(rate) = self.rate.or(sheet.rate_hz) else {
            bail!("the configs need the update rate: give --rate HZ or rate_hz in {}", self.sheet.display());
        };
        if !(rate.is_finite() && rate > 0.0) {
            bail!("--rate {rate}: give a positive rate");
        }
        let topic = self.topic.clone().or(sheet.topic.clone()).unwrap_or_else(|| "/imu0".to_string());
        let source = format!("the datasheet {}", self.sheet.display());
        let noise = ImuNoise::from_datasheet(&sheet, &source, rate, &topic, self.export.inflate);
        for e in self.export.write(&noise)? {
            writeln!(out, "wrote {} ({})", e.path.display(), e.format.name())?;
        }
        Ok(ExitCode::SUCCESS)
    }
}

fn print_sensor(out: &mut impl Write, q: Quantity, s: &SensorSheet) -> std::io::Result<()> {
    writeln!(out, "\n== {}", q.kind())?;
    for t in Term::ALL {
        let Some(v) = s.get(t) else { continue };
        let (alt, k) = t.alt_unit_of(q);
        let written = s.written.get(t.name()).map_or("", String::as_str);
        writeln!(out, "{:>3} = {v:.4e} {} = {:.4e} {alt}   (written \"{written}\")", t.name(), t.unit_of(q), v * k)?;
    }
    if let Some(tc) = s.bias_correlation_time_s {
        writeln!(out, "bias correlation time {tc} s")?;
    }
    Ok(())
}

//! `octavar datasheet`: a datasheet's figures (TOML, any customary unit) -> octavar's units and the estimators'
//! configs, as `analyze --export` writes them from a record.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Context};
use octavar::datasheet::{Datasheet, SensorSheet};
use octavar::export::{ExportRequest, ImuNoise};
use octavar::fit::Term;
use octavar::quantity::Quantity;

/// Turn datasheet figures (deg/sqrt(h), deg/h, mdps/sqrt(Hz), ug/sqrt(Hz), mg, m/s/sqrt(h), ...) into octavar's
/// units and into the configs `analyze --export` writes.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The datasheet: TOML with [gyro] and [accel] figures as "VALUE UNIT" strings (docs/exports.md).
    pub sheet: PathBuf,
    /// Write a config, FORMAT=FILE (repeatable): kalibr, openvins, vins, orbslam3, gtsam, kfgins, gz, matlab.
    #[arg(long = "export", value_name = "FORMAT=FILE")]
    pub exports: Vec<String>,
    /// The update rate the configs name, Hz (default: the sheet's rate_hz).
    #[arg(long, value_name = "HZ")]
    pub rate: Option<f64>,
    /// The ROS topic the configs name (default: the sheet's topic, else /imu0).
    #[arg(long, value_name = "TOPIC")]
    pub topic: Option<String>,
    /// Multiply every noise figure of the configs by X.
    #[arg(long, value_name = "X", default_value_t = 1.0)]
    pub inflate: f64,
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
        let exports: Vec<ExportRequest> =
            self.exports.iter().map(|e| ExportRequest::parse(e)).collect::<Result<_, _>>()?;
        if exports.is_empty() {
            return Ok(ExitCode::SUCCESS);
        }
        let Some(rate) = self.rate.or(sheet.rate_hz) else {
            bail!("the configs need the update rate: give --rate HZ or rate_hz in {}", self.sheet.display());
        };
        if !(rate.is_finite() && rate > 0.0 && self.inflate.is_finite() && self.inflate > 0.0) {
            bail!("--rate and --inflate must be positive numbers");
        }
        let topic = self.topic.clone().or(sheet.topic.clone()).unwrap_or_else(|| "/imu0".to_string());
        let source = format!("the datasheet {}", self.sheet.display());
        let noise = ImuNoise::from_datasheet(&sheet, &source, rate, &topic, self.inflate);
        for e in &exports {
            std::fs::write(&e.path, e.format.render(&noise))
                .with_context(|| format!("writing the {} export {}", e.format.name(), e.path.display()))?;
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

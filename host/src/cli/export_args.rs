//! The export flags `analyze`, `gap` and `datasheet` share: `--export FORMAT=FILE` (repeatable), `--kalibr FILE`
//! as its synonym, and `--inflate X`; checked before any input is read, and the files written from one
//! [`ImuNoise`].

use std::path::PathBuf;

use anyhow::{bail, Context};
use octavar::export::{ExportFormat, ExportRequest, ImuNoise};

/// The export flags.
#[derive(Debug, clap::Args)]
pub struct ExportArgs {
    /// Write a Kalibr imu.yaml: the same as --export kalibr=FILE.
    #[arg(long, value_name = "FILE")]
    pub kalibr: Option<PathBuf>,
    /// Write the noise figures for a state estimator or simulator, FORMAT=FILE (repeatable): kalibr, openvins,
    /// vins, orbslam3, gtsam, kfgins, gz, matlab. Each file opens with where every number came from.
    #[arg(long = "export", value_name = "FORMAT=FILE")]
    pub exports: Vec<String>,
    /// Multiply every noise figure of the exports by X (a margin for motion, vibration and temperature that a
    /// still bench does not see; the files say so).
    #[arg(long, value_name = "X", default_value_t = 1.0)]
    pub inflate: f64,
}

impl ExportArgs {
    /// The exports asked for (`--export`, and `--kalibr` as `--export kalibr=FILE`), with `--inflate` checked.
    pub fn requests(&self) -> anyhow::Result<Vec<ExportRequest>> {
        let mut exports: Vec<ExportRequest> =
            self.exports.iter().map(|e| ExportRequest::parse(e)).collect::<Result<_, _>>()?;
        if let Some(path) = &self.kalibr {
            exports.push(ExportRequest { format: ExportFormat::Kalibr, path: path.clone() });
        }
        let positive = self.inflate.is_finite() && self.inflate > 0.0;
        if !exports.is_empty() && !positive {
            bail!("--inflate {}: give a positive factor", self.inflate);
        }
        Ok(exports)
    }

    /// Whether any export was asked for.
    pub fn any(&self) -> bool {
        self.kalibr.is_some() || !self.exports.is_empty()
    }

    /// Write every export asked for from `noise` (made with this `--inflate`): the requests written.
    pub fn write(&self, noise: &ImuNoise) -> anyhow::Result<Vec<ExportRequest>> {
        let requests = self.requests()?;
        for e in &requests {
            std::fs::write(&e.path, e.format.render(noise))
                .with_context(|| format!("writing the {} export {}", e.format.name(), e.path.display()))?;
        }
        Ok(requests)
    }
}

//! IMU noise exports: the fits turned into the configuration files of the state estimators and simulators that
//! read them (Kalibr, OpenVINS, VINS-Mono/Fusion, ORB-SLAM3, GTSAM, KF-GINS, Gazebo, MATLAB's imuSensor).
//!
//! [`noise`] takes the figures from the fits, in SI, with the text of where each came from; one module per
//! format writes them in that format's convention (continuous-time density or per-sample deviation, which term
//! fills which field, the units), with a comment at the top that says, for every number, the term, its interval
//! and the conversion, and names any field with no honest counterpart. docs/exports.md gives each convention with
//! a link to the format's own documentation.

mod from_gap;
pub mod noise;

mod gtsam;
mod gz;
mod kalibr;
mod kfgins;
mod matlab;
mod openvins;
mod orbslam3;
mod vins;

use std::fmt::Write as _;
use std::path::PathBuf;

pub use noise::{BiasModel, Figure, ImuNoise, SensorNoise};

/// An export format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExportFormat {
    /// Kalibr's imu.yaml.
    Kalibr,
    /// OpenVINS's kalibr_imu_chain.yaml.
    OpenVins,
    /// VINS-Mono and VINS-Fusion's IMU parameters.
    Vins,
    /// ORB-SLAM3's IMU settings.
    OrbSlam3,
    /// GTSAM's PreintegrationParams covariances.
    Gtsam,
    /// KF-GINS's imunoise block.
    KfGins,
    /// Gazebo / gz-sensors IMU noise (SDF).
    Gz,
    /// MATLAB's imuSensor (gyroparams, accelparams).
    Matlab,
}

impl ExportFormat {
    /// Every format with its name on the command line.
    pub const ALL: [(&'static str, ExportFormat); 8] = [
        ("kalibr", ExportFormat::Kalibr),
        ("openvins", ExportFormat::OpenVins),
        ("vins", ExportFormat::Vins),
        ("orbslam3", ExportFormat::OrbSlam3),
        ("gtsam", ExportFormat::Gtsam),
        ("kfgins", ExportFormat::KfGins),
        ("gz", ExportFormat::Gz),
        ("matlab", ExportFormat::Matlab),
    ];

    /// The format's name on the command line.
    pub fn name(self) -> &'static str {
        Self::ALL.iter().find(|(_, f)| *f == self).map_or("?", |(n, _)| n)
    }

    /// The format named `name` (case-insensitive).
    pub fn parse(name: &str) -> Option<ExportFormat> {
        let n = name.trim().to_ascii_lowercase();
        Self::ALL.iter().find(|(k, _)| *k == n).map(|(_, f)| *f)
    }

    /// The file in this format.
    pub fn render(self, n: &ImuNoise) -> String {
        match self {
            ExportFormat::Kalibr => kalibr::render(n),
            ExportFormat::OpenVins => openvins::render(n),
            ExportFormat::Vins => vins::render(n),
            ExportFormat::OrbSlam3 => orbslam3::render(n),
            ExportFormat::Gtsam => gtsam::render(n),
            ExportFormat::KfGins => kfgins::render(n),
            ExportFormat::Gz => gz::render(n),
            ExportFormat::Matlab => matlab::render(n),
        }
    }
}

/// A `--export FORMAT=FILE` request.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ExportRequest {
    pub format: ExportFormat,
    pub path: PathBuf,
}

/// A `--export` value that names no format, or no file.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
#[error("--export {given:?}: {why} (use FORMAT=FILE with FORMAT one of {known})")]
pub struct BadExport {
    pub given: String,
    pub why: String,
    pub known: String,
}

impl ExportRequest {
    /// Parse `FORMAT=FILE`.
    ///
    /// # Errors
    /// [`BadExport`] naming what is wrong and the formats known.
    pub fn parse(text: &str) -> Result<ExportRequest, BadExport> {
        let known = ExportFormat::ALL.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ");
        let bad = |why: &str| BadExport { given: text.to_string(), why: why.to_string(), known: known.clone() };
        let (name, file) = text.split_once('=').ok_or_else(|| bad("no '='"))?;
        let format = ExportFormat::parse(name).ok_or_else(|| bad(&format!("unknown format {name:?}")))?;
        if file.trim().is_empty() {
            return Err(bad("no file named"));
        }
        Ok(ExportRequest { format, path: PathBuf::from(file.trim()) })
    }
}

/// A number as C's `%.6e` writes it (`1.234560e-04`): YAML 1.1 loaders read an exponent without its sign as
/// text, and OpenCV's FileStorage wants the point.
pub fn sci(v: f64) -> String {
    if !v.is_finite() {
        return if v.is_nan() {
            ".nan".to_string()
        } else if v > 0.0 {
            ".inf".to_string()
        } else {
            "-.inf".to_string()
        };
    }
    let s = format!("{v:.6e}");
    let (mantissa, exp) = s.split_once('e').unwrap_or((&s, "0"));
    let e: i32 = exp.parse().unwrap_or(0);
    format!("{mantissa}e{}{:02}", if e < 0 { '-' } else { '+' }, e.abs())
}

/// A number with a decimal point (`200.0`, `0.5`).
pub fn real(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e15 {
        format!("{v:.1}")
    } else {
        format!("{v}")
    }
}

/// The comment at the top of every export: the source, the format's convention and link, and for every field the
/// figure's provenance (`fields`: field name, value as written, and where it came from).
pub(crate) fn provenance(
    comment: &str,
    n: &ImuNoise,
    format: &str,
    convention: &str,
    fields: &[(String, String, String)],
) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{comment} {format}, written by octavar from {} at {} Hz.", n.source, real(n.rate_hz));
    for line in wrap(convention, 100) {
        let _ = writeln!(s, "{comment} {line}");
    }
    if n.inflate != 1.0 {
        let _ = writeln!(s, "{comment} Every noise figure is multiplied by {} (--inflate).", n.inflate);
    }
    let _ = writeln!(s, "{comment} Where each number comes from:");
    for (field, value, how) in fields {
        for (i, line) in wrap(&format!("{field} = {value}: {how}"), 96).iter().enumerate() {
            let _ = writeln!(s, "{comment} {}{line}", if i == 0 { "- " } else { "    " });
        }
    }
    s
}

/// A `key: value` line at `indent`, or where there is no value the key commented out, pointing to the comment
/// at the top that says why.
pub(crate) fn value_line(s: &mut String, indent: &str, key: &str, value: Option<f64>) {
    match value {
        Some(v) => {
            let _ = writeln!(s, "{indent}{key}: {}", sci(v));
        }
        None => {
            let _ = writeln!(s, "{indent}# {key}: (missing: see above)");
        }
    }
}

/// The provenance line of a figure, or the reason it is missing.
pub(crate) fn field(name: &str, f: Option<&Figure>, missing: &str) -> (String, String, String) {
    match f {
        Some(f) => (name.to_string(), sci(f.value), format!("{} [{}]", f.how, f.unit)),
        None => (name.to_string(), "(not written)".to_string(), missing.to_string()),
    }
}

/// Words of `text` in lines of at most `width` characters.
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines = Vec::new();
    let mut line = String::new();
    for word in text.split_whitespace() {
        if !line.is_empty() && line.len() + 1 + word.len() > width {
            lines.push(std::mem::take(&mut line));
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(word);
    }
    if !line.is_empty() {
        lines.push(line);
    }
    lines
}

/// Why a sensor's figure is missing.
pub(crate) fn no_sensor(n: &ImuNoise, q: crate::quantity::Quantity) -> &'static str {
    use crate::quantity::Quantity;
    let given = match q {
        Quantity::AngularRate => n.gyro.is_some(),
        Quantity::Acceleration => n.accel.is_some(),
    };
    match (given, q) {
        (true, _) => "the source gives no figure for it",
        (false, Quantity::AngularRate) => "no gyro channel was analysed (--column): add your gyro's figure",
        (false, Quantity::Acceleration) => {
            "no accelerometer channel was analysed (--accel-column): add your accelerometer's figure"
        }
    }
}

#[cfg(test)]
mod tests;

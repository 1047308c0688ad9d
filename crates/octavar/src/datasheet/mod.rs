//! Datasheet figures: a TOML file of a sensor's noise figures in any customary unit, read into octavar's units,
//! and a measured fit compared with them (does this unit meet its datasheet?).
//!
//! ```toml
//! rate_hz = 200            # the update rate the exports name (optional)
//! topic = "/imu0"          # the ROS topic they name (optional)
//! [gyro]
//! N = "0.3 deg/sqrt(h)"    # or noise_density = "5 mdps/sqrt(Hz)", arw = ...
//! B = "4 deg/h"            # or bias_instability
//! K = "0.1 deg/h/sqrt(h)"  # or random_walk, rrw
//! bias_correlation_time = "100 s"   # for the Gauss-Markov bias the gz and kfgins exports write (optional)
//! [accel]
//! N = "60 ug/sqrt(Hz)"     # or noise_density, vrw
//! B = "0.04 mg"
//! K = "3e-4 m/s^3/sqrt(Hz)"
//! ```
//!
//! [`units`] parses the units by their dimension, so every spelling of a unit is read and a figure of the wrong
//! kind (deg/h given for an angle random walk) is refused with the dimension it has and the one it needs.

pub mod units;

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;

use crate::fit::{NoiseFit, Term};
use crate::quantity::Quantity;

pub use units::{figure_in_base, parse_unit, UnitError};

/// One sensor's datasheet figures in octavar's units ([`Term::unit_of`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SensorSheet {
    /// Each term given, in octavar's unit of it.
    pub terms: BTreeMap<&'static str, f64>,
    /// The figure as the datasheet wrote it, by term.
    pub written: BTreeMap<&'static str, String>,
    /// The correlation time of a Gauss-Markov bias model, s, if given.
    pub bias_correlation_time_s: Option<f64>,
}

impl SensorSheet {
    /// Term `t`'s figure, in octavar's unit.
    pub fn get(&self, t: Term) -> Option<f64> {
        self.terms.get(t.name()).copied()
    }
}

/// A datasheet: the gyro's and the accelerometer's figures, and the rate and topic the exports name.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Datasheet {
    pub rate_hz: Option<f64>,
    pub topic: Option<String>,
    pub gyro: Option<SensorSheet>,
    pub accel: Option<SensorSheet>,
}

/// A datasheet that cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum DatasheetError {
    #[error("reading the datasheet {path}: {err}")]
    Io { path: String, err: std::io::Error },
    #[error("{path}: {err}")]
    Toml { path: String, err: String },
    #[error("{path}: [{section}] {key}: {err}")]
    Figure { path: String, section: String, key: String, err: Box<UnitError> },
    #[error("{path}: [{section}] {key}: {why}")]
    Key { path: String, section: String, key: String, why: String },
    #[error("{path}: no [gyro] or [accel] section")]
    Empty { path: String },
}

/// The term a datasheet key names.
fn term_of(key: &str, q: Quantity) -> Option<Term> {
    let k = key.to_ascii_lowercase();
    Some(match k.as_str() {
        "q" | "quantization" => Term::Q,
        "n" | "noise_density" | "white_noise" => Term::N,
        "arw" if q == Quantity::AngularRate => Term::N,
        "vrw" if q == Quantity::Acceleration => Term::N,
        "b" | "bias_instability" | "bias_stability" => Term::B,
        "k" | "random_walk" | "bias_random_walk" => Term::K,
        "rrw" if q == Quantity::AngularRate => Term::K,
        "arw_bias" | "aaw" if q == Quantity::Acceleration => Term::K,
        "r" | "rate_ramp" | "ramp" => Term::R,
        _ => return None,
    })
}

impl Datasheet {
    /// Read a datasheet TOML file.
    ///
    /// # Errors
    /// [`DatasheetError`] naming the file, the section, the key and what is wrong.
    pub fn read(path: &Path) -> Result<Datasheet, DatasheetError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|err| DatasheetError::Io { path: name.clone(), err })?;
        Datasheet::parse(&text, &name)
    }

    /// Parse a datasheet's TOML text; `name` names it in errors.
    ///
    /// # Errors
    /// See [`Datasheet::read`].
    pub fn parse(text: &str, name: &str) -> Result<Datasheet, DatasheetError> {
        let table: toml::Table = text
            .parse()
            .map_err(|e: toml::de::Error| DatasheetError::Toml { path: name.to_string(), err: e.to_string() })?;
        let mut sheet = Datasheet::default();
        let key_err = |section: &str, key: &str, why: &str| DatasheetError::Key {
            path: name.to_string(),
            section: section.to_string(),
            key: key.to_string(),
            why: why.to_string(),
        };
        for (key, value) in &table {
            match (key.as_str(), value) {
                ("rate_hz", v) => {
                    let r = v.as_float().or_else(|| v.as_integer().map(|i| i as f64));
                    sheet.rate_hz =
                        Some(r.filter(|r| *r > 0.0).ok_or_else(|| key_err("", key, "a positive number of Hz"))?);
                }
                ("topic", v) => sheet.topic = Some(v.as_str().ok_or_else(|| key_err("", key, "a string"))?.to_string()),
                ("gyro", toml::Value::Table(t)) => sheet.gyro = Some(sensor(t, Quantity::AngularRate, "gyro", name)?),
                ("accel", toml::Value::Table(t)) => {
                    sheet.accel = Some(sensor(t, Quantity::Acceleration, "accel", name)?)
                }
                _ => return Err(key_err("", key, "unknown key (rate_hz, topic, [gyro], [accel])")),
            }
        }
        if sheet.gyro.is_none() && sheet.accel.is_none() {
            return Err(DatasheetError::Empty { path: name.to_string() });
        }
        Ok(sheet)
    }

    /// The sheet of a channel of `q`.
    pub fn sensor(&self, q: Quantity) -> Option<&SensorSheet> {
        match q {
            Quantity::AngularRate => self.gyro.as_ref(),
            Quantity::Acceleration => self.accel.as_ref(),
        }
    }
}

fn sensor(t: &toml::Table, q: Quantity, section: &str, name: &str) -> Result<SensorSheet, DatasheetError> {
    let mut out = SensorSheet::default();
    for (key, value) in t {
        let key_err = |why: &str| DatasheetError::Key {
            path: name.to_string(),
            section: section.to_string(),
            key: key.clone(),
            why: why.to_string(),
        };
        let text = value.as_str().ok_or_else(|| key_err("a figure with its unit, as a string: \"0.3 deg/sqrt(h)\""))?;
        let fig_err = |err| DatasheetError::Figure {
            path: name.to_string(),
            section: section.to_string(),
            key: key.clone(),
            err: Box::new(err),
        };
        if key == "bias_correlation_time" {
            let (v, u) = units::value_and_unit(text).map_err(fig_err)?;
            if !(u.dim.time == 1.0 && u.dim.angle == 0.0 && u.dim.length == 0.0 && v > 0.0) {
                return Err(key_err("a positive time with its unit: \"100 s\""));
            }
            out.bias_correlation_time_s = Some(v * u.to_si);
            continue;
        }
        let term = term_of(key, q).ok_or_else(|| {
            key_err("unknown key (N, B, K, R, Q; noise_density, bias_instability, random_walk, bias_correlation_time)")
        })?;
        let v = figure_in_base(text, term, q).map_err(fig_err)?;
        out.terms.insert(term.name(), v);
        out.written.insert(term.name(), text.to_string());
    }
    Ok(out)
}

/// How a measured term stands against its datasheet figure.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Comparison {
    /// The term (N, B, K, R, Q).
    pub term: &'static str,
    /// The datasheet's figure, in octavar's unit.
    pub datasheet: f64,
    /// As the datasheet wrote it.
    pub written: String,
    /// The measured value, where identifiable.
    pub measured: Option<f64>,
    /// measured / datasheet, with the interval's ends over the datasheet.
    pub ratio: Option<f64>,
    pub ratio_lo: Option<f64>,
    pub ratio_hi: Option<f64>,
    /// `meets` (the whole interval at or below the figure), `exceeds` (the whole interval above it), `consistent`
    /// (the interval holds the figure), `below bound` (not identifiable, its upper bound under the figure), or
    /// `unknown`.
    pub verdict: &'static str,
}

/// Each term the sheet gives, against the fit.
pub fn compare(fit: &NoiseFit, sheet: &SensorSheet) -> Vec<Comparison> {
    Term::ALL
        .iter()
        .filter_map(|&t| {
            let d = sheet.get(t)?;
            let e = fit.term(t);
            let over = |v: Option<f64>| v.map(|v| v / d);
            let verdict = match (e.value, e.lo, e.hi) {
                (Some(_), _, Some(hi)) if hi <= d => "meets",
                (Some(_), Some(lo), _) if lo > d => "exceeds",
                (Some(_), _, _) => "consistent",
                (None, _, Some(hi)) if hi <= d => "below bound",
                _ => "unknown",
            };
            Some(Comparison {
                term: t.name(),
                datasheet: d,
                written: sheet.written.get(t.name()).cloned().unwrap_or_default(),
                measured: e.value,
                ratio: over(e.value),
                ratio_lo: over(e.lo),
                ratio_hi: over(e.hi),
                verdict,
            })
        })
        .collect()
}

/// The comparison as text: one line per term.
pub fn comparison_text(rows: &[Comparison], q: Quantity) -> String {
    let mut s = String::from("against the datasheet (measured / datasheet, with the interval):\n");
    for r in rows {
        let unit = Term::ALL.iter().find(|t| t.name() == r.term).map_or("", |t| t.unit_of(q));
        let line = match (r.measured, r.ratio, r.ratio_lo, r.ratio_hi) {
            (Some(m), Some(x), Some(lo), Some(hi)) => format!(
                "{:>3}   {m:.4e} / {:.4e} {unit} ({}) = {x:.2} ({lo:.2} .. {hi:.2}): {}",
                r.term, r.datasheet, r.written, r.verdict
            ),
            (_, _, _, Some(hi)) => {
                format!(
                    "{:>3}   not identifiable, at most {hi:.2} of the datasheet's {}: {}",
                    r.term, r.written, r.verdict
                )
            }
            _ => format!("{:>3}   not measured (datasheet {}): {}", r.term, r.written, r.verdict),
        };
        let _ = writeln!(s, "{line}");
    }
    s
}

#[cfg(test)]
mod tests;

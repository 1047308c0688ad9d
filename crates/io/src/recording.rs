//! A recording in memory, whatever its format: one series per channel in deg/s with NaN for gaps, the rate and
//! the temperature; and the units a rate channel may be written in.

use serde::Serialize;

use octavar_stats::quantity::Quantity;

/// A unit octavar does not know.
#[derive(Debug, thiserror::Error)]
#[error("unknown unit {unit:?}: octavar knows {known}")]
pub struct UnknownUnit {
    /// The name given.
    pub unit: String,
    /// The names octavar knows.
    pub known: String,
}

/// Units a rate column may be in; everything is converted to deg/s.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum RateUnit {
    /// deg/s.
    DegPerS,
    /// rad/s.
    RadPerS,
    /// mrad/s.
    MradPerS,
    /// deg/h.
    DegPerH,
}

impl RateUnit {
    /// Every unit with the names it is known by.
    pub const NAMES: [(&'static str, RateUnit); 8] = [
        ("deg/s", RateUnit::DegPerS),
        ("dps", RateUnit::DegPerS),
        ("rad/s", RateUnit::RadPerS),
        ("rads", RateUnit::RadPerS),
        ("mrad/s", RateUnit::MradPerS),
        ("mrads", RateUnit::MradPerS),
        ("deg/h", RateUnit::DegPerH),
        ("dph", RateUnit::DegPerH),
    ];

    /// Parse a unit name.
    ///
    /// # Errors
    /// [`UnknownUnit`] listing the known names.
    pub fn parse(name: &str) -> Result<RateUnit, UnknownUnit> {
        let n = name.trim().to_ascii_lowercase();
        Self::NAMES.iter().find(|(k, _)| *k == n).map(|(_, u)| *u).ok_or_else(|| UnknownUnit {
            unit: name.to_string(),
            known: "deg/s (dps), rad/s, mrad/s, deg/h (dph)".to_string(),
        })
    }

    /// Multiply a value in this unit by this to get deg/s.
    pub fn to_dps(self) -> f64 {
        match self {
            RateUnit::DegPerS => 1.0,
            RateUnit::RadPerS => 180.0 / std::f64::consts::PI,
            RateUnit::MradPerS => 0.18 / std::f64::consts::PI,
            RateUnit::DegPerH => 1.0 / 3600.0,
        }
    }
}

/// Units an accelerometer column may be in; everything is converted to m/s^2.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum AccelUnit {
    /// m/s^2.
    MPerS2,
    /// Standard gravities (9.80665 m/s^2).
    G,
    /// Thousandths of a standard gravity.
    Mg,
}

impl AccelUnit {
    /// Parse a unit name: `m/s^2` (also `m/s2`, `mps2`), `g`, `mg`.
    ///
    /// # Errors
    /// [`UnknownUnit`] listing the known names.
    pub fn parse(name: &str) -> Result<AccelUnit, UnknownUnit> {
        match name.trim().to_ascii_lowercase().as_str() {
            "m/s^2" | "m/s2" | "m/s/s" | "mps2" => Ok(AccelUnit::MPerS2),
            "g" => Ok(AccelUnit::G),
            "mg" => Ok(AccelUnit::Mg),
            _ => Err(UnknownUnit { unit: name.to_string(), known: "m/s^2 (m/s2), g, mg".to_string() }),
        }
    }

    /// Multiply a value in this unit by this to get m/s^2.
    pub fn to_m_per_s2(self) -> f64 {
        match self {
            AccelUnit::MPerS2 => 1.0,
            AccelUnit::G => octavar_stats::quantity::STANDARD_GRAVITY,
            AccelUnit::Mg => octavar_stats::quantity::STANDARD_GRAVITY / 1000.0,
        }
    }
}

/// A recording in memory: one series per column, in its quantity's unit (deg/s for a gyro, m/s^2 for an
/// accelerometer), NaN for gaps.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Recording {
    /// Where it came from.
    pub source: String,
    /// Column names.
    pub names: Vec<String>,
    /// One series per column, deg/s or m/s^2.
    pub channels: Vec<Vec<f64>>,
    /// What each column measures, where it is not a gyro: a column past the end of this list is a gyro.
    pub quantities: Vec<Quantity>,
    /// The temperature column, degC, if asked for.
    pub temp_c: Option<Vec<f64>>,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Counters of the read.
    pub info: StreamInfo,
}

impl Recording {
    /// What column `i` measures.
    pub fn quantity(&self, i: usize) -> Quantity {
        self.quantities.get(i).copied().unwrap_or_default()
    }
}

/// What a streamed read found.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct StreamInfo {
    /// Column names read, in order.
    pub columns: Vec<String>,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Samples delivered (rows kept plus gap samples inserted), per channel.
    pub samples: u64,
    /// Samples that are NaN (empty cells, NaN text, time gaps), summed over channels.
    pub gaps: u64,
    /// Rows dropped by the filters.
    pub filtered_out: u64,
}

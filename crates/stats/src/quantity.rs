//! What a channel measures: an angular rate (a gyro, in deg/s) or a specific force (an accelerometer, in m/s^2).
//!
//! Every series octavar computes on is in its quantity's base unit; the readers convert to it, and the
//! writers take the names of the terms' units from here. The Allan variance and the IEEE 952 fit are the same
//! mathematics for both: only the names of the units and of the terms differ (angle random walk is velocity
//! random walk on an accelerometer).

use serde::Serialize;

/// Standard gravity, m/s^2 (the `g` of mg and ug).
pub const STANDARD_GRAVITY: f64 = 9.806_65;

/// What a channel measures.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Quantity {
    /// A gyro's angular rate, deg/s.
    #[default]
    #[serde(rename = "gyro")]
    AngularRate,
    /// An accelerometer's specific force, m/s^2 (gravity included).
    #[serde(rename = "accel")]
    Acceleration,
}

impl Quantity {
    /// The unit every series of this quantity is in.
    pub fn unit(self) -> &'static str {
        match self {
            Quantity::AngularRate => "deg/s",
            Quantity::Acceleration => "m/s^2",
        }
    }

    /// The kind's name in JSON and reports: `gyro` or `accel`.
    pub fn kind(self) -> &'static str {
        match self {
            Quantity::AngularRate => "gyro",
            Quantity::Acceleration => "accel",
        }
    }

    /// The factor from this quantity's base unit to SI (rad/s for a gyro, m/s^2 for an accelerometer).
    pub fn to_si(self) -> f64 {
        match self {
            Quantity::AngularRate => std::f64::consts::PI / 180.0,
            Quantity::Acceleration => 1.0,
        }
    }

    /// The SI unit of [`Quantity::to_si`]: `rad/s` or `m/s^2`.
    pub fn si_unit(self) -> &'static str {
        match self {
            Quantity::AngularRate => "rad/s",
            Quantity::Acceleration => "m/s^2",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_json_names_are_gyro_and_accel() {
        assert_eq!(serde_json::to_value(Quantity::AngularRate).unwrap(), "gyro");
        assert_eq!(serde_json::to_value(Quantity::Acceleration).unwrap(), "accel");
        assert_eq!(Quantity::Acceleration.kind(), "accel");
        assert!((Quantity::AngularRate.to_si() * 180.0 - std::f64::consts::PI).abs() < 1e-15);
    }
}

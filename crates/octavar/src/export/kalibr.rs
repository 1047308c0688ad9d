//! Kalibr's `imu.yaml`: continuous-time densities in SI units, the white noise as `*_noise_density` and the bias
//! random walk as `*_random_walk` (<https://github.com/ethz-asl/kalibr/wiki/IMU-Noise-Model>). Kalibr's model has
//! no bias instability: the random walk stands for the whole bias drift.

use std::fmt::Write as _;

use super::{field, no_sensor, provenance, real, value_line, ImuNoise};
use crate::quantity::Quantity;

/// The convention, for the file's comment.
pub(super) const CONVENTION: &str = "Continuous-time densities in SI units (Kalibr's IMU noise model): \
    *_noise_density is the white noise N (rad/s/sqrt(Hz), m/s^2/sqrt(Hz)); *_random_walk is the bias random walk K \
    (rad/s^2/sqrt(Hz), m/s^3/sqrt(Hz)). Kalibr's model has no bias instability term: the random walk is its only \
    bias drift, so where the record shows none the figure below is a bound or a stand-in, as it says. \
    https://github.com/ethz-asl/kalibr/wiki/IMU-Noise-Model";

/// A field's name, its value where there is one, and its provenance line (name, value as written, source).
pub(super) type Field = (&'static str, Option<f64>, (String, String, String));

/// The four noise fields of Kalibr's model, with their provenance, in Kalibr's order.
pub(super) fn fields(n: &ImuNoise) -> Vec<Field> {
    let mut out = Vec::new();
    for q in [Quantity::Acceleration, Quantity::AngularRate] {
        let s = if q == Quantity::AngularRate { n.gyro.as_ref() } else { n.accel.as_ref() };
        let (density, walk) = (s.and_then(|s| s.density.as_ref()), s.and_then(|s| s.random_walk.as_ref()));
        let (dn, wn): (&'static str, &'static str) = match q {
            Quantity::AngularRate => ("gyroscope_noise_density", "gyroscope_random_walk"),
            Quantity::Acceleration => ("accelerometer_noise_density", "accelerometer_random_walk"),
        };
        out.push((dn, density.map(|f| f.value), field(dn, density, no_sensor(n, q))));
        out.push((wn, walk.map(|f| f.value), field(wn, walk, no_sensor(n, q))));
    }
    out
}

pub(super) fn render(n: &ImuNoise) -> String {
    let f = fields(n);
    let mut s = provenance("#", n, "Kalibr imu.yaml", CONVENTION, &f.iter().map(|x| x.2.clone()).collect::<Vec<_>>());
    let _ = writeln!(s, "rostopic: {}", n.topic);
    let _ = writeln!(s, "update_rate: {}", real(n.rate_hz));
    for (name, value, _) in &f {
        value_line(&mut s, "", name, *value);
    }
    s
}

//! VINS-Mono and VINS-Fusion's IMU parameters: `acc_n`, `gyr_n` (white noise), `acc_w`, `gyr_w` (bias random
//! walk) and `g_norm`, in the `%YAML:1.0` file their estimator reads through OpenCV's FileStorage
//! (<https://github.com/HKUST-Aerial-Robotics/VINS-Fusion/blob/master/config/euroc/euroc_stereo_imu_config.yaml>).

use std::fmt::Write as _;

use super::{field, no_sensor, provenance, real, sci, value_line, ImuNoise};
use crate::quantity::{Quantity, STANDARD_GRAVITY};

const CONVENTION: &str = "VINS's config calls these \"measurement noise standard deviation\" and \"bias random \
    work noise standard deviation\"; its preintegration uses them as Kalibr's continuous-time densities, and its \
    authors' own Allan tool (imu_utils) writes them so: acc_n and gyr_n are the white noise N (m/s^2/sqrt(Hz), \
    rad/s/sqrt(Hz)), acc_w and gyr_w the bias random walk K (m/s^3/sqrt(Hz), rad/s^2/sqrt(Hz)). VINS's examples \
    use values 10 to 50 times a static record's (motion, vibration and temperature add noise a still bench does \
    not see): use --inflate for that, never a silent factor. Only the IMU block is written: merge it into your \
    camera config. https://github.com/HKUST-Aerial-Robotics/VINS-Fusion";

pub(super) fn render(n: &ImuNoise) -> String {
    let g = n.gyro.as_ref();
    let a = n.accel.as_ref();
    let rows = [
        ("acc_n", a.and_then(|s| s.density.as_ref()), Quantity::Acceleration),
        ("gyr_n", g.and_then(|s| s.density.as_ref()), Quantity::AngularRate),
        ("acc_w", a.and_then(|s| s.random_walk.as_ref()), Quantity::Acceleration),
        ("gyr_w", g.and_then(|s| s.random_walk.as_ref()), Quantity::AngularRate),
    ];
    let mut fields: Vec<(String, String, String)> =
        rows.iter().map(|(k, f, q)| field(k, *f, no_sensor(n, *q))).collect();
    let gravity = n.gravity();
    let g_norm = gravity.unwrap_or(STANDARD_GRAVITY);
    fields.push((
        "g_norm".to_string(),
        sci(g_norm),
        match gravity {
            Some(_) => "the magnitude of the three accelerometer axes' static means [m/s^2]".to_string(),
            None => "standard gravity (three accelerometer axes were not analysed) [m/s^2]".to_string(),
        },
    ));
    let mut s = String::from("%YAML:1.0\n");
    s += &provenance("#", n, "VINS-Mono / VINS-Fusion IMU parameters", CONVENTION, &fields);
    s += "imu: 1\n";
    let _ = writeln!(s, "imu_topic: \"{}\"", n.topic);
    for (k, f, _) in rows {
        value_line(&mut s, "", k, f.map(|f| f.value));
    }
    let _ = writeln!(s, "g_norm: {}", sci(g_norm));
    let _ = writeln!(s, "# the IMU's rate, for reference (VINS reads it from the messages): {} Hz", real(n.rate_hz));
    s
}

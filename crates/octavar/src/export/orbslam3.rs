//! ORB-SLAM3's IMU settings: `IMU.NoiseGyro`, `IMU.NoiseAcc`, `IMU.GyroWalk`, `IMU.AccWalk` and `IMU.Frequency`
//! in its `%YAML:1.0` settings file (<https://github.com/UZ-SLAMLab/ORB_SLAM3/blob/master/Examples/Monocular-Inertial/EuRoC.yaml>).

use std::fmt::Write as _;

use super::{field, no_sensor, provenance, real, value_line, ImuNoise};
use crate::quantity::Quantity;

const CONVENTION: &str = "ORB-SLAM3 takes continuous-time densities (its settings' units: rad/s^0.5, m/s^1.5, \
    rad/s^1.5, m/s^2.5) and turns them into per-sample deviations itself (noise times sqrt(IMU.Frequency), walk \
    divided by it): IMU.NoiseGyro and IMU.NoiseAcc are the white noise N, IMU.GyroWalk and IMU.AccWalk the bias \
    random walk K, in SI. The camera-IMU transform (IMU.T_b_c1) is not measured by octavar: merge this block into \
    your settings. https://github.com/UZ-SLAMLab/ORB_SLAM3";

pub(super) fn render(n: &ImuNoise) -> String {
    let g = n.gyro.as_ref();
    let a = n.accel.as_ref();
    let rows = [
        ("IMU.NoiseGyro", g.and_then(|s| s.density.as_ref()), Quantity::AngularRate),
        ("IMU.NoiseAcc", a.and_then(|s| s.density.as_ref()), Quantity::Acceleration),
        ("IMU.GyroWalk", g.and_then(|s| s.random_walk.as_ref()), Quantity::AngularRate),
        ("IMU.AccWalk", a.and_then(|s| s.random_walk.as_ref()), Quantity::Acceleration),
    ];
    let fields: Vec<(String, String, String)> = rows.iter().map(|(k, f, q)| field(k, *f, no_sensor(n, *q))).collect();
    let mut s = String::from("%YAML:1.0\n");
    s += &provenance("#", n, "ORB-SLAM3 IMU settings", CONVENTION, &fields);
    for (k, f, _) in rows {
        value_line(&mut s, "", k, f.map(|f| f.value));
    }
    let _ = writeln!(s, "IMU.Frequency: {}", real(n.rate_hz));
    s
}

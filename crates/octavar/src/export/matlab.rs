//! MATLAB's `imuSensor` (Navigation and Sensor Fusion Toolboxes): `gyroparams` and `accelparams` with
//! NoiseDensity, BiasInstability and RandomWalk, as a script that builds the sensor
//! (<https://www.mathworks.com/help/nav/ref/gyroparams.html>, <https://www.mathworks.com/help/nav/ref/accelparams.html>).

use std::fmt::Write as _;

use super::{field, no_sensor, provenance, real, sci, ImuNoise, SensorNoise};
use crate::quantity::Quantity;

const CONVENTION: &str = "imuSensor's parameters in SI: NoiseDensity is the white noise N ((rad/s)/sqrt(Hz), \
    (m/s^2)/sqrt(Hz)), BiasInstability the flicker floor's B (rad/s, m/s^2; read, as IEEE 952 reads it, from the \
    floor over 0.664), RandomWalk the bias random walk K ((rad/s)*sqrt(Hz), (m/s^2)*sqrt(Hz)). \
    https://www.mathworks.com/help/nav/ref/gyroparams.html";

pub(super) fn render(n: &ImuNoise) -> String {
    let mut fields = Vec::new();
    for (q, var, s) in
        [(Quantity::AngularRate, "gyro", n.gyro.as_ref()), (Quantity::Acceleration, "accel", n.accel.as_ref())]
    {
        fields.push(field(&format!("{var}.NoiseDensity"), s.and_then(|s| s.density.as_ref()), no_sensor(n, q)));
        fields.push(field(
            &format!("{var}.BiasInstability"),
            s.and_then(|s| s.bias_instability.as_ref()),
            no_sensor(n, q),
        ));
        fields.push(field(&format!("{var}.RandomWalk"), s.and_then(|s| s.random_walk.as_ref()), no_sensor(n, q)));
    }
    let mut s = provenance("%", n, "MATLAB imuSensor parameters", CONVENTION, &fields);
    let mut parts = Vec::new();
    for (var, ctor, sensor, name) in [
        ("gyro", "gyroparams", n.gyro.as_ref(), "'Gyroscope'"),
        ("accel", "accelparams", n.accel.as_ref(), "'Accelerometer'"),
    ] {
        let Some(sensor) = sensor else { continue };
        let _ = writeln!(s, "{var} = {ctor}({});", params(sensor));
        parts.push(format!("{name}, {var}"));
    }
    let _ = writeln!(
        s,
        "imu = imuSensor('accel-gyro', 'SampleRate', {}{});",
        real(n.rate_hz),
        parts.iter().map(|p| format!(", {p}")).collect::<String>()
    );
    s
}

/// The name-value pairs of one sensor.
fn params(s: &SensorNoise) -> String {
    let mut out = Vec::new();
    for (name, f) in
        [("NoiseDensity", &s.density), ("BiasInstability", &s.bias_instability), ("RandomWalk", &s.random_walk)]
    {
        if let Some(f) = f {
            out.push(format!("'{name}', {}", sci(f.value)));
        }
    }
    out.join(", ")
}

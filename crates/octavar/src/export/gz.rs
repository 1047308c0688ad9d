//! Gazebo (gz-sensors, and Gazebo Classic's SDF) IMU noise: a `<noise type="gaussian">` element per axis of
//! `<angular_velocity>` and `<linear_acceleration>`, as an SDF `<imu>` fragment
//! (<http://sdformat.org/spec?ver=1.9&elem=sensor#imu_angular_velocity>, gz-sensors' `GaussianNoiseModel`).

use std::fmt::Write as _;

use super::{no_sensor, provenance, real, sci, ImuNoise, SensorNoise};
use crate::quantity::Quantity;

const CONVENTION: &str = "gz-sensors adds, per sample, white noise of deviation stddev (a per-sample deviation: \
    the density N times sqrt(update rate)), a constant bias drawn once from N(bias_mean, bias_stddev), and a \
    first-order Gauss-Markov dynamic bias. Its dynamic_bias_stddev is the process's driving density, not its \
    deviation: the process it draws has stationary deviation dynamic_bias_stddev sqrt(T/2), so it is written as \
    sigma sqrt(2/T). bias_mean is the axis's static mean for a gyro; for an accelerometer the static mean holds \
    gravity, so 0 is written. bias_stddev (the spread of turn-on biases between runs) is not measured by one \
    record: 0 is written. Units rad/s and m/s^2. \
    http://sdformat.org/spec?ver=1.9&elem=sensor#imu_angular_velocity";

pub(super) fn render(n: &ImuNoise) -> String {
    let mut fields = Vec::new();
    let rate = n.rate_hz;
    for (q, s) in [(Quantity::AngularRate, n.gyro.as_ref()), (Quantity::Acceleration, n.accel.as_ref())] {
        let tag = element(q);
        match s {
            None => fields.push((tag.to_string(), "(not written)".to_string(), no_sensor(n, q).to_string())),
            Some(s) => {
                if let Some(d) = &s.density {
                    fields.push((
                        format!("{tag}/stddev"),
                        sci(d.value * rate.sqrt()),
                        format!("{} [{}], x sqrt({} Hz)", d.how, d.unit, real(rate)),
                    ));
                }
                if let Some(m) = &s.bias_model {
                    fields.push((
                        format!("{tag}/dynamic_bias_stddev"),
                        sci(m.sigma * (2.0 / m.tau_c_s).sqrt()),
                        format!("{} [{}], x sqrt(2 / T)", m.how, q.si_unit()),
                    ));
                    fields.push((
                        format!("{tag}/dynamic_bias_correlation_time"),
                        sci(m.tau_c_s),
                        "the Gauss-Markov process's correlation time T [s]".to_string(),
                    ));
                }
            }
        }
    }
    let mut s = String::from("<?xml version=\"1.0\"?>\n<!--\n");
    s += &provenance("", n, "Gazebo / gz-sensors IMU noise (an SDF <imu> element)", CONVENTION, &fields)
        .replace("--inflate", "the inflate option")
        .replace("--", "- -");
    s += "-->\n<imu>\n";
    for (q, sensor) in [(Quantity::AngularRate, n.gyro.as_ref()), (Quantity::Acceleration, n.accel.as_ref())] {
        let Some(sensor) = sensor else { continue };
        let _ = writeln!(s, "  <{}>", element(q));
        for (i, axis) in ["x", "y", "z"].iter().enumerate() {
            let _ = writeln!(s, "    <{axis}>");
            s += &noise(q, sensor, i, rate);
            let _ = writeln!(s, "    </{axis}>");
        }
        let _ = writeln!(s, "  </{}>", element(q));
    }
    s += "</imu>\n";
    s
}

fn element(q: Quantity) -> &'static str {
    match q {
        Quantity::AngularRate => "angular_velocity",
        Quantity::Acceleration => "linear_acceleration",
    }
}

/// One axis's `<noise>` element.
fn noise(q: Quantity, s: &SensorNoise, axis: usize, rate: f64) -> String {
    let stddev = s.density.as_ref().map_or(0.0, |d| d.value * rate.sqrt());
    let bias_mean = match q {
        Quantity::AngularRate => s.means.get(axis).copied().filter(|m| m.is_finite()).unwrap_or(0.0),
        Quantity::Acceleration => 0.0,
    };
    let (dyn_sd, dyn_t) = s.bias_model.as_ref().map_or((0.0, 0.0), |m| (m.sigma * (2.0 / m.tau_c_s).sqrt(), m.tau_c_s));
    let mut out = String::new();
    let _ = writeln!(out, "      <noise type=\"gaussian\">");
    let _ = writeln!(out, "        <mean>0</mean>");
    let _ = writeln!(out, "        <stddev>{}</stddev>", sci(stddev));
    let _ = writeln!(out, "        <bias_mean>{}</bias_mean>", sci(bias_mean));
    let _ = writeln!(out, "        <bias_stddev>0</bias_stddev>");
    let _ = writeln!(out, "        <dynamic_bias_stddev>{}</dynamic_bias_stddev>", sci(dyn_sd));
    let _ = writeln!(out, "        <dynamic_bias_correlation_time>{}</dynamic_bias_correlation_time>", sci(dyn_t));
    let _ = writeln!(out, "      </noise>");
    out
}

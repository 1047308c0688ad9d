//! KF-GINS's `imunoise` block: angular and velocity random walk, the Gauss-Markov biases' deviations and their
//! correlation time, in KF-GINS's units (<https://github.com/i2Nav-WHU/KF-GINS>, `dataset/kf-gins.yaml`).

use std::fmt::Write as _;

use super::{no_sensor, provenance, ImuNoise};
use crate::quantity::Quantity;

const CONVENTION: &str = "KF-GINS models each bias as a first-order Gauss-Markov process: arw is the gyro's white \
    noise N in deg/sqrt(h), vrw the accelerometer's in m/s/sqrt(h), gbstd and abstd the processes' stationary \
    deviations in deg/h and mGal (1 mGal = 1e-5 m/s^2), corrtime their correlation time in hours (KF-GINS has one \
    for both: the gyro's is written, the accelerometer's is in its line below). gsstd and asstd (scale-factor \
    stability, ppm) are not measured by a static record: KF-GINS's example values are written and marked so. \
    https://github.com/i2Nav-WHU/KF-GINS";

/// m/s^2 per mGal.
const MGAL: f64 = 1e-5;
/// KF-GINS's example scale-factor stability, ppm.
const EXAMPLE_SCALE_PPM: f64 = 1000.0;

pub(super) fn render(n: &ImuNoise) -> String {
    let d2 = 180.0 / std::f64::consts::PI;
    let g = n.gyro.as_ref();
    let a = n.accel.as_ref();
    let arw = g.and_then(|s| s.density.as_ref()).map(|f| (f.value * d2 * 60.0, f.how.clone()));
    let vrw = a.and_then(|s| s.density.as_ref()).map(|f| (f.value * 60.0, f.how.clone()));
    let gb = g.and_then(|s| s.bias_model.as_ref());
    let ab = a.and_then(|s| s.bias_model.as_ref());
    let gbstd = gb.map(|m| (m.sigma * d2 * 3600.0, m.how.clone()));
    let abstd = ab.map(|m| (m.sigma / MGAL, m.how.clone()));
    let corr = gb.or(ab).map(|m| m.tau_c_s / 3600.0);
    let line = |name: &str, v: &Option<(f64, String)>, unit: &str, conv: &str, q: Quantity| match v {
        Some((x, how)) => (name.to_string(), format!("{x:.6} {unit}"), format!("{how}, {conv}")),
        None => (name.to_string(), "(not written)".to_string(), no_sensor(n, q).to_string()),
    };
    let mut fields = vec![
        line("arw", &arw, "deg/sqrt(h)", "x 180/pi x 60", Quantity::AngularRate),
        line("vrw", &vrw, "m/s/sqrt(h)", "x 60", Quantity::Acceleration),
        line("gbstd", &gbstd, "deg/h", "x 180/pi x 3600", Quantity::AngularRate),
        line("abstd", &abstd, "mGal", "/ 1e-5", Quantity::Acceleration),
    ];
    fields.push(match (gb, ab) {
        (Some(m), other) => (
            "corrtime".to_string(),
            format!("{:.6} h", m.tau_c_s / 3600.0),
            format!(
                "the gyro bias process's correlation time / 3600{}",
                other.map_or(String::new(), |a| format!(" (the accelerometer's is {:.4} h)", a.tau_c_s / 3600.0))
            ),
        ),
        (None, Some(m)) => (
            "corrtime".to_string(),
            format!("{:.6} h", m.tau_c_s / 3600.0),
            "the accelerometer bias process's correlation time / 3600".to_string(),
        ),
        (None, None) => ("corrtime".to_string(), "(not written)".to_string(), "no bias model".to_string()),
    });
    fields.push((
        "gsstd, asstd".to_string(),
        format!("{EXAMPLE_SCALE_PPM} ppm"),
        "no counterpart in a static noise record: KF-GINS's example value, not a measurement".to_string(),
    ));
    let mut s = provenance("#", n, "KF-GINS imunoise", CONVENTION, &fields);
    s += "imunoise:\n";
    let triple = |v: f64| format!("[{v:.6}, {v:.6}, {v:.6}]");
    for (name, v, unit) in [
        ("arw", &arw, "deg/sqrt(hr)"),
        ("vrw", &vrw, "m/s/sqrt(hr)"),
        ("gbstd", &gbstd, "deg/hr"),
        ("abstd", &abstd, "mGal"),
    ] {
        match v {
            Some((x, _)) => {
                let _ = writeln!(s, "    {name}: {}  # [{unit}]", triple(*x));
            }
            None => {
                let _ = writeln!(s, "    # {name}: (missing: see above)");
            }
        }
    }
    let _ = writeln!(s, "    gsstd: {}  # [ppm] KF-GINS's example value, not measured", triple(EXAMPLE_SCALE_PPM));
    let _ = writeln!(s, "    asstd: {}  # [ppm] KF-GINS's example value, not measured", triple(EXAMPLE_SCALE_PPM));
    match corr {
        Some(c) => {
            let _ = writeln!(s, "    corrtime: {c:.6}  # [hr]");
        }
        None => s += "    # corrtime: (missing: see above)\n",
    }
    s
}

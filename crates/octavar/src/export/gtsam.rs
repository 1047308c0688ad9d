//! GTSAM's IMU preintegration parameters: the continuous-time covariances of `PreintegrationParams` and
//! `PreintegrationCombinedParams` as 3x3 matrices in a YAML file, with the lines that build the parameters in
//! Python (<https://gtsam.org/doxygen/a04039.html>, `gtsam/navigation/PreintegrationParams.h`).

use std::fmt::Write as _;

use super::{field, no_sensor, provenance, sci, ImuNoise};
use crate::quantity::{Quantity, STANDARD_GRAVITY};

const CONVENTION: &str = "GTSAM's covariances are continuous-time (it multiplies them by 1/dt per sample): \
    gyroscopeCovariance = N_g^2 I (rad^2/s^2/Hz), accelerometerCovariance = N_a^2 I (m^2/s^4/Hz), \
    biasOmegaCovariance = K_g^2 I and biasAccCovariance = K_a^2 I (the bias random walks', of \
    PreintegrationCombinedParams). integrationCovariance has no counterpart in a noise record (it models the \
    integration's own error): GTSAM's examples use 1e-8 I, written here. Build the parameters in Python: \
    c = yaml.safe_load(open(FILE)); p = gtsam.PreintegrationCombinedParams.MakeSharedU(c['gravity']); \
    p.setGyroscopeCovariance(np.array(c['gyroscopeCovariance'])); and the same for the others. \
    https://gtsam.org/doxygen/a04039.html";

/// Integration covariance GTSAM's examples use.
const INTEGRATION_COVARIANCE: f64 = 1e-8;

pub(super) fn render(n: &ImuNoise) -> String {
    let g = n.gyro.as_ref();
    let a = n.accel.as_ref();
    let rows = [
        ("gyroscopeCovariance", g.and_then(|s| s.density.as_ref()), Quantity::AngularRate),
        ("accelerometerCovariance", a.and_then(|s| s.density.as_ref()), Quantity::Acceleration),
        ("biasOmegaCovariance", g.and_then(|s| s.random_walk.as_ref()), Quantity::AngularRate),
        ("biasAccCovariance", a.and_then(|s| s.random_walk.as_ref()), Quantity::Acceleration),
    ];
    let mut fields: Vec<(String, String, String)> = rows
        .iter()
        .map(|(k, f, q)| {
            let (name, value, how) = field(k, *f, no_sensor(n, *q));
            match f {
                Some(f) => (name, format!("{} I", sci(f.value * f.value)), format!("the square of {how}")),
                None => (name, value, how),
            }
        })
        .collect();
    let gravity = n.gravity().unwrap_or(STANDARD_GRAVITY);
    fields.push((
        "gravity".to_string(),
        sci(gravity),
        match n.gravity() {
            Some(_) => "the magnitude of the three accelerometer axes' static means [m/s^2]".to_string(),
            None => "standard gravity (three accelerometer axes were not analysed) [m/s^2]".to_string(),
        },
    ));
    let mut s = provenance("#", n, "GTSAM preintegration parameters", CONVENTION, &fields);
    let diag = |v: f64| -> String {
        let z = sci(0.0);
        let d = sci(v);
        format!("\n  - [{d}, {z}, {z}]\n  - [{z}, {d}, {z}]\n  - [{z}, {z}, {d}]")
    };
    let _ = writeln!(s, "gravity: {}", sci(gravity));
    for (k, f, _) in rows {
        match f {
            Some(f) => {
                let _ = writeln!(s, "{k}:{}", diag(f.value * f.value));
            }
            None => {
                let _ = writeln!(s, "# {k}: (missing: see above)");
            }
        }
    }
    let _ = writeln!(s, "integrationCovariance:{}", diag(INTEGRATION_COVARIANCE));
    s
}

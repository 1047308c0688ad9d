//! Shared helpers: where the reference data is, and skipping politely when it is absent.

use std::path::PathBuf;

use octavar_shared::sensor::{Adc, Channel, FrontEnd, GyroModel, GENERIC};
use octavar_shared::sim::rng::SimRng;
use octavar_shared::sim::{GyroSim, TempCoupling, TemperatureProfile, Wander};

/// The reference data folder: `OCTAVAR_DATA`, or `../shared/data` from the workspace root. `None`, with a
/// printed line, where it is absent; under CI (`CI` set), which always has it, a missing folder fails the test
/// instead, so that no reference test passes there with nothing checked.
#[allow(dead_code)]
pub fn data_dir() -> Option<PathBuf> {
    let dir = match std::env::var_os("OCTAVAR_DATA") {
        Some(d) => PathBuf::from(d),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data"),
    };
    if dir.is_dir() {
        return Some(dir);
    }
    if std::env::var_os("CI").is_some() {
        panic!("CI must have the reference data: {} is not a folder (set OCTAVAR_DATA)", dir.display());
    }
    println!("skipped: reference data not found at {} (set OCTAVAR_DATA)", dir.display());
    None
}

/// A Python with allantools (the independent reference): `OCTAVAR_PYTHON`, or the `.venv-ref` that `.ci/run`
/// makes. `None`, with a printed line, where there is none.
#[allow(dead_code)]
pub fn allantools_python() -> Option<PathBuf> {
    reference_python("allantools")
}

/// A Python that can import `module` (a reference tool of `bench/ref_venv.sh`: allantools, nptdms, mcap_ros2):
/// `OCTAVAR_PYTHON`, or the `.venv-ref` that `.ci/run` makes. `None`, with a printed line, where there is none;
/// under CI a missing module is a failure, since `.ci/run` installs them all.
#[allow(dead_code)]
pub fn reference_python(module: &str) -> Option<PathBuf> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let candidates = [std::env::var_os("OCTAVAR_PYTHON").map(PathBuf::from), Some(root.join(".venv-ref/bin/python"))];
    for py in candidates.into_iter().flatten() {
        let ok = std::process::Command::new(&py)
            .args(["-c", &format!("import {module}")])
            .output()
            .is_ok_and(|o| o.status.success());
        if ok {
            return Some(py);
        }
    }
    if std::env::var_os("CI").is_some() {
        panic!("CI must have the Python module {module}: .ci/run installs it into .venv-ref (bench/ref_venv.sh)");
    }
    println!("skipped: no Python with {module} (run .ci/run once, or set OCTAVAR_PYTHON)");
    None
}

/// Path of a file under `tests/reference/`.
#[allow(dead_code)]
pub fn reference_script(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("reference").join(name)
}

/// A fresh temporary directory for one test.
#[allow(dead_code)]
pub fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("octavar-test-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create temp dir");
    dir
}

/// A draw log-uniform on [lo, hi] (the simulated cases' parameter ranges).
#[allow(dead_code)]
pub fn log_uniform(rng: &mut SimRng, lo: f64, hi: f64) -> f64 {
    (lo.ln() + (hi / lo).ln() * rng.uniform()).exp()
}

/// A draw uniform on [lo, hi].
#[allow(dead_code)]
pub fn uniform(rng: &mut SimRng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.uniform()
}

/// The closed-form Allan deviation of a model's base terms (N, B, K) at tau.
#[allow(dead_code)]
pub fn base_adev(m: &GyroSim, tau: f64) -> f64 {
    let f = 2.0 * std::f64::consts::LN_2 / std::f64::consts::PI;
    (m.n_deg_per_rt_s.powi(2) / tau + f * m.b_dps.powi(2) + m.k_dps_per_rt_s.powi(2) * tau / 3.0).sqrt()
}

/// A generic 16-bit channel whose step is `q` deg/s.
#[allow(dead_code)]
pub fn coarse_channel(q: f64) -> Channel {
    let adc = Adc { bits: 16, vref_mv: 3300.0 };
    let sens = adc.mv_per_code() / q;
    let gyro = GyroModel { sensitivity_mv_per_dps: sens, null_mv: 1650.0, range_dps: 30000.0 * q, ..GENERIC };
    Channel { gyro, front: FrontEnd::WIRE, adc }
}

/// A temperature cycle of period `p` s (1-5 degC peak to peak, uniform, with a slow wander) and a bias coupled to
/// it through a thermal lag of 10 s to half the cycle (log-uniform), the coupled bias 3-6 times `model`'s Allan
/// deviation at a third of the cycle: the profile, the coupling and the swing, degC.
#[allow(dead_code)]
pub fn temperature_coupling(rng: &mut SimRng, model: &GyroSim, p: f64) -> (TemperatureProfile, TempCoupling, f64) {
    let swing = uniform(rng, 1.0, 5.0);
    let lag = log_uniform(rng, 10.0, 0.5 * p);
    let h = 1.0 / (1.0 + (2.0 * std::f64::consts::PI * lag / p).powi(2)).sqrt();
    let k = uniform(rng, 3.0, 6.0) * base_adev(model, p / 3.0) / (0.5 * swing * h);
    let profile = TemperatureProfile {
        min_c: 22.0,
        max_c: 22.0 + swing,
        period_s: p,
        phase_rad: uniform(rng, -3.0, 3.0),
        wander: Some(Wander { sigma_c: 0.05 * swing, tau_s: p / 4.0 }),
    };
    (profile, TempCoupling { dps_per_c: k, ref_c: 23.5, lag_s: lag }, swing)
}

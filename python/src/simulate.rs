//! `simulate(model, duration, seed)`: the samples of the virtual bench (`octavar_shared::sim`), as
//! `octavar simulate` writes them: the rate each channel's ADC reports, in deg/s (or the analog rate before the
//! ADC), and the bench temperature. The model is a `model.toml` (as `analyze --model-out` and `gap --model-out`
//! write it) or a dict of the one-channel flags: `n`, `b`, `k`, `r`, `q`, `bias`, `sensor`, `rate`.

use std::path::PathBuf;

use numpy::PyArray1;
use octavar::simulate::{load_model, parse_duration, single_channel};
use octavar_shared::sensor::SensorKind;
use octavar_shared::sim::{Bench, BenchSim, GyroSim};
use pyo3::exceptions::PyMemoryError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::errors::{os_error, value_error};

/// The model argument: a `model.toml`'s path, or a dict of terms.
#[derive(FromPyObject)]
pub enum ModelArg<'py> {
    /// One channel from its terms.
    Terms(Bound<'py, PyDict>),
    /// A `model.toml`.
    Path(PathBuf),
}

/// The duration: seconds, or text such as `"600"`, `"30m"`, `"72h"`, `"3d"`.
#[derive(FromPyObject)]
pub enum Duration {
    /// Seconds.
    Seconds(f64),
    /// With a unit.
    Text(String),
}

/// The parts the dict's `sensor` may name, as `octavar simulate --sensor` names them.
const SENSORS: [(&str, SensorKind); 5] = [
    ("generic", SensorKind::Generic),
    ("idg1215-x", SensorKind::Idg1215X),
    ("idg1215-y", SensorKind::Idg1215Y),
    ("adxrs300", SensorKind::Adxrs300),
    ("env05h", SensorKind::Env05h),
];

/// A one-channel bench from a dict of terms (2000 Hz unless `rate` is given, as the command's default).
fn from_terms(terms: &Bound<'_, PyDict>) -> PyResult<BenchSim> {
    let mut gyro = GyroSim::default();
    let (mut sensor, mut rate_hz) = (SensorKind::Generic, 2000.0);
    for (key, value) in terms.iter() {
        let key: String = key.extract().map_err(|_| value_error("model: the dict's keys must be strings"))?;
        let number = || {
            value
                .extract::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| value_error(format!("model[{key:?}] must be a finite number")))
        };
        match key.as_str() {
            "n" => gyro.n_deg_per_rt_s = number()?,
            "b" => gyro.b_dps = number()?,
            "k" => gyro.k_dps_per_rt_s = number()?,
            "r" => gyro.r_dps_per_s = number()?,
            "q" => gyro.q_deg = number()?,
            "bias" => gyro.bias_dps = number()?,
            "rate" => rate_hz = number()?,
            "sensor" => {
                let name: String = value.extract().map_err(|_| value_error("model[\"sensor\"] must be a string"))?;
                sensor = SENSORS.iter().find(|(n, _)| *n == name).map(|(_, k)| *k).ok_or_else(|| {
                    value_error(format!("model[\"sensor\"] {name:?}: use {}", SENSORS.map(|(n, _)| n).join(", ")))
                })?;
            }
            other => {
                return Err(value_error(format!(
                    "model key {other:?}: a dict model takes n (deg/sqrt(s)), b (deg/s), k (deg/s/sqrt(s)), r \
                     (deg/s^2), q (deg), bias (deg/s), sensor and rate (Hz); other effects need a model.toml"
                )))
            }
        }
    }
    Ok(single_channel(sensor, gyro, rate_hz, 0))
}

/// One array per channel, the temperature, and the rate of a simulated run.
type Simulated<'py> = (Vec<Bound<'py, PyArray1<f64>>>, Bound<'py, PyArray1<f64>>, f64);

/// Simulate `model` for `duration` with `seed` (and `rate`, Hz, where given).
#[pyfunction]
#[pyo3(signature = (model, duration, seed, rate, analog))]
pub fn simulate<'py>(
    py: Python<'py>,
    model: ModelArg<'py>,
    duration: Duration,
    seed: u64,
    rate: Option<f64>,
    analog: bool,
) -> PyResult<Simulated<'py>> {
    let mut model = match model {
        ModelArg::Terms(d) => from_terms(&d)?,
        ModelArg::Path(p) => load_model(&p).map_err(|e| match &e {
            octavar::simulate::SimulateError::ReadModel { err, .. } => os_error(err, e.to_string()),
            _ => value_error(e.to_string()),
        })?,
    };
    if let Some(r) = rate {
        model.rate_hz = r;
    }
    model.seed = seed;
    let duration_s = match duration {
        Duration::Seconds(s) if s > 0.0 && s.is_finite() => s,
        Duration::Seconds(s) => {
            return Err(value_error(format!("duration must be a positive number of seconds, got {s}")))
        }
        Duration::Text(t) => parse_duration(&t).map_err(|e| value_error(e.to_string()))?,
    };
    let mut bench = Bench::new(&model).map_err(|e| value_error(format!("model: {e}")))?;
    if model.channels.iter().any(|c| c.sensor == SensorKind::Temperature) {
        return Err(value_error("model: a temperature channel is not a gyro; simulate gives the bench temperature"));
    }
    let total = (duration_s * model.rate_hz).round();
    if !(total >= 1.0 && total <= usize::MAX as f64) {
        return Err(value_error(format!("duration {duration_s} s at {} Hz gives no sample", model.rate_hz)));
    }
    let total = total as usize;
    let n_channels = model.channels.len();
    let (channels, temp) = py.detach(|| {
        let alloc = |n: usize| {
            let mut v: Vec<f64> = Vec::new();
            v.try_reserve_exact(n).map(|()| v).map_err(|_| {
                PyMemoryError::new_err(format!("{n} samples do not fit in memory: simulate a shorter duration"))
            })
        };
        let mut channels = (0..n_channels).map(|_| alloc(total)).collect::<PyResult<Vec<_>>>()?;
        let mut temp = alloc(total)?;
        let wiring = bench.channels().to_vec();
        for _ in 0..total {
            let s = bench.next_sample();
            temp.push(s.temp_c);
            for (k, out) in channels.iter_mut().enumerate() {
                out.push(if analog { s.rate_dps[k] } else { wiring[k].code_to_dps(s.codes[k]) });
            }
        }
        PyResult::Ok((channels, temp))
    })?;
    let arrays = channels.into_iter().map(|c| PyArray1::from_vec(py, c)).collect();
    Ok((arrays, PyArray1::from_vec(py, temp), model.rate_hz))
}

//! `gap(...)`: the sim-to-real gap diagnosis of a rate record, returned as the dict of the JSON document that
//! `octavar gap --json` writes (the same keys, the same values; JSON's null is None).
//!
//! The record is split in time (`holdout_fraction` of it held out at its end), or a second record is the holdout;
//! an optional temperature series (degC, one value per sample) drives the ensemble and the temperature view.

use numpy::PyReadonlyArray1;
use octavar::gap::{diagnose, GapInput, GapOptions, HoldoutCheck};
use octavar::quantity::Quantity;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use serde_json::Value;

use crate::errors::value_error;
use crate::samples;

/// A JSON value as the Python object `json.loads` would make of it.
fn to_python<'py>(py: Python<'py>, v: &Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => b.into_pyobject(py)?.to_owned().into_any(),
        Value::Number(n) => match (n.as_i64(), n.as_u64()) {
            (Some(i), _) => i.into_pyobject(py)?.into_any(),
            (None, Some(u)) => u.into_pyobject(py)?.into_any(),
            _ => n.as_f64().unwrap_or(f64::NAN).into_pyobject(py)?.into_any(),
        },
        Value::String(s) => s.into_pyobject(py)?.into_any(),
        Value::Array(items) => {
            let list = PyList::empty(py);
            for item in items {
                list.append(to_python(py, item)?)?;
            }
            list.into_any()
        }
        Value::Object(map) => {
            let dict = PyDict::new(py);
            for (k, item) in map {
                dict.set_item(k, to_python(py, item)?)?;
            }
            dict.into_any()
        }
    })
}

/// A borrowed optional series, checked like the record.
fn optional<'a>(a: &'a Option<PyReadonlyArray1<'_, f64>>, name: &str) -> PyResult<Option<&'a [f64]>> {
    a.as_ref().map(|a| samples::borrow(a, name)).transpose()
}

/// Diagnose the gap between `data` (rate at `rate` Hz) and the simulation of its fitted model.
#[pyfunction]
#[pyo3(signature = (data, rate, temperature, holdout, holdout_temperature, holdout_fraction, seeds, oversample,
    holdout_check, keep_transients, quantity, gaps))]
#[allow(clippy::too_many_arguments)]
pub fn gap<'py>(
    py: Python<'py>,
    data: PyReadonlyArray1<'py, f64>,
    rate: f64,
    temperature: Option<PyReadonlyArray1<'py, f64>>,
    holdout: Option<PyReadonlyArray1<'py, f64>>,
    holdout_temperature: Option<PyReadonlyArray1<'py, f64>>,
    holdout_fraction: f64,
    seeds: usize,
    oversample: usize,
    holdout_check: &str,
    keep_transients: bool,
    quantity: &str,
    gaps: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let rate_hz = samples::rate(rate)?;
    let holdout_check = match holdout_check {
        "plain" => HoldoutCheck::Plain,
        "predictive" => HoldoutCheck::Predictive,
        other => return Err(value_error(format!("holdout_check {other:?}: use \"plain\" or \"predictive\""))),
    };
    let quantity = match quantity {
        "gyro" => Quantity::AngularRate,
        "accel" => Quantity::Acceleration,
        other => return Err(value_error(format!("quantity {other:?}: use \"gyro\" (deg/s) or \"accel\" (m/s^2)"))),
    };
    if !(1..=4096).contains(&oversample) {
        return Err(value_error(format!("oversample must be 1 .. 4096, got {oversample}")));
    }
    let data = samples::borrow(&data, "data")?;
    let temperature = optional(&temperature, "temperature")?;
    let holdout = optional(&holdout, "holdout")?;
    let holdout_temperature = optional(&holdout_temperature, "holdout_temperature")?;
    if holdout.is_none() && holdout_temperature.is_some() {
        return Err(value_error("holdout_temperature is the temperature of a separate holdout: give holdout too"));
    }
    let opts = GapOptions { seeds, oversample, holdout_check, keep_transients, quantity, ..Default::default() };
    let report = py.detach(|| {
        samples::check_nan(data, "data", gaps)?;
        if let Some(h) = holdout {
            samples::check_nan(h, "holdout", gaps)?;
        }
        let input = match holdout {
            Some(h) => GapInput::joined(
                data.to_vec(),
                temperature.map(<[f64]>::to_vec),
                h.to_vec(),
                holdout_temperature.map(<[f64]>::to_vec),
                rate_hz,
            ),
            None => GapInput::split(data.to_vec(), temperature.map(<[f64]>::to_vec), rate_hz, holdout_fraction),
        }
        .map_err(|e| value_error(e.to_string()))?;
        let report = diagnose(&input, &opts, &|_, _, _| {}).map_err(|e| value_error(e.to_string()))?;
        PyResult::Ok(report.to_json())
    })?;
    to_python(py, &report)
}

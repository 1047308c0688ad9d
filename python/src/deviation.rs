//! `deviation(...)`: one statistic as `octavar analyze` tabulates it (Stable32's table), as a dict of arrays: per
//! tau the averaging factor, the number of terms, the deviation, its interval at the chosen confidence, the EDF
//! and the noise type behind it. The tau lists are octavar's (Stable32's stop ratios, as the command's `--taus`),
//! not allantools'; the keys are those of a point in `octavar analyze --json`, plus `noise_method`.

use numpy::{PyArray1, PyReadonlyArray1};
use octavar::stats::{self, DevPoint, NoiseMethod, NoiseSpec, Options, Statistic, TauSpec};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::allan::statistic;
use crate::errors::value_error;
use crate::samples;

/// A tau request of `deviation`.
#[derive(FromPyObject)]
pub enum DevTaus<'py> {
    /// `"octave"`, `"decade"` or `"all"`.
    Name(String),
    /// About this many taus per decade.
    PerDecade(u32),
    /// Taus in seconds.
    Values(PyReadonlyArray1<'py, f64>),
}

impl DevTaus<'_> {
    /// The library's tau request.
    fn spec(&self) -> PyResult<TauSpec> {
        Ok(match self {
            DevTaus::Name(name) => match name.as_str() {
                "octave" => TauSpec::Octave,
                "decade" => TauSpec::Decade,
                "all" => TauSpec::All,
                other => {
                    return Err(value_error(format!(
                        "taus {other:?}: use \"octave\", \"decade\", \"all\", a number of taus per decade or an array \
                         of taus in seconds"
                    )))
                }
            },
            DevTaus::PerDecade(0) => return Err(value_error("taus 0: give at least one tau per decade")),
            DevTaus::PerDecade(k) => TauSpec::PerDecade(*k),
            DevTaus::Values(v) => TauSpec::Explicit(v.as_array().to_vec()),
        })
    }
}

/// The name of a noise identification method.
fn method_name(m: NoiseMethod) -> &'static str {
    match m {
        NoiseMethod::Acf => "acf",
        NoiseMethod::B1 => "b1",
        NoiseMethod::Fixed => "fixed",
        NoiseMethod::Default => "default",
    }
}

/// `stat` of `data` with intervals at `confidence`, the noise type identified per tau (or `noise`, a fixed alpha).
#[pyfunction]
#[pyo3(signature = (data, rate, stat, data_type, taus, confidence, noise, gaps))]
#[allow(clippy::too_many_arguments)]
pub fn deviation<'py>(
    py: Python<'py>,
    data: PyReadonlyArray1<'py, f64>,
    rate: f64,
    stat: &str,
    data_type: &str,
    taus: DevTaus<'py>,
    confidence: f64,
    noise: Option<i32>,
    gaps: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let stat = statistic(stat)?;
    let kind = samples::kind(data_type)?;
    let rate_hz = samples::rate(rate)?;
    let spec = taus.spec()?;
    let noise = match noise {
        None => NoiseSpec::Auto,
        Some(a) if (-4..=2).contains(&a) => NoiseSpec::Fixed(a),
        Some(a) => {
            return Err(value_error(format!(
                "noise {a}: give the power-law alpha of the frequency noise, 2 (white PM) .. -4, or None to identify it"
            )))
        }
    };
    let data = samples::borrow(&data, "data")?;
    let opts = Options { confidence, noise, ..Default::default() };
    let points = py.detach(|| {
        samples::check_nan(data, "data", gaps)?;
        stats::analyze(data, kind, 1.0 / rate_hz, stat, &spec, &opts).map_err(|e| value_error(e.to_string()))
    })?;
    points_dict(py, stat, confidence, &points)
}

/// The dict of deviation points: one array per column of the table (keys as `octavar analyze --json` names them).
pub fn points_dict<'py>(
    py: Python<'py>,
    stat: Statistic,
    confidence: f64,
    points: &[DevPoint],
) -> PyResult<Bound<'py, PyDict>> {
    let column = |f: fn(&DevPoint) -> f64| PyArray1::from_vec(py, points.iter().map(f).collect());
    let d = PyDict::new(py);
    d.set_item("stat", stat.name().to_ascii_lowercase())?;
    d.set_item("confidence", confidence)?;
    d.set_item("m", PyArray1::from_vec(py, points.iter().map(|p| p.m).collect()))?;
    d.set_item("tau_s", column(|p| p.tau_s))?;
    d.set_item("n", PyArray1::from_vec(py, points.iter().map(|p| p.n).collect()))?;
    d.set_item("dev", column(|p| p.dev))?;
    d.set_item("lo", column(|p| p.lo))?;
    d.set_item("hi", column(|p| p.hi))?;
    d.set_item("alpha", PyArray1::from_vec(py, points.iter().map(|p| p.alpha).collect()))?;
    d.set_item("edf", column(|p| p.edf))?;
    d.set_item("noise_method", points.iter().map(|p| method_name(p.noise_method)).collect::<Vec<_>>())?;
    Ok(d)
}

//! The IEEE 952 fit as a dict: `fit(data, rate)` fits the overlapping Allan deviation at octave tau of a rate
//! record, as `octavar analyze` does; `fit_deviations(taus, devs, ...)` fits deviations computed elsewhere (by
//! allantools, say); `model_adev(fit, taus)` is the fitted model's curve for a plot.
//!
//! Each term (N, B, K, R, Q) is `{"value", "interval": (lo, hi), "identifiable", "unit", "alt": {"value", "unit"}}`;
//! a term the data cannot separate from its neighbours has no value and an upper bound as its interval's top,
//! as in the command's report. Beside them: `chi2`, `dof`, `chi2_per_dof`, `confidence`, `tau_range_s`,
//! `bandwidth_hz`, the classic graphical readouts (`classic`) and the fitted squares (`squares`, which
//! `model_adev` reads: a term that is not identifiable keeps its fitted square there).

use numpy::{PyArray1, PyReadonlyArray1};
use octavar::fit::{fit_deviations as fit_points, octave_oadev, FitOptions, NoiseFit, Term};
use octavar::quantity::Quantity;
use octavar::stats::{edf_for, DataKind, DevPoint, NoiseMethod, Series, Statistic};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::deviation::points_dict;
use crate::errors::value_error;
use crate::samples;

/// What a channel measures: `"gyro"` (deg/s) or `"accel"` (m/s^2); it names the terms' units.
fn quantity(name: &str) -> PyResult<Quantity> {
    match name {
        "gyro" => Ok(Quantity::AngularRate),
        "accel" => Ok(Quantity::Acceleration),
        other => Err(value_error(format!("quantity {other:?}: use \"gyro\" (deg/s) or \"accel\" (m/s^2)"))),
    }
}

/// The fit's options from the keyword arguments.
fn options(
    confidence: f64,
    tau_min: Option<f64>,
    tau_max: Option<f64>,
    bandwidth: Option<f64>,
    terms: Option<Vec<String>>,
    model_error: f64,
) -> PyResult<FitOptions> {
    if !(confidence > 0.0 && confidence < 1.0) {
        return Err(value_error(format!("confidence must be in (0, 1), got {confidence}")));
    }
    if !(model_error >= 0.0 && model_error.is_finite()) {
        return Err(value_error(format!("model_error must be a finite fraction >= 0, got {model_error}")));
    }
    if let Some(f) = bandwidth.filter(|f| !(*f > 0.0 && f.is_finite())) {
        return Err(value_error(format!("bandwidth must be a positive number of Hz, got {f}")));
    }
    let terms = match terms {
        None => Term::ALL.to_vec(),
        Some(names) => names
            .iter()
            .map(|n| {
                Term::ALL
                    .into_iter()
                    .find(|t| t.name().eq_ignore_ascii_case(n))
                    .ok_or_else(|| value_error(format!("term {n:?}: the IEEE 952 terms are Q, N, B, K and R")))
            })
            .collect::<PyResult<_>>()?,
    };
    Ok(FitOptions {
        terms,
        tau_min_s: tau_min.unwrap_or(0.0),
        tau_max_s: tau_max.unwrap_or(f64::INFINITY),
        confidence,
        bandwidth_hz: bandwidth,
        model_error,
    })
}

/// The fit as a dict (see the module doc).
fn fit_dict<'py>(py: Python<'py>, f: &NoiseFit, q: Quantity) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let squares = PyDict::new(py);
    for t in Term::ALL {
        let e = f.term(t);
        let (alt_unit, k) = t.alt_unit_of(q);
        let term = PyDict::new(py);
        term.set_item("value", e.value)?;
        term.set_item("interval", (e.lo, e.hi))?;
        term.set_item("identifiable", e.identifiable)?;
        term.set_item("unit", t.unit_of(q))?;
        let alt = PyDict::new(py);
        alt.set_item("value", e.value.map(|v| v * k))?;
        alt.set_item("unit", alt_unit)?;
        term.set_item("alt", alt)?;
        d.set_item(t.name(), term)?;
        squares.set_item(t.name(), f.squares[t as usize])?;
    }
    d.set_item("chi2", f.chi2)?;
    d.set_item("dof", f.dof)?;
    d.set_item("chi2_per_dof", if f.dof > 0 { f.chi2 / f.dof as f64 } else { f64::NAN })?;
    d.set_item("confidence", f.confidence)?;
    d.set_item("tau_range_s", (f.tau_range_s[0], f.tau_range_s[1]))?;
    d.set_item("bandwidth_hz", f.bandwidth_hz)?;
    let classic = PyDict::new(py);
    classic.set_item("N", f.classic.n)?;
    classic.set_item("B", f.classic.b)?;
    classic.set_item("B_tau_s", f.classic.b_tau_s)?;
    classic.set_item("K", f.classic.k)?;
    d.set_item("classic", classic)?;
    d.set_item("squares", squares)?;
    Ok(d)
}

/// Fit the IEEE 952 terms to the overlapping Allan deviation at octave tau of the rate record `data`.
#[pyfunction]
#[pyo3(signature = (data, rate, confidence, tau_min, tau_max, bandwidth, terms, model_error, quantity, gaps))]
#[allow(clippy::too_many_arguments)]
pub fn fit<'py>(
    py: Python<'py>,
    data: PyReadonlyArray1<'py, f64>,
    rate: f64,
    confidence: f64,
    tau_min: Option<f64>,
    tau_max: Option<f64>,
    bandwidth: Option<f64>,
    terms: Option<Vec<String>>,
    model_error: f64,
    quantity: &str,
    gaps: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let rate_hz = samples::rate(rate)?;
    let q = self::quantity(quantity)?;
    let opts = options(confidence, tau_min, tau_max, bandwidth, terms, model_error)?;
    let data = samples::borrow(&data, "data")?;
    // The deviations' own intervals at Stable32's 68.3%, as `octavar analyze` computes the points it fits.
    const POINT_CONFIDENCE: f64 = 0.683;
    let (points, result) = py.detach(|| {
        samples::check_nan(data, "data", gaps)?;
        let series = Series::new(data, DataKind::Frequency, 1.0 / rate_hz).map_err(|e| value_error(e.to_string()))?;
        let points = octave_oadev(&series, POINT_CONFIDENCE).map_err(|e| value_error(e.to_string()))?;
        let result = fit_points(&points, Some(&opts)).map_err(|e| value_error(e.to_string()))?;
        PyResult::Ok((points, result.in_units_of(q)))
    })?;
    let d = fit_dict(py, &result, q)?;
    d.set_item("points", points_dict(py, Statistic::Oadev, POINT_CONFIDENCE, &points)?)?;
    Ok(d)
}

/// The noise type (power-law alpha of the rate) at each point of an Allan deviation curve, from the slope mu of
/// log AVAR against log tau through its neighbours: AVAR ~ tau^mu with mu = -alpha - 1, rounded and kept within
/// -2 (random walk) .. 2 (white phase). Used only where the caller gives no EDF.
fn alphas_from_slope(taus: &[f64], devs: &[f64]) -> Vec<i32> {
    let n = taus.len();
    (0..n)
        .map(|k| {
            let (a, b) = (k.saturating_sub(1), (k + 1).min(n - 1));
            if a == b {
                return 0;
            }
            let mu = 2.0 * (devs[b] / devs[a]).ln() / (taus[b] / taus[a]).ln();
            if mu.is_finite() {
                (-mu - 1.0).round().clamp(-2.0, 2.0) as i32
            } else {
                0
            }
        })
        .collect()
}

/// Fit the IEEE 952 terms to Allan deviations `devs` at `taus` (s) computed elsewhere.
#[pyfunction]
#[pyo3(signature = (taus, devs, ns, edf, rate, stat, confidence, tau_min, tau_max, bandwidth, terms, model_error, quantity))]
#[allow(clippy::too_many_arguments)]
pub fn fit_deviations<'py>(
    py: Python<'py>,
    taus: PyReadonlyArray1<'py, f64>,
    devs: PyReadonlyArray1<'py, f64>,
    ns: Option<PyReadonlyArray1<'py, f64>>,
    edf: Option<PyReadonlyArray1<'py, f64>>,
    rate: Option<f64>,
    stat: &str,
    confidence: f64,
    tau_min: Option<f64>,
    tau_max: Option<f64>,
    bandwidth: Option<f64>,
    terms: Option<Vec<String>>,
    model_error: f64,
    quantity: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let stat = match stat {
        "oadev" => Statistic::Oadev,
        "adev" => Statistic::Adev,
        other => {
            return Err(value_error(format!(
                "stat {other:?}: the fit reads Allan deviations, \"oadev\" (overlapping) or \"adev\""
            )))
        }
    };
    let q = self::quantity(quantity)?;
    let opts = options(confidence, tau_min, tau_max, bandwidth, terms, model_error)?;
    let taus = samples::borrow(&taus, "taus")?;
    let devs = samples::borrow(&devs, "devs")?;
    let ns = ns.as_ref().map(|a| samples::borrow(a, "ns")).transpose()?;
    let edf = edf.as_ref().map(|a| samples::borrow(a, "edf")).transpose()?;
    let rate_hz = rate.map(samples::rate).transpose()?;
    for (name, len) in [("devs", Some(devs.len())), ("ns", ns.map(<[f64]>::len)), ("edf", edf.map(<[f64]>::len))] {
        if let Some(len) = len.filter(|&l| l != taus.len()) {
            return Err(value_error(format!("{name} has {len} values for {} taus", taus.len())));
        }
    }
    if let Some(i) = taus.iter().position(|t| !(*t > 0.0 && t.is_finite())) {
        return Err(value_error(format!(
            "taus[{i}] is {}: a tau must be a positive, finite number of seconds",
            taus[i]
        )));
    }
    if taus.windows(2).any(|w| w[1] <= w[0]) {
        return Err(value_error("taus must increase"));
    }
    // Averaging factor and terms of each point, where the rate and the counts are known: the EDF can then be
    // computed, and the intervals account for the correlation between taus.
    let shape: Option<Vec<(u64, u64)>> = match (ns, rate_hz) {
        (Some(ns), Some(r)) => {
            Some(taus.iter().zip(ns).map(|(t, n)| ((t * r).round().max(1.0) as u64, n.max(0.0) as u64)).collect())
        }
        _ => None,
    };
    let edf: Vec<f64> =
        match (edf, &shape) {
            (Some(e), _) => e.to_vec(),
            (None, Some(shape)) => {
                let alphas = alphas_from_slope(taus, devs);
                shape
                    .iter()
                    .zip(alphas)
                    .map(|(&(m, n), alpha)| {
                        let n_phase = match stat {
                            Statistic::Adev => (n + 1) * m + 1,
                            _ => n + 2 * m,
                        };
                        edf_for(stat, alpha, m as f64, n_phase as f64)
                    })
                    .collect()
            }
            (None, None) => return Err(value_error(
                "fit_deviations needs each point's degrees of freedom: give edf=, or ns= and rate= to compute them \
                 (allantools returns ns)",
            )),
        };
    let points: Vec<DevPoint> = (0..taus.len())
        .map(|k| {
            let (m, n) = shape.as_ref().map_or((0, 0), |s| s[k]);
            DevPoint {
                m,
                tau_s: taus[k],
                n,
                stride: if stat == Statistic::Adev { m } else { 1 },
                dev: devs[k],
                alpha: 0,
                noise_method: NoiseMethod::Default,
                edf: edf[k],
                lo: f64::NAN,
                hi: f64::NAN,
            }
        })
        .collect();
    let result = py.detach(|| fit_points(&points, Some(&opts)).map_err(|e| value_error(e.to_string())))?;
    fit_dict(py, &result.in_units_of(q), q)
}

/// The fitted model's Allan deviation at `taus` from its squares (Q^2, N^2, B^2, K^2, R^2) and the bandwidth that
/// shaped its white term.
#[pyfunction]
#[pyo3(signature = (squares, bandwidth, taus))]
pub fn model_adev<'py>(
    py: Python<'py>,
    squares: [f64; 5],
    bandwidth: Option<f64>,
    taus: PyReadonlyArray1<'py, f64>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let taus = samples::borrow(&taus, "taus")?;
    let adev = taus
        .iter()
        .map(|&tau| Term::ALL.iter().zip(squares).map(|(t, s)| s * t.basis_with(tau, bandwidth)).sum::<f64>().sqrt())
        .collect();
    Ok(PyArray1::from_vec(py, adev))
}

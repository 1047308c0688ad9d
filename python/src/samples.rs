//! What every function checks of its input: the samples, borrowed from numpy without a copy; the sample rate;
//! the data type; and NaN, which is a gap only where the caller says so (`gaps=True`), as `octavar analyze`
//! reads an empty cell.

use numpy::PyReadonlyArray1;
use octavar::stats::DataKind;
use pyo3::PyResult;
use rayon::prelude::*;

use crate::errors::value_error;

/// The samples of a read-only 1-D float64 array, without a copy. The Python half passes only contiguous arrays;
/// this refuses any other, so the module never reads a strided array as if it were contiguous.
pub fn borrow<'a>(array: &'a PyReadonlyArray1<'_, f64>, name: &str) -> PyResult<&'a [f64]> {
    let slice = array
        .as_slice()
        .map_err(|_| value_error(format!("{name} must be a contiguous one-dimensional float64 array")))?;
    if slice.is_empty() {
        return Err(value_error(format!("{name} is empty")));
    }
    Ok(slice)
}

/// The sample rate, Hz: positive and finite.
pub fn rate(rate_hz: f64) -> PyResult<f64> {
    if rate_hz > 0.0 && rate_hz.is_finite() {
        Ok(rate_hz)
    } else {
        Err(value_error(format!("rate must be a positive, finite number of samples per second, got {rate_hz}")))
    }
}

/// `"phase"` or `"freq"`, as allantools names them.
pub fn kind(data_type: &str) -> PyResult<DataKind> {
    match data_type {
        "phase" => Ok(DataKind::Phase),
        "freq" => Ok(DataKind::Frequency),
        other => Err(value_error(format!(
            "data_type {other:?}: use \"freq\" (rate samples, each the mean over 1/rate; a gyro's) or \"phase\""
        ))),
    }
}

/// Refuse a NaN sample unless NaN marks gaps (`gaps`). Runs without the GIL: one parallel scan.
pub fn check_nan(data: &[f64], name: &str, gaps: bool) -> PyResult<()> {
    if gaps {
        return Ok(());
    }
    match data.par_iter().position_first(|v| v.is_nan()) {
        Some(i) => Err(value_error(format!(
            "{name}[{i}] is NaN: pass gaps=True to read NaN as a missing sample (a gap), as octavar analyze reads an \
             empty cell"
        ))),
        None => Ok(()),
    }
}

/// `data` without its leading and trailing NaN samples (the library trims them too; gaps=True only).
pub fn trimmed(data: &[f64]) -> &[f64] {
    let first = data.iter().position(|v| !v.is_nan()).unwrap_or(data.len());
    let last = data.iter().rposition(|v| !v.is_nan()).map_or(first, |i| i + 1);
    &data[first..last]
}

/// Phase points of `n` samples of `kind` (frequency samples are the differences of N + 1 phase points).
pub fn n_phase(n: usize, kind: DataKind) -> usize {
    match kind {
        DataKind::Phase => n,
        DataKind::Frequency => n + 1,
    }
}

//! The allantools-compatible functions: `adev(data, rate, data_type, taus)` and its six siblings return
//! `(taus, devs, errs, ns)` as allantools 2024.6 does, so a script switches by changing its import.
//!
//! What "as allantools does" means here, from its `tau_generator` and `remove_small_ns`:
//! - the tau lists come from the N phase points (N = samples + 1 for frequency data): `"octave"` is m = 2^k for
//!   k <= floor(log2 N), `"decade"` m = 1, 2, 4 x 10^k for k <= floor(log10 N), `"all"` every m; an array of taus
//!   (s) becomes m = round(tau rate), half to even as numpy rounds. Only 0 < m < N is kept, sorted, once each;
//! - a tau whose estimate has fewer than 2 terms is left out;
//! - `errs` is dev / sqrt(n), and the taus are m / rate.
//!
//! The deviations are the library's (`octavar::stats::analyze` at those m, without intervals), which agree with
//! allantools' to about 1e-13. A NaN sample is an error unless NaN marks gaps (`gaps=True`); finding one costs
//! nothing on a clean record, because the term counts show it. One tau lies outside what the library computes: TOTDEV at m = N - 1 (only `"all"`
//! or an explicit tau reaches it), where the reflected record still has N - 2 terms; [`totdev_last`] computes it
//! from the samples in one pass.

use numpy::{PyArray1, PyReadonlyArray1};
use octavar::stats::{self, DataKind, Options, Statistic, TauSpec};
use pyo3::prelude::*;

use crate::errors::value_error;
use crate::samples;

/// A tau request: one of allantools' names, or taus in seconds.
#[derive(FromPyObject)]
pub enum Taus<'py> {
    /// `"octave"`, `"decade"` or `"all"`.
    Name(String),
    /// Taus in seconds.
    Values(PyReadonlyArray1<'py, f64>),
}

/// The statistic of a function name.
pub fn statistic(name: &str) -> PyResult<Statistic> {
    Statistic::ALL.into_iter().find(|s| s.name().eq_ignore_ascii_case(name)).ok_or_else(|| {
        value_error(format!("unknown statistic {name:?}: use adev, oadev, mdev, hdev, ohdev, tdev or totdev"))
    })
}

/// allantools' averaging factors for `taus` over `n_phase` phase points at `rate_hz` (see the module doc).
fn averaging_factors(taus: &Taus<'_>, n_phase: usize, rate_hz: f64) -> PyResult<Vec<u64>> {
    let n = n_phase as f64;
    let mut ms: Vec<u64> = match taus {
        Taus::Name(name) => match name.as_str() {
            "octave" => (0..=n.log2().floor() as i32).map(|k| 1u64 << k).collect(),
            "decade" => (0..=n.log10().floor() as u32).flat_map(|k| [1u64, 2, 4].map(|f| f * 10u64.pow(k))).collect(),
            "all" => (1..=n_phase as u64).collect(),
            other => {
                return Err(value_error(format!(
                    "taus {other:?}: use \"octave\", \"decade\", \"all\" or an array of taus in seconds"
                )))
            }
        },
        Taus::Values(values) => {
            let values = values.as_array();
            let mut ms = Vec::with_capacity(values.len());
            for (i, &t) in values.iter().enumerate() {
                if !(t > 0.0 && t.is_finite()) {
                    return Err(value_error(format!(
                        "taus[{i}] is {t}: a tau must be a positive, finite number of seconds"
                    )));
                }
                let m = (t * rate_hz).round_ties_even();
                if m >= 1.0 && m < n {
                    ms.push(m as u64);
                }
            }
            ms
        }
    };
    ms.retain(|&m| m >= 1 && (m as usize) < n_phase);
    ms.sort_unstable();
    ms.dedup();
    Ok(ms)
}

/// `(m, n, dev)` of `stat` at allantools' averaging factors, those with at least 2 terms.
fn estimates(
    data: &[f64],
    kind: DataKind,
    rate_hz: f64,
    stat: Statistic,
    ms: &[u64],
) -> PyResult<Vec<(u64, u64, f64)>> {
    let tau0_s = 1.0 / rate_hz;
    let n_phase = samples::n_phase(data.len(), kind);
    let last = (stat == Statistic::Totdev && n_phase >= 3).then(|| n_phase as u64 - 1);
    let lib_ms: Vec<f64> = ms.iter().filter(|&&m| Some(m) != last).map(|&m| m as f64 * tau0_s).collect();
    let opts = Options { intervals: false, ..Default::default() };
    let mut rows = Vec::with_capacity(ms.len());
    if !lib_ms.is_empty() {
        match stats::analyze(data, kind, tau0_s, stat, &TauSpec::Explicit(lib_ms), &opts) {
            Ok(points) => rows.extend(points.iter().map(|p| (p.m, p.n, p.dev))),
            // No tau left is answered below, as it is when none was asked for; every other fault is the data's.
            Err(stats::StatsError::NoTau { .. }) => {}
            Err(e) => return Err(value_error(e.to_string())),
        }
    }
    if let Some(m) = last.filter(|m| ms.contains(m)) {
        if let Some(dev) = totdev_last(data, kind, tau0_s) {
            rows.push((m, n_phase as u64 - 2, dev));
        }
    }
    rows.retain(|&(_, n, dev)| n > 1 && !dev.is_nan());
    if rows.is_empty() {
        return Err(value_error(format!(
            "no tau of this request has two or more terms of {} in {n_phase} phase points",
            stat.name()
        )));
    }
    Ok(rows)
}

/// TOTDEV at m = N - 1 of a gap-free record of N phase points: with the odd reflections `x*[-j] = 2 x[0] - x[j]`
/// and `x*[N-1+j] = 2 x[N-1] - x[N-1-j]`, term i (i = 1 .. N-2) is `2 (x[0] + x[N-1] - x[i] - x[N-1-i])`. For
/// frequency data x[k] is tau0 times the sum of the first k samples less their mean, so the term is
/// `2 tau0 (S_i - P_i)` with P_i the sum of the first i and S_i of the last i centred samples.
fn totdev_last(data: &[f64], kind: DataKind, tau0_s: f64) -> Option<f64> {
    let n_phase = samples::n_phase(data.len(), kind);
    if n_phase < 3 {
        return None;
    }
    let sum: f64 = match kind {
        DataKind::Frequency => {
            let mean = data.iter().sum::<f64>() / data.len() as f64;
            let (mut head, mut tail, mut sum) = (0.0, 0.0, 0.0);
            for i in 1..n_phase - 1 {
                head += data[i - 1] - mean;
                tail += data[data.len() - i] - mean;
                let d = 2.0 * tau0_s * (tail - head);
                sum += d * d;
            }
            sum
        }
        DataKind::Phase => {
            let (x0, xn) = (data[0], data[n_phase - 1]);
            (1..n_phase - 1)
                .map(|i| {
                    let d = 2.0 * (x0 + xn - data[i] - data[n_phase - 1 - i]);
                    d * d
                })
                .sum()
        }
    };
    let tau = (n_phase - 1) as f64 * tau0_s;
    Some((sum / (2.0 * tau * tau * (n_phase - 2) as f64)).sqrt())
}

/// The number of terms of `stat` at m in a gap-free record of `n_phase` points (TOTDEV's reflected record has
/// N - 2 at every m, the last one included).
fn gap_free_terms(stat: Statistic, n_phase: usize, m: u64) -> u64 {
    match stat {
        Statistic::Totdev => n_phase.saturating_sub(2) as u64,
        _ => stat.terms(n_phase, m as usize) as u64,
    }
}

/// The four arrays allantools returns.
type AllanArrays<'py> =
    (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>);

/// `stat` of `data` at allantools' taus: `(taus, devs, errs, ns)`.
#[pyfunction]
#[pyo3(signature = (stat, data, rate, data_type, taus, gaps))]
pub fn allan<'py>(
    py: Python<'py>,
    stat: &str,
    data: PyReadonlyArray1<'py, f64>,
    rate: f64,
    data_type: &str,
    taus: Taus<'py>,
    gaps: bool,
) -> PyResult<AllanArrays<'py>> {
    let stat = statistic(stat)?;
    let kind = samples::kind(data_type)?;
    let rate_hz = samples::rate(rate)?;
    let data = samples::borrow(&data, "data")?;
    // With gaps, the tau list is allantools' over the record the library sees: NaN at either end trimmed.
    let record = if gaps { samples::trimmed(data) } else { data };
    let n_phase = samples::n_phase(record.len(), kind);
    let ms = averaging_factors(&taus, n_phase, rate_hz)?;
    let rows = py.detach(|| {
        let rows = estimates(record, kind, rate_hz, stat, &ms);
        // Without gaps a NaN is an error. It costs nothing to look for one: a NaN leaves fewer terms than a
        // gap-free record has (inside the record: the terms touching it; at either end: the library trims it),
        // and only then is the record searched for it, to name it. (A NaN that no term of the request touches
        // changes nothing, and goes unremarked.)
        let complete =
            |rows: &Vec<(u64, u64, f64)>| rows.iter().all(|&(m, n, _)| n == gap_free_terms(stat, n_phase, m));
        if !gaps && !rows.as_ref().is_ok_and(complete) {
            samples::check_nan(data, "data", false)?;
        }
        rows
    })?;
    let taus: Vec<f64> = rows.iter().map(|r| r.0 as f64 / rate_hz).collect();
    let devs: Vec<f64> = rows.iter().map(|r| r.2).collect();
    let errs: Vec<f64> = rows.iter().map(|r| r.2 / (r.1 as f64).sqrt()).collect();
    let ns: Vec<f64> = rows.iter().map(|r| r.1 as f64).collect();
    Ok((
        PyArray1::from_vec(py, taus),
        PyArray1::from_vec(py, devs),
        PyArray1::from_vec(py, errs),
        PyArray1::from_vec(py, ns),
    ))
}

//! `octavar._octavar`: the Rust half of the Python package `octavar`, a thin layer over the octavar library.
//!
//! Each function borrows its numpy input read-only (a contiguous float64 array is never copied; the Python half,
//! `octavar/__init__.py`, makes the one copy any other array needs), releases the GIL while the library computes,
//! and hands back numpy arrays that take over the library's vectors without a copy, or plain dicts. Bad input is a
//! `ValueError` and an unreadable file an `OSError`, each carrying the message the `octavar` command prints
//! ([`errors`]).
//!
//! | module | Python function(s) | library |
//! |---|---|---|
//! | [`allan`] | `adev`, `oadev`, `mdev`, `hdev`, `ohdev`, `tdev`, `totdev`: allantools' signature and tau lists | `stats::analyze` |
//! | [`deviation`] | `deviation`: the Stable32 table (interval, EDF, noise type per tau) | `stats::analyze` |
//! | [`fit`] | `fit`, `fit_deviations`, `model_adev`: the IEEE 952 terms as a dict | `fit` |
//! | [`gap`] | `gap`: the gap report as the dict of its JSON | `gap::diagnose` |
//! | [`read`] | `read`: samples and rate from every format `analyze` reads | `io::formats` |
//! | [`simulate`] | `simulate`: the virtual bench's samples | `octavar_shared::sim` |
//!
//! [`samples`] holds what they share: the borrowed input, the rate and data type, the NaN check.

mod allan;
mod deviation;
mod errors;
mod fit;
mod gap;
mod read;
mod samples;
mod simulate;

use pyo3::prelude::*;

/// The module `octavar._octavar`.
#[pymodule]
fn _octavar(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(allan::allan, m)?)?;
    m.add_function(wrap_pyfunction!(deviation::deviation, m)?)?;
    m.add_function(wrap_pyfunction!(fit::fit, m)?)?;
    m.add_function(wrap_pyfunction!(fit::fit_deviations, m)?)?;
    m.add_function(wrap_pyfunction!(fit::model_adev, m)?)?;
    m.add_function(wrap_pyfunction!(gap::gap, m)?)?;
    m.add_function(wrap_pyfunction!(read::read, m)?)?;
    m.add_function(wrap_pyfunction!(simulate::simulate, m)?)?;
    Ok(())
}

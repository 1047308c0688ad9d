//! The Allan deviation family and its confidence intervals, on f64 phase or frequency data.
//!
//! - [`series`]: input preparation (frequency to phase, precision, NaN gaps);
//! - [`taus`]: tau lists (octave, decade, all, N per decade, explicit) with Stable32's stop ratios;
//! - [`deviation`]: ADEV, OADEV, MDEV, TDEV, HDEV, OHDEV, TOTDEV in O(N) per tau; `modified` (MDEV's running
//!   sums) and `total` (TOTDEV's reflected ends) hold the gap-free many-tau passes of two of them;
//! - [`noise_id`]: power-law noise identification (lag-1 autocorrelation, B1/R(n) fallback);
//! - [`edf`]: equivalent degrees of freedom (Greenhall's algorithm, SP 1065 formulas) and chi-square intervals;
//! - `octave`: OADEV of long frequency records without the phase array (the path [`analyze`] takes there);
//! - `blocks`: ADEV and HDEV of frequency records at octave taus from block sums, without the phase array;
//! - [`analysis`]: all of it in one call, one row per tau, like a Stable32 table;
//! - [`fit`]: the IEEE 952 noise terms Q, N, B, K, R fitted to an Allan variance curve, with their intervals;
//! - [`quantity`]: what a channel measures (gyro or accelerometer) and its base unit;
//! - [`tails`]: the normal and Poisson upper tails the gap diagnosis's tests are read against.
//!
//! This crate is the bottom of the host's layers: it imports only `octavar_shared`.

// `!(x > 0.0)` rejects NaN along with the non-positive values; clippy's rewrite (`x <= 0.0`) would let NaN
// through, so its lints against the form are off. Numeric kernels index several arrays in step, which reads
// better than zipped iterators.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::nonminimal_bool, clippy::needless_range_loop)]

pub mod analysis;
mod blocks;
pub mod deviation;
pub mod edf;
pub mod error;
pub mod fit;
mod kernel;
pub mod linalg;
mod modified;
pub mod noise_id;
mod octave;
mod ordered;
pub mod point;
pub mod quantity;
pub mod robust;
pub mod series;
pub mod stream_oadev;
pub mod strided;
pub mod tails;
pub mod taus;
#[doc(hidden)]
pub mod test_signals;
mod total;

pub use analysis::{analyze, analyze_series};
pub use deviation::{deviation_at, RawDeviation, Statistic};
pub use error::StatsError;
pub use noise_id::{identify, NoiseMethod};
pub use point::{edf_for, strided_avar_edf, DevPoint, NoiseSpec, Options};
pub use series::{DataKind, Series};
pub use taus::TauSpec;

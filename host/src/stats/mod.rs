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
//! - [`analysis`]: all of it in one call, one row per tau, like a Stable32 table.

pub mod analysis;
mod blocks;
pub mod deviation;
pub mod edf;
pub mod error;
mod kernel;
pub mod linalg;
mod modified;
pub mod noise_id;
mod octave;
mod ordered;
pub mod point;
pub mod robust;
pub mod series;
pub mod streamed;
pub mod strided;
pub mod taus;
mod total;

pub use analysis::{analyze, analyze_series};
pub use deviation::{estimate, RawDeviation, Statistic};
pub use error::StatsError;
pub use noise_id::{identify, NoiseMethod};
pub use point::{edf_for, strided_avar_edf, DevPoint, NoiseSpec, Options};
pub use series::{DataKind, Series};
pub use taus::TauSpec;

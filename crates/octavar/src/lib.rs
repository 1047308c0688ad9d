//! octavar's host library: everything the `octavar` command does, as functions the tests call.
//!
//! The binary (`host/`, the `octavar-cli` crate) only parses flags, calls these functions and prints. The library has no
//! clap, no stdout and no `process::exit`; errors are typed per module and locate the fault (file, line, column).
//!
//! The host is five crates along its layers, so Cargo forbids an arrow back: `octavar-stats` (the Allan family,
//! the noise-term fit, the quantities), `octavar-io` (the readers) and `octavar-gap` (the diagnosis) below this
//! library, and `octavar-cli` (the `octavar` command, the only crate with clap, indicatif, ctrlc and anyhow) above
//! it. This crate re-exports the three below as `stats` (with `fit` and `quantity`), `io` and `gap`.
//!
//! The modules by job, each importing only modules on the rows below it (and `octavar_shared`, below them all);
//! `farm-studio look` shows no circle and no upward import:
//!
//! | row | module     | job                                                                                  |
//! |-----|------------|--------------------------------------------------------------------------------------|
//! | 1   | `demo`     | the paper's experiment on the virtual bench: Table 1, figures, gap diagnoses         |
//! | 1   | `plot`     | ADEV and gap figures (PNG, SVG)                                                      |
//! | 1   | `export`   | IMU noise configs for state estimators and simulators (Kalibr, VINS, GTSAM, ...)     |
//! | 2   | `datasheet`| datasheet figures in any unit, and a fit measured against them                      |
//! | 2   | `analyze`  | one channel's statistics and fit, its text/JSON/CSV writers, the streamed path       |
//! | 2   | `board`    | the octavar board: recording it, verifying captures, the accumulator, a simulated one |
//! | 2   | `simulate` | a gyro simulated from a fitted model (`shared::sim`)                                 |
//! | 3   | `gap`      | crate `octavar-gap`: where a fitted model's simulation and a recording part, and why |
//! | 3   | `io`       | crate `octavar-io`: every format read into samples (CSV, TDMS, bags, captures)       |
//! | 4   | `stats`    | crate `octavar-stats`: the Allan family with intervals, the fit (`fit`), `quantity`  |

// `!(x > 0.0)` is how this crate rejects NaN along with the non-positive values; clippy's rewrite (`x <= 0.0`)
// would let NaN through, so its lints against the form are off. Numeric kernels index several arrays in step,
// which reads better than zipped iterators.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::nonminimal_bool, clippy::needless_range_loop)]

pub mod analyze;
pub mod board;
pub mod datasheet;
pub mod demo;
pub mod export;
pub mod plot;
pub mod simulate;

pub use octavar_gap as gap;
pub use octavar_io as io;
pub use octavar_stats as stats;
pub use octavar_stats::{fit, quantity};

#[cfg(test)]
use octavar_stats::test_signals;

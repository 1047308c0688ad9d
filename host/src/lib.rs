//! octavar's host library: everything the `octavar` command does, as functions the tests call.
//!
//! The binary (`src/main.rs`, `src/cli/`) only parses flags, calls these functions and prints. The library has no
//! clap, no stdout and no `process::exit`; errors are typed per module and locate the fault (file, line, column).

// `!(x > 0.0)` is how this crate rejects NaN along with the non-positive values; clippy's rewrite (`x <= 0.0`)
// would let NaN through, so its lints against the form are off. Numeric kernels index several arrays in step,
// which reads better than zipped iterators.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::nonminimal_bool, clippy::needless_range_loop)]

pub mod accumulate;
pub mod analyze;
pub mod capture;
pub mod csv_rows;
pub mod decode;
pub mod demo;
pub mod device_sim;
pub mod fit;
pub mod formats;
pub mod gap;
pub mod input;
pub mod plot;
pub mod record;
pub mod recording;
pub mod ros2_bag;
pub mod simulate;
pub mod snapshot_stats;
pub mod stats;
pub mod streaming;
pub mod tdms;
pub mod verify;

#[cfg(test)]
mod test_signals;

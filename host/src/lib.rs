//! octavar's host library: everything the `octavar` command does, as functions the tests call.
//!
//! The binary (`src/main.rs`, `src/cli/`) only parses flags, calls these functions and prints. The library has no
//! clap, no stdout and no `process::exit`; errors are typed per module and locate the fault (file, line, column).

pub mod accumulate;
pub mod analyze;
pub mod capture;
pub mod decode;
pub mod device_sim;
pub mod demo;
pub mod fit;
pub mod gap;
pub mod input;
pub mod plot;
pub mod record;
pub mod recording;
pub mod simulate;
pub mod snapshot_stats;
pub mod stats;
pub mod streaming;
pub mod verify;

#[cfg(test)]
mod test_signals;

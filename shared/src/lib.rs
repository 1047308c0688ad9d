//! octavar's no_std core, shared by the firmware and the host.
//!
//! Everything both sides must agree on lives here, so that a snapshot made on the microcontroller can be
//! replayed on the host bit for bit:
//!
//! - [`acc`]: the exact octave Allan accumulator (integer sums, constant memory, optional stride);
//! - [`proto`]: the frames that travel between device and host (postcard, COBS, CRC-32);
//! - [`sensor`]: the gyro and ADC models (code <-> volts <-> deg/s);
//! - [`sim`]: a deterministic virtual gyro + ADC that streams in constant memory;
//! - [`estimate`]: the onboard estimate of N and B from an accumulator snapshot.
//!
//! The crate has no allocation and no unsafe code; it builds for `thumbv7em-none-eabihf`.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]

pub mod acc;
pub mod estimate;
pub mod fieldlog;
pub mod proto;
pub mod sensor;
pub mod sim;

pub use acc::{AccError, OctaveAllan, Snapshot};

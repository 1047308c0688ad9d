//! octavar's no_std core, shared by the firmware and the host.
//!
//! Everything both sides must agree on lives here, so that a snapshot made on the microcontroller can be
//! replayed on the host bit for bit:
//!
//! - [`acc`]: the exact octave Allan accumulator (integer sums, constant memory, optional stride);
//! - [`proto`]: the frames that travel between device and host (postcard, COBS, CRC-32);
//! - [`sensor`]: the gyro and ADC models (code <-> volts <-> deg/s);
//! - [`sim`]: a deterministic virtual gyro + ADC that streams in constant memory;
//! - [`estimate`]: the onboard estimate of N and B from an accumulator snapshot;
//! - [`device`]: the device core: channel table, schedule, characterizer, sample ring (firmware and host
//!   simulator both run it);
//! - [`fieldlog`]: the field log's record format, recovery and checkpoint policy, over any NOR flash;
//! - [`adc_f4`]: the STM32F405's sampling converter (ADC1 scan, DMA2 ring, TIM3 trigger, TIM5 count): failure
//!   checks and the recovery, with a model of the hardware with faults injected for the tests;
//! - [`flash_f4`]: the STM32F405 flash controller's erase, program and option-byte sequences at x32, checked by
//!   its error flags, with a model of the controller they run on in tests and in QEMU.
//!
//! The crate has no allocation and no unsafe code; it builds for `thumbv7em-none-eabihf`.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
// `!(x > 0.0)` rejects NaN along with the non-positive values; clippy's rewrite (`x <= 0.0`) would let NaN
// through. Numeric kernels index several arrays in step, which reads better than zipped iterators.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::nonminimal_bool, clippy::needless_range_loop)]

pub mod acc;
pub mod adc_f4;
pub mod device;
pub mod estimate;
pub mod fieldlog;
pub mod flash_f4;
pub mod proto;
pub mod sensor;
pub mod sim;

pub use acc::{AccError, OctaveAllan, Snapshot};

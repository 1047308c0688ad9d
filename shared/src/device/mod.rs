//! The device core: everything octavar's firmware does between the ADC and the link that needs no hardware.
//!
//! - [`config`]: the channel table and the schedule ([`DeviceConfig::F405`] is the board);
//! - [`characterizer`]: accumulators, snapshot rounds, the onboard estimate, raw streaming, gaps, commands,
//!   through a [`FrameSink`];
//! - [`ring`]: the hardware-indexed sample ring: which block to take, and what a stall cost;
//! - [`sampler`]: the sampler's poll over the ring: check the converter, copy, check again, hand on.
//!
//! The firmware's tasks and the host's device simulator are thin wrappers around these, so the host's tests
//! exercise the code the board runs.

pub mod characterizer;
pub mod config;
pub mod ring;
pub mod sampler;

pub use characterizer::{Characterizer, FrameSink};
pub use config::{ChannelSpec, DeviceConfig, F405_CHANNELS, STRIDE};
pub use ring::{ReadyBlock, RingReader};
pub use sampler::{BlockSink, Sampler, SamplerEvent, ScanRing};

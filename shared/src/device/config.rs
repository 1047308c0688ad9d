//! The device's configuration as data: its channel table (which sensor is on which ADC input, in scan order), its
//! sample rate and ADC, and its schedule (scans per block, per raw-sample frame, per snapshot round).
//!
//! [`DeviceConfig::F405`] is octavar's board: the firmware runs it, the host's device simulator runs it, and the
//! host reads the same table to convert codes. Nothing else spells these numbers out.

use crate::acc::Snapshot;
use crate::proto::{ChannelInfo, Frame, Hello, MAX_CHANNELS, MAX_CODES};
use crate::sensor::SensorKind;

/// Stride of the onboard accumulators: clusters every m / 8 samples keep about 98% of the full-overlap degrees of
/// freedom for an eighth of the sums.
pub const STRIDE: usize = 8;

/// One input of a scan: the sensor on it and the name the hello frame gives it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChannelSpec<'a> {
    /// What is wired to the input (its conversions come from [`crate::sensor`]).
    pub kind: SensorKind,
    /// Its name in the hello frame.
    pub name: &'a str,
}

/// What a device samples and how it schedules its frames.
///
/// A *scan* is one code of every channel, taken at one trigger; scans are numbered from boot by the hardware
/// (the sampler's trigger count), so a number that jumps is a gap.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeviceConfig<'a> {
    /// Firmware version in the hello frame.
    pub firmware: &'a str,
    /// Board name in the hello frame.
    pub board: &'a str,
    /// Scans per second, Hz.
    pub rate_hz: u32,
    /// ADC resolution, bits.
    pub adc_bits: u8,
    /// ADC reference, mV.
    pub vref_mv: u16,
    /// The channels in scan order; the first [`DeviceConfig::gyros`] have accumulators.
    pub channels: &'a [ChannelSpec<'a>],
    /// Gyro channels: `0..gyros`.
    pub gyros: usize,
    /// The temperature channel, if any: its mean code over a round goes into the status frame.
    pub temp_channel: Option<usize>,
    /// Scans per sample block (the sampler hands blocks of this size to the characterizer).
    pub block_scans: usize,
    /// Scans per snapshot round.
    pub snapshot_every: u64,
    /// Scans per raw [`crate::proto::Samples`] frame at most.
    pub raw_scans_per_frame: usize,
}

/// The channels of octavar's board, in scan order (ADC1 IN0..IN4; the firmware's `board.rs` has the pins).
pub const F405_CHANNELS: [ChannelSpec<'static>; 5] = [
    ChannelSpec { kind: SensorKind::Idg1215X, name: "IDG1215 X" },
    ChannelSpec { kind: SensorKind::Idg1215Y, name: "IDG1215 Y" },
    ChannelSpec { kind: SensorKind::Adxrs300, name: "ADXRS300" },
    ChannelSpec { kind: SensorKind::Env05h, name: "ENV-05H" },
    ChannelSpec { kind: SensorKind::Temperature, name: "ADXRS300 TEMP" },
];

impl DeviceConfig<'static> {
    /// octavar's board: four gyro outputs and the ADXRS300 TEMP output at 2 kS/s, 12-bit ADC at 3.3 V; blocks of
    /// 128 scans (64 ms, four raw frames of 32 scans), a snapshot round every second.
    pub const F405: DeviceConfig<'static> = DeviceConfig {
        firmware: env!("CARGO_PKG_VERSION"),
        board: "STM32F405RG",
        rate_hz: 2_000,
        adc_bits: 12,
        vref_mv: 3300,
        channels: &F405_CHANNELS,
        gyros: 4,
        temp_channel: Some(4),
        block_scans: 128,
        snapshot_every: 2_000,
        raw_scans_per_frame: 32,
    };
}

impl<'a> DeviceConfig<'a> {
    /// Channels per scan.
    pub const fn width(&self) -> usize {
        self.channels.len()
    }

    /// Codes in one sample block.
    pub const fn block_codes(&self) -> usize {
        self.block_scans * self.width()
    }

    /// Bit mask of every channel.
    pub const fn all_channels_mask(&self) -> u8 {
        ((1u16 << self.width()) - 1) as u8
    }

    /// Whether the configuration is one the characterizer can run: 1..=8 channels, gyros among them, a
    /// temperature channel after the gyros, blocks of whole raw frames that fit a frame, a nonzero schedule.
    pub const fn is_valid(&self) -> bool {
        let w = self.width();
        let temp_ok = match self.temp_channel {
            Some(t) => t >= self.gyros && t < w,
            None => true,
        };
        w > 0
            && w <= MAX_CHANNELS
            && w <= 8
            && self.gyros <= w
            && temp_ok
            && self.block_scans > 0
            && self.raw_scans_per_frame > 0
            && self.block_scans.is_multiple_of(self.raw_scans_per_frame)
            && self.raw_scans_per_frame * w <= MAX_CODES
            && self.snapshot_every > 0
            && self.rate_hz > 0
    }

    /// The hello frame: versions, board, rates and the channel list.
    pub fn hello(&self) -> Frame {
        let mut h = Hello::new(self.firmware, self.board, self.rate_hz, self.adc_bits, self.vref_mv, STRIDE as u8);
        for c in self.channels {
            let _ = h.channels.push(ChannelInfo::new(c.kind, c.name));
        }
        Frame::Hello(h)
    }

    /// An empty snapshot of this device's accumulators.
    pub const fn empty_snapshot() -> Snapshot {
        Snapshot::empty_for::<STRIDE>()
    }
}

const _: () = assert!(DeviceConfig::F405.is_valid());

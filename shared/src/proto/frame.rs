//! The frames the device sends to the host.
//!
//! Plain data: bounded collections are heapless 0.9 `Vec`/`String` with the capacities of [`super`]'s
//! constants, so every value has a worst-case size (see [`super::MaxSize`]) that fits one frame.
//! The order of the variants and of the fields is the wire format: change it only with a
//! [`super::PROTOCOL_VERSION`] bump.

use heapless::{String, Vec};
use serde::{Deserialize, Serialize};

use super::{SnapshotPart, MAX_CHANNELS, MAX_CHANNEL_NAME, MAX_CODES, MAX_IDENT, PROTOCOL_VERSION};
use crate::estimate::NoiseEstimate;
use crate::sensor::SensorKind;

/// Everything the device sends to the host (the body of a device -> host frame).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Frame {
    /// Who is talking: versions, board, sampling and the channel list.
    Hello(Hello),
    /// Raw ADC codes of one or more channels.
    Samples(Samples),
    /// One part of a channel's accumulator snapshot.
    AllanSnapshot(SnapshotPart),
    /// Health counters.
    Status(Status),
    /// The onboard estimate of N and B per gyro channel.
    Estimate(Estimate),
    /// One part of a snapshot read back from the field log in flash.
    FieldLog(FieldLogRecord),
    /// The end of a field-log read-out.
    FieldLogEnd(FieldLogEnd),
    /// A host command was carried out.
    Ack(Ack),
    /// A checkpoint the host asked for ([`super::Command::Checkpoint`]) was written, or failed.
    CheckpointReport(CheckpointReport),
}

impl Frame {
    /// The variant's name, for logs and per-kind counts.
    pub const fn name(&self) -> &'static str {
        match self {
            Frame::Hello(_) => "hello",
            Frame::Samples(_) => "samples",
            Frame::AllanSnapshot(_) => "allan-snapshot",
            Frame::Status(_) => "status",
            Frame::Estimate(_) => "estimate",
            Frame::FieldLog(_) => "field-log",
            Frame::FieldLogEnd(_) => "field-log-end",
            Frame::Ack(_) => "ack",
            Frame::CheckpointReport(_) => "checkpoint-report",
        }
    }
}

/// The device introduces itself.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Hello {
    /// [`PROTOCOL_VERSION`] of the firmware: the host refuses a version it does not know.
    pub protocol_version: u16,
    /// Firmware version, for example `0.1.0+9831cae`.
    pub firmware: String<MAX_IDENT>,
    /// Board name, for example `octavar-f405`.
    pub board: String<MAX_IDENT>,
    /// Samples per second per channel, in Hz (`sample_rate_hz` in serialised documents such as decode's JSON).
    #[serde(rename = "sample_rate_hz")]
    pub rate_hz: u32,
    /// ADC resolution in bits.
    pub adc_bits: u8,
    /// ADC reference voltage, in mV.
    pub vref_mv: u16,
    /// Stride S of the onboard accumulators (see [`crate::acc`]).
    pub stride: u8,
    /// The channels, in channel order: channel `i` is bit `i` of every channel mask.
    pub channels: Vec<ChannelInfo, MAX_CHANNELS>,
}

impl Hello {
    /// A hello with this crate's [`PROTOCOL_VERSION`] and no channels; names longer than [`MAX_IDENT`] bytes
    /// are cut at a character boundary.
    pub fn new(firmware: &str, board: &str, rate_hz: u32, adc_bits: u8, vref_mv: u16, stride: u8) -> Self {
        Hello {
            protocol_version: PROTOCOL_VERSION,
            firmware: truncated(firmware),
            board: truncated(board),
            rate_hz,
            adc_bits,
            vref_mv,
            stride,
            channels: Vec::new(),
        }
    }
}

/// One channel of the device.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ChannelInfo {
    /// The part on the channel.
    pub kind: SensorKind,
    /// A short name, for example `adxrs300` or `idg1215.x`.
    pub name: String<MAX_CHANNEL_NAME>,
}

impl ChannelInfo {
    /// A channel; a name longer than [`MAX_CHANNEL_NAME`] bytes is cut at a character boundary.
    pub fn new(kind: SensorKind, name: &str) -> Self {
        ChannelInfo { kind, name: truncated(name) }
    }
}

/// `s` cut to at most `N` bytes at a character boundary.
pub(super) fn truncated<const N: usize>(s: &str) -> String<N> {
    let mut out = String::new();
    for c in s.chars() {
        if out.push(c).is_err() {
            break;
        }
    }
    out
}

/// Raw codes, interleaved: sample set after sample set, each set one code per channel of `channel_mask`
/// in increasing channel order.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Samples {
    /// Index of the first sample set (per-channel sample count since the last reset, starting at 0).
    pub first_sample: u64,
    /// Bit `i` set: channel `i` is in every set.
    pub channel_mask: u8,
    /// The codes; their number is a multiple of the channels in the mask.
    pub codes: Vec<u16, MAX_CODES>,
}

impl Samples {
    /// An empty frame for the channels of `channel_mask`, starting at sample `first_sample`.
    pub const fn new(first_sample: u64, channel_mask: u8) -> Self {
        Samples { first_sample, channel_mask, codes: Vec::new() }
    }

    /// Channels per sample set.
    pub const fn channels(&self) -> usize {
        self.channel_mask.count_ones() as usize
    }

    /// Complete sample sets held (0 for an empty mask).
    pub fn sets(&self) -> usize {
        self.codes.len().checked_div(self.channels()).unwrap_or(0)
    }

    /// Sample sets one frame holds for `channel_mask` (`MAX_CODES / channels`).
    pub const fn capacity_sets(channel_mask: u8) -> usize {
        match channel_mask.count_ones() {
            0 => 0,
            c => MAX_CODES / c as usize,
        }
    }

    /// Append one sample set (one code per channel of the mask).
    ///
    /// # Errors
    /// `Err(())` when the set does not have one code per channel or the frame is full; nothing is appended.
    #[allow(clippy::result_unit_err)]
    pub fn push_set(&mut self, set: &[u16]) -> Result<(), ()> {
        if set.len() != self.channels() || set.is_empty() || self.codes.len() + set.len() > MAX_CODES {
            return Err(());
        }
        self.codes.extend_from_slice(set).map_err(|_| ())
    }

    /// The channels of the mask in increasing order: slot `j` of every set is the `j`-th of them.
    pub fn mask_channels(&self) -> impl Iterator<Item = usize> + '_ {
        (0..8).filter(move |&c| self.channel_mask & (1 << c) != 0)
    }

    /// The codes of channel slot `slot`, set after set.
    pub fn slot_codes(&self, slot: usize) -> impl Iterator<Item = u16> + '_ {
        self.codes.iter().skip(slot).step_by(self.channels().max(1)).copied()
    }

    /// The code of channel slot `slot` (0-based among the mask's channels) in sample set `set`.
    pub fn code(&self, set: usize, slot: usize) -> Option<u16> {
        if slot >= self.channels() {
            return None;
        }
        let i = set.checked_mul(self.channels())?.checked_add(slot)?;
        self.codes.get(i).copied()
    }

    /// The frames of a block of scans: `codes` holds whole scans of `width` codes (channel 0 first), the frames
    /// keep the channels of `channel_mask`, `sets_per_frame` scans each (the last frame may hold fewer; at most
    /// [`Samples::capacity_sets`]), and the first one starts at sample `first_sample`. What the firmware streams
    /// and what the host's device simulator streams, from one place.
    pub fn pack_scans(
        first_sample: u64,
        channel_mask: u8,
        width: usize,
        sets_per_frame: usize,
        codes: &[u16],
    ) -> impl Iterator<Item = Samples> + '_ {
        let per = sets_per_frame.clamp(1, Self::capacity_sets(channel_mask).max(1));
        let width = width.clamp(1, MAX_CHANNELS);
        codes.chunks(per * width).enumerate().map(move |(i, chunk)| {
            let mut frame = Samples::new(first_sample + (i * per) as u64, channel_mask);
            let mut set = [0u16; MAX_CHANNELS];
            for scan in chunk.chunks_exact(width) {
                let mut k = 0;
                for (c, &code) in scan.iter().enumerate() {
                    if channel_mask & (1 << c) != 0 {
                        set[k] = code;
                        k += 1;
                    }
                }
                let _ = frame.push_set(&set[..k]);
            }
            frame
        })
    }
}

/// Health counters of the device.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Status {
    /// Time since boot, in ms.
    pub uptime_ms: u64,
    /// Samples taken per channel since the last reset.
    pub samples_per_channel: u64,
    /// Sample losses since boot: ADC overruns, stalls that outlasted the sample ring, a characterizer that fell
    /// behind. Each is a gap in the hardware sample index, pooled across.
    pub adc_overruns: u32,
    /// Frames dropped since boot because USB was busy or disconnected.
    pub frames_dropped: u32,
    /// Board temperature in degC (the MCU's sensor, or a gyro's temperature output); `None` without one.
    pub temperature_c: Option<f32>,
    /// Scans lost since the last reset: the sum of this session's gaps, each counted exactly from the hardware
    /// sample index. `samples_per_channel + samples_lost` scans of time have passed in the session.
    pub samples_lost: u64,
    /// The deepest the stack has been since boot, in bytes: the high-water mark of the stack painted at boot.
    /// `None` from a sender that does not measure it (the host's simulated device).
    pub stack_peak_bytes: Option<u32>,
}

/// The onboard noise estimate of the gyro channels.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Estimate {
    /// Samples per channel the estimate is based on.
    pub samples: u64,
    /// One entry per gyro channel.
    pub channels: Vec<ChannelEstimate, MAX_CHANNELS>,
}

/// N and B of one channel (f32, computed on the device by [`crate::estimate`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ChannelEstimate {
    /// Channel index.
    pub channel: u8,
    /// Angle random walk N, in deg/sqrt(s); `None` until enough data.
    pub n_dps_per_rt_s: Option<f32>,
    /// Bias instability B (ADEV floor / 0.6643), in deg/s; `None` until the floor is seen.
    pub b_dps: Option<f32>,
    /// The averaging time B was read at, in s.
    pub tau_b_s: Option<f32>,
}

impl ChannelEstimate {
    /// The estimate of channel `channel`.
    pub const fn new(channel: u8, e: &NoiseEstimate) -> Self {
        ChannelEstimate { channel, n_dps_per_rt_s: e.n_dps_per_rt_s, b_dps: e.b_dps, tau_b_s: e.tau_b_s }
    }

    /// The estimate without its channel index.
    pub const fn noise(&self) -> NoiseEstimate {
        NoiseEstimate { n_dps_per_rt_s: self.n_dps_per_rt_s, b_dps: self.b_dps, tau_b_s: self.tau_b_s }
    }
}

/// One part of one channel's snapshot of a checkpoint read back from the field log
/// ([`crate::fieldlog::Checkpoint`]).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FieldLogRecord {
    /// The checkpoint's sequence number in the log (increasing with time).
    pub checkpoint: u32,
    /// The sampling time the checkpoint covers, in s, pooled over its sessions (the log keeps no wall clock).
    pub time_s: u32,
    /// Power-on sessions pooled in the checkpoint.
    pub sessions: u32,
    /// ADC overruns counted over those sessions.
    pub adc_overruns: u32,
    /// The snapshot part, as [`Frame::AllanSnapshot`] carries it.
    pub part: SnapshotPart,
}

/// The acknowledgement of a host command, sent once the command has taken effect.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Ack {
    /// The sequence number of the command's frame.
    pub seq: u32,
}

/// What a checkpoint the host asked for cost: the measured stalls of the CPU on the flash, and the scans lost.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CheckpointReport {
    /// The sequence number of the command's frame.
    pub seq: u32,
    /// The checkpoint's number in the log (0 when it failed).
    pub checkpoint: u32,
    /// How long programming it held the CPU, in us (measured on the device's time base).
    pub program_us: u32,
    /// How long the erase that prepared the next checkpoint's slot held it, in us (0: none was due).
    pub erase_us: u32,
    /// Scans the sampler lost while the checkpoint was written and the next slot prepared.
    pub samples_lost: u32,
    /// The flash controller's error flags when writing failed (FLASH_SR; 0: written).
    pub flash_error: u32,
}

/// The end of a field-log read-out.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FieldLogEnd {
    /// Checkpoints sent in this read-out.
    pub checkpoints: u32,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_cut_at_char_boundaries() {
        let c = ChannelInfo::new(SensorKind::Generic, "ééééééééé"); // 18 bytes
        assert_eq!(c.name.as_str(), "éééééééé");
        let h = Hello::new("0123456789012345678901234567", "b", 2000, 12, 3300, 8);
        assert_eq!(h.firmware.len(), MAX_IDENT);
        assert_eq!(h.protocol_version, PROTOCOL_VERSION);
    }

    #[test]
    fn samples_sets() {
        let mut s = Samples::new(10, 0b101);
        assert_eq!(Samples::capacity_sets(0b101), 80);
        assert_eq!(Samples::capacity_sets(0), 0);
        assert!(s.push_set(&[1]).is_err());
        for i in 0..80 {
            s.push_set(&[i, i + 1000]).unwrap();
        }
        assert!(s.push_set(&[1, 2]).is_err());
        assert_eq!(s.sets(), 80);
        assert_eq!(s.code(79, 1), Some(1079));
        assert_eq!(s.code(0, 2), None);
        assert_eq!(s.code(usize::MAX, 1), None);
        let mut empty = Samples::new(0, 0);
        assert!(empty.push_set(&[]).is_err());
        assert_eq!(empty.sets(), 0);
    }

    #[test]
    fn scans_pack_into_frames_of_the_masked_channels() {
        // 5 scans of 3 channels (code = 100 scan + channel), channels 0 and 2 kept, 2 scans per frame.
        let codes: std::vec::Vec<u16> = (0..5u16).flat_map(|s| (0..3u16).map(move |c| 100 * s + c)).collect();
        let frames: std::vec::Vec<Samples> = Samples::pack_scans(40, 0b101, 3, 2, &codes).collect();
        assert_eq!(frames.len(), 3);
        assert_eq!(frames.iter().map(|f| f.first_sample).collect::<std::vec::Vec<_>>(), [40, 42, 44]);
        assert_eq!(frames.iter().map(Samples::sets).collect::<std::vec::Vec<_>>(), [2, 2, 1]);
        assert_eq!(frames[1].code(1, 0), Some(300));
        assert_eq!(frames[1].code(1, 1), Some(302));
        assert_eq!(frames[2].code(0, 1), Some(402));
        // A request beyond a frame's capacity is cut to it: nothing is dropped.
        let many = vec![7u16; 3 * 200];
        let frames: std::vec::Vec<Samples> = Samples::pack_scans(0, 0b111, 3, 1000, &many).collect();
        assert_eq!(frames.iter().map(Samples::sets).sum::<usize>(), 200);
        assert!(frames.iter().all(|f| f.sets() <= Samples::capacity_sets(0b111)));
    }
}

//! Frames of a simulated device: the exact byte stream octavar's firmware sends for given ADC codes.
//!
//! [`DeviceSim`] is the firmware's `characterize` task on the host: one exact octave accumulator
//! (`OctaveAllan<8>`) per gyro channel, scans taken in blocks of [`DeviceConfig::block_sets`], a hello at boot,
//! raw [`Samples`] frames of each block *before* the block is accumulated (while raw streaming is on), and on
//! every [`DeviceConfig::snapshot_every`] scans a round of snapshot parts (one channel after the other), an
//! estimate and a status frame. Lost samples (an ADC overrun) pool the accumulators as the firmware does: the
//! raw stream shows a jump in `first_sample`, and no Allan difference straddles the gap. Frames are numbered by
//! one [`Encoder`], as the firmware's frame queue does; [`DeviceSim::drop_next_frames`] makes the device drop
//! frames (a busy link) so their numbers go missing.
//!
//! Tests use it to make captures with known content; `octavar demo` and the QEMU test can compare a device
//! against it.
//!
//! # Examples
//! ```
//! use octavar::device_sim::{DeviceConfig, DeviceSim};
//! let cfg = DeviceConfig::firmware();
//! let mut dev = DeviceSim::new(cfg, 0xff);
//! let mut wire = Vec::new();
//! dev.boot(&mut wire);
//! for i in 0..4_100u32 {
//!     let c = 2048 + (i % 7) as u16;
//!     dev.push_scan(&[c, c, c, c, 1900], &mut wire);
//! }
//! let stats = octavar::verify::verify(octavar::decode::CaptureReader::new(&wire[..], "sim")).unwrap();
//! assert_eq!(stats.checked, 4 * 2); // two rounds of four gyro snapshots
//! assert!(stats.passed());
//! ```

use octavar_shared::acc::{OctaveAllan, Snapshot};
use octavar_shared::estimate::{estimate, EstimateConfig};
use octavar_shared::proto::{
    ChannelEstimate, ChannelInfo, Command, Encoder, Estimate, Frame, Hello, Samples, SnapshotPart, Status,
};
use octavar_shared::sensor::{Channel, GyroModel, SensorKind, ADXRS300};

/// The accumulator stride of the firmware.
pub const STRIDE: usize = 8;

/// How the simulated device is set up: the firmware's `config.rs` as data.
#[derive(Clone, Debug, PartialEq)]
pub struct DeviceConfig {
    /// Firmware version in the hello.
    pub firmware: String,
    /// Board name in the hello.
    pub board: String,
    /// Samples per second per channel, Hz.
    pub sample_rate_hz: u32,
    /// ADC bits.
    pub adc_bits: u8,
    /// ADC reference, mV.
    pub vref_mv: u16,
    /// The channels in scan order; the first `gyros` have accumulators.
    pub channels: Vec<ChannelInfo>,
    /// Gyro channels (0..gyros).
    pub gyros: usize,
    /// The temperature channel, if any (its mean code goes into the status frame).
    pub temp_channel: Option<usize>,
    /// Scans per block (the sampler's DMA half-buffer).
    pub block_sets: usize,
    /// Scans per snapshot round.
    pub snapshot_every: u64,
    /// Scans per raw [`Samples`] frame at most.
    pub raw_sets_per_frame: usize,
}

impl DeviceConfig {
    /// The firmware's configuration: 2 kS/s, 12-bit ADC at 3.3 V, IDG1215 X, IDG1215 Y, ADXRS300, ENV-05H and the
    /// ADXRS300 TEMP output; blocks of 128 scans, a round every second, 32 scans per raw frame.
    pub fn firmware() -> Self {
        let channels = [
            (SensorKind::Idg1215X, "IDG1215 X"),
            (SensorKind::Idg1215Y, "IDG1215 Y"),
            (SensorKind::Adxrs300, "ADXRS300"),
            (SensorKind::Env05h, "ENV-05H"),
            (SensorKind::Temperature, "ADXRS300 TEMP"),
        ];
        DeviceConfig {
            firmware: "sim".into(),
            board: "octavar device_sim".into(),
            sample_rate_hz: 2000,
            adc_bits: 12,
            vref_mv: 3300,
            channels: channels.iter().map(|&(k, n)| ChannelInfo::new(k, n)).collect(),
            gyros: 4,
            temp_channel: Some(4),
            block_sets: 128,
            snapshot_every: 2000,
            raw_sets_per_frame: 32,
        }
    }

    /// Channels per scan.
    pub fn width(&self) -> usize {
        self.channels.len()
    }

    /// Bit mask of every channel.
    pub fn all_channels_mask(&self) -> u8 {
        ((1u16 << self.width().min(8)) - 1) as u8
    }

    /// The hello frame.
    pub fn hello(&self) -> Frame {
        let mut h =
            Hello::new(&self.firmware, &self.board, self.sample_rate_hz, self.adc_bits, self.vref_mv, STRIDE as u8);
        for c in &self.channels {
            let _ = h.channels.push(c.clone());
        }
        Frame::Hello(h)
    }
}

/// The bench scale of a channel's part: deg/s per code (1 for a part without a built-in model).
pub fn dps_per_code(kind: SensorKind) -> f64 {
    GyroModel::of(kind).map_or(1.0, |g| Channel::bench(g).dps_per_code())
}

/// The ADC code of the ADXRS300 TEMP output at `temp_c` on the bench (2.50 V at 25 degC, 8.4 mV/K, through the
/// rate output's 2/3 divider): what the firmware's temperature channel reads.
pub fn temperature_code(temp_c: f64) -> u16 {
    let ch = Channel::bench(ADXRS300);
    let t = ADXRS300.temp_output.expect("the ADXRS300 has a TEMP output");
    ch.adc.quantize(ch.front.apply(t.mv_at_25c + t.mv_per_c * (temp_c - 25.0)))
}

/// Temperature in degC from the mean code of the temperature channel (the firmware's `temperature_c`).
pub fn temperature_c(mean_code: f64) -> f32 {
    let ch = Channel::bench(ADXRS300);
    let t = ADXRS300.temp_output.expect("the ADXRS300 has a TEMP output");
    let sensor_mv = ch.front.invert((mean_code + 0.5) * ch.adc.mv_per_code());
    (25.0 + (sensor_mv - t.mv_at_25c) / t.mv_per_c) as f32
}

/// The simulated device.
#[derive(Clone, Debug)]
pub struct DeviceSim {
    cfg: DeviceConfig,
    enc: Encoder,
    accs: Vec<OctaveAllan<STRIDE>>,
    /// Snapshots pooled before the last gap or reset.
    base: Vec<Snapshot>,
    /// Scans accumulated since boot or reset.
    samples: u64,
    /// Scans until the next round.
    until_round: u64,
    raw_mask: u8,
    temp_sum: u64,
    temp_n: u32,
    /// Scan index since boot of the next scan (jumps over lost samples).
    next_scan: u64,
    /// The scan index (since boot) of this session's first scan: raw samples are numbered from it, as the
    /// firmware's `Characterizer` does, so a reset starts the raw index at 0 again. `None` until the first block
    /// of the session.
    origin: Option<u64>,
    /// The scans of the block being filled.
    block: Vec<u16>,
    block_first: u64,
    gap_before: bool,
    adc_overruns: u32,
    frames_dropped: u32,
    drop_next: u32,
}

impl DeviceSim {
    /// A device just booted, streaming raw codes of the channels in `raw_mask` (0: none).
    ///
    /// # Panics
    /// If the configuration has no channel, more gyros than channels, or blocks that do not fit whole raw frames.
    pub fn new(cfg: DeviceConfig, raw_mask: u8) -> Self {
        assert!(!cfg.channels.is_empty() && cfg.channels.len() <= 8 && cfg.gyros <= cfg.channels.len());
        assert!(cfg.block_sets > 0 && cfg.raw_sets_per_frame > 0 && cfg.snapshot_every > 0);
        assert!(cfg.raw_sets_per_frame * cfg.width() <= octavar_shared::proto::MAX_CODES);
        let empty = Snapshot::empty(STRIDE).expect("power of two");
        DeviceSim {
            accs: vec![OctaveAllan::new(); cfg.gyros],
            base: vec![empty; cfg.gyros],
            samples: 0,
            until_round: cfg.snapshot_every,
            raw_mask: raw_mask & cfg.all_channels_mask(),
            temp_sum: 0,
            temp_n: 0,
            next_scan: 0,
            origin: None,
            block: Vec::with_capacity(cfg.block_sets * cfg.width()),
            block_first: 0,
            gap_before: false,
            adc_overruns: 0,
            frames_dropped: 0,
            drop_next: 0,
            enc: Encoder::new(),
            cfg,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &DeviceConfig {
        &self.cfg
    }

    /// Scans accumulated since boot or the last reset.
    pub fn samples(&self) -> u64 {
        self.samples
    }

    /// The pooled snapshot of gyro `g` now.
    pub fn snapshot(&self, g: usize) -> Snapshot {
        let mut s = self.base[g];
        let _ = s.merge(&self.accs[g].snapshot());
        s
    }

    /// Send a frame (or drop it, counting the drop, while [`DeviceSim::drop_next_frames`] is in effect).
    fn send(&mut self, frame: &Frame, out: &mut Vec<u8>) {
        match self.enc.encode_to_vec(frame) {
            Ok(bytes) if self.drop_next == 0 => out.extend_from_slice(&bytes),
            Ok(_) => {
                self.drop_next -= 1;
                self.frames_dropped += 1;
            }
            Err(e) => panic!("every frame fits by construction: {e}"),
        }
    }

    /// The next `n` frames are dropped as if the link were busy: their sequence numbers go missing.
    pub fn drop_next_frames(&mut self, n: u32) {
        self.drop_next += n;
    }

    /// Start-up: the hello frame.
    pub fn boot(&mut self, out: &mut Vec<u8>) {
        let hello = self.cfg.hello();
        self.send(&hello, out);
    }

    /// Act on a host command (as the firmware's `Characterizer::command`).
    pub fn command(&mut self, cmd: Command, out: &mut Vec<u8>) {
        match cmd {
            Command::StartRaw { channel_mask } => self.raw_mask = channel_mask & self.cfg.all_channels_mask(),
            Command::StopRaw => self.raw_mask = 0,
            Command::Reset => {
                let empty = Snapshot::empty(STRIDE).expect("power of two");
                self.accs.iter_mut().for_each(OctaveAllan::reset);
                self.base.iter_mut().for_each(|b| *b = empty);
                self.samples = 0;
                self.until_round = self.cfg.snapshot_every;
                self.temp_sum = 0;
                self.temp_n = 0;
                self.origin = None;
            }
            Command::Hello => self.boot(out),
            Command::ReadFieldLog { .. } => {}
        }
    }

    /// `n` samples are lost before the next scan (an ADC overrun): the next block starts after a gap.
    ///
    /// Completes the block in progress first, as the sampler does when it restarts the ADC.
    pub fn lose_samples(&mut self, n: u64, out: &mut Vec<u8>) {
        self.flush_block(out);
        self.next_scan += n;
        self.gap_before = true;
        self.adc_overruns += 1;
    }

    /// One scan: one code per channel, in channel order. Blocks are processed when full.
    ///
    /// # Panics
    /// If `scan` does not have one code per channel.
    pub fn push_scan(&mut self, scan: &[u16], out: &mut Vec<u8>) {
        assert_eq!(scan.len(), self.cfg.width(), "one code per channel");
        if self.block.is_empty() {
            self.block_first = self.next_scan;
        }
        self.block.extend_from_slice(scan);
        self.next_scan += 1;
        if self.block.len() == self.cfg.block_sets * self.cfg.width() {
            self.flush_block(out);
        }
    }

    /// Process a partially filled block now (the end of a run).
    pub fn flush_block(&mut self, out: &mut Vec<u8>) {
        if self.block.is_empty() {
            return;
        }
        let block = std::mem::take(&mut self.block);
        self.feed(self.block_first, &block, out);
        self.block = block;
        self.block.clear();
    }

    /// The firmware's `Characterizer::feed` for one block of scans starting at scan `first_sample`.
    fn feed(&mut self, first_sample: u64, codes: &[u16], out: &mut Vec<u8>) {
        let width = self.cfg.width();
        if std::mem::take(&mut self.gap_before) {
            for g in 0..self.cfg.gyros {
                let s = self.accs[g].snapshot();
                let _ = self.base[g].merge(&s);
                self.accs[g].reset();
            }
        }
        let origin = *self.origin.get_or_insert(first_sample);
        if self.raw_mask != 0 {
            self.stream_raw(first_sample - origin, codes, out);
        }
        let sets = codes.len() / width;
        let mut at = 0;
        while at < sets {
            let n = (sets - at).min(self.until_round as usize);
            let chunk = &codes[at * width..(at + n) * width];
            for (g, acc) in self.accs.iter_mut().enumerate() {
                for set in chunk.chunks_exact(width) {
                    acc.push(set[g]);
                }
            }
            if let Some(t) = self.cfg.temp_channel {
                for set in chunk.chunks_exact(width) {
                    self.temp_sum += u64::from(set[t]);
                }
                self.temp_n += n as u32;
            }
            self.samples += n as u64;
            self.until_round -= n as u64;
            at += n;
            if self.until_round == 0 {
                self.until_round = self.cfg.snapshot_every;
                self.round(out);
            }
        }
    }

    fn stream_raw(&mut self, first_sample: u64, codes: &[u16], out: &mut Vec<u8>) {
        let (mask, width, per) = (self.raw_mask, self.cfg.width(), self.cfg.raw_sets_per_frame);
        for frame in Samples::pack_scans(first_sample, mask, width, per, codes) {
            self.send(&Frame::Samples(frame), out);
        }
    }

    /// A snapshot round: the parts of every gyro's snapshot, the estimate, the status.
    fn round(&mut self, out: &mut Vec<u8>) {
        let mut est = Estimate { samples: self.samples, channels: heapless::Vec::new() };
        for g in 0..self.cfg.gyros {
            let snap = self.snapshot(g);
            for part in SnapshotPart::split(g as u8, &snap) {
                self.send(&Frame::AllanSnapshot(part), out);
            }
            let cfg = EstimateConfig {
                sample_rate_hz: self.cfg.sample_rate_hz as f32,
                dps_per_code: dps_per_code(self.cfg.channels[g].kind) as f32,
                min_independent: 4,
            };
            let _ = est.channels.push(ChannelEstimate::new(g as u8, &estimate(&snap, &cfg)));
        }
        if self.cfg.gyros > 0 {
            self.send(&Frame::Estimate(est), out);
        }
        let temperature_c = (self.temp_n > 0).then(|| temperature_c(self.temp_sum as f64 / f64::from(self.temp_n)));
        self.temp_sum = 0;
        self.temp_n = 0;
        let status = Status {
            uptime_ms: self.next_scan * 1000 / u64::from(self.cfg.sample_rate_hz.max(1)),
            samples_per_channel: self.samples,
            adc_overruns: self.adc_overruns,
            frames_dropped: self.frames_dropped,
            temperature_c,
        };
        self.send(&Frame::Status(status), out);
    }
}

/// The whole frame stream of a device that boots with raw streaming of `raw_mask` and samples `scans`
/// (each one code per channel of `cfg`); a final partial block is processed too.
pub fn device_frames<I, S>(cfg: DeviceConfig, raw_mask: u8, scans: I) -> Vec<u8>
where
    I: IntoIterator<Item = S>,
    S: AsRef<[u16]>,
{
    let mut dev = DeviceSim::new(cfg, raw_mask);
    let mut out = Vec::new();
    dev.boot(&mut out);
    for s in scans {
        dev.push_scan(s.as_ref(), &mut out);
    }
    dev.flush_block(&mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::decode::{CaptureReader, Record};

    fn scans(n: u32) -> impl Iterator<Item = [u16; 5]> {
        (0..n).map(|i| {
            let x = (i.wrapping_mul(2654435761) >> 22) as u16;
            [2000 + x % 97, 2000 + x % 13, 1900 + x % 31, 2048 + x % 5, 1950]
        })
    }

    #[test]
    fn frame_order_is_the_firmwares() {
        let wire = device_frames(DeviceConfig::firmware(), 0x1f, scans(2100));
        let kinds: Vec<&str> = CaptureReader::new(&wire[..], "sim")
            .map(|d| match d.unwrap().record {
                Record::Hello(_) => "hello",
                Record::Samples(_) => "samples",
                Record::Snapshot(_) => "snapshot",
                Record::Status(_) => "status",
                Record::Estimate(_) => "estimate",
                _ => "other",
            })
            .collect();
        // 2100 scans: blocks of 128, the round falls inside the 16th block (after its raw frames).
        assert_eq!(kinds[0], "hello");
        let first_snapshot = kinds.iter().position(|k| *k == "snapshot").unwrap();
        assert_eq!(first_snapshot, 1 + 16 * 4);
        assert_eq!(
            &kinds[first_snapshot..first_snapshot + 6],
            ["snapshot", "snapshot", "snapshot", "snapshot", "estimate", "status"]
        );
        // The partial last block (52 scans) still streams its raw codes.
        assert_eq!(kinds.len(), 1 + 64 + 6 + 2);
    }

    #[test]
    fn a_reset_restarts_the_raw_index_as_the_firmware_does() {
        let mut dev = DeviceSim::new(DeviceConfig::firmware(), 0x01);
        let mut out = Vec::new();
        dev.boot(&mut out);
        let block = DeviceConfig::firmware().block_sets as u64;
        for s in scans(3 * block as u32) {
            dev.push_scan(s.as_ref(), &mut out);
        }
        dev.command(Command::Reset, &mut out);
        dev.lose_samples(5, &mut out);
        for s in scans(2 * block as u32) {
            dev.push_scan(s.as_ref(), &mut out);
        }
        let firsts: Vec<u64> = CaptureReader::new(&out[..], "sim")
            .filter_map(|d| match d.unwrap().record {
                Record::Samples(s) => Some(s.first_sample),
                _ => None,
            })
            .collect();
        let per = DeviceConfig::firmware().raw_sets_per_frame as u64;
        // Before the reset: 0, per, ... ; after it the index starts at 0 again (the lost samples before the
        // session's first block are not a gap within the session).
        let after: Vec<u64> = firsts.iter().copied().skip((3 * block / per) as usize).collect();
        assert_eq!(firsts[0], 0);
        assert_eq!(after[0], 0, "{firsts:?}");
        assert_eq!(after[1], per, "{firsts:?}");
        assert_eq!(dev.samples(), 2 * block);
    }

    #[test]
    fn temperature_code_round_trips() {
        for t in [20.0, 22.5, 25.0, 31.0] {
            let back = temperature_c(f64::from(temperature_code(t)));
            assert!((f64::from(back) - t).abs() < 0.2, "{t} -> {back}");
        }
    }

    #[test]
    fn device_snapshot_is_the_plain_accumulator_without_gaps() {
        let mut dev = DeviceSim::new(DeviceConfig::firmware(), 0);
        let mut out = Vec::new();
        let mut acc = OctaveAllan::<8>::new();
        for s in scans(5000) {
            dev.push_scan(&s, &mut out);
            acc.push(s[2]);
        }
        dev.flush_block(&mut out);
        assert_eq!(dev.snapshot(2), acc.snapshot());
    }
}

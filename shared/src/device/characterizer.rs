//! The characterizer: sample blocks in; snapshots, estimates, status and (on command) raw samples out.
//!
//! It feeds one exact octave Allan accumulator (`OctaveAllan<8>`) per gyro channel and, every
//! [`DeviceConfig::snapshot_every`] scans, sends a snapshot round through its [`FrameSink`]: the snapshot of each
//! gyro (split into parts that fit a frame), the onboard estimate of N and B, and a status frame. The firmware's
//! characterize task and the host's device simulator are this code with a different sink.
//!
//! # Gaps
//! Blocks carry the hardware index of their first scan (the sampler's trigger count since boot). A block that
//! does not start where the previous one ended follows a gap: the scans between were lost (an ADC overrun, a
//! flash erase that outlasted the ring, a characterizer that fell behind), and the gap's size is exact. The
//! accumulators are *pooled* across it: their snapshot is merged into a base and they restart, so no Allan
//! difference straddles the gap ([`Snapshot::merge`]). The raw samples show the gap as the same jump in
//! `first_sample`, and the status frame counts the lost scans, so a host replay pools at the same place and
//! matches bit for bit.
//!
//! # Sessions
//! A reset ([`Command::Reset`]) starts a new session: empty accumulators, and the raw sample index
//! ([`Samples::first_sample`]) back to 0 at the first block after the reset, so a host lines the raw samples up
//! with the new accumulators as after a boot. Scans lost before that block are not a gap of the new session.

use crate::acc::{OctaveAllan, Snapshot};
use crate::device::config::{DeviceConfig, STRIDE};
use crate::estimate::{noise_estimate, EstimateConfig};
use crate::proto::{Ack, ChannelEstimate, Command, Estimate, Frame, Samples, SnapshotPart, Status};
use crate::sensor;

/// Scans gathered per channel before they are pushed into its accumulator.
const GATHER: usize = 64;

/// Where the characterizer's frames go: the firmware's frame queue, or the host simulator's byte vector.
///
/// Sending never blocks: a sink that cannot take a frame drops it and counts the drop.
pub trait FrameSink {
    /// Queue one frame (or drop it and count the drop).
    fn send(&mut self, frame: &Frame);
    /// Frames dropped since boot, for the status frame.
    fn frames_dropped(&self) -> u32;
    /// The stack's high-water mark since boot, bytes, for the status frame (`None`: not measured).
    fn stack_peak_bytes(&self) -> Option<u32> {
        None
    }
    /// A snapshot round is complete: every gyro's pooled snapshot this session, the sample losses since boot and
    /// the scans accumulated this session (what the field log checkpoints). Called after the round's frames.
    fn round(&mut self, snapshots: &[Snapshot], losses: u32, samples: u64) {
        let _ = (snapshots, losses, samples);
    }
}

/// The characterizer's state: accumulators, pooled bases, the schedule, raw streaming, loss counters.
#[derive(Clone, Debug)]
pub struct Characterizer<'a, const G: usize> {
    cfg: DeviceConfig<'a>,
    accs: [OctaveAllan<STRIDE>; G],
    /// Snapshots pooled before the last gap (or reset).
    base: [Snapshot; G],
    /// Scans accumulated this session.
    samples: u64,
    /// Hardware index of this session's first scan: raw samples are numbered from it. `None` until the first
    /// block of the session.
    origin: Option<u64>,
    /// Hardware index the next block should start at (`None` before the first block since boot).
    next_index: Option<u64>,
    /// Scans until the next snapshot round.
    until_round: u64,
    /// Channels streamed raw (0: off).
    raw_mask: u8,
    /// Sum and count of temperature codes since the last round.
    temp_sum: u64,
    temp_n: u32,
    /// Scans lost this session (the sum of its gaps).
    samples_lost: u64,
    /// Loss events since boot.
    losses: u32,
}

impl<'a, const G: usize> Characterizer<'a, G> {
    /// A device just booted: empty accumulators, raw streaming of the channels in `raw_mask` (0: none).
    ///
    /// A `const fn`, so the firmware can place its characterizer (19 KiB) in a static at build time rather than
    /// build it on the stack.
    ///
    /// # Panics
    /// If `cfg` is not [`DeviceConfig::is_valid`] or does not have `G` gyros (a build-time mistake).
    pub const fn new(cfg: DeviceConfig<'a>, raw_mask: u8) -> Self {
        assert!(cfg.is_valid() && cfg.gyros == G, "a device configuration with G gyros");
        let empty = DeviceConfig::empty_snapshot();
        Self {
            accs: [const { OctaveAllan::new() }; G],
            base: [empty; G],
            samples: 0,
            origin: None,
            next_index: None,
            until_round: cfg.snapshot_every,
            raw_mask: raw_mask & cfg.all_channels_mask(),
            temp_sum: 0,
            temp_n: 0,
            samples_lost: 0,
            losses: 0,
            cfg,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &DeviceConfig<'a> {
        &self.cfg
    }

    /// The hello frame of this device.
    pub fn hello(&self) -> Frame {
        self.cfg.hello()
    }

    /// Scans accumulated this session.
    pub fn samples(&self) -> u64 {
        self.samples
    }

    /// Scans lost this session.
    pub fn samples_lost(&self) -> u64 {
        self.samples_lost
    }

    /// Loss events since boot.
    pub fn losses(&self) -> u32 {
        self.losses
    }

    /// The channels streamed raw.
    pub fn raw_mask(&self) -> u8 {
        self.raw_mask
    }

    /// The hardware index the next block is expected at (`None` before the first block).
    pub fn next_index(&self) -> Option<u64> {
        self.next_index
    }

    /// The pooled snapshot of gyro `g`: the base merged with the running accumulator.
    pub fn snapshot(&self, g: usize) -> Snapshot {
        let mut s = self.base[g];
        // Same stride by construction.
        let _ = s.merge(&self.accs[g].snapshot());
        s
    }

    /// Act on a host command that arrived with sequence number `seq`, and acknowledge it with that number.
    /// [`Command::ReadFieldLog`] and [`Command::Checkpoint`] are the field log's (the firmware routes them there);
    /// they are not acknowledged here.
    pub fn command(&mut self, seq: u32, cmd: Command, sink: &mut impl FrameSink) {
        match cmd {
            Command::StartRaw { channel_mask } => self.raw_mask = channel_mask & self.cfg.all_channels_mask(),
            Command::StopRaw => self.raw_mask = 0,
            Command::Reset => self.reset(),
            Command::Hello => sink.send(&self.hello()),
            Command::ReadFieldLog { .. } | Command::Checkpoint => return,
        }
        sink.send(&Frame::Ack(Ack { seq }));
    }

    /// Back to the state of [`Characterizer::new`] with raw streaming of `raw_mask`, in place.
    pub fn restart(&mut self, raw_mask: u8) {
        self.reset();
        self.next_index = None;
        self.losses = 0;
        self.raw_mask = raw_mask & self.cfg.all_channels_mask();
    }

    /// Start a new session (see the module docs); raw streaming and the loss count since boot carry on.
    pub fn reset(&mut self) {
        let empty = DeviceConfig::empty_snapshot();
        self.accs.iter_mut().for_each(OctaveAllan::reset);
        self.base.iter_mut().for_each(|b| *b = empty);
        self.samples = 0;
        self.origin = None;
        self.until_round = self.cfg.snapshot_every;
        self.temp_sum = 0;
        self.temp_n = 0;
        self.samples_lost = 0;
    }

    /// Feed one block of whole scans (`codes[scan * width + channel]`) whose first scan has hardware index
    /// `first_index`: pool across a gap, stream the raw codes, accumulate, and send a snapshot round on each
    /// round boundary. A trailing partial scan is ignored.
    pub fn feed(&mut self, first_index: u64, codes: &[u16], sink: &mut impl FrameSink) {
        let width = self.cfg.width();
        let scans = codes.len() / width;
        let codes = &codes[..scans * width];
        if let Some(expected) = self.next_index {
            if first_index != expected {
                self.losses = self.losses.saturating_add(1);
                if self.origin.is_some() {
                    // An index that went back (a restarted counter) is a discontinuity too: pool, lose nothing.
                    self.samples_lost += first_index.saturating_sub(expected);
                    self.pool();
                }
            }
        }
        self.next_index = Some(first_index + scans as u64);
        let origin = *self.origin.get_or_insert(first_index);
        if self.raw_mask != 0 {
            let first = first_index.saturating_sub(origin);
            let (mask, per) = (self.raw_mask, self.cfg.raw_scans_per_frame);
            for frame in Samples::pack_scans(first, mask, width, per, codes) {
                sink.send(&Frame::Samples(frame));
            }
        }
        let mut at = 0;
        while at < scans {
            let n = (scans - at).min(self.until_round as usize);
            let chunk = &codes[at * width..(at + n) * width];
            // Each gyro's codes gathered out of the interleaved scans, then pushed as a slice: the accumulator
            // keeps its every-sample state in registers across a slice, not across single pushes.
            let mut gathered = [0u16; GATHER];
            for (g, acc) in self.accs.iter_mut().enumerate() {
                for part in chunk.chunks(GATHER * width) {
                    let k = part.len() / width;
                    for (code, scan) in gathered.iter_mut().zip(part.chunks_exact(width)) {
                        *code = scan[g];
                    }
                    acc.push_slice(&gathered[..k]);
                }
            }
            if let Some(t) = self.cfg.temp_channel {
                for scan in chunk.chunks_exact(width) {
                    self.temp_sum += u64::from(scan[t]);
                }
                self.temp_n += n as u32;
            }
            self.samples += n as u64;
            self.until_round -= n as u64;
            at += n;
            if self.until_round == 0 {
                self.until_round = self.cfg.snapshot_every;
                self.round(first_index + at as u64, sink);
            }
        }
    }

    /// Merge the running accumulators into the base and restart them.
    fn pool(&mut self) {
        for (base, acc) in self.base.iter_mut().zip(self.accs.iter_mut()) {
            let _ = base.merge(&acc.snapshot());
            acc.reset();
        }
    }

    /// A round is complete, `scans_since_boot` scans into the hardware count: snapshots, estimate, status; then
    /// the sink's round hook.
    fn round(&mut self, scans_since_boot: u64, sink: &mut impl FrameSink) {
        let mut snapshots = [DeviceConfig::empty_snapshot(); G];
        let mut est = Estimate { samples: self.samples, channels: heapless::Vec::new() };
        for (g, snap) in snapshots.iter_mut().enumerate() {
            *snap = self.snapshot(g);
            for part in SnapshotPart::split(g as u8, snap) {
                sink.send(&Frame::AllanSnapshot(part));
            }
            let cfg = EstimateConfig {
                rate_hz: self.cfg.rate_hz as f32,
                dps_per_code: sensor::dps_per_code(self.cfg.channels[g].kind) as f32,
                min_independent: 4,
            };
            let _ = est.channels.push(ChannelEstimate::new(g as u8, &noise_estimate(snap, &cfg)));
        }
        if G > 0 {
            sink.send(&Frame::Estimate(est));
        }
        let temperature_c =
            (self.temp_n > 0).then(|| sensor::temperature_c(self.temp_sum as f64 / f64::from(self.temp_n)));
        self.temp_sum = 0;
        self.temp_n = 0;
        sink.send(&Frame::Status(Status {
            uptime_ms: scans_since_boot * 1000 / u64::from(self.cfg.rate_hz),
            samples_per_channel: self.samples,
            adc_overruns: self.losses,
            frames_dropped: sink.frames_dropped(),
            temperature_c,
            samples_lost: self.samples_lost,
            stack_peak_bytes: sink.stack_peak_bytes(),
        }));
        sink.round(&snapshots, self.losses, self.samples);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proto::{Frame, Status};
    use std::vec::Vec;

    /// A sink that keeps the frames.
    #[derive(Default)]
    struct Kept(Vec<Frame>);

    impl FrameSink for Kept {
        fn send(&mut self, frame: &Frame) {
            self.0.push(frame.clone());
        }
        fn frames_dropped(&self) -> u32 {
            0
        }
    }

    fn scan(i: u64) -> [u16; 5] {
        let x = (i.wrapping_mul(2_654_435_761) >> 7) as u16;
        [2000 + x % 97, 2000 + x % 13, 1900 + x % 31, 2048 + x % 5, 1950]
    }

    fn block(first: u64, scans: u64) -> Vec<u16> {
        (first..first + scans).flat_map(scan).collect()
    }

    fn statuses(k: &Kept) -> Vec<Status> {
        k.0.iter().filter_map(|f| if let Frame::Status(s) = f { Some(s.clone()) } else { None }).collect()
    }

    #[test]
    fn interleaved_blocks_accumulate_as_one_push_per_sample() {
        // Blocks of odd sizes, gathered per gyro and pushed as slices, against an independent per-sample push.
        let mut core = Characterizer::<4>::new(DeviceConfig::F405, 0);
        let mut refs = [const { OctaveAllan::<STRIDE>::new() }; 4];
        let mut sink = Kept::default();
        let mut at = 0;
        for len in [1u64, 63, 64, 65, 128, 200, 3, 4000] {
            core.feed(at, &block(at, len), &mut sink);
            for i in at..at + len {
                for (g, r) in refs.iter_mut().enumerate() {
                    r.push(scan(i)[g]);
                }
            }
            at += len;
        }
        for (g, r) in refs.iter().enumerate() {
            assert_eq!(core.snapshot(g), r.snapshot(), "gyro {g}");
        }
        // A round every 2000 scans, the uptime from the hardware index.
        let s = statuses(&sink);
        assert_eq!(s.len() as u64, at / 2000);
        assert_eq!((s[0].uptime_ms, s[0].samples_per_channel, s[0].samples_lost), (1000, 2000, 0));
    }

    #[test]
    fn a_jump_in_the_index_is_a_pooled_gap_of_exactly_that_size() {
        let mut core = Characterizer::<4>::new(DeviceConfig::F405, 0);
        let mut sink = Kept::default();
        core.feed(0, &block(0, 1500), &mut sink);
        core.feed(1500 + 777, &block(1500 + 777, 1000), &mut sink);
        assert_eq!((core.samples(), core.samples_lost(), core.losses()), (2500, 777, 1));
        // The pooled snapshot: the two parts merged, no difference across the gap.
        let mut a = OctaveAllan::<STRIDE>::new();
        let mut b = OctaveAllan::<STRIDE>::new();
        (0..1500).for_each(|i| a.push(scan(i)[2]));
        (2277..3277).for_each(|i| b.push(scan(i)[2]));
        let mut want = a.snapshot();
        want.merge(&b.snapshot()).unwrap();
        assert_eq!(core.snapshot(2), want);
        let s = statuses(&sink);
        assert_eq!((s[0].samples_lost, s[0].adc_overruns, s[0].uptime_ms), (777, 1, (2000 + 777) / 2));
    }

    #[test]
    fn commands_take_effect_and_are_acknowledged_with_their_number() {
        let mut core = Characterizer::<4>::new(DeviceConfig::F405, 0);
        let mut sink = Kept::default();
        core.feed(0, &block(0, 640), &mut sink);
        core.command(41, Command::StartRaw { channel_mask: 0xff }, &mut sink);
        assert_eq!(core.raw_mask(), 0x1f, "the mask is cut to the channels there are");
        assert_eq!(sink.0.last(), Some(&Frame::Ack(Ack { seq: 41 })));
        core.command(42, Command::Reset, &mut sink);
        assert_eq!(sink.0.last(), Some(&Frame::Ack(Ack { seq: 42 })));
        // After the reset, scans lost before the session's first block are not the session's gap, and the raw
        // index starts at 0 again.
        core.feed(1000, &block(1000, 64), &mut sink);
        assert_eq!((core.samples(), core.samples_lost(), core.losses()), (64, 0, 1));
        let raw: Vec<u64> =
            sink.0.iter().filter_map(|f| if let Frame::Samples(s) = f { Some(s.first_sample) } else { None }).collect();
        assert_eq!(raw, [0, 32]);
        // A field-log read is the store's: no ack from here.
        let n = sink.0.len();
        core.command(43, Command::ReadFieldLog { from_checkpoint: 0 }, &mut sink);
        assert_eq!(sink.0.len(), n);
    }
}

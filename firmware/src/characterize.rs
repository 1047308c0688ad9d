//! The characterize task: sample blocks in; snapshots, estimates, status and (on command) raw samples out.
//!
//! It feeds one exact octave Allan accumulator (`OctaveAllan<8>`) per gyro channel and, every second of samples,
//! sends a snapshot round: the snapshot of each gyro (split into parts that fit a frame), the onboard estimate of
//! N and B, and a status frame. The same round goes to the store task through [`SNAPSHOT_READY`]. This code is
//! the same on the board and in QEMU: only the source of the blocks and the sink of the frames differ.
//!
//! Gaps: when the sampler loses samples (an ADC overrun, a flash erase stalling the CPU), the block after the gap
//! says so and the accumulators are *pooled* across it: their snapshot is merged into a base and they restart, so
//! no Allan difference straddles the gap ([`Snapshot::merge`]). The raw samples show the gap as a jump in
//! `first_sample`; a host replay pools at the same place and matches bit for bit.

use core::sync::atomic::Ordering;

use embassy_futures::select::{select, Either};
use embassy_sync::blocking_mutex::raw::{CriticalSectionRawMutex, NoopRawMutex};
use embassy_sync::channel::Channel;
use embassy_sync::signal::Signal;
use embassy_sync::zerocopy_channel;
use octavar_shared::acc::{OctaveAllan, Snapshot};
use octavar_shared::estimate::{estimate, EstimateConfig};
use octavar_shared::proto::{
    ChannelEstimate, ChannelInfo, Command, Estimate, Frame, Hello, Samples, SnapshotPart, Status,
};

use crate::config::*;
use crate::frames;

/// One block of scans from the sampler: `codes[set * CHANNELS + channel]`.
pub struct SampleBlock {
    /// Index of the first scan since boot (jumps over lost samples). The raw `Samples` frames count from the last
    /// reset instead (see [`Characterizer`]).
    pub first_sample: u64,
    /// Samples were lost just before this block.
    pub gap_before: bool,
    /// The codes, scan by scan.
    pub codes: [u16; BLOCK_CODES],
}

impl SampleBlock {
    /// An empty block (the zerocopy channel's storage starts with these).
    pub const EMPTY: SampleBlock = SampleBlock { first_sample: 0, gap_before: false, codes: [0; BLOCK_CODES] };
}

/// Receiving end of the sample blocks (sampler -> characterize).
pub type BlockReceiver = zerocopy_channel::Receiver<'static, NoopRawMutex, SampleBlock>;
/// Sending end of the sample blocks.
pub type BlockSender = zerocopy_channel::Sender<'static, NoopRawMutex, SampleBlock>;

/// One snapshot round, from characterize to the store task: only the latest matters.
#[derive(Clone, Copy)]
pub struct Round {
    /// The pooled snapshot of every gyro channel (this session only).
    pub snapshots: [Snapshot; GYROS],
    /// ADC overruns so far this session.
    pub adc_overruns: u32,
    /// Scans accumulated this session.
    pub samples: u64,
}

/// The latest snapshot round, characterize -> store.
pub static SNAPSHOT_READY: Signal<CriticalSectionRawMutex, Round> = Signal::new();
/// Host commands for characterize (raw streaming, reset, hello), from the link task.
pub static COMMANDS: Channel<CriticalSectionRawMutex, Command, 4> = Channel::new();

/// The hello frame: versions, board, rates and the channel list.
pub fn hello() -> Frame {
    let mut h = Hello::new(
        env!("CARGO_PKG_VERSION"),
        if cfg!(feature = "qemu") { "qemu netduinoplus2" } else { "STM32F405RG" },
        SAMPLE_RATE_HZ,
        12,
        3300,
        STRIDE as u8,
    );
    for (kind, name) in CHANNEL_KINDS {
        let _ = h.channels.push(ChannelInfo::new(kind, name));
    }
    Frame::Hello(h)
}

/// The characterize task's state: accumulators, pooled bases, raw streaming.
///
/// A reset (`Command::Reset`) starts a new session: empty accumulators, and the raw sample index
/// (`Samples::first_sample`) back to 0 at the first block after the reset, so that the host lines the raw
/// samples up with the new accumulators as after a boot. Gaps after that still show as jumps in the index.
pub struct Characterizer {
    accs: [OctaveAllan<STRIDE>; GYROS],
    /// Snapshots pooled before the last gap (or reset).
    base: [Snapshot; GYROS],
    /// Scans accumulated since boot or reset.
    samples: u64,
    /// The sampler's index (since boot) of this session's first scan: raw samples are numbered from it. `None`
    /// until the first block of the session.
    origin: Option<u64>,
    /// Scans until the next snapshot round.
    until_round: u64,
    /// Channels streamed raw (0: off).
    raw_mask: u8,
    /// Sum and count of temperature codes since the last round.
    temp_sum: u64,
    temp_n: u32,
}

impl Characterizer {
    /// A fresh state (empty accumulators, raw streaming `raw_mask`).
    pub fn new(raw_mask: u8) -> Self {
        let empty = Snapshot::empty(STRIDE).expect("stride is a power of two");
        Self {
            accs: [const { OctaveAllan::new() }; GYROS],
            base: [empty; GYROS],
            samples: 0,
            origin: None,
            until_round: SNAPSHOT_EVERY_SETS,
            raw_mask: raw_mask & ALL_CHANNELS_MASK,
            temp_sum: 0,
            temp_n: 0,
        }
    }

    /// Act on a host command.
    pub fn command(&mut self, cmd: Command) {
        match cmd {
            Command::StartRaw { channel_mask } => self.raw_mask = channel_mask & ALL_CHANNELS_MASK,
            Command::StopRaw => self.raw_mask = 0,
            Command::Reset => *self = Self::new(self.raw_mask),
            Command::Hello => frames::send(&hello()),
            // The link task routes field-log reads to the store task.
            Command::ReadFieldLog { .. } => {}
        }
        defmt::info!("command {}: raw mask {=u8:#x}", cmd, self.raw_mask);
    }

    /// The pooled snapshot of gyro `g`: the base merged with the running accumulator.
    pub fn snapshot(&self, g: usize) -> Snapshot {
        let mut s = self.base[g];
        // Same stride by construction.
        let _ = s.merge(&self.accs[g].snapshot());
        s
    }

    /// Feed one block: accumulate, stream raw codes, and send a snapshot round on each second boundary.
    pub fn feed(&mut self, block: &SampleBlock) {
        let origin = *self.origin.get_or_insert(block.first_sample);
        if block.gap_before {
            for g in 0..GYROS {
                let _ = self.base[g].merge(&self.accs[g].snapshot());
                self.accs[g].reset();
            }
        }
        if self.raw_mask != 0 {
            self.stream_raw(block, block.first_sample.saturating_sub(origin));
        }
        let mut at = 0;
        while at < BLOCK_SETS {
            let n = (BLOCK_SETS - at).min(self.until_round as usize);
            let codes = &block.codes[at * CHANNELS..(at + n) * CHANNELS];
            for (g, acc) in self.accs.iter_mut().enumerate() {
                for set in codes.chunks_exact(CHANNELS) {
                    acc.push(set[g]);
                }
            }
            for set in codes.chunks_exact(CHANNELS) {
                self.temp_sum += u64::from(set[TEMP_CHANNEL]);
            }
            self.temp_n += n as u32;
            self.samples += n as u64;
            self.until_round -= n as u64;
            at += n;
            if self.until_round == 0 {
                self.until_round = SNAPSHOT_EVERY_SETS;
                self.round();
            }
        }
    }

    /// Send the block's codes of the streamed channels; `first` is its first scan's index in this session.
    fn stream_raw(&self, block: &SampleBlock, first: u64) {
        for frame in Samples::pack_scans(first, self.raw_mask, CHANNELS, RAW_SETS_PER_FRAME, &block.codes) {
            frames::send(&Frame::Samples(frame));
        }
    }

    /// One second of samples is complete: snapshots, estimate, status; the round to the store task.
    fn round(&mut self) {
        let mut snapshots = [Snapshot::empty(STRIDE).expect("power of two"); GYROS];
        let mut est = Estimate { samples: self.samples, channels: heapless::Vec::new() };
        for (g, snap) in snapshots.iter_mut().enumerate() {
            *snap = self.snapshot(g);
            for part in SnapshotPart::split(g as u8, snap) {
                frames::send(&Frame::AllanSnapshot(part));
            }
            let ch = gyro_channel(g);
            let cfg = EstimateConfig {
                sample_rate_hz: SAMPLE_RATE_HZ as f32,
                dps_per_code: ch.dps_per_code() as f32,
                min_independent: 4,
            };
            let e = estimate(snap, &cfg);
            if let (Some(n), Some(b)) = (e.n_dps_per_rt_s, e.b_dps) {
                defmt::info!(
                    "{}: N {} deg/sqrt(h), B {} deg/h (tau {} s)",
                    CHANNEL_KINDS[g].1,
                    n * 60.0,
                    b * 3600.0,
                    e.tau_b_s.unwrap_or(0.0)
                );
            }
            let _ = est.channels.push(ChannelEstimate {
                channel: g as u8,
                n_dps_per_rt_s: e.n_dps_per_rt_s,
                b_dps: e.b_dps,
                tau_b_s: e.tau_b_s,
            });
        }
        frames::send(&Frame::Estimate(est));

        let temperature_c = (self.temp_n > 0).then(|| temperature_c(self.temp_sum as f64 / f64::from(self.temp_n)));
        self.temp_sum = 0;
        self.temp_n = 0;
        let adc_overruns = crate::ADC_OVERRUNS.load(Ordering::Relaxed);
        frames::send(&Frame::Status(Status {
            uptime_ms: embassy_time::Instant::now().as_millis(),
            samples_per_channel: self.samples,
            adc_overruns,
            frames_dropped: frames::FRAMES_DROPPED.load(Ordering::Relaxed),
            temperature_c,
        }));
        SNAPSHOT_READY.signal(Round { snapshots, adc_overruns, samples: self.samples });
    }
}

/// Feeds the accumulators from the sampler's blocks and acts on host commands.
#[embassy_executor::task]
pub async fn characterize_task(mut blocks: BlockReceiver, raw_mask: u8) {
    let mut c = Characterizer::new(raw_mask);
    frames::send(&hello());
    loop {
        match select(blocks.receive(), COMMANDS.receive()).await {
            Either::First(block) => {
                c.feed(block);
                blocks.receive_done();
            }
            Either::Second(cmd) => c.command(cmd),
        }
    }
}

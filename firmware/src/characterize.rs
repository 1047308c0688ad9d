//! The characterize task: the device core (`octavar_shared::device::Characterizer`) between the sampler's
//! blocks and the frame queue.
//!
//! Everything it computes (accumulators, snapshot rounds, the onboard estimate, raw streaming, pooling across
//! gaps, commands and their acknowledgements) is the shared core, which the host's device simulator runs too;
//! this task only moves blocks and commands in, frames out, and hands each snapshot round to the store task.

use core::sync::atomic::{AtomicU32, Ordering};

use embassy_futures::select::{select, Either};
use embassy_sync::blocking_mutex::raw::{CriticalSectionRawMutex, NoopRawMutex};
use embassy_sync::channel::Channel;
use embassy_sync::signal::Signal;
use embassy_sync::zerocopy_channel;
use octavar_shared::acc::Snapshot;
use octavar_shared::device::{Characterizer, DeviceConfig, FrameSink};
use octavar_shared::proto::{Command, Frame};
use static_cell::ConstStaticCell;

use crate::config::*;
use crate::frames;

/// One block of scans from the sampler: `codes[scan * CHANNELS + channel]`.
pub struct SampleBlock {
    /// Hardware index (the trigger count since boot) of the block's first scan: it jumps over lost scans.
    pub first_index: u64,
    /// The codes, scan by scan.
    pub codes: [u16; BLOCK_CODES],
}

impl SampleBlock {
    /// An empty block (the zerocopy channel's storage starts with these).
    pub const EMPTY: SampleBlock = SampleBlock { first_index: 0, codes: [0; BLOCK_CODES] };
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
    /// Sample losses since boot.
    pub adc_overruns: u32,
    /// Scans accumulated this session.
    pub samples: u64,
}

/// The latest snapshot round, characterize -> store.
pub static SNAPSHOT_READY: Signal<CriticalSectionRawMutex, Round> = Signal::new();
/// Host commands for characterize with their frame's sequence number, from the link task.
pub static COMMANDS: Channel<CriticalSectionRawMutex, (u32, Command), 4> = Channel::new();
/// Blocks characterize has taken: the watchdog is fed only while this moves.
pub static BLOCKS_TAKEN: AtomicU32 = AtomicU32::new(0);

/// The frame queue as the device core's sink; rounds go to the store task, estimates to the defmt log.
struct Queue;

impl FrameSink for Queue {
    fn send(&mut self, frame: &Frame) {
        if let Frame::Estimate(e) = frame {
            for c in &e.channels {
                if let (Some(n), Some(b)) = (c.n_dps_per_rt_s, c.b_dps) {
                    let name = DEVICE.channels[usize::from(c.channel)].name;
                    defmt::info!("{}: N {} deg/sqrt(h), B {} deg/h", name, n * 60.0, b * 3600.0);
                }
            }
        }
        frames::send(frame);
    }

    fn frames_dropped(&self) -> u32 {
        frames::FRAMES_DROPPED.load(Ordering::Relaxed)
    }

    fn stack_peak_bytes(&self) -> Option<u32> {
        Some(crate::stack::peak_bytes())
    }

    fn round(&mut self, snapshots: &[Snapshot], losses: u32, samples: u64) {
        let mut round = Round { snapshots: [DeviceConfig::empty_snapshot(); GYROS], adc_overruns: losses, samples };
        round.snapshots.copy_from_slice(snapshots);
        SNAPSHOT_READY.signal(round);
    }
}

/// The hello frame of this build.
pub fn hello() -> Frame {
    DEVICE.hello()
}

/// Channels streamed raw from boot: all of them in QEMU (so a host can replay every code), none on the board.
pub const RAW_AT_BOOT: u8 = if cfg!(feature = "qemu") { DEVICE.all_channels_mask() } else { 0 };

/// The device core, built at compile time in its static (19 KiB: too big to build on the stack and move).
static CORE: ConstStaticCell<Characterizer<'static, GYROS>> =
    ConstStaticCell::new(Characterizer::new(DEVICE, RAW_AT_BOOT));

/// The device core (once: the characterize task owns it; QEMU's benchmark borrows it first).
pub fn core() -> &'static mut Characterizer<'static, GYROS> {
    CORE.take()
}

/// One sample block into the device core, its frames into the frame queue (what the task does with each block;
/// QEMU's benchmark times it).
pub fn feed_block(core: &mut Characterizer<'static, GYROS>, block: &SampleBlock) {
    core.feed(block.first_index, &block.codes, &mut Queue);
}

/// Feeds the device core from the sampler's blocks and acts on host commands.
#[embassy_executor::task]
pub async fn characterize_task(mut blocks: BlockReceiver, core: &'static mut Characterizer<'static, GYROS>) {
    loop {
        match select(blocks.receive(), COMMANDS.receive()).await {
            Either::First(block) => {
                feed_block(core, block);
                blocks.receive_done();
                BLOCKS_TAKEN.fetch_add(1, Ordering::Relaxed);
                // The link takes this block's frames before the next block is fed, so the sampler's backlog
                // after a stall comes out as a stream of one block's frames at a time, not a burst of several
                // that the frame queue would drop. Bounded: a link that stops taking frames costs a block
                // [`DRAIN_LIMIT`], well inside the sampler's ring, and its frames are dropped as before.
                frames::drained_within(DRAIN_LIMIT).await;
            }
            Either::Second((seq, cmd)) => {
                core.command(seq, cmd, &mut Queue);
                defmt::info!("command {} ({}): raw mask {=u8:#x}", seq, cmd, core.raw_mask());
            }
        }
    }
}

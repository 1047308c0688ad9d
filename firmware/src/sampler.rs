//! The sampler task: scans from the DMA ring, located by the hardware scan counter, into sample blocks for
//! characterize. The same loop runs on the board (`adc.rs`: TIM3 -> ADC1 scan -> DMA2 ring, TIM5 counting the
//! triggers) and in QEMU (`qemu.rs`: a virtual ADC with the same ring and counter).
//!
//! The loop never waits on anything but its poll timer. Each poll is `octavar_shared::device::Sampler::poll`,
//! which the host tests run against a model of the converter with faults injected: check the converter, copy
//! each block the ring holds complete, check the converter again (a block goes on only if the converter was
//! still healthy when its copy ended), and hand it on with its first scan's hardware index. Which block is ready,
//! which the DMA overwrote while the CPU was away (a flash erase stalls every fetch), and how many scans that
//! cost is `RingReader`'s arithmetic on the counter. When characterize is behind, the blocks stay in the ring; if
//! it falls a whole ring behind, the lap is a gap like any other. Every loss reaches characterize as an exact
//! jump in the index.

use core::sync::atomic::{AtomicU32, Ordering};

use embassy_time::Ticker;
use octavar_shared::device::{BlockSink, ReadyBlock, Sampler, SamplerEvent};

use crate::characterize::BlockSender;
use crate::config::*;

/// The ring a converter fills and the sampler reads: the board's (`adc.rs`) and QEMU's virtual one.
pub use octavar_shared::device::ScanRing;

/// Hardware index of the next scan the sampler will hand on, low 32 bits (for the QEMU run's end and the logs;
/// the M4 has no 64-bit atomics).
pub static NEXT_SCAN: AtomicU32 = AtomicU32::new(0);
/// Scans in the ring the sampler has not handed on, at its last poll (the store waits for this to fall below a
/// block before it stalls the CPU on the flash).
pub static BACKLOG_SCANS: AtomicU32 = AtomicU32::new(0);
/// Scans lost since boot (skipped over in the ring, or dropped in a converter recovery), saturating.
pub static SCANS_LOST: AtomicU32 = AtomicU32::new(0);

/// Characterize's free blocks, as the poll fills and hands them on.
pub struct Blocks<'a>(pub &'a mut BlockSender);

impl BlockSink<BLOCK_CODES> for Blocks<'_> {
    fn free_block(&mut self) -> Option<&mut [u16; BLOCK_CODES]> {
        self.0.try_send().map(|b| &mut b.codes)
    }

    fn hand_on(&mut self, block: &ReadyBlock) {
        if block.skipped > 0 {
            defmt::warn!("sampler: {} scans lost before scan {}", block.skipped, block.first_index);
        }
        if let Some(b) = self.0.try_send() {
            b.first_index = block.first_index;
            self.0.send_done();
        }
    }

    fn note(&mut self, event: SamplerEvent) {
        match event {
            SamplerEvent::Restarted { first } => defmt::warn!("sampler: converter restarted at scan {}", first),
            SamplerEvent::Discarded { first_index, first } => defmt::warn!(
                "sampler: the converter failed during the copy of scan {}; restarted at scan {}",
                first_index,
                first
            ),
            SamplerEvent::Overtaken { first_index } => {
                defmt::warn!("sampler: the DMA overtook the copy of scan {}", first_index)
            }
        }
    }
}

/// Hand the ring's blocks to characterize, forever.
pub async fn run<R: ScanRing<BLOCK_CODES>>(ring: &mut R, mut blocks: BlockSender) -> ! {
    // Both converters number their first scan 0, in ring slot 0 (TIM5 starts at 0; so does QEMU's count).
    let mut sampler = Sampler::new(RING_SCANS, BLOCK_SCANS, 0);
    let mut ticker = Ticker::every(SAMPLER_POLL);
    loop {
        ticker.next().await;
        sampler.poll(ring, &mut Blocks(&mut blocks));
        NEXT_SCAN.store(sampler.next_index() as u32, Ordering::Relaxed);
        let backlog = ring.started().saturating_sub(sampler.next_index());
        BACKLOG_SCANS.store(backlog.min(u64::from(u32::MAX)) as u32, Ordering::Relaxed);
        SCANS_LOST.store(sampler.lost().min(u64::from(u32::MAX)) as u32, Ordering::Relaxed);
    }
}

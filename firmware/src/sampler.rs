//! The sampler task: scans from the DMA ring, located by the hardware scan counter, into sample blocks for
//! characterize. The same loop runs on the board (`adc.rs`: TIM3 -> ADC1 scan -> DMA2 ring, TIM5 counting the
//! triggers) and in QEMU (`qemu.rs`: a virtual ADC with the same ring and counter).
//!
//! The loop never waits on anything but its poll timer. Which block is ready, which the DMA overwrote while the
//! CPU was away (a flash erase stalls every fetch), and how many scans that cost is `RingReader`'s arithmetic on
//! the counter (shared, tested on the host). When characterize is behind, the blocks stay in the ring; if it
//! falls a whole ring behind, the lap is a gap like any other. Every block carries its first scan's hardware
//! index, so every loss reaches characterize as an exact jump.

use core::sync::atomic::{AtomicU32, Ordering};

use embassy_time::Ticker;
use octavar_shared::device::{ReadyBlock, RingReader};

use crate::characterize::BlockSender;
use crate::config::*;

/// Hardware index of the next scan the sampler will hand on, low 32 bits (for the QEMU run's end and the logs;
/// the M4 has no 64-bit atomics).
pub static NEXT_SCAN: AtomicU32 = AtomicU32::new(0);
/// Scans in the ring the sampler has not handed on, at its last poll (the store waits for this to fall below a
/// block before it stalls the CPU on the flash).
pub static BACKLOG_SCANS: AtomicU32 = AtomicU32::new(0);
/// Scans lost since boot (skipped over in the ring, or dropped in a converter recovery), saturating.
pub static SCANS_LOST: AtomicU32 = AtomicU32::new(0);

/// A ring of scans written by hardware (or its model) and the counter of scans started.
pub trait ScanRing {
    /// Scans started since boot: the hardware trigger count, extended to 64 bits.
    fn started(&mut self) -> u64;
    /// Copy the block's [`BLOCK_SCANS`] scans (from ring slot `block.slot` on, contiguous) into `out`.
    fn copy_block(&mut self, block: &ReadyBlock, out: &mut [u16; BLOCK_CODES]);
    /// Check the converter and recover it if it failed: `Some(first)` when the DMA was re-armed at slot 0 and
    /// its first scan there will be the one with hardware index `first`.
    fn check(&mut self) -> Option<u64>;
}

/// Hand the ring's blocks to characterize, forever.
pub async fn run<R: ScanRing>(ring: &mut R, mut blocks: BlockSender) -> ! {
    let mut reader = RingReader::new(RING_SCANS, BLOCK_SCANS);
    let mut ticker = Ticker::every(SAMPLER_POLL);
    loop {
        ticker.next().await;
        if let Some(first) = ring.check() {
            reader.restart_at(first);
            defmt::warn!("sampler: converter restarted at scan {}", first);
        }
        while let Some(ready) = reader.poll(ring.started()) {
            // Characterize is behind: the scans wait in the ring.
            let Some(block) = blocks.try_send() else { break };
            ring.copy_block(&ready, &mut block.codes);
            if !reader.confirm(ring.started()) {
                defmt::warn!("sampler: the DMA overtook the copy of scan {}", ready.first_index);
                continue;
            }
            if ready.skipped > 0 {
                defmt::warn!("sampler: {} scans lost before scan {}", ready.skipped, ready.first_index);
            }
            block.first_index = ready.first_index;
            blocks.send_done();
        }
        NEXT_SCAN.store(reader.next_index() as u32, Ordering::Relaxed);
        let backlog = ring.started().saturating_sub(reader.next_index());
        BACKLOG_SCANS.store(backlog.min(u64::from(u32::MAX)) as u32, Ordering::Relaxed);
        SCANS_LOST.store(reader.lost().min(u64::from(u32::MAX)) as u32, Ordering::Relaxed);
    }
}

//! The per-sample cost on QEMU (feature `qemu`), measured at start-up and printed through semihosting.
//!
//! QEMU counts no cycles, but with `-icount shift=0` each instruction advances virtual time by exactly 1 ns, and
//! the time base counts virtual time: virtual nanoseconds per sample are instructions per sample. Two figures:
//! - `Characterizer::feed` alone: the device core on blocks of interleaved scans (four gyros and the
//!   temperature), snapshot rounds, estimates and frame encoding included, raw streaming off;
//! - the whole path a sample takes on the board: the sampler's poll (`Sampler::poll`: the converter check,
//!   the volatile copy of the block out of a DMA ring, the check after it, the hand-off through the zerocopy
//!   channel), characterize's receive and `feed` with the real frame queue as its sink. The frame queue is
//!   emptied between blocks outside the timed part (that is the link's work), and the last round it handed the
//!   store is taken back (it is no session of the device).
//!
//! The cycle estimate beside it: the hot loops run from the ART's instruction cache (64 lines of 128 bits) at
//! 168 MHz with 5 wait states, so a cache hit costs what the Cortex-M4 TRM's instruction timings give (1 cycle,
//! 2 for a load, 2-4 for a taken branch); an instruction averages about 1.3 cycles there. A fetch that misses the
//! cache waits 5 cycles per 16-byte line (4 to 8 instructions), so the bound, every line missed, is 2.5 cycles
//! per instruction.

use core::hint::black_box;

use cortex_m_semihosting::hprintln;
use octavar_shared::device::{Characterizer, FrameSink, ReadyBlock, Sampler};
use octavar_shared::proto::{encode_to_vec, Frame};
use static_cell::StaticCell;

use crate::characterize::{self, BlockReceiver, BlockSender};
use crate::config::*;
use crate::frames::FRAMES_OUT;
use crate::sampler::{Blocks, ScanRing};
use crate::timebase;

/// Blocks timed by each benchmark: 32 000 scans, 16 snapshot rounds.
const BLOCKS: u64 = 250;
/// Average cycles per instruction from the ART's cache, and every fetch missing it.
const CPI_CACHED: f64 = 1.3;
const CPI_WORST: f64 = 2.5;

/// Encodes the core's frames and drops them.
struct EncodeOnly;

impl FrameSink for EncodeOnly {
    fn send(&mut self, frame: &Frame) {
        black_box(encode_to_vec(0, frame).ok());
    }
    fn frames_dropped(&self) -> u32 {
        0
    }
}

/// Scans of noise around mid-scale on the gyros and a steady temperature code, interleaved as the DMA writes
/// them.
fn fill(codes: &mut [u16]) {
    let mut s = 12345u32;
    for (i, c) in codes.iter_mut().enumerate() {
        s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        *c = if i % CHANNELS == GYROS { 1900 } else { 2048 + (s >> 26) as u16 };
    }
}

/// Print a figure: instructions per sample per gyro channel, in thousandths, and the cycle estimate.
fn print(what: &str, per_milli: u64, note: &str) {
    let instr = per_milli as f64 / 1000.0;
    hprintln!(
        "octavar-bench: {}: {}.{:03} instructions/sample/channel (about {} cycles, at most {}; {})",
        what,
        per_milli / 1000,
        per_milli % 1000,
        (instr * CPI_CACHED + 0.5) as u32,
        (instr * CPI_WORST + 0.5) as u32,
        note
    );
}

/// Time `Characterizer::feed` alone.
pub fn bench_characterizer(core: &mut Characterizer<'static, GYROS>) {
    static BLOCK: StaticCell<[u16; BLOCK_CODES]> = StaticCell::new();
    let block = BLOCK.init([0; BLOCK_CODES]);
    fill(block);
    core.restart(0);
    // Warm up (fill the accumulators' rings), then time.
    core.feed(0, block, &mut EncodeOnly);
    let t0 = timebase::now_us();
    for b in 1..=BLOCKS {
        core.feed(b * BLOCK_SCANS as u64, black_box(&block[..]), &mut EncodeOnly);
    }
    let t1 = timebase::now_us();
    let per_milli = (t1 - t0) * 1_000_000 / (BLOCKS * (BLOCK_SCANS * GYROS) as u64);
    print("Characterizer::feed", per_milli, "virtual ns with -icount shift=0; rounds and frame encoding included");
}

/// Blocks in the benchmark's ring: the poll's cost does not depend on the ring's length, and QEMU's SRAM holds
/// the stack above the statics (a board-sized ring would take 20 KiB of it).
const BENCH_RING_BLOCKS: usize = 4;

/// A DMA ring of codes, read with volatile loads as the board's is, one block more of it "converted" per poll.
struct BenchRing {
    ring: &'static [u16; BENCH_RING_BLOCKS * BLOCK_CODES],
    started: u64,
}

impl ScanRing<BLOCK_CODES> for BenchRing {
    fn started(&mut self) -> u64 {
        black_box(self.started)
    }

    fn copy_block(&mut self, block: &ReadyBlock, out: &mut [u16; BLOCK_CODES]) {
        let base = self.ring.as_ptr();
        for (i, code) in out.iter_mut().enumerate() {
            // SAFETY: blocks tile the ring, so slot * CHANNELS + i is in bounds; volatile as the board's DMA ring.
            *code = unsafe { base.add(block.slot * CHANNELS + i).read_volatile() };
        }
    }

    fn check(&mut self) -> Option<u64> {
        None
    }
}

/// Time the whole path: poll, copy, hand-off, receive, feed into the real frame queue.
pub fn bench_whole_path(core: &mut Characterizer<'static, GYROS>, tx: &mut BlockSender, rx: &mut BlockReceiver) {
    static RING: StaticCell<[u16; BENCH_RING_BLOCKS * BLOCK_CODES]> = StaticCell::new();
    let ring = RING.init([0; BENCH_RING_BLOCKS * BLOCK_CODES]);
    fill(ring);
    let mut ring = BenchRing { ring, started: 0 };
    let mut sampler = Sampler::new(BENCH_RING_BLOCKS * BLOCK_SCANS, BLOCK_SCANS, 0);
    core.restart(0);
    let (mut timed, mut blocks_fed) = (0u64, 0u64);
    // One block before timing: the accumulators' rings fill.
    for b in 0..=BLOCKS {
        ring.started += BLOCK_SCANS as u64 + u64::from(b == 0);
        let t0 = timebase::now_us();
        sampler.poll(&mut ring, &mut Blocks(tx));
        if let Some(block) = rx.try_receive() {
            characterize::feed_block(core, block);
            rx.receive_done();
            blocks_fed += 1;
        }
        let t1 = timebase::now_us();
        if b > 0 {
            timed += t1 - t0;
        }
        while FRAMES_OUT.try_receive().is_ok() {}
    }
    assert!(blocks_fed == BLOCKS + 1, "the benchmark's blocks all went through");
    // The benchmark's rounds are no session of the device: the store must not checkpoint them.
    characterize::SNAPSHOT_READY.reset();
    let per_milli = timed * 1_000_000 / (BLOCKS * (BLOCK_SCANS * GYROS) as u64);
    print(
        "whole path",
        per_milli,
        "the poll, the ring copy, the hand-off, feed and the frame queue; virtual ns with -icount shift=0",
    );
}

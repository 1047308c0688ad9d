//! The sampler's step: one poll of the converter's ring, handing every good block on with its hardware index.
//!
//! The firmware's sampler task runs [`Sampler::poll`] every poll period (`firmware/src/sampler.rs` keeps only the
//! ticker, the channel to characterize and the counters it publishes); the host tests run the same function
//! against the model of the converter (`crate::adc_f4::model`), so the step they check is the step the board
//! takes. One poll:
//!
//! 1. checks the converter, and restarts the reader where a recovery re-armed the ring;
//! 2. asks [`RingReader`] for each block the ring holds complete, copies it into a free block of the consumer;
//! 3. checks the converter again *after* the copy: its failure flags hold until a recovery clears them, so a
//!    converter healthy now was healthy while the copy read the ring, and the block holds what its index says.
//!    A block the converter failed during (or before) is thrown away, and its scans count as lost;
//! 4. confirms with the reader that the DMA did not overtake the copy, and hands the block on.
//!
//! Every scan is either handed on or counted lost: the first index of each block handed on minus the end of the
//! one before is exactly the [`ReadyBlock::skipped`] it carries, and [`Sampler::lost`] sums them.

use super::config::DeviceConfig;
use super::ring::{ReadyBlock, RingReader};

/// A ring of scans written by hardware (or its model) and the counter of scans started, read in blocks of
/// `BLOCK_CODES` codes (the board's block by default).
pub trait ScanRing<const BLOCK_CODES: usize = { DeviceConfig::F405.block_codes() }> {
    /// Scans started since boot: the hardware trigger count, extended to 64 bits.
    fn started(&mut self) -> u64;
    /// Copy the block's scans (from ring slot `block.slot` on, contiguous) into `out`.
    fn copy_block(&mut self, block: &ReadyBlock, out: &mut [u16; BLOCK_CODES]);
    /// Check the converter and recover it if it failed: `Some(first)` when the DMA was re-armed at slot 0 and
    /// its first scan there will be the one with hardware index `first`.
    fn check(&mut self) -> Option<u64>;
}

/// Where the blocks go: the consumer's free blocks, filled and handed on one at a time.
pub trait BlockSink<const BLOCK_CODES: usize = { DeviceConfig::F405.block_codes() }> {
    /// The codes of the next free block, or `None` while the consumer is behind (the scans wait in the ring).
    fn free_block(&mut self) -> Option<&mut [u16; BLOCK_CODES]>;
    /// Hand on the block [`BlockSink::free_block`] gave last, now filled with `block`'s scans; `block.skipped`
    /// scans were lost just before it.
    fn hand_on(&mut self, block: &ReadyBlock);
    /// Something the logs should show.
    fn note(&mut self, _event: SamplerEvent) {}
}

/// What a poll did besides handing blocks on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SamplerEvent {
    /// The converter had failed and was restarted; its first scan will have hardware index `first`.
    Restarted {
        /// Hardware index of the first scan after the recovery.
        first: u64,
    },
    /// The converter failed before the copy of the block at `first_index` ended: the block was thrown away and
    /// the converter restarted at `first`.
    Discarded {
        /// Hardware index of the block's first scan.
        first_index: u64,
        /// Hardware index of the first scan after the recovery.
        first: u64,
    },
    /// The DMA overwrote the block at `first_index` while it was being copied: it was thrown away.
    Overtaken {
        /// Hardware index of the block's first scan.
        first_index: u64,
    },
}

/// The sampler's position in the converter's ring (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sampler {
    reader: RingReader,
}

impl Sampler {
    /// A sampler of a ring of `ring_scans` scans in blocks of `block_scans`, whose first scan (in slot 0) has
    /// hardware index `first`.
    ///
    /// # Panics
    /// If the ring is not a whole number of blocks, at least two.
    pub const fn new(ring_scans: usize, block_scans: usize, first: u64) -> Self {
        Sampler { reader: RingReader::starting_at(ring_scans, block_scans, first) }
    }

    /// Hardware index of the next scan to hand on.
    pub const fn next_index(&self) -> u64 {
        self.reader.next_index()
    }

    /// Scans lost since the sampler started.
    pub const fn lost(&self) -> u64 {
        self.reader.lost()
    }

    /// One poll: check the converter, then copy, re-check and hand on every block the ring holds complete, until
    /// none is left or the consumer has no free block.
    pub fn poll<R, S, const BLOCK_CODES: usize>(&mut self, ring: &mut R, sink: &mut S)
    where
        R: ScanRing<BLOCK_CODES>,
        S: BlockSink<BLOCK_CODES>,
    {
        if let Some(first) = ring.check() {
            self.reader.restart_at(first);
            sink.note(SamplerEvent::Restarted { first });
        }
        while let Some(ready) = self.reader.poll(ring.started()) {
            let Some(codes) = sink.free_block() else { break };
            ring.copy_block(&ready, codes);
            if let Some(first) = ring.check() {
                self.reader.restart_at(first);
                sink.note(SamplerEvent::Discarded { first_index: ready.first_index, first });
                continue;
            }
            if !self.reader.confirm(ring.started()) {
                sink.note(SamplerEvent::Overtaken { first_index: ready.first_index });
                continue;
            }
            sink.hand_on(&ready);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const C: usize = 2;
    const BLOCK: usize = 4;
    const RING: usize = 4 * BLOCK;

    /// A ring written by index (scan j's codes are `j * C + channel`) whose converter fails at a chosen check.
    struct Ring {
        started: u64,
        checks: u32,
        /// At which check (counting from 1) the converter is found failed, and where it restarts.
        fail_at: Option<(u32, u64)>,
    }

    impl Ring {
        fn new(started: u64) -> Self {
            Ring { started, checks: 0, fail_at: None }
        }
    }

    impl ScanRing<{ BLOCK * C }> for Ring {
        fn started(&mut self) -> u64 {
            self.started
        }
        fn copy_block(&mut self, block: &ReadyBlock, out: &mut [u16; BLOCK * C]) {
            for (i, code) in out.iter_mut().enumerate() {
                *code = (block.first_index * C as u64 + i as u64) as u16;
            }
        }
        fn check(&mut self) -> Option<u64> {
            self.checks += 1;
            match self.fail_at {
                Some((n, first)) if n == self.checks => Some(first),
                _ => None,
            }
        }
    }

    #[derive(Default)]
    struct Sink {
        block: [u16; BLOCK * C],
        handed: Vec<(u64, u64)>,
        events: Vec<SamplerEvent>,
        full: bool,
    }

    impl BlockSink<{ BLOCK * C }> for Sink {
        fn free_block(&mut self) -> Option<&mut [u16; BLOCK * C]> {
            (!self.full).then_some(&mut self.block)
        }
        fn hand_on(&mut self, block: &ReadyBlock) {
            assert_eq!(u64::from(self.block[0]), block.first_index * C as u64);
            self.handed.push((block.first_index, block.skipped));
        }
        fn note(&mut self, event: SamplerEvent) {
            self.events.push(event);
        }
    }

    #[test]
    fn blocks_go_on_in_order_while_the_consumer_takes_them_and_wait_in_the_ring_while_it_does_not() {
        let mut ring = Ring::new(2 * BLOCK as u64 + 1);
        let mut sink = Sink { full: true, ..Sink::default() };
        let mut s = Sampler::new(RING, BLOCK, 0);
        s.poll(&mut ring, &mut sink);
        assert!(sink.handed.is_empty());
        sink.full = false;
        s.poll(&mut ring, &mut sink);
        assert_eq!(sink.handed, [(0, 0), (BLOCK as u64, 0)]);
        assert_eq!((s.next_index(), s.lost()), (2 * BLOCK as u64, 0));
        // One check before the blocks and one after each copy.
        assert_eq!(ring.checks, 2 + 2);
    }

    #[test]
    fn a_failure_found_after_the_copy_throws_the_block_away_and_counts_its_scans_to_the_restart() {
        let first = 3 * BLOCK as u64 + 1;
        let mut ring = Ring::new(BLOCK as u64 + 1);
        // The check before the copy passes; the one after it finds the converter failed.
        ring.fail_at = Some((2, first));
        let mut sink = Sink::default();
        let mut s = Sampler::new(RING, BLOCK, 0);
        s.poll(&mut ring, &mut sink);
        assert!(sink.handed.is_empty());
        assert_eq!(sink.events, [SamplerEvent::Discarded { first_index: 0, first }]);
        ring.started = first + BLOCK as u64 + 1;
        s.poll(&mut ring, &mut sink);
        assert_eq!(sink.handed, [(first, first)], "the block after the restart, every scan before it lost");
        assert_eq!(s.lost(), first);
    }

    #[test]
    fn a_failure_found_before_the_poll_restarts_the_reader_at_the_first_scan_after_the_recovery() {
        let first = 2 * BLOCK as u64 + 3;
        let mut ring = Ring::new(first + BLOCK as u64 + 1);
        ring.fail_at = Some((1, first));
        let mut sink = Sink::default();
        let mut s = Sampler::new(RING, BLOCK, 0);
        s.poll(&mut ring, &mut sink);
        assert_eq!(sink.events, [SamplerEvent::Restarted { first }]);
        assert_eq!(sink.handed, [(first, first)]);
    }
}

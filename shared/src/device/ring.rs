//! The sample ring: which block of a hardware-indexed DMA ring can be taken, and exactly what was lost.
//!
//! The sampler's DMA writes scans in circular mode into a ring of `ring_scans` scans, and a hardware counter
//! counts the scans *started* (triggered) since boot. The DMA was armed at slot 0 for scan `base` (0 at boot, the
//! first scan after an overrun recovery later), so scan `j` lands in slot `(j - base) mod ring_scans`. Scan `j` is
//! complete once scan `j + 1` has started (a scan converts in a fraction of the trigger period), and its slot is
//! overwritten only after scan `j + ring_scans` has started. So from the counter alone the reader knows which
//! blocks are ready, which were overwritten while the CPU was away (a flash erase stalls every fetch, interrupts
//! included), and how many scans that cost: nothing is guessed from elapsed time.
//!
//! [`RingReader::poll`] names the next block to copy (skipping, and counting, what the ring no longer holds);
//! after the copy, [`RingReader::confirm`] reads the counter again and keeps the block only if the DMA cannot
//! have reached it during the copy. The reader never waits: a sampler that cannot hand a block on (its consumer
//! is behind) simply polls later, and the ring's lap becomes an exact gap.
//!
//! # Examples
//! ```
//! use octavar_shared::device::ring::RingReader;
//! let mut r = RingReader::new(16 * 128, 128);
//! assert!(r.poll(100).is_none());                 // the first block is not complete yet
//! let b = r.poll(129).unwrap();                   // scans 0..128 are complete
//! assert_eq!((b.first_index, b.slot, b.skipped), (0, 0, 0));
//! assert!(r.confirm(130));                        // nothing overwrote them meanwhile
//! let b = r.poll(10_000).unwrap();                // a 4.9 s stall: the ring lapped
//! assert_eq!(b.first_index % 128, 0);
//! assert_eq!(b.skipped, b.first_index - 128);     // every scan in between is counted as lost
//! ```

/// A block the sampler may copy now.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReadyBlock {
    /// Hardware index of the block's first scan.
    pub first_index: u64,
    /// Ring slot (scan position) of its first scan; the block is contiguous in the ring.
    pub slot: usize,
    /// Scans skipped just before it because the ring no longer held them (0 without a gap).
    pub skipped: u64,
}

/// The reader's position in a hardware-indexed ring (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RingReader {
    ring_scans: u64,
    block_scans: u64,
    /// Hardware index of the scan the DMA wrote to slot 0 first.
    base: u64,
    /// Hardware index of the next scan to take (always `base` plus a multiple of the block).
    next: u64,
    /// Scans skipped since the last block handed out.
    skipped: u64,
    /// Scans skipped since the reader started.
    lost: u64,
}

impl RingReader {
    /// A reader of a ring of `ring_scans` scans taken in blocks of `block_scans`, from scan 0.
    ///
    /// # Panics
    /// If the ring is not a whole number of blocks, at least two.
    pub const fn new(ring_scans: usize, block_scans: usize) -> Self {
        assert!(block_scans > 0 && ring_scans.is_multiple_of(block_scans) && ring_scans >= 2 * block_scans);
        RingReader {
            ring_scans: ring_scans as u64,
            block_scans: block_scans as u64,
            base: 0,
            next: 0,
            skipped: 0,
            lost: 0,
        }
    }

    /// A reader of the same ring whose first scan, in slot 0, has hardware index `first` (the trigger count when
    /// the converter was armed).
    ///
    /// # Panics
    /// As [`RingReader::new`].
    pub const fn starting_at(ring_scans: usize, block_scans: usize, first: u64) -> Self {
        let mut r = Self::new(ring_scans, block_scans);
        r.base = first;
        r.next = first;
        r
    }

    /// Hardware index of the next scan the reader will take.
    pub const fn next_index(&self) -> u64 {
        self.next
    }

    /// Scans lost (skipped) since the reader started.
    pub const fn lost(&self) -> u64 {
        self.lost
    }

    /// Move on to the first block the ring still holds for at least one more block period after `started`.
    fn skip_overwritten(&mut self, started: u64) {
        // The block at `next` may be copied only while scan `next + ring` has not started, with a block of
        // margin for the copy itself.
        if self.next + self.ring_scans < started + self.block_scans {
            let oldest = started + self.block_scans - self.ring_scans;
            let to = self.base + (oldest - self.base).div_ceil(self.block_scans) * self.block_scans;
            self.skipped += to - self.next;
            self.lost += to - self.next;
            self.next = to;
        }
    }

    /// The next block to copy when the hardware counter reads `started`, or `None` if it is not complete yet.
    pub fn poll(&mut self, started: u64) -> Option<ReadyBlock> {
        self.skip_overwritten(started);
        // The block's last scan, `next + block - 1`, is complete once the scan after it has started.
        (started > self.next + self.block_scans).then(|| ReadyBlock {
            first_index: self.next,
            slot: ((self.next - self.base) % self.ring_scans) as usize,
            skipped: self.skipped,
        })
    }

    /// The block from the last [`RingReader::poll`] has been copied and the counter now reads `started`: `true`
    /// if the copy is good (the DMA had not started the scan that overwrites its first slot), and the reader
    /// moves past it; `false` if it must be thrown away, and its scans are counted as lost.
    pub fn confirm(&mut self, started: u64) -> bool {
        if started <= self.next + self.ring_scans {
            self.next += self.block_scans;
            self.skipped = 0;
            true
        } else {
            self.skip_overwritten(started);
            false
        }
    }

    /// The sampler re-armed the DMA at ring slot 0 (overrun recovery), and the first scan it will write there
    /// has hardware index `first`. Every scan not yet taken before it is lost.
    pub fn restart_at(&mut self, first: u64) {
        let first = first.max(self.next);
        self.skipped += first - self.next;
        self.lost += first - self.next;
        self.base = first;
        self.next = first;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const RING: usize = 8 * 16;
    const BLOCK: usize = 16;

    /// A DMA ring written by index: slot `j % RING` holds `j` (as the hardware would write scan j's codes).
    struct Dma {
        ring: [u64; RING],
        written: u64,
    }

    impl Dma {
        fn run_to(&mut self, started: u64) {
            while self.written < started {
                self.ring[(self.written % RING as u64) as usize] = self.written;
                self.written += 1;
            }
        }
    }

    proptest! {
        /// Whatever the polling rhythm (long stalls included): every block handed out holds exactly the scans
        /// its index says, blocks and skips tile the index line without overlap, and nothing is skipped while the
        /// reader polls at least every ring-minus-two-blocks scans.
        #[test]
        fn blocks_and_skips_tile_the_index_line(steps in proptest::collection::vec((1u64..400, 0u64..12), 1..200)) {
            let mut dma = Dma { ring: [u64::MAX; RING], written: 0 };
            let mut r = RingReader::new(RING, BLOCK);
            let (mut started, mut covered, mut lost) = (0u64, 0u64, 0u64);
            let mut max_step = 0;
            for (step, during_copy) in steps {
                started += step;
                max_step = max_step.max(step + during_copy);
                dma.run_to(started);
                while let Some(b) = r.poll(started) {
                    prop_assert_eq!(b.first_index, covered + b.skipped);
                    prop_assert_eq!(b.first_index % BLOCK as u64, 0);
                    let copy: Vec<u64> = dma.ring[b.slot..b.slot + BLOCK].to_vec();
                    // The DMA may run on while the copy is made; the copy saw the ring before that.
                    started += during_copy;
                    dma.run_to(started);
                    if r.confirm(started) {
                        let want: Vec<u64> = (b.first_index..b.first_index + BLOCK as u64).collect();
                        prop_assert_eq!(copy, want);
                        lost += b.skipped;
                        covered = b.first_index + BLOCK as u64;
                    }
                }
                prop_assert!(r.next_index() + RING as u64 >= started);
            }
            lost += r.next_index() - covered;
            prop_assert_eq!(r.lost(), lost);
            if max_step + 1 < (RING - 2 * BLOCK) as u64 {
                prop_assert_eq!(r.lost(), 0);
            }
        }
    }

    #[test]
    fn a_stall_longer_than_the_ring_loses_exactly_the_scans_between() {
        let mut r = RingReader::new(RING, BLOCK);
        let b = r.poll(BLOCK as u64 + 1).unwrap();
        assert!(r.confirm(BLOCK as u64 + 1));
        assert_eq!(b.first_index, 0);
        // 1000 scans later: the ring holds the last RING scans; the reader resumes at a block boundary at least a
        // block younger than the oldest intact scan.
        let started = 1000 + BLOCK as u64;
        let b = r.poll(started).unwrap();
        let oldest = started + BLOCK as u64 - RING as u64;
        assert_eq!(b.first_index, oldest.div_ceil(BLOCK as u64) * BLOCK as u64);
        assert_eq!(b.skipped, b.first_index - BLOCK as u64);
        assert!(r.confirm(started));
        assert_eq!(r.lost(), b.skipped);
    }

    #[test]
    fn a_copy_overtaken_by_the_dma_is_thrown_away_and_counted() {
        let mut r = RingReader::new(RING, BLOCK);
        let b = r.poll(RING as u64 - BLOCK as u64).unwrap();
        assert_eq!(b.first_index, 0);
        // The DMA started scan RING (slot 0) while the block was being copied.
        assert!(!r.confirm(RING as u64 + 1));
        assert!(r.lost() > 0 && r.next_index().is_multiple_of(BLOCK as u64));
        assert_eq!(r.poll(RING as u64 + 1).unwrap().skipped, r.lost());
    }

    #[test]
    fn a_restart_counts_the_scans_up_to_the_new_first_index() {
        let mut r = RingReader::new(RING, BLOCK);
        r.poll(BLOCK as u64 + 1).unwrap();
        assert!(r.confirm(BLOCK as u64 + 1));
        let first = 3 * RING as u64 + 5;
        r.restart_at(first);
        assert_eq!(r.lost(), first - BLOCK as u64);
        let b = r.poll(first + BLOCK as u64 + 1).unwrap();
        assert_eq!((b.first_index, b.slot, b.skipped), (first, 0, r.lost()));
        assert!(r.confirm(first + BLOCK as u64 + 1));
        // A later lap resumes on the new grid of blocks.
        let b = r.poll(first + 10 * RING as u64).unwrap();
        assert_eq!((b.first_index - first) % BLOCK as u64, 0);
        assert_eq!(b.slot as u64, (b.first_index - first) % RING as u64);
    }
}

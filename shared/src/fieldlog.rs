//! The field log: accumulator snapshots checkpointed to two reserved flash sectors, safe against power cuts.
//!
//! A gyro left on a battery for three days must not lose three days to a flat battery. The firmware writes a
//! [`Checkpoint`] (the snapshots of every gyro channel) at most every ten minutes; after a power cycle the host
//! asks for it and gets the last one that was completely written. This module is the part of that which can be
//! tested on the host: the record format, the recovery scan and the write order. The flash itself is behind the
//! [`LogFlash`] trait: the firmware implements it with the controller sequences of [`crate::flash_f4`] on
//! sectors 1 and 2 of the STM32F405 (see [`STM32F405_LOG_SECTORS`] and the root `memory.x`), the tests with
//! [`RamFlash`], a NOR flash model that can lose power at any word write or erase.
//!
//! # Format
//! Each of the two sectors holds fixed-size slots written in order; a slot is one record:
//!
//! ```text
//! word 0        MAGIC                      written first: a slot whose word 0 is erased was never started
//! word 1        seq                        monotonic sequence number, one more than the newest valid record
//! word 2        L = payload length in words
//! words 3..3+L  payload
//! word 3+L      CRC-32 (IEEE) of words 1..3+L, little-endian bytes
//! word 4+L      COMMIT                     written last
//! ```
//!
//! NOR flash programs only 1 -> 0 and erases to all ones, word by word in the order above. A record is valid
//! when its magic, length, CRC and commit word all check; the commit word is written only after every other word
//! completed, so a cut anywhere leaves either a complete record or one that fails the check (the CRC also
//! rejects half-erased old records). Recovery takes the valid record with the highest sequence number.
//!
//! # Write order (why a power cut loses at most one interval)
//! Records go into the first *blank* slot after the newest valid record in its sector. When that sector is full,
//! the other sector (which holds only older records) is erased and written from slot 0. So the newest complete
//! record is never erased or overwritten: a cut during an append recovers the checkpoint being written (if its
//! commit word made it) or the one before; a cut during the erase recovers the one before. Erases are rare (one
//! per sector-full of records: with the STM32F405's 16 KiB sectors and 4 gyro channels, every 5 checkpoints).
//!
//! # Examples
//! ```
//! use octavar_shared::fieldlog::{FieldLog, RamFlash};
//! let mut log = FieldLog::open(RamFlash::<512>::new(), 8).unwrap();
//! assert_eq!(log.latest_seq(), None);
//! log.append(&[1, 2, 3, 4, 5, 6, 7, 8]).unwrap();
//! log.append(&[9; 8]).unwrap();
//! // Power cycle: a new FieldLog over the same flash finds the newest record.
//! let mut log = FieldLog::open(log.into_flash(), 8).unwrap();
//! let mut buf = [0u32; 8];
//! assert_eq!(log.read_latest(&mut buf).unwrap(), Some(2));
//! assert_eq!(buf, [9; 8]);
//! ```

use crate::acc::{LevelSum, Snapshot, LEVELS};
use crate::proto::framing::CRC;

/// First word of every record ("OCTV" in ASCII, little-endian).
pub const MAGIC: u32 = u32::from_le_bytes(*b"OCTV");
/// Last word of every record; written only after all the others.
pub const COMMIT: u32 = 0x5AA5_0FF0;
/// Words in a record besides the payload: magic, seq, length, CRC, commit.
pub const OVERHEAD_WORDS: usize = 5;
/// The erased state of a flash word.
pub const ERASED: u32 = 0xFFFF_FFFF;

/// Where the field log lives on the STM32F405RG: sectors 1 and 2, 16 KiB each (RM0090 section 3.3, table 5). Small
/// sectors, because erasing one stalls the single-bank flash, and the CPU with it, for at most 0.5 s at x32 (a
/// 128 KiB sector: 2 s), which the firmware's 1.024 s sample ring outlives.
/// The root `memory.x` starts the program after them (`_stext` at sector 4) and exports the same numbers as the
/// linker symbols `__fieldlog_start` / `__fieldlog_end`; the firmware checks they agree.
pub const STM32F405_LOG_SECTORS: [LogSector; 2] = [
    LogSector { index: 1, address: 0x0800_4000, bytes: 16 * 1024 },
    LogSector { index: 2, address: 0x0800_8000, bytes: 16 * 1024 },
];

/// One flash sector of the log, as the MCU numbers it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LogSector {
    /// The sector number in the reference manual.
    pub index: u8,
    /// Its absolute address.
    pub address: u32,
    /// Its size in bytes.
    pub bytes: u32,
}

/// The flash the log is written to: two equal sectors, addressed in 32-bit words from each sector's start.
///
/// Programming may only clear bits (1 -> 0); erase sets a whole sector to [`ERASED`]. Implementations write
/// words in increasing address order, so that a cut leaves earlier words complete.
pub trait LogFlash {
    /// The driver's error (a failed erase, a power cut in a simulation).
    type Error: core::fmt::Debug;
    /// Words in one sector (both sectors are the same size).
    fn sector_words(&self) -> usize;
    /// Erase `sector` (0 or 1) to all ones.
    ///
    /// # Errors
    /// When the driver fails; the sector is then in an unknown state.
    fn erase(&mut self, sector: usize) -> Result<(), Self::Error>;
    /// Program `words` at word offset `offset` of `sector`.
    ///
    /// # Errors
    /// When the driver fails; words already programmed stay programmed.
    fn write(&mut self, sector: usize, offset: usize, words: &[u32]) -> Result<(), Self::Error>;
    /// Read `buf.len()` words from word offset `offset` of `sector`.
    ///
    /// # Errors
    /// When the driver fails.
    fn read(&mut self, sector: usize, offset: usize, buf: &mut [u32]) -> Result<(), Self::Error>;
}

/// Errors of the field log.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LogError<E> {
    /// The flash driver failed.
    Flash(E),
    /// A payload of another length than the log was opened with, or a buffer of the wrong size.
    BadLength,
    /// A sector cannot hold even one record of this payload length.
    SectorTooSmall,
}

impl<E: core::fmt::Debug> core::fmt::Display for LogError<E> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            LogError::Flash(e) => write!(f, "flash error: {e:?}"),
            LogError::BadLength => f.write_str("payload length differs from the log's record length"),
            LogError::SectorTooSmall => f.write_str("a flash sector cannot hold one record"),
        }
    }
}

impl<E: core::fmt::Debug> core::error::Error for LogError<E> {}

/// Where the newest valid record is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Newest {
    sector: usize,
    slot: usize,
    seq: u32,
}

/// The double-buffered checkpoint log over a [`LogFlash`]; every record has the same payload length.
#[derive(Debug)]
pub struct FieldLog<F: LogFlash> {
    flash: F,
    payload_words: usize,
    slots_per_sector: usize,
    newest: Option<Newest>,
    /// The blank slot the next append takes, found (and its sector erased) ahead by [`FieldLog::prepare_append`].
    ready: Option<(usize, usize)>,
}

impl<F: LogFlash> FieldLog<F> {
    /// Scan `flash` for the newest valid record of `payload_words` words (what a boot does).
    ///
    /// # Errors
    /// [`LogError::SectorTooSmall`] if a sector cannot hold one record; [`LogError::Flash`] on a read error.
    pub fn open(flash: F, payload_words: usize) -> Result<Self, LogError<F::Error>> {
        let slot_words = payload_words + OVERHEAD_WORDS;
        let slots_per_sector = flash.sector_words() / slot_words;
        if slots_per_sector == 0 {
            return Err(LogError::SectorTooSmall);
        }
        let mut log = Self { flash, payload_words, slots_per_sector, newest: None, ready: None };
        for sector in 0..2 {
            for slot in 0..slots_per_sector {
                if let Some(seq) = log.check_slot(sector, slot)? {
                    if log.newest.is_none_or(|n| seq > n.seq) {
                        log.newest = Some(Newest { sector, slot, seq });
                    }
                }
            }
        }
        Ok(log)
    }

    /// Words in one record's payload.
    pub fn payload_words(&self) -> usize {
        self.payload_words
    }

    /// Records one sector holds.
    pub fn slots_per_sector(&self) -> usize {
        self.slots_per_sector
    }

    /// Sequence number of the newest valid record, if any.
    pub fn latest_seq(&self) -> Option<u32> {
        self.newest.map(|n| n.seq)
    }

    /// The flash, for what else goes through its controller; a caller that writes the log's sectors through it
    /// must reopen the log.
    pub fn flash_mut(&mut self) -> &mut F {
        &mut self.flash
    }

    /// Give the flash back.
    pub fn into_flash(self) -> F {
        self.flash
    }

    /// Copy the newest valid record's payload into `buf` and return its sequence number (`None`: empty log).
    ///
    /// # Errors
    /// [`LogError::BadLength`] if `buf` is not `payload_words` long; [`LogError::Flash`] on a read error.
    pub fn read_latest(&mut self, buf: &mut [u32]) -> Result<Option<u32>, LogError<F::Error>> {
        if buf.len() != self.payload_words {
            return Err(LogError::BadLength);
        }
        let Some(n) = self.newest else { return Ok(None) };
        let base = n.slot * self.slot_words() + 3;
        self.flash.read(n.sector, base, buf).map_err(LogError::Flash)?;
        Ok(Some(n.seq))
    }

    /// Append a record and return its sequence number. The newest complete record stays intact until this one
    /// is committed.
    ///
    /// # Errors
    /// [`LogError::BadLength`] for a payload of the wrong length; [`LogError::Flash`] when the flash fails (a
    /// power cut in a simulation): the log then still holds its previous newest record.
    pub fn append(&mut self, payload: &[u32]) -> Result<u32, LogError<F::Error>> {
        if payload.len() != self.payload_words {
            return Err(LogError::BadLength);
        }
        let seq = self.newest.map_or(1, |n| n.seq.wrapping_add(1));
        let (sector, slot) = match self.ready.take() {
            Some(ready) => ready,
            None => self.next_slot()?,
        };
        let base = slot * self.slot_words();
        let header = [MAGIC, seq, self.payload_words as u32];
        let crc = {
            let mut c = CRC.digest();
            update_words(&mut c, &header[1..]);
            update_words(&mut c, payload);
            c.finalize()
        };
        let w = |e| LogError::Flash(e);
        self.flash.write(sector, base, &header).map_err(w)?;
        self.flash.write(sector, base + 3, payload).map_err(w)?;
        self.flash.write(sector, base + 3 + self.payload_words, &[crc]).map_err(w)?;
        self.flash.write(sector, base + 4 + self.payload_words, &[COMMIT]).map_err(w)?;
        self.newest = Some(Newest { sector, slot, seq });
        Ok(seq)
    }

    /// Find the slot the next [`FieldLog::append`] will take, erasing the other sector now if the newest record's
    /// sector is full (or the log holds nothing valid), so that the append only programs. Returns whether it
    /// erased. An erase and a programming each stall a single-bank flash's CPU; this lets the caller run
    /// between them. The newest record stays intact, as in an append.
    ///
    /// # Errors
    /// [`LogError::Flash`] when the erase or the blank check's read fails (the next append tries again).
    pub fn prepare_append(&mut self) -> Result<bool, LogError<F::Error>> {
        if self.ready.is_some() {
            return Ok(false);
        }
        let sector_before = self.newest.map(|n| n.sector);
        let ready = self.next_slot()?;
        self.ready = Some(ready);
        // next_slot erases exactly when it moves to the other sector or starts an empty log.
        Ok(sector_before != Some(ready.0))
    }

    /// Erase both sectors: the log is empty afterwards.
    ///
    /// # Errors
    /// [`LogError::Flash`] when an erase fails.
    pub fn clear(&mut self) -> Result<(), LogError<F::Error>> {
        self.newest = None;
        self.ready = None;
        self.flash.erase(0).map_err(LogError::Flash)?;
        self.flash.erase(1).map_err(LogError::Flash)
    }

    fn slot_words(&self) -> usize {
        self.payload_words + OVERHEAD_WORDS
    }

    /// The slot the next record goes to, erasing the other sector when the newest record's sector is full.
    fn next_slot(&mut self) -> Result<(usize, usize), LogError<F::Error>> {
        let (sector, first) = match self.newest {
            Some(n) => (n.sector, n.slot + 1),
            None => {
                // Nothing valid anywhere: any content is garbage. Start on a freshly erased sector 0.
                self.flash.erase(0).map_err(LogError::Flash)?;
                return Ok((0, 0));
            }
        };
        for slot in first..self.slots_per_sector {
            if self.slot_is_blank(sector, slot)? {
                return Ok((sector, slot));
            }
        }
        let other = sector ^ 1;
        self.flash.erase(other).map_err(LogError::Flash)?;
        Ok((other, 0))
    }

    fn slot_is_blank(&mut self, sector: usize, slot: usize) -> Result<bool, LogError<F::Error>> {
        let mut chunk = [0u32; 16];
        let base = slot * self.slot_words();
        let end = base + self.slot_words();
        let mut at = base;
        while at < end {
            let n = (end - at).min(chunk.len());
            self.flash.read(sector, at, &mut chunk[..n]).map_err(LogError::Flash)?;
            if chunk[..n].iter().any(|&w| w != ERASED) {
                return Ok(false);
            }
            at += n;
        }
        Ok(true)
    }

    /// The sequence number of the record in `slot` if it is complete and intact.
    fn check_slot(&mut self, sector: usize, slot: usize) -> Result<Option<u32>, LogError<F::Error>> {
        let base = slot * self.slot_words();
        let mut header = [0u32; 3];
        self.flash.read(sector, base, &mut header).map_err(LogError::Flash)?;
        if header[0] != MAGIC || header[2] as usize != self.payload_words {
            return Ok(None);
        }
        let mut tail = [0u32; 2];
        self.flash.read(sector, base + 3 + self.payload_words, &mut tail).map_err(LogError::Flash)?;
        if tail[1] != COMMIT {
            return Ok(None);
        }
        let mut c = CRC.digest();
        update_words(&mut c, &header[1..]);
        let mut chunk = [0u32; 16];
        let mut at = 0;
        while at < self.payload_words {
            let n = (self.payload_words - at).min(chunk.len());
            self.flash.read(sector, base + 3 + at, &mut chunk[..n]).map_err(LogError::Flash)?;
            update_words(&mut c, &chunk[..n]);
            at += n;
        }
        Ok((c.finalize() == tail[0]).then_some(header[1]))
    }
}

/// Feed words to a CRC-32 (the frames' CRC-32/ISO-HDLC, [`crate::proto::crc32`]) as their little-endian bytes.
fn update_words(crc: &mut crc::Digest<'_, u32>, words: &[u32]) {
    for w in words {
        crc.update(&w.to_le_bytes());
    }
}

/// What the firmware checkpoints: the snapshots of its gyro channels, pooled over every power cycle.
///
/// After a power cut the firmware reads the newest checkpoint back and pools it ([`Checkpoint::merge_session`])
/// with the new session's snapshots, so that each checkpoint covers the whole deployment: a cut costs at most
/// the samples since the last checkpoint (the differences straddling the cut are not formed: see
/// [`Snapshot::merge`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Checkpoint<const CH: usize> {
    /// Power-on sessions pooled in this checkpoint (1 for the first).
    pub sessions: u32,
    /// ADC overruns counted over those sessions.
    pub adc_overruns: u32,
    /// One snapshot per gyro channel, in the firmware's channel order.
    pub snapshots: [Snapshot; CH],
}

/// Words one [`Snapshot`] takes in a checkpoint: stride, samples (2), and per level n (2) + sum (4).
pub const SNAPSHOT_WORDS: usize = 3 + LEVELS * 6;

impl<const CH: usize> Checkpoint<CH> {
    /// Payload words of a checkpoint: what [`FieldLog::open`] needs.
    pub const WORDS: usize = 2 + CH * SNAPSHOT_WORDS;

    /// A checkpoint of `sessions` sessions with empty snapshots of stride `stride`.
    ///
    /// # Panics
    /// If `stride` is not a power of two in 1..=64 (a programming error).
    pub fn empty(stride: usize) -> Self {
        let empty = Snapshot::empty(stride).expect("stride is a power of two in 1..=64");
        Self { sessions: 0, adc_overruns: 0, snapshots: [empty; CH] }
    }

    /// Write the checkpoint into `out` (exactly [`Self::WORDS`] long).
    ///
    /// # Errors
    /// [`LogError::BadLength`] for another length.
    pub fn encode<E>(&self, out: &mut [u32]) -> Result<(), LogError<E>> {
        if out.len() != Self::WORDS {
            return Err(LogError::BadLength);
        }
        out[0] = self.sessions;
        out[1] = self.adc_overruns;
        for (snap, words) in self.snapshots.iter().zip(out[2..].chunks_exact_mut(SNAPSHOT_WORDS)) {
            words[0] = u32::from(snap.stride);
            words[1] = snap.samples as u32;
            words[2] = (snap.samples >> 32) as u32;
            for (l, w) in snap.levels.iter().zip(words[3..].chunks_exact_mut(6)) {
                w[0] = l.n as u32;
                w[1] = (l.n >> 32) as u32;
                for (i, x) in w[2..].iter_mut().enumerate() {
                    *x = (l.sum_sq >> (32 * i)) as u32;
                }
            }
        }
        Ok(())
    }

    /// Read a checkpoint back from [`Self::WORDS`] words.
    ///
    /// # Errors
    /// [`LogError::BadLength`] for another length.
    pub fn decode<E>(words: &[u32]) -> Result<Self, LogError<E>> {
        if words.len() != Self::WORDS {
            return Err(LogError::BadLength);
        }
        let mut cp = Self::empty(1);
        cp.sessions = words[0];
        cp.adc_overruns = words[1];
        for (snap, w) in cp.snapshots.iter_mut().zip(words[2..].chunks_exact(SNAPSHOT_WORDS)) {
            snap.stride = w[0] as u8;
            snap.samples = u64::from(w[1]) | u64::from(w[2]) << 32;
            for (l, lw) in snap.levels.iter_mut().zip(w[3..].chunks_exact(6)) {
                let n = u64::from(lw[0]) | u64::from(lw[1]) << 32;
                let sum_sq = lw[2..].iter().enumerate().fold(0u128, |a, (i, &x)| a | u128::from(x) << (32 * i));
                *l = LevelSum { n, sum_sq };
            }
        }
        Ok(cp)
    }

    /// The checkpoint of a new session: `base` (the newest checkpoint found at boot) pooled with this session's
    /// snapshots and overrun count. A base with another stride (an old firmware) is not pooled.
    pub fn merge_session(base: Option<&Self>, current: &[Snapshot; CH], adc_overruns: u32) -> Self {
        let mut out = Self { sessions: 1, adc_overruns, snapshots: *current };
        if let Some(b) = base {
            let mut pooled = b.snapshots;
            if pooled.iter_mut().zip(current.iter()).all(|(p, c)| p.merge(c).is_ok()) {
                out.snapshots = pooled;
                out.sessions = b.sessions.saturating_add(1);
                out.adc_overruns = b.adc_overruns.saturating_add(adc_overruns);
            }
        }
        out
    }
}

/// Errors of [`RamFlash`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RamFlashError {
    /// The simulated power failed: this operation was cut short and nothing after it happens.
    PowerCut,
    /// A sector number other than 0 or 1, or an access past the sector's end.
    OutOfRange,
}

/// A NOR flash in RAM with two sectors of `W` words: programming ANDs (1 -> 0 only), erase sets all ones.
///
/// For tests it can lose power: after [`RamFlash::cut_after`] `n` steps (one word programmed, or one erase) the
/// step in progress is left half done (a programmed word with only some of its bits cleared; an erase that has
/// set only some bits of some words) and every later operation fails with [`RamFlashError::PowerCut`] until
/// [`RamFlash::power_on`]. The flash controller model ([`crate::flash_f4::model`]) keeps its array in one.
#[derive(Clone, Debug)]
pub struct RamFlash<const W: usize> {
    words: [[u32; W]; 2],
    /// Steps left before the power fails (`None`: never).
    budget: Option<u64>,
    dead: bool,
    rng: u64,
    /// Steps taken since creation (word writes + erases).
    pub steps: u64,
}

impl<const W: usize> Default for RamFlash<W> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const W: usize> RamFlash<W> {
    /// A flash with both sectors erased.
    pub const fn new() -> Self {
        Self { words: [[ERASED; W]; 2], budget: None, dead: false, rng: 0x9E37_79B9_7F4A_7C15, steps: 0 }
    }

    /// Let the power fail during step `steps + 1` from now; `seed` chooses the half-done bits.
    pub fn cut_after(&mut self, steps: u64, seed: u64) {
        self.budget = Some(steps);
        self.rng = seed | 1;
    }

    /// Power back on: operations work again (the cells keep whatever state the cut left).
    pub fn power_on(&mut self) {
        self.budget = None;
        self.dead = false;
    }

    /// Whether the power has failed.
    pub fn is_dead(&self) -> bool {
        self.dead
    }

    /// The raw words of `sector`.
    pub fn sector(&self, sector: usize) -> &[u32; W] {
        &self.words[sector]
    }

    fn next_rand(&mut self) -> u32 {
        // xorshift64*
        self.rng ^= self.rng >> 12;
        self.rng ^= self.rng << 25;
        self.rng ^= self.rng >> 27;
        (self.rng.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 32) as u32
    }

    /// Take one step; `Ok(true)` if it completes, `Ok(false)` if the power fails during it.
    fn step(&mut self) -> Result<bool, RamFlashError> {
        if self.dead {
            return Err(RamFlashError::PowerCut);
        }
        self.steps += 1;
        match self.budget {
            Some(0) => {
                self.dead = true;
                Ok(false)
            }
            Some(ref mut b) => {
                *b -= 1;
                Ok(true)
            }
            None => Ok(true),
        }
    }
}

impl<const W: usize> LogFlash for RamFlash<W> {
    type Error = RamFlashError;

    fn sector_words(&self) -> usize {
        W
    }

    fn erase(&mut self, sector: usize) -> Result<(), RamFlashError> {
        if sector > 1 {
            return Err(RamFlashError::OutOfRange);
        }
        if self.step()? {
            self.words[sector] = [ERASED; W];
            return Ok(());
        }
        // Cut mid-erase: erasing only sets bits, some words are done, others got some of their bits.
        for i in 0..W {
            let r = self.next_rand();
            let set = match r & 3 {
                0 => ERASED,
                1 => 0,
                _ => self.next_rand() & self.next_rand(),
            };
            self.words[sector][i] |= set;
        }
        Err(RamFlashError::PowerCut)
    }

    fn write(&mut self, sector: usize, offset: usize, words: &[u32]) -> Result<(), RamFlashError> {
        if sector > 1 || offset + words.len() > W {
            return Err(RamFlashError::OutOfRange);
        }
        for (i, &w) in words.iter().enumerate() {
            let at = offset + i;
            if self.step()? {
                self.words[sector][at] &= w;
            } else {
                // Cut mid-program: only some of the bits to be cleared are cleared.
                let to_clear = self.words[sector][at] & !w;
                let r = self.next_rand();
                self.words[sector][at] &= !(to_clear & r);
                return Err(RamFlashError::PowerCut);
            }
        }
        Ok(())
    }

    fn read(&mut self, sector: usize, offset: usize, buf: &mut [u32]) -> Result<(), RamFlashError> {
        if sector > 1 || offset + buf.len() > W {
            return Err(RamFlashError::OutOfRange);
        }
        if self.dead {
            return Err(RamFlashError::PowerCut);
        }
        buf.copy_from_slice(&self.words[sector][offset..offset + buf.len()]);
        Ok(())
    }
}

mod policy;
mod read_out;
pub use policy::{CheckpointPolicy, RoundOutcome};
pub use read_out::read_out_frame;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::acc::OctaveAllan;

    /// The payload of checkpoint number `k` (deterministic, distinct for each k).
    fn payload(k: u32, words: usize) -> Vec<u32> {
        (0..words as u32).map(|i| k.wrapping_mul(0x0101_0101) ^ i.wrapping_mul(0x9E37_79B9) ^ 0x00F0_0F00).collect()
    }

    /// Which checkpoint a payload is, if it is one of ours intact.
    fn which(p: &[u32], max_k: u32) -> Option<u32> {
        (0..=max_k).find(|&k| payload(k, p.len()) == p)
    }

    #[test]
    fn the_record_crc_is_crc32_of_the_words_little_endian() {
        let mut c = CRC.digest();
        update_words(&mut c, &[0x3433_3231, 0x3837_3635]);
        c.update(b"9");
        assert_eq!(c.finalize(), 0xCBF4_3926, "the standard check value of \"123456789\"");
    }

    #[test]
    fn appends_fill_one_sector_then_alternate() {
        const P: usize = 20;
        let mut log = FieldLog::open(RamFlash::<100>::new(), P).unwrap(); // 4 slots of 25 words
        assert_eq!(log.slots_per_sector(), 4);
        let mut buf = [0u32; P];
        for k in 1..=30u32 {
            assert_eq!(log.append(&payload(k, P)).unwrap(), k);
            let mut reopened = FieldLog::open(log.into_flash(), P).unwrap();
            assert_eq!(reopened.read_latest(&mut buf).unwrap(), Some(k));
            assert_eq!(buf.to_vec(), payload(k, P));
            log = reopened;
        }
    }

    #[test]
    fn wrong_lengths_are_rejected() {
        let mut log = FieldLog::open(RamFlash::<100>::new(), 20).unwrap();
        assert_eq!(log.append(&[0; 19]), Err(LogError::BadLength));
        assert_eq!(log.read_latest(&mut [0; 21]), Err(LogError::BadLength));
        assert!(matches!(FieldLog::open(RamFlash::<10>::new(), 20), Err(LogError::SectorTooSmall)));
    }

    #[test]
    fn garbage_flash_holds_no_record() {
        let mut flash = RamFlash::<256>::new();
        let mut s = 12345u32;
        for sector in 0..2 {
            let words: Vec<u32> = (0..256)
                .map(|_| {
                    s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                    s
                })
                .collect();
            // Program garbage, including things that look like headers.
            flash.write(sector, 0, &words).unwrap();
            flash.write(sector, 10, &[MAGIC, 7, 20]).unwrap_or(());
        }
        let mut log = FieldLog::open(flash, 20).unwrap();
        assert_eq!(log.latest_seq(), None);
        assert_eq!(log.append(&payload(1, 20)).unwrap(), 1);
        let mut buf = [0u32; 20];
        let mut log = FieldLog::open(log.into_flash(), 20).unwrap();
        assert_eq!(log.read_latest(&mut buf).unwrap(), Some(1));
    }

    /// The claim of the module: cut the power at a random step of a random append, many times over, with
    /// half-programmed words and half-erased sectors; after every power-on the log holds either the checkpoint
    /// being written or the one before, intact, and it keeps working.
    #[test]
    fn power_cuts_never_lose_more_than_one_checkpoint_nor_corrupt_it() {
        const P: usize = 24; // 29-word slots: 3 per 96-word sector, so erases come often
        let mut rng = 0xDEAD_BEEF_u64;
        let mut next = move || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            rng
        };
        let mut flash = RamFlash::<96>::new();
        let mut last_ok: Option<u32> = None; // the checkpoint number we know is committed
        let mut k = 0u32; // checkpoint numbers written so far
        let (mut cuts, mut recovered_new, mut recovered_old, mut cuts_in_erase) = (0, 0, 0, 0);
        for _round in 0..4000 {
            let mut log = FieldLog::open(flash, P).unwrap();
            let mut buf = [0u32; P];
            let got = log.read_latest(&mut buf).unwrap().map(|_| which(&buf, k).expect("never a corrupt record"));
            assert_eq!(got, last_ok, "recovered state");
            // A few clean appends, then one that loses power at a random step.
            let clean = (next() % 4) as u32;
            for _ in 0..clean {
                k += 1;
                log.append(&payload(k, P)).unwrap();
                last_ok = Some(k);
            }
            k += 1;
            let mut flash_cut = log.into_flash();
            let before_steps = flash_cut.steps;
            // An append takes at most 1 erase + 29 word writes.
            flash_cut.cut_after(next() % 31, next());
            let mut log = FieldLog::open(flash_cut, P).unwrap();
            let result = log.append(&payload(k, P));
            flash = log.into_flash();
            match result {
                Ok(_) => last_ok = Some(k),
                Err(LogError::Flash(RamFlashError::PowerCut)) => {
                    cuts += 1;
                    if flash.steps - before_steps == 1 && flash.is_dead() {
                        cuts_in_erase += 1;
                    }
                }
                Err(e) => panic!("{e:?}"),
            }
            flash.power_on();
            let mut check = FieldLog::open(flash, P).unwrap();
            let got = check.read_latest(&mut buf).unwrap().map(|_| which(&buf, k).expect("never corrupt"));
            if got == Some(k) {
                recovered_new += 1;
                last_ok = Some(k);
            } else {
                assert_eq!(got, last_ok, "a cut during checkpoint {k} recovered {got:?}");
                recovered_old += 1;
            }
            flash = check.into_flash();
        }
        assert!(cuts > 2000 && recovered_old > 1000 && recovered_new > 100, "{cuts} {recovered_old} {recovered_new}");
        let _ = cuts_in_erase;
    }

    #[test]
    fn checkpoints_round_trip_and_pool_sessions() {
        let mut accs = [OctaveAllan::<8>::new(), OctaveAllan::<8>::new()];
        for i in 0..5000u32 {
            accs[0].push((2048 + (i * 7919) % 61) as u16);
            accs[1].push((1000 + (i * 104_729) % 4000) as u16);
        }
        let snaps = [accs[0].snapshot(), accs[1].snapshot()];
        let cp = Checkpoint::<2>::merge_session(None, &snaps, 3);
        let mut words = vec![0u32; Checkpoint::<2>::WORDS];
        cp.encode::<()>(&mut words).unwrap();
        let back = Checkpoint::<2>::decode::<()>(&words).unwrap();
        assert_eq!(back, cp);
        assert_eq!(back.sessions, 1);

        let second = Checkpoint::<2>::merge_session(Some(&back), &snaps, 1);
        assert_eq!(second.sessions, 2);
        assert_eq!(second.adc_overruns, 4);
        assert_eq!(second.snapshots[1].samples, 10_000);
        assert_eq!(second.snapshots[0].levels[3].n, 2 * snaps[0].levels[3].n);

        // The log stores it like any payload.
        let mut log = FieldLog::open(RamFlash::<2048>::new(), Checkpoint::<2>::WORDS).unwrap();
        second.encode::<()>(&mut words).unwrap();
        log.append(&words).unwrap();
        let mut log = FieldLog::open(log.into_flash(), Checkpoint::<2>::WORDS).unwrap();
        let mut buf = vec![0u32; Checkpoint::<2>::WORDS];
        log.read_latest(&mut buf).unwrap();
        assert_eq!(Checkpoint::<2>::decode::<()>(&buf).unwrap(), second);
    }

    #[test]
    fn four_gyro_checkpoints_fit_the_f405_sectors() {
        let slot_bytes = (Checkpoint::<4>::WORDS + OVERHEAD_WORDS) * 4;
        let per_sector = STM32F405_LOG_SECTORS[0].bytes as usize / slot_bytes;
        // A sector holds several checkpoints, so an erase (and its stall) comes once per few checkpoints.
        assert!(per_sector >= 4, "{per_sector} checkpoints per 16 KiB sector");
        assert_eq!(STM32F405_LOG_SECTORS[0].address + STM32F405_LOG_SECTORS[0].bytes, STM32F405_LOG_SECTORS[1].address);
    }
}

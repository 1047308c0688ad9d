//! A model of the STM32F405's flash controller (RM0090 section 3) over a [`RamFlash`] array: the register rules
//! the driver's sequences must follow (the key sequences, PG before a store, PSIZE matching a word store,
//! alignment, SER with STRT, the write-1-to-clear status flags, BSY for a few reads after each operation), the
//! datasheet's worst-case time of each operation at the parallelism it ran at, and faults to inject.
//!
//! The host tests drive [`super::erase_sector`], [`super::program`] and [`super::set_brown_out_level`] through it;
//! the QEMU firmware keeps its field log in it and stalls the CPU for the time it reports.

use super::{cr, erase_worst_us, optcr, sr, FlashOp, FlashRegs, Parallelism, PROGRAM_OP_WORST_US};
use crate::fieldlog::{LogFlash, LogSector, RamFlash};

/// The controller and two sectors of flash, `W` words of each backed by RAM; every other address is the
/// program, write-protected.
pub struct ControllerModel<const W: usize> {
    sectors: [LogSector; 2],
    /// The flash array of the two sectors (it can lose power: [`RamFlash::cut_after`]).
    pub array: RamFlash<W>,
    cr: u32,
    sr: u32,
    optcr: u32,
    /// The option bytes as programmed (OPTCR shows them after a reset).
    option_bytes: u32,
    keys_seen: u8,
    opt_keys_seen: u8,
    /// A wrong key locks FLASH_CR until the next reset.
    locked_out: bool,
    busy_reads: u8,
    busy_us: u64,
    /// Time of the programming sequence in progress (since PG was set).
    program_us: u64,
    inject: Option<(FlashOp, u32)>,
    /// What the driver did, for the tests.
    pub log: ModelLog,
}

/// What the driver did to the model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ModelLog {
    /// Sector erases carried out.
    pub erases: u32,
    /// Words programmed.
    pub words: u32,
    /// Option-byte writes carried out.
    pub option_writes: u32,
    /// Rule breaks by the driver (flags the model raised that were not injected): 0 for a correct driver.
    pub violations: u32,
    /// The parallelism of the last erase or program.
    pub parallelism: Option<Parallelism>,
    /// Total worst-case busy time, microseconds.
    pub busy_us: u64,
    /// The longest single erase or programming sequence, microseconds.
    pub longest_us: u64,
}

impl<const W: usize> ControllerModel<W> {
    /// After a power-on reset: locked, both sectors erased, factory option bytes (brown-out off).
    pub const fn new(sectors: [LogSector; 2]) -> Self {
        Self {
            sectors,
            array: RamFlash::new(),
            cr: cr::LOCK,
            sr: 0,
            optcr: optcr::RESET,
            option_bytes: optcr::RESET,
            keys_seen: 0,
            opt_keys_seen: 0,
            locked_out: false,
            busy_reads: 0,
            busy_us: 0,
            program_us: 0,
            inject: None,
            log: ModelLog {
                erases: 0,
                words: 0,
                option_writes: 0,
                violations: 0,
                parallelism: None,
                busy_us: 0,
                longest_us: 0,
            },
        }
    }

    /// A reset: the registers as after power-on, OPTCR loaded from the option bytes; the array keeps its words.
    pub fn reset(&mut self) {
        self.cr = cr::LOCK;
        self.sr = 0;
        self.optcr = self.option_bytes | optcr::OPTLOCK;
        self.keys_seen = 0;
        self.opt_keys_seen = 0;
        self.locked_out = false;
        self.busy_reads = 0;
    }

    /// The next operation of kind `op` fails with the status `flags` (and changes nothing).
    pub fn inject(&mut self, op: FlashOp, flags: u32) {
        self.inject = Some((op, flags));
    }

    /// The option bytes as programmed.
    pub fn option_bytes(&self) -> u32 {
        self.option_bytes
    }

    /// Worst-case busy time since the last call, microseconds (what QEMU stalls for).
    pub fn take_busy_us(&mut self) -> u64 {
        core::mem::take(&mut self.busy_us)
    }

    fn locked(&self) -> bool {
        self.cr & cr::LOCK != 0
    }

    fn psize(&self) -> Parallelism {
        Parallelism::from_bits((self.cr & cr::PSIZE_MASK) >> cr::PSIZE_SHIFT)
    }

    /// The driver broke a rule: raise `flags` as the hardware would.
    fn violation(&mut self, flags: u32) {
        self.log.violations += 1;
        self.sr |= flags;
    }

    /// An injected fault for `op`, if one is pending.
    fn injected(&mut self, op: FlashOp) -> bool {
        match self.inject {
            Some((o, flags)) if o == op => {
                self.sr |= flags;
                self.inject = None;
                self.busy_reads = 2;
                true
            }
            _ => false,
        }
    }

    fn busy(&mut self, us: u64) {
        self.busy_us += us;
        self.log.busy_us += us;
        self.busy_reads = 2;
        self.sr |= sr::EOP;
    }

    /// The sector and word an address falls in, if the model backs it.
    fn locate(&self, address: u32) -> Option<(usize, usize)> {
        self.sectors.iter().enumerate().find_map(|(i, s)| {
            let off = address.checked_sub(s.address)? as usize;
            (off < 4 * W).then_some((i, off / 4))
        })
    }

    fn start_erase(&mut self, value: u32) {
        if value & cr::PG != 0 || value & cr::MER != 0 {
            return self.violation(sr::PGSERR);
        }
        let snb = ((value & cr::SNB_MASK) >> cr::SNB_SHIFT) as u8;
        let Some(sector) = self.sectors.iter().position(|s| s.index == snb) else {
            // Erasing the program's own sectors: write-protected here.
            return self.violation(sr::WRPERR);
        };
        if self.injected(FlashOp::Erase) {
            return;
        }
        let psize = self.psize();
        let us = erase_worst_us(self.sectors[sector].bytes, psize);
        self.log.parallelism = Some(psize);
        self.log.longest_us = self.log.longest_us.max(us);
        self.log.erases += 1;
        if self.array.erase(sector).is_err() {
            self.sr |= sr::OPERR;
        }
        self.busy(us);
    }
}

impl<const W: usize> FlashRegs for ControllerModel<W> {
    fn cr(&mut self) -> u32 {
        self.cr
    }

    fn set_cr(&mut self, value: u32) {
        if self.locked() {
            return;
        }
        if self.busy_reads > 0 {
            // Written while busy: RM0090 forbids it.
            self.log.violations += 1;
        }
        // A programming sequence runs from setting PG to clearing it: its time counts as one stall.
        match (self.cr & cr::PG != 0, value & cr::PG != 0) {
            (false, true) => self.program_us = 0,
            (true, false) => self.log.longest_us = self.log.longest_us.max(self.program_us),
            _ => {}
        }
        self.cr = value & !cr::STRT;
        if value & cr::STRT != 0 {
            if value & cr::SER != 0 || value & cr::MER != 0 {
                self.start_erase(value);
            } else {
                self.violation(sr::PGSERR);
            }
        }
    }

    fn sr(&mut self) -> u32 {
        if self.busy_reads > 0 {
            self.busy_reads -= 1;
            return self.sr | sr::BSY;
        }
        self.sr
    }

    fn clear_sr(&mut self, flags: u32) {
        self.sr &= !flags;
    }

    fn key(&mut self, key: u32) {
        if self.locked_out || !self.locked() {
            // A key written out of sequence: a bus error, and FLASH_CR stays locked until the next reset.
            self.log.violations += 1;
            self.locked_out = true;
            self.cr |= cr::LOCK;
            return;
        }
        match (self.keys_seen, key) {
            (0, k) if k == super::KEYS[0] => self.keys_seen = 1,
            (1, k) if k == super::KEYS[1] => {
                self.keys_seen = 0;
                self.cr &= !cr::LOCK;
            }
            _ => {
                self.log.violations += 1;
                self.locked_out = true;
                self.cr |= cr::LOCK;
            }
        }
    }

    fn optcr(&mut self) -> u32 {
        self.optcr
    }

    fn set_optcr(&mut self, value: u32) {
        if self.optcr & optcr::OPTLOCK != 0 {
            return;
        }
        self.optcr = value & !optcr::OPTSTRT;
        if value & optcr::OPTSTRT == 0 {
            return;
        }
        if self.injected(FlashOp::OptionBytes) {
            return;
        }
        self.option_bytes = value & !(optcr::OPTSTRT | optcr::OPTLOCK);
        self.log.option_writes += 1;
        // RM0090 gives no figure for it; a sector erase's worth at x8 bounds it.
        self.busy(erase_worst_us(16 * 1024, Parallelism::X8));
    }

    fn opt_key(&mut self, key: u32) {
        if self.optcr & optcr::OPTLOCK == 0 {
            return;
        }
        match (self.opt_keys_seen, key) {
            (0, k) if k == super::OPT_KEYS[0] => self.opt_keys_seen = 1,
            (1, k) if k == super::OPT_KEYS[1] => {
                self.opt_keys_seen = 0;
                self.optcr &= !optcr::OPTLOCK;
            }
            _ => {
                self.log.violations += 1;
                self.opt_keys_seen = 0;
            }
        }
    }

    fn store(&mut self, address: u32, value: u32) {
        if self.locked() || self.cr & cr::PG == 0 {
            return self.violation(sr::PGSERR);
        }
        if self.psize() != Parallelism::X32 {
            // A word store at another parallelism.
            return self.violation(sr::PGPERR);
        }
        if !address.is_multiple_of(4) {
            return self.violation(sr::PGAERR);
        }
        let Some((sector, word)) = self.locate(address) else {
            return self.violation(sr::WRPERR);
        };
        if self.injected(FlashOp::Program) {
            return;
        }
        self.log.parallelism = Some(Parallelism::X32);
        self.log.words += 1;
        if self.array.write(sector, word, &[value]).is_err() {
            self.sr |= sr::OPERR;
        }
        self.program_us += PROGRAM_OP_WORST_US;
        self.busy(PROGRAM_OP_WORST_US);
    }

    fn load(&mut self, address: u32) -> u32 {
        let mut w = [crate::fieldlog::ERASED];
        if let Some((sector, word)) = self.locate(address) {
            let _ = self.array.read(sector, word, &mut w);
        }
        w[0]
    }
}

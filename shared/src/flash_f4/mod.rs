//! The STM32F405's flash controller (RM0090 section 3): a sector erase and word programming at x32 parallelism,
//! and the brown-out option byte, each checked through the status register's error flags.
//!
//! The sequences live here, over the [`FlashRegs`] trait, so they run unchanged on three targets: the board
//! (the firmware implements the trait with the PAC), QEMU (the same [`model::ControllerModel`] the host tests use,
//! stalling the CPU for the datasheet's worst-case time of each operation) and the host tests, which check every
//! register the sequences touch against the model of RM0090's rules.
//!
//! Why x32: embassy-stm32's F4 erase leaves PSIZE at x8, where a 16 KiB sector takes up to 0.8 s; at x32 it takes
//! at most 0.5 s. x32 needs a supply of 2.7 V or more, which the brown-out level 3 the board is brought up with
//! guarantees ([`brown_out_level`], [`set_brown_out_level`]).
//!
//! The worst-case times ([`erase_worst_us`], [`program_worst_us`]) are what the firmware proves its sample ring
//! against at build time.

pub mod log;
pub mod model;

pub use log::F4LogFlash;

/// FLASH_KEYR's unlock sequence.
pub const KEYS: [u32; 2] = [0x4567_0123, 0xCDEF_89AB];
/// FLASH_OPTKEYR's unlock sequence.
pub const OPT_KEYS: [u32; 2] = [0x0819_2A3B, 0x4C5D_6E7F];

/// FLASH_CR bits.
pub mod cr {
    /// Programming.
    pub const PG: u32 = 1 << 0;
    /// Sector erase.
    pub const SER: u32 = 1 << 1;
    /// Mass erase.
    pub const MER: u32 = 1 << 2;
    /// Sector number, bits 6:3.
    pub const SNB_SHIFT: u32 = 3;
    /// Sector number mask.
    pub const SNB_MASK: u32 = 0xF << SNB_SHIFT;
    /// Parallelism, bits 9:8.
    pub const PSIZE_SHIFT: u32 = 8;
    /// Parallelism mask.
    pub const PSIZE_MASK: u32 = 0b11 << PSIZE_SHIFT;
    /// Start an erase.
    pub const STRT: u32 = 1 << 16;
    /// Locked (until the key sequence).
    pub const LOCK: u32 = 1 << 31;
}

/// FLASH_SR bits.
pub mod sr {
    /// End of operation.
    pub const EOP: u32 = 1 << 0;
    /// Operation error.
    pub const OPERR: u32 = 1 << 1;
    /// Write protection error.
    pub const WRPERR: u32 = 1 << 4;
    /// Programming alignment error.
    pub const PGAERR: u32 = 1 << 5;
    /// Programming parallelism error.
    pub const PGPERR: u32 = 1 << 6;
    /// Programming sequence error.
    pub const PGSERR: u32 = 1 << 7;
    /// Busy.
    pub const BSY: u32 = 1 << 16;
    /// Every error flag.
    pub const ERRORS: u32 = OPERR | WRPERR | PGAERR | PGPERR | PGSERR;
}

/// FLASH_OPTCR bits.
pub mod optcr {
    /// Option bytes locked (until the option key sequence).
    pub const OPTLOCK: u32 = 1 << 0;
    /// Start the option bytes' programming.
    pub const OPTSTRT: u32 = 1 << 1;
    /// Brown-out level, bits 3:2.
    pub const BOR_SHIFT: u32 = 2;
    /// Brown-out level mask.
    pub const BOR_MASK: u32 = 0b11 << BOR_SHIFT;
    /// The register's value after a reset with factory option bytes (RM0090 section 3.9.10).
    pub const RESET: u32 = 0x0FFF_AAED;
}

/// The program/erase parallelism (FLASH_CR.PSIZE), which the supply voltage bounds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Parallelism {
    /// Byte at a time (1.8 V and up).
    X8,
    /// Half-word (2.1 V and up).
    X16,
    /// Word (2.7 V and up): what this driver uses.
    X32,
    /// Double word (needs an external Vpp).
    X64,
}

impl Parallelism {
    /// The PSIZE field's value.
    pub const fn bits(self) -> u32 {
        match self {
            Parallelism::X8 => 0,
            Parallelism::X16 => 1,
            Parallelism::X32 => 2,
            Parallelism::X64 => 3,
        }
    }

    /// From the PSIZE field.
    pub const fn from_bits(bits: u32) -> Self {
        match bits & 0b11 {
            0 => Parallelism::X8,
            1 => Parallelism::X16,
            2 => Parallelism::X32,
            _ => Parallelism::X64,
        }
    }
}

/// The parallelism this driver erases and programs at.
pub const PARALLELISM: Parallelism = Parallelism::X32;

/// Worst-case erase time of a sector of `bytes` at `psize`, microseconds: DS8626 table 44's maxima for the 16, 64
/// and 128 KiB sectors (x8 800/2400/4000 ms, x16 600/1400/2600 ms, x32 and x64 500/1100/2000 ms).
pub const fn erase_worst_us(bytes: u32, psize: Parallelism) -> u64 {
    let ms = match (bytes, psize) {
        (0..=16_384, Parallelism::X8) => 800,
        (0..=16_384, Parallelism::X16) => 600,
        (0..=16_384, _) => 500,
        (16_385..=65_536, Parallelism::X8) => 2400,
        (16_385..=65_536, Parallelism::X16) => 1400,
        (16_385..=65_536, _) => 1100,
        (_, Parallelism::X8) => 4000,
        (_, Parallelism::X16) => 2600,
        _ => 2000,
    };
    ms * 1000
}

/// Worst-case time of one program operation (a byte at x8, a word at x32), microseconds (DS8626 table 44).
pub const PROGRAM_OP_WORST_US: u64 = 100;

/// Worst-case time to program `words` 32-bit words at `psize`, microseconds: one operation per byte at x8, per
/// half-word at x16, per word at x32.
pub const fn program_worst_us(words: usize, psize: Parallelism) -> u64 {
    let ops_per_word = match psize {
        Parallelism::X8 => 4,
        Parallelism::X16 => 2,
        _ => 1,
    };
    words as u64 * ops_per_word * PROGRAM_OP_WORST_US
}

/// The controller's registers and the flash array, as the sequences see them.
///
/// Every method is one bus access; implementations must not reorder them.
pub trait FlashRegs {
    /// Read FLASH_CR.
    fn cr(&mut self) -> u32;
    /// Write FLASH_CR.
    fn set_cr(&mut self, value: u32);
    /// Read FLASH_SR.
    fn sr(&mut self) -> u32;
    /// Write FLASH_SR (its flags clear where a 1 is written).
    fn clear_sr(&mut self, flags: u32);
    /// Write FLASH_KEYR.
    fn key(&mut self, key: u32);
    /// Read FLASH_OPTCR.
    fn optcr(&mut self) -> u32;
    /// Write FLASH_OPTCR.
    fn set_optcr(&mut self, value: u32);
    /// Write FLASH_OPTKEYR.
    fn opt_key(&mut self, key: u32);
    /// A 32-bit store to the flash array at `address`.
    fn store(&mut self, address: u32, value: u32);
    /// A 32-bit load from the flash array at `address`.
    fn load(&mut self, address: u32) -> u32;
    /// After an erase or a programming sequence: the board resets the ART caches (RM0090 section 3.5.2), QEMU
    /// stalls for the time the operation takes.
    fn changed(&mut self) {}
}

/// A failed flash operation: the status register's error flags, and which operation raised them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FlashError {
    /// What was being done.
    pub op: FlashOp,
    /// FLASH_SR's error flags ([`sr::ERRORS`]) when it failed; 0 when the controller stayed locked.
    pub flags: u32,
    /// The address programmed, or the sector's first address.
    pub address: u32,
}

/// A flash operation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FlashOp {
    /// Unlocking FLASH_CR or FLASH_OPTCR.
    Unlock,
    /// A sector erase.
    Erase,
    /// Programming a word.
    Program,
    /// Writing the option bytes.
    OptionBytes,
}

impl core::fmt::Display for FlashError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let names = [
            (sr::OPERR, "OPERR"),
            (sr::WRPERR, "WRPERR"),
            (sr::PGAERR, "PGAERR"),
            (sr::PGPERR, "PGPERR"),
            (sr::PGSERR, "PGSERR"),
        ];
        write!(f, "flash {:?} at {:#010x} failed:", self.op, self.address)?;
        if self.flags == 0 {
            return f.write_str(" the controller stayed locked");
        }
        for (bit, name) in names {
            if self.flags & bit != 0 {
                write!(f, " {name}")?;
            }
        }
        Ok(())
    }
}

/// Wait while the controller is busy; then the error flags (cleared once read).
fn wait_idle<R: FlashRegs>(regs: &mut R) -> u32 {
    while regs.sr() & sr::BSY != 0 {}
    let flags = regs.sr() & sr::ERRORS;
    if flags != 0 {
        regs.clear_sr(flags);
    }
    flags
}

/// Unlock FLASH_CR (no-op when it is unlocked).
fn unlock<R: FlashRegs>(regs: &mut R, address: u32) -> Result<(), FlashError> {
    if regs.cr() & cr::LOCK != 0 {
        regs.key(KEYS[0]);
        regs.key(KEYS[1]);
    }
    if regs.cr() & cr::LOCK != 0 {
        return Err(FlashError { op: FlashOp::Unlock, flags: 0, address });
    }
    Ok(())
}

/// Erase sector `snb` (whose first address is `address`, for the error) at [`PARALLELISM`]: RM0090 section 3.6.3.
/// The controller is locked again afterwards.
///
/// # Errors
/// The status register's error flags after the erase (or before it, left by an earlier operation and cleared
/// here), or a controller that would not unlock.
pub fn erase_sector<R: FlashRegs>(regs: &mut R, snb: u8, address: u32) -> Result<(), FlashError> {
    wait_idle(regs);
    unlock(regs, address)?;
    let select = cr::SER | ((u32::from(snb) << cr::SNB_SHIFT) & cr::SNB_MASK) | (PARALLELISM.bits() << cr::PSIZE_SHIFT);
    regs.set_cr(select);
    regs.set_cr(select | cr::STRT);
    let flags = wait_idle(regs);
    regs.set_cr(cr::LOCK);
    regs.changed();
    if flags != 0 {
        return Err(FlashError { op: FlashOp::Erase, flags, address });
    }
    Ok(())
}

/// Program `words` from `address` on (word-aligned) at [`PARALLELISM`], one word at a time in increasing address
/// order: RM0090 section 3.6.4. Stops at the first word that fails; the controller is locked again afterwards.
///
/// # Errors
/// The failing word's address and the status register's error flags.
pub fn program<R: FlashRegs>(regs: &mut R, address: u32, words: &[u32]) -> Result<(), FlashError> {
    wait_idle(regs);
    unlock(regs, address)?;
    regs.set_cr(cr::PG | (PARALLELISM.bits() << cr::PSIZE_SHIFT));
    let mut result = Ok(());
    for (i, &w) in words.iter().enumerate() {
        let at = address + 4 * i as u32;
        regs.store(at, w);
        let flags = wait_idle(regs);
        if flags != 0 {
            result = Err(FlashError { op: FlashOp::Program, flags, address: at });
            break;
        }
    }
    regs.set_cr(cr::LOCK);
    regs.changed();
    result
}

/// The brown-out reset level the option bytes set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BrownOut {
    /// Reset below about 2.70 V (BOR_LEV = 00): the supply the x32 parallelism needs.
    Level3,
    /// About 2.40 V (01).
    Level2,
    /// About 2.10 V (10).
    Level1,
    /// Off: the power-on reset only, about 1.8 V (11, the factory setting).
    Off,
}

impl BrownOut {
    /// From the BOR_LEV field.
    pub const fn from_bits(bits: u32) -> Self {
        match bits & 0b11 {
            0 => BrownOut::Level3,
            1 => BrownOut::Level2,
            2 => BrownOut::Level1,
            _ => BrownOut::Off,
        }
    }

    /// The BOR_LEV field's value.
    pub const fn bits(self) -> u32 {
        match self {
            BrownOut::Level3 => 0,
            BrownOut::Level2 => 1,
            BrownOut::Level1 => 2,
            BrownOut::Off => 3,
        }
    }
}

/// The brown-out level the option bytes hold now.
pub fn brown_out_level<R: FlashRegs>(regs: &mut R) -> BrownOut {
    BrownOut::from_bits((regs.optcr() & optcr::BOR_MASK) >> optcr::BOR_SHIFT)
}

/// What [`set_brown_out_level`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OptionWrite {
    /// The option bytes already held the level; nothing was written.
    AlreadySet,
    /// The level was programmed and the controller reported no error.
    Written,
}

/// Program the brown-out level into the option bytes (RM0090 section 3.7.2), unless they hold it already, and
/// lock them again. A power cut during the write can leave the option bytes inconsistent, so this runs only when
/// asked (the bring-up), never at every boot.
///
/// # Errors
/// The status register's error flags after OPTSTRT, or option registers that would not unlock; the caller
/// reports the failure as one.
pub fn set_brown_out_level<R: FlashRegs>(regs: &mut R, level: BrownOut) -> Result<OptionWrite, FlashError> {
    if brown_out_level(regs) == level {
        return Ok(OptionWrite::AlreadySet);
    }
    let failed = |flags| FlashError { op: FlashOp::OptionBytes, flags, address: 0x1FFF_C000 };
    wait_idle(regs);
    if regs.optcr() & optcr::OPTLOCK != 0 {
        regs.opt_key(OPT_KEYS[0]);
        regs.opt_key(OPT_KEYS[1]);
    }
    if regs.optcr() & optcr::OPTLOCK != 0 {
        return Err(FlashError { op: FlashOp::Unlock, flags: 0, address: 0x1FFF_C000 });
    }
    let value = (regs.optcr() & !optcr::BOR_MASK) | (level.bits() << optcr::BOR_SHIFT);
    regs.set_optcr(value);
    regs.set_optcr(value | optcr::OPTSTRT);
    let flags = wait_idle(regs);
    let relock = regs.optcr() | optcr::OPTLOCK;
    regs.set_optcr(relock);
    if flags != 0 {
        return Err(failed(flags));
    }
    // FLASH_OPTCR now holds the value written whether or not the option bytes took it, so reading it back proves
    // nothing; the option bytes load at the next reset, where the boot reads BOR_LEV and warns unless it is set.
    Ok(OptionWrite::Written)
}

#[cfg(test)]
mod tests;

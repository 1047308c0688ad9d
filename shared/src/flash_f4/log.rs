//! The field log's flash on the STM32F405: [`LogFlash`] over the controller's checked sequences, for two
//! sectors of the MCU ([`crate::fieldlog::STM32F405_LOG_SECTORS`] on the board).

use super::{erase_sector, program, FlashError, FlashRegs};
use crate::fieldlog::{LogFlash, LogSector};

/// The log's two sectors through the controller `R`; `sector_words` of each are used (the whole sector on the
/// board; QEMU's model backs only part of it).
pub struct F4LogFlash<R> {
    regs: R,
    sectors: [LogSector; 2],
    sector_words: usize,
}

impl<R: FlashRegs> F4LogFlash<R> {
    /// The log on `sectors`, using their first `sector_words` words.
    ///
    /// # Panics
    /// If `sector_words` exceeds a sector.
    pub fn new(regs: R, sectors: [LogSector; 2], sector_words: usize) -> Self {
        assert!(sectors.iter().all(|s| sector_words * 4 <= s.bytes as usize), "the log's words fit its sectors");
        Self { regs, sectors, sector_words }
    }

    /// The controller, for what else goes through it (the option bytes).
    pub fn regs(&mut self) -> &mut R {
        &mut self.regs
    }

    fn address(&self, sector: usize, word: usize) -> u32 {
        self.sectors[sector].address + 4 * word as u32
    }
}

impl<R: FlashRegs> LogFlash for F4LogFlash<R> {
    type Error = FlashError;

    fn sector_words(&self) -> usize {
        self.sector_words
    }

    fn erase(&mut self, sector: usize) -> Result<(), FlashError> {
        let s = self.sectors[sector];
        erase_sector(&mut self.regs, s.index, s.address)
    }

    fn write(&mut self, sector: usize, offset: usize, words: &[u32]) -> Result<(), FlashError> {
        let address = self.address(sector, offset);
        program(&mut self.regs, address, words)
    }

    fn read(&mut self, sector: usize, offset: usize, buf: &mut [u32]) -> Result<(), FlashError> {
        let address = self.address(sector, offset);
        for (i, w) in buf.iter_mut().enumerate() {
            *w = self.regs.load(address + 4 * i as u32);
        }
        Ok(())
    }
}

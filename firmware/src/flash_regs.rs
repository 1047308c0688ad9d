//! The flash controller's registers and array on the board, through the PAC, for the shared checked sequences
//! (`octavar_shared::flash_f4`: erase and program at x32, the brown-out option byte), and its accelerator (the
//! ART's caches and prefetch).

use embassy_stm32::pac;
use embassy_stm32::pac::flash::regs::{Cr, Optcr, Sr};
use embassy_stm32::peripherals::FLASH;
use embassy_stm32::Peri;
use octavar_shared::flash_f4::FlashRegs;

/// The flash controller, owned: holding the peripheral keeps every other driver off it.
pub struct PacFlash {
    _flash: Peri<'static, FLASH>,
}

impl PacFlash {
    /// Take the controller.
    pub fn new(flash: Peri<'static, FLASH>) -> Self {
        Self { _flash: flash }
    }
}

impl FlashRegs for PacFlash {
    fn cr(&mut self) -> u32 {
        pac::FLASH.cr().read().0
    }

    fn set_cr(&mut self, value: u32) {
        pac::FLASH.cr().write_value(Cr(value));
    }

    fn sr(&mut self) -> u32 {
        pac::FLASH.sr().read().0
    }

    fn clear_sr(&mut self, flags: u32) {
        pac::FLASH.sr().write_value(Sr(flags));
    }

    fn key(&mut self, key: u32) {
        pac::FLASH.keyr().write_value(key);
    }

    fn optcr(&mut self) -> u32 {
        pac::FLASH.optcr().read().0
    }

    fn set_optcr(&mut self, value: u32) {
        pac::FLASH.optcr().write_value(Optcr(value));
    }

    fn opt_key(&mut self, key: u32) {
        pac::FLASH.optkeyr().write_value(key);
    }

    fn store(&mut self, address: u32, value: u32) {
        // SAFETY: the sequences store only into the field log's sectors (memory.x keeps the program out of them),
        // word-aligned, with PG set.
        unsafe { core::ptr::write_volatile(address as *mut u32, value) };
        cortex_m::asm::dsb();
    }

    fn load(&mut self, address: u32) -> u32 {
        // SAFETY: an aligned read of the memory-mapped flash.
        unsafe { core::ptr::read_volatile(address as *const u32) }
    }

    fn changed(&mut self) {
        flash_caches_reset();
    }
}

/// Instruction and data caches and prefetch on (embassy-stm32 sets the wait states but leaves the ART off).
pub fn flash_accelerator_on() {
    pac::FLASH.acr().modify(|w| {
        w.set_prften(true);
        w.set_icen(true);
        w.set_dcen(true);
    });
}

/// After a flash erase or write: the caches may hold the old contents of the changed lines. RM0090 section
/// 3.5.2: disable them, reset them, enable them again.
pub fn flash_caches_reset() {
    let acr = pac::FLASH.acr();
    acr.modify(|w| {
        w.set_icen(false);
        w.set_dcen(false);
    });
    acr.modify(|w| {
        w.set_icrst(true);
        w.set_dcrst(true);
    });
    acr.modify(|w| {
        w.set_icrst(false);
        w.set_dcrst(false);
    });
    flash_accelerator_on();
}

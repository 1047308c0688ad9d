//! The field log's flash in QEMU (feature `qemu`; QEMU's own flash is read-only): the board's x32 sequences
//! (`octavar_shared::flash_f4`) over the host tests' model of the flash controller.
//!
//! The model lives in RAM that the start-up code leaves alone (`.uninit`), so a reset is a power cycle of the
//! flash: what was programmed stays. QEMU starts with RAM zeroed, so the first boot finds no marker and starts
//! from erased sectors. Two build-time switches:
//! - `OCTAVAR_QEMU_FLASH_TIMING=worst`: each erase and programming stalls the CPU, interrupts masked, for the
//!   datasheet's worst case at the parallelism it ran at, and prints `octavar-qemu: flash busy US us`;
//! - `OCTAVAR_QEMU_POWER_CUT_STEP=N` (N > 0): on the first boot, the power fails during the flash's N-th step
//!   from boot (a word programmed or a sector erased; RamFlash leaves that step half done); the firmware prints
//!   `octavar-qemu: power cut at flash step N` and resets, as a power cycle would.

use core::mem::MaybeUninit;
use core::sync::atomic::{AtomicBool, Ordering};

use cortex_m_semihosting::hprintln;
use octavar_shared::fieldlog::STM32F405_LOG_SECTORS;
use octavar_shared::flash_f4::model::ControllerModel;
use octavar_shared::flash_f4::{F4LogFlash, FlashRegs};

use crate::qemu::{parse_u64, stall_cpu_us, FLASH_TIMING_WORST, SEED};

/// Words of each log sector the model backs: 8 KiB, two checkpoints each (so the log alternates and erases
/// often). The model charges erases for the whole 16 KiB sector.
pub const SECTOR_WORDS: usize = 2048;
/// The flash step during which the power fails on the first boot (`OCTAVAR_QEMU_POWER_CUT_STEP`; unset or 0:
/// never).
pub const POWER_CUT_STEP: Option<u64> = match parse_u64(option_env!("OCTAVAR_QEMU_POWER_CUT_STEP"), 0) {
    0 => None,
    n => Some(n),
};

/// Marks the model as set up by an earlier boot ("OCTF").
const MARKER: u32 = 0x4654_434F;

/// The model, in RAM the start-up code does not initialise.
#[link_section = ".uninit.octavar_flash_model"]
static mut MODEL: MaybeUninit<ControllerModel<SECTOR_WORDS>> = MaybeUninit::uninit();
/// [`MARKER`] once [`MODEL`] holds a model.
#[link_section = ".uninit.octavar_flash_marker"]
static mut MODEL_MARKER: MaybeUninit<u32> = MaybeUninit::uninit();

/// The field log's flash in QEMU.
pub type QemuFlash = F4LogFlash<ModelRegs>;

/// The model as the board's sequences see it (once per boot).
pub fn take() -> QemuFlash {
    static TAKEN: AtomicBool = AtomicBool::new(false);
    assert!(!TAKEN.swap(true, Ordering::Relaxed), "the flash model is taken once per boot");
    // SAFETY: taken once per boot (checked above), before any task runs; the marker tells a model an earlier boot
    // set up from RAM that was never written (QEMU zeroes RAM at start).
    let model = unsafe {
        let marker = core::ptr::addr_of_mut!(MODEL_MARKER).cast::<u32>();
        let model = &mut *core::ptr::addr_of_mut!(MODEL);
        if marker.read_volatile() == MARKER {
            let m = model.assume_init_mut();
            m.reset();
            m
        } else {
            let m = model.write(ControllerModel::new(STM32F405_LOG_SECTORS));
            if let Some(step) = POWER_CUT_STEP {
                m.array.cut_after(step - 1, SEED);
            }
            marker.write_volatile(MARKER);
            m
        }
    };
    F4LogFlash::new(ModelRegs(model), STM32F405_LOG_SECTORS, SECTOR_WORDS)
}

/// The controller model as the sequences' registers: stalls the CPU after each operation when
/// [`FLASH_TIMING_WORST`], and power-cycles the board when the model's power fails.
pub struct ModelRegs(&'static mut ControllerModel<SECTOR_WORDS>);

impl FlashRegs for ModelRegs {
    fn cr(&mut self) -> u32 {
        self.0.cr()
    }
    fn set_cr(&mut self, value: u32) {
        self.0.set_cr(value)
    }
    fn sr(&mut self) -> u32 {
        self.0.sr()
    }
    fn clear_sr(&mut self, flags: u32) {
        self.0.clear_sr(flags)
    }
    fn key(&mut self, key: u32) {
        self.0.key(key)
    }
    fn optcr(&mut self) -> u32 {
        self.0.optcr()
    }
    fn set_optcr(&mut self, value: u32) {
        self.0.set_optcr(value)
    }
    fn opt_key(&mut self, key: u32) {
        self.0.opt_key(key)
    }
    fn store(&mut self, address: u32, value: u32) {
        self.0.store(address, value)
    }
    fn load(&mut self, address: u32) -> u32 {
        self.0.load(address)
    }
    fn changed(&mut self) {
        let us = self.0.take_busy_us();
        if FLASH_TIMING_WORST && us > 0 {
            stall_cpu_us(us);
            hprintln!("octavar-qemu: flash busy {} us", us);
        }
        if self.0.log.violations > 0 {
            hprintln!("octavar-qemu: the flash sequences broke {} controller rules", self.0.log.violations);
        }
        if self.0.array.is_dead() {
            // The cells keep what the cut left; the power comes back with the reset.
            hprintln!("octavar-qemu: power cut at flash step {}", self.0.array.steps);
            self.0.array.power_on();
            cortex_m::peripheral::SCB::sys_reset();
        }
    }
}

//! The board: clocks, the flash accelerator, the brown-out level check, watchdog, the USB serial number, and one parts
//! struct per task. The crystal and the analog pins are the board variant's (`board_config.rs`).
//!
//! | signal                 | pin  | ADC1 channel | front end (see README)                  |
//! |------------------------|------|--------------|-----------------------------------------|
//! | IDG1215 X rate         | PA0  | IN0          | direct (3 V part)                       |
//! | IDG1215 Y rate         | PA1  | IN1          | direct (3 V part)                       |
//! | ADXRS300 rate          | PA2  | IN2          | 2/3 divider (5 V part, 2.5 V null)      |
//! | ENV-05H rate           | PA3  | IN3          | x3 around its 2.5 V null, centred 1.65 V |
//! | ADXRS300 TEMP          | PA4  | IN4          | 2/3 divider                             |
//! | USB OTG FS D- / D+     | PA11 / PA12 | -     | -                                       |
//! | SWD (probe-rs, defmt)  | PA13 / PA14 | -     | -                                       |
//!
//! The pins are those of `f405-8mhz`; the Feather's (`f405-12mhz`) are A0-A4 = PA4-PA7, PC4 (`board_config.rs`).
//! The scan order is the channel order of `octavar_shared::device::F405_CHANNELS`.

use embassy_stm32::pac;
use embassy_stm32::peripherals::{ADC1, DMA2_CH0, TIM3, TIM5, USB_OTG_FS};
use embassy_stm32::time::Hertz;
use embassy_stm32::{bind_interrupts, peripherals, usb, Config, Peri};
use octavar_shared::flash_f4::{self, BrownOut};

use crate::board_config::BOARD;

bind_interrupts!(
    /// The interrupts the tasks' drivers need.
    pub struct Irqs {
        OTG_FS => usb::InterruptHandler<peripherals::USB_OTG_FS>;
    }
);

/// The crystal on the board (HSE), Hz.
pub const HSE_HZ: u32 = BOARD.hse_hz;
/// PLL input divider M: a 2 MHz VCO input (RM0090 section 6.3.2 allows 1..2 MHz; 2 MHz has the least jitter).
pub const PLL_M: u32 = HSE_HZ / 2_000_000;
/// PLL multiplier N: VCO output 100..432 MHz.
pub const PLL_N: u32 = 168;
/// PLL divider P: the system clock.
pub const PLL_P: u32 = 2;
/// PLL divider Q: the 48 MHz USB clock.
pub const PLL_Q: u32 = 7;
/// VCO output, Hz.
pub const VCO_HZ: u32 = HSE_HZ / PLL_M * PLL_N;
/// System clock (and AHB, core, SysTick), Hz.
pub const SYSCLK_HZ: u32 = VCO_HZ / PLL_P;
/// USB OTG FS clock, Hz.
pub const USB_HZ: u32 = VCO_HZ / PLL_Q;
/// APB1 (42 MHz max): its timers run at twice it when the prescaler is not 1.
pub const APB1_HZ: u32 = SYSCLK_HZ / 4;
/// APB2 (84 MHz max): the ADC clock is APB2 / 4 = 21 MHz (36 MHz max).
pub const APB2_HZ: u32 = SYSCLK_HZ / 2;
/// The kernel clock of TIM2..TIM5, Hz.
pub const TIM3_HZ: u32 = 2 * APB1_HZ;

const _: () = assert!(HSE_HZ.is_multiple_of(2_000_000) && HSE_HZ >= 4_000_000 && HSE_HZ <= 26_000_000);
const _: () = assert!(PLL_M >= 2 && PLL_M <= 63);
const _: () = assert!(HSE_HZ / PLL_M >= 1_000_000 && HSE_HZ / PLL_M <= 2_000_000);
const _: () = assert!(VCO_HZ >= 100_000_000 && VCO_HZ <= 432_000_000);
const _: () = assert!(SYSCLK_HZ == 168_000_000 && USB_HZ == 48_000_000);
const _: () = assert!(APB1_HZ <= 42_000_000 && APB2_HZ <= 84_000_000);
// TIM3 divides exactly down to the sample rate: 84 MHz / 2 kHz = 42 000 counts, in 16 bits.
const _: () =
    assert!(TIM3_HZ.is_multiple_of(crate::config::SAMPLE_RATE_HZ) && TIM3_HZ / crate::config::SAMPLE_RATE_HZ <= 65_536);
// The field log's sectors are the ones memory.x reserves (sectors 1 and 2, before the program's `_stext`).
const _: () = assert!(octavar_shared::fieldlog::STM32F405_LOG_SECTORS[0].address == 0x0800_4000);
const _: () = assert!(octavar_shared::fieldlog::STM32F405_LOG_SECTORS[1].address == 0x0800_8000);
const _: () = assert!(octavar_shared::fieldlog::STM32F405_LOG_SECTORS[1].bytes == 16 * 1024);

/// What the sampler owns: ADC1, its DMA stream, the trigger timer and the trigger counter (`adc.rs`). `adc.rs`
/// drives them through the PAC; holding them here keeps every other driver off them.
#[allow(dead_code)]
pub struct SamplerParts {
    /// The converter.
    pub adc: Peri<'static, ADC1>,
    /// DMA2 stream 0 (ADC1's request, channel 0).
    pub dma: Peri<'static, DMA2_CH0>,
    /// The 2 kHz trigger.
    pub tim3: Peri<'static, TIM3>,
    /// The trigger counter: the hardware scan index.
    pub tim5: Peri<'static, TIM5>,
}

/// What the USB task owns.
pub struct UsbParts {
    /// The OTG FS core.
    pub otg: Peri<'static, USB_OTG_FS>,
    /// D+.
    pub dp: Peri<'static, peripherals::PA12>,
    /// D-.
    pub dm: Peri<'static, peripherals::PA11>,
}

/// What the store task owns: the flash controller (`flash_regs.rs`; the F405 stalls on flash reads during a
/// write or erase anyway, so the sequences poll).
pub struct StoreParts {
    /// The controller, driven by `octavar_shared::flash_f4`'s sequences.
    pub flash: crate::flash_regs::PacFlash,
}

/// All the parts, one struct per task, plus the core peripherals.
pub struct Parts {
    /// Sampler.
    pub sampler: SamplerParts,
    /// USB.
    pub usb: UsbParts,
    /// Store.
    pub store: StoreParts,
    /// SysTick, for the time driver.
    pub syst: cortex_m::peripheral::SYST,
}

/// Set the clocks and the flash accelerator, check the brown-out level, start the HAL and split the peripherals.
pub fn init() -> Parts {
    let mut config = Config::default();
    {
        use embassy_stm32::rcc::*;
        config.rcc.hse = Some(Hse { freq: Hertz(HSE_HZ), mode: HseMode::Oscillator });
        config.rcc.pll_src = PllSource::HSE;
        config.rcc.pll = Some(Pll {
            prediv: pll_prediv(PLL_M),
            mul: PllMul::MUL168,       // PLL_N
            divp: Some(PllPDiv::DIV2), // PLL_P: SYSCLK_HZ
            divq: Some(PllQDiv::DIV7), // PLL_Q: USB_HZ
            divr: None,
        });
        config.rcc.ahb_pre = AHBPrescaler::DIV1;
        config.rcc.apb1_pre = APBPrescaler::DIV4; // APB1_HZ
        config.rcc.apb2_pre = APBPrescaler::DIV2; // APB2_HZ
        config.rcc.sys = Sysclk::PLL1_P;
        config.rcc.mux.clk48sel = mux::Clk48sel::PLL1_Q;
    }
    let p = embassy_stm32::init(config);
    crate::flash_regs::flash_accelerator_on();
    let mut flash = crate::flash_regs::PacFlash::new(p.FLASH);
    check_brown_out(&mut flash);
    let core = cortex_m::Peripherals::take().expect("core peripherals are taken once");
    Parts {
        sampler: SamplerParts { adc: p.ADC1, dma: p.DMA2_CH0, tim3: p.TIM3, tim5: p.TIM5 },
        usb: UsbParts { otg: p.USB_OTG_FS, dp: p.PA12, dm: p.PA11 },
        store: StoreParts { flash },
        syst: core.SYST,
    }
}

/// The PLL's M divider as embassy-stm32 spells it.
const fn pll_prediv(m: u32) -> embassy_stm32::rcc::PllPreDiv {
    use embassy_stm32::rcc::PllPreDiv;
    match m {
        4 => PllPreDiv::DIV4,
        6 => PllPreDiv::DIV6,
        8 => PllPreDiv::DIV8,
        12 => PllPreDiv::DIV12,
        _ => panic!("add the PLL divider of this crystal"),
    }
}

/// The field log programs at x32, which needs 2.7 V: brown-out level 3 resets the MCU below that rather than let
/// a sagging battery corrupt a write. The level is an option byte, programmed once at bring-up
/// (`octavar_shared::flash_f4::set_brown_out_level`), never at boot: a power cut during an option-byte write can
/// corrupt the option bytes, and a write that fails would fail again on every boot. Here it is only read.
fn check_brown_out(flash: &mut crate::flash_regs::PacFlash) {
    match flash_f4::brown_out_level(flash) {
        BrownOut::Level3 => defmt::info!("board: brown-out reset at level 3 (2.70 V)"),
        other => defmt::warn!(
            "board: brown-out reset is {} (the option bytes): x32 flash writes need level 3; set it once at bring-up",
            other
        ),
    }
}

/// The chip's 96-bit unique ID as 24 hex digits: the USB serial number, so every board is its own port.
pub fn serial_number() -> &'static str {
    static SERIAL: static_cell::StaticCell<[u8; 24]> = static_cell::StaticCell::new();
    let buf = SERIAL.init([0; 24]);
    for (i, word) in (0..3).map(|n| pac::UID.uid(n).read()).enumerate() {
        for (k, b) in word.to_be_bytes().iter().enumerate() {
            let hex = b"0123456789ABCDEF";
            buf[8 * i + 2 * k] = hex[usize::from(b >> 4)];
            buf[8 * i + 2 * k + 1] = hex[usize::from(b & 0xF)];
        }
    }
    core::str::from_utf8(buf).unwrap_or("octavar")
}

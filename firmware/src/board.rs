//! The board: clocks, the pin table, the ADC channel map, and one parts struct per task.
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
//! The scan order is the channel order of `config::CHANNEL_KINDS`.

use embassy_stm32::adc::{AdcChannel, AnyAdcChannel};
use embassy_stm32::flash::{Blocking, Flash};
use embassy_stm32::peripherals::{ADC1, DMA2_CH0, TIM3, USB_OTG_FS};
use embassy_stm32::time::Hertz;
use embassy_stm32::{bind_interrupts, dma, peripherals, usb, Config, Peri};

bind_interrupts!(
    /// The interrupts the tasks' drivers need.
    pub struct Irqs {
        OTG_FS => usb::InterruptHandler<peripherals::USB_OTG_FS>;
        DMA2_STREAM0 => dma::InterruptHandler<peripherals::DMA2_CH0>;
    }
);

/// The crystal on the board (HSE), Hz.
pub const HSE_HZ: u32 = 8_000_000;
/// PLL input divider M: the VCO input must be 1..2 MHz (RM0090 section 6.3.2).
pub const PLL_M: u32 = 4;
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
/// APB1 (42 MHz max): TIM3 runs at twice it when the prescaler is not 1.
pub const APB1_HZ: u32 = SYSCLK_HZ / 4;
/// APB2 (84 MHz max): the ADC clock is APB2 / 4 = 21 MHz (36 MHz max).
pub const APB2_HZ: u32 = SYSCLK_HZ / 2;
/// TIM3's kernel clock, Hz.
pub const TIM3_HZ: u32 = 2 * APB1_HZ;

const _: () = assert!(HSE_HZ / PLL_M >= 1_000_000 && HSE_HZ / PLL_M <= 2_000_000);
const _: () = assert!(VCO_HZ >= 100_000_000 && VCO_HZ <= 432_000_000);
const _: () = assert!(SYSCLK_HZ == 168_000_000 && USB_HZ == 48_000_000);
const _: () = assert!(APB1_HZ <= 42_000_000 && APB2_HZ <= 84_000_000);
// TIM3 divides exactly down to the sample rate: 84 MHz / 2 kHz = 42 000 counts, in 16 bits.
const _: () =
    assert!(TIM3_HZ.is_multiple_of(crate::config::SAMPLE_RATE_HZ) && TIM3_HZ / crate::config::SAMPLE_RATE_HZ <= 65_536);
// The field log's sectors are the ones memory.x reserves (0x080C_0000, 2 x 128 KiB).
const _: () = assert!(octavar_shared::fieldlog::STM32F405_LOG_SECTORS[0].address == 0x080C_0000);
const _: () = assert!(octavar_shared::fieldlog::STM32F405_LOG_SECTORS[1].address == 0x080E_0000);

/// What the sampler owns: ADC1, its DMA stream, the trigger timer, and the analog inputs in scan order.
pub struct SamplerParts {
    /// The converter.
    pub adc: Peri<'static, ADC1>,
    /// DMA2 stream 0 (ADC1's request, channel 0).
    pub dma: Peri<'static, DMA2_CH0>,
    /// The 2 kHz trigger.
    pub tim: Peri<'static, TIM3>,
    /// IN0..IN4 in scan order.
    pub inputs: [AnyAdcChannel<'static, ADC1>; crate::config::CHANNELS],
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

/// What the store task owns: the flash controller.
pub struct StoreParts {
    /// Blocking flash driver (the F405 stalls on flash reads during a write or erase anyway).
    pub flash: Flash<'static, Blocking>,
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

/// Set the clocks, start the HAL and split the peripherals.
pub fn init() -> Parts {
    let mut config = Config::default();
    {
        use embassy_stm32::rcc::*;
        config.rcc.hse = Some(Hse { freq: Hertz(HSE_HZ), mode: HseMode::Oscillator });
        config.rcc.pll_src = PllSource::HSE;
        config.rcc.pll = Some(Pll {
            prediv: PllPreDiv::DIV4,   // PLL_M
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
    let core = cortex_m::Peripherals::take().expect("core peripherals are taken once");
    Parts {
        sampler: SamplerParts {
            adc: p.ADC1,
            dma: p.DMA2_CH0,
            tim: p.TIM3,
            inputs: [
                p.PA0.degrade_adc(),
                p.PA1.degrade_adc(),
                p.PA2.degrade_adc(),
                p.PA3.degrade_adc(),
                p.PA4.degrade_adc(),
            ],
        },
        usb: UsbParts { otg: p.USB_OTG_FS, dp: p.PA12, dm: p.PA11 },
        store: StoreParts { flash: Flash::new_blocking(p.FLASH) },
        syst: core.SYST,
    }
}

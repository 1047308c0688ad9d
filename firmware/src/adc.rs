//! The board's converter: TIM3 triggers a scan of the five ADC1 inputs 2000 times a second, DMA2 stream 0 writes
//! the codes into the sample ring in circular mode, and TIM5 counts TIM3's triggers: the hardware scan index.
//!
//! Timing: TIM3's update event (TRGO) starts each scan; a scan of five inputs at 480 sampling cycles takes
//! 5 x 492 / 21 MHz = 117 us of the 500 us period. TIM5 runs in external clock mode 1 on ITR1 (TIM3's TRGO,
//! RM0090 table 94), so its count is the number of scans started, whatever the CPU was doing: the sampler reads
//! it to know which ring slots hold which scans (`sampler.rs`). The DMA needs no interrupt.
//!
//! What the converter decides at run time is `octavar_shared::adc_f4`'s, over its register trait, and tested on
//! the host against a model of this hardware with faults injected: the 64-bit scan index, whether the converter
//! has failed (an overrun, a DMA error, a stopped stream, or a ring position that disagrees with the trigger
//! count), and the recovery of RM0090 section 13.8.1 (the ADC off and on again at its first channel, the DMA
//! re-armed at slot 0, the trigger enabled just after a TIM3 edge, so the first scan's index is known; TIM3 and
//! TIM5 run on throughout). This file holds the one-time configuration and those registers through the PAC.

use core::cell::UnsafeCell;

use embassy_stm32::pac;
use embassy_stm32::pac::adc::regs::{Cr2, Sr};
use embassy_stm32::pac::adc::vals::{Res, SampleTime};
use embassy_stm32::pac::adccommon::vals::Adcpre;
use embassy_stm32::pac::dma::regs::{Cr, Ixr, Ndtr};
use embassy_stm32::pac::gpio::vals::Moder;
use embassy_stm32::pac::timer::vals::{Mms, Sms, Ts};
use octavar_shared::adc_f4::{dma_flags, settled_ticks, Converter, ConverterConfig, ConverterRegs, Failure};

use crate::board::{SamplerParts, APB2_HZ, SYSCLK_HZ, TIM3_HZ};
use crate::board_config::{Port, BOARD};
use crate::config::*;

/// DMA2 stream 0 carries ADC1's requests on channel 0 (RM0090 table 43).
const DMA_STREAM: usize = 0;
/// Where the stream's flags sit in DMA_LISR/HISR and DMA_LIFCR/HIFCR.
const DMA_FLAG_SHIFT: u32 = [0, 6, 16, 22][DMA_STREAM % 4];
/// The ADC's clock: APB2 / 4 (ADC_CCR.ADCPRE), 21 MHz.
const ADC_HZ: u32 = APB2_HZ / 4;
/// ADC cycles per conversion: 480 sampling, 12 converting (RM0090 section 13.5).
const CONVERSION_CYCLES: u32 = 480 + 12;
/// TIM3 ticks per trigger period.
const PERIOD_TICKS: u32 = TIM3_HZ / SAMPLE_RATE_HZ;
/// TIM3 ticks from a trigger to its scan's last code: 3 ADC cycles of trigger latency, then the conversions.
const SCAN_TICKS: u32 = (3 + CHANNELS as u32 * CONVERSION_CYCLES) * (TIM3_HZ / ADC_HZ);
/// CPU cycles per TIM3 tick (the busy waits count CPU cycles).
const CPU_CYCLES_PER_TICK: u32 = SYSCLK_HZ / TIM3_HZ;

/// The converter's dimensions and timing for the shared decisions.
const CONVERTER: ConverterConfig = ConverterConfig {
    channels: CHANNELS,
    ring_scans: RING_SCANS,
    settled_ticks: settled_ticks(SCAN_TICKS, PERIOD_TICKS),
    // tSTAB is 3 us at most (the datasheet's ADC characteristics): wait 4.
    stabilisation_ticks: TIM3_HZ / 250_000,
};

const _: () = assert!(TIM3_HZ.is_multiple_of(ADC_HZ) && SYSCLK_HZ.is_multiple_of(TIM3_HZ));
// The check waits for the scan to settle (180 us at most, as firmware/README.md says): most of the period is
// left to read the ring's position in.
const _: () =
    assert!(CONVERTER.settled_ticks <= 180 * (TIM3_HZ / 1_000_000) && CONVERTER.settled_ticks < PERIOD_TICKS / 2);

/// The ring the DMA writes: shared with the hardware, so read only with volatile loads.
struct Ring(UnsafeCell<[u16; RING_CODES]>);
// SAFETY: the CPU only reads it (volatile), the DMA only writes it; the sampler's poll discards any copy the DMA
// may have overtaken or written while the converter was failing.
unsafe impl Sync for Ring {}
static RING: Ring = Ring(UnsafeCell::new([0; RING_CODES]));

/// The board's converter: the shared decisions over the PAC's registers.
pub type HwRing = Converter<PacConverter>;

/// ADC1, DMA2 stream 0, TIM3 and TIM5 through the PAC, owned (holding the parts keeps every other driver off
/// them).
pub struct PacConverter {
    _parts: SamplerParts,
}

/// Configure the pins, ADC1, DMA2 stream 0's addresses, TIM5 and TIM3, and start sampling: the first scan is
/// scan 0, in ring slot 0.
pub fn start(parts: SamplerParts) -> HwRing {
    pac::RCC.apb2enr().modify(|w| w.set_adc1en(true));
    pac::RCC.ahb1enr().modify(|w| {
        w.set_dma2en(true);
        w.set_gpioaen(true);
        w.set_gpioben(true);
        w.set_gpiocen(true);
    });
    pac::RCC.apb1enr().modify(|w| {
        w.set_tim3en(true);
        w.set_tim5en(true);
    });
    for p in &BOARD.adc_pins {
        let gpio = match p.port {
            Port::A => pac::GPIOA,
            Port::B => pac::GPIOB,
            Port::C => pac::GPIOC,
        };
        gpio.moder().modify(|w| w.set_moder(usize::from(p.pin), Moder::ANALOG));
    }

    // ADC clock: APB2 (84 MHz) / 4 = 21 MHz.
    pac::ADC123_COMMON.ccr().modify(|w| w.set_adcpre(Adcpre::DIV4));
    let adc = pac::ADC1;
    adc.cr2().write(|w| w.set_adon(false));
    adc.cr1().write(|w| {
        w.set_scan(true);
        w.set_res(Res::BITS12);
    });
    // SMPR2 holds channels 0-9, SMPR1 channels 10-18.
    for p in &BOARD.adc_pins {
        let ch = usize::from(p.channel);
        if ch < 10 {
            adc.smpr2().modify(|w| w.set_smp(ch, SampleTime::CYCLES480));
        } else {
            adc.smpr1().modify(|w| w.set_smp(ch - 10, SampleTime::CYCLES480));
        }
    }
    adc.sqr1().write(|w| w.set_l((CHANNELS - 1) as u8));
    adc.sqr3().write(|w| {
        for (rank, p) in BOARD.adc_pins.iter().enumerate() {
            w.set_sq(rank, p.channel);
        }
    });

    // TIM3 first, with its update event loading the prescaler before anything counts its TRGO.
    let tim3 = pac::TIM3;
    tim3.cr1().modify(|w| w.set_cen(false));
    tim3.psc().write_value(0);
    tim3.arr().write(|w| w.set_arr((PERIOD_TICKS - 1) as u16));
    tim3.egr().write(|w| w.set_ug(true));
    tim3.cr2().modify(|w| w.set_mms(Mms::UPDATE));

    // TIM5 counts TIM3's TRGO.
    let tim5 = pac::TIM5;
    tim5.cr1().modify(|w| w.set_cen(false));
    tim5.psc().write_value(0);
    tim5.arr().write_value(u32::MAX);
    tim5.smcr().modify(|w| {
        w.set_ts(Ts::ITR1);
        w.set_sms(Sms::EXT_CLOCK_MODE);
    });
    tim5.egr().write(|w| w.set_ug(true));
    tim5.cnt().write_value(0);
    tim5.cr1().modify(|w| w.set_cen(true));

    // The stream's addresses, once: ADC1's data register to the ring (the stream is disabled after reset).
    let st = pac::DMA2.st(DMA_STREAM);
    st.par().write_value(pac::ADC1.dr().as_ptr() as u32);
    st.m0ar().write_value(RING.0.get() as u32);

    let ring = Converter::start(PacConverter { _parts: parts }, CONVERTER);
    tim3.cr1().modify(|w| w.set_cen(true));
    defmt::info!("adc: {} channels at {} Hz, ring of {} scans", CHANNELS, SAMPLE_RATE_HZ, RING_SCANS);
    ring
}

impl ConverterRegs for PacConverter {
    fn adc_sr(&mut self) -> u32 {
        pac::ADC1.sr().read().0
    }

    fn set_adc_sr(&mut self, value: u32) {
        pac::ADC1.sr().write_value(Sr(value));
    }

    fn adc_cr2(&mut self) -> u32 {
        pac::ADC1.cr2().read().0
    }

    fn set_adc_cr2(&mut self, value: u32) {
        pac::ADC1.cr2().write_value(Cr2(value));
    }

    fn dma_cr(&mut self) -> u32 {
        pac::DMA2.st(DMA_STREAM).cr().read().0
    }

    fn set_dma_cr(&mut self, value: u32) {
        pac::DMA2.st(DMA_STREAM).cr().write_value(Cr(value));
    }

    fn dma_ndtr(&mut self) -> u32 {
        pac::DMA2.st(DMA_STREAM).ndtr().read().0
    }

    fn set_dma_ndtr(&mut self, value: u32) {
        pac::DMA2.st(DMA_STREAM).ndtr().write_value(Ndtr(value));
    }

    fn dma_flags(&mut self) -> u32 {
        (pac::DMA2.isr(DMA_STREAM / 4).read().0 >> DMA_FLAG_SHIFT) & dma_flags::ALL
    }

    fn clear_dma_flags(&mut self, flags: u32) {
        pac::DMA2.ifcr(DMA_STREAM / 4).write_value(Ixr((flags & dma_flags::ALL) << DMA_FLAG_SHIFT));
    }

    fn tim5_cnt(&mut self) -> u32 {
        pac::TIM5.cnt().read()
    }

    fn tim3_cnt(&mut self) -> u32 {
        u32::from(pac::TIM3.cnt().read().cnt())
    }

    fn read_ring(&mut self, from: usize, out: &mut [u16]) {
        assert!(from + out.len() <= RING_CODES);
        let base = RING.0.get() as *const u16;
        for (i, code) in out.iter_mut().enumerate() {
            // SAFETY: from + i < RING_CODES (checked above), so the index is in bounds; the read is volatile
            // because the DMA writes the ring.
            *code = unsafe { base.add(from + i).read_volatile() };
        }
    }

    fn delay_ticks(&mut self, ticks: u32) {
        cortex_m::asm::delay(ticks * CPU_CYCLES_PER_TICK);
    }

    fn critical<T>(&mut self, f: impl FnOnce(&mut Self) -> T) -> T {
        critical_section::with(|_| f(self))
    }

    fn failed(&mut self, failure: &Failure) {
        defmt::warn!("adc: {}: restarting", failure);
    }
}

const _: () = assert!(RING_SCANS.is_multiple_of(BLOCK_SCANS));

//! The board's converter: TIM3 triggers a scan of the five ADC1 inputs 2000 times a second, DMA2 stream 0 writes
//! the codes into the sample ring in circular mode, and TIM5 counts TIM3's triggers: the hardware scan index.
//!
//! Timing: TIM3's update event (TRGO) starts each scan; a scan of five inputs at 480 sampling cycles takes
//! 5 x 492 / 21 MHz = 117 us of the 500 us period. TIM5 runs in external clock mode 1 on ITR1 (TIM3's TRGO,
//! RM0090 table 94), so its count is the number of scans started, whatever the CPU was doing: the sampler reads
//! it to know which ring slots hold which scans (`sampler.rs`). The DMA needs no interrupt.
//!
//! Recovery (RM0090 section 13.8.1): an ADC overrun (OVR), a DMA error, a stopped stream, or a ring position
//! that disagrees with the trigger count (the channel order rotated) stops the scans and restarts them cleanly:
//! the ADC's trigger is disabled and the ADC switched off (which resets its sequencer to the first channel), the
//! DMA is re-armed at ring slot 0 with a full count, the ADC switched on, and its trigger enabled again right
//! after a TIM3 edge, so the first scan afterwards is on the TIM3 grid and its index is known. TIM3 and TIM5 run
//! on throughout: stopping TIM3 would lose the grid and the count that make the gap exact.

use core::cell::UnsafeCell;

use embassy_stm32::pac;
use embassy_stm32::pac::adc::vals::{Dds, Exten, Res, SampleTime};
use embassy_stm32::pac::adccommon::vals::Adcpre;
use embassy_stm32::pac::dma::vals::{Dir, Pl, Size};
use embassy_stm32::pac::gpio::vals::Moder;
use embassy_stm32::pac::timer::vals::{Mms, Sms, Ts};

use crate::board::{SamplerParts, TIM3_HZ};
use crate::board_config::{Port, BOARD};
use crate::config::*;
use crate::sampler::ScanRing;
use octavar_shared::device::ReadyBlock;

/// The ADC's regular-group trigger selection for TIM3's TRGO (RM0090 section 13.13.3, EXTSEL = 1000).
const EXTSEL_TIM3_TRGO: u8 = 0b1000;
/// DMA2 stream 0 carries ADC1's requests on channel 0 (RM0090 table 43).
const DMA_STREAM: usize = 0;

/// The ring the DMA writes: shared with the hardware, so read only with volatile loads.
struct Ring(UnsafeCell<[u16; RING_CODES]>);
// SAFETY: the CPU only reads it (volatile), the DMA only writes it; `sampler::run` discards any copy the DMA may
// have overtaken.
unsafe impl Sync for Ring {}
static RING: Ring = Ring(UnsafeCell::new([0; RING_CODES]));

/// The running converter.
pub struct HwRing {
    /// TIM5's last reading and its wraps (the count extended to 64 bits).
    last: u32,
    wraps: u32,
    /// Hardware index of the scan the DMA wrote to slot 0 first.
    base: u64,
    _parts: SamplerParts,
}

impl HwRing {
    /// Configure the pins, ADC1, DMA2 stream 0, TIM5 and TIM3, and start sampling.
    pub fn start(parts: SamplerParts) -> Self {
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
        tim3.arr().write(|w| w.set_arr((TIM3_HZ / SAMPLE_RATE_HZ - 1) as u16));
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

        arm_dma();
        adc_on();
        adc.cr2().modify(|w| w.set_exten(Exten::RISING_EDGE));
        tim3.cr1().modify(|w| w.set_cen(true));
        defmt::info!("adc: {} channels at {} Hz, ring of {} scans", CHANNELS, SAMPLE_RATE_HZ, RING_SCANS);
        HwRing { last: 0, wraps: 0, base: 0, _parts: parts }
    }

    /// Whether the DMA's position agrees with the trigger count (`None` if a trigger came between the reads).
    fn position_agrees(&mut self) -> Option<bool> {
        let s1 = self.started();
        let ndtr = u64::from(pac::DMA2.st(DMA_STREAM).ndtr().read().ndt());
        let s2 = self.started();
        if s1 != s2 || s1 < self.base {
            return None;
        }
        let ring = RING_CODES as u64;
        let written = (ring - ndtr) % ring;
        // Every started scan is written, but the last may still be converting (up to a scan's codes short).
        let expected = ((s1 - self.base) * CHANNELS as u64) % ring;
        Some((expected + ring - written) % ring <= CHANNELS as u64)
    }

    /// Stop the scans, re-arm the DMA at slot 0 and the ADC at its first channel, and restart on the TIM3 grid.
    /// Returns the hardware index of the first scan afterwards.
    fn recover(&mut self) -> u64 {
        let adc = pac::ADC1;
        let first = critical_section::with(|_| {
            adc.cr2().modify(|w| w.set_exten(Exten::DISABLED));
            adc.cr2().modify(|w| w.set_adon(false));
            adc.sr().modify(|w| {
                w.set_ovr(false);
                w.set_strt(false);
            });
            arm_dma();
            adc_on();
            // Wait for a TIM3 edge (at most one period), then enable the trigger well before the next one.
            let c0 = pac::TIM5.cnt().read();
            while pac::TIM5.cnt().read() == c0 {}
            adc.cr2().modify(|w| w.set_exten(Exten::RISING_EDGE));
            pac::TIM5.cnt().read()
        });
        let first = self.extend(first);
        self.base = first;
        first
    }

    fn extend(&mut self, low: u32) -> u64 {
        if low < self.last {
            self.wraps += 1;
        }
        self.last = low;
        (u64::from(self.wraps) << 32) | u64::from(low)
    }
}

/// Arm DMA2 stream 0: ADC1's data register to the whole ring, circular, half-words.
fn arm_dma() {
    let st = pac::DMA2.st(DMA_STREAM);
    st.cr().modify(|w| w.set_en(false));
    while st.cr().read().en() {}
    pac::DMA2.ifcr(DMA_STREAM / 4).write(|w| {
        let n = DMA_STREAM % 4;
        w.set_tcif(n, true);
        w.set_htif(n, true);
        w.set_teif(n, true);
        w.set_dmeif(n, true);
        w.set_feif(n, true);
    });
    st.par().write_value(pac::ADC1.dr().as_ptr() as u32);
    st.m0ar().write_value(RING.0.get() as u32);
    st.ndtr().write(|w| w.set_ndt(RING_CODES as u16));
    st.cr().write(|w| {
        w.set_chsel(0);
        w.set_dir(Dir::PERIPHERAL_TO_MEMORY);
        w.set_circ(true);
        w.set_minc(true);
        w.set_pinc(false);
        w.set_psize(Size::BITS16);
        w.set_msize(Size::BITS16);
        w.set_pl(Pl::VERY_HIGH);
    });
    st.cr().modify(|w| w.set_en(true));
}

/// Switch the ADC on with DMA requests after every conversion, and wait out its stabilisation (3 us).
fn adc_on() {
    pac::ADC1.cr2().modify(|w| {
        w.set_dma(false);
        w.set_dds(Dds::CONTINUOUS);
        w.set_extsel(EXTSEL_TIM3_TRGO);
    });
    pac::ADC1.cr2().modify(|w| {
        w.set_dma(true);
        w.set_adon(true);
    });
    cortex_m::asm::delay(crate::board::SYSCLK_HZ / 250_000);
}

impl ScanRing for HwRing {
    fn started(&mut self) -> u64 {
        let low = pac::TIM5.cnt().read();
        self.extend(low)
    }

    fn copy_block(&mut self, block: &ReadyBlock, out: &mut [u16; BLOCK_CODES]) {
        let slot = block.slot;
        let base = RING.0.get() as *const u16;
        for (i, code) in out.iter_mut().enumerate() {
            // SAFETY: slot + BLOCK_SCANS <= RING_SCANS (blocks tile the ring), so the index is in bounds; the
            // read is volatile because the DMA writes the ring.
            *code = unsafe { base.add(slot * CHANNELS + i).read_volatile() };
        }
    }

    fn check(&mut self) -> Option<u64> {
        let sr = pac::ADC1.sr().read();
        let isr = pac::DMA2.isr(DMA_STREAM / 4).read();
        let n = DMA_STREAM % 4;
        let stream_on = pac::DMA2.st(DMA_STREAM).cr().read().en();
        let failed = sr.ovr() || isr.teif(n) || isr.dmeif(n) || !stream_on || self.position_agrees() == Some(false);
        if !failed {
            return None;
        }
        defmt::warn!(
            "adc: overrun {} DMA error {} stream on {}: restarting",
            sr.ovr(),
            isr.teif(n) || isr.dmeif(n),
            stream_on
        );
        Some(self.recover())
    }
}

const _: () = assert!(RING_SCANS.is_multiple_of(BLOCK_SCANS));

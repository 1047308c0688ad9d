//! The STM32F405's sampling converter: TIM3 triggers a scan of ADC1's channels, DMA2 stream 0 writes the codes
//! into a ring in circular mode, and TIM5 counts TIM3's triggers, the hardware scan index. This module decides
//! whether the converter is healthy and recovers it when it is not, over the [`ConverterRegs`] trait, so the
//! same decisions run on the board (the firmware implements the trait with the PAC, `firmware/src/adc.rs`) and
//! in the host tests, against [`model::ScanModel`]: a model of the scan, the circular DMA and both timers with
//! faults injected.
//!
//! **The scan index.** TIM5 counts every trigger, whatever the CPU or the converter does; [`Converter`] extends
//! its 32 bits to 64 (the sampler reads it many times per wrap, which comes every 24 days at 2 kS/s).
//!
//! **Failure.** The converter has failed when the ADC overran (ADC_SR.OVR: the DMA requests then stop), the
//! stream reports a transfer or direct-mode error (TEIF, DMEIF), the stream is disabled (a transfer error
//! disables it), or the DMA's position in the ring disagrees with the trigger count (a code went missing, so
//! the channel order in the ring rotated). The flags hold until a recovery clears them, and a missing code keeps
//! the position off until the DMA is re-armed, so a check that passes after a block was copied proves the block
//! was written and read while the converter was healthy.
//!
//! **The position check is exact.** Every code of the scan a trigger starts is in the ring
//! [`ConverterConfig::settled_ticks`] after it (the conversions, the ADC's trigger latency and the DMA's
//! transfer, with margin): the check waits, if need be, until TIM3's count is past that point, then reads the
//! stream's NDTR between two readings of the trigger count that agree. The ring then holds exactly
//! `(started - base) * channels` codes since the DMA was armed, modulo its length; one code fewer is a failure.
//! (A tolerance of a scan's codes, as if the last scan might still be converting, would let a single missing code
//! through, and with it blocks whose channels are rotated.)
//!
//! **Recovery** (RM0090 section 13.8.1), with interrupts masked: the ADC's trigger is disabled and the ADC
//! switched off (which resets its sequencer to the first channel), OVR cleared, the stream re-armed at ring slot
//! 0 with a full count and its flags cleared, the ADC switched on with its DMA requests re-enabled and given its
//! stabilisation time, and its trigger enabled again just after a TIM3 edge: the first scan afterwards is the
//! next trigger, whose index is the count read then. TIM3 and TIM5 run on throughout: stopping TIM3 would lose
//! the grid and the count that make the gap exact.

pub mod model;

use crate::device::{ReadyBlock, ScanRing};

/// ADC_SR bits (RM0090 section 13.13.1): flags cleared by writing 0 (rc_w0).
pub mod adc_sr {
    /// End of conversion.
    pub const EOC: u32 = 1 << 1;
    /// Regular channel start flag.
    pub const STRT: u32 = 1 << 4;
    /// Overrun: a code was lost, and the DMA requests stopped.
    pub const OVR: u32 = 1 << 5;
    /// Every flag.
    pub const FLAGS: u32 = 0x3F;
}

/// ADC_CR2 bits (RM0090 section 13.13.3).
pub mod adc_cr2 {
    /// The ADC is on.
    pub const ADON: u32 = 1 << 0;
    /// DMA requests after each conversion.
    pub const DMA: u32 = 1 << 8;
    /// DMA requests go on after the last transfer of the DMA's count (needed for a circular ring).
    pub const DDS: u32 = 1 << 9;
    /// Regular group trigger selection, bits 27:24.
    pub const EXTSEL_MASK: u32 = 0xF << 24;
    /// EXTSEL = 1000: TIM3's TRGO.
    pub const EXTSEL_TIM3_TRGO: u32 = 0b1000 << 24;
    /// Regular group trigger edge, bits 29:28.
    pub const EXTEN_MASK: u32 = 0b11 << 28;
    /// EXTEN = 01: the rising edge.
    pub const EXTEN_RISING: u32 = 0b01 << 28;
}

/// DMA_SxCR bits (RM0090 section 10.5.5).
pub mod dma_cr {
    /// The stream is enabled.
    pub const EN: u32 = 1 << 0;
    /// Direction, bits 7:6 (00: peripheral to memory).
    pub const DIR_MASK: u32 = 0b11 << 6;
    /// Circular mode.
    pub const CIRC: u32 = 1 << 8;
    /// Peripheral address increment.
    pub const PINC: u32 = 1 << 9;
    /// Memory address increment.
    pub const MINC: u32 = 1 << 10;
    /// Peripheral data size, bits 12:11.
    pub const PSIZE_MASK: u32 = 0b11 << 11;
    /// PSIZE = 01: half-words.
    pub const PSIZE_16: u32 = 0b01 << 11;
    /// Memory data size, bits 14:13.
    pub const MSIZE_MASK: u32 = 0b11 << 13;
    /// MSIZE = 01: half-words.
    pub const MSIZE_16: u32 = 0b01 << 13;
    /// Priority level 11: very high.
    pub const PL_VERY_HIGH: u32 = 0b11 << 16;
    /// Channel selection, bits 27:25 (000: channel 0, ADC1's on stream 0, RM0090 table 43).
    pub const CHSEL_MASK: u32 = 0b111 << 25;
    /// The ring's stream: ADC1's data register to memory, channel 0, circular, half-words, very high priority.
    pub const RING: u32 = CIRC | MINC | PSIZE_16 | MSIZE_16 | PL_VERY_HIGH;
}

/// A DMA stream's flags in DMA_LISR/HISR and DMA_LIFCR/HIFCR, as stream 0's field (bits 5:0) holds them; the
/// register implementation moves them to its stream's field.
pub mod dma_flags {
    /// FIFO error.
    pub const FEIF: u32 = 1 << 0;
    /// Direct mode error.
    pub const DMEIF: u32 = 1 << 2;
    /// Transfer error: the hardware disabled the stream.
    pub const TEIF: u32 = 1 << 3;
    /// Half transfer.
    pub const HTIF: u32 = 1 << 4;
    /// Transfer complete (set too when software disables the stream).
    pub const TCIF: u32 = 1 << 5;
    /// Every flag.
    pub const ALL: u32 = FEIF | DMEIF | TEIF | HTIF | TCIF;
}

/// ADC1, DMA2 stream 0, TIM3 and TIM5 and the ring, as the converter's decisions see them.
///
/// Each register method is one bus access; implementations must not reorder them.
pub trait ConverterRegs {
    /// Read ADC_SR.
    fn adc_sr(&mut self) -> u32;
    /// Write ADC_SR (its flags clear where a 0 is written).
    fn set_adc_sr(&mut self, value: u32);
    /// Read ADC_CR2.
    fn adc_cr2(&mut self) -> u32;
    /// Write ADC_CR2.
    fn set_adc_cr2(&mut self, value: u32);
    /// Read the stream's DMA_SxCR.
    fn dma_cr(&mut self) -> u32;
    /// Write the stream's DMA_SxCR.
    fn set_dma_cr(&mut self, value: u32);
    /// Read the stream's DMA_SxNDTR: transfers left before the ring wraps.
    fn dma_ndtr(&mut self) -> u32;
    /// Write the stream's DMA_SxNDTR.
    fn set_dma_ndtr(&mut self, value: u32);
    /// Read the stream's flags ([`dma_flags`]).
    fn dma_flags(&mut self) -> u32;
    /// Clear the stream's `flags` ([`dma_flags`]) through the interrupt flag clear register.
    fn clear_dma_flags(&mut self, flags: u32);
    /// Read TIM5_CNT: TIM3's triggers counted since TIM5 started, 32 bits, wrapping.
    fn tim5_cnt(&mut self) -> u32;
    /// Read TIM3_CNT: timer ticks since the last trigger (TIM3's update event).
    fn tim3_cnt(&mut self) -> u32;
    /// Read `out.len()` codes of the ring from code `from` on (volatile loads: the DMA writes the ring).
    fn read_ring(&mut self, from: usize, out: &mut [u16]);
    /// Busy-wait at least `ticks` of TIM3's clock.
    fn delay_ticks(&mut self, ticks: u32);
    /// Run `f` with interrupts masked.
    fn critical<T>(&mut self, f: impl FnOnce(&mut Self) -> T) -> T;
    /// The converter was found failed and is about to be recovered: the board logs why.
    fn failed(&mut self, _failure: &Failure) {}
}

/// The converter's dimensions and timing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ConverterConfig {
    /// Channels in one scan.
    pub channels: usize,
    /// Scans in the ring.
    pub ring_scans: usize,
    /// TIM3 ticks after a trigger by which its scan's codes are all in the ring ([`settled_ticks`]).
    pub settled_ticks: u32,
    /// TIM3 ticks the ADC needs after ADON before it converts (tSTAB).
    pub stabilisation_ticks: u32,
}

impl ConverterConfig {
    /// Codes in the ring.
    pub const fn ring_codes(&self) -> usize {
        self.ring_scans * self.channels
    }
}

/// TIM3 ticks after a trigger by which its scan is in the ring: the scan's conversions (`scan_ticks`, the
/// trigger latency included) and an eighth of the trigger period for the DMA's transfer and margin.
pub const fn settled_ticks(scan_ticks: u32, period_ticks: u32) -> u32 {
    scan_ticks + period_ticks / 8
}

/// Why the converter was found failed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Failure {
    /// ADC_SR.OVR: the ADC overran.
    pub overrun: bool,
    /// TEIF: a DMA transfer error.
    pub transfer_error: bool,
    /// DMEIF: a DMA direct-mode error.
    pub direct_mode_error: bool,
    /// The stream is disabled.
    pub stream_off: bool,
    /// The DMA's position in the ring disagrees with the trigger count (checked only when the flags are clear).
    pub position: bool,
}

/// The running converter over its registers `R`: the extended trigger count and where the ring's slot 0 is.
pub struct Converter<R> {
    regs: R,
    config: ConverterConfig,
    /// TIM5's last reading and its wraps (the count extended to 64 bits).
    last: u32,
    wraps: u32,
    /// Hardware index of the scan the DMA writes to slot 0 first.
    base: u64,
}

impl<R: ConverterRegs> Converter<R> {
    /// Arm the DMA at ring slot 0, switch the ADC on and enable its trigger, with ADC1, the stream's addresses,
    /// TIM3 and TIM5 configured and TIM3 not yet counting: its first trigger is then the first scan, in slot 0,
    /// with the index TIM5 holds now ([`Converter::base`]).
    pub fn start(mut regs: R, config: ConverterConfig) -> Self {
        arm_dma(&mut regs, config.ring_codes());
        adc_on(&mut regs, config.stabilisation_ticks);
        let cr2 = regs.adc_cr2();
        regs.set_adc_cr2((cr2 & !adc_cr2::EXTEN_MASK) | adc_cr2::EXTEN_RISING);
        let low = regs.tim5_cnt();
        Converter { regs, config, last: low, wraps: 0, base: u64::from(low) }
    }

    /// Hardware index of the scan the DMA writes to ring slot 0 first (since the start or the last recovery).
    pub const fn base(&self) -> u64 {
        self.base
    }

    /// The registers.
    pub fn regs(&mut self) -> &mut R {
        &mut self.regs
    }

    /// Scans started: TIM5's count extended to 64 bits.
    pub fn started(&mut self) -> u64 {
        let low = self.regs.tim5_cnt();
        self.extend(low)
    }

    fn extend(&mut self, low: u32) -> u64 {
        if low < self.last {
            self.wraps += 1;
        }
        self.last = low;
        (u64::from(self.wraps) << 32) | u64::from(low)
    }

    /// Why the converter has failed, or `None` if it is healthy (see the module docs).
    pub fn failure(&mut self) -> Option<Failure> {
        let sr = self.regs.adc_sr();
        let flags = self.regs.dma_flags();
        let stream_on = self.regs.dma_cr() & dma_cr::EN != 0;
        let mut failure = Failure {
            overrun: sr & adc_sr::OVR != 0,
            transfer_error: flags & dma_flags::TEIF != 0,
            direct_mode_error: flags & dma_flags::DMEIF != 0,
            stream_off: !stream_on,
            position: false,
        };
        if failure == Failure::default() {
            failure.position = !self.position_agrees();
        }
        (failure != Failure::default()).then_some(failure)
    }

    /// Whether the DMA has written exactly the codes of the scans started since it was armed.
    fn position_agrees(&mut self) -> bool {
        let ring = self.config.ring_codes() as u64;
        loop {
            let s1 = self.started();
            let phase = self.regs.tim3_cnt();
            if phase < self.config.settled_ticks {
                // The trigger's scan may still be converting: wait until it is all in the ring.
                self.regs.delay_ticks(self.config.settled_ticks - phase);
                continue;
            }
            let ndtr = u64::from(self.regs.dma_ndtr());
            if self.started() != s1 {
                // A trigger came between the readings: read again.
                continue;
            }
            let Some(scans) = s1.checked_sub(self.base) else { return false };
            let written = (ring - ndtr % ring) % ring;
            return written == scans * self.config.channels as u64 % ring;
        }
    }

    /// Stop the scans, re-arm the DMA at slot 0 and the ADC at its first channel, and restart on the TIM3 grid
    /// (see the module docs). Returns the hardware index of the first scan afterwards.
    pub fn recover(&mut self) -> u64 {
        let ring_codes = self.config.ring_codes();
        let stabilisation = self.config.stabilisation_ticks;
        let low = self.regs.critical(|regs| {
            let cr2 = regs.adc_cr2();
            regs.set_adc_cr2(cr2 & !adc_cr2::EXTEN_MASK);
            let cr2 = regs.adc_cr2();
            regs.set_adc_cr2(cr2 & !adc_cr2::ADON);
            let sr = regs.adc_sr();
            regs.set_adc_sr(sr & !(adc_sr::OVR | adc_sr::STRT));
            arm_dma(regs, ring_codes);
            adc_on(regs, stabilisation);
            // Wait for a TIM3 edge (at most one period), then enable the trigger well before the next one.
            let c0 = regs.tim5_cnt();
            while regs.tim5_cnt() == c0 {}
            let cr2 = regs.adc_cr2();
            regs.set_adc_cr2((cr2 & !adc_cr2::EXTEN_MASK) | adc_cr2::EXTEN_RISING);
            regs.tim5_cnt()
        });
        let first = self.extend(low);
        self.base = first;
        first
    }

    /// Check the converter, and recover it if it failed: `Some(first)`, the hardware index of the first scan
    /// after the recovery.
    pub fn check_and_recover(&mut self) -> Option<u64> {
        let failure = self.failure()?;
        self.regs.failed(&failure);
        Some(self.recover())
    }
}

/// Arm the stream: disable it and wait until it is, clear its flags, and enable it at ring slot 0 with a full
/// count (RM0090 section 10.3, the stream configuration procedure). Its addresses (ADC1_DR, the ring) are set once, at configuration.
fn arm_dma<R: ConverterRegs>(regs: &mut R, ring_codes: usize) {
    let cr = regs.dma_cr();
    regs.set_dma_cr(cr & !dma_cr::EN);
    while regs.dma_cr() & dma_cr::EN != 0 {}
    regs.clear_dma_flags(dma_flags::ALL);
    regs.set_dma_ndtr(ring_codes as u32);
    regs.set_dma_cr(dma_cr::RING);
    regs.set_dma_cr(dma_cr::RING | dma_cr::EN);
}

/// Switch the ADC on with DMA requests after every conversion (DMA cleared and set again, which re-enables the
/// requests an overrun stopped), on TIM3's trigger, and wait out its stabilisation.
fn adc_on<R: ConverterRegs>(regs: &mut R, stabilisation_ticks: u32) {
    let cr2 = regs.adc_cr2();
    regs.set_adc_cr2((cr2 & !(adc_cr2::DMA | adc_cr2::EXTSEL_MASK)) | adc_cr2::DDS | adc_cr2::EXTSEL_TIM3_TRGO);
    let cr2 = regs.adc_cr2();
    regs.set_adc_cr2(cr2 | adc_cr2::DMA | adc_cr2::ADON);
    regs.delay_ticks(stabilisation_ticks);
}

impl<R: ConverterRegs, const BLOCK_CODES: usize> ScanRing<BLOCK_CODES> for Converter<R> {
    fn started(&mut self) -> u64 {
        Converter::started(self)
    }

    fn copy_block(&mut self, block: &ReadyBlock, out: &mut [u16; BLOCK_CODES]) {
        self.regs.read_ring(block.slot * self.config.channels, out);
    }

    fn check(&mut self) -> Option<u64> {
        self.check_and_recover()
    }
}

#[cfg(test)]
mod tests;

//! The sampler task: TIM3 triggers a scan of the five ADC1 inputs 2000 times a second; DMA2 stream 0 writes the
//! codes into a ring buffer; the task copies each half of the ring straight into a sample block for characterize.
//!
//! Timing: TIM3's update event (TRGO) starts each scan; a scan of five inputs at 480 sampling cycles takes
//! 5 x 492 / 21 MHz = 117 us of the 500 us period. The ring holds two blocks of 128 scans (64 ms each), and
//! characterize may fall four blocks behind before samples are lost.
//!
//! Losses: if characterize is three blocks behind, the sampler skips a half ring instead of waiting (counted as
//! an overrun). If the task is late by more than a half ring (a flash erase stalls the CPU), the DMA ring overruns;
//! if the ADC itself overruns (OVR), its DMA requests stop and no data arrives. Both are counted in
//! [`crate::ADC_OVERRUNS`] (the status frame reports it), logged with `warn!`, and the ADC is restarted; the
//! next block is marked as following a gap, with its sample index advanced by the time lost.

use core::sync::atomic::Ordering;

use embassy_stm32::adc::{Adc, Exten, RingBufferedAdc, SampleTime};
use embassy_stm32::peripherals::ADC1;
use embassy_stm32::time::Hertz;
use embassy_stm32::timer::low_level::{MasterMode, RoundTo, Timer as HwTimer};
use embassy_time::{with_timeout, Duration, Instant, Timer};
use static_cell::StaticCell;

use crate::board::{Irqs, SamplerParts};
use crate::characterize::BlockSender;
use crate::config::*;

/// The DMA ring: two halves of one block each.
static DMA_RING: StaticCell<[u16; 2 * BLOCK_CODES]> = StaticCell::new();

/// A half ring takes this long to fill; a read not done in twice that means the ADC stopped.
const HALF_RING: Duration = Duration::from_micros(BLOCK_SETS as u64 * 1_000_000 / SAMPLE_RATE_HZ as u64);

/// Samples the gyros and the temperature into blocks for characterize.
#[embassy_executor::task]
pub async fn sampler_task(parts: SamplerParts, mut blocks: BlockSender) {
    let SamplerParts { adc, dma, tim, inputs } = parts;

    // TIM3: update event at SAMPLE_RATE_HZ, routed to TRGO for the ADC's external trigger.
    let timer = HwTimer::new(tim);
    timer.set_frequency(Hertz(SAMPLE_RATE_HZ), RoundTo::Faster);
    timer.set_master_mode(MasterMode::UPDATE);

    let adc = Adc::new(adc);
    let ring = DMA_RING.init([0; 2 * BLOCK_CODES]);
    let mut adc: RingBufferedAdc<'static, ADC1> = adc.into_ring_buffered(
        dma,
        ring,
        Irqs,
        inputs.into_iter().map(|ch| (ch, SampleTime::CYCLES480)),
        embassy_stm32::triggers::TIM3_TRGO,
        Exten::RISING_EDGE,
    );
    adc.start();
    timer.start();
    defmt::info!("sampler: {} channels at {} Hz", CHANNELS, SAMPLE_RATE_HZ);

    let mut next_index: u64 = 0;
    let mut gap = false;
    let mut last_ok = Instant::now();
    loop {
        // Characterize is three blocks behind: skip a half ring of samples (a gap) rather than wait.
        let Some(block) = blocks.try_send() else {
            Timer::after(HALF_RING).await;
            adc.clear();
            crate::ADC_OVERRUNS.fetch_add(1, Ordering::Relaxed);
            defmt::warn!("sampler: characterize is behind, samples dropped");
            continue;
        };
        let read = with_timeout(HALF_RING * 2, adc.read(&mut block.codes)).await;
        if matches!(read, Ok(Ok(_))) {
            block.first_sample = next_index;
            block.gap_before = gap;
        }
        match read {
            Ok(Ok(_)) => {
                next_index += BLOCK_SETS as u64;
                last_ok = Instant::now();
                blocks.send_done();
                gap = false;
            }
            failure => {
                crate::ADC_OVERRUNS.fetch_add(1, Ordering::Relaxed);
                match failure {
                    Ok(Err(_)) => defmt::warn!("sampler: DMA ring overrun, restarting the ADC"),
                    _ => defmt::warn!("sampler: no data from the ADC (overrun), restarting it"),
                }
                restart(&mut adc);
                // Advance the sample index by the time lost, so raw samples show the gap.
                let lost_us = (Instant::now() - last_ok).as_micros();
                next_index += (lost_us * u64::from(SAMPLE_RATE_HZ) / 1_000_000).max(1);
                last_ok = Instant::now();
                gap = true;
            }
        }
    }
}

/// Restart after an overrun: clear the ADC's OVR flag and re-arm its DMA requests (RM0090 section 13.8.1: after
/// an overrun the DMA bit must be cleared and set again), then resynchronise the ring.
fn restart(adc: &mut RingBufferedAdc<'static, ADC1>) {
    let regs = embassy_stm32::pac::ADC1;
    regs.sr().modify(|w| w.set_ovr(false));
    regs.cr2().modify(|w| w.set_dma(false));
    regs.cr2().modify(|w| w.set_dma(true));
    adc.clear();
    adc.start();
}

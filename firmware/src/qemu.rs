//! The QEMU platform (feature `qemu`): what replaces embassy-stm32 on QEMU's netduinoplus2 (an STM32F405).
//!
//! embassy-stm32's `init` cannot run there (QEMU does not emulate RCC and PWR), its ADC model is a ramp and it
//! has no DMA, so this module provides:
//! - a simulated sampler: `shared::sim`'s virtual bench (the paper's four gyros plus the ADXRS300 temperature
//!   output), in blocks paced by the time driver at 2 kS/s per channel, with raw streaming of all channels on
//!   from the start (so a host can replay every code and check every snapshot);
//! - the link: frames written byte by byte to USART1's data register (QEMU writes them to `-serial`);
//! - the field log in a RAM flash model (QEMU's flash is read-only);
//! - an accumulator benchmark at start-up, printed through semihosting;
//! - optionally, a host `Command::Reset` after [`RESET_AT_SECONDS`] of samples (at a block boundary), so a run
//!   shows what a host sees at a reset;
//! - a semihosting exit (code 0) after [`RUN_SECONDS`] of samples, once every frame has been written.
//!
//! The application (characterize, store, frames) is the same code as on the board.

use core::sync::atomic::Ordering;

use cortex_m_semihosting::{debug, hprintln};
use embassy_time::{Duration, Ticker, Timer};
use octavar_shared::acc::OctaveAllan;
use octavar_shared::fieldlog::{LogFlash, RamFlash, RamFlashError};
use octavar_shared::proto::Command;
use octavar_shared::sensor::{Channel, ADXRS300};
use octavar_shared::sim::{Bench, BenchSim, ChannelSim, GyroSim};
use static_cell::StaticCell;

use crate::characterize::{BlockSender, COMMANDS};
use crate::config::*;
use crate::frames::FRAMES_OUT;

/// Seconds of samples per run: `OCTAVAR_QEMU_SECONDS` at build time, 5 by default.
pub const RUN_SECONDS: u64 = parse_u64(option_env!("OCTAVAR_QEMU_SECONDS"), 5);
/// Seed of the simulated bench: `OCTAVAR_QEMU_SEED` at build time, 1 by default.
pub const SEED: u64 = parse_u64(option_env!("OCTAVAR_QEMU_SEED"), 1);
/// Seconds of samples after which the simulated host sends `Command::Reset`: `OCTAVAR_QEMU_RESET_AT` at build
/// time, 0 (the default) for never. The reset comes at the first block boundary at or after that time, once
/// characterize has taken every block before it, so the run stays deterministic.
pub const RESET_AT_SECONDS: u64 = parse_u64(option_env!("OCTAVAR_QEMU_RESET_AT"), 0);
/// The core clock QEMU's netduinoplus2 gives SysTick, Hz.
pub const SYSCLK_HZ: u32 = 168_000_000;

const fn parse_u64(s: Option<&str>, default: u64) -> u64 {
    let Some(s) = s else { return default };
    let b = s.as_bytes();
    if b.is_empty() {
        return default;
    }
    let mut v = 0u64;
    let mut i = 0;
    while i < b.len() {
        assert!(b[i].is_ascii_digit(), "OCTAVAR_QEMU_* must be a decimal number");
        v = v * 10 + (b[i] - b'0') as u64;
        i += 1;
    }
    v
}

/// USART1 registers (RM0090 section 30.6): status, data, baud rate, control 1.
mod usart1 {
    pub const BASE: usize = 0x4001_1000;
    pub const SR: *mut u32 = BASE as *mut u32;
    pub const DR: *mut u32 = (BASE + 0x04) as *mut u32;
    pub const BRR: *mut u32 = (BASE + 0x08) as *mut u32;
    pub const CR1: *mut u32 = (BASE + 0x0C) as *mut u32;
    /// SR: transmit data register empty.
    pub const TXE: u32 = 1 << 7;
    /// CR1: USART enable, transmitter enable.
    pub const UE: u32 = 1 << 13;
    pub const TE: u32 = 1 << 3;
    /// RCC APB2ENR (RM0090 section 6.3.14) and its USART1EN bit.
    pub const RCC_APB2ENR: *mut u32 = 0x4002_3844 as *mut u32;
    pub const USART1EN: u32 = 1 << 4;
}

/// What the QEMU build owns.
pub struct Parts {
    /// SysTick, for the time driver.
    pub syst: cortex_m::peripheral::SYST,
    /// The RAM flash standing in for sectors 10 and 11.
    pub flash: QemuFlash,
}

/// Words in each of the two RAM sectors: 8 KiB, two checkpoints each (so the log alternates and erases often).
pub const SECTOR_WORDS: usize = 2048;

/// The RAM flash, in a static so that tasks hold only a reference to it.
static FLASH: StaticCell<RamFlash<SECTOR_WORDS>> = StaticCell::new();

/// The field log's flash in QEMU: a [`RamFlash`] in a static.
pub struct QemuFlash(&'static mut RamFlash<SECTOR_WORDS>);

impl LogFlash for QemuFlash {
    type Error = RamFlashError;

    fn sector_words(&self) -> usize {
        self.0.sector_words()
    }

    fn erase(&mut self, sector: usize) -> Result<(), RamFlashError> {
        self.0.erase(sector)
    }

    fn write(&mut self, sector: usize, offset: usize, words: &[u32]) -> Result<(), RamFlashError> {
        self.0.write(sector, offset, words)
    }

    fn read(&mut self, sector: usize, offset: usize, buf: &mut [u32]) -> Result<(), RamFlashError> {
        self.0.read(sector, offset, buf)
    }
}

/// Enable USART1 (115200 Bd at 84 MHz, 8N1; QEMU ignores the rate) and hand out the parts.
pub fn init() -> Parts {
    let core = cortex_m::Peripherals::take().expect("core peripherals are taken once");
    // SAFETY: these are the documented USART1 and RCC registers of the STM32F405; nothing else uses them.
    unsafe {
        usart1::RCC_APB2ENR.write_volatile(usart1::RCC_APB2ENR.read_volatile() | usart1::USART1EN);
        usart1::BRR.write_volatile(84_000_000 / 115_200);
        usart1::CR1.write_volatile(usart1::UE | usart1::TE);
    }
    Parts { syst: core.SYST, flash: QemuFlash(FLASH.init(RamFlash::new())) }
}

fn uart_write(bytes: &[u8]) {
    for &b in bytes {
        // SAFETY: USART1 was enabled in `init`; polling TXE and writing DR is the documented transmit sequence.
        unsafe {
            while usart1::SR.read_volatile() & usart1::TXE == 0 {}
            usart1::DR.write_volatile(u32::from(b));
        }
    }
}

/// The link: encoded frames to USART1.
#[embassy_executor::task]
pub async fn uart_task() {
    loop {
        let frame = FRAMES_OUT.receive().await;
        uart_write(&frame);
    }
}

/// The simulated bench: the paper's Table 1 numbers for the four gyros (N, B), a few K, the lab's drift.
fn bench_model() -> BenchSim {
    let gyro = |n: f64, b: f64| GyroSim { n_deg_per_rt_s: n, b_dps: b, k_dps_per_rt_s: n * 1e-3, ..Default::default() };
    let mut channels = heapless::Vec::new();
    for (kind, g) in [
        (CHANNEL_KINDS[0].0, gyro(3.2e-3, 14e-3)),
        (CHANNEL_KINDS[1].0, gyro(3.0e-3, 13e-3)),
        (CHANNEL_KINDS[2].0, gyro(46e-3, 26e-3)),
        (CHANNEL_KINDS[3].0, gyro(4.0e-4, 9.5e-4)),
    ] {
        let _ = channels.push(ChannelSim { sensor: kind, channel: None, gyro: g });
    }
    BenchSim { fs_hz: f64::from(SAMPLE_RATE_HZ), seed: SEED, temperature: Default::default(), channels }
}

/// The code the ADXRS300 TEMP output gives at `temp_c` through its 2/3 divider.
fn temperature_code(temp_c: f64) -> u16 {
    let ch = Channel::bench(ADXRS300);
    let t = ADXRS300.temp_output.expect("the ADXRS300 has a TEMP output");
    ch.adc.quantize(ch.front.apply(t.mv_at_25c + t.mv_per_c * (temp_c - 25.0)))
}

/// Stands in for the ADC: blocks of simulated scans at 2 kS/s; exits QEMU after [`RUN_SECONDS`].
#[embassy_executor::task]
pub async fn sim_sampler_task(mut blocks: BlockSender) {
    let mut bench = match Bench::new(&bench_model()) {
        Ok(b) => b,
        Err(e) => defmt::panic!("sim: {}", defmt::Debug2Format(&e)),
    };
    let total_blocks = (RUN_SECONDS * u64::from(SAMPLE_RATE_HZ)).div_ceil(BLOCK_SETS as u64);
    let mut ticker = Ticker::every(Duration::from_micros(BLOCK_SETS as u64 * 1_000_000 / u64::from(SAMPLE_RATE_HZ)));
    let reset_block = match RESET_AT_SECONDS {
        0 => None,
        s => Some((s * u64::from(SAMPLE_RATE_HZ)).div_ceil(BLOCK_SETS as u64)),
    };
    let mut next_index = 0u64;
    for b in 0..total_blocks {
        ticker.next().await;
        if reset_block == Some(b) {
            // As a host would: characterize takes every earlier block, then the reset, then the next block.
            while !blocks.is_empty() {
                Timer::after_millis(1).await;
            }
            COMMANDS.send(Command::Reset).await;
            while !COMMANDS.is_empty() {
                Timer::after_millis(1).await;
            }
            hprintln!("octavar-qemu: reset after {} samples", next_index);
        }
        // Wait rather than drop: the simulation may run slower than real time, and every code must arrive.
        let block = blocks.send().await;
        block.first_sample = next_index;
        block.gap_before = false;
        for set in block.codes.chunks_exact_mut(CHANNELS) {
            let s = bench.next_sample();
            set[..GYROS].copy_from_slice(&s.codes()[..GYROS]);
            set[TEMP_CHANNEL] = temperature_code(s.temp_c);
        }
        blocks.send_done();
        next_index += BLOCK_SETS as u64;
    }
    // Let characterize finish the last block and the link write every frame, then stop QEMU.
    while !blocks.is_empty() || !FRAMES_OUT.is_empty() {
        Timer::after_millis(1).await;
    }
    Timer::after_millis(5).await;
    hprintln!(
        "octavar-qemu: {} samples per channel, {} frames dropped, {} ADC overruns",
        next_index,
        crate::frames::FRAMES_DROPPED.load(Ordering::Relaxed),
        crate::ADC_OVERRUNS.load(Ordering::Relaxed)
    );
    debug::exit(debug::EXIT_SUCCESS);
}

/// Time `OctaveAllan<8>::push` on this core and print it through semihosting.
///
/// QEMU counts no cycles, but with `-icount shift=0` each instruction advances virtual time by exactly 1 ns, and
/// SysTick counts virtual time at 168 MHz: so virtual nanoseconds per sample are instructions per sample. The DWT
/// cycle counter is read too, to show whether this QEMU emulates it.
pub fn bench_accumulator() {
    const CODES: usize = 1024;
    const ROUNDS: usize = 256;
    static mut CODES_BUF: [u16; CODES] = [0; CODES];
    // SAFETY: used only here, before the executor starts.
    let codes = unsafe { &mut *core::ptr::addr_of_mut!(CODES_BUF) };
    let mut s = 12345u32;
    for c in codes.iter_mut() {
        s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        *c = 2048 + (s >> 26) as u16; // 64 codes of noise around mid-scale
    }
    let mut acc = OctaveAllan::<8>::new();
    // Warm up (and fill the rings), then time.
    acc.push_slice(codes);
    let mut core = unsafe { cortex_m::Peripherals::steal() };
    core.DCB.enable_trace();
    core.DWT.enable_cycle_counter();
    let dwt0 = cortex_m::peripheral::DWT::cycle_count();
    let t0 = crate::systick::cycles();
    for _ in 0..ROUNDS {
        acc.push_slice(core::hint::black_box(&codes[..]));
    }
    let t1 = crate::systick::cycles();
    let dwt1 = cortex_m::peripheral::DWT::cycle_count();
    // The same loop with a trivial body: the cost of reading the codes.
    let t2 = crate::systick::cycles();
    let mut sum = 0u32;
    for _ in 0..ROUNDS {
        for &c in core::hint::black_box(&codes[..]) {
            sum = sum.wrapping_add(u32::from(c));
        }
    }
    let t3 = crate::systick::cycles();
    core::hint::black_box((sum, acc.count()));
    let samples = (CODES * ROUNDS) as u64;
    let ns = |cycles: u64| cycles * 1_000_000_000 / u64::from(SYSCLK_HZ);
    let per_sample_milli = ns(t1 - t0) * 1000 / samples;
    let loop_milli = ns(t3 - t2) * 1000 / samples;
    hprintln!(
        "octavar-bench: OctaveAllan<8>::push: {}.{:03} instructions/sample/channel (virtual ns; exact with -icount shift=0), read loop alone {}.{:03}; {} samples; DWT CYCCNT delta {}",
        per_sample_milli / 1000,
        per_sample_milli % 1000,
        loop_milli / 1000,
        loop_milli % 1000,
        samples,
        dwt1.wrapping_sub(dwt0)
    );
}

//! The QEMU platform (feature `qemu`): what replaces the board's converter and USB on QEMU's netduinoplus2 (an
//! STM32F405).
//!
//! embassy-stm32's `init` cannot run there (QEMU does not emulate RCC and PWR), and QEMU's ADC is a ramp with no
//! DMA, so this module provides:
//! - a virtual converter: `shared::sim`'s virtual bench (the paper's four gyros plus the ADXRS300 temperature
//!   output) behind a trigger count that follows the free-running time base (`timebase.rs`, QEMU's TIM2) at
//!   2 kS/s. The sampler task (`sampler.rs`) is the board's: it decides by the count, exactly as on the board,
//!   which blocks of the 1.024 s ring it can take and which a stall has cost;
//! - the link: frames written to USART1's data register, commands read from its receiver through the same
//!   command decoder and router as USB's (QEMU connects USART1 to `-serial`);
//! - stalls: with `OCTAVAR_QEMU_STALL_EVERY=S` and `OCTAVAR_QEMU_STALL_MS=M`, the CPU stops for M ms every S
//!   seconds with interrupts masked, as a flash erase stops it, while the virtual converter's count runs on;
//! - the field log's flash (`qemu_flash.rs`): the host tests' model of the flash controller, driven by the
//!   board's own x32 sequences, in RAM a reset keeps, with worst-case timing and power cuts on request;
//! - benchmarks at start-up of the per-sample path (`qemu_bench.rs`), printed through semihosting;
//! - a semihosting exit (code 0) after [`RUN_SECONDS`] of scans, once every frame has been written.
//!
//! Raw streaming of every channel is on from the start, so a host can replay every code and check every
//! snapshot. The application (sampler, characterize, store, frames, commands) is the same code as on the board.

use core::sync::atomic::Ordering;

use cortex_m_semihosting::{debug, hprintln};
use embassy_futures::select::select;
use embassy_time::{Duration, Timer};
use octavar_shared::device::ReadyBlock;
use octavar_shared::proto::{Command, Decoder};
use octavar_shared::sensor::temperature_code;
use octavar_shared::sim::{Bench, BenchSim, ChannelSim, GyroSim};
use static_cell::StaticCell;

use crate::characterize::BlockSender;
use crate::config::*;
use crate::frames::{FRAMES_OUT, LINK_UP};
use crate::sampler::{self, ScanRing};
use crate::timebase;

/// Seconds of scans per run: `OCTAVAR_QEMU_SECONDS` at build time, 5 by default.
pub const RUN_SECONDS: u64 = parse_u64(option_env!("OCTAVAR_QEMU_SECONDS"), 5);
/// Seed of the simulated bench: `OCTAVAR_QEMU_SEED` at build time, 1 by default.
pub const SEED: u64 = parse_u64(option_env!("OCTAVAR_QEMU_SEED"), 1);
/// A stall every this many seconds of the time base (`OCTAVAR_QEMU_STALL_EVERY`; 0, the default: none).
pub const STALL_EVERY_S: u64 = parse_u64(option_env!("OCTAVAR_QEMU_STALL_EVERY"), 0);
/// Each stall's length in ms (`OCTAVAR_QEMU_STALL_MS`, 1000 by default).
pub const STALL_MS: u64 = parse_u64(option_env!("OCTAVAR_QEMU_STALL_MS"), 1000);
/// Whether flash operations stall the CPU for their worst-case time (`OCTAVAR_QEMU_FLASH_TIMING=worst` at build
/// time; `none`, the default: they take no time).
pub const FLASH_TIMING_WORST: bool = match option_env!("OCTAVAR_QEMU_FLASH_TIMING") {
    None => false,
    Some(v) => parse_timing(v),
};
/// The core clock QEMU's netduinoplus2 gives SysTick, Hz.
pub const SYSCLK_HZ: u32 = 168_000_000;
/// The kernel clock of QEMU's TIM2..TIM5 (its timer model counts at 1 GHz, not at the board's 84 MHz).
pub const TIMER_CLOCK_HZ: u32 = 1_000_000_000;
/// Scans of the run: whole blocks covering [`RUN_SECONDS`].
pub const RUN_SCANS: u64 = (RUN_SECONDS * SAMPLE_RATE_HZ as u64).div_ceil(BLOCK_SCANS as u64) * BLOCK_SCANS as u64;

const fn parse_timing(s: &str) -> bool {
    match s.as_bytes() {
        b"worst" => true,
        b"none" | b"" => false,
        _ => panic!("OCTAVAR_QEMU_FLASH_TIMING must be worst or none"),
    }
}

pub const fn parse_u64(s: Option<&str>, default: u64) -> u64 {
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
    /// SR: transmit data register empty; read data register not empty.
    pub const TXE: u32 = 1 << 7;
    pub const RXNE: u32 = 1 << 5;
    /// CR1: USART enable, transmitter enable, receiver enable.
    pub const UE: u32 = 1 << 13;
    pub const TE: u32 = 1 << 3;
    pub const RE: u32 = 1 << 2;
    /// RCC APB2ENR (RM0090 section 6.3.14) and its USART1EN bit.
    pub const RCC_APB2ENR: *mut u32 = 0x4002_3844 as *mut u32;
    pub const USART1EN: u32 = 1 << 4;
}

/// What the QEMU build owns (the field log's flash is `qemu_flash`'s).
pub struct Parts {
    /// SysTick, for the time driver.
    pub syst: cortex_m::peripheral::SYST,
}

/// Stop the CPU for `us` microseconds of the time base with interrupts masked, as a flash operation does (then
/// every fetch waits, interrupt vectors included). The time base and the virtual converter run on.
pub fn stall_cpu_us(us: u64) {
    let until = timebase::now_us() + us;
    critical_section::with(|_| {
        while timebase::now_us() < until {
            // Sleep to the next SysTick rather than spin; its interrupt stays masked (a stall loses them).
            cortex_m::peripheral::SCB::clear_pendst();
            cortex_m::asm::wfi();
        }
    });
}

/// A hard fault in QEMU: say where, and how much stack was left, and exit with failure rather than hang.
#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    hprintln!(
        "octavar-qemu: hard fault at pc {:#010x} (lr {:#010x}); stack never used: {} bytes",
        frame.pc(),
        frame.lr(),
        crate::stack::unused_bytes()
    );
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}

/// Where a probe sets the RTT up channel's mode: the flags word of defmt-rtt's `_SEGGER_RTT` control block, 44
/// bytes in on a 32-bit target (a 16-byte id, two channel counts, then the up channel's name, buffer, size, write
/// and read words), as SEGGER's layout fixes it.
const RTT_UP_FLAGS: usize = 44;
/// SEGGER's block-if-full mode, which probe-rs sets when it attaches.
const RTT_MODE_BLOCK_IF_FULL: u32 = 2;
/// Log lines written with no reader: several times the 512-byte RTT buffer.
const RTT_FLOOD_LINES: u32 = 64;

/// What an unplugged probe leaves: the RTT up channel in block-if-full mode and nobody reading it. The firmware
/// then logs several buffers' worth. With defmt-rtt's `disable-blocking-mode` the lines that do not fit are
/// dropped and boot goes on; a blocking logger would hang here for good, and the QEMU test would time out.
fn rtt_as_an_unplugged_probe_leaves_it() {
    extern "C" {
        static _SEGGER_RTT: u8;
    }
    // SAFETY: the flags word is an AtomicU32 inside defmt-rtt's control block (interior mutability: the probe
    // writes it too); the offset is SEGGER's fixed layout.
    let flags =
        unsafe { &*(core::ptr::addr_of!(_SEGGER_RTT).add(RTT_UP_FLAGS) as *const core::sync::atomic::AtomicU32) };
    flags.store(RTT_MODE_BLOCK_IF_FULL, Ordering::Relaxed);
    for i in 0..RTT_FLOOD_LINES {
        defmt::info!("qemu: the RTT channel blocks if full and nobody reads it: line {} of {}", i + 1, RTT_FLOOD_LINES);
    }
    hprintln!(
        "octavar-qemu: {} log lines with the RTT channel block-if-full and no reader: boot goes on",
        RTT_FLOOD_LINES
    );
}

/// Enable USART1 (115200 Bd at 84 MHz, 8N1; QEMU ignores the rate) and hand out the parts.
pub fn init() -> Parts {
    rtt_as_an_unplugged_probe_leaves_it();
    let core = cortex_m::Peripherals::take().expect("core peripherals are taken once");
    // SAFETY: these are the documented USART1 and RCC registers of the STM32F405; nothing else uses them.
    unsafe {
        usart1::RCC_APB2ENR.write_volatile(usart1::RCC_APB2ENR.read_volatile() | usart1::USART1EN);
        usart1::BRR.write_volatile(84_000_000 / 115_200);
        usart1::CR1.write_volatile(usart1::UE | usart1::TE | usart1::RE);
    }
    Parts { syst: core.SYST }
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

/// A received byte, if one is waiting.
fn uart_read() -> Option<u8> {
    // SAFETY: as in `uart_write`; reading DR clears RXNE.
    unsafe { (usart1::SR.read_volatile() & usart1::RXNE != 0).then(|| usart1::DR.read_volatile() as u8) }
}

/// The link: the hello, then encoded frames to USART1; command frames from USART1 to the command router.
#[embassy_executor::task]
pub async fn uart_task() {
    crate::frames::flush_stale();
    // As on USB: a lone delimiter before the first frame, so a receiver's leftover bytes end there.
    uart_write(&octavar_shared::proto::RESYNC);
    crate::frames::send(&crate::characterize::hello());
    LINK_UP.store(true, Ordering::Relaxed);
    let mut decoder = Decoder::<Command>::new();
    loop {
        while let Ok(frame) = FRAMES_OUT.try_receive() {
            uart_write(&frame);
        }
        let mut byte = [0u8; 1];
        while let Some(b) = uart_read() {
            byte[0] = b;
            for received in decoder.feed(&byte) {
                match received {
                    Ok(r) => crate::commands::route(r.seq, r.msg),
                    Err(e) => defmt::warn!("uart: bad command frame: {}", defmt::Debug2Format(&e)),
                }
            }
        }
        // Woken by the first frame queued, as the USB task is (characterize waits for the queue to drain before
        // its next block: `frames::drained_within`). The timer is for the receive side, which has no interrupt
        // here.
        select(FRAMES_OUT.ready_to_receive(), Timer::after(Duration::from_micros(500))).await;
    }
}

/// The simulated bench: the paper's Table 1 numbers for the four gyros (N, B), a few K, the lab's drift.
fn bench_model() -> BenchSim {
    let gyro = |n: f64, b: f64| GyroSim { n_deg_per_rt_s: n, b_dps: b, k_dps_per_rt_s: n * 1e-3, ..Default::default() };
    let mut channels = heapless::Vec::new();
    for (kind, g) in [
        (DEVICE.channels[0].kind, gyro(3.2e-3, 14e-3)),
        (DEVICE.channels[1].kind, gyro(3.0e-3, 13e-3)),
        (DEVICE.channels[2].kind, gyro(46e-3, 26e-3)),
        (DEVICE.channels[3].kind, gyro(4.0e-4, 9.5e-4)),
    ] {
        let _ = channels.push(ChannelSim { sensor: kind, channel: None, gyro: g });
    }
    BenchSim { rate_hz: f64::from(SAMPLE_RATE_HZ), seed: SEED, temperature: Default::default(), channels }
}

/// The virtual converter: the simulated bench behind a trigger count that follows the time base.
///
/// The board's DMA writes every scan into the ring as it is converted, at no cost to the CPU. Here a scan's
/// codes are simulated when the sampler copies its block: the same codes (the bench is one deterministic
/// sequence), without spending the CPU time of scans that the ring has already lost. Those are not simulated
/// at all: nobody can see them, and the bench's noise simply goes on from where it was.
pub struct VirtualAdc {
    bench: Bench,
    /// The time base at the first trigger.
    t0_us: u64,
}

impl VirtualAdc {
    fn new() -> Self {
        let bench = match Bench::new(&bench_model()) {
            Ok(b) => b,
            Err(e) => panic!("sim: {:?}", e),
        };
        VirtualAdc { bench, t0_us: timebase::now_us() }
    }
}

impl ScanRing for VirtualAdc {
    fn started(&mut self) -> u64 {
        let elapsed = timebase::now_us() - self.t0_us;
        // The run stops triggering after its last scan (plus the one that completes it).
        (elapsed * u64::from(SAMPLE_RATE_HZ) / 1_000_000).min(RUN_SCANS + 1)
    }

    fn copy_block(&mut self, _block: &ReadyBlock, out: &mut [u16; BLOCK_CODES]) {
        for scan in out.chunks_exact_mut(CHANNELS) {
            let s = self.bench.next_sample();
            scan[..GYROS].copy_from_slice(&s.codes()[..GYROS]);
            scan[GYROS] = temperature_code(s.temp_c);
        }
    }

    fn check(&mut self) -> Option<u64> {
        None
    }
}

/// The sampler on the virtual converter (10 KiB of simulator state, built in its static).
#[embassy_executor::task]
pub async fn sampler_task(blocks: BlockSender) {
    static ADC: StaticCell<VirtualAdc> = StaticCell::new();
    sampler::run(ADC.init_with(VirtualAdc::new), blocks).await
}

/// Stalls the CPU for [`STALL_MS`] every [`STALL_EVERY_S`] seconds, interrupts masked, as a flash erase does
/// (then every fetch waits, interrupt vectors included). The time base and the virtual converter run on.
#[embassy_executor::task]
pub async fn stall_task() {
    if STALL_EVERY_S == 0 {
        return;
    }
    let mut next = timebase::now_us() + STALL_EVERY_S * 1_000_000;
    loop {
        Timer::at(embassy_time::Instant::from_micros(next)).await;
        stall_cpu_us(STALL_MS * 1000);
        hprintln!("octavar-qemu: stalled {} ms", STALL_MS);
        next += STALL_EVERY_S * 1_000_000;
    }
}

/// Ends the run: once the sampler has passed [`RUN_SCANS`] and characterize and the link are idle, prints the
/// counts and exits QEMU.
#[embassy_executor::task]
pub async fn finish_task() {
    while u64::from(sampler::NEXT_SCAN.load(Ordering::Relaxed)) < RUN_SCANS {
        Timer::after_millis(10).await;
    }
    // Let characterize take the last block and the link write every frame.
    Timer::after_millis(50).await;
    while !FRAMES_OUT.is_empty() {
        Timer::after_millis(1).await;
    }
    Timer::after_millis(5).await;
    hprintln!(
        "octavar-qemu: {} scans, {} lost, {} frames dropped; stack peak {} of {} bytes; frame queue peak {} of {}",
        RUN_SCANS,
        sampler::SCANS_LOST.load(Ordering::Relaxed),
        crate::frames::FRAMES_DROPPED.load(Ordering::Relaxed),
        crate::stack::peak_bytes(),
        crate::stack::size_bytes(),
        crate::frames::FRAMES_PEAK.load(Ordering::Relaxed),
        crate::frames::FRAME_QUEUE
    );
    debug::exit(debug::EXIT_SUCCESS);
}

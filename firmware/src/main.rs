//! octavar's firmware: characterise analog MEMS gyros on an STM32F405RG with the exact octave Allan variance.
//!
//! # Tasks and the channels between them
//!
//! ```text
//!  sampler_task ──SampleBlock (zerocopy_channel, 2 blocks of 128 scans)──> characterize_task
//!  (sample ring: DMA by TIM3 trigger, located by TIM5's count)              │  the shared device core:
//!                                                                            │  OctaveAllan<8> per gyro,
//!          FRAMES_OUT (Channel<FrameBuf, 16>, try_send; drops ───────────────┤  rounds, estimate, raw,
//!          counted in FRAMES_DROPPED, reported in Status)                    │  gaps, acks
//!                 │                                                          │
//!                 v                                                          v
//!            usb_task ──COMMANDS (seq, Command)──────────────────────> characterize_task
//!          (CDC-ACM)  ──LOG_READ (seq, from)──> store_task <──SNAPSHOT_READY (Signal<Round>)──┘
//!                                              (field log in flash sectors 1 + 2)
//!  watchdog_task: feeds the IWDG while characterize takes blocks
//! ```
//!
//! - `sampler_task` (`sampler.rs` over `adc.rs`): 2000 scans/s of IDG1215 X, IDG1215 Y, ADXRS300, ENV-05H and the
//!   ADXRS300 temperature; every block carries its hardware scan index, so every loss is an exact gap.
//! - `characterize_task` (`characterize.rs`): `octavar_shared::device::Characterizer`, which the host's device
//!   simulator runs too.
//! - `usb_task` (`usb.rs`): frames out while the host holds DTR, commands in; never blocks the others.
//! - `store_task` (`store.rs`): checkpoints at most every 10 minutes, read back on command.
//!
//! With the `qemu` feature (`qemu.rs`), a virtual converter replaces the ADC under the same sampler loop, and
//! `uart_task` (USART1) replaces USB; characterize, store, frames and commands are the same code. Both builds
//! take time from the free-running TIM2 (`timebase.rs`) through the driver of `systick.rs`.
#![no_std]
#![no_main]

use defmt::unwrap;
use defmt_rtt as _;
use embassy_executor::Spawner;
// The QEMU build starts no embassy-stm32 driver, but links its PAC's interrupt vector table.
#[cfg(feature = "qemu")]
use embassy_stm32 as _;
use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use embassy_sync::zerocopy_channel;
use static_cell::StaticCell;

mod board_config;
mod characterize;
mod commands;
mod config;
mod frames;
mod sampler;
mod stack;
mod store;
mod systick;
mod timebase;
mod watchdog;

#[cfg(not(feature = "qemu"))]
mod adc;
#[cfg(not(feature = "qemu"))]
mod board;
#[cfg(not(feature = "qemu"))]
mod flash_regs;
#[cfg(feature = "qemu")]
mod qemu;
#[cfg(feature = "qemu")]
mod qemu_bench;
#[cfg(feature = "qemu")]
mod qemu_flash;
#[cfg(not(feature = "qemu"))]
mod usb;

use characterize::{characterize_task, SampleBlock};
use config::BLOCKS_IN_FLIGHT;

/// Storage of the sample blocks in flight (sampler -> characterize).
static BLOCKS: StaticCell<[SampleBlock; BLOCKS_IN_FLIGHT]> = StaticCell::new();
/// The zerocopy channel over [`BLOCKS`].
static BLOCK_CHANNEL: StaticCell<zerocopy_channel::Channel<'static, NoopRawMutex, SampleBlock>> = StaticCell::new();

// defmt log lines carry the time base's microseconds.
defmt::timestamp!("{=u64:us}", timebase::now_us());

#[embassy_executor::main]
async fn main(spawner: Spawner) {
    // First, before any task runs: the paint the stack's high-water mark is read from.
    stack::paint();
    let blocks = BLOCK_CHANNEL
        .init(zerocopy_channel::Channel::new(BLOCKS.init([const { SampleBlock::EMPTY }; BLOCKS_IN_FLIGHT])));
    #[cfg_attr(not(feature = "qemu"), allow(unused_mut))]
    let (mut block_tx, mut block_rx) = blocks.split();

    #[cfg(not(feature = "qemu"))]
    {
        let parts = board::init();
        systick::init(parts.syst, board::SYSCLK_HZ, board::TIM3_HZ);
        defmt::info!("octavar {}: {} at {} Hz", env!("CARGO_PKG_VERSION"), config::DEVICE.board, board::SYSCLK_HZ);
        spawner.spawn(unwrap!(watchdog::watchdog_task()));
        spawner.spawn(unwrap!(sampler_task(parts.sampler, block_tx)));
        spawner.spawn(unwrap!(characterize_task(block_rx, characterize::core())));
        spawner.spawn(unwrap!(usb::usb_task(parts.usb)));
        spawner.spawn(unwrap!(store_task(store::board_flash(parts.store))));
    }
    #[cfg(feature = "qemu")]
    {
        let parts = qemu::init();
        systick::init(parts.syst, qemu::SYSCLK_HZ, qemu::TIMER_CLOCK_HZ);
        let core = characterize::core();
        qemu_bench::bench_characterizer(core);
        qemu_bench::bench_whole_path(core, &mut block_tx, &mut block_rx);
        core.restart(characterize::RAW_AT_BOOT);
        spawner.spawn(unwrap!(watchdog::watchdog_task()));
        spawner.spawn(unwrap!(qemu::uart_task()));
        spawner.spawn(unwrap!(characterize_task(block_rx, core)));
        spawner.spawn(unwrap!(store_task(qemu_flash::take())));
        spawner.spawn(unwrap!(qemu::stall_task()));
        spawner.spawn(unwrap!(qemu::finish_task()));
        spawner.spawn(unwrap!(qemu::sampler_task(block_tx)));
    }
}

/// The sampler on the board's converter.
#[cfg(not(feature = "qemu"))]
#[embassy_executor::task]
async fn sampler_task(parts: board::SamplerParts, blocks: characterize::BlockSender) {
    let mut ring = adc::start(parts);
    sampler::run(&mut ring, blocks).await
}

/// The flash the field log is written to in this build.
#[cfg(not(feature = "qemu"))]
type LogFlashImpl = store::BoardFlash;
#[cfg(feature = "qemu")]
type LogFlashImpl = qemu_flash::QemuFlash;

/// The field log (see `store.rs`).
#[embassy_executor::task]
async fn store_task(flash: LogFlashImpl) {
    store::run(flash).await
}

/// In QEMU, print the panic through semihosting and exit with failure; on the board, log it with defmt (unless
/// the panic came from inside a log line, where defmt is taken) and stop.
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    #[cfg(feature = "qemu")]
    {
        cortex_m_semihosting::hprintln!("octavar-qemu: panic: {}", info);
        cortex_m_semihosting::debug::exit(cortex_m_semihosting::debug::EXIT_FAILURE);
    }
    static PANICKING: core::sync::atomic::AtomicBool = core::sync::atomic::AtomicBool::new(false);
    if !PANICKING.swap(true, core::sync::atomic::Ordering::Relaxed) {
        defmt::error!("panic: {}", defmt::Display2Format(info));
    }
    cortex_m::asm::udf()
}

//! octavar's firmware: characterise analog MEMS gyros on an STM32F405RG with the exact octave Allan variance.
//!
//! # Tasks and the channels between them
//!
//! ```text
//!  sampler_task ──SampleBlock (zerocopy_channel, 3 x 128 scans)──> characterize_task
//!  (TIM3 → ADC1 scan → DMA ring)                                   │  OctaveAllan<8> per gyro, estimate
//!                                                                  │
//!          FRAMES_OUT (Channel<FrameBuf, 16>, try_send; drops ─────┤  every second: snapshot parts,
//!          counted in FRAMES_DROPPED, reported in Status)          │  estimate, status; raw samples on
//!                 │                                                │  command
//!                 v                                                v
//!            usb_task ──COMMANDS (Channel<Command, 4>)──> characterize_task
//!          (CDC-ACM)  ──LOG_READ (Signal<u32>)──────────> store_task <──SNAPSHOT_READY (Signal<Round>)──┘
//!                                                         (field log in flash sectors 10 + 11)
//! ```
//!
//! - `sampler_task` (`sampler.rs`): 2000 scans/s of IDG1215 X, IDG1215 Y, ADXRS300, ENV-05H and the ADXRS300
//!   temperature; counts ADC overruns in [`ADC_OVERRUNS`] and restarts the ADC.
//! - `characterize_task` (`characterize.rs`): accumulators, snapshot rounds, onboard N and B, raw streaming.
//! - `usb_task` (`usb.rs`): frames out, commands in; never blocks the others.
//! - `store_task` (`store.rs`): checkpoints at most every 10 minutes, read back on command.
//!
//! With the `qemu` feature (`qemu.rs`), `sim_sampler_task` (shared::sim codes) replaces the sampler and
//! `uart_task` (USART1) replaces USB; characterize, store and the frames are the same code. Both builds use the
//! SysTick time driver of `systick.rs`.
#![no_std]
#![no_main]

use core::sync::atomic::AtomicU32;

use defmt::unwrap;
use defmt_rtt as _;
// The QEMU build starts no embassy-stm32 driver, but links its PAC's interrupt vector table.
use embassy_executor::Spawner;
#[cfg(feature = "qemu")]
use embassy_stm32 as _;
use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use embassy_sync::zerocopy_channel;
use static_cell::StaticCell;

mod characterize;
mod config;
mod frames;
mod store;
mod systick;

#[cfg(not(feature = "qemu"))]
mod board;
#[cfg(feature = "qemu")]
mod qemu;
#[cfg(not(feature = "qemu"))]
mod sampler;
#[cfg(not(feature = "qemu"))]
mod usb;

use characterize::{characterize_task, SampleBlock};
use config::BLOCKS_IN_FLIGHT;

/// ADC overruns (DMA ring lapped, or the ADC's OVR), counted by the sampler, reported in the status frame.
pub static ADC_OVERRUNS: AtomicU32 = AtomicU32::new(0);

/// Storage of the sample blocks in flight (sampler -> characterize).
static BLOCKS: StaticCell<[SampleBlock; BLOCKS_IN_FLIGHT]> = StaticCell::new();
/// The zerocopy channel over [`BLOCKS`].
static BLOCK_CHANNEL: StaticCell<zerocopy_channel::Channel<'static, NoopRawMutex, SampleBlock>> = StaticCell::new();

#[embassy_executor::main]
async fn main(spawner: Spawner) {
    let blocks = BLOCK_CHANNEL
        .init(zerocopy_channel::Channel::new(BLOCKS.init([const { SampleBlock::EMPTY }; BLOCKS_IN_FLIGHT])));
    let (block_tx, block_rx) = blocks.split();

    #[cfg(not(feature = "qemu"))]
    {
        let parts = board::init();
        systick::init(parts.syst, board::SYSCLK_HZ);
        defmt::info!("octavar {}: STM32F405RG at {} Hz", env!("CARGO_PKG_VERSION"), board::SYSCLK_HZ);
        spawner.spawn(unwrap!(sampler::sampler_task(parts.sampler, block_tx)));
        spawner.spawn(unwrap!(characterize_task(block_rx, 0)));
        spawner.spawn(unwrap!(usb::usb_task(parts.usb)));
        spawner.spawn(unwrap!(store_task(store::BoardFlash::new(parts.store))));
    }
    #[cfg(feature = "qemu")]
    {
        let parts = qemu::init();
        systick::init(parts.syst, qemu::SYSCLK_HZ);
        qemu::bench_accumulator();
        spawner.spawn(unwrap!(qemu::uart_task()));
        spawner.spawn(unwrap!(characterize_task(block_rx, config::ALL_CHANNELS_MASK)));
        spawner.spawn(unwrap!(store_task(parts.flash)));
        spawner.spawn(unwrap!(qemu::sim_sampler_task(block_tx)));
    }
}

/// The flash the field log is written to in this build.
#[cfg(not(feature = "qemu"))]
type LogFlashImpl = store::BoardFlash;
#[cfg(feature = "qemu")]
type LogFlashImpl = qemu::QemuFlash;

/// The field log (see `store.rs`).
#[embassy_executor::task]
async fn store_task(flash: LogFlashImpl) {
    store::run(flash).await
}

/// Log the panic with defmt; in QEMU, also print it through semihosting and exit with failure.
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    defmt::error!("panic: {}", defmt::Display2Format(info));
    #[cfg(feature = "qemu")]
    {
        cortex_m_semihosting::hprintln!("octavar-qemu: panic: {}", info);
        cortex_m_semihosting::debug::exit(cortex_m_semihosting::debug::EXIT_FAILURE);
    }
    cortex_m::asm::udf()
}

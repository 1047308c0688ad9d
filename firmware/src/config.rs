//! What the application is configured with, on the board and in QEMU alike: the device (its channel table and
//! schedule, from `octavar_shared::device`), the sample ring, and the periods of checkpoints and polls.
//!
//! The pins and the crystal are the board's (`board_config.rs`).

use embassy_time::Duration;
use octavar_shared::device::DeviceConfig;

/// The device: octavar's board as `octavar_shared::device::DeviceConfig::F405` describes it, named for this build.
pub const DEVICE: DeviceConfig<'static> = DeviceConfig {
    firmware: env!("CARGO_PKG_VERSION"),
    board: if cfg!(feature = "qemu") { "qemu netduinoplus2" } else { crate::board_config::BOARD.name },
    ..DeviceConfig::F405
};

/// Scans per second (TIM3 triggers one ADC scan of all channels per sample).
pub const SAMPLE_RATE_HZ: u32 = DEVICE.rate_hz;
/// Channels in one scan: the four gyro outputs, then the temperature.
pub const CHANNELS: usize = DEVICE.width();
/// Gyro channels (each has an accumulator).
pub const GYROS: usize = 4;
/// Scans in one sample block (sampler -> characterize).
pub const BLOCK_SCANS: usize = DEVICE.block_scans;
/// Codes in one sample block.
pub const BLOCK_CODES: usize = DEVICE.block_codes();
/// Sample blocks the sampler can hand to characterize before it waits (the ring holds the rest).
pub const BLOCKS_IN_FLIGHT: usize = 2;
/// Scans in the DMA ring: 1.024 s, which outlives the longest flash stall (a 16 KiB sector's erase at x32, at
/// most 0.5 s: `store::RING_COVERS_THE_WORST_STALL`); a longer stall loses scans, and the hardware index counts
/// them exactly.
pub const RING_SCANS: usize = 16 * BLOCK_SCANS;
/// Codes in the DMA ring (20 KiB).
pub const RING_CODES: usize = RING_SCANS * CHANNELS;
/// How often the sampler looks at the ring.
pub const SAMPLER_POLL: Duration = Duration::from_millis(16);
/// The longest characterize waits for the link to take a block's frames before it feeds the next block
/// ([`crate::frames::drained_within`]): an eighth of a block's time, so a link that stops taking frames slows
/// characterize by at most that and the sampler's backlog still drains.
pub const DRAIN_LIMIT: Duration = Duration::from_millis(8);
/// Scans in one sampler poll period.
pub const POLL_SCANS: usize = (SAMPLER_POLL.as_micros() * SAMPLE_RATE_HZ as u64 / 1_000_000) as usize;
/// Scans a stall of the CPU can last without losing one, when it starts with the sampler caught up: the ring,
/// less the block being filled and a poll period's scans the sampler has not looked at yet, less a block of
/// room for the copy once the CPU is back. 1760 scans, 0.88 s.
pub const STALL_BUDGET_SCANS: usize = RING_SCANS - 2 * BLOCK_SCANS - POLL_SCANS;

/// Field-log checkpoints at most this often (the "every 10 minutes at most").
#[cfg(not(feature = "qemu"))]
pub const CHECKPOINT_EVERY_SCANS: u64 = 10 * 60 * SAMPLE_RATE_HZ as u64;
/// In QEMU runs of a few seconds, checkpoint every two seconds so the log is exercised.
#[cfg(feature = "qemu")]
pub const CHECKPOINT_EVERY_SCANS: u64 = 2 * SAMPLE_RATE_HZ as u64;

const _: () = assert!(DEVICE.is_valid() && DEVICE.gyros == GYROS);
const _: () = assert!(crate::board_config::BOARD.adc_pins.len() == CHANNELS, "one ADC pin per channel");
const _: () = assert!(RING_CODES <= u16::MAX as usize, "the DMA counts at most 65535 transfers");
// The sampler looks at the ring many times per lap.
const _: () = assert!(DRAIN_LIMIT.as_micros() * 8 <= BLOCK_SCANS as u64 * 1_000_000 / SAMPLE_RATE_HZ as u64);
const _: () = assert!(SAMPLER_POLL.as_micros() * 16 < RING_SCANS as u64 * 1_000_000 / SAMPLE_RATE_HZ as u64);

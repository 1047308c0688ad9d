//! What the application is configured with, on the board and in QEMU alike: rates, the channel order, the
//! sensors on each channel, and the periods of snapshots and checkpoints.
//!
//! The pin each channel is wired to is in `board.rs` (the real board only).

use octavar_shared::sensor::{Channel, SensorKind, ADXRS300, ENV05H, IDG1215_X, IDG1215_Y};

/// Samples per second on every channel (TIM3 triggers one ADC scan of all channels per sample).
pub const SAMPLE_RATE_HZ: u32 = 2_000;
/// Channels in one scan: the four gyro outputs, then the temperature.
pub const CHANNELS: usize = 5;
/// The first [`GYROS`] channels are gyros; each has an accumulator.
pub const GYROS: usize = 4;
/// Index of the temperature channel in a scan.
pub const TEMP_CHANNEL: usize = 4;
/// Stride of the accumulators (clusters every m / 8 samples: about 98% of the full-overlap degrees of freedom).
pub const STRIDE: usize = 8;
/// Scans in one sample block (sampler -> characterize): 64 ms at 2 kS/s, four raw-sample frames of 32 scans.
pub const BLOCK_SETS: usize = 128;
/// Codes in one sample block.
pub const BLOCK_CODES: usize = BLOCK_SETS * CHANNELS;
/// Sample blocks the sampler can get ahead of characterize (192 ms of slack).
pub const BLOCKS_IN_FLIGHT: usize = 3;
/// A snapshot round (snapshot, estimate and status frames) every this many scans: one second.
pub const SNAPSHOT_EVERY_SETS: u64 = SAMPLE_RATE_HZ as u64;
/// Raw-sample frames carry at most this many scans (the frame's 160-code limit over five channels).
pub const RAW_SETS_PER_FRAME: usize = 32;
/// Bit mask of every channel (for [`octavar_shared::proto::Command::StartRaw`]).
pub const ALL_CHANNELS_MASK: u8 = (1 << CHANNELS) - 1;

/// Field-log checkpoints at most this often (the "every 10 minutes at most").
#[cfg(not(feature = "qemu"))]
pub const CHECKPOINT_EVERY_SETS: u64 = 10 * 60 * SAMPLE_RATE_HZ as u64;
/// In QEMU runs of a few seconds, checkpoint every two seconds so the log is exercised.
#[cfg(feature = "qemu")]
pub const CHECKPOINT_EVERY_SETS: u64 = 2 * SAMPLE_RATE_HZ as u64;

/// The sensor on each channel, in scan order; what the hello frame lists.
pub const CHANNEL_KINDS: [(SensorKind, &str); CHANNELS] = [
    (SensorKind::Idg1215X, "IDG1215 X"),
    (SensorKind::Idg1215Y, "IDG1215 Y"),
    (SensorKind::Adxrs300, "ADXRS300"),
    (SensorKind::Env05h, "ENV-05H"),
    (SensorKind::Temperature, "ADXRS300 TEMP"),
];

/// The bench channel (gyro, front end, ADC) of gyro `g`: the code <-> deg/s scale the estimate uses.
pub fn gyro_channel(g: usize) -> Channel {
    Channel::bench(match g {
        0 => IDG1215_X,
        1 => IDG1215_Y,
        2 => ADXRS300,
        _ => ENV05H,
    })
}

/// Temperature in degC from a mean code of the temperature channel: the ADXRS300 TEMP output (2.50 V at 25 degC,
/// 8.4 mV/K) through the same 2/3 divider as its rate output.
pub fn temperature_c(mean_code: f64) -> f32 {
    let ch = Channel::bench(ADXRS300);
    let t = ADXRS300.temp_output.expect("the ADXRS300 has a TEMP output");
    let sensor_mv = ch.front.invert((mean_code + 0.5) * ch.adc.mv_per_code());
    (25.0 + (sensor_mv - t.mv_at_25c) / t.mv_per_c) as f32
}

const _: () = assert!(BLOCK_SETS.is_multiple_of(RAW_SETS_PER_FRAME));
const _: () = assert!(RAW_SETS_PER_FRAME * CHANNELS <= octavar_shared::proto::MAX_CODES);
const _: () = assert!(GYROS + 1 == CHANNELS && TEMP_CHANNEL == GYROS);

//! Worst-case postcard sizes, and the compile-time proof that every frame fits [`MAX_FRAME`](super::MAX_FRAME).
//!
//! postcard writes unsigned integers wider than a byte as LEB128 varints (7 bits a byte: a `u16` takes up to
//! 3 bytes, a `u32` 5, a `u64` 10, a `u128` 19), `u8` as one byte, `f32` as 4 bytes, an `Option` as a tag byte
//! and the value, an enum as its variant index (a varint) and the variant's fields, a sequence or string as its
//! length (a varint) and the elements. [`MaxSize::MAX_SIZE`] adds these up per type; the tests at the end of
//! the module serialise a worst-case value of every type and check that it takes exactly that many bytes.
//!
//! # Examples
//! ```
//! use octavar_shared::proto::{Frame, MaxSize, MAX_BODY};
//! assert!(Frame::MAX_SIZE <= MAX_BODY);
//! ```

use heapless::{String, Vec};

use super::{
    Ack, ChannelEstimate, ChannelInfo, CheckpointReport, Command, Estimate, FieldLogEnd, FieldLogRecord, Frame, Hello,
    Samples, SnapshotPart, Status, MAX_BODY,
};
use crate::acc::LevelSum;
use crate::sensor::SensorKind;

/// A type whose postcard encoding never exceeds `MAX_SIZE` bytes.
pub trait MaxSize {
    /// The largest postcard encoding of any value of the type, in bytes.
    const MAX_SIZE: usize;
}

/// Bytes of the largest varint of a `bits`-bit unsigned integer.
pub const fn varint_max(bits: u32) -> usize {
    bits.div_ceil(7) as usize
}

/// Bytes of `n` as a varint (a sequence length).
const fn varint_len(mut n: usize) -> usize {
    let mut len = 1;
    while n >= 0x80 {
        n >>= 7;
        len += 1;
    }
    len
}

const fn max(a: usize, b: usize) -> usize {
    if a > b {
        a
    } else {
        b
    }
}

macro_rules! fixed {
    ($($t:ty => $n:expr),* $(,)?) => { $(impl MaxSize for $t { const MAX_SIZE: usize = $n; })* };
}

fixed! {
    u8 => 1,
    u16 => varint_max(16),
    u32 => varint_max(32),
    u64 => varint_max(64),
    u128 => varint_max(128),
    f32 => 4,
    // Six variants: the index is one varint byte.
    SensorKind => 1,
}

impl<T: MaxSize> MaxSize for Option<T> {
    const MAX_SIZE: usize = 1 + T::MAX_SIZE;
}

impl<const N: usize> MaxSize for String<N> {
    const MAX_SIZE: usize = varint_len(N) + N;
}

impl<T: MaxSize, const N: usize> MaxSize for Vec<T, N> {
    const MAX_SIZE: usize = varint_len(N) + N * T::MAX_SIZE;
}

/// `impl MaxSize` for a struct: the sum of its fields' sizes.
macro_rules! sum_of_fields {
    ($t:ident { $($f:ident: $ft:ty),* $(,)? }) => {
        impl MaxSize for $t {
            const MAX_SIZE: usize = 0 $(+ <$ft as MaxSize>::MAX_SIZE)*;
        }
        // Fails to build when a field is added to or removed from the struct but not here.
        const _: fn(&$t) = |v| { let $t { $($f: _),* } = v; };
    };
}

sum_of_fields!(LevelSum { n: u64, sum_sq: u128 });
sum_of_fields!(ChannelInfo { kind: SensorKind, name: String<{ super::MAX_CHANNEL_NAME }> });
sum_of_fields!(Hello {
    protocol_version: u16,
    firmware: String<{ super::MAX_IDENT }>,
    board: String<{ super::MAX_IDENT }>,
    rate_hz: u32,
    adc_bits: u8,
    vref_mv: u16,
    stride: u8,
    channels: Vec<ChannelInfo, { super::MAX_CHANNELS }>,
});
sum_of_fields!(Samples { first_sample: u64, channel_mask: u8, codes: Vec<u16, { super::MAX_CODES }> });
sum_of_fields!(SnapshotPart {
    channel: u8,
    stride: u8,
    samples: u64,
    first_level: u8,
    level_count: u8,
    levels: Vec<LevelSum, { super::LEVELS_PER_PART }>,
});
sum_of_fields!(Status {
    uptime_ms: u64,
    samples_per_channel: u64,
    adc_overruns: u32,
    frames_dropped: u32,
    temperature_c: Option<f32>,
    samples_lost: u64,
    stack_peak_bytes: Option<u32>,
});
sum_of_fields!(ChannelEstimate {
    channel: u8,
    n_dps_per_rt_s: Option<f32>,
    b_dps: Option<f32>,
    tau_b_s: Option<f32>,
});
sum_of_fields!(Estimate { samples: u64, channels: Vec<ChannelEstimate, { super::MAX_CHANNELS }> });
sum_of_fields!(FieldLogRecord { checkpoint: u32, time_s: u32, sessions: u32, adc_overruns: u32, part: SnapshotPart });
sum_of_fields!(FieldLogEnd { checkpoints: u32 });
sum_of_fields!(Ack { seq: u32 });
sum_of_fields!(CheckpointReport {
    seq: u32,
    checkpoint: u32,
    program_us: u32,
    erase_us: u32,
    samples_lost: u32,
    flash_error: u32
});

impl MaxSize for Frame {
    // Nine variants: one varint byte of index, then the largest variant.
    const MAX_SIZE: usize = 1 + max(
        max(
            max(max(Hello::MAX_SIZE, Samples::MAX_SIZE), max(SnapshotPart::MAX_SIZE, Status::MAX_SIZE)),
            max(max(Estimate::MAX_SIZE, FieldLogRecord::MAX_SIZE), max(FieldLogEnd::MAX_SIZE, Ack::MAX_SIZE)),
        ),
        CheckpointReport::MAX_SIZE,
    );
}

impl MaxSize for Command {
    // Six variants; the largest carries a u32.
    const MAX_SIZE: usize = 1 + u32::MAX_SIZE;
}

// The proof that every frame and command fits one frame buffer, checked when the crate builds.
const _: () = assert!(Frame::MAX_SIZE <= MAX_BODY, "a frame type outgrew MAX_FRAME");
const _: () = assert!(Command::MAX_SIZE <= MAX_BODY, "a command outgrew MAX_FRAME");

//! The protocol's tests: golden bytes, worst-case sizes, round trips, corruption and cuts, chunking, and a
//! million-input no-panic run. Helpers shared by them live here.

mod chunking;
mod corruption;
mod fuzz;
mod golden;
mod roundtrip;
mod sizes;

use std::vec::Vec;

use super::frame::truncated;
use super::*;
use crate::acc::LevelSum;
use crate::sensor::SensorKind;

/// Every sensor kind, in wire order.
pub(super) const KINDS: [SensorKind; 6] = [
    SensorKind::Idg1215X,
    SensorKind::Idg1215Y,
    SensorKind::Adxrs300,
    SensorKind::Env05h,
    SensorKind::Generic,
    SensorKind::Temperature,
];

/// One small, fixed example of every frame kind, in variant order (the golden-bytes values).
pub(super) fn example_frames() -> Vec<Frame> {
    let mut hello = Hello::new("0.1.0", "octavar-f405", 2000, 12, 3300, 8);
    hello.channels.push(ChannelInfo::new(SensorKind::Adxrs300, "adxrs300")).unwrap();
    hello.channels.push(ChannelInfo::new(SensorKind::Temperature, "temp")).unwrap();

    let mut samples = Samples::new(4096, 0b0000_0011);
    samples.push_set(&[2048, 4095]).unwrap();
    samples.push_set(&[0, 127]).unwrap();

    let part = SnapshotPart {
        channel: 1,
        stride: 8,
        samples: 1 << 20,
        first_level: 0,
        level_count: 2,
        levels: heapless::Vec::from_slice(&[
            LevelSum { n: 1_048_575, sum_sq: 1 << 70 },
            LevelSum { n: 300, sum_sq: 12_345 },
        ])
        .unwrap(),
    };

    let mut estimate = Estimate { samples: 1 << 30, channels: heapless::Vec::new() };
    let env05h = ChannelEstimate { channel: 0, n_dps_per_rt_s: Some(4.0e-4), b_dps: Some(9.5e-4), tau_b_s: Some(64.0) };
    estimate.channels.push(env05h).unwrap();
    let adxrs = ChannelEstimate { channel: 2, n_dps_per_rt_s: Some(0.046), b_dps: None, tau_b_s: None };
    estimate.channels.push(adxrs).unwrap();

    vec![
        Frame::Hello(hello),
        Frame::Samples(samples),
        Frame::AllanSnapshot(part.clone()),
        Frame::Status(Status {
            uptime_ms: 86_400_000,
            samples_per_channel: 172_800_000,
            adc_overruns: 2,
            frames_dropped: 17,
            temperature_c: Some(23.5),
            samples_lost: 3_999,
            stack_peak_bytes: Some(5_120),
        }),
        Frame::Estimate(estimate),
        Frame::FieldLog(FieldLogRecord { checkpoint: 12, time_s: 3600, sessions: 2, adc_overruns: 1, part }),
        Frame::FieldLogEnd(FieldLogEnd { checkpoints: 13 }),
        Frame::Ack(Ack { seq: 70_000 }),
        Frame::CheckpointReport(CheckpointReport {
            seq: 9,
            checkpoint: 41,
            program_us: 78_700,
            erase_us: 500_000,
            samples_lost: 0,
            flash_error: 0,
        }),
    ]
}

/// Every command, in variant order.
pub(super) fn example_commands() -> Vec<Command> {
    vec![
        Command::StartRaw { channel_mask: 0b101 },
        Command::StopRaw,
        Command::Reset,
        Command::ReadFieldLog { from_checkpoint: 300 },
        Command::Hello,
        Command::Checkpoint,
    ]
}

/// A string of exactly `N` bytes and no zero byte.
pub(super) fn full_string<const N: usize>() -> heapless::String<N> {
    truncated(&"\u{7f}".repeat(N))
}

/// The largest possible part: every field at its widest varint.
pub(super) fn worst_part() -> SnapshotPart {
    let mut levels = heapless::Vec::new();
    while levels.push(LevelSum { n: u64::MAX, sum_sq: u128::MAX }).is_ok() {}
    SnapshotPart { channel: 255, stride: 255, samples: u64::MAX, first_level: 255, level_count: 255, levels }
}

/// The largest value of every frame kind, in variant order.
pub(super) fn worst_frames() -> Vec<Frame> {
    let mut channels = heapless::Vec::new();
    while channels.push(ChannelInfo { kind: SensorKind::Temperature, name: full_string() }).is_ok() {}
    let hello = Hello {
        protocol_version: u16::MAX,
        firmware: full_string(),
        board: full_string(),
        rate_hz: u32::MAX,
        adc_bits: 255,
        vref_mv: u16::MAX,
        stride: 255,
        channels,
    };
    let mut codes = heapless::Vec::new();
    while codes.push(u16::MAX).is_ok() {}
    let mut est = heapless::Vec::new();
    let e = ChannelEstimate {
        channel: 255,
        n_dps_per_rt_s: Some(f32::MAX),
        b_dps: Some(f32::MIN),
        tau_b_s: Some(f32::MAX),
    };
    while est.push(e).is_ok() {}
    vec![
        Frame::Hello(hello),
        Frame::Samples(Samples { first_sample: u64::MAX, channel_mask: 255, codes }),
        Frame::AllanSnapshot(worst_part()),
        Frame::Status(Status {
            uptime_ms: u64::MAX,
            samples_per_channel: u64::MAX,
            adc_overruns: u32::MAX,
            frames_dropped: u32::MAX,
            temperature_c: Some(f32::MAX),
            samples_lost: u64::MAX,
            stack_peak_bytes: Some(u32::MAX),
        }),
        Frame::Estimate(Estimate { samples: u64::MAX, channels: est }),
        Frame::FieldLog(FieldLogRecord {
            checkpoint: u32::MAX,
            time_s: u32::MAX,
            sessions: u32::MAX,
            adc_overruns: u32::MAX,
            part: worst_part(),
        }),
        Frame::FieldLogEnd(FieldLogEnd { checkpoints: u32::MAX }),
        Frame::Ack(Ack { seq: u32::MAX }),
        Frame::CheckpointReport(CheckpointReport {
            seq: u32::MAX,
            checkpoint: u32::MAX,
            program_us: u32::MAX,
            erase_us: u32::MAX,
            samples_lost: u32::MAX,
            flash_error: u32::MAX,
        }),
    ]
}

/// A small, fast, seeded generator (xorshift64*) for the long randomised runs.
pub(super) struct XorShift(u64);

impl XorShift {
    pub(super) fn new(seed: u64) -> Self {
        XorShift(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    pub(super) fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in `0..n` (n > 0).
    pub(super) fn below(&mut self, n: usize) -> usize {
        (((self.next_u64() >> 32) * n as u64) >> 32) as usize
    }
    pub(super) fn byte(&mut self) -> u8 {
        (self.next_u64() >> 56) as u8
    }
}

/// A random frame of a random kind (field values random, collections of random length).
pub(super) fn random_frame(rng: &mut XorShift) -> Frame {
    let r = |rng: &mut XorShift, bits: u32| rng.next_u64() >> (64 - bits);
    match rng.below(9) {
        0 => {
            let mut h = Hello::new("0.1.0+g1234567", "octavar-f405", r(rng, 16) as u32, 12, 3300, 8);
            for i in 0..rng.below(MAX_CHANNELS + 1) {
                h.channels.push(ChannelInfo::new(KINDS[rng.below(6)], &format!("ch{i}"))).unwrap();
            }
            Frame::Hello(h)
        }
        1 => {
            let mask = rng.byte() | 1;
            let mut s = Samples::new(r(rng, 40), mask);
            let sets = rng.below(Samples::capacity_sets(mask) + 1);
            for _ in 0..sets {
                let set: Vec<u16> = (0..s.channels()).map(|_| r(rng, 12) as u16).collect();
                s.push_set(&set).unwrap();
            }
            Frame::Samples(s)
        }
        2 | 5 => {
            let count = rng.below(LEVELS_PER_PART + 1);
            let levels: heapless::Vec<LevelSum, LEVELS_PER_PART> =
                (0..count).map(|_| LevelSum { n: r(rng, 40), sum_sq: u128::from(r(rng, 64)) << r(rng, 6) }).collect();
            let part = SnapshotPart {
                channel: rng.byte() & 7,
                stride: 8,
                samples: r(rng, 40),
                first_level: 0,
                level_count: count as u8,
                levels,
            };
            if rng.below(2) == 0 {
                Frame::AllanSnapshot(part)
            } else {
                Frame::FieldLog(FieldLogRecord {
                    checkpoint: r(rng, 20) as u32,
                    time_s: r(rng, 32) as u32,
                    sessions: r(rng, 4) as u32,
                    adc_overruns: r(rng, 8) as u32,
                    part,
                })
            }
        }
        3 => Frame::Status(Status {
            uptime_ms: r(rng, 40),
            samples_per_channel: r(rng, 40),
            adc_overruns: r(rng, 8) as u32,
            frames_dropped: r(rng, 16) as u32,
            temperature_c: (rng.below(2) == 0).then(|| r(rng, 10) as f32 / 16.0),
            samples_lost: r(rng, 24),
            stack_peak_bytes: (rng.below(2) == 0).then(|| r(rng, 17) as u32),
        }),
        4 => {
            let n = rng.below(MAX_CHANNELS + 1);
            let channels: heapless::Vec<ChannelEstimate, MAX_CHANNELS> = (0..n)
                .map(|i| ChannelEstimate {
                    channel: i as u8,
                    n_dps_per_rt_s: Some(r(rng, 20) as f32 * 1e-6),
                    b_dps: (rng.below(3) > 0).then(|| r(rng, 20) as f32 * 1e-6),
                    tau_b_s: (rng.below(3) > 0).then(|| r(rng, 10) as f32),
                })
                .collect();
            Frame::Estimate(Estimate { samples: r(rng, 40), channels })
        }
        6 => Frame::FieldLogEnd(FieldLogEnd { checkpoints: r(rng, 20) as u32 }),
        7 => Frame::CheckpointReport(CheckpointReport {
            seq: r(rng, 32) as u32,
            checkpoint: r(rng, 20) as u32,
            program_us: r(rng, 20) as u32,
            erase_us: r(rng, 20) as u32,
            samples_lost: r(rng, 12) as u32,
            flash_error: r(rng, 8) as u32,
        }),
        _ => Frame::Ack(Ack { seq: r(rng, 32) as u32 }),
    }
}

/// A capture of `frames` numbered from `first_seq`: the bytes and, per frame, its byte range (delimiter
/// included).
pub(super) fn capture(frames: &[Frame], first_seq: u32) -> (Vec<u8>, Vec<core::ops::Range<usize>>) {
    let mut enc = Encoder::starting_at(first_seq);
    let mut bytes = Vec::new();
    let mut ranges = Vec::new();
    let mut buf = [0u8; MAX_FRAME];
    for f in frames {
        let n = enc.encode(f, &mut buf).unwrap();
        ranges.push(bytes.len()..bytes.len() + n);
        bytes.extend_from_slice(&buf[..n]);
    }
    (bytes, ranges)
}

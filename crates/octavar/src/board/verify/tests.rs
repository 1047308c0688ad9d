//! Tests of capture verification: exact replays agree, every kind of mismatch is found and named.

use super::*;
use crate::board::simulated::{DeviceConfig, DeviceSim};
use octavar_shared::proto::{Command, Decoder, Encoder, Frame, SnapshotPart};

fn scan(i: u32) -> [u16; 5] {
    let x = (i.wrapping_mul(2654435761) >> 20) as u16;
    [2000 + x % 97, 2000 + x % 13, 1900 + x % 301, 2048 + x % 5, 1950]
}

fn run(dev: &mut DeviceSim, from: u32, n: u32, out: &mut Vec<u8>) {
    for i in from..from + n {
        dev.push_scan(&scan(i), out);
    }
}

fn check(wire: &[u8]) -> VerifyReport {
    verify(CaptureReader::new(wire, "t.cap")).unwrap()
}

#[test]
fn a_device_gap_is_pooled_and_matches() {
    let mut dev = DeviceSim::new(DeviceConfig::F405, 0x1f);
    let mut out = Vec::new();
    dev.boot(&mut out);
    run(&mut dev, 0, 3000, &mut out);
    dev.lose_samples(77, &mut out);
    run(&mut dev, 3000, 4000, &mut out);
    let r = check(&out);
    assert_eq!((r.checked, r.matched, r.unchecked), (12, 12, 0), "{r:#?}");
    assert!(r.passed());
    // The gap is reported where the device lost the samples, and the device's own count agrees.
    assert_eq!(r.device_gaps, [DeviceGap { at_sample: 3000, lost: 77 }]);
    assert_eq!((r.device_samples_lost, r.status_samples_lost), (77, Some(77)));
}

#[test]
fn raw_streaming_paused_is_not_checkable_rather_than_a_mismatch() {
    let mut dev = DeviceSim::new(DeviceConfig::F405, 0x1f);
    let mut out = Vec::new();
    dev.boot(&mut out);
    run(&mut dev, 0, 2100, &mut out);
    dev.command(Command::StopRaw, &mut out);
    run(&mut dev, 2100, 1000, &mut out);
    dev.command(Command::StartRaw { channel_mask: 0x1f }, &mut out);
    run(&mut dev, 3100, 3000, &mut out);
    let r = check(&out);
    assert_eq!((r.checked, r.matched, r.mismatched_snapshots), (4, 4, 0), "{r:#?}");
    assert_eq!(r.unchecked, 8);
    assert!(r.unchecked_why.iter().all(|g| matches!(g.reason, Unchecked::RawHole { .. })), "{r:#?}");
    assert!(r.passed());
}

#[test]
fn late_start_lost_frames_and_unstreamed_channels_are_explained() {
    // Raw streaming of channels 0 and 1 only, starting after the first round.
    let mut dev = DeviceSim::new(DeviceConfig::F405, 0);
    let mut out = Vec::new();
    dev.boot(&mut out);
    run(&mut dev, 0, 2500, &mut out);
    dev.command(Command::StartRaw { channel_mask: 0b11 }, &mut out);
    run(&mut dev, 2500, 2000, &mut out);
    let r = check(&out);
    assert_eq!(r.checked, 0);
    assert!(!r.passed());
    let reasons: Vec<_> = r.unchecked_why.iter().map(|g| (g.channel, g.reason.clone())).collect();
    assert!(reasons.contains(&(0, Unchecked::StartsLate { first_sample: 2432 })), "{reasons:?}");
    assert!(reasons.contains(&(3, Unchecked::NotStreamed)), "{reasons:?}");

    // Lost raw frames: the snapshot before the loss is checked, the ones after are not.
    let mut dev = DeviceSim::new(DeviceConfig::F405, 0x1f);
    let mut out = Vec::new();
    dev.boot(&mut out);
    run(&mut dev, 0, 2100, &mut out);
    dev.drop_next_frames(2);
    run(&mut dev, 2100, 2100, &mut out);
    let r = check(&out);
    assert_eq!((r.checked, r.matched), (4, 4), "{r:#?}");
    assert_eq!(r.unchecked, 4);
    assert!(
        matches!(r.unchecked_why[0].reason, Unchecked::FramesLost { from_sample: 2048, to_sample: 2112 }),
        "{r:#?}"
    );
}

/// The frames of `wire` without its hello, numbered from `first_seq`, raw indices shifted by `shift`.
fn continued(wire: &[u8], first_seq: u32, shift: u64) -> Vec<u8> {
    let mut dec = octavar_shared::proto::Decoder::<Frame>::new();
    let mut enc = Encoder::starting_at(first_seq);
    let mut out = Vec::new();
    for r in dec.feed(wire) {
        match r.unwrap().msg {
            Frame::Hello(_) => {}
            Frame::Samples(mut s) => {
                s.first_sample += shift;
                out.extend_from_slice(&enc.encode_to_vec(&Frame::Samples(s)).unwrap());
            }
            f => out.extend_from_slice(&enc.encode_to_vec(&f).unwrap()),
        }
    }
    out
}

#[test]
fn snapshots_after_a_reset_that_restarts_the_raw_index_are_checked() {
    // The firmware at a reset: empty accumulators and the raw index back to 0 at the next block, frames
    // numbered on (no reboot). After the reset it sends what a fresh device sends, without the hello.
    let mut dev = DeviceSim::new(DeviceConfig::F405, 0x1f);
    let mut out = Vec::new();
    dev.boot(&mut out);
    run(&mut dev, 0, 39 * 128, &mut out); // two rounds, then the reset at a block boundary
    let next_seq = Decoder::<Frame>::new().feed(&out).count() as u32;
    let mut fresh = DeviceSim::new(DeviceConfig::F405, 0x1f);
    let mut after = Vec::new();
    run(&mut fresh, 39 * 128, 33 * 128, &mut after); // two more rounds
    let mut wire = out.clone();
    wire.extend(continued(&after, next_seq, 0));
    let r = check(&wire);
    assert_eq!((r.snapshots, r.checked, r.matched, r.unchecked), (16, 16, 16, 0), "{r:#?}");
    assert_eq!((r.decode.lost_frames, r.decode.restarts), (0, 0));
    assert!(r.passed());

    // A raw index that runs on through the reset (since boot) cannot be lined up with the new accumulators.
    let mut wire = out;
    wire.extend(continued(&after, next_seq, 39 * 128));
    let r = check(&wire);
    assert_eq!((r.checked, r.matched, r.unchecked), (8, 8, 8), "{r:#?}");
    assert!(r.unchecked_why.iter().all(|g| g.reason == Unchecked::DeviceReset), "{r:#?}");
}

#[test]
fn a_wrong_snapshot_is_reported_with_channel_level_expected_and_got() {
    let mut dev = DeviceSim::new(DeviceConfig::F405, 0x1f);
    let mut out = Vec::new();
    dev.boot(&mut out);
    run(&mut dev, 0, 2100, &mut out);
    // A valid frame (good CRC) carrying a snapshot that is off by one in level 3.
    let mut bad = dev.snapshot(1);
    bad.levels[3].sum_sq += 1;
    let mut enc = Encoder::starting_at(10_000);
    for p in SnapshotPart::split(1, &bad) {
        out.extend_from_slice(&enc.encode_to_vec(&Frame::AllanSnapshot(p)).unwrap());
    }
    let r = check(&out);
    assert_eq!(r.mismatched_snapshots, 1, "{r:#?}");
    assert!(!r.passed());
    assert_eq!(r.mismatches.len(), 1);
    let m = &r.mismatches[0];
    assert_eq!((m.channel, m.samples, m.frame_seq), (1, 2048, 10_000));
    match m.field {
        MismatchField::Level { level, expected, got } => {
            assert_eq!(level, 3);
            assert_eq!(got.sum_sq, expected.sum_sq + 1);
        }
        ref other => panic!("{other:?}"),
    }
    assert!(m.to_string().starts_with("channel 1, snapshot at sample 2048 (frame 10000"), "{m}");
}

//! Tests of the decoder, the summary and the export.

use super::*;
use octavar_shared::acc::OctaveAllan;
use octavar_shared::proto::{Encoder, Samples};

fn snapshot(samples: u32) -> Snapshot {
    let mut acc = OctaveAllan::<8>::new();
    (0..samples).for_each(|i| acc.push((i.wrapping_mul(2654435761) >> 20) as u16));
    acc.snapshot()
}

fn decoded(bytes: &[u8]) -> (Vec<Decoded>, DecodeStats) {
    let mut r = CaptureReader::new(bytes, "t");
    let v = r.by_ref().collect::<Result<Vec<_>, _>>().unwrap();
    (v, r.stats().clone())
}

#[test]
fn snapshot_parts_join_and_a_lost_part_is_counted() {
    let snap = snapshot(300_000); // 18 levels: two parts
    let parts: Vec<_> = SnapshotPart::split(2, &snap).collect();
    assert_eq!(parts.len(), 2);
    let mut enc = Encoder::new();
    let mut bytes = Vec::new();
    for p in &parts {
        bytes.extend_from_slice(&enc.encode_to_vec(&Frame::AllanSnapshot(p.clone())).unwrap());
    }
    // Second snapshot: only its second part arrives.
    enc.encode_to_vec(&Frame::AllanSnapshot(parts[0].clone())).unwrap();
    let second_at = bytes.len() as u64;
    bytes.extend_from_slice(&enc.encode_to_vec(&Frame::AllanSnapshot(parts[1].clone())).unwrap());
    let (recs, stats) = decoded(&bytes);
    assert_eq!(recs.len(), 1);
    assert_eq!(recs[0].message, Message::Snapshot(ChannelSnapshot { channel: 2, snapshot: snap }));
    assert_eq!(recs[0].meta.seq, 1);
    assert_eq!(recs[0].meta.offset, 0);
    assert_eq!((stats.snapshots, stats.snapshot_parts, stats.incomplete_snapshots), (1, 3, 1));
    assert_eq!(stats.lost_frames, 1);
    assert_eq!(stats.bad_frames, [BadFrame { offset: second_at, len: 0, reason: BadReason::SnapshotParts }]);
}

#[test]
fn field_log_parts_join_with_their_checkpoint() {
    let snap = snapshot(300_000);
    let mut enc = Encoder::new();
    let mut bytes = Vec::new();
    for part in SnapshotPart::split(1, &snap) {
        let rec = FieldLogRecord { checkpoint: 3, time_s: 600, sessions: 2, adc_overruns: 1, part };
        bytes.extend_from_slice(&enc.encode_to_vec(&Frame::FieldLog(rec)).unwrap());
    }
    bytes.extend_from_slice(&enc.encode_to_vec(&Frame::FieldLogEnd(FieldLogEnd { checkpoints: 1 })).unwrap());
    let (recs, stats) = decoded(&bytes);
    let want =
        FieldLogSnapshot { checkpoint: 3, time_s: 600, sessions: 2, adc_overruns: 1, channel: 1, snapshot: snap };
    assert_eq!(recs[0].message, Message::FieldLog(want));
    assert_eq!(recs[1].message, Message::FieldLogEnd(FieldLogEnd { checkpoints: 1 }));
    assert_eq!((stats.field_log_snapshots, stats.field_log_ends, stats.incomplete_snapshots), (1, 1, 0));
}

#[test]
fn offsets_locate_bad_frames_and_the_tail() {
    let mut enc = Encoder::new();
    let mut s = Samples::new(0, 1);
    s.push_set(&[7]).unwrap();
    let good = enc.encode_to_vec(&Frame::Samples(s.clone())).unwrap();
    let mut bad = enc.encode_to_vec(&Frame::Samples(s)).unwrap();
    bad[3] ^= 0x40;
    let mut bytes = good.to_vec();
    bytes.extend_from_slice(&bad);
    bytes.extend_from_slice(&good);
    bytes.extend_from_slice(&good[..5]);
    let (recs, stats) = decoded(&bytes);
    assert_eq!(recs.len(), 2);
    assert_eq!(recs[1].meta.offset, (good.len() + bad.len()) as u64);
    assert_eq!(stats.bad_frame_count(), 1);
    assert_eq!(stats.truncated_tail, 5);
    let first = stats.bad_frames[0];
    assert_eq!((first.offset, first.len), (good.len() as u64, bad.len() as u64 - 1));
    assert!(matches!(first.reason, BadReason::Crc | BadReason::Cobs), "{first:?}");
    assert_eq!(stats.bad_frames[1].offset, (2 * good.len() + bad.len()) as u64);
    assert_eq!(stats.bytes_dropped, bad.len() as u64 - 1 + 5);
}

#[test]
fn an_empty_capture_is_an_error() {
    let mut r = CaptureReader::new(&[][..], "empty.cap");
    let e = r.next().unwrap().unwrap_err();
    assert_eq!(e.to_string(), "empty.cap is empty (0 bytes): nothing was recorded");
    assert!(r.next().is_none());
}

#[test]
fn thinning_keeps_an_even_bounded_series() {
    let mut t = Thinned::new(8);
    (0..100u32).for_each(|i| t.push(i));
    let (items, step) = t.into_parts();
    assert!(items.len() <= 8);
    assert!(items.windows(2).all(|w| u64::from(w[1] - w[0]) == step), "{items:?} {step}");
    assert_eq!(items[0], 0);
}

#[test]
fn adev_at_interpolates_between_octaves() {
    let snap = snapshot(1 << 16);
    let a = snap.adev_codes(10).unwrap();
    let b = snap.adev_codes(11).unwrap();
    assert_eq!(adev_codes_at(&snap, 1024.0, 1.0), Some(a));
    let mid = adev_codes_at(&snap, 2000.0, 1.0).unwrap();
    assert!(mid > a.min(b) && mid < a.max(b) || a == b, "{a} {mid} {b}");
    assert_eq!(adev_codes_at(&snap, 2000.0, 1e6), None);
}

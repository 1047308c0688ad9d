//! Worst-case sizes: the largest value of every frame kind serialises to exactly its [`MaxSize`], and its
//! encoded frame, delimiter included, fits [`MAX_FRAME`].

use super::*;

fn body_len<T: serde::Serialize>(v: &T) -> usize {
    let mut buf = [0u8; 4 * MAX_FRAME];
    postcard::to_slice(v, &mut buf).unwrap().len()
}

/// The arithmetic of [`MaxSize`] is exact: a value with every field at its widest takes that many bytes.
#[test]
fn worst_case_values_take_exactly_max_size() {
    let worst = worst_frames();
    for f in &worst {
        let (inner, max) = match f {
            Frame::Hello(v) => (body_len(v), Hello::MAX_SIZE),
            Frame::Samples(v) => (body_len(v), Samples::MAX_SIZE),
            Frame::AllanSnapshot(v) => (body_len(v), SnapshotPart::MAX_SIZE),
            Frame::Status(v) => (body_len(v), Status::MAX_SIZE),
            Frame::Estimate(v) => (body_len(v), Estimate::MAX_SIZE),
            Frame::FieldLog(v) => (body_len(v), FieldLogRecord::MAX_SIZE),
            Frame::FieldLogEnd(v) => (body_len(v), FieldLogEnd::MAX_SIZE),
            Frame::Ack(v) => (body_len(v), Ack::MAX_SIZE),
            Frame::CheckpointReport(v) => (body_len(v), CheckpointReport::MAX_SIZE),
        };
        assert_eq!(inner, max, "{f:?}");
        assert_eq!(body_len(f), 1 + max);
    }
    let largest = worst.iter().map(body_len).max().unwrap();
    assert_eq!(largest, Frame::MAX_SIZE);
    assert_eq!(body_len(&Command::ReadFieldLog { from_checkpoint: u32::MAX }), Command::MAX_SIZE);
    assert_eq!(body_len(&worst_part().levels[0]), 29);
}

/// The documented table of worst cases (body bytes, then the frame on the wire).
#[test]
fn worst_case_table() {
    assert_eq!(Hello::MAX_SIZE + 1, 209);
    assert_eq!(Samples::MAX_SIZE + 1, 494);
    assert_eq!(SnapshotPart::MAX_SIZE + 1, 480);
    assert_eq!(Status::MAX_SIZE + 1, 52);
    assert_eq!(Estimate::MAX_SIZE + 1, 140);
    assert_eq!(FieldLogRecord::MAX_SIZE + 1, 500);
    assert_eq!(FieldLogEnd::MAX_SIZE + 1, 6);
    assert_eq!(Ack::MAX_SIZE + 1, 6);
    assert_eq!(CheckpointReport::MAX_SIZE + 1, 31);
    assert_eq!(Frame::MAX_SIZE, 500);
    assert_eq!(Command::MAX_SIZE, 6);
    // 500 body + 8 sequence/CRC = 508 bytes before COBS; COBS adds ceil(508 / 254) = 2; plus the delimiter.
    let wire = Frame::MAX_SIZE + SEQ_LEN + CRC_LEN;
    assert_eq!(cobs::max_encoding_length(wire) + 1, 511);
    assert!(cobs::max_encoding_length(wire) < MAX_FRAME);
}

/// Every worst-case frame encodes, delimiter included, within [`MAX_FRAME`], whatever its sequence number, and
/// decodes back.
#[test]
fn worst_case_frames_fit_and_decode() {
    let mut buf = [0u8; MAX_FRAME];
    for f in worst_frames() {
        for seq in [0, 0x0101_0101, u32::MAX] {
            let n = encode_frame(seq, &f, &mut buf).unwrap();
            assert!(n <= MAX_FRAME, "{n}");
            assert_eq!(n, encode_to_vec(seq, &f).unwrap().len());
            let mut dec = Decoder::<Frame>::new();
            let got: Vec<_> = dec.feed(&buf[..n]).collect();
            assert_eq!(got, [Ok(Received { seq, lost: 0, msg: f.clone() })]);
        }
    }
}

/// A full 32-level snapshot of worst-case sums goes out in two parts, each within a frame.
#[test]
fn full_snapshot_splits_into_two_fitting_frames() {
    let mut snap = crate::acc::Snapshot::empty(64).unwrap();
    snap.samples = u64::MAX;
    snap.levels = [LevelSum { n: u64::MAX, sum_sq: u128::MAX }; crate::acc::LEVELS];
    let parts: Vec<_> = SnapshotPart::split(7, &snap).collect();
    assert_eq!(parts.len(), 2);
    for p in &parts {
        let n = encode_to_vec(0, &Frame::AllanSnapshot(p.clone())).unwrap().len();
        assert!(n <= MAX_FRAME, "{n}");
        let rec = FieldLogRecord {
            checkpoint: u32::MAX,
            time_s: u32::MAX,
            sessions: u32::MAX,
            adc_overruns: u32::MAX,
            part: p.clone(),
        };
        assert!(encode_to_vec(0, &Frame::FieldLog(rec)).unwrap().len() <= MAX_FRAME);
    }
    assert_eq!(SnapshotPart::join(&parts), Ok((7, snap)));
}

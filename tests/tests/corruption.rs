//! Damaged captures: bytes flipped, inserted and deleted at random (1%), captures cut mid-frame, and frames
//! altered behind a valid CRC. Decode yields every intact frame and never a damaged one; verify never calls
//! damaged or altered data a match, and nothing panics.

use std::collections::BTreeMap;

use octavar::board::verify::{verify, MismatchField, VerifyReport};
use octavar::io::decode::{CaptureReader, Decoded, Message};
use octavar_shared::acc::{OctaveAllan, Snapshot};
use octavar_shared::proto::{encode_to_vec, Decoder, Frame, SnapshotPart};

use crate::pipeline::device_capture;

/// xorshift64*: a small deterministic generator for the damage.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

/// The frames of a clean capture: (first byte, one past the delimiter, seq, frame).
fn frames(wire: &[u8]) -> Vec<(usize, usize, u32, Frame)> {
    let mut out = Vec::new();
    let mut dec = Decoder::<Frame>::new();
    let mut start = 0;
    for (i, &b) in wire.iter().enumerate() {
        if let Some(r) = dec.push(b) {
            let r = r.expect("the clean capture has no bad frame");
            out.push((start, i + 1, r.seq, r.msg));
            start = i + 1;
        }
    }
    out
}

/// Damage about `rate` of the bytes (flip, insert or delete, a third each); returns the damaged capture and, per
/// frame, whether any of its bytes (delimiter included) or the position just before it was touched.
fn damage(wire: &[u8], spans: &[(usize, usize, u32, Frame)], rate: f64, rng: &mut Rng) -> (Vec<u8>, Vec<bool>) {
    let frame_of = |i: usize| spans.partition_point(|s| s.1 <= i);
    let mut touched = vec![false; spans.len()];
    let mut out = Vec::with_capacity(wire.len() + wire.len() / 50);
    let threshold = (rate * u64::MAX as f64) as u64;
    for (i, &b) in wire.iter().enumerate() {
        if rng.next() >= threshold {
            out.push(b);
            continue;
        }
        let f = frame_of(i);
        touched[f] = true;
        if b == 0 && f + 1 < spans.len() {
            touched[f + 1] = true; // a damaged delimiter merges the frame with the next
        }
        match rng.below(3) {
            0 => out.push(b ^ (1 + rng.below(255)) as u8),
            1 => {
                // An insertion before byte i lands in the frame that holds byte i.
                out.push(rng.next() as u8);
                out.push(b);
            }
            _ => {}
        }
    }
    (out, touched)
}

/// The original records keyed by frame sequence number (a snapshot under its last part's).
fn originals(wire: &[u8]) -> BTreeMap<u32, Message> {
    CaptureReader::new(wire, "clean").map(|d| d.unwrap()).map(|d: Decoded| (d.meta.seq, d.message)).collect()
}

/// The frames each record was made of.
fn record_frames(spans: &[(usize, usize, u32, Frame)]) -> BTreeMap<u32, Vec<usize>> {
    let mut out = BTreeMap::new();
    let mut parts: BTreeMap<u8, Vec<usize>> = BTreeMap::new();
    for (i, (_, _, seq, f)) in spans.iter().enumerate() {
        match f {
            Frame::AllanSnapshot(p) => {
                let v = parts.entry(p.channel).or_default();
                if p.first_level == 0 {
                    v.clear();
                }
                v.push(i);
                if p.is_last() {
                    out.insert(*seq, std::mem::take(v));
                }
            }
            _ => {
                out.insert(*seq, vec![i]);
            }
        }
    }
    out
}

fn no_false_match(r: &VerifyReport) {
    assert_eq!(r.mismatched_snapshots, 0, "intact frames never disagree: {:#?}", r.mismatches);
    assert_eq!(r.checked, r.matched);
}

#[test]
fn one_percent_damage_yields_every_intact_frame_and_no_damaged_one() {
    let (wire, _) = device_capture(21, 6);
    let spans = frames(&wire);
    let clean = originals(&wire);
    let made_of = record_frames(&spans);
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let (mut intact_seen, mut damaged_frames) = (0, 0);
    for round in 0..30 {
        let (bad, touched) = damage(&wire, &spans, 0.01, &mut rng);
        let mut reader = CaptureReader::new(&bad[..], "damaged");
        let got: Vec<Decoded> = reader.by_ref().map(|d| d.unwrap()).collect();
        let by_seq: BTreeMap<u32, &Message> = got.iter().map(|d| (d.meta.seq, &d.message)).collect();
        assert_eq!(by_seq.len(), got.len(), "round {round}: a sequence number twice");
        // Never a damaged record: everything decoded is exactly an original.
        for d in &got {
            assert_eq!(Some(&d.message), clean.get(&d.meta.seq), "round {round}: seq {} altered", d.meta.seq);
        }
        // Every intact record is there.
        for (seq, frames) in &made_of {
            if frames.iter().all(|&f| !touched[f]) {
                assert!(by_seq.contains_key(seq), "round {round}: intact frame {seq} missing");
                intact_seen += 1;
            }
        }
        damaged_frames += touched.iter().filter(|&&t| t).count();
        let stats = reader.stats();
        assert!(stats.bad_frame_count() > 0 && stats.lost_frames > 0, "round {round}: {stats:?}");
        no_false_match(&verify(CaptureReader::new(&bad[..], "damaged")).unwrap());
    }
    assert!(intact_seen > 100 && damaged_frames > 100, "{intact_seen} {damaged_frames}");
}

#[test]
fn a_capture_cut_mid_frame_yields_every_frame_before_the_cut() {
    let (wire, _) = device_capture(4, 3);
    let spans = frames(&wire);
    let mut rng = Rng(7);
    for _ in 0..40 {
        let cut = 1 + rng.below(wire.len() - 1);
        let complete = spans.iter().filter(|s| s.1 <= cut).count();
        let tail = cut - spans.get(complete).map_or(cut, |s| s.0);
        let mut reader = CaptureReader::new(&wire[..cut], "cut");
        let n = reader.by_ref().count();
        let st = reader.stats();
        assert_eq!(st.frames as usize, complete, "cut at {cut}");
        assert_eq!(st.truncated_tail as usize, tail, "cut at {cut}");
        assert!(n <= complete);
        let r = verify(CaptureReader::new(&wire[..cut], "cut")).unwrap();
        no_false_match(&r);
        // Rounds whose raw samples and snapshot parts are all before the cut are checked.
        let rounds_before =
            spans[..complete].iter().filter(|s| matches!(&s.3, Frame::AllanSnapshot(p) if p.is_last())).count() as u64;
        assert_eq!(r.checked, rounds_before, "cut at {cut}");
    }
}

/// Replace frame `i` of a clean capture by `frame` with the same sequence number and a valid CRC.
fn replace(wire: &[u8], spans: &[(usize, usize, u32, Frame)], i: usize, frame: &Frame) -> Vec<u8> {
    let (start, end, seq, _) = &spans[i];
    let mut out = wire[..*start].to_vec();
    out.extend_from_slice(&encode_to_vec(*seq, frame).unwrap());
    out.extend_from_slice(&wire[*end..]);
    out
}

#[test]
fn altered_codes_or_sums_behind_a_valid_crc_are_mismatches() {
    let (wire, scans) = device_capture(9, 3);
    let spans = frames(&wire);
    let mut rng = Rng(99);
    let samples_frames: Vec<usize> = (0..spans.len())
        .filter(|&i| matches!(&spans[i].3, Frame::Samples(s) if s.first_sample + (s.sets() as u64) <= 4000))
        .collect();
    for _ in 0..12 {
        // One raw code changed: the replay of the changed codes must differ from the device's snapshots.
        let i = samples_frames[rng.below(samples_frames.len())];
        let Frame::Samples(mut s) = spans[i].3.clone() else { unreachable!() };
        let set = rng.below(s.sets());
        let slot = rng.below(4); // a gyro channel
        let at = set * s.channels() + slot;
        s.codes[at] = 4095 - s.codes[at];
        let sample = s.first_sample as usize + set;
        let mut changed: Vec<u16> = scans.iter().map(|x| x[slot]).collect();
        changed[sample] = s.codes[at];
        let mut acc = OctaveAllan::<8>::new();
        let round_end = (sample / 2000 + 1) * 2000;
        acc.push_slice(&changed[..round_end]);
        let mut honest = OctaveAllan::<8>::new();
        honest.push_slice(&scans.iter().map(|x| x[slot]).collect::<Vec<_>>()[..round_end]);
        assert_ne!(acc.snapshot(), honest.snapshot(), "the change must matter for this check to mean anything");

        let r = verify(CaptureReader::new(&replace(&wire, &spans, i, &Frame::Samples(s))[..], "altered")).unwrap();
        assert!(!r.passed());
        assert!(r.mismatched_snapshots >= 1, "{r:#?}");
        assert!(r.mismatches.iter().all(|m| usize::from(m.channel) == slot), "{:#?}", r.mismatches);
        assert!(r.mismatches.iter().all(|m| m.samples as usize >= round_end), "{:#?}", r.mismatches);
    }

    // One snapshot's sum off by one in one level.
    let snaps: Vec<usize> =
        (0..spans.len()).filter(|&i| matches!(&spans[i].3, Frame::AllanSnapshot(p) if p.levels.len() > 3)).collect();
    for _ in 0..8 {
        let i = snaps[rng.below(snaps.len())];
        let Frame::AllanSnapshot(mut p) = spans[i].3.clone() else { unreachable!() };
        let level = rng.below(p.levels.len());
        p.levels[level].sum_sq ^= 1 << rng.below(8);
        let (channel, samples) = (p.channel, p.samples);
        let r =
            verify(CaptureReader::new(&replace(&wire, &spans, i, &Frame::AllanSnapshot(p))[..], "altered")).unwrap();
        assert_eq!(r.mismatched_snapshots, 1, "{r:#?}");
        assert_eq!(r.mismatches.len(), 1);
        let m = &r.mismatches[0];
        assert_eq!((m.channel, m.samples), (channel, samples));
        assert!(matches!(m.field, MismatchField::Level { level: l, .. } if usize::from(l) == level));
    }
}

#[test]
fn random_bytes_and_mutated_snapshots_never_panic() {
    let mut rng = Rng(31337);
    let (wire, _) = device_capture(2, 1);
    let spans = frames(&wire);
    for _ in 0..200 {
        let len = rng.below(4000);
        let bytes: Vec<u8> = (0..len).map(|_| if rng.below(8) == 0 { 0 } else { rng.next() as u8 }).collect();
        let _ = verify(CaptureReader::new(&bytes[..], "noise")).map(|r| no_false_match(&r));
    }
    // Valid frames with nonsense inside: absurd strides, sample counts and level counts.
    let snap_frame = spans.iter().position(|s| matches!(s.3, Frame::AllanSnapshot(_))).unwrap();
    for _ in 0..200 {
        let Frame::AllanSnapshot(mut p) = spans[snap_frame].3.clone() else { unreachable!() };
        match rng.below(4) {
            0 => p.stride = rng.next() as u8,
            1 => p.samples = rng.next(),
            2 => p.level_count = rng.next() as u8,
            _ => p.first_level = rng.next() as u8,
        }
        let _ = verify(CaptureReader::new(&replace(&wire, &spans, snap_frame, &Frame::AllanSnapshot(p))[..], "x"));
    }
    let mut s = Snapshot::empty(8).unwrap();
    s.samples = u64::MAX;
    let parts: Vec<SnapshotPart> = SnapshotPart::split(7, &s).collect();
    let bytes = replace(&wire, &spans, snap_frame, &Frame::AllanSnapshot(parts[0].clone()));
    let r = verify(CaptureReader::new(&bytes[..], "huge")).unwrap();
    no_false_match(&r);
}

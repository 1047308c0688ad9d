//! Corrupted and cut captures: every intact frame comes out, no corrupted one does.

use std::collections::BTreeMap;

use super::*;

fn random_frames(rng: &mut XorShift, n: usize) -> Vec<Frame> {
    (0..n).map(|_| random_frame(rng)).collect()
}

/// Decode `bytes` all at once: the accepted frames by sequence number, and the decoder.
fn decode(bytes: &[u8]) -> (BTreeMap<u32, Frame>, Decoder<Frame>) {
    let mut dec = Decoder::<Frame>::new();
    let mut got = BTreeMap::new();
    for r in dec.feed(bytes).flatten() {
        assert!(got.insert(r.seq, r.msg).is_none(), "frame {} accepted twice", r.seq);
    }
    (got, dec)
}

/// 1% of the bytes of a capture replaced by random different values, 20 captures of 1500 frames: every frame
/// whose bytes and preceding delimiter are untouched comes out equal to the original; nothing else comes out.
#[test]
fn one_percent_corruption_yields_every_intact_frame_and_no_corrupted_one() {
    let mut rng = XorShift::new(0xC0FFEE);
    let (mut total_intact, mut total_frames) = (0, 0);
    for round in 0..20u32 {
        let frames = random_frames(&mut rng, 1500);
        let first_seq = round.wrapping_mul(0x1234_5679).wrapping_sub(700); // some rounds wrap around
        let (mut bytes, ranges) = capture(&frames, first_seq);
        let mut hit = vec![false; bytes.len()];
        for _ in 0..bytes.len() / 100 {
            let i = rng.below(bytes.len());
            bytes[i] ^= rng.byte().max(1);
            hit[i] = true;
        }
        let (got, dec) = decode(&bytes);
        for (seq, msg) in &got {
            let k = seq.wrapping_sub(first_seq) as usize;
            assert!(k < frames.len(), "round {round}: unknown seq {seq}");
            assert_eq!(msg, &frames[k], "round {round}: a corrupted frame {seq} was accepted");
        }
        for (k, r) in ranges.iter().enumerate() {
            let from = if k == 0 { 0 } else { r.start - 1 }; // the previous delimiter
            if !hit[from..r.end].contains(&true) {
                total_intact += 1;
                let seq = first_seq.wrapping_add(k as u32);
                assert!(got.contains_key(&seq), "round {round}: intact frame {k} lost");
            }
        }
        total_frames += frames.len();
        let s = dec.stats();
        // Every frame that did not come out is a loss the sequence numbers reveal (the last frames of a
        // capture excepted, when they are all lost: here the capture's tail is almost surely intact).
        let received = got.len() as u64;
        let first_k = got.keys().map(|s| s.wrapping_sub(first_seq)).min().unwrap();
        let last_k = got.keys().map(|s| s.wrapping_sub(first_seq)).max().unwrap();
        assert_eq!(s.lost, u64::from(last_k - first_k + 1) - received, "round {round}");
        assert_eq!(s.restarts, 0);
        assert!(s.errors() > 0);
        assert_eq!(s.bytes, bytes.len() as u64);
    }
    // With 1% of bytes hit and frames of about 100 bytes, roughly a third of the frames survive.
    assert!(total_intact > total_frames / 5, "{total_intact} of {total_frames}");
}

/// Every single-bit error and every single-byte substitution of every example frame is rejected.
#[test]
fn every_single_bit_and_byte_error_is_rejected() {
    for f in example_frames().iter().chain(worst_frames().iter()) {
        let frame = encode_to_vec(5, f).unwrap();
        let body = frame.len() - 1; // keep the delimiter
        let mut dec = Decoder::<Frame>::new();
        for i in 0..body {
            for bit in 0..8 {
                let mut b = frame.clone();
                b[i] ^= 1 << bit;
                assert!(dec.feed(&b).all(|r| r.is_err()), "{f:?}: bit {bit} of byte {i}");
            }
            for v in [0x01, 0x7f, 0xfe, 0xff] {
                let mut b = frame.clone();
                if b[i] != v {
                    b[i] = v;
                    assert!(dec.feed(&b).all(|r| r.is_err()), "{f:?}: byte {i} = {v}");
                }
            }
        }
        assert_eq!(dec.stats().frames, 0);
    }
}

/// Garbage before, between and after frames costs only the frame it runs into.
#[test]
fn resynchronises_after_garbage() {
    let frames = example_frames();
    let (clean, ranges) = capture(&frames, 0);
    let mut bytes = vec![0x42, 0x13, 0x00, 0xFF, 0xFF]; // a delimited garbage frame, then garbage run into frame 0
    bytes.extend_from_slice(&clean[..ranges[3].end]);
    bytes.extend(std::iter::repeat_n(0x99, 2000)); // an oversize run, delimited by frame 4's end
    bytes.extend_from_slice(&clean[ranges[3].end..]);
    let (got, dec) = decode(&bytes);
    let seqs: Vec<u32> = got.keys().copied().collect();
    assert_eq!(seqs, [1, 2, 3, 5, 6, 7, 8]);
    assert_eq!(dec.stats().lost, 1); // frame 4; frame 0 came before the first accepted one
    assert_eq!(dec.stats().oversize, 1);
    assert_eq!(dec.stats().errors(), 3);
}

/// A capture cut anywhere yields exactly the frames whose delimiter lies before the cut.
#[test]
fn a_cut_capture_yields_every_frame_before_the_cut() {
    let mut rng = XorShift::new(77);
    let frames = random_frames(&mut rng, 300);
    let (bytes, ranges) = capture(&frames, 10);
    let mut cuts: Vec<usize> = (0..200).map(|_| rng.below(bytes.len() + 1)).collect();
    cuts.extend([0, 1, bytes.len() - 1, bytes.len()]);
    cuts.extend(ranges.iter().take(20).flat_map(|r| [r.start, r.end - 1, r.end]));
    for cut in cuts {
        let (got, mut dec) = decode(&bytes[..cut]);
        let complete = ranges.iter().filter(|r| r.end <= cut).count();
        assert_eq!(got.len(), complete, "cut at {cut}");
        for (k, f) in frames.iter().take(complete).enumerate() {
            assert_eq!(got.get(&(10 + k as u32)), Some(f));
        }
        assert_eq!(dec.stats().errors(), 0);
        let tail = cut - ranges.get(complete.wrapping_sub(1)).map_or(0, |r| r.end);
        assert_eq!(dec.pending(), tail as u64);
        assert_eq!(dec.finish(), tail as u64);
    }
}

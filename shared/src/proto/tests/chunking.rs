//! Chunking invariance: one byte at a time, all at once and random chunks give the same frames, errors and
//! counters.

use proptest::prelude::*;

use super::*;

type Outcome = (Vec<Result<Received<Frame>, DecodeError>>, DecoderStats);

fn all_at_once(bytes: &[u8]) -> Outcome {
    let mut dec = Decoder::<Frame>::new();
    let out = dec.feed(bytes).collect();
    (out, *dec.stats())
}

fn byte_by_byte(bytes: &[u8]) -> Outcome {
    let mut dec = Decoder::<Frame>::new();
    let out = bytes.iter().filter_map(|&b| dec.push(b)).collect();
    (out, *dec.stats())
}

fn in_chunks(bytes: &[u8], cuts: &[usize]) -> Outcome {
    let mut dec = Decoder::<Frame>::new();
    let mut out = Vec::new();
    let mut cuts: Vec<usize> = cuts.iter().map(|c| c % (bytes.len() + 1)).collect();
    cuts.sort_unstable();
    let mut at = 0;
    for c in cuts.into_iter().chain([bytes.len()]) {
        out.extend(dec.feed(&bytes[at..c]));
        at = c;
    }
    (out, *dec.stats())
}

/// A capture of random frames, with some bytes corrupted and some garbage spliced in.
fn damaged_capture(seed: u64, frames: usize, damage: usize) -> Vec<u8> {
    let mut rng = XorShift::new(seed);
    let frames: Vec<Frame> = (0..frames).map(|_| random_frame(&mut rng)).collect();
    let (mut bytes, _) = capture(&frames, rng.next_u64() as u32);
    for _ in 0..damage {
        let i = rng.below(bytes.len() + 1);
        match rng.below(3) {
            0 if i < bytes.len() => bytes[i] = rng.byte(),
            1 => bytes.insert(i, if rng.below(4) == 0 { 0 } else { rng.byte() }),
            _ if i < bytes.len() => {
                bytes.remove(i);
            }
            _ => {}
        }
    }
    bytes
}

#[test]
fn byte_by_byte_equals_all_at_once_on_a_long_damaged_capture() {
    let bytes = damaged_capture(1, 2000, 300);
    let whole = all_at_once(&bytes);
    assert!(whole.1.frames > 1000 && whole.1.errors() > 50, "{:?}", whole.1);
    assert_eq!(byte_by_byte(&bytes), whole);
    let cuts: Vec<usize> = (0..5000).map(|i| i * 7919).collect();
    assert_eq!(in_chunks(&bytes, &cuts), whole);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1000, ..ProptestConfig::default() })]

    #[test]
    fn chunking_does_not_matter(
        seed in any::<u64>(),
        frames in 0usize..12,
        damage in 0usize..6,
        cuts in proptest::collection::vec(any::<usize>(), 0..40),
    ) {
        let bytes = damaged_capture(seed, frames, damage);
        let whole = all_at_once(&bytes);
        prop_assert_eq!(&byte_by_byte(&bytes), &whole);
        prop_assert_eq!(&in_chunks(&bytes, &cuts), &whole);
    }

    #[test]
    fn arbitrary_bytes_in_any_chunking(
        bytes in proptest::collection::vec(prop_oneof![Just(0u8), any::<u8>()], 0..700),
        cuts in proptest::collection::vec(any::<usize>(), 0..20),
    ) {
        let whole = all_at_once(&bytes);
        prop_assert_eq!(&byte_by_byte(&bytes), &whole);
        prop_assert_eq!(&in_chunks(&bytes, &cuts), &whole);
        prop_assert_eq!(whole.1.bytes, bytes.len() as u64);
    }
}

//! A million random and mutated inputs through both decoders: no panic, and nothing accepted that was not
//! sent.
//!
//! The default run (1,000,000 inputs, a few seconds with the test profile's opt-level 3) runs with every
//! `cargo test`. The heavier `#[ignore]`d run (50,000,000 inputs, several minutes) is for CI or a nightly:
//! `cargo test -p octavar-shared --release proto::tests::fuzz::fifty_million -- --ignored`.

use super::*;

/// A pool of valid frames and their encodings to mutate.
fn pool(rng: &mut XorShift) -> Vec<(Frame, Vec<u8>)> {
    let mut frames = example_frames();
    frames.extend(worst_frames());
    frames.extend((0..50).map(|_| random_frame(rng)));
    frames
        .into_iter()
        .enumerate()
        .map(|(i, f)| {
            let bytes = encode_to_vec(i as u32, &f).unwrap().to_vec();
            (f, bytes)
        })
        .collect()
}

/// One input: random bytes, or a few valid frames with random mutations (bit flips, substitutions, inserted
/// and deleted bytes, inserted and deleted delimiters, truncation, duplicated runs).
fn input(rng: &mut XorShift, pool: &[(Frame, Vec<u8>)], out: &mut Vec<u8>) {
    out.clear();
    if rng.below(4) == 0 {
        let len = rng.below(600);
        let zeros = rng.below(40); // per mille chance of a zero
        out.extend((0..len).map(|_| if rng.below(1000) < zeros { 0 } else { rng.byte() }));
        return;
    }
    for _ in 0..1 + rng.below(3) {
        out.extend_from_slice(&pool[rng.below(pool.len())].1);
    }
    for _ in 0..rng.below(5) {
        let i = rng.below(out.len() + 1);
        match rng.below(7) {
            0 if i < out.len() => out[i] ^= 1 << rng.below(8),
            1 if i < out.len() => out[i] = rng.byte(),
            2 => out.insert(i, rng.byte()),
            3 => out.insert(i, 0),
            4 if i < out.len() => {
                out.remove(i);
            }
            5 => out.truncate(i),
            6 if i < out.len() => {
                let j = i + rng.below(out.len() - i);
                let run: Vec<u8> = out[i..j].to_vec();
                out.splice(j..j, run);
            }
            _ => {}
        }
    }
}

fn run(inputs: u64, seed: u64) {
    let mut rng = XorShift::new(seed);
    let pool = pool(&mut rng);
    let mut frames = Decoder::<Frame>::new();
    let mut commands = Decoder::<Command>::new();
    let mut buf = Vec::with_capacity(2048);
    let (mut accepted, mut fed) = (0u64, 0u64);
    for _ in 0..inputs {
        input(&mut rng, &pool, &mut buf);
        fed += buf.len() as u64;
        for r in frames.feed(&buf).flatten() {
            // Only a frame that was sent can come out: the one with its sequence number in the pool.
            let sent = pool.get(r.seq as usize).map(|p| &p.0);
            assert_eq!(Some(&r.msg), sent, "accepted a frame that was never sent: {r:?}");
            accepted += 1;
        }
        for r in commands.feed(&buf) {
            let _ = r;
        }
        // Unterminated tails go, so each input starts clean half of the time; the other half they run on.
        if rng.below(2) == 0 {
            frames.finish();
            commands.finish();
        }
    }
    assert_eq!(frames.stats().bytes, fed);
    assert!(accepted > inputs / 4, "{accepted} of {inputs}");
    assert!(frames.stats().errors() > inputs / 4);
}

#[test]
fn a_million_random_and_mutated_inputs() {
    run(1_000_000, 1);
}

#[test]
#[ignore = "heavy: 50 million inputs, for CI or a nightly run with --ignored"]
fn fifty_million_random_and_mutated_inputs() {
    run(50_000_000, 2);
}

//! Throughput of the exact octave accumulator on the host, one channel, one core (issue 2 floors: S = 1 at
//! least 200 million samples/s, S = 8 at least 50 million).

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use octavar_shared::acc::OctaveAllan;

fn codes(n: usize) -> Vec<u16> {
    let mut s = 12345u64;
    (0..n)
        .map(|_| {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((s >> 32) as u32 >> 20) as u16
        })
        .collect()
}

fn run<const S: usize>(c: &mut Criterion, codes: &[u16]) {
    let mut g = c.benchmark_group("accumulator");
    g.throughput(Throughput::Elements(codes.len() as u64));
    g.bench_function(format!("push_stride_{S}"), |b| {
        b.iter(|| {
            let mut acc = OctaveAllan::<S>::new();
            acc.push_slice(black_box(codes));
            black_box(acc.sum_sq(0))
        })
    });
    g.finish();
}

fn accumulator(c: &mut Criterion) {
    let data = codes(1 << 22);
    run::<1>(c, &data);
    run::<8>(c, &data);
}

criterion_group!(benches, accumulator);
criterion_main!(benches);

//! OADEV at octave tau on 1e7 samples, compute only (from the samples in memory to the table with noise types,
//! EDF and intervals): the number bench/allantools_compare.sh sets against allantools.
//!
//! `cargo bench -p octavar --bench analyze` times a deterministic 1e7-sample record; with arguments
//! `FILE.f64 RATE_HZ REPS` it reads that raw f64le file instead and prints one JSON line
//! `{"compute_s", "compute_plain_s", "stride", "oadev": [[m, dev], ...]}` (used by the comparison script). Both
//! times are `analyze` from the array in memory: the phase, its OADEV at octave tau, and (compute_s) the noise
//! identification, EDF and intervals.

use std::time::Instant;

use octavar::stats::{analyze, DataKind, Options, Statistic, TauSpec};

/// Process CPU time, s (all threads): steadier than wall time when other work shares the cores.
fn cpu_s() -> f64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: a valid out-pointer.
    unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let (y, rate, reps, json) = if args.len() >= 3 {
        let bytes = std::fs::read(&args[0]).expect("reading the rate file");
        let y: Vec<f64> = bytes.chunks_exact(8).map(|b| f64::from_le_bytes(b.try_into().unwrap())).collect();
        (y, args[1].parse::<f64>().expect("rate"), args[2].parse::<usize>().expect("reps"), true)
    } else {
        let mut s = 0x9E37_79B9_7F4A_7C15u64;
        let y: Vec<f64> = (0..10_000_000)
            .map(|_| {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            })
            .collect();
        (y, 1.0, 7, false)
    };
    let opts = Options::default();
    let (mut best, mut cpu, mut rows) = (f64::INFINITY, f64::INFINITY, Vec::new());
    for _ in 0..reps.max(1) {
        let (c0, t0) = (cpu_s(), Instant::now());
        rows = analyze(&y, DataKind::Frequency, 1.0 / rate, Statistic::Oadev, &TauSpec::Octave, &opts).unwrap();
        best = best.min(t0.elapsed().as_secs_f64());
        cpu = cpu.min(cpu_s() - c0);
    }
    // Like for like with allantools' oadev, which returns deviations, counts and dev/sqrt(n): no noise
    // identification, EDF or chi-square intervals.
    let plain = Options { intervals: false, ..Options::default() };
    let (mut best_plain, mut cpu_plain) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..reps.max(1) {
        let (c0, t0) = (cpu_s(), Instant::now());
        let r = analyze(&y, DataKind::Frequency, 1.0 / rate, Statistic::Oadev, &TauSpec::Octave, &plain).unwrap();
        best_plain = best_plain.min(t0.elapsed().as_secs_f64());
        cpu_plain = cpu_plain.min(cpu_s() - c0);
        assert_eq!(r.len(), rows.len());
    }
    if json {
        let pts: Vec<String> = rows.iter().map(|p| format!("[{}, {:e}]", p.m, p.dev)).collect();
        println!(
            "{{\"compute_s\": {best}, \"compute_plain_s\": {best_plain}, \"stride\": {}, \"oadev\": [{}]}}",
            octavar::stats::stream_oadev::DEFAULT_STRIDE,
            pts.join(", ")
        );
    } else {
        println!(
            "OADEV octave, {} samples, {} taus: {:.1} ms deviations only, {:.1} ms with noise ID + EDF + intervals, \
             best of {} (CPU time, all threads: {:.1} ms, {:.1} ms)",
            y.len(),
            rows.len(),
            best_plain * 1e3,
            best * 1e3,
            reps,
            cpu_plain * 1e3,
            cpu * 1e3
        );
    }
}

//! The demo's floor (issue 5): the paper's bench, 72 h x 4 channels at 2 kS/s through the accumulator, frames,
//! decoder and fit, in at most 60 s on two cores. One timed run (criterion's repeated sampling would take
//! minutes): `cargo bench -p octavar --bench demo` (`OCTAVAR_DEMO_HOURS` for a shorter run).

use std::time::Instant;

use octavar::demo::{self, BENCH_RATE_HZ};

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return; // `cargo test --benches` asks for a list
    }
    let hours: f64 = std::env::var("OCTAVAR_DEMO_HOURS").ok().and_then(|h| h.parse().ok()).unwrap_or(72.0);
    let samples = (hours * 3600.0 * BENCH_RATE_HZ) as u64;
    demo::retain_freed_memory();
    let model = demo::paper_bench(1);
    let t0 = Instant::now();
    let runs = demo::accumulate_bench(&model, samples, (600.0 * BENCH_RATE_HZ) as u64, 2000, &|_| {}).unwrap();
    let rounds: Vec<_> = runs.iter().map(|r| r.snapshots.clone()).collect();
    let t_sim = t0.elapsed().as_secs_f64();
    let capture = demo::snapshot_capture(&rounds);
    let snaps = demo::last_snapshots(&capture, rounds.len()).unwrap();
    let results = demo::analyse(&snaps, &model);
    let t_gap = Instant::now();
    let gaps: Vec<_> = demo::diagnose_channels(&runs, &|_, _, _| {}).into_iter().map(Result::unwrap).collect();
    let t_gap = t_gap.elapsed().as_secs_f64();
    let total = t0.elapsed().as_secs_f64();
    let per_s = samples as f64 * rounds.len() as f64 / t_sim;
    println!(
        "demo {hours} h x {} channels: simulate + accumulate {t_sim:.1} s ({:.1} M samples/s on {} threads), gap {t_gap:.1} s, total {total:.1} s",
        rounds.len(),
        per_s / 1e6,
        rayon::current_num_threads()
    );
    for r in &results {
        println!(
            "  {:<10} N {:.4e} (paper {:.1e}, {:+.1}%)  B {:.4e} (paper {:.1e}, {:+.1}%)",
            r.paper.label,
            r.fit.n.value.unwrap_or(f64::NAN),
            r.paper.paper_n,
            100.0 * (r.fit.n.value.unwrap_or(f64::NAN) / r.paper.paper_n - 1.0),
            r.fit.b.value.unwrap_or(f64::NAN),
            r.paper.paper_b,
            100.0 * (r.fit.b.value.unwrap_or(f64::NAN) / r.paper.paper_b - 1.0),
        );
    }
    for (r, g) in results.iter().zip(&gaps) {
        let j = g.to_json();
        println!(
            "  {:<10} gap: {} (held-out shrink {:.1}%)",
            r.paper.label,
            g.effect_name(),
            100.0 * j["holdout"]["shrink"].as_f64().unwrap_or(f64::NAN)
        );
    }
    assert!(total <= 60.0 || hours < 72.0, "the demo took {total:.1} s (floor: 60 s)");
}

//! The IEEE 952 fit on the virtual gyro (issue 4 floor): 72 h at 2 kS/s of an IDG1215 Y with the paper's N and
//! B and a rate random walk whose +1/2 slope shows inside the record, through the firmware's accumulator
//! (S = 8), ten seeds. N within 3%, B within 10%, K within 25% for at least 9 of 10 seeds; the coverage of the
//! 95% intervals is printed. A long statistical run: it runs in CI (CI set) and is skipped otherwise
//! (`CI=1 cargo test -p octavar-tests fit_coverage -- --nocapture` to run it by hand).

use octavar::fit::{fit_deviations, FitOptions, Term};
use octavar::stats::strided::snapshot_points;
use octavar_shared::acc::OctaveAllan;
use octavar_shared::sensor::{Channel, IDG1215_Y};
use octavar_shared::sim::{GyroSim, VirtualGyro};
use rayon::prelude::*;

const FS: f64 = 2000.0;
const N: f64 = 3.0e-3;
const B: f64 = 13e-3;
const K: f64 = 5.0e-4;

fn run(seed: u64, hours: f64) -> octavar::fit::NoiseFit {
    let gyro = GyroSim { n_deg_per_rt_s: N, b_dps: B, k_dps_per_rt_s: K, ..Default::default() };
    let channel = Channel::bench(IDG1215_Y);
    let mut g = VirtualGyro::new(&gyro, channel, FS, seed).unwrap();
    let mut acc = Box::new(OctaveAllan::<8>::new());
    let total = (hours * 3600.0 * FS) as u64;
    let mut block = [0u16; 8192];
    let mut left = total;
    while left > 0 {
        let n = (left as usize).min(block.len());
        g.fill_codes(25.0, &mut block[..n]);
        acc.push_slice(&block[..n]);
        left -= n as u64;
    }
    let pts = snapshot_points(&acc.snapshot(), FS, channel.dps_per_code(), 0.683);
    fit_deviations(&pts, Some(&FitOptions::default())).unwrap()
}

#[test]
fn fit_recovers_n_b_k_on_72_hours_for_9_of_10_seeds() {
    if std::env::var_os("CI").is_none() {
        println!("skipped: 72 h x 10 seeds is a CI-only run (set CI=1)");
        return;
    }
    let fits: Vec<_> = (1..=10u64).into_par_iter().map(|s| run(s, 72.0)).collect();
    let (mut ok_n, mut ok_b, mut ok_k) = (0, 0, 0);
    let (mut cov_n, mut cov_b, mut cov_k) = (0, 0, 0);
    for (i, f) in fits.iter().enumerate() {
        let rel = |t: Term, truth: f64| f.term(t).value.map_or(f64::INFINITY, |v| (v / truth - 1.0).abs());
        let covers = |t: Term, truth: f64| {
            let e = f.term(t);
            matches!((e.lo, e.hi), (Some(lo), Some(hi)) if lo <= truth && truth <= hi)
        };
        ok_n += usize::from(rel(Term::N, N) <= 0.03);
        ok_b += usize::from(rel(Term::B, B) <= 0.10);
        ok_k += usize::from(rel(Term::K, K) <= 0.25);
        cov_n += usize::from(covers(Term::N, N));
        cov_b += usize::from(covers(Term::B, B));
        cov_k += usize::from(covers(Term::K, K));
        println!(
            "seed {}: N {:+.2}%  B {:+.2}%  K {:+.2}%",
            i + 1,
            100.0 * (f.n.value.unwrap_or(0.0) / N - 1.0),
            100.0 * (f.b.value.unwrap_or(0.0) / B - 1.0),
            100.0 * (f.k.value.unwrap_or(0.0) / K - 1.0)
        );
    }
    println!("within floors: N {ok_n}/10, B {ok_b}/10, K {ok_k}/10");
    println!("95% intervals covering the truth: N {cov_n}/10, B {cov_b}/10, K {cov_k}/10");
    assert!(ok_n >= 9 && ok_b >= 9 && ok_k >= 9, "N {ok_n}, B {ok_b}, K {ok_k} of 10 within 3/10/25%");
}

/// A short version that always runs: 2 h, one seed, where N and B are already well determined.
#[test]
fn fit_recovers_n_and_b_on_two_hours() {
    let f = run(42, 2.0);
    let n = f.n.value.unwrap();
    let b = f.b.value.unwrap();
    assert!((n / N - 1.0).abs() < 0.03, "N {n}");
    assert!((b / B - 1.0).abs() < 0.15, "B {b}");
}

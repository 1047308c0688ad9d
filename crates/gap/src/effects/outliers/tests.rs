//! The outliers estimator on contaminated records made here, without `shared::sim` (a Box-Muller Gaussian on the
//! test LCG, spikes drawn apart), on Gaussian controls, and end to end through the diagnosis.

use rayon::prelude::*;

use super::*;
use crate::effects::common::oadev_points;
use crate::{diagnose, GapInput, GapOptions};
use octavar_stats::test_signals::Lcg;

/// A standard Gaussian by Box-Muller (its tails are a Gaussian's, where the sum of 12 uniforms stops at 6).
fn gauss(g: &mut Lcg) -> f64 {
    let u = 1.0 - g.uniform();
    let v = g.uniform();
    (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
}

/// A contamination: a share `share` of the samples are spikes, magnitudes uniform on `lo..hi` white sds, in runs
/// whose lengths are uniform on `1..=run_max` (one sign a run).
#[derive(Clone, Copy, Debug)]
struct Spec {
    share: f64,
    lo: f64,
    hi: f64,
    run_max: usize,
}

/// White noise of sd `sigma` with the spikes of `spec` (`None`: clean), and the realised share of spiked samples.
fn contaminated(n: usize, sigma: f64, spec: Option<Spec>, seed: u64) -> (Vec<f64>, f64) {
    let mut g = Lcg::new(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0x5bd1);
    let mut x: Vec<f64> = (0..n).map(|_| sigma * gauss(&mut g)).collect();
    let Some(s) = spec else { return (x, 0.0) };
    // A run starts with probability q at every sample outside a run (the next run may follow at once, with its
    // own sign: independent events, as a numpy mask `rng.random(n) < q` draws them); mean run length L:
    // share = qL / (1 - q + qL).
    let l = (1 + s.run_max) as f64 / 2.0;
    let q = s.share / (l - s.share * (l - 1.0));
    let (mut i, mut hits) = (0, 0usize);
    while i < n {
        if g.uniform() < q {
            let len = 1 + (g.uniform() * s.run_max as f64) as usize;
            let sign = if g.uniform() < 0.5 { -1.0 } else { 1.0 };
            for v in x.iter_mut().skip(i).take(len) {
                *v += sign * sigma * (s.lo + (s.hi - s.lo) * g.uniform());
                hits += 1;
            }
            i += len;
        } else {
            i += 1;
        }
    }
    (x, hits as f64 / n as f64)
}

/// The contamination read off `x`, with no gaps.
fn read_all(x: &[f64]) -> Option<Contamination> {
    read(x, &vec![false; x.len()], 0.0)
}

/// Whether the estimator names a process in `x`.
fn found(x: &[f64]) -> bool {
    read_all(x).is_some_and(|c| c.is_process(x.len()))
}

const N: usize = 1 << 20;
const SIGMA: f64 = 0.1;

/// Each scenario: the share within `share_tol` (relative) of the realised one, the magnitude law's centre within
/// `size_tol` white sds and its half-width within `spread_tol` white sds, the mean run length where stated.
fn recovered(spec: Spec, seed: u64, share_tol: f64, size_tol: f64, spread_tol: f64, run_mean: Option<(f64, f64)>) {
    let (x, share) = contaminated(N, SIGMA, Some(spec), seed);
    let c = read_all(&x).expect("a mixture");
    assert!(c.is_process(N), "{spec:?}: {c:?}");
    let m = c.mix;
    let (centre, half) = (0.5 * (spec.lo + spec.hi), 0.5 * (spec.hi - spec.lo));
    let got = (m.eps, m.centre / SIGMA, m.spread / SIGMA, calibrate::Law::of(&c).run_mean());
    eprintln!("{spec:?} seed {seed}: share {share:.5} -> {:.5}, centre {centre} -> {:.2}, half-width {half} -> {:.2}, run mean -> {:.2}, sigma {:.4}, lr {:.0}", got.0, got.1, got.2, got.3, m.sigma / SIGMA, m.lr);
    assert!((m.eps / share - 1.0).abs() < share_tol, "share {share} read {}", m.eps);
    assert!((got.1 - centre).abs() < size_tol, "centre {centre} read {}", got.1);
    assert!((got.2 - half).abs() < spread_tol, "half-width {half} read {}", got.2);
    if let Some((want, tol)) = run_mean {
        assert!((got.3 - want).abs() < tol, "run mean {want} read {}", got.3);
    }
}

/// numpy-like contamination: 2% and 12% of the samples, 4-9 sds, isolated: share within 10%, centre within 0.3
/// sd, half-width within 0.5 sd, no runs read (mean run length within 0.1 of 1).
#[test]
fn numpy_like_contamination_is_recovered() {
    for (share, seed) in [(0.02, 1), (0.05, 2), (0.12, 3)] {
        let spec = Spec { share, lo: 4.0, hi: 9.0, run_max: 1 };
        recovered(spec, seed, 0.10, 0.3, 0.5, Some((1.0, 0.1)));
    }
}

/// XSens-like: 5% at 6-13 sds in runs of 1-2 (mean 1.5): share within 10%, centre within 0.3 sd, half-width
/// within 0.5 sd, mean run length within 0.15.
#[test]
fn xsens_like_runs_are_recovered() {
    let spec = Spec { share: 0.05, lo: 6.0, hi: 13.0, run_max: 2 };
    recovered(spec, 4, 0.10, 0.3, 0.5, Some((1.5, 0.15)));
}

/// Rare spikes, 1e-4 of the samples at 10 sds (about 105 of them): share within 25% (a Poisson count of 100
/// scatters by 10%), size within 0.2 sd, half-width under 1 sd (a uniform half-width w adds `w^2 / 3` to the
/// magnitudes' variance of about 1.2 sd^2 from the noise: with 100 spikes, w of 1 is within one standard error).
#[test]
fn rare_spikes_are_recovered() {
    let spec = Spec { share: 1e-4, lo: 10.0, hi: 10.0, run_max: 1 };
    recovered(spec, 5, 0.25, 0.2, 1.0, Some((1.0, 1e-9)));
}

/// Dense small spikes, 20% at 3 sds: below any threshold one by one, read by their shape: share within 15%,
/// centre within 0.3 sd, half-width under 0.6 sd.
#[test]
fn dense_small_contamination_is_recovered() {
    let spec = Spec { share: 0.2, lo: 3.0, hi: 3.0, run_max: 1 };
    recovered(spec, 6, 0.15, 0.3, 0.6, None);
}

/// Controls: no process on Gaussian white noise (60 records of 2^20 samples), on white + random walk + a
/// flicker-like sum of AR(1)s (40 records), and on white noise through a coarse ADC (a step of 0.5-3 sds, 20
/// records). Measured: none of the 120 is named.
#[test]
fn gaussian_controls_have_no_outliers() {
    let white: Vec<u64> = (0..60).collect();
    let named: Vec<u64> =
        white.par_iter().copied().filter(|&s| found(&contaminated(N, SIGMA, None, 100 + s).0)).collect();
    assert!(named.is_empty(), "white noise named outliers at seeds {named:?}");
    let coloured: Vec<u64> = (0..40u64)
        .into_par_iter()
        .filter(|&s| {
            let (mut x, _) = contaminated(N, SIGMA, None, 200 + s);
            let mut g = Lcg::new(900 + s);
            // A random walk and three AR(1)s at 0.1, 1 and 10 s at 100 Hz, each about the white sd at its time.
            let (mut rw, mut ar) = (0.0, [0.0; 3]);
            for v in x.iter_mut() {
                rw += 2e-3 * SIGMA * gauss(&mut g);
                let mut f = 0.0;
                for (k, a) in ar.iter_mut().enumerate() {
                    let pole = (-1.0 / (10f64.powi(k as i32 + 1))).exp();
                    *a = pole * *a + 0.3 * SIGMA * (1.0 - pole * pole).sqrt() * gauss(&mut g);
                    f += *a;
                }
                *v += rw + f;
            }
            found(&x)
        })
        .collect();
    assert!(coloured.is_empty(), "white + flicker + random walk named outliers at seeds {coloured:?}");
    let quantised: Vec<u64> = (0..20u64)
        .into_par_iter()
        .filter(|&s| {
            let step = SIGMA * (0.5 + 2.5 * s as f64 / 19.0);
            let (x, _) = contaminated(N, SIGMA, None, 300 + s);
            let q: Vec<f64> = x.iter().map(|v| (v / step + 0.37).round() * step).collect();
            found(&q)
        })
        .collect();
    assert!(quantised.is_empty(), "quantised white noise named outliers at seeds {quantised:?}");
}

/// The rate of the records given to [`estimated`], Hz.
const RATE_HZ: f64 = 100.0;

/// `x` (at [`RATE_HZ`]) through `outliers` as the chain's first step would see it: the base fit's model, no gaps.
fn estimated(x: &[f64]) -> Option<EffectFit> {
    let rate_hz = RATE_HZ;
    let pts = oadev_points(x, rate_hz);
    let f = octavar_stats::fit::fit(&pts, &octavar_stats::fit::FitOptions::default()).unwrap();
    let base = crate::base_model(&f, x);
    let d = TrainingData {
        rate_dps: x,
        recorded_dps: x,
        temp_c: None,
        rate_hz,
        base: &base,
        base_fit: &f,
        gaps: &[],
        lattice_dps: None,
        shaped_dps: None,
    };
    outliers(&d)
}

/// The effect through `fit_effect`: the model carries the mixture and the base N is the white noise's without the
/// spikes' variance (within 3%).
#[test]
fn the_fitted_model_carries_the_mixture_and_the_clean_white_noise() {
    let spec = Spec { share: 0.05, lo: 6.0, hi: 13.0, run_max: 2 };
    let (x, _) = contaminated(N, SIGMA, Some(spec), 7);
    let e = estimated(&x).expect("outliers");
    let o = e.gyro.outliers.unwrap();
    let n_true = SIGMA / RATE_HZ.sqrt();
    eprintln!("{:?}; N {} (truth {n_true})", e.params, e.gyro.n_deg_per_rt_s);
    assert!((e.gyro.n_deg_per_rt_s / n_true - 1.0).abs() < 0.03, "N {}", e.gyro.n_deg_per_rt_s);
    assert!(o.run_mean > 1.3 && o.spread_dps > 0.0);
    let json = serde_json::to_value(&e.params).unwrap();
    for key in ["per_sample", "size_dps", "spread_dps", "run_mean", "robust_sigma_dps", "count"] {
        assert!(json[key].is_number(), "{key}");
    }
}

/// White noise under a slow walk (so the samples cross several levels), rounded to a lattice of `step` white
/// sds, with `spec`'s spikes added before the rounding.
fn on_lattice(step: f64, spec: Option<Spec>, seed: u64) -> (Vec<f64>, f64) {
    let (x, share) = contaminated(N, SIGMA, spec, seed);
    let mut g = Lcg::new(seed ^ 0x1a77);
    let mut walk = 0.0;
    let rounded = x
        .iter()
        .map(|v| {
            walk += 4.0 * step * SIGMA / (N as f64).sqrt() * gauss(&mut g);
            ((v + walk) / (step * SIGMA) + 0.37).round() * step * SIGMA
        })
        .collect();
    (rounded, share)
}

/// On an ADC lattice from 0.7 to 10 white sds a step (the sweep's range), where most residuals sit at exactly 0
/// or one step: without spikes the estimator names nothing (undithered, it read a "contamination" of one step on
/// a coarse lattice); with spikes of 30 sds at 1e-4 of the samples (about 100), it finds them, their size within
/// 10%, their share within 15% up to 5 sds a step, and within a factor 2.2 at 7 and 10 (spikes of 3-4 steps stand
/// at the edge of a law held beyond three steps).
#[test]
fn spikes_on_a_coarse_lattice_are_told_from_its_steps() {
    let steps = [0.7, 1.5, 3.0, 5.0, 7.0, 10.0];
    let named: Vec<f64> =
        steps.par_iter().copied().filter(|&q| estimated(&on_lattice(q, None, 400 + q as u64).0).is_some()).collect();
    assert!(named.is_empty(), "quantised noise under a walk named outliers at steps {named:?}");
    let spec = Spec { share: 1e-4, lo: 30.0, hi: 30.0, run_max: 1 };
    for q in steps {
        let (x, share) = on_lattice(q, Some(spec), 500 + q as u64);
        let e = estimated(&x).unwrap_or_else(|| panic!("step {q}: spikes not found"));
        let o = e.gyro.outliers.unwrap();
        eprintln!("step {q}: share {share:.2e} -> {:.2e}, size {:.2} sds", o.per_sample, o.size_dps / SIGMA);
        let tol = if q <= 5.0 { 0.15 } else { 1.2 };
        assert!((o.per_sample / share - 1.0).abs() < tol, "step {q}: share {share} read {}", o.per_sample);
        assert!((o.size_dps / SIGMA / 30.0 - 1.0).abs() < 0.1, "step {q}: size {} sds", o.size_dps / SIGMA);
    }
}

/// Rare spikes of two steps on a lattice seven white sds a step (about twenty in a million samples): far too few
/// for the share of residuals between the lattice's reach and three steps, and at three dithered sds, among the
/// dithered core's own thousands, yet a clean lattice under this noise leaves no residual beyond a step and a
/// half. Counted there against the clean bound, they are named, at two steps (the lattice's value of 1.9-2.1
/// steps), their share within a third; the same lattice without them names nothing
/// (`spikes_on_a_coarse_lattice_are_told_from_its_steps`).
#[test]
fn rare_spikes_on_a_coarse_lattice_are_counted_beyond_its_reach() {
    let spec = Spec { share: 2e-5, lo: 13.3, hi: 14.7, run_max: 1 };
    for seed in [1, 2, 3] {
        let (x, share) = on_lattice(7.0, Some(spec), 700 + seed);
        let e = estimated(&x).unwrap_or_else(|| panic!("seed {seed}: spikes not found"));
        let o = e.gyro.outliers.unwrap();
        eprintln!("seed {seed}: share {share:.2e} -> {:.2e}, size {:.2} sds", o.per_sample, o.size_dps / SIGMA);
        assert!((o.per_sample / share - 1.0).abs() < 0.34, "seed {seed}: share {share} read {}", o.per_sample);
        assert!((o.size_dps / SIGMA / 14.0 - 1.0).abs() < 0.1, "seed {seed}: size {} sds", o.size_dps / SIGMA);
    }
}

/// A model.toml written before the mixture fields loads, as isolated spikes of one size.
#[test]
fn an_old_model_file_still_loads() {
    let g: GyroSim =
        toml::from_str("n_deg_per_rt_s = 0.01\noutliers = { per_sample = 1e-4, size_sigma = 8.0 }\n").unwrap();
    let o = g.outliers.unwrap();
    assert_eq!((o.per_sample, o.size_sigma, o.spread_dps, o.spread_sigma, o.run_mean), (1e-4, 8.0, 0.0, 0.0, 0.0));
}

/// End to end: an XSens-like record (white noise and a random walk, 5% of the samples spikes of 6-13 sds in runs
/// of 1-2) is diagnosed `outliers`; after the chain the distribution view's training gap and the held-out gap are
/// below 2.5, and no transient is masked (the spikes are a steady process, not bursts).
///
/// Ignored until it holds: today it is named `outliers` (training distribution gap 520.9 -> 1.64) but the held-out
/// distribution gap after is 3.27 and the chain's held-out gap 2.82.
#[test]
#[ignore = "held-out gap after the chain 2.82 (distribution 3.27), above 2.5"]
fn a_contaminated_record_is_diagnosed_outliers() {
    let rate_hz = 100.0;
    let n = 1 << 19;
    let spec = Spec { share: 0.05, lo: 6.0, hi: 13.0, run_max: 2 };
    let (mut x, _) = contaminated(n, SIGMA, Some(spec), 11);
    let mut g = Lcg::new(77);
    let mut rw = 0.0;
    for v in x.iter_mut() {
        rw += 1e-3 * SIGMA * gauss(&mut g);
        *v += rw;
    }
    let input = GapInput::split(x, None, rate_hz, 0.5).unwrap();
    let r = diagnose(&input, &GapOptions { seeds: 12, ..Default::default() }, &|_, _, _| {}).unwrap();
    eprintln!("{}", r.text());
    assert!(r.input.transients.is_empty(), "{:?}", r.input.transients);
    assert_eq!(r.effect_name(), "outliers");
    let dist = |views: &[crate::compare::ViewGap]| {
        views.iter().find(|v| v.view.name() == "distribution").map(|v| v.gap).unwrap()
    };
    let (before, after) = (dist(&r.base.eval.training), dist(&r.final_eval().training));
    let (h_before, h_after) = (dist(&r.base.eval.holdout), dist(&r.final_eval().holdout));
    let total = r.holdout.total.unwrap();
    eprintln!(
        "distribution training {before:.2} -> {after:.2}, holdout {h_before:.2} -> {h_after:.2}; holdout total {:.2} -> {:.2}",
        total.gap_before, total.gap_after
    );
    assert!(after < 2.5 && h_after < 2.5 && total.gap_after < 2.5);
}

/// The transient scan leaves steady contamination alone, however dense: numpy-like (2% and 12% at 4-9 sds),
/// XSens-like (5% at 6-13 sds in runs of 1-2), 20% at 3 sds, and rare isolated spikes (2e-4 at 10-20 sds). A
/// burst is a cluster far denser than the record's own spike rate; none of these has one. (Rare spikes in runs are
/// not covered: the burst test counts each sample of a run as an event of its own.)
#[test]
fn steady_contamination_is_not_masked_as_bursts() {
    let specs = [
        Spec { share: 0.02, lo: 4.0, hi: 9.0, run_max: 1 },
        Spec { share: 0.12, lo: 4.0, hi: 9.0, run_max: 1 },
        Spec { share: 0.05, lo: 6.0, hi: 13.0, run_max: 2 },
        Spec { share: 0.2, lo: 3.0, hi: 3.0, run_max: 1 },
        Spec { share: 2e-4, lo: 10.0, hi: 20.0, run_max: 1 },
    ];
    let masked: Vec<String> = specs
        .par_iter()
        .enumerate()
        .flat_map_iter(|(k, spec)| {
            (0..3u64).filter_map(move |s| {
                let (x, _) = contaminated(1 << 19, SIGMA, Some(*spec), 500 + 10 * k as u64 + s);
                let scan = crate::transients::scan(&x, 100.0);
                (!scan.events.is_empty()).then(|| format!("{spec:?} seed {s}: {:?}", scan.events))
            })
        })
        .collect();
    assert!(masked.is_empty(), "{masked:#?}");
}

/// The excess kurtosis of the differences of adjacent means of `m` samples (the Allan differences at `m`).
fn difference_kurtosis(x: &[f64], m: usize) -> f64 {
    let means: Vec<f64> = x.chunks_exact(m).map(|c| c.iter().sum::<f64>() / m as f64).collect();
    let d: Vec<f64> = means.windows(2).map(|w| w[1] - w[0]).collect();
    let n = d.len() as f64;
    let mean = d.iter().sum::<f64>() / n;
    let m2 = d.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
    let m4 = d.iter().map(|v| (v - mean).powi(4)).sum::<f64>() / n;
    m4 / (m2 * m2) - 3.0
}

/// The difference kurtosis at `m` of white noise of sd `SIGMA` plus shared::sim's spikes of `o`, over four records.
fn simulated_kurtosis(o: &Outliers, m: usize) -> f64 {
    use octavar_shared::sim::effects::Spikes;
    (0..4u64)
        .map(|s| {
            let mut rng = SimRng::new(900 + s);
            let mut spikes = Spikes::new(o, SIGMA, &mut rng);
            let x: Vec<f64> = (0..N).map(|_| SIGMA * rng.normal() + spikes.next(&mut rng)).collect();
            difference_kurtosis(&x, m)
        })
        .sum::<f64>()
        / 4.0
}

/// Spikes near the core in runs with a geometric tail, as shared::sim draws them (0.65% of the samples at 4.6 +-
/// 1.3 sds, mean run 1.64, a run of two going on with probability 1/3): read off the residuals, a run's partner in
/// the median's window pulls the magnitudes in, and run members are flagged less often than lone spikes, so the
/// law read is short of the runs' fourth moment, which the long runs carry. What the views test is whether the
/// law's simulation has the record's heavy tails: the Allan differences' excess kurtosis. The law corrected
/// against synthetic records of itself gives it within 20% at 1, 2, 4 and 8 samples on three records (a record's
/// own kurtosis at 8 samples scatters by about 10% about the law's), where the law as read falls 35% or more short
/// at 4 or 8 samples on each (it reads the runs' continuation at 0.16-0.18 against 0.33; corrected, 0.28-0.34).
#[test]
fn spikes_near_the_core_are_read_without_the_estimators_bias() {
    use octavar_shared::sim::effects::Spikes;
    let truth = Outliers {
        per_sample: 6.5e-3,
        size_sigma: 4.6,
        spread_sigma: 1.3,
        run_mean: 1.64,
        run_continue: 1.0 / 3.0,
        ..Default::default()
    };
    for seed in [21, 22, 23] {
        let mut rng = SimRng::new(seed);
        let mut spikes = Spikes::new(&truth, SIGMA, &mut rng);
        let x: Vec<f64> = (0..N).map(|_| SIGMA * rng.normal() + spikes.next(&mut rng)).collect();
        let c = read_all(&x).expect("a mixture");
        let law = calibrate::corrected(&c, N, None);
        let raw = calibrate::Law::of(&c);
        let mut worst_raw = 0.0f64;
        for m in [1, 2, 4, 8] {
            let real = difference_kurtosis(&x, m);
            let (k_raw, k_law) = (simulated_kurtosis(&raw.outliers(), m), simulated_kurtosis(&law.outliers(), m));
            eprintln!("seed {seed} m {m}: real {real:.3}, as read {k_raw:.3}, corrected {k_law:.3}");
            assert!((k_law / real - 1.0).abs() < 0.2, "seed {seed} m {m}: real {real}, corrected law {k_law}");
            worst_raw = worst_raw.max(1.0 - k_raw / real);
        }
        assert!(worst_raw > 0.35, "seed {seed}: the law as read was already within {worst_raw} of the record");
    }
}

/// Spikes clear of the core with a few residuals between (what a bistable bias's flips or a burst's edges leave:
/// here single samples of 9-15 sds on a tenth of a thousandth of the samples, against spikes of 33-37 sds on
/// three times as many): the likelihood's uniform law must stretch down to the few, which reads the spikes a third
/// small and spread over most of their size; the law read off the cluster holds the spikes' centre within 3%,
/// their spread within a few sds, and their share within a tenth.
#[test]
fn a_few_residuals_between_core_and_spikes_leave_the_spikes_law() {
    let spec = Spec { share: 3e-4, lo: 33.0, hi: 37.0, run_max: 1 };
    let (mut x, share) = contaminated(N, SIGMA, Some(spec), 23);
    let mut g = Lcg::new(77);
    for i in (5_000..x.len()).step_by(10_000) {
        x[i] += SIGMA * (9.0 + 6.0 * g.uniform()) * if g.uniform() < 0.5 { -1.0 } else { 1.0 };
    }
    let e = estimated(&x).expect("outliers");
    let json = serde_json::to_value(&e.params).unwrap();
    let size = json["size_dps"].as_f64().unwrap() / SIGMA;
    let spread_sds = json["spread_dps"].as_f64().unwrap() / SIGMA;
    let per_sample = json["per_sample"].as_f64().unwrap();
    assert!((size / 35.0 - 1.0).abs() < 0.03, "centre {size} sds");
    assert!(spread_sds < 4.0, "spread {spread_sds} sds");
    assert!((per_sample / share - 1.0).abs() < 0.1, "share {per_sample} against {share}");
}

/// A dozen spikes of 5.7 sds in a quarter of a million samples (24 records) are a process on most records: half
/// of them stand beyond 5 core sds, where the Gaussian core leaves 0.14, and five such residuals are a Poisson
/// tail of 4e-7. Read by the normal approximation the count once had to pass (`5 + 3 sqrt(expected)` beyond what
/// the core explains: seven), the same records made a process on 13 of the 24; by the Poisson tail, on 19.
#[test]
fn a_dozen_spikes_of_six_sds_are_a_process() {
    let n = 250_000;
    let spec = Spec { share: 4.4e-5, lo: 5.7, hi: 5.7, run_max: 1 };
    let read: Vec<(bool, bool)> = (0..24u64)
        .into_par_iter()
        .map(|s| {
            let (x, _) = contaminated(n, SIGMA, Some(spec), 700 + s);
            let c = read_all(&x).expect("a mixture");
            let m = &c.mix;
            let by_normal_approximation = m.lr >= MIN_LR
                && m.centre >= MIN_CENTRE_SIGMAS * m.sigma
                && c.tail.0 as f64 - c.tail.1 >= MIN_SPIKES as f64 + 3.0 * c.tail.1.sqrt()
                && c.flagged.len() >= MIN_SPIKES;
            (c.is_process(n), by_normal_approximation)
        })
        .collect();
    let named = read.iter().filter(|r| r.0).count();
    let approximated = read.iter().filter(|r| r.1).count();
    assert!(approximated <= 15, "the premise: the normal approximation names {approximated} of 24");
    assert!(named >= 18, "{named} of 24 named");
}

/// Dense spikes of two to three steps on a lattice coarser than the noise (a tenth of the samples, the lattice 2
/// to 6 white sds a step): the law is read beyond the lattice's reach, not beyond three steps, so the share comes
/// back within 15% and the size within 10% (held beyond three steps, a law of spikes of 2.3 steps read a share of
/// 5.6% for 10.4% on a sweep record), and the samples later steps learn from are cleaned of all but a few of
/// the spikes beyond the reach.
#[test]
fn dense_spikes_of_two_steps_on_a_coarse_lattice_are_read_whole() {
    let cases = [(4.4, 7.8, 12.1), (3.0, 6.0, 9.0), (6.0, 9.0, 16.0), (2.0, 5.0, 8.0)];
    for (k, (step, lo, hi)) in cases.into_iter().enumerate() {
        let spec = Spec { share: 0.1, lo, hi, run_max: 2 };
        let (x, share) = on_lattice(step, Some(spec), 600 + k as u64);
        let e = estimated(&x).unwrap_or_else(|| panic!("step {step}: spikes not found"));
        let o = e.gyro.outliers.unwrap();
        let size = o.size_dps / SIGMA / (0.5 * (lo + hi));
        eprintln!("step {step}: share {share:.3} -> {:.3}, size {size:.3} of the truth", o.per_sample);
        assert!((o.per_sample / share - 1.0).abs() < 0.15, "step {step}: share {share} read {}", o.per_sample);
        assert!((size - 1.0).abs() < 0.1, "step {step}: size {size} of the truth");
        let cleaned = e.cleaned.as_deref().unwrap();
        let clean_spikes = cleaned.windows(9).filter(|w| {
            let mut nb: Vec<f64> = w[..4].iter().chain(&w[5..]).copied().collect();
            nb.sort_by(f64::total_cmp);
            (w[4] - 0.5 * (nb[3] + nb[4])).abs() > 2.75 * step * SIGMA
        });
        let left = clean_spikes.count();
        // (Where four or more of a sample's eight neighbours are spikes, the median moves and a few stay.)
        assert!(
            (left as f64) < 0.01 * share * N as f64,
            "step {step}: {left} spikes of three steps left in the cleaned samples"
        );
    }
}

/// Spikes clear of a coloured core (white noise through a first-order low-pass, as a sensor's output bandwidth
/// leaves it; the spikes added after it): 0.72% of the samples at 14-21 white sds, in runs of 1-2. The residuals'
/// core is no longer Gaussian in shape, and the likelihood's share moves with how its tails meet the spikes'
/// law (3-6% off here); every spike stands clear, so the share is their count: within 2% of the realised share.
#[test]
fn clear_spikes_on_a_coloured_core_are_counted() {
    for (pole, seed) in [(0.85, 4u64), (0.7, 5), (0.85, 7)] {
        let spec = Spec { share: 0.0072, lo: 14.1, hi: 21.3, run_max: 2 };
        let (clean, _) = contaminated(N, SIGMA, None, 40 + seed);
        let (spiked, share) = contaminated(N, SIGMA, Some(spec), 40 + seed);
        let mut y = 0.0;
        let x: Vec<f64> = clean
            .iter()
            .zip(&spiked)
            .map(|(c, s)| {
                y = pole * y + (1.0 - pole) * c;
                y + (s - c)
            })
            .collect();
        let c = read_all(&x).expect("a mixture");
        let law = clear_law(c.mix, &c.flagged, c.valid).expect("spikes clear of the core");
        eprintln!("pole {pole}: share {share:.5}, likelihood's {:.5}, read {:.5}", c.mix.eps, law.eps);
        assert!((law.eps / share - 1.0).abs() < 0.02, "pole {pole}: share {share} read {}", law.eps);
    }
}

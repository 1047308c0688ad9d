//! Each term of the independent generator against its closed form, written from the formula: the overlapping
//! Allan variance against the one its autocovariance gives, the variance, the mean or the response. Averages over
//! seeds are held within 4 standard errors of the seed mean.

use std::f64::consts::PI;

use rayon::prelude::*;

use super::*;

/// The overlapping Allan variance at `m` samples of rate samples `y` (deg/s)^2.
fn oavar(y: &[f64], m: usize) -> f64 {
    let mut s = Vec::with_capacity(y.len() + 1);
    s.push(0.0);
    let mut acc = 0.0;
    for v in y {
        acc += v;
        s.push(acc);
    }
    let terms = y.len() + 1 - 2 * m;
    let sum: f64 = (0..terms).map(|i| ((s[i + 2 * m] - 2.0 * s[i + m] + s[i]) / m as f64).powi(2)).sum();
    sum / (2.0 * terms as f64)
}

/// The Allan variance at `m` samples of a stationary process of autocovariance `r(k)` at lag k samples: half the
/// variance of the difference of two adjacent m-sample sums over m^2, `(Var S - Cov(S1, S2)) / m^2`.
fn avar_from_acf(r: impl Fn(usize) -> f64, m: usize) -> f64 {
    let var_s: f64 = m as f64 * r(0) + 2.0 * (1..m).map(|k| (m - k) as f64 * r(k)).sum::<f64>();
    let cov: f64 = (0..2 * m - 1).map(|j| (m as f64 - (j as f64 - (m - 1) as f64).abs()) * r(j + 1)).sum();
    (var_s - cov) / (m * m) as f64
}

/// Mean and 4 standard errors of the seed values.
fn mean_4se(v: &[f64]) -> (f64, f64) {
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64;
    (mean, 4.0 * (var / v.len() as f64).sqrt())
}

/// The seed means of `oavar` at each of `ms` over `seeds` records of `g` against `want(m)`, within 4 standard
/// errors plus `allowance` of the expectation; the failures as lines.
fn check_allan(name: &str, g: &IndepGyro, fs: f64, n: usize, seeds: u64, ms: &[usize], want: impl Fn(usize) -> f64) {
    let per_seed: Vec<Vec<f64>> = (0..seeds)
        .into_par_iter()
        .map(|s| {
            let y = g.generate(fs, n, s).rate_dps;
            ms.iter().map(|&m| oavar(&y, m)).collect()
        })
        .collect();
    let mut fails = Vec::new();
    for (i, &m) in ms.iter().enumerate() {
        let v: Vec<f64> = per_seed.iter().map(|a| a[i]).collect();
        let (mean, se4) = mean_4se(&v);
        let w = want(m);
        println!("{name} m {m}: mean {mean:.4e} closed form {w:.4e} ({:+.4}, 4 SE {:.4})", mean / w - 1.0, se4 / w);
        if (mean - w).abs() > se4 {
            fails.push(format!("{name} m {m}: {mean:.4e} vs {w:.4e} (4 SE {se4:.2e})"));
        }
    }
    assert!(fails.is_empty(), "{fails:#?}");
}

const MS: [usize; 5] = [1, 4, 16, 64, 256];

/// The generator and its base noise share no code with shared::sim: outside comments they name nothing of
/// octavar_shared (the oracle's mapping lives apart, in `oracle.rs`).
#[test]
fn generator_does_not_use_shared_sim() {
    for (file, src) in [("indep_gyro/mod.rs", include_str!("mod.rs")), ("fft_gyro.rs", include_str!("../fft_gyro.rs"))]
    {
        let code = src.lines().map(str::trim_start).filter(|l| !l.starts_with("//"));
        for line in code {
            assert!(!line.contains("octavar_shared"), "{file} uses octavar_shared: {line}");
        }
    }
}

/// Gauss-Markov: Allan variance of autocovariance `sigma^2 exp(-|t|/T)` (T = 2 s at 10 Hz), 48 records of 2^14.
#[test]
fn gauss_markov_has_the_exponential_autocovariance() {
    let (sigma, t, fs) = (0.3, 2.0, 10.0);
    let g = IndepGyro { gauss_markov: Some(Markov { sigma_dps: sigma, tau_s: t }), ..Default::default() };
    check_allan("gauss_markov", &g, fs, 1 << 14, 48, &MS, |m| {
        avar_from_acf(|k| sigma * sigma * (-(k as f64) / fs / t).exp(), m)
    });
    let (_, negative) = from_autocovariance(|l| (-l / t).exp(), fs, 1 << 14, &mut stream(1, 9));
    assert!(negative < 1e-12, "negative eigenvalues: {negative}");
}

/// Resonance: Allan variance of the damped oscillator's autocovariance (1.3 Hz, Q 8 at 10 Hz), and its variance.
#[test]
fn resonance_has_the_oscillator_autocovariance() {
    let o = Oscillator { sigma_dps: 0.2, freq_hz: 1.3, q: 8.0 };
    let fs = 10.0;
    let g = IndepGyro { resonance: Some(o), ..Default::default() };
    // The variance is the Allan variance's m = 1 term plus the lag-one covariance: check it directly.
    let vars: Vec<f64> = (0..48u64)
        .into_par_iter()
        .map(|s| {
            let y = g.generate(fs, 1 << 14, s).rate_dps;
            y.iter().map(|v| v * v).sum::<f64>() / y.len() as f64
        })
        .collect();
    let (mean, se4) = mean_4se(&vars);
    assert!((mean - 0.04).abs() < se4, "variance {mean:.4e} vs 0.04 (4 SE {se4:.1e})");
    check_allan("resonance", &g, fs, 1 << 14, 48, &[1, 2, 4, 8, 32, 128], |m| {
        avar_from_acf(|k| oscillator_acf(&o, k as f64 / fs), m)
    });
}

/// Bistable bias: only its two zero-mean levels, and the Allan variance of `var exp(-(l1 + l2) |t|)`, `var =
/// step^2 l1 l2 / (l1 + l2)^2` (dwells 2 s and 6 s at 10 Hz).
#[test]
fn bistable_is_a_telegraph_of_its_dwells() {
    let tg = Telegraph { step_dps: 0.5, dwell_low_s: 2.0, dwell_high_s: 6.0 };
    let fs = 10.0;
    let g = IndepGyro { telegraph: Some(tg), ..Default::default() };
    let y = g.generate(fs, 1 << 15, 3).rate_dps;
    let (low, high) = (-0.5 * 0.75, 0.5 * 0.25);
    assert!(y.iter().all(|&v| v == low || v == high));
    let (l1, l2) = (1.0 / tg.dwell_low_s, 1.0 / tg.dwell_high_s);
    let var = 0.25 * l1 * l2 / (l1 + l2).powi(2);
    check_allan("bistable", &g, fs, 1 << 15, 48, &MS, |m| {
        avar_from_acf(|k| var * (-(l1 + l2) * k as f64 / fs).exp(), m)
    });
}

/// Bias steps: the jumps are a random walk of per-sample increment variance `lambda sigma^2 tau0`, whose Allan
/// variance is `K^2 tau0 (2 m^2 + 1) / (6 m)` with `K^2 = lambda sigma^2`; and the count is `lambda` times the
/// record's length.
#[test]
fn bias_steps_are_a_random_walk_of_jumps() {
    let (per_hour, sigma, fs, n) = (360.0, 0.05, 10.0, 1 << 14);
    let j = Jumps { per_hour, sigma_dps: sigma };
    let counts: Vec<f64> = (0..200u64)
        .map(|s| {
            let y = jumps(&j, fs, n, &mut stream(s, 3));
            y.windows(2).filter(|w| w[1] != w[0]).count() as f64 + f64::from(y[0] != 0.0)
        })
        .collect();
    let (mean, se4) = mean_4se(&counts);
    let want = per_hour / 3600.0 * n as f64 / fs;
    assert!((mean - want).abs() < se4, "jumps per record {mean} vs {want}");
    let k2 = per_hour / 3600.0 * sigma * sigma;
    let g = IndepGyro { jumps: Some(j), ..Default::default() };
    check_allan("bias_steps", &g, fs, n, 64, &MS, |m| k2 / fs * (2.0 * (m * m) as f64 + 1.0) / (6.0 * m as f64));
}

/// Bandwidth: white noise of sd s through the filter is the AR(1) of autocovariance `s^2 (1 - a) / (1 + a) a^|k|`
/// (its Allan variance at each m), and a sinusoid of frequency f comes out with the gain `(1 - a) / |1 - a
/// e^(-i w)|`, w = 2 pi f / rate_hz, and DC gain 1.
#[test]
fn bandwidth_is_the_first_order_low_pass() {
    let (fs, f3db, n_coef) = (100.0, 12.0, 0.01);
    let a = (-2.0 * PI * f3db / fs).exp();
    let s2 = n_coef * n_coef * fs;
    let g = IndepGyro { n_deg_per_rt_s: n_coef, bandwidth_hz: Some(f3db), ..Default::default() };
    check_allan("bandwidth", &g, fs, 1 << 14, 48, &[1, 2, 4, 16, 64], |m| {
        avar_from_acf(|k| s2 * (1.0 - a) / (1.0 + a) * a.powi(k as i32), m)
    });
    for f in [1.0, 12.0, 30.0] {
        let w = 2.0 * PI * f / fs;
        let gain = (1.0 - a) / (1.0 - 2.0 * a * w.cos() + a * a).sqrt();
        let mut x: Vec<f64> = (0..20_000).map(|i| 3.0 + (w * i as f64).sin()).collect();
        low_pass(&mut x, f3db, fs);
        // Amplitude of the settled part by least squares on sin and cos at w.
        let (mut ss, mut sc, mut mean) = (0.0, 0.0, 0.0);
        let tail = &x[1000..];
        for (i, v) in tail.iter().enumerate() {
            let p = w * (i + 1000) as f64;
            ss += (v - 3.0) * p.sin();
            sc += (v - 3.0) * p.cos();
            mean += v;
        }
        let amp = 2.0 * (ss * ss + sc * sc).sqrt() / tail.len() as f64;
        assert!((amp / gain - 1.0).abs() < 2e-3, "f {f}: gain {amp} vs {gain}");
        assert!((mean / tail.len() as f64 - 3.0).abs() < 1e-3);
    }
}

/// Sinusoid: at m samples, the m-sample means are a sinusoid of amplitude `A D`, `D = sin(pi f m tau0) / (m
/// sin(pi f tau0))`, so the Allan variance over phases is `A^2 D^2 sin^2(pi f m tau0)`; 16 phases evenly spread
/// make the phase average exact.
#[test]
fn sinusoid_has_its_allan_variance() {
    let (fs, amp, period) = (10.0, 0.2, 7.3);
    let f = 1.0 / period;
    for m in MS {
        let mean: f64 = (0..16)
            .map(|k| {
                let s = Sine { amplitude_dps: amp, period_s: period, phase_rad: 2.0 * PI * k as f64 / 16.0 };
                let g = IndepGyro { sinusoids: vec![s], ..Default::default() };
                oavar(&g.generate(fs, 8192, 0).rate_dps, m)
            })
            .sum::<f64>()
            / 16.0;
        let d = (PI * f * m as f64 / fs).sin() / (m as f64 * (PI * f / fs).sin());
        let want = amp * amp * d * d * (PI * f * m as f64 / fs).sin().powi(2);
        assert!((mean - want).abs() < 1e-9 * amp * amp, "m {m}: {mean:.6e} vs {want:.6e}");
    }
}

/// Temperature: a pure cycle of amplitude h through the lag comes out as a cycle of amplitude `k h / sqrt(1 + (2
/// pi lag / P)^2)`, delayed by `atan(2 pi lag / P)`, about `k (mean - ref)`; and the bench's wander has its sd.
#[test]
fn temperature_couples_through_a_first_order_lag() {
    let (fs, period, lag, k) = (2.0, 600.0, 70.0, 0.01);
    let bench = BenchTemperature {
        mean_c: 24.0,
        swing_c: 3.0,
        period_s: period,
        phase_rad: 0.0,
        harmonic: 0.0,
        wander_sd_c: 0.0,
        wander_tau_s: 1.0,
    };
    let g = IndepGyro {
        bench: Some(bench),
        coupling: Some(Coupling { dps_per_c: k, lag_s: lag, ref_c: 23.0 }),
        ..Default::default()
    };
    let y = g.generate(fs, 20 * 1200, 0).rate_dps;
    let w = 2.0 * PI / period;
    let tail = &y[2400..];
    let (mut ss, mut sc, mut mean) = (0.0, 0.0, 0.0);
    for (i, v) in tail.iter().enumerate() {
        let t = (i + 2400) as f64 / fs;
        ss += (v - 0.01) * (w * t).sin();
        sc += (v - 0.01) * (w * t).cos();
        mean += v;
    }
    let len = tail.len() as f64;
    let (amp, phase) = (2.0 * (ss * ss + sc * sc).sqrt() / len, sc.atan2(ss));
    let want_amp = k * 1.5 / (1.0 + (w * lag).powi(2)).sqrt();
    assert!((amp / want_amp - 1.0).abs() < 1e-3, "amplitude {amp} vs {want_amp}");
    assert!((phase + (w * lag).atan()).abs() < 1e-3, "phase {phase} vs {}", -(w * lag).atan());
    assert!((mean / len - k * (24.0 - 23.0)).abs() < 1e-6);

    let wander = BenchTemperature { swing_c: 0.0, wander_sd_c: 0.4, wander_tau_s: 50.0, ..bench };
    let vars: Vec<f64> = (0..48u64)
        .into_par_iter()
        .map(|s| bench_temperature(&wander, fs, 1 << 14, s).iter().map(|t| (t - 24.0).powi(2)).sum::<f64>() / 16384.0)
        .collect();
    let (mean, se4) = mean_4se(&vars);
    assert!((mean - 0.16).abs() < se4, "wander variance {mean} vs 0.16 (4 SE {se4})");
}

/// Quantisation: every value on the lattice, and for a signal spread over many steps the rounding error has mean
/// 0 and variance `step^2 / 12`.
#[test]
fn quantization_puts_values_on_the_lattice() {
    let (fs, n_coef, step, offset) = (10.0, 0.05, 0.03, 0.011);
    let plain = IndepGyro { n_deg_per_rt_s: n_coef, ..Default::default() };
    let q = IndepGyro { lattice: Some(Lattice { step_dps: step, offset_dps: offset }), ..plain.clone() };
    let (x, y) = (plain.generate(fs, 1 << 16, 4).rate_dps, q.generate(fs, 1 << 16, 4).rate_dps);
    let mut err = Vec::with_capacity(x.len());
    for (a, b) in x.iter().zip(&y) {
        let k = (b - offset) / step;
        assert!((k - k.round()).abs() < 1e-9, "{b} is off the lattice");
        err.push(b - a);
    }
    let (mean, se4) = mean_4se(&err);
    assert!(mean.abs() < se4, "rounding error mean {mean}");
    let var = err.iter().map(|e| e * e).sum::<f64>() / err.len() as f64;
    // The sd of a sample variance of a uniform error is about 0.9 var / sqrt(n): 4 of them are 1.4%.
    assert!((var / (step * step / 12.0) - 1.0).abs() < 0.015, "rounding error variance {var}");
}

/// Outliers and contamination: the share of spiked samples, the runs (weights 4:2:1 for 1, 2, 3 samples; events
/// may follow one another at once, as a Bernoulli mask draws them), the
/// mean square size `(lo^2 + lo hi + hi^2) / 3` white sigmas^2, both signs alike.
#[test]
fn contamination_has_its_share_runs_and_sizes() {
    let white = 0.02;
    for longest_run in [1, 3] {
        let c = Contamination { per_sample: 2e-3, size_sigma: [8.0, 20.0], longest_run };
        let n = 1 << 20;
        let x = contamination(&c, white, n, &mut stream(11, 6));
        let spiked = x.iter().filter(|v| **v != 0.0).count() as f64;
        // Events are Bernoulli starts: the count's sd is about sqrt(events) times the mean run.
        let mean_run = if longest_run == 1 { 1.0 } else { 11.0 / 7.0 };
        let events = c.per_sample * n as f64 / mean_run;
        assert!((spiked / (c.per_sample * n as f64) - 1.0).abs() < 4.0 / events.sqrt(), "{longest_run}: {spiked}");
        let ms = x.iter().filter(|v| **v != 0.0).map(|v| (v / white).powi(2)).sum::<f64>() / spiked;
        let want = (64.0 + 160.0 + 400.0) / 3.0;
        assert!((ms / want - 1.0).abs() < 0.05, "mean square size {ms} vs {want}");
        let sum: f64 = x.iter().sum::<f64>() / white;
        assert!(sum.abs() < 4.0 * (spiked * want).sqrt(), "signs unbalanced: {sum}");
        let mut runs = [0usize; 4];
        let mut len = 0;
        for v in x.iter().chain([0.0].iter()) {
            if *v != 0.0 {
                len += 1;
            } else if len > 0 {
                runs[len.min(3)] += 1;
                len = 0;
            }
        }
        if longest_run == 1 {
            // Isolated events meet only where one starts right after another: about n p^2 of them.
            let meet = n as f64 * c.per_sample * c.per_sample;
            let met = (runs[2] + runs[3]) as f64;
            assert!(met <= meet + 4.0 * meet.sqrt() + 1.0, "{met} adjacent spikes, about {meet} expected");
        } else {
            let all = (runs[1] + runs[2] + runs[3]) as f64;
            for (r, w) in [(1, 4.0 / 7.0), (2, 2.0 / 7.0), (3, 1.0 / 7.0)] {
                let share = runs[r] as f64 / all;
                assert!((share - w).abs() < 4.0 * (w * (1.0 - w) / all).sqrt(), "run {r}: {share} vs {w}");
            }
        }
    }
}

/// Dense contamination keeps the share asked for: 15% of the samples in runs of up to three, where events that
/// followed each run with a clean sample, or started at the rate of the share over the mean run, would give 13-14%.
#[test]
fn dense_contamination_has_its_share() {
    let c = Contamination { per_sample: 0.15, size_sigma: [3.0, 5.0], longest_run: 3 };
    let n = 1 << 20;
    let x = contamination(&c, 0.02, n, &mut stream(12, 6));
    let share = x.iter().filter(|v| **v != 0.0).count() as f64 / n as f64;
    assert!((share / c.per_sample - 1.0).abs() < 0.02, "share {share}");
}

/// Warm-up: the seed mean of block means of a noisy record follows `size exp(-t / tau)`.
#[test]
fn warm_up_settles_exponentially() {
    let (fs, size, tau) = (10.0, -0.4, 30.0);
    let g = IndepGyro {
        n_deg_per_rt_s: 0.02,
        settling: Some(Settling { size_dps: size, tau_s: tau }),
        ..Default::default()
    };
    let blocks: Vec<Vec<f64>> = (0..32u64)
        .into_par_iter()
        .map(|s| g.generate(fs, 4000, s).rate_dps.chunks(100).map(|c| c.iter().sum::<f64>() / 100.0).collect())
        .collect();
    for b in 0..40 {
        let v: Vec<f64> = blocks.iter().map(|x| x[b]).collect();
        let (mean, se4) = mean_4se(&v);
        let want = (0..100).map(|i| size * (-((b * 100 + i) as f64) / fs / tau).exp()).sum::<f64>() / 100.0;
        assert!((mean - want).abs() < se4, "block {b}: {mean} vs {want}");
    }
}

//! The virtual gyro's narrowband and event processes against their closed forms: the resonance (a second-order
//! Gauss-Markov process, against the sampled oscillator's spectrum and autocovariance), the bistable bias (random
//! telegraph) and
//! the warm-up. The helpers and the error budget are those of [`crate::sim_closed_form`].

use octavar::stats::edf::chi2_quantile;
use octavar_shared::sim::{BistableSim, GyroSim, ResonanceSim, VirtualGyro, WarmUpSim};
use std::f64::consts::PI;

use crate::sim_closed_form::{ar1_avar_exact, channel, edf, oavar, octaves, rates, within_chi2, FAMILY_ALPHA, FS};

/// The poles `r e^{+-i theta}` (per sample at [`FS`]) of a resonance at `f0` Hz with quality factor `q`:
/// `r = exp(-zeta w0 tau0)`, `theta = w0 tau0 sqrt(1 - zeta^2)`, `zeta = 1 / (2 q)`.
fn resonance_poles(f0: f64, q: f64) -> (f64, f64) {
    let zeta = 0.5 / q;
    let w0 = 2.0 * PI * f0 / FS;
    ((-zeta * w0).exp(), w0 * (1.0 - zeta * zeta).sqrt())
}

/// The sine's weight in the damped oscillator's autocovariance, `zeta / sqrt(1 - zeta^2)` for `zeta = 1 / (2 q)`.
fn oscillator_c(q: f64) -> f64 {
    let zeta = 0.5 / q;
    zeta / (1.0 - zeta * zeta).sqrt()
}

/// Autocovariance at lag `k` samples of the damped oscillator driven by white noise, variance `var`, read at each
/// sample: the continuous process's `var e^(-zeta w0 t) (cos wd t + c sin wd t)` at `t = k tau0`, that is
/// `var r^k (cos k theta + c sin k theta)` with the poles `r e^{+-i theta}` and `c` of [`oscillator_c`].
fn resonance_acov(var: f64, (r, theta): (f64, f64), c: f64, k: usize) -> f64 {
    let k = k as f64;
    var * r.powf(k) * ((k * theta).cos() + c * (k * theta).sin())
}

/// The equivalent degrees of freedom of the fully overlapping Allan variance at `m` of `n` samples of a stationary
/// Gaussian sequence of autocovariance `acov` (zero beyond its length), exactly: the estimate is `sum d_i^2` over the
/// `T = n + 1 - 2m` second differences `d_i` of the phase, whose covariance at lag k is
/// `c(k) = -1/2 sum_{p,q} w_p w_q G(|k + q - p|)` (weights 1, -2, 1 at 0, m, 2m; `G(j)` the variance of a sum of j
/// samples), so `Var(sum d^2) = 2 sum_{i,j} c(i - j)^2` and the EDF is `2 (T c(0))^2 / Var(sum d^2)`. Greenhall's
/// EDF is for power-law noise; a narrowband process's differences stay correlated over its decay time.
fn oavar_dof_exact(acov: &[f64], m: usize, n: usize) -> f64 {
    let top = 4 * m + acov.len() + 2;
    // G(j) = j acov(0) + 2 sum_{k=1}^{j-1} (j - k) acov(k), by running sums.
    let mut g = vec![0.0; top + 1];
    let (mut s1, mut sk) = (0.0, 0.0);
    for j in 1..=top {
        if j >= 2 && j - 1 < acov.len() {
            s1 += acov[j - 1];
            sk += (j - 1) as f64 * acov[j - 1];
        }
        g[j] = j as f64 * acov[0] + 2.0 * (j as f64 * s1 - sk);
    }
    let w = [(0usize, 1.0), (m, -2.0), (2 * m, 1.0)];
    let c = |k: usize| -> f64 {
        let mut v = 0.0;
        for &(p, wp) in &w {
            for &(q, wq) in &w {
                v += wp * wq * g[(k + q).abs_diff(p)];
            }
        }
        -0.5 * v
    };
    let terms = n + 1 - 2 * m;
    let reach = (2 * m + acov.len()).min(terms - 1);
    let c0 = c(0);
    let var =
        2.0 * (terms as f64 * c0 * c0 + 2.0 * (1..=reach).map(|k| (terms - k) as f64 * c(k).powi(2)).sum::<f64>());
    2.0 * (terms as f64 * c0).powi(2) / var
}

/// One-sided spectrum, (deg/s)^2/Hz, of the sampled oscillator of [`resonance_acov`]: the autocovariance is
/// `var Re((1 - i c) z^k)`, `z = r e^{i theta}`, whose one-sided sum against `e^{-iwk}` is the geometric
/// `(1/2) ((1 - i c) / (1 - z e^{-iw}) + (1 + i c) / (1 - conj(z) e^{-iw}))`; the two-sided spectrum is twice its
/// real part less the lag-0 term, and the one-sided density `2 tau0` times that.
fn resonance_psd(var: f64, (r, theta): (f64, f64), c: f64, f: f64) -> f64 {
    let w = 2.0 * PI * f / FS;
    // (cr + i ci) / (1 - r e^{i (phi - w)}), real part.
    let re_of = |cr: f64, ci: f64, phi: f64| {
        let (dr, di) = (1.0 - r * (phi - w).cos(), -r * (phi - w).sin());
        (cr * dr + ci * di) / (dr * dr + di * di)
    };
    let one_sided_sum = 0.5 * (re_of(1.0, -c, theta) + re_of(1.0, c, -theta));
    2.0 / FS * var * (2.0 * one_sided_sum - 1.0)
}

/// Allan variance at `m` samples of a stationary sequence from its autocovariance: `(4 G(m) - G(2m)) / (2 m^2)`,
/// `G(n) = n acov(0) + 2 sum_{k=1}^{n-1} (n - k) acov(k)`, the variance of a sum of n consecutive samples.
fn avar_from_acov(acov: &[f64], m: usize) -> f64 {
    let g = |n: usize| n as f64 * acov[0] + 2.0 * (1..n.min(acov.len())).map(|k| (n - k) as f64 * acov[k]).sum::<f64>();
    (4.0 * g(m) - g(2 * m)) / (2.0 * (m * m) as f64)
}

/// The resonance's two closed forms agree: the spectrum is the Fourier sum of the damped-cosine
/// autocovariance, it integrates to sigma^2, peaks within its half-width of f0, and its half-power width is f0/Q
/// within 5% (Q = 8 and 30).
#[test]
fn sim_resonance_spectrum_and_autocovariance_agree() {
    for (f0, q) in [(7.0, 8.0), (20.0, 30.0)] {
        let sigma = 0.2;
        let (poles, c) = (resonance_poles(f0, q), oscillator_c(q));
        let acov: Vec<f64> = (0..20_000).map(|k| resonance_acov(sigma * sigma, poles, c, k)).collect();
        let grid: Vec<f64> = (1..50_000).map(|i| i as f64 * (FS / 2.0) / 50_000.0).collect();
        let psd: Vec<f64> = grid.iter().map(|&f| resonance_psd(sigma * sigma, poles, c, f)).collect();
        for &f in &[0.3 * f0, f0, 1.2 * f0, 2.0 * f0] {
            let w = 2.0 * PI * f / FS;
            let sum = 2.0 / FS
                * (acov[0] + 2.0 * acov.iter().enumerate().skip(1).map(|(k, g)| g * (w * k as f64).cos()).sum::<f64>());
            let s = resonance_psd(sigma * sigma, poles, c, f);
            assert!((sum / s - 1.0).abs() < 1e-6, "f0 {f0} at {f}: Fourier sum {sum:e} vs closed form {s:e}");
        }
        let df = grid[1] - grid[0];
        let total: f64 = psd.iter().sum::<f64>() * df;
        assert!((total / (sigma * sigma) - 1.0).abs() < 1e-3, "f0 {f0}: the spectrum integrates to {total:e}");
        let (ipk, &pk) = psd.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).unwrap();
        assert!((grid[ipk] - f0).abs() < 0.5 * f0 / q, "f0 {f0}: peak at {}", grid[ipk]);
        let above: Vec<f64> = grid.iter().zip(&psd).filter(|(_, &p)| p >= 0.5 * pk).map(|(f, _)| *f).collect();
        let width = above[above.len() - 1] - above[0];
        assert!((width / (f0 / q) - 1.0).abs() < 0.05, "f0 {f0} Q {q}: half-power width {width} Hz");
    }
}

/// The simulated resonance against its closed forms: the overlapping Allan variance against the exact form from
/// the autocovariance (chi-square at the estimator's exact EDF for this process, [`oavar_dof_exact`]), and a Hann-windowed segment-averaged periodogram at seven
/// frequencies across the bump against its exact expectation, `sum_k acov(k) R_w(k) e^{-iwk}` (`R_w` the window's
/// autocorrelation), each within the chi-square band of its degrees of freedom (`2K` over K segments, less where
/// the real and imaginary parts of a segment's transform differ in variance). Its stationary variance is sigma^2.
#[test]
fn sim_resonance_matches_its_discrete_closed_form() {
    // The exact EDF on white noise: 2T/3 at m = 1 (c(0) = 2, c(1) = -1), and Greenhall's from m = 64.
    let n_w = 1 << 20;
    assert!((oavar_dof_exact(&[1.0], 1, n_w) / (2.0 * (n_w - 1) as f64 / 3.0) - 1.0).abs() < 1e-5);
    for m in [64usize, 1024, 16384] {
        let ratio = oavar_dof_exact(&[1.0], m, n_w) / edf(&[0], m as f64, m as f64, (n_w + 1) as f64);
        assert!((ratio - 1.0).abs() < 1e-3, "white noise m={m}: exact EDF / Greenhall's = {ratio}");
    }
    let (sigma, f0, q) = (0.2, 7.0, 8.0);
    let model = GyroSim { resonance: Some(ResonanceSim { sigma_dps: sigma, freq_hz: f0, q }), ..Default::default() };
    let (poles, sine_weight) = (resonance_poles(f0, q), oscillator_c(q));
    let var = sigma * sigma;
    // r^k falls below 1e-30 of the variance within 2600 lags.
    let acov: Vec<f64> = (0..4096).map(|k| resonance_acov(var, poles, sine_weight, k)).collect();
    let n = 1 << 21;
    let ms = octaves(1, n, 16);
    let seeds = [81u64, 82];
    const SEG: usize = 512;
    let freqs = [0.3 * f0, 0.7 * f0, f0 * (1.0 - 0.5 / q), f0, f0 * (1.0 + 0.5 / q), 1.5 * f0, 3.0 * f0];
    let checks = seeds.len() * (ms.len() + freqs.len() + 1);
    let p = FAMILY_ALPHA / checks as f64;
    let window: Vec<f64> = (0..SEG).map(|i| 0.5 * (1.0 - (2.0 * PI * (i as f64 + 0.5) / SEG as f64).cos())).collect();
    let r_w: Vec<f64> = (0..SEG).map(|k| (0..SEG - k).map(|i| window[i] * window[i + k]).sum()).collect();
    for &seed in &seeds {
        let y = rates(&model, n, seed);
        // Stationary variance: n / (2 Q / (pi f0 tau0)) ~ 30000 independent stretches; bound from the exact
        // variance of the sample variance of a Gaussian sequence, 2 sum_k acov(k)^2 / n.
        let s2 = y.iter().map(|v| v * v).sum::<f64>() / n as f64;
        let sd = (2.0 * (acov[0] * acov[0] + 2.0 * acov[1..].iter().map(|g| g * g).sum::<f64>()) / n as f64).sqrt();
        let z = chi2_quantile(1.0 - p, 1.0).sqrt();
        assert!((s2 - var).abs() < z * sd, "seed {seed}: variance {s2:e} against {var:e} (sd {sd:e})");
        for &m in &ms {
            let (est, _) = oavar(&y, m);
            let dof = oavar_dof_exact(&acov, m, n);
            within_chi2(&format!("resonance seed {seed}"), m, est, avar_from_acov(&acov, m), dof, p);
        }
        for &f in &freqs {
            let w = 2.0 * PI * f / FS;
            let (c, s) = (w.cos(), w.sin());
            let k_seg = n / SEG;
            let mut est = 0.0;
            for j in 0..k_seg {
                let (mut re, mut im, mut pc, mut ps) = (0.0, 0.0, 1.0f64, 0.0f64);
                for (i, wi) in window.iter().enumerate() {
                    let v = wi * y[j * SEG + i];
                    re += v * pc;
                    im -= v * ps;
                    let pc2 = pc * c - ps * s;
                    ps = ps * c + pc * s;
                    pc = pc2;
                }
                est += re * re + im * im;
            }
            est /= k_seg as f64;
            let mean = acov[0] * r_w[0] + 2.0 * (1..SEG).map(|k| acov[k] * r_w[k] * (w * k as f64).cos()).sum::<f64>();
            // E[Z^2] = sum_{a,b} w_a w_b acov(a - b) e^{-iw(a + b)}; Var|Z|^2 = mean^2 + |E Z^2|^2.
            let (mut zr, mut zi) = (0.0, 0.0);
            for a in 0..SEG {
                for b in 0..SEG {
                    let g = window[a] * window[b] * acov[a.abs_diff(b)];
                    let ph = w * (a + b) as f64;
                    zr += g * ph.cos();
                    zi -= g * ph.sin();
                }
            }
            let dof = 2.0 * k_seg as f64 * mean * mean / (mean * mean + zr * zr + zi * zi);
            let what = format!("resonance periodogram seed {seed} at {f:.3} Hz");
            within_chi2(&what, SEG, est, mean, dof, p);
            // The expectation is the closed-form spectrum seen through the window: within 10% where the bump is
            // several window widths (4 FS / SEG = 0.8 Hz) wide.
            let closed = resonance_psd(var, poles, sine_weight, f) * FS / 2.0 * r_w[0];
            assert!((mean / closed - 1.0).abs() < 0.1, "{what}: expectation {mean:e} against the spectrum {closed:e}");
        }
    }
}

/// The t quantile at `1 - p/2` for `dof` degrees of freedom (Cornish-Fisher, to order 1/dof^2 from the normal's).
fn t_quantile_two_sided(p: f64, dof: f64) -> f64 {
    let z = chi2_quantile(1.0 - p, 1.0).sqrt();
    z + (z.powi(3) + z) / (4.0 * dof) + (5.0 * z.powi(5) + 16.0 * z.powi(3) + 3.0 * z) / (96.0 * dof * dof)
}

/// The bistable bias (random telegraph) against its closed forms. Its sampled autocovariance is
/// `var a^|k|`, `var = step^2 l1 l2 / (l1 + l2)^2`, `a = exp(-(l1 + l2) tau0)`: the overlapping Allan variance is the
/// discrete AR(1) form, checked by chi-square at Greenhall's EDF where a cluster spans twenty flips or more
/// (m >= 256) and by a t-test on 64 batch means below, where the differences are far from Gaussian. The share of
/// time in the high level is `l1 / (l1 + l2)` and the expected number of flips in n samples `2 n p_low p_up`
/// (`p_up = l1 / (l1 + l2) (1 - a)`), within normal bounds of their exact and renewal variances.
#[test]
fn sim_bistable_matches_its_discrete_closed_form() {
    let (step, dwell_low, dwell_high) = (0.3, 0.2, 0.05); // 20 and 5 samples
    let model = GyroSim {
        bistable: Some(BistableSim { step_dps: step, dwell_low_s: dwell_low, dwell_high_s: dwell_high }),
        ..Default::default()
    };
    let (l1, l2) = (1.0 / dwell_low, 1.0 / dwell_high);
    let total = l1 + l2;
    let var = step * step * l1 * l2 / (total * total);
    let a = (-total / FS).exp();
    let p_high = l1 / total;
    let (high, low) = (step * (1.0 - p_high), -step * p_high);
    let n = 1 << 21;
    let seeds = [91u64, 92];
    let ms = octaves(1, n, 16);
    let p = FAMILY_ALPHA / (seeds.len() * (ms.len() + 2)) as f64;
    const BATCHES: usize = 64;
    for &seed in &seeds {
        let mut g = VirtualGyro::new(&model, channel(), FS, seed).unwrap();
        let y: Vec<f64> = (0..n).map(|_| g.next_rate(25.0)).collect();
        assert!(y.iter().all(|&v| v == high || v == low), "only the two zero-mean levels");
        for &m in &ms {
            let want = ar1_avar_exact(var, a, m);
            let what = format!("bistable seed {seed}");
            if m >= 256 {
                let (est, _) = oavar(&y, m);
                let dof = edf(&[0, -1, -2], m as f64, m as f64, (n + 1) as f64);
                within_chi2(&what, m, est, want, dof, p);
            } else {
                // The mean of d_i^2 / (2 m^2) over the overlapping differences, in 64 consecutive batches.
                let mut x = vec![0.0; n + 1];
                for i in 0..n {
                    x[i + 1] = x[i] + y[i];
                }
                let terms = n + 1 - 2 * m;
                let per = terms / BATCHES;
                let means: Vec<f64> = (0..BATCHES)
                    .map(|b| {
                        (b * per..(b + 1) * per).map(|i| (x[i + 2 * m] - 2.0 * x[i + m] + x[i]).powi(2)).sum::<f64>()
                            / (2.0 * (m * m) as f64 * per as f64)
                    })
                    .collect();
                let mu = means.iter().sum::<f64>() / BATCHES as f64;
                let sd = (means.iter().map(|v| (v - mu).powi(2)).sum::<f64>() / (BATCHES - 1) as f64).sqrt();
                let t = (mu - want) / (sd / (BATCHES as f64).sqrt());
                let bound = t_quantile_two_sided(p, (BATCHES - 1) as f64);
                assert!(t.abs() < bound, "{what} m={m}: AVAR {mu:.6e} vs {want:.6e}, t = {t:.2} (bound {bound:.2})");
            }
        }
        let z = chi2_quantile(1.0 - p, 1.0).sqrt();
        // Occupancy: the mean of a stationary two-state chain's indicator, variance p_h p_l (1 + a) / ((1 - a) n).
        let share = y.iter().filter(|&&v| v == high).count() as f64 / n as f64;
        let sd = (p_high * (1.0 - p_high) * (1.0 + a) / ((1.0 - a) * n as f64)).sqrt();
        assert!((share - p_high).abs() < z * sd, "seed {seed}: high share {share} against {p_high} (sd {sd:.2e})");
        // Flips: a renewal count of low + high cycles (geometric dwells of means 1/p_up, 1/p_down samples).
        let (p_up, p_down) = (l1 / total * (1.0 - a), l2 / total * (1.0 - a));
        let mu_c = 1.0 / p_up + 1.0 / p_down;
        let var_c = (1.0 - p_up) / (p_up * p_up) + (1.0 - p_down) / (p_down * p_down);
        let mean = 2.0 * n as f64 / mu_c;
        let sd = (4.0 * n as f64 * var_c / mu_c.powi(3)).sqrt() + 2.0;
        let flips = g.flip_count() as f64;
        assert!((flips - mean).abs() < z * sd, "seed {seed}: {flips} flips, expected {mean:.0} (sd {sd:.0})");
        // The count is the level changes seen in the samples (and one more where sample 0 flipped already).
        let changes = y.windows(2).filter(|w| w[0] != w[1]).count() as u64;
        assert!((0..=1).contains(&(g.flip_count() - changes)), "{} flips, {changes} changes", g.flip_count());
    }
}

/// The warm-up is `size exp(-t / tau)` from the first sample, exactly, and it enters before the sensor's
/// first-order filter: through the filter `y_n = a y_{n-1} + (1 - a) x_n` (started at x_0) the exponential
/// `S d^n` becomes `S [(1 - a) d (d^n - a^n) / (d - a) + a^n]`. White noise beside it adds without touching it:
/// the same seed without the warm-up gives the same noise.
#[test]
fn sim_warm_up_is_exact() {
    let (size, tau) = (0.3, 2.0);
    let warm = WarmUpSim { size_dps: size, tau_s: tau };
    let model = GyroSim { warm_up: Some(warm), ..Default::default() };
    let y = rates(&model, 100_000, 1);
    for (i, &v) in y.iter().enumerate() {
        let want = size * (-(i as f64) / FS / tau).exp();
        assert!((v - want).abs() <= 1e-12 * want + 1e-200, "sample {i}: {v} vs {want}");
    }
    let f3 = 5.0;
    let filtered = GyroSim { warm_up: Some(warm), bandwidth_hz: Some(f3), ..Default::default() };
    let y = rates(&filtered, 20_000, 1);
    let a = (-2.0 * PI * f3 / FS).exp();
    let d = (-1.0 / (FS * tau)).exp();
    for (i, &v) in y.iter().enumerate() {
        let k = i as i32;
        let want = size * ((1.0 - a) * d * (d.powi(k) - a.powi(k)) / (d - a) + a.powi(k));
        assert!((v - want).abs() <= 1e-11 * size, "filtered sample {i}: {v} vs {want}");
    }
    let noisy = GyroSim { n_deg_per_rt_s: 0.01, warm_up: Some(warm), ..Default::default() };
    let plain = GyroSim { n_deg_per_rt_s: 0.01, ..Default::default() };
    let (a_n, b_n) = (rates(&noisy, 50_000, 2), rates(&plain, 50_000, 2));
    for (i, (x, z)) in a_n.iter().zip(&b_n).enumerate() {
        let want = size * (-(i as f64) / FS / tau).exp();
        assert!((x - z - want).abs() <= 1e-15 * (x.abs() + 1.0), "sample {i}: {} vs {want}", x - z);
    }
}

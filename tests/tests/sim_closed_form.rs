//! The virtual gyro (`octavar_shared::sim`) against the closed-form Allan variance of each term and effect.
//!
//! Every random term is checked at octave taus with a two-sided chi-square bound at Greenhall's equivalent degrees
//! of freedom for the estimator used (fully overlapping f64 AVAR computed here, or the octave accumulator with
//! stride 8 on ADC codes). Each test spends a family-wise error of 0.1% over all its checks (Bonferroni), and the
//! seeds are fixed, so the tests are deterministic and a pass is not luck at the 0.1% level. Where sampling makes
//! the discrete Allan variance differ from the continuous closed form (random walk, Gauss-Markov, low-pass,
//! sinusoid), the exact discrete form is used; each one is written out below from its autocovariance, independently
//! of the simulator's code. Deterministic terms (ramp, sinusoid, temperature through the lag, warm-up) get exact
//! bounds. Where a process is not Gaussian at short tau (the bistable bias, whose differences are 0 or a step),
//! the chi-square bound starts where a cluster holds some twenty events, and the shorter taus are checked by a
//! t-test on batch means, which assumes nothing about the distribution.

use octavar::stats::edf::{chi2_quantile, greenhall_edf};
use octavar_shared::acc::OctaveAllan;
use octavar_shared::sensor::{Adc, Channel, FrontEnd, SensorKind, GENERIC, IDG1215_X};
use octavar_shared::sim::flicker::FlickerBank;
use octavar_shared::sim::{
    Bench, BenchSim, BiasSteps, BistableSim, ChannelSim, GaussMarkovSim, GyroSim, Outliers, ResonanceSim, Sinusoid,
    TempCoupling, TemperatureProfile, VirtualGyro, WarmUpSim,
};
use std::f64::consts::{LN_2, PI};

/// Sample rate of the statistical tests (tau0 = 10 ms).
pub(crate) const FS: f64 = 100.0;
/// Family-wise two-sided error per test.
pub(crate) const FAMILY_ALPHA: f64 = 1e-3;
/// How flat the flicker bank is from tau = 32 tau0: its design (every process updated each sample) is within 0.6%
/// of the closed form; holding the slow processes adds a ripple measured at about +0.8% at 32 tau0 and +0.3% above.
const FLATNESS: f64 = 0.01;

pub(crate) fn channel() -> Channel {
    Channel::bench(GENERIC)
}

/// `n` analog rates of a model (the noise-only path), at a constant 25 degC.
pub(crate) fn rates(model: &GyroSim, n: usize, seed: u64) -> Vec<f64> {
    let mut g = VirtualGyro::new(model, channel(), FS, seed).unwrap();
    (0..n).map(|_| g.next_rate(25.0)).collect()
}

/// Fully overlapping Allan variance of rate samples at `m` samples, and the number of differences.
pub(crate) fn oavar(y: &[f64], m: usize) -> (f64, usize) {
    let mut x = Vec::with_capacity(y.len() + 1);
    let mut acc = 0.0;
    x.push(0.0);
    for v in y {
        acc += v;
        x.push(acc);
    }
    let terms = y.len() + 1 - 2 * m;
    let mut s = 0.0;
    for i in 0..terms {
        let d = x[i + 2 * m] - 2.0 * x[i + m] + x[i];
        s += d * d;
    }
    (s / (2.0 * (m * m) as f64 * terms as f64), terms)
}

/// Octave averaging factors from `lo` while at least `min_clusters` clusters fit in `n` samples.
pub(crate) fn octaves(lo: usize, n: usize, min_clusters: usize) -> Vec<usize> {
    let mut v = Vec::new();
    let mut m = lo;
    while n / m >= min_clusters {
        v.push(m);
        m *= 2;
    }
    v
}

/// The smallest Greenhall EDF over the candidate noise exponents (conservative for mixtures).
pub(crate) fn edf(alphas: &[i32], m: f64, stride: f64, n_phase: f64) -> f64 {
    alphas.iter().map(|&a| greenhall_edf(a, 2, m, m, stride, n_phase)).fold(f64::INFINITY, f64::min)
}

/// Check `est` against `expected` at `dof` degrees of freedom with per-check error `p`:
/// `dof est / expected` must lie between the chi-square quantiles `p/2` and `1 - p/2`.
pub(crate) fn within_chi2(what: &str, m: usize, est: f64, expected: f64, dof: f64, p: f64) {
    within_chi2_range(what, m, est, (expected, expected), dof, p);
}

/// As [`within_chi2`] where the expectation is only known to lie in `lo_exp..=hi_exp`: the band runs from the
/// lower quantile of the lowest to the upper quantile of the highest.
fn within_chi2_range(what: &str, m: usize, est: f64, (lo_exp, hi_exp): (f64, f64), dof: f64, p: f64) {
    assert!(dof.is_finite() && dof > 0.0, "{what} m={m}: bad edf {dof}");
    let lo = lo_exp * chi2_quantile(p / 2.0, dof) / dof;
    let hi = hi_exp * chi2_quantile(1.0 - p / 2.0, dof) / dof;
    assert!(
        (lo..=hi).contains(&est),
        "{what} m={m}: AVAR {est:.6e} outside [{lo:.6e}, {hi:.6e}] (expected {lo_exp:.6e}..{hi_exp:.6e}, edf {dof:.1})"
    );
}

/// Run the overlapping check over octave taus for every seed: `expected(m)` in (deg/s)^2.
fn check_oavar(
    what: &str,
    model: &GyroSim,
    n: usize,
    seeds: &[u64],
    ms: &[usize],
    alphas: &[i32],
    expected: impl Fn(usize) -> f64,
) {
    let p = FAMILY_ALPHA / (seeds.len() * ms.len()) as f64;
    for &seed in seeds {
        let y = rates(model, n, seed);
        for &m in ms {
            let (est, _) = oavar(&y, m);
            let dof = edf(alphas, m as f64, m as f64, (n + 1) as f64);
            within_chi2(&format!("{what} seed {seed}"), m, est, expected(m), dof, p);
        }
    }
}

/// Exact Allan variance at `m` samples of a stationary AR(1) sequence (variance `var`, lag-one correlation `a`),
/// from its autocovariance `var a^|k|`: AVAR = (4 G(m) - G(2m)) / (2 m^2), G(n) = Var(sum of n samples).
pub(crate) fn ar1_avar_exact(var: f64, a: f64, m: usize) -> f64 {
    let g = |n: f64| n * (1.0 + a) / (1.0 - a) - 2.0 * a * (1.0 - a.powf(n)) / ((1.0 - a) * (1.0 - a));
    let m = m as f64;
    var * (4.0 * g(m) - g(2.0 * m)) / (2.0 * m * m)
}

/// Continuous Gauss-Markov closed form (IEEE 952 / El-Sheimy 2008): (q_c T^2 / tau)[1 - T/(2 tau)(3 - 4e^{-tau/T} + e^{-2 tau/T})].
fn gm_avar_continuous(sigma: f64, t: f64, tau: f64) -> f64 {
    let qc = 2.0 * sigma * sigma / t;
    let r = tau / t;
    qc * t * t / tau * (1.0 - (3.0 - 4.0 * (-r).exp() + (-2.0 * r).exp()) / (2.0 * r))
}

/// Discrete Allan variance of rate random walk with per-sample increment variance q: q (2 m^2 + 1) / (6 m)
/// (the continuous K^2 tau / 3 plus K^2 tau0^2 / (6 tau)).
fn rw_avar_exact(q: f64, m: usize) -> f64 {
    let m = m as f64;
    q * (2.0 * m * m + 1.0) / (6.0 * m)
}

/// Discrete Allan variance of a sampled sinusoid of amplitude `amp`, frequency `f`:
/// A^2 sin^4(pi f tau) / (m sin(pi f tau0))^2, which tends to A^2 sin^4(pi f tau) / (pi f tau)^2.
fn sine_avar_exact(amp: f64, f: f64, m: usize) -> f64 {
    let tau0 = 1.0 / FS;
    let tau = m as f64 * tau0;
    let s = (PI * f * tau).sin();
    amp * amp * s.powi(4) / (m as f64 * (PI * f * tau0).sin()).powi(2)
}

#[test]
fn sim_white_noise_is_n2_over_tau() {
    let nn = 0.01; // deg/sqrt(s): per-sample sd 0.1 deg/s at 100 Hz
    let model = GyroSim { n_deg_per_rt_s: nn, ..Default::default() };
    let n = 1 << 20;
    let ms = octaves(1, n, 16);
    check_oavar("white", &model, n, &[1, 2, 3], &ms, &[0], |m| nn * nn / (m as f64 / FS));
}

#[test]
fn sim_angle_noise_is_3q2_over_tau2() {
    // White angle noise (IEEE 952 quantization noise): the rate is the differenced white angle, exactly
    // 3 Q^2 / tau^2 at every tau, plus N to show the two add.
    let (q, nn) = (2e-4, 1e-3); // deg, deg/sqrt(s)
    let model = GyroSim { q_deg: q, n_deg_per_rt_s: nn, ..Default::default() };
    let n = 1 << 20;
    let ms = octaves(1, n, 16);
    check_oavar("angle", &model, n, &[4, 5], &ms, &[2, 0], |m| {
        let tau = m as f64 / FS;
        3.0 * q * q / (tau * tau) + nn * nn / tau
    });
}

#[test]
fn sim_flicker_floor_is_0_6643_b() {
    // 4 M samples: m = 1 .. 2^17; the bounds are the bank's design (within 1.8% of the floor from m = 1, 0.6%
    // from m = 32) widened by the holding ripple.
    let b = 0.02;
    let floor = 2.0 * LN_2 / PI * b * b;
    let model = GyroSim { b_dps: b, ..Default::default() };
    let n = 1 << 22;
    let ms = octaves(1, n, 32);
    let seeds = [11, 12];
    let p = FAMILY_ALPHA / (seeds.len() * ms.len()) as f64;
    for &seed in &seeds {
        let y = rates(&model, n, seed);
        for &m in &ms {
            let (est, _) = oavar(&y, m);
            let dof = edf(&[-1], m as f64, m as f64, (n + 1) as f64);
            let design = FlickerBank::design_avar(b, m as f64);
            let bound = if m >= 32 { 0.006 } else { 0.018 };
            assert!((design / floor - 1.0).abs() < bound, "design {design} against {floor} at m={m}");
            let band = (design * (1.0 - FLATNESS), design * (1.0 + FLATNESS));
            within_chi2_range(&format!("flicker seed {seed}"), m, est, band, dof, p);
        }
    }
}

#[test]
fn sim_flicker_over_eight_decades_through_the_adc() {
    // N + B through a 16-bit, 1 mV/code ADC at 1000 codes per deg/s, into the octave accumulator (stride 8):
    // 2^28 samples reach tau = 2^26 tau0 (8 decades above tau0; the design function covers the bank to 2^35).
    let gyro = octavar_shared::sensor::GyroModel {
        kind: SensorKind::Generic,
        sensitivity_mv_per_dps: 1000.0,
        null_mv: 32768.0,
        range_dps: 30.0,
        bandwidth_hz: 1e9,
        supply_mv: 65536.0,
        temp_output: None,
        assumptions: &[],
    };
    let ch = Channel { gyro, front: FrontEnd::WIRE, adc: Adc { bits: 16, vref_mv: 65536.0 } };
    let (b, nn) = (1.0, 0.02);
    let model = GyroSim { b_dps: b, n_deg_per_rt_s: nn, ..Default::default() };
    let mut g = VirtualGyro::new(&model, ch, FS, 99).unwrap();
    let mut acc = OctaveAllan::<8>::new();
    let n: u64 = 1 << 28;
    for _ in 0..n {
        acc.push(g.next(25.0).code);
    }
    assert_eq!(g.clipped_count(), 0);
    let snap = acc.snapshot();
    let floor = 2.0 * LN_2 / PI * b * b;
    let codes2 = 1e6; // (codes per deg/s)^2
    let levels: Vec<usize> = (5..=26).collect();
    let p = FAMILY_ALPHA / levels.len() as f64;
    for &k in &levels {
        let m = (1u64 << k) as f64;
        let est = snap.avar_codes2(k).unwrap();
        // White N^2/tau plus quantisation LSB^2/12 (both white); flicker within the bank's flatness.
        let white = nn * nn * FS / m * codes2 + 1.0 / 12.0 / m;
        let band = (floor * (1.0 - FLATNESS) * codes2 + white, floor * (1.0 + FLATNESS) * codes2 + white);
        let dof = edf(&[-1, 0], m, snap.stride_factor(k) as f64, (n + 1) as f64);
        within_chi2_range("flicker long run", 1 << k, est, band, dof, p);
    }
}

#[test]
fn sim_random_walk_is_k2_tau_over_3() {
    let k = 0.002;
    let model = GyroSim { k_dps_per_rt_s: k, ..Default::default() };
    let n = 1 << 20;
    let ms = octaves(1, n, 16);
    check_oavar("random walk", &model, n, &[21, 22, 23], &ms, &[-2], |m| rw_avar_exact(k * k / FS, m));
    // The discrete form is the closed form plus K^2 tau0^2 / (6 tau): the same within 1% from m = 5.
    let tau = 8.0 / FS;
    assert!((rw_avar_exact(k * k / FS, 8) / (k * k * tau / 3.0) - 1.0).abs() < 0.01);
}

#[test]
fn sim_ramp_is_r2_tau2_over_2_exactly() {
    let r = 0.05;
    let model = GyroSim { r_dps_per_s: r, bias_dps: 0.3, ..Default::default() };
    let n = 1 << 16;
    let y = rates(&model, n, 1);
    for m in octaves(1, n, 4) {
        let tau = m as f64 / FS;
        let (est, _) = oavar(&y, m);
        let want = r * r * tau * tau / 2.0;
        assert!((est / want - 1.0).abs() < 1e-6, "m={m}: {est} vs {want}");
    }
}

#[test]
fn sim_constant_bias_has_zero_allan_variance() {
    let model = GyroSim { bias_dps: 1.5, ..Default::default() };
    let y = rates(&model, 4096, 1);
    assert!(y.iter().all(|&v| v == 1.5));
    assert_eq!(oavar(&y, 4).0, 0.0);
}

#[test]
fn sim_gauss_markov_matches_its_discrete_closed_form() {
    let (sigma, t_s) = (0.3, 0.2); // T = 20 samples
    let model = GyroSim { gauss_markov: Some(GaussMarkovSim { sigma_dps: sigma, tau_s: t_s }), ..Default::default() };
    let a = (-1.0 / (t_s * FS)).exp();
    let n = 1 << 21;
    let ms = octaves(1, n, 16);
    check_oavar("gauss-markov", &model, n, &[31, 32], &ms, &[0, -1, -2], |m| ar1_avar_exact(sigma * sigma, a, m));
    // Where T >> tau0 the discrete form approaches the continuous one (q_c = 2 sigma^2 / T).
    for m in [40usize, 200, 2000] {
        let d = ar1_avar_exact(sigma * sigma, a, m) / gm_avar_continuous(sigma, t_s, m as f64 / FS) - 1.0;
        assert!(d.abs() < 0.01, "m={m}: discrete vs continuous {d}");
    }
}

#[test]
fn sim_first_order_bandwidth_is_gauss_markov_with_t_1_over_2_pi_f() {
    let (nn, f3) = (0.01, 2.0);
    let model = GyroSim { n_deg_per_rt_s: nn, bandwidth_hz: Some(f3), ..Default::default() };
    let a = (-2.0 * PI * f3 / FS).exp(); // T = 1/(2 pi f3dB) = 7.96 samples
    let s2 = nn * nn * FS; // white input variance
    let var = s2 * (1.0 - a) / (1.0 + a);
    let n = 1 << 21;
    let ms = octaves(1, n, 16);
    check_oavar("low-pass", &model, n, &[41, 42], &ms, &[0, -1, -2], |m| ar1_avar_exact(var, a, m));
    // DC gain 1: at long tau it is the unfiltered N^2 / tau.
    let m = 4096;
    assert!((ar1_avar_exact(var, a, m) / (nn * nn * FS / m as f64) - 1.0).abs() < 0.01);
}

/// |mean of cos(2 w i + c)| over `terms` consecutive i is at most 1 / (terms |sin w|): the estimator of a pure
/// sinusoid's AVAR is within that fraction of the discrete closed form.
fn sine_rel_bound(f: f64, terms: usize) -> f64 {
    1.0 / (terms as f64 * (2.0 * PI * f / FS).sin().abs())
}

#[test]
fn sim_sinusoids_match_the_closed_form() {
    let list = [
        Sinusoid { amplitude_dps: 0.3, period_s: 0.37, phase_rad: 0.4 },
        Sinusoid { amplitude_dps: 0.1, period_s: 5.3, phase_rad: 2.0 },
    ];
    let n = 1 << 20;
    for s in list {
        let model = GyroSim { sinusoids: [s].into_iter().collect(), ..Default::default() };
        let y = rates(&model, n, 1);
        let f = 1.0 / s.period_s;
        for m in octaves(1, n, 64) {
            let (est, terms) = oavar(&y, m);
            let want = sine_avar_exact(s.amplitude_dps, f, m);
            let tol = want * sine_rel_bound(f, terms) + 1e-12 * s.amplitude_dps.powi(2);
            assert!((est - want).abs() <= tol, "P={} m={m}: {est:e} vs {want:e} (tol {tol:e})", s.period_s);
        }
    }
    // Two sinusoids at once add their Allan variances (different frequencies), within the same bounds.
    let model = GyroSim { sinusoids: list.into_iter().collect(), ..Default::default() };
    let y = rates(&model, n, 1);
    for m in [1usize, 16, 256] {
        let (est, terms) = oavar(&y, m);
        let want: f64 = list.iter().map(|s| sine_avar_exact(s.amplitude_dps, 1.0 / s.period_s, m)).sum();
        let slack: f64 = list
            .iter()
            .map(|s| s.amplitude_dps.powi(2) * 4.0 * sine_rel_bound(1.0 / s.period_s, terms).max(1.0 / terms as f64))
            .sum();
        assert!((est - want).abs() <= slack * 2.0, "m={m}: {est:e} vs {want:e}");
    }
}

#[test]
fn sim_temperature_cycle_through_the_lag_is_a_sinusoid_of_known_amplitude() {
    let (t_min, t_max, period, lag, k) = (20.0, 30.0, 10.0, 0.5, 0.02);
    let gyro =
        GyroSim { temperature: Some(TempCoupling { dps_per_c: k, ref_c: 25.0, lag_s: lag }), ..Default::default() };
    let model = BenchSim {
        rate_hz: FS,
        seed: 5,
        temperature: TemperatureProfile { min_c: t_min, max_c: t_max, period_s: period, phase_rad: 0.0, wander: None },
        channels: [ChannelSim { sensor: SensorKind::Generic, channel: None, gyro }].into_iter().collect(),
    };
    let mut bench = Bench::new(&model).unwrap();
    let w = 2.0 * PI / (period * FS); // rad per sample
    let a = (-1.0 / (lag * FS)).exp();
    // H = (1 - a) / (1 - a e^{-iw})
    let (re, im) = (1.0 - a * w.cos(), a * w.sin());
    let mag = (1.0 - a) / (re * re + im * im).sqrt();
    let phase = -im.atan2(re);
    let amp = k * 5.0 * mag;
    assert!((mag - 1.0 / (1.0 + (2.0 * PI * lag / period).powi(2)).sqrt()).abs() < 1e-3, "continuous limit");
    let n = 1 << 18;
    let mut y = Vec::with_capacity(n);
    for i in 0..n {
        let s = bench.next_sample();
        let temp_want = 25.0 + 5.0 * (w * i as f64).sin();
        assert!((s.temp_c - temp_want).abs() < 1e-9, "temperature at {i}");
        let rate_want = amp * (w * i as f64 + phase).sin();
        if i > 2000 {
            // 40 thermal time constants: the start-up transient is below e^-40.
            assert!((s.rate_dps[0] - rate_want).abs() < 1e-9, "rate at {i}: {} vs {rate_want}", s.rate_dps[0]);
        }
        y.push(s.rate_dps[0]);
    }
    let y = &y[2001..];
    for m in octaves(1, y.len(), 64) {
        let (est, terms) = oavar(y, m);
        let want = sine_avar_exact(amp, 1.0 / period, m);
        let tol = want * sine_rel_bound(1.0 / period, terms) + 1e-15;
        assert!((est - want).abs() <= tol, "m={m}: {est:e} vs {want:e}");
    }
}

#[test]
fn sim_quantization_adds_lsb2_over_12() {
    // White noise of 1 LSB sd dithers the 12-bit ADC: code AVAR = (sigma^2 + 1/12) / m in codes^2.
    let ch = Channel::bench(IDG1215_X);
    let lsb = ch.dps_per_code();
    let sigma_codes = 1.0;
    let model = GyroSim { n_deg_per_rt_s: sigma_codes * lsb / FS.sqrt(), ..Default::default() };
    let n: u64 = 1 << 22;
    let seeds = [51u64, 52];
    let levels: Vec<usize> = (0..=16).collect();
    let p = FAMILY_ALPHA / (seeds.len() * levels.len()) as f64;
    for &seed in &seeds {
        let mut g = VirtualGyro::new(&model, ch, FS, seed).unwrap();
        let mut acc = OctaveAllan::<8>::new();
        for _ in 0..n {
            acc.push(g.next(25.0).code);
        }
        let snap = acc.snapshot();
        for &k in &levels {
            let m = (1u64 << k) as f64;
            let est = snap.avar_codes2(k).unwrap();
            let dof = edf(&[0], m, snap.stride_factor(k) as f64, (n + 1) as f64);
            within_chi2(
                &format!("quantisation seed {seed}"),
                1 << k,
                est,
                (sigma_codes.powi(2) + 1.0 / 12.0) / m,
                dof,
                p,
            );
            if k == 0 {
                // The 1/12 is resolved: sigma^2 alone is far outside the 99.9% band at m = 1.
                let hi = sigma_codes.powi(2) * chi2_quantile(1.0 - p / 2.0, dof) / dof;
                assert!(est > hi, "quantisation noise not visible: {est} <= {hi}");
            }
        }
    }
}

#[test]
fn sim_bias_steps_are_a_random_walk() {
    // p = 0.02 steps per sample (7200 per hour at 100 Hz), sd 0.05 deg/s: increments of variance p sigma^2.
    let (per_hour, sd) = (7200.0, 0.05);
    let model = GyroSim { bias_steps: Some(BiasSteps { per_hour, sigma_dps: sd }), ..Default::default() };
    let p_step = per_hour / 3600.0 / FS;
    let n = 1 << 21;
    // From m = 512 a difference spans about 20 steps or more: close enough to Gaussian for the chi-square bound.
    let ms = octaves(512, n, 16);
    check_oavar("bias steps", &model, n, &[61, 62], &ms, &[-2], |m| rw_avar_exact(p_step * sd * sd, m));
    let mut g = VirtualGyro::new(&model, channel(), FS, 61).unwrap();
    for _ in 0..n {
        g.next_rate(25.0);
    }
    // Binomial count: mean n p = 41943, sd 202; 5 sigma.
    let c = g.step_count() as f64;
    let mean = n as f64 * p_step;
    assert!((c - mean).abs() < 5.0 * (mean * (1.0 - p_step)).sqrt(), "{c} steps, expected {mean}");
}

#[test]
fn sim_outliers_are_white_with_variance_p_size2() {
    let (p_out, size) = (0.01, 1.0);
    let model = GyroSim {
        outliers: Some(Outliers { per_sample: p_out, size_dps: size, ..Default::default() }),
        ..Default::default()
    };
    let n = 1 << 21;
    // From m = 2048 a cluster holds about 20 outliers: near Gaussian.
    let ms = octaves(2048, n, 16);
    check_oavar("outliers", &model, n, &[71, 72], &ms, &[0], |m| p_out * size * size / m as f64);
    let y = rates(&model, n, 71);
    assert!(y.iter().all(|&v| v == 0.0 || v.abs() == size));
    let mut g = VirtualGyro::new(&model, channel(), FS, 71).unwrap();
    let hits = (0..n).filter(|_| g.next_rate(25.0) != 0.0).count() as u64;
    assert_eq!(hits, g.outlier_count());
    let mean = n as f64 * p_out;
    assert!((hits as f64 - mean).abs() < 5.0 * (mean * (1.0 - p_out)).sqrt());
    // Size in sigma: with N the spike is size_sigma * N sqrt(rate_hz).
    let m2 = GyroSim {
        n_deg_per_rt_s: 0.01,
        outliers: Some(Outliers { per_sample: 1.0, size_sigma: 8.0, ..Default::default() }),
        ..Default::default()
    };
    let with = rates(&m2, 10_000, 3);
    // Every sample carries a spike of 8 x 0.1 deg/s on noise of sd 0.1: mean |rate| = 0.8 within 5 sd (0.005).
    let mean_abs = with.iter().map(|v| v.abs()).sum::<f64>() / with.len() as f64;
    assert!((mean_abs - 0.8).abs() < 0.005, "{mean_abs}");
}

/// The standard normal upper tail (Numerical Recipes' `erfcc`, relative error under 1.2e-7).
fn normal_sf(z: f64) -> f64 {
    let x = z / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.5 * x.abs());
    let poly = -x * x - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98 + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let erfc = t * poly.exp();
    0.5 * if x >= 0.0 { erfc } else { 2.0 - erfc }
}

/// The mean of `f` over `y` and its standard error, the samples' correlation over runs of mean length `run_mean`
/// allowed for by the factor `2 run_mean - 1` on the variance (an AR(1) of pole c has `(1 + c) / (1 - c)`).
fn mean_and_se(y: &[f64], run_mean: f64, f: impl Fn(f64) -> f64) -> (f64, f64) {
    let n = y.len() as f64;
    let (mut s1, mut s2) = (0.0, 0.0);
    for &v in y {
        let u = f(v);
        s1 += u;
        s2 += u * u;
    }
    let m = s1 / n;
    (m, ((s2 / n - m * m) * (2.0 * run_mean - 1.0) / n).sqrt())
}

/// Contamination: spikes on a share f of the samples, magnitudes uniform on c +- w, in runs of mean L (one sign per
/// run; a run of two or more goes on with probability c2). Alone, the process has share f of non-zero samples, `E y^2 = f (c^2 + w^2/3)`, `E y^4 = f (c^4 +
/// 2 c^2 w^2 + w^4/5)` and autocovariance `f rho_k c^2` at lag k, `rho_k = (1 - 1/L) c2^(k-1)`; on unit white noise, the
/// share beyond 5 sds is `(1 - f) 2 Q(5) + f P(|s + g| > 5)`. Each within 5 standard errors (2^21 samples).
#[test]
fn sim_contamination_matches_the_mixtures_closed_form() {
    // Runs of mean 2.5, each spike after the second continuing with probability 0.4: rho_1 = 0.6, rho_2 = 0.24.
    let (f, c, w, run_mean, run_continue): (f64, f64, f64, f64, f64) = (0.1, 6.0, 3.0, 2.5, 0.4);
    let rho = |k: i32| (1.0 - 1.0 / run_mean) * run_continue.powi(k - 1);
    let spikes = Outliers { per_sample: f, size_dps: c, spread_dps: w, run_mean, run_continue, ..Default::default() };
    let model = GyroSim { outliers: Some(spikes), ..Default::default() };
    let n = 1 << 21;
    let y = rates(&model, n, 5);
    let (mu2, mu4) = (c * c + w * w / 3.0, c.powi(4) + 2.0 * c * c * w * w + w.powi(4) / 5.0);
    let check = |what: &str, (got, se): (f64, f64), want: f64| {
        assert!((got - want).abs() < 5.0 * se, "{what}: {got} vs {want} (se {se})");
    };
    check("share", mean_and_se(&y, run_mean, |v| f64::from(u8::from(v != 0.0))), f);
    assert!(y.iter().all(|v| *v == 0.0 || (c - w..=c + w).contains(&v.abs())));
    check("E y^2", mean_and_se(&y, run_mean, |v| v * v), f * mu2);
    check("E y^4", mean_and_se(&y, run_mean, |v| v.powi(4)), f * mu4);
    for lag in [1usize, 2] {
        let prods: Vec<f64> = y.windows(lag + 1).map(|p| p[0] * p[lag]).collect();
        check("autocovariance", mean_and_se(&prods, run_mean, |v| v), f * rho(lag as i32) * c * c);
    }
    // The same process on unit white noise: the tail share beyond 5 sds, by the closed form of a Gaussian
    // convolved with the uniform magnitude law (the mean over s of P(|s + g| > 5), by Simpson's rule).
    let sigma_w = 1.0;
    let noisy = GyroSim { n_deg_per_rt_s: sigma_w / FS.sqrt(), outliers: Some(spikes), ..Default::default() };
    let y = rates(&noisy, n, 6);
    let beyond = |s: f64| normal_sf(5.0 - s) + normal_sf(5.0 + s);
    let k = 200;
    let simpson: f64 = (0..=k)
        .map(|i| {
            let wt = if i == 0 || i == k {
                1.0
            } else if i % 2 == 1 {
                4.0
            } else {
                2.0
            };
            wt * beyond(c - w + 2.0 * w * i as f64 / k as f64)
        })
        .sum::<f64>()
        / (3.0 * k as f64);
    let tail = (1.0 - f) * 2.0 * normal_sf(5.0) + f * simpson;
    check("share beyond 5 sd", mean_and_se(&y, run_mean, |v| f64::from(u8::from(v.abs() > 5.0))), tail);
    let m2 = sigma_w * sigma_w + f * mu2;
    let m4 = 3.0 + 6.0 * f * mu2 + f * mu4;
    check("E y^2 with noise", mean_and_se(&y, run_mean, |v| v * v), m2);
    check("E y^4 with noise", mean_and_se(&y, run_mean, |v| v.powi(4)), m4);
    let kurt = m4 / (m2 * m2) - 3.0;
    assert!(kurt > 5.0, "the mixture is heavy-tailed: excess kurtosis {kurt}");
}

/// A model without spread or runs draws exactly what isolated spikes of one size drew: the same spikes, sample for
/// sample, whether the new fields are absent or zero.
#[test]
fn sim_isolated_spikes_are_unchanged_by_the_mixture_fields() {
    let one = Outliers { per_sample: 1e-3, size_dps: 0.5, ..Default::default() };
    let zero_runs = Outliers { run_mean: 1.0, ..one };
    let a = rates(&GyroSim { outliers: Some(one), ..Default::default() }, 200_000, 9);
    let b = rates(&GyroSim { outliers: Some(zero_runs), ..Default::default() }, 200_000, 9);
    assert_eq!(a, b);
    assert!(a.iter().all(|v| *v == 0.0 || v.abs() == 0.5));
}

#[test]
fn sim_is_deterministic_bit_for_bit() {
    let model = GyroSim {
        bias_dps: 0.1,
        q_deg: 1e-4,
        n_deg_per_rt_s: 0.01,
        b_dps: 0.005,
        k_dps_per_rt_s: 1e-4,
        r_dps_per_s: 1e-5,
        gauss_markov: Some(GaussMarkovSim { sigma_dps: 0.01, tau_s: 3.0 }),
        bandwidth_hz: Some(20.0),
        sinusoids: [Sinusoid { amplitude_dps: 0.02, period_s: 0.5, phase_rad: 0.0 }].into_iter().collect(),
        temperature: Some(TempCoupling { dps_per_c: 0.01, ref_c: 25.0, lag_s: 10.0 }),
        bias_steps: Some(BiasSteps { per_hour: 100.0, sigma_dps: 0.01 }),
        outliers: Some(Outliers { per_sample: 1e-3, size_dps: 0.5, ..Default::default() }),
        resonance: Some(ResonanceSim { sigma_dps: 0.01, freq_hz: 7.0, q: 5.0 }),
        bistable: Some(BistableSim { step_dps: 0.01, dwell_low_s: 2.0, dwell_high_s: 1.0 }),
        warm_up: Some(WarmUpSim { size_dps: 0.05, tau_s: 30.0 }),
    };
    let run = |seed| {
        let mut g = VirtualGyro::new(&model, channel(), FS, seed).unwrap();
        (0..200_000)
            .map(|i| {
                let s = g.next(25.0 + (i % 1000) as f64 * 1e-3);
                (s.rate_dps.to_bits(), s.code, s.clipped)
            })
            .collect::<Vec<_>>()
    };
    let (a, b, c) = (run(7), run(7), run(8));
    assert!(a == b, "same seed must give the same samples");
    let differ = a.iter().zip(&c).filter(|(x, y)| x.0 != y.0).count();
    assert!(differ > 199_000, "another seed must give other samples ({differ} differ)");
    let bench = BenchSim {
        rate_hz: FS,
        seed: 3,
        temperature: TemperatureProfile {
            min_c: 22.0,
            max_c: 25.0,
            wander: Some(octavar_shared::sim::Wander { sigma_c: 0.2, tau_s: 60.0 }),
            ..Default::default()
        },
        channels: [ChannelSim { sensor: SensorKind::Adxrs300, channel: None, gyro: model.clone() }]
            .into_iter()
            .collect(),
    };
    let x: Vec<_> = Bench::new(&bench).unwrap().take(50_000).map(|s| (s.temp_c.to_bits(), s.codes[0])).collect();
    let y: Vec<_> = Bench::new(&bench).unwrap().take(50_000).map(|s| (s.temp_c.to_bits(), s.codes[0])).collect();
    assert!(x == y);
}

#[test]
fn sim_state_is_constant_memory() {
    // Fixed-size state, no heap: the size does not depend on the run length or the decades of flicker.
    let gyro = std::mem::size_of::<VirtualGyro>();
    let bench = std::mem::size_of::<Bench>();
    println!("size_of VirtualGyro = {gyro} B, Bench (8 channels) = {bench} B");
    assert!(gyro <= 1152, "VirtualGyro is {gyro} B");
    // About 1.3 KiB a channel: each carries its model (the outliers' mixture of sizes and runs included).
    assert!(bench <= 11 * 1024, "Bench is {bench} B");
}

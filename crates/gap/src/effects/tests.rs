//! Each estimator on simulated records with its effect injected, and on clean ones.

use rayon::prelude::*;

use super::common::oadev_points;
use super::*;
use octavar_shared::sensor::{Channel, ADXRS300};
use octavar_shared::sim::rng::SimRng;
use octavar_shared::sim::temperature::Thermal;
use octavar_shared::sim::WarmUpSim;
use octavar_shared::sim::{BiasSteps, BistableSim, GaussMarkovSim, Outliers, ResonanceSim, Sinusoid, TempCoupling};
use octavar_shared::sim::{TemperatureProfile, VirtualGyro, Wander};
use octavar_stats::fit::{fit, FitOptions};

/// The analog rate (and the bench temperature) of `model` for `n` samples.
fn simulate(
    model: &GyroSim,
    rate_hz: f64,
    n: usize,
    seed: u64,
    temp: Option<&TemperatureProfile>,
) -> (Vec<f64>, Vec<f64>) {
    let mut g = VirtualGyro::new(model, Channel::bench(ADXRS300), rate_hz, seed).unwrap();
    let mut rng = SimRng::new(seed ^ 0xabcdef);
    let p = temp.copied().unwrap_or_default();
    let mut th = Thermal::new(&p, rate_hz, &mut rng);
    let mut x = Vec::with_capacity(n);
    let mut t = Vec::with_capacity(n);
    for _ in 0..n {
        let tc = th.next(&mut rng);
        x.push(g.next_rate(tc));
        t.push(tc);
    }
    (x, t)
}

/// The base model as the diagnosis makes it: the IEEE fit on the OADEV, identifiable terms, the mean as bias.
fn base_of(x: &[f64], rate_hz: f64) -> (GyroSim, NoiseFit) {
    let pts = oadev_points(x, rate_hz);
    let f = fit(&pts, &FitOptions::default()).unwrap();
    (crate::base_model(&f, x), f)
}

/// The estimators' view of the samples `x` at `rate_hz` on the model `base` fitted as `fit`: the samples as
/// recorded, no gaps, no temperature, an analog rate, nothing taken out before.
fn data_of<'a>(x: &'a [f64], rate_hz: f64, base: &'a GyroSim, fit: &'a NoiseFit) -> TrainingData<'a> {
    TrainingData {
        rate_dps: x,
        recorded_dps: x,
        temp_c: None,
        rate_hz,
        base,
        base_fit: fit,
        gaps: &[],
        lattice_dps: None,
        shaped_dps: None,
    }
}

fn run(effect: Effect, x: &[f64], t: Option<&[f64]>, rate_hz: f64) -> Option<EffectFit> {
    let (g, f) = base_of(x, rate_hz);
    let d = TrainingData { temp_c: t, ..data_of(x, rate_hz, &g, &f) };
    let t0 = std::time::Instant::now();
    let out = fit_effect(effect, &d);
    eprintln!("{effect}: {:?} in {:?}", out.as_ref().map(|e| &e.params), t0.elapsed());
    out
}

/// `n` samples of `m` at `rate_hz` as the channel `ch` records them (its ADC codes back in deg/s, on its lattice), at
/// a steady 25 degC.
pub(crate) fn on_the_bench_lattice(m: &GyroSim, ch: Channel, rate_hz: f64, seed: u64, n: usize) -> Vec<f64> {
    let mut g = VirtualGyro::new(m, ch, rate_hz, seed).unwrap();
    (0..n).map(|_| ch.code_to_dps(g.next(25.0).code)).collect()
}

fn base_model() -> GyroSim {
    GyroSim { n_deg_per_rt_s: 0.01, b_dps: 0.005, k_dps_per_rt_s: 2e-5, ..Default::default() }
}

fn rel(a: f64, b: f64) -> f64 {
    (a / b - 1.0).abs()
}

#[test]
fn names_round_trip() {
    for e in Effect::ALL {
        assert_eq!(Effect::parse(e.name()), Some(e));
    }
    assert_eq!(Effect::parse("Gauss-Markov"), Some(Effect::GaussMarkov));
    assert_eq!(Effect::parse("flicker"), None);
}

#[test]
fn clean_data_has_no_effect() {
    for seed in [1, 2] {
        let rate_hz: f64 = 100.0;
        let temp = TemperatureProfile {
            min_c: 22.0,
            max_c: 25.0,
            period_s: 3600.0,
            wander: Some(Wander { sigma_c: 0.2, tau_s: 600.0 }),
            ..Default::default()
        };
        let (x, t) = simulate(&base_model(), rate_hz, 500_000, seed, Some(&temp));
        let mut alarms = Vec::new();
        for e in Effect::ALL {
            let tc = (e == Effect::Temperature).then_some(&t[..]);
            if let Some(r) = run(e, &x, tc, rate_hz) {
                alarms.push((e, r.params));
            }
        }
        assert!(alarms.is_empty(), "seed {seed}: false alarms {alarms:?}");
    }
}

#[test]
fn temperature_recovers_coefficient_and_lag() {
    let rate_hz = 50.0;
    let temp = TemperatureProfile {
        min_c: 20.0,
        max_c: 30.0,
        period_s: 3600.0,
        wander: Some(Wander { sigma_c: 0.5, tau_s: 600.0 }),
        ..Default::default()
    };
    let m = GyroSim { temperature: Some(TempCoupling { dps_per_c: 0.02, ref_c: 25.0, lag_s: 300.0 }), ..base_model() };
    let (x, t) = simulate(&m, rate_hz, 500_000, 3, Some(&temp));
    let e = run(Effect::Temperature, &x, Some(&t), rate_hz).unwrap();
    let c = e.gyro.temperature.unwrap();
    // Tolerance: 5% on the coefficient, 20% on the lag.
    assert!(rel(c.dps_per_c, 0.02) < 0.05, "{c:?}");
    assert!(rel(c.lag_s, 300.0) < 0.2, "{c:?}");
}

/// A coupling read loosely (t of 3 to 7) over under two cycles of its driver takes the flicker's wander at that
/// period with it: the base terms re-fitted beside it weigh the curve's points by what the fit took
/// ([`common::refit_base`]), and read B nearer the truth than a plain fit on the record less the coupling, on the
/// worst of 24 records.
#[test]
fn a_loose_coupling_leaves_the_flicker_beneath_it() {
    let rate_hz = 50.0;
    let wander = Some(Wander { sigma_c: 0.1, tau_s: 390.0 });
    let temp = TemperatureProfile { min_c: 22.0, max_c: 24.0, period_s: 1550.0, wander, ..Default::default() };
    let truth = 6.5e-3;
    let m = GyroSim {
        n_deg_per_rt_s: 7.2e-3,
        b_dps: truth,
        k_dps_per_rt_s: 6.5e-6,
        temperature: Some(TempCoupling { dps_per_c: 0.0207, ref_c: 23.0, lag_s: 210.0 }),
        ..Default::default()
    };
    let read: Vec<(f64, f64)> = (0..24u64)
        .into_par_iter()
        .filter_map(|seed| {
            let (x, t) = simulate(&m, rate_hz, 135_000, seed, Some(&temp));
            let (g, f) = base_of(&x, rate_hz);
            let d = TrainingData { temp_c: Some(&t), ..data_of(&x, rate_hz, &g, &f) };
            let e = fit_effect(Effect::Temperature, &d)?;
            let c = e.gyro.temperature?;
            let only = GyroSim { temperature: Some(c), ..Default::default() };
            let response = crate::chain::deterministic_part(&only, rate_hz, Some(&t), x.len())?;
            let cleaned: Vec<f64> = x.iter().zip(&response).map(|(a, b)| a - b).collect();
            let plain = common::refit_base(&d, &cleaned, f64::INFINITY)?.0.b_dps;
            Some((e.gyro.b_dps, plain))
        })
        .collect();
    assert!(read.len() >= 20, "the coupling found on {} of 24 records", read.len());
    // The worst of the records: the plain re-fit reads B 18% low on one (the premise), the weighed one within 6%.
    let worst = |pick: fn(&(f64, f64)) -> f64| read.iter().map(|r| (pick(r) / truth).ln().abs()).fold(0.0, f64::max);
    let (weighed, plain) = (worst(|r| r.0), worst(|r| r.1));
    assert!(plain > 0.15, "the plain re-fit's worst |ln(B / truth)| {plain:.3}: the records no longer test this");
    assert!(weighed < 0.1, "worst |ln(B / truth)|: {weighed:.3} (plain {plain:.3})");
}

/// A coupling found where the model's base terms are all zero is kept. A bistable bias read on the Allan curve of
/// a record whose filter corner hides the white noise gives the telegraph every octave and leaves no base term;
/// the base terms' re-fit beside the coupling then has no curve to read (each point held at a tenth of the
/// model's, zero), and the model keeps its base terms as they are.
#[test]
fn a_coupling_is_kept_where_the_models_base_terms_are_all_zero() {
    let (rate_hz, n) = (20.0, 200_000);
    let temp = TemperatureProfile { min_c: 20.0, max_c: 22.0, period_s: 1000.0, ..Default::default() };
    let m = GyroSim { temperature: Some(TempCoupling { dps_per_c: 0.025, ref_c: 21.0, lag_s: 3.0 }), ..base_model() };
    let (x, t) = simulate(&m, rate_hz, n, 5, Some(&temp));
    let levels = telegraph(&mut SimRng::new(5), n, rate_hz, 0.15, [60.0, 30.0]);
    let recorded: Vec<f64> = x.iter().zip(&levels).map(|(x, l)| x + l).collect();
    let (_, f) = base_of(&x, rate_hz);
    let silent = GyroSim::default();
    let d = TrainingData {
        recorded_dps: &recorded,
        shaped_dps: Some(&levels),
        temp_c: Some(&t),
        ..data_of(&x, rate_hz, &silent, &f)
    };
    let e = fit_effect(Effect::Temperature, &d).expect("the coupling is found");
    let c = e.gyro.temperature.unwrap();
    assert!(rel(c.dps_per_c, 0.025) < 0.1, "{c:?}");
}

/// Beside a Gauss-Markov process the model already carries, a coupling's re-fit reads the base terms and the
/// process together on the samples less the coupling ([`common::refit_base`]): the flicker floor, the white noise
/// and the process's variance and time constant come out near the truth on every one of 8 records, where taking
/// the process off the curve at its variance and fitting the IEEE terms to what is left reads a flicker floor of
/// four times the truth out of the difference.
#[test]
fn a_coupling_beside_a_markov_process_re_fits_the_base_terms_with_it() {
    let rate_hz = 6.1;
    let temp = TemperatureProfile { min_c: 21.0, max_c: 25.0, period_s: 6750.0, ..Default::default() };
    let markov = GaussMarkovSim { sigma_dps: 0.046, tau_s: 1.2 };
    let m = GyroSim {
        n_deg_per_rt_s: 5e-3,
        b_dps: 2e-3,
        gauss_markov: Some(markov),
        temperature: Some(TempCoupling { dps_per_c: 0.02, ref_c: 23.0, lag_s: 250.0 }),
        ..Default::default()
    };
    let read: Vec<GyroSim> = (0..8u64)
        .into_par_iter()
        .filter_map(|seed| {
            let (x, t) = simulate(&m, rate_hz, 128_000, seed, Some(&temp));
            let (_, f) = base_of(&x, rate_hz);
            // The model as the process's own step leaves it: the process and the base terms, no coupling.
            let base = GyroSim { temperature: None, bias_dps: common::mean(&x), ..m.clone() };
            let d = TrainingData { temp_c: Some(&t), ..data_of(&x, rate_hz, &base, &f) };
            fit_effect(Effect::Temperature, &d).map(|e| e.gyro)
        })
        .collect();
    assert_eq!(read.len(), 8, "the coupling found on {} of 8 records", read.len());
    for g in &read {
        let (sigma, tau) = g.gauss_markov.map_or((0.0, 0.0), |p| (p.sigma_dps, p.tau_s));
        assert!(rel(sigma, markov.sigma_dps) < 0.1, "{g:?}");
        assert!(rel(tau, markov.tau_s) < 0.3, "{g:?}");
        assert!(rel(g.n_deg_per_rt_s, m.n_deg_per_rt_s) < 0.5, "{g:?}");
        assert!(g.b_dps < 2.0 * m.b_dps, "a flicker floor read out of the process's difference: {g:?}");
    }
}

/// One FFT and the two-neighbour identity give what five tapered FFTs give, on the same grid.
#[test]
fn sine_tapers_from_one_fft_match_the_direct_transforms() {
    let n = 1000;
    let v: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin() + 0.01 * (i as f64) + (i % 7) as f64).collect();
    let nfft = 2 * (n + 1);
    let plan = rustfft::FftPlanner::new().plan_fft_forward(nfft);
    let fast = super::temperature::sine_tapered(&v, 5, &*plan);
    let mu = v.iter().sum::<f64>() / n as f64;
    for (j, w) in super::common::sine_tapers(n, 5).iter().enumerate() {
        let mut re = vec![0.0; nfft];
        let mut im = vec![0.0; nfft];
        for i in 0..n {
            re[i] = (v[i] - mu) * w[i];
        }
        super::common::fft(&mut re, &mut im);
        let scale = re.iter().map(|x| x.abs()).fold(0.0, f64::max);
        for m in 0..=nfft / 2 {
            assert!((fast[j].0[m] - re[m]).abs() < 1e-9 * scale, "taper {j} bin {m}: {} vs {}", fast[j].0[m], re[m]);
            assert!((fast[j].1[m] - im[m]).abs() < 1e-9 * scale, "taper {j} bin {m}: {} vs {}", fast[j].1[m], im[m]);
        }
    }
}

/// The coupling's standard error is the spread it really has: over 40 noise draws of one weak coupling in white
/// noise and flicker (the temperature the same in all), the scatter of the estimates matches the reported
/// `dps_per_c / t_stat` within 25%, and the estimates centre on the truth within 3 of their standard errors of
/// the mean. The one-Hann-taper regression this replaced scattered 1.4 times as much (1.55e-3 against 1.10e-3
/// deg/s/degC here) and reported 0.72 of its scatter: the test fails on it.
#[test]
fn temperature_standard_error_is_the_scatter() {
    let rate_hz = 10.0;
    let temp = TemperatureProfile {
        min_c: 22.0,
        max_c: 24.0,
        period_s: 1200.0,
        wander: Some(Wander { sigma_c: 0.1, tau_s: 300.0 }),
        ..Default::default()
    };
    let k_true = 0.012;
    let m = GyroSim { temperature: Some(TempCoupling { dps_per_c: k_true, ref_c: 23.0, lag_s: 60.0 }), ..base_model() };
    let (_, t) = simulate(&m, rate_hz, 96_000, 1, Some(&temp));
    let draws: Vec<(f64, f64)> = (0..40u64)
        .into_par_iter()
        .map(|seed| {
            let mut g = VirtualGyro::new(&m, Channel::bench(ADXRS300), rate_hz, 100 + seed).unwrap();
            let x: Vec<f64> = t.iter().map(|&tc| g.next_rate(tc)).collect();
            let (b, f) = base_of(&x, rate_hz);
            let d = TrainingData { temp_c: Some(&t), ..data_of(&x, rate_hz, &b, &f) };
            let e = fit_effect(Effect::Temperature, &d).expect("a 10-sigma coupling is found");
            let k = param(&e, "dps_per_c");
            (k, k / param(&e, "t_stat"))
        })
        .collect();
    let n = draws.len() as f64;
    let mean = draws.iter().map(|d| d.0).sum::<f64>() / n;
    let scatter = (draws.iter().map(|d| (d.0 - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    let se = (draws.iter().map(|d| d.1 * d.1).sum::<f64>() / n).sqrt();
    eprintln!("mean {mean:.5} truth {k_true} scatter {scatter:.2e} reported se {se:.2e}");
    assert!((scatter / se - 1.0).abs() < 0.25, "scatter {scatter:.3e}, reported {se:.3e}");
    assert!((mean - k_true).abs() < 3.0 * scatter / n.sqrt(), "mean {mean:.5} against {k_true}");
}

#[test]
fn sinusoids_recovered() {
    let rate_hz = 200.0;
    let mut m = base_model();
    m.sinusoids.push(Sinusoid { amplitude_dps: 0.02, period_s: 7.3, phase_rad: 0.4 }).unwrap();
    m.sinusoids.push(Sinusoid { amplitude_dps: 0.05, period_s: 0.5, phase_rad: -1.0 }).unwrap();
    let (x, _) = simulate(&m, rate_hz, 1 << 20, 4, None);
    let e = run(Effect::Sinusoid, &x, None, rate_hz).unwrap();
    assert_eq!(e.gyro.sinusoids.len(), 2, "{:?}", e.params);
    let s = &e.gyro.sinusoids;
    // Tolerance: 5% on amplitudes, 1e-3 on periods, 0.1 rad on phases.
    assert!(rel(s[0].amplitude_dps, 0.05) < 0.05 && rel(s[0].period_s, 0.5) < 1e-3, "{s:?}");
    assert!(rel(s[1].amplitude_dps, 0.02) < 0.05 && rel(s[1].period_s, 7.3) < 1e-3, "{s:?}");
    assert!((s[0].phase_rad + 1.0).abs() < 0.1 && (s[1].phase_rad - 0.4).abs() < 0.1, "{s:?}");
}

/// A sinusoid of two cycles per record, beyond the periodogram's search (a third of the record and shorter): the
/// least squares finds it, with its amplitude's z under the noise model, and a record without it finds nothing.
#[test]
fn a_sinusoid_of_two_cycles_per_record_is_found() {
    let (rate_hz, n) = (10.0, 1 << 18);
    let record_s = n as f64 / rate_hz;
    let period_s = record_s / 2.1;
    for seed in [5, 6] {
        let mut m = base_model();
        m.sinusoids.push(Sinusoid { amplitude_dps: 0.04, period_s, phase_rad: 1.1 }).unwrap();
        let (x, _) = simulate(&m, rate_hz, n, seed, None);
        let e = run(Effect::Sinusoid, &x, None, rate_hz).expect("the long period is found");
        let EffectParams::Sinusoid(p) = &e.params else { panic!("{:?}", e.params) };
        // Tolerance: four of its own standard errors on the period and the amplitude.
        let one = &p.sinusoids[0];
        assert!((one.period_s - period_s).abs() < 4.0 * one.period_se_s, "seed {seed}: {one:?}");
        assert!((one.amplitude_dps - 0.04).abs() < 4.0 * one.amplitude_se_dps, "seed {seed}: {one:?}");
        assert!(p.amplitude_z > 6.0, "seed {seed}: z {}", p.amplitude_z);
        let (clean, _) = simulate(&base_model(), rate_hz, n, seed, None);
        let none = run(Effect::Sinusoid, &clean, None, rate_hz);
        assert!(none.is_none(), "seed {seed}: found on the clean record: {:?}", none.map(|e| e.params));
    }
}

/// The amplitude's standard error (the spread the ensemble members draw from) against the closed form on white
/// noise, `sqrt(2 / n) sigma`, and against the scatter of the estimates over 16 records of red noise (flicker
/// and random walk, whose leakage through the record's window the Hann background alone missed: on withheld
/// sinusoid 16 it gave 3.1e-4 against a scatter of 4.4e-4 over ten noise draws; the exact form gives 3.7e-4).
#[test]
fn sinusoid_amplitude_standard_error_is_its_scatter() {
    let rate_hz = 50.0;
    let n = 1 << 17;
    let sine = Sinusoid { amplitude_dps: 0.01, period_s: 80.0, phase_rad: 0.3 };
    let se_of = |e: &EffectFit| match &e.spread {
        Some(ParamSpread::Sinusoids { se, .. }) => se[0][0],
        _ => panic!("no sinusoids' spread: {:?}", e.params),
    };
    let mut white = GyroSim { n_deg_per_rt_s: 0.01, ..Default::default() };
    white.sinusoids.push(sine).unwrap();
    let (x, _) = simulate(&white, rate_hz, n, 11, None);
    let closed = (2.0 / n as f64).sqrt() * 0.01 * rate_hz.sqrt();
    let se = se_of(&run(Effect::Sinusoid, &x, None, rate_hz).unwrap());
    assert!(rel(se, closed) < 0.05, "white: se {se:.3e}, closed form {closed:.3e}");
    let mut red = base_model();
    red.sinusoids.push(Sinusoid { amplitude_dps: 0.02, ..sine }).unwrap();
    let fits: Vec<(f64, f64)> = (0..16u64)
        .into_par_iter()
        .map(|seed| {
            let (x, _) = simulate(&red, rate_hz, n, 100 + seed, None);
            let e = run(Effect::Sinusoid, &x, None, rate_hz).unwrap();
            (e.gyro.sinusoids[0].amplitude_dps, se_of(&e))
        })
        .collect();
    let k = fits.len() as f64;
    let mean = fits.iter().map(|f| f.0).sum::<f64>() / k;
    let scatter = (fits.iter().map(|f| (f.0 - mean).powi(2)).sum::<f64>() / (k - 1.0)).sqrt();
    let se = fits.iter().map(|f| f.1).sum::<f64>() / k;
    // 16 draws: the scatter's own sd is 18%.
    eprintln!("scatter {scatter:.3e} against se {se:.3e}");
    assert!(scatter / se > 0.6 && scatter / se < 1.6, "scatter {scatter:.3e} against se {se:.3e}");
}

#[test]
fn long_period_sinusoid_with_decimation() {
    // A day-long period in a 10-day record at 5 Hz (4.3 M samples: the periodogram is block-averaged).
    let rate_hz = 5.0;
    let mut m = base_model();
    m.sinusoids.push(Sinusoid { amplitude_dps: 0.03, period_s: 86_400.0, phase_rad: 1.0 }).unwrap();
    let (x, _) = simulate(&m, rate_hz, 4_320_000, 5, None);
    let e = run(Effect::Sinusoid, &x, None, rate_hz).unwrap();
    let s = e.gyro.sinusoids[0];
    // Flicker (B = 0.005) at 1/day leaves an amplitude error of about 0.0015 deg/s (1 sigma): 15%.
    assert!(rel(s.amplitude_dps, 0.03) < 0.15 && rel(s.period_s, 86_400.0) < 0.02, "{s:?}");
}

#[test]
fn bandwidth_recovered() {
    for (rate_hz, f3) in [(1000.0, 100.0), (1000.0, 20.0)] {
        let m = GyroSim { bandwidth_hz: Some(f3), ..base_model() };
        let (x, _) = simulate(&m, rate_hz, 500_000, 6, None);
        let e = run(Effect::Bandwidth, &x, None, rate_hz).unwrap();
        // Tolerance: 10% on f3dB, 3% on N.
        assert!(rel(e.gyro.bandwidth_hz.unwrap(), f3) < 0.1, "{:?}", e.params);
        assert!(rel(e.gyro.n_deg_per_rt_s, 0.01) < 0.03, "{:?}", e.params);
    }
}

/// The Allan variance of an AR process from its poles ([`super::curve::arma_avar`] and the filtered forms built on
/// it) against a brute-force reference: the impulse response of the recursion as shared::sim runs it (the ARMA(2,1)
/// resonance, the AR(1) Gauss-Markov process, each through the first-order low-pass `y = a y + (1 - a) x`), its
/// autocovariance summed from that response, and `Var(S_2 - S_1) / (2 m^2)` for two adjacent sums of m samples
/// from the autocovariance. Also: one pole is `ar1_avar`, the two poles of a resonance are `resonance_avar`.
#[test]
fn filtered_allan_forms_match_the_impulse_response() {
    use super::curve::*;
    use octavar_shared::sim::noise::ResonanceCoefficients;
    use rustfft::num_complex::Complex64;
    let rate_hz = 200.0;
    let brute = |ar: &[f64], ma: f64, b: f64, lp: Option<f64>, m: usize| -> f64 {
        let len = 40_000;
        let a_lp = lp.map(|f| (-2.0 * std::f64::consts::PI * f / rate_hz).exp());
        let (mut x, mut y) = (vec![0.0; len], vec![0.0; len]);
        for i in 0..len {
            let mut v = match i {
                0 => b,
                1 => b * ma,
                _ => 0.0,
            };
            for (j, c) in ar.iter().enumerate() {
                if i > j {
                    v += c * x[i - 1 - j];
                }
            }
            x[i] = v;
            y[i] = match a_lp {
                Some(a) => (1.0 - a) * v + if i > 0 { a * y[i - 1] } else { 0.0 },
                None => v,
            };
        }
        let gamma = |k: usize| -> f64 { (0..len - k).map(|i| y[i] * y[i + k]).sum() };
        // Weights +1 on m samples then -1 on m: their autocorrelation at lag k.
        let w: Vec<f64> = (0..2 * m).map(|i| if i < m { 1.0 } else { -1.0 }).collect();
        let var: f64 = (0..2 * m)
            .map(|k| {
                let c: f64 = (0..2 * m - k).map(|i| w[i] * w[i + k]).sum();
                if k == 0 {
                    c * gamma(0)
                } else {
                    2.0 * c * gamma(k)
                }
            })
            .sum();
        var / (2.0 * (m * m) as f64)
    };
    for (f0, q, lp) in [(13.7, 7.7, Some(23.2)), (30.0, 3.0, Some(50.0)), (5.0, 20.0, None), (40.0, 2.0, Some(8.0))] {
        let c = ResonanceCoefficients::of(f0, q, 1.0 / rate_hz);
        for m in [1usize, 2, 5, 16, 64] {
            let got = filtered_resonance_avar(f0, q, lp, m as f64, rate_hz);
            let want = brute(&[c.a1, c.a2], c.ma, c.s, lp, m);
            assert!(rel(got, want) < 1e-6, "resonance {f0} Hz Q {q} through {lp:?}, m {m}: {got} vs {want}");
        }
    }
    for (t_s, lp) in [(0.05, Some(10.0)), (0.5, Some(3.0)), (0.02, Some(40.0))] {
        let a = (-1.0 / (rate_hz * t_s)).exp();
        for m in [1usize, 3, 8, 32, 128] {
            let got = filtered_gm_avar(t_s, lp, m as f64 / rate_hz, rate_hz);
            let want = brute(&[a], 0.0, (1.0 - a * a).sqrt(), lp, m);
            assert!(rel(got, want) < 1e-6, "Gauss-Markov T {t_s} through {lp:?}, m {m}: {got} vs {want}");
        }
    }
    for m in [1.0, 7.0, 100.0, 5000.0] {
        let a = 0.93;
        let one = arma_avar(&[Complex64::new(a, 0.0)], 0.0, m) * (1.0 - a * a);
        assert!(rel(one, ar1_avar(a, m)) < 1e-9, "one pole, m {m}");
        let (f0, q) = (12.0, 6.0);
        let two = filtered_resonance_avar(f0, q, Some(1e9), m, rate_hz);
        assert!(rel(two, resonance_avar(f0, q, m, rate_hz)) < 1e-6, "a corner far above the band, m {m}");
    }
}

/// Each of a bandwidth and a resonance inside its band, read with the other already in the model (a later step
/// of the chain, or a backfitting round): the resonance's sd within four of its standard errors and its centre
/// and Q as well, the corner and N within 2%. The simulator passes the resonance through the low-pass, so a bump
/// read on the filtered record without the filter's gain comes out with the gain's share of its power (0.74 at
/// 13.7 Hz under a 23 Hz corner: its sd 15% low), and a corner read against the resonance's unfiltered Allan
/// variance comes out about 4% low with N as much.
#[test]
fn bandwidth_and_resonance_each_read_under_the_other() {
    let rate_hz = 200.0;
    let (f3, f0, q, sigma) = (23.2, 13.7, 7.7, 0.013);
    let res = ResonanceSim { sigma_dps: sigma, freq_hz: f0, q };
    let m = GyroSim {
        n_deg_per_rt_s: 2.0e-3,
        b_dps: 7e-4,
        bandwidth_hz: Some(f3),
        resonance: Some(res),
        ..Default::default()
    };
    for seed in [1, 2] {
        let (x, _) = simulate(&m, rate_hz, 1 << 19, seed, None);
        let (g, f) = base_of(&x, rate_hz);
        let with_bw = GyroSim { bandwidth_hz: Some(f3), ..g.clone() };
        let d = data_of(&x, rate_hz, &with_bw, &f);
        let e = fit_effect(Effect::Resonance, &d).expect("the resonance under the filter is found");
        for (key, se, truth) in [("sigma_dps", "sigma_se_dps", sigma), ("freq_hz", "freq_se_hz", f0), ("q", "q_se", q)]
        {
            assert!(within_se(&e, key, se, truth, 4.0), "seed {seed}: {key} in {:?}", e.params);
        }
        let with_res = GyroSim { resonance: Some(res), ..g };
        let d = TrainingData { base: &with_res, ..d };
        let e = fit_effect(Effect::Bandwidth, &d).expect("the filter over the resonance is found");
        eprintln!("BW {:?}", e.params);
        assert!(rel(e.gyro.bandwidth_hz.unwrap(), f3) < 0.05, "seed {seed}: {:?}", e.params);
    }
}

/// `n` samples at `rate_hz` of a telegraph between 0 and `step`, written out apart from the simulator: it starts low
/// and flips with probability `dt / dwell` per sample, `dwells_s` the mean dwells `[low, high]`.
fn telegraph(rng: &mut SimRng, n: usize, rate_hz: f64, step: f64, dwells_s: [f64; 2]) -> Vec<f64> {
    let mut high = false;
    (0..n)
        .map(|_| {
            if rng.uniform() < 1.0 / (dwells_s[usize::from(high)] * rate_hz) {
                high = !high;
            }
            if high {
                step
            } else {
                0.0
            }
        })
        .collect()
}

/// A bistable bias that reached the output through the sensor's filter, taken out sharp by an earlier step: the
/// record (written out here: white noise and a telegraph of exponential dwells, through `y = a y + (1 - a) x`) less
/// the sharp telegraph keeps the filtered edges' residue, a high-passed telegraph that fills the roll-off in. With
/// the telegraph as `shaped_dps`, each corner is tried on the record less the telegraph through it, and the corner
/// comes back; without, it does not (the premise, checked).
#[test]
fn bandwidth_read_under_bias_jumps_taken_out_sharp() {
    let (rate_hz, f3, n) = (100.0, 4.0, 1 << 19);
    let a = (-2.0 * std::f64::consts::PI * f3 / rate_hz).exp();
    for seed in [3, 4] {
        let mut rng = SimRng::new(seed);
        // Jumps of 20 sigma, dwells of 0.5 s low and 1.5 s high.
        let telegraph = telegraph(&mut rng, n, rate_hz, 2.0, [0.5, 1.5]);
        let mut y = 0.0;
        let mut x = Vec::with_capacity(n);
        for (i, level) in telegraph.iter().enumerate() {
            let v = 0.1 * rng.normal() + level;
            y = if i == 0 { v } else { a * y + (1.0 - a) * v };
            x.push(y);
        }
        let less: Vec<f64> = x.iter().zip(&telegraph).map(|(x, t)| x - t).collect();
        let (g, f) = base_of(&less, rate_hz);
        let d = TrainingData { recorded_dps: &x, shaped_dps: Some(&telegraph), ..data_of(&less, rate_hz, &g, &f) };
        let e = fit_effect(Effect::Bandwidth, &d).expect("the filter is found");
        assert!(rel(e.gyro.bandwidth_hz.unwrap(), f3) < 0.1, "seed {seed}: {:?}", e.params);
        let sharp = fit_effect(Effect::Bandwidth, &TrainingData { shaped_dps: None, ..d });
        let corner = sharp.and_then(|e| e.gyro.bandwidth_hz);
        eprintln!("seed {seed}: corner {:?} through the filter, {corner:?} taken out sharp", e.gyro.bandwidth_hz);
        assert!(
            corner.is_none_or(|c| rel(c, f3) > 0.3),
            "seed {seed}: the sharp residue left the corner at {corner:?}"
        );
    }
}

/// Jumps a scan placed late on a filtered record (the middle of a filtered edge comes the filter's delay after the
/// jump) are placed back at their own samples through the filter: the record less them through it is the filtered
/// white noise again, sample for sample, and the corner's fit reads N as it would from the noise alone. The premise,
/// checked: the record less the late jumps through the filter carries a filtered pulse at each jump, which raises
/// its Allan variance at tau0 by more than a tenth (the corner's fit then read N high and the ensemble's telegraph
/// flips drowned in noise the record does not have).
#[test]
fn jumps_taken_out_late_are_placed_back_through_the_filter() {
    let (rate_hz, f3, n, sigma) = (15.0, 0.8, 1 << 18, 0.02);
    let a = (-2.0 * std::f64::consts::PI * f3 / rate_hz).exp();
    for seed in [5, 6] {
        let mut rng = SimRng::new(seed);
        // Flips of 0.14 deg/s, 17 filtered-noise sds, dwells of 60 s low and 30 s high: about 400 of them.
        let telegraph = telegraph(&mut rng, n, rate_hz, 0.14, [60.0, 30.0]);
        let (mut y, mut w) = (0.0, 0.0);
        let mut x = Vec::with_capacity(n);
        let mut noise = Vec::with_capacity(n);
        // A bias of 0.3 deg/s, as the sensor's: the jumps' places do not hang on the record's level.
        for (i, level) in telegraph.iter().enumerate() {
            let v = 0.3 + sigma * rng.normal();
            y = if i == 0 { v + level } else { a * y + (1.0 - a) * (v + level) };
            w = if i == 0 { v } else { a * w + (1.0 - a) * v };
            x.push(y);
            noise.push(w);
        }
        let late: Vec<f64> = (0..n).map(|i| telegraph[i.saturating_sub(2)]).collect();
        let less: Vec<f64> = x.iter().zip(&late).map(|(x, t)| x - t).collect();
        let placed = super::common::jumps_placed_through_filter(&less, &late, f3, rate_hz);
        // Every jump at least a filter's reach (16 samples) from its neighbours is back at its own sample; an
        // excursion of a sample or two, which no scan sees, may be placed a sample off.
        let edges = |v: &[f64]| -> Vec<usize> { (1..n).filter(|&i| (v[i] - v[i - 1]).abs() > 1e-12).collect() };
        let (truth, back) = (edges(&telegraph), edges(&placed));
        let lone: Vec<usize> = (0..truth.len())
            .filter(|&k| {
                (k == 0 || truth[k] - truth[k - 1] > 16) && truth.get(k + 1).is_none_or(|&e| e - truth[k] > 16)
            })
            .map(|k| truth[k])
            .collect();
        assert!(lone.len() > 300, "seed {seed}: {} jumps", lone.len());
        let missed: Vec<usize> = lone.iter().copied().filter(|e| back.binary_search(e).is_err()).collect();
        assert!(missed.is_empty(), "seed {seed}: jumps not placed back at {missed:?}");
        // The filtered noise again, but for the start-up and that short excursion's samples.
        let out = jumps_through_filter(&less, &late, f3, rate_hz);
        let off = out.iter().zip(&noise).skip(64).filter(|(b, w)| (*b - *w).abs() > 1e-9).count();
        assert!(off < 100, "seed {seed}: {off} samples off the filtered noise");
        let mut lp = octavar_shared::sim::noise::LowPass::new(f3, rate_hz);
        let unplaced: Vec<f64> = less.iter().zip(&late).map(|(v, s)| v + s - lp.next(*s)).collect();
        let avar0 = |v: &[f64]| oadev_points(v, rate_hz)[0].avar;
        assert!(avar0(&unplaced) > 1.1 * avar0(&noise), "seed {seed}: the premise");
        let (g, f) = base_of(&less, rate_hz);
        let d = TrainingData { recorded_dps: &x, shaped_dps: Some(&late), ..data_of(&less, rate_hz, &g, &f) };
        let e = fit_effect(Effect::Bandwidth, &d).expect("the filter is found");
        let n_true = sigma / rate_hz.sqrt();
        assert!(rel(e.gyro.n_deg_per_rt_s, n_true) < 0.05, "seed {seed}: {:?}", e.params);
        assert!(rel(e.gyro.bandwidth_hz.unwrap(), f3) < 0.1, "seed {seed}: {:?}", e.params);
    }
}

#[test]
fn gauss_markov_recovered() {
    // The slow process at 0.008 deg/s: its hump stands clear of the base model's flicker floor (0.0033 deg/s) on
    // every seed; at half that it is found on about two seeds in five, as the flicker's scatter allows.
    for (rate_hz, sigma, t) in [(100.0, 0.02, 2.0), (10.0, 0.008, 300.0)] {
        let m = GyroSim { gauss_markov: Some(GaussMarkovSim { sigma_dps: sigma, tau_s: t }), ..base_model() };
        let (x, _) = simulate(&m, rate_hz, 1_000_000, 7, None);
        let e = run(Effect::GaussMarkov, &x, None, rate_hz).unwrap();
        let g = e.gyro.gauss_markov.unwrap();
        // Tolerance: 25% on sigma, a factor 1.5 on T (the hump's position on an octave grid).
        assert!(rel(g.sigma_dps, sigma) < 0.25, "{g:?}");
        assert!((g.tau_s / t).ln().abs() < 1.5f64.ln(), "{g:?}");
    }
}

/// The premise of [`crate::rank::ONE_FREEDOM_CHI2`]: on white noise through a corner a few samples long, a
/// Gauss-Markov process follows the Allan curve as the corner does (the process is that filtered noise); on a
/// process beside white noise of its own, the process follows it far better.
#[test]
fn a_markov_process_follows_a_corners_curve_no_better_than_the_corner() {
    let fall = |e: &EffectFit| match &e.params {
        params::EffectParams::GaussMarkov(p) => p.delta_chi2,
        params::EffectParams::Bandwidth(p) => p.delta_chi2,
        _ => unreachable!(),
    };
    let falls = |m: &GyroSim, rate_hz: f64| {
        let (x, _) = simulate(m, rate_hz, 400_000, 11, None);
        let markov = run(Effect::GaussMarkov, &x, None, rate_hz).unwrap();
        let corner = run(Effect::Bandwidth, &x, None, rate_hz).unwrap();
        (fall(&markov), fall(&corner))
    };
    let one = crate::rank::ONE_FREEDOM_CHI2;
    // A corner of 2.2 samples' time constant.
    let (markov, corner) = falls(&GyroSim { bandwidth_hz: Some(10.6), ..base_model() }, 148.0);
    assert!(corner > 100.0 && markov < corner + one, "corner's record: process {markov}, corner {corner}");
    // A process of 20 samples.
    let m = GyroSim { gauss_markov: Some(GaussMarkovSim { sigma_dps: 0.02, tau_s: 1.0 }), ..base_model() };
    let (markov, corner) = falls(&m, 20.0);
    assert!(markov > corner + 10.0 * one, "process's record: process {markov}, corner {corner}");
}

/// White noise through a corner whose time constant is under a sample (1.07 Hz at 6.1 Hz) is a process faster than
/// the Gauss-Markov search's floor of two samples: the best time constant is that floor, and no process is read,
/// where a corner is. A process of seven samples beside the same noise is read inside the search.
#[test]
fn a_process_faster_than_two_samples_is_not_read() {
    let rate_hz = 6.1;
    let fast = GyroSim { n_deg_per_rt_s: 3.4e-3, b_dps: 2.5e-3, bandwidth_hz: Some(1.07), ..Default::default() };
    (0..4u64).into_par_iter().for_each(|seed| {
        let (x, _) = simulate(&fast, rate_hz, 128_000, seed, None);
        assert!(run(Effect::Bandwidth, &x, None, rate_hz).is_some(), "seed {seed}: the corner is read");
        let markov = run(Effect::GaussMarkov, &x, None, rate_hz);
        assert!(markov.is_none(), "seed {seed}: {:?}", markov.map(|e| e.params));
        let (x, _) = simulate(&markov_of_seven_samples(None), rate_hz, 128_000, seed, None);
        let g = run(Effect::GaussMarkov, &x, None, rate_hz).and_then(|e| e.gyro.gauss_markov);
        assert!(g.is_some_and(|g| (g.tau_s / 1.2).ln().abs() < 1.5f64.ln()), "seed {seed}: {g:?}");
    });
}

/// White noise, flicker and a Gauss-Markov process of seven samples at 6.1 Hz, through `bandwidth_hz`.
fn markov_of_seven_samples(bandwidth_hz: Option<f64>) -> GyroSim {
    GyroSim {
        n_deg_per_rt_s: 3.4e-3,
        b_dps: 2.5e-3,
        bandwidth_hz,
        gauss_markov: Some(GaussMarkovSim { sigma_dps: 0.046, tau_s: 1.2 }),
        ..Default::default()
    }
}

/// The bandwidth candidate on `x`, read on the model the Gauss-Markov process's own step fits to it, as the chain
/// reads it after that step.
fn corner_beside_the_markov_step(x: &[f64], rate_hz: f64) -> Option<EffectFit> {
    let (g, f) = base_of(x, rate_hz);
    let markov = fit_effect(Effect::GaussMarkov, &data_of(x, rate_hz, &g, &f)).expect("the process");
    let d = TrainingData { base: &markov.gyro, ..data_of(x, rate_hz, &g, &f) };
    fit_effect(Effect::Bandwidth, &d)
}

/// A filter corner read on a model that carries a Gauss-Markov process and no corner: the process is fitted
/// beside each corner tried, so the curve's chi-square falls only by what a corner adds, below the corner's own
/// test ([`crate::evidence`]) on every record; the process's variance stays in the model.
#[test]
fn no_corner_is_read_beside_a_markov_process_that_has_none() {
    let rate_hz = 6.1;
    let m = markov_of_seven_samples(None);
    let falls: Vec<f64> = (0..6u64)
        .into_par_iter()
        .map(|seed| {
            let (x, _) = simulate(&m, rate_hz, 128_000, seed, None);
            match corner_beside_the_markov_step(&x, rate_hz) {
                Some(e) => {
                    assert!(e.gyro.gauss_markov.is_some_and(|p| p.sigma_dps > 0.0), "seed {seed}: {:?}", e.gyro);
                    match e.params {
                        params::EffectParams::Bandwidth(p) => p.delta_chi2,
                        _ => unreachable!(),
                    }
                }
                None => 0.0,
            }
        })
        .collect();
    let test = crate::evidence::threshold(Effect::Bandwidth).unwrap();
    assert!(falls.iter().all(|&v| v < test), "the corner's falls beside the process: {falls:?}");
}

/// A filter corner at 0.18 of the rate beside a Gauss-Markov process of seven samples, read on a model that
/// carries the process as its own step read it: that step reads the process's time constant with part of the
/// corner's roll-off in it (1.4 s for 1.2 s on the sweep's record of this draw), so held there the corner has
/// little left to explain; searched beside each corner, the corner is found, within 30% (the curve's first octave
/// alone bends), on every seed.
#[test]
fn a_corner_is_read_beside_a_markov_process_whose_time_constant_took_part_of_it() {
    let rate_hz = 6.1;
    let f3 = 1.07;
    let m = markov_of_seven_samples(Some(f3));
    let read: Vec<Option<f64>> = (0..6u64)
        .into_par_iter()
        .map(|seed| {
            let (x, _) = simulate(&m, rate_hz, 128_000, seed, None);
            corner_beside_the_markov_step(&x, rate_hz).and_then(|e| e.gyro.bandwidth_hz)
        })
        .collect();
    assert!(read.iter().all(|r| r.is_some_and(|b| rel(b, f3) < 0.3)), "the corners read: {read:?}");
}

/// The mirror of the test above: the corner's step first, then the process on the model it left. The base fit
/// reads these short taus as flicker with no white noise of its own, and white noise through a low corner is a
/// Gauss-Markov process: the corner step reads white noise and process together as one corner a tenth of the
/// sensor's (0.105 Hz for 1.07 Hz on every seed here, 0.11 Hz on the independent generator's record of this
/// draw). Under that corner the process's fit holds its time constant at the search's lower bound (four seeds of
/// six) or fails; with the corner searched beside it, the process comes back within 25% in sigma and T and the
/// corner within 30%, on every seed.
#[test]
fn a_markov_process_is_read_beside_a_corner_step_that_took_it_for_the_filter() {
    let rate_hz = 6.1;
    let f3 = 1.07;
    let m = markov_of_seven_samples(Some(f3));
    let read: Vec<(u64, Option<f64>, Option<GyroSim>)> = (0..6u64)
        .into_par_iter()
        .map(|seed| {
            let (x, _) = simulate(&m, rate_hz, 128_000, seed, None);
            let (g, f) = base_of(&x, rate_hz);
            let corner = fit_effect(Effect::Bandwidth, &data_of(&x, rate_hz, &g, &f)).expect("a corner");
            let base = corner.gyro.clone();
            let markov = fit_effect(Effect::GaussMarkov, &TrainingData { base: &base, ..data_of(&x, rate_hz, &g, &f) });
            (seed, base.bandwidth_hz, markov.map(|e| e.gyro))
        })
        .collect();
    for (seed, step, got) in &read {
        // The premise: the corner step took the process for the filter.
        assert!(step.is_some_and(|c| c < 0.3 * f3), "seed {seed}: the corner step read {step:?}");
        let got = got.as_ref().unwrap_or_else(|| panic!("seed {seed}: no process beside the corner step's"));
        let p = got.gauss_markov.expect("the process");
        assert!(rel(p.sigma_dps, 0.046) < 0.25 && rel(p.tau_s, 1.2) < 0.25, "seed {seed}: {p:?}");
        let corner = got.bandwidth_hz.expect("a corner");
        assert!(rel(corner, f3) < 0.3, "seed {seed}: corner {corner}");
    }
}

/// `n` samples of the ADXRS300 bench channel's codes at 500 Hz, as deg/s, with its step `q`, the model and the
/// rate: half a step of white noise, and a random walk that moves the offset over a few steps (the inversion of
/// the quantised variance assumes the offset wanders over the lattice).
fn quantized(n: usize, seed: u64) -> (Vec<f64>, f64, GyroSim, f64) {
    let ch = Channel::bench(ADXRS300);
    let q = ch.dps_per_code();
    let rate_hz: f64 = 500.0;
    let m =
        GyroSim { n_deg_per_rt_s: 0.5 * q / rate_hz.sqrt(), k_dps_per_rt_s: 0.01, bias_dps: 0.1, ..Default::default() };
    let mut g = VirtualGyro::new(&m, ch, rate_hz, seed).unwrap();
    let x = (0..n).map(|_| ch.code_to_dps(g.next(25.0).code)).collect();
    (x, q, m, rate_hz)
}

/// A resonance read after a coarse ADC lattice: its base re-fit leaves the rounding's white noise to the
/// lattice the model already carries, and reads the analog N (the record's own white noise is 15% above it).
#[test]
fn a_resonance_read_on_a_lattice_leaves_its_rounding_to_it() {
    let ch = Channel::bench(ADXRS300);
    let q = ch.dps_per_code();
    let rate_hz: f64 = 500.0;
    let n_true = 0.5 * q / rate_hz.sqrt();
    let m = GyroSim {
        n_deg_per_rt_s: n_true,
        k_dps_per_rt_s: 0.01,
        bias_dps: 0.1,
        resonance: Some(ResonanceSim { sigma_dps: 1.5 * q, freq_hz: 20.0, q: 10.0 }),
        ..Default::default()
    };
    let x = on_the_bench_lattice(&m, ch, rate_hz, 4, 400_000);
    let (b, f) = base_of(&x, rate_hz);
    let lattice = fit_effect(Effect::Quantization, &data_of(&x, rate_hz, &b, &f)).expect("the lattice");
    let on_lattice = TrainingData { base: &lattice.gyro, lattice_dps: Some(q), ..data_of(&x, rate_hz, &b, &f) };
    let n_of = |d: &TrainingData| fit_effect(Effect::Resonance, d).expect("the resonance").gyro.n_deg_per_rt_s;
    let plain = n_of(&TrainingData { lattice_dps: None, ..on_lattice });
    assert!(plain > 1.1 * n_true, "premise: the record's white noise {plain:.3e} is the analog N {n_true:.3e}");
    let read = n_of(&on_lattice);
    assert!(rel(read, n_true) < 0.07, "N {read:.3e} for {n_true:.3e} (the record's: {plain:.3e})");
}

/// A filter corner read on a coarse ADC lattice: white noise through a corner at a tenth of the rate, rounded to a
/// step of twice its filtered sd, so the rounded record moves a whole step at a time. The lattice's share of the
/// curve is taken off over the analog terms read at each corner tried: the corner comes out within 5% and N
/// within 5% (0.6% and 2% at three seeds). Taken as nothing (the record's white noise its own), the same curve puts
/// the corner at least 20% off (26-28% high at those seeds), or finds none.
#[test]
fn a_corner_read_on_a_lattice_leaves_its_rounding_to_it() {
    let ch = Channel::bench(ADXRS300);
    let q = ch.dps_per_code();
    let (rate_hz, f3db) = (200.0f64, 20.0);
    // The filtered white noise's sd is N sqrt(rate) times sqrt((1 - a) / (1 + a)), a the low-pass pole.
    let a = (-2.0 * std::f64::consts::PI * f3db / rate_hz).exp();
    let n_true = 0.5 * q / (rate_hz.sqrt() * ((1.0 - a) / (1.0 + a)).sqrt());
    let m = GyroSim {
        n_deg_per_rt_s: n_true,
        k_dps_per_rt_s: 1e-3,
        bias_dps: 0.1,
        bandwidth_hz: Some(f3db),
        ..Default::default()
    };
    let x = on_the_bench_lattice(&m, ch, rate_hz, 6, 600_000);
    let (b, f) = base_of(&x, rate_hz);
    let lattice = fit_effect(Effect::Quantization, &data_of(&x, rate_hz, &b, &f)).expect("the lattice");
    let on_lattice = TrainingData { base: &lattice.gyro, lattice_dps: Some(q), ..data_of(&x, rate_hz, &b, &f) };
    let corner = |d: &TrainingData| {
        fit_effect(Effect::Bandwidth, d).map(|e| (e.gyro.bandwidth_hz.unwrap(), e.gyro.n_deg_per_rt_s))
    };
    let plain = corner(&TrainingData { lattice_dps: None, ..on_lattice });
    assert!(plain.is_none_or(|(fc, _)| rel(fc, f3db) > 0.2), "premise: the white form misreads the corner {plain:?}");
    let (fc, n) = corner(&on_lattice).expect("the corner");
    assert!(rel(fc, f3db) < 0.05, "corner {fc:.2} Hz for {f3db} Hz");
    assert!(rel(n, n_true) < 0.05, "N {n:.3e} for {n_true:.3e}");
}

#[test]
fn quantization_recovered() {
    let (x, q, m, rate_hz) = quantized(1_000_000, 8);
    let e = run(Effect::Quantization, &x, None, rate_hz).unwrap();
    assert!(rel(param(&e, "step_dps"), q) < 1e-6, "{:?}", e.params);
    // The channel puts codes on the data's lattice.
    let c = e.channel.unwrap();
    for &v in x.iter().take(100) {
        assert!((c.code_to_dps(c.dps_to_code(v)) - v).abs() < 1e-6 * q);
    }
    // The analog N is recovered within 15% from the quantised white noise.
    assert!(rel(e.gyro.n_deg_per_rt_s, m.n_deg_per_rt_s) < 0.15, "{:?}", e.params);
}

/// A lattice is read from the samples as recorded, not from what an earlier step left: once a bias step of a
/// third of a step is taken out of half the record, the values are off the lattice, and the lattice is still
/// found, with N from the step's own samples.
#[test]
fn quantization_read_on_the_recorded_samples() {
    let (recorded, q, m, rate_hz) = quantized(400_000, 9);
    let left: Vec<f64> = recorded.iter().enumerate().map(|(i, v)| if i < 200_000 { *v } else { v - q / 3.0 }).collect();
    assert!(super::quantization::lattice(&left).is_none_or(|(step, _)| rel(step, q) > 0.01), "premise: a lattice left");
    let (b, f) = base_of(&left, rate_hz);
    let d = TrainingData { recorded_dps: &recorded, ..data_of(&left, rate_hz, &b, &f) };
    let e = fit_effect(Effect::Quantization, &d).expect("the lattice of the recorded samples");
    assert!(rel(param(&e, "step_dps"), q) < 1e-6, "{:?}", e.params);
    assert!(rel(e.gyro.n_deg_per_rt_s, m.n_deg_per_rt_s) < 0.15, "{:?}", e.params);
}

#[test]
fn bias_steps_recovered() {
    let rate_hz: f64 = 100.0;
    let m = GyroSim { bias_steps: Some(BiasSteps { per_hour: 2.0, sigma_dps: 0.05 }), ..base_model() };
    let (x, _) = simulate(&m, rate_hz, 2_000_000, 9, None);
    let e = run(Effect::BiasSteps, &x, None, rate_hz).unwrap();
    let b = e.gyro.bias_steps.unwrap();
    // 11 expected steps in 5.6 h: Poisson and a handful of sizes, so factor-2 tolerances.
    assert!((b.per_hour / 2.0).ln().abs() < 2f64.ln() && (b.sigma_dps / 0.05).ln().abs() < 2f64.ln(), "{b:?}");
}

/// Bias steps found beside a bistable bias that an earlier step took out a sample late at each flip (the recovery's
/// residue: a one-sample pulse of the telegraph's step at every flip). The model the chain carries there was fitted
/// beside the telegraph on the curve as recorded, so its rate random walk is the steps' walk (`K^2 = lambda
/// sigma^2`). The steps' base keeps the white noise and quantisation it was given and takes the walk out of K: an
/// IEEE re-fit of the samples less both reads the residue's pulses as quantisation noise, and the model then
/// parts from the record at the shortest taus, where steps change nothing.
#[test]
fn bias_steps_beside_a_telegraph_taken_out_keep_the_white_noise() {
    let (rate_hz, n) = (100.0, 1 << 20);
    let (white_sd, per_hour, sigma) = (0.1, 60.0, 1.0);
    let mut rng = SimRng::new(17);
    // Telegraph steps of 20 sample sds, dwells 2 s low and 6 s high; bias steps of 10 sds, 60 an hour.
    let telegraph = telegraph(&mut rng, n, rate_hz, 2.0, [2.0, 6.0]);
    let mut bias = 0.0;
    let mut x = Vec::with_capacity(n);
    for level in &telegraph {
        if rng.uniform() < per_hour / 3600.0 / rate_hz {
            bias += sigma * rng.normal();
        }
        x.push(level + bias + white_sd * rng.normal());
    }
    // Taken out a sample late: the level before each flip held one sample too long.
    let late: Vec<f64> = (0..n).map(|i| telegraph[i.saturating_sub(1)]).collect();
    let less: Vec<f64> = x.iter().zip(&late).map(|(x, t)| x - t).collect();
    let n_white = white_sd / rate_hz.sqrt();
    let walk = per_hour / 3600.0 * sigma * sigma;
    let base = GyroSim { n_deg_per_rt_s: n_white, k_dps_per_rt_s: walk.sqrt(), ..Default::default() };
    let f = fit(&oadev_points(&less, rate_hz), &FitOptions::default()).unwrap();
    let d = TrainingData { recorded_dps: &x, shaped_dps: Some(&late), ..data_of(&less, rate_hz, &base, &f) };
    let e = fit_effect(Effect::BiasSteps, &d).expect("the steps are found");
    let g = &e.gyro;
    let b = g.bias_steps.as_ref().unwrap();
    eprintln!("{b:?}: N {:.4e} Q {:.3e} K {:.3e}", g.n_deg_per_rt_s, g.q_deg, g.k_dps_per_rt_s);
    assert!(rel(b.per_hour * b.sigma_dps * b.sigma_dps / 3600.0, walk) < 0.5, "{b:?}");
    assert!(rel(g.n_deg_per_rt_s, n_white) < 0.05 && g.q_deg == 0.0, "N {} Q {}", g.n_deg_per_rt_s, g.q_deg);
    assert!(g.k_dps_per_rt_s < 0.5 * walk.sqrt(), "K {} against the walk's {}", g.k_dps_per_rt_s, walk.sqrt());
}

/// Spikes found beside a bistable bias that an earlier step took out. The model the chain carries there was
/// fitted beside the telegraph on the curve as recorded: its white noise holds the spikes' too, and the telegraph's
/// ensemble draws the whole telegraph. The samples less the recovered levels keep what the recovery missed (here
/// the step read a tenth small, and every flip placed a sample late: a pulse of the step's size, more of them than
/// spikes), which a re-fit of their curve reads as flicker the model then draws beside the telegraph, and which
/// the spikes' law would take for spikes. So the samples beside each flip are left aside, and the spikes' base is
/// the model's own curve less the spikes' law: the white noise of the samples, no flicker. Spikes of 40 sample
/// sds on 1 sample in 2,000, telegraph steps of 6 sds, a flip every 1,250 samples on average.
#[test]
fn spikes_beside_a_telegraph_taken_out_keep_the_models_base() {
    let (rate_hz, n) = (10.0, 1 << 19);
    let (white_sd, eps, size, step) = (0.1, 5e-4, 4.0, 0.6);
    let mut rng = SimRng::new(19);
    let telegraph = telegraph(&mut rng, n, rate_hz, step, [50.0, 200.0]);
    let x: Vec<f64> = telegraph
        .iter()
        .map(|level| {
            let spike = if rng.uniform() < eps { size * if rng.uniform() < 0.5 { -1.0 } else { 1.0 } } else { 0.0 };
            level + spike + white_sd * rng.normal()
        })
        .collect();
    let recovered: Vec<f64> = (0..n).map(|i| 0.9 * telegraph[i.saturating_sub(1)]).collect();
    let less: Vec<f64> = x.iter().zip(&recovered).map(|(x, t)| x - t).collect();
    let n_white = white_sd / rate_hz.sqrt();
    let n_with_spikes = ((white_sd * white_sd + eps * size * size) / rate_hz).sqrt();
    let base = GyroSim { n_deg_per_rt_s: n_with_spikes, ..Default::default() };
    let f = fit(&oadev_points(&less, rate_hz), &FitOptions::default()).unwrap();
    let d = TrainingData { recorded_dps: &x, shaped_dps: Some(&recovered), ..data_of(&less, rate_hz, &base, &f) };
    let e = fit_effect(Effect::Outliers, &d).expect("the spikes are found");
    let (g, o) = (&e.gyro, e.gyro.outliers.as_ref().unwrap());
    eprintln!(
        "{o:?}: N {:.4e} (truth {n_white:.4e}) B {:.3e} K {:.3e} Q {:.3e}",
        g.n_deg_per_rt_s, g.b_dps, g.k_dps_per_rt_s, g.q_deg
    );
    assert!(rel(o.size_dps, size) < 0.1 && rel(o.per_sample, eps) < 0.2, "{o:?}");
    assert!(rel(g.n_deg_per_rt_s, n_white) < 0.05, "N {} (truth {n_white})", g.n_deg_per_rt_s);
    assert!(
        g.b_dps == 0.0 && g.k_dps_per_rt_s == 0.0 && g.q_deg == 0.0,
        "B {} K {} Q {}",
        g.b_dps,
        g.k_dps_per_rt_s,
        g.q_deg
    );
}

/// A bistable bias's excursions too short for its scan (a sample at the other level, the telegraph's step towards
/// it) are left in the samples less the recovered levels: sixteen of them are not a spike process, though they
/// stand eight sds out (the premise, checked: without the levels the same samples read as one). Spikes of either sign
/// beside them are still read, their size within a tenth and their share within a fifth, those of the step's own
/// size too (they stand a step away from the other level as often as towards it).
#[test]
fn a_telegraphs_short_excursions_are_not_spikes() {
    let (rate_hz, n) = (10.0, 1 << 19);
    let (white_sd, step) = (0.1, 0.8);
    for (seed, eps, size) in [(23, 0.0, 0.0), (24, 0.0, 0.0), (25, 5e-4, 4.0), (26, 5e-4, step)] {
        let mut rng = SimRng::new(seed);
        let levels = telegraph(&mut rng, n, rate_hz, step, [50.0, 200.0]);
        let mut x: Vec<f64> = levels.iter().map(|l| l + white_sd * rng.normal()).collect();
        let mut put = 0;
        while put < 16 {
            let i = 10 + (rng.uniform() * (n - 20) as f64) as usize;
            if levels[i - 4..=i + 4].iter().all(|&l| l == levels[i]) {
                x[i] += if levels[i] == 0.0 { step } else { -step };
                put += 1;
            }
        }
        let mut spikes = 0;
        for v in x.iter_mut() {
            if rng.uniform() < eps {
                *v += size * rng.sign();
                spikes += 1;
            }
        }
        let less: Vec<f64> = x.iter().zip(&levels).map(|(x, l)| x - l).collect();
        let base = GyroSim { n_deg_per_rt_s: white_sd / rate_hz.sqrt(), ..Default::default() };
        let f = fit(&oadev_points(&less, rate_hz), &FitOptions::default()).unwrap();
        let d = TrainingData { recorded_dps: &x, shaped_dps: Some(&levels), ..data_of(&less, rate_hz, &base, &f) };
        let e = fit_effect(Effect::Outliers, &d);
        if eps == 0.0 {
            assert!(e.is_none(), "seed {seed}: excursions read as spikes: {:?}", e.map(|e| e.params));
            let premise = fit_effect(Effect::Outliers, &TrainingData { shaped_dps: None, ..d });
            assert!(premise.is_some(), "seed {seed}: premise: the excursions alone are no spike process");
        } else {
            let o = e.expect("the spikes are found").gyro.outliers.unwrap();
            let share = spikes as f64 / n as f64;
            assert!(rel(o.size_dps, size) < 0.1 && rel(o.per_sample, share) < 0.2, "seed {seed}: {o:?} ({share})");
        }
    }
}

/// One bias step of 0.1 deg/s in a record of the base gyro (ten times the scan's threshold) is fitted as a
/// process: found at its sample within a window, its size within 10%, and a rate of one step over the record's
/// length divided by its detection probability. A Poisson process seen through half a record often leaves one
/// step there; whether the process explains the record is the views' call.
#[test]
fn one_bias_step_gives_a_process() {
    let rate_hz: f64 = 100.0;
    let (mut x, _) = simulate(&base_model(), rate_hz, 1 << 19, 31, None);
    let at = 300_000;
    x[at..].iter_mut().for_each(|v| *v += 0.1);
    let e = run(Effect::BiasSteps, &x, None, rate_hz).expect("one step fits a process");
    let json = serde_json::to_value(&e.params).unwrap();
    let found = json["at_s"][0].as_f64().unwrap() * rate_hz;
    assert!(param(&e, "count") == 1.0 && (found - at as f64).abs() < 200.0, "{json}");
    let size = json["sizes_dps"][0].as_f64().unwrap();
    assert!(rel(size, 0.1) < 0.1, "{:?}", e.params);
    let hours = x.len() as f64 / rate_hz / 3600.0;
    let b = e.gyro.bias_steps.unwrap();
    assert!(b.per_hour >= 1.0 / hours && b.per_hour <= 5.0 / hours, "{b:?}");
}

/// A warm-up settling from 0.3 deg/s over a minute passes the bias-step scan's threshold where its decay meets
/// the record's start, but it is not sharp (a quarter-window mean difference keeps a small share of it), so alone
/// it fits no bias-step process; the same change made a step does.
#[test]
fn a_settling_warm_up_is_not_a_lone_bias_step() {
    let rate_hz: f64 = 100.0;
    let (x, _) = simulate(&base_model(), rate_hz, 1 << 19, 32, None);
    let settling: Vec<f64> =
        x.iter().enumerate().map(|(i, v)| v + 0.3 * (-(i as f64) / rate_hz / 60.0).exp()).collect();
    let l = bias_steps::scan_window(&settling, rate_hz).unwrap();
    assert!(!bias_steps::mosum_scan(&settling, l).unwrap().steps.is_empty(), "premise: the scan finds the change");
    assert!(run(Effect::BiasSteps, &settling, None, rate_hz).is_none());
}

/// The bias-step scan's threshold holds on noise without steps: over 40 records of the base gyro's white noise,
/// flicker and random walk (the robust scale of a red-noise scan statistic is read from few independent
/// windows, so its peaks reach further than a Gaussian's), none shows the [`bias_steps::PROCESS_STEPS`] peaks
/// beyond the threshold that show a process by their number, and at
/// most 4 show one or more. A peak only fits the process: the views then judge whether its simulation explains a
/// significant gap, and the withheld sweep's controls measure how often that names it on effect-free records.
#[test]
fn bias_step_scan_holds_its_threshold_on_noise() {
    let rate_hz: f64 = 100.0;
    let counts: Vec<usize> = (0..40u64)
        .into_par_iter()
        .map(|seed| {
            let (x, _) = simulate(&base_model(), rate_hz, 1 << 18, 500 + seed, None);
            let l = bias_steps::scan_window(&x, rate_hz).unwrap();
            bias_steps::mosum_scan(&x, l).unwrap().steps.len()
        })
        .collect();
    let many = counts.iter().filter(|&&c| c >= bias_steps::PROCESS_STEPS).count();
    let any = counts.iter().filter(|&&c| c > 0).count();
    assert!(many == 0 && any <= 4, "peaks beyond the threshold per record: {counts:?}");
}

#[test]
fn outliers_recovered() {
    let rate_hz: f64 = 100.0;
    let m = GyroSim {
        outliers: Some(Outliers { per_sample: 1e-4, size_sigma: 10.0, ..Default::default() }),
        ..base_model()
    };
    let (x, _) = simulate(&m, rate_hz, 1_000_000, 10, None);
    let e = run(Effect::Outliers, &x, None, rate_hz).unwrap();
    let o = e.gyro.outliers.unwrap();
    let size = 10.0 * 0.01 * rate_hz.sqrt();
    // Tolerance: 25% on the rate (100 events), 5% on the size.
    assert!(rel(o.per_sample, 1e-4) < 0.25 && rel(o.size_dps, size) < 0.05, "{o:?}");
}

/// A warm-up read beside a spike mixture an earlier step found keeps that step's white noise. The mixture (5.2
/// sds on 10% of the samples, written out here) overlaps the core, so the spikes step flags and cleans only part of
/// it, and reads N off the record's curve less the whole law. An IEEE re-fit of the cleaned samples less the
/// warm-up puts the unflagged spikes in N, and the model, which draws the law beside N, would carry them twice.
#[test]
fn a_warm_up_beside_a_spike_mixture_keeps_the_white_noise() {
    let (rate_hz, n, sd) = (10.0, 400_000, 0.01);
    let mut rng = SimRng::new(41);
    let x: Vec<f64> = (0..n)
        .map(|i| {
            let spike = if rng.uniform() < 0.1 { (4.9 + 0.6 * rng.uniform()) * sd } else { 0.0 };
            let sign = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
            0.05 * (-(i as f64) / rate_hz / 2000.0).exp() + sd * rng.normal() + sign * spike
        })
        .collect();
    let n_white = sd / rate_hz.sqrt();
    let (g, f) = base_of(&x, rate_hz);
    let spikes = fit_effect(Effect::Outliers, &data_of(&x, rate_hz, &g, &f)).expect("the mixture is found");
    let n_spikes = spikes.gyro.n_deg_per_rt_s;
    let cleaned = spikes.cleaned.as_deref().expect("the flagged samples cleaned").clone();
    let (_, f2) = base_of(&cleaned, rate_hz);
    let d = TrainingData { recorded_dps: &x, ..data_of(&cleaned, rate_hz, &spikes.gyro, &f2) };
    let w = fit_effect(Effect::WarmUp, &d).expect("the warm-up is found");
    let refit = f2.sim_terms(GyroSim::default()).n_deg_per_rt_s;
    eprintln!(
        "N: truth {n_white:.4e}, spikes step {n_spikes:.4e}, warm-up {:.4e}, re-fit {refit:.4e}",
        w.gyro.n_deg_per_rt_s
    );
    assert!(rel(n_spikes, n_white) < 0.05, "the premise: the spikes step reads N {n_spikes} (truth {n_white})");
    assert!(refit > 1.05 * n_white, "the premise: the cleaned samples' white noise {refit} carries unflagged spikes");
    assert!(rel(w.gyro.n_deg_per_rt_s, n_white) < 0.05, "N {} (truth {n_white})", w.gyro.n_deg_per_rt_s);
    let u = w.gyro.warm_up.as_ref().unwrap();
    assert!(rel(u.size_dps, 0.05) < 0.2 && rel(u.tau_s, 2000.0) < 0.3, "{u:?}");
}

/// A coupling's spread draws its in-band complex coefficient, `k` through the lag's gain and phase at the
/// estimate's frequency, from a circular Gaussian about the fitted one whose parts each have the standard
/// error through the same gain: 4000 members' coefficients and lags, read back to in-phase and quadrature
/// parts, have that mean (within 4 standard errors of a mean) and that sd (within 5%, about 4 sds of an sd).
#[test]
fn a_couplings_members_draw_its_in_band_coefficient() {
    let (k, lag, f, se) = (0.01, 100.0, 1.0 / 1000.0, 0.0012);
    let w = 2.0 * std::f64::consts::PI * f;
    let parts = |k: f64, lag: f64| -> [f64; 2] {
        let phase = (w * lag).atan();
        [k * phase.cos() * phase.cos(), k * phase.cos() * phase.sin()]
    };
    let gyro =
        GyroSim { temperature: Some(TempCoupling { dps_per_c: k, ref_c: 23.0, lag_s: lag }), ..Default::default() };
    let spread = ParamSpread::Coupling { se_dps_per_c: se, f_hz: f };
    let n = 4000;
    let drawn: Vec<[f64; 2]> = (0..n as u64)
        .map(|seed| {
            let c = spread.draw(&gyro, seed).temperature.unwrap();
            parts(c.dps_per_c, c.lag_s)
        })
        .collect();
    let fitted = parts(k, lag);
    let gain = (w * lag).atan().cos();
    for i in 0..2 {
        let mean = drawn.iter().map(|p| p[i]).sum::<f64>() / n as f64;
        let sd = (drawn.iter().map(|p| (p[i] - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
        assert!(
            (mean - fitted[i]).abs() < 4.0 * se * gain / (n as f64).sqrt(),
            "part {i}: mean {mean} vs {}",
            fitted[i]
        );
        assert!((sd / (se * gain) - 1.0).abs() < 0.05, "part {i}: sd {sd} vs {}", se * gain);
    }
}

/// A spike rate's spread draws each member's share from the gamma law of shape `runs + 1/2` about the fitted
/// share: over 20000 members, the mean share is the fitted one times `(runs + 1/2) / (runs + 1/2)` = 1 (within 4
/// standard errors of a mean) and its relative sd `1 / sqrt(runs + 1/2)` (within 3%), for a dozen runs and for a
/// fraction of one (the shape below 1 takes the other branch of the draw).
#[test]
fn a_spike_rates_members_draw_the_rate_from_its_count() {
    let eps = 1e-4;
    let gyro = GyroSim {
        outliers: Some(Outliers { per_sample: eps, size_dps: 1.0, ..Default::default() }),
        ..Default::default()
    };
    for runs in [12.0, 0.3] {
        let spread = ParamSpread::SpikeRate { runs };
        let n = 20_000;
        let drawn: Vec<f64> =
            (0..n as u64).map(|seed| spread.draw(&gyro, seed).outliers.unwrap().per_sample / eps).collect();
        let mean = drawn.iter().sum::<f64>() / n as f64;
        let sd = (drawn.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
        let want_sd = 1.0 / (runs + 0.5f64).sqrt();
        assert!((mean - 1.0).abs() < 4.0 * want_sd / (n as f64).sqrt(), "runs {runs}: mean {mean}");
        assert!((sd / want_sd - 1.0).abs() < 0.03, "runs {runs}: sd {sd} vs {want_sd}");
        assert!(drawn.iter().all(|&r| r > 0.0 && r.is_finite()), "runs {runs}: a share out of range");
    }
}

/// A parameter of an estimate or its standard error, by its key in the report's JSON.
fn param(e: &EffectFit, key: &str) -> f64 {
    let json = serde_json::to_value(&e.params).unwrap();
    json[key].as_f64().unwrap_or_else(|| panic!("no {key} in {json}"))
}

/// |estimate - truth| within `k` of its reported standard errors.
fn within_se(e: &EffectFit, key: &str, se_key: &str, truth: f64, k: f64) -> bool {
    (param(e, key) - truth).abs() <= k * param(e, se_key)
}

/// The resonance's centre, quality factor and sd come back within four of their standard errors (the least
/// squares' in ln P, widened for the Welch bins' correlation) over two seeds each of a narrow bump at 20 Hz, a
/// broad one at 2 Hz and a sharp one at 7 Hz, on the base gyro's white noise, flicker and random walk; and the
/// base terms re-fitted under it keep N within 3% (the base fit alone takes part of the bump's Allan variance for
/// white noise).
#[test]
fn resonance_recovered() {
    let rate_hz = 100.0;
    for (sigma, f0, q) in [(0.05, 20.0, 10.0), (0.05, 2.0, 4.0), (0.03, 7.0, 30.0)] {
        for seed in [1, 2] {
            let m = GyroSim { resonance: Some(ResonanceSim { sigma_dps: sigma, freq_hz: f0, q }), ..base_model() };
            let (x, _) = simulate(&m, rate_hz, 500_000, seed, None);
            let e = run(Effect::Resonance, &x, None, rate_hz).expect("a resonance 4-18 times the background is found");
            let r = e.gyro.resonance.unwrap();
            assert_eq!((r.sigma_dps, r.freq_hz, r.q), (param(&e, "sigma_dps"), param(&e, "freq_hz"), param(&e, "q")));
            for (key, se, truth) in
                [("sigma_dps", "sigma_se_dps", sigma), ("freq_hz", "freq_se_hz", f0), ("q", "q_se", q)]
            {
                assert!(
                    within_se(&e, key, se, truth, 4.0),
                    "seed {seed}, truth {sigma} {f0} {q}: {key} in {:?}",
                    e.params
                );
            }
            assert!(rel(e.gyro.n_deg_per_rt_s, 0.01) < 0.03, "seed {seed}: N {}", e.gyro.n_deg_per_rt_s);
        }
    }
}

/// A resonance read on a model that already carries a Gauss-Markov process (a later step of the chain): a process
/// of 1.2 s and a bump at 1.43 Hz, Q 4.3, in 6.1 Hz samples with white noise alone beside them, the process read
/// first. The base terms are re-fitted with the process's variance beside them, its time constant held: at 12
/// seeds N stays within 10% of the truth (2-9% low), no flicker above 3e-3 deg/s appears (0-2.1e-3) and the
/// process's sd stays within 5%. Taken off at the variance its own step read, the process left a difference the
/// base terms followed: B of 6.8-9.1e-3 at 10 of the 12 seeds, and N up to twice the truth.
#[test]
fn a_resonance_read_beside_a_gauss_markov_process_leaves_the_white_noise_alone() {
    let rate_hz = 6.1;
    let n_true = 0.006;
    let markov = GaussMarkovSim { sigma_dps: 0.046, tau_s: 1.2 };
    let m = GyroSim {
        n_deg_per_rt_s: n_true,
        gauss_markov: Some(markov),
        resonance: Some(ResonanceSim { sigma_dps: 0.011, freq_hz: 1.43, q: 4.3 }),
        ..Default::default()
    };
    for seed in 1..=12 {
        let (x, _) = simulate(&m, rate_hz, 128_000, seed, None);
        let (b, f) = base_of(&x, rate_hz);
        let process = fit_effect(Effect::GaussMarkov, &data_of(&x, rate_hz, &b, &f)).expect("the process");
        let d = TrainingData { base: &process.gyro, ..data_of(&x, rate_hz, &b, &f) };
        let e = fit_effect(Effect::Resonance, &d).expect("the resonance beside the process");
        let (n, flicker) = (e.gyro.n_deg_per_rt_s, e.gyro.b_dps);
        let sd = e.gyro.gauss_markov.expect("the process kept").sigma_dps;
        assert!(rel(n, n_true) < 0.1, "seed {seed}: N {n:.3e} for {n_true:.3e}");
        assert!(flicker < 3e-3, "seed {seed}: B {flicker:.3e} where there is none");
        assert!(rel(sd, markov.sigma_dps) < 0.05, "seed {seed}: the process's sd {sd:.4} for {}", markov.sigma_dps);
    }
}

/// No resonance in plain noise (white, flicker, random walk; 4 seeds), nor in its neighbours: a sinusoid (a line,
/// the sinusoid candidate's; three frequencies), a Gauss-Markov process and a first-order bandwidth (broad
/// shapes of the background).
#[test]
fn resonance_is_not_found_in_noise_lines_or_broad_shapes() {
    let rate_hz = 100.0;
    let mut records: Vec<(String, GyroSim)> = (0..4).map(|i| (format!("plain {i}"), base_model())).collect();
    for p in [0.05, 0.31, 3.7] {
        let mut m = base_model();
        m.sinusoids.push(Sinusoid { amplitude_dps: 0.05, period_s: p, phase_rad: 0.3 }).unwrap();
        records.push((format!("sinusoid P {p}"), m));
    }
    records.push((
        "gauss_markov".into(),
        GyroSim { gauss_markov: Some(GaussMarkovSim { sigma_dps: 0.05, tau_s: 0.05 }), ..base_model() },
    ));
    records.push(("bandwidth".into(), GyroSim { bandwidth_hz: Some(10.0), ..base_model() }));
    let found: Vec<String> = records
        .par_iter()
        .enumerate()
        .filter_map(|(i, (what, m))| {
            let (x, _) = simulate(m, rate_hz, 500_000, 40 + i as u64, None);
            run(Effect::Resonance, &x, None, rate_hz).map(|e| format!("{what}: {:?}", e.params))
        })
        .collect();
    assert!(found.is_empty(), "false resonances: {found:?}");
}

/// The bistable bias's step and mean dwells come back within four standard errors (the step's from the scatter
/// of the jumps' sizes, a dwell's the exponential's `dwell / sqrt(count)`), over two seeds each of a slow
/// asymmetric one (120 s low, 60 s high), a fast symmetric one (20 s) and one with short high excursions
/// (300 s low, 30 s high, many of them shorter than the scan can see one by one).
#[test]
fn bistable_recovered() {
    let rate_hz = 10.0;
    for (step, lo, hi) in [(0.1, 120.0, 60.0), (0.15, 20.0, 20.0), (0.08, 300.0, 30.0)] {
        for seed in [1, 2] {
            let m = GyroSim {
                bistable: Some(BistableSim { step_dps: step, dwell_low_s: lo, dwell_high_s: hi }),
                ..base_model()
            };
            let (x, _) = simulate(&m, rate_hz, 500_000, seed, None);
            let e = run(Effect::Bistable, &x, None, rate_hz).expect("a bistable bias is found");
            let b = e.gyro.bistable.unwrap();
            assert_eq!(b.step_dps, param(&e, "step_dps"));
            for (key, se, truth) in [
                ("step_dps", "step_se_dps", step),
                ("dwell_low_s", "dwell_low_se_s", lo),
                ("dwell_high_s", "dwell_high_se_s", hi),
            ] {
                assert!(
                    within_se(&e, key, se, truth, 4.0),
                    "seed {seed}, truth {step} {lo} {hi}: {key} in {:?}",
                    e.params
                );
            }
        }
    }
}

/// Power at long tau that is not the telegraph's does not lengthen its dwells: beside two slow sinusoids (500 s
/// and 5,000 s, as a temperature response and a slow wander would be), a telegraph of 67 s low and 15 s high
/// comes back within four standard errors, on two noise levels and two seeds each. The Allan curve's re-reading
/// of the correlation time may shorten the counted one (missed excursions make it long) but not stretch it past
/// the count's own scatter: left free to four times, it read both dwells at twice the truth here.
#[test]
fn bistable_dwells_are_not_stretched_by_slow_power_beside_them() {
    let rate_hz = 14.0;
    let (step, lo, hi) = (0.117, 66.6, 15.0);
    for (n, b) in [(0.005, 0.003), (0.01, 0.008)] {
        for seed in [1, 2] {
            let mut m = GyroSim {
                n_deg_per_rt_s: n,
                b_dps: b,
                k_dps_per_rt_s: b * 1e-3,
                bistable: Some(BistableSim { step_dps: step, dwell_low_s: lo, dwell_high_s: hi }),
                ..Default::default()
            };
            m.sinusoids.push(Sinusoid { amplitude_dps: 0.044, period_s: 498.0, phase_rad: 0.3 }).unwrap();
            m.sinusoids.push(Sinusoid { amplitude_dps: 0.033, period_s: 5141.0, phase_rad: 1.1 }).unwrap();
            let (x, _) = simulate(&m, rate_hz, 241_000, seed, None);
            let e = run(Effect::Bistable, &x, None, rate_hz).expect("a bistable bias is found");
            for (key, se, truth) in [("dwell_low_s", "dwell_low_se_s", lo), ("dwell_high_s", "dwell_high_se_s", hi)] {
                assert!(within_se(&e, key, se, truth, 4.0), "N {n}, seed {seed}: {key} in {:?}", e.params);
            }
        }
    }
}

/// A telegraph whose rarer state lasts one to two of the scan's windows, beside a Gauss-Markov process strong
/// enough to lift the scan's threshold near the step (0.046 deg/s at 1.2 s against flips of 0.23 deg/s, 345 s
/// low and 19 s high, 6.1 Hz, 128,000 samples): the scan at its best window sees both edges of most excursions,
/// so their alternation names the process, on four seeds. Kept two windows apart, the scan's jumps show one edge
/// of many excursions, of either sign: on the record these parameters come from, 35 of 47 pairs alternate where
/// the test needs a tail below 1e-4 / 8.
#[test]
fn a_telegraph_of_short_excursions_beside_a_strong_markov_process_is_found() {
    let rate_hz = 6.0966;
    let (step, lo, hi) = (0.234, 345.4, 19.32);
    let m = GyroSim {
        n_deg_per_rt_s: 0.002,
        b_dps: 0.002,
        gauss_markov: Some(GaussMarkovSim { sigma_dps: 0.046, tau_s: 1.2 }),
        bistable: Some(BistableSim { step_dps: step, dwell_low_s: lo, dwell_high_s: hi }),
        ..Default::default()
    };
    let missed: Vec<String> = (1..5u64)
        .into_par_iter()
        .filter_map(|seed| {
            let (x, _) = simulate(&m, rate_hz, 128_000, seed, None);
            match run(Effect::Bistable, &x, None, rate_hz) {
                Some(e) if (e.gyro.bistable.unwrap().step_dps / step - 1.0).abs() < 0.2 => None,
                other => Some(format!("seed {seed}: {:?}", other.map(|e| e.params))),
            }
        })
        .collect();
    assert!(missed.is_empty(), "telegraphs missed or misread: {missed:?}");
}

/// No bistable bias in spikes of one size and one sign (0.5% of the samples, 8 times the white noise), which give
/// the scan an up and a down edge of equal size a window or less apart.
#[test]
fn bistable_is_not_found_in_spikes_of_one_size() {
    let rate_hz = 10.0;
    let found: Vec<String> = (1..4u64)
        .into_par_iter()
        .filter_map(|seed| {
            let (mut x, _) = simulate(&base_model(), rate_hz, 500_000, seed, None);
            let sd = 0.01 * rate_hz.sqrt();
            let mut rng = SimRng::new(100 + seed);
            for v in x.iter_mut() {
                if rng.uniform() < 0.005 {
                    *v += 8.0 * sd;
                }
            }
            run(Effect::Bistable, &x, None, rate_hz).map(|e| format!("seed {seed}: {:?}", e.params))
        })
        .collect();
    assert!(found.is_empty(), "false bistable biases: {found:?}");
}

/// No bistable bias in plain noise, in random bias steps (Gaussian jumps of either sign: the bias-steps
/// candidate's), nor in a Gauss-Markov process (whose Allan variance is the same form), 3 seeds each.
#[test]
fn bistable_is_not_found_in_noise_steps_or_gauss_markov() {
    let rate_hz = 10.0;
    let steps = GyroSim { bias_steps: Some(BiasSteps { per_hour: 6.0, sigma_dps: 0.04 }), ..base_model() };
    let gm = GyroSim { gauss_markov: Some(GaussMarkovSim { sigma_dps: 0.02, tau_s: 60.0 }), ..base_model() };
    let base = base_model();
    let cases: Vec<(&str, &GyroSim, u64)> =
        (1..4u64).flat_map(|s| [("plain", &base, s), ("bias_steps", &steps, s), ("gauss_markov", &gm, s)]).collect();
    let found: Vec<String> = cases
        .par_iter()
        .filter_map(|&(what, m, seed)| {
            let (x, _) = simulate(m, rate_hz, 500_000, seed, None);
            run(Effect::Bistable, &x, None, rate_hz).map(|e| format!("{what} seed {seed}: {:?}", e.params))
        })
        .collect();
    assert!(found.is_empty(), "false bistable biases: {found:?}");
}

/// The warm-up's size comes back within four standard errors and its time constant within a factor 1.5 (the
/// grid is four per octave), for a fast one (60 s) and a slow one (2000 s, a tenth of the record) of either
/// sign, two seeds each.
#[test]
fn warm_up_recovered() {
    let rate_hz = 10.0;
    for (size, tau) in [(0.08, 60.0), (-0.1, 2000.0)] {
        for seed in [1, 2] {
            let m = GyroSim { warm_up: Some(WarmUpSim { size_dps: size, tau_s: tau }), ..base_model() };
            let (x, _) = simulate(&m, rate_hz, 262_144, seed, None);
            let e = run(Effect::WarmUp, &x, None, rate_hz).expect("a warm-up is found");
            let w = e.gyro.warm_up.unwrap();
            assert!(within_se(&e, "size_dps", "size_se_dps", size, 4.0), "seed {seed}: {:?}", e.params);
            assert!((w.tau_s / tau).ln().abs() < 1.5f64.ln(), "seed {seed}: {:?}", e.params);
        }
    }
}

/// No warm-up in plain noise, nor in a tenfold random walk with a ramp, 4 seeds each.
#[test]
fn warm_up_is_not_found_in_noise_random_walk_or_ramp() {
    let rate_hz = 10.0;
    let drift = GyroSim { k_dps_per_rt_s: 2e-4, r_dps_per_s: 1e-6, ..base_model() };
    let base = base_model();
    let cases: Vec<(&str, &GyroSim, u64)> =
        (1..5u64).flat_map(|s| [("plain", &base, s), ("random walk + ramp", &drift, s)]).collect();
    let found: Vec<String> = cases
        .par_iter()
        .filter_map(|&(what, m, seed)| {
            let (x, _) = simulate(m, rate_hz, 262_144, seed, None);
            run(Effect::WarmUp, &x, None, rate_hz).map(|e| format!("{what} seed {seed}: {:?}", e.params))
        })
        .collect();
    assert!(found.is_empty(), "false warm-ups: {found:?}");
}

/// The warm-up scan's threshold holds on noise without a warm-up: over 24 records each of the base gyro's white
/// noise, flicker and random walk, and of the same with a tenfold random walk and a ramp, the largest |t| of the
/// scan (some fifty correlated t-statistics, under the record's own base fit, a trend where it has a ramp) stays
/// below [`warm_up::T_STAT`] (about 4 at most where it was measured on 40).
#[test]
fn warm_up_scan_holds_its_threshold_on_noise() {
    let rate_hz = 10.0;
    let drift = GyroSim { k_dps_per_rt_s: 2e-4, r_dps_per_s: 1e-6, ..base_model() };
    let largest: Vec<f64> = (0..48u64)
        .into_par_iter()
        .map(|i| {
            let m = if i % 2 == 0 { base_model() } else { drift.clone() };
            let (x, _) = simulate(&m, rate_hz, 262_144, 700 + i, None);
            let (g, _) = base_of(&x, rate_hz);
            warm_up::largest_t(&x, rate_hz, &warm_up::BlockNoise::of(&g), g.r_dps_per_s != 0.0)
        })
        .collect();
    assert!(largest.iter().all(|&t| t < warm_up::T_STAT), "largest |t| per record: {largest:?}");
}

/// A named jump process is found again by its own scan on another record of the same model: a bistable bias of
/// 0.1 deg/s (dwells 120 s and 60 s) and bias steps (0.05 deg/s, 20 an hour) raise the Allan variance at 30 s
/// many times over the base terms', and on records drawn with two other seeds, less what [`JumpScan`] takes out,
/// what it leaves is at most 30% of what the jumps made, and the same within 30% on two such records (no scan is
/// made from a fit that took nothing out).
#[test]
fn a_named_jump_process_is_found_again_on_another_record() {
    let rate_hz = 10.0;
    let n = 500_000;
    let avar_at = |x: &[f64], tau: f64| {
        let pts = oadev_points(x, rate_hz);
        pts.iter().min_by(|a, b| (a.tau_s / tau).ln().abs().total_cmp(&(b.tau_s / tau).ln().abs())).unwrap().avar
    };
    let (plain, _) = simulate(&base_model(), rate_hz, n, 5, None);
    let base_avar = avar_at(&plain, 30.0);
    let models = [
        GyroSim {
            bistable: Some(BistableSim { step_dps: 0.1, dwell_low_s: 120.0, dwell_high_s: 60.0 }),
            ..base_model()
        },
        GyroSim { bias_steps: Some(BiasSteps { per_hour: 20.0, sigma_dps: 0.05 }), ..base_model() },
    ];
    for (m, effect) in models.iter().zip([Effect::Bistable, Effect::BiasSteps]) {
        let (x, _) = simulate(m, rate_hz, n, 1, None);
        let e = run(effect, &x, None, rate_hz).expect("the process is found");
        let scan = JumpScan::of(&e, &x, rate_hz).expect("a process taken out gives a scan");
        let left: Vec<(f64, f64)> = [5, 6]
            .iter()
            .map(|&seed| {
                let (mut other, _) = simulate(m, rate_hz, n, seed, None);
                let with_jumps = avar_at(&other, 30.0);
                scan.take_out(&mut other);
                (with_jumps, avar_at(&other, 30.0))
            })
            .collect();
        eprintln!("{effect}: base {base_avar:.3e}, with jumps and left {left:?}");
        for &(with_jumps, without) in &left {
            assert!(
                with_jumps > 5.0 * base_avar,
                "{effect}: the jumps barely show ({with_jumps:.3e} vs {base_avar:.3e})"
            );
            assert!(without < 0.3 * with_jumps, "{effect}: {without:.3e} left of {with_jumps:.3e}");
        }
        // What the scan leaves is the same on two records of the model: the comparison is like with like.
        assert!(rel(left[0].1, left[1].1) < 0.3, "{effect}: {left:?}");
        let nothing_out = EffectFit { cleaned: None, ..e };
        assert!(JumpScan::of(&nothing_out, &x, rate_hz).is_none());
    }
}

/// [`common::at_top`] marks a search's minimum at its upper bound (a criterion still falling there), and only there:
/// not an interior minimum, nor one at the lower bound; [`common::at_bottom`] marks the lower bound alike.
#[test]
fn a_search_that_ends_at_a_bound_is_told_from_one_inside() {
    let (lo, hi, n) = (0.1, 1000.0, 40);
    let falling = common::log_search(lo, hi, n, |x| -x.ln());
    let inside = common::log_search(lo, hi, n, |x| (x.ln() - 3.0).powi(2));
    let rising = common::log_search(lo, hi, n, |x| x.ln());
    assert!(common::at_top(falling.0, lo, hi, n) && !common::at_bottom(falling.0, lo, hi, n), "{falling:?}");
    assert!(!common::at_top(inside.0, lo, hi, n) && (inside.0.ln() - 3.0).abs() < 1e-3, "{inside:?}");
    assert!(!common::at_bottom(inside.0, lo, hi, n), "{inside:?}");
    assert!(common::at_bottom(rising.0, lo, hi, n) && !common::at_top(rising.0, lo, hi, n), "{rising:?}");
    // An interior minimum a tenth of a grid step inside either bound is inside.
    let step = (hi / lo).ln() / (n - 1) as f64;
    let near_top = common::log_search(lo, hi, n, |x| (x.ln() - (hi.ln() - 0.1 * step)).powi(2));
    assert!(!common::at_top(near_top.0, lo, hi, n), "{near_top:?}");
    let near_bottom = common::log_search(lo, hi, n, |x| (x.ln() - (lo.ln() + 0.1 * step)).powi(2));
    assert!(!common::at_bottom(near_bottom.0, lo, hi, n), "{near_bottom:?}");
}

/// A coupling whose lag runs past the search (ten records: its response is a slow ramp whose size trades against
/// the coefficient) is not read, where the search's bound would have given it a lag of three records; one lagging a
/// third of the record, the longest the sweep draws, is read at its lag, inside the search.
#[test]
fn a_coupling_whose_lag_runs_past_the_search_is_not_read() {
    let (rate_hz, n) = (10.0, 262_144);
    let record = n as f64 / rate_hz;
    let temp = TemperatureProfile {
        min_c: 22.0,
        max_c: 28.0,
        period_s: 3600.0,
        wander: Some(Wander { sigma_c: 0.3, tau_s: 900.0 }),
        ..Default::default()
    };
    let cases: Vec<(f64, f64, u64)> =
        [1, 2].into_iter().flat_map(|s| [(3.0, 10.0 * record, s), (0.05, record / 3.0, s)]).collect();
    let read: Vec<(f64, u64, Option<EffectFit>)> = cases
        .par_iter()
        .map(|&(k, lag, seed)| {
            let coupling = TempCoupling { dps_per_c: k, ref_c: 25.0, lag_s: lag };
            let m = GyroSim { temperature: Some(coupling), ..base_model() };
            let (x, t) = simulate(&m, rate_hz, n, seed, Some(&temp));
            (lag, seed, run(Effect::Temperature, &x, Some(&t), rate_hz))
        })
        .collect();
    for (lag, seed, e) in read {
        if lag > record {
            assert!(e.is_none(), "seed {seed}: a lag of ten records read as {:?}", e.map(|e| e.params));
        } else {
            let c = e.expect("a coupling lagging a third of the record is read").gyro.temperature.unwrap();
            assert!((c.lag_s / lag).ln().abs() < 2f64.ln() && c.lag_s < 3.0 * record, "seed {seed}: {c:?}");
        }
    }
}

/// On an ADC lattice five times coarser than the white noise (the rounded record holds a value, then moves a
/// whole step), the warm-up's test weighs the samples by their own noise, rounding in: over 24 records of white
/// noise, flicker and a random walk that carries the bias over several steps, rounded to the lattice at an offset
/// of their own, the quantisation estimator's model and lattice given, no warm-up is named.
#[test]
fn a_coarse_lattice_is_no_warm_up() {
    let rate_hz: f64 = 10.0;
    let n = 262_144usize;
    let white_sd = base_model().n_deg_per_rt_s * rate_hz.sqrt();
    let step = 5.0 * white_sd;
    let walk = GyroSim { k_dps_per_rt_s: 4.0 * step / (n as f64 / rate_hz).sqrt(), ..base_model() };
    let named: Vec<Option<f64>> = (0..24u64)
        .into_par_iter()
        .map(|i| {
            let (analog, _) = simulate(&walk, rate_hz, n, 900 + i, None);
            let offset = step * (i as f64 / 24.0);
            let x: Vec<f64> = analog.iter().map(|v| ((v - offset) / step).round() * step + offset).collect();
            let (g, f) = base_of(&x, rate_hz);
            let q = fit_effect(Effect::Quantization, &data_of(&x, rate_hz, &g, &f)).expect("the lattice is found");
            let lattice = q.channel.as_ref().map(|c| c.dps_per_code());
            assert!(lattice.is_some_and(|l| rel(l, step) < 0.01), "lattice {lattice:?} for {step}");
            let d = TrainingData { base: &q.gyro, lattice_dps: lattice, ..data_of(&x, rate_hz, &g, &f) };
            fit_effect(Effect::WarmUp, &d).map(|w| match w.params {
                params::EffectParams::WarmUp(p) => p.t_stat,
                _ => f64::NAN,
            })
        })
        .collect();
    assert!(named.iter().all(Option::is_none), "warm-ups named (their t): {named:?}");
}

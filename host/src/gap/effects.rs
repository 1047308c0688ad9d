//! The candidate effects of the gap diagnosis and their estimators, from the training samples only.
//!
//! Each [`Effect`] is a term the IEEE 952 base model (Q, N, B, K, R) lacks. [`estimate`] fits its parameters on
//! the training data and returns the base model with the effect added ([`EffectFit::gyro`]), re-fitting the base
//! terms the effect overlaps (N under a bandwidth or with quantisation or outliers, K under bias steps, all of
//! them jointly with a Gauss-Markov process), or `None` when the data carry no trace of it.
//!
//! | effect | method | parameters |
//! |--------|--------|------------|
//! | temperature | regression of the block-averaged rate on the temperature through a first-order lag, lag by grid + golden search, significance with an AR(1) effective sample size | `dps_per_c`, `lag_s`, `ref_c` |
//! | sinusoid | Hann-windowed periodogram against a log-band median background, frequency refined on the windowed projection, amplitude/phase by joint least squares | `amplitude_dps`, `period_s`, `phase_rad` (up to 4) |
//! | bandwidth | joint weighted fit of the short-tau OADEV with the exact Allan form of sampled first-order low-passed white noise, f3dB by grid + golden search | `bandwidth_hz` |
//! | gauss_markov | joint fit of the OADEV with the base terms plus the exact Gauss-Markov Allan form, T by grid + golden search | `sigma_dps`, `tau_s` |
//! | quantization | lattice step of the sample values (distinct-value gaps, verified on 99% of samples) | `step_dps` |
//! | bias_steps | MOSUM scan of windowed mean differences at the bias-instability tau, robust (MAD) threshold; truncated-normal size fit | `per_hour`, `sigma_dps` |
//! | outliers | residual from a 5-point running median, robust (MAD) sigma, isolated spikes beyond 6 sigma | `per_sample`, `size_dps` |
//!
//! All of them run in well under a second on a million samples (one FFT, a few O(N) passes, small fits on the
//! octave OADEV curve).

use octavar_shared::sensor::{Adc, Channel, FrontEnd, GyroModel, GENERIC};
use octavar_shared::sim::{
    BiasSteps, GaussMarkovSim, GyroSim, Outliers, Sinusoid, TempCoupling, MAX_SINUSOIDS,
};
use rustfft::num_complex::Complex;
use rustfft::FftPlanner;
use serde::Serialize;
use serde_json::{json, Value};

use crate::fit::{fit, FitOptions, FitPoint, NoiseFit, FLICKER_AVAR_FACTOR};
use crate::stats::{analyze_series, DataKind, Options, Series, Statistic, TauSpec};

/// A candidate effect: something the IEEE 952 base model does not have.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Effect {
    /// Bias coupled to the temperature through a thermal lag.
    Temperature,
    /// Sinusoids on the rate (vibration, supply ripple, a daily cycle without a temperature channel).
    Sinusoid,
    /// A first-order output bandwidth (the sensor's or an anti-alias filter).
    Bandwidth,
    /// Exponentially correlated (Gauss-Markov) rate noise.
    GaussMarkov,
    /// ADC quantisation: sample values on a lattice.
    Quantization,
    /// Random bias steps.
    BiasSteps,
    /// Isolated spikes.
    Outliers,
}

impl Effect {
    /// Every effect, in the vocabulary's order.
    pub const ALL: [Effect; 7] = [
        Effect::Temperature,
        Effect::Sinusoid,
        Effect::Bandwidth,
        Effect::GaussMarkov,
        Effect::Quantization,
        Effect::BiasSteps,
        Effect::Outliers,
    ];

    /// The name in the vocabulary (CLI, JSON).
    pub fn name(self) -> &'static str {
        match self {
            Effect::Temperature => "temperature",
            Effect::Sinusoid => "sinusoid",
            Effect::Bandwidth => "bandwidth",
            Effect::GaussMarkov => "gauss_markov",
            Effect::Quantization => "quantization",
            Effect::BiasSteps => "bias_steps",
            Effect::Outliers => "outliers",
        }
    }

    /// The effect of a name (as [`Effect::name`] gives it; `-` is accepted for `_`, case is ignored).
    pub fn parse(s: &str) -> Option<Effect> {
        let s = s.trim().to_ascii_lowercase().replace('-', "_");
        Effect::ALL.into_iter().find(|e| e.name() == s)
    }
}

impl core::fmt::Display for Effect {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name())
    }
}

/// What an estimator sees: the training samples and the base model fitted on them.
#[derive(Clone, Copy, Debug)]
pub struct TrainingData<'a> {
    /// Rate samples, deg/s (no gaps).
    pub rate_dps: &'a [f64],
    /// The temperature at each sample, degC, where there is a temperature channel.
    pub temp_c: Option<&'a [f64]>,
    /// Sample rate, Hz.
    pub fs_hz: f64,
    /// The base simulation model (IEEE terms fitted on these samples).
    pub base: &'a GyroSim,
    /// The base fit itself.
    pub base_fit: &'a NoiseFit,
}

/// An effect fitted on the training data.
#[derive(Clone, Debug, PartialEq)]
pub struct EffectFit {
    /// Which effect.
    pub effect: Effect,
    /// Its parameters, named with their units (`{"amplitude_dps": .., "period_s": ..}`).
    pub params: Value,
    /// Number of free parameters the effect adds (for the ranking's penalty).
    pub n_params: usize,
    /// The base model with the effect added (base terms it overlaps re-fitted).
    pub gyro: GyroSim,
    /// For quantisation: a channel whose ADC step is the data's lattice step (`None`: keep the base channel).
    pub channel: Option<Channel>,
}

/// Fit `effect` on the training data; `None` when the data show no trace of it.
pub fn estimate(effect: Effect, data: &TrainingData) -> Option<EffectFit> {
    let n = data.rate_dps.len();
    if n < 64 || !(data.fs_hz.is_finite() && data.fs_hz > 0.0) {
        return None;
    }
    if data.rate_dps.iter().any(|v| !v.is_finite()) {
        return None;
    }
    match effect {
        Effect::Temperature => temperature(data),
        Effect::Sinusoid => sinusoid(data),
        Effect::Bandwidth => bandwidth(data),
        Effect::GaussMarkov => gauss_markov(data),
        Effect::Quantization => quantization(data),
        Effect::BiasSteps => bias_steps(data),
        Effect::Outliers => outliers(data),
    }
}

// ---------------------------------------------------------------------------------------------------------------
// Shared helpers.

fn mean(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    x.iter().sum::<f64>() / x.len() as f64
}

/// Median of a copy (O(n) selection).
fn median(x: &[f64]) -> f64 {
    if x.is_empty() {
        return f64::NAN;
    }
    let mut v = x.to_vec();
    let k = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(k, f64::total_cmp);
    *m
}

/// Block means of `x` over blocks of `m` samples (the last partial block dropped).
fn block_means(x: &[f64], m: usize) -> Vec<f64> {
    let m = m.max(1);
    x.chunks_exact(m).map(|c| c.iter().sum::<f64>() / m as f64).collect()
}

/// The overlapping Allan variance at octave tau, with Greenhall EDFs, as fit points.
fn oadev_points(x: &[f64], fs: f64) -> Vec<FitPoint> {
    let Ok(s) = Series::new(x, DataKind::Frequency, 1.0 / fs) else {
        return Vec::new();
    };
    let opts = Options::default();
    analyze_series(&s, Statistic::Oadev, &TauSpec::Octave, &opts)
        .map(|rows| {
            rows.iter()
                .filter(|p| p.edf.is_finite() && p.edf > 0.0 && p.dev.is_finite() && p.dev > 0.0)
                .map(|p| FitPoint { tau_s: p.tau_s, avar: p.dev * p.dev, edf: p.edf })
                .collect()
        })
        .unwrap_or_default()
}

/// Allan variance at `m` samples of a unit-variance discrete AR(1) of pole `a` (autocovariance `a^|k|`):
/// `[m (1+a)/(1-a) - a (2u + u^2)/(1-a)^2] / m^2`, `u = 1 - a^m` (the form in shared::sim::noise).
fn ar1_avar(a: f64, m: f64) -> f64 {
    if a <= 0.0 {
        return 1.0 / m;
    }
    let la = a.ln();
    let oma = -la.exp_m1();
    let u = -(m * la).exp_m1();
    (m * (1.0 + a) / oma - a * (2.0 * u + u * u) / (oma * oma)) / (m * m)
}

/// Allan variance of a unit-variance Gauss-Markov process of correlation time `t_s`, sampled every `tau0`, at
/// `tau`: the exact discrete AR(1) form while T is within a thousand samples, else the continuous form
/// `2 T/tau [1 - T/(2 tau)(3 - 4 e^{-tau/T} + e^{-2 tau/T})]` (IEEE 952 Annex C; series at small tau/T).
fn gm_avar(t_s: f64, tau: f64, tau0: f64) -> f64 {
    let m = (tau / tau0).round().max(1.0);
    if t_s / tau0 <= 1000.0 {
        return ar1_avar((-tau0 / t_s).exp(), m);
    }
    let x = tau / t_s;
    let shape = if x < 1e-3 {
        x * x / 3.0 - x * x * x / 4.0
    } else {
        1.0 - (4.0 * (-(-x).exp_m1()) - (-(-2.0 * x).exp_m1())) / (2.0 * x)
    };
    2.0 * shape / x
}

/// Allan variance of white rate noise of unit N (per-sample variance fs) through the sampled first-order
/// low-pass `y = a y + (1 - a) x`, `a = exp(-2 pi f3dB / fs)`, as shared::sim applies it: an AR(1) of variance
/// `fs (1 - a)/(1 + a)`. Tends to `fit::lowpass_white_factor(tau/T) / tau` when T >> tau0.
fn lowpass_white_avar(f3db: Option<f64>, tau: f64, fs: f64) -> f64 {
    let m = (tau * fs).round().max(1.0);
    match f3db {
        Some(f) if f > 0.0 => {
            let a = (-2.0 * std::f64::consts::PI * f / fs).exp();
            fs * (1.0 - a) / (1.0 + a) * ar1_avar(a, m)
        }
        _ => fs / m,
    }
}

/// A weighted non-negative least-squares fit of AVAR = sum theta_j col_j, weights from the model (IRLS), every
/// subset of columns tried; the score is the log-domain chi-square sum (ln avar - ln model)^2 / (2/edf + e^2)
/// that `fit::fit` minimises.
struct Joint {
    theta: Vec<f64>,
    chi2: f64,
}

const MODEL_ERROR2: f64 = 0.03 * 0.03;

fn joint_fit(pts: &[FitPoint], cols: &[Vec<f64>]) -> Option<Joint> {
    let p = cols.len();
    let np = pts.len();
    if np < 2 || p == 0 {
        return None;
    }
    let rel: Vec<f64> = pts.iter().map(|q| 2.0 / q.edf + MODEL_ERROR2).collect();
    let mut var: Vec<f64> = pts.iter().zip(&rel).map(|(q, r)| q.avar * q.avar * r).collect();
    let mut best: Option<Vec<f64>> = None;
    for _ in 0..5 {
        let mut round: Option<(f64, Vec<f64>)> = None;
        for mask in 1u32..(1 << p) {
            let act: Vec<usize> = (0..p).filter(|j| mask & (1 << j) != 0).collect();
            if act.len() > np {
                continue;
            }
            let k = act.len();
            let mut a = vec![vec![0.0; k]; k];
            let mut b = vec![0.0; k];
            let scale: Vec<f64> = act
                .iter()
                .map(|&j| (0..np).map(|i| cols[j][i] * cols[j][i] / var[i]).sum::<f64>().sqrt())
                .collect();
            if scale.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
                continue;
            }
            for i in 0..np {
                for (r, &jr) in act.iter().enumerate() {
                    let xr = cols[jr][i] / scale[r];
                    b[r] += xr * pts[i].avar / var[i];
                    for (c, &jc) in act.iter().enumerate() {
                        a[r][c] += xr * cols[jc][i] / scale[c] / var[i];
                    }
                }
            }
            let Some(sol) = solve(a, b) else { continue };
            if sol.iter().any(|v| *v < 0.0 || !v.is_finite()) {
                continue;
            }
            let mut theta = vec![0.0; p];
            for (r, &j) in act.iter().enumerate() {
                theta[j] = sol[r] / scale[r];
            }
            let chi: f64 = (0..np)
                .map(|i| {
                    let m: f64 = (0..p).map(|j| theta[j] * cols[j][i]).sum();
                    (pts[i].avar - m).powi(2) / var[i]
                })
                .sum();
            // Akaike's penalty per active term: a term must buy more than 2 in chi-square (a ramp bending the
            // top two octaves would otherwise trade against the flicker floor and a Gauss-Markov time).
            let aic = chi + 2.0 * k as f64;
            if round.as_ref().is_none_or(|(c, _)| aic < *c) {
                round = Some((aic, theta));
            }
        }
        let (_, theta) = round?;
        for i in 0..np {
            let m: f64 = (0..p).map(|j| theta[j] * cols[j][i]).sum();
            let m = if m > 0.0 { m } else { pts[i].avar };
            var[i] = m * m * rel[i];
        }
        best = Some(theta);
    }
    let theta = best?;
    let chi2 = log_chi2(pts, |i| (0..p).map(|j| theta[j] * cols[j][i]).sum());
    Some(Joint { theta, chi2 })
}

fn log_chi2(pts: &[FitPoint], model: impl Fn(usize) -> f64) -> f64 {
    pts.iter()
        .enumerate()
        .map(|(i, q)| {
            let m = model(i).max(1e-300);
            (q.avar.ln() - m.ln()).powi(2) / (2.0 / q.edf + MODEL_ERROR2)
        })
        .sum()
}

/// Gaussian elimination with partial pivoting; `None` when singular.
fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let n = b.len();
    for c in 0..n {
        let piv = (c..n).max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs()))?;
        if !(a[piv][c].abs() > 1e-13) {
            return None;
        }
        a.swap(c, piv);
        b.swap(c, piv);
        for r in c + 1..n {
            let f = a[r][c] / a[c][c];
            if f != 0.0 {
                for k in c..n {
                    a[r][k] -= f * a[c][k];
                }
                b[r] -= f * b[c];
            }
        }
    }
    let mut x = vec![0.0; n];
    for r in (0..n).rev() {
        let s: f64 = (r + 1..n).map(|k| a[r][k] * x[k]).sum();
        x[r] = (b[r] - s) / a[r][r];
    }
    Some(x)
}

/// Golden-section minimisation of `f` on [lo, hi].
fn golden(mut lo: f64, mut hi: f64, iters: usize, f: impl Fn(f64) -> f64) -> (f64, f64) {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let mut x1 = hi - g * (hi - lo);
    let mut x2 = lo + g * (hi - lo);
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..iters {
        if f1 <= f2 {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - g * (hi - lo);
            f1 = f(x1);
        } else {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + g * (hi - lo);
            f2 = f(x2);
        }
    }
    if f1 <= f2 {
        (x1, f1)
    } else {
        (x2, f2)
    }
}

/// Grid search over `ln x` on [lo, hi] (n points), then golden refinement between the best point's neighbours.
fn log_search(lo: f64, hi: f64, n: usize, f: impl Fn(f64) -> f64) -> (f64, f64) {
    let (l0, l1) = (lo.ln(), hi.ln());
    let grid: Vec<f64> = (0..n).map(|i| l0 + (l1 - l0) * i as f64 / (n - 1) as f64).collect();
    let vals: Vec<f64> = grid.iter().map(|&u| f(u.exp())).collect();
    let (ib, _) = vals
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))
        .unwrap_or((0, &f64::INFINITY));
    let a = grid[ib.saturating_sub(1)];
    let b = grid[(ib + 1).min(n - 1)];
    let (u, v) = golden(a, b, 24, |u| f(u.exp()));
    if v <= vals[ib] {
        (u.exp(), v)
    } else {
        (grid[ib].exp(), vals[ib])
    }
}

/// Number of base-term columns ([`base_columns`]); an effect's own column comes after them.
const BASE_COLS: usize = 5;

/// The columns of the base terms N (shaped by `bw`), B, K, R and Q at the points' taus, N per unit N^2. The Q
/// column is all zero (so [`joint_fit`] never uses it) unless `with_q`: the base fit's choice, for at the
/// shortest taus angle white noise and a low-pass corner or a fast Gauss-Markov trade against each other.
fn base_columns(pts: &[FitPoint], fs: f64, bw: Option<f64>, with_q: bool) -> Vec<Vec<f64>> {
    let q = if with_q { 3.0 } else { 0.0 };
    vec![
        pts.iter().map(|p| lowpass_white_avar(bw, p.tau_s, fs)).collect(),
        pts.iter().map(|_| FLICKER_AVAR_FACTOR).collect(),
        pts.iter().map(|p| p.tau_s / 3.0).collect(),
        pts.iter().map(|p| p.tau_s * p.tau_s / 2.0).collect(),
        pts.iter().map(|p| q / (p.tau_s * p.tau_s)).collect(),
    ]
}

/// The base model with its N, B, K, R and Q replaced by the fitted squares.
fn with_base_terms(base: &GyroSim, theta: &[f64]) -> GyroSim {
    GyroSim {
        n_deg_per_rt_s: theta[0].max(0.0).sqrt(),
        b_dps: theta[1].max(0.0).sqrt(),
        k_dps_per_rt_s: theta[2].max(0.0).sqrt(),
        r_dps_per_s: theta[3].max(0.0).sqrt(),
        q_deg: theta[4].max(0.0).sqrt(),
        ..base.clone()
    }
}

/// The IEEE fit (default options, the base's bandwidth) on a record cleaned of an effect's fitted component: the
/// base model with its Q, N, B, K, R replaced by the fitted terms of that fit, and the fit's squares.
fn refit_base(base: &GyroSim, cleaned: &[f64], fs: f64) -> Option<(GyroSim, [f64; 5])> {
    let pts = oadev_points(cleaned, fs);
    let opts = FitOptions { bandwidth_hz: base.bandwidth_hz, ..Default::default() };
    let f = fit(&pts, &opts).ok()?;
    Some((f.sim_terms(base.clone()), f.squares))
}

/// The standard normal upper tail.
fn normal_sf(z: f64) -> f64 {
    0.5 * statrs::function::erf::erfc(z / std::f64::consts::SQRT_2)
}

// ---------------------------------------------------------------------------------------------------------------
// Temperature.

/// Bias coupled to the temperature through a first-order thermal lag.
///
/// Method: rate and temperature are block-averaged to blocks of at most a second (at least 8192 blocks where the
/// record allows; the temperature moves over minutes to days). For each lag the temperature goes through the
/// discrete first-order lag (`y = T + a (y - T)`, `a = exp(-dt/lag)`, started settled, as shared::sim's
/// `ThermalLag`), and the coefficient comes from a generalised least-squares regression in the frequency domain
/// (Whittle): with Hann-tapered transforms X (lagged temperature) and R (rate), `k = sum Re(X* R)/S / sum |X|^2/S`
/// over the non-zero frequencies, S the two-sided PSD of the gyro's noise, `N^2 + B^2/(2 pi f) + K^2/(4 pi^2 f^2)`
/// (IEEE 952 Annex C). Ordinary least squares would let the flicker and random walk at the lowest frequencies,
/// where a slow temperature wander also lives, dominate the estimate; GLS weighs each frequency by its noise. The
/// lag minimises the GLS residual `sum |R - k X|^2 / S` on a log grid from the block length to three record
/// lengths, refined by golden-section search, and is compared with no lag. Two passes: S from the base fit, then
/// from the IEEE fit of the record without the fitted coupling (the base fit took part of the temperature bump
/// for flicker or random walk), which also gives the model's base terms. The coefficient counts when it exceeds 5
/// standard errors, `Var k = (sum w^2/dt) / sum |X|^2/S` (twice the independent-bin value, for the taper's
/// correlation of neighbouring bins): slow bias wander that happens to correlate with a slow temperature is not
/// taken for coupling.
fn temperature(d: &TrainingData) -> Option<EffectFit> {
    let temp = d.temp_c?;
    let n = d.rate_dps.len().min(temp.len());
    if n < 64 || temp[..n].iter().any(|v| !v.is_finite()) {
        return None;
    }
    let m = ((n / 8192).max(1)).min((d.fs_hz.max(1.0)) as usize).max(1);
    let r = block_means(&d.rate_dps[..n], m);
    let t = block_means(&temp[..n], m);
    let nb = r.len();
    if nb < 16 {
        return None;
    }
    let dt = m as f64 / d.fs_hz;
    let t_spread = t.iter().fold(f64::MIN, |a, &b| a.max(b)) - t.iter().fold(f64::MAX, |a, &b| a.min(b));
    if !(t_spread > 0.0) {
        return None;
    }
    let lagged = |lag: f64| -> Vec<f64> {
        let a = if lag > 0.0 { (-dt / lag).exp() } else { 0.0 };
        let mut y = t[0];
        t.iter()
            .map(|&x| {
                y = x + a * (y - x);
                y
            })
            .collect()
    };
    let nfft = nb.next_power_of_two();
    let half = nfft / 2;
    let wd = 2.0 * std::f64::consts::PI / nb as f64;
    let taper: Vec<f64> = (0..nb).map(|i| 0.5 * (1.0 - (wd * (i as f64 + 0.5)).cos())).collect();
    let sum_w2: f64 = taper.iter().map(|w| w * w).sum();
    let transform = |v: &[f64]| -> (Vec<f64>, Vec<f64>) {
        let mu = mean(v);
        let mut re = vec![0.0; nfft];
        let mut im = vec![0.0; nfft];
        for (i, (x, w)) in v.iter().zip(&taper).enumerate() {
            re[i] = (x - mu) * w;
        }
        fft(&mut re, &mut im);
        re.truncate(half + 1);
        im.truncate(half + 1);
        (re, im)
    };
    let (rr, ri) = transform(&r);
    let df = 1.0 / (nfft as f64 * dt);
    let two_pi = 2.0 * std::f64::consts::PI;
    let spectrum = |sq: &[f64; 5]| -> Vec<f64> {
        let floor = (sq[1] + sq[2] + sq[3]).max(1e-300) * 1e-9;
        (0..=half)
            .map(|k| {
                let f = (k as f64 * df).max(df);
                (sq[1] + sq[2] / (two_pi * f) + sq[3] / (two_pi * two_pi * f * f)).max(floor)
            })
            .collect()
    };
    // (k, GLS residual, sum |X|^2/S) for a lagged temperature.
    let gls = |x: &[f64], s: &[f64]| -> (f64, f64, f64) {
        let (xr, xi) = transform(x);
        let (mut sxx, mut sxr, mut srr) = (0.0, 0.0, 0.0);
        for k in 1..=half {
            sxx += (xr[k] * xr[k] + xi[k] * xi[k]) / s[k];
            sxr += (xr[k] * rr[k] + xi[k] * ri[k]) / s[k];
            srr += (rr[k] * rr[k] + ri[k] * ri[k]) / s[k];
        }
        if !(sxx > 0.0) {
            return (0.0, f64::INFINITY, 0.0);
        }
        (sxr / sxx, srr - sxr * sxr / sxx, sxx)
    };
    let record = nb as f64 * dt;
    let best_lag = |s: &[f64]| -> f64 {
        let (lag, crit) = log_search(dt, 3.0 * record, 40, |lag| gls(&lagged(lag), s).1);
        if gls(&t, s).1 <= crit {
            0.0
        } else {
            lag
        }
    };
    // Pass 1: the base fit's noise.
    let s1 = spectrum(&d.base_fit.squares);
    let lag1 = best_lag(&s1);
    let (k1, _, _) = gls(&lagged(lag1), &s1);
    let cleaned_of = |k: f64, lag: f64| -> Vec<f64> {
        let a_full = if lag > 0.0 { (-1.0 / (d.fs_hz * lag)).exp() } else { 0.0 };
        let mut y = temp[0];
        d.rate_dps[..n]
            .iter()
            .zip(&temp[..n])
            .map(|(&r, &tc)| {
                y = tc + a_full * (y - tc);
                r - k * y
            })
            .collect()
    };
    // Pass 2: the noise of the record without the coupling.
    let (_, squares) = refit_base(d.base, &cleaned_of(k1, lag1), d.fs_hz)?;
    let s2 = spectrum(&squares);
    let lag = best_lag(&s2);
    let x = lagged(lag);
    let (k, _, sxx) = gls(&x, &s2);
    if !(k.is_finite() && k != 0.0 && sxx > 0.0) {
        return None;
    }
    let se = (sum_w2 / dt / sxx).sqrt();
    if !(k.abs() > 5.0 * se) {
        return None;
    }
    let (refit, _) = refit_base(d.base, &cleaned_of(k, lag), d.fs_hz)?;
    // The sim adds bias + k (T_lag - ref): ref keeps the intercept (mean rate - k mean T_lag) with the base bias.
    let c0 = mean(&r) - k * mean(&x);
    let ref_c = (d.base.bias_dps - c0) / k;
    let gyro = GyroSim { temperature: Some(TempCoupling { dps_per_c: k, ref_c, lag_s: lag }), ..refit };
    Some(EffectFit {
        effect: Effect::Temperature,
        params: json!({"dps_per_c": k, "lag_s": lag, "ref_c": ref_c, "t_stat": k / se}),
        n_params: 2,
        gyro,
        channel: None,
    })
}

// ---------------------------------------------------------------------------------------------------------------
// Sinusoids.

/// In-place forward FFT of the complex sequence `re + i im` (rustfft; any length).
fn fft(re: &mut [f64], im: &mut [f64]) {
    let mut buf: Vec<Complex<f64>> = re.iter().zip(im.iter()).map(|(&r, &i)| Complex::new(r, i)).collect();
    FftPlanner::new().plan_fft_forward(buf.len()).process(&mut buf);
    for ((r, i), c) in re.iter_mut().zip(im.iter_mut()).zip(&buf) {
        *r = c.re;
        *i = c.im;
    }
}

/// `|sum w_n x_n e^{-i 2 pi f n dt}|^2` with the Hann window, by a rotating phasor (renormalised).
fn hann_power(y: &[f64], f: f64, dt: f64) -> f64 {
    let n = y.len();
    let d = 2.0 * std::f64::consts::PI * f * dt;
    let (cd, sd) = (d.cos(), d.sin());
    let wd = 2.0 * std::f64::consts::PI / n as f64;
    let (cw, sw) = (wd.cos(), wd.sin());
    let (mut c, mut s) = (1.0f64, 0.0f64);
    let (mut wc, mut ws) = (1.0f64, 0.0f64);
    let (mut re, mut im) = (0.0, 0.0);
    for (i, &v) in y.iter().enumerate() {
        let w = 0.5 * (1.0 - wc);
        re += w * v * c;
        im -= w * v * s;
        let c2 = c * cd - s * sd;
        s = s * cd + c * sd;
        c = c2;
        let wc2 = wc * cw - ws * sw;
        ws = ws * cw + wc * sw;
        wc = wc2;
        if i & 1023 == 1023 {
            let g = 1.5 - 0.5 * (c * c + s * s);
            c *= g;
            s *= g;
        }
    }
    re * re + im * im
}

/// Sinusoids on the rate.
///
/// Method: the Hann-windowed periodogram of the mean-removed record (block-averaged to at most 2^21 points, so a
/// record of days still resolves periods of a day; each block's time is its centre and the amplitude is
/// corrected for the block average's sinc), zero-padded to a power of two. The background at each bin is the
/// median of the periodogram in a band around it (+-16 bins at low frequency, log bands of 1/8 relative width
/// above, interpolated in log-log), so 1/f and 1/f^2 noise set their own level; a bin is a peak where it is a local
/// maximum beyond `ln(bins) + 7` times the background mean (the periodogram ordinate is exponential, so about
/// 1e-3 false peaks per record). Periods from a third of the record to two samples are searched. Each peak's
/// frequency is refined by golden search on the windowed projection within +-1 bin; amplitudes and phases of up
/// to four peaks come from one joint least-squares fit of sines and cosines (plus a quadratic trend). The base
/// terms are re-fitted on the record without the sinusoids (the base fit covered their Allan bump with B or K).
/// Joint least squares of `y` (sampled every `dt`, the first sample at `t_off`) on a quadratic trend (so slow
/// wander does not leak into long periods) and a (cos, sin) pair per frequency, in one pass with rotating
/// phasors: the coefficients (trend first) and the residual sum of squares.
fn sinusoid_ls(y: &[f64], freqs: &[f64], dt: f64, t_off: f64) -> Option<(Vec<f64>, f64)> {
    let n = y.len();
    let p = 3 + 2 * freqs.len();
    let mut ata = vec![vec![0.0; p]; p];
    let mut atb = vec![0.0; p];
    let mut yy = 0.0;
    let rot: Vec<(f64, f64)> = freqs
        .iter()
        .map(|f| {
            let a = 2.0 * std::f64::consts::PI * f * dt;
            (a.cos(), a.sin())
        })
        .collect();
    let mut ph: Vec<(f64, f64)> = freqs
        .iter()
        .map(|f| {
            let a = 2.0 * std::f64::consts::PI * f * t_off;
            (a.cos(), a.sin())
        })
        .collect();
    let mut row = vec![0.0; p];
    for (i, &v) in y.iter().enumerate() {
        let u = 2.0 * i as f64 / n as f64 - 1.0;
        row[0] = 1.0;
        row[1] = u;
        row[2] = u * u - 1.0 / 3.0;
        for (j, (c, s)) in ph.iter().enumerate() {
            row[3 + 2 * j] = *c;
            row[4 + 2 * j] = *s;
        }
        yy += v * v;
        for r in 0..p {
            atb[r] += row[r] * v;
            for c in r..p {
                ata[r][c] += row[r] * row[c];
            }
        }
        for (j, (c, s)) in ph.iter_mut().enumerate() {
            let (cr, sr) = rot[j];
            let c2 = *c * cr - *s * sr;
            *s = *s * cr + *c * sr;
            *c = c2;
            if i & 1023 == 1023 {
                let g = 1.5 - 0.5 * (*c * *c + *s * *s);
                *c *= g;
                *s *= g;
            }
        }
    }
    for r in 0..p {
        for c in 0..r {
            ata[r][c] = ata[c][r];
        }
    }
    let sol = solve(ata, atb.clone())?;
    let explained: f64 = sol.iter().zip(&atb).map(|(a, b)| a * b).sum();
    Some((sol, yy - explained))
}

fn sinusoid(d: &TrainingData) -> Option<EffectFit> {
    let x = d.rate_dps;
    let n0 = x.len();
    let dec = n0.div_ceil(1 << 21).max(1);
    let mu = mean(x);
    let y: Vec<f64> = if dec == 1 { x.iter().map(|v| v - mu).collect() } else { block_means(x, dec).iter().map(|v| v - mu).collect() };
    let n = y.len();
    if n < 64 {
        return None;
    }
    let dt = dec as f64 / d.fs_hz;
    let t_off = (dec as f64 - 1.0) / 2.0 / d.fs_hz;
    let nfft = n.next_power_of_two();
    let pad = nfft as f64 / n as f64;
    let mut re = vec![0.0; nfft];
    let mut im = vec![0.0; nfft];
    let wd = 2.0 * std::f64::consts::PI / n as f64;
    for (i, v) in y.iter().enumerate() {
        re[i] = v * 0.5 * (1.0 - (wd * i as f64).cos());
    }
    fft(&mut re, &mut im);
    let half = nfft / 2;
    let pw: Vec<f64> = (0..half).map(|k| re[k] * re[k] + im[k] * im[k]).collect();
    drop(re);
    drop(im);
    let df = 1.0 / (nfft as f64 * dt);
    let record = n as f64 * dt;
    let k_lo = ((3.0 / record) / df).ceil().max(2.0) as usize;
    let k_hi = half - 2;
    if k_lo + 8 >= k_hi {
        return None;
    }
    // Background: band medians.
    let excl = (3.0 * pad).ceil() as usize;
    let w_low = (16.0 * pad).ceil() as usize;
    let switch = (8 * w_low).max(64);
    let mut bg = vec![0.0; half];
    for (k, b) in bg.iter_mut().enumerate().take(switch.min(half)).skip(1) {
        let lo = k.saturating_sub(w_low).max(1);
        let hi = (k + w_low).min(half - 1);
        let v: Vec<f64> = (lo..=hi).filter(|j| j.abs_diff(k) > excl).map(|j| pw[j]).collect();
        *b = median(&v);
    }
    if switch < half {
        let mut centres: Vec<(f64, f64)> = Vec::new();
        let mut lo = switch / 2;
        while lo < half {
            let hi = ((lo as f64 * 1.125).ceil() as usize).max(lo + 2 * w_low).min(half);
            let med = median(&pw[lo..hi]);
            centres.push((((lo as f64) * (hi as f64)).sqrt().ln(), med.max(1e-300).ln()));
            lo = hi;
        }
        let mut c = 0;
        for (k, b) in bg.iter_mut().enumerate().skip(switch) {
            let lk = (k as f64).ln();
            while c + 1 < centres.len() && centres[c + 1].0 < lk {
                c += 1;
            }
            let v = if c + 1 >= centres.len() || lk <= centres[c].0 {
                centres[c].1
            } else {
                let (a, b2) = (centres[c], centres[c + 1]);
                a.1 + (b2.1 - a.1) * (lk - a.0) / (b2.0 - a.0)
            };
            *b = v.exp();
        }
    }
    let thr = (k_hi - k_lo) as f64;
    let thr = thr.ln() + 7.0;
    let mut peaks: Vec<(usize, f64)> = (k_lo..k_hi)
        .filter(|&k| pw[k] >= pw[k - 1] && pw[k] >= pw[k + 1] && bg[k] > 0.0)
        .map(|k| (k, pw[k] / (bg[k] / std::f64::consts::LN_2)))
        .filter(|&(_, z)| z > thr)
        .collect();
    peaks.sort_by(|a, b| b.1.total_cmp(&a.1));
    let mut chosen: Vec<usize> = Vec::new();
    let sep = (8.0 * pad).ceil() as usize;
    for (k, _) in peaks {
        if chosen.iter().all(|&c| c.abs_diff(k) > sep) {
            chosen.push(k);
            if chosen.len() == MAX_SINUSOIDS {
                break;
            }
        }
    }
    if chosen.is_empty() {
        return None;
    }
    // Refine each frequency on the windowed projection.
    let freqs: Vec<f64> = chosen
        .iter()
        .map(|&k| {
            let f0 = k as f64 * df;
            let (f, _) = golden((f0 - df).max(df * 0.5), f0 + df, 30, |f| -hann_power(&y, f, dt));
            f
        })
        .collect();
    // The frequencies refined on the whole record: the windowed projection gives away the record's ends, and a
    // period learnt on 8 cycles 1.5% off has drifted by an eighth of a cycle over an equal holdout. Each frequency
    // in turn minimises the residual of the joint least squares below, within half a bin of where it is.
    let mut freqs = freqs;
    for _ in 0..2 {
        for j in 0..freqs.len() {
            let f0 = freqs[j];
            let (f, _) = golden(f0 - 0.5 * df, f0 + 0.5 * df, 20, |f| {
                let mut trial = freqs.clone();
                trial[j] = f;
                sinusoid_ls(&y, &trial, dt, t_off).map_or(f64::INFINITY, |r| r.1)
            });
            freqs[j] = f;
        }
    }
    let (sol, _) = sinusoid_ls(&y, &freqs, dt, t_off)?;
    let mut list: Vec<Sinusoid> = Vec::new();
    for (j, &f) in freqs.iter().enumerate() {
        let (a, b) = (sol[3 + 2 * j], sol[4 + 2 * j]);
        // Block averaging scales a sinusoid by sin(pi f D/fs) / (D sin(pi f/fs)).
        let g = if dec > 1 {
            let u = std::f64::consts::PI * f / d.fs_hz;
            ((u * dec as f64).sin() / (dec as f64 * u.sin())).abs().max(1e-3)
        } else {
            1.0
        };
        // a cos + b sin = A sin(w t + phi): a = A sin phi, b = A cos phi.
        list.push(Sinusoid { amplitude_dps: (a * a + b * b).sqrt() / g, period_s: 1.0 / f, phase_rad: a.atan2(b) });
    }
    list.sort_by(|a, b| b.amplitude_dps.total_cmp(&a.amplitude_dps));
    // The base terms re-fitted without the sinusoids (the base fit covered their Allan bump with B or K).
    let two_pi = 2.0 * std::f64::consts::PI;
    let cleaned: Vec<f64> = x
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            let t = i as f64 / d.fs_hz;
            v - list.iter().map(|s| s.amplitude_dps * (two_pi * t / s.period_s + s.phase_rad).sin()).sum::<f64>()
        })
        .collect();
    let mut gyro = refit_base(d.base, &cleaned, d.fs_hz).map_or_else(|| d.base.clone(), |r| r.0);
    gyro.sinusoids.clear();
    for s in &list {
        let _ = gyro.sinusoids.push(*s);
    }
    let s0 = list[0];
    let all: Vec<Value> = list
        .iter()
        .map(|s| json!({"amplitude_dps": s.amplitude_dps, "period_s": s.period_s, "phase_rad": s.phase_rad}))
        .collect();
    Some(EffectFit {
        effect: Effect::Sinusoid,
        params: json!({"amplitude_dps": s0.amplitude_dps, "period_s": s0.period_s, "phase_rad": s0.phase_rad,
                       "sinusoids": all}),
        n_params: 3 * list.len(),
        gyro,
        channel: None,
    })
}

// ---------------------------------------------------------------------------------------------------------------
// Bandwidth.

/// Minimum log-domain chi-square improvement for an effect fitted on the OADEV curve to count (the model-error
/// floor of 3% already keeps the first octaves from dominating).
const CURVE_DELTA_CHI2: f64 = 30.0;

/// A first-order output bandwidth.
///
/// Method: the OADEV at octave tau (Greenhall EDFs) is fitted jointly with N (white noise through the sampled
/// first-order low-pass, the exact AR(1) Allan form, which tends to `fit::lowpass_white_factor` when the corner
/// is far below the sample rate), B, K and R, by weighted non-negative least squares (IRLS, every subset of
/// terms), the corner f3dB on a log grid from fs/2000 to fs/2 refined by golden search. It counts when the
/// log-domain chi-square falls by at least [`CURVE_DELTA_CHI2`] from the unfiltered fit. N, B, K, R and Q are
/// re-fitted with the bandwidth in place (the base fit reads N low from the bent short taus).
fn bandwidth(d: &TrainingData) -> Option<EffectFit> {
    let fs = d.fs_hz;
    let pts = oadev_points(d.rate_dps, fs);
    if pts.len() < 5 {
        return None;
    }
    let with_q = d.base.q_deg > 0.0;
    let score = |f: Option<f64>| joint_fit(&pts, &base_columns(&pts, fs, f, with_q));
    let plain = score(None)?;
    let (f, chi) = log_search(fs / 2000.0, fs / 2.0, 40, |f| score(Some(f)).map_or(f64::INFINITY, |j| j.chi2));
    if !(chi + CURVE_DELTA_CHI2 < plain.chi2) {
        return None;
    }
    let j = score(Some(f))?;
    if !(j.theta[0] > 0.0) {
        return None;
    }
    let mut gyro = with_base_terms(d.base, &j.theta);
    gyro.bandwidth_hz = Some(f);
    Some(EffectFit {
        effect: Effect::Bandwidth,
        params: json!({"bandwidth_hz": f, "n_deg_per_rt_s": gyro.n_deg_per_rt_s,
                       "delta_chi2": plain.chi2 - chi}),
        n_params: 1,
        gyro,
        channel: None,
    })
}

// ---------------------------------------------------------------------------------------------------------------
// Gauss-Markov.

/// A Gauss-Markov (first-order exponentially correlated) rate noise.
///
/// Method: the OADEV at octave tau is fitted jointly with the base terms N, B, K, R, Q and a Gauss-Markov term of
/// unit variance (its exact Allan form: the discrete AR(1) expression, or IEEE 952 Annex C's continuous one for
/// T beyond a thousand samples), weighted NNLS as for the bandwidth, T on a log grid from 2 tau0 to a third of
/// the record refined by golden search. It counts when the log-domain chi-square falls by at least
/// [`CURVE_DELTA_CHI2`] from the base-terms-only fit and the process carries at least a fifth of the model's
/// Allan variance somewhere on the curve; N, B, K, R and Q are re-fitted with it.
fn gauss_markov(d: &TrainingData) -> Option<EffectFit> {
    let fs = d.fs_hz;
    let tau0 = 1.0 / fs;
    let pts = oadev_points(d.rate_dps, fs);
    if pts.len() < 6 {
        return None;
    }
    let bw = d.base.bandwidth_hz;
    let base_cols = base_columns(&pts, fs, bw, d.base.q_deg > 0.0);
    let plain = joint_fit(&pts, &base_cols)?;
    let cols_for = |t: f64| {
        let mut c = base_cols.clone();
        c.push(pts.iter().map(|q| gm_avar(t, q.tau_s, tau0)).collect());
        c
    };
    let record = d.rate_dps.len() as f64 * tau0;
    let t_hi = (record / 3.0).max(4.0 * tau0);
    let (t, chi) = log_search(2.0 * tau0, t_hi, 40, |t| joint_fit(&pts, &cols_for(t)).map_or(f64::INFINITY, |j| j.chi2));
    if !(chi + CURVE_DELTA_CHI2 < plain.chi2) {
        return None;
    }
    let cols = cols_for(t);
    let j = joint_fit(&pts, &cols)?;
    let s2 = j.theta[BASE_COLS];
    if !(s2 > 0.0) {
        return None;
    }
    let share = (0..pts.len())
        .map(|i| {
            let tot: f64 = (0..cols.len()).map(|c| j.theta[c] * cols[c][i]).sum();
            s2 * cols[BASE_COLS][i] / tot
        })
        .fold(0.0, f64::max);
    if share < 0.2 {
        return None;
    }
    let mut gyro = with_base_terms(d.base, &j.theta);
    gyro.gauss_markov = Some(GaussMarkovSim { sigma_dps: s2.sqrt(), tau_s: t });
    Some(EffectFit {
        effect: Effect::GaussMarkov,
        params: json!({"sigma_dps": s2.sqrt(), "tau_s": t, "delta_chi2": plain.chi2 - chi}),
        n_params: 2,
        gyro,
        channel: None,
    })
}

// ---------------------------------------------------------------------------------------------------------------
// Quantisation.

/// The lattice `offset + k q` the sample values sit on: `(q, a lattice point)`, or `None`.
fn lattice(x: &[f64]) -> Option<(f64, f64)> {
    let stride = (x.len() / 200_000).max(1);
    let sample: Vec<f64> = x.iter().step_by(stride).copied().collect();
    let mut v = sample.clone();
    v.sort_by(f64::total_cmp);
    v.dedup();
    if v.len() < 2 || v.len() * 4 > sample.len() {
        return None; // (nearly) every value distinct: no lattice
    }
    let span = v[v.len() - 1] - v[0];
    let gaps: Vec<f64> = v.windows(2).map(|w| w[1] - w[0]).filter(|g| *g > span * 1e-12).collect();
    if gaps.is_empty() {
        return None;
    }
    // The step: the smallest gap that is common (a tenth quantile keeps a rare off-lattice pair out), then the
    // mean of the gaps that are one step.
    let mut g = gaps.clone();
    g.sort_by(f64::total_cmp);
    let q0 = g[g.len() / 10];
    let ones: Vec<f64> = gaps.iter().copied().filter(|x| (x / q0 - 1.0).abs() < 0.01).collect();
    let q = if ones.is_empty() { q0 } else { mean(&ones) };
    // A lattice point: the most frequent value.
    let mut sorted = sample.clone();
    sorted.sort_by(f64::total_cmp);
    let (mut best, mut best_n, mut i) = (sorted[0], 0, 0);
    while i < sorted.len() {
        let mut j = i;
        while j < sorted.len() && sorted[j] == sorted[i] {
            j += 1;
        }
        if j - i > best_n {
            best_n = j - i;
            best = sorted[i];
        }
        i = j;
    }
    let on = sample
        .iter()
        .filter(|&&s| {
            let k = (s - best) / q;
            (k - k.round()).abs() < 1e-3
        })
        .count();
    (on as f64 >= 0.99 * sample.len() as f64).then_some((q, best))
}

/// Variance of `Q(sigma Z + u)` averaged over a uniform offset u (the quantiser rounds to multiples of q).
fn quantized_var(sigma: f64, q: f64) -> f64 {
    if sigma > 2.0 * q {
        return sigma * sigma + q * q / 12.0; // Sheppard's correction, exact to ~1e-8 here
    }
    if sigma <= 0.0 {
        return q * q / 12.0 * 0.0;
    }
    let kmax = (6.0 * sigma / q).ceil() as i64 + 2;
    let nu = 32;
    let mut acc = 0.0;
    for iu in 0..nu {
        let u = (iu as f64 + 0.5) / nu as f64 * q;
        let (mut s1, mut s2) = (0.0, 0.0);
        for k in -kmax..=kmax {
            let lo = ((k as f64 - 0.5) * q - u) / sigma;
            let hi = ((k as f64 + 0.5) * q - u) / sigma;
            let p = normal_sf(lo) - normal_sf(hi);
            let v = k as f64 * q;
            s1 += p * v;
            s2 += p * v * v;
        }
        acc += s2 - s1 * s1;
    }
    acc / nu as f64
}

/// ADC quantisation.
///
/// Method: the distinct sample values of (up to 200 000 of) the samples; when they are few, the step is the
/// common smallest gap between them, and the lattice `offset + k q` is confirmed on 99% of the samples (robust
/// to a few off-lattice ones). It counts when the quantisation noise is not negligible, `q > 0.1 sigma` (sigma the
/// per-sample sd of the white noise, half the mean square first difference). That white noise contains the
/// quantisation noise; the analog N is recovered by inverting the variance of a quantised Gaussian with a uniformly wandering
/// offset (Sheppard's `sigma^2 + q^2/12` when sigma > 2q, computed exactly below).
fn quantization(d: &TrainingData) -> Option<EffectFit> {
    let (q, point) = lattice(d.rate_dps)?;
    let fs = d.fs_hz;
    let x = d.rate_dps;
    // The per-sample white variance from the first differences (half their mean square): below one step the
    // quantised noise is not white at longer tau, so N from the Allan curve would not do.
    let v_white = x.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum::<f64>() / (2.0 * (x.len() - 1) as f64);
    if !(q > 0.1 * v_white.sqrt()) {
        return None;
    }
    // Analog per-sample sd: bisection on quantized_var(sigma) = v_white.
    let (mut lo, mut hi) = (0.0, v_white.sqrt().max(q) * 2.0);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if quantized_var(mid, q) < v_white {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let sigma = 0.5 * (lo + hi);
    let mu = mean(x);
    let k0 = ((mu - point) / q).round();
    let m0 = point + k0 * q;
    let gyro = GyroSim { n_deg_per_rt_s: sigma / fs.sqrt(), bias_dps: mu, ..d.base.clone() };
    Some(EffectFit {
        effect: Effect::Quantization,
        params: json!({"step_dps": q, "lattice_point_dps": m0, "n_deg_per_rt_s": gyro.n_deg_per_rt_s}),
        n_params: 1,
        gyro,
        channel: Some(lattice_channel(q, m0)),
    })
}

/// A generic 16-bit channel whose codes stand for `m0 + (code - 32768) q` deg/s: round to nearest on that lattice.
fn lattice_channel(q: f64, m0: f64) -> Channel {
    let adc = Adc { bits: 16, vref_mv: 3300.0 };
    let sens = adc.mv_per_code() / q;
    let gyro = GyroModel {
        sensitivity_mv_per_dps: sens,
        null_mv: sens * (32768.5 * q - m0),
        range_dps: 32767.0 * q,
        ..GENERIC
    };
    Channel { gyro, front: FrontEnd::WIRE, adc }
}

// ---------------------------------------------------------------------------------------------------------------
// Bias steps.

/// Random bias steps.
///
/// Method: a moving-sum (MOSUM) change-point scan (Eichinger & Kirch 2018, Bernoulli 24): `D(t) = mean(x[t..t+L])
/// - mean(x[t-L..t])` on a grid of L/8, with L the tau of the OADEV minimum (where the bias is best defined;
/// between 16 samples and a 64th of the record). The scale of D is robust (1.4826 MAD, so flicker and random walk
/// set it and the steps barely do), and a step is a local maximum of |D| beyond `max(5, sqrt(2 ln(N/L)) + 2)`
/// scales, at least 2L from a larger one; its time and size are refined on a finer grid. Steps are Gaussian and
/// the small ones go unseen: sigma comes from the truncated-normal likelihood of the sizes seen beyond the
/// threshold, and the rate from the count divided by the detection probability (at least 0.2); fewer than three
/// steps are events, not a process, and give no fit. The base terms are
/// re-fitted on the record without the detected steps (the base fit took their random-walk-like Allan variance,
/// `lambda sigma^2 tau / 3`, for K).
/// Fewest detected steps for a bias-step process.
const MIN_STEPS: usize = 3;

fn bias_steps(d: &TrainingData) -> Option<EffectFit> {
    let x = d.rate_dps;
    let n = x.len();
    let fs = d.fs_hz;
    let pts = oadev_points(x, fs);
    let tau_min = pts.iter().min_by(|a, b| a.avar.total_cmp(&b.avar)).map(|p| p.tau_s)?;
    let l = ((tau_min * fs).round() as usize).clamp(16, (n / 64).max(16));
    if n < 8 * l {
        return None;
    }
    let mu = mean(x);
    let mut pre = Vec::with_capacity(n + 1);
    let mut acc = 0.0;
    pre.push(0.0);
    for v in x {
        acc += v - mu;
        pre.push(acc);
    }
    let dstat = |t: usize| (pre[t + l] - 2.0 * pre[t] + pre[t - l]) / l as f64;
    let h = (l / 8).max(1);
    let grid: Vec<usize> = (l..=n - l).step_by(h).collect();
    let dv: Vec<f64> = grid.iter().map(|&t| dstat(t)).collect();
    let abs: Vec<f64> = dv.iter().map(|v| v.abs()).collect();
    let scale = 1.4826 * median(&abs);
    if !(scale > 0.0) {
        return None;
    }
    let kappa = (2.0 * (n as f64 / l as f64).ln()).sqrt().max(0.0) + 2.0;
    let kappa = kappa.max(5.0);
    let thr = kappa * scale;
    let mut cand: Vec<usize> = (0..grid.len()).filter(|&i| abs[i] > thr).collect();
    cand.sort_by(|&a, &b| abs[b].total_cmp(&abs[a]));
    let mut steps: Vec<(usize, f64)> = Vec::new();
    for i in cand {
        let t = grid[i];
        if steps.iter().all(|&(s, _)| s.abs_diff(t) >= 2 * l) {
            // Refine on a finer grid within +-h.
            let (a, b) = (t.saturating_sub(h).max(l), (t + h).min(n - l));
            let hf = (h / 8).max(1);
            let (tb, db) = (a..=b)
                .step_by(hf)
                .map(|u| (u, dstat(u)))
                .max_by(|p, q| p.1.abs().total_cmp(&q.1.abs()))
                .unwrap_or((t, dv[i]));
            steps.push((tb, db));
        }
    }
    // A rate and a size distribution need a few steps: one or two are events (a knock, a connector), not a
    // process that a simulation could repeat; CATS gyro_y has one jump, and its gap is the temperature's.
    if steps.len() < MIN_STEPS {
        return None;
    }
    let sizes: Vec<f64> = steps.iter().map(|s| s.1).collect();
    // Truncated-normal MLE of sigma given |s| > thr.
    let nll = |sig: f64| -> f64 {
        let pdet = (2.0 * normal_sf(thr / sig)).max(1e-300);
        sizes.iter().map(|s| sig.ln() + s * s / (2.0 * sig * sig)).sum::<f64>() + sizes.len() as f64 * pdet.ln()
    };
    let (sigma, _) = log_search(thr * 0.05, thr * 100.0, 60, nll);
    let pdet = (2.0 * normal_sf(thr / sigma)).max(0.2);
    let hours = n as f64 / fs / 3600.0;
    let per_hour = steps.len() as f64 / pdet / hours;
    // The base terms re-fitted on the record without the detected steps (the base fit took them for K).
    let mut order = steps.clone();
    order.sort_by_key(|s| s.0);
    let mut level = 0.0;
    let mut next = 0;
    let cleaned: Vec<f64> = x
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            while next < order.len() && order[next].0 <= i {
                level += order[next].1;
                next += 1;
            }
            v - level
        })
        .collect();
    let refit = refit_base(d.base, &cleaned, fs).map_or_else(|| d.base.clone(), |r| r.0);
    let gyro = GyroSim { bias_steps: Some(BiasSteps { per_hour, sigma_dps: sigma }), ..refit };
    let at: Vec<f64> = steps.iter().map(|s| s.0 as f64 / fs).collect();
    Some(EffectFit {
        effect: Effect::BiasSteps,
        params: json!({"per_hour": per_hour, "sigma_dps": sigma, "count": steps.len(), "at_s": at,
                       "sizes_dps": sizes, "threshold_dps": thr}),
        n_params: 2,
        gyro,
        channel: None,
    })
}

// ---------------------------------------------------------------------------------------------------------------
// Outliers.

/// Sigmas beyond which an isolated sample is an outlier.
const OUTLIER_SIGMAS: f64 = 6.0;

/// The median of four: the mean of the middle two.
fn median4(mut v: [f64; 4]) -> f64 {
    v.sort_unstable_by(f64::total_cmp);
    0.5 * (v[1] + v[2])
}

/// Isolated spikes.
///
/// Method: the residual of each sample from the median of its four neighbours (two each side; a spike does not
/// move a median and is not shrunk by its own sample in it; steps, drifts and sinusoids slower than a few
/// samples leave no residual), its robust scale 1.4826 MAD (the mean absolute residual times 1.2533 when the MAD is 0 on coarse quantisation); a
/// sample is a spike when its residual exceeds [`OUTLIER_SIGMAS`] scales while its neighbours' do not. A
/// Gaussian record of 1e6 samples leaves about 0.002 such samples. Parameters: the fraction of samples and the
/// median spike size. The base terms are re-fitted with the spikes replaced by their neighbours' median (the
/// base N contained their white variance `p size^2`).
fn outliers(d: &TrainingData) -> Option<EffectFit> {
    let x = d.rate_dps;
    let n = x.len();
    let mut r = vec![0.0; n];
    for i in 2..n - 2 {
        r[i] = x[i] - median4([x[i - 2], x[i - 1], x[i + 1], x[i + 2]]);
    }
    let abs: Vec<f64> = r[2..n - 2].iter().map(|v| v.abs()).collect();
    let mut scale = 1.4826 * median(&abs);
    if !(scale > 0.0) {
        scale = 1.2533 * mean(&abs);
    }
    if !(scale > 0.0) {
        return None;
    }
    let thr = OUTLIER_SIGMAS * scale;
    let big = |i: usize| r[i].abs() > thr;
    let hits: Vec<usize> = (3..n - 3).filter(|&i| big(i) && !big(i - 1) && !big(i + 1)).collect();
    if hits.is_empty() {
        return None;
    }
    let sizes: Vec<f64> = hits.iter().map(|&i| r[i].abs()).collect();
    let size = median(&sizes);
    let p = hits.len() as f64 / (n - 6) as f64;
    let fs = d.fs_hz;
    // The base terms re-fitted with the spikes replaced by their neighbours' median (they added white variance).
    let mut cleaned = x.to_vec();
    for &i in &hits {
        cleaned[i] = x[i] - r[i];
    }
    let refit = refit_base(d.base, &cleaned, fs).map_or_else(|| d.base.clone(), |r| r.0);
    let gyro = GyroSim { outliers: Some(Outliers { per_sample: p, size_dps: size, size_sigma: 0.0 }), ..refit };
    Some(EffectFit {
        effect: Effect::Outliers,
        params: json!({"per_sample": p, "size_dps": size, "count": hits.len(), "robust_sigma_dps": scale}),
        n_params: 2,
        gyro,
        channel: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use octavar_shared::sim::{TemperatureProfile, VirtualGyro, Wander};
    use octavar_shared::sim::temperature::Thermal;
    use octavar_shared::sim::rng::SimRng;
    use octavar_shared::sensor::{Channel, ADXRS300};

    /// The analog rate (and the bench temperature) of `model` for `n` samples.
    fn simulate(model: &GyroSim, fs: f64, n: usize, seed: u64, temp: Option<&TemperatureProfile>) -> (Vec<f64>, Vec<f64>) {
        let mut g = VirtualGyro::new(model, Channel::bench(ADXRS300), fs, seed).unwrap();
        let mut rng = SimRng::new(seed ^ 0xabcdef);
        let p = temp.copied().unwrap_or_default();
        let mut th = Thermal::new(&p, fs, &mut rng);
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
    fn base_of(x: &[f64], fs: f64) -> (GyroSim, NoiseFit) {
        let pts = oadev_points(x, fs);
        let f = fit(&pts, &FitOptions::default()).unwrap();
        (crate::gap::base_model(&f, x), f)
    }

    fn run(effect: Effect, x: &[f64], t: Option<&[f64]>, fs: f64) -> Option<EffectFit> {
        let (g, f) = base_of(x, fs);
        let d = TrainingData { rate_dps: x, temp_c: t, fs_hz: fs, base: &g, base_fit: &f };
        let t0 = std::time::Instant::now();
        let out = estimate(effect, &d);
        eprintln!("{effect}: {:?} in {:?}", out.as_ref().map(|e| &e.params), t0.elapsed());
        out
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
            let fs: f64 = 100.0;
            let temp = TemperatureProfile { min_c: 22.0, max_c: 25.0, period_s: 3600.0, wander: Some(Wander { sigma_c: 0.2, tau_s: 600.0 }), ..Default::default() };
            let (x, t) = simulate(&base_model(), fs, 500_000, seed, Some(&temp));
            let mut alarms = Vec::new();
            for e in Effect::ALL {
                let tc = (e == Effect::Temperature).then_some(&t[..]);
                if let Some(r) = run(e, &x, tc, fs) {
                    alarms.push((e, r.params));
                }
            }
            assert!(alarms.is_empty(), "seed {seed}: false alarms {alarms:?}");
        }
    }

    #[test]
    fn temperature_recovers_coefficient_and_lag() {
        let fs = 50.0;
        let temp = TemperatureProfile { min_c: 20.0, max_c: 30.0, period_s: 3600.0, wander: Some(Wander { sigma_c: 0.5, tau_s: 600.0 }), ..Default::default() };
        let m = GyroSim { temperature: Some(TempCoupling { dps_per_c: 0.02, ref_c: 25.0, lag_s: 300.0 }), ..base_model() };
        let (x, t) = simulate(&m, fs, 500_000, 3, Some(&temp));
        let e = run(Effect::Temperature, &x, Some(&t), fs).unwrap();
        let c = e.gyro.temperature.unwrap();
        // Tolerance: 5% on the coefficient, 20% on the lag.
        assert!(rel(c.dps_per_c, 0.02) < 0.05, "{c:?}");
        assert!(rel(c.lag_s, 300.0) < 0.2, "{c:?}");
    }

    #[test]
    fn sinusoids_recovered() {
        let fs = 200.0;
        let mut m = base_model();
        m.sinusoids.push(Sinusoid { amplitude_dps: 0.02, period_s: 7.3, phase_rad: 0.4 }).unwrap();
        m.sinusoids.push(Sinusoid { amplitude_dps: 0.05, period_s: 0.5, phase_rad: -1.0 }).unwrap();
        let (x, _) = simulate(&m, fs, 1 << 20, 4, None);
        let e = run(Effect::Sinusoid, &x, None, fs).unwrap();
        assert_eq!(e.gyro.sinusoids.len(), 2, "{:?}", e.params);
        let s = &e.gyro.sinusoids;
        // Tolerance: 5% on amplitudes, 1e-3 on periods, 0.1 rad on phases.
        assert!(rel(s[0].amplitude_dps, 0.05) < 0.05 && rel(s[0].period_s, 0.5) < 1e-3, "{s:?}");
        assert!(rel(s[1].amplitude_dps, 0.02) < 0.05 && rel(s[1].period_s, 7.3) < 1e-3, "{s:?}");
        assert!((s[0].phase_rad + 1.0).abs() < 0.1 && (s[1].phase_rad - 0.4).abs() < 0.1, "{s:?}");
    }

    #[test]
    fn long_period_sinusoid_with_decimation() {
        // A day-long period in a 10-day record at 5 Hz (4.3 M samples: the periodogram is block-averaged).
        let fs = 5.0;
        let mut m = base_model();
        m.sinusoids.push(Sinusoid { amplitude_dps: 0.03, period_s: 86_400.0, phase_rad: 1.0 }).unwrap();
        let (x, _) = simulate(&m, fs, 4_320_000, 5, None);
        let e = run(Effect::Sinusoid, &x, None, fs).unwrap();
        let s = e.gyro.sinusoids[0];
        // Flicker (B = 0.005) at 1/day leaves an amplitude error of about 0.0015 deg/s (1 sigma): 15%.
        assert!(rel(s.amplitude_dps, 0.03) < 0.15 && rel(s.period_s, 86_400.0) < 0.02, "{s:?}");
    }

    #[test]
    fn bandwidth_recovered() {
        for (fs, f3) in [(1000.0, 100.0), (1000.0, 20.0)] {
            let m = GyroSim { bandwidth_hz: Some(f3), ..base_model() };
            let (x, _) = simulate(&m, fs, 500_000, 6, None);
            let e = run(Effect::Bandwidth, &x, None, fs).unwrap();
            // Tolerance: 10% on f3dB, 3% on N.
            assert!(rel(e.gyro.bandwidth_hz.unwrap(), f3) < 0.1, "{:?}", e.params);
            assert!(rel(e.gyro.n_deg_per_rt_s, 0.01) < 0.03, "{:?}", e.params);
        }
    }

    #[test]
    fn gauss_markov_recovered() {
        for (fs, sigma, t) in [(100.0, 0.02, 2.0), (10.0, 0.004, 300.0)] {
            let m = GyroSim { gauss_markov: Some(GaussMarkovSim { sigma_dps: sigma, tau_s: t }), ..base_model() };
            let (x, _) = simulate(&m, fs, 1_000_000, 7, None);
            let e = run(Effect::GaussMarkov, &x, None, fs).unwrap();
            let g = e.gyro.gauss_markov.unwrap();
            // Tolerance: 25% on sigma, a factor 1.5 on T (the hump's position on an octave grid).
            assert!(rel(g.sigma_dps, sigma) < 0.25, "{g:?}");
            assert!((g.tau_s / t).ln().abs() < 1.5f64.ln(), "{g:?}");
        }
    }

    #[test]
    fn quantization_recovered() {
        let ch = Channel::bench(ADXRS300);
        let q = ch.dps_per_code();
        let fs: f64 = 500.0;
        // Half a step of white noise, and a random walk that moves the offset over a few steps (the inversion
        // assumes the offset wanders over the lattice).
        let m = GyroSim { n_deg_per_rt_s: 0.5 * q / fs.sqrt(), k_dps_per_rt_s: 0.01, bias_dps: 0.1, ..Default::default() };
        let mut g = VirtualGyro::new(&m, ch, fs, 8).unwrap();
        let x: Vec<f64> = (0..1_000_000).map(|_| ch.code_to_dps(g.next(25.0).code)).collect();
        let e = run(Effect::Quantization, &x, None, fs).unwrap();
        assert!(rel(e.params["step_dps"].as_f64().unwrap(), q) < 1e-6, "{:?}", e.params);
        // The channel puts codes on the data's lattice.
        let c = e.channel.unwrap();
        for &v in x.iter().take(100) {
            assert!((c.code_to_dps(c.dps_to_code(v)) - v).abs() < 1e-6 * q);
        }
        // The analog N is recovered within 15% from the quantised white noise.
        assert!(rel(e.gyro.n_deg_per_rt_s, m.n_deg_per_rt_s) < 0.15, "{:?}", e.params);
    }

    #[test]
    fn bias_steps_recovered() {
        let fs: f64 = 100.0;
        let m = GyroSim { bias_steps: Some(BiasSteps { per_hour: 2.0, sigma_dps: 0.05 }), ..base_model() };
        let (x, _) = simulate(&m, fs, 2_000_000, 9, None);
        let e = run(Effect::BiasSteps, &x, None, fs).unwrap();
        let b = e.gyro.bias_steps.unwrap();
        // 11 expected steps in 5.6 h: Poisson and a handful of sizes, so factor-2 tolerances.
        assert!((b.per_hour / 2.0).ln().abs() < 2f64.ln() && (b.sigma_dps / 0.05).ln().abs() < 2f64.ln(), "{b:?}");
    }

    #[test]
    fn outliers_recovered() {
        let fs: f64 = 100.0;
        let m = GyroSim { outliers: Some(Outliers { per_sample: 1e-4, size_dps: 0.0, size_sigma: 10.0 }), ..base_model() };
        let (x, _) = simulate(&m, fs, 1_000_000, 10, None);
        let e = run(Effect::Outliers, &x, None, fs).unwrap();
        let o = e.gyro.outliers.unwrap();
        let size = 10.0 * 0.01 * fs.sqrt();
        // Tolerance: 25% on the rate (100 events), 5% on the size.
        assert!(rel(o.per_sample, 1e-4) < 0.25 && rel(o.size_dps, size) < 0.05, "{o:?}");
    }
}

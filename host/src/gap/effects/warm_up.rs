//! The warm-up candidate: the bias settling exponentially after power-on, `size exp(-t / tau)` from the record's
//! first sample, found by generalised least squares on block means against the base model's own noise.
//!
//! A warm-up is a deterministic transient at the start of a record. Flicker and random walk wander as far over the
//! same stretch, so an ordinary least-squares fit of an exponential would find one in almost any record; the
//! regression here weighs the block means by the covariance the base model gives them, and a warm-up counts only
//! where it stands out against that. Where the base model has a ramp, a linear trend is fitted beside it, so the
//! ramp is not taken for a warm-up.

use super::params::WarmUpParams;
use octavar_shared::sim::{GyroSim, WarmUpSim};

use super::common::*;
use super::{Effect, EffectFit, EffectKind, TrainingData};

/// Most block means in one regression (the covariance is factorised once per block length).
const MAX_BLOCKS: usize = 256;
/// Shortest block, samples.
const MIN_BLOCK: usize = 4;
/// The time constants tried at a block length: 8 to 16 blocks (four per octave), so the decay spans eight blocks
/// or more and the window 16 time constants or more where the record allows.
const TAU_BLOCKS: [f64; 4] = [8.0, 9.513_656_920_021_768, 11.313_708_498_984_761, 13.454_342_644_059_432];
/// The warm-up counts beyond this many standard errors of its size: on 40 records each of white noise, flicker
/// and random walk, with and without a ramp and a tenfold random walk, the largest of the scan's some fifty
/// correlated t-statistics stayed at or below 3.2 and 4.0 (the test `warm_up_scan_holds_its_threshold_on_noise`).
pub(super) const T_STAT: f64 = 5.0;
/// The first pass, against the base fit's noise (which took part of a warm-up for random walk or ramp, so its
/// t-statistics read low), keeps a candidate beyond this many.
const T_STAT_FIRST: f64 = 3.0;

/// Half the variance of the difference of two block means `k` blocks apart (`k >= 1`), for blocks of `t_s`
/// seconds (`b` samples at `fs`), under the IEEE terms with squares `sq` = [Q^2, N^2, B^2, K^2, R^2] (R is a
/// trend, fitted, not noise): white `N^2 / T`; flicker `(2 B^2 / pi) J(k)` with
/// `J(k) = [-4 ln 2 - 4 k^2 ln 2k + 2 (k+1)^2 ln 2(k+1) + 2 (k-1)^2 ln 2(k-1)] / 8` (the integral of its spectrum
/// through the two block means; `J(1) = ln 2`, the Allan variance); random walk `K^2 T (k - 1/3) / 2`; white
/// angle noise `(Q rate_hz / b)^2` times 3 (neighbours share an end) or 2.
fn semivariogram(sq: &[f64; 5], t_s: f64, b: f64, rate_hz: f64, k: usize) -> f64 {
    if k == 0 {
        return 0.0;
    }
    let kf = k as f64;
    let xlnx = |v: f64| if v > 0.0 { v * v * (2.0 * v).ln() } else { 0.0 };
    let j = (-4.0 * std::f64::consts::LN_2 - 4.0 * xlnx(kf) + 2.0 * xlnx(kf + 1.0) + 2.0 * xlnx(kf - 1.0)) / 8.0;
    let q = (sq[0].sqrt() * rate_hz / b).powi(2) * if k == 1 { 3.0 } else { 2.0 };
    sq[1] / t_s + 2.0 * sq[2] / std::f64::consts::PI * j + sq[3] * t_s * (kf - 1.0 / 3.0) / 2.0 + q
}

/// In-place Cholesky factor (lower) of a symmetric positive definite matrix stored row-major, size `m`; `None`
/// when it is not positive definite.
fn cholesky(a: &mut [f64], m: usize) -> Option<()> {
    for j in 0..m {
        let mut d = a[j * m + j];
        for k in 0..j {
            d -= a[j * m + k] * a[j * m + k];
        }
        if !(d > 0.0) {
            return None;
        }
        let d = d.sqrt();
        a[j * m + j] = d;
        for i in j + 1..m {
            let mut s = a[i * m + j];
            for k in 0..j {
                s -= a[i * m + k] * a[j * m + k];
            }
            a[i * m + j] = s / d;
        }
    }
    Some(())
}

/// Solve `L y = v` in place (forward substitution) for the lower factor `l` of size `m`.
fn forward(l: &[f64], m: usize, v: &mut [f64]) {
    for i in 0..m {
        let mut s = v[i];
        for k in 0..i {
            s -= l[i * m + k] * v[k];
        }
        v[i] = s / l[i * m + i];
    }
}

/// One block length's regression: the whitened contrasts of the block means and of the trend, ready for any tau.
struct Blocks {
    /// Samples per block.
    b: usize,
    /// Block means used.
    nb: usize,
    /// Cholesky factor of the contrasts' covariance.
    l: Vec<f64>,
    /// Whitened contrasts of the block means.
    z: Vec<f64>,
    /// Whitened contrasts of the block index (the trend), where one is fitted.
    t: Option<Vec<f64>>,
}

impl Blocks {
    /// The first `min(n / b, MAX_BLOCKS)` block means of the record whose running sums are `pre`, as contrasts
    /// against the last of them, whitened under the noise of squares `sq`; with a `trend` column or without.
    fn new(pre: &[f64], b: usize, sq: &[f64; 5], rate_hz: f64, trend: bool) -> Option<Blocks> {
        let n = pre.len() - 1;
        let nb = (n / b).min(MAX_BLOCKS);
        if nb < 32 {
            return None;
        }
        let m = nb - 1;
        let y: Vec<f64> = (0..nb).map(|j| (pre[(j + 1) * b] - pre[j * b]) / b as f64).collect();
        let t_s = b as f64 / rate_hz;
        let gam: Vec<f64> = (0..nb).map(|k| semivariogram(sq, t_s, b as f64, rate_hz, k)).collect();
        let last = nb - 1;
        let mut l = vec![0.0; m * m];
        for i in 0..m {
            for j in 0..=i {
                let v = gam[last - i] + gam[last - j] - gam[i - j];
                l[i * m + j] = v;
                l[j * m + i] = v;
            }
        }
        cholesky(&mut l, m)?;
        let mut z: Vec<f64> = (0..m).map(|j| y[j] - y[last]).collect();
        forward(&l, m, &mut z);
        let t = trend.then(|| {
            let mut t: Vec<f64> = (0..m).map(|j| j as f64 - last as f64).collect();
            forward(&l, m, &mut t);
            t
        });
        Some(Blocks { b, nb, l, z, t })
    }

    /// The GLS fit of the contrasts on the warm-up of time constant `tau` samples (block-averaged exactly) and the
    /// trend where there is one: the warm-up's size (deg/s at the first sample) and its standard error.
    fn fit(&self, tau: f64) -> Option<(f64, f64)> {
        let (b, m, last) = (self.b as f64, self.nb - 1, self.nb - 1);
        let d = (-1.0 / tau).exp();
        let scale = -(-b / tau).exp_m1() / (b * -(-1.0 / tau).exp_m1());
        let g_at = |j: usize| d.powf(j as f64 * b) * scale;
        let mut g: Vec<f64> = (0..m).map(|j| g_at(j) - g_at(last)).collect();
        forward(&self.l, m, &mut g);
        let dot = |a: &[f64], c: &[f64]| a.iter().zip(c).map(|(x, y)| x * y).sum::<f64>();
        let (gg, gz) = (dot(&g, &g), dot(&g, &self.z));
        let Some(t) = &self.t else {
            return (gg > 0.0).then(|| (gz / gg, 1.0 / gg.sqrt()));
        };
        let (gt, tt, tz) = (dot(&g, t), dot(t, t), dot(t, &self.z));
        let det = gg * tt - gt * gt;
        if !(det > 0.0) {
            return None;
        }
        Some(((tt * gz - gt * tz) / det, (tt / det).sqrt()))
    }
}

/// The best warm-up over every block length and time constant, with a trend or without: `(size, se, tau_s)` with
/// the largest `|size| / se`.
fn scan(x: &[f64], rate_hz: f64, sq: &[f64; 5], trend: bool) -> Option<(f64, f64, f64)> {
    let n = x.len();
    let mut pre = Vec::with_capacity(n + 1);
    let mut acc = 0.0;
    pre.push(0.0);
    for v in x {
        acc += v;
        pre.push(acc);
    }
    let mut best: Option<(f64, f64, f64)> = None;
    let mut b = MIN_BLOCK;
    while 8 * b <= n / 4 {
        if let Some(blocks) = Blocks::new(&pre, b, sq, rate_hz, trend) {
            for &k in &TAU_BLOCKS {
                let tau = k * b as f64;
                if tau > n as f64 / 4.0 {
                    break;
                }
                if let Some((size, se)) = blocks.fit(tau) {
                    if best.is_none_or(|(s, e, _)| (size / se).abs() > (s / e).abs()) {
                        best = Some((size, se, tau / rate_hz));
                    }
                }
            }
        }
        b *= 2;
    }
    best
}

/// The scan's largest |t| on `x` under the noise of squares `sq`, with a trend or without (for the threshold's
/// test).
#[cfg(test)]
pub(super) fn largest_t(x: &[f64], rate_hz: f64, sq: &[f64; 5], trend: bool) -> f64 {
    scan(x, rate_hz, sq, trend).map_or(0.0, |(s, e, _)| (s / e).abs())
}

/// The warmup effect: [`warm_up`] and its parameters.
pub(super) struct Kind;

impl EffectKind for Kind {
    const EFFECT: Effect = Effect::WarmUp;
    type Params = WarmUpParams;

    fn estimate(data: &TrainingData) -> Option<EffectFit> {
        warm_up(data)
    }

    fn test_statistic(p: &WarmUpParams) -> Option<f64> {
        Some(p.t_stat)
    }

    /// The joint fit moves the size; the time constant is held.
    fn reestimated(p: &WarmUpParams, gyro: &GyroSim) -> WarmUpParams {
        WarmUpParams { size_dps: gyro.warm_up.map_or(p.size_dps, |w| w.size_dps), ..p.clone() }
    }
}

/// The bias settling after power-on.
///
/// Method: block means at block lengths on an octave grid from 4 samples (at most 256 blocks each, from the
/// record's start), as contrasts against the last block used, regressed by generalised least squares on the
/// warm-up `exp(-t / tau)` averaged over each block exactly (t from the first sample), and on a linear trend where
/// the base model has a ramp (else a warm-up of a long tau would be half taken by the trend); the
/// covariance is the one the base model's IEEE terms give block means (white, flicker and random walk, through
/// their semivariogram, [`semivariogram`]). tau runs over 8 to 16 blocks at each block length, four per octave,
/// up to a quarter of the record; the largest t-statistic of the size wins. Two passes, as for the temperature
/// coupling: the base fit's noise first (it took part of the warm-up for random walk or ramp), then the noise
/// of the IEEE fit of the record less that warm-up, which also gives the model's base terms. The warm-up counts
/// beyond [`T_STAT`] standard errors.
pub(super) fn warm_up(d: &TrainingData) -> Option<EffectFit> {
    let x = d.rate_dps;
    let rate_hz = d.rate_hz;
    let trend = d.base.r_dps_per_s != 0.0;
    let (size1, se1, tau1) = scan(x, rate_hz, &d.base_fit.squares, trend)?;
    if !((size1 / se1).abs() > T_STAT_FIRST) {
        return None;
    }
    let cleaned_of = |size: f64, tau_s: f64| -> Vec<f64> {
        let decay = (-1.0 / (rate_hz * tau_s)).exp();
        let mut w = size;
        x.iter()
            .map(|&v| {
                let out = v - w;
                w *= decay;
                out
            })
            .collect()
    };
    let (_, squares) = refit_base(d.base, d.gaps, &cleaned_of(size1, tau1), rate_hz)?;
    let (size, se, tau_s) = scan(x, rate_hz, &squares, trend)?;
    if !((size / se).abs() > T_STAT) {
        return None;
    }
    let (refit, _) = refit_base(d.base, d.gaps, &cleaned_of(size, tau_s), rate_hz)?;
    let gyro = GyroSim { warm_up: Some(WarmUpSim { size_dps: size, tau_s }), ..refit };
    Some(EffectFit {
        effect: Effect::WarmUp,
        params: WarmUpParams { size_dps: size, tau_s, size_se_dps: se, t_stat: size / se }.into(),
        n_params: 2,
        gyro,
        channel: None,
        spread: None,
        cleaned: None,
    })
}

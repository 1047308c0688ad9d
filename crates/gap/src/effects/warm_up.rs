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
use octavar_stats::linalg::{cholesky, forward_solve};

/// Most block means in one regression (the covariance is factorised once per block length).
const MAX_BLOCKS: usize = 256;
/// Shortest block, samples.
const MIN_BLOCK: usize = 4;
/// The longest time constant tried, as a share of the record: a warm-up that has not settled by the record's end
/// still bends the bias in a way random walk does not, and a time constant of a third of a whole recording is two
/// thirds of its training part.
const LONGEST_TAU: f64 = 0.7;
/// The warm-up counts beyond this many standard errors of its size: on 40 records each of white noise, flicker
/// and random walk, with and without a ramp and a tenfold random walk, the largest of the scan's some fifty
/// correlated t-statistics stayed at or below 3.2 and 4.0 (the test `warm_up_scan_holds_its_threshold_on_noise`).
pub(super) const T_STAT: f64 = 5.0;
/// How much more of the block means' chi-square a warm-up fitted without the trend must take than the trend
/// alone, where the base model has a ramp, for the warm-up to replace the ramp: a time constant is searched where
/// the slope is not, and a true ramp is a straight line that an exponential follows only in part.
const RAMP_MARGIN_CHI2: f64 = 9.0;
/// The first pass, against the base fit's noise (which took part of a warm-up for random walk or ramp, so its
/// t-statistics read low), keeps a candidate beyond this many.
const T_STAT_FIRST: f64 = 3.0;

/// The noise a warm-up is weighed against: the model's IEEE terms and its Gauss-Markov process (a flicker fit
/// reads a Gauss-Markov process as bias instability, whose block means wander far more than the process's do).
#[derive(Clone, Copy, Debug)]
pub(super) struct BlockNoise {
    /// [Q^2, N^2, B^2, K^2]: deg^2, (deg/s)^2 s, (deg/s)^2, (deg/s)^2/s.
    squares: [f64; 4],
    /// The Gauss-Markov process's variance, (deg/s)^2, and correlation time, s.
    gauss_markov: Option<(f64, f64)>,
}

impl BlockNoise {
    /// The noise of `gyro`'s stochastic terms (its ramp is a trend, fitted, not noise).
    pub(super) fn of(gyro: &GyroSim) -> Self {
        BlockNoise {
            squares: ieee_squares(gyro),
            gauss_markov: gyro.gauss_markov.as_ref().map(|g| (g.sigma_dps * g.sigma_dps, g.tau_s)),
        }
    }

    /// Half the variance of the difference of two block means `k` blocks apart, for `k` in `0..count`, blocks of
    /// `b` samples at `rate_hz` (`t_s` seconds). The IEEE terms: white `N^2 / T`; flicker `(2 B^2 / pi) J(k)` with
    /// `J(k) = [-4 ln 2 - 4 k^2 ln 2k + 2 (k+1)^2 ln 2(k+1) + 2 (k-1)^2 ln 2(k-1)] / 8` (the integral of its
    /// spectrum through the two block means; `J(1) = ln 2`, the Allan variance); random walk `K^2 T (k - 1/3) / 2`;
    /// white angle noise `(Q rate_hz / b)^2` times 3 (neighbours share an end) or 2. The Gauss-Markov process, the
    /// sampled AR(1) of pole `a` and variance `v`: `C(0) - C(k)`, the block means' covariances
    /// `C(0) = v/b^2 sum_{|d|<b} (b - |d|) a^|d|` and `C(k) = v/b^2 a^(kb) sum_{|d|<b} (b - |d|) a^d`.
    fn semivariogram(&self, b: usize, rate_hz: f64, count: usize) -> Vec<f64> {
        let [q2, n2, b2, k2] = self.squares;
        let (bf, t_s) = (b as f64, b as f64 / rate_hz);
        let xlnx = |v: f64| if v > 0.0 { v * v * (2.0 * v).ln() } else { 0.0 };
        let gm = self.gauss_markov.filter(|&(v, t)| v > 0.0 && t > 0.0).map(|(v, t)| {
            let a = (-1.0 / (rate_hz * t)).exp();
            let (mut c0, mut g) = (bf, bf);
            let mut p = 1.0;
            for d in 1..b {
                p *= a;
                let w = bf - d as f64;
                c0 += 2.0 * w * p;
                g += w * (p + 1.0 / p);
            }
            (v / (bf * bf), a.powf(bf), c0, g)
        });
        (0..count)
            .map(|k| {
                if k == 0 {
                    return 0.0;
                }
                let kf = k as f64;
                let j = (-4.0 * std::f64::consts::LN_2 - 4.0 * xlnx(kf) + 2.0 * xlnx(kf + 1.0) + 2.0 * xlnx(kf - 1.0))
                    / 8.0;
                let q = q2 * (rate_hz / bf).powi(2) * if k == 1 { 3.0 } else { 2.0 };
                let ieee = n2 / t_s + 2.0 * b2 / std::f64::consts::PI * j + k2 * t_s * (kf - 1.0 / 3.0) / 2.0 + q;
                let markov = gm.map_or(0.0, |(scale, ab, c0, g)| scale * (c0 - ab.powf(kf) * g));
                ieee + markov
            })
            .collect()
    }
}

/// One block length's regression: the whitened contrasts of the block means and of the trend, ready for any tau.
struct Blocks {
    /// Samples per block.
    b: usize,
    /// Block means used.
    nb: usize,
    /// Cholesky factor of the contrasts' covariance.
    l: Vec<Vec<f64>>,
    /// Whitened contrasts of the block means.
    z: Vec<f64>,
    /// Whitened contrasts of the block index (the trend), where one is fitted.
    t: Option<Vec<f64>>,
}

impl Blocks {
    /// The first `min(n / b, MAX_BLOCKS)` block means of the record whose running sums are `pre`, as contrasts
    /// against the last of them, whitened under `noise`; with a `trend` column or without.
    fn new(pre: &[f64], b: usize, noise: &BlockNoise, rate_hz: f64, trend: bool) -> Option<Blocks> {
        let n = pre.len() - 1;
        let nb = (n / b).min(MAX_BLOCKS);
        if nb < 32 {
            return None;
        }
        let m = nb - 1;
        let y: Vec<f64> = (0..nb).map(|j| (pre[(j + 1) * b] - pre[j * b]) / b as f64).collect();
        let gam = noise.semivariogram(b, rate_hz, nb);
        let last = nb - 1;
        let cov: Vec<Vec<f64>> =
            (0..m).map(|i| (0..m).map(|j| gam[last - i] + gam[last - j] - gam[i.abs_diff(j)]).collect()).collect();
        let l = cholesky(&cov)?;
        let z = forward_solve(&l, &(0..m).map(|j| y[j] - y[last]).collect::<Vec<_>>());
        let t = trend.then(|| forward_solve(&l, &(0..m).map(|j| j as f64 - last as f64).collect::<Vec<_>>()));
        Some(Blocks { b, nb, l, z, t })
    }

    /// The GLS fit of the contrasts on the warm-up of time constant `tau` samples (block-averaged exactly) and the
    /// trend where there is one and `with_trend` asks for it: the warm-up's size (deg/s at the first sample) and its
    /// standard error.
    fn fit(&self, tau: f64, with_trend: bool) -> Option<(f64, f64)> {
        let (b, m, last) = (self.b as f64, self.nb - 1, self.nb - 1);
        let d = (-1.0 / tau).exp();
        let scale = -(-b / tau).exp_m1() / (b * -(-1.0 / tau).exp_m1());
        let g_at = |j: usize| d.powf(j as f64 * b) * scale;
        let g = forward_solve(&self.l, &(0..m).map(|j| g_at(j) - g_at(last)).collect::<Vec<_>>());
        let dot = |a: &[f64], c: &[f64]| a.iter().zip(c).map(|(x, y)| x * y).sum::<f64>();
        let (gg, gz) = (dot(&g, &g), dot(&g, &self.z));
        let Some(t) = self.t.as_ref().filter(|_| with_trend) else {
            return (gg > 0.0).then(|| (gz / gg, 1.0 / gg.sqrt()));
        };
        let (gt, tt, tz) = (dot(&g, t), dot(t, t), dot(t, &self.z));
        let det = gg * tt - gt * gt;
        if !(det > 0.0) {
            return None;
        }
        Some(((tt * gz - gt * tz) / det, (tt / det).sqrt()))
    }

    /// The chi-square the trend alone takes from the contrasts (0 without a trend column).
    fn trend_chi2(&self) -> f64 {
        self.t.as_ref().map_or(0.0, |t| {
            let (tt, tz) = t.iter().zip(&self.z).fold((0.0, 0.0), |(a, b), (x, z)| (a + x * x, b + x * z));
            if tt > 0.0 {
                tz * tz / tt
            } else {
                0.0
            }
        })
    }
}

/// The best warm-up over every block length and time constant, with a trend or without: `(size, se, tau_s)` with
/// the largest `|size| / se`. With a trend, a warm-up fitted without it that takes [`RAMP_MARGIN_CHI2`] more of
/// the block means' chi-square than the trend alone wins over any fitted beside the trend: the base fit read the
/// warm-up's long tail as a ramp.
fn scan(x: &[f64], rate_hz: f64, noise: &BlockNoise, trend: bool) -> Option<(f64, f64, f64)> {
    let n = x.len();
    let mut pre = Vec::with_capacity(n + 1);
    let mut acc = 0.0;
    pre.push(0.0);
    for v in x {
        acc += v;
        pre.push(acc);
    }
    // The best fit and where it was found: (size, se, tau_s), with its block length and the longest tau allowed
    // there, samples.
    type Found = Option<((f64, f64, f64), usize, f64)>;
    let (mut best, mut instead_of_ramp): (Found, Found) = (None, None);
    let better =
        |best: &Found, (size, se): (f64, f64)| best.is_none_or(|((s, e, _), _, _)| (size / se).abs() > (s / e).abs());
    let mut b = MIN_BLOCK;
    while 8 * b <= n / 4 {
        // The longest block length (the next would leave fewer than 32 blocks) carries the time constants on,
        // four per octave, up to LONGEST_TAU of the record.
        let longest = 16 * b > n / 4;
        let taus = (0..).map(|j| 8.0 * 2f64.powf(j as f64 / 4.0)).take_while(|&k| longest || k < 16.0);
        let reach = n as f64 * if longest { LONGEST_TAU } else { 0.25 };
        if let Some(blocks) = Blocks::new(&pre, b, noise, rate_hz, trend) {
            let trend_chi2 = blocks.trend_chi2();
            for k in taus {
                let tau = k * b as f64;
                if tau > reach {
                    break;
                }
                if let Some(fit) = blocks.fit(tau, true) {
                    if better(&best, fit) {
                        best = Some(((fit.0, fit.1, tau / rate_hz), b, reach));
                    }
                }
                if let Some(fit @ (size, se)) = blocks.fit(tau, false).filter(|_| trend) {
                    if (size / se).powi(2) > trend_chi2 + RAMP_MARGIN_CHI2 && better(&instead_of_ramp, fit) {
                        instead_of_ramp = Some(((size, se, tau / rate_hz), b, reach));
                    }
                }
            }
        }
        b *= 2;
    }
    let with_trend = instead_of_ramp.is_none();
    let (found, b, reach) = instead_of_ramp.or(best)?;
    Some(match Blocks::new(&pre, b, noise, rate_hz, trend) {
        Some(blocks) => blocks.refined_tau(found, reach, rate_hz, with_trend),
        None => found,
    })
}

impl Blocks {
    /// The time constant between the scan's grid points: the grid steps by a quarter octave, which leaves a
    /// warm-up's tau up to a tenth off and, beside a warm-up of many standard errors, a residue of its decay that a
    /// later step reads as an effect of its own. So the fit's `|size| / se` is maximised over tau (the profile
    /// likelihood of the GLS fit at the block length the grid's best `found`, `(size, se, tau_s)`, was found at)
    /// by Brent's search within a grid step either side of it, up to the scan's `reach` (samples); `found` stands
    /// where the search finds no better.
    fn refined_tau(&self, found: (f64, f64, f64), reach: f64, rate_hz: f64, with_trend: bool) -> (f64, f64, f64) {
        let tau0 = found.2 * rate_hz;
        let step = 2f64.powf(0.25);
        let (lo, hi) = ((tau0 / step).ln(), (tau0 * step).min(reach).max(tau0).ln());
        let t_of = |ln_tau: f64| self.fit(ln_tau.exp(), with_trend).map_or(f64::NAN, |(s, e)| -(s / e).abs());
        let (ln_tau, neg_t) = brent(lo, hi, 1e-3, 24, t_of);
        match self.fit(ln_tau.exp(), with_trend) {
            Some((size, se)) if -neg_t > (found.0 / found.1).abs() => (size, se, ln_tau.exp() / rate_hz),
            _ => found,
        }
    }
}

/// The scan's largest |t| on `x` under `noise`, with a trend or without (for the threshold's
/// test).
#[cfg(test)]
pub(super) fn largest_t(x: &[f64], rate_hz: f64, noise: &BlockNoise, trend: bool) -> f64 {
    scan(x, rate_hz, noise, trend).map_or(0.0, |(s, e, _)| (s / e).abs())
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
/// Method: block means at block lengths on an octave grid from 4 samples (at most 256 blocks each, from the record's
/// start), as contrasts against the last block used, regressed by generalised least squares on the warm-up `exp(-t /
/// tau)` averaged over each block exactly (t from the first sample), and on a linear trend where the base model has a
/// ramp (else a warm-up of a long tau would be half taken by the trend; a warm-up without the trend that explains the
/// block means better than the trend replaces it, [`scan`]); the covariance is the one the model's noise gives block
/// means (white, flicker, random walk and a Gauss-Markov process, through their semivariogram,
/// [`BlockNoise::semivariogram`]). tau runs over 8 to 16 blocks at each block length, four per octave, up to a quarter
/// of the record, and on at the longest block length up to [`LONGEST_TAU`] of it; the largest t-statistic of the size
/// wins, its tau refined between the grid's points ([`Blocks::refined_tau`]). Two passes, as for the temperature
/// coupling. The first proposes a warm-up under two noises: the base fit's, and the base fit's without random walk and
/// ramp (the base fit took the warm-up's long tail for them, and a warm-up over half the record then looks like their
/// wander). Each proposal beyond [`T_STAT_FIRST`] is taken out and the IEEE terms refitted on what is left; the second
/// pass scans again under that refit's noise, which also gives the model's base terms, and the proposal whose second
/// pass has the larger t-statistic is kept. The warm-up counts beyond [`T_STAT`] standard errors of that second pass,
/// which weighs it against the noise the record has without it.
pub(super) fn warm_up(d: &TrainingData) -> Option<EffectFit> {
    let x = d.rate_dps;
    let rate_hz = d.rate_hz;
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
    // The first pass's noises: the base fit's, and the base fit's without its random walk and ramp, which may be
    // the warm-up's own long tail.
    let noise = samples_noise(d);
    let quiet = GyroSim { k_dps_per_rt_s: 0.0, r_dps_per_s: 0.0, ..noise.clone() };
    let firsts = [&noise, &quiet].map(|g| scan(x, rate_hz, &BlockNoise::of(g), g.r_dps_per_s != 0.0));
    let (size, se, tau_s) = firsts
        .into_iter()
        .flatten()
        .filter(|&(size1, se1, _)| (size1 / se1).abs() > T_STAT_FIRST)
        .filter_map(|(size1, _, tau1)| {
            let (refit1, _) = refit_noise(d, &cleaned_of(size1, tau1))?;
            scan(x, rate_hz, &BlockNoise::of(&refit1), refit1.r_dps_per_s != 0.0)
        })
        .max_by(|a, b| (a.0 / a.1).abs().total_cmp(&(b.0 / b.1).abs()))?;
    if !((size / se).abs() > T_STAT) {
        return None;
    }
    // As the temperature coupling's: where the base terms cannot be re-fitted, the model's stand.
    let refit = refit_base(d, &cleaned_of(size, tau_s), size / se).map_or_else(|| d.base.clone(), |r| r.0);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::curve::gm_avar;
    use octavar_shared::sim::rng::SimRng;
    use octavar_shared::sim::GaussMarkovSim;

    /// A warm-up whose time constant lies midway (in octaves) between two of the scan's grid points, in white
    /// noise far below it: the grid alone reads tau up to a tenth off; the refined tau comes back within 2% of the
    /// truth the record was drawn with, and the size within 2%.
    #[test]
    fn a_time_constant_between_grid_points_is_read_to_the_truth() {
        let rate_hz: f64 = 10.0;
        let n = 200_000;
        // Grid points sit at 2^(j/4) samples: 2^(13 + 1/8) is midway between two of them.
        let tau_samples = 2f64.powf(13.125);
        let (size, sd) = (1.0, 0.05);
        let mut rng = SimRng::new(7);
        let x: Vec<f64> = (0..n).map(|i| size * (-(i as f64) / tau_samples).exp() + sd * rng.normal()).collect();
        let gyro = GyroSim { n_deg_per_rt_s: sd / rate_hz.sqrt(), ..Default::default() };
        let (s, _, tau_s) = scan(&x, rate_hz, &BlockNoise::of(&gyro), false).expect("a warm-up");
        let truth_s = tau_samples / rate_hz;
        assert!((tau_s / truth_s - 1.0).abs() < 0.02, "tau {tau_s} s for {truth_s} s");
        assert!((s / size - 1.0).abs() < 0.02, "size {s} for {size}");
    }

    /// Two neighbouring block means differ by the Allan variance at the block's length, so the Gauss-Markov
    /// part of the semivariogram at one block is the process's Allan variance (curve.rs's exact AR(1) form), at
    /// blocks shorter and longer than its correlation time; far apart, the block means are independent, and the
    /// semivariogram tends to the block mean's variance.
    #[test]
    fn the_gauss_markov_semivariogram_is_its_allan_variance_at_one_block() {
        let rate_hz = 10.0;
        let gm = GaussMarkovSim { sigma_dps: 0.3, tau_s: 2.0 };
        let noise = BlockNoise::of(&GyroSim { gauss_markov: Some(gm), ..Default::default() });
        for b in [1usize, 4, 20, 64, 500] {
            let g = noise.semivariogram(b, rate_hz, 400);
            let tau = b as f64 / rate_hz;
            let avar = 0.09 * gm_avar(2.0, tau, 1.0 / rate_hz);
            assert!((g[1] / avar - 1.0).abs() < 1e-9, "b {b}: {} against {avar}", g[1]);
            // Far apart: C(k) -> 0, so gamma -> C(0), the block mean's variance, which is 2 T / (b tau0) of the
            // process's for blocks much longer than T.
            if b >= 64 {
                let c0 = g[399];
                let expected = 0.09 * 2.0 * 2.0 / tau * (1.0 - 2.0 / tau * (1.0 - (-tau / 2.0).exp()));
                assert!((c0 / expected - 1.0).abs() < 0.02, "b {b}: {c0} against {expected}");
            }
        }
    }
}

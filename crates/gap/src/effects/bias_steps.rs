//! The bias-steps candidate: random steps of the bias, found by a windowed scan of mean differences.

use super::params::BiasStepsParams;
use octavar_shared::sim::{BiasSteps, GyroSim};
use std::sync::Arc;

use super::common::*;
use super::{Effect, EffectFit, EffectKind, ParamSpread, TrainingData};

/// Fewest detected steps that show a process by their number: from it on, the steps need not be sharp
/// ([`is_sharp`]), the base terms are re-fitted on the record without them, and the chain takes them out of the
/// samples.
pub(super) const PROCESS_STEPS: usize = 3;

/// The scan's threshold in robust scales of its statistic: `max(FLOOR, sqrt(2 ln(N/L)) + MARGIN)`.
/// `sqrt(2 ln(N/L))` is about the largest of the N/L independent windows' Gaussian noise. The margin is lower
/// than a threshold for one event alone would need (noise passes it in about one record in ten), since a peak
/// only names the process through the views: the estimator has no test of its own, and a step is named only
/// where its simulation takes a significant gap of the record away.
const THRESHOLD_MARGIN: f64 = 1.5;
/// The threshold's floor, in robust scales.
const THRESHOLD_FLOOR: f64 = 4.5;

/// What the moving-sum scan found.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Scan {
    /// The threshold on |D|, deg/s.
    pub threshold: f64,
    /// Each step's sample index and size, deg/s, largest first.
    pub steps: Vec<(usize, f64)>,
}

/// The scan's window L, samples: the tau of the OADEV minimum, between 16 samples and a 64th of the record;
/// `None` for a record shorter than 8 windows.
pub(super) fn scan_window(x: &[f64], rate_hz: f64) -> Option<usize> {
    let n = x.len();
    let pts = oadev_points(x, rate_hz);
    let tau_min = pts.iter().min_by(|a, b| a.avar.total_cmp(&b.avar)).map(|p| p.tau_s)?;
    let l = ((tau_min * rate_hz).round() as usize).clamp(16, (n / 64).max(16));
    (n >= 8 * l).then_some(l)
}

/// The moving-sum scan of `x` at window `l` (see [`bias_steps`]), keeping one step of any two closer than two
/// windows; `None` when the statistic has no scale.
pub(super) fn mosum_scan(x: &[f64], l: usize) -> Option<Scan> {
    mosum_scan_apart(x, l, 2 * l)
}

/// The moving-sum scan of `x` at window `l`, keeping one step of any two closer than `apart` samples. A lone
/// step's mean difference falls linearly to zero a window either side of it, so `apart` of one window or more
/// never counts one step twice.
pub(super) fn mosum_scan_apart(x: &[f64], l: usize, apart: usize) -> Option<Scan> {
    let n = x.len();
    if l == 0 || n < 2 * l + 1 {
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
    let kappa = ((2.0 * (n as f64 / l as f64).ln()).sqrt() + THRESHOLD_MARGIN).max(THRESHOLD_FLOOR);
    let threshold = kappa * scale;
    let mut cand: Vec<usize> = (0..grid.len()).filter(|&i| abs[i] > threshold).collect();
    cand.sort_by(|&a, &b| abs[b].total_cmp(&abs[a]));
    let mut steps: Vec<(usize, f64)> = Vec::new();
    for i in cand {
        let t = grid[i];
        if steps.iter().all(|&(s, _)| s.abs_diff(t) >= apart) {
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
    Some(Scan { threshold, steps })
}

/// The share of a step's size that the mean difference across windows a quarter as long must keep for a lone
/// step to count as a step ([`is_sharp`]).
const SHARPNESS: f64 = 0.5;

/// Whether the change of size `size` the scan found at sample `t` with window `l` is sharp: a step keeps its size
/// in the mean difference across windows of `l / 4` (within an eighth of a window of where the scan put it),
/// while a smooth change over a time longer than the window (a warm-up settling, found where its decay meets the
/// record's start) keeps about a quarter. Where a process shows only one or two steps, each must be sharp and at least two
/// windows from either end of the record; a run of steps proves itself by their number.
fn is_sharp(x: &[f64], l: usize, t: usize, size: f64) -> bool {
    // Within two windows of an end, a change cannot be told from a start settling (a warm-up) or an end drifting.
    if t < 2 * l || t + 2 * l > x.len() {
        return false;
    }
    let q = (l / 4).max(1);
    let mean = |a: usize, b: usize| x[a..b].iter().sum::<f64>() / (b - a) as f64;
    // The scan placed the step within an eighth of a window (its grid refined); a step keeps its size there.
    let (lo, hi) = (t - l / 8, t + l / 8);
    let step = (l / 32).max(1);
    (lo..=hi).step_by(step).any(|u| ((mean(u, u + q) - mean(u - q, u)) * size.signum()) >= SHARPNESS * size.abs())
}

/// The bias level the `steps` (sample index, signed size; any order) build over `n` samples, from 0 before the
/// first.
fn step_levels(steps: &[(usize, f64)], n: usize) -> Vec<f64> {
    let mut order = steps.to_vec();
    order.sort_by_key(|s| s.0);
    let mut level = 0.0;
    let mut next = 0;
    (0..n)
        .map(|i| {
            while next < order.len() && order[next].0 <= i {
                level += order[next].1;
                next += 1;
            }
            level
        })
        .collect()
}

/// The steps the scan at window `l` finds in `x`, as the bias level they build ([`step_levels`]), its mean taken
/// out: what [`bias_steps`] takes out of the samples, found again on any series by the same scan. `None` when the
/// scan has no scale.
pub(super) fn recovered_levels(x: &[f64], l: usize) -> Option<Vec<f64>> {
    let scan = mosum_scan(x, l)?;
    let mut levels = step_levels(&scan.steps, x.len());
    let m = mean(&levels);
    levels.iter_mut().for_each(|v| *v -= m);
    Some(levels)
}

/// `base` with the random walk of a bias-step process of power `walk` (`lambda sigma^2`, (deg/s)^2/s) taken out
/// of its rate random walk: `K^2 - lambda sigma^2`, at least 0. A compound Poisson walk of Gaussian steps has the
/// Allan variance `lambda sigma^2 tau / 3` at every tau, a rate random walk's exactly, so the base fit read it as
/// K and nothing else.
///
/// This is the base beside steps found after an earlier step took jumps out of the samples (a bistable bias's
/// levels). An IEEE re-fit there reads the curve of the samples less both, whose short taus carry the recovery's
/// residue (a flip or a step placed a sample off is a one-sample pulse of its size), as quantisation noise, and
/// its model then parts from the record where the steps change nothing.
fn less_step_walk(base: &GyroSim, walk: f64) -> GyroSim {
    let k2 = base.k_dps_per_rt_s * base.k_dps_per_rt_s;
    GyroSim { k_dps_per_rt_s: (k2 - walk).max(0.0).sqrt(), ..base.clone() }
}

/// The biassteps effect: [`bias_steps`] and its parameters.
pub(super) struct Kind;

impl EffectKind for Kind {
    const EFFECT: Effect = Effect::BiasSteps;
    type Params = BiasStepsParams;

    fn estimate(data: &TrainingData) -> Option<EffectFit> {
        bias_steps(data)
    }
}

/// Random bias steps.
///
/// Method: a moving-sum (MOSUM) change-point scan (Eichinger & Kirch 2018, Bernoulli 24):
/// `D(t) = mean(x[t..t+L]) - mean(x[t-L..t])` on a grid of L/8, with L the tau of the OADEV minimum (where the
/// bias is best defined; between 16 samples and a 64th of the record). The scale of D is robust (1.4826 MAD, so
/// flicker and random walk set it and the steps barely do), and a step is a local maximum of |D| beyond
/// `max(4.5, sqrt(2 ln(N/L)) + 1.5)` scales ([`THRESHOLD_MARGIN`]), at least 2L from a larger one; its time
/// and size are refined on a finer grid. Steps are Gaussian and the small ones go unseen: sigma comes from the
/// truncated-normal likelihood of the sizes seen beyond the threshold, and the rate from the count divided by the
/// detection probability (at least 0.2). A single step gives a fit: a Poisson process seen through half a record
/// often leaves one or two steps there, and the views decide whether the process explains the gap (a moment fit
/// from D's fourth cumulant cannot stand in for the scan: over 16 blocks its t-statistic is no larger on step
/// records than on effect-free ones). From
/// [`PROCESS_STEPS`] steps on, the base terms are re-fitted on the record without the detected steps (the base fit
/// took their random-walk-like Allan variance, `lambda sigma^2 tau / 3`, for K).
pub(super) fn bias_steps(d: &TrainingData) -> Option<EffectFit> {
    let x = d.rate_dps;
    let n = x.len();
    let rate_hz = d.rate_hz;
    let l = scan_window(x, rate_hz)?;
    let Scan { threshold: thr, mut steps } = mosum_scan(x, l)?;
    let lone = steps.len() < PROCESS_STEPS;
    if lone {
        steps.retain(|&(t, size)| is_sharp(x, l, t, size));
    }
    // One step is enough to fit the process: a Poisson rate seen through a training part may leave a single step
    // there and many in the held-out part, and the views, not a count, judge whether the process explains the
    // record (a knock or a connector's jump is a transient, masked before the chain).
    if steps.is_empty() {
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
    let hours = n as f64 / rate_hz / 3600.0;
    let per_hour = steps.len() as f64 / pdet / hours;
    // The base terms re-fitted on the record without the detected steps (the base fit took them for K).
    let cleaned: Vec<f64> = x.iter().zip(step_levels(&steps, n)).map(|(v, l)| v - l).collect();
    // One or two steps barely move the Allan curve, so the base terms stay as they are: a re-fit there would
    // change the model by the re-fit, not by the steps, and the views would judge the wrong thing.
    let refit = if lone {
        d.base.clone()
    } else if d.shaped_dps.is_some() {
        less_step_walk(d.base, per_hour / 3600.0 * sigma * sigma)
    } else {
        refit_base(d, &cleaned, f64::INFINITY).map_or_else(|| d.base.clone(), |r| r.0)
    };
    let gyro = GyroSim { bias_steps: Some(BiasSteps { per_hour, sigma_dps: sigma }), ..refit };
    let at: Vec<f64> = steps.iter().map(|s| s.0 as f64 / rate_hz).collect();
    Some(EffectFit {
        effect: Effect::BiasSteps,
        params: BiasStepsParams {
            per_hour,
            sigma_dps: sigma,
            count: steps.len(),
            at_s: at,
            sizes_dps: sizes,
            threshold_dps: thr,
        }
        .into(),
        n_params: 2,
        gyro,
        channel: None,
        spread: Some(ParamSpread::StepRate { steps: steps.len() as f64 }),
        // A lone step or two is named as a process the views judge, not as a realisation the chain takes out:
        // taken out, a jump that falls with a temperature swing would take the record's coherence with the
        // temperature along with it (CATS gyro_y), and the temperature view would credit the steps.
        cleaned: (!lone).then(|| Arc::new(cleaned)),
    })
}

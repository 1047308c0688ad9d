//! The bistable candidate: a bias that flips between two levels at random (random telegraph noise, popcorn noise),
//! found as jumps of one size that alternate in sign.
//!
//! Its Allan variance is exactly a Gauss-Markov process's (correlation time `1 / (l1 + l2)`), so the Allan curve
//! cannot tell the two apart; nor can the jump scan of the bias-steps candidate alone, which sees a jump either
//! way. What only a bistable bias has: every jump is the same size, and an up-jump is always followed by a down-jump
//! (the bias returns to the level it left), where random bias steps (a random walk of Gaussian jumps) go up or down
//! at random and by any amount.

use super::params::BistableParams;
use octavar_shared::sim::{BistableSim, GyroSim};
use std::sync::Arc;

use super::bias_steps::mosum_scan_apart;
use super::common::*;
use super::curve::{
    base_columns, filtered_gm_avar, joint_fit, joint_fit_keeping, less_known, with_base_terms, CURVE_DELTA_CHI2,
};
use super::{Effect, EffectFit, EffectKind, ParamSpread, TrainingData};

/// Fewest jumps detected at the chosen window: with missed jumps and a false one or two, a few cycles are needed
/// before the alternation means anything.
const MIN_JUMPS: usize = 12;
/// Family-wise error of the alternation test over the windows tried: the chance that the signs of a random walk's
/// detected jumps (independent, each way with probability 1/2) alternate as often as seen.
const ALTERNATION_ALPHA: f64 = 1e-4;
/// Largest spread of the jumps' refined sizes (robust coefficient of variation): a bistable bias has one size;
/// random steps big enough to be seen spread by at least this much.
const MAX_SIZE_SPREAD: f64 = 0.35;

/// Largest reduced chi-square of the telegraph's fit on the Allan curve for its correlation time to replace the
/// counted one ([`telegraph_on_curve`]). The telegraphs of the withheld sweep alone (seeds 0-9 of both generators)
/// reach 0.2 to 4.4; beside a Gauss-Markov process of a fifteenth of its correlation time, about 30.
const MAX_CURVE_STRAIN: f64 = 10.0;

/// What the scan at one window found.
#[derive(Clone, Debug)]
struct Flips {
    /// Window, samples.
    window: usize,
    /// Jumps in time order: sample index and signed size (the window's mean difference), deg/s.
    jumps: Vec<(usize, f64)>,
    /// Consecutive pairs of opposite sign.
    alternating: usize,
    /// The binomial tail of that many alternations or more among the pairs, at 1/2 each.
    p_value: f64,
    /// The scan's threshold on the mean difference, deg/s.
    threshold: f64,
}

/// The scan at window `l`, keeping jumps `apart` samples or more apart, its jumps put in time order and their
/// alternation counted.
fn flips_at(x: &[f64], l: usize, apart: usize) -> Option<Flips> {
    let scan = mosum_scan_apart(x, l, apart)?;
    let mut jumps = scan.steps;
    jumps.sort_by_key(|j| j.0);
    let pairs = jumps.len().saturating_sub(1);
    let alternating = jumps.windows(2).filter(|w| w[0].1 * w[1].1 < 0.0).count();
    Some(Flips {
        window: l,
        p_value: binomial_half_tail(pairs, alternating),
        jumps,
        alternating,
        threshold: scan.threshold,
    })
}

/// A jump: sample index, signed size (deg/s), and whether the scan saw it (else it was put back).
type Jump = (usize, f64, bool);

/// The jumps with the ones the scan missed between two of the same sign put back: the scan keeps one jump of
/// any two closer than its spacing (two windows, or one), so a shorter excursion shows one of its two jumps.
/// Between consecutive jumps of one sign the missing opposite one is where the mean difference over windows
/// bounded by the two (at most the scan's) is most opposite; its size is the opposite of the first's. Before the
/// first jump and after the last the record's end stands in for the missing neighbour: a short excursion there
/// shows only its inner jump, and the stretch to the end would take the wrong state. The missing jump is put back
/// where the opposite mean difference passes the scan's threshold.
fn repaired(x: &[f64], f: &Flips) -> Vec<Jump> {
    let mut pre = Vec::with_capacity(x.len() + 1);
    let mut acc = 0.0;
    pre.push(0.0);
    for v in x {
        acc += v;
        pre.push(acc);
    }
    let avg = |a: usize, b: usize| (pre[b] - pre[a]) / (b - a) as f64;
    let l = f.window;
    let mut out = Vec::with_capacity(f.jumps.len() * 2);
    // The most opposite change of level within `lo..hi` against a jump of `size`, where it passes the threshold,
    // with half a window or more on each side of it.
    let opposite_within = |lo: usize, hi: usize, size: f64| -> Option<usize> {
        (lo + l / 2..hi.saturating_sub(l / 2))
            .map(|t| {
                let d = avg(t, (t + l).min(hi)) - avg(t.saturating_sub(l).max(lo), t);
                (t, -d * size.signum())
            })
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .filter(|&(_, d)| d > f.threshold)
            .map(|(t, _)| t)
    };
    if let Some(&first) = f.jumps.first() {
        if let Some(t) = opposite_within(0, first.0, first.1) {
            out.push((t, -first.1, false));
        }
    }
    for (i, &j) in f.jumps.iter().enumerate() {
        out.push((j.0, j.1, true));
        let Some(&next) = f.jumps.get(i + 1) else { continue };
        if j.1 * next.1 > 0.0 && next.0 > j.0 + 2 {
            let best = (j.0 + 1..next.0)
                .map(|t| {
                    let d = avg(t, (t + l).min(next.0)) - avg(t.saturating_sub(l).max(j.0), t);
                    (t, -d * j.1.signum())
                })
                .max_by(|a, b| a.1.total_cmp(&b.1));
            if let Some((t, _)) = best {
                out.push((t, -j.1, false));
            }
        }
    }
    if let Some(&last) = f.jumps.last() {
        if let Some(t) = opposite_within(last.0, x.len(), last.1) {
            out.push((t, -last.1, false));
        }
    }
    out
}

/// The sizes of `jumps` measured again over the longest stretches their neighbours allow (up to 16 windows `l`
/// each side, half a window kept clear of each jump), signed.
fn refined_sizes(x: &[f64], jumps: &[Jump], l: usize) -> Vec<f64> {
    let cap = 16 * l;
    let margin = l / 2;
    (0..jumps.len())
        .map(|i| {
            let t = jumps[i].0;
            let prev = if i > 0 { jumps[i - 1].0 + margin } else { 0 };
            let next = jumps.get(i + 1).map_or(x.len(), |j| j.0.saturating_sub(margin));
            let a1 = t.saturating_sub(margin).max(1);
            let a0 = t.saturating_sub(cap).max(prev).min(a1 - 1);
            let b0 = (t + margin).min(x.len() - 1);
            let b1 = (t + cap).min(next).clamp(b0 + 1, x.len());
            mean(&x[b0..b1]) - mean(&x[a0..a1])
        })
        .collect()
}

/// Short excursions the scan saw by one edge, put back whole. An excursion narrower than the window `l` shows as
/// a plateau of the mean difference at `step w / l`, once up and once down within a window, and the scan keeps
/// one of the two; where the signs still alternate (the neighbouring excursion lost its other edge too), nothing
/// marks the edge as missing, and the stretch to the next jump takes the excursion's state. A flip keeps the level
/// it reaches, so its size measured again over the stretches either side is a step; an excursion's is about
/// none. So each seen jump with neighbours two windows or more away whose measured size is under half of `step`
/// is replaced by the excursion's two edges: the longest run, within a window of it, of samples more than half a
/// step from the level around it (the median of the window beyond each side), both marked as put back.
/// `sizes` are the jumps' [`refined_sizes`].
fn split_short_excursions(x: &[f64], jumps: Vec<Jump>, sizes: &[f64], step: f64, l: usize) -> Vec<Jump> {
    let mut out = Vec::with_capacity(jumps.len() + 8);
    for (i, (&j, &size)) in jumps.iter().zip(sizes).enumerate() {
        let prev = if i > 0 { jumps[i - 1].0 } else { 0 };
        let next = jumps.get(i + 1).map_or(x.len(), |k| k.0);
        let t = j.0;
        let room = t >= prev + 2 * l && t + 2 * l <= next;
        if !j.2 || !room || size.abs() >= 0.5 * step {
            out.push(j);
            continue;
        }
        let around: Vec<f64> = x[t - 2 * l..t - l].iter().chain(&x[t + l..t + 2 * l]).copied().collect();
        let level = median(&around);
        let (a, b) = (t - l, t + l);
        // The longest run of samples half a step or more from the level, either way.
        let run_of = |sign: f64| {
            let (mut best, mut start) = ((0, 0), None);
            for k in a..=b {
                let inside = k < b && (x[k] - level) * sign > 0.5 * step;
                match (inside, start) {
                    (true, None) => start = Some(k),
                    (false, Some(s0)) => {
                        if k - s0 > best.1 - best.0 {
                            best = (s0, k);
                        }
                        start = None;
                    }
                    _ => {}
                }
            }
            best
        };
        let (up, down) = (run_of(1.0), run_of(-1.0));
        let (sign, (s0, s1)) = if up.1 - up.0 >= down.1 - down.0 { (1.0, up) } else { (-1.0, down) };
        if s1 > s0 {
            out.push((s0, sign * step, false));
            out.push((s1, -sign * step, false));
        } else {
            out.push(j);
        }
    }
    out
}

/// The sizes of the jumps the scan saw (not those put back), of their [`refined_sizes`] `sizes`, unsigned.
fn seen_of(sizes: &[f64], jumps: &[Jump]) -> Vec<f64> {
    sizes.iter().zip(jumps).filter(|(_, j)| j.2).map(|(s, _)| s.abs()).collect()
}

/// The telegraph's jumps as the scan at window `l` saw them in `x` ([`Flips`]): missed edges put back
/// ([`repaired`]), short excursions seen by one edge put back whole ([`split_short_excursions`], at the median
/// seen size), with the unsigned sizes of the seen jumps before that split (for the test of one size) and after
/// it (for the step: the excursions' edges split off are not flips).
struct ReadJumps {
    jumps: Vec<Jump>,
    seen_before: Vec<f64>,
    seen: Vec<f64>,
}

fn read_jumps(x: &[f64], flips: &Flips, l: usize) -> ReadJumps {
    let jumps = repaired(x, flips);
    let sizes = refined_sizes(x, &jumps, l);
    let seen_before = seen_of(&sizes, &jumps);
    let jumps = split_short_excursions(x, jumps, &sizes, median(&seen_before), l);
    let seen = seen_of(&refined_sizes(x, &jumps, l), &jumps);
    ReadJumps { jumps, seen_before, seen }
}

/// The dwells read again from the Allan curve, where it tells them better than the count of jumps. A telegraph of
/// step `s` spending a share `p` of the time high is, in its Allan variance, a Gauss-Markov process of variance
/// `s^2 p (1 - p)` and correlation time `T = dwell_low dwell_high / (dwell_low + dwell_high)`; the counted dwells
/// miss the excursions shorter than the scan's window, and the correction for them is approximate where the
/// shorter dwell is a few windows. So with the step held (the jumps measure it well), that variance and `T` are
/// fitted with the base terms on the OADEV of the record (T from a quarter of the counted one to three of the count's
/// standard errors above it, `counts` the completed dwells (low, high)), and the
/// dwells `T / p` and `T / (1 - p)` replace the counted ones where they lower the curve's chi-square by
/// [`CURVE_DELTA_CHI2`] and the telegraph and base terms follow the curve there (reduced chi-square at most
/// [`MAX_CURVE_STRAIN`]); `p` takes the root on the counted dwells' side of one half, or where that root is within
/// a quarter of one half, the share of time the record spends high (`occupancy`).
///
/// Returns the dwells (low, high) and the base terms' squares fitted beside that telegraph on the same curve: a
/// jump missed or put at the wrong sample leaves a level error in the record less the levels, which an IEEE fit of
/// that record reads as a random walk, while the curve less the telegraph's exact Allan variance has none. `None`
/// when the curve has too few points or no fit.
fn telegraph_on_curve(
    d: &TrainingData,
    step: f64,
    dwell_low: f64,
    dwell_high: f64,
    counts: (usize, usize),
    occupancy: f64,
) -> Option<(f64, f64, Vec<f64>)> {
    let rate_hz = d.rate_hz;
    let bw = d.base.bandwidth_hz;
    let pts = less_known(&gapped_oadev_points(d.rate_dps, d.gaps, rate_hz), d.base, bw, rate_hz, d.lattice_dps);
    if pts.len() < 6 {
        return None;
    }
    let with_q = d.base.q_deg > 0.0;
    let base_cols = base_columns(&pts, rate_hz, bw, with_q);
    let column = |t: f64| -> Vec<f64> { pts.iter().map(|p| filtered_gm_avar(t, bw, p.tau_s, rate_hz)).collect() };
    // The counted dwells' telegraph, its variance held, with the base terms free.
    let t0 = dwell_low * dwell_high / (dwell_low + dwell_high);
    let p0 = dwell_high / (dwell_low + dwell_high);
    let var0 = step * step * p0 * (1.0 - p0);
    let col0 = column(t0);
    let counted: Vec<_> = pts
        .iter()
        .zip(&col0)
        .map(|(p, c)| octavar_stats::fit::FitPoint { avar: (p.avar - var0 * c).max(0.1 * p.avar), ..*p })
        .collect();
    let at_counted = joint_fit(&counted, &base_cols)?;
    let keep = 1u32 << base_cols.len();
    let fit_at = |t: f64| {
        let mut cols = base_cols.clone();
        cols.push(column(t));
        joint_fit_keeping(&pts, &cols, keep)
    };
    // Missed excursions make the counted dwells long, never short: the curve may shorten T to a quarter, but
    // lengthen it only within three of the count's standard errors. Longer, the curve's power at long tau is
    // another effect's (a 5,000 s sinusoid and a temperature response beside a telegraph of 12 s read T at 24 s,
    // and the ensemble's flips then carried half the record's power at 1-20 s).
    let (w_low, w_high) = (dwell_high / (dwell_low + dwell_high), dwell_low / (dwell_low + dwell_high));
    let t_se = (w_low * w_low / counts.0.max(1) as f64 + w_high * w_high / counts.1.max(1) as f64).sqrt();
    let t_hi = t0 * (1.0 + 3.0 * t_se).min(4.0);
    let (t, chi) = log_search(t0 / 4.0, t_hi, 24, |t| fit_at(t).map_or(f64::INFINITY, |j| j.chi2));
    let counted_result = (dwell_low, dwell_high, at_counted.theta.clone());
    // A curve the telegraph and the base terms cannot follow at any correlation time has a shape they lack (a
    // Gauss-Markov hump beside the telegraph's), which pulls the fitted time towards it: the counted dwells stand.
    let dof = pts.len().saturating_sub(base_cols.len() + 2).max(1) as f64;
    if !(chi + CURVE_DELTA_CHI2 < at_counted.chi2) || chi > MAX_CURVE_STRAIN * dof {
        return Some(counted_result);
    }
    let Some(j) = fit_at(t) else { return Some(counted_result) };
    let var = j.theta[base_cols.len()];
    let disc = 1.0 - 4.0 * var / (step * step);
    if !(var > 0.0 && disc > 0.0) {
        return Some(counted_result);
    }
    // p from the variance is ill-conditioned near one half (dp/dvar = 1 / (s^2 |1 - 2p|)): there the share of
    // time spent high, which missed short excursions hardly move, is the better estimate.
    let root = 0.5 * (1.0 - disc.sqrt());
    let p_high = match disc.sqrt() > 0.5 {
        true if p0 < 0.5 => root,
        true => 1.0 - root,
        false => occupancy,
    };
    Some((t / p_high, t / (1.0 - p_high), j.theta))
}

/// The bistable effect: [`bistable`] and its parameters.
pub(super) struct Kind;

impl EffectKind for Kind {
    const EFFECT: Effect = Effect::Bistable;
    type Params = BistableParams;

    fn estimate(data: &TrainingData) -> Option<EffectFit> {
        bistable(data)
    }
}

/// A bias flipping between two levels (random telegraph noise).
///
/// Method: the bias-steps candidate's moving-sum scan (means of a window L after and before each instant, robust
/// threshold) at windows L on an octave grid from 8 samples to a 64th of the record; at each, the jumps found are
/// put in time order and the consecutive pairs of opposite sign counted. Under a random walk of steps (or noise)
/// each pair alternates with probability 1/2; the window whose count is least likely so is kept, and the process
/// counts when that binomial tail, times the windows tried, is below [`ALTERNATION_ALPHA`], there are at least
/// [`MIN_JUMPS`] jumps, and their sizes, measured again over the longest stretches the neighbouring jumps allow,
/// spread by at most [`MAX_SIZE_SPREAD`] (robust coefficient of variation). The step is their mean size. Where two
/// consecutive jumps have the same sign, the scan (which keeps one of two jumps closer than its spacing) missed the one
/// of a short excursion between them, and it is put back ([`repaired`]). Where that reading finds no telegraph, the
/// scan is read again keeping jumps down to one window apart, the test taken over both readings' windows: a telegraph
/// whose rarer state lasts one to two windows then shows both edges of each excursion, where the first reading sees one
/// edge, of either sign, and leaves the alternation to chance. The second reading comes only second: on a telegraph the
/// first reading finds, it would read excursions as short as two samples and leave residues at its edges that the
/// spikes' estimator takes for spikes. The state between two jumps is the sign of
/// the jump into it; a dwell's mean in each state is that state's time over its
/// completed dwells (the first and last, cut by the record's ends, add time but no count), corrected for the
/// excursions too short to be seen (about a window: each one merges two dwells of the other state into one,
/// `d_obs = d / (e^{-c/d_low} + e^{-c/d_high} - 1)`, solved by iteration). The base terms are re-fitted on the record
/// less the reconstructed two-level bias (the base fit took its Gauss-Markov-like Allan variance for flicker or
/// random walk).
pub(super) fn bistable(d: &TrainingData) -> Option<EffectFit> {
    bistable_read(d, 2, 1.0).or_else(|| bistable_read(d, 1, 2.0))
}

/// [`bistable`] with the scan keeping jumps `apart_windows` windows or more apart, its alternation test taken
/// over `readings` times the windows tried (the readings [`bistable`] makes).
fn bistable_read(d: &TrainingData, apart_windows: usize, readings: f64) -> Option<EffectFit> {
    let x = d.rate_dps;
    let n = x.len();
    let rate_hz = d.rate_hz;
    let mut windows = Vec::new();
    let mut l = 8usize;
    while l <= n / 64 {
        windows.push(l);
        l *= 2;
    }
    if windows.is_empty() {
        return None;
    }
    let tried = windows.len() as f64 * readings;
    let best = windows
        .iter()
        .filter_map(|&l| flips_at(x, l, apart_windows * l))
        .filter(|f| f.jumps.len() >= MIN_JUMPS)
        .min_by(|a, b| a.p_value.total_cmp(&b.p_value).then(b.jumps.len().cmp(&a.jumps.len())))?;
    if !(best.p_value * tried < ALTERNATION_ALPHA) {
        return None;
    }
    // One size: the jumps the scan saw (one put back is measured over its short excursion).
    let ReadJumps { jumps, seen_before, seen: abs } = read_jumps(x, &best, best.window);
    let step = median(&seen_before);
    let spread = 1.4826 * median(&seen_before.iter().map(|a| (a - step).abs()).collect::<Vec<_>>()) / step;
    if !(step > 0.0 && spread <= MAX_SIZE_SPREAD) {
        return None;
    }
    let step = mean(&abs);
    let step_se =
        (abs.iter().map(|a| (a - step).powi(2)).sum::<f64>() / (abs.len() - 1) as f64 / abs.len() as f64).sqrt();
    let States { edges, time_high, time_low, count_high, count_low } = States::between(&jumps, n, rate_hz)?;
    let (obs_high, obs_low) = (time_high / count_high as f64, time_low / count_low as f64);
    // An excursion shows in the scan when its mean difference, `step min(1, w / L)` for a width w, passes the
    // threshold: shorter ones go unseen, and each merges two dwells of the other state.
    let c = best.window as f64 * (best.threshold / step).min(1.0) / rate_hz;
    let (mut dwell_high, mut dwell_low) = (obs_high, obs_low);
    for _ in 0..50 {
        let seen = ((-c / dwell_low).exp() + (-c / dwell_high).exp() - 1.0).max(0.2);
        dwell_high = obs_high * seen;
        dwell_low = obs_low * seen;
    }
    // The record less the two zero-mean levels, for the base terms' re-fit.
    let p_high = time_high / (time_high + time_low);
    let on_curve = telegraph_on_curve(d, step, dwell_low, dwell_high, (count_low, count_high), p_high);
    let (dwell_low, dwell_high) = on_curve.as_ref().map_or((dwell_low, dwell_high), |c| (c.0, c.1));
    let mut levels = telegraph_levels(x, &edges, step, p_high);
    mend_level_errors(x, &mut levels, step, best.window);
    let cleaned: Vec<f64> = x.iter().zip(levels).map(|(v, l)| v - l).collect();
    let refit = match &on_curve {
        Some((_, _, theta)) => with_base_terms(d.base, theta),
        None => refit_base(d, &cleaned, f64::INFINITY).map_or_else(|| d.base.clone(), |r| r.0),
    };
    let gyro = GyroSim {
        bistable: Some(BistableSim { step_dps: step, dwell_low_s: dwell_low, dwell_high_s: dwell_high }),
        ..refit
    };
    Some(EffectFit {
        effect: Effect::Bistable,
        params: BistableParams {
            step_dps: step,
            dwell_low_s: dwell_low,
            dwell_high_s: dwell_high,
            step_se_dps: step_se,
            dwell_low_se_s: dwell_low / (count_low as f64).sqrt(),
            dwell_high_se_s: dwell_high / (count_high as f64).sqrt(),
            jumps: best.jumps.len(),
            alternating: best.alternating,
            window_s: best.window as f64 / rate_hz,
            jumps_apart_windows: apart_windows,
            shortest_seen_s: c,
            p_value: best.p_value,
            size_spread: spread,
        }
        .into(),
        n_params: 3,
        gyro,
        channel: None,
        spread: Some(ParamSpread::Dwells { low: count_low as f64, high: count_high as f64 }),
        cleaned: Some(Arc::new(cleaned)),
    })
}

/// The two zero-mean levels of a telegraph of step `step` spending a share `p_high` of the time high, over the
/// stretches `edges` (start, end, high) of `x`.
///
/// A stretch whose state the jumps gave wrong (a jump put back between two of one sign at the wrong place, a false
/// jump beside a missed one) leaves `x` less its level a whole step off its neighbours' for as long as it lasts, a
/// level error that no noise term explains. So each stretch is put in the other state where `x` less the levels
/// over it stands about a whole step from the mean over its two neighbours (weighted by their lengths): more than
/// three quarters of one, and within a quarter of a step of that mean in the other state (a random walk beneath
/// moves the neighbours' means by part of a step, not by one), where the stretch is long enough for its mean to
/// tell (half a step beyond four standard errors of the sample noise, read from the RMS of the samples'
/// differences).
fn telegraph_levels(x: &[f64], edges: &[(usize, usize, bool)], step: f64, p_high: f64) -> Vec<f64> {
    let (high, low) = (step * (1.0 - p_high), -step * p_high);
    // The RMS of the differences, not a robust scale: on an ADC lattice coarser than the noise most differences
    // are 0, and a median of them would call a stretch of one sample long enough.
    let noise_sd =
        (x.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum::<f64>() / (2.0 * (x.len().max(2) - 1) as f64)).sqrt();
    let long_enough = |len: usize| 0.5 * step > 4.0 * noise_sd / (len as f64).sqrt();
    let level = |h: bool| if h { high } else { low };
    let mut states: Vec<bool> = edges.iter().map(|e| e.2).collect();
    let stretch_mean = |k: usize, states: &[bool]| {
        let (a, b, _) = edges[k];
        (b > a).then(|| x[a..b].iter().sum::<f64>() / (b - a) as f64 - level(states[k]))
    };
    for k in 0..edges.len() {
        let Some(own) = stretch_mean(k, &states) else { continue };
        // The neighbours' mean, each weighted by its length.
        let (sum, len) = [k.checked_sub(1), (k + 1 < edges.len()).then_some(k + 1)]
            .into_iter()
            .flatten()
            .filter_map(|j| stretch_mean(j, &states).map(|m| (m, (edges[j].1 - edges[j].0) as f64)))
            .fold((0.0, 0.0), |(s, l), (m, w)| (s + m * w, l + w));
        if len == 0.0 {
            continue;
        }
        let reference = sum / len;
        let flipped = own + level(states[k]) - level(!states[k]);
        let long = long_enough(edges[k].1 - edges[k].0);
        if long && (own - reference).abs() > 0.75 * step && (flipped - reference).abs() < 0.25 * step {
            states[k] = !states[k];
        }
    }
    let mut levels = vec![0.0; x.len()];
    for (&(a, b, _), &h) in edges.iter().zip(&states) {
        levels[a..b].iter_mut().for_each(|v| *v = level(h));
    }
    levels
}

/// The telegraph the scan at window `l` finds in `x`, as its two zero-mean levels: what [`bistable`] takes out of
/// the samples, found again on any series by the same scan, jumps put back and states read the same way, with no
/// test of its own (the effect is already named). `None` where the scan finds no completed dwell of each state.
pub(super) fn recovered_levels(x: &[f64], l: usize, apart: usize) -> Option<Vec<f64>> {
    let n = x.len();
    let flips = flips_at(x, l, apart)?;
    if flips.jumps.len() < 2 {
        return None;
    }
    let ReadJumps { jumps, seen, .. } = read_jumps(x, &flips, l);
    let step = mean(&seen);
    let States { edges, time_high, time_low, .. } = States::between(&jumps, n, 1.0)?;
    let mut levels = telegraph_levels(x, &edges, step, time_high / (time_high + time_low));
    mend_level_errors(x, &mut levels, step, l);
    Some(levels)
}

/// How far a jump's size may part from the telegraph's step, as a share of the step, and still be read as a flip
/// the levels got wrong ([`mend_level_errors`]).
const FLIP_SIZE_TOLERANCE: f64 = 0.25;

/// The share of a stretch's samples [`mend_level_errors`] finds in the state the stretch leaves, at least, for it
/// to put them in the other: the rest are the residues of flips placed a few samples off, a pulse the scan passes
/// over.
const MEND_SHARE: f64 = 0.98;

/// The stretches whose state the levels still give wrong, put in the other state. Where the jumps read a short
/// excursion's edges at the wrong places (a quick up and down again, its down-edge put hundreds of samples late),
/// `x` less the levels keeps a jump of the step's size at each end of the stretch in the wrong state;
/// [`telegraph_levels`] compares whole stretches between the jumps it was given, and one whose neighbours the noise
/// beneath has moved escapes it. So the scan of the jumps runs again, at the telegraph's window `l`, over `x` less
/// the levels, each jump measured again over the stretches to its neighbours. The jumps of the step's size (within
/// [`FLIP_SIZE_TOLERANCE`]) split the record into stretches, each a whole number of steps from the one before. A
/// stretch one step from the level around it (its two neighbours' where they agree; at an end of the record, its
/// one neighbour's where it is the shorter) is put in the other state, where one of its ends lies within two
/// windows of an edge of the levels (the edge put in the wrong place), or the stretch reaches an end of the record
/// (a flip the levels missed), and nearly all its levels are of the state it
/// leaves ([`MEND_SHARE`]; a stretch whose levels mix both states is not a state error the step explains). A bias
/// step of the telegraph's size reads as such a jump too, but at a place of its own, not at an edge of the levels:
/// beside a process of 75 steps a record, most of them the size of the telegraph's step or less, stretches
/// between such steps would be put in the wrong state.
fn mend_level_errors(x: &[f64], levels: &mut [f64], step: f64, l: usize) {
    let n = x.len().min(levels.len());
    if !(step > 0.0) || n < 4 * l {
        return;
    }
    let cleaned: Vec<f64> = x[..n].iter().zip(&levels[..n]).map(|(v, l)| v - l).collect();
    let Some(scan) = mosum_scan_apart(&cleaned, l, 2 * l) else { return };
    // Each jump measured again over the stretches to its neighbours: the scan's own size is its largest mean
    // difference near the jump, which the noise lifts.
    let mut jumps: Vec<Jump> = scan.steps.iter().map(|s| (s.0, s.1, true)).collect();
    jumps.sort_unstable_by_key(|j| j.0);
    let sizes = refined_sizes(&cleaned, &jumps, l);
    let flips: Vec<(usize, f64)> = jumps
        .iter()
        .zip(sizes)
        .map(|(j, s)| (j.0, s))
        .filter(|&(_, s)| (s.abs() / step - 1.0).abs() <= FLIP_SIZE_TOLERANCE)
        .collect();
    if flips.is_empty() {
        return;
    }
    // Each stretch and its offset from the first, in whole steps.
    let mut stretches: Vec<(usize, usize, i64)> = Vec::with_capacity(flips.len() + 1);
    let (mut start, mut offset) = (0usize, 0i64);
    for &(t, size) in &flips {
        stretches.push((start, t, offset));
        offset += if size > 0.0 { 1 } else { -1 };
        start = t;
    }
    stretches.push((start, n, offset));
    let (high, low) = levels[..n].iter().fold((f64::MIN, f64::MAX), |(h, lo), &v| (h.max(v), lo.min(v)));
    let len = |j: usize| stretches[j].1 - stretches[j].0;
    // The levels' own edges, and whether a jump at `t` lies within two windows of one.
    let edges: Vec<usize> = (1..n).filter(|&i| levels[i] != levels[i - 1]).collect();
    let at_an_edge = |t: usize| {
        let k = edges.partition_point(|&e| e + 2 * l < t);
        edges.get(k).is_some_and(|&e| e <= t + 2 * l)
    };
    for j in 0..stretches.len() {
        let (a, b, k) = stretches[j];
        // The level around the stretch: its two neighbours' where they agree; at an end of the record, the one
        // neighbour's where the stretch is the shorter.
        let around = match (j.checked_sub(1), (j + 1 < stretches.len()).then_some(j + 1)) {
            (Some(p), Some(q)) => (stretches[p].2 == stretches[q].2).then_some(stretches[p].2),
            (None, Some(q)) => (len(j) < len(q)).then_some(stretches[q].2),
            (Some(p), None) => (len(j) < len(p)).then_some(stretches[p].2),
            (None, None) => None,
        };
        let Some(around) = around else { continue };
        // Inside the record, a state error begins or ends where the levels put an edge in the wrong place; at an
        // end, a flip the levels missed leaves the stretch to the end in the state before it.
        let at_an_end = a == 0 || b == n;
        if !(at_an_end || at_an_edge(a) || at_an_edge(b)) {
            continue;
        }
        // Above the level around by a step in x less the levels: the levels there read low where the state was
        // high.
        let (from, to) = match k - around {
            1 => (low, high),
            -1 => (high, low),
            _ => continue,
        };
        let in_from = levels[a..b].iter().filter(|&&v| v == from).count();
        if b > a && in_from as f64 >= MEND_SHARE * (b - a) as f64 {
            levels[a..b].iter_mut().filter(|v| **v == from).for_each(|v| *v = to);
        }
    }
}

/// The two states between the jumps: each stretch of the record with its state, and each state's time and
/// completed dwells.
struct States {
    /// (start, end, high) of each stretch, in order.
    edges: Vec<(usize, usize, bool)>,
    /// Time in the high state, s.
    time_high: f64,
    /// Time in the low state, s.
    time_low: f64,
    /// Completed dwells in the high state (the first and last stretches, cut by the record's ends, are not).
    count_high: usize,
    /// Completed dwells in the low state.
    count_low: usize,
}

impl States {
    /// The states of a record of `n` samples at `rate_hz` between `jumps` (sample, size, seen), from the sign of
    /// the jump into each stretch; the stretch before the first jump is the other state. `None` unless each state
    /// has a completed dwell.
    fn between(jumps: &[Jump], n: usize, rate_hz: f64) -> Option<States> {
        let (mut time_high, mut time_low, mut count_high, mut count_low) = (0.0, 0.0, 0usize, 0usize);
        let first_high = jumps[0].1 < 0.0;
        let mut edges: Vec<(usize, usize, bool)> = vec![(0, jumps[0].0, first_high)];
        for (i, j) in jumps.iter().enumerate() {
            let end = jumps.get(i + 1).map_or(n, |k| k.0);
            edges.push((j.0, end, j.1 > 0.0));
        }
        let last = edges.len() - 1;
        for (i, &(a, b, high)) in edges.iter().enumerate() {
            let dt = (b - a) as f64 / rate_hz;
            let complete = i > 0 && i < last;
            if high {
                time_high += dt;
                count_high += usize::from(complete);
            } else {
                time_low += dt;
                count_low += usize::from(complete);
            }
        }
        (count_high > 0 && count_low > 0).then_some(States { edges, time_high, time_low, count_high, count_low })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stretch the jumps put in the wrong state (the low level read as high for a thousand samples, between two
    /// true ones) is put back in its state: `x` less the levels is then the noise alone, where a stretch read
    /// wrong would leave a whole step there; a short stretch whose mean cannot tell keeps the state it was given.
    #[test]
    fn a_stretch_given_the_wrong_state_is_put_back() {
        let n = 6_000;
        let noise = octavar_stats::test_signals::white(n, 7);
        let truth = |i: usize| (1_000..2_000).contains(&i) || (4_000..5_000).contains(&i);
        let (step, p_high) = (1.0, 1.0 / 3.0);
        let level = |h: bool| if h { step * (1.0 - p_high) } else { -step * p_high };
        let x: Vec<f64> = (0..n).map(|i| level(truth(i)) + 0.3 * noise[i]).collect();
        // The stretch 2000..3000 is low but read as high; 3000..3002 is too short to tell either way.
        let edges = [
            (0, 1_000, false),
            (1_000, 2_000, true),
            (2_000, 3_000, true),
            (3_000, 3_002, true),
            (3_002, 4_000, false),
            (4_000, 5_000, true),
            (5_000, n, false),
        ];
        let levels = telegraph_levels(&x, &edges, step, p_high);
        for (i, l) in levels.iter().enumerate() {
            let want = if (3_000..3_002).contains(&i) { level(true) } else { level(truth(i)) };
            assert!((l - want).abs() < 1e-12, "sample {i}: level {l}, want {want}");
        }
    }

    /// The case of an excursion read at the wrong places, from a record of the independent generator: the telegraph
    /// went up and, 35 samples later, down again, and the levels kept it high 400 samples longer (the jumps put
    /// the down-edge late, and the stretch's neighbours, moved by the noise beneath, did not tell it). `x` less the
    /// levels then holds a step down and a step up, which a bias-step scan named as steps. [`mend_level_errors`]
    /// finds the two and puts the samples between in their state: every sample is then the truth's. The other
    /// stretches, and a bias step of half the telegraph's step, are left as they are.
    #[test]
    fn an_edge_read_late_is_mended_and_other_jumps_are_left() {
        let (n, l, step, p_high) = (20_000, 8, 0.25, 0.25);
        let noise = octavar_stats::test_signals::white(n, 11);
        let high =
            |i: usize| (2_000..5_000).contains(&i) || (8_000..8_035).contains(&i) || (14_000..16_000).contains(&i);
        let bias_step = |i: usize| if i >= 11_000 { 0.5 * step } else { 0.0 };
        let x: Vec<f64> = (0..n).map(|i| if high(i) { step } else { 0.0 } + bias_step(i) + 0.02 * noise[i]).collect();
        let level = |h: bool| if h { step * (1.0 - p_high) } else { -step * p_high };
        let mut levels: Vec<f64> = (0..n).map(|i| level(high(i) || (8_035..8_435).contains(&i))).collect();
        let wrong = |levels: &[f64]| (0..n).filter(|&i| (levels[i] == level(true)) != high(i)).count();
        assert_eq!(wrong(&levels), 400, "the premise");
        mend_level_errors(&x, &mut levels, step, l);
        assert_eq!(wrong(&levels), 0);
        assert!(levels.iter().all(|&v| v == level(true) || v == level(false)));
    }

    /// Two short excursions, each seen by one edge (the scan keeps one of two edges within a window), whose seen
    /// edges still alternate in sign with their neighbours: nothing marks an edge missing, the stretch between
    /// them takes the excursions' state until its level puts it back, and the excursions themselves are left in
    /// the record less the levels, pulses of a whole step that a bias-step scan then finds. Each seen edge
    /// measures about no step over the stretches either side, and is replaced by the excursion's two edges: every
    /// sample's state is then the truth.
    #[test]
    fn short_excursions_seen_by_one_edge_are_put_back_whole() {
        let (n, l, step) = (20_000, 16, 1.0);
        let noise = octavar_stats::test_signals::white(n, 5);
        let high = |i: usize| {
            (2_000..4_000).contains(&i)
                || (8_000..8_008).contains(&i)
                || (12_000..12_015).contains(&i)
                || (16_000..18_000).contains(&i)
        };
        let x: Vec<f64> = (0..n).map(|i| if high(i) { step } else { 0.0 } + 0.05 * noise[i]).collect();
        // What the scan at window 16 shows: the first excursion's up-edge at 8/16 of a step, the second's
        // down-edge at 15/16.
        let seen: Vec<Jump> =
            [(2_000, 1.0), (4_000, -1.0), (8_000, 0.5), (12_015, -0.94), (16_000, 1.0), (18_000, -1.0)]
                .iter()
                .map(|&(t, s)| (t, s, true))
                .collect();
        let wrong = |jumps: &[Jump]| {
            let States { edges, time_high, time_low, .. } = States::between(jumps, n, 1.0).unwrap();
            let levels = telegraph_levels(&x, &edges, step, time_high / (time_high + time_low));
            let lo = levels.iter().copied().fold(f64::INFINITY, f64::min);
            (0..n).filter(|&i| (levels[i] - lo > 0.5 * step) != high(i)).count()
        };
        // The stretch between is put back in its state by its level, but the excursions stay where they were.
        assert!(wrong(&seen) >= 23, "the premise: {} samples in the wrong state", wrong(&seen));
        let sizes = refined_sizes(&x, &seen, l);
        let split = split_short_excursions(&x, seen, &sizes, step, l);
        assert_eq!(split.len(), 8, "{split:?}");
        for (t, s) in [(8_000, 1.0), (8_008, -1.0), (12_000, 1.0), (12_015, -1.0)] {
            assert!(split.contains(&(t, s, false)), "edge {t} {s}: {split:?}");
        }
        assert_eq!(wrong(&split), 0);
    }

    /// A short excursion cut by each end of the record shows only its inner jump to the scan: the outer one is put
    /// back at its place, with the opposite sign, and the jumps the scan saw are kept as they were.
    #[test]
    fn excursions_cut_by_the_records_ends_are_put_back() {
        let n = 10_000;
        let noise = octavar_stats::test_signals::white(n, 3);
        let level = |i: usize| if (200..260).contains(&i) || (5_000..9_940).contains(&i) { 1.0 } else { 0.0 };
        let x: Vec<f64> = (0..n).map(|i| level(i) + 0.01 * noise[i]).collect();
        let seen =
            Flips { window: 100, jumps: vec![(260, -1.0), (5_000, 1.0)], alternating: 1, p_value: 0.5, threshold: 0.3 };
        let jumps = repaired(&x, &seen);
        assert_eq!(jumps.len(), 4, "{jumps:?}");
        let (t0, s0, seen0) = jumps[0];
        assert!(t0.abs_diff(200) <= 2 && s0 == 1.0 && !seen0, "{jumps:?}");
        assert_eq!(&jumps[1..3], &[(260, -1.0, true), (5_000, 1.0, true)]);
        let (t3, s3, seen3) = jumps[3];
        assert!(t3.abs_diff(9_940) <= 2 && s3 == -1.0 && !seen3, "{jumps:?}");
        // Without an excursion at the ends nothing is added there.
        let plain: Vec<f64> =
            (0..n).map(|i| if (260..5_000).contains(&i) { -1.0 } else { 0.0 } + 0.01 * noise[i]).collect();
        let seen =
            Flips { window: 100, jumps: vec![(260, -1.0), (5_000, 1.0)], alternating: 1, p_value: 0.5, threshold: 0.3 };
        assert_eq!(repaired(&plain, &seen), [(260, -1.0, true), (5_000, 1.0, true)]);
    }
}

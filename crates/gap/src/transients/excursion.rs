//! From flagged blocks to events: each flagged block or burst (a core) grown into an excursion against a
//! baseline through the medians of its sides, the test that leaves alone an offset the part's own steps explain
//! (a MOSUM count of steps at the offset's length and longer), and the merging and padding of the events kept.

use std::collections::HashMap;

use super::stats::{mean, median, prev_pow2, robust_scale, Prefix};
use super::{Reason, Shape, Transient};

/// An offset is explained by the record's own steps when the expected number of pairs of steps as close as its
/// duration is at least this.
const STEP_PAIR_ALPHA: f64 = 0.01;
/// The step count's threshold at a MOSUM window of `m` independent windows, in robust scales of the MOSUM:
/// `max(FLOOR, sqrt(2 ln m))`, about where noise alone gives one step in the part.
const STEP_KAPPA_FLOOR: f64 = 3.5;

/// A flagged block (or burst): where, at which scale, how many robust scales from its baseline.
#[derive(Clone, Copy, Debug)]
pub(super) struct Core {
    pub(super) start: usize,
    pub(super) end: usize,
    pub(super) scale: usize,
    pub(super) z: f64,
    pub(super) burst: bool,
    /// A burst of separate spikes: its large samples fill less than half its span or have both signs (a fifth of
    /// them or more each way). Its shape is a burst whatever the mean of its span, which the red noise under a
    /// long burst can lift or lower more than its few spikes.
    pub(super) spiky: bool,
}

/// An excursion grown from a core.
pub(super) struct Grown {
    pub(super) start: usize,
    pub(super) end: usize,
    pub(super) mean: f64,
    pub(super) peak: f64,
    pub(super) shape: Shape,
    /// Median level on each side, deg/s, where there is a side.
    pub(super) before: Option<f64>,
    pub(super) after: Option<f64>,
}

/// Steps found at one MOSUM window: the robust threshold and each step's index and |size|, largest first.
pub(super) struct StepScan {
    threshold: f64,
    steps: Vec<(usize, f64)>,
}

pub(super) struct Ctx<'a> {
    /// The record with its isolated spikes replaced.
    pub(super) x: &'a [f64],
    /// The record.
    pub(super) raw: &'a [f64],
    pub(super) prefix: &'a Prefix,
    pub(super) n_valid: usize,
    pub(super) sigma: f64,
    pub(super) steps: HashMap<usize, StepScan>,
}

impl Ctx<'_> {
    /// Grow `core` into an excursion: a baseline from the medians on both sides, then the interval about the core
    /// that maximises a CUSUM of the deviations (signed for an offset, absolute for a burst).
    pub(super) fn refine(&self, core: &Core, covered: &[bool]) -> Option<Grown> {
        let x = self.x;
        let n = x.len();
        let ext = 3 * core.scale.max(core.end - core.start) + 8;
        // The search window, stopping at excursions already taken.
        let mut w0 = core.start;
        while w0 > 0 && core.start - w0 < ext && !covered[w0 - 1] {
            w0 -= 1;
        }
        let mut w1 = core.end;
        while w1 < n && w1 - core.end < ext && !covered[w1] {
            w1 += 1;
        }
        let f = (w1 - w0).max(32);
        let side = |a: usize, b: usize| -> Option<(f64, f64)> {
            let v: Vec<f64> = (a..b).filter(|&i| !covered[i] && x[i].is_finite()).map(|i| x[i]).collect();
            (v.len() >= 8).then(|| (median(&v), 0.5 * (a + b) as f64))
        };
        let before = side(w0.saturating_sub(f), w0);
        let after = side(w1, (w1 + f).min(n));
        let base = |i: usize| -> f64 {
            match (before, after) {
                (Some((ml, cl)), Some((mr, cr))) => ml + (mr - ml) * (i as f64 - cl) / (cr - cl),
                (Some((m, _)), None) | (None, Some((m, _))) => m,
                (None, None) => f64::NAN,
            }
        };
        before.or(after)?;
        let d: Vec<f64> = (w0..w1).map(|i| x[i] - base(i)).collect();
        let core_d: Vec<f64> = d[core.start - w0..core.end - w0].iter().copied().filter(|v| v.is_finite()).collect();
        if core_d.is_empty() {
            return None;
        }
        let m = mean(&core_d);
        let ma = core_d.iter().map(|v| v.abs()).sum::<f64>() / core_d.len() as f64;
        let shape = if m.abs() >= 0.5 * ma && !core.spiky { Shape::Offset } else { Shape::Burst };
        let s = self.sigma;
        let g: Vec<f64> = match shape {
            Shape::Offset => {
                // Half the offset (the CUSUM's optimal reference), at most 1.5 sigma: the edges go where the
                // samples are clearly raised, not into a stretch of noise that happens to lean the same way.
                let k = (0.5 * m.abs()).min(1.5 * s);
                d.iter().map(|v| if v.is_finite() { m.signum() * v - k } else { 0.0 }).collect()
            }
            Shape::Burst => {
                // The energy of each deviation in per-sample scales, capped at 16 (4 sigma) so a lone spike cannot
                // bridge a long stretch of noise, less a reference between the noise's energy (1) and the core's.
                let u = |v: f64| (v / s).powi(2).min(16.0);
                let e_core = core_d.iter().map(|&v| u(v)).sum::<f64>() / core_d.len() as f64;
                let c = (0.5 * (1.0 + e_core)).clamp(2.0, 4.0);
                d.iter().map(|&v| if v.is_finite() { u(v) - c } else { 0.0 }).collect()
            }
        };
        let (a, b) = (core.start - w0, core.end - w0);
        let (lo, hi) = if core.spiky {
            // Separate spikes: their span, first to last; the energy of the samples between them and around is the
            // noise's, and on a wandering level a line through the sides' medians would take the wander for more.
            (a, b - 1)
        } else if core.burst {
            // A burst's large samples belong together (the Poisson test said so): the whole span, extended outward
            // over weaker edges.
            (a - best_run(g[..a].iter().rev()), b - 1 + best_run(g[b..].iter()))
        } else {
            best_interval(&g, a, b)
        };
        let fin: Vec<f64> = d[lo..=hi].iter().copied().filter(|v| v.is_finite()).collect();
        // The peak from the record itself: spikes within the excursion are part of it.
        let peak =
            (w0 + lo..=w0 + hi).map(|i| (self.raw[i] - base(i)).abs()).filter(|v| v.is_finite()).fold(0.0, f64::max);
        Some(Grown {
            start: w0 + lo,
            end: w0 + hi + 1,
            mean: mean(&fin),
            peak,
            shape,
            before: before.map(|b| b.0),
            after: after.map(|a| a.0),
        })
    }

    /// The step-process test of an offset: steps at least half its size elsewhere in the part, found by a MOSUM
    /// at the offset's block length and at 2, 4 and 8 times it (a process's steps, each as marginal as the offset at
    /// its own length, stand out at a longer window when they are far enough apart); explained when, at one of
    /// them, pairs of such steps as close as the offset's duration are to be expected.
    pub(super) fn step_process(&mut self, t: &Transient) -> Option<Reason> {
        let n = self.x.len();
        let h0 = t.scale.min(prev_pow2((t.len / 2).max(1)));
        let mut best: Option<(usize, f64)> = None;
        for h in [h0, 2 * h0, 4 * h0, 8 * h0] {
            if 16 * h > n {
                break;
            }
            let (prefix, n_valid) = (self.prefix, self.n_valid);
            let sc = self.steps.entry(h).or_insert_with(|| step_scan(prefix, n_valid, h));
            let thr = sc.threshold.max(0.5 * t.mean_dps.abs());
            let (a, b) = (t.start.saturating_sub(2 * h), t.end() + 2 * h);
            let k = sc.steps.iter().take_while(|s| s.1 >= thr).filter(|s| s.0 < a || s.0 > b).count();
            let lambda = k as f64 / self.n_valid as f64;
            let expected = k as f64 * (1.0 - (-lambda * t.len as f64).exp());
            if best.is_none_or(|b| expected > b.1) {
                best = Some((k, expected));
            }
        }
        let (k, expected) = best?;
        (expected >= STEP_PAIR_ALPHA).then_some(Reason::StepProcess { other_steps: k, expected_pairs: expected })
    }
}

/// How many of `g`'s leading values to take for the largest sum (0 when no prefix sum is positive).
fn best_run<'a>(g: impl Iterator<Item = &'a f64>) -> usize {
    let (mut acc, mut best, mut len) = (0.0, 0.0, 0);
    for (i, v) in g.enumerate() {
        acc += v;
        if acc > best {
            best = acc;
            len = i + 1;
        }
    }
    len
}

/// The interval `[lo, hi]` of largest sum of `g` among those that overlap `[a, b)`: for each point p of the core,
/// the best sum ending at p plus the best starting at p (Kadane both ways), O(len).
fn best_interval(g: &[f64], a: usize, b: usize) -> (usize, usize) {
    let n = g.len();
    let mut left = vec![(0.0, 0usize); n];
    let mut run = (f64::NEG_INFINITY, 0usize);
    for i in 0..n {
        run = if run.0 > 0.0 { (run.0 + g[i], run.1) } else { (g[i], i) };
        left[i] = run;
    }
    let mut right = vec![(0.0, 0usize); n];
    let mut run = (f64::NEG_INFINITY, n - 1);
    for i in (0..n).rev() {
        run = if run.0 > 0.0 { (run.0 + g[i], run.1) } else { (g[i], i) };
        right[i] = run;
    }
    let mut best = (f64::NEG_INFINITY, a, a);
    for p in a..b.min(n) {
        let sum = left[p].0 + right[p].0 - g[p];
        if sum > best.0 {
            best = (sum, left[p].1, right[p].1);
        }
    }
    (best.1, best.2)
}

/// The MOSUM scan of the cleaned series at window `h`: `D(t) = mean(x[t..t+h]) - mean(x[t-h..t])` on a grid of
/// h/4, steps where |D| is a local maximum beyond the scale's threshold, at least 2h apart.
fn step_scan(prefix: &Prefix, n_valid: usize, h: usize) -> StepScan {
    let n = prefix.len();
    let stride = (h / 4).max(1);
    let grid: Vec<usize> = if n >= 2 * h { (h..=n - h).step_by(stride).collect() } else { Vec::new() };
    let dv: Vec<f64> =
        grid.iter().map(|&t| prefix.mean(t, t + h, h.div_ceil(2)) - prefix.mean(t - h, t, h.div_ceil(2))).collect();
    let m = (n_valid as f64 / h as f64).max(2.0);
    let threshold = (2.0 * m.ln()).sqrt().max(STEP_KAPPA_FLOOR) * robust_scale(&dv, false);
    let mut cand: Vec<usize> = (0..grid.len()).filter(|&i| dv[i].abs() > threshold).collect();
    cand.sort_by(|&a, &b| dv[b].abs().total_cmp(&dv[a].abs()));
    let mut steps: Vec<(usize, f64)> = Vec::new();
    for i in cand {
        let t = grid[i];
        if steps.iter().all(|s| s.0.abs_diff(t) >= 2 * h) {
            steps.push((t, dv[i].abs()));
        }
    }
    StepScan { threshold, steps }
}

/// Events sorted by start, merged when the gap between two is shorter than the shorter of them, then padded by
/// their edge margin (1 + len/32 samples each side).
pub(super) fn merge_and_pad(events: Vec<Transient>, n: usize) -> Vec<Transient> {
    let mut merged: Vec<Transient> = Vec::new();
    for e in events {
        if let Some(last) = merged.last_mut() {
            let gap = e.start.saturating_sub(last.end());
            if gap <= last.len.min(e.len) {
                let end = last.end().max(e.end());
                let (la, lb) = (last.len as f64, e.len as f64);
                last.mean_dps = (last.mean_dps * la + e.mean_dps * lb) / (la + lb);
                last.peak_dps = last.peak_dps.max(e.peak_dps);
                if e.shape == Shape::Burst {
                    last.shape = Shape::Burst;
                }
                last.len = end - last.start;
                continue;
            }
        }
        merged.push(e);
    }
    for e in &mut merged {
        let pad = 1 + e.len / 32;
        let start = e.start.saturating_sub(pad);
        let end = (e.end() + pad).min(n);
        e.start = start;
        e.len = end - start;
    }
    // Padding can make neighbours touch: join them.
    let mut out: Vec<Transient> = Vec::new();
    for e in merged {
        match out.last_mut() {
            Some(last) if e.start <= last.end() => {
                let end = last.end().max(e.end());
                last.peak_dps = last.peak_dps.max(e.peak_dps);
                last.len = end - last.start;
            }
            _ => out.push(e),
        }
    }
    out
}

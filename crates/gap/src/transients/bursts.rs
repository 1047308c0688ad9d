//! Bursts of large samples: the spans where samples beyond the spike threshold come denser than the part's own
//! Poisson rate of them allows (pairs by the law of the smallest gap, three or more by a scan over octave windows),
//! each cut to its most significant run; the large samples outside them are a steady spike process.

use octavar_stats::tails::{ln_poisson_sf, poisson_sf};

/// Family-wise false-alarm probability of the burst test over a part.
const BURST_ALPHA: f64 = 1e-3;
/// Fewest large samples in a burst found by the window test (pairs have their own test).
const MIN_BURST_SPIKES: usize = 3;
/// A large sample at the end of a burst stands apart from it beyond this many median gaps of the burst.
const BURST_TRIM_GAPS: usize = 8;

/// Spans `[first, last]` of large samples denser than the part's own rate of them allows.
///
/// Under the null the large samples are a Poisson process of rate p per sample (estimated from the part, less the
/// spans found, iterated to a fixed point); the expected number of large samples followed within `w` samples by at
/// least `k - 1` others is `n p P(Poisson(p w) >= k - 1)`. At each octave window w up to the longest event, the
/// smallest k that keeps this under [`BURST_ALPHA`] over all windows makes a burst.
pub(super) fn find_bursts(ex: &[usize], n_valid: usize, max_len: usize, p_floor: f64) -> (Vec<(usize, usize)>, f64) {
    let windows: Vec<usize> = (1..40).map(|k| 1usize << k).take_while(|&w| w <= max_len.max(2)).collect();
    // Half the level for pairs, half for the windows of three or more.
    let alpha = 0.5 * BURST_ALPHA / windows.len() as f64;
    let mut p = p_floor.max(ex.len() as f64 / n_valid as f64);
    let mut spans: Vec<(usize, usize)> = Vec::new();
    for _ in 0..8 {
        let mut marks: Vec<(usize, usize)> = Vec::new();
        // Pairs: of m large samples uniform over the part, two lie within g of each other with probability
        // about m (m - 1) g / n (the smallest gap's law; no window lengths to correct for).
        let m = (p * n_valid as f64).max(2.0);
        for w in ex.windows(2) {
            let g = (w[1] - w[0]) as f64;
            if m * (m - 1.0) * g / n_valid as f64 <= 0.5 * BURST_ALPHA {
                marks.push((w[0], w[1]));
            }
        }
        for &w in &windows {
            let Some(k_min) = burst_count(n_valid, p, w, alpha) else { continue };
            let mut j = 0;
            for i in 0..ex.len() {
                j = j.max(i);
                while j < ex.len() && ex[j] < ex[i] + w {
                    j += 1;
                }
                if j - i >= k_min {
                    marks.push((ex[i], ex[j - 1]));
                }
            }
        }
        marks.sort_unstable();
        spans.clear();
        for (a, b) in marks {
            match spans.last_mut() {
                Some(last) if a <= last.1 + 1 => last.1 = last.1.max(b),
                _ => spans.push((a, b)),
            }
        }
        for span in &mut spans {
            *span = trim_span(ex, *span, p);
        }
        let mut inside = 0;
        let mut s = 0;
        for &i in ex {
            while s < spans.len() && spans[s].1 < i {
                s += 1;
            }
            if s < spans.len() && spans[s].0 <= i {
                inside += 1;
            }
        }
        let p_new = p_floor.max((ex.len() - inside) as f64 / n_valid as f64);
        if p_new >= p {
            break;
        }
        p = p_new;
    }
    (spans, p)
}

/// A burst span reduced to its most significant run of large samples: of every run of consecutive ones, the one
/// whose count is least likely within its length at the null rate `p` (a window that starts at a lone spike, or
/// at two that happen to be close, holds the burst too, and they are not part of it). Spans of more than 256 large
/// samples (dense runs) only lose ends that stand apart by more than [`BURST_TRIM_GAPS`] median gaps.
fn trim_span(ex: &[usize], (a, b): (usize, usize), p: f64) -> (usize, usize) {
    let lo = ex.partition_point(|&i| i < a);
    let hi = ex.partition_point(|&i| i <= b);
    let mut pts = &ex[lo..hi];
    if pts.len() < 3 {
        return (a, b);
    }
    if pts.len() <= 256 {
        let mut best = (f64::INFINITY, 0, pts.len() - 1);
        for i in 0..pts.len() {
            for j in i + 1..pts.len() {
                let w = pts[j] - pts[i] + 1;
                let score = ln_poisson_sf(p * (w - 1) as f64, j - i);
                if score < best.0 {
                    best = (score, i, j);
                }
            }
        }
        return (pts[best.1], pts[best.2]);
    }
    let mut gaps: Vec<usize> = pts.windows(2).map(|w| w[1] - w[0]).collect();
    gaps.sort_unstable();
    let limit = BURST_TRIM_GAPS * gaps[gaps.len() / 2].max(1);
    while pts.len() > 2 && pts[1] - pts[0] > limit {
        pts = &pts[1..];
    }
    while pts.len() > 2 && pts[pts.len() - 1] - pts[pts.len() - 2] > limit {
        pts = &pts[..pts.len() - 1];
    }
    (pts[0], pts[pts.len() - 1])
}

/// The fewest large samples within `w` that the null rate `p` makes unexpected at level `alpha`.
fn burst_count(n_valid: usize, p: f64, w: usize, alpha: f64) -> Option<usize> {
    let mu = p * (w - 1) as f64;
    let lead = n_valid as f64 * p;
    let start = MIN_BURST_SPIKES.max(mu.ceil() as usize + 1);
    (start..=w).find(|&k| lead * poisson_sf(mu, k - 1) <= alpha)
}

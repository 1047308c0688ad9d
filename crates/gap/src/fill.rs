//! Gaps in a series of samples: where they are, and filling them by interpolation for the estimators, which want
//! samples without gaps. A gap is a missing sample or a masked transient (NaN in a part).

use std::ops::Range;

/// A copy with NaN runs filled by linear interpolation between their neighbours (the ends by the nearest value);
/// the estimators want gap-free samples, and the few gaps of a real record hardly move them.
pub fn fill_gaps(x: &[f64]) -> Vec<f64> {
    let mut out = x.to_vec();
    refill(&mut out, &gap_runs(x));
    out
}

/// The runs of non-finite samples in `x` (missing, or masked as transients), in order.
pub fn gap_runs(x: &[f64]) -> Vec<Range<usize>> {
    let mut runs = Vec::new();
    let mut start = None;
    for (i, v) in x.iter().enumerate() {
        match (v.is_finite(), start) {
            (false, None) => start = Some(i),
            (true, Some(a)) => {
                runs.push(a..i);
                start = None;
            }
            _ => {}
        }
    }
    if let Some(a) = start {
        runs.push(a..x.len());
    }
    runs
}

/// A copy of `x` with the samples of `runs` set to NaN again: for the statistics that take gaps as gaps (the
/// Allan deviation), where a fill would count as samples.
pub fn with_gaps(x: &[f64], runs: &[Range<usize>]) -> Vec<f64> {
    let mut out = x.to_vec();
    for r in runs {
        out[r.start.min(x.len())..r.end.min(x.len())].iter_mut().for_each(|v| *v = f64::NAN);
    }
    out
}

/// Most samples each side of a run whose mean anchors its fill.
pub const ANCHOR_SAMPLES: usize = 256;

/// Fill the samples of `runs` in `x` by linear interpolation between anchors beside each run: the mean of up to as
/// many samples as the run is long ([`ANCHOR_SAMPLES`] at most, not reaching into the runs beside it), placed at
/// their centre. A line drawn between the two single samples beside a run carries one sample's noise over the
/// whole run, a box as large as the white noise's sample spread that a slow estimate reads as signal; the means
/// carry a fraction of it. A run at an end takes the anchor beside it; a series that is all one run is left alone.
/// An estimator that takes a component out of filled samples fills the runs again from what it leaves, so that
/// the fill carries none of that component: a line drawn through a gap of minutes under a temperature response
/// would leave the response's curve, less the line, as a bump in what is left.
pub fn refill(x: &mut [f64], runs: &[Range<usize>]) {
    let n = x.len();
    for (k, r) in runs.iter().enumerate() {
        let (a, b) = (r.start.min(n), r.end.min(n));
        if a >= b {
            continue;
        }
        let w = (b - a).clamp(1, ANCHOR_SAMPLES);
        let prev_end = if k > 0 { runs[k - 1].end.min(a) } else { 0 };
        let next_start = runs.get(k + 1).map_or(n, |r| r.start.max(b).min(n));
        // (position, mean) of the samples [lo, hi).
        let anchor = |lo: usize, hi: usize, x: &[f64]| -> Option<(f64, f64)> {
            (hi > lo).then(|| ((lo + hi - 1) as f64 / 2.0, x[lo..hi].iter().sum::<f64>() / (hi - lo) as f64))
        };
        let left = anchor(a.saturating_sub(w).max(prev_end), a, x);
        let right = anchor(b, (b + w).min(next_start), x);
        match (left, right) {
            (Some((pl, xl)), Some((ph, xh))) => {
                for j in a..b {
                    x[j] = xl + (xh - xl) * (j as f64 - pl) / (ph - pl);
                }
            }
            (Some((_, v)), None) | (None, Some((_, v))) => x[a..b].iter_mut().for_each(|y| *y = v),
            (None, None) => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Runs are found at the start, inside and at the end; a refill draws the line between the samples beside
    /// each run (the means of as many each side as the run is long, here one to three, not reaching into the next run; at an
    /// end the mean beside it), whatever the run
    /// held before.
    #[test]
    fn runs_are_found_and_filled_by_their_neighbours() {
        let nan = f64::NAN;
        let x = [nan, 1.0, 2.0, nan, nan, nan, 6.0, 7.0, nan, nan];
        let runs = gap_runs(&x);
        assert_eq!(runs, vec![0..1, 3..6, 8..10]);
        assert_eq!(fill_gaps(&x), vec![1.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 6.5, 6.5]);
        // A component taken out of the filled samples: the refill follows what is left, not the old line.
        let mut y: Vec<f64> = fill_gaps(&x).iter().enumerate().map(|(i, v)| v - 10.0 * i as f64).collect();
        y[4] = 99.0;
        refill(&mut y, &runs);
        assert_eq!(y, vec![-9.0, -9.0, -18.0, -27.0, -36.0, -45.0, -54.0, -63.0, -58.5, -58.5]);
        // The runs set to NaN again: the same runs come back, the rest untouched.
        let back = with_gaps(&y, &runs);
        assert_eq!(gap_runs(&back), runs);
        assert_eq!(back[1..3], y[1..3]);
        assert!(gap_runs(&[1.0, 2.0]).is_empty());
        let mut all = [nan; 3];
        refill(&mut all, &gap_runs(&[nan; 3]));
        assert!(all.iter().all(|v| v.is_nan()));
    }

    /// A long run is anchored on the means beside it: alternating noise of +-1 around a line of slope 0.01 fills
    /// with the line itself (to 1%), where the single samples beside the run would put it off by up to 1.
    #[test]
    fn a_long_run_is_anchored_on_means() {
        let n = 3000;
        let mut x: Vec<f64> = (0..n).map(|i| 0.01 * i as f64 + if i % 2 == 0 { 1.0 } else { -1.0 }).collect();
        let run = 1000..2001;
        refill(&mut x, std::slice::from_ref(&run));
        for j in run {
            assert!((x[j] - 0.01 * j as f64).abs() < 0.01, "at {j}: {} against {}", x[j], 0.01 * j as f64);
        }
    }
}

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

/// Fill the samples of `runs` in `x` by linear interpolation between the samples beside each run (a run at an
/// end takes the nearest one; a series that is all one run is left alone). An estimator that takes a component
/// out of filled samples fills the runs again from what it leaves, so that the fill carries none of that
/// component: a line drawn through a gap of minutes under a temperature response would leave the response's
/// curve, less the line, as a bump in what is left.
pub fn refill(x: &mut [f64], runs: &[Range<usize>]) {
    let n = x.len();
    for r in runs {
        let (a, b) = (r.start.min(n), r.end.min(n));
        if a >= b {
            continue;
        }
        match (a.checked_sub(1), (b < n).then_some(b)) {
            (Some(l), Some(h)) => {
                let (xl, xh) = (x[l], x[h]);
                for j in a..b {
                    x[j] = xl + (xh - xl) * (j - l) as f64 / (h - l) as f64;
                }
            }
            (Some(l), None) => {
                let v = x[l];
                x[a..b].iter_mut().for_each(|y| *y = v);
            }
            (None, Some(h)) => {
                let v = x[h];
                x[a..b].iter_mut().for_each(|y| *y = v);
            }
            (None, None) => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Runs are found at the start, inside and at the end; a refill draws the line between the samples beside
    /// each run (the nearest sample at an end), whatever the run held before.
    #[test]
    fn runs_are_found_and_filled_by_their_neighbours() {
        let nan = f64::NAN;
        let x = [nan, 1.0, 2.0, nan, nan, nan, 6.0, 7.0, nan, nan];
        let runs = gap_runs(&x);
        assert_eq!(runs, vec![0..1, 3..6, 8..10]);
        assert_eq!(fill_gaps(&x), vec![1.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 7.0, 7.0]);
        // A component taken out of the filled samples: the refill follows what is left, not the old line.
        let mut y: Vec<f64> = fill_gaps(&x).iter().enumerate().map(|(i, v)| v - 10.0 * i as f64).collect();
        y[4] = 99.0;
        refill(&mut y, &runs);
        assert_eq!(y, vec![-9.0, -9.0, -18.0, -27.0, -36.0, -45.0, -54.0, -63.0, -63.0, -63.0]);
        // The runs set to NaN again: the same runs come back, the rest untouched.
        let back = with_gaps(&y, &runs);
        assert_eq!(gap_runs(&back), runs);
        assert_eq!(back[1..3], y[1..3]);
        assert!(gap_runs(&[1.0, 2.0]).is_empty());
        let mut all = [nan; 3];
        refill(&mut all, &gap_runs(&[nan; 3]));
        assert!(all.iter().all(|v| v.is_nan()));
    }
}

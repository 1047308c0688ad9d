//! Order statistics for the robust estimates: the median and quantiles by selection (O(n), no full sort).

/// The median of `x` (the upper one of an even count); NaN when `x` is empty.
pub fn median(x: &[f64]) -> f64 {
    median_in_place(&mut x.to_vec())
}

/// [`median`], reordering `v` instead of copying it.
pub fn median_in_place(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, f64::total_cmp);
    *m
}

/// The Gaussian-consistent robust scale of `v`, 1.4826 times its median absolute deviation, and its median
/// (reordering `v`); NaN when `v` is empty.
pub fn mad_scale_in_place(v: &mut [f64]) -> (f64, f64) {
    let med = median_in_place(v);
    let mut dev: Vec<f64> = v.iter().map(|x| (x - med).abs()).collect();
    (med, 1.4826 * median_in_place(&mut dev))
}

/// The `p` quantile of `v` (the element of rank round((n - 1) p)), reordering it; NaN when `v` is empty.
pub fn quantile_in_place(v: &mut [f64], p: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let k = ((v.len() - 1) as f64 * p).round() as usize;
    let (_, m, _) = v.select_nth_unstable_by(k, f64::total_cmp);
    *m
}

/// The quartiles and the median of `v` (the elements of rank round((n - 1) / 4), n / 2 and round(3 (n - 1) / 4),
/// as [`quantile_in_place`] and [`median_in_place`] give them), reordering it: the quartiles are selected within
/// the halves the median's selection leaves, so the three cost about two passes; NaN when `v` is empty.
pub fn quartiles_in_place(v: &mut [f64]) -> (f64, f64, f64) {
    if v.is_empty() {
        return (f64::NAN, f64::NAN, f64::NAN);
    }
    let n = v.len();
    let mid = n / 2;
    let (lo, med, hi) = v.select_nth_unstable_by(mid, f64::total_cmp);
    let med = *med;
    let rank = |p: f64| ((n - 1) as f64 * p).round() as usize;
    let (k1, k3) = (rank(0.25), rank(0.75));
    let q1 = if k1 < mid { *lo.select_nth_unstable_by(k1, f64::total_cmp).1 } else { med };
    let q3 = if k3 > mid { *hi.select_nth_unstable_by(k3 - mid - 1, f64::total_cmp).1 } else { med };
    (q1, med, q3)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn medians_and_quantiles_by_rank() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 3.0, "the upper median of an even count");
        assert!(median(&[]).is_nan());
        let mut v: Vec<f64> = (0..101).map(f64::from).rev().collect();
        assert_eq!(quantile_in_place(&mut v, 0.9), 90.0);
        assert_eq!(quantile_in_place(&mut v, 0.0), 0.0);
    }

    #[test]
    fn quartiles_are_the_quantiles_of_their_ranks() {
        let mut state = 12345u64;
        for n in [1usize, 2, 3, 4, 5, 7, 8, 100, 1001] {
            let v: Vec<f64> = (0..n)
                .map(|_| {
                    state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    ((state >> 40) % 17) as f64
                })
                .collect();
            let want = (quantile_in_place(&mut v.clone(), 0.25), median(&v), quantile_in_place(&mut v.clone(), 0.75));
            assert_eq!(quartiles_in_place(&mut v.clone()), want, "n = {n}");
        }
        assert!(quartiles_in_place(&mut []).0.is_nan());
    }
}

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

/// The `p` quantile of `v` (the element of rank round((n - 1) p)), reordering it; NaN when `v` is empty.
pub fn quantile_in_place(v: &mut [f64], p: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let k = ((v.len() - 1) as f64 * p).round() as usize;
    let (_, m, _) = v.select_nth_unstable_by(k, f64::total_cmp);
    *m
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
}

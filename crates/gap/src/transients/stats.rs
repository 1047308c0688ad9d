//! The robust local statistics the transient scan tests every series with: the medians of each point's two sides
//! (the point and its overlapping blocks left out), the residuals against them, robust scales that survive
//! outliers, coarse value lattices and smooth components, the lattice step, the false-alarm threshold, and prefix
//! sums for block means over gaps.

/// The threshold at a scale with `m` independent blocks, in robust scales: `max(FLOOR, sqrt(2 ln m) + MARGIN)`.
const KAPPA_MARGIN: f64 = 1.5;
/// The threshold's floor, in robust scales.
const KAPPA_FLOOR: f64 = 5.5;
/// Gaussian consistency of 1.4826 MAD.
const MAD_TO_SD: f64 = 1.482_602_218_505_602;

/// Prefix sums of the finite values (less their first value, for precision) and their count.
pub(super) struct Prefix {
    sum: Vec<f64>,
    count: Vec<u32>,
    offset: f64,
}

impl Prefix {
    pub(super) fn new(x: &[f64]) -> Prefix {
        let offset = x.iter().copied().find(|v| v.is_finite()).unwrap_or(0.0);
        let mut sum = Vec::with_capacity(x.len() + 1);
        let mut count = Vec::with_capacity(x.len() + 1);
        let (mut s, mut c) = (0.0, 0u32);
        sum.push(s);
        count.push(c);
        for v in x {
            if v.is_finite() {
                s += v - offset;
                c += 1;
            }
            sum.push(s);
            count.push(c);
        }
        Prefix { sum, count, offset }
    }

    pub(super) fn len(&self) -> usize {
        self.sum.len() - 1
    }

    /// The mean of the finite values in `[a, b)`, NaN with fewer than `min_count` of them.
    pub(super) fn mean(&self, a: usize, b: usize, min_count: usize) -> f64 {
        let c = (self.count[b] - self.count[a]) as usize;
        if c == 0 || c < min_count {
            return f64::NAN;
        }
        (self.sum[b] - self.sum[a]) / c as f64 + self.offset
    }
}

/// The running medians of `v` on each side of every point: over offsets `-h..-e` (left) and `e+1..=h` (right),
/// NaN skipped. The point itself and the `e` on each side that share samples with it (overlapping blocks) are
/// left out, so a point is always compared with values it does not contain: where the series is locally monotone
/// (a ramp, a drift that dominates the noise) a median that included it would return the point itself, a residual
/// of exactly 0 whatever the noise. At each end the series is continued by its point reflection about the end
/// value (`2 v[0] - v[j]`), which keeps a ramp, a step near the end and a random walk on their course.
pub(super) fn side_medians(v: &[f64], h: usize, e: usize) -> (Vec<f64>, Vec<f64>) {
    let n = v.len();
    let (Some(first), Some(last)) = (v.iter().position(|x| x.is_finite()), v.iter().rposition(|x| x.is_finite()))
    else {
        return (vec![f64::NAN; n], vec![f64::NAN; n]);
    };
    let (pa, pb) = (v[first], v[last]);
    let at = |j: isize| -> f64 {
        if j < 0 {
            let m = (-j) as usize;
            if m < n {
                2.0 * pa - v[m]
            } else {
                f64::NAN
            }
        } else if (j as usize) < n {
            v[j as usize]
        } else {
            let m = 2 * (n as isize - 1) - j;
            if m >= 0 {
                2.0 * pb - v[m as usize]
            } else {
                f64::NAN
            }
        }
    };
    let (h, e) = (h as isize, e as isize);
    let min_count = ((h - e) as usize / 4).max(1);
    // M(j), the median over [j - h, j - e - 1], for j in 0..n + h + e + 1: the left side of i is M(i), the
    // right side M(i + h + e + 1), so one sliding window serves both.
    let shift = (h + e + 1) as usize;
    let mut win: Vec<f64> = Vec::with_capacity((h - e + 1) as usize);
    let insert = |win: &mut Vec<f64>, x: f64| {
        if x.is_finite() {
            let p = win.partition_point(|a| a.total_cmp(&x).is_lt());
            win.insert(p, x);
        }
    };
    let remove = |win: &mut Vec<f64>, x: f64| {
        if x.is_finite() {
            let p = win.partition_point(|a| a.total_cmp(&x).is_lt());
            win.remove(p);
        }
    };
    for j in -h..-e {
        insert(&mut win, at(j));
    }
    let mut m = Vec::with_capacity(n + shift);
    for j in 0..(n + shift) as isize {
        let c = win.len();
        m.push(if c < min_count {
            f64::NAN
        } else if c % 2 == 1 {
            win[c / 2]
        } else {
            0.5 * (win[c / 2 - 1] + win[c / 2])
        });
        remove(&mut win, at(j - h));
        insert(&mut win, at(j - e));
    }
    let keep = |i: usize, x: f64| if v[i].is_finite() { x } else { f64::NAN };
    let left = (0..n).map(|i| keep(i, m[i])).collect();
    let right = (0..n).map(|i| keep(i, m[i + shift])).collect();
    (left, right)
}

/// Residuals of `v` against its two sides (see [`side_medians`]): `(two_sided, both)`. `two_sided` is `v` less
/// the mean of the two side medians: its robust scale is the scale's noise (a step adds to it only at the few
/// points next to it). `both` is how far `v` stands out from both sides in the same direction (the smaller of
/// the two differences), 0 where it lies between them: a bump stands out from both sides, a step from one, a
/// ramp from the two in opposite directions. With one side missing (a gap), the other decides.
pub(super) fn residuals(v: &[f64], h: usize, e: usize) -> (Vec<f64>, Vec<f64>) {
    let (left, right) = side_medians(v, h, e);
    let mut two = Vec::with_capacity(v.len());
    let mut both = Vec::with_capacity(v.len());
    for ((x, l), r) in v.iter().zip(&left).zip(&right) {
        let (dl, dr) = (x - l, x - r);
        let (t, b) = match (dl.is_finite(), dr.is_finite()) {
            (true, true) => (x - 0.5 * (l + r), if dl * dr > 0.0 { dl.signum() * dl.abs().min(dr.abs()) } else { 0.0 }),
            (true, false) => (dl, dl),
            (false, true) => (dr, dr),
            (false, false) => (f64::NAN, f64::NAN),
        };
        two.push(t);
        both.push(b);
    }
    (two, both)
}

/// A robust scale of the finite values of `r`: the larger of 1.4826 MAD and the mean absolute deviation of the
/// 99% closest to the median (Gaussian-consistent). The MAD resists a large share of outlying values; the trimmed
/// mean stays positive and continuous where the values sit on a coarse lattice and the MAD is 0 or jumps by whole
/// steps. With `tail` and at least 200 values, also the scale that puts the quantile leaving about 10 values above
/// it (between the 95% and 99.9% ones) where a Gaussian's would be: where a smooth process dominates a block
/// length, the residuals near its turning points are heavier-tailed than the bulk says, and the threshold
/// extrapolates from the tail.
pub(super) fn robust_scale(r: &[f64], tail: bool) -> f64 {
    let v: Vec<f64> = r.iter().copied().filter(|x| x.is_finite()).collect();
    if v.len() < 3 {
        return f64::NAN;
    }
    let m = median(&v);
    let mut dev: Vec<f64> = v.iter().map(|x| (x - m).abs()).collect();
    let len = dev.len();
    let k = len / 2;
    dev.select_nth_unstable_by(k, f64::total_cmp);
    let mad = dev[k];
    let tail_scale = if tail && len >= 200 {
        let q = (1.0 - 10.0 / len as f64).clamp(0.95, 0.999);
        let i = ((q * len as f64) as usize).min(len - 1);
        dev.select_nth_unstable_by(i, f64::total_cmp);
        dev[i] / (std::f64::consts::SQRT_2 * statrs::function::erf::erf_inv(q))
    } else {
        0.0
    };
    let keep = ((len as f64 * 0.99) as usize).max(1);
    if keep < len {
        dev.select_nth_unstable_by(keep, f64::total_cmp);
    }
    // E|Z| over |Z| below its 99% quantile: 2 (phi(0) - phi(2.5758)) / 0.99.
    let trimmed = dev[..keep].iter().sum::<f64>() / keep as f64 / 0.776_745;
    (MAD_TO_SD * mad).max(trimmed).max(tail_scale)
}

/// The step of the lattice the values sit on: the smallest absolute difference of neighbours above a millionth
/// of their median non-zero difference (rounding noise aside); about a millionth of the noise when there is no
/// lattice, where it is harmless.
pub(super) fn quantum(x: &[f64]) -> f64 {
    let d: Vec<f64> = x.windows(2).map(|w| (w[1] - w[0]).abs()).filter(|v| v.is_finite() && *v > 0.0).collect();
    if d.is_empty() {
        return 0.0;
    }
    let tiny = 1e-6 * median(&d);
    d.iter().copied().filter(|&v| v > tiny).fold(f64::INFINITY, f64::min)
}

/// The threshold, in robust scales, at a scale of `m` independent blocks.
pub(super) fn kappa(m: f64) -> f64 {
    ((2.0 * m.max(2.0).ln()).sqrt() + KAPPA_MARGIN).max(KAPPA_FLOOR)
}

pub(super) use octavar_stats::tails::normal_sf;

pub(super) use octavar_stats::robust::median;

pub(super) fn mean(x: &[f64]) -> f64 {
    if x.is_empty() {
        return f64::NAN;
    }
    x.iter().sum::<f64>() / x.len() as f64
}

/// The largest power of two at most `v` (1 for 0).
pub(super) fn prev_pow2(v: usize) -> usize {
    if v <= 1 {
        1
    } else {
        1 << (usize::BITS - 1 - v.leading_zeros())
    }
}

//! The covariance of Allan variance estimates across averaging times, for a gyro of the IEEE 952 model.
//!
//! Overlapping estimates at neighbouring octaves are made of the same samples, so their errors are correlated,
//! strongly so where flicker or random walk dominates. A fit that weights each tau as if its error were its own
//! counts the same information several times and draws intervals too narrow. This module gives the full
//! covariance matrix the interval computation needs ([`super::intervals`]).
//!
//! The angle `x` (the running sum of the rate times tau0) of each term has stationary second increments, and
//! its generalised covariance (Greenhall's `sw` function) is, for a lag `h` in seconds,
//!
//! ```text
//! G(h) = Q^2 [h = 0]  -  N^2 |h| / 2  +  B^2 / (2 pi) h^2 ln|h|  +  K^2 |h|^3 / 12
//! ```
//!
//! (each term gives back its Allan variance 3 Q^2 / tau^2, N^2 / tau, (2 ln 2 / pi) B^2, K^2 tau / 3). The
//! second differences `d_a(i) = x(i + 2 m_a) - 2 x(i + m_a) + x(i)` at averaging factors `m_a`, `m_b` then have
//! the cross-covariance `R(L) = sum_k sum_l c_k c_l G((L + k m_a - l m_b) tau0)` at lag `L = i - j`, with
//! `c = (1, -2, 1)`, and for Gaussian noise the estimates `A_a = sum_t d_a(s_a t)^2 / (2 tau_a^2 M_a)` (M_a terms
//! starting every s_a samples) have
//!
//! ```text
//! Cov(A_a, A_b) = 2 sum_t sum_u R(s_a t - s_b u)^2 / (4 tau_a^2 tau_b^2 M_a M_b).
//! ```
//!
//! The double sum is a sum over lags weighted by how many pairs share each lag. It is summed term by term where
//! the lags are few, and otherwise integrated piecewise with Gauss-Legendre between the points where `R` or
//! the weight bends (`R` is a polynomial between them for white noise and random walk, so the rule is exact
//! there; the flicker term's `h^2 ln|h|` tail, which decays as `L^-2`, is followed out to 32 times the span).
//! The rate ramp R is deterministic and adds nothing here.

use super::Term;

/// Where an Allan variance estimate's second differences lie in the record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EstimateShape {
    /// Averaging factor m (tau = m tau0).
    pub m: f64,
    /// Number of second differences averaged (M).
    pub terms: f64,
    /// Samples between the starts of consecutive differences: 1 for the overlapping estimate, m for the
    /// non-overlapping one, m / S for an octave accumulator of stride S.
    pub stride: f64,
}

/// The noise of the angle: the squares of the five terms' coefficients (ramp unused).
#[derive(Clone, Copy, Debug)]
struct Angle {
    q2: f64,
    n2: f64,
    b2: f64,
    k2: f64,
}

impl Angle {
    /// The continuous part of the generalised covariance, deg^2, at lag `h` seconds.
    fn g(&self, h: f64) -> f64 {
        let a = h.abs();
        let flicker = if a > 0.0 { self.b2 / (2.0 * std::f64::consts::PI) * a * a * a.ln() } else { 0.0 };
        -0.5 * self.n2 * a + flicker + self.k2 * a * a * a / 12.0
    }
}

const C: [f64; 3] = [1.0, -2.0, 1.0];

/// The pair of estimates whose covariance is summed.
struct Pair<'a> {
    angle: &'a Angle,
    tau0: f64,
    ma: f64,
    mb: f64,
}

impl Pair<'_> {
    /// The cross-covariance of the two second differences at lag `l` samples (continuous part).
    fn r(&self, l: f64) -> f64 {
        let mut s = 0.0;
        for (k, ck) in C.iter().enumerate() {
            for (j, cj) in C.iter().enumerate() {
                s += ck * cj * self.angle.g((l + k as f64 * self.ma - j as f64 * self.mb) * self.tau0);
            }
        }
        s
    }

    /// The angle-quantization part of the cross-covariance at lag `l`: nonzero where a pair of the nine points
    /// coincides.
    fn r_q(&self, l: f64) -> f64 {
        let mut s = 0.0;
        for (k, ck) in C.iter().enumerate() {
            for (j, cj) in C.iter().enumerate() {
                if (l + k as f64 * self.ma - j as f64 * self.mb).abs() < 0.5 {
                    s += ck * cj * self.angle.q2;
                }
            }
        }
        s
    }
}

/// Length of the overlap of `[0, a)` and `[l, l + b)`.
fn overlap(l: f64, a: f64, b: f64) -> f64 {
    (a.min(l + b) - l.max(0.0)).max(0.0)
}

/// Gauss-Legendre nodes and weights on [-1, 1], 8 points.
const GL8: [(f64, f64); 8] = [
    (-0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
    (-0.796_666_477_413_626_7, 0.222_381_034_453_374_48),
    (-0.525_532_409_916_329_0, 0.313_706_645_877_887_3),
    (-0.183_434_642_495_649_8, 0.362_683_783_378_362_0),
    (0.183_434_642_495_649_8, 0.362_683_783_378_362_0),
    (0.525_532_409_916_329_0, 0.313_706_645_877_887_3),
    (0.796_666_477_413_626_7, 0.222_381_034_453_374_48),
    (0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
];

/// Lags summed one by one where the core span is at most this; integrated above it.
const DIRECT_SPAN: f64 = 512.0;

/// The flicker term's tails are followed out to this many core spans on each side.
const FLICKER_TAIL_SPANS: f64 = 32.0;

/// `sum_t sum_u R(s_a t - s_b u)^2`: the sum of squared cross-covariances over the pairs of differences.
fn pair_sum(pair: &Pair, a: &EstimateShape, b: &EstimateShape) -> f64 {
    let len_a = a.terms * a.stride;
    let len_b = b.terms * b.stride;
    let (ma, mb) = (pair.ma, pair.mb);
    // The core: lags where the two differences share points, outside which R vanishes but for flicker.
    let (lo, hi) = (-2.0 * ma, 2.0 * mb);
    let weight = |l: f64| overlap(l, len_a, len_b);
    let (mut s, tail_lo, tail_hi) = if a.stride == 1.0 && b.stride == 1.0 && hi - lo <= DIRECT_SPAN {
        let mut s = 0.0;
        let mut l = lo.max(-len_b);
        while l <= hi.min(len_a) {
            let r = pair.r(l) + pair.r_q(l);
            s += r * r * weight(l);
            l += 1.0;
        }
        (s, lo - 0.5, hi + 0.5)
    } else {
        let mut cuts: Vec<f64> = (0..3).flat_map(|k| (0..3).map(move |j| j as f64 * mb - k as f64 * ma)).collect();
        let mut s = integrate(pair, lo, hi, &mut cuts, len_a, len_b);
        // Angle quantization: a few isolated lags, where it adds 2 R R_q + R_q^2.
        if pair.angle.q2 > 0.0 {
            cuts.dedup_by(|x, y| (*x - *y).abs() < 0.5);
            for &l in &cuts {
                let rq = pair.r_q(l);
                s += (2.0 * pair.r(l) * rq + rq * rq) * weight(l);
            }
        }
        (s, lo, hi)
    };
    if pair.angle.b2 > 0.0 {
        let span = hi - lo;
        let mut t = 0.0;
        let mut step = span;
        while t < FLICKER_TAIL_SPANS * span {
            s += integrate(pair, tail_lo - t - step, tail_lo - t, &mut Vec::new(), len_a, len_b);
            s += integrate(pair, tail_hi + t, tail_hi + t + step, &mut Vec::new(), len_a, len_b);
            t += step;
            step *= 2.0;
        }
    }
    s / (a.stride * b.stride)
}

/// The integral of `R(l)^2 overlap(l)` over `[x0, x1]`, split at `cuts` (sorted in place) and where the overlap
/// weight bends, Gauss-Legendre on four pieces of each part.
fn integrate(pair: &Pair, x0: f64, x1: f64, cuts: &mut Vec<f64>, len_a: f64, len_b: f64) -> f64 {
    let (x0, x1) = (x0.max(-len_b), x1.min(len_a));
    if x1 <= x0 {
        return 0.0;
    }
    let mut at: Vec<f64> = cuts.iter().copied().chain([0.0, len_a - len_b]).filter(|c| *c > x0 && *c < x1).collect();
    at.push(x0);
    at.push(x1);
    at.sort_by(f64::total_cmp);
    at.dedup();
    cuts.sort_by(f64::total_cmp);
    let mut s = 0.0;
    for w in at.windows(2) {
        let h = (w[1] - w[0]) / 4.0;
        for p in 0..4 {
            let c = w[0] + h * (p as f64 + 0.5);
            for (x, wt) in GL8 {
                let l = c + 0.5 * h * x;
                let r = pair.r(l);
                s += 0.5 * h * wt * r * r * overlap(l, len_a, len_b);
            }
        }
    }
    s
}

/// The covariance matrix of Allan variance estimates of the given shapes, (deg/s)^4, for a record sampled every
/// `tau0_s` seconds of a gyro with the fitted squares `squares` (Q^2, N^2, B^2, K^2, R^2 in [`Term`] order).
pub fn avar_covariance(shapes: &[EstimateShape], tau0_s: f64, squares: &[f64; 5]) -> Vec<Vec<f64>> {
    let angle = Angle {
        q2: squares[Term::Q as usize],
        n2: squares[Term::N as usize],
        b2: squares[Term::B as usize],
        k2: squares[Term::K as usize],
    };
    let n = shapes.len();
    let mut cov = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in i..n {
            let (a, b) = (&shapes[i], &shapes[j]);
            let pair = Pair { angle: &angle, tau0: tau0_s, ma: a.m, mb: b.m };
            let ta = a.m * tau0_s;
            let tb = b.m * tau0_s;
            let c = 2.0 * pair_sum(&pair, a, b) / (4.0 * ta * ta * tb * tb * a.terms * b.terms);
            cov[i][j] = c;
            cov[j][i] = c;
        }
    }
    cov
}

#[cfg(test)]
mod tests;

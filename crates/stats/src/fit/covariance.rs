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
//! `R` is linear in the squares, so the covariance is a quadratic form in them: [`CovarianceBasis`] sums the
//! products of the terms' own cross-covariances once, and gives the matrix for any squares at the cost of a
//! few multiplications (the upper bounds of the fit ask for it at many models).
//!
//! The double sum is a sum over lags weighted by how many pairs share each lag. It is summed term by term where
//! the lags are few, and otherwise integrated piecewise with Gauss-Legendre between the points where `R` or
//! the weight bends (`R` is a polynomial between them for white noise and random walk, so the rule is exact
//! there; the flicker term's `h^2 ln|h|` tail, which decays as `L^-2`, is followed out to 32 times the span).
//! The rate ramp R is deterministic and adds nothing here.

use super::Term;

/// Where an Allan variance estimate's second differences lie in the record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EstimatorShape {
    /// Averaging factor m (tau = m tau0).
    pub m: f64,
    /// Number of second differences averaged (M).
    pub terms: f64,
    /// Samples between the starts of consecutive differences: 1 for the overlapping estimate, m for the
    /// non-overlapping one, m / S for an octave accumulator of stride S.
    pub stride: f64,
}

/// The noise terms with a covariance, in [`Term`] order: Q, N, B, K.
const NOISE_TERMS: usize = 4;

/// The pairs (t, u), t <= u, of noise terms, in the order of a basis entry.
const TERM_PAIRS: [(usize, usize); 10] =
    [(0, 0), (0, 1), (0, 2), (0, 3), (1, 1), (1, 2), (1, 3), (2, 2), (2, 3), (3, 3)];

/// The continuous part of each term's generalised covariance for a unit square, deg^2, at lag `h` seconds:
/// N, B and K (angle quantization is a spike at zero, handled apart).
#[inline]
fn g_terms(h: f64) -> [f64; 3] {
    let a = h.abs();
    let flicker = if a > 0.0 { a * a * a.ln() / (2.0 * std::f64::consts::PI) } else { 0.0 };
    [-0.5 * a, flicker, a * a * a / 12.0]
}

const C: [f64; 3] = [1.0, -2.0, 1.0];

/// The pair of estimates whose covariance is summed.
struct Pair {
    tau0: f64,
    ma: f64,
    mb: f64,
}

impl Pair {
    /// Each term's cross-covariance of the two second differences at lag `l` samples, for unit squares
    /// (Q, N, B, K); `with_q` adds the quantization spike where a pair of the nine points coincides.
    fn r(&self, l: f64, with_q: bool) -> [f64; NOISE_TERMS] {
        let mut r = [0.0; NOISE_TERMS];
        for (k, ck) in C.iter().enumerate() {
            for (j, cj) in C.iter().enumerate() {
                let lag = l + k as f64 * self.ma - j as f64 * self.mb;
                let c = ck * cj;
                let g = g_terms(lag * self.tau0);
                r[1] += c * g[0];
                r[2] += c * g[1];
                r[3] += c * g[2];
                if with_q && lag.abs() < 0.5 {
                    r[0] += c;
                }
            }
        }
        r
    }
}

/// The products of the terms' cross-covariances at one lag, weighted, added to `acc`.
#[inline]
fn accumulate(acc: &mut [f64; 10], r: &[f64; NOISE_TERMS], weight: f64) {
    for (a, &(t, u)) in acc.iter_mut().zip(&TERM_PAIRS) {
        *a += weight * r[t] * r[u];
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
    (-0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (-0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (0.796_666_477_413_626_7, 0.222_381_034_453_374_48),
    (0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
];

/// Lags summed one by one where the core span is at most this; integrated above it.
const DIRECT_SPAN: f64 = 512.0;

/// The flicker term's tails are followed out to this many core spans on each side.
const FLICKER_TAIL_SPANS: f64 = 32.0;

/// Gauss-Legendre pieces per part between breakpoints.
const PIECES: usize = 2;

/// `sum_t sum_u R_x(s_a t - s_b u) R_y(s_a t - s_b u)` for every pair of terms (x, y): the sums of products of
/// cross-covariances over the pairs of differences.
fn pair_sums(pair: &Pair, a: &EstimatorShape, b: &EstimatorShape) -> [f64; 10] {
    let len_a = a.terms * a.stride;
    let len_b = b.terms * b.stride;
    let (ma, mb) = (pair.ma, pair.mb);
    // The core: lags where the two differences share points, outside which R vanishes but for flicker.
    let (lo, hi) = (-2.0 * ma, 2.0 * mb);
    let weight = |l: f64| overlap(l, len_a, len_b);
    let mut acc = [0.0; 10];
    let (tail_lo, tail_hi) = if a.stride == 1.0 && b.stride == 1.0 && hi - lo <= DIRECT_SPAN {
        let mut l = lo.max(-len_b);
        while l <= hi.min(len_a) {
            accumulate(&mut acc, &pair.r(l, true), weight(l));
            l += 1.0;
        }
        (lo - 0.5, hi + 0.5)
    } else {
        let mut cuts: Vec<f64> = (0..3).flat_map(|k| (0..3).map(move |j| j as f64 * mb - k as f64 * ma)).collect();
        integrate(&mut acc, pair, lo, hi, &cuts, len_a, len_b);
        // Angle quantization: a spike at a few isolated lags, summed there.
        cuts.sort_by(f64::total_cmp);
        cuts.dedup_by(|x, y| (*x - *y).abs() < 0.5);
        for &l in &cuts {
            let r = pair.r(l, true);
            let w = weight(l);
            for (x, &(t, u)) in acc.iter_mut().zip(&TERM_PAIRS) {
                if t == 0 {
                    // R_q sits in the Q component only: its products with every term at this lag.
                    *x += w * r[0] * r[u];
                }
            }
        }
        (lo, hi)
    };
    let span = hi - lo;
    let mut t = 0.0;
    let mut step = span;
    while t < FLICKER_TAIL_SPANS * span {
        integrate(&mut acc, pair, tail_lo - t - step, tail_lo - t, &[], len_a, len_b);
        integrate(&mut acc, pair, tail_hi + t, tail_hi + t + step, &[], len_a, len_b);
        t += step;
        step *= 2.0;
    }
    let s = a.stride * b.stride;
    acc.map(|v| v / s)
}

/// Adds the integral of the products `R_x(l) R_y(l) overlap(l)` over `[x0, x1]` to `acc`, split at `cuts` and
/// where the overlap weight bends, Gauss-Legendre on [`PIECES`] pieces of each part (continuous terms only).
fn integrate(acc: &mut [f64; 10], pair: &Pair, x0: f64, x1: f64, cuts: &[f64], len_a: f64, len_b: f64) {
    let (x0, x1) = (x0.max(-len_b), x1.min(len_a));
    if x1 <= x0 {
        return;
    }
    let mut at: Vec<f64> = cuts.iter().copied().chain([0.0, len_a - len_b]).filter(|c| *c > x0 && *c < x1).collect();
    at.push(x0);
    at.push(x1);
    at.sort_by(f64::total_cmp);
    at.dedup();
    for w in at.windows(2) {
        let h = (w[1] - w[0]) / PIECES as f64;
        for p in 0..PIECES {
            let c = w[0] + h * (p as f64 + 0.5);
            for (x, wt) in GL8 {
                let l = c + 0.5 * h * x;
                accumulate(acc, &pair.r(l, false), 0.5 * h * wt * overlap(l, len_a, len_b));
            }
        }
    }
}

/// The covariance of Allan variance estimates as a quadratic form in the squares: per pair of estimates, the
/// sums of products of the terms' cross-covariances (see the module doc).
#[derive(Clone, Debug)]
pub struct CovarianceBasis {
    n: usize,
    /// Row-major upper triangle of the matrix: per entry, the ten products' sums, normalised.
    entries: Vec<[f64; 10]>,
}

impl CovarianceBasis {
    /// The basis for estimates of the given shapes in a record sampled every `tau0_s` seconds.
    pub fn new(shapes: &[EstimatorShape], tau0_s: f64) -> Self {
        let n = shapes.len();
        let mut entries = Vec::with_capacity(n * (n + 1) / 2);
        for i in 0..n {
            for j in i..n {
                let (a, b) = (&shapes[i], &shapes[j]);
                let pair = Pair { tau0: tau0_s, ma: a.m, mb: b.m };
                let ta = a.m * tau0_s;
                let tb = b.m * tau0_s;
                let norm = 2.0 / (4.0 * ta * ta * tb * tb * a.terms * b.terms);
                entries.push(pair_sums(&pair, a, b).map(|v| v * norm));
            }
        }
        CovarianceBasis { n, entries }
    }

    /// The covariance matrix, (deg/s)^4, for the squares `squares` (Q^2, N^2, B^2, K^2, R^2 in [`Term`] order).
    pub fn at(&self, squares: &[f64; 5]) -> Vec<Vec<f64>> {
        let th = [
            squares[Term::Q as usize],
            squares[Term::N as usize],
            squares[Term::B as usize],
            squares[Term::K as usize],
        ];
        let coef: [f64; 10] = TERM_PAIRS.map(|(t, u)| th[t] * th[u] * if t == u { 1.0 } else { 2.0 });
        let mut cov = vec![vec![0.0; self.n]; self.n];
        let mut e = self.entries.iter();
        for i in 0..self.n {
            for j in i..self.n {
                let v: f64 = e.next().expect("an entry per pair").iter().zip(&coef).map(|(s, c)| s * c).sum();
                cov[i][j] = v;
                cov[j][i] = v;
            }
        }
        cov
    }
}

/// The covariance matrix of Allan variance estimates of the given shapes, (deg/s)^4, for a record sampled every
/// `tau0_s` seconds of a gyro with the fitted squares `squares` (Q^2, N^2, B^2, K^2, R^2 in [`Term`] order).
pub fn avar_covariance(shapes: &[EstimatorShape], tau0_s: f64, squares: &[f64; 5]) -> Vec<Vec<f64>> {
    CovarianceBasis::new(shapes, tau0_s).at(squares)
}

#[cfg(test)]
mod tests;

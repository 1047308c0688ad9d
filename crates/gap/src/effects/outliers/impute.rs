//! The flagged spikes' samples filled in again: each one drawn from its clean neighbours as the noise itself
//! would have it, so that the record the chain's later steps learn from keeps the noise's short-tau structure.
//!
//! A spike's sample replaced by its neighbours' median is too smooth: the median of eight neighbours has a small
//! fraction of one sample's variance, and where a twentieth of the samples are replaced the Allan variance at one
//! to four samples comes out 1-5% low, which a filter corner read next takes as a lower corner. Here each sample is
//! drawn as the noise would have it given its clean neighbours within [`HALF_WINDOW`] each side: the simple
//! kriging of their deviations from the local level (the mean of the clean samples within [`LEVEL_HALF`] each
//! side), under the covariance the record's own short-lag variogram gives beside the deviations' robust variance,
//! plus a Gaussian draw of the kriging error (a conditional simulation). The level is taken as known: ordinary
//! kriging, which estimates it from the eight neighbours, ties each filled sample to them (on white noise it is
//! their mean), and where a twentieth of the samples were filled so the Allan variance at long tau came out 21%
//! high. The flagged samples are filled in order, and each one filled counts as a clean neighbour of the next
//! (sequential Gaussian simulation), so a run of spikes is filled with the correlation the noise has along it.

use super::HALF_WINDOW;
use octavar_shared::sim::rng::SimRng;

/// The draws' stream (fixed, so the diagnosis is repeatable).
const IMPUTE_SEED: u64 = 0x1_a9e7;

/// Clean samples each side whose mean is the level a sample's deviation is read from.
pub(super) const LEVEL_HALF: usize = 2048;

/// Deviations from the level the covariance's variance is read from, at most (a stride through longer records).
const LEVEL_SAMPLES: usize = 200_000;

/// The kriging weights of a set of neighbours and the kriging variance.
type Weights = (Vec<f64>, f64);

/// The simple kriging weights of the neighbours at offsets `offs` (from the sample filled) under the covariance
/// `c(k) = sill - g(k)`, and the kriging variance; `None` where the system is singular or the variance is not
/// positive.
fn kriging(offs: &[isize], g: &[f64], sill: f64) -> Option<Weights> {
    let k = offs.len();
    let cov = |d: isize| sill - g[d.unsigned_abs()];
    let mut a = vec![0.0; k * (k + 1)];
    for r in 0..k {
        for c in 0..k {
            a[r * (k + 1) + c] = cov(offs[r] - offs[c]);
        }
        a[r * (k + 1) + k] = cov(offs[r]);
    }
    let w = solve(&mut a, k)?;
    let var = sill - (0..k).map(|r| w[r] * cov(offs[r])).sum::<f64>();
    (var > 0.0 && w.iter().all(|v| v.is_finite())).then_some((w, var))
}

/// Solves the `dim`-square system whose augmented rows are `a` (each `dim + 1` long), by Gaussian elimination
/// with partial pivoting.
fn solve(a: &mut [f64], dim: usize) -> Option<Vec<f64>> {
    let w = dim + 1;
    let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for col in 0..dim {
        let piv = (col..dim).max_by(|&p, &q| a[p * w + col].abs().total_cmp(&a[q * w + col].abs()))?;
        if a[piv * w + col].abs() <= 1e-12 * scale {
            return None;
        }
        if piv != col {
            for c in 0..w {
                a.swap(piv * w + c, col * w + c);
            }
        }
        for r in 0..dim {
            if r != col {
                let f = a[r * w + col] / a[col * w + col];
                if f != 0.0 {
                    for c in col..w {
                        a[r * w + c] -= f * a[col * w + c];
                    }
                }
            }
        }
    }
    Some((0..dim).map(|r| a[r * w + dim] / a[r * w + r]).collect())
}

/// `x` with each sample at the indices of `flagged` (ascending) filled in from its neighbours under the
/// semivariogram `g` (lags up to `2 HALF_WINDOW` at least, read outside `skip` and the flagged samples:
/// [`super::short_lag::variogram`]) ([module docs](self)); samples marked in `skip` (gaps, and the samples around jumps taken out)
/// are not read. A sample with fewer than two clean neighbours, or all of them where the variogram could not be
/// read, takes the value paired with its index.
pub(super) fn fill(x: &[f64], flagged: &[(usize, f64)], skip: &[bool], g: Option<&[f64]>) -> Vec<f64> {
    let n = x.len();
    let mut out = x.to_vec();
    let mut clean: Vec<bool> = skip.iter().map(|s| !s).collect();
    for &(i, _) in flagged {
        clean[i] = false;
    }
    let level = Level::new(x, &clean);
    let sill = g.and_then(|_| level.deviations_variance(x, &clean));
    let (Some(g), Some(sill)) = (g.filter(|g| g.len() > 2 * HALF_WINDOW), sill) else {
        for &(i, v) in flagged {
            out[i] = v;
        }
        return out;
    };
    let mut rng = SimRng::new(IMPUTE_SEED);
    // The weights by which neighbours are clean: a bit per offset, -HALF_WINDOW..-1 then 1..HALF_WINDOW.
    let mut cache: Vec<Option<Option<Weights>>> = vec![None; 1 << (2 * HALF_WINDOW)];
    let offsets: Vec<isize> = (-(HALF_WINDOW as isize)..=HALF_WINDOW as isize).filter(|&o| o != 0).collect();
    for &(i, fallback) in flagged {
        let mut mask = 0usize;
        let mut offs = Vec::with_capacity(2 * HALF_WINDOW);
        for (b, &o) in offsets.iter().enumerate() {
            let j = i as isize + o;
            if j >= 0 && (j as usize) < n && clean[j as usize] {
                mask |= 1 << b;
                offs.push(o);
            }
        }
        let fit = match level.at(i) {
            Some(m) if offs.len() >= 2 => {
                cache[mask].get_or_insert_with(|| kriging(&offs, g, sill)).as_ref().map(|f| (m, f))
            }
            _ => None,
        };
        out[i] = match fit {
            Some((m, (w, var))) => {
                let dev: f64 = offs.iter().zip(w).map(|(&o, w)| w * (out[(i as isize + o) as usize] - m)).sum();
                m + dev + var.sqrt() * rng.normal()
            }
            None => fallback,
        };
        clean[i] = true;
    }
    out
}

/// The local level: the mean of the clean samples within [`LEVEL_HALF`] each side, from prefix sums (the samples
/// filled later are not counted, which moves a level by a few of its 64 terms at most).
struct Level {
    sum: Vec<f64>,
    count: Vec<u32>,
}

impl Level {
    fn new(x: &[f64], clean: &[bool]) -> Level {
        let mut sum = Vec::with_capacity(x.len() + 1);
        let mut count = Vec::with_capacity(x.len() + 1);
        let (mut s, mut c) = (0.0, 0u32);
        sum.push(s);
        count.push(c);
        for (v, &ok) in x.iter().zip(clean) {
            if ok {
                s += v;
                c += 1;
            }
            sum.push(s);
            count.push(c);
        }
        Level { sum, count }
    }

    /// The level at sample `i`; `None` with fewer than a quarter of the window's samples clean.
    fn at(&self, i: usize) -> Option<f64> {
        let n = self.sum.len() - 1;
        let (lo, hi) = (i.saturating_sub(LEVEL_HALF), (i + LEVEL_HALF + 1).min(n));
        let c = self.count[hi] - self.count[lo];
        (c as usize >= LEVEL_HALF / 2).then(|| (self.sum[hi] - self.sum[lo]) / c as f64)
    }

    /// The variance of the clean samples' deviations from their level, robustly (the square of 1.4826 times
    /// their median absolute deviation, so the spikes the flags missed move it little).
    fn deviations_variance(&self, x: &[f64], clean: &[bool]) -> Option<f64> {
        let stride = (x.len() / LEVEL_SAMPLES).max(1);
        let mut d: Vec<f64> =
            (0..x.len()).step_by(stride).filter(|&t| clean[t]).filter_map(|t| self.at(t).map(|m| x[t] - m)).collect();
        if d.len() < 100 {
            return None;
        }
        let (_, scale) = octavar_stats::robust::mad_scale_in_place(&mut d);
        (scale > 0.0).then_some(scale * scale)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use octavar_stats::robust::median_in_place;

    /// White noise through a one-pole filter of pole `a`, unit innovations.
    fn filtered(n: usize, a: f64, seed: u64) -> Vec<f64> {
        let mut rng = SimRng::new(seed);
        let mut y = 0.0;
        (0..n)
            .map(|_| {
                y = a * y + rng.normal();
                y
            })
            .collect()
    }

    /// The mean square of the first differences at lag `m` of the averages over `m` samples (twice the Allan
    /// variance, non-overlapped), over the whole record.
    fn avar(x: &[f64], m: usize) -> f64 {
        let means: Vec<f64> = x.chunks_exact(m).map(|c| c.iter().sum::<f64>() / m as f64).collect();
        means.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum::<f64>() / (2 * (means.len() - 1)) as f64
    }

    /// On white noise the neighbours say nothing of a sample: the weights vanish and the variance is the sample's.
    /// On an AR(1) of pole 0.6 with both neighbours of the sample clean, the weights are the closed form's
    /// `a / (1 + a^2)` each and the variance `1 / (1 + a^2)` of the process's (innovations of unit variance).
    #[test]
    fn simple_kriging_has_its_closed_forms() {
        let white = [0.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0];
        let (w, var) = kriging(&[-2, -1, 1, 3], &white, 1.0).unwrap();
        assert!(w.iter().all(|v| v.abs() < 1e-12) && (var - 1.0).abs() < 1e-12, "{w:?} {var}");
        let a: f64 = 0.6;
        let sill = 1.0 / (1.0 - a * a);
        let g: Vec<f64> = (0..9).map(|k| sill * (1.0 - a.powi(k))).collect();
        let (w, var) = kriging(&[-1, 1], &g, sill).unwrap();
        let want = a / (1.0 + a * a);
        assert!(w.iter().all(|v| (v - want).abs() < 1e-12), "{w:?} against {want}");
        assert!((var - 1.0 / (1.0 + a * a)).abs() < 1e-12, "{var}");
    }

    /// A twentieth of a filtered noise's samples, singly and in runs of two, are replaced. Filled from the
    /// neighbours' median, the Allan variance at one to four samples comes out 1-5% below the clean record's;
    /// filled by the kriged draw, within 2% of it at every tau from one sample to 256.
    #[test]
    fn filled_samples_give_the_short_tau_allan_variance_back() {
        for (a, seed) in [(0.5, 1), (0.8, 2)] {
            let n = 400_000;
            let x = filtered(n, a, seed);
            let mut rng = SimRng::new(seed + 100);
            let mut flagged = Vec::new();
            let mut i = 5;
            while i < n - 5 {
                if rng.uniform() < 0.035 {
                    flagged.push(i);
                    if rng.uniform() < 0.4 {
                        flagged.push(i + 1);
                        i += 1;
                    }
                    i += 2;
                }
                i += 1;
            }
            let share = flagged.len() as f64 / n as f64;
            assert!((0.04..0.07).contains(&share), "{share}");
            let mut spiked = x.clone();
            for &i in &flagged {
                spiked[i] += 10.0 * rng.sign();
            }
            let is_flagged = {
                let mut v = vec![false; n];
                flagged.iter().for_each(|&i| v[i] = true);
                v
            };
            let median_fill = |i: usize| {
                let mut w: Vec<f64> = (i - HALF_WINDOW..=i + HALF_WINDOW)
                    .filter(|&j| j != i && !is_flagged[j])
                    .map(|j| spiked[j])
                    .collect();
                median_in_place(&mut w)
            };
            let with_median: Vec<(usize, f64)> = flagged.iter().map(|&i| (i, median_fill(i))).collect();
            let by_median: Vec<f64> = {
                let mut v = spiked.clone();
                with_median.iter().for_each(|&(i, m)| v[i] = m);
                v
            };
            let g = crate::effects::outliers::short_lag::variogram(&spiked, &is_flagged, 2 * HALF_WINDOW);
            let kriged = fill(&spiked, &with_median, &vec![false; n], g.as_deref());
            for m in [1, 2, 4, 16, 64, 256] {
                let truth = avar(&x, m);
                let med = avar(&by_median, m) / truth - 1.0;
                let kri = avar(&kriged, m) / truth - 1.0;
                eprintln!("pole {a} m {m}: median {med:.4} kriged {kri:.4}");
                if m <= 4 {
                    assert!(med < -0.01, "pole {a}, m {m}: the median fill is off by {med}");
                }
                assert!(kri.abs() < 0.02, "pole {a}, m {m}: the kriged fill is off by {kri}, the median's by {med}");
            }
        }
    }
}

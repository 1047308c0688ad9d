//! The record's structure over a few samples, which the spikes' residuals are read against: its variogram at short
//! lags, read robustly past the spikes, and a Gaussian process that has that variogram.
//!
//! A spike's residual is its sample less the median of its neighbours within four samples each side, so how the
//! residuals of a noise are spread depends on the noise only through its variogram at lags up to eight: white
//! noise, a Gauss-Markov process of a few samples and a resonance with the same variance give the same sample
//! different neighbours to be read against. Where a spike's partner in its run is left out of its window, a
//! correlated noise loses its nearest and best neighbour, and the residual widens; synthetic records of white noise
//! do not show that, and a law corrected against them stays too wide. The process drawn here is the increments'
//! autoregression of order [`ORDER`] fitted by Yule-Walker (Levinson-Durbin) to the increments' autocovariance the
//! variogram gives, summed: it has the record's variogram at every lag up to `ORDER + 1`, whatever the noise's
//! colour, and wanders beyond, which a median of neighbours takes out.

use octavar_shared::sim::rng::SimRng;
use octavar_stats::robust::median_in_place;

/// Order of the increments' autoregression: the variogram is matched at lags up to one more.
pub(super) const ORDER: usize = 8;

/// The median of a chi-square variable of one degree of freedom: a Gaussian difference's square over its variance.
const CHI2_1_MEDIAN: f64 = 0.454_936_423_119_572_8;

/// Pairs at each lag the variogram is read from, at most (a stride through longer records).
const VARIOGRAM_PAIRS: usize = 400_000;

/// Fewest pairs at a lag for the variogram to be read.
const LEAST_PAIRS: usize = 100;

/// The semivariogram `gamma(k) = E (x(t+k) - x(t))^2 / 2` at lags `0..=lags`, read from the pairs of samples
/// neither of which is marked in `skip`, as the median of the squared differences over [`CHI2_1_MEDIAN`] (a share
/// of spikes not marked moves it little); `None` where a lag has too few pairs or the differences vanish.
pub(super) fn variogram(x: &[f64], skip: &[bool], lags: usize) -> Option<Vec<f64>> {
    let n = x.len();
    let stride = (n / VARIOGRAM_PAIRS).max(1);
    let mut g = vec![0.0; lags + 1];
    let mut d2 = Vec::with_capacity(n / stride + 1);
    for (k, gk) in g.iter_mut().enumerate().skip(1) {
        d2.clear();
        d2.extend(
            (0..n.saturating_sub(k))
                .step_by(stride)
                .filter(|&t| !skip[t] && !skip[t + k])
                .map(|t| (x[t + k] - x[t]).powi(2)),
        );
        if d2.len() < LEAST_PAIRS {
            return None;
        }
        *gk = median_in_place(&mut d2) / CHI2_1_MEDIAN / 2.0;
        if !(*gk > 0.0 && gk.is_finite()) {
            return None;
        }
    }
    Some(g)
}

/// A Gaussian process with a given variogram at short lags: its increments an autoregression.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct ShortLag {
    /// The increments' autoregressive coefficients, lag 1 first.
    phi: Vec<f64>,
    /// The increments' innovation sd.
    innovation: f64,
}

impl ShortLag {
    /// The process whose variogram is `g` at lags `0..=ORDER + 1` (fewer where the increments' autocovariance
    /// stops being positive definite at a lower order); `None` where `g` is too short or has no increments.
    pub fn of_variogram(g: &[f64]) -> Option<ShortLag> {
        if g.len() < ORDER + 2 {
            return None;
        }
        // The increments' autocovariance: c(0) = 2 gamma(1), c(k) = gamma(k+1) + gamma(k-1) - 2 gamma(k).
        let c: Vec<f64> =
            (0..=ORDER).map(|k| if k == 0 { 2.0 * g[1] } else { g[k + 1] + g[k - 1] - 2.0 * g[k] }).collect();
        if !(c[0] > 0.0) {
            return None;
        }
        let (phi, err) = levinson(&c);
        (err > 0.0).then(|| ShortLag { phi, innovation: err.sqrt() })
    }

    /// `len` samples of the process times `scale`, from `rng` (started settled: a burn-in of ten orders).
    pub fn draw(&self, len: usize, scale: f64, rng: &mut SimRng) -> Vec<f64> {
        let p = self.phi.len();
        let burn = 10 * p.max(1);
        let mut d = vec![0.0; burn + len];
        let mut x = Vec::with_capacity(len);
        let mut level = 0.0;
        for t in 0..burn + len {
            let ar: f64 = self.phi.iter().enumerate().filter(|(j, _)| *j < t).map(|(j, f)| f * d[t - 1 - j]).sum();
            d[t] = ar + self.innovation * rng.normal();
            if t >= burn {
                level += d[t];
                x.push(scale * level);
            }
        }
        x
    }
}

/// The Yule-Walker coefficients of the autocovariance `c` (lags `0..c.len()`) by Levinson-Durbin, and the
/// innovation variance; the recursion stops at the last order whose reflection coefficient stays inside the unit
/// circle (an empirical sequence need not be positive definite).
fn levinson(c: &[f64]) -> (Vec<f64>, f64) {
    let mut phi: Vec<f64> = Vec::new();
    let mut err = c[0];
    for k in 1..c.len() {
        let acc = c[k] - phi.iter().enumerate().map(|(j, f)| f * c[k - 1 - j]).sum::<f64>();
        let refl = acc / err;
        if !(refl.abs() < 1.0) {
            break;
        }
        let prev = phi.clone();
        phi.push(refl);
        for j in 0..k - 1 {
            phi[j] = prev[j] - refl * prev[k - 2 - j];
        }
        err *= 1.0 - refl * refl;
    }
    (phi, err)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// White noise through a one-pole filter of pole `a` plus white noise of sd `w`, unit innovations.
    fn filtered(n: usize, a: f64, w: f64, seed: u64) -> Vec<f64> {
        let mut rng = SimRng::new(seed);
        let mut y = 0.0;
        (0..n)
            .map(|_| {
                y = a * y + rng.normal();
                y + w * rng.normal()
            })
            .collect()
    }

    /// The closed-form semivariogram of an AR(1) of pole `a` and unit innovations, plus white noise of sd `w`:
    /// `(1 - a^k) / (1 - a^2) + w^2`.
    fn closed_form(a: f64, w: f64, k: usize) -> f64 {
        (1.0 - a.powi(k as i32)) / (1.0 - a * a) + w * w
    }

    #[test]
    fn the_variogram_of_a_filtered_noise_is_its_closed_form() {
        let (a, w) = (0.6, 0.5);
        let x = filtered(200_000, a, w, 5);
        let g = variogram(&x, &vec![false; x.len()], ORDER + 1).unwrap();
        for (k, gk) in g.iter().enumerate().skip(1) {
            let truth = closed_form(a, w, k);
            assert!((gk / truth - 1.0).abs() < 0.02, "lag {k}: {gk} against {truth}");
        }
    }

    /// The process drawn from a closed-form variogram has that variogram at every lag up to `ORDER + 1`, for
    /// white noise, a Gauss-Markov process of a few samples over white noise, and a process of a few samples alone.
    #[test]
    fn the_process_drawn_has_the_variogram_it_was_given() {
        for (a, w) in [(0.0, 1.0), (0.87, 0.5), (0.6, 0.0)] {
            let g: Vec<f64> = (0..=ORDER + 1).map(|k| if k == 0 { 0.0 } else { closed_form(a, w, k) }).collect();
            let p = ShortLag::of_variogram(&g).unwrap();
            let x = p.draw(400_000, 1.0, &mut SimRng::new(9));
            for (k, &want) in g.iter().enumerate().skip(1) {
                let got = x.windows(k + 1).map(|v| (v[k] - v[0]).powi(2)).sum::<f64>() / (2 * (x.len() - k)) as f64;
                assert!((got / want - 1.0).abs() < 0.03, "pole {a}, white {w}, lag {k}: {got} against {want}");
            }
        }
    }
}

//! A filter-ready bias model: the first-order Gauss-Markov process whose Allan deviation best matches the
//! measured bias-instability region, with its fit quality.
//!
//! A Kalman filter cannot carry flicker noise (bias instability B has no finite-order state model), so INS filters
//! model the bias as a first-order Gauss-Markov (GM) process: stationary standard deviation `sigma`, correlation
//! time `T`. Its Allan variance is that of low-passed white noise of density `2 sigma^2 T`:
//!
//! ```text
//! AVAR(tau) = (2 sigma^2 T / tau) [1 - T/(2 tau) (3 - 4 e^(-tau/T) + e^(-2 tau/T))]
//! ```
//!
//! rising as a random walk of `K^2 = 2 sigma^2 / T` below T and falling as white noise above it, with its peak
//! near 1.89 T. The fit finds (sigma, T), beside the white terms Q and N, that best match the measured Allan
//! variances up to where a random walk or ramp takes over from the bias instability, in the same weights as the
//! IEEE 952 fit.

use super::{lowpass_white_factor, NoiseFit, Term};
use crate::DevPoint;

/// A fitted first-order Gauss-Markov bias.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct GaussMarkovFit {
    /// Stationary standard deviation, in the series' unit (deg/s, m/s^2).
    pub sigma: f64,
    /// Correlation time, s.
    pub tau_c_s: f64,
    /// The tau range matched, s.
    pub tau_range_s: [f64; 2],
    /// Points matched.
    pub points: usize,
    /// The largest ratio between measured and modelled Allan deviation over the range, less one (0.1: within 10%),
    /// among the points precise enough to show it (EDF of about 50 or more).
    pub max_misfit: f64,
    /// Chi-square per degree of freedom of the match (each point weighted by its own variance).
    pub chi2_per_dof: f64,
}

/// The Allan variance of a first-order Gauss-Markov process of stationary deviation `sigma` and correlation time
/// `tau_c` at averaging time `tau`.
pub fn gauss_markov_avar(sigma: f64, tau_c: f64, tau: f64) -> f64 {
    2.0 * sigma * sigma * tau_c / tau * lowpass_white_factor(tau / tau_c)
}

/// Relative model error of each point, as in the IEEE 952 fit.
const MODEL_ERROR: f64 = 0.03;
/// The least weight `1 / (2 / edf + e^2)` of a point counted in the largest misfit (an EDF of about 50).
const PRECISE_WEIGHT: f64 = 25.0;
/// The process's least share of the model for a point to count in the matched range.
const BIAS_SHARE: f64 = 0.25;

/// The Gauss-Markov bias that best matches `points` (the OADEV at octave tau the IEEE 952 `fit` used), or `None`
/// where the curve has no bias region of at least two points.
///
/// The white terms are refitted beside the process (a Gauss-Markov hump read by the five-term fit can take a
/// share of N or Q): for each correlation time on a log grid, Q^2, N^2 and sigma^2 are solved by non-negative
/// weighted least squares in relative error, and the correlation time of least log-domain chi-square is kept.
pub fn fit_gauss_markov(points: &[DevPoint], fit: &NoiseFit) -> Option<GaussMarkovFit> {
    let region = BiasRegion::new(points, fit)?;
    let (x, cost, best_tau) = region.best_fit()?;
    let model = |tau: f64| region.model(&x, tau, best_tau);
    // The range where the process is at least a quarter of the curve: the bias region it matches.
    let matched: Vec<&(f64, f64, f64)> = region
        .points
        .iter()
        .filter(|r| x[2] * gauss_markov_avar(1.0, best_tau, r.0) >= BIAS_SHARE * model(r.0))
        .collect();
    let (first, last) = (matched.first()?, matched.last()?);
    // The misfit where the points themselves are precise (their deviation within about 10%): beyond, the
    // scatter of the estimate is larger than any misfit could be told from it.
    let max_misfit = matched
        .iter()
        .filter(|r| r.2 >= PRECISE_WEIGHT)
        .map(|&&(tau, avar, _)| ((avar / model(tau)).ln().abs() / 2.0).exp() - 1.0)
        .fold(0.0, f64::max);
    let dof = region.points.len().saturating_sub(idx_count(&x) + 1).max(1);
    Some(GaussMarkovFit {
        sigma: x[2].sqrt(),
        tau_c_s: best_tau,
        tau_range_s: [first.0, last.0],
        points: matched.len(),
        max_misfit,
        chi2_per_dof: cost / dof as f64,
    })
}

/// The measured points a Gauss-Markov process is matched to, as (tau, AVAR, weight), and the fit's bandwidth.
struct BiasRegion {
    points: Vec<(f64, f64, f64)>,
    bw: Option<f64>,
}

impl BiasRegion {
    /// The usable points of the bias region of `fit`, or `None` where fewer than three are.
    fn new(points: &[DevPoint], fit: &NoiseFit) -> Option<BiasRegion> {
        let usable: Vec<&DevPoint> = points
            .iter()
            .filter(|p| p.dev.is_finite() && p.dev > 0.0 && p.edf.is_finite() && p.edf > 0.0)
            .filter(|p| p.tau_s >= fit.tau_range_s[0] && p.tau_s <= fit.tau_range_s[1])
            .collect();
        let min_at = usable.iter().min_by(|a, b| a.dev.total_cmp(&b.dev))?.tau_s;
        // The curve up to where a random walk or ramp of the fit takes over from B (or twice the minimum's tau where
        // B is not in the fit): past it the bias is not stationary, and no Gauss-Markov process follows it.
        let b_part = |tau: f64| fit.term_avar(Term::B, tau);
        let drift = |tau: f64| fit.term_avar(Term::K, tau) + fit.term_avar(Term::R, tau);
        let region: Vec<(f64, f64, f64)> = usable
            .iter()
            .filter(|p| {
                if fit.squares[Term::B as usize] > 0.0 {
                    b_part(p.tau_s) >= drift(p.tau_s) || p.tau_s <= min_at
                } else {
                    p.tau_s <= 2.0 * min_at
                }
            })
            .map(|p| (p.tau_s, p.dev * p.dev, 1.0 / (2.0 / p.edf + MODEL_ERROR * MODEL_ERROR)))
            .collect();
        if region.len() < 3 {
            return None;
        }
        Some(BiasRegion { points: region, bw: fit.bandwidth_hz })
    }

    /// The model's terms at `tau` for unit parameters: Q^2, N^2, and the process of correlation time `tau_c`.
    #[inline]
    fn basis(&self, tau: f64, tau_c: f64) -> [f64; 3] {
        [Term::Q.basis_with(tau, self.bw), Term::N.basis_with(tau, self.bw), gauss_markov_avar(1.0, tau_c, tau)]
    }

    /// The Allan variance at `tau` of the model `x` (Q^2, N^2, sigma^2) with correlation time `tau_c`.
    #[inline]
    fn model(&self, x: &[f64; 3], tau: f64, tau_c: f64) -> f64 {
        let b = self.basis(tau, tau_c);
        x[0] * b[0] + x[1] * b[1] + x[2] * b[2]
    }

    /// The weighted log-domain chi-square of the model `x` with correlation time `tau_c`.
    fn log_cost(&self, x: &[f64; 3], tau_c: f64) -> f64 {
        self.points
            .iter()
            .map(|&(tau, avar, w)| {
                let m = self.model(x, tau, tau_c);
                if m > 0.0 {
                    w * (avar.ln() - m.ln()).powi(2)
                } else {
                    f64::INFINITY
                }
            })
            .sum()
    }

    /// The non-negative solution (Q^2, N^2, sigma^2) of least cost with correlation time `tau_c`, and its cost.
    fn solve(&self, tau_c: f64) -> Option<([f64; 3], f64)> {
        let mut best: Option<([f64; 3], f64)> = None;
        // Every subset that keeps the process: the non-negative solution of least cost.
        for mask in [0b100u8, 0b110, 0b101, 0b111] {
            let idx: Vec<usize> = (0..3).filter(|j| mask >> (2 - j) & 1 == 1).collect();
            let k = idx.len();
            let (mut a, mut r) = (vec![vec![0.0; k]; k], vec![0.0; k]);
            for &(tau, avar, w) in &self.points {
                let b = self.basis(tau, tau_c);
                for (i, &ji) in idx.iter().enumerate() {
                    r[i] += w * b[ji] / avar;
                    for (l, &jl) in idx.iter().enumerate() {
                        a[i][l] += w * b[ji] * b[jl] / (avar * avar);
                    }
                }
            }
            let Some(sol) = crate::linalg::solve(a, r, 1e-300) else { continue };
            if sol.iter().any(|v| !(*v >= 0.0)) {
                continue;
            }
            let mut x = [0.0; 3];
            for (i, &j) in idx.iter().enumerate() {
                x[j] = sol[i];
            }
            let c = self.log_cost(&x, tau_c);
            if best.as_ref().is_none_or(|b| c < b.1) {
                best = Some((x, c));
            }
        }
        best
    }

    /// The solution of least cost over a log grid of correlation times: (solution, cost, correlation time).
    fn best_fit(&self) -> Option<([f64; 3], f64, f64)> {
        let (t0, t1) = (self.points[0].0, self.points[self.points.len() - 1].0);
        let grid = 160;
        let (lo, hi) = ((t0 / 30.0).ln(), (t1 * 30.0).ln());
        let (mut best, mut best_tau) = (None::<([f64; 3], f64)>, 0.0);
        for i in 0..=grid {
            let tau_c = (lo + (hi - lo) * i as f64 / grid as f64).exp();
            if let Some(s) = self.solve(tau_c) {
                if best.as_ref().is_none_or(|b| s.1 < b.1) {
                    (best, best_tau) = (Some(s), tau_c);
                }
            }
        }
        let (x, cost) = best?;
        Some((x, cost, best_tau))
    }
}

/// Parameters in use (non-zero) of a solution.
fn idx_count(x: &[f64; 3]) -> usize {
    x.iter().filter(|v| **v > 0.0).count()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::{fit_deviations, octave_oadev, FitOptions};
    use crate::{DataKind, Series};

    #[test]
    fn the_allan_variance_has_the_random_walk_and_white_limits() {
        let (sigma, tc) = (0.3, 50.0);
        // Far below T: a random walk of K^2 = 2 sigma^2 / T, AVAR = K^2 tau / 3.
        let tau = 0.01;
        let rw = 2.0 * sigma * sigma / tc * tau / 3.0;
        assert!((gauss_markov_avar(sigma, tc, tau) / rw - 1.0).abs() < 1e-3);
        // Far above: white noise of density 2 sigma^2 T, AVAR = 2 sigma^2 T / tau.
        let tau = 1e6;
        assert!((gauss_markov_avar(sigma, tc, tau) / (2.0 * sigma * sigma * tc / tau) - 1.0).abs() < 1e-3);
    }

    #[test]
    fn a_simulated_gauss_markov_bias_is_recovered() {
        // White noise plus an AR(1) bias (exact discretisation of a GM process), drawn here sample by sample.
        let (rate, n): (f64, usize) = (10.0, 2_000_000);
        let (sigma, tc, nw) = (0.05, 40.0, 0.01);
        let phi = (-1.0 / (rate * tc)).exp();
        let drive = sigma * (1.0 - phi * phi).sqrt();
        let w = crate::test_signals::white(n, 11);
        let v = crate::test_signals::white(n, 12);
        let mut b = 0.0;
        let data: Vec<f64> = (0..n)
            .map(|i| {
                b = phi * b + drive * v[i];
                b + nw * rate.sqrt() * w[i]
            })
            .collect();
        let series = Series::new(&data, DataKind::Frequency, 1.0 / rate).unwrap();
        let pts = octave_oadev(&series, 0.683).unwrap();
        let fit = fit_deviations(&pts, Some(&FitOptions::default())).unwrap();
        let gm = fit_gauss_markov(&pts, &fit).unwrap();
        assert!((gm.sigma / sigma - 1.0).abs() < 0.15, "{gm:?}");
        assert!((gm.tau_c_s / tc - 1.0).abs() < 0.3, "{gm:?}");
        assert!(gm.max_misfit < 0.25 && gm.chi2_per_dof < 5.0, "{gm:?}");
    }
}

//! The stochastic part of a chain's model re-estimated jointly on the Allan curve, in the manner of the GMWM
//! (Guerrier, Skaloud, Stebler and Victoria-Feser, JASA 2013): the base terms and every stochastic effect the
//! chain holds fitted together on the octave Allan variances of the samples, rather than each effect on a curve
//! whose other terms were fixed when it was found.
//!
//! The Haar wavelet variance the GMWM fits is half the Allan variance, so the octave OADEV is the same
//! information; each process enters with its exact Allan form (the columns of [`super::curve`]). The model is
//! linear in the processes' powers (N^2, B^2, K^2, R^2, Q^2, a Gauss-Markov or resonance variance) and
//! nonlinear in their time scales (a Gauss-Markov time, a resonance's centre and Q, an output bandwidth's
//! corner): the powers come from the weighted non-negative fit of [`joint_fit_keeping`] at each trial of the
//! time scales (variable projection), and the time scales from cyclic golden-section searches in their logs
//! around the chain's estimates. A named effect's power is kept in the fit, however small the curve finds it.
//!
//! The effects whose realisation the chain recovered (bias steps, a bistable bias, spikes) are out of the samples
//! this fit sees, and the deterministic ones (temperature, sinusoids, warm-up) too: the chain fits those by
//! least squares in the time domain (`crate::chain`).

use std::ops::Range;

use octavar_shared::sim::GyroSim;

use super::common::{gapped_oadev_points, golden};
use super::curve::{
    base_columns, filtered_gm_avar, filtered_resonance_avar, joint_fit_keeping, lattice_excess, with_base_terms,
    BASE_COLS,
};
use octavar_stats::fit::FitPoint;

/// Golden-section steps per time scale and round.
const GOLDEN_STEPS: usize = 14;
/// Rounds over the time scales.
const ROUNDS: usize = 2;
/// How far each round searches a time scale: a factor of `e^SPAN` either side of where it is.
const SPAN: f64 = 1.1;

/// What the joint fit found: the model and the log-domain chi-square of the curve under it and under the model
/// as it came in (its powers and time scales held).
pub struct JointCurve {
    /// The model with its base terms and stochastic effects re-estimated.
    pub gyro: GyroSim,
    /// The chi-square of the re-estimated model.
    pub chi2: f64,
    /// The chi-square of the model as it came in.
    pub chi2_before: f64,
}

/// The time scales of a model's stochastic effects, in logs, in the order [`TimeScales::columns`] uses them.
#[derive(Clone, Debug)]
struct TimeScales {
    bandwidth: Option<f64>,
    gauss_markov: Option<f64>,
    resonance: Option<(f64, f64)>,
}

impl TimeScales {
    fn of(g: &GyroSim) -> Self {
        TimeScales {
            bandwidth: g.bandwidth_hz.map(f64::ln),
            gauss_markov: g.gauss_markov.map(|m| m.tau_s.ln()),
            resonance: g.resonance.map(|r| (r.freq_hz.ln(), r.q.ln())),
        }
    }

    fn to_vec(&self) -> Vec<f64> {
        let mut v: Vec<f64> = self.bandwidth.into_iter().chain(self.gauss_markov).collect();
        if let Some((f, q)) = self.resonance {
            v.extend([f, q]);
        }
        v
    }

    fn with_values(&self, v: &[f64]) -> Self {
        let mut it = v.iter().copied();
        let bandwidth = self.bandwidth.map(|_| it.next().unwrap_or(f64::NAN));
        let gauss_markov = self.gauss_markov.map(|_| it.next().unwrap_or(f64::NAN));
        let resonance = self.resonance.map(|_| (it.next().unwrap_or(f64::NAN), it.next().unwrap_or(f64::NAN)));
        TimeScales { bandwidth, gauss_markov, resonance }
    }

    /// The bounds of each time scale's log, in [`TimeScales::to_vec`]'s order, for a record of `record_s` at
    /// `rate_hz`.
    fn bounds(&self, rate_hz: f64, record_s: f64) -> Vec<(f64, f64)> {
        let mut b = Vec::new();
        if self.bandwidth.is_some() {
            b.push(((rate_hz / 2000.0).ln(), (0.45 * rate_hz).ln()));
        }
        if self.gauss_markov.is_some() {
            b.push(((2.0 / rate_hz).ln(), (record_s / 3.0).max(4.0 / rate_hz).ln()));
        }
        if self.resonance.is_some() {
            b.push(((4.0 / record_s).ln(), (0.49 * rate_hz).ln()));
            b.push((0.5f64.ln(), 1000f64.ln()));
        }
        b
    }

    /// The Allan columns at the points: the base terms' (N through the bandwidth), then a Gauss-Markov process's
    /// and a resonance's of unit variance, where the model has them; and the bit mask of the effects' columns.
    fn columns(&self, pts: &[FitPoint], rate_hz: f64, with_q: bool, with_r: bool) -> (Vec<Vec<f64>>, u32) {
        let bw = self.bandwidth.map(f64::exp);
        let mut cols = base_columns(pts, rate_hz, bw, with_q);
        if !with_r {
            cols[3].iter_mut().for_each(|v| *v = 0.0);
        }
        let mut keep = 0u32;
        if let Some(t) = self.gauss_markov {
            keep |= 1 << cols.len();
            cols.push(pts.iter().map(|p| filtered_gm_avar(t.exp(), bw, p.tau_s, rate_hz)).collect());
        }
        if let Some((f, q)) = self.resonance {
            keep |= 1 << cols.len();
            let col = pts.iter().map(|p| filtered_resonance_avar(f.exp(), q.exp(), bw, p.tau_s * rate_hz, rate_hz));
            cols.push(col.collect());
        }
        (cols, keep)
    }
}

/// The base terms and the stochastic effects of `model` (its output bandwidth, Gauss-Markov process and
/// resonance) re-estimated jointly on the octave OADEV of `rate_dps` (the training samples less the model's
/// deterministic part and the recovered realisations; the runs `gaps` filled, taken as gaps), less the
/// quantisation noise of the ADC lattice of step `lattice_dps` where the model's channel has one; `None` when the
/// curve has too few points or the fit fails.
pub fn stochastic(
    model: &GyroSim,
    rate_dps: &[f64],
    gaps: &[Range<usize>],
    rate_hz: f64,
    lattice_dps: Option<f64>,
) -> Option<JointCurve> {
    let raw = gapped_oadev_points(rate_dps, gaps, rate_hz);
    let lattice = lattice_excess(&raw, model, model.bandwidth_hz, rate_hz, lattice_dps);
    let pts: Vec<FitPoint> = raw
        .into_iter()
        .map(|p| {
            let rounding = lattice.as_ref().map_or(0.0, |l| l.at(p.tau_s, rate_hz));
            FitPoint { avar: (p.avar - rounding).max(0.1 * p.avar), ..p }
        })
        .collect();
    on_points(model, &pts, rate_hz, rate_dps.len() as f64 / rate_hz)
}

/// [`stochastic`] on the Allan variances `pts` of a record of `record_s` at `rate_hz`.
fn on_points(model: &GyroSim, pts: &[FitPoint], rate_hz: f64, record_s: f64) -> Option<JointCurve> {
    if pts.len() < 6 {
        return None;
    }
    let (with_q, with_r) = (model.q_deg > 0.0, model.r_dps_per_s > 0.0);
    let start = TimeScales::of(model);
    let chi2_at = |ts: &TimeScales| {
        let (cols, keep) = ts.columns(pts, rate_hz, with_q, with_r);
        joint_fit_keeping(pts, &cols, keep).map_or(f64::INFINITY, |j| j.chi2)
    };
    let chi2_before = {
        let (cols, _) = start.columns(pts, rate_hz, with_q, with_r);
        let theta = powers_of(model);
        super::curve::log_chi2(pts, |i| cols.iter().zip(&theta).map(|(c, t)| c[i] * t).sum())
    };
    let bounds = start.bounds(rate_hz, record_s);
    let mut x = start.to_vec();
    for (v, (lo, hi)) in x.iter_mut().zip(&bounds) {
        *v = v.clamp(*lo, *hi);
    }
    for _ in 0..ROUNDS {
        for k in 0..x.len() {
            let (lo, hi) = ((x[k] - SPAN).max(bounds[k].0), (x[k] + SPAN).min(bounds[k].1));
            if !(lo < hi) {
                continue;
            }
            let trial = |v: f64| {
                let mut y = x.clone();
                y[k] = v;
                chi2_at(&start.with_values(&y))
            };
            let (v, c) = golden(lo, hi, GOLDEN_STEPS, trial);
            if c <= trial(x[k]) {
                x[k] = v;
            }
        }
    }
    let ts = start.with_values(&x);
    let (cols, keep) = ts.columns(pts, rate_hz, with_q, with_r);
    let j = joint_fit_keeping(pts, &cols, keep)?;
    let mut gyro = with_base_terms(model, &j.theta);
    gyro.bandwidth_hz = ts.bandwidth.map(f64::exp);
    let mut next = BASE_COLS;
    if let (Some(t), Some(m)) = (ts.gauss_markov, gyro.gauss_markov.as_mut()) {
        m.tau_s = t.exp();
        m.sigma_dps = j.theta[next].max(0.0).sqrt();
        next += 1;
    }
    if let (Some((f, q)), Some(r)) = (ts.resonance, gyro.resonance.as_mut()) {
        r.freq_hz = f.exp();
        r.q = q.exp();
        r.sigma_dps = j.theta[next].max(0.0).sqrt();
    }
    Some(JointCurve { gyro, chi2: j.chi2, chi2_before })
}

/// The powers of `model`'s columns in [`TimeScales::columns`]'s order: N^2, B^2, K^2, R^2, Q^2, then a
/// Gauss-Markov variance and a resonance variance where it has them.
fn powers_of(model: &GyroSim) -> Vec<f64> {
    let mut p = vec![
        model.n_deg_per_rt_s.powi(2),
        model.b_dps.powi(2),
        model.k_dps_per_rt_s.powi(2),
        model.r_dps_per_s.powi(2),
        model.q_deg.powi(2),
    ];
    p.extend(model.gauss_markov.map(|m| m.sigma_dps.powi(2)));
    p.extend(model.resonance.map(|r| r.sigma_dps.powi(2)));
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use octavar_shared::sim::GaussMarkovSim;

    /// The exact Allan variance of white noise N, flicker B and a Gauss-Markov process (IEEE 952 Annex C's
    /// continuous form, `sigma^2 2T/tau [1 - T/(2 tau)(3 - 4 e^{-tau/T} + e^{-2 tau/T})]`, written out here) at
    /// octave taus, as points of many degrees of freedom.
    fn exact_points(n: f64, b: f64, sigma: f64, t: f64, rate_hz: f64, octaves: usize) -> Vec<FitPoint> {
        (0..octaves)
            .map(|k| {
                let tau = (1u64 << k) as f64 / rate_hz;
                let u = tau / t;
                let gm = sigma * sigma * 2.0 / u * (1.0 - (3.0 - 4.0 * (-u).exp() + (-2.0 * u).exp()) / (2.0 * u));
                let avar = n * n / tau + 2.0 * std::f64::consts::LN_2 / std::f64::consts::PI * b * b + gm;
                FitPoint { tau_s: tau, avar, edf: 1e5, shape: None }
            })
            .collect()
    }

    /// A Gauss-Markov process whose first estimate took a time constant three times too long and left part of
    /// its hump to the flicker term (as a base fit does when it reads a hump as bias instability) comes back
    /// out of the joint fit: the time, the sigma and the base terms near the truth that made the curve.
    #[test]
    fn a_gauss_markov_hump_taken_by_the_base_terms_comes_back_out() {
        let rate_hz = 100.0;
        let (n, b, sigma, t) = (0.01, 0.001, 0.02, 5.0);
        let pts = exact_points(n, b, sigma, t, rate_hz, 17);
        let start = GyroSim {
            n_deg_per_rt_s: 0.012,
            b_dps: 0.004,
            gauss_markov: Some(GaussMarkovSim { sigma_dps: 0.008, tau_s: 3.0 * t }),
            ..Default::default()
        };
        let j = on_points(&start, &pts, rate_hz, 2e4).expect("the joint fit runs");
        assert!(j.chi2 < j.chi2_before, "{} against {}", j.chi2, j.chi2_before);
        let gm = j.gyro.gauss_markov.unwrap();
        assert!((gm.tau_s / t - 1.0).abs() < 0.05, "T {}", gm.tau_s);
        assert!((gm.sigma_dps / sigma - 1.0).abs() < 0.05, "sigma {}", gm.sigma_dps);
        assert!((j.gyro.n_deg_per_rt_s / n - 1.0).abs() < 0.03, "N {}", j.gyro.n_deg_per_rt_s);
        assert!((j.gyro.b_dps / b - 1.0).abs() < 0.2, "B {}", j.gyro.b_dps);
    }
}

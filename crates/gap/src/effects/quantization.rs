//! The quantization candidate: the lattice the sample values sit on (an ADC step), and the channel that
//! reproduces it.

use super::params::QuantizationParams;
use octavar_shared::sensor::{Adc, Channel, FrontEnd, GyroModel, GENERIC};
use octavar_shared::sim::GyroSim;

use super::common::*;
use super::noise_spectrum::coloured_half_difference;
use super::{Effect, EffectFit, EffectKind, TrainingData};

/// The lattice `offset + k q` the sample values sit on: `(q, a lattice point)`, or `None`.
pub(super) fn lattice(x: &[f64]) -> Option<(f64, f64)> {
    let stride = (x.len() / 200_000).max(1);
    let sample: Vec<f64> = x.iter().step_by(stride).copied().collect();
    let mut v = sample.clone();
    v.sort_by(f64::total_cmp);
    v.dedup();
    if v.len() < 2 || v.len() * 4 > sample.len() {
        return None; // (nearly) every value distinct: no lattice
    }
    let span = v[v.len() - 1] - v[0];
    let gaps: Vec<f64> = v.windows(2).map(|w| w[1] - w[0]).filter(|g| *g > span * 1e-12).collect();
    if gaps.is_empty() {
        return None;
    }
    // The step: the smallest gap that is common (a tenth quantile keeps a rare off-lattice pair out), then the
    // mean of the gaps that are one step.
    let mut g = gaps.clone();
    g.sort_by(f64::total_cmp);
    let q0 = g[g.len() / 10];
    let ones: Vec<f64> = gaps.iter().copied().filter(|x| (x / q0 - 1.0).abs() < 0.01).collect();
    let q = if ones.is_empty() { q0 } else { mean(&ones) };
    // A lattice point: the most frequent value.
    let mut sorted = sample.clone();
    sorted.sort_by(f64::total_cmp);
    let (mut best, mut best_n, mut i) = (sorted[0], 0, 0);
    while i < sorted.len() {
        let mut j = i;
        while j < sorted.len() && sorted[j] == sorted[i] {
            j += 1;
        }
        if j - i > best_n {
            best_n = j - i;
            best = sorted[i];
        }
        i = j;
    }
    let on = sample
        .iter()
        .filter(|&&s| {
            let k = (s - best) / q;
            (k - k.round()).abs() < 1e-3
        })
        .count();
    (on as f64 >= 0.99 * sample.len() as f64).then_some((q, best))
}

/// Variance of `Q(sigma Z + u)` averaged over a uniform offset u (the quantiser rounds to multiples of q).
pub(super) fn quantized_var(sigma: f64, q: f64) -> f64 {
    if sigma > 2.0 * q {
        return sigma * sigma + q * q / 12.0; // Sheppard's correction, exact to ~1e-8 here
    }
    if sigma <= 0.0 {
        return q * q / 12.0 * 0.0;
    }
    let kmax = (6.0 * sigma / q).ceil() as i64 + 2;
    let nu = 32;
    let mut acc = 0.0;
    for iu in 0..nu {
        let u = (iu as f64 + 0.5) / nu as f64 * q;
        let (mut s1, mut s2) = (0.0, 0.0);
        for k in -kmax..=kmax {
            let lo = ((k as f64 - 0.5) * q - u) / sigma;
            let hi = ((k as f64 + 0.5) * q - u) / sigma;
            let p = normal_sf(lo) - normal_sf(hi);
            let v = k as f64 * q;
            s1 += p * v;
            s2 += p * v * v;
        }
        acc += s2 - s1 * s1;
    }
    acc / nu as f64
}

/// The quantization effect: [`quantization`] and its parameters.
pub(super) struct Kind;

impl EffectKind for Kind {
    const EFFECT: Effect = Effect::Quantization;
    type Params = QuantizationParams;

    fn estimate(data: &TrainingData) -> Option<EffectFit> {
        quantization(data)
    }
}

/// ADC quantisation.
///
/// Method: the distinct sample values of (up to 200 000 of) the samples; when they are few, the step is the
/// common smallest gap between them, and the lattice `offset + k q` is confirmed on 99% of the samples (robust
/// to a few off-lattice ones). It counts when the quantisation noise is not negligible, `q > 0.1 sigma` (sigma the
/// per-sample sd of the white noise, half the mean square first difference, less what the model's Gauss-Markov
/// process or resonance puts there, [`coloured_half_difference`]). That white noise contains the
/// quantisation noise; the analog N is recovered by inverting the variance of a quantised Gaussian with a uniformly wandering
/// offset (Sheppard's `sigma^2 + q^2/12` when sigma > 2q, computed exactly below).
pub(super) fn quantization(d: &TrainingData) -> Option<EffectFit> {
    // The samples as recorded, outside the gaps: a gap's interpolated fill lies off the lattice, and so does a
    // sample less an earlier step's bias steps or sinusoid.
    let (q, point) = lattice(&outside_gaps(d.recorded_dps, d.gaps))?;
    let rate_hz = d.rate_hz;
    // The per-sample white variance from the first differences (half their mean square) of what the earlier
    // steps left (a spike or a sinusoid they explained would swell it): below one step the quantised noise is not
    // white at longer tau, so N from the Allan curve would not do.
    let kept = outside_gaps(d.rate_dps, d.gaps);
    let x: &[f64] = &kept;
    // A Gauss-Markov process or a resonance the model already has swells the first differences too: their share
    // is taken off.
    let v_diff = x.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum::<f64>() / (2.0 * (x.len() - 1) as f64);
    let v_white = v_diff - coloured_half_difference(d.base, rate_hz).min(0.9 * v_diff);
    if !(q > 0.1 * v_white.sqrt()) {
        return None;
    }
    // Analog per-sample sd: bisection on quantized_var(sigma) = v_white.
    let (mut lo, mut hi) = (0.0, v_white.sqrt().max(q) * 2.0);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if quantized_var(mid, q) < v_white {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let sigma = 0.5 * (lo + hi);
    let mu = mean(x);
    let k0 = ((mu - point) / q).round();
    let m0 = point + k0 * q;
    let gyro = GyroSim { n_deg_per_rt_s: sigma / rate_hz.sqrt(), bias_dps: mu, ..d.base.clone() };
    Some(EffectFit {
        effect: Effect::Quantization,
        params: QuantizationParams { step_dps: q, lattice_point_dps: m0, n_deg_per_rt_s: gyro.n_deg_per_rt_s }.into(),
        n_params: 1,
        gyro,
        channel: Some(lattice_channel(q, m0)),
        spread: None,
        cleaned: None,
    })
}

/// A generic 16-bit channel whose codes stand for `m0 + (code - 32768) q` deg/s: round to nearest on that lattice.
pub(super) fn lattice_channel(q: f64, m0: f64) -> Channel {
    let adc = Adc { bits: 16, vref_mv: 3300.0 };
    let sens = adc.mv_per_code() / q;
    let gyro = GyroModel {
        sensitivity_mv_per_dps: sens,
        null_mv: sens * (32768.5 * q - m0),
        range_dps: 32767.0 * q,
        ..GENERIC
    };
    Channel { gyro, front: FrontEnd::WIRE, adc }
}

//! The `distribution` view: the shape of the values, not their scale, in points at tau0 and one point per octave
//! tau.
//!
//! On the local residual `x[i] - (x[i-1] + x[i+1]) / 2` (which removes drifts and keeps the sign of a one-sided
//! spike): skewness, kurtosis, and the share beyond [`TAIL_SIGMA`] robust sigmas (the rms winsorised at 4 sigmas
//! of the interquartile range; on a visible lattice, beyond [`LATTICE_TAIL_STEPS`] steps at least). On the first differences, which keep an ADC step and drop its offset: the share on
//! the lattice step, when the real part has a visible one ([`lattice_of`]). And the excess kurtosis of the Allan
//! differences (adjacent block means) at every octave tau from 2 tau0, where bias steps, outliers and temperature
//! jumps show as heavy tails and sinusoids as light ones, even when the base fit has taken their Allan variance for
//! a random walk.
//!
//! The scale at tau0 is left to the Allan deviation's first point, which carries the fit's model allowance: a
//! scale point here, floored only by its sampling spread (`sqrt(0.5 / n)`, a tenth of a percent on a long record),
//! would turn any 2% error of the fitted N into the worst gap of the whole diagnosis.

use super::PointInfo;
use octavar_stats::robust::{median_in_place as median, quartiles_in_place};

/// Tail threshold of the distribution view, robust sigmas.
pub const TAIL_SIGMA: f64 = 5.0;
/// On a visible lattice, the tail threshold is at least this many steps: nearer, a residual is the noise crossing
/// a decision level, and how often it does so follows where the bias sits between levels, not the noise's tails.
pub const LATTICE_TAIL_STEPS: f64 = 3.0;
/// Fewest Allan differences a kurtosis point needs.
const MIN_DIFFERENCES: usize = 64;
/// Clip of the winsorised scale, in sigmas from the interquartile range.
const WINSOR_SIGMA: f64 = 4.0;

/// The points of a part's distribution view.
#[derive(Clone, Debug)]
pub(super) struct DistributionPlan {
    /// The real part's visible lattice step, deg/s.
    pub lattice_step: Option<f64>,
    /// Block lengths (samples) of the Allan-difference kurtosis points.
    kurt_ms: Vec<usize>,
}

impl DistributionPlan {
    /// The points of `real` (deg/s, NaN gaps) sampled at `rate_hz`.
    pub fn new(real: &[f64], rate_hz: f64) -> (DistributionPlan, Vec<PointInfo>) {
        let n = real.len();
        let tau0 = 1.0 / rate_hz;
        let valid = real.iter().filter(|v| v.is_finite()).count().max(1) as f64;
        let dist_pt = |label: &'static str, floor_sd: f64| PointInfo {
            label,
            tau_s: tau0,
            tau_lo_s: tau0,
            tau_hi_s: tau0,
            floor_sd,
        };
        let mut points = vec![
            dist_pt("skewness", 0.02 + (6.0 / valid).sqrt()),
            dist_pt("kurtosis", 0.05 + (24.0 / valid).sqrt()),
            dist_pt("tail_share", (3.0 / valid).sqrt() / valid.sqrt()),
        ];
        let lattice_step = lattice_of(real);
        if lattice_step.is_some() {
            points.push(dist_pt("lattice_share", 0.02));
        }
        // The kurtosis of the Allan differences at octave taus from 2 tau0, while there are enough of them.
        let mut kurt_ms = Vec::new();
        let mut m = 2usize;
        while n / m > MIN_DIFFERENCES {
            let tau = m as f64 * tau0;
            let k = (n / m - 1) as f64;
            points.push(PointInfo {
                label: "difference_kurtosis",
                tau_s: tau,
                tau_lo_s: tau / std::f64::consts::SQRT_2,
                tau_hi_s: tau * std::f64::consts::SQRT_2,
                floor_sd: 0.05 + (24.0 / k).sqrt(),
            });
            kurt_ms.push(m);
            m *= 2;
        }
        (DistributionPlan { lattice_step, kurt_ms }, points)
    }

    /// The view's values of `x`, in the order of its points.
    pub fn values(&self, x: &[f64]) -> Vec<f64> {
        let mut r: Vec<f64> = x.windows(3).map(|w| w[1] - 0.5 * (w[0] + w[2])).filter(|v| v.is_finite()).collect();
        let k = if self.lattice_step.is_some() { 4 } else { 3 } + self.kurt_ms.len();
        if r.len() < 16 {
            return vec![f64::NAN; k];
        }
        let n = r.len() as f64;
        let mean = r.iter().sum::<f64>() / n;
        let (mut m2, mut m3, mut m4) = (0.0, 0.0, 0.0);
        for &v in &r {
            let d = v - mean;
            let d2 = d * d;
            m2 += d2;
            m3 += d2 * d;
            m4 += d2 * d2;
        }
        let (m2, m3, m4) = (m2 / n, m3 / n, m4 / n);
        let skew = if m2 > 0.0 { m3 / m2.powf(1.5) } else { f64::NAN };
        let kurt = if m2 > 0.0 { m4 / (m2 * m2) - 3.0 } else { f64::NAN };
        let (q1, med, q3) = quartiles_in_place(&mut r);
        let iqr_sigma = (q3 - q1) / 1.349;
        for v in r.iter_mut() {
            *v = (*v - med).abs();
        }
        // Winsorised at 4 IQR sigmas: outliers count at most 4 sigma each, and a lattice finer than the noise,
        // which biases the MAD and the IQR by a share of its step, moves only the clip point. On a lattice coarser
        // than the noise, the IQR may be zero (most residuals are), so the clip and the threshold are held to
        // whole steps; the share then varies smoothly with where the bias sits between levels instead of
        // jumping from a 5-sigma share to the share of every residual off zero.
        let q = self.lattice_step.unwrap_or(0.0);
        let clip = WINSOR_SIGMA * iqr_sigma.max(q);
        let scale = (r.iter().map(|&v| v.min(clip) * v.min(clip)).sum::<f64>() / n).sqrt();
        let threshold = (TAIL_SIGMA * scale).max(LATTICE_TAIL_STEPS * q);
        let tail = if threshold > 0.0 {
            r.iter().filter(|&&v| v > threshold).count() as f64 / n
        } else {
            // A constant record: the share of non-zero residuals.
            r.iter().filter(|&&v| v > 0.0).count() as f64 / n
        };
        let mut out = vec![skew, kurt, tail];
        if let Some(q) = self.lattice_step {
            out.push(lattice_share(x, q));
        }
        out.extend(difference_kurtosis(x, &self.kurt_ms));
        out
    }
}

/// The excess kurtosis of the differences of adjacent non-overlapping block means (the Allan differences) for
/// each block length of `ms` (increasing octaves from 2); NaN where fewer than [`MIN_DIFFERENCES`] are free of
/// gaps. Block means at 2m are the pairwise means at m, so all lengths cost O(n).
pub(crate) fn difference_kurtosis(x: &[f64], ms: &[usize]) -> Vec<f64> {
    let mut out = Vec::with_capacity(ms.len());
    let mut means: Vec<f64> = x.to_vec();
    let mut m = 1usize;
    for &target in ms {
        while m < target {
            means = means.chunks_exact(2).map(|c| 0.5 * (c[0] + c[1])).collect();
            m *= 2;
        }
        let d: Vec<f64> = means.windows(2).map(|w| w[1] - w[0]).filter(|v| v.is_finite()).collect();
        if d.len() < MIN_DIFFERENCES {
            out.push(f64::NAN);
            continue;
        }
        let n = d.len() as f64;
        let mean = d.iter().sum::<f64>() / n;
        let (mut m2, mut m4) = (0.0, 0.0);
        for v in &d {
            let e = (v - mean) * (v - mean);
            m2 += e;
            m4 += e * e;
        }
        let (m2, m4) = (m2 / n, m4 / n);
        out.push(if m2 > 0.0 { m4 / (m2 * m2) - 3.0 } else { f64::NAN });
    }
    out
}

/// The lattice step of a record: the smallest non-zero first difference, kept when 99% of the differences are
/// multiples of it and it is at least half the per-sample noise sd (robust scale of the differences / sqrt 2).
pub fn lattice_of(x: &[f64]) -> Option<f64> {
    let mut d: Vec<f64> = x.windows(2).map(|w| (w[1] - w[0]).abs()).filter(|v| v.is_finite()).collect();
    if d.len() < 16 {
        return None;
    }
    let mut tmp = d.clone();
    let scale = 1.4826 * median(&mut tmp);
    let big = d.iter().copied().fold(0.0f64, f64::max);
    if big <= 0.0 {
        return None;
    }
    let tiny = 1e-9 * big;
    d.retain(|&v| v > tiny);
    let q = d.iter().copied().fold(f64::INFINITY, f64::min);
    // Visible: the step is at least half the per-sample noise sd (the differences' scale / sqrt 2), where its
    // q^2/12 adds at least 2% to the white variance; a finer lattice changes nothing the other views could see.
    if !q.is_finite() || (scale > 0.0 && q < 0.5 * scale / std::f64::consts::SQRT_2) {
        return None;
    }
    (lattice_share(x, q) >= 0.99).then_some(q)
}

/// Share of the first differences of `x` that are whole multiples of `q` (within 1% of `q`).
pub fn lattice_share(x: &[f64], q: f64) -> f64 {
    let (mut on, mut n) = (0usize, 0usize);
    for w in x.windows(2) {
        let d = w[1] - w[0];
        if d.is_finite() {
            n += 1;
            let k = d / q;
            if (k - k.round()).abs() < 0.01 {
                on += 1;
            }
        }
    }
    if n == 0 {
        f64::NAN
    } else {
        on as f64 / n as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use octavar_stats::test_signals::white;

    /// On a lattice three times coarser than the noise, the tail share does not depend on where the bias sits
    /// between two levels: at a level, most residuals are 0 and the interquartile range too, and a 5-sigma share
    /// of a zero scale would count every residual off zero (about a third of them), where between two levels
    /// the scale is a step and the share is 0. Held to three steps, both are 0; spikes of five steps on 1% of the
    /// samples count in either place.
    #[test]
    fn tail_share_on_a_coarse_lattice_follows_spikes_not_the_bias() {
        let q = 3.0;
        let on_lattice = |offset: f64, spikes: bool| -> Vec<f64> {
            white(50_000, 9)
                .iter()
                .enumerate()
                .map(|(i, v)| {
                    let spike = if spikes && i % 100 == 50 { 5.0 * q } else { 0.0 };
                    ((v + offset + spike) / q).round() * q
                })
                .collect()
        };
        let at_level = on_lattice(0.0, false);
        let (plan, _) = DistributionPlan::new(&at_level, 1.0);
        assert_eq!(plan.lattice_step, Some(q), "premise: the lattice is seen");
        let share = |x: &[f64]| plan.values(x)[2];
        let zeros = at_level.windows(3).filter(|w| w[1] - 0.5 * (w[0] + w[2]) == 0.0).count();
        assert!(zeros * 2 > at_level.len(), "premise: most residuals at a level are 0 ({zeros})");
        for offset in [0.0, 0.5 * q, 0.25 * q] {
            assert!(share(&on_lattice(offset, false)) < 1e-3, "offset {offset}: {}", share(&on_lattice(offset, false)));
            let spiky = share(&on_lattice(offset, true));
            assert!((spiky - 0.01).abs() < 0.002, "offset {offset}: {spiky}");
        }
    }
}

//! The outliers candidate: isolated spikes beyond a robust threshold above a running median.

use super::params::{to_value, OutliersParams};
use octavar_shared::sim::{GyroSim, Outliers};
use std::sync::Arc;

use super::common::*;
use super::{Effect, EffectFit, TrainingData};

/// Sigmas beyond which an isolated sample is an outlier.
pub(super) const OUTLIER_SIGMAS: f64 = 6.0;

/// Fewest spikes that make a rate: two or three events are not a process.
const MIN_SPIKES: usize = 5;

/// Spikes of a steady process are spread over the record: when more than half of them fall within this fraction
/// of it, they are a cluster (what a burst leaves), not a rate. For five spikes at uniform times, three or more
/// within a fiftieth of the record happen about once in a hundred records.
const CLUSTER_SPAN: f64 = 0.02;

/// The median of four: the mean of the middle two.
pub(super) fn median4(mut v: [f64; 4]) -> f64 {
    v.sort_unstable_by(f64::total_cmp);
    0.5 * (v[1] + v[2])
}

/// Isolated spikes.
///
/// Method: the residual of each sample from the median of its four neighbours (two each side; a spike does not
/// move a median and is not shrunk by its own sample in it; steps, drifts and sinusoids slower than a few
/// samples leave no residual), its robust scale 1.4826 MAD (the mean absolute residual times 1.2533 when the MAD is 0 on coarse quantisation); a
/// sample is a spike when its residual exceeds [`OUTLIER_SIGMAS`] scales while its neighbours' do not. A
/// Gaussian record of 1e6 samples leaves about 0.002 such samples. Parameters: the fraction of samples and the
/// median spike size. A process needs a rate: at least [`MIN_SPIKES`] spikes, not most of them within
/// [`CLUSTER_SPAN`] of the record (a burst's remnant is an event, not a steady process). The base terms are re-fitted with the spikes replaced by their neighbours' median (the
/// base N contained their white variance `p size^2`).
pub(super) fn outliers(d: &TrainingData) -> Option<EffectFit> {
    let x = d.rate_dps;
    let n = x.len();
    let mut r = vec![0.0; n];
    for i in 2..n - 2 {
        r[i] = x[i] - median4([x[i - 2], x[i - 1], x[i + 1], x[i + 2]]);
    }
    let abs: Vec<f64> = r[2..n - 2].iter().map(|v| v.abs()).collect();
    let mut scale = 1.4826 * median(&abs);
    if !(scale > 0.0) {
        scale = 1.2533 * mean(&abs);
    }
    if !(scale > 0.0) {
        return None;
    }
    let thr = OUTLIER_SIGMAS * scale;
    let big = |i: usize| r[i].abs() > thr;
    let hits: Vec<usize> = (3..n - 3).filter(|&i| big(i) && !big(i - 1) && !big(i + 1)).collect();
    if hits.len() < MIN_SPIKES || clustered(&hits, n) {
        return None;
    }
    let sizes: Vec<f64> = hits.iter().map(|&i| r[i].abs()).collect();
    let size = median(&sizes);
    let p = hits.len() as f64 / (n - 6) as f64;
    let rate_hz = d.rate_hz;
    // The base terms re-fitted with the spikes replaced by their neighbours' median (they added white variance).
    let mut cleaned = x.to_vec();
    for &i in &hits {
        cleaned[i] = x[i] - r[i];
    }
    let refit = refit_base(d.base, d.gaps, &cleaned, rate_hz).map_or_else(|| d.base.clone(), |r| r.0);
    let gyro = GyroSim { outliers: Some(Outliers { per_sample: p, size_dps: size, size_sigma: 0.0 }), ..refit };
    Some(EffectFit {
        effect: Effect::Outliers,
        params: to_value(&OutliersParams { per_sample: p, size_dps: size, count: hits.len(), robust_sigma_dps: scale }),
        n_params: 2,
        gyro,
        channel: None,
        spread: None,
        cleaned: Some(Arc::new(cleaned)),
    })
}

/// Whether more than half of the spikes at sample indices `hits` (sorted) lie within [`CLUSTER_SPAN`] of a record
/// of `n` samples.
fn clustered(hits: &[usize], n: usize) -> bool {
    let span = (CLUSTER_SPAN * n as f64) as usize;
    let need = hits.len() / 2 + 1;
    hits.windows(need).any(|w| w[need - 1] - w[0] <= span)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spikes_most_of_them_in_one_place_are_a_cluster() {
        let n = 100_000;
        // Five spread over the record: a rate. Three of five within 1% of it: a cluster.
        assert!(!clustered(&[1_000, 21_000, 41_000, 61_000, 81_000], n));
        assert!(clustered(&[1_000, 50_000, 50_400, 50_900, 81_000], n));
        // Half of them (two of four) is not more than half.
        assert!(!clustered(&[1_000, 50_000, 50_400, 81_000], n));
    }
}

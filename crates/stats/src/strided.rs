//! From an accumulator snapshot (device or replay) to Allan deviation points with confidence intervals.
//!
//! A snapshot holds exact sums per octave, not the samples, so the noise type behind each interval comes from
//! the snapshot itself: the local slope mu of AVAR ~ tau^mu between neighbouring octaves gives the power-law
//! exponent alpha = -mu - 1 (white FM 0, flicker FM -1, random walk FM -2; steeper falls are PM). The EDF is
//! Greenhall's for the accumulator's stride factor ([`octavar_shared::acc::Snapshot::stride_factor`]).

use octavar_shared::acc::{Snapshot, LEVELS};

use crate::edf::confidence_interval;
use crate::{strided_avar_edf, DevPoint, NoiseMethod};

/// Allan deviation points of a snapshot, in the unit of `scale` per code (deg/s per code for a gyro channel;
/// 1.0 for codes), with `confidence` intervals. Levels without differences are left out.
pub fn snapshot_points(snap: &Snapshot, rate_hz: f64, scale: f64, confidence: f64) -> Vec<DevPoint> {
    let avars: Vec<Option<f64>> = (0..LEVELS).map(|k| snap.avar_codes2(k).map(|v| v * scale * scale)).collect();
    let shape = StridedShape { stride: u64::from(snap.stride), n_phase: snap.samples as f64 + 1.0, confidence };
    octave_points(&avars, |k| snap.levels[k].n, |m| m / rate_hz, &shape)
}

/// What the interval of a strided octave estimate depends on besides its value.
pub(crate) struct StridedShape {
    /// Stride S: clusters start every m/S samples (every sample where m <= S).
    pub stride: u64,
    /// Phase points of the record (samples + 1, gaps left out).
    pub n_phase: f64,
    /// Two-sided confidence of the interval.
    pub confidence: f64,
}

/// Points from per-level Allan variances (`None` where a level is left out): the noise type from the local
/// slope, Greenhall's EDF for the stride factor min(m, S), the chi-square interval. `pairs(k)` is the number
/// of differences at level k, `tau_s(m)` the averaging time of m samples. Shared by the device snapshots and
/// the streamed analysis.
pub(crate) fn octave_points(
    avars: &[Option<f64>],
    pairs: impl Fn(usize) -> u64,
    tau_s: impl Fn(f64) -> f64,
    shape: &StridedShape,
) -> Vec<DevPoint> {
    let mut out = Vec::new();
    for (k, avar) in avars.iter().enumerate() {
        let Some(avar) = *avar else { continue };
        let m = (1u64 << k) as f64;
        let alpha = alpha_from_slopes(avars, k);
        let edf = strided_avar_edf(alpha, m, (shape.stride as f64).min(m), shape.n_phase);
        let dev = avar.sqrt();
        let (lo, hi) = if edf.is_finite() && edf > 0.0 {
            confidence_interval(dev, edf, shape.confidence)
        } else {
            (f64::NAN, f64::NAN)
        };
        out.push(DevPoint {
            m: 1u64 << k,
            tau_s: tau_s(m),
            n: pairs(k),
            stride: ((1u64 << k) / shape.stride).max(1),
            dev,
            alpha,
            noise_method: NoiseMethod::Default,
            edf,
            lo,
            hi,
        });
    }
    out
}

/// alpha at level k from the AVAR slope to its neighbours (their average where both exist).
fn alpha_from_slopes(avars: &[Option<f64>], k: usize) -> i32 {
    let slope = |a: usize, b: usize| match (avars.get(a).copied().flatten(), avars.get(b).copied().flatten()) {
        (Some(x), Some(y)) if x > 0.0 && y > 0.0 => Some((y / x).log2()),
        _ => None,
    };
    let left = if k > 0 { slope(k - 1, k) } else { None };
    let right = slope(k, k + 1);
    let mu = match (left, right) {
        (Some(l), Some(r)) => (l + r) / 2.0,
        (Some(s), None) | (None, Some(s)) => s,
        (None, None) => -1.0,
    };
    // AVAR ~ tau^mu: mu = -1 white FM (alpha 0), 0 flicker FM (-1), +1 random walk FM (-2); mu = -2 is PM, where
    // alpha 1 (flicker PM) or 2 (white PM) cannot be told apart by slope: take 1.
    let alpha = (-mu - 1.0).round() as i32;
    alpha.clamp(-2, 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use octavar_shared::acc::OctaveAllan;

    #[test]
    fn white_codes_give_alpha_zero_and_intervals_around_the_truth() {
        let mut acc = OctaveAllan::<8>::new();
        let mut g = crate::test_signals::Lcg::new(7);
        for _ in 0..(1 << 18) {
            acc.push(((g.next_u64() >> 32) as u32 >> 20) as u16);
        }
        let pts = snapshot_points(&acc.snapshot(), 1000.0, 1.0, 0.95);
        let sigma = ((4096.0f64 * 4096.0 - 1.0) / 12.0).sqrt();
        let mut covered = 0;
        for p in &pts[..12] {
            assert_eq!(p.alpha, 0, "m = {}", p.m);
            let truth = sigma / (p.m as f64).sqrt();
            covered += usize::from(p.lo <= truth && truth <= p.hi);
        }
        assert!(covered >= 10, "95% intervals covered the truth {covered} times of 12");
    }
}

//! The `adev` view: ln of the overlapping Allan deviation at octave taus, floored by the real curve's EDF.

use super::PointInfo;
use octavar_stats::{analyze_series, DataKind, Options, Series, Statistic, TauSpec};

/// The octave taus of a part's Allan deviation.
#[derive(Clone, Debug)]
pub(super) struct AdevPlan {
    rate_hz: f64,
    /// Cluster sizes, samples, in increasing order.
    ms: Vec<u64>,
}

impl AdevPlan {
    /// The octave taus where the real part has an Allan deviation, with the EDF of the real curve as each point's
    /// floor.
    pub fn new(real: &[f64], rate_hz: f64) -> (AdevPlan, Vec<PointInfo>) {
        let mut ms = Vec::new();
        let mut points = Vec::new();
        if let Ok(series) = Series::new(real, DataKind::Frequency, 1.0 / rate_hz) {
            let opts = Options { intervals: true, ..Default::default() };
            if let Ok(rows) = analyze_series(&series, Statistic::Oadev, &TauSpec::Octave, &opts) {
                for r in rows.iter().filter(|r| r.dev > 0.0 && r.n >= 2) {
                    let edf = if r.edf.is_finite() && r.edf > 0.0 { r.edf } else { r.n as f64 / 2.0 };
                    ms.push(r.m);
                    points.push(PointInfo {
                        label: "tau",
                        tau_s: r.tau_s,
                        tau_lo_s: r.tau_s / std::f64::consts::SQRT_2,
                        tau_hi_s: r.tau_s * std::f64::consts::SQRT_2,
                        floor_sd: (0.5 / edf).sqrt(),
                    });
                }
            }
        }
        (AdevPlan { rate_hz, ms }, points)
    }

    /// The overlapping Allan deviation of `x` at the plan's taus (NaN where it cannot be computed). `parallel`:
    /// let the statistics use rayon.
    pub fn deviations(&self, x: &[f64], parallel: bool) -> Vec<f64> {
        let mut out = vec![f64::NAN; self.ms.len()];
        let Ok(series) = Series::new(x, DataKind::Frequency, 1.0 / self.rate_hz) else { return out };
        let opts = Options { intervals: false, parallel, ..Default::default() };
        if let Ok(rows) = analyze_series(&series, Statistic::Oadev, &TauSpec::Octave, &opts) {
            for r in rows {
                if let Ok(i) = self.ms.binary_search(&r.m) {
                    out[i] = r.dev;
                }
            }
        }
        out
    }
}

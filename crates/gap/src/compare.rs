//! The comparison of a real measure with its ensemble's: a z-score per point, and a view's gap, the RMS z over its
//! worst window one decade wide in tau.
//!
//! `z = (real - mean) / sd`, with `sd` the ensemble's standard deviation floored by the statistical spread the
//! point has anyway (from the EDF for ADEV, the number of averaged periodogram bins for PSD, the sample count for
//! the moments) and widened in quadrature by a model-error allowance ([`ViewKind::model_floor`]), so a tight
//! ensemble cannot make z explode. A view's gap is a window rather than the whole view because an effect lives in
//! a band: an RMS over 17 octaves diluted a z of -4.5 at the top two taus to 1.7.

use serde::Serialize;

use super::views::{Measure, Plan, PointInfo, ViewKind};

/// Width of the window a gap is measured over, decades of tau.
pub const WINDOW_DECADES: f64 = 1.0;

/// One point's comparison.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PointZ {
    /// What the point is and where.
    #[serde(flatten)]
    pub info: PointInfo,
    /// The real value (in the view's domain: ln, atanh, or plain).
    pub real: f64,
    /// The ensemble mean.
    pub sim_mean: f64,
    /// The sd used (ensemble sd, floored, with the model allowance).
    pub sd: f64,
    /// (real - mean) / sd.
    pub z: f64,
}

/// One view's comparison: its points and the RMS of their z.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ViewGap {
    /// Which view.
    pub view: ViewKind,
    /// Its points, in increasing tau (the distribution's in their fixed order).
    pub points: Vec<PointZ>,
    /// RMS of the z-scores (0 without points).
    pub rms: f64,
    /// The view's gap: the largest RMS z over a window of its points one decade wide in tau
    /// ([`worst_window`]).
    pub gap: f64,
    /// That window: the index range of its points.
    pub window: (usize, usize),
}

/// Compare the real measure with the ensemble's, view by view (views without points are left out).
pub fn compare(plan: &Plan, real: &Measure, sims: &[Measure]) -> Vec<ViewGap> {
    let mut out = Vec::new();
    for (v, kind) in ViewKind::ALL.iter().enumerate() {
        let mut points = Vec::new();
        for (i, info) in plan.points[v].iter().enumerate() {
            let r = real.values[v][i];
            let s: Vec<f64> = sims.iter().map(|m| m.values[v][i]).filter(|x| x.is_finite()).collect();
            if !r.is_finite() || s.len() < 3 {
                continue;
            }
            let n = s.len() as f64;
            let mean = s.iter().sum::<f64>() / n;
            let var = s.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0);
            let sd0 = var.sqrt().max(info.floor_sd);
            let m = kind.model_floor();
            let sd = (sd0 * sd0 + m * m).sqrt();
            let z = if sd > 0.0 { (r - mean) / sd } else { 0.0 };
            points.push(PointZ { info: info.clone(), real: r, sim_mean: mean, sd, z });
        }
        if points.is_empty() {
            continue;
        }
        // Stable: the distribution's points at tau0 keep their order.
        points.sort_by(|a, b| a.info.tau_s.total_cmp(&b.info.tau_s));
        let rms = (points.iter().map(|p| p.z * p.z).sum::<f64>() / points.len() as f64).sqrt();
        let (a, b, gap) = worst_window(&points);
        out.push(ViewGap { view: *kind, points, rms, gap, window: (a, b) });
    }
    out
}

/// The largest RMS z over a window of `points` (sorted by tau) one decade wide in tau, as `(a, b, rms)` with
/// the window's index range `a..b`; `(0, 0, 0.0)` without points. The windows start at every point and take the
/// points up to ten times its tau; a window inside the previous one (the short ones at the top of the tau range)
/// is skipped, so every window spans a full decade, or the whole view when it spans less.
pub fn worst_window(points: &[PointZ]) -> (usize, usize, f64) {
    let mut best = (0, 0, 0.0);
    let mut prev_end = 0;
    for i in 0..points.len() {
        let top = points[i].info.tau_s * 10f64.powf(WINDOW_DECADES) * (1.0 + 1e-9);
        let end = i + points[i..].iter().take_while(|p| p.info.tau_s <= top).count();
        if i > 0 && end <= prev_end {
            continue;
        }
        prev_end = end;
        let w = &points[i..end];
        let rms = (w.iter().map(|p| p.z * p.z).sum::<f64>() / w.len() as f64).sqrt();
        if rms > best.2 {
            best = (i, end, rms);
        }
    }
    best
}

//! The gap measure, where the gap lies, and the ranking of the candidate effects.
//!
//! - **Per view**: the RMS of its points' z-scores ([`super::views::ViewGap::rms`]); about 1 (a little less, for
//!   the model allowance) when real and simulation agree.
//! - **The gap**: the worst view's RMS ([`gap_of`]). It is significant above [`SIGNIFICANT_GAP`]. After a fix, and
//!   on the holdout, the gap is the RMS of that same view (the one the diagnosis located), so the held-out check
//!   measures the gap the diagnosis is about; the worst view of each is reported beside it.
//! - **The total**: the RMS over the views of their RMS ([`total_of`]); it ranks the candidates, because a fix
//!   that cures one view must not look useless while an unrelated view stays the worst.
//! - **Where** ([`locate`]): in the worst view, the contiguous run of points (in increasing tau) whose |z| exceed
//!   3 with the largest sum of z^2 (the single largest |z| when none exceed 3); its tau band in seconds, the sign
//!   of its summed z (real above or below the ensemble) and its size (RMS z in the band, and for ADEV, PSD and
//!   temperature the ratio of real to simulated there).
//! - **Ranking** ([`score`]): `score = total_after * (1 + PARAM_PENALTY * n_params)`; the best candidate has the
//!   lowest score and must be below [`EXPLAINS`] (3/4) of the base model's total (`n_params = 0`). The penalty, 5% per parameter, is what
//!   an extra parameter must buy: an effect with three parameters must cut the total by more than 15% against an
//!   effect with none to win.

use serde::Serialize;

use super::views::{ViewGap, ViewKind};

/// A gap (worst view's RMS z) above this is significant. Where real and simulation agree each view's RMS is
/// about 1 (a little less with the model allowance); 2.5 leaves room for the worst of four views whose sds come
/// from 20 members. Checked: white noise against its own fit comes out `none` (the module example of
/// [`crate::gap`]), CATS gyro_x (which hardly follows the temperature) gives 1.94; the simulated controls of
/// tests/tests/gap_withheld.rs must stay below it.
pub const SIGNIFICANT_GAP: f64 = 2.5;

/// Penalty per parameter an effect adds, as a fraction of its total gap.
pub const PARAM_PENALTY: f64 = 0.05;

/// A candidate explains the gap when its score is below this fraction of the base model's total: it must remove
/// at least a quarter of the total gap, parameters paid for. Below that the gap is reported as significant but
/// unexplained (the effect is `none`), rather than naming an effect that changes little.
pub const EXPLAINS: f64 = 0.75;

/// |z| above which a point is part of the gap's band.
pub const BAND_Z: f64 = 3.0;

/// Real above or below the simulation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Sign {
    /// Real above the ensemble.
    Above,
    /// Real below the ensemble.
    Below,
}

impl Sign {
    /// `above` or `below`.
    pub fn name(self) -> &'static str {
        match self {
            Sign::Above => "above",
            Sign::Below => "below",
        }
    }
}

/// Where the gap lies.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Location {
    /// The worst view.
    pub view: ViewKind,
    /// Tau band, s: lowest and highest tau edge of the band's points.
    pub band_s: [f64; 2],
    /// Real above or below.
    pub sign: Sign,
    /// RMS z over the band's points.
    pub z_rms: f64,
    /// Points in the band.
    pub points: usize,
    /// Labels of the band's points (the distribution's statistics, or `tau`/`band`/`block`).
    pub labels: Vec<&'static str>,
    /// Real / simulated in the band: Allan deviation ratio (adev), power ratio (psd); `None` otherwise.
    pub ratio: Option<f64>,
    /// Real and mean simulated correlation with temperature at the band's strongest point (temperature view).
    pub correlation: Option<[f64; 2]>,
}

/// The gap: the worst view's RMS z (0 without views).
pub fn gap_of(views: &[ViewGap]) -> f64 {
    views.iter().map(|v| v.rms).fold(0.0, f64::max)
}

/// The total: RMS over the views of their RMS z.
pub fn total_of(views: &[ViewGap]) -> f64 {
    if views.is_empty() {
        return 0.0;
    }
    (views.iter().map(|v| v.rms * v.rms).sum::<f64>() / views.len() as f64).sqrt()
}

/// The worst view.
pub fn worst(views: &[ViewGap]) -> Option<&ViewGap> {
    views.iter().max_by(|a, b| a.rms.total_cmp(&b.rms))
}

/// The ranking score of a model: its total gap with the parameter penalty.
pub fn score(total: f64, n_params: usize) -> f64 {
    total * (1.0 + PARAM_PENALTY * n_params as f64)
}

/// `1 - after / before` (0 when before is 0).
pub fn shrink(before: f64, after: f64) -> f64 {
    if before > 0.0 {
        1.0 - after / before
    } else {
        0.0
    }
}

/// Where the gap lies in the worst view (see the module doc); `None` without views.
pub fn locate(views: &[ViewGap]) -> Option<Location> {
    let w = worst(views)?;
    let pts = &w.points;
    // Runs of |z| > BAND_Z; the one with the largest sum of z^2.
    let mut best: Option<(usize, usize, f64)> = None;
    let mut i = 0;
    while i < pts.len() {
        if pts[i].z.abs() <= BAND_Z {
            i += 1;
            continue;
        }
        let start = i;
        let mut s = 0.0;
        while i < pts.len() && pts[i].z.abs() > BAND_Z {
            s += pts[i].z * pts[i].z;
            i += 1;
        }
        if best.is_none_or(|(_, _, b)| s > b) {
            best = Some((start, i, s));
        }
    }
    let (a, b) = match best {
        Some((a, b, _)) => (a, b),
        None => {
            let k = (0..pts.len()).max_by(|&x, &y| pts[x].z.abs().total_cmp(&pts[y].z.abs()))?;
            (k, k + 1)
        }
    };
    let band = &pts[a..b];
    let sum_z: f64 = band.iter().map(|p| p.z).sum();
    let n = band.len() as f64;
    let lo = band.iter().map(|p| p.info.tau_lo_s).fold(f64::INFINITY, f64::min);
    let hi = band.iter().map(|p| p.info.tau_hi_s).fold(0.0, f64::max);
    let mean_diff = band.iter().map(|p| p.real - p.sim_mean).sum::<f64>() / n;
    let ratio = match w.view {
        ViewKind::Adev | ViewKind::Psd => Some(mean_diff.exp()),
        _ => None,
    };
    let correlation = (w.view == ViewKind::Temperature).then(|| {
        let p = band.iter().max_by(|x, y| x.z.abs().total_cmp(&y.z.abs())).expect("band is not empty");
        [p.real.tanh(), p.sim_mean.tanh()]
    });
    Some(Location {
        view: w.view,
        band_s: [lo, hi],
        sign: if sum_z >= 0.0 { Sign::Above } else { Sign::Below },
        z_rms: (band.iter().map(|p| p.z * p.z).sum::<f64>() / n).sqrt(),
        points: band.len(),
        labels: band.iter().map(|p| p.info.label).collect(),
        ratio,
        correlation,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gap::views::{PointInfo, PointZ};

    fn view(kind: ViewKind, zs: &[f64]) -> ViewGap {
        let points: Vec<PointZ> = zs
            .iter()
            .enumerate()
            .map(|(i, &z)| {
                let tau = 2f64.powi(i as i32);
                PointZ {
                    info: PointInfo { label: "tau", tau_s: tau, tau_lo_s: tau / 1.5, tau_hi_s: tau * 1.5, floor_sd: 0.0 },
                    real: 0.1 * z,
                    sim_mean: 0.0,
                    sd: 0.1,
                    z,
                }
            })
            .collect();
        let rms = (zs.iter().map(|z| z * z).sum::<f64>() / zs.len() as f64).sqrt();
        ViewGap { view: kind, points, rms }
    }

    #[test]
    fn the_band_is_the_heaviest_run_above_three() {
        let v = vec![
            view(ViewKind::Psd, &[0.5, 1.0, -0.3]),
            view(ViewKind::Adev, &[0.1, 4.0, 0.2, 3.5, 6.0, 5.0, 1.0]),
        ];
        assert!((gap_of(&v) - v[1].rms).abs() < 1e-12);
        let loc = locate(&v).unwrap();
        assert_eq!(loc.view, ViewKind::Adev);
        assert_eq!(loc.points, 3);
        assert!((loc.band_s[0] - 8.0 / 1.5).abs() < 1e-9 && (loc.band_s[1] - 32.0 * 1.5).abs() < 1e-9, "{loc:?}");
        assert_eq!(loc.sign, Sign::Above);
        assert!(loc.ratio.unwrap() > 1.0);
        // Nothing above 3: the single largest |z|, with its sign.
        let loc = locate(&[view(ViewKind::Adev, &[0.1, -2.0, 1.0])]).unwrap();
        assert_eq!((loc.points, loc.sign), (1, Sign::Below));
    }

    #[test]
    fn penalty_and_shrink() {
        assert!(score(2.0, 3) > score(2.0, 0));
        assert!(score(1.5, 3) < score(2.0, 0));
        assert!((shrink(8.0, 2.0) - 0.75).abs() < 1e-12);
        assert_eq!(shrink(0.0, 1.0), 0.0);
    }
}

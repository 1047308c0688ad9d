//! What a gap looks like, in words a user can model from: the view, the band, the sign, the size and the shape
//! (a spectral bump at 19-21 Hz with ten times the power; a hump in the Allan deviation at 2-3 s; heavy tails in
//! the Allan differences at 0.1-2 s; coherence with the temperature at periods of 2-30 h).
//!
//! The diagnosis keeps two answers apart: no significant gap, and a significant gap that no candidate of the
//! vocabulary explains. For the second (and for what a chain leaves), [`shape_of`] describes the gap where it lies
//! so the user knows what to model. The shape is read from the located window's core (its strongest point and the
//! neighbours beyond [`BAND_Z`] of the same sign) against the points beside it in the same view: a band whose real-to-simulated ratio stands at least [`BUMP_CONTRAST`] times above the
//! points beside it on both sides is a bump (or a dip), one that reaches the end of the view is an excess (or a
//! deficit) towards that end, and anything else is a broad excess or deficit.

use serde::Serialize;

use super::compare::{PointZ, ViewGap};
use super::rank::{Location, Sign, BAND_Z};
use super::views::ViewKind;

/// How far a band's real/simulated ratio must stand above (or below) its neighbours' on both sides to be called
/// a bump (or a dip) rather than a broad excess.
pub const BUMP_CONTRAST: f64 = 2.0;

/// The shape of a gap, for a user to model from.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GapShape {
    /// The view.
    pub view: ViewKind,
    /// Its band in tau (1/f for the PSD and temperature views), s: the core of the located window.
    pub band_s: [f64; 2],
    /// The band as frequencies, Hz (PSD and temperature views).
    pub band_hz: Option<[f64; 2]>,
    /// Real above or below the simulation.
    pub sign: Sign,
    /// RMS z over the band.
    pub z_rms: f64,
    /// A short name of the shape: `spectral_bump`, `spectral_dip`, `spectral_excess`, `spectral_deficit`,
    /// `allan_hump`, `allan_dip`, `allan_excess`, `allan_deficit`, `heavy_tails`, `light_tails`, `skew`,
    /// `spikes`, `lattice`, `temperature_coherence`.
    pub kind: &'static str,
    /// Real over simulated in the band: power (PSD), Allan deviation (ADEV); the statistic's real and simulated
    /// values for the distribution, the coherences for the temperature.
    pub ratio: Option<f64>,
    /// The sentence.
    pub text: String,
}

/// The shape of the gap located at `loc` in `views` (the comparison it was located in); `None` when the
/// located view is not among them.
pub fn shape_of(views: &[ViewGap], loc: &Location) -> Option<GapShape> {
    let v = views.iter().find(|v| v.view == loc.view)?;
    let (a, b) = v.window;
    v.points.get(a..b).filter(|p| !p.is_empty())?;
    let (a, b) = core_band(v, (a, b), loc.view);
    let band = &v.points[a..b];
    let diff = |p: &PointZ| p.real - p.sim_mean;
    let mean_diff = band.iter().map(diff).sum::<f64>() / band.len() as f64;
    // The neighbours' mean difference on each side (up to two points each), where the view has points there.
    let side = |range: std::ops::Range<usize>| -> Option<f64> {
        let pts = v.points.get(range)?;
        (!pts.is_empty()).then(|| pts.iter().map(diff).sum::<f64>() / pts.len() as f64)
    };
    let below = side(a.saturating_sub(2)..a);
    let above = side(b..(b + 2).min(v.points.len()));
    // The sign of the core itself: a window can sum to the other sign when the strong point is a narrow one.
    let up = mean_diff >= 0.0;
    let sign = if up { Sign::Above } else { Sign::Below };
    let stands = |other: Option<f64>| {
        other.is_some_and(|o| {
            let c = BUMP_CONTRAST.ln();
            if up {
                mean_diff - o >= c
            } else {
                o - mean_diff >= c
            }
        })
    };
    let lo = band.iter().map(|p| p.info.tau_lo_s).fold(f64::INFINITY, f64::min);
    let hi = band.iter().map(|p| p.info.tau_hi_s).fold(0.0, f64::max);
    let hz = [1.0 / hi, 1.0 / lo];
    let (kind, ratio, text) = match loc.view {
        ViewKind::Psd => {
            let r = mean_diff.exp();
            let (kind, what) = match (stands(below) && stands(above), up) {
                (true, true) => ("spectral_bump", "a spectral bump"),
                (true, false) => ("spectral_dip", "a spectral dip"),
                (false, true) => ("spectral_excess", "excess power"),
                (false, false) => ("spectral_deficit", "missing power"),
            };
            let edge = match (below.is_none(), above.is_none()) {
                (true, _) => " (up to the highest frequency)",
                (_, true) => " (down to the lowest frequency)",
                _ => "",
            };
            let text = format!("{what} at {} Hz{edge}: {} the simulated power", range(hz), times(r));
            (kind, Some(r), text)
        }
        ViewKind::Adev => {
            let r = mean_diff.exp();
            let (kind, what) = match (stands(below) && stands(above), up) {
                (true, true) => ("allan_hump", "a hump in the Allan deviation"),
                (true, false) => ("allan_dip", "a dip in the Allan deviation"),
                (false, true) => ("allan_excess", "the Allan deviation above the simulation"),
                (false, false) => ("allan_deficit", "the Allan deviation below the simulation"),
            };
            let text = format!("{what} at tau {} s: {} the simulated deviation", range([lo, hi]), times(r));
            (kind, Some(r), text)
        }
        ViewKind::Distribution => distribution_shape(band),
        ViewKind::Temperature => {
            let [real, sim] = loc.correlation.unwrap_or([f64::NAN, f64::NAN]);
            let text = format!(
                "the rate follows the temperature at periods of {} s: coherence {real:.2} real against {sim:.2} \
                 simulated",
                range([lo, hi])
            );
            ("temperature_coherence", Some(real), text)
        }
    };
    Some(GapShape {
        view: loc.view,
        band_s: [lo, hi],
        band_hz: matches!(loc.view, ViewKind::Psd | ViewKind::Temperature).then_some(hz),
        sign,
        z_rms: loc.z_rms,
        kind,
        ratio,
        text,
    })
}

/// The core of the gap in `v`'s located `window`: the window's strongest point and its neighbours beyond BAND_Z of
/// the same sign (the whole window when no point is that far out, and always in the distribution view), so that a
/// narrow bump is named by its own band.
fn core_band(v: &ViewGap, window: (usize, usize), view: ViewKind) -> (usize, usize) {
    let (a, b) = window;
    let Some(w) = v.points.get(a..b) else { return window };
    let peak = a + w.iter().enumerate().max_by(|x, y| x.1.z.abs().total_cmp(&y.1.z.abs())).map_or(0, |m| m.0);
    let strong = |i: usize| v.points[i].z.abs() >= BAND_Z && v.points[i].z.signum() == v.points[peak].z.signum();
    if strong(peak) && view != ViewKind::Distribution {
        let mut lo = peak;
        while lo > 0 && strong(lo - 1) {
            lo -= 1;
        }
        let mut hi = peak + 1;
        while hi < v.points.len() && strong(hi) {
            hi += 1;
        }
        (lo, hi)
    } else {
        (a, b)
    }
}

/// The distribution view's shape: the statistic of the band that stands out most, and which way.
fn distribution_shape(band: &[PointZ]) -> (&'static str, Option<f64>, String) {
    // The point of the band that stands out most says which statistic it is.
    let p = band.iter().max_by(|x, y| x.z.abs().total_cmp(&y.z.abs())).expect("band is not empty");
    let at = if p.info.label == "difference_kurtosis" {
        let taus: Vec<f64> =
            band.iter().filter(|q| q.info.label == "difference_kurtosis").map(|q| q.info.tau_s).collect();
        let t0 = taus.iter().copied().fold(f64::INFINITY, f64::min);
        let t1 = taus.iter().copied().fold(0.0, f64::max);
        format!(" of the Allan differences at tau {} s", range([t0, t1]))
    } else {
        " of the samples' local residuals".to_string()
    };
    let (kind, what) = match (p.info.label, p.z > 0.0) {
        ("kurtosis" | "difference_kurtosis", true) => ("heavy_tails", "heavy tails"),
        ("kurtosis" | "difference_kurtosis", false) => ("light_tails", "light tails"),
        ("skewness", _) => ("skew", "a skewed distribution"),
        ("tail_share", true) => ("spikes", "more samples beyond 5 robust sigma"),
        ("tail_share", false) => ("light_tails", "fewer samples beyond 5 robust sigma"),
        _ => ("lattice", "values on a lattice"),
    };
    let text = format!(
        "{what}{at}: {} {:.3} real against {:.3} simulated",
        p.info.label.replace('_', " "),
        p.real,
        p.sim_mean
    );
    (kind, Some(p.real), text)
}

/// `a-b` with three significant digits each.
fn range([a, b]: [f64; 2]) -> String {
    format!("{}-{}", sig3(a), sig3(b))
}

/// Three significant digits, without an exponent between 1e-3 and 1e5.
fn sig3(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let mag = x.abs().log10().floor() as i32;
    if !(-3..5).contains(&mag) {
        return format!("{x:.2e}");
    }
    let decimals = (2 - mag).max(0) as usize;
    format!("{x:.decimals$}")
}

/// `12 times` or `a third of` style wording of a ratio.
fn times(r: f64) -> String {
    if r >= 1.0 {
        format!("{} times", sig3(r))
    } else {
        format!("{} of", sig3(r))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compare::{worst_window, PointZ};
    use crate::rank::locate;
    use crate::views::PointInfo;

    /// A PSD view whose points sit on the simulation but for `bump` (ln power above the simulation) at indices
    /// `at`, taus 1/f for f from 50 Hz down by fifths of a decade.
    fn psd(bump: f64, at: std::ops::Range<usize>) -> ViewGap {
        let points: Vec<PointZ> = (0..12)
            .map(|i| {
                let f = 50.0 / 10f64.powf(i as f64 / 5.0);
                let d = if at.contains(&i) { bump } else { 0.0 };
                PointZ {
                    info: PointInfo {
                        label: "band",
                        tau_s: 1.0 / f,
                        tau_lo_s: 1.0 / (f * 1.2),
                        tau_hi_s: 1.2 / f,
                        floor_sd: 0.05,
                    },
                    real: d,
                    sim_mean: 0.0,
                    sd: 0.1,
                    z: d / 0.1,
                }
            })
            .rev()
            .collect();
        let (a, b, gap) = worst_window(&points);
        ViewGap { view: ViewKind::Psd, points, rms: gap, gap, window: (a, b) }
    }

    #[test]
    fn a_narrow_excess_of_power_is_a_bump_with_its_frequency_and_ratio() {
        // Ten times the power in two bands near 20 Hz (indices 2 and 3: 19.9 and 12.6 Hz), nothing beside them.
        let v = vec![psd(10f64.ln(), 2..4)];
        let loc = locate(&v).unwrap();
        let s = shape_of(&v, &loc).unwrap();
        assert_eq!((s.kind, s.sign), ("spectral_bump", Sign::Above), "{s:?}");
        let [f0, f1] = s.band_hz.unwrap();
        assert!(f0 < 12.6 && f1 > 19.9, "{s:?}");
        assert!(s.text.starts_with("a spectral bump at "), "{}", s.text);
        // The band is the bump's own two points: ten times the power.
        assert!((s.ratio.unwrap() - 10.0).abs() < 1e-9, "{s:?}");
        assert!(f0 > 8.0 && f1 < 30.0, "{s:?}");
        // The same excess over every band is a broad excess, not a bump.
        let v = vec![psd(10f64.ln(), 0..12)];
        let s = shape_of(&v, &locate(&v).unwrap()).unwrap();
        assert_eq!(s.kind, "spectral_excess", "{s:?}");
        assert!((s.ratio.unwrap() - 10.0).abs() < 1e-9);
    }

    #[test]
    fn numbers_are_written_with_three_digits() {
        assert_eq!(range([0.0195, 20.04]), "0.0195-20.0");
        assert_eq!(sig3(123456.0), "1.23e5");
        assert_eq!(times(0.5), "0.500 of");
    }
}

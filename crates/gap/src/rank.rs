//! The gap measure, where the gap lies, and the ranking of the candidate effects.
//!
//! - **Per view**: the RMS of its points' z-scores over its worst window one decade wide in tau
//!   ([`super::compare::worst_window`], [`ViewGap::gap`]); about 1 when real and simulation agree.
//! - **The gap**: the worst view's gap ([`gap_of`]). It is significant above [`SIGNIFICANT_GAP`]. After a fix, and
//!   on the holdout, the gap is the RMS z of the same view's points at the same taus ([`band_gap`]), so the
//!   held-out check measures the gap the diagnosis is about; the worst view of each is reported beside it.
//! - **The total**: the RMS over the views of their gaps ([`total_of`]); it ranks the candidates, because a fix
//!   that cures one view must not look useless while an unrelated view stays the worst, and every view a
//!   candidate fixes counts. A view's gap enters it in full up to [`SOFT_CAP`] and by its logarithm beyond
//!   ([`soft`]): one view a hundred times off (a disturbance, a corrupted stretch) must not decide alone, and a
//!   candidate that halves a gap of 4000 there must not beat one that takes another view from 9 to 1.
//! - **Where** ([`locate`]): the worst view's worst window: its tau band in seconds, the sign of its summed z
//!   (real above or below the ensemble) and its size (RMS z in the band, and for ADEV and PSD the ratio of real to
//!   simulated there, for the temperature view the coherences).
//! - **Ranking** ([`score`], [`choose`]): `score = total_after * (1 + PARAM_PENALTY * n_params)`; the best
//!   candidate has the lowest score, and its excess over a right model's total ([`RIGHT_MODEL_GAP`]) must be
//!   below [`EXPLAINS`] (3/4) of the current model's ([`explains`]). The penalty, 5% per parameter, is what an extra parameter must buy: an effect with three
//!   parameters must cut the total by more than 15% against an effect with none to win. A gap in the temperature
//!   view goes to the temperature coupling when it explains the total and scores within [`DRIVER_PREFERENCE`]
//!   of the best or clears that view: a sinusoid at the temperature's cycle imitates it, but only the coupling
//!   has a driver. A Gauss-Markov process that follows the Allan curve no better than a filter corner is white
//!   noise through a first-order filter, the spectrum the corner draws with fewer parameters: it is not chosen
//!   where the corner explains the total, and one that leaves no white noise beside it gives way to a corner that
//!   scores within [`FILTER_PREFERENCE`] of it.

use serde::Serialize;

use super::compare::ViewGap;
use super::effects::{Effect, EffectFit};
use super::judge::Evaluated;
use super::views::ViewKind;

/// A gap (the worst view's worst-decade RMS z) above this is significant. Where real and simulation agree a
/// view's gap is about 1; 2.5 leaves room for the worst window of four views whose sds come from 20 members.
/// Checked: white noise against its own fit comes out `none` (the module example of [`crate`]); the 10
/// simulated controls of tests/tests/gap_withheld.rs give 0.98 to 1.70.
pub const SIGNIFICANT_GAP: f64 = 2.5;

/// Penalty per parameter an effect adds, as a fraction of its total gap.
pub const PARAM_PENALTY: f64 = 0.05;

/// A candidate explains the gap when its score's excess over a right model's total is below this fraction of the
/// current model's ([`explains`]): it must remove at least a quarter of the gap, parameters paid for. Below that
/// the gap is reported as significant but unexplained (the effect is `none`), rather than naming an effect that
/// changes little.
pub const EXPLAINS: f64 = 0.75;

/// A view's gap counts in full in the total up to this, and by its logarithm beyond ([`soft`]): four times the
/// significance threshold, above the gaps a single effect of the withheld-effect tests leaves in any view.
pub const SOFT_CAP: f64 = 10.0;

/// How much worse a temperature coupling's score may be than the best candidate's and still be chosen, when the
/// gap lies in the temperature view (see [`choose`]).
pub const DRIVER_PREFERENCE: f64 = 1.25;

/// How much worse a filter corner's score may be than a Gauss-Markov process's and still be chosen in its place,
/// where the process left no white noise beside it (see [`choose`]): a single ensemble draw moves a total by about
/// this much.
pub const FILTER_PREFERENCE: f64 = 1.10;

/// How much further a Gauss-Markov process must take the Allan curve's chi-square than a filter corner to be read
/// as a process of its own (see [`choose`]): the 1% point of the chi-square law of one degree of freedom, the
/// white noise the process leaves above its corner.
pub const ONE_FREEDOM_CHI2: f64 = 6.63;

/// The white noise a Gauss-Markov process may leave beside it, as a fraction of its own low-frequency density
/// `sigma sqrt(2 T)`, and still be read as the white noise seen through a filter (see [`choose`]).
pub const WHITE_LEFT: f64 = 0.05;

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
    /// The representative taus of the band's first and last point, s (which points [`band_gap`] takes).
    pub tau_range_s: [f64; 2],
    /// Real above or below.
    pub sign: Sign,
    /// RMS z over the band's points.
    pub z_rms: f64,
    /// Points in the band.
    pub points: usize,
    /// Labels of the band's points (the distribution's statistics, or `tau`/`band`).
    pub labels: Vec<&'static str>,
    /// Real / simulated in the band: Allan deviation ratio (adev), power ratio (psd); `None` otherwise.
    pub ratio: Option<f64>,
    /// Real and mean simulated coherence with the temperature (its magnitude: the correlation of the two within
    /// the band at the best phase) at the band's strongest point (temperature view).
    pub correlation: Option<[f64; 2]>,
}

/// The gap: the worst view's gap (its worst decade window's RMS z; 0 without views).
pub fn gap_of(views: &[ViewGap]) -> f64 {
    views.iter().map(|v| v.gap).fold(0.0, f64::max)
}

/// A view's gap as the total counts it: itself up to [`SOFT_CAP`], `SOFT_CAP (1 + ln(gap / SOFT_CAP))` beyond.
pub fn soft(gap: f64) -> f64 {
    if gap <= SOFT_CAP {
        gap
    } else {
        SOFT_CAP * (1.0 + (gap / SOFT_CAP).ln())
    }
}

/// The total: RMS over the views of their gaps, each through [`soft`].
pub fn total_of(views: &[ViewGap]) -> f64 {
    if views.is_empty() {
        return 0.0;
    }
    (views.iter().map(|v| soft(v.gap).powi(2)).sum::<f64>() / views.len() as f64).sqrt()
}

/// The worst view.
pub fn worst(views: &[ViewGap]) -> Option<&ViewGap> {
    views.iter().max_by(|a, b| a.gap.total_cmp(&b.gap))
}

/// The RMS z, in `views`, of the points of the located view whose tau lies in the located band (the same
/// points on the training part; on the holdout, the points at the same taus). `None` when the view has no point
/// there.
pub fn band_gap(views: &[ViewGap], loc: &Location) -> Option<f64> {
    let v = views.iter().find(|v| v.view == loc.view)?;
    let [lo, hi] = loc.tau_range_s;
    let z: Vec<f64> = v
        .points
        .iter()
        .filter(|p| p.info.tau_s >= lo * (1.0 - 1e-9) && p.info.tau_s <= hi * (1.0 + 1e-9))
        .map(|p| p.z)
        .collect();
    (!z.is_empty()).then(|| (z.iter().map(|z| z * z).sum::<f64>() / z.len() as f64).sqrt())
}

/// The gap of a chain on `views`: the largest RMS z over the bands where its steps located the gap ([`band_gap`]
/// at each of `locations`); `None` when the views have no point in any of them.
pub fn chain_gap<'a>(views: &[ViewGap], locations: impl IntoIterator<Item = &'a Location>) -> Option<f64> {
    locations.into_iter().filter_map(|l| band_gap(views, l)).reduce(f64::max)
}

/// The ranking score of a model: its total gap with the parameter penalty.
pub fn score(total: f64, n_params: usize) -> f64 {
    total * (1.0 + PARAM_PENALTY * n_params as f64)
}

/// The gap of a model that is right, taken at its upper end: the RMS z of its points is a draw of about 1 or
/// less. Judged against the ensemble of the model that made the record (its true parameters), the 280 effect
/// cases of the withheld-effect tests (seeds 0-39) give a median 0.6, 0.2 to 1.6 in nine cases of ten and at
/// most 3.1 at their located bands (`GAP_ORACLE=1` in tests/tests/gap_withheld.rs).
pub const RIGHT_MODEL_GAP: f64 = 1.0;

/// The shrink a right model reaches on a part whose gap before a fix is `before`: `1 - RIGHT_MODEL_GAP /
/// before`, at least 0. A held-out gap of 2 before promises no more than about 50%, so a shrink below 70% there
/// says little against the effect; the report says so.
pub fn shrink_if_right(before: f64) -> f64 {
    shrink(before, RIGHT_MODEL_GAP).max(0.0)
}

/// `1 - after / before` (0 when before is 0).
pub fn shrink(before: f64, after: f64) -> f64 {
    if before > 0.0 {
        1.0 - after / before
    } else {
        0.0
    }
}

/// Where the gap lies: the worst view's worst decade window (see the module doc); `None` without views.
pub fn locate(views: &[ViewGap]) -> Option<Location> {
    let w = worst(views)?;
    let (a, b) = w.window;
    if b <= a {
        return None;
    }
    let band = &w.points[a..b];
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
        tau_range_s: [band[0].info.tau_s, band[band.len() - 1].info.tau_s],
        sign: if sum_z >= 0.0 { Sign::Above } else { Sign::Below },
        z_rms: w.gap,
        points: band.len(),
        labels: band.iter().map(|p| p.info.label).collect(),
        ratio,
        correlation,
    })
}

/// A gap before and after, on one part.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PartGap {
    /// The base model's gap (the located band's RMS z).
    pub gap_before: f64,
    /// With the effect.
    pub gap_after: f64,
    /// 1 - after / before.
    pub shrink: f64,
}

impl PartGap {
    /// Before and after, with their shrink.
    pub fn new(gap_before: f64, gap_after: f64) -> PartGap {
        PartGap { gap_before, gap_after, shrink: shrink(gap_before, gap_after) }
    }
}

/// One candidate effect's result at a step of the diagnosis.
#[derive(Clone, Debug)]
pub struct CandidateResult {
    /// The effect.
    pub effect: Effect,
    /// Its fit, or `None` when the data showed no trace of it.
    pub fit: Option<EffectFit>,
    /// Its ensemble's comparison.
    pub eval: Option<Evaluated>,
    /// Training gap after: the RMS z, with the effect, of the located view's points in the located band (`None`
    /// without a fit).
    pub gap_after: Option<f64>,
    /// Training: the worst view's gap with the effect.
    pub worst_after: Option<f64>,
    /// Total (RMS over views) after, training.
    pub total_after: Option<f64>,
    /// Ranking score.
    pub score: Option<f64>,
    /// Holdout gap after (the same view and band).
    pub holdout_after: Option<f64>,
    /// Holdout: the worst view's gap with the effect.
    pub holdout_worst_after: Option<f64>,
}

impl CandidateResult {
    /// The measures of a candidate's comparison `eval` at the located band `loc` (`None`s without a fit).
    pub fn new(effect: Effect, fit: Option<EffectFit>, eval: Option<Evaluated>, loc: Option<&Location>) -> Self {
        let in_view = |v: &[ViewGap]| -> Option<f64> { loc.and_then(|l| band_gap(v, l)) };
        match (&fit, &eval) {
            (Some(f), Some(e)) => {
                let t = total_of(&e.training);
                let has_holdout = !e.holdout.is_empty();
                CandidateResult {
                    effect,
                    gap_after: in_view(&e.training).or(Some(gap_of(&e.training))),
                    worst_after: Some(gap_of(&e.training)),
                    total_after: Some(t),
                    score: Some(score(t, f.n_params)),
                    holdout_after: if has_holdout { in_view(&e.holdout) } else { None },
                    holdout_worst_after: has_holdout.then(|| gap_of(&e.holdout)),
                    fit,
                    eval,
                }
            }
            _ => CandidateResult {
                effect,
                fit,
                eval,
                gap_after: None,
                worst_after: None,
                total_after: None,
                score: None,
                holdout_after: None,
                holdout_worst_after: None,
            },
        }
    }
}

/// Whether a candidate of score `score` explains a model's total gap `total_before`: it removes at least a
/// quarter of the excess over [`RIGHT_MODEL_GAP`], the total a right model leaves (`score - 1 < 3/4 (total -
/// 1)`). Measured from zero instead, a gap in one view of four counts for little in a total that the other three
/// hold near 1: a temperature view at 3.2 beside three views at 0.6-1.3 is a total of 1.79, and the coupling that
/// takes it to 1 leaves a total of 1.22, a third of the excess but only 32% of the total.
pub fn explains(score: f64, total_before: f64) -> bool {
    score - RIGHT_MODEL_GAP < EXPLAINS * (total_before - RIGHT_MODEL_GAP)
}

/// Whether `c` is a temperature coupling below its estimator's own test (proposed from 3 standard errors, named on
/// its own from 5: [`super::evidence::test`]). Such a coupling is taken only for a gap the temperature view
/// locates: a gap elsewhere (the heavy-tailed Allan differences of a warm-up) that a weak coupling also happens to
/// lower on the training part is not its evidence.
fn weak_coupling(c: &CandidateResult) -> bool {
    c.effect == Effect::Temperature && c.fit.as_ref().and_then(super::evidence::of).is_some_and(|ev| !ev.names())
}

/// Whether `c` is a Gauss-Markov process that took the white noise's place: its model keeps less white noise than
/// [`WHITE_LEFT`] of the process's own low-frequency density. White noise through a first-order low-pass filter is
/// exactly such a process (an AR(1) with the filter's time constant), so its spectrum is a filter corner's.
fn white_through_a_filter(c: &CandidateResult) -> bool {
    let Some(fit) = c.fit.as_ref().filter(|_| c.effect == Effect::GaussMarkov) else { return false };
    fit.gyro
        .gauss_markov
        .as_ref()
        .is_some_and(|g| fit.gyro.n_deg_per_rt_s < WHITE_LEFT * g.sigma_dps * (2.0 * g.tau_s).sqrt())
}

/// Whether the Gauss-Markov process `markov` follows the Allan curve no better than the filter corner `corner`,
/// by the fall of the curve's chi-square each fit reports: the process beside white noise has one freedom more
/// than white noise through a corner (the white noise left above the corner), and where that freedom does not buy
/// [`ONE_FREEDOM_CHI2`] the two are one spectrum, read by the corner with the fewer parameters. On the singles of
/// both generators a corner's own record gives the two falls within 2 of each other (or the corner's the larger,
/// where its time constant is below the process's two samples), and a process's gives its own fall 80 or more
/// beyond the corner's.
fn draws_the_corners_curve(markov: &CandidateResult, corner: &CandidateResult) -> bool {
    use crate::effects::params::EffectParams;
    match (markov.fit.as_ref().map(|f| &f.params), corner.fit.as_ref().map(|f| &f.params)) {
        (Some(EffectParams::GaussMarkov(m)), Some(EffectParams::Bandwidth(c))) => {
            m.delta_chi2 < c.delta_chi2 + ONE_FREEDOM_CHI2
        }
        _ => false,
    }
}

/// The candidate that explains the current model's gap (see the module doc), by its index in `candidates`;
/// `None` when none removes a quarter of the total `total_before`. `loc` is where the gap lies.
///
/// A gap in the temperature view is a relation with a recorded channel: the coupling to that channel is the first
/// explanation, and one without a driver (a sinusoid at the temperature's cycle) wins only when it is clearly
/// better. The coupling is kept when it explains the total and either scores within [`DRIVER_PREFERENCE`] of the
/// best or leaves no significant gap in the temperature view. The second clause matters because the coupling is
/// judged there on what it leaves, which a 4% error in the coefficient over ten cycles already shows, while a
/// sinusoid is judged on the raw coherence.
///
/// A Gauss-Markov process that follows the Allan curve no better than a filter corner that explains the total
/// ([`draws_the_corners_curve`]) is not chosen: the two draw one spectrum, a sensor's bandwidth is the reading
/// with the fewer parameters, and what the views find between them is the ensemble's draw and the effects neither
/// models (beside a warm-up the record's excess at long taus ranked a process of two samples above the corner by
/// 24%). One that took the white noise's place ([`white_through_a_filter`]) gives way to a corner that explains the
/// total and scores within [`FILTER_PREFERENCE`] of it.
pub fn choose(candidates: &[CandidateResult], total_before: f64, loc: Option<&Location>) -> Option<usize> {
    let in_temperature_view = loc.is_some_and(|l| l.view == ViewKind::Temperature);
    let explains = |c: &CandidateResult| {
        c.score.is_some_and(|s| explains(s, total_before)) && (in_temperature_view || !weak_coupling(c))
    };
    // A process that follows the curve no better than a corner that explains the total is that corner's spectrum.
    let a_corners_spectrum =
        |m: &CandidateResult| candidates.iter().any(|c| draws_the_corners_curve(m, c) && explains(c));
    let best = candidates
        .iter()
        .enumerate()
        .filter(|(_, c)| explains(c) && !a_corners_spectrum(c))
        .min_by(|a, b| a.1.score.unwrap_or(f64::INFINITY).total_cmp(&b.1.score.unwrap_or(f64::INFINITY)))
        .map(|(i, _)| i)?;
    let b = &candidates[best];
    if loc.is_some_and(|l| l.view == ViewKind::Temperature) && b.effect != Effect::Temperature {
        let coupling = candidates.iter().position(|c| {
            let clears = c.gap_after.is_some_and(|g| g < SIGNIFICANT_GAP);
            c.effect == Effect::Temperature
                && explains(c)
                && c.score.is_some_and(|s| s <= DRIVER_PREFERENCE * b.score.unwrap_or(0.0) || clears)
        });
        if coupling.is_some() {
            return coupling;
        }
    }
    if white_through_a_filter(b) {
        let corner = candidates.iter().position(|c| {
            c.effect == Effect::Bandwidth
                && explains(c)
                && c.score.is_some_and(|s| s <= FILTER_PREFERENCE * b.score.unwrap_or(0.0))
        });
        if corner.is_some() {
            return corner;
        }
    }
    Some(best)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compare::{worst_window, PointZ};
    use crate::views::PointInfo;
    use octavar_shared::sim::GyroSim;

    fn view(kind: ViewKind, zs: &[f64]) -> ViewGap {
        let points: Vec<PointZ> = zs
            .iter()
            .enumerate()
            .map(|(i, &z)| {
                let tau = 2f64.powi(i as i32);
                PointZ {
                    info: PointInfo {
                        label: "tau",
                        tau_s: tau,
                        tau_lo_s: tau / 1.5,
                        tau_hi_s: tau * 1.5,
                        floor_sd: 0.0,
                    },
                    real: 0.1 * z,
                    sim_mean: 0.0,
                    sd: 0.1,
                    z,
                }
            })
            .collect();
        let rms = (zs.iter().map(|z| z * z).sum::<f64>() / zs.len() as f64).sqrt();
        let (a, b, gap) = worst_window(&points);
        ViewGap { view: kind, points, rms, gap, window: (a, b) }
    }

    fn rms(z: &[f64]) -> f64 {
        (z.iter().map(|z| z * z).sum::<f64>() / z.len() as f64).sqrt()
    }

    #[test]
    fn the_band_is_the_worst_decade() {
        // Octave points: a decade window holds 4 of them (1, 2, 4, 8).
        let z = [0.1, 4.0, 0.2, 3.5, 6.0, 5.0, 1.0];
        let v = vec![view(ViewKind::Psd, &[0.5, 1.0, -0.3]), view(ViewKind::Adev, &z)];
        let best = (0..4).map(|i| rms(&z[i..i + 4])).fold(0.0, f64::max);
        assert!((best - rms(&z[3..7])).abs() < 1e-12);
        assert!((gap_of(&v) - best).abs() < 1e-12);
        let loc = locate(&v).unwrap();
        assert_eq!((loc.view, loc.points), (ViewKind::Adev, 4));
        assert!((loc.band_s[0] - 8.0 / 1.5).abs() < 1e-9 && (loc.band_s[1] - 64.0 * 1.5).abs() < 1e-9, "{loc:?}");
        assert_eq!(loc.tau_range_s, [8.0, 64.0]);
        assert_eq!(loc.sign, Sign::Above);
        assert!(loc.ratio.unwrap() > 1.0);
        // The same taus in another comparison: their RMS z, whatever the rest of the view does.
        let other = vec![view(ViewKind::Adev, &[9.0, 9.0, 9.0, 1.0, -1.0, 1.0, -1.0])];
        assert!((band_gap(&other, &loc).unwrap() - 1.0).abs() < 1e-12);
        assert!(band_gap(&[view(ViewKind::Psd, &[1.0])], &loc).is_none());
        // A view shorter than a decade is one window; the sign follows the summed z.
        let loc = locate(&[view(ViewKind::Adev, &[0.1, -2.0, 1.0])]).unwrap();
        assert_eq!((loc.points, loc.sign), (3, Sign::Below));
    }

    /// A candidate of `effect` with `gyro` as its model, scoring `score` with no parameters.
    fn candidate(effect: Effect, gyro: GyroSim, score: f64) -> CandidateResult {
        candidate_falling(effect, gyro, score, 0.0)
    }

    /// [`candidate`] whose fit took the Allan curve's chi-square down by `fall`.
    fn candidate_falling(effect: Effect, gyro: GyroSim, score: f64, fall: f64) -> CandidateResult {
        use crate::effects::params::{BandwidthParams, GaussMarkovParams};
        let params = match effect {
            Effect::GaussMarkov => GaussMarkovParams { sigma_dps: 0.0, tau_s: 0.0, delta_chi2: fall }.into(),
            _ => BandwidthParams { bandwidth_hz: 0.0, n_deg_per_rt_s: 0.0, delta_chi2: fall }.into(),
        };
        let fit = EffectFit { effect, params, n_params: 0, gyro, channel: None, spread: None, cleaned: None };
        CandidateResult {
            effect,
            fit: Some(fit),
            eval: None,
            gap_after: Some(score),
            worst_after: Some(score),
            total_after: Some(score),
            score: Some(score),
            holdout_after: None,
            holdout_worst_after: None,
        }
    }

    #[test]
    fn a_markov_process_that_took_the_white_noise_s_place_gives_way_to_a_filter_corner() {
        use octavar_shared::sim::GaussMarkovSim;
        // White noise of density 3.3e-3 deg/sqrt(s) through a 10.6 Hz corner: a process of T = 15 ms whose
        // sigma sqrt(2T) is that density, with no white noise left beside it.
        let markov = |n: f64| GyroSim {
            n_deg_per_rt_s: n,
            gauss_markov: Some(GaussMarkovSim { sigma_dps: 0.019, tau_s: 0.015 }),
            ..Default::default()
        };
        let corner = GyroSim { n_deg_per_rt_s: 3.3e-3, bandwidth_hz: Some(10.6), ..Default::default() };
        let pick = |n: f64, corner_score: f64| {
            // The process's fit follows the curve better than the corner's by far more than one freedom's worth.
            let c = [
                candidate_falling(Effect::GaussMarkov, markov(n), 1.11, 100.0),
                candidate_falling(Effect::Bandwidth, corner.clone(), corner_score, 0.0),
            ];
            c[choose(&c, 40.0, None).unwrap()].effect
        };
        assert_eq!(pick(0.0, 1.19), Effect::Bandwidth);
        // Clearly worse, the corner does not replace it.
        assert_eq!(pick(0.0, 1.30), Effect::GaussMarkov);
        // A process beside white noise of its own is not a filter's doing.
        assert_eq!(pick(1e-3, 1.19), Effect::GaussMarkov);
    }

    #[test]
    fn a_markov_process_that_follows_the_curve_no_better_than_a_corner_gives_way_to_it() {
        use octavar_shared::sim::GaussMarkovSim;
        // A process of T = 16 ms beside white noise at 6% of its own density (above WHITE_LEFT): a fit of white
        // noise through a 10.4 Hz corner at 148 Hz, whose curve the corner follows as well.
        let markov = GyroSim {
            n_deg_per_rt_s: 2.1e-4,
            gauss_markov: Some(GaussMarkovSim { sigma_dps: 0.0189, tau_s: 0.0159 }),
            ..Default::default()
        };
        assert!(!white_through_a_filter(&candidate(Effect::GaussMarkov, markov.clone(), 1.07)));
        let corner = GyroSim { n_deg_per_rt_s: 3.4e-3, bandwidth_hz: Some(10.4), ..Default::default() };
        let pick = |markov_fall: f64, corner_score: f64| {
            let c = [
                candidate_falling(Effect::GaussMarkov, markov.clone(), 1.07, markov_fall),
                candidate_falling(Effect::Bandwidth, corner.clone(), corner_score, 5012.6),
            ];
            c[choose(&c, 40.0, None).unwrap()].effect
        };
        // The falls of that record's two fits: one spectrum.
        assert_eq!(pick(5012.8, 1.16), Effect::Bandwidth);
        // The process's freedom bought more than one parameter's chi-square: a process of its own.
        assert_eq!(pick(5012.6 + 2.0 * ONE_FREEDOM_CHI2, 1.16), Effect::GaussMarkov);
        // Worse in the views, the corner is still the reading of that spectrum...
        assert_eq!(pick(5012.8, 1.30), Effect::Bandwidth);
        // ...unless it does not explain the gap.
        assert_eq!(pick(5012.8, 35.0), Effect::GaussMarkov);
    }

    #[test]
    fn penalty_and_shrink() {
        assert!(score(2.0, 3) > score(2.0, 0));
        assert!(score(1.5, 3) < score(2.0, 0));
        assert!((shrink(8.0, 2.0) - 0.75).abs() < 1e-12);
        assert_eq!(shrink(0.0, 1.0), 0.0);
        assert!((shrink_if_right(2.0) - 0.5).abs() < 1e-12);
        assert_eq!(shrink_if_right(0.8), 0.0);
    }
}

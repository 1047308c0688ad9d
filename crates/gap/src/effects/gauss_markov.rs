//! The Gauss-Markov candidate: an exponentially correlated rate noise, fitted jointly with the base terms on
//! the Allan curve.

use super::params::GaussMarkovParams;
use octavar_shared::sim::{GaussMarkovSim, GyroSim};
use octavar_stats::fit::FitPoint;

use super::common::*;
use super::curve::*;
use super::filter_input::refer_to_bandwidth;
use super::{Effect, EffectFit, EffectKind, TrainingData};

/// The Gauss-Markov effect: [`gauss_markov`] and its parameters.
pub(super) struct Kind;

impl EffectKind for Kind {
    const EFFECT: Effect = Effect::GaussMarkov;
    type Params = GaussMarkovParams;

    fn estimate(data: &TrainingData) -> Option<EffectFit> {
        gauss_markov(data)
    }

    fn reestimated(p: &GaussMarkovParams, gyro: &GyroSim) -> GaussMarkovParams {
        match gyro.gauss_markov {
            Some(m) => GaussMarkovParams { sigma_dps: m.sigma_dps, tau_s: m.tau_s, ..p.clone() },
            None => p.clone(),
        }
    }
}

/// A Gauss-Markov (first-order exponentially correlated) rate noise.
///
/// Method: the OADEV at octave tau is fitted jointly with the base terms N, B, K, R, Q and a Gauss-Markov term of
/// unit variance (its exact Allan form: the discrete AR(1) expression, through the model's output bandwidth where
/// it has one, or IEEE 952 Annex C's continuous one for T beyond a thousand samples), weighted NNLS as for the
/// bandwidth, T on a log grid from 2 tau0 to a third of the record refined by golden search. It counts when the
/// log-domain chi-square falls by at least [`CURVE_DELTA_CHI2`] from the base-terms-only fit and the process
/// carries at least a fifth of the model's Allan variance somewhere on the curve, and T is not the search's floor
/// of 2 tau0 ([`at_bottom`]); N, B, K, R and Q are re-fitted with it. On a model that already carries a resonance
/// or a bistable bias, their Allan variance is taken off the curve first.
///
/// Beside an output bandwidth an earlier step read, the corner is also searched again with the process
/// ([`beside_free_corner`]), and the fit of smaller chi-square kept: white noise through a low corner is a
/// Gauss-Markov process, so where the base fit read no white noise of its own, a corner step takes the process for
/// the filter, far below the sensor's corner, and under that corner either no process fits or one as fast as the
/// search allows stands in for the white noise the corner took.
pub(super) fn gauss_markov(d: &TrainingData) -> Option<EffectFit> {
    let rate_hz = d.rate_hz;
    let bw = d.base.bandwidth_hz;
    let raw = gapped_oadev_points(d.rate_dps, d.gaps, rate_hz);
    let held = at_corner(d, &points_under(d, &raw, bw), bw).filter(Found::accepted);
    let free = bw.and_then(|_| beside_free_corner(d, &raw));
    let found = [held, free].into_iter().flatten().min_by(|a, b| a.j.chi2.total_cmp(&b.j.chi2))?;
    let Found { corner, t, j, delta_chi2, .. } = found;
    let s2 = j.theta[BASE_COLS];
    let mut gyro = with_base_terms(&GyroSim { bandwidth_hz: corner, ..d.base.clone() }, &j.theta);
    // The sinusoids and the resonance were read from the output: the model sends them through the corner.
    refer_to_bandwidth(&mut gyro, bw, rate_hz);
    gyro.gauss_markov = Some(GaussMarkovSim { sigma_dps: s2.sqrt(), tau_s: t });
    Some(EffectFit {
        effect: Effect::GaussMarkov,
        params: GaussMarkovParams { sigma_dps: s2.sqrt(), tau_s: t, delta_chi2 }.into(),
        n_params: 2,
        gyro,
        channel: None,
        spread: None,
        cleaned: None,
    })
}

/// A process fitted on the curve under one corner.
struct Found {
    /// The output bandwidth it was fitted under.
    corner: Option<f64>,
    /// Its time constant, s.
    t: f64,
    /// The joint fit: the base terms' squares, then the process's variance.
    j: Joint,
    /// The chi-square's fall from the base terms alone.
    delta_chi2: f64,
    /// The most of the model's Allan variance the process carries at any point.
    share: f64,
    /// Whether the time constant sits at the search's floor of two samples ([`at_bottom`]).
    at_floor: bool,
}

impl Found {
    /// Whether the process counts: the chi-square falls by [`CURVE_DELTA_CHI2`], the process carries a fifth
    /// of the Allan variance somewhere, and its time constant is not the search's floor.
    fn accepted(&self) -> bool {
        self.delta_chi2 > CURVE_DELTA_CHI2 && self.share >= 0.2 && !self.at_floor
    }
}

/// The curve `raw` less what the model already carries (a resonance, a bistable bias), under `corner`.
fn points_under(d: &TrainingData, raw: &[FitPoint], corner: Option<f64>) -> Vec<FitPoint> {
    let model = GyroSim { bandwidth_hz: corner, ..d.base.clone() };
    less_known(raw, &model, corner, d.rate_hz, d.lattice_dps)
}

/// The base terms alone on `pts` under `corner`: their chi-square.
fn plain_chi2(d: &TrainingData, pts: &[FitPoint], corner: Option<f64>) -> Option<f64> {
    joint_fit(pts, &base_columns(pts, d.rate_hz, corner, d.base.q_deg > 0.0)).map(|j| j.chi2)
}

/// The process of best time constant beside the base terms on `pts` under `corner`, its chi-square's fall
/// measured from the base terms alone under that corner; `None` with fewer than 6 points or no fit.
fn at_corner(d: &TrainingData, pts: &[FitPoint], corner: Option<f64>) -> Option<Found> {
    if pts.len() < 6 {
        return None;
    }
    let plain = plain_chi2(d, pts, corner)?;
    let tau0 = 1.0 / d.rate_hz;
    let base_cols = base_columns(pts, d.rate_hz, corner, d.base.q_deg > 0.0);
    let cols_for = |t: f64| {
        let mut c = base_cols.clone();
        c.push(pts.iter().map(|q| filtered_gm_avar(t, corner, q.tau_s, d.rate_hz)).collect());
        c
    };
    let record = d.rate_dps.len() as f64 * tau0;
    let (t_lo, t_hi) = (2.0 * tau0, (record / 3.0).max(4.0 * tau0));
    let (t, _) = log_search(t_lo, t_hi, T_GRID, |t| joint_fit(pts, &cols_for(t)).map_or(f64::INFINITY, |j| j.chi2));
    let cols = cols_for(t);
    let j = joint_fit(pts, &cols)?;
    let s2 = j.theta[BASE_COLS];
    if !(s2 > 0.0) {
        return None;
    }
    let share = (0..pts.len())
        .map(|i| {
            let tot: f64 = (0..cols.len()).map(|c| j.theta[c] * cols[c][i]).sum();
            s2 * cols[BASE_COLS][i] / tot
        })
        .fold(0.0, f64::max);
    let at_floor = at_bottom(t, t_lo, t_hi, T_GRID);
    Some(Found { corner, t, delta_chi2: plain - j.chi2, share, j, at_floor })
}

/// Time constants of the search's log grid, from two samples to a third of the record.
const T_GRID: usize = 40;

/// Corners of the free search's log grid, from a thousandth of the Nyquist frequency to it.
const CORNER_GRID: usize = 16;

/// The process with the output bandwidth searched beside it (log grid from rate_hz/2000 to rate_hz/2, golden
/// refinement), the chi-square's fall measured from the base terms alone under their own best corner, so that
/// the corner's freedom buys the process nothing. `None` where the process does not count, or the best corner is
/// the search's top (no filter in the band: the corner step's own reading stands).
fn beside_free_corner(d: &TrainingData, raw: &[FitPoint]) -> Option<Found> {
    let (lo, hi) = (d.rate_hz / 2000.0, d.rate_hz / 2.0);
    // Under an ADC lattice, each corner's curve has the rounding taken off over the base terms read under it.
    let pts_at = |f: f64| {
        let model = GyroSim { bandwidth_hz: Some(f), ..d.base.clone() };
        analog_curve(raw, &model, model.gauss_markov, Some(f), d.rate_hz, d.lattice_dps, d.base.q_deg > 0.0)
    };
    let chi_at = |f: f64| at_corner(d, &pts_at(f), Some(f)).map_or(f64::INFINITY, |g| g.j.chi2);
    let (corner, _) = log_search(lo, hi, CORNER_GRID, chi_at);
    if at_top(corner, lo, hi, CORNER_GRID) {
        return None;
    }
    let (_, plain) = log_search(lo, hi, CORNER_GRID, |f| plain_chi2(d, &pts_at(f), Some(f)).unwrap_or(f64::INFINITY));
    let mut g = at_corner(d, &pts_at(corner), Some(corner))?;
    g.delta_chi2 = plain - g.j.chi2;
    g.accepted().then_some(g)
}

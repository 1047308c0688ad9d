//! The Gauss-Markov candidate: an exponentially correlated rate noise, fitted jointly with the base terms on
//! the Allan curve.

use super::params::GaussMarkovParams;
use octavar_shared::sim::{GaussMarkovSim, GyroSim};

use super::common::*;
use super::curve::*;
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
/// bandwidth, T on a log grid from 2 tau0 to a third of the record refined by golden search. It counts when the log-domain chi-square falls by at least
/// [`CURVE_DELTA_CHI2`] from the base-terms-only fit and the process carries at least a fifth of the model's
/// Allan variance somewhere on the curve; N, B, K, R and Q are re-fitted with it. On a model that already carries
/// a resonance or a bistable bias, their Allan variance is taken off the curve first.
pub(super) fn gauss_markov(d: &TrainingData) -> Option<EffectFit> {
    let rate_hz = d.rate_hz;
    let tau0 = 1.0 / rate_hz;
    let bw = d.base.bandwidth_hz;
    // A resonance or a bistable bias the model already has is not this process (a later step of the chain).
    let pts = less_known(&gapped_oadev_points(d.rate_dps, d.gaps, rate_hz), d.base, bw, rate_hz, d.lattice_dps);
    if pts.len() < 6 {
        return None;
    }
    let base_cols = base_columns(&pts, rate_hz, bw, d.base.q_deg > 0.0);
    let plain = joint_fit(&pts, &base_cols)?;
    let cols_for = |t: f64| {
        let mut c = base_cols.clone();
        c.push(pts.iter().map(|q| filtered_gm_avar(t, bw, q.tau_s, rate_hz)).collect());
        c
    };
    let record = d.rate_dps.len() as f64 * tau0;
    let t_hi = (record / 3.0).max(4.0 * tau0);
    let (t, chi) =
        log_search(2.0 * tau0, t_hi, 40, |t| joint_fit(&pts, &cols_for(t)).map_or(f64::INFINITY, |j| j.chi2));
    if !(chi + CURVE_DELTA_CHI2 < plain.chi2) {
        return None;
    }
    let cols = cols_for(t);
    let j = joint_fit(&pts, &cols)?;
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
    if share < 0.2 {
        return None;
    }
    let mut gyro = with_base_terms(d.base, &j.theta);
    gyro.gauss_markov = Some(GaussMarkovSim { sigma_dps: s2.sqrt(), tau_s: t });
    Some(EffectFit {
        effect: Effect::GaussMarkov,
        params: GaussMarkovParams { sigma_dps: s2.sqrt(), tau_s: t, delta_chi2: plain.chi2 - chi }.into(),
        n_params: 2,
        gyro,
        channel: None,
        spread: None,
        cleaned: None,
    })
}

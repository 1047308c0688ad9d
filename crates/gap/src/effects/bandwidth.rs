//! The bandwidth candidate: a first-order low-pass on the output, fitted on the short-tau Allan curve.

use super::params::BandwidthParams;
use octavar_shared::sim::GyroSim;

use super::common::*;
use super::curve::*;
use super::filter_input::refer_to_bandwidth;
use super::{Effect, EffectFit, EffectKind, TrainingData};

/// The bandwidth effect: [`bandwidth`] and its parameters.
pub(super) struct Kind;

impl EffectKind for Kind {
    const EFFECT: Effect = Effect::Bandwidth;
    type Params = BandwidthParams;

    fn estimate(data: &TrainingData) -> Option<EffectFit> {
        bandwidth(data)
    }

    fn test_statistic(p: &BandwidthParams) -> Option<f64> {
        Some(p.delta_chi2)
    }

    fn reestimated(p: &BandwidthParams, gyro: &GyroSim) -> BandwidthParams {
        BandwidthParams {
            bandwidth_hz: gyro.bandwidth_hz.unwrap_or(p.bandwidth_hz),
            n_deg_per_rt_s: gyro.n_deg_per_rt_s,
            ..p.clone()
        }
    }
}

/// Points of the corner's log grid, from a thousandth of the Nyquist frequency to it.
const CORNER_GRID: usize = 40;

/// A first-order output bandwidth.
///
/// Method: the OADEV at octave tau (Greenhall EDFs) is fitted jointly with N (white noise through the sampled
/// first-order low-pass, the exact AR(1) Allan form, which tends to `fit::lowpass_white_factor` when the corner
/// is far below the sample rate), B, K and R, by weighted non-negative least squares (IRLS, every subset of
/// terms), the corner f3dB on a log grid from rate_hz/2000 to rate_hz/2 refined by golden search. It counts when the
/// log-domain chi-square falls by at least [`CURVE_DELTA_CHI2`] from the unfiltered fit. N, B, K, R and Q are
/// re-fitted with the bandwidth in place (the base fit reads N low from the bent short taus). On a model that
/// already carries a resonance (a later step of the chain), its closed-form Allan variance through the corner
/// tried is taken off the curve first; a Gauss-Markov process the model carries is a column of the fit beside the
/// corner, its time constant held; where an earlier step took bias jumps out (bias
/// steps, a bistable bias), each corner is tried on the record less those jumps through it.
pub(super) fn bandwidth(d: &TrainingData) -> Option<EffectFit> {
    let rate_hz = d.rate_hz;
    // The Allan variance of a resonance or a Gauss-Markov process the model already has is not the filter's; the
    // simulator passes them through the filter too, so what is taken off depends on the corner tried.
    let raw = gapped_oadev_points(d.rate_dps, d.gaps, rate_hz);
    if raw.len() < 5 {
        return None;
    }
    let with_q = d.base.q_deg > 0.0;
    // Bias jumps an earlier step took out sharp reached the output through the sensor's filter: under a corner
    // tried, the samples are the record less them through that corner (their sharp edges taken out of a smooth
    // record leave high-pass residue that fills the roll-off in).
    let raw_at = |f: Option<f64>| match (d.shaped_dps, f) {
        (Some(s), Some(f)) => gapped_oadev_points(&jumps_through_filter(d.rate_dps, s, f, rate_hz), d.gaps, rate_hz),
        _ => raw.clone(),
    };
    // A Gauss-Markov process the model carries is fitted beside the corner (its time constant held, its variance
    // free), not taken off at the variance its own step read: taken off, what is left where the process dominates
    // is a small difference of large numbers, held at a tenth of the point where it goes below, and the curve's
    // log-domain chi-square measures the process's misfit there; any corner that bends it away lowered it by
    // 2,900-3,800 on records with no corner at all.
    let markov = d.base.gauss_markov;
    // A resonance read from the output before the corner is what passed it: under each corner tried, its input
    // is larger by what that corner takes ([`refer_to_bandwidth`]), so what is taken off is what was read.
    let known_at = |f: Option<f64>| {
        let mut known = GyroSim { gauss_markov: None, bandwidth_hz: f, ..d.base.clone() };
        refer_to_bandwidth(&mut known, d.base.bandwidth_hz, rate_hz);
        known
    };
    // The process's time constant as its own step read it, without the corner, is too long where the corner took
    // part of its roll-off (1.4 s read for 1.2 s beside a corner at 0.18 of the rate): it is searched beside each
    // corner, on these factors of it. The fit returns the factor it kept (1 without a process).
    const SCALES: [f64; 8] = [0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.1];
    // Under an ADC lattice the rounding's share of the curve depends on how smooth the analog rate is under the
    // corner tried: N, B and K are read on the curve once, and the lattice taken off over them.
    let points_at = |f: Option<f64>| analog_curve(&raw_at(f), &known_at(f), markov, f, rate_hz, d.lattice_dps, with_q);
    let score = |f: Option<f64>| {
        let pts = points_at(f);
        let base = base_columns(&pts, rate_hz, f, with_q);
        let Some(g) = markov else { return joint_fit_keeping(&pts, &base, 0).map(|j| (j, 1.0)) };
        let mut best: Option<(super::curve::Joint, f64)> = None;
        for sc in SCALES {
            let mut cols = base.clone();
            cols.push(pts.iter().map(|p| filtered_gm_avar(g.tau_s * sc, f, p.tau_s, rate_hz)).collect());
            if let Some(j) = joint_fit_keeping(&pts, &cols, 1 << BASE_COLS) {
                if best.as_ref().is_none_or(|b| j.chi2 < b.0.chi2) {
                    best = Some((j, sc));
                }
            }
        }
        best
    };
    let plain = score(None)?.0;
    let (lo, hi) = (rate_hz / 2000.0, rate_hz / 2.0);
    let (f, chi) = log_search(lo, hi, CORNER_GRID, |f| score(Some(f)).map_or(f64::INFINITY, |j| j.0.chi2));
    // A corner at the Nyquist frequency is the search's bound: whatever bends the curve at the shortest tau (a
    // resonance's misfit there) takes it, and a first-order filter above the band is not seen at all.
    if !(chi + CURVE_DELTA_CHI2 < plain.chi2) || at_top(f, lo, hi, CORNER_GRID) {
        return None;
    }
    let (j, sc) = score(Some(f))?;
    if !(j.theta[0] > 0.0) {
        return None;
    }
    let mut gyro = with_base_terms(d.base, &j.theta);
    gyro.bandwidth_hz = Some(f);
    // The sinusoids and the resonance were read from the output: the model sends them through the corner.
    refer_to_bandwidth(&mut gyro, d.base.bandwidth_hz, rate_hz);
    if let (Some(g), Some(&v)) = (gyro.gauss_markov.as_mut(), j.theta.get(BASE_COLS)) {
        g.sigma_dps = v.max(0.0).sqrt();
        g.tau_s *= sc;
    }
    Some(EffectFit {
        effect: Effect::Bandwidth,
        params: BandwidthParams { bandwidth_hz: f, n_deg_per_rt_s: gyro.n_deg_per_rt_s, delta_chi2: plain.chi2 - chi }
            .into(),
        n_params: 1,
        gyro,
        channel: None,
        spread: None,
        cleaned: None,
    })
}

//! The outliers candidate: spikes on a share of the samples, from rare isolated ones to epsilon-contaminated noise
//! (up to a fifth of the samples), one by one or in short runs.
//!
//! # Method
//! - **Residual.** Each sample less the median of its eight neighbours (four each side, the sample itself left
//!   out): drifts, steps and sinusoids slower than a few samples leave next to nothing, and a spike is not shrunk
//!   by its own value. Eight neighbours keep the median close where spikes come in runs of up to three or are
//!   dense (at a 20% contamination, four of eight neighbours are spikes in under 6% of windows). Two passes: the
//!   second (where the magnitudes' centre stands [`SECOND_PASS_SIGMAS`] out) leaves the spikes the first flagged
//!   out of the windows, so a spike's partner in its run does not pull the median (in runs of two at 6-13 sds it
//!   read the magnitudes 2% low, which the base N, fitted on what the spikes leave of the Allan variance, took up
//!   as 8%). Samples whose window touches a gap are left out.
//! - **Lattice.** Where the samples sit on an ADC lattice, the residuals are read on the samples plus a Gaussian
//!   dither of half a step: a step coarser than the noise leaves most residuals at exactly 0, where the core has
//!   no scale and every sample one step off reads as a spike. The spikes' magnitudes are held beyond the lattice's
//!   own reach where spikes stand there ([`lattice_reach`]: a step and a half where the noise is a quarter of a
//!   step, two and a half where it is half a step), and beyond three steps otherwise. Every sample whose
//!   undithered residual stands beyond the reach is cleaned, onto its neighbours' median on the lattice. A law
//!   read from the reach is corrected against synthetic records rounded to the lattice over the white noise under
//!   it ([`calibrate`]); one held beyond three steps is left as read, against that bound. Where the noise is near
//!   a step or more, the lattice has no reach: the law is held beyond three steps, and the flagged samples are
//!   cleaned back onto the lattice. Where the model's channel already rounds to the lattice, its base terms (the
//!   quantisation estimator's, N the analog noise under the lattice) stay as they are. Spikes too few for the
//!   dithered core's mixture (a dozen of two steps in a quarter of a million samples) are counted beyond the
//!   reach against what a clean lattice leaves there ([`beyond_reach`]).
//! - **After other steps.** The estimator reads whatever the chain's earlier steps left: a smooth part taken out
//!   leaves each sample's step against its neighbours as it was, and beside jumps taken out the samples around
//!   each are left aside (below), so spikes may be named on the estimator's own test after any step.
//! - **Mixture.** The residuals' magnitudes are fitted by maximum likelihood as a Gaussian core plus spikes whose
//!   magnitude is uniform on `centre +- spread` ([`mixture`]): the core's scale is read where the core dominates,
//!   not inflated by the contamination as a MAD would be, and spikes too small to stand above any threshold are
//!   counted in the share by their shape. The share, the centre and the spread are the model's `per_sample`,
//!   `size_dps` and `spread_dps`: a spike adds its magnitude to the residual, so the law is read in deg/s.
//! - **Evidence.** A process is kept when twice the log-likelihood gained over the Gaussian alone exceeds
//!   [`MIN_LR`], the centre stands at least [`MIN_CENTRE_SIGMAS`] core sds out (a light or slightly heavy core is
//!   not a spike process), at least [`MIN_SPIKES`] residuals stand beyond [`TAIL_SIGMAS`] core sds, more than the
//!   core's Gaussian tail gives at [`TAIL_ALPHA`] (their count is Poisson under the core alone), and the flagged
//!   spikes are not most of them within [`CLUSTER_SPAN`] of the record (what a burst leaves is an event, not a
//!   steady process).
//! - **Runs.** A residual is flagged where the spike component is the likelier (and beyond [`FLAG_SIGMAS`]).
//!   Flagged pairs k samples apart with one sign come from a run or by chance; chance gives as many of opposite
//!   signs. The same-sign excess over `n eps D^2` (D the chance that a spike is flagged, from the fitted law) is
//!   `rho_k`, the probability that the sample k after a spike is of its run: the mean run length is
//!   `1 / (1 - rho_1)`, and the probability that a run of two goes on is `rho_k / rho_(k-1)`, pooled over lags
//!   up to [`RUN_LAGS`] (the two parameters of [`Outliers`]' run law, which holds runs of one or two as well as
//!   geometric ones).
//! - **Calibration.** Where the spikes stand near the core, the law and the runs read so are biased (a run's
//!   partner pulls a spike's residual in; run members are flagged less often than lone spikes); the law is
//!   corrected by indirect inference against synthetic records of itself ([`calibrate`]).
//! - **Base terms.** The spikes' own Allan variance (autocovariance `eps E s^2` at lag 0, `eps centre^2 rho_k` at
//!   lag k: runs share a sign) is taken off the OADEV and the base terms are re-fitted on what is left, each
//!   point's degrees of freedom scaled by the share left squared (its sampling error is the whole variance's). The
//!   flagged spikes, replaced by their neighbours' median, are the realisation the chain's later steps learn
//!   without, and those steps' re-fits keep the white noise read here ([`super::common::refit_base`]).
//! - **Beside jumps taken out.** Where an earlier step took jumps out (a bistable bias's flips, bias steps), a
//!   jump placed a sample off leaves a pulse of its whole size: the samples within [`JUMP_GUARD`] of each jump are
//!   not read, and the curve the base terms are re-fitted on is the model's own (fitted beside the jumps on the
//!   record as recorded), not that of the samples less the jumps, which keeps what the recovery missed.

use octavar_shared::sim::rng::SimRng;
use octavar_shared::sim::{GyroSim, Outliers};
use std::sync::Arc;

use super::common::*;
use super::curve::{ar1_avar, base_curve, refit_base_terms};
use super::params::OutliersParams;
use super::quantization::lattice;
use super::{Effect, EffectFit, EffectKind, ParamSpread, TrainingData};
use octavar_stats::robust::mad_scale_in_place;
use octavar_stats::tails::poisson_sf;

mod calibrate;
mod lattice_reach;
mod mixture;
#[cfg(test)]
mod tests;

/// Neighbours each side of the median a residual is taken from.
const HALF_WINDOW: usize = 4;

/// Twice the log-likelihood a mixture must gain over the Gaussian core alone.
pub(crate) const MIN_LR: f64 = 50.0;

/// The magnitude law's centre must stand this many core sds out: a core a little lighter or heavier than a
/// Gaussian fits as a "contamination" buried in it.
const MIN_CENTRE_SIGMAS: f64 = 2.5;

/// The tail where spikes must outnumber what the core explains, core sds.
const TAIL_SIGMAS: f64 = 5.0;

/// Fewest spikes that make a rate: two or three events are not a process.
const MIN_SPIKES: usize = 5;

/// The residuals beyond [`TAIL_SIGMAS`] must be more than the Gaussian core gives (a Poisson count) at this
/// significance: at the 0.1-0.6 residuals a core of 0.2-1 million samples leaves there, that is 5 or 6 of them.
const TAIL_ALPHA: f64 = 1e-4;

/// The residuals are taken again without the flagged spikes in the windows when the magnitudes' centre stands
/// this many core sds out.
const SECOND_PASS_SIGMAS: f64 = 5.0;

/// A residual is flagged as a spike only beyond this many core sds (and where the spike is the likelier).
const FLAG_SIGMAS: f64 = 3.5;

/// Spikes of a steady process are spread over the record: when more than half of them fall within this fraction
/// of it, they are a cluster (what a burst leaves), not a rate. For five spikes at uniform times, three or more
/// within a fiftieth of the record happen about once in a hundred records.
const CLUSTER_SPAN: f64 = 0.02;

/// The median of a few values (the mean of the middle two of an even count).
fn median_small(v: &mut [f64]) -> f64 {
    v.sort_unstable_by(f64::total_cmp);
    let k = v.len() / 2;
    if v.len().is_multiple_of(2) {
        0.5 * (v[k - 1] + v[k])
    } else {
        v[k]
    }
}

/// Each sample less the median of its [`HALF_WINDOW`] neighbours each side, leaving out the neighbours marked in
/// `skip` (spikes flagged by a first pass) while at least half of them remain; NaN at the ends and where the
/// window touches a sample in `gap` (true: missing or masked).
///
/// Where the level steps between the two sides (the medians of the left and right neighbours differ by more than
/// [`STEP_SIGMAS`] residual sds: a bias jump, a bistable bias's flip), the sample belongs to one side's level, and
/// its residual is the smaller of the two one-sided ones: against both sides at once, every sample at a jump
/// would stand half a step out and read as a spike.
fn residuals(x: &[f64], gap: &[bool], skip: Option<&[bool]>) -> Vec<f64> {
    let n = x.len();
    let h = HALF_WINDOW;
    let mut r = vec![f64::NAN; n];
    let mut sides = vec![(f64::NAN, f64::NAN); n];
    let mut prefix = vec![0usize; n + 1];
    for i in 0..n {
        prefix[i + 1] = prefix[i] + usize::from(gap[i]);
    }
    // The median of the neighbours at `at`, without the skipped ones where at least `least` remain.
    let median_of = |at: &mut dyn Iterator<Item = usize>, least: usize, w: &mut [f64]| -> f64 {
        let (mut k, mut all) = (0, 0);
        for j in at {
            if skip.is_none_or(|s| !s[j]) {
                w[k] = x[j];
                k += 1;
            }
            // The whole window, kept past the unskipped ones for the case too few remain.
            w[2 * HALF_WINDOW + all] = x[j];
            all += 1;
        }
        if k < least {
            w.copy_within(2 * HALF_WINDOW..2 * HALF_WINDOW + all, 0);
            k = all;
        }
        median_small(&mut w[..k])
    };
    let mut w = [0.0; 4 * HALF_WINDOW];
    for i in h..n.saturating_sub(h) {
        if prefix[i + h + 1] - prefix[i - h] > 0 {
            continue;
        }
        r[i] = x[i] - median_of(&mut (i - h..i).chain(i + 1..=i + h), h, &mut w);
        let left = median_of(&mut (i - h..i), h / 2, &mut w);
        let right = median_of(&mut (i + 1..i + h + 1), h / 2, &mut w);
        sides[i] = (x[i] - left, x[i] - right);
    }
    let mut valid: Vec<f64> = r.iter().copied().filter(|v| v.is_finite()).collect();
    if valid.is_empty() {
        return r;
    }
    let (_, scale) = mad_scale_in_place(&mut valid);
    if !(scale > 0.0) {
        return r;
    }
    for (ri, &(l, rt)) in r.iter_mut().zip(&sides) {
        if ri.is_finite() && (l - rt).abs() > STEP_SIGMAS * scale {
            *ri = if l.abs() < rt.abs() { l } else { rt };
        }
    }
    r
}

/// The longest lag at which same-sign pairs of flagged spikes are counted for the run law.
const RUN_LAGS: usize = 4;

/// Spikes whose fitted magnitude law starts this many core sds out stand clear of the core: every one of them is
/// flagged.
const CLEAR_SIGMAS: f64 = 10.0;

/// Fewest flagged spikes whose quartiles give the magnitude law ([`clear_law`]).
const QUARTILE_SPIKES: usize = 8;

/// The magnitude law of spikes that stand clear of the core, from the quartiles of the flagged magnitudes, or
/// `None` where they do not. A uniform law on `centre +- spread` has its quartiles at `centre +- spread / 2`.
/// - Where the fitted law's lower edge is [`CLEAR_SIGMAS`] core sds out, the flagged spikes are the whole sample
///   of it. The likelihood's uniform support must cover every flagged magnitude, so one stray spike at half the
///   others' size (a spike on a bias flip) stretches it to twice the width, and the simulated spikes lose a third
///   of their fourth moment; the quartiles do not move.
/// - Where only the quartiles' law is that far out, most flagged residuals are a cluster clear of the core and a
///   few stand between (a bistable bias's flips, the edges of a burst): the likelihood's law, stretched down to
///   cover them, reads the spikes a third small and far too spread. The law is the cluster's (the quartiles again
///   of the magnitudes beyond the first law's lower edge); the few between are left to the core and to the
///   effects that made them.
///
/// Either way the share is the flagged residuals within the law's support (less three core sds) over the `valid`
/// residuals: clear of the core every spike is flagged, and the count does not depend on the core's shape. The
/// likelihood's share does: on a core a sensor's bandwidth has coloured, its Gaussian meets the spikes' law in
/// the wrong place, and the share moves by 3-6% (a sample's kurtosis and tail share move with it, and the
/// distribution view sees that much).
///
/// Elsewhere (spikes buried in the core, or too few) the likelihood's law stands.
fn clear_law(m: mixture::Mixture, flagged: &[(usize, f64)], valid: usize) -> Option<mixture::Mixture> {
    if flagged.len() < QUARTILE_SPIKES {
        return None;
    }
    let mut mags: Vec<f64> = flagged.iter().map(|f| f.1.abs()).collect();
    mags.sort_by(f64::total_cmp);
    let quartile_law = |mags: &[f64]| {
        let (centre, spread) = quartile_centre_spread(mags);
        mixture::Mixture { centre, spread, ..m }
    };
    let quartiles = quartile_law(&mags);
    let clear = CLEAR_SIGMAS * m.sigma;
    if valid == 0 {
        return None;
    }
    // The share: the flagged residuals within the law's support, widened by the core's noise on each spike's
    // residual, over the `valid` residuals. Clear of the core, every spike is flagged.
    let within_share = |law: &mixture::Mixture| {
        mags.iter().filter(|&&v| v >= law.centre - law.spread - 3.0 * m.sigma).count() as f64 / valid as f64
    };
    if m.centre - m.spread >= clear {
        return Some(mixture::Mixture { eps: within_share(&quartiles), ..quartiles });
    }
    if quartiles.centre - quartiles.spread < clear {
        return None;
    }
    // The few between pull the first quartile down: the law again from the cluster alone.
    let cluster = &mags[mags.partition_point(|&v| v < quartiles.centre - quartiles.spread)..];
    if cluster.len() < QUARTILE_SPIKES {
        return None;
    }
    let law = quartile_law(cluster);
    Some(mixture::Mixture { eps: within_share(&law), ..law })
}

/// The centre and half-width of a uniform law with the quartiles of `mags` (sorted, not empty): a uniform law on
/// `centre +- spread` has its quartiles at `centre +- spread / 2`.
fn quartile_centre_spread(mags: &[f64]) -> (f64, f64) {
    let quantile = |p: f64| {
        let at = p * (mags.len() - 1) as f64;
        let (i, frac) = (at.floor() as usize, at.fract());
        mags[i] + frac * (mags[(i + 1).min(mags.len() - 1)] - mags[i])
    };
    let (q1, q3) = (quantile(0.25), quantile(0.75));
    (0.5 * (q1 + q3), q3 - q1)
}

/// How far apart, in residual sds, the medians of a sample's left and right neighbours must be for the level to
/// have stepped between them: their difference has an sd of about one residual sd on noise alone.
const STEP_SIGMAS: f64 = 6.0;

/// What the estimator reads off a record: the fitted mixture, the spikes it flags, the run law.
#[derive(Clone, Debug)]
pub(super) struct Contamination {
    /// The fitted core and magnitude law, in deg/s.
    pub mix: mixture::Mixture,
    /// Flagged samples and their residuals.
    pub flagged: Vec<(usize, f64)>,
    /// Probability that the sample after a spike is of its run (`rho_1`).
    pub rho1: f64,
    /// Probability that a run of two or more goes on (`rho_k / rho_(k-1)`, pooled over lags 2 to [`RUN_LAGS`]).
    pub cont_next: f64,
    /// Residuals beyond [`TAIL_SIGMAS`] core sds, and how many the core explains.
    pub tail: (usize, f64),
    /// Residuals read (outside gaps and the record's ends).
    pub valid: usize,
}

impl Contamination {
    /// Whether the evidence makes a spike process ([`MIN_LR`], [`MIN_CENTRE_SIGMAS`], [`MIN_SPIKES`] beyond
    /// [`TAIL_SIGMAS`], not a cluster).
    pub fn is_process(&self, n: usize) -> bool {
        let m = &self.mix;
        let (beyond, expected) = self.tail;
        let hits: Vec<usize> = self.flagged.iter().map(|f| f.0).collect();
        m.lr >= MIN_LR
            && m.centre >= MIN_CENTRE_SIGMAS * m.sigma
            && beyond >= MIN_SPIKES
            && poisson_sf(expected, beyond) <= TAIL_ALPHA
            && hits.len() >= MIN_SPIKES
            && !clustered(&hits, n)
    }
}

/// Read the contamination of `x` (deg/s; `gap` marks missing or masked samples), the spikes' magnitudes beyond
/// `least` deg/s; `None` without a residual scale.
pub(super) fn read(x: &[f64], gap: &[bool], least: f64) -> Option<Contamination> {
    let first = read_with(x, gap, None, least)?;
    // Spikes that stand clear of the core are flagged nearly all and nothing else; small dense ones are flagged
    // in part and with the core's own extremes, and leaving those out would bend the core: one pass.
    if first.mix.centre < SECOND_PASS_SIGMAS * first.mix.sigma {
        return Some(first);
    }
    let mut skip = vec![false; x.len()];
    for &(i, _) in &first.flagged {
        skip[i] = true;
    }
    read_with(x, gap, Some(&skip), least)
}

/// One pass of [`read`]: the residuals (their windows without the samples in `skip`), the mixture, the flags.
fn read_with(x: &[f64], gap: &[bool], skip: Option<&[bool]>, least: f64) -> Option<Contamination> {
    let r = residuals(x, gap, skip);
    let mut valid: Vec<f64> = r.iter().copied().filter(|v| v.is_finite()).collect();
    if valid.len() < 64 {
        return None;
    }
    let k = valid.len() / 2;
    let med = *valid.select_nth_unstable_by(k, f64::total_cmp).1;
    let abs: Vec<f64> = valid.iter().map(|v| (v - med).abs()).collect();
    let mix = mixture::fit(&abs, least)?;
    let n_valid = abs.len();
    // Flag where the spike is the likelier, from FLAG_SIGMAS out.
    let mut flag = FLAG_SIGMAS * mix.sigma;
    while flag < 100.0 * mix.sigma && mix.spike_odds(flag) < 1.0 {
        flag += 0.05 * mix.sigma;
    }
    let flagged: Vec<(usize, f64)> =
        r.iter().enumerate().filter(|(_, v)| (**v - med).abs() > flag).map(|(i, v)| (i, v - med)).collect();
    // Runs: flagged pairs k apart of one sign beyond those of opposite signs, against n eps D^2.
    let d = mix.spike_sf(flag);
    let pairs = n_valid as f64 * mix.eps * d * d;
    // Same-sign pairs beyond opposite-sign ones k apart, and their count.
    let excess = |k: usize| {
        let (mut same, mut opposite) = (0.0f64, 0.0f64);
        for (j, &(i, v)) in flagged.iter().enumerate() {
            for &(i2, v2) in flagged[j + 1..].iter().take_while(|f| f.0 <= i + k) {
                if i2 == i + k {
                    if v * v2 > 0.0 {
                        same += 1.0;
                    } else {
                        opposite += 1.0;
                    }
                }
            }
        }
        (same - opposite, same + opposite)
    };
    let (e1, all1) = excess(1);
    let rho1 = if e1 > 3.0 * all1.sqrt() && pairs > 0.0 { (e1 / pairs).clamp(0.0, 0.9) } else { 0.0 };
    // A run of two or more goes on with one probability c (`rho_k = rho_1 c^(k-1)`): c pooled over lags 2-4,
    // `(rho_2 + rho_3 + rho_4) / (rho_1 + rho_2 + rho_3)`, so that the long runs, which carry most of a run
    // law's fourth moment, are read from every lag that sees them, and a lag too sparse to pass a test of its own
    // still counts.
    let cont_next = if rho1 > 0.0 {
        let later: Vec<f64> = (2..=RUN_LAGS).map(|k| excess(k).0.max(0.0)).collect();
        let above: f64 = later.iter().sum();
        let below = e1 + later[..later.len() - 1].iter().sum::<f64>();
        (above / below).clamp(0.0, 0.9)
    } else {
        0.0
    };
    let beyond = abs.iter().filter(|&&v| v > TAIL_SIGMAS * mix.sigma).count();
    let expected = n_valid as f64 * (1.0 - mix.eps) * 2.0 * normal_sf(TAIL_SIGMAS);
    Some(Contamination { mix, flagged, rho1, cont_next, tail: (beyond, expected), valid: n_valid })
}

/// The outliers effect: [`outliers`] and its parameters.
pub(super) struct Kind;

impl EffectKind for Kind {
    const EFFECT: Effect = Effect::Outliers;
    type Params = OutliersParams;

    fn estimate(data: &TrainingData) -> Option<EffectFit> {
        outliers(data)
    }

    fn test_statistic(p: &OutliersParams) -> Option<f64> {
        Some(p.lr)
    }
}

/// Spikes on a share of the samples ([module docs](self)).
pub(super) fn outliers(d: &TrainingData) -> Option<EffectFit> {
    let x = d.rate_dps;
    let n = x.len();
    let mut gap = vec![false; n];
    for g in d.gaps {
        for v in &mut gap[g.start.min(n)..g.end.min(n)] {
            *v = true;
        }
    }
    // Beside jumps an earlier step took out (a bistable bias's flips, bias steps), a jump placed a sample off
    // leaves a pulse of its whole size: the recovery's residue, not a spike, so the samples around each are not
    // read.
    if let Some(s) = d.shaped_dps {
        // The levels come back from sums of samples: equal to rounding, not exactly.
        let tiny = 1e-9 * s.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for i in 1..n.min(s.len()) {
            if (s[i] - s[i - 1]).abs() > tiny {
                gap[i.saturating_sub(JUMP_GUARD)..(i + JUMP_GUARD).min(n)].fill(true);
            }
        }
        leave_out_excursions(x, s, tiny, &mut gap);
    }
    // On an ADC lattice the residuals sit on a few values (most on 0 where the step is coarser than the noise):
    // a dither makes them continuous, so the core has a scale, and the spikes' magnitudes are held beyond the steps
    // the lattice itself takes between neighbours.
    let lattice = lattice(&outside_gaps(d.recorded_dps, d.gaps));
    // The residuals on the lattice itself, and how far the lattice's own reach: beyond it, every residual is a
    // spike's.
    let on_lattice = lattice.and_then(|(q, point)| {
        lattice_reach::OnLattice::read(residuals(x, &gap, None), d.recorded_dps, &gap, q, point)
    });
    let dithered = lattice.map(|(q, _)| dither(x, q));
    let least = match (&on_lattice, lattice) {
        (Some(at), _) => at.least(),
        (None, Some((q, _))) => lattice_reach::FAR_STEPS * q,
        (None, None) => 0.0,
    };
    let (c, law) = match read(dithered.as_deref().unwrap_or(x), &gap, least).filter(|c| c.is_process(n)) {
        Some(c) => {
            // Spikes clear of the core are read off their cluster; the calibration is for laws near it. On a
            // lattice it runs where the law is read from the reach (spikes stand between the reach and three
            // steps); held beyond three steps, the law is left as read, against that bound.
            let law = match (clear_law(c.mix, &c.flagged, c.valid), lattice, &on_lattice) {
                (Some(mix), _, _) => calibrate::Law { mix, ..calibrate::Law::of(&c) },
                (None, Some(_), Some(at)) if at.busy() => {
                    calibrate::corrected(&c, n, Some(calibrate::OnLattice::of(at)))
                }
                (None, Some(_), _) => calibrate::Law::of(&c),
                (None, None, _) => calibrate::corrected(&c, n, None),
            };
            (c, law)
        }
        // Spikes beyond a lattice's reach too few for the dithered core's mixture: read off their count.
        None => {
            let c = beyond_reach(on_lattice.as_ref().filter(|at| at.reading.spiked())?).filter(|c| c.is_process(n))?;
            let law = calibrate::Law::of(&c);
            (c, law)
        }
    };
    let m = law.mix;
    let run_mean = law.run_mean();
    let spikes = law.outliers();
    let refit = refit_without(d, &spikes);
    let mut cleaned = x.to_vec();
    match (lattice, &on_lattice) {
        // On a lattice, the samples whose undithered residual stands beyond the lattice's reach, each moved onto
        // its neighbours' median: every one is a spike's, and the dithered flags would both miss spikes of two or
        // three steps (a core the dither widens holds them) and move a sample a step too far where the dither
        // pushed its residual past a half step. The steps that learn without the spikes would read what is left
        // as white noise under the lattice.
        (Some((q, _)), Some(at)) => {
            let reach = at.reach();
            for (i, r) in at.residuals.iter().enumerate() {
                if r.abs() >= reach - 0.25 * q {
                    cleaned[i] = x[i] - q * (r / q).round();
                }
            }
        }
        // Without a reach, the flagged samples, back on the lattice where they were.
        (Some((q, _)), None) => {
            for &(i, r) in &c.flagged {
                cleaned[i] = x[i] - q * (r / q).round();
            }
        }
        (None, _) => {
            for &(i, r) in &c.flagged {
                cleaned[i] = x[i] - r;
            }
        }
    }
    Some(EffectFit {
        effect: Effect::Outliers,
        params: OutliersParams {
            per_sample: m.eps,
            size_dps: m.centre,
            spread_dps: m.spread,
            run_mean,
            run_continue: law.cont_next,
            count: c.flagged.len(),
            robust_sigma_dps: m.sigma,
            lr: c.mix.lr,
        }
        .into(),
        n_params: 3 + usize::from(law.rho1 > 0.0) + usize::from(law.cont_next > 0.0),
        gyro: GyroSim { outliers: Some(spikes), ..refit },
        channel: None,
        // The rate rests on the runs counted: each is a Poisson event of the training part.
        spread: Some(ParamSpread::SpikeRate { runs: m.eps * n as f64 / run_mean.max(1.0) }),
        cleaned: Some(Arc::new(cleaned)),
    })
}

/// Spikes on a lattice read off the undithered residuals at or beyond its reach, where no clean residual stands
/// (a clean lattice leaves there at most [`lattice_reach::clean_share_bound`]): a dozen spikes of two steps in a
/// quarter of a million samples are too few for the dithered core's mixture, which finds them at three dithered
/// sds among a thousand of the core's own, yet a clean lattice under noise of a seventh of a step leaves none
/// there. The evidence is their count against the clean bound: `lr` is twice the log-likelihood of the count
/// under its own rate over the bound's (`2 (k ln(k / mu0) - k + mu0)`); the law's centre and spread are the
/// magnitudes' quartiles (their midpoint and half range when fewer than [`QUARTILE_SPIKES`]), its share the count
/// over the residuals read, and the core the white noise under the lattice. Spikes under the reach are not
/// counted: on a lattice they are its own residuals.
fn beyond_reach(at: &lattice_reach::OnLattice) -> Option<Contamination> {
    let (q, reach) = (at.step, at.reach());
    let flagged: Vec<(usize, f64)> =
        at.residuals.iter().enumerate().filter(|(_, r)| r.abs() >= reach - 0.25 * q).map(|(i, &r)| (i, r)).collect();
    let k = flagged.len();
    if k < MIN_SPIKES || at.reading.read == 0 {
        return None;
    }
    let mu0 = at.reading.clean_beyond.max(1e-12);
    let kf = k as f64;
    let lr = 2.0 * (kf * (kf / mu0).ln() - kf + mu0);
    let mut mags: Vec<f64> = flagged.iter().map(|f| f.1.abs()).collect();
    mags.sort_by(f64::total_cmp);
    let (centre, spread) = if k >= QUARTILE_SPIKES {
        quartile_centre_spread(&mags)
    } else {
        (0.5 * (mags[0] + mags[k - 1]), 0.5 * (mags[k - 1] - mags[0]))
    };
    let valid = at.reading.read;
    let mix = mixture::Mixture { sigma: at.reading.noise_steps * q, eps: kf / valid as f64, centre, spread, lr };
    Some(Contamination { mix, flagged, rho1: 0.0, cont_next: 0.0, tail: (k, mu0), valid })
}

/// Marks in `gap` the samples where a two-level bias taken out (`shaped`: a bistable bias's levels, equal within
/// `tiny`) made an excursion too short for its scan to resolve: a sample or two at the other level, whose residual
/// is the step between the levels towards the other one, within [`EXCURSION_SDS`] residual sds, and at least
/// [`EXCURSION_LEAST_SDS`] out. A telegraph's
/// dwells are exponential, so a few of hundreds are a sample or two long; the bistable model draws them, and the
/// spike law would read them as spikes of the step's size (13 of them beside a Gauss-Markov process of 1.2 s at
/// 6 Hz read as a spike process at 0.237 deg/s, the step being 0.229). Spikes of the step's size stand a step away
/// from the other level as often as towards it, so the residuals towards it are left out only where a sign test
/// says they outnumber those away ([`EXCURSION_ALPHA`]): beside a contamination whose spikes are of the step's
/// size, leaving out half of them misread its law.
fn leave_out_excursions(x: &[f64], shaped: &[f64], tiny: f64, gap: &mut [bool]) {
    let n = x.len().min(shaped.len());
    let lo = shaped[..n].iter().copied().fold(f64::INFINITY, f64::min);
    let hi = shaped[..n].iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !(hi - lo > tiny) || shaped[..n].iter().any(|&v| (v - lo).abs() > tiny && (v - hi).abs() > tiny) {
        return;
    }
    let r = residuals(x, gap, None);
    let mut valid: Vec<f64> = r.iter().copied().filter(|v| v.is_finite()).collect();
    if valid.is_empty() {
        return;
    }
    let (_, scale) = mad_scale_in_place(&mut valid);
    if !(scale > 0.0) {
        return;
    }
    let step = hi - lo;
    // Each residual's sign against the other level: +1 where it stands a step towards it, -1 a step away.
    let side = |i: usize, ri: f64| {
        let towards = if (shaped[i] - lo).abs() <= tiny { step } else { -step };
        let near = |target: f64| ri.abs() >= EXCURSION_LEAST_SDS * scale && (ri - target).abs() < EXCURSION_SDS * scale;
        if near(towards) {
            1
        } else if near(-towards) {
            -1
        } else {
            0
        }
    };
    let sides: Vec<i8> =
        r.iter().enumerate().take(n).map(|(i, &ri)| if ri.is_finite() { side(i, ri) } else { 0 }).collect();
    // Spikes stand a step away from the other level as often as towards it; excursions only towards it.
    let towards = sides.iter().filter(|&&v| v == 1).count();
    let away = sides.iter().filter(|&&v| v == -1).count();
    if binomial_half_tail(towards + away, towards) > EXCURSION_ALPHA {
        return;
    }
    for (g, &v) in gap.iter_mut().zip(&sides) {
        if v == 1 {
            *g = true;
        }
    }
}

/// The sign test's significance below which the residuals a step towards a two-level bias's other level are its
/// excursions, not spikes ([`leave_out_excursions`]).
const EXCURSION_ALPHA: f64 = 1e-3;

/// How near, in residual sds, a residual must stand to a two-level bias's step towards the other level to be an
/// excursion the bias's scan did not resolve ([`leave_out_excursions`]).
const EXCURSION_SDS: f64 = 3.0;

/// How far out, in residual sds, a residual must stand to be left out as an excursion: where the spikes' evidence
/// starts ([`TAIL_SIGMAS`]). The core's own samples stay read, so its scale is not bent, and its tail does not
/// dilute the sign test.
const EXCURSION_LEAST_SDS: f64 = TAIL_SIGMAS;

/// The samples either side of a jump taken out that the spikes' reading leaves aside ([`outliers`]).
const JUMP_GUARD: usize = 2;

/// `x` plus a Gaussian dither of sd [`DITHER_STEPS`] lattice steps `q` (a fixed stream, so the diagnosis is
/// repeatable).
fn dither(x: &[f64], q: f64) -> Vec<f64> {
    let mut rng = SimRng::new(DITHER_SEED);
    x.iter().map(|v| v + DITHER_STEPS * q * rng.normal()).collect()
}

/// The dither's sd, lattice steps: the residuals' lattice (steps and half steps) smoothed to within a percent of
/// a continuous density (a Gaussian of sd s over a comb of spacing q ripples by `exp(-2 pi^2 s^2 / q^2)`), while a
/// spike of three steps still stands six dithered sds out.
const DITHER_STEPS: f64 = 0.5;

/// The dither's stream.
const DITHER_SEED: u64 = 0xd1_7e4;

/// The Allan variance of the spike process of `o` at `m` samples, from its autocovariance: `R0 = eps E s^2` and
/// `R_k = R1 c2^(k-1)`, `R1 = eps centre^2 (1 - 1 / run_mean)` (a run's spikes share a sign). With `c2 > 0` that is
/// white `R0 - R1 / c2` plus an AR(1) of pole c2 and variance `R1 / c2`; with `c2 = 0`, `(R0 + 2 R1) / m - 3 R1 / m^2`.
fn spike_avar(o: &Outliers, m: f64) -> f64 {
    let (c, w) = (o.size_dps, o.spread_dps);
    let r0 = o.per_sample * (c * c + w * w / 3.0);
    let r1 = o.per_sample * c * c * (1.0 - 1.0 / o.run_mean.max(1.0));
    let c2 = o.run_continue;
    if c2 > 1e-9 {
        (r0 - r1 / c2) / m + r1 / c2 * ar1_avar(c2, m)
    } else {
        (r0 + 2.0 * r1) / m - 3.0 * r1 / (m * m)
    }
}

/// The base terms re-fitted on the OADEV less the spikes' Allan variance (no ramp the base fit did not have);
/// each point's EDF is scaled by the share left squared, since its sampling error is the whole variance's.
///
/// Where an earlier step took jumps out (a bistable bias's levels, bias steps: `d.shaped_dps`), the samples carry
/// the recovery's residue (a flip placed a sample off is a one-sample pulse of its whole size, a spike of its own),
/// and the model's base terms were fitted beside the process on the curve as recorded, spikes and all: the curve
/// re-fitted is then the model's own base curve, less the spikes'.
fn refit_without(d: &TrainingData, o: &Outliers) -> GyroSim {
    let rate_hz = d.rate_hz;
    // Where the model's channel has a lattice, the base's N is the analog noise the quantisation estimator
    // recovered under it, which a curve of rounded samples does not give back (below a step the rounding error
    // is neither white nor independent of the noise): the base terms stay.
    if d.lattice_dps.is_some() {
        return d.base.clone();
    }
    let mut pts = gapped_oadev_points(d.rate_dps, d.gaps, rate_hz);
    if d.shaped_dps.is_some() {
        pts = base_curve(d.base, &pts, rate_hz);
    }
    let pts: Vec<_> = pts
        .into_iter()
        .filter_map(|mut p| {
            let own = spike_avar(o, p.tau_s * rate_hz);
            let left = (p.avar - own) / p.avar;
            (left > 0.02).then(|| {
                p.avar -= own;
                p.edf *= left * left;
                p
            })
        })
        .collect();
    refit_base_terms(d.base, &pts, rate_hz)
}

/// Whether more than half of the spikes at sample indices `hits` (sorted) lie within [`CLUSTER_SPAN`] of a record
/// of `n` samples.
fn clustered(hits: &[usize], n: usize) -> bool {
    let span = (CLUSTER_SPAN * n as f64) as usize;
    let need = hits.len() / 2 + 1;
    hits.windows(need).any(|w| w[need - 1] - w[0] <= span)
}

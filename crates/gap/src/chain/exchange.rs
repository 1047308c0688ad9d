//! The exchange step of the search: an effect of the chain traded for one of the runners-up of its own step.
//!
//! A step names the candidate that explains most of the gap on the chain found so far, with only the effects
//! before it in place. Two effects of the vocabulary can draw nearly the same shape over part of the curve: a
//! Gauss-Markov process of a few seconds is white noise through a first-order filter, and read before a resonance
//! it takes part of the bump with the filter's roll-off, scoring ahead of the sensor's real corner. Once every
//! effect of the chain is in place the two no longer draw the same shape, but the step has already chosen, and
//! the answer depends on the order the effects were found in.
//!
//! So, once the chain is found and pruned ([`super::prune`]), each effect the views named is tried in exchange for each
//! of the [`RUNNERS_UP`] best-scored candidates of its own step that are not in the chain: the chain with the exchange
//! is learnt again from the training samples as the diagnosis learnt it ([`super::learn`]) and judged against the
//! record. The exchange is kept where that chain leaves no significant gap on the training part (or a smaller one than
//! the chain's: a chain that has not explained everything is not made worse by a better reading of what it did explain)
//! and its score (the views' total with the parameter penalty, [`rank::score`]) beats the chain's by
//! [`EXCHANGE_MARGIN`]; of several, the best. A chain whose total is already within [`evidence::AGREEMENT_TOTAL`]
//! agrees with the record as well as the ensemble's members agree with each other, and is not second-guessed. The
//! held-out part plays no role here: it remains the check of the chain chosen.
//!
//! Effects that their estimator named are not exchanged: no view sees them, so the views cannot prefer another.

use super::model::{Model, NamedBy, Rounds};
use super::search::{by_score, Found};
use crate::effects::params::EffectParams;
use crate::effects::{Effect, EffectFit};
use crate::error::GapError;
use crate::evidence;
use crate::judge::Evaluated;
use crate::rank::{self, PartGap};

/// How much better than the chain's a chain with an exchange must score to be kept. Every model is judged by
/// members drawn with the same seeds, so two models that differ by one effect's shape differ in total by far less
/// than one ensemble draw moves a total ([`evidence::VIEWS_TOLERANCE`], 10%); 5% is half that. A Gauss-Markov
/// process of 2.2 s read before a resonance, in place of a filter corner at 0.41 Hz (a 2.3 Hz record), left a
/// training total of 1.31 with the chain; the corner in its place 1.26, with one parameter fewer (scores 1.77 and
/// 1.63).
pub const EXCHANGE_MARGIN: f64 = 1.05;

/// How many of a step's best-scored other candidates are tried in its effect's place. A step is judged on the
/// chain found so far, where an effect not yet named can rank a wrong candidate second: beside a large warm-up
/// still in the record, a filter corner was named in a Gauss-Markov process's place and a sinusoid of two cycles
/// ranked second (scores 7.58, 11.04 and 11.16 for the process); with the warm-up in place the process held out
/// at 0.82.
pub const RUNNERS_UP: usize = 2;

/// The fall of the Allan curve's log chi-square that a filter corner's or a Gauss-Markov process's fit carries
/// (the two effects read on that curve; other effects' statistics are on other scales).
fn allan_curve_fall(fit: &EffectFit) -> Option<f64> {
    match &fit.params {
        EffectParams::Bandwidth(p) => Some(p.delta_chi2),
        EffectParams::GaussMarkov(p) => Some(p.delta_chi2),
        _ => None,
    }
}

/// Whether the Allan curve cannot prefer `candidate` to the step's own `fit`: both are read on that curve, the
/// candidate has more parameters, and lowers the curve's chi-square by less than [`rank::ONE_FREEDOM_CHI2`] a
/// parameter more, the test by which the step itself ([`rank::choose`]) reads a process as the corner's spectrum.
/// A Gauss-Markov process of a few samples' correlation time with no white noise beside it is white noise through
/// a first-order corner: the same process, the same fall of the curve's chi-square (5,012.8 and 5,012.6 on a
/// corner at 10.4 Hz of a 148 Hz record; 2,092.1 and 2,089.7 on one at 1.8 Hz of a 21 Hz record with a resonance
/// beside it), and the views' totals then differ by the ensemble's draw. The corner, with fewer parameters, stays.
fn curve_cannot_prefer(fit: &EffectFit, candidate: Option<&EffectFit>) -> bool {
    let Some(candidate) = candidate else { return false };
    let (Some(own), Some(other)) = (allan_curve_fall(fit), allan_curve_fall(candidate)) else { return false };
    let extra = candidate.n_params.saturating_sub(fit.n_params);
    extra > 0 && other - own < rank::ONE_FREEDOM_CHI2 * extra as f64
}

/// An effect of the chain exchanged for another, and the views' training totals of the chain before and after.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Exchanged {
    /// The effect taken out.
    pub effect: Effect,
    /// The effect put in its place: one of the best-scored candidates of its step outside the chain.
    pub replacement: Effect,
    /// The views' training total of the chain with `effect`.
    pub total_with: f64,
    /// The same with `replacement` in its place.
    pub total_after: f64,
}

/// The chain `found`, with at most one effect the views named exchanged for the best-scored other candidate of its
/// step where the chain learnt with that one scores clearly better (module doc); the exchange is recorded in
/// [`Found::exchanged`]. `relearn` learns a chain of effects with the rounds after each step from the training
/// samples and judges its model against the record.
///
/// # Errors
/// As `relearn`.
pub(crate) fn exchange(
    mut found: Found,
    mut relearn: impl FnMut(&[Effect], &[Rounds]) -> Result<(Model, Evaluated), GapError>,
) -> Result<Found, GapError> {
    let total_with = rank::total_of(&found.eval.training);
    if total_with <= evidence::AGREEMENT_TOTAL {
        return Ok(found);
    }
    let params: usize = found.steps.iter().map(|s| s.fit.n_params).sum();
    let score_with = rank::score(total_with, params);
    let gap_with = rank::gap_of(&found.eval.training);
    let effects: Vec<Effect> = found.steps.iter().map(|s| s.effect).collect();
    let rounds: Vec<Rounds> = found.steps.iter().map(|s| s.rounds()).collect();
    // The best exchange: (step, candidate, model, comparison, total, score).
    let mut best: Option<(usize, usize, Model, Evaluated, f64, f64)> = None;
    for (k, step) in found.steps.iter().enumerate() {
        if step.named_by != NamedBy::View {
            continue;
        }
        let runners_up = by_score(&step.candidates)
            .into_iter()
            .filter(|&i| step.candidates[i].fit.is_some() && !effects.contains(&step.candidates[i].effect))
            .take(RUNNERS_UP);
        for c in runners_up {
            let candidate = &step.candidates[c];
            if curve_cannot_prefer(&step.fit, candidate.fit.as_ref()) {
                continue;
            }
            let mut with = effects.clone();
            with[k] = candidate.effect;
            let (model, eval) = relearn(&with, &rounds)?;
            let total_after = rank::total_of(&eval.training);
            let gap_after = rank::gap_of(&eval.training);
            let settled = gap_after <= rank::SIGNIFICANT_GAP || gap_after < gap_with;
            let n = params - step.fit.n_params + candidate.fit.as_ref().map_or(0, |f| f.n_params);
            let score = rank::score(total_after, n);
            if settled && EXCHANGE_MARGIN * score < score_with && best.as_ref().is_none_or(|b| score < b.5) {
                best = Some((k, c, model, eval, total_after, score));
            }
        }
    }
    let Some((k, c, model, eval, total_after, _)) = best else { return Ok(found) };
    let step = &mut found.steps[k];
    let candidate = step.candidates[c].clone();
    let Some(fit) = candidate.fit else { return Ok(found) };
    let effect = step.effect;
    step.effect = candidate.effect;
    step.fit = fit;
    step.refit = None;
    if let Some(after) = rank::band_gap(&eval.training, &step.location) {
        step.training = PartGap::new(step.training.gap_before, after);
    }
    if let (Some(h), Some(after)) = (step.holdout, rank::band_gap(&eval.holdout, &step.location)) {
        step.holdout = Some(PartGap::new(h.gap_before, after));
    }
    step.eval = eval.clone();
    for s in &mut found.steps {
        s.refit = Some(s.final_fit().reestimated(&model.gyro));
    }
    found.model = model;
    found.eval = eval;
    found.exchanged.push(Exchanged { effect, replacement: candidate.effect, total_with, total_after });
    Ok(found)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::model::Step;
    use crate::chain::prune::tests::{effects, eval, found, step};
    use crate::effects::params::{BandwidthParams, GaussMarkovParams};
    use crate::effects::EffectFit;
    use crate::evidence::Evidence;
    use crate::rank::CandidateResult;
    use crate::views::ViewKind;
    use octavar_shared::sim::GyroSim;

    /// A step's runner-up: `effect` fitted with `params` and `n_params` parameters, on a default model.
    fn runner_up(effect: Effect, params: EffectParams, n_params: usize) -> EffectFit {
        EffectFit { effect, params, n_params, gyro: GyroSim::default(), channel: None, spread: None, cleaned: None }
    }

    /// A Gauss-Markov process named before a resonance, its step's runner-up a filter corner (score 2.1).
    fn steps(first_by: NamedBy) -> Vec<Step> {
        let mut first = step(Effect::GaussMarkov, first_by);
        let params = BandwidthParams { bandwidth_hz: 0.4, n_deg_per_rt_s: 0.0, delta_chi2: 0.0 };
        let corner = runner_up(Effect::Bandwidth, params.into(), 2);
        first.candidates = vec![
            CandidateResult::new(Effect::GaussMarkov, Some(first.fit.clone()), Some(eval(1.6)), None),
            CandidateResult::new(Effect::Bandwidth, Some(corner), Some(eval(1.9)), None),
            CandidateResult::new(Effect::Resonance, None, None, None),
        ];
        vec![first, step(Effect::Resonance, NamedBy::View)]
    }

    /// The chain learnt again: with the corner in the process's place it totals `with_corner`, else 3.
    fn relearn(with_corner: f64) -> impl FnMut(&[Effect], &[Rounds]) -> Result<(Model, Evaluated), GapError> {
        move |effects: &[Effect], _: &[Rounds]| {
            let model = Model { gyro: GyroSim::default(), spreads: Vec::new(), channel: None };
            let total = if effects == [Effect::Bandwidth, Effect::Resonance] { with_corner } else { 3.0 };
            Ok((model, eval(total)))
        }
    }

    #[test]
    fn an_effect_its_runner_up_beats_is_exchanged() {
        let f = exchange(found(steps(NamedBy::View), 1.5), relearn(1.0)).unwrap();
        assert_eq!(effects(&f), [Effect::Bandwidth, Effect::Resonance]);
        assert_eq!(f.steps[0].fit.effect, Effect::Bandwidth);
        assert_eq!(
            f.exchanged,
            [Exchanged {
                effect: Effect::GaussMarkov,
                replacement: Effect::Bandwidth,
                total_with: 1.5,
                total_after: 1.0
            }]
        );
        assert!((rank::total_of(&f.eval.training) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn the_second_runner_up_is_tried_too() {
        // A sinusoid scored ahead of the corner at the process's step; only the corner mends the chain.
        let mut s = steps(NamedBy::View);
        let params = BandwidthParams { bandwidth_hz: 0.0, n_deg_per_rt_s: 0.0, delta_chi2: 100.0 };
        let sinusoid = runner_up(Effect::Sinusoid, params.into(), 3);
        s[0].candidates[2] = CandidateResult::new(Effect::Sinusoid, Some(sinusoid), Some(eval(1.7)), None);
        let f = exchange(found(s, 1.5), relearn(1.0)).unwrap();
        assert_eq!(effects(&f), [Effect::Bandwidth, Effect::Resonance]);
    }

    #[test]
    fn an_exchange_within_the_ensembles_draw_or_beside_a_larger_gap_is_refused() {
        // 1.45 against 1.5 (the parameters equal): within the margin.
        let f = exchange(found(steps(NamedBy::View), 1.5), relearn(1.45)).unwrap();
        assert_eq!(effects(&f), [Effect::GaussMarkov, Effect::Resonance]);
        assert!(f.exchanged.is_empty());
        // The chain leaves 3.0 in both views; the exchange a lower total (2.83) but 4.0 in one view: a significant
        // gap larger than the chain's.
        let two = |adev: f64, psd: f64| {
            let mut e = eval(adev);
            let mut v = e.training[0].clone();
            (v.view, v.gap, v.rms) = (ViewKind::Psd, psd, psd);
            e.training.push(v);
            e
        };
        let chain = || {
            let mut f = found(steps(NamedBy::View), 3.0);
            f.eval = two(3.0, 3.0);
            f
        };
        let model = || Model { gyro: GyroSim::default(), spreads: Vec::new(), channel: None };
        let f = exchange(chain(), |_: &[Effect], _: &[Rounds]| Ok((model(), two(4.0, 0.1)))).unwrap();
        assert!(f.exchanged.is_empty());
        // A significant gap smaller than the chain's is a better reading of what the chain explained: kept.
        let f = exchange(chain(), |e: &[Effect], _: &[Rounds]| {
            Ok((model(), if e == [Effect::Bandwidth, Effect::Resonance] { two(2.6, 0.5) } else { two(3.0, 3.0) }))
        })
        .unwrap();
        assert_eq!(effects(&f), [Effect::Bandwidth, Effect::Resonance]);
    }

    /// A filter corner named (one parameter, the curve's chi-square lower by `corner_fall`), its step's runner-up a
    /// Gauss-Markov process (two, lower by `process_fall`); the chain learnt with the process totals 1.0, with the
    /// corner 1.5.
    fn corner_then_process(corner_fall: f64, process_fall: f64) -> Found {
        let mut first = step(Effect::Bandwidth, NamedBy::View);
        first.fit.n_params = 1;
        first.fit.params =
            BandwidthParams { bandwidth_hz: 10.4, n_deg_per_rt_s: 3.4e-3, delta_chi2: corner_fall }.into();
        let params = GaussMarkovParams { sigma_dps: 0.019, tau_s: 0.016, delta_chi2: process_fall };
        let process = runner_up(Effect::GaussMarkov, params.into(), 2);
        first.candidates = vec![
            CandidateResult::new(Effect::Bandwidth, Some(first.fit.clone()), Some(eval(1.5)), None),
            CandidateResult::new(Effect::GaussMarkov, Some(process), Some(eval(1.6)), None),
        ];
        found(vec![first], 1.5)
    }

    #[test]
    fn a_corner_is_not_exchanged_for_a_process_the_allan_curve_cannot_prefer() {
        let relearn = |effects: &[Effect], _: &[Rounds]| {
            let model = Model { gyro: GyroSim::default(), spreads: Vec::new(), channel: None };
            Ok((model, eval(if effects == [Effect::GaussMarkov] { 1.0 } else { 1.5 })))
        };
        // The same fall of the curve's chi-square, or one a few units lower than one freedom's 1% point buys: the
        // same process, and the corner stays.
        for process_fall in [5012.8, 5015.0, 5012.6 + 0.99 * rank::ONE_FREEDOM_CHI2] {
            let f = exchange(corner_then_process(5012.6, process_fall), relearn).unwrap();
            assert_eq!(effects(&f), [Effect::Bandwidth], "{process_fall}");
            assert!(f.exchanged.is_empty());
        }
        // A process that lowers it by more than that for its extra parameter is the better reading of the curve.
        let f = exchange(corner_then_process(5012.6, 5020.0), relearn).unwrap();
        assert_eq!(effects(&f), [Effect::GaussMarkov]);
    }

    #[test]
    fn a_chain_in_agreement_or_an_effect_its_estimator_named_is_not_tried() {
        let mut tried = 0;
        let mut inner = relearn(0.5);
        let mut counting = |e: &[Effect], r: &[Rounds]| {
            tried += 1;
            inner(e, r)
        };
        let f = exchange(found(steps(NamedBy::View), 0.95), &mut counting).unwrap();
        assert!(f.exchanged.is_empty());
        let evidence = Evidence { statistic: "t", value: 9.0, threshold: 5.0 };
        let f = exchange(found(steps(NamedBy::Estimator(evidence)), 1.5), &mut counting).unwrap();
        assert!(f.exchanged.is_empty());
        // Nothing was learnt again: the chain agreed, then the process was its estimator's and the resonance's
        // step holds no runner-up.
        assert_eq!(tried, 0);
    }
}

//! The backward step of the search: an effect a later one made redundant is taken out of the chain.
//!
//! The search adds effects one at a time, each to explain what the chain before it left. An effect added early
//! can stand in for part of one found later: a Gauss-Markov process read before the filter corner it imitates, or
//! before a temperature response whose slow wander it took for its own. Once the later effect is in place, the
//! earlier one explains nothing the chain needs, yet it stays named, and the answer then depends on the order the
//! effects were found in.
//!
//! So, once the chain is found, each effect the views named is tried out of it: the chain without it is learnt
//! again from the training samples as the diagnosis learnt it ([`super::learn`]: each step's estimator, the
//! backfitting and joint rounds) and judged against the record. Where that chain does not agree with the record,
//! it is learnt once more with a backfitting and a joint round after its last step, as the search ends every
//! chain: the effect taken out may have been making up for one read before it, which then has to be read again
//! with the whole chain in place. The effect is taken out when that chain leaves no
//! significant gap on the training part and agrees with the record about as well: its views' total at most
//! [`evidence::VIEWS_TOLERANCE`] times the full chain's, or at most [`evidence::AGREEMENT_TOTAL`], where the
//! ensemble's own draws agree no better. Of several such effects the one whose absence costs least goes first, and
//! the rest are tried again on the chain without it. The held-out part plays no role here: it remains the check
//! of the chain chosen.
//!
//! Effects that their estimator named are not tried: no view sees them, so the views cannot say they are
//! redundant.

use super::model::{Model, NamedBy, Rounds};
use super::search::Found;
use crate::effects::Effect;
use crate::error::GapError;
use crate::evidence;
use crate::judge::Evaluated;
use crate::rank;

/// An effect taken out of the chain, and the views' training total of the chain with it and without it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pruned {
    /// The effect.
    pub effect: Effect,
    /// The views' training total of the chain with it.
    pub total_with: f64,
    /// The same without it.
    pub total_without: f64,
}

/// The chain `found`, less every effect the views named that a later one made redundant (module doc), with what
/// was taken out in its [`Found::pruned`]. `relearn` learns a chain of effects with the rounds after each step
/// from the training samples and judges its model against the record.
///
/// # Errors
/// As `relearn`.
pub(crate) fn prune(
    mut found: Found,
    mut relearn: impl FnMut(&[Effect], &[Rounds]) -> Result<(Model, Evaluated), GapError>,
) -> Result<Found, GapError> {
    while found.steps.len() >= 2 {
        let total_with = rank::total_of(&found.eval.training);
        let allowed = (evidence::VIEWS_TOLERANCE * total_with).max(evidence::AGREEMENT_TOTAL);
        let mut best: Option<(usize, Model, Evaluated, f64)> = None;
        for (k, step) in found.steps.iter().enumerate() {
            if step.named_by != NamedBy::View {
                continue;
            }
            let (effects, rounds) = without_step(&found, k);
            let (model, eval) = learn_finished(&effects, rounds, allowed, &mut relearn)?;
            let total_without = rank::total_of(&eval.training);
            if agrees(&eval, allowed) && best.as_ref().is_none_or(|b| total_without < b.3) {
                best = Some((k, model, eval, total_without));
            }
        }
        let Some((k, model, eval, total_without)) = best else { break };
        let step = found.steps.remove(k);
        for s in &mut found.steps {
            s.refit = Some(s.final_fit().reestimated(&model.gyro));
        }
        found.model = model;
        found.eval = eval;
        found.pruned.push(Pruned { effect: step.effect, total_with, total_without });
    }
    Ok(found)
}

/// Whether the chain judged `eval` leaves no significant gap on the training part and a views' total within
/// `allowed`.
fn agrees(eval: &Evaluated, allowed: f64) -> bool {
    rank::gap_of(&eval.training) <= rank::SIGNIFICANT_GAP && rank::total_of(&eval.training) <= allowed
}

/// The chain `effects` learnt with `rounds` after its steps, and where it does not then agree with the record
/// ([`agrees`]), learnt once more with a backfitting and a joint round after its last step, as the search ends
/// every chain it finds; of the two, the one with the lower views' total. With an effect gone, the ones read
/// before it may have to be read again with the whole chain in place: a filter corner read first, with a
/// temperature response and a sinusoid still in the samples, sat 17% high, and a Gauss-Markov process of three
/// samples named later made up its roll-off; without the process, the corner read as first learnt left a gap of
/// 6.2, and read again on the chain, 1.35 and a lower total than the process's chain.
fn learn_finished(
    effects: &[Effect],
    mut rounds: Vec<Rounds>,
    allowed: f64,
    relearn: &mut impl FnMut(&[Effect], &[Rounds]) -> Result<(Model, Evaluated), GapError>,
) -> Result<(Model, Evaluated), GapError> {
    let first = relearn(effects, &rounds)?;
    let Some(last) = rounds.last_mut() else { return Ok(first) };
    let finished = Rounds { backfit: last.backfit || effects.len() >= 2, joint: true };
    if agrees(&first.1, allowed) || *last == finished {
        return Ok(first);
    }
    *last = finished;
    let again = relearn(effects, &rounds)?;
    Ok(if rank::total_of(&again.1.training) < rank::total_of(&first.1.training) { again } else { first })
}

/// The effects of `found`'s chain without its step `k`, and the rounds after each of the others: the rounds that
/// followed step `k` follow the step before it (or, for the first, the one after it), so that a round run after
/// the chain is still run after it.
fn without_step(found: &Found, k: usize) -> (Vec<Effect>, Vec<Rounds>) {
    let mut effects = Vec::new();
    let mut rounds: Vec<Rounds> = Vec::new();
    for (i, s) in found.steps.iter().enumerate() {
        if i != k {
            effects.push(s.effect);
            rounds.push(s.rounds());
        }
    }
    let gone = found.steps[k].rounds();
    if let Some(r) = rounds.get_mut(k.saturating_sub(1)) {
        r.backfit |= gone.backfit;
        r.joint |= gone.joint;
    }
    (effects, rounds)
}

#[cfg(test)]
pub(super) mod tests {
    use octavar_shared::sim::GyroSim;

    use super::*;
    use crate::chain::model::Step;
    use crate::chain::Model;
    use crate::compare::ViewGap;
    use crate::effects::params::{BandwidthParams, GaussMarkovParams};
    use crate::effects::EffectFit;
    use crate::evidence::Evidence;
    use crate::judge::Evaluated;
    use crate::rank::{Location, PartGap, Sign};
    use crate::views::ViewKind;

    /// A comparison whose one view has the gap (and so the total) `gap`.
    pub(in crate::chain) fn eval(gap: f64) -> Evaluated {
        let view = ViewGap { view: ViewKind::Adev, points: Vec::new(), rms: gap, gap, window: (0, 0) };
        Evaluated { training: vec![view], holdout: Vec::new(), adev_band: Vec::new(), real_holdout: None }
    }

    pub(in crate::chain) fn step(effect: Effect, named_by: NamedBy) -> Step {
        let params = match effect {
            Effect::GaussMarkov => GaussMarkovParams { sigma_dps: 0.0, tau_s: 0.0, delta_chi2: 0.0 }.into(),
            _ => BandwidthParams { bandwidth_hz: 0.0, n_deg_per_rt_s: 0.0, delta_chi2: 0.0 }.into(),
        };
        let gyro = GyroSim::default();
        let fit = EffectFit { effect, params, n_params: 2, gyro, channel: None, spread: None, cleaned: None };
        let location = Location {
            view: ViewKind::Adev,
            band_s: [1.0, 10.0],
            tau_range_s: [1.0, 8.0],
            sign: Sign::Above,
            z_rms: 1.0,
            points: 4,
            labels: Vec::new(),
            ratio: None,
            correlation: None,
        };
        Step {
            effect,
            named_by,
            fit,
            eval: eval(1.0),
            location,
            training: PartGap::new(5.0, 1.0),
            holdout: None,
            candidates: Vec::new(),
            refit: None,
            backfitted: false,
            joint: false,
        }
    }

    /// The chain `steps` with the views' total `total`.
    pub(in crate::chain) fn found(steps: Vec<Step>, total: f64) -> Found {
        let model = Model { gyro: GyroSim::default(), spreads: Vec::new(), channel: None };
        let (first_candidates, last_tried, pruned) = (Vec::new(), Vec::new(), Vec::new());
        Found {
            steps,
            first_candidates,
            last_tried,
            model,
            eval: eval(total),
            pruned,
            exchanged: Vec::new(),
            retried: None,
        }
    }

    /// The chain learnt again: the filter corner alone agrees with the total `without_markov`; the process alone
    /// leaves a significant gap.
    fn relearn(without_markov: f64) -> impl FnMut(&[Effect], &[Rounds]) -> Result<(Model, Evaluated), GapError> {
        move |effects: &[Effect], _: &[Rounds]| {
            let model = Model { gyro: GyroSim::default(), spreads: Vec::new(), channel: None };
            let total = match effects {
                [Effect::Bandwidth] => without_markov,
                _ => 6.0,
            };
            Ok((model, eval(total)))
        }
    }

    pub(in crate::chain) fn effects(f: &Found) -> Vec<Effect> {
        f.steps.iter().map(|s| s.effect).collect()
    }

    #[test]
    fn an_effect_a_later_one_made_redundant_is_taken_out() {
        // A process read first, then the corner it imitated: the chain without the process agrees as well.
        let steps = || vec![step(Effect::GaussMarkov, NamedBy::View), step(Effect::Bandwidth, NamedBy::View)];
        let f = prune(found(steps(), 0.9), relearn(0.95)).unwrap();
        assert_eq!(effects(&f), [Effect::Bandwidth]);
        assert_eq!(f.pruned, [Pruned { effect: Effect::GaussMarkov, total_with: 0.9, total_without: 0.95 }]);
        assert!((rank::total_of(&f.eval.training) - 0.95).abs() < 1e-12);
        // Beyond agreement and more than 10% worse without it, the process stays.
        let f = prune(found(steps(), 1.2), relearn(1.4)).unwrap();
        assert_eq!(effects(&f), [Effect::GaussMarkov, Effect::Bandwidth]);
        assert!(f.pruned.is_empty());
        // Within 10% of a total beyond agreement, it goes.
        let f = prune(found(steps(), 1.2), relearn(1.3)).unwrap();
        assert_eq!(effects(&f), [Effect::Bandwidth]);
    }

    #[test]
    fn a_chain_tried_without_an_effect_is_read_again_with_the_whole_chain_in_place() {
        // A corner read first and a process that made up its roll-off: without the process, the corner as first
        // learnt leaves a significant gap; read again after the last step (a backfitting and a joint round), it
        // agrees better than the process's chain.
        let steps = || vec![step(Effect::Bandwidth, NamedBy::View), step(Effect::GaussMarkov, NamedBy::View)];
        let relearn = |finished_corner: f64| {
            move |effects: &[Effect], rounds: &[Rounds]| {
                let model = Model { gyro: GyroSim::default(), spreads: Vec::new(), channel: None };
                let total = match (effects, rounds) {
                    ([Effect::GaussMarkov], _) => 0.95,
                    ([Effect::Bandwidth], [Rounds { backfit: false, joint: true }]) => finished_corner,
                    _ => 6.0,
                };
                Ok((model, eval(total)))
            }
        };
        let f = prune(found(steps(), 0.91), relearn(0.93)).unwrap();
        assert_eq!(effects(&f), [Effect::Bandwidth]);
        assert_eq!(f.pruned, [Pruned { effect: Effect::GaussMarkov, total_with: 0.91, total_without: 0.93 }]);
        // Read again, the corner agrees less well than the process: the corner goes, as before.
        let f = prune(found(steps(), 0.91), relearn(0.98)).unwrap();
        assert_eq!(effects(&f), [Effect::GaussMarkov]);
        // Read again, it still leaves the gap: the first learning is kept, and the corner goes.
        let f = prune(found(steps(), 0.91), relearn(7.0)).unwrap();
        assert_eq!(f.pruned, [Pruned { effect: Effect::Bandwidth, total_with: 0.91, total_without: 0.95 }]);
    }

    #[test]
    fn an_effect_its_estimator_named_is_not_tried() {
        let evidence = Evidence { statistic: "t", value: 9.0, threshold: 5.0 };
        let steps =
            vec![step(Effect::GaussMarkov, NamedBy::Estimator(evidence)), step(Effect::Bandwidth, NamedBy::View)];
        let mut tried = Vec::new();
        let mut inner = relearn(0.95);
        let f = prune(found(steps, 0.9), |e: &[Effect], r: &[Rounds]| {
            tried.push(e.to_vec());
            inner(e, r)
        })
        .unwrap();
        assert_eq!(effects(&f), [Effect::GaussMarkov, Effect::Bandwidth]);
        // Only the corner was tried out, and without it the chain keeps a significant gap, as first learnt and
        // read again.
        assert_eq!(tried, [vec![Effect::GaussMarkov], vec![Effect::GaussMarkov]]);
    }

    #[test]
    fn the_rounds_after_a_step_taken_out_follow_the_step_before_it() {
        let mut steps = vec![
            step(Effect::GaussMarkov, NamedBy::View),
            step(Effect::Bandwidth, NamedBy::View),
            step(Effect::Sinusoid, NamedBy::View),
        ];
        steps[2].joint = true;
        steps[2].backfitted = true;
        let f = found(steps, 1.0);
        let (e, r) = without_step(&f, 2);
        assert_eq!(e, [Effect::GaussMarkov, Effect::Bandwidth]);
        assert_eq!(r, [Rounds::default(), Rounds { backfit: true, joint: true }]);
        let (e, r) = without_step(&f, 0);
        assert_eq!(e, [Effect::Bandwidth, Effect::Sinusoid]);
        assert_eq!(r, [Rounds::default(), Rounds { backfit: true, joint: true }]);
    }
}

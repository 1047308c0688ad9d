//! The diagnosis itself: the record made ready, the base model judged, the chain of effects ranked and learnt
//! step by step, the held-out checks computed, and the report assembled from them.

use super::base::{base_model, fit_base, training_adev};
use super::chain::{self, Model, Progress, ProgressFn};
use super::effects::Effect;
use super::ensemble;
use super::error::GapError;
use super::input::{GapInput, GapOptions, HoldoutCheck, MIN_PART};
use super::judge::Judge;
use super::report::{self, GapReport};
use super::{compare, holdout, transients};

/// Diagnose the gap between a record and the simulation of its fitted model (see the module doc of
/// [`crate::gap`]).
///
/// # Errors
/// A part too short, a bad temperature column, too few seeds, a base fit that fails, or a model the simulator
/// rejects.
pub fn diagnose(input: &GapInput, opts: &GapOptions, report_progress: &ProgressFn) -> Result<GapReport, GapError> {
    if opts.seeds < 3 {
        return Err(GapError::TooFewSeeds(opts.seeds));
    }
    input.check_temperature()?;
    input.check_values()?;
    // Transient disturbances become gaps in both parts before anything else sees the record.
    let transients = if opts.keep_transients { Vec::new() } else { transients::parts::find(input) };
    let masked_input;
    let original = input;
    let input = if transients.is_empty() {
        input
    } else {
        masked_input = transients::parts::masked(input, &transients);
        &masked_input
    };
    let n_train = input.n_train;
    let n_hold = input.n_holdout();
    let nan_count = |x: &GapInput| {
        [&x.rate_dps[..n_train], &x.rate_dps[n_train..]].map(|p| p.iter().filter(|v| v.is_nan()).count())
    };
    let missing = nan_count(input);
    let missing_before_mask = nan_count(original);
    if n_train - missing[0] < MIN_PART {
        return Err(GapError::TooShort { part: "training", n: n_train, missing: missing[0], needed: MIN_PART });
    }
    let has_holdout = n_hold > 0;
    if has_holdout && n_hold - missing[1] < MIN_PART {
        return Err(GapError::TooShort { part: "holdout", n: n_hold, missing: missing[1], needed: MIN_PART });
    }
    let rate_hz = input.rate_hz;
    let predictive = has_holdout && opts.holdout_check == HoldoutCheck::Predictive;
    // Ensembles: the base, one per candidate of the first step, about half as many again for later steps.
    let mut progress = Progress::new(report_progress, 2 + opts.effects.len() + usize::from(predictive));
    progress.expect("base fit", 0);

    // Base model on the training part.
    let training = &input.rate_dps[..n_train];
    let (real_adev, base_fit) = match &opts.base_fit {
        Some(f) => (training_adev(training, rate_hz)?, f.clone()),
        None => fit_base(training, rate_hz, &opts.fit)?,
    };
    let base = base_model(&base_fit, training);
    let base_model = Model { gyro: base.clone(), spreads: Vec::new(), channel: opts.channel };

    // Plans and the real measures, against which every model is judged.
    let judge = Judge::new(input, opts);
    let rec = judge.record();
    progress.tick("base fit");
    let base_eval = judge.evaluate(&base, &[], opts.channel.as_ref(), None, "base")?;
    progress.tick("base ensemble");

    // The chain, on the training samples and their temperature.
    let temp_train = rec.training_temp();
    let found = chain::search(
        &judge,
        &opts.effects,
        base_model,
        base_eval.clone(),
        &base_fit,
        training,
        temp_train,
        rate_hz,
        &mut progress,
    )?;
    let chain::Found { steps, first_candidates, last_tried, model, eval } = found;

    // The held-out check against predictive ensembles (see [`holdout`]), of the base model and the whole chain.
    let predictive_views = match (predictive, judge.hold_plan(), judge.real_holdout()) {
        (true, Some(hp), Some(real_hold)) => {
            let learner = holdout::Learner {
                rate_hz,
                temp_c: temp_train,
                fit: &opts.fit,
                fixed_base: opts.base_fit.as_ref(),
                fallback: &base_fit,
                channel: opts.channel,
            };
            let seeds = judge.seeds();
            // A base model not learnt from the record predicts what its plain ensemble does.
            let base_views = match opts.base_fit {
                Some(_) => None,
                None => {
                    let relearn = |t: &[f64]| (learner.base(t).1, opts.channel);
                    let m = ensemble::predict_holdout(&base, opts.channel.as_ref(), &rec, hp, seeds, None, &relearn)
                        .map_err(|err| GapError::Sim { model: "base".into(), err })?;
                    Some(compare::compare(hp, real_hold, &m))
                }
            };
            let chain_views = match steps.last() {
                Some(last) => {
                    let effects: Vec<Effect> = steps.iter().map(|s| s.effect).collect();
                    let rounds: Vec<_> = steps.iter().map(|s| s.rounds()).collect();
                    let explained = ensemble::temperature_response(&model.gyro, &rec);
                    let resp_hold = explained.as_deref().map(|r| &r[n_train..]);
                    let relearn = |t: &[f64]| learner.with_chain(&effects, &rounds, t);
                    let m = ensemble::predict_holdout(
                        &model.gyro,
                        model.channel.as_ref(),
                        &rec,
                        hp,
                        seeds,
                        resp_hold,
                        &relearn,
                    )
                    .map_err(|err| GapError::Sim { model: last.effect.name().to_string(), err })?;
                    // The real holdout as this model was judged on it (less its own temperature response).
                    eval.real_holdout.as_ref().map(|real| compare::compare(hp, real, &m))
                }
                None => None,
            };
            progress.tick("holdout check");
            Some((base_views.unwrap_or_else(|| base_eval.holdout.clone()), chain_views))
        }
        _ => None,
    };
    progress.done = progress.total;
    progress.expect("done", 0);
    Ok(report::assemble(report::Parts {
        rate_hz,
        n_train,
        n_holdout: n_hold,
        missing: missing_before_mask,
        transients,
        seeds: opts.seeds,
        has_temperature: input.temp_c.is_some(),
        channel: opts.channel,
        base,
        base_fit,
        real_adev,
        base_eval,
        final_eval: eval,
        candidates: first_candidates,
        chain: steps,
        last_tried,
        model,
        predictive: predictive_views,
    }))
}

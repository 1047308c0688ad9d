//! The diagnosis itself: the record made ready, the base model judged, the chain of effects ranked and learnt
//! step by step, the held-out checks computed, and the report assembled from them.

use rayon::prelude::*;

use super::base::{base_model, fit_base, training_adev};
use super::chain::{self, Model, Step, StepData, MAX_STEPS};
use super::effects::{self, Effect, EffectFit};
use super::ensemble;
use super::error::GapError;
use super::fill::{fill_gaps, gap_runs};
use super::input::{GapInput, GapOptions, HoldoutCheck, MIN_PART};
use super::judge::Judge;
use super::rank::{self, CandidateResult, PartGap};
use super::report::{self, GapReport};
use super::{compare, disturbances, holdout};

/// Candidates of a later step that get a second chance with the chain backfitted around them, best score first.
const SECOND_CHANCES: usize = 2;

/// Progress: `(stage, done, total)`, called after each ensemble.
pub type ProgressFn<'a> = dyn Fn(&str, usize, usize) + Sync + 'a;

/// Diagnose the gap between a record and the simulation of its fitted model (see the module doc of
/// [`crate::gap`]).
///
/// # Errors
/// A part too short, a bad temperature column, too few seeds, a base fit that fails, or a model the simulator
/// rejects.
pub fn diagnose(input: &GapInput, opts: &GapOptions, progress: &ProgressFn) -> Result<GapReport, GapError> {
    if opts.seeds < 3 {
        return Err(GapError::TooFewSeeds(opts.seeds));
    }
    input.check_temperature()?;
    input.check_values()?;
    // Transient disturbances become gaps in both parts before anything else sees the record.
    let transients = if opts.keep_transients { Vec::new() } else { disturbances::find(input) };
    let masked_input;
    let original = input;
    let input = if transients.is_empty() {
        input
    } else {
        masked_input = disturbances::masked(input, &transients);
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
    let mut total_steps = 2 + opts.effects.len() + usize::from(predictive);
    let mut done = 0;
    progress("base fit", done, total_steps);

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
    done += 1;
    progress("base fit", done, total_steps);
    let base_eval = judge.evaluate(&base, &[], opts.channel.as_ref(), None, "base")?;
    done += 1;
    progress("base ensemble", done, total_steps);

    // The chain: rank the candidates on the model so far, add the best, go on while a significant gap remains.
    // The training samples each step learns from, less the realisations the steps before recovered.
    let gaps = gap_runs(training);
    let filled = fill_gaps(training);
    let mut series = filled.clone();
    // What the chain's steps recovered of their effects' realisations (`filled - series`); `None` before any.
    let mut realised: Option<Vec<f64>> = None;
    let temp_train = rec.training_temp();
    let mut steps: Vec<Step> = Vec::new();
    let mut first_candidates: Vec<CandidateResult> = Vec::new();
    let mut last_tried: Vec<CandidateResult> = Vec::new();
    let mut model = base_model.clone();
    let mut eval = base_eval.clone();
    loop {
        let first = steps.is_empty();
        let significant = rank::gap_of(&eval.training) > rank::SIGNIFICANT_GAP;
        if !first && (!significant || steps.len() >= MAX_STEPS) {
            break;
        }
        let location = rank::locate(&eval.training);
        let remaining: Vec<Effect> =
            opts.effects.iter().copied().filter(|e| !steps.iter().any(|s| s.effect == *e)).collect();
        if remaining.is_empty() {
            break;
        }
        if !first {
            total_steps += remaining.len();
        }
        let data = StepData::new(&model.gyro, &series, &gaps, temp_train, rate_hz, &base_fit, first);
        let training_data = data.training(&model.gyro, temp_train, rate_hz);
        let fits: Vec<(Effect, Option<EffectFit>)> =
            remaining.par_iter().map(|&e| (e, effects::estimate(e, &training_data))).collect();
        let mut candidates = Vec::with_capacity(fits.len());
        for (effect, fit) in fits {
            let eval = match &fit {
                Some(f) => {
                    let m = model.with(f);
                    let known = data.realised_with(realised.as_deref(), f);
                    let known = known.as_deref().or(realised.as_deref());
                    Some(judge.evaluate(&m.gyro, &m.spreads, m.channel.as_ref(), known, effect.name())?)
                }
                None => None,
            };
            candidates.push(CandidateResult::new(effect, fit, eval, location.as_ref()));
            done += 1;
            progress(effect.name(), done, total_steps);
        }
        let total_before = rank::total_of(&eval.training);
        let mut chosen = rank::choose(&candidates, total_before, location.as_ref());
        if first {
            first_candidates = candidates.clone();
        }
        // A later step whose best candidates explain too little alone get a second chance with the chain backfitted
        // around them: an effect read before the one under it took part of it (a bandwidth's corner read low
        // under a resonance), and the candidate on that model explains less than it would.
        let mut backfitted_step: Option<(Model, Vec<Option<EffectFit>>)> = None;
        if chosen.is_none() && !first && significant {
            let mut order: Vec<usize> = (0..candidates.len()).filter(|&i| candidates[i].score.is_some()).collect();
            order.sort_by(|&a, &b| {
                candidates[a].score.unwrap_or(f64::INFINITY).total_cmp(&candidates[b].score.unwrap_or(f64::INFINITY))
            });
            for &i in order.iter().take(SECOND_CHANCES) {
                let Some(f) = candidates[i].fit.clone() else { continue };
                let mut taken = series.clone();
                data.take_out(&mut taken, &f);
                let mut fits: Vec<&EffectFit> = steps.iter().map(Step::final_fit).collect();
                fits.push(&f);
                let (m, refits) = chain::backfit(&model.with(&f), &fits, &taken, &gaps, temp_train, rate_hz, &base_fit);
                if refits.iter().all(Option::is_none) {
                    continue;
                }
                let known = data.realised_with(realised.as_deref(), &f);
                let known = known.as_deref().or(realised.as_deref());
                let e = judge.evaluate(&m.gyro, &m.spreads, m.channel.as_ref(), known, f.effect.name())?;
                let fit = refits.last().cloned().flatten().unwrap_or(f);
                let c = CandidateResult::new(candidates[i].effect, Some(fit), Some(e), location.as_ref());
                total_steps += 1;
                done += 1;
                progress("backfit", done, total_steps);
                if rank::choose(std::slice::from_ref(&c), total_before, location.as_ref()).is_some() {
                    candidates[i] = c;
                    chosen = Some(i);
                    backfitted_step = Some((m, refits));
                    break;
                }
            }
        }
        let (Some(i), true, Some(loc)) = (chosen, significant, location) else {
            if !first {
                last_tried = candidates;
            }
            break;
        };
        let c = &candidates[i];
        let (Some(fit), Some(after)) = (c.fit.clone(), c.eval.clone()) else { break };
        let in_band = |v: &[compare::ViewGap]| rank::band_gap(v, &loc);
        let training_gap = PartGap::new(in_band(&eval.training).unwrap_or(0.0), c.gap_after.unwrap_or(0.0));
        let holdout_gap = in_band(&eval.holdout).map(|b| PartGap::new(b, c.holdout_after.unwrap_or(b)));
        if fit.cleaned.is_some() {
            data.take_out(&mut series, &fit);
            realised = Some(filled.iter().zip(&series).map(|(f, s)| f - s).collect());
        }
        let backfitted = backfitted_step.is_some();
        match backfitted_step {
            Some((m, refits)) => {
                for (s, r) in steps.iter_mut().zip(refits) {
                    if r.is_some() {
                        s.refit = r;
                    }
                }
                model = m;
            }
            None => model = model.with(&fit),
        }
        steps.push(Step {
            effect: c.effect,
            fit,
            eval: after.clone(),
            location: loc,
            training: training_gap,
            holdout: holdout_gap,
            candidates,
            refit: None,
            backfitted,
        });
        eval = after;
    }

    // A backfitting round over a chain of two or more whose last step had none: kept when the final model's
    // training total falls.
    if steps.len() >= 2 && !steps.last().is_some_and(|s| s.backfitted) {
        let fits: Vec<&EffectFit> = steps.iter().map(Step::final_fit).collect();
        let (refitted, refits) = chain::backfit(&model, &fits, &series, &gaps, temp_train, rate_hz, &base_fit);
        if refits.iter().any(Option::is_some) {
            let after = judge.evaluate(
                &refitted.gyro,
                &refitted.spreads,
                refitted.channel.as_ref(),
                realised.as_deref(),
                "backfit",
            )?;
            total_steps += 1;
            done += 1;
            progress("backfit", done, total_steps);
            if rank::total_of(&after.training) < rank::total_of(&eval.training) {
                for (s, r) in steps.iter_mut().zip(refits) {
                    if r.is_some() {
                        s.refit = r;
                    }
                }
                if let Some(last) = steps.last_mut() {
                    last.backfitted = true;
                }
                model = refitted;
                eval = after;
            }
        }
    }

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
                    let rounds: Vec<bool> = steps.iter().map(|s| s.backfitted).collect();
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
            done += 1;
            progress("holdout check", done, total_steps);
            Some((base_views.unwrap_or_else(|| base_eval.holdout.clone()), chain_views))
        }
        _ => None,
    };
    progress("done", total_steps, total_steps);
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

//! The diagnosis itself: the record made ready, the base model judged, the chain of effects ranked and learnt
//! step by step, the held-out checks computed, and the report assembled from them.

use super::base::{base_model, fit_base, training_adev};
use super::chain::{self, Model, Progress, ProgressFn};
use super::effects::Effect;
use super::error::GapError;
use super::input::{GapInput, GapOptions, HoldoutCheck, MIN_PART};
use super::judge::Judge;
use super::report::{self, GapReport};
use super::{holdout, transients};

/// Diagnose the gap between a record and the simulation of its fitted model (see the module doc of
/// [`crate`]).
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
    let masked = (!transients.is_empty()).then(|| transients::parts::masked(input, &transients));
    let missing = missing_samples(input);
    let input = masked.as_ref().unwrap_or(input);
    check_lengths(input)?;
    let (n_train, n_hold) = (input.n_train, input.n_holdout());
    let has_holdout = n_hold > 0;
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
    let start = chain::Start {
        judge: &judge,
        effects: &opts.effects,
        base: &base_model,
        base_eval: &base_eval,
        base_fit: &base_fit,
        training,
        temp: temp_train,
        rate_hz,
    };
    let found = chain::search(&start, &mut progress)?;
    // The backward step: each effect the views named, tried out of the chain learnt again without it.
    let mut relearn = |effects: &[Effect], rounds: &[chain::Rounds], stage: &str| {
        let (m, realised) = chain::learn(effects, rounds, &base_model, &base_fit, training, temp_train, rate_hz);
        progress.expect(stage, 1);
        let eval = judge.evaluate(&m.gyro, &m.spreads, m.channel.as_ref(), realised.as_deref(), stage)?;
        progress.tick(stage);
        Ok((m, eval))
    };
    let found = chain::prune(found, |effects, rounds| relearn(effects, rounds, "prune"))?;
    // The exchange: each effect the views named, tried against the runner-up of its own step.
    let found = chain::exchange(found, |effects, rounds| relearn(effects, rounds, "exchange"))?;

    // The held-out check against predictive ensembles (see [`holdout`]), of the base model and the whole chain.
    let predictive_views = if predictive {
        let learner = holdout::Learner {
            rate_hz,
            temp_c: temp_train,
            fit: &opts.fit,
            fixed_base: opts.base_fit.as_ref(),
            fallback: &base_fit,
            channel: opts.channel,
        };
        let views = holdout::predictive_views(&judge, &learner, &base, &base_eval.holdout, &found, n_train)?;
        progress.tick("holdout check");
        views
    } else {
        None
    };
    progress.done = progress.total;
    progress.expect("done", 0);
    let summary = report::InputSummary {
        rate_hz,
        quantity: opts.quantity,
        n_train,
        n_holdout: n_hold,
        missing,
        transients,
        seeds: opts.seeds,
        has_temperature: input.temp_c.is_some(),
        channel: opts.channel,
    };
    Ok(report::assemble(summary, (base, base_fit, base_eval, real_adev), found, predictive_views))
}

/// The samples missing from each part before any transient is masked: `[training, holdout]`.
fn missing_samples(input: &GapInput) -> [usize; 2] {
    let (train, hold) = input.rate_dps.split_at(input.n_train);
    [train, hold].map(|p| p.iter().filter(|v| v.is_nan()).count())
}

/// Whether each part keeps [`MIN_PART`] samples once its gaps are left out (a holdout may be empty).
fn check_lengths(input: &GapInput) -> Result<(), GapError> {
    let [train, hold] = missing_samples(input);
    let (n_train, n_hold) = (input.n_train, input.n_holdout());
    if n_train - train < MIN_PART {
        return Err(GapError::TooShort { part: "training", n: n_train, missing: train, needed: MIN_PART });
    }
    if n_hold > 0 && n_hold - hold < MIN_PART {
        return Err(GapError::TooShort { part: "holdout", n: n_hold, missing: hold, needed: MIN_PART });
    }
    Ok(())
}

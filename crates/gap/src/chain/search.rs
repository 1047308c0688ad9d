//! The search for the chain: each step ranks the remaining candidates on the model so far and adds the effect
//! the views or its own estimator name (see the module doc of [`crate::chain`]).

use std::ops::Range;
use std::rc::Rc;

use rayon::prelude::*;

use super::backfit::backfit;
use super::data::StepData;
use super::joint;
use super::model::{Model, NamedBy, Step, MAX_STEPS};
use crate::compare::ViewGap;
use crate::effects::{self, Effect, EffectFit, JumpScan};
use crate::error::GapError;
use crate::evidence;
use crate::fill::{fill_gaps, gap_runs};
use crate::judge::{Evaluated, Judge};
use crate::rank::{self, CandidateResult, Location, PartGap};
use octavar_stats::fit::NoiseFit;

/// Candidates of a later step that get a second chance with the chain backfitted around them, best score first.
const SECOND_CHANCES: usize = 2;

/// The best-scored candidates tried first in pairs when no single one explains the gap.
const PAIR_POOL: usize = 2;

/// Progress: `(stage, done, total)`, called after each ensemble.
pub type ProgressFn<'a> = dyn Fn(&str, usize, usize) + Sync + 'a;

/// Counts the ensembles run against the ones expected, for a progress bar.
pub(crate) struct Progress<'a> {
    report: &'a ProgressFn<'a>,
    /// Ensembles run.
    pub done: usize,
    /// Ensembles expected.
    pub total: usize,
}

impl<'a> Progress<'a> {
    /// A count of `total` expected ensembles, none run.
    pub fn new(report: &'a ProgressFn<'a>, total: usize) -> Self {
        Progress { report, done: 0, total }
    }

    /// One more ensemble run, of `stage`.
    pub fn tick(&mut self, stage: &str) {
        self.done += 1;
        self.total = self.total.max(self.done);
        (self.report)(stage, self.done, self.total);
    }

    /// `stage` begins, with `more` ensembles expected beyond those counted.
    pub fn expect(&mut self, stage: &str, more: usize) {
        self.total += more;
        (self.report)(stage, self.done, self.total);
    }
}

/// What the search found.
pub(crate) struct Found {
    /// The steps, in the order found.
    pub steps: Vec<Step>,
    /// The first step's candidates, in vocabulary order.
    pub first_candidates: Vec<CandidateResult>,
    /// The candidates tried on the chain's model when none explained what it left.
    pub last_tried: Vec<CandidateResult>,
    /// The final model.
    pub model: Model,
    /// Its comparison with the record.
    pub eval: Evaluated,
    /// The effects the backward step took out of the chain, in the order taken ([`super::prune`]).
    pub pruned: Vec<super::Pruned>,
    /// The effect the exchange step traded for another candidate of its step ([`super::exchange`]).
    pub exchanged: Vec<super::Exchanged>,
    /// Where the greedy chain left a significant gap and the chain searched again from the first ranking's
    /// runner-up explained it better: what the greedy chain had found.
    pub retried: Option<Retried>,
}

/// The greedy chain given up for one searched from another first step ([`search`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Retried {
    /// The greedy chain's effects, in the order found.
    pub greedy: Vec<Effect>,
    /// Its views' training total and worst view's gap.
    pub greedy_total: f64,
    /// Its worst view's gap, training.
    pub greedy_worst: f64,
    /// The first step the kept chain was searched from: the runner-up of the first ranking.
    pub first: Effect,
}

/// The search's fixed inputs and its state between steps.
struct Search<'a, 'p> {
    judge: &'a Judge<'a>,
    base_fit: &'a NoiseFit,
    temp: Option<&'a [f64]>,
    rate_hz: f64,
    /// The runs of missing or masked training samples.
    gaps: Vec<Range<usize>>,
    /// The training samples, gaps filled (shared: the estimators read them beside the search's own state).
    filled: Rc<[f64]>,
    progress: &'a mut Progress<'p>,
    /// The training samples less the realisations the steps so far recovered (what the next step learns from).
    series: Vec<f64>,
    /// What the steps recovered of their effects' realisations (`filled - series`); `None` before any.
    realised: Option<Vec<f64>>,
    /// The part of `realised` that the sensor's filter shapes ([`StepData::shaped_with`]); `None` before any.
    shaped: Option<Vec<f64>>,
    steps: Vec<Step>,
    model: Model,
    eval: Evaluated,
}

/// What a search starts from: the effects it may name, the base model and its comparison, and the training
/// samples it learns from.
pub(crate) struct Start<'a> {
    /// The comparison every model is judged by.
    pub judge: &'a Judge<'a>,
    /// The vocabulary the chain names from.
    pub effects: &'a [Effect],
    /// The base model and its comparison with the record.
    pub base: &'a Model,
    pub base_eval: &'a Evaluated,
    /// The IEEE fit the base model was made from.
    pub base_fit: &'a NoiseFit,
    /// The training samples (gaps as NaN) and their temperature.
    pub training: &'a [f64],
    pub temp: Option<&'a [f64]>,
    pub rate_hz: f64,
}

/// The chain found from `start`: the greedy chain, or where it leaves a significant gap, the chain from the first
/// ranking's runner-up where that explains the gap better (the module doc of [`super`]).
///
/// # Errors
/// [`GapError::Sim`]: the simulator rejects a candidate's model.
pub(crate) fn search(start: &Start, progress: &mut Progress) -> Result<Found, GapError> {
    let found = greedy(start, progress, None)?;
    // The greedy chain leaves a significant gap: its first step may have taken part of two effects' gap (bias steps
    // drawn over a telegraph and its spikes), so the chain is searched again from the runner-up of the first
    // ranking, and kept where it explains what the greedy one left.
    let Some(first) = found.steps.first().filter(|s| matches!(s.named_by, NamedBy::View)) else { return Ok(found) };
    if rank::gap_of(&found.eval.training) <= rank::SIGNIFICANT_GAP {
        return Ok(found);
    }
    let base_total = rank::total_of(&start.base_eval.training);
    let Some(alt) = by_score(&found.first_candidates)
        .into_iter()
        .map(|i| &found.first_candidates[i])
        .find(|c| c.effect != first.effect && c.score.is_some_and(|sc| rank::explains(sc, base_total)))
        .map(|c| c.effect)
    else {
        return Ok(found);
    };
    let mut other = greedy(start, progress, Some(alt))?;
    let score = |f: &Found| rank::score(rank::total_of(&f.eval.training), f.steps.iter().map(|s| s.fit.n_params).sum());
    if !rank::explains(score(&other), score(&found)) {
        return Ok(found);
    }
    other.retried = Some(Retried {
        greedy: found.steps.iter().map(|s| s.effect).collect(),
        greedy_total: rank::total_of(&found.eval.training),
        greedy_worst: rank::gap_of(&found.eval.training),
        first: alt,
    });
    Ok(other)
}

/// The greedy search from `start`: each step adds the effect that explains most of the gap on the model so far;
/// `forced_first`, where given, is the first step's effect (from the first ranking) in place of the best-scored.
fn greedy(start: &Start, progress: &mut Progress, forced_first: Option<Effect>) -> Result<Found, GapError> {
    let Start { judge, effects, base, base_eval, base_fit, training, temp, rate_hz } = *start;
    let filled = fill_gaps(training);
    let mut s = Search {
        judge,
        base_fit,
        temp,
        rate_hz,
        gaps: gap_runs(training),
        series: filled.clone(),
        filled: filled.into(),
        progress,
        realised: None,
        shaped: None,
        steps: Vec::new(),
        model: base.clone(),
        eval: base_eval.clone(),
    };
    let mut first_candidates = Vec::new();
    let mut last_tried = Vec::new();
    // The chain's length when a joint round was last tried on a stuck chain (once a length).
    let mut jointly_at = None;
    while s.steps.len() < MAX_STEPS {
        let first = s.steps.is_empty();
        let significant = rank::gap_of(&s.eval.training) > rank::SIGNIFICANT_GAP;
        let remaining: Vec<Effect> =
            effects.iter().copied().filter(|e| !s.steps.iter().any(|st| st.effect == *e)).collect();
        let Some(location) = rank::locate(&s.eval.training) else { break };
        if remaining.is_empty() {
            break;
        }
        let data = s.step_data(first);
        // The views' route (the first step always ranks the candidates, for the report).
        let mut candidates = Vec::new();
        if first || significant {
            candidates = s.rank(&remaining, &data, &location)?;
            if first {
                first_candidates = candidates.clone();
                if let Some(i) = forced_first.and_then(|e| candidates.iter().position(|c| c.effect == e)) {
                    if let (Some(fit), Some(after)) = (candidates[i].fit.clone(), candidates[i].eval.clone()) {
                        s.model = s.model.with(&fit);
                        s.add(&data, fit, after, candidates.clone(), &location, NamedBy::View, None);
                        continue;
                    }
                }
            }
            if significant && s.view_step(&data, &mut candidates, &location, first)? {
                last_tried.clear();
                continue;
            }
            if !first {
                last_tried = candidates.clone();
            }
        }
        // The estimators' route.
        let ranked = candidates.clone();
        if s.evidence_step(&remaining, &data, candidates, &location, first.then_some(&mut first_candidates))? {
            last_tried.clear();
            continue;
        }
        // The views' route with a named jump process's jumps taken out of record and members alike.
        if !first && s.less_jumps_step(&remaining, &data, &ranked, &location)? {
            last_tried.clear();
            continue;
        }
        // Stuck beside a significant gap: the chain's effects and the base terms, each read with only the steps
        // before it in place, may be what is off (a white noise the base fit read with a sinusoid still in the
        // samples). Re-estimated together, every route is tried once more on that model.
        if significant && !first && jointly_at != Some(s.steps.len()) {
            jointly_at = Some(s.steps.len());
            if s.joint_round()? {
                continue;
            }
        }
        break;
    }
    s.final_backfit()?;
    if !s.steps.is_empty() {
        s.joint_round()?;
    }
    let (steps, model, eval) = (s.steps, s.model, s.eval);
    Ok(Found {
        steps,
        first_candidates,
        last_tried,
        model,
        eval,
        pruned: Vec::new(),
        exchanged: Vec::new(),
        retried: None,
    })
}

impl Search<'_, '_> {
    /// What this step's estimators learn from.
    fn step_data(&self, first: bool) -> StepData {
        let (model, shaped) = (&self.model.gyro, self.shaped.as_deref());
        StepData::new(model, &self.series, shaped, &self.gaps, self.temp, self.rate_hz, self.base_fit, first)
    }

    /// The realisations known on the model with `fit` added to this step's model (`data` its data).
    fn known_with(&self, data: &StepData, fit: &EffectFit) -> Option<Vec<f64>> {
        data.realised_with(self.realised.as_deref(), fit).or_else(|| self.realised.clone())
    }

    /// `m` compared with the record (`known`: the realisations recovered so far), one ensemble.
    fn evaluate(&mut self, m: &Model, known: Option<&[f64]>, stage: &str) -> Result<Evaluated, GapError> {
        let e = self.judge.evaluate(&m.gyro, &m.spreads, m.channel.as_ref(), known, stage)?;
        self.progress.tick(stage);
        Ok(e)
    }

    /// Every remaining effect estimated on `data`, added to the model and compared with the record.
    fn rank(
        &mut self,
        remaining: &[Effect],
        data: &StepData,
        location: &Location,
    ) -> Result<Vec<CandidateResult>, GapError> {
        if !self.steps.is_empty() {
            self.progress.expect("chain", remaining.len());
        }
        let training =
            data.training(&self.filled, &self.model.gyro, self.model.channel.as_ref(), self.temp, self.rate_hz);
        let fits: Vec<(Effect, Option<EffectFit>)> =
            remaining.par_iter().map(|&e| (e, effects::fit_effect(e, &training))).collect();
        let mut candidates = Vec::with_capacity(fits.len());
        for (effect, fit) in fits {
            let eval = match &fit {
                Some(f) => {
                    let m = self.model.with(f);
                    let known = self.known_with(data, f);
                    Some(self.evaluate(&m, known.as_deref(), effect.name())?)
                }
                None => None,
            };
            candidates.push(CandidateResult::new(effect, fit, eval, Some(location)));
        }
        Ok(candidates)
    }

    /// The views' route: the candidate that explains the significant gap, alone, with the chain backfitted
    /// around it (a later step), or in a pair; adds its step (two for a pair) and says whether it did.
    fn view_step(
        &mut self,
        data: &StepData,
        candidates: &mut [CandidateResult],
        location: &Location,
        first: bool,
    ) -> Result<bool, GapError> {
        let total_before = rank::total_of(&self.eval.training);
        if let Some(i) = rank::choose(candidates, total_before, Some(location)) {
            let (Some(fit), Some(after)) = (candidates[i].fit.clone(), candidates[i].eval.clone()) else {
                return Ok(false);
            };
            self.model = self.model.with(&fit);
            self.add(data, fit, after, candidates.to_vec(), location, NamedBy::View, None);
            return Ok(true);
        }
        if !first {
            if let Some((i, model, refits)) = self.second_chance(data, candidates, location, total_before)? {
                let (Some(fit), Some(after)) = (candidates[i].fit.clone(), candidates[i].eval.clone()) else {
                    return Ok(false);
                };
                self.model = model;
                self.add(data, fit, after, candidates.to_vec(), location, NamedBy::View, Some(refits));
                if let Some(last) = self.steps.last_mut() {
                    last.backfitted = true;
                }
                return Ok(true);
            }
        }
        self.pair_step(data, candidates, location, total_before)
    }

    /// A later step whose best candidates explain too little alone: each gets a second chance with the chain
    /// backfitted around it (an effect read before the one under it took part of it: a bandwidth's corner read
    /// low under a resonance). Returns the index of the candidate that then explains the gap (its entry replaced
    /// by the backfitted one), the backfitted model and the earlier steps' refits.
    #[allow(clippy::type_complexity)]
    fn second_chance(
        &mut self,
        data: &StepData,
        candidates: &mut [CandidateResult],
        location: &Location,
        total_before: f64,
    ) -> Result<Option<(usize, Model, Vec<Option<EffectFit>>)>, GapError> {
        for i in by_score(candidates).into_iter().take(SECOND_CHANCES) {
            let Some(f) = candidates[i].fit.clone() else { continue };
            let mut taken = self.series.clone();
            data.take_out(&mut taken, &f);
            let mut fits: Vec<&EffectFit> = self.steps.iter().map(Step::final_fit).collect();
            fits.push(&f);
            let shaped = data.shaped_with(self.shaped.as_deref(), &f);
            let (m, refits) = backfit(
                &self.model.with(&f),
                &fits,
                &self.filled,
                &taken,
                shaped.as_deref(),
                &self.gaps,
                self.temp,
                self.rate_hz,
                self.base_fit,
            );
            if refits.iter().all(Option::is_none) {
                continue;
            }
            let known = self.known_with(data, &f);
            self.progress.expect("backfit", 1);
            let e = self.evaluate(&m, known.as_deref(), f.effect.name())?;
            let fit = refits.last().cloned().flatten().unwrap_or(f);
            let c = CandidateResult::new(candidates[i].effect, Some(fit), Some(e), Some(location));
            if rank::choose(std::slice::from_ref(&c), total_before, Some(location)).is_some() {
                candidates[i] = c;
                let earlier = refits[..refits.len() - 1].to_vec();
                return Ok(Some((i, m, earlier)));
            }
        }
        Ok(None)
    }

    /// Two effects that share the gap, neither removing a quarter of it alone: each candidate of [`pair_pool`]
    /// first, and every other effect estimated on the model with it (the first's realisation taken out); the best
    /// pair that explains the gap (the parameters of both paid for) is added as two steps. A second effect whose
    /// part of the gap the first hid from every view (outliers diluted by a sinusoid the base fit read as white
    /// noise) need not score well alone to be found.
    fn pair_step(
        &mut self,
        data: &StepData,
        candidates: &[CandidateResult],
        location: &Location,
        total_before: f64,
    ) -> Result<bool, GapError> {
        let pool = pair_pool(candidates, &self.eval.training);
        let mut best: Option<(f64, usize, EffectFit, Evaluated)> = None;
        for (k, &i) in pool.iter().enumerate() {
            let Some(a) = candidates[i].fit.as_ref() else { continue };
            let with_a = self.model.with(a);
            let mut series_a = self.series.clone();
            data.take_out(&mut series_a, a);
            let known_a = self.known_with(data, a);
            let shaped_a = data.shaped_with(self.shaped.as_deref(), a);
            let data_a = StepData::new(
                &with_a.gyro,
                &series_a,
                shaped_a.as_deref(),
                &self.gaps,
                self.temp,
                self.rate_hz,
                self.base_fit,
                false,
            );
            let recorded = Rc::clone(&self.filled);
            let training_a = data_a.training(&recorded, &with_a.gyro, with_a.channel.as_ref(), self.temp, self.rate_hz);
            // The second: every other effect, learnt on the model with the first (one the first hid may show now),
            // but for the firsts already tried with this one.
            for j in (0..candidates.len()).filter(|&j| j != i && !pool[..k].contains(&j)) {
                let Some(b) = effects::fit_effect(candidates[j].effect, &training_a) else { continue };
                let m = with_a.with(&b);
                let known = data_a.realised_with(known_a.as_deref(), &b).or_else(|| known_a.clone());
                self.progress.expect("pair", 1);
                let e = self.evaluate(&m, known.as_deref(), b.effect.name())?;
                let score = rank::score(rank::total_of(&e.training), a.n_params + b.n_params);
                if rank::explains(score, total_before) && best.as_ref().is_none_or(|(s, ..)| score < *s) {
                    best = Some((score, i, b, e));
                }
            }
        }
        let Some((_, i, b, e)) = best else { return Ok(false) };
        let (Some(a), Some(a_eval)) = (candidates[i].fit.clone(), candidates[i].eval.clone()) else {
            return Ok(false);
        };
        self.model = self.model.with(&a);
        self.add(data, a, a_eval, candidates.to_vec(), location, NamedBy::View, None);
        // The second step learns from the samples less the first's realisation, on the model with it.
        let data_b = self.step_data(false);
        let c = CandidateResult::new(b.effect, Some(b.clone()), Some(e.clone()), Some(location));
        self.model = self.model.with(&b);
        self.add(&data_b, b, e, vec![c], location, NamedBy::View, None);
        Ok(true)
    }

    /// The estimators' route: the remaining effect whose own test names it most strongly beyond its calibrated
    /// threshold, added when the views find the model with it no worse (the next strongest tried where not); says
    /// whether it added one. `candidates`
    /// are the step's ranking where it ranked (their fits are reused), and `first_candidates` the report's first
    /// ranking when this is the first step.
    fn evidence_step(
        &mut self,
        remaining: &[Effect],
        data: &StepData,
        mut candidates: Vec<CandidateResult>,
        location: &Location,
        first_candidates: Option<&mut Vec<CandidateResult>>,
    ) -> Result<bool, GapError> {
        let training =
            data.training(&self.filled, &self.model.gyro, self.model.channel.as_ref(), self.temp, self.rate_hz);
        let significant = rank::gap_of(&self.eval.training) > rank::SIGNIFICANT_GAP;
        let mut chosen = None;
        for mut fit in
            evidence::named(remaining, |e| candidates.iter().find(|c| c.effect == e).map(|c| c.fit.clone()), &training)
        {
            let Some(ev) = evidence::of(&fit) else { continue };
            let m = self.model.with(&fit);
            let known = self.known_with(data, &fit);
            self.progress.expect("evidence", 1);
            let mut after = self.evaluate(&m, known.as_deref(), fit.effect.name())?;
            let mut m = m;
            // Named on its own test, it must still leave the views no worse than it found them, or in agreement
            // ([`evidence::still_agrees`]), and a curve's test beside a significant gap must take that gap below
            // significance.
            let before = rank::total_of(&self.eval.training);
            let mut worse = self.worse_than_now(&after, location);
            // The estimator refitted the base terms alone beside its effect, on a curve whose other effects it took
            // as known; where that leaves the views worse, the model's stochastic terms re-estimated together with
            // the new effect in place may not.
            if worse {
                if let Some(j) = self.reestimated(&m) {
                    self.progress.expect("evidence", 1);
                    let joint = self.evaluate(&j, known.as_deref(), fit.effect.name())?;
                    if !self.worse_than_now(&joint, location) {
                        fit = EffectFit { params: fit.params.reestimated(&j.gyro), gyro: j.gyro.clone(), ..fit };
                        (m, after, worse) = (j, joint, false);
                    }
                }
            }
            // Evidence far beyond its threshold names the effect wherever the views still agree with the record.
            if worse {
                let significant_after = rank::gap_of(&after.training) > rank::SIGNIFICANT_GAP;
                worse = !evidence::names_whatever_the_band(&ev, rank::total_of(&after.training), significant_after);
            }
            let clears = rank::band_gap(&after.training, location).is_some_and(|g| g < rank::SIGNIFICANT_GAP);
            // A curve's test names an effect only where the views find the model with it better: beside a
            // significant gap, below significance in the gap's band; elsewhere, a total lower by more than the
            // ensemble's draw moves it (a filter corner read into a Gauss-Markov process's roll-off lowers the
            // curve's chi-square and nothing else), or, for a bump, a model before it already in agreement.
            let curve_test = evidence::needs_a_fitting_model(fit.effect);
            let better = evidence::VIEWS_TOLERANCE * rank::total_of(&after.training) < before
                || (before <= evidence::AGREEMENT_TOTAL && evidence::curve_test_names_beside_agreement(fit.effect));
            if worse || (curve_test && if significant { !clears } else { !better }) {
                continue;
            }
            chosen = Some((fit, ev, m, after));
            break;
        }
        let Some((fit, ev, m, after)) = chosen else { return Ok(false) };
        let c = CandidateResult::new(fit.effect, Some(fit.clone()), Some(after.clone()), Some(location));
        match candidates.iter_mut().find(|x| x.effect == fit.effect) {
            Some(x) => *x = c,
            None => candidates.push(c),
        }
        if let Some(f) = first_candidates {
            *f = candidates.clone();
        }
        self.model = m;
        self.add(data, fit, after, candidates, location, NamedBy::Estimator(ev), None);
        Ok(true)
    }

    /// Whether the views find `e` worse than the model so far: its training total beyond
    /// [`evidence::VIEWS_TOLERANCE`] times the model's (and beyond [`evidence::AGREEMENT_TOTAL`]), unless it keeps
    /// the band `location` no worse and still agrees with the record ([`evidence::still_agrees`]).
    fn worse_than_now(&self, e: &Evaluated, location: &Location) -> bool {
        let before = rank::total_of(&self.eval.training);
        let allowed = (evidence::VIEWS_TOLERANCE * before).max(evidence::AGREEMENT_TOTAL);
        let total = rank::total_of(&e.training);
        let band_kept = match (rank::band_gap(&self.eval.training, location), rank::band_gap(&e.training, location)) {
            (Some(b), Some(a)) => a <= evidence::VIEWS_TOLERANCE * b,
            _ => false,
        };
        total > allowed
            && !(band_kept && evidence::still_agrees(total, rank::gap_of(&e.training) > rank::SIGNIFICANT_GAP))
    }

    /// The route beside a named jump process (the chain's module doc): where the chain took a bistable bias's or
    /// bias steps' realisation out, the record and every member of the model so far are compared with their jumps
    /// found and taken out by the process's own scan ([`Judge::less_jumps`]); where that comparison leaves a
    /// significant gap that the base terms read again on the samples less the jumps do not take below
    /// significance, each remaining effect, estimated on this step's data (the fits of `candidates` reused), is
    /// judged the same way, and the best that explains the gap ([`rank::explains`]) and leaves the plain views no
    /// worse ([`Self::worse_than_now`]) is added. Says whether it added one.
    fn less_jumps_step(
        &mut self,
        remaining: &[Effect],
        data: &StepData,
        candidates: &[CandidateResult],
        location: &Location,
    ) -> Result<bool, GapError> {
        let scans: Vec<JumpScan> =
            self.steps.iter().filter_map(|st| JumpScan::of(st.final_fit(), &self.filled, self.rate_hz)).collect();
        if scans.is_empty() {
            return Ok(false);
        }
        let less = |x: &mut [f64]| scans.iter().for_each(|sc| sc.take_out(x));
        let real = self.judge.training_less(&less);
        self.progress.expect("less jumps", 1);
        let (gyro, spreads, channel) = (&self.model.gyro, &self.model.spreads, self.model.channel.as_ref());
        let before = self.judge.less_jumps(gyro, spreads, channel, &less, &real, "chain")?;
        self.progress.tick("less jumps");
        let gap_before = rank::gap_of(&before);
        if gap_before <= rank::SIGNIFICANT_GAP {
            return Ok(false);
        }
        // The base terms read again on the samples less the jumps: where they alone take the gap below
        // significance, it is theirs (a telegraph's joint curve fit reads the flicker beneath it as none), not a
        // hidden effect's.
        let mut refit = data.base_fit.sim_terms(self.model.gyro.clone());
        if self.model.channel.is_some() {
            refit.q_deg = self.model.gyro.q_deg;
        }
        self.progress.expect("less jumps", 1);
        let null =
            self.judge.less_jumps(&refit, &self.model.spreads, self.model.channel.as_ref(), &less, &real, "base")?;
        self.progress.tick("less jumps");
        if rank::gap_of(&null) <= rank::SIGNIFICANT_GAP {
            return Ok(false);
        }
        let total_before = rank::total_of(&before);
        let training =
            data.training(&self.filled, &self.model.gyro, self.model.channel.as_ref(), self.temp, self.rate_hz);
        let fits: Vec<EffectFit> = remaining
            .par_iter()
            .filter_map(|&e| match candidates.iter().find(|c| c.effect == e) {
                Some(c) => c.fit.clone(),
                None => effects::fit_effect(e, &training),
            })
            .collect();
        self.progress.expect("less jumps", fits.len());
        let mut best: Option<(f64, EffectFit, Vec<ViewGap>)> = None;
        for fit in fits {
            let m = self.model.with(&fit);
            let after =
                self.judge.less_jumps(&m.gyro, &m.spreads, m.channel.as_ref(), &less, &real, fit.effect.name())?;
            self.progress.tick("less jumps");
            let score = rank::score(rank::total_of(&after), fit.n_params);
            if rank::explains(score, total_before) && best.as_ref().is_none_or(|(s, ..)| score < *s) {
                best = Some((score, fit, after));
            }
        }
        let Some((_, fit, less_after)) = best else { return Ok(false) };
        let m = self.model.with(&fit);
        let known = self.known_with(data, &fit);
        self.progress.expect("less jumps", 1);
        let after = self.evaluate(&m, known.as_deref(), fit.effect.name())?;
        if self.worse_than_now(&after, location) {
            return Ok(false);
        }
        let named_by = NamedBy::ViewsLessJumps { gap_before, gap_after: rank::gap_of(&less_after) };
        let c = CandidateResult::new(fit.effect, Some(fit.clone()), Some(after.clone()), Some(location));
        self.model = m;
        self.add(data, fit, after, vec![c], location, named_by, None);
        Ok(true)
    }

    /// Add a step whose model is already `self.model`: `fit` learnt from `data`, `after` its comparison, its
    /// realisation (if it recovered one) taken out of what the next step learns from, and where a backfitting
    /// round chose it, each earlier step's refit.
    #[allow(clippy::too_many_arguments)]
    fn add(
        &mut self,
        data: &StepData,
        fit: EffectFit,
        after: Evaluated,
        candidates: Vec<CandidateResult>,
        location: &Location,
        named_by: NamedBy,
        refits: Option<Vec<Option<EffectFit>>>,
    ) {
        let chosen = candidates.iter().find(|c| c.effect == fit.effect);
        let gap_after = chosen.and_then(|c| c.gap_after).unwrap_or(0.0);
        let holdout_after = chosen.and_then(|c| c.holdout_after);
        let training = PartGap::new(rank::band_gap(&self.eval.training, location).unwrap_or(0.0), gap_after);
        let holdout = rank::band_gap(&self.eval.holdout, location).map(|b| PartGap::new(b, holdout_after.unwrap_or(b)));
        if fit.cleaned.is_some() {
            self.shaped = data.shaped_with(self.shaped.as_deref(), &fit);
            data.take_out(&mut self.series, &fit);
            self.realised = Some(self.filled.iter().zip(&self.series).map(|(f, s)| f - s).collect());
        }
        for (s, r) in self.steps.iter_mut().zip(refits.into_iter().flatten()) {
            if r.is_some() {
                s.refit = r;
            }
        }
        self.steps.push(Step {
            effect: fit.effect,
            named_by,
            fit,
            eval: after.clone(),
            location: location.clone(),
            training,
            holdout,
            candidates,
            refit: None,
            backfitted: false,
            joint: false,
        });
        self.eval = after;
    }

    /// A joint re-estimation of the chain's model ([`joint::reestimate`]): the base terms and every effect so far
    /// fitted together on the training samples less the recovered realisations, kept when the views find the
    /// model no worse; each step's parameters are then read from it. Says whether it was kept.
    fn joint_round(&mut self) -> Result<bool, GapError> {
        let shaped = self.shaped.as_deref();
        let Some(m) = joint::reestimate(&self.model, &self.series, shaped, &self.gaps, self.temp, self.rate_hz) else {
            return Ok(false);
        };
        self.progress.expect("joint", 1);
        let realised = self.realised.clone();
        let after = self.evaluate(&m, realised.as_deref(), "joint")?;
        if rank::total_of(&after.training) > rank::total_of(&self.eval.training) {
            return Ok(false);
        }
        for s in self.steps.iter_mut() {
            s.refit = Some(s.final_fit().reestimated(&m.gyro));
        }
        if let Some(last) = self.steps.last_mut() {
            last.joint = true;
        }
        self.model = m;
        self.eval = after;
        Ok(true)
    }

    /// `m` jointly re-estimated ([`joint::reestimate`]) on the training samples less the realisations the chain
    /// recovered; `None` where nothing changes.
    fn reestimated(&self, m: &Model) -> Option<Model> {
        joint::reestimate(m, &self.series, self.shaped.as_deref(), &self.gaps, self.temp, self.rate_hz)
    }

    /// A backfitting round over a chain of two or more whose last step had none: kept when the final model's
    /// training total falls.
    fn final_backfit(&mut self) -> Result<(), GapError> {
        if self.steps.len() < 2 || self.steps.last().is_some_and(|s| s.backfitted) {
            return Ok(());
        }
        let fits: Vec<&EffectFit> = self.steps.iter().map(Step::final_fit).collect();
        let (refitted, refits) = backfit(
            &self.model,
            &fits,
            &self.filled,
            &self.series,
            self.shaped.as_deref(),
            &self.gaps,
            self.temp,
            self.rate_hz,
            self.base_fit,
        );
        if refits.iter().all(Option::is_none) {
            return Ok(());
        }
        self.progress.expect("backfit", 1);
        let realised = self.realised.clone();
        let after = self.evaluate(&refitted, realised.as_deref(), "backfit")?;
        if rank::total_of(&after.training) < rank::total_of(&self.eval.training) {
            for (s, r) in self.steps.iter_mut().zip(refits) {
                if r.is_some() {
                    s.refit = r;
                }
            }
            if let Some(last) = self.steps.last_mut() {
                last.backfitted = true;
            }
            self.model = refitted;
            self.eval = after;
        }
        Ok(())
    }
}

/// The candidates tried first in pairs: the [`PAIR_POOL`] best-scored, and for each view the one that takes the most
/// of its gap (`before`, the views of the model so far) where it takes a quarter or more. Two effects that share
/// the gap each take their own view's part and leave the other's, so neither need score well alone: a bistable
/// bias beside a strong sinusoid clears the distribution view and leaves the spectrum's line, and scores behind
/// effects that touch nothing.
fn pair_pool(candidates: &[CandidateResult], before: &[ViewGap]) -> Vec<usize> {
    let mut pool: Vec<usize> = by_score(candidates).into_iter().take(PAIR_POOL).collect();
    for v in before {
        let after = |c: &CandidateResult| {
            c.eval.as_ref()?.training.iter().find(|w| w.view == v.view).map(|w| w.gap).filter(|g| g.is_finite())
        };
        let best = (0..candidates.len())
            .filter_map(|i| Some((i, after(&candidates[i])?)))
            .filter(|&(_, g)| g < PAIR_VIEW_SHARE * v.gap && v.gap > rank::SIGNIFICANT_GAP)
            .min_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((i, _)) = best {
            if !pool.contains(&i) && candidates[i].score.is_some() {
                pool.push(i);
            }
        }
    }
    // The better-scored of each pair goes first.
    pool.sort_by(|&a, &b| {
        candidates[a].score.unwrap_or(f64::INFINITY).total_cmp(&candidates[b].score.unwrap_or(f64::INFINITY))
    });
    pool
}

/// The share of a significant view's gap a candidate must leave at most to join the pairs for that view.
const PAIR_VIEW_SHARE: f64 = 0.75;

/// The indices of the candidates that have a score, best (lowest) first.
pub(super) fn by_score(candidates: &[CandidateResult]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..candidates.len()).filter(|&i| candidates[i].score.is_some()).collect();
    order.sort_by(|&a, &b| {
        candidates[a].score.unwrap_or(f64::INFINITY).total_cmp(&candidates[b].score.unwrap_or(f64::INFINITY))
    });
    order
}

//! The diagnosis as a result: the chain of effects, where each gap lay, what each candidate bought on training and
//! held-out data, what is left unexplained; as text for a person and as the JSON document scripts read.
//!
//! JSON keys (stable; scripts rely on them), in [`Document`]: `effect` (the chain's first effect, a vocabulary
//! name, or `none`), `view`, `band_s` `[lo, hi]`, `sign` (`above`/`below`), `gap_before`, `gap_after`, `shrink`,
//! `holdout` `{gap_before, gap_after, shrink, shrink_if_right}` (all of the first effect, at the base model's
//! located band), `candidates` `[{effect, params, gap_after, shrink, ...}]` (the first step's ranking), `model`
//! (the base model with every effect of the chain, as a `model.toml` channel's `gyro`), `effect_params` (the first
//! effect's). The chain: `effects` `[{effect, params, view, band_s, sign, gap_before, gap_after, holdout:
//! {gap_before, gap_after}, backfitted, found_params, evidence}]` in the order found (`params` as the final model carries
//! them; where a backfitting round estimated the effect again, `backfitted` is true and `found_params` are the
//! step's first values; the gaps are the step's own; `evidence` is `{"route": "view"}` or, where the effect's
//! estimator named it and no view's gap did, `{"route": "estimator", "statistic", "value", "threshold"}`), and `holdout_total` `{gap_before, gap_after, shrink}`, the
//! largest held-out gap over the chain's located bands, of the base model and of the whole chain, every
//! parameter frozen. Also:
//! `transients` `[{part, start_s, duration_s, peak_dps}]` (the disturbances masked as gaps, `start_s` from the
//! start of their part), `verdict` (`no_gap`, `explained`, `unexplained`), `unexplained` (what the gap left after the chain looks like),
//! `fit_strain` (the base fit's reduced chi-square when it is far above 1), `size`, `significant`, `explained`,
//! `threshold`, `total_before`, `total_after`, `base_model`, `base_fit`, `views` (every view's gap on both parts,
//! base and chain), `worst`, `views_detail`, `n_train`, `n_holdout`, `missing_samples` `{training, holdout}`,
//! `fs_hz` (the sample rate), `seeds`, `pruned` `[{effect, total_with, total_without}]` (the effects the views
//! named that a later one made redundant, taken out of the chain: the views' training totals with and without); in
//! `chain`, `retried` `{greedy, greedy_total, greedy_worst, first}` where the greedy chain left a significant gap and
//! the chain searched again from the first ranking's runner-up (`first`) explained it better (null otherwise), and
//! `exchanged` `[{effect, replacement, total_with, total_after}]` (an effect the views named traded for the
//! best-scored other candidate of its step: the views' training totals of the chain before and after); `holdout_predictive` `{gap_before, gap_after, shrink, worst}` with
//! [`super::input::HoldoutCheck::Predictive`] (null without).
//!
//! The report itself ([`GapReport`]) is nested: the record as diagnosed ([`InputSummary`]), the base model
//! ([`BaseResult`]), the chain ([`ChainResult`]) and the held-out checks ([`HoldoutResult`]), beside the first
//! effect's headline figures. This module holds those types, their assembly from what the diagnosis found and the
//! accessors both writers share; `text` writes the report a person reads, `json` the document scripts read.

mod json;
mod text;

use octavar_shared::sensor::Channel;
use octavar_shared::sim::GyroSim;
use serde::Serialize;

pub use json::Document;

use super::chain::{Found, Model, Step};
use super::compare::ViewGap;
use super::describe::{shape_of, GapShape};
use super::effects::Effect;
use super::holdout::PredictiveViews;
use super::judge::Evaluated;
use super::rank::{self, CandidateResult, Location, PartGap};
use super::transients::{self, Masked};
use octavar_stats::fit::NoiseFit;
use octavar_stats::quantity::Quantity;
use octavar_stats::DevPoint;

/// The base fit's reduced chi-square above which the report says the IEEE five-term model cannot follow the
/// training curve (its 3% model allowance included, a fit that can scores about 1).
pub const FIT_STRAIN: f64 = 10.0;

/// The diagnosis, in four sections (the record as diagnosed, the base model, the chain of effects, the held-out
/// checks) and the headline figures of the first effect.
#[derive(Clone, Debug)]
pub struct GapReport {
    /// The record as the diagnosis saw it.
    pub input: InputSummary,
    /// The base model and its comparison.
    pub base: BaseResult,
    /// The chain of effects and the final model.
    pub chain: ChainResult,
    /// The held-out checks (every field `None` or NaN without a holdout).
    pub holdout: HoldoutResult,
    /// Training gap at the base's located band, before and after the first effect.
    pub training: PartGap,
    /// The worst view's gap on each part, of the base model and of the whole chain: `[training base, training
    /// chain, holdout base, holdout chain]` (the holdout's NaN without one).
    pub worst: [f64; 4],
    /// Totals (RMS over views) on training, base and chain.
    pub total: [f64; 2],
}

/// The record as the diagnosis saw it.
#[derive(Clone, Debug)]
pub struct InputSummary {
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// What the record measures: a gyro's figures are in deg/s, an accelerometer's in m/s^2 (the diagnosis is the
    /// same; the names of the units differ).
    pub quantity: Quantity,
    /// Training samples.
    pub n_train: usize,
    /// Held-out samples.
    pub n_holdout: usize,
    /// Gaps (NaN samples: empty cells, NaN text, time jumps) in the training part and in the holdout. The views
    /// leave them out, every ensemble member has the same ones, and the estimators see them filled linearly.
    pub missing: [usize; 2],
    /// The transient disturbances masked as gaps before the diagnosis, in time order (empty with
    /// [`super::input::GapOptions::keep_transients`]).
    pub transients: Vec<Masked>,
    /// Ensemble size.
    pub seeds: usize,
    /// Whether a temperature channel was used.
    pub has_temperature: bool,
    /// The ADC channel of the base ensemble (`None`: the analog rate).
    pub channel: Option<Channel>,
}

/// The base model: the IEEE 952 fit on the training part and how its simulation compares with the record.
#[derive(Clone, Debug)]
pub struct BaseResult {
    /// The base model.
    pub gyro: GyroSim,
    /// Its fit.
    pub fit: NoiseFit,
    /// Its comparison.
    pub eval: Evaluated,
    /// Real training OADEV (with intervals), for the plot.
    pub real_adev: Vec<DevPoint>,
    /// Where its gap lies on the training part.
    pub location: Option<Location>,
    /// Whether its gap is significant ([`rank::SIGNIFICANT_GAP`]).
    pub significant: bool,
}

/// The chain of effects the diagnosis found and the model with all of them.
#[derive(Clone, Debug)]
pub struct ChainResult {
    /// The steps, in the order found.
    pub steps: Vec<Step>,
    /// The first step's candidates, in vocabulary order.
    pub candidates: Vec<CandidateResult>,
    /// The candidates tried on the chain's model when none of them removed a quarter of the gap it left (empty
    /// when the chain ended for want of a significant gap, or found no effect).
    pub last_tried: Vec<CandidateResult>,
    /// The model with every effect of the chain.
    pub model: Model,
    /// The final model's comparison: the chain's, backfitted where the diagnosis kept that round (the base's
    /// without a chain).
    pub eval: Evaluated,
    /// What the significant gap left after the chain looks like (`None`: nothing significant is left).
    pub unexplained: Option<GapShape>,
    /// The effects the views named that a later one made redundant, taken out of the chain
    /// ([`crate::chain::prune`]).
    pub pruned: Vec<crate::chain::Pruned>,
    /// The effect of the chain traded for the best-scored other candidate of its step ([`crate::chain::exchange`]).
    pub exchanged: Vec<crate::chain::Exchanged>,
    /// The greedy chain given up for one searched from the first ranking's runner-up, where that explained what
    /// the greedy one left ([`crate::chain::Retried`]).
    pub retried: Option<crate::chain::Retried>,
}

/// The held-out checks.
#[derive(Clone, Debug)]
pub struct HoldoutResult {
    /// Holdout gap at the base's band, before and after the first effect.
    pub first: Option<PartGap>,
    /// The whole chain held out, every parameter frozen: the largest held-out gap over the bands its steps
    /// located (the base's band without a chain), of the base model and of the chain's model. The worst view of
    /// the holdout, wherever it lies, is [`GapReport::worst`].
    pub total: Option<PartGap>,
    /// With [`super::input::HoldoutCheck::Predictive`]: the holdout gap at the base's band against the predictive
    /// ensembles, base and chain (see [`super::holdout`]).
    pub predictive: Option<PartGap>,
    /// The worst view's gap on the holdout against the predictive ensembles, base and chain (NaN without).
    pub predictive_worst: [f64; 2],
}

/// Build the report from the base model, the chain the diagnosis found and the predictive views.
pub(crate) fn assemble(
    input: InputSummary,
    base: (GyroSim, NoiseFit, Evaluated, Vec<DevPoint>),
    found: Found,
    predictive: Option<PredictiveViews>,
) -> GapReport {
    let (gyro, fit, base_eval, real_adev) = base;
    let Found { steps, first_candidates, last_tried, model, eval: last_eval, pruned, exchanged, retried } = found;
    let location = rank::locate(&base_eval.training);
    let in_band = |v: &[ViewGap]| -> Option<f64> { location.as_ref().and_then(|l| rank::band_gap(v, l)) };
    let gap_before = rank::gap_of(&base_eval.training);
    let significant = gap_before > rank::SIGNIFICANT_GAP;
    let has_holdout = !base_eval.holdout.is_empty();
    let first = steps.first();
    let training = PartGap::new(gap_before, first.map_or(gap_before, |s| s.training.gap_after));
    let first_held = if has_holdout { in_band(&base_eval.holdout) } else { None }.map(|b| {
        let first_after = first.and_then(|s| s.candidates.iter().find(|c| c.effect == s.effect));
        PartGap::new(b, first_after.and_then(|c| c.holdout_after).unwrap_or(b))
    });
    let hold_worst = if has_holdout { rank::gap_of(&base_eval.holdout) } else { f64::NAN };
    let hold_worst_after = if has_holdout { rank::gap_of(&last_eval.holdout) } else { f64::NAN };
    // The whole chain held out: at the bands its steps located (the base's band without a chain), the worst of
    // them, for the base model and for the chain's.
    let judged: Vec<&Location> =
        if steps.is_empty() { location.iter().collect() } else { steps.iter().map(|s| &s.location).collect() };
    let holdout_total = match (
        rank::chain_gap(&base_eval.holdout, judged.iter().copied()),
        rank::chain_gap(&last_eval.holdout, judged.iter().copied()),
    ) {
        (Some(b), Some(a)) if has_holdout => Some(PartGap::new(b, a)),
        _ => None,
    };
    let (holdout_predictive, predictive_worst) = match &predictive {
        Some((base, chain)) => {
            let after = chain.as_ref().unwrap_or(if steps.is_empty() { base } else { &last_eval.holdout });
            let gap = in_band(base).map(|b| PartGap::new(b, in_band(after).unwrap_or(b)));
            (gap, [rank::gap_of(base), rank::gap_of(after)])
        }
        None => (None, [f64::NAN; 2]),
    };
    let worst_after = rank::gap_of(&last_eval.training);
    let unexplained = if worst_after > rank::SIGNIFICANT_GAP {
        rank::locate(&last_eval.training).and_then(|l| shape_of(&last_eval.training, &l))
    } else {
        None
    };
    let total = [rank::total_of(&base_eval.training), rank::total_of(&last_eval.training)];
    GapReport {
        input,
        base: BaseResult { gyro, fit, eval: base_eval, real_adev, location, significant },
        chain: ChainResult {
            steps,
            candidates: first_candidates,
            last_tried,
            model,
            eval: last_eval,
            unexplained,
            pruned,
            exchanged,
            retried,
        },
        holdout: HoldoutResult {
            first: first_held,
            total: holdout_total,
            predictive: holdout_predictive,
            predictive_worst,
        },
        training,
        worst: [gap_before, worst_after, hold_worst, hold_worst_after],
        total,
    }
}

/// The answer of a diagnosis, kept apart as the user needs them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// The simulation of the fitted model agrees with the record.
    NoGap,
    /// The chain leaves no significant gap: it explained a significant gap, or its effects were named by their
    /// estimators' own tests where the views showed none (each step's `evidence` says which).
    Explained,
    /// A significant gap is left that no candidate explains (after the chain, if it found any effect).
    Unexplained,
}

impl GapReport {
    /// The bands the held-out check of the whole chain is judged at: each step's location (the base's without a
    /// chain).
    pub fn judged_locations(&self) -> Vec<&Location> {
        if self.chain.steps.is_empty() {
            self.base.location.iter().collect()
        } else {
            self.chain.steps.iter().map(|s| &s.location).collect()
        }
    }

    /// `input` as this diagnosis saw it: with its transients masked as gaps.
    pub fn masked_input(&self, input: &super::input::GapInput) -> super::input::GapInput {
        transients::parts::masked(input, &self.input.transients)
    }

    /// The chain's first effect (`None`: no significant gap, or no candidate removes a quarter of it).
    pub fn effect(&self) -> Option<Effect> {
        self.chain.steps.first().map(|s| s.effect)
    }

    /// The chain's first effect's name, or `none`.
    pub fn effect_name(&self) -> &'static str {
        self.effect().map_or("none", Effect::name)
    }

    /// The effects of the chain, in the order found.
    pub fn effects(&self) -> Vec<Effect> {
        self.chain.steps.iter().map(|s| s.effect).collect()
    }

    /// The first step's candidate of the chain's first effect.
    pub fn chosen(&self) -> Option<&CandidateResult> {
        let e = self.effect()?;
        self.chain.candidates.iter().find(|c| c.effect == e)
    }

    /// The recommended model: the base with every effect of the chain (parameters from training).
    pub fn model(&self) -> &GyroSim {
        &self.chain.model.gyro
    }

    /// The comparison of the whole chain's model (the base's without a chain).
    pub fn final_eval(&self) -> &Evaluated {
        &self.chain.eval
    }

    /// No gap, explained, or a gap left unexplained.
    pub fn verdict(&self) -> Verdict {
        match (self.base.significant, &self.chain.unexplained) {
            (false, _) if self.chain.steps.is_empty() => Verdict::NoGap,
            (_, None) if !self.chain.steps.is_empty() => Verdict::Explained,
            _ => Verdict::Unexplained,
        }
    }

    /// The base fit's reduced chi-square when it is above [`FIT_STRAIN`]: the IEEE terms cannot follow the
    /// training curve.
    pub fn fit_strain(&self) -> Option<f64> {
        let r = self.base.fit.chi2 / self.base.fit.dof.max(1) as f64;
        (r > FIT_STRAIN && r.is_finite()).then_some(r)
    }
}

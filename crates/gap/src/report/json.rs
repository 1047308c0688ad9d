//! The report as the JSON document scripts read: [`Document`] and its parts, whose field names are the keys the
//! module doc of `report` lists (stable: scripts rely on them), and the tables of every view's gap it carries.

use std::collections::BTreeMap;

use octavar_shared::sensor::Channel;
use octavar_shared::sim::GyroSim;
use serde::Serialize;
use serde_json::Value;

use super::{GapReport, Verdict};
use crate::chain::NamedBy;
use crate::compare::ViewGap;
use crate::describe::GapShape;
use crate::effects::{Effect, EffectParams};
use crate::judge::Evaluated;
use crate::rank::{self, PartGap, Sign};
use crate::transients::Masked;
use crate::views::ViewKind;
use octavar_stats::fit::NoiseFit;

impl GapReport {
    /// The JSON document (see the module doc for its keys).
    pub fn document(&self) -> Document<'_> {
        let loc = self.base.location.as_ref();
        let candidates = self.candidate_docs();
        let effects = self.step_docs();
        let first = self.chain.steps.first();
        let missing_samples = Missing { training: self.input.missing[0], holdout: self.input.missing[1] };
        let model_channel = self.chain.model.channel.filter(|_| self.chain.model.channel != self.input.channel);
        let predictive = self.holdout.predictive.map(|h| PredictiveDoc {
            gap_before: h.gap_before,
            gap_after: h.gap_after,
            shrink: h.shrink,
            worst: self.holdout.predictive_worst.map(finite),
        });
        Document {
            input: self.input_doc(missing_samples),
            base: self.base_doc(),
            chain: ChainDoc {
                effects: effects.clone(),
                model: self.model(),
                model_channel,
                verdict: self.verdict(),
                unexplained: self.chain.unexplained.as_ref(),
                total: self.total[1],
                worst: self.worst[1],
                pruned: self.pruned_docs(),
                exchanged: self
                    .chain
                    .exchanged
                    .iter()
                    .map(|x| ExchangedDoc {
                        effect: x.effect.name(),
                        replacement: x.replacement.name(),
                        total_with: x.total_with,
                        total_after: x.total_after,
                    })
                    .collect(),
                retried: self.chain.retried.as_ref().map(|r| RetriedDoc {
                    greedy: r.greedy.iter().map(|e| e.name()).collect(),
                    greedy_total: r.greedy_total,
                    greedy_worst: r.greedy_worst,
                    first: r.first.name(),
                }),
            },
            effect: self.effect_name(),
            view: loc.map(|l| l.view),
            band_s: loc.map(|l| l.band_s),
            sign: loc.map(|l| l.sign),
            size: self.size(),
            gap_before: self.training.gap_before,
            gap_after: self.training.gap_after,
            shrink: self.training.shrink,
            holdout: self.holdout.first.map(|h| HoldoutDoc {
                gap_before: h.gap_before,
                gap_after: h.gap_after,
                shrink: h.shrink,
                shrink_if_right: rank::shrink_if_right(h.gap_before),
                total: self.holdout.total,
                predictive,
                worst: BeforeAfter::new(self.worst[2], self.worst[3]),
            }),
            holdout_predictive: predictive,
            candidates,
            model: self.model(),
            model_channel,
            effect_params: first.map(|s| &s.final_fit().params),
            effects,
            holdout_total: self.holdout.total,
            transients: &self.input.transients,
            verdict: self.verdict(),
            unexplained: self.chain.unexplained.as_ref(),
            fit_strain: self.fit_strain(),
            significant: self.base.significant,
            explained: self.verdict() != Verdict::Unexplained,
            threshold: rank::SIGNIFICANT_GAP,
            total_before: self.total[0],
            total_after: self.total[1],
            base_model: &self.base.gyro,
            base_fit: &self.base.fit,
            views: self.view_table(),
            worst: Worst {
                training: [self.worst[0], self.worst[1]],
                holdout: [finite(self.worst[2]), finite(self.worst[3])],
            },
            views_detail: self.views_detail(),
            n_train: self.input.n_train,
            n_holdout: self.input.n_holdout,
            missing_samples,
            rate_hz: self.input.rate_hz,
            seeds: self.input.seeds,
            pruned: self.pruned_docs(),
        }
    }

    /// The effects taken out of the chain as redundant.
    fn pruned_docs(&self) -> Vec<PrunedDoc> {
        let doc = |p: &crate::chain::Pruned| PrunedDoc {
            effect: p.effect.name(),
            total_with: p.total_with,
            total_without: p.total_without,
        };
        self.chain.pruned.iter().map(doc).collect()
    }

    /// The first step's candidates, each with its gaps after on training and held out.
    fn candidate_docs(&self) -> Vec<CandidateDoc<'_>> {
        let hb = self.holdout.first.map(|p| p.gap_before);
        self.chain
            .candidates
            .iter()
            .map(|c| {
                let f = c.fit.as_ref();
                CandidateDoc {
                    effect: c.effect,
                    params: f.map(|f| &f.params),
                    n_params: f.map(|f| f.n_params),
                    gap_after: c.gap_after,
                    shrink: c.gap_after.map(|a| rank::shrink(self.training.gap_before, a)),
                    total_after: c.total_after,
                    score: c.score,
                    holdout: CandidateHoldout {
                        gap_after: c.holdout_after,
                        shrink: c.holdout_after.zip(hb).map(|(a, b)| rank::shrink(b, a)),
                    },
                    worst_after: c.worst_after,
                    holdout_worst_after: c.holdout_worst_after,
                    chosen: Some(c.effect) == self.effect(),
                    note: f.is_none().then_some("no trace of this effect in the training data"),
                }
            })
            .collect()
    }

    /// The chain's steps.
    fn step_docs(&self) -> Vec<StepDoc<'_>> {
        self.chain
            .steps
            .iter()
            .enumerate()
            .map(|(i, s)| StepDoc {
                effect: s.effect,
                jointly_reestimated: self.chain.steps[i..].iter().any(|later| later.joint),
                params: &s.final_fit().params,
                found_params: s.moved().then_some(&s.fit.params),
                backfitted: s.moved(),
                evidence: s.named_by,
                view: s.location.view,
                band_s: s.location.band_s,
                sign: s.location.sign,
                gap_before: s.training.gap_before,
                gap_after: s.training.gap_after,
                holdout: s.holdout.map(|h| StepHoldout { gap_before: h.gap_before, gap_after: h.gap_after }),
            })
            .collect()
    }

    /// What the diagnosis was given.
    fn input_doc(&self, missing_samples: Missing) -> InputDoc<'_> {
        InputDoc {
            fs_hz: self.input.rate_hz,
            kind: self.input.quantity.kind(),
            unit: self.input.quantity.unit(),
            n_train: self.input.n_train,
            n_holdout: self.input.n_holdout,
            missing_samples,
            transients: &self.input.transients,
            seeds: self.input.seeds,
            has_temperature: self.input.has_temperature,
            channel: self.input.channel,
        }
    }

    /// The base model and the gap it leaves.
    fn base_doc(&self) -> BaseDoc<'_> {
        let loc = self.base.location.as_ref();
        BaseDoc {
            model: &self.base.gyro,
            fit: &self.base.fit,
            fit_strain: self.fit_strain(),
            significant: self.base.significant,
            view: loc.map(|l| l.view),
            band_s: loc.map(|l| l.band_s),
            sign: loc.map(|l| l.sign),
            size: self.size(),
            total: self.total[0],
            worst: self.worst[0],
        }
    }

    /// The size of the base model's gap where it lies.
    fn size(&self) -> Option<Size<'_>> {
        self.base.location.as_ref().map(|l| Size {
            z_rms: l.z_rms,
            points: l.points,
            labels: &l.labels,
            ratio: l.ratio,
            correlation_real_sim: l.correlation,
        })
    }

    /// The JSON document as a value (see the module doc for its keys).
    pub fn to_json(&self) -> Value {
        serde_json::to_value(self.document()).unwrap_or(Value::Null)
    }

    /// Every view's gap, of the base model and of the whole chain, on both parts.
    fn view_table(&self) -> BTreeMap<&'static str, ViewRow> {
        let after = self.final_eval();
        let gap = |v: &[ViewGap], k: ViewKind| v.iter().find(|g| g.view == k).map(|g| g.gap);
        let mut m = BTreeMap::new();
        for k in ViewKind::ALL {
            let Some(tb) = gap(&self.base.eval.training, k) else { continue };
            let row = ViewRow {
                training: [Some(tb), gap(&after.training, k)],
                holdout: [gap(&self.base.eval.holdout, k), gap(&after.holdout, k)],
            };
            m.insert(k.name(), row);
        }
        m
    }

    /// Every point of every view for the base model, each candidate of the first step and each step of the chain
    /// after the first (`chain_2`, ...).
    fn views_detail(&self) -> BTreeMap<String, PartViews<'_>> {
        fn one(e: &Evaluated) -> PartViews<'_> {
            PartViews { training: &e.training, holdout: &e.holdout }
        }
        let mut m = BTreeMap::new();
        m.insert("base".to_string(), one(&self.base.eval));
        for c in &self.chain.candidates {
            if let Some(e) = &c.eval {
                m.insert(c.effect.name().to_string(), one(e));
            }
        }
        for (k, s) in self.chain.steps.iter().enumerate().skip(1) {
            m.insert(format!("chain_{}", k + 1), one(&s.eval));
        }
        m
    }
}

/// The JSON document of a report (see the module doc).
#[derive(Debug, Serialize)]
pub struct Document<'a> {
    /// The record as diagnosed.
    input: InputDoc<'a>,
    /// The base model.
    base: BaseDoc<'a>,
    /// The chain of effects.
    chain: ChainDoc<'a>,
    effect: &'static str,
    view: Option<ViewKind>,
    band_s: Option<[f64; 2]>,
    sign: Option<Sign>,
    size: Option<Size<'a>>,
    gap_before: f64,
    gap_after: f64,
    shrink: f64,
    holdout: Option<HoldoutDoc>,
    holdout_predictive: Option<PredictiveDoc>,
    candidates: Vec<CandidateDoc<'a>>,
    model: &'a GyroSim,
    model_channel: Option<Channel>,
    effect_params: Option<&'a EffectParams>,
    effects: Vec<StepDoc<'a>>,
    holdout_total: Option<PartGap>,
    transients: &'a [Masked],
    verdict: Verdict,
    unexplained: Option<&'a GapShape>,
    fit_strain: Option<f64>,
    significant: bool,
    explained: bool,
    threshold: f64,
    total_before: f64,
    total_after: f64,
    base_model: &'a GyroSim,
    base_fit: &'a NoiseFit,
    views: BTreeMap<&'static str, ViewRow>,
    worst: Worst,
    views_detail: BTreeMap<String, PartViews<'a>>,
    n_train: usize,
    n_holdout: usize,
    missing_samples: Missing,
    /// The sample rate, Hz (the document's key is `fs_hz`).
    #[serde(rename = "fs_hz")]
    rate_hz: f64,
    seeds: usize,
    pruned: Vec<PrunedDoc>,
}

/// The located band's size.
#[derive(Debug, Serialize)]
struct Size<'a> {
    z_rms: f64,
    points: usize,
    labels: &'a [&'static str],
    ratio: Option<f64>,
    correlation_real_sim: Option<[f64; 2]>,
}

/// The first effect's held-out check.
#[derive(Debug, Serialize)]
struct HoldoutDoc {
    gap_before: f64,
    gap_after: f64,
    shrink: f64,
    shrink_if_right: f64,
    /// The whole chain held out (the document's `holdout_total`).
    total: Option<PartGap>,
    /// Against the predictive ensembles (the document's `holdout_predictive`).
    predictive: Option<PredictiveDoc>,
    /// The worst view's gap on the holdout, base model and chain.
    worst: BeforeAfter,
}

/// The held-out check against the predictive ensembles.
#[derive(Clone, Copy, Debug, Serialize)]
struct PredictiveDoc {
    gap_before: f64,
    gap_after: f64,
    shrink: f64,
    worst: [Option<f64>; 2],
}

/// One candidate of the first step.
#[derive(Debug, Serialize)]
struct CandidateDoc<'a> {
    effect: Effect,
    params: Option<&'a EffectParams>,
    n_params: Option<usize>,
    gap_after: Option<f64>,
    shrink: Option<f64>,
    total_after: Option<f64>,
    score: Option<f64>,
    holdout: CandidateHoldout,
    worst_after: Option<f64>,
    holdout_worst_after: Option<f64>,
    chosen: bool,
    note: Option<&'static str>,
}

/// A candidate's held-out gap at the located band.
#[derive(Debug, Serialize)]
struct CandidateHoldout {
    gap_after: Option<f64>,
    shrink: Option<f64>,
}

/// One step of the chain.
#[derive(Clone, Debug, Serialize)]
struct StepDoc<'a> {
    effect: Effect,
    /// The parameters the final model carries (backfitted where `backfitted`).
    params: &'a EffectParams,
    /// The parameters as the step first found them, where a later round changed them.
    found_params: Option<&'a EffectParams>,
    /// Whether a round after its step (a backfitting round on the final model less itself, or a joint
    /// re-estimation) moved the effect's parameters: `params` then differ from `found_params`.
    backfitted: bool,
    /// Whether a joint re-estimation of the base terms and the chain's effects, kept by the diagnosis, followed
    /// this effect's step.
    jointly_reestimated: bool,
    /// What named the effect: `{"route": "view"}`, or `{"route": "estimator", "statistic", "value",
    /// "threshold"}` where its estimator's own test named it and no view's gap did, or `{"route":
    /// "views_less_jumps", "gap_before", "gap_after"}` where the views named it with a named jump process's jumps
    /// taken out of the record and of every member alike.
    evidence: NamedBy,
    view: ViewKind,
    band_s: [f64; 2],
    sign: Sign,
    gap_before: f64,
    gap_after: f64,
    holdout: Option<StepHoldout>,
}

/// A step's held-out gap at its band.
#[derive(Clone, Copy, Debug, Serialize)]
struct StepHoldout {
    gap_before: f64,
    gap_after: f64,
}

/// A view's gap before and after on each part.
#[derive(Debug, Serialize)]
struct ViewRow {
    training: [Option<f64>; 2],
    holdout: [Option<f64>; 2],
}

/// The worst view's gap, before and after, on each part.
#[derive(Debug, Serialize)]
struct Worst {
    training: [f64; 2],
    holdout: [Option<f64>; 2],
}

/// One comparison's views on both parts.
#[derive(Debug, Serialize)]
struct PartViews<'a> {
    training: &'a [ViewGap],
    holdout: &'a [ViewGap],
}

/// Gaps per part.
#[derive(Clone, Copy, Debug, Serialize)]
struct Missing {
    training: usize,
    holdout: usize,
}

/// A figure of the base model and of the chain's.
#[derive(Clone, Copy, Debug, Serialize)]
struct BeforeAfter {
    base: Option<f64>,
    chain: Option<f64>,
}

impl BeforeAfter {
    fn new(base: f64, chain: f64) -> BeforeAfter {
        BeforeAfter { base: finite(base), chain: finite(chain) }
    }
}

/// The document's `input` section: the record as the diagnosis saw it.
#[derive(Debug, Serialize)]
struct InputDoc<'a> {
    fs_hz: f64,
    /// `gyro` or `accel`: an accelerometer's figures (the keys named `_dps` included) are in m/s^2.
    kind: &'static str,
    /// The unit of the record and of every figure named `_dps`.
    unit: &'static str,
    n_train: usize,
    n_holdout: usize,
    missing_samples: Missing,
    transients: &'a [Masked],
    seeds: usize,
    has_temperature: bool,
    channel: Option<Channel>,
}

/// The document's `base` section: the base model, its fit, and where and how much its simulation parts from the
/// training record.
#[derive(Debug, Serialize)]
struct BaseDoc<'a> {
    model: &'a GyroSim,
    fit: &'a NoiseFit,
    fit_strain: Option<f64>,
    significant: bool,
    view: Option<ViewKind>,
    band_s: Option<[f64; 2]>,
    sign: Option<Sign>,
    size: Option<Size<'a>>,
    /// The total over views and the worst view's gap, on the training part.
    total: f64,
    worst: f64,
}

/// The document's `chain` section: the effects found, the model with all of them, and what is left.
#[derive(Debug, Serialize)]
struct ChainDoc<'a> {
    effects: Vec<StepDoc<'a>>,
    model: &'a GyroSim,
    model_channel: Option<Channel>,
    verdict: Verdict,
    unexplained: Option<&'a GapShape>,
    /// The total over views and the worst view's gap, on the training part.
    total: f64,
    worst: f64,
    /// The effects taken out of the chain as redundant.
    pruned: Vec<PrunedDoc>,
    /// The effect traded for the best-scored other candidate of its step.
    exchanged: Vec<ExchangedDoc>,
    /// The greedy chain given up for one searched from another first step.
    retried: Option<RetriedDoc>,
}

/// The greedy chain given up: its effects, its training total and worst gap, and the first step searched from.
#[derive(Debug, Serialize)]
struct RetriedDoc {
    greedy: Vec<&'static str>,
    greedy_total: f64,
    greedy_worst: f64,
    first: &'static str,
}

/// An effect of the chain exchanged for another candidate of its step, with the views' training totals of the
/// chain before and after.
#[derive(Debug, Serialize)]
struct ExchangedDoc {
    effect: &'static str,
    replacement: &'static str,
    total_with: f64,
    total_after: f64,
}

/// An effect taken out of the chain as redundant, with the views' training totals of the chain with and without it.
#[derive(Debug, Serialize)]
struct PrunedDoc {
    effect: &'static str,
    total_with: f64,
    total_without: f64,
}

fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

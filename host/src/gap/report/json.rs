//! The report as the JSON document scripts read: [`Document`] and its parts, whose field names are the keys the
//! module doc of `report` lists (stable: scripts rely on them), and the tables of every view's gap it carries.

use std::collections::BTreeMap;

use octavar_shared::sensor::Channel;
use octavar_shared::sim::GyroSim;
use serde::Serialize;
use serde_json::Value;

use super::{GapReport, Verdict};
use crate::fit::NoiseFit;
use crate::gap::chain::NamedBy;
use crate::gap::compare::ViewGap;
use crate::gap::describe::GapShape;
use crate::gap::effects::{Effect, EffectParams};
use crate::gap::judge::Evaluated;
use crate::gap::rank::{self, PartGap, Sign};
use crate::gap::transients::Masked;
use crate::gap::views::ViewKind;

impl GapReport {
    /// The JSON document (see the module doc for its keys).
    pub fn document(&self) -> Document<'_> {
        let loc = self.location.as_ref();
        let hb = self.holdout.map(|p| p.gap_before);
        let candidates = self
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
                    chosen: Some(c.effect) == self.effect,
                    note: f.is_none().then_some("no trace of this effect in the training data"),
                }
            })
            .collect();
        let effects = self
            .chain
            .iter()
            .enumerate()
            .map(|(i, s)| StepDoc {
                effect: s.effect,
                jointly_reestimated: self.chain[i..].iter().any(|later| later.joint),
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
            .collect();
        let first = self.chain.first();
        Document {
            effect: self.effect_name(),
            view: loc.map(|l| l.view),
            band_s: loc.map(|l| l.band_s),
            sign: loc.map(|l| l.sign),
            size: loc.map(|l| Size {
                z_rms: l.z_rms,
                points: l.points,
                labels: &l.labels,
                ratio: l.ratio,
                correlation_real_sim: l.correlation,
            }),
            gap_before: self.training.gap_before,
            gap_after: self.training.gap_after,
            shrink: self.training.shrink,
            holdout: self.holdout.map(|h| HoldoutDoc {
                gap_before: h.gap_before,
                gap_after: h.gap_after,
                shrink: h.shrink,
                shrink_if_right: rank::shrink_if_right(h.gap_before),
            }),
            holdout_predictive: self.holdout_predictive.map(|h| PredictiveDoc {
                gap_before: h.gap_before,
                gap_after: h.gap_after,
                shrink: h.shrink,
                worst: self.holdout_predictive_worst.map(finite),
            }),
            candidates,
            model: self.model(),
            model_channel: self.model.channel.filter(|_| self.model.channel != self.channel),
            effect_params: first.map(|s| &s.final_fit().params),
            effects,
            holdout_total: self.holdout_total,
            transients: &self.transients,
            verdict: self.verdict(),
            unexplained: self.unexplained.as_ref(),
            fit_strain: self.fit_strain(),
            significant: self.significant,
            explained: self.verdict() != Verdict::Unexplained,
            threshold: rank::SIGNIFICANT_GAP,
            total_before: self.total[0],
            total_after: self.total[1],
            base_model: &self.base,
            base_fit: &self.base_fit,
            views: self.view_table(),
            worst: Worst {
                training: [self.worst[0], self.worst[1]],
                holdout: [finite(self.worst[2]), finite(self.worst[3])],
            },
            views_detail: self.views_detail(),
            n_train: self.n_train,
            n_holdout: self.n_holdout,
            missing_samples: Missing { training: self.missing[0], holdout: self.missing[1] },
            rate_hz: self.rate_hz,
            seeds: self.seeds,
        }
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
            let Some(tb) = gap(&self.base_eval.training, k) else { continue };
            let row = ViewRow {
                training: [Some(tb), gap(&after.training, k)],
                holdout: [gap(&self.base_eval.holdout, k), gap(&after.holdout, k)],
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
        m.insert("base".to_string(), one(&self.base_eval));
        for c in &self.candidates {
            if let Some(e) = &c.eval {
                m.insert(c.effect.name().to_string(), one(e));
            }
        }
        for (k, s) in self.chain.iter().enumerate().skip(1) {
            m.insert(format!("chain_{}", k + 1), one(&s.eval));
        }
        m
    }
}

/// The JSON document of a report (see the module doc).
#[derive(Debug, Serialize)]
pub struct Document<'a> {
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
}

/// The held-out check against the predictive ensembles.
#[derive(Debug, Serialize)]
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
#[derive(Debug, Serialize)]
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
    /// "threshold"}` where its estimator's own test named it and no view's gap did.
    evidence: NamedBy,
    view: ViewKind,
    band_s: [f64; 2],
    sign: Sign,
    gap_before: f64,
    gap_after: f64,
    holdout: Option<StepHoldout>,
}

/// A step's held-out gap at its band.
#[derive(Debug, Serialize)]
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
#[derive(Debug, Serialize)]
struct Missing {
    training: usize,
    holdout: usize,
}

fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

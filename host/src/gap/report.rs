//! The diagnosis as a result: the chain of effects, where each gap lay, what each candidate bought on training and
//! held-out data, what is left unexplained; as text for a person and as the JSON document scripts read.
//!
//! JSON keys (stable; scripts rely on them), in [`Document`]: `effect` (the chain's first effect, a vocabulary
//! name, or `none`), `view`, `band_s` `[lo, hi]`, `sign` (`above`/`below`), `gap_before`, `gap_after`, `shrink`,
//! `holdout` `{gap_before, gap_after, shrink, shrink_if_right}` (all of the first effect, at the base model's
//! located band), `candidates` `[{effect, params, gap_after, shrink, ...}]` (the first step's ranking), `model`
//! (the base model with every effect of the chain, as a `model.toml` channel's `gyro`), `effect_params` (the first
//! effect's). The chain: `effects` `[{effect, params, view, band_s, sign, gap_before, gap_after, holdout:
//! {gap_before, gap_after}, backfitted, found_params}]` in the order found (`params` as the final model carries
//! them; where a backfitting round estimated the effect again, `backfitted` is true and `found_params` are the
//! step's first values; the gaps are the step's own), and `holdout_total` `{gap_before, gap_after, shrink}`, the
//! largest held-out gap over the chain's located bands, of the base model and of the whole chain, every
//! parameter frozen. Also:
//! `transients` `[{part, start_s, duration_s, peak_dps}]` (the disturbances masked as gaps, `start_s` from the
//! start of their part), `verdict` (`no_gap`, `explained`, `unexplained`), `unexplained` (what the gap left after the chain looks like),
//! `fit_strain` (the base fit's reduced chi-square when it is far above 1), `size`, `significant`, `explained`,
//! `threshold`, `total_before`, `total_after`, `base_model`, `base_fit`, `views` (every view's gap on both parts,
//! base and chain), `worst`, `views_detail`, `n_train`, `n_holdout`, `missing_samples` `{training, holdout}`,
//! `fs_hz`, `seeds`; `holdout_predictive` `{gap_before, gap_after, shrink, worst}` with
//! [`super::input::HoldoutCheck::Predictive`] (null without).

use std::collections::BTreeMap;
use std::fmt::Write as _;

use octavar_shared::sensor::Channel;
use octavar_shared::sim::GyroSim;
use serde::Serialize;
use serde_json::Value;

use super::chain::{Model, Step};
use super::compare::ViewGap;
use super::describe::{shape_of, GapShape};
use super::disturbances::{self, Masked};
use super::effects::Effect;
use super::judge::Evaluated;
use super::rank::{self, CandidateResult, Location, PartGap, Sign};
use super::views::ViewKind;
use crate::fit::NoiseFit;
use crate::stats::DevPoint;

/// The base fit's reduced chi-square above which the report says the IEEE five-term model cannot follow the
/// training curve (its 3% model allowance included, a fit that can scores about 1).
pub const FIT_STRAIN: f64 = 10.0;

/// Below this shrink of a right model ([`rank::shrink_if_right`]) the text report says the held-out check is
/// weak.
const WEAK_HOLDOUT_SHRINK: f64 = 0.7;

/// The diagnosis.
#[derive(Clone, Debug)]
pub struct GapReport {
    /// The chain's first effect (`None`: no significant gap, or no candidate removes a quarter of it).
    pub effect: Option<Effect>,
    /// Whether the base gap is significant ([`rank::SIGNIFICANT_GAP`]).
    pub significant: bool,
    /// Where the base gap lies on the training part.
    pub location: Option<Location>,
    /// The worst view's gap on each part, of the base model and of the whole chain: `[training base, training
    /// chain, holdout base, holdout chain]` (the holdout's NaN without one).
    pub worst: [f64; 4],
    /// Training gap at the base's located band, before and after the first effect.
    pub training: PartGap,
    /// Holdout gap at the same band, before and after the first effect (`None` without a holdout).
    pub holdout: Option<PartGap>,
    /// The whole chain held out, every parameter frozen: the largest held-out gap over the bands its steps
    /// located (the base's band without a chain), of the base model and of the chain's model (`None` without a
    /// holdout). The worst view of the holdout, wherever it lies, is [`GapReport::worst`].
    pub holdout_total: Option<PartGap>,
    /// With [`super::input::HoldoutCheck::Predictive`]: the holdout gap at the base's band against the predictive ensembles,
    /// base and chain (see [`super::holdout`]).
    pub holdout_predictive: Option<PartGap>,
    /// The worst view's gap on the holdout against the predictive ensembles, base and chain (NaN without).
    pub holdout_predictive_worst: [f64; 2],
    /// Totals (RMS over views) on training, base and chain.
    pub total: [f64; 2],
    /// The first step's candidates, in vocabulary order.
    pub candidates: Vec<CandidateResult>,
    /// The chain of effects, in the order found.
    pub chain: Vec<Step>,
    /// The candidates tried on the chain's model when none of them removed a quarter of the gap it left (empty
    /// when the chain ended for want of a significant gap, or found no effect).
    pub last_tried: Vec<CandidateResult>,
    /// The model with every effect of the chain.
    pub model: Model,
    /// What the significant gap left after the chain looks like (`None`: nothing significant is left).
    pub unexplained: Option<GapShape>,
    /// The base model.
    pub base: GyroSim,
    /// Its fit.
    pub base_fit: NoiseFit,
    /// The ADC channel of the base ensemble (`None`: the analog rate).
    pub channel: Option<Channel>,
    /// The base model's comparison.
    pub base_eval: Evaluated,
    /// The final model's comparison: the chain's, backfitted where the diagnosis kept that round (the base's
    /// without a chain).
    pub final_eval: Evaluated,
    /// Real training OADEV (with intervals), for the plot.
    pub real_adev: Vec<DevPoint>,
    /// Sample rate, Hz.
    pub fs_hz: f64,
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
}

/// What [`assemble`] needs.
pub(crate) struct Parts {
    pub fs_hz: f64,
    pub n_train: usize,
    pub n_holdout: usize,
    pub missing: [usize; 2],
    pub transients: Vec<Masked>,
    pub seeds: usize,
    pub has_temperature: bool,
    pub channel: Option<Channel>,
    pub base: GyroSim,
    pub base_fit: NoiseFit,
    pub real_adev: Vec<DevPoint>,
    pub base_eval: Evaluated,
    /// The comparison of the final model (the base's without a chain).
    pub final_eval: Evaluated,
    /// The first step's candidates.
    pub candidates: Vec<CandidateResult>,
    pub chain: Vec<Step>,
    /// The candidates tried on the chain's model when none explained what it left.
    pub last_tried: Vec<CandidateResult>,
    /// The model with every effect of the chain.
    pub model: Model,
    /// The holdout views against the predictive ensembles: the base model's and the chain's (`None`: the plain
    /// ones stand).
    pub predictive: Option<(Vec<ViewGap>, Option<Vec<ViewGap>>)>,
}

/// Build the report from the chain the diagnosis found.
pub(crate) fn assemble(p: Parts) -> GapReport {
    let location = rank::locate(&p.base_eval.training);
    let in_band = |v: &[ViewGap]| -> Option<f64> { location.as_ref().and_then(|l| rank::band_gap(v, l)) };
    let gap_before = rank::gap_of(&p.base_eval.training);
    let significant = gap_before > rank::SIGNIFICANT_GAP;
    let has_holdout = !p.base_eval.holdout.is_empty();
    let first = p.chain.first();
    let last_eval = &p.final_eval;
    let training = PartGap::new(gap_before, first.map_or(gap_before, |s| s.training.gap_after));
    let holdout = if has_holdout { in_band(&p.base_eval.holdout) } else { None }.map(|b| {
        let first_after = first.and_then(|s| s.candidates.iter().find(|c| c.effect == s.effect));
        PartGap::new(b, first_after.and_then(|c| c.holdout_after).unwrap_or(b))
    });
    let hold_worst = if has_holdout { rank::gap_of(&p.base_eval.holdout) } else { f64::NAN };
    let hold_worst_after = if has_holdout { rank::gap_of(&last_eval.holdout) } else { f64::NAN };
    // The whole chain held out: at the bands its steps located (the base's band without a chain), the worst of
    // them, for the base model and for the chain's.
    let judged: Vec<&Location> =
        if p.chain.is_empty() { location.iter().collect() } else { p.chain.iter().map(|s| &s.location).collect() };
    let holdout_total = match (
        rank::chain_gap(&p.base_eval.holdout, judged.iter().copied()),
        rank::chain_gap(&last_eval.holdout, judged.iter().copied()),
    ) {
        (Some(b), Some(a)) if has_holdout => Some(PartGap::new(b, a)),
        _ => None,
    };
    let (holdout_predictive, holdout_predictive_worst) = match &p.predictive {
        Some((base, chain)) => {
            let after = chain.as_ref().unwrap_or(if p.chain.is_empty() { base } else { &last_eval.holdout });
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
    GapReport {
        effect: first.map(|s| s.effect),
        significant,
        location,
        worst: [gap_before, worst_after, hold_worst, hold_worst_after],
        training,
        holdout,
        holdout_total,
        holdout_predictive,
        holdout_predictive_worst,
        total: [rank::total_of(&p.base_eval.training), rank::total_of(&last_eval.training)],
        candidates: p.candidates,
        model: p.model,
        unexplained,
        chain: p.chain,
        last_tried: p.last_tried,
        base: p.base,
        base_fit: p.base_fit,
        channel: p.channel,
        base_eval: p.base_eval,
        final_eval: p.final_eval,
        real_adev: p.real_adev,
        fs_hz: p.fs_hz,
        n_train: p.n_train,
        n_holdout: p.n_holdout,
        missing: p.missing,
        transients: p.transients,
        seeds: p.seeds,
        has_temperature: p.has_temperature,
    }
}

/// The answer of a diagnosis, kept apart as the user needs them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// The simulation of the fitted model agrees with the record.
    NoGap,
    /// A significant gap, and the chain leaves none.
    Explained,
    /// A significant gap is left that no candidate explains (after the chain, if it found any effect).
    Unexplained,
}

impl GapReport {
    /// The bands the held-out check of the whole chain is judged at: each step's location (the base's without a
    /// chain).
    pub fn judged_locations(&self) -> Vec<&Location> {
        if self.chain.is_empty() {
            self.location.iter().collect()
        } else {
            self.chain.iter().map(|s| &s.location).collect()
        }
    }

    /// `input` as this diagnosis saw it: with its transients masked as gaps.
    pub fn masked_input(&self, input: &super::input::GapInput) -> super::input::GapInput {
        disturbances::masked(input, &self.transients)
    }

    /// The chain's first effect's name, or `none`.
    pub fn effect_name(&self) -> &'static str {
        self.effect.map_or("none", Effect::name)
    }

    /// The effects of the chain, in the order found.
    pub fn effects(&self) -> Vec<Effect> {
        self.chain.iter().map(|s| s.effect).collect()
    }

    /// The first step's candidate of the chain's first effect.
    pub fn chosen(&self) -> Option<&CandidateResult> {
        let e = self.effect?;
        self.candidates.iter().find(|c| c.effect == e)
    }

    /// The recommended model: the base with every effect of the chain (parameters from training).
    pub fn model(&self) -> &GyroSim {
        &self.model.gyro
    }

    /// The comparison of the whole chain's model (the base's without a chain).
    pub fn final_eval(&self) -> &Evaluated {
        &self.final_eval
    }

    /// No gap, explained, or a gap left unexplained.
    pub fn verdict(&self) -> Verdict {
        match (self.significant, &self.unexplained) {
            (false, _) => Verdict::NoGap,
            (true, None) if !self.chain.is_empty() => Verdict::Explained,
            _ => Verdict::Unexplained,
        }
    }

    /// The base fit's reduced chi-square when it is above [`FIT_STRAIN`]: the IEEE terms cannot follow the
    /// training curve.
    pub fn fit_strain(&self) -> Option<f64> {
        let r = self.base_fit.chi2 / self.base_fit.dof.max(1) as f64;
        (r > FIT_STRAIN && r.is_finite()).then_some(r)
    }

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
            .map(|s| StepDoc {
                effect: s.effect,
                params: &s.final_fit().params,
                found_params: s.refit.as_ref().map(|_| &s.fit.params),
                backfitted: s.refit.is_some(),
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
            fs_hz: self.fs_hz,
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

    /// A short text a person can read: what, where, how big, how sure, what the fix buys on held-out data.
    pub fn text(&self) -> String {
        let mut s = String::new();
        let missing = |m: usize| if m > 0 { format!(" ({m} missing)") } else { String::new() };
        let hold = if self.n_holdout > 0 {
            format!("{} held out{}", self.n_holdout, missing(self.missing[1]))
        } else {
            "no holdout".to_string()
        };
        let [mt, mh] = disturbances::seconds(&self.transients);
        let masked = if self.transients.is_empty() {
            "no transient masked".to_string()
        } else {
            format!(
                "{} transient{} masked ({mt:.1} s of training, {mh:.1} s of holdout)",
                self.transients.len(),
                if self.transients.len() == 1 { "" } else { "s" }
            )
        };
        let _ = writeln!(
            s,
            "gap diagnosis: {} training samples{} at {} Hz, {hold}; {masked}; ensemble of {} seeds{}",
            self.n_train,
            missing(self.missing[0]),
            self.fs_hz,
            self.seeds,
            if self.has_temperature { ", driven by the recorded temperature" } else { "" }
        );
        for t in &self.transients {
            let _ = writeln!(
                s,
                "  transient in the {} part at {:.1} s for {:.1} s, peak {:.3e} deg/s: masked as a gap",
                t.part.name(),
                t.start_s,
                t.duration_s,
                t.peak_dps
            );
        }
        let b = &self.base;
        let _ = writeln!(
            s,
            "base model (IEEE 952 fit on training): N {:.3e} deg/sqrt(s), B {:.3e} deg/s, K {:.3e} deg/s/sqrt(s), R {:.3e} deg/s^2, bias {:.4e} deg/s",
            b.n_deg_per_rt_s, b.b_dps, b.k_dps_per_rt_s, b.r_dps_per_s, b.bias_dps
        );
        if let Some(r) = self.fit_strain() {
            let _ = writeln!(
                s,
                "note: the IEEE five-term fit cannot follow the training curve (reduced chi-square {r:.1}, about 1 when it can): the record has a shape those terms lack"
            );
        }
        let _ = writeln!(s, "views (gap: the RMS z of real against the ensemble over the worst decade of tau; about 1 when they agree; base -> {}):", if self.chain.is_empty() { "base" } else { "with the chain" });
        let after = self.final_eval();
        let f = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.2}"));
        let gap = |v: &[ViewGap], k: ViewKind| v.iter().find(|x| x.view == k).map(|x| x.gap);
        for g in &self.base_eval.training {
            let _ = writeln!(
                s,
                "  {:<13} training {:>7.2} -> {:>7}   holdout {:>7} -> {:>7}",
                g.view.name(),
                g.gap,
                f(gap(&after.training, g.view)),
                f(gap(&self.base_eval.holdout, g.view)),
                f(gap(&after.holdout, g.view))
            );
        }
        if let Some(l) = &self.location {
            let _ = writeln!(
                s,
                "gap {:.2} (threshold {:.1}: {}): {}",
                self.training.gap_before,
                rank::SIGNIFICANT_GAP,
                if self.significant { "significant" } else { "not significant" },
                where_text(l)
            );
        }
        for (k, step) in self.chain.iter().enumerate() {
            if k > 0 {
                let _ = writeln!(
                    s,
                    "step {}: the gap left on the model with {}: {:.2}: {}",
                    k + 1,
                    chain_names(&self.chain[..k]),
                    step.training.gap_before,
                    where_text(&step.location)
                );
            }
            let _ = writeln!(
                s,
                "candidates{} (gap after in that view, total over views, score = total x (1 + 0.05 x params); holdout gap after):",
                if self.chain.len() > 1 { format!(" of step {}", k + 1) } else { String::new() }
            );
            candidate_lines(&mut s, &step.candidates, Some(step.effect));
        }
        if !self.last_tried.is_empty() {
            let _ = writeln!(
                s,
                "candidates tried on the model with {} (none removes a quarter of the gap it leaves):",
                chain_names(&self.chain)
            );
            candidate_lines(&mut s, &self.last_tried, None);
        }
        if self.chain.is_empty() {
            let _ = writeln!(
                s,
                "candidates (gap after in that view, total over views, score = total x (1 + 0.05 x params); holdout gap after):"
            );
            candidate_lines(&mut s, &self.candidates, None);
        }
        if self.worst[2].is_finite() {
            let _ = writeln!(
                s,
                "worst view on the holdout: {:.2} -> {:.2}{}",
                self.worst[2],
                self.worst[3],
                match self.base_eval.holdout.iter().max_by(|a, b| a.gap.total_cmp(&b.gap)) {
                    Some(w) if self.significant && Some(w.view) != self.location.as_ref().map(|l| l.view) =>
                        format!(" ({}: the holdout has a gap of its own that training did not show)", w.view.name()),
                    _ => String::new(),
                }
            );
        }
        if let Some(first) = self.chain.first() {
            let _ = write!(
                s,
                "diagnosis: {} (gap {:.2} -> {:.2} on training, shrink {:.0}%",
                first.effect.name(),
                self.training.gap_before,
                self.training.gap_after,
                100.0 * self.training.shrink
            );
            if let Some(h) = self.holdout {
                let _ = write!(
                    s,
                    "; held out, parameters frozen: {:.2} -> {:.2}, shrink {:.0}%{}",
                    h.gap_before,
                    h.gap_after,
                    100.0 * h.shrink,
                    match self.holdout_predictive {
                        Some(p) => format!(
                            "; against the predictive ensembles, which carry the learnt parameters' error: {:.2} -> {:.2}, shrink {:.0}%",
                            p.gap_before,
                            p.gap_after,
                            100.0 * p.shrink
                        ),
                        None => String::new(),
                    }
                );
            }
            let _ = writeln!(s, ")");
            for step in &self.chain[1..] {
                let _ = writeln!(
                    s,
                    "  then {} ({} {}, gap {:.2} -> {:.2} on training{})",
                    step.effect.name(),
                    step.location.view.name(),
                    band_text(&step.location),
                    step.training.gap_before,
                    step.training.gap_after,
                    step.holdout
                        .map_or(String::new(), |h| format!(", {:.2} -> {:.2} held out", h.gap_before, h.gap_after))
                );
            }
            let refitted: Vec<&str> =
                self.chain.iter().filter(|s| s.refit.is_some()).map(|s| s.effect.name()).collect();
            if !refitted.is_empty() {
                let _ = writeln!(
                    s,
                    "backfitted: {} estimated again with every other effect of the chain in place (the model carries those values)",
                    refitted.join(", ")
                );
            }
            if let (true, Some(t)) = (self.chain.len() > 1, self.holdout_total) {
                let _ = writeln!(
                    s,
                    "the whole chain ({}), held out with every parameter frozen, at the worst of its bands: {:.2} -> {:.2}, shrink {:.0}%",
                    chain_names(&self.chain),
                    t.gap_before,
                    t.gap_after,
                    100.0 * t.shrink
                );
            }
            if let Some(note) = self.holdout.as_ref().and_then(weak_holdout_note) {
                let _ = writeln!(s, "{note}");
            }
        }
        match self.verdict() {
            Verdict::NoGap => {
                let _ = writeln!(s, "diagnosis: none (the simulation of the fitted model agrees with the record)");
            }
            Verdict::Unexplained => {
                let what = match &self.unexplained {
                    Some(u) => format!(
                        ": {} view, {} the simulation, |z| RMS {:.1}: {}",
                        u.view.name(),
                        u.sign.name(),
                        u.z_rms,
                        u.text
                    ),
                    None => String::new(),
                };
                if self.chain.is_empty() {
                    let _ = writeln!(s, "diagnosis: none: the gap is significant, but no candidate removes a quarter of it; it is not one of the known effects{what}");
                } else {
                    let _ = writeln!(s, "left unexplained after the chain: a significant gap that no candidate removes a quarter of{what}");
                }
            }
            Verdict::Explained => {}
        }
        s
    }
}

/// `a, b then c` of a chain's effects.
fn chain_names(steps: &[Step]) -> String {
    steps.iter().map(|s| s.effect.name()).collect::<Vec<_>>().join(" + ")
}

/// `tau 1.0e0 .. 2.0e1 s`.
fn band_text(l: &Location) -> String {
    format!("tau {:.3e} .. {:.3e} s", l.band_s[0], l.band_s[1])
}

/// Where a gap lies and its size, as the report's line says it.
fn where_text(l: &Location) -> String {
    let size = match (l.ratio, l.correlation) {
        (Some(r), _) if l.view == ViewKind::Adev => format!(", real/sim Allan deviation x{r:.3}"),
        (Some(r), _) => format!(", real/sim power x{r:.3}"),
        (_, Some([a, b])) => format!(", coherence with temperature {a:.2} real vs {b:.2} simulated"),
        _ => format!(" ({})", l.labels.join(", ")),
    };
    format!(
        "worst view {}, {}, real {} the simulation, |z| RMS {:.1} over {} point(s){size}",
        l.view.name(),
        band_text(l),
        l.sign.name(),
        l.z_rms,
        l.points
    )
}

/// One line per candidate of a step, the chosen one starred.
fn candidate_lines(s: &mut String, candidates: &[CandidateResult], chosen: Option<Effect>) {
    for c in candidates {
        let mark = if Some(c.effect) == chosen { "*" } else { " " };
        match (&c.fit, c.gap_after, c.total_after, c.score) {
            (Some(f), Some(g), Some(t), Some(sc)) => {
                let h = c.holdout_after.map_or("-".to_string(), |h| format!("{h:.2}"));
                let _ = writeln!(
                    s,
                    " {mark}{:<13} gap {g:>7.2} total {t:>7.2} score {sc:>7.2}  holdout {h:>7}  {}",
                    c.effect.name(),
                    compact(&f.params)
                );
            }
            _ => {
                let _ = writeln!(s, " {mark}{:<13} no trace in the training data", c.effect.name());
            }
        }
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
    effect_params: Option<&'a Value>,
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
    fs_hz: f64,
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
    params: Option<&'a Value>,
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
    params: &'a Value,
    /// The parameters as the step first found them, where a backfitting round changed them.
    found_params: Option<&'a Value>,
    /// Whether a backfitting round estimated the effect again on the final model less itself.
    backfitted: bool,
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

/// `{"a": 1.0, "b": 2.0}` as `a=1.000e0 b=2.000e0`.
fn compact(v: &Value) -> String {
    match v {
        Value::Object(m) => m
            .iter()
            .map(|(k, v)| match v {
                Value::Number(n) => format!("{k}={:.4e}", n.as_f64().unwrap_or(f64::NAN)),
                other => format!("{k}={}", other),
            })
            .collect::<Vec<_>>()
            .join(" "),
        other => other.to_string(),
    }
}

/// The report's `note:` line when the holdout's gap before a fix is too small for a right model to shrink it by
/// [`WEAK_HOLDOUT_SHRINK`] (see [`rank::shrink_if_right`]); `None` when it is large enough.
fn weak_holdout_note(h: &PartGap) -> Option<String> {
    let expected = rank::shrink_if_right(h.gap_before);
    (expected < WEAK_HOLDOUT_SHRINK).then(|| {
        format!(
            "note: the holdout's gap before a fix is only {:.2}, and a model that is right still scores about {:.0} there (an RMS z), so about {:.0}% is the shrink to expect even of the right effect; a smaller shrink here is weak evidence against it",
            h.gap_before,
            rank::RIGHT_MODEL_GAP,
            100.0 * expected
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The note appears exactly below a gap of 1 / (1 - 0.7) = 3.33 before a fix, and states the shrink a right
    /// model (RMS z of 1 after) would reach: 1 - 1/1.8 = 44% at 1.8.
    #[test]
    fn a_weak_holdout_gets_a_note_with_the_shrink_a_right_model_reaches() {
        let part = |before: f64| PartGap::new(before, 1.0);
        let note = weak_holdout_note(&part(1.8)).expect("a note at 1.8");
        assert!(note.starts_with("note:") && note.contains("only 1.80") && note.contains("about 44%"), "{note}");
        assert!(weak_holdout_note(&part(3.30)).is_some());
        assert!(weak_holdout_note(&part(3.36)).is_none());
        assert!(weak_holdout_note(&part(12.0)).is_none());
        // A holdout that shows no gap at all: a right model cannot shrink it, and the note says 0%, not a negative.
        assert!(weak_holdout_note(&part(0.8)).unwrap().contains("about 0%"));
    }
}

//! The diagnosis as a result: the chosen effect, where the gap lies, what each candidate buys on training and
//! held-out data; as text for a person, as the JSON document scripts read, and as the gap plot's data.
//!
//! JSON keys (stable; scripts rely on them): `effect` (a vocabulary name, or `none`), `view`, `band_s` `[lo, hi]`,
//! `sign` (`above`/`below`), `gap_before`, `gap_after`, `shrink`, `holdout` `{gap_before, gap_after, shrink}`,
//! `candidates` `[{effect, params, gap_after, shrink, ...}]`, `model` (the base model plus the chosen effect, as a
//! `model.toml` channel's `gyro`), `effect_params`. Also: `size`, `significant`, `threshold`, `total_before`,
//! `total_after`, `base_model`, `base_fit`, `views` (every view's RMS on both parts, before and after), `n_train`,
//! `n_holdout`, `missing_samples` `{training, holdout}` (NaN gaps), `fs_hz`, `seeds`; `holdout.shrink_if_right`
//! (the shrink a right model would reach there, [`rank::shrink_if_right`]); `holdout_predictive` `{gap_before,
//! gap_after, shrink, worst}` with [`HoldoutCheck::Predictive`] (null without).

use std::fmt::Write as _;

use octavar_shared::sensor::Channel;
use octavar_shared::sim::GyroSim;
use serde::Serialize;
use serde_json::{json, Value};

use super::compare::ViewGap;
use super::effects::{Effect, EffectFit};
use super::rank::{self, Location};
use super::views::ViewKind;
use super::Evaluated;
use crate::fit::NoiseFit;
use crate::plot::{Band, GapPlot};
use crate::stats::DevPoint;

/// A gap before and after, on one part.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PartGap {
    /// The base model's gap (the located band's RMS z).
    pub gap_before: f64,
    /// With the effect.
    pub gap_after: f64,
    /// 1 - after / before.
    pub shrink: f64,
}

impl PartGap {
    /// Before and after, with their shrink.
    pub fn new(gap_before: f64, gap_after: f64) -> PartGap {
        PartGap { gap_before, gap_after, shrink: rank::shrink(gap_before, gap_after) }
    }
}

/// One candidate effect's result.
#[derive(Clone, Debug)]
pub struct CandidateResult {
    /// The effect.
    pub effect: Effect,
    /// Its fit, or `None` when the data showed no trace of it.
    pub fit: Option<EffectFit>,
    /// Its ensemble's comparison.
    pub eval: Option<Evaluated>,
    /// Training gap after: the RMS z, with the effect, of the view where the base gap lies (`None` without a fit).
    pub gap_after: Option<f64>,
    /// Training: the worst view's gap with the effect.
    pub worst_after: Option<f64>,
    /// Total (RMS over views) after, training.
    pub total_after: Option<f64>,
    /// Ranking score.
    pub score: Option<f64>,
    /// Holdout gap after (the same view).
    pub holdout_after: Option<f64>,
    /// Holdout: the worst view's gap with the effect.
    pub holdout_worst_after: Option<f64>,
}

/// The diagnosis.
#[derive(Clone, Debug)]
pub struct GapReport {
    /// The chosen effect (`None`: no significant gap, or no candidate removes a quarter of it).
    pub effect: Option<Effect>,
    /// Whether the base gap is significant ([`rank::SIGNIFICANT_GAP`]).
    pub significant: bool,
    /// Where the base gap lies on the training part.
    pub location: Option<Location>,
    /// The worst view's gap on each part, before and after: `[training before, training after, holdout before,
    /// holdout after]` (the holdout's NaN without one). On the holdout the worst view may differ from the one the
    /// diagnosis is about (a disturbance only the held-out part has).
    pub worst: [f64; 4],
    /// Training gap before/after.
    pub training: PartGap,
    /// Holdout gap before/after (`None` without a holdout), against the ensembles of the models learnt from the
    /// real training part.
    pub holdout: Option<PartGap>,
    /// With [`HoldoutCheck::Predictive`]: the holdout gap before/after against the predictive ensembles (see
    /// [`super::holdout`]), whose spread carries the error of the parameters learnt on training.
    pub holdout_predictive: Option<PartGap>,
    /// The worst view's gap on the holdout against the predictive ensembles, before and after (NaN without).
    pub holdout_predictive_worst: [f64; 2],
    /// Totals (RMS over views) before and after, training.
    pub total: [f64; 2],
    /// Every candidate, in vocabulary order.
    pub candidates: Vec<CandidateResult>,
    /// The base model.
    pub base: GyroSim,
    /// Its fit.
    pub base_fit: NoiseFit,
    /// The ADC channel of the base ensemble (`None`: the analog rate).
    pub channel: Option<Channel>,
    /// The base model's comparison.
    pub base_eval: Evaluated,
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
    /// Ensemble size.
    pub seeds: usize,
    /// Whether a temperature channel was used.
    pub has_temperature: bool,
}

/// How the held-out gap is judged.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Default, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum HoldoutCheck {
    /// Against the ensembles of the models learnt from the real training part: their spread is the noise's.
    #[default]
    Plain,
    /// Also against predictive ensembles: each member re-learns the model from a simulated training part and
    /// predicts the holdout ([`super::ensemble::predict_holdout`]), so the spread carries the error of the
    /// parameters learnt on training as well as the noise.
    Predictive,
}

impl HoldoutCheck {
    /// `predictive` or `plain`.
    pub fn name(self) -> &'static str {
        match self {
            HoldoutCheck::Predictive => "predictive",
            HoldoutCheck::Plain => "plain",
        }
    }
}

/// How much worse a temperature coupling's score may be than the best candidate's and still be chosen, when the
/// gap lies in the temperature view (see `assemble`).
pub const DRIVER_PREFERENCE: f64 = 1.25;

/// Below this shrink of a right model ([`rank::shrink_if_right`]) the text report says the held-out check is
/// weak: the 70% the withheld-effect tests ask of a diagnosis.
const WEAK_HOLDOUT_SHRINK: f64 = 0.7;

/// What [`assemble`] needs.
pub(crate) struct Parts {
    pub fs_hz: f64,
    pub n_train: usize,
    pub n_holdout: usize,
    pub missing: [usize; 2],
    pub seeds: usize,
    pub has_temperature: bool,
    pub channel: Option<Channel>,
    pub base: GyroSim,
    pub base_fit: NoiseFit,
    pub real_adev: Vec<DevPoint>,
    pub base_eval: Evaluated,
    pub candidates: Vec<(Effect, Option<EffectFit>, Option<Evaluated>)>,
}

/// Rank the candidates and build the report. The gap before is the worst decade window of the base model's worst
/// view on training, which is where the gap is located; "after" and the holdout gaps are the RMS z of the same
/// view's points at the same taus, so the held-out check measures the gap the diagnosis is about (the worst views
/// are reported beside them).
pub(crate) fn assemble(p: Parts) -> GapReport {
    let location = rank::locate(&p.base_eval.training);
    let in_view = |v: &[ViewGap]| -> Option<f64> { location.as_ref().and_then(|l| rank::band_gap(v, l)) };
    let gap_before = rank::gap_of(&p.base_eval.training);
    let total_before = rank::total_of(&p.base_eval.training);
    let has_holdout = !p.base_eval.holdout.is_empty();
    let hold_before = if has_holdout { in_view(&p.base_eval.holdout) } else { None };
    let candidates: Vec<CandidateResult> = p
        .candidates
        .into_iter()
        .map(|(effect, fit, eval)| match (&fit, &eval) {
            (Some(f), Some(e)) => {
                let t = rank::total_of(&e.training);
                CandidateResult {
                    effect,
                    gap_after: in_view(&e.training).or(Some(rank::gap_of(&e.training))),
                    worst_after: Some(rank::gap_of(&e.training)),
                    total_after: Some(t),
                    score: Some(rank::score(t, f.n_params)),
                    holdout_after: if has_holdout { in_view(&e.holdout) } else { None },
                    holdout_worst_after: has_holdout.then(|| rank::gap_of(&e.holdout)),
                    fit,
                    eval,
                }
            }
            _ => CandidateResult {
                effect,
                fit,
                eval,
                gap_after: None,
                worst_after: None,
                total_after: None,
                score: None,
                holdout_after: None,
                holdout_worst_after: None,
            },
        })
        .collect();
    let significant = gap_before > rank::SIGNIFICANT_GAP;
    let best = candidates
        .iter()
        .filter(|c| c.score.is_some_and(|s| s < rank::EXPLAINS * total_before))
        .min_by(|a, b| a.score.unwrap_or(f64::INFINITY).total_cmp(&b.score.unwrap_or(f64::INFINITY)));
    // A gap in the temperature view is a relation with a recorded channel: the coupling to that channel is the
    // first explanation, and one without a driver (a sinusoid at the temperature's cycle) wins only when it is
    // clearly better: the coupling is kept when it explains the total (below EXPLAINS of the base's) and either
    // scores within DRIVER_PREFERENCE of the best or leaves no significant gap in the temperature view. The
    // second clause matters because the coupling is judged there on what it leaves, which a 4% error in the
    // coefficient over ten cycles already shows, while a sinusoid is judged on the raw coherence.
    let best = match (&location, best) {
        (Some(l), Some(b)) if l.view == ViewKind::Temperature && b.effect != Effect::Temperature => candidates
            .iter()
            .find(|c| {
                let clears = c.gap_after.is_some_and(|g| g < rank::SIGNIFICANT_GAP);
                c.effect == Effect::Temperature
                    && c.score.is_some_and(|s| {
                        s < rank::EXPLAINS * total_before && (s <= DRIVER_PREFERENCE * b.score.unwrap_or(0.0) || clears)
                    })
            })
            .or(Some(b)),
        (_, b) => b,
    };
    let chosen = if significant { best } else { None };
    let gap_after = chosen.and_then(|c| c.gap_after).unwrap_or(gap_before);
    let total_after = chosen.and_then(|c| c.total_after).unwrap_or(total_before);
    let holdout = hold_before.map(|b| {
        let a = chosen.and_then(|c| c.holdout_after).unwrap_or(b);
        PartGap::new(b, a)
    });
    let hold_worst = if has_holdout { rank::gap_of(&p.base_eval.holdout) } else { f64::NAN };
    let worst = [
        gap_before,
        chosen.and_then(|c| c.worst_after).unwrap_or(gap_before),
        hold_worst,
        chosen.and_then(|c| c.holdout_worst_after).unwrap_or(hold_worst),
    ];
    GapReport {
        effect: chosen.map(|c| c.effect),
        significant,
        location,
        worst,
        training: PartGap::new(gap_before, gap_after),
        holdout,
        holdout_predictive: None,
        holdout_predictive_worst: [f64::NAN; 2],
        total: [total_before, total_after],
        candidates,
        base: p.base,
        base_fit: p.base_fit,
        channel: p.channel,
        base_eval: p.base_eval,
        real_adev: p.real_adev,
        fs_hz: p.fs_hz,
        n_train: p.n_train,
        n_holdout: p.n_holdout,
        missing: p.missing,
        seeds: p.seeds,
        has_temperature: p.has_temperature,
    }
}

impl GapReport {
    /// Add the held-out check against the predictive ensembles (see [`super::holdout`]): `base` is the base
    /// model's holdout comparison (`None`: the plain one stands, which is the same distribution when the base
    /// model is not re-learnt from the record), `chosen` the chosen effect's.
    pub(crate) fn apply_predictive(&mut self, base: Option<Vec<ViewGap>>, chosen: Option<Vec<ViewGap>>) {
        let loc = self.location.clone();
        let in_view = |v: &[ViewGap]| loc.as_ref().and_then(|l| rank::band_gap(v, l));
        let plain_after = self.chosen().and_then(|c| c.eval.as_ref()).map(|e| e.holdout.clone());
        let base = base.unwrap_or_else(|| self.base_eval.holdout.clone());
        let after = chosen.or(plain_after).unwrap_or_else(|| base.clone());
        self.holdout_predictive = in_view(&base).map(|b| {
            let a = in_view(&after).unwrap_or(b);
            PartGap::new(b, a)
        });
        self.holdout_predictive_worst = [rank::gap_of(&base), rank::gap_of(&after)];
    }

    /// The chosen effect's name, or `none`.
    pub fn effect_name(&self) -> &'static str {
        self.effect.map_or("none", Effect::name)
    }

    /// The chosen candidate.
    pub fn chosen(&self) -> Option<&CandidateResult> {
        let e = self.effect?;
        self.candidates.iter().find(|c| c.effect == e)
    }

    /// The recommended model: the base, or the chosen effect's model (parameters from training).
    pub fn model(&self) -> &GyroSim {
        self.chosen().and_then(|c| c.fit.as_ref()).map_or(&self.base, |f| &f.gyro)
    }

    /// The JSON document (see the module doc for its keys).
    pub fn to_json(&self) -> Value {
        let loc = self.location.as_ref();
        let candidates: Vec<Value> = self
            .candidates
            .iter()
            .map(|c| {
                let f = c.fit.as_ref();
                let h = c.holdout_after;
                let hb = self.holdout.map(|p| p.gap_before);
                json!({
                    "effect": c.effect.name(),
                    "params": f.map_or(Value::Null, |f| f.params.clone()),
                    "n_params": f.map(|f| f.n_params),
                    "gap_after": c.gap_after,
                    "shrink": c.gap_after.map(|a| rank::shrink(self.training.gap_before, a)),
                    "total_after": c.total_after,
                    "score": c.score,
                    "holdout": {
                        "gap_after": h,
                        "shrink": h.zip(hb).map(|(a, b)| rank::shrink(b, a)),
                    },
                    "worst_after": c.worst_after,
                    "holdout_worst_after": c.holdout_worst_after,
                    "chosen": Some(c.effect) == self.effect,
                    "note": if f.is_none() { Value::from("no trace of this effect in the training data") } else { Value::Null },
                })
            })
            .collect();
        let views = self.view_table();
        json!({
            "effect": self.effect_name(),
            "view": loc.map(|l| l.view.name()),
            "band_s": loc.map(|l| l.band_s),
            "sign": loc.map(|l| l.sign.name()),
            "size": loc.map(|l| json!({"z_rms": l.z_rms, "points": l.points, "labels": l.labels,
                                         "ratio": l.ratio, "correlation_real_sim": l.correlation})),
            "gap_before": self.training.gap_before,
            "gap_after": self.training.gap_after,
            "shrink": self.training.shrink,
            "holdout": self.holdout.map_or(Value::Null, |h| json!({
                "gap_before": h.gap_before, "gap_after": h.gap_after, "shrink": h.shrink,
                "shrink_if_right": rank::shrink_if_right(h.gap_before) })),
            "holdout_predictive": self.holdout_predictive.map_or(Value::Null, |h| json!({
                "gap_before": h.gap_before, "gap_after": h.gap_after, "shrink": h.shrink,
                "worst": [finite(self.holdout_predictive_worst[0]), finite(self.holdout_predictive_worst[1])] })),
            "candidates": candidates,
            "model": serde_json::to_value(self.model()).unwrap_or(Value::Null),
            "model_channel": self.chosen().and_then(|c| c.fit.as_ref()).and_then(|f| f.channel)
                .map(|c| serde_json::to_value(c).unwrap_or(Value::Null)),
            "effect_params": self.chosen().and_then(|c| c.fit.as_ref()).map_or(Value::Null, |f| f.params.clone()),
            "significant": self.significant,
            "explained": !self.significant || self.effect.is_some(),
            "threshold": rank::SIGNIFICANT_GAP,
            "total_before": self.total[0],
            "total_after": self.total[1],
            "base_model": serde_json::to_value(&self.base).unwrap_or(Value::Null),
            "base_fit": serde_json::to_value(&self.base_fit).unwrap_or(Value::Null),
            "views": views,
            "worst": {"training": [self.worst[0], self.worst[1]],
                      "holdout": [finite(self.worst[2]), finite(self.worst[3])]},
            "views_detail": self.views_detail(),
            "n_train": self.n_train,
            "n_holdout": self.n_holdout,
            "missing_samples": {"training": self.missing[0], "holdout": self.missing[1]},
            "fs_hz": self.fs_hz,
            "seeds": self.seeds,
        })
    }

    /// Every view's gap: `{"adev": {"training": [before, after], "holdout": [before, after]}, ...}`.
    fn view_table(&self) -> Value {
        let after = self.chosen().and_then(|c| c.eval.as_ref());
        let rms = |v: &[ViewGap], k: ViewKind| v.iter().find(|g| g.view == k).map(|g| g.gap);
        let mut m = serde_json::Map::new();
        for k in ViewKind::ALL {
            let tb = rms(&self.base_eval.training, k);
            if tb.is_none() {
                continue;
            }
            let ta = after.map_or(tb, |e| rms(&e.training, k));
            let hb = rms(&self.base_eval.holdout, k);
            let ha = after.map_or(hb, |e| rms(&e.holdout, k));
            m.insert(k.name().into(), json!({"training": [tb, ta], "holdout": [hb, ha]}));
        }
        Value::Object(m)
    }

    /// Every point of every view for the base model and each candidate: `{"base": {"training": [view...],
    /// "holdout": [...]}, "<effect>": {...}}`, each view `{"view", "rms", "points": [{"label", "tau_s",
    /// "tau_lo_s", "tau_hi_s", "floor_sd", "real", "sim_mean", "sd", "z"}]}`.
    pub fn views_detail(&self) -> Value {
        let one = |e: &Evaluated| json!({"training": e.training, "holdout": e.holdout});
        let mut m = serde_json::Map::new();
        m.insert("base".into(), one(&self.base_eval));
        for c in &self.candidates {
            if let Some(e) = &c.eval {
                m.insert(c.effect.name().into(), one(e));
            }
        }
        Value::Object(m)
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
        let _ = writeln!(
            s,
            "gap diagnosis: {} training samples{} at {} Hz, {hold}; ensemble of {} seeds{}",
            self.n_train,
            missing(self.missing[0]),
            self.fs_hz,
            self.seeds,
            if self.has_temperature { ", driven by the recorded temperature" } else { "" }
        );
        let b = &self.base;
        let _ = writeln!(
            s,
            "base model (IEEE 952 fit on training): N {:.3e} deg/sqrt(s), B {:.3e} deg/s, K {:.3e} deg/s/sqrt(s), R {:.3e} deg/s^2, bias {:.4e} deg/s",
            b.n_deg_per_rt_s, b.b_dps, b.k_dps_per_rt_s, b.r_dps_per_s, b.bias_dps
        );
        let _ = writeln!(s, "views (gap: the RMS z of real against the ensemble over the worst decade of tau; about 1 when they agree):");
        let after = self.chosen().and_then(|c| c.eval.as_ref());
        for g in &self.base_eval.training {
            let a = after.and_then(|e| e.training.iter().find(|x| x.view == g.view)).map(|x| x.gap);
            let hb = self.base_eval.holdout.iter().find(|x| x.view == g.view).map(|x| x.gap);
            let ha = after.and_then(|e| e.holdout.iter().find(|x| x.view == g.view)).map(|x| x.gap);
            let f = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.2}"));
            let _ = writeln!(
                s,
                "  {:<13} training {:>7.2} -> {:>7}   holdout {:>7} -> {:>7}",
                g.view.name(),
                g.gap,
                f(a.or(Some(g.gap))),
                f(hb),
                f(ha.or(hb))
            );
        }
        if let Some(l) = &self.location {
            let size = match (l.ratio, l.correlation) {
                (Some(r), _) if l.view == ViewKind::Adev => format!(", real/sim Allan deviation x{r:.3}"),
                (Some(r), _) => format!(", real/sim power x{r:.3}"),
                (_, Some([a, b])) => format!(", coherence with temperature {a:.2} real vs {b:.2} simulated"),
                _ => format!(" ({})", l.labels.join(", ")),
            };
            let _ = writeln!(
                s,
                "gap {:.2} (threshold {:.1}: {}): worst view {}, tau {:.3e} .. {:.3e} s, real {} the simulation, |z| RMS {:.1} over {} point(s){size}",
                self.training.gap_before,
                rank::SIGNIFICANT_GAP,
                if self.significant { "significant" } else { "not significant" },
                l.view.name(),
                l.band_s[0],
                l.band_s[1],
                l.sign.name(),
                l.z_rms,
                l.points,
            );
        }
        let _ = writeln!(
            s,
            "candidates (gap after in that view, total over views, score = total x (1 + 0.05 x params); holdout gap after):"
        );
        for c in &self.candidates {
            let mark = if Some(c.effect) == self.effect { "*" } else { " " };
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
        if self.worst[2].is_finite() {
            let _ = writeln!(
                s,
                "worst view on the holdout: {:.2} -> {:.2}{}",
                self.worst[2],
                self.worst[3],
                match self.base_eval.holdout.iter().max_by(|a, b| a.gap.total_cmp(&b.gap)) {
                    Some(w) if Some(w.view) != self.location.as_ref().map(|l| l.view) =>
                        format!(" ({}: the holdout has a gap of its own that training did not show)", w.view.name()),
                    _ => String::new(),
                }
            );
        }
        match (self.effect, self.significant) {
            (Some(e), _) => {
                let _ = write!(
                    s,
                    "diagnosis: {} (gap {:.2} -> {:.2} on training, shrink {:.0}%",
                    e.name(),
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
                if let Some(note) = self.holdout.as_ref().and_then(weak_holdout_note) {
                    let _ = writeln!(s, "{note}");
                }
            }
            (None, false) => {
                let _ = writeln!(s, "diagnosis: none (the simulation of the fitted model agrees with the record)");
            }
            (None, true) => {
                let _ = writeln!(s, "diagnosis: none: the gap is significant, but no candidate removes a quarter of it; it is not one of the known effects");
            }
        }
        s
    }

    /// The gap plot's data: real training OADEV, the ensemble band before and after, and the gap's band when the
    /// worst view has a tau axis.
    pub fn plot_data(&self) -> GapPlot {
        let to_bands = |e: &Evaluated| -> Vec<Band> {
            e.adev_band.iter().map(|&(tau_s, lo, hi)| Band { tau_s, lo, hi }).collect()
        };
        let mut p = GapPlot::new(self.real_adev.clone(), to_bands(&self.base_eval));
        p.before_label = "simulated, base model".to_string();
        if let Some(c) = self.chosen() {
            p.after = c.eval.as_ref().map(to_bands);
            p.after_label = format!("simulated, + {}", c.effect.name());
        }
        if let Some(l) = &self.location {
            if self.significant && l.view != ViewKind::Distribution {
                p.band_s = Some((l.band_s[0], l.band_s[1]));
                p.band_label = format!("gap: {} ({})", l.view.name(), l.sign.name());
            }
        }
        p
    }
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

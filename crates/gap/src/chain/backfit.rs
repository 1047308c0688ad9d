//! Effects estimated again with every other effect of the chain in place (backfitting), and a chain learnt again
//! on other data as the diagnosis learnt it.

use std::ops::Range;

use octavar_shared::sim::GyroSim;

use super::data::StepData;
use super::joint;
use super::model::{Model, Rounds};
use crate::effects::{self, Effect, EffectFit};
use crate::fill::{fill_gaps, gap_runs};
use octavar_stats::fit::NoiseFit;

/// `gyro` without `effect` (its field cleared), for the effects the backfitting round estimates again; `None` for
/// the ones it leaves as found: quantisation (a channel, not a field) and the effects that recovered a realisation
/// (the samples the others learnt from have it taken out).
pub fn without(gyro: &GyroSim, effect: Effect) -> Option<GyroSim> {
    match effect {
        Effect::BiasSteps | Effect::Outliers | Effect::Bistable => None,
        _ => effect.taken_from(gyro),
    }
}

/// One backfitting round over a chain of two or more effects: each effect, in the chain's order, is estimated
/// again on the final model less itself, so that it is read with every other effect of the chain in place rather
/// than only the ones found before it (a bandwidth read before the resonance under it takes part of the bump for
/// its corner; the resonance then sits on that corner). `fits` are the chain's fits in its order, `recorded` the
/// training samples as recorded (gaps filled; where an ADC lattice is read), `series` the
/// training samples less the recovered realisations (gaps filled, the runs `gaps`), `shaped` the part of those
/// realisations the sensor's filter shapes ([`StepData::shaped_with`]). Returns the final model and,
/// per step, the fit that replaced it (`None`: kept as found, because the effect is one [`without`] leaves or
/// its estimator found no trace on the model without it).
#[allow(clippy::too_many_arguments)]
pub fn backfit(
    model: &Model,
    fits: &[&EffectFit],
    recorded: &[f64],
    series: &[f64],
    shaped: Option<&[f64]>,
    gaps: &[Range<usize>],
    temp_c: Option<&[f64]>,
    rate_hz: f64,
    base_fit: &NoiseFit,
) -> (Model, Vec<Option<EffectFit>>) {
    let mut gyro = model.gyro.clone();
    let mut refits: Vec<Option<EffectFit>> = vec![None; fits.len()];
    if fits.len() >= 2 {
        for (i, fit) in fits.iter().enumerate() {
            if fit.cleaned.is_some() {
                continue;
            }
            let Some(rest) = without(&gyro, fit.effect) else { continue };
            let data = StepData::new(&rest, series, shaped, gaps, temp_c, rate_hz, base_fit, false);
            if let Some(f) = effects::fit_effect(
                fit.effect,
                &data.training(recorded, &rest, model.channel.as_ref(), temp_c, rate_hz),
            ) {
                gyro = f.gyro.clone();
                refits[i] = Some(f);
            }
        }
    }
    let spreads =
        fits.iter().zip(&refits).filter_map(|(f, r)| r.as_ref().map_or(&f.spread, |r| &r.spread).clone()).collect();
    (Model { gyro, spreads, channel: model.channel }, refits)
}

/// The chain `effects` learnt from the training samples `training` (gaps as NaN) as the diagnosis learns it, step by
/// step from the base model `base` (fitted as `base_fit`), each step from the samples less what the steps before
/// recovered ([`StepData::take_out`]), with a backfitting round ([`backfit`]) and a joint re-estimation
/// ([`joint::reestimate`]) after step `k` where `rounds[k]` says the diagnosis kept them; an effect whose
/// estimator finds no trace is skipped. Returns the model and the realisations the steps recovered (the training
/// samples less what the last step learnt from; `None` where no step recovered one), which an ensemble of the
/// model on these samples is given.
pub fn learn(
    effects: &[Effect],
    rounds: &[Rounds],
    base: &Model,
    base_fit: &NoiseFit,
    training: &[f64],
    temp_c: Option<&[f64]>,
    rate_hz: f64,
) -> (Model, Option<Vec<f64>>) {
    let mut model = base.clone();
    let gaps = gap_runs(training);
    let recorded = fill_gaps(training);
    let mut series = recorded.clone();
    let mut shaped: Option<Vec<f64>> = None;
    let mut fits = Vec::new();
    let mut recovered = false;
    for (k, &effect) in effects.iter().enumerate() {
        let data = StepData::new(&model.gyro, &series, shaped.as_deref(), &gaps, temp_c, rate_hz, base_fit, k == 0);
        if let Some(f) =
            effects::fit_effect(effect, &data.training(&recorded, &model.gyro, model.channel.as_ref(), temp_c, rate_hz))
        {
            if f.cleaned.is_some() {
                shaped = data.shaped_with(shaped.as_deref(), &f);
                recovered = true;
            }
            data.take_out(&mut series, &f);
            model = model.with(&f);
            fits.push(f);
        }
        let round = rounds.get(k).copied().unwrap_or_default();
        if round.backfit {
            let all: Vec<&EffectFit> = fits.iter().collect();
            let (m, refits) =
                backfit(&model, &all, &recorded, &series, shaped.as_deref(), &gaps, temp_c, rate_hz, base_fit);
            for (f, r) in fits.iter_mut().zip(refits) {
                if let Some(r) = r {
                    *f = r;
                }
            }
            model = m;
        }
        if round.joint {
            if let Some(m) = joint::reestimate(&model, &series, shaped.as_deref(), &gaps, temp_c, rate_hz) {
                model = m;
            }
        }
    }
    let realised = recovered.then(|| recorded.iter().zip(&series).map(|(r, s)| r - s).collect());
    (model, realised)
}

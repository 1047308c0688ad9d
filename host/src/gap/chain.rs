//! The chain of effects: after the best effect, the remaining candidates are ranked again on the model that
//! already has it, while a significant gap remains and a candidate removes at least a quarter of it.
//!
//! A real bench record often carries more than one effect (a temperature coupling and a resonance, a Gauss-Markov
//! hump and outliers). Each step of the chain starts from the model so far ([`Model`]): its ensemble is the
//! comparison the step ranks against, and its estimators see the training samples less the model's deterministic
//! part ([`deterministic_part`]: the temperature response, the sinusoids, the warm-up) and less the realisations
//! that earlier steps recovered ([`StepData::take_out`]: the bistable bias's levels, the bias steps, the spikes),
//! with the model itself as their base, so that the effect they add is added to every effect found before. The
//! IEEE base terms are re-fitted on those samples for the estimators that need a base fit. Each step reports where
//! the gap lay on the model before it, the gap there before and after on both parts, and its ranking; the
//! held-out check of the whole chain compares the base model with the last one, every parameter frozen from
//! training.
//!
//! Effects found one after the other are each read with only the ones before them in place: a filter corner read
//! with a resonance still in the record takes part of the bump for its knee, and the resonance is then read on
//! that corner. [`backfit`] estimates each effect again on the final model less itself; the diagnosis runs it when
//! a later step's candidate explains too little on the chain as found, and once over the whole chain, keeping it
//! where the fit improves, and [`learn`] repeats it where the diagnosis did.

use octavar_shared::sensor::Channel;
use octavar_shared::sim::effects::{Sinusoids, WarmUp};
use octavar_shared::sim::noise::LowPass;
use octavar_shared::sim::temperature::ThermalLag;
use octavar_shared::sim::GyroSim;

use std::ops::Range;

use super::base::fit_base;
use super::effects::{self, Effect, EffectFit, ParamSpread, TrainingData};
use super::fill::{fill_gaps, gap_runs, refill, with_gaps};
use super::judge::Evaluated;
use super::rank::{CandidateResult, Location, PartGap};
use crate::fit::{FitOptions, NoiseFit};

/// Most effects a chain holds.
pub const MAX_STEPS: usize = 4;

/// A model of the chain: the simulation model, the spreads of its effects' parameters and its ADC channel.
#[derive(Clone, Debug)]
pub struct Model {
    /// The simulation model (the base terms and every effect so far).
    pub gyro: GyroSim,
    /// The sampling spread of each effect's parameters, in the chain's order.
    pub spreads: Vec<ParamSpread>,
    /// The ADC channel (`None`: the analog rate).
    pub channel: Option<Channel>,
}

impl Model {
    /// This model with `fit`'s effect added (its model already holds this one's effects).
    pub fn with(&self, fit: &EffectFit) -> Model {
        let mut spreads = self.spreads.clone();
        spreads.extend(fit.spread.clone());
        Model { gyro: fit.gyro.clone(), spreads, channel: fit.channel.or(self.channel) }
    }
}

/// One step of the chain.
#[derive(Clone, Debug)]
pub struct Step {
    /// The effect added.
    pub effect: Effect,
    /// Its fit (its model has every effect of the chain up to this one).
    pub fit: EffectFit,
    /// The comparison of that model with the record.
    pub eval: Evaluated,
    /// Where the gap lay on the model before this step.
    pub location: Location,
    /// The training gap at that location, before and after this step.
    pub training: PartGap,
    /// The held-out gap at that location (the same view and band), before and after (`None` without a holdout).
    pub holdout: Option<PartGap>,
    /// Every candidate of this step, in vocabulary order.
    pub candidates: Vec<CandidateResult>,
    /// The effect estimated again on the chain's final model less itself ([`backfit`]), where the diagnosis kept
    /// that round: its parameters are the ones the final model carries.
    pub refit: Option<EffectFit>,
    /// Whether a backfitting round followed this step (the re-learning on other data repeats it).
    pub backfitted: bool,
}

impl Step {
    /// The fit whose parameters the final model carries: the backfitted one where there is one.
    pub fn final_fit(&self) -> &EffectFit {
        self.refit.as_ref().unwrap_or(&self.fit)
    }
}

/// The deterministic part of `gyro`'s rate over the `temp_c.len()` (or `n`) first samples of the record at
/// `rate_hz`: its temperature response through the thermal lag, its sinusoids and its warm-up, through its
/// bandwidth as the simulator applies it. `None` when it has none.
pub fn deterministic_part(gyro: &GyroSim, rate_hz: f64, temp_c: Option<&[f64]>, n: usize) -> Option<Vec<f64>> {
    let coupling = gyro.temperature.filter(|_| temp_c.is_some());
    if coupling.is_none() && gyro.sinusoids.is_empty() && gyro.warm_up.is_none() {
        return None;
    }
    let tau0 = 1.0 / rate_hz;
    let mut sines = Sinusoids::new(&gyro.sinusoids, tau0);
    let mut warm_up = gyro.warm_up.map(|w| WarmUp::new(&w, tau0));
    let mut lag = coupling.map(|c| ThermalLag::new(&c, tau0));
    let mut low_pass = gyro.bandwidth_hz.map(|f| LowPass::new(f, rate_hz));
    Some(
        (0..n)
            .map(|i| {
                let mut v = sines.next(i as u64) + warm_up.as_mut().map_or(0.0, WarmUp::next_dps);
                if let (Some(l), Some(t)) = (lag.as_mut(), temp_c) {
                    v += l.next(t[i]);
                }
                match low_pass.as_mut() {
                    Some(lp) => lp.next(v),
                    None => v,
                }
            })
            .collect(),
    )
}

/// What a step's estimators learn from: the training samples (gaps filled) less the realisations the steps before
/// recovered and less the model's deterministic part, and an IEEE fit of them (the base fit itself while the
/// model is the base).
pub struct StepData {
    /// The samples, deg/s.
    pub rate_dps: Vec<f64>,
    /// Their base fit.
    pub base_fit: NoiseFit,
    /// The runs of samples missing or masked in the training part (filled in `rate_dps`).
    pub gaps: Vec<Range<usize>>,
}

impl StepData {
    /// The data of a step on `model`, from the training samples `filled` (the runs `gaps` filled) and their
    /// temperature; `first` says whether this is the chain's first step (the model is the base, fitted as
    /// `base_fit`). The gaps are filled again once the deterministic part is out, and the IEEE fit takes them as
    /// gaps.
    pub fn new(
        model: &GyroSim,
        filled: &[f64],
        gaps: &[Range<usize>],
        temp_c: Option<&[f64]>,
        rate_hz: f64,
        base_fit: &NoiseFit,
        first: bool,
    ) -> StepData {
        let gaps = gaps.to_vec();
        if first {
            return StepData { rate_dps: filled.to_vec(), base_fit: base_fit.clone(), gaps };
        }
        let mut rate_dps: Vec<f64> = match deterministic_part(model, rate_hz, temp_c, filled.len()) {
            Some(d) => filled.iter().zip(&d).map(|(x, d)| x - d).collect(),
            None => filled.to_vec(),
        };
        refill(&mut rate_dps, &gaps);
        let base_fit = fit_base(&with_gaps(&rate_dps, &gaps), rate_hz, &FitOptions::default())
            .map(|(_, f)| f)
            .unwrap_or_else(|_| base_fit.clone());
        StepData { rate_dps, base_fit, gaps }
    }

    /// `series` (the samples this step's data was made from) less the realisation of the effect that `fit`
    /// recovered from this step's data, where it recovered one ([`EffectFit::cleaned`]): what the next step's
    /// data is made from.
    pub fn take_out(&self, series: &mut [f64], fit: &EffectFit) {
        if let Some(cleaned) = fit.cleaned.as_deref().filter(|c| c.len() == series.len()) {
            for ((s, d), c) in series.iter_mut().zip(&self.rate_dps).zip(cleaned) {
                *s -= d - c;
            }
        }
    }

    /// `before` (the realisations the steps before recovered, training length; `None`: none) with the one `fit`
    /// recovered from this step's data added; `None` when `fit` recovered none.
    pub fn realised_with(&self, before: Option<&[f64]>, fit: &EffectFit) -> Option<Vec<f64>> {
        let cleaned = fit.cleaned.as_deref().filter(|c| c.len() == self.rate_dps.len())?;
        Some(match before {
            Some(b) => b.iter().zip(&self.rate_dps).zip(cleaned).map(|((b, d), c)| b + d - c).collect(),
            None => self.rate_dps.iter().zip(cleaned).map(|(d, c)| d - c).collect(),
        })
    }

    /// The estimators' view of it, on `model`.
    pub fn training<'a>(&'a self, model: &'a GyroSim, temp_c: Option<&'a [f64]>, rate_hz: f64) -> TrainingData<'a> {
        TrainingData {
            rate_dps: &self.rate_dps,
            temp_c,
            rate_hz,
            base: model,
            base_fit: &self.base_fit,
            gaps: &self.gaps,
        }
    }
}

/// `gyro` without `effect` (its field cleared), for the effects the backfitting round estimates again; `None` for
/// the ones it leaves as found: quantisation (a channel, not a field) and the effects that recovered a realisation
/// (the samples the others learnt from have it taken out).
pub fn without(gyro: &GyroSim, effect: Effect) -> Option<GyroSim> {
    let mut g = gyro.clone();
    match effect {
        Effect::Temperature => g.temperature = None,
        Effect::Sinusoid => g.sinusoids.clear(),
        Effect::Bandwidth => g.bandwidth_hz = None,
        Effect::GaussMarkov => g.gauss_markov = None,
        Effect::Resonance => g.resonance = None,
        Effect::WarmUp => g.warm_up = None,
        Effect::Quantization | Effect::BiasSteps | Effect::Outliers | Effect::Bistable => return None,
    }
    Some(g)
}

/// One backfitting round over a chain of two or more effects: each effect, in the chain's order, is estimated
/// again on the final model less itself, so that it is read with every other effect of the chain in place rather
/// than only the ones found before it (a bandwidth read before the resonance under it takes part of the bump for
/// its corner; the resonance then sits on that corner). `fits` are the chain's fits in its order, `series` the
/// training samples less the recovered realisations (gaps filled, the runs `gaps`). Returns the final model and,
/// per step, the fit that replaced it (`None`: kept as found, because the effect is one [`without`] leaves or
/// its estimator found no trace on the model without it).
#[allow(clippy::too_many_arguments)]
pub fn backfit(
    model: &Model,
    fits: &[&EffectFit],
    series: &[f64],
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
            let data = StepData::new(&rest, series, gaps, temp_c, rate_hz, base_fit, false);
            if let Some(f) = effects::estimate(fit.effect, &data.training(&rest, temp_c, rate_hz)) {
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
/// recovered ([`StepData::take_out`]), with a backfitting round ([`backfit`]) after step `k` where `rounds[k]`, as
/// the diagnosis did; an effect whose estimator finds no trace is skipped.
pub fn learn(
    effects: &[Effect],
    rounds: &[bool],
    base: &Model,
    base_fit: &NoiseFit,
    training: &[f64],
    temp_c: Option<&[f64]>,
    rate_hz: f64,
) -> Model {
    let mut model = base.clone();
    let gaps = gap_runs(training);
    let mut series = fill_gaps(training);
    let mut fits = Vec::new();
    for (k, &effect) in effects.iter().enumerate() {
        let data = StepData::new(&model.gyro, &series, &gaps, temp_c, rate_hz, base_fit, k == 0);
        if let Some(f) = effects::estimate(effect, &data.training(&model.gyro, temp_c, rate_hz)) {
            data.take_out(&mut series, &f);
            model = model.with(&f);
            fits.push(f);
        }
        if rounds.get(k).copied().unwrap_or(false) {
            let all: Vec<&EffectFit> = fits.iter().collect();
            let (m, refits) = backfit(&model, &all, &series, &gaps, temp_c, rate_hz, base_fit);
            for (f, r) in fits.iter_mut().zip(refits) {
                if let Some(r) = r {
                    *f = r;
                }
            }
            model = m;
        }
    }
    model
}

#[cfg(test)]
mod tests {
    use super::*;
    use octavar_shared::sim::{Sinusoid, TempCoupling};

    /// The deterministic part is the sinusoids and the lagged coupling as written out here from their
    /// definitions, through the first-order low-pass `y = a y + (1 - a) x` started at its first input.
    #[test]
    fn the_deterministic_part_follows_its_closed_form() {
        let rate_hz = 10.0;
        let n = 5000;
        let mut gyro = GyroSim {
            temperature: Some(TempCoupling { dps_per_c: 0.02, ref_c: 25.0, lag_s: 30.0 }),
            bandwidth_hz: Some(2.0),
            ..Default::default()
        };
        gyro.sinusoids.push(Sinusoid { amplitude_dps: 0.3, period_s: 7.0, phase_rad: 0.4 }).unwrap();
        let temp: Vec<f64> = (0..n).map(|i| 25.0 + 2.0 * (i as f64 / 800.0).sin()).collect();
        let got = deterministic_part(&gyro, rate_hz, Some(&temp), n).unwrap();
        let a_lag = (-1.0 / (rate_hz * 30.0f64)).exp();
        let a_lp = (-2.0 * std::f64::consts::PI * 2.0 / rate_hz).exp();
        let (mut t_lag, mut y) = (temp[0], 0.0);
        for i in 0..n {
            t_lag = if i == 0 { temp[0] } else { a_lag * t_lag + (1.0 - a_lag) * temp[i] };
            let x = 0.3 * (2.0 * std::f64::consts::PI * i as f64 / (7.0 * rate_hz) + 0.4).sin() + 0.02 * (t_lag - 25.0);
            y = if i == 0 { x } else { a_lp * y + (1.0 - a_lp) * x };
            assert!((got[i] - y).abs() < 1e-9, "sample {i}: {} vs {y}", got[i]);
        }
        // Without a temperature the coupling adds nothing; a model of noise terms alone has no deterministic part.
        gyro.sinusoids.clear();
        assert!(deterministic_part(&gyro, rate_hz, None, n).is_none());
        assert!(deterministic_part(&GyroSim { n_deg_per_rt_s: 0.1, ..Default::default() }, rate_hz, None, n).is_none());
    }
}

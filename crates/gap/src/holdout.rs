//! The held-out check's predictive ensembles: the diagnosis's own learning procedure, re-run on each member's
//! simulated training part (a parametric bootstrap of train-then-predict).
//!
//! A model learnt from one training part carries that part's realisation: a coupling read 20% high because the
//! noise happened to follow the temperature over four cycles, a sinusoid's period 2% off. The plain ensemble of
//! that model spreads by the noise alone, so a correct effect learnt with such an error still reads as a gap on
//! the holdout. The predictive ensemble asks the question the held-out check is about: does the holdout look like
//! what a model learnt from a training part like the real one predicts? Member `i` simulates the training part
//! of the learnt model, learns from it exactly as the diagnosis learnt from the real one ([`Learner`]: the base
//! fit, then the chain's estimators in order), and simulates what it learnt over the holdout
//! ([`super::ensemble::predict_holdout`]). Every parameter applied to the real holdout is still the one frozen
//! from the real training part; only the ensemble it is judged against changes.

use octavar_shared::sensor::Channel;
use octavar_shared::sim::GyroSim;

use super::base::{base_model, fit_base};
use super::chain::{self, Model};
use super::compare::{self, ViewGap};
use super::effects::Effect;
use super::ensemble;
use super::error::GapError;
use super::judge::Judge;
use octavar_stats::fit::{FitOptions, NoiseFit};

/// The holdout's views against the predictive ensembles: the base model's and the chain's (`None` without a
/// chain).
pub(crate) type PredictiveViews = (Vec<ViewGap>, Option<Vec<ViewGap>>);

/// The holdout's views against the predictive ensembles: the base model's (its plain ensemble's views
/// `base_holdout` where the base was not learnt from the record) and the chain's (`None` without a chain).
/// `None` without a holdout.
///
/// # Errors
/// A model the simulator rejects.
pub(crate) fn predictive_views(
    judge: &Judge,
    learner: &Learner,
    base: &GyroSim,
    base_holdout: &[ViewGap],
    found: &chain::Found,
    n_train: usize,
) -> Result<Option<PredictiveViews>, GapError> {
    let (Some(hp), Some(real_hold)) = (judge.hold_plan(), judge.real_holdout()) else {
        return Ok(None);
    };
    let rec = judge.record();
    let seeds = judge.seeds();
    let channel = learner.channel;
    // A base model not learnt from the record predicts what its plain ensemble does.
    let base_views = match learner.fixed_base {
        Some(_) => base_holdout.to_vec(),
        None => {
            let relearn = |t: &[f64]| (learner.base(t).1, channel);
            let m = ensemble::predict_holdout(base, channel.as_ref(), &rec, hp, seeds, None, &relearn)
                .map_err(|err| GapError::Sim { model: "base".into(), err })?;
            compare::compare(hp, real_hold, &m)
        }
    };
    let Some(last) = found.steps.last() else {
        return Ok(Some((base_views, None)));
    };
    let effects: Vec<Effect> = found.steps.iter().map(|s| s.effect).collect();
    let rounds: Vec<_> = found.steps.iter().map(|s| s.rounds()).collect();
    let model = &found.model;
    let explained = ensemble::temperature_response(&model.gyro, &rec);
    let resp_hold = explained.as_deref().map(|r| &r[n_train..]);
    let relearn = |t: &[f64]| learner.with_chain(&effects, &rounds, t);
    let m = ensemble::predict_holdout(&model.gyro, model.channel.as_ref(), &rec, hp, seeds, resp_hold, &relearn)
        .map_err(|err| GapError::Sim { model: last.effect.name().to_string(), err })?;
    // The real holdout as this model was judged on it (less its own temperature response).
    let chain_views = found.eval.real_holdout.as_ref().map(|real| compare::compare(hp, real, &m));
    Ok(Some((base_views, chain_views)))
}

/// The diagnosis's learning procedure, to be re-run on simulated training parts.
pub struct Learner<'a> {
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// The training part's temperature (the members are driven by it too).
    pub temp_c: Option<&'a [f64]>,
    /// The base fit's options.
    pub fit: &'a FitOptions,
    /// A base fit made outside the record ([`super::GapOptions::base_fit`]): then it is not re-learnt.
    pub fixed_base: Option<&'a NoiseFit>,
    /// The base fit of the real training part, used when a member's own fit fails.
    pub fallback: &'a NoiseFit,
    /// The ensemble's channel (`None`: the analog rate).
    pub channel: Option<Channel>,
}

impl Learner<'_> {
    /// The base fit and model learnt from `train`.
    pub fn base(&self, train: &[f64]) -> (NoiseFit, GyroSim) {
        let f = match self.fixed_base {
            Some(f) => f.clone(),
            None => fit_base(train, self.rate_hz, self.fit).map(|(_, f)| f).unwrap_or_else(|_| self.fallback.clone()),
        };
        let g = base_model(&f, train);
        (f, g)
    }

    /// The model with the chain `effects` learnt from `train` as the diagnosis learns it ([`chain::learn`]; an
    /// effect whose estimator finds no trace is left out), and its channel.
    pub fn with_chain(
        &self,
        effects: &[Effect],
        rounds: &[chain::Rounds],
        train: &[f64],
    ) -> (GyroSim, Option<Channel>) {
        let (f, base) = self.base(train);
        let start = Model { gyro: base, spreads: Vec::new(), channel: self.channel };
        let (m, _) = chain::learn(effects, rounds, &start, &f, train, self.temp_c, self.rate_hz);
        (m.gyro, m.channel)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ensemble::{predict_holdout, simulate, Target};
    use crate::views::{Plan, ViewKind};

    fn white_record(n: usize, sigma: f64) -> Vec<f64> {
        octavar_stats::test_signals::white(n, 11).iter().map(|v| v * sigma).collect()
    }

    /// A re-learning that changes nothing: the predictive ensemble is the plain one of the same model with the
    /// salted seeds, bit for bit (the holdout part, its measures, the salt).
    #[test]
    fn a_relearning_that_changes_nothing_is_the_plain_ensemble() {
        let x = white_record(4096, 0.1);
        let rec = Target { rate_dps: &x, temp_c: None, rate_hz: 10.0, n_train: 2048, oversample: 1 };
        let gyro = GyroSim { n_deg_per_rt_s: 0.1 / 10f64.sqrt(), ..Default::default() };
        let train = Plan::new(rec.training(), None, 10.0);
        let hold = Plan::new(rec.holdout(), None, 10.0);
        let seeds = [1u64, 2, 3];
        let same = |_: &[f64]| (gyro.clone(), None);
        let pred = predict_holdout(&gyro, None, &rec, &hold, &seeds, None, &same).unwrap();
        let salted: Vec<u64> = seeds.iter().map(|s| s.wrapping_add(super::super::ensemble::PREDICT_SALT)).collect();
        let plain = simulate(&gyro, &[], None, &rec, &train, Some(&hold), &salted, None).unwrap();
        let bits = |m: &[crate::views::Measure]| -> Vec<Vec<u64>> {
            m.iter().flat_map(|m| m.values.iter().map(|v| v.iter().map(|x| x.to_bits()).collect())).collect()
        };
        assert!(!pred.is_empty());
        assert_eq!(bits(&pred), bits(&plain.holdout));
    }

    /// White noise: the predictive spread of the holdout's ln ADEV at tau0 is the plain one (the noise's) and the
    /// spread of what the members re-learnt (the fitted curve's ln ADEV at tau0, closed form) in quadrature. The
    /// re-learning is the diagnosis's own base fit, whose 3% model allowance makes N about as uncertain as the
    /// curve at a few hundred samples, so the predictive spread is well above the plain one.
    #[test]
    fn the_predictive_spread_carries_the_learnt_parameters_error() {
        let rate_hz = 10.0;
        let tau0 = 1.0 / rate_hz;
        let x = white_record(1 << 15, 0.1);
        let rec = Target { rate_dps: &x, temp_c: None, rate_hz, n_train: 1 << 14, oversample: 1 };
        let f = crate::base::fit_base(rec.training(), rate_hz, &FitOptions::default()).unwrap().1;
        let gyro = base_model(&f, rec.training());
        let learner = Learner {
            rate_hz,
            temp_c: None,
            fit: &FitOptions::default(),
            fixed_base: None,
            fallback: &f,
            channel: None,
        };
        let train = Plan::new(rec.training(), None, rate_hz);
        let hold = Plan::new(rec.holdout(), None, rate_hz);
        let seeds: Vec<u64> = (100..160).collect();
        let learnt = std::sync::Mutex::new(Vec::new());
        let relearn = |t: &[f64]| {
            let (f, g) = learner.base(t);
            learnt.lock().unwrap().push(0.5 * f.model_avar(tau0).ln());
            (g, None)
        };
        let pred = predict_holdout(&gyro, None, &rec, &hold, &seeds, None, &relearn).unwrap();
        let plain = simulate(&gyro, &[], None, &rec, &train, Some(&hold), &seeds, None).unwrap().holdout;
        let sd = |v: &[f64]| {
            let mu = v.iter().sum::<f64>() / v.len() as f64;
            (v.iter().map(|x| (x - mu) * (x - mu)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
        };
        let at_tau0 = |m: &[crate::views::Measure]| -> Vec<f64> {
            m.iter().map(|m| m.values[ViewKind::Adev as usize][0]).collect()
        };
        let (sp, sn, sl) = (sd(&at_tau0(&pred)), sd(&at_tau0(&plain)), sd(&learnt.lock().unwrap()));
        let expected = (sn * sn + sl * sl).sqrt();
        assert!(sp > 1.3 * sn, "predictive {sp:.2e} against plain {sn:.2e}: the learnt error is missing");
        // Each sd from 60 members is within 9% (1 sigma).
        assert!((0.8..1.25).contains(&(sp / expected)), "predictive {sp:.2e}, plain (+) learnt {expected:.2e}");
    }
}

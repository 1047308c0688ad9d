//! The judge of models: a record's two parts, their view plans and real measures, and the ensemble's seeds,
//! against which any model's ensemble is simulated and compared. [`super::diagnose`] judges the base model and
//! each candidate with it; the withheld-effect tests judge the model that made the record, with the same seeds.

use octavar_shared::sensor::Channel;
use octavar_shared::sim::GyroSim;

use super::compare::{self, ViewGap};
use super::error::GapError;
use super::fill::fill_gaps;
use super::input::{GapInput, GapOptions};
use super::{effects, ensemble, views};

/// One model's ensemble, compared with the real record on both parts.
#[derive(Clone, Debug)]
pub struct Evaluated {
    /// Views on the training part.
    pub training: Vec<ViewGap>,
    /// Views on the holdout part (empty without a holdout).
    pub holdout: Vec<ViewGap>,
    /// The ensemble's OADEV band on the training part: (tau, min, max).
    pub adev_band: Vec<(f64, f64, f64)>,
    /// The real holdout's measure this model was compared with (for a model with a temperature coupling, less
    /// the coupling's response); `None` without a holdout.
    pub real_holdout: Option<views::Measure>,
}

/// A record made ready for judging models against it.
pub struct Judge<'a> {
    rate_dps: &'a [f64],
    /// The temperature with its gaps filled ([`fill_gaps`]).
    temp_c: Option<Vec<f64>>,
    rate_hz: f64,
    n_train: usize,
    oversample: usize,
    seeds: Vec<u64>,
    train_plan: views::Plan,
    hold_plan: Option<views::Plan>,
    real_train: views::Measure,
    real_hold: Option<views::Measure>,
}

impl<'a> Judge<'a> {
    /// Plans and real measures of both parts of `input` (no holdout part when it has no held-out samples), with
    /// the seeds and oversampling of `opts`.
    pub fn new(input: &'a GapInput, opts: &GapOptions) -> Judge<'a> {
        let temp_c = input.temp_c.as_deref().map(fill_gaps);
        let oversample = opts.oversample.max(1);
        let (train_plan, hold_plan, real_train, real_hold) = {
            let rec = ensemble::Target {
                rate_dps: &input.rate_dps,
                temp_c: temp_c.as_deref(),
                rate_hz: input.rate_hz,
                n_train: input.n_train,
                oversample,
            };
            let train_plan = views::Plan::new(rec.training(), rec.training_temp(), rec.rate_hz);
            let hold_plan =
                (input.n_holdout() > 0).then(|| views::Plan::new(rec.holdout(), rec.holdout_temp(), rec.rate_hz));
            let real_train = train_plan.measure(rec.training(), rec.training_temp(), true);
            let real_hold = hold_plan.as_ref().map(|p| p.measure(rec.holdout(), rec.holdout_temp(), true));
            (train_plan, hold_plan, real_train, real_hold)
        };
        Judge {
            rate_dps: &input.rate_dps,
            temp_c,
            rate_hz: input.rate_hz,
            n_train: input.n_train,
            oversample,
            seeds: (0..opts.seeds as u64).map(|i| opts.first_seed + i).collect(),
            train_plan,
            hold_plan,
            real_train,
            real_hold,
        }
    }

    /// The record (its temperature's gaps filled).
    pub fn record(&self) -> ensemble::Target<'_> {
        ensemble::Target {
            rate_dps: self.rate_dps,
            temp_c: self.temp_c.as_deref(),
            rate_hz: self.rate_hz,
            n_train: self.n_train,
            oversample: self.oversample,
        }
    }

    /// The ensemble's seeds.
    pub fn seeds(&self) -> &[u64] {
        &self.seeds
    }

    /// The holdout's view plan; `None` without a holdout.
    pub fn hold_plan(&self) -> Option<&views::Plan> {
        self.hold_plan.as_ref()
    }

    /// The real holdout's measure; `None` without a holdout.
    pub fn real_holdout(&self) -> Option<&views::Measure> {
        self.real_hold.as_ref()
    }

    /// The real training part with `less` applied to it (gaps filled for it, then put back), measured on the
    /// training plan: what [`Judge::less_jumps`] compares every model's members with.
    pub fn training_less(&self, less: &(dyn Fn(&mut [f64]) + Sync)) -> views::Measure {
        let rec = self.record();
        self.train_plan.measure(&ensemble::less_in_gaps(rec.training(), less), rec.training_temp(), true)
    }

    /// `gyro`'s ensemble compared with the record on the training part, in the views of the samples themselves
    /// (Allan deviation, spectrum, distribution), with `less` applied to every member's training samples as it was
    /// to the real ones, measured as `real` ([`Judge::training_less`], [`ensemble::simulate_less`]): with a named
    /// jump process's scan as `less` ([`effects::JumpScan`]), record and members are compared with their jumps
    /// taken out the same way, so the members' fresh jumps no longer hide what else the record holds. `name` names
    /// the model in an error.
    ///
    /// # Errors
    /// [`GapError::Sim`]: the simulator rejects the model.
    pub fn less_jumps(
        &self,
        gyro: &GyroSim,
        spreads: &[effects::ParamSpread],
        ch: Option<&Channel>,
        less: &(dyn Fn(&mut [f64]) + Sync),
        real: &views::Measure,
        name: &str,
    ) -> Result<Vec<ViewGap>, GapError> {
        let rec = self.record();
        let members = ensemble::simulate_less(gyro, spreads, ch, &rec, &self.train_plan, &self.seeds, less)
            .map_err(|err| GapError::Sim { model: name.to_string(), err })?;
        let mut views = compare::compare(&self.train_plan, real, &members);
        views.retain(|v| v.view != views::ViewKind::Temperature);
        Ok(views)
    }

    /// `gyro`'s ensemble (its members drawing their effects' parameters from `spreads`, on channel `ch` or as the analog rate)
    /// compared with the record on both parts. A model with a temperature coupling is judged in the temperature
    /// view on what its coupling leaves, on the real record as on each member. `realised` is the realisation of
    /// the model's random effects recovered from the training part (the bistable bias's levels, the bias steps, the
    /// spikes; training length, deg/s): the temperature view takes the real training part less it, since a
    /// coherence with the temperature compares the record with a driver those effects do not follow, and their
    /// power, once known, only hides a coupling (a member's coherence scatters about the same null level with or
    /// without them). The other views compare it as recorded with members that draw it afresh. `name` names the
    /// model in an error.
    ///
    /// # Errors
    /// [`GapError::Sim`]: the simulator rejects the model.
    pub fn evaluate(
        &self,
        gyro: &GyroSim,
        spreads: &[effects::ParamSpread],
        ch: Option<&Channel>,
        realised: Option<&[f64]>,
        name: &str,
    ) -> Result<Evaluated, GapError> {
        let rec = self.record();
        let explained = ensemble::temperature_response(gyro, &rec);
        let e = ensemble::simulate(
            gyro,
            spreads,
            ch,
            &rec,
            &self.train_plan,
            self.hold_plan.as_ref(),
            &self.seeds,
            explained.as_deref(),
        )
        .map_err(|err| GapError::Sim { model: name.to_string(), err })?;
        let known_train: Option<Vec<f64>> = match (explained.as_deref(), realised) {
            (Some(resp), Some(r)) => Some(resp[..self.n_train].iter().zip(r).map(|(a, b)| a + b).collect()),
            (Some(resp), None) => Some(resp[..self.n_train].to_vec()),
            (None, Some(r)) => Some(r.to_vec()),
            (None, None) => None,
        };
        let remeasured = known_train.as_ref().map(|known| {
            let train = self.train_plan.with_explained(&self.real_train, rec.training(), rec.training_temp(), known);
            let hold = explained.as_ref().and_then(|resp| {
                let resp_hold = &resp[self.n_train..];
                self.hold_plan
                    .as_ref()
                    .zip(self.real_hold.as_ref())
                    .map(|(p, m)| p.with_explained(m, rec.holdout(), rec.holdout_temp(), resp_hold))
            });
            (train, hold)
        });
        let (real_train, real_hold) = match &remeasured {
            Some((t, h)) => (t, h.as_ref().or(self.real_hold.as_ref())),
            None => (&self.real_train, self.real_hold.as_ref()),
        };
        let training = compare::compare(&self.train_plan, real_train, &e.training);
        let holdout = match (&self.hold_plan, real_hold) {
            (Some(p), Some(r)) => compare::compare(p, r, &e.holdout),
            _ => Vec::new(),
        };
        let adev_band = self.train_plan.points[0]
            .iter()
            .enumerate()
            .filter_map(|(i, info)| {
                let v: Vec<f64> = e.training.iter().map(|m| m.adev[i]).filter(|x| x.is_finite() && *x > 0.0).collect();
                (!v.is_empty()).then(|| {
                    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
                    let hi = v.iter().copied().fold(0.0, f64::max);
                    (info.tau_s, lo, hi)
                })
            })
            .collect();
        Ok(Evaluated { training, holdout, adev_band, real_holdout: real_hold.cloned() })
    }
}

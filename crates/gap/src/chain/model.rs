//! The chain's model and steps: the simulation model with every effect found so far, what each step added and
//! what named it.

use octavar_shared::sensor::Channel;
use octavar_shared::sim::GyroSim;
use serde::Serialize;

use crate::effects::{Effect, EffectFit, ParamSpread};
use crate::evidence::Evidence;
use crate::judge::Evaluated;
use crate::rank::{CandidateResult, Location, PartGap};

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

/// What named a step's effect.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "route", rename_all = "snake_case")]
pub enum NamedBy {
    /// The views' gap: the effect removed at least a quarter of the significant gap the model before it left.
    View,
    /// The effect's own estimator, beyond a threshold calibrated on effect-free records, where no view's gap
    /// named it ([`crate::evidence`]).
    Estimator(Evidence),
    /// The views with a named jump process's jumps taken out of the record and of every member alike
    /// ([`crate::judge::Judge::less_jumps`]), where the process's fresh jumps in the members hid the effect from
    /// the plain views: it removed at least a quarter of that comparison's significant gap.
    ViewsLessJumps {
        /// The gap of that comparison on the model before the effect.
        gap_before: f64,
        /// The same with the effect.
        gap_after: f64,
    },
}

/// One step of the chain.
#[derive(Clone, Debug)]
pub struct Step {
    /// The effect added.
    pub effect: Effect,
    /// What named it.
    pub named_by: NamedBy,
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
    /// The effect estimated again on the chain's final model less itself ([`super::backfit`]), where the diagnosis kept
    /// that round: its parameters are the ones the final model carries.
    pub refit: Option<EffectFit>,
    /// Whether a backfitting round followed this step (the re-learning on other data repeats it).
    pub backfitted: bool,
    /// Whether a joint re-estimation of the base terms and every effect so far followed this step and was kept
    /// ([`super::joint`]: where the search was stuck after it, or after the chain's last step; the re-learning on
    /// other data repeats it).
    pub joint: bool,
}

/// The rounds that followed a step, which a chain learnt again on other data repeats ([`super::learn`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Rounds {
    /// A backfitting round ([`super::backfit`]).
    pub backfit: bool,
    /// A joint re-estimation ([`super::joint::reestimate`]).
    pub joint: bool,
}

impl Step {
    /// The rounds that followed this step.
    pub fn rounds(&self) -> Rounds {
        Rounds { backfit: self.backfitted, joint: self.joint }
    }
}

impl Step {
    /// The fit whose parameters the final model carries: the backfitted one where there is one.
    pub fn final_fit(&self) -> &EffectFit {
        self.refit.as_ref().unwrap_or(&self.fit)
    }

    /// Whether a later round (backfitting, joint re-estimation) moved the effect's parameters from the ones its
    /// step found.
    pub fn moved(&self) -> bool {
        self.refit.as_ref().is_some_and(|r| r.params != self.fit.params)
    }
}

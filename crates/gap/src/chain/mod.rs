//! The chain of effects: which effects a record holds beyond the base model, found one step at a time.
//!
//! A real bench record often carries more than one effect (a temperature coupling and a resonance, a Gauss-Markov
//! hump and outliers). Each step of the chain starts from the model so far ([`Model`]): its ensemble is the
//! comparison the step ranks against, and its estimators see the training samples less the model's deterministic
//! part ([`deterministic_part`]: the temperature response, the sinusoids, the warm-up) and less the realisations
//! that earlier steps recovered ([`StepData::take_out`]: the bistable bias's levels, the bias steps, the spikes),
//! with the model itself as their base, so that the effect they add is added to every effect found before. The
//! IEEE base terms are re-fitted on those samples for the estimators that need a base fit.
//!
//! A step names an effect by one of three routes ([`search`], [`NamedBy`]):
//! - **the views**: while a significant gap remains, the remaining candidates are ranked on the model so far and
//!   the best is added when it removes at least a quarter of the gap's excess over what a right model leaves
//!   ([`crate::rank::explains`]). When no single candidate does, two effects may share the gap, each too
//!   small alone to take a quarter of it (a sinusoid beside a filter corner): the best-scored candidates are
//!   tried in pairs, the second estimated on the model with the first, and a pair that explains the gap is
//!   added as two steps.
//! - **the estimators**: an effect whose own test names it beyond a threshold calibrated on effect-free records
//!   ([`crate::evidence`]) is added where the views name nothing: a warm-up over the first minutes, a small
//!   temperature coupling beside a larger effect.
//! - **the views less the jumps**: beside a named jump process (a bistable bias, bias steps), the plain views
//!   compare the record with members that draw the process afresh, and its spread hides a partner of several
//!   times the base noise. Where neither route above names anything, the record and every member are compared
//!   again with their jumps found and taken out by the process's own scan, the same way on both
//!   ([`crate::judge::Judge::less_jumps`]); a remaining effect that removes a quarter of that comparison's
//!   significant gap, and leaves the plain views no worse, is added.
//!
//! The search is greedy, and a first step can take part of two effects' gap at once (bias steps drawn over a
//! telegraph's flips and its spikes score better than the telegraph, which leaves the spikes' tails): where the
//! greedy chain ends with a significant gap, the chain is searched again from the first ranking's best-scored other
//! candidate that explains the base's gap, and that chain is kept where it removes a quarter of the excess the
//! greedy one left (its score, parameters paid for, against the greedy one's total: [`crate::rank::explains`]).
//! The report says so ([`Retried`]).
//!
//! Each step reports where the gap lay on the model before it, the gap there before and after on both parts, its
//! ranking and what named it; the held-out check of the whole chain compares the base model with the last one,
//! every parameter frozen from training.
//!
//! Effects found one after the other are each read with only the ones before them in place: a filter corner read
//! with a resonance still in the record takes part of the bump for its knee, and the resonance is then read on
//! that corner. [`backfit`] estimates each effect again on the final model less itself; the search runs it when
//! a later step's candidate explains too little on the chain as found, and once over the whole chain, keeping it
//! where the fit improves, and [`learn`] repeats it where the diagnosis did. An ADC lattice read while spikes were
//! still in the samples holds their swing of the first differences as white noise; the round reads it again once
//! they are out.
//!
//! The base terms and every effect of the chain are re-estimated together ([`joint`]): the deterministic effects
//! by least squares in the time domain, the stochastic ones with the base terms on the Allan curve, GMWM-style.
//! The round is kept where the views find the model no worse. It runs where the search is stuck (a significant
//! gap that no route names an effect for), after which every route is tried once more on the re-estimated model,
//! and once the chain is found. It does not run after every step: there, the freedom of the effects found so far
//! covers part of the gap the next one leaves (a resonance widened over a filter's roll-off), and that effect
//! then goes unnamed. Where the search is stuck, no route names the next one as the model stands, and what is
//! off may be the chain's own estimates, each read with only the steps before it in place: the white noise a
//! base fit read beside a sinusoid and bias steps (a spectrum a quarter below the record's, held out at 14.7)
//! comes back to the record's once the sinusoid is in the model (held out at 1.7).
//!
//! Last, each effect the views named is tried out of the chain ([`prune`]): an effect read early in place of part
//! of a later one (a Gauss-Markov process before the filter corner it imitated) is dropped where the chain
//! without it agrees with the record as well.
//!
//! Then each effect the views named is tried in exchange for the best-scored other candidate of its own step
//! ([`exchange`]): a Gauss-Markov process that scored ahead of the sensor's filter corner while a resonance was
//! still unnamed gives way to the corner where the chain learnt with it scores clearly better.
//!
//! `model` holds the types, `data` what a step learns from, `backfit` the re-estimation of one effect at a time,
//! `joint` the joint one, `search` the steps, `prune` the backward step and `exchange` the trade of one effect for
//! another.

mod backfit;
mod data;
mod exchange;
pub mod joint;
mod model;
mod prune;
mod search;

pub use backfit::{backfit, learn, without};
pub use data::{deterministic_part, StepData};
pub(crate) use exchange::exchange;
pub use exchange::Exchanged;
pub use model::{Model, NamedBy, Rounds, Step, MAX_STEPS};
pub(crate) use prune::prune;
pub use prune::Pruned;
pub use search::ProgressFn;
pub use search::Retried;
pub(crate) use search::{search, Found, Progress, Start};

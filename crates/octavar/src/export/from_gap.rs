//! The figures of a gap diagnosis, for `octavar gap --export`: the base fit's terms of the diagnosed channel,
//! and as its bias model the Gauss-Markov process the diagnosis named, where it named one.
//!
//! A diagnosis that names `gauss_markov` has found an exponentially correlated bias that the simulation needs,
//! checked on the held-out part with its parameters frozen: a better bias model for a filter than the process
//! matched to the Allan curve alone, which is what the export falls back to without it.

use super::noise::{BiasModel, ImuNoise};
use crate::analyze::ChannelAnalysis;
use crate::fit::fit_gauss_markov;
use crate::gap::{Effect, GapReport};
use crate::quantity::Quantity;

impl ImuNoise {
    /// The figures of `report`'s channel `name` (its training mean `mean`, the static bias) for a config at the
    /// record's rate.
    pub fn from_gap(
        report: &GapReport,
        name: &str,
        mean: Option<f64>,
        source: &str,
        topic: &str,
        inflate: f64,
    ) -> Self {
        let q = report.input.quantity;
        let fit = report.base.fit.clone();
        let bias_model = fit_gauss_markov(&report.base.real_adev, &fit);
        let channel = ChannelAnalysis {
            name: name.to_string(),
            quantity: q,
            unit: q.unit().to_string(),
            tau0_s: 1.0 / report.input.rate_hz,
            n_samples: report.input.n_train,
            n_gaps: report.input.missing[0],
            mean,
            stats: Vec::new(),
            fit_points: report.base.real_adev.clone(),
            fit: Ok(fit),
            bias_model,
        }
        .with_quantity(q);
        let mut noise =
            ImuNoise::from_channels(std::slice::from_ref(&channel), source, report.input.rate_hz, topic, inflate);
        if let Some(model) = named_gauss_markov(report, inflate) {
            let sensor = match q {
                Quantity::AngularRate => noise.gyro.as_mut(),
                Quantity::Acceleration => noise.accel.as_mut(),
            };
            if let Some(s) = sensor {
                s.bias_model = Some(model);
            }
        }
        noise
    }
}

/// The Gauss-Markov bias of the diagnosis's final model, where its chain named one: SI, inflated, with the step
/// that named it and its training and held-out gaps.
fn named_gauss_markov(report: &GapReport, inflate: f64) -> Option<BiasModel> {
    let step = report.chain.steps.iter().position(|s| s.effect == Effect::GaussMarkov)?;
    let gm = report.model().gauss_markov?;
    let q = report.input.quantity;
    let s = &report.chain.steps[step];
    let held_out = s.holdout.as_ref().map_or_else(
        || "no held-out part".to_string(),
        |h| format!("held out {:.2} -> {:.2}, every parameter frozen", h.gap_before, h.gap_after),
    );
    let conv = if q.to_si() != 1.0 { " x pi/180" } else { "" };
    let inflated = if inflate != 1.0 { format!(" x {inflate} (--inflate)") } else { String::new() };
    Some(BiasModel {
        sigma: gm.sigma_dps * q.to_si() * inflate,
        tau_c_s: gm.tau_s,
        how: format!(
            "the gauss_markov effect the gap diagnosis named (step {} of its chain; its {} gap at tau {:.3e} .. {:.3e} s: \
             training {:.2} -> {:.2}, {held_out}): sigma = {:.4e} {}{conv}{inflated}, correlation time {:.4e} s",
            step + 1,
            s.location.view.name(),
            s.location.band_s[0],
            s.location.band_s[1],
            s.training.gap_before,
            s.training.gap_after,
            gm.sigma_dps,
            q.unit(),
            gm.tau_s
        ),
    })
}

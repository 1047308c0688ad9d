//! What a step's estimators learn from: the training samples less the model's deterministic part and less the
//! realisations earlier steps recovered, with an IEEE fit of them.

use std::ops::Range;

use octavar_shared::sensor::Channel;
use octavar_shared::sim::effects::{Sinusoids, WarmUp};
use octavar_shared::sim::noise::LowPass;
use octavar_shared::sim::temperature::ThermalLag;
use octavar_shared::sim::GyroSim;

use crate::base::fit_base;
use crate::effects::{jumps_through_filter, EffectFit, TrainingData};
use crate::fill::{refill, with_gaps};
use octavar_stats::fit::{FitOptions, NoiseFit};

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
    /// The realisations the steps before took out that the sensor's filter shapes, as taken out
    /// ([`TrainingData::shaped_dps`]).
    pub shaped: Option<Vec<f64>>,
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
    #[allow(clippy::too_many_arguments)] // the samples and what the steps took out, the record's context, the model
    pub fn new(
        model: &GyroSim,
        filled: &[f64],
        shaped: Option<&[f64]>,
        gaps: &[Range<usize>],
        temp_c: Option<&[f64]>,
        rate_hz: f64,
        base_fit: &NoiseFit,
        first: bool,
    ) -> StepData {
        let gaps = gaps.to_vec();
        let shaped = shaped.map(<[f64]>::to_vec);
        if first {
            return StepData { rate_dps: filled.to_vec(), shaped, base_fit: base_fit.clone(), gaps };
        }
        let mut rate_dps: Vec<f64> = match deterministic_part(model, rate_hz, temp_c, filled.len()) {
            Some(d) => filled.iter().zip(&d).map(|(x, d)| x - d).collect(),
            None => filled.to_vec(),
        };
        // The shaped realisations were taken out sharp; the model's sensor passes them through its filter.
        if let (Some(s), Some(f)) = (shaped.as_deref(), model.bandwidth_hz) {
            rate_dps = jumps_through_filter(&rate_dps, s, f, rate_hz);
        }
        refill(&mut rate_dps, &gaps);
        let base_fit = fit_base(&with_gaps(&rate_dps, &gaps), rate_hz, &FitOptions::default())
            .map(|(_, f)| f)
            .unwrap_or_else(|_| base_fit.clone());
        StepData { rate_dps, shaped, base_fit, gaps }
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

    /// `before` (the shaped realisations the steps before took out; `None`: none) with the one `fit` recovered from
    /// this step's data added where the sensor's filter shapes it; `before` as it was otherwise.
    pub fn shaped_with(&self, before: Option<&[f64]>, fit: &EffectFit) -> Option<Vec<f64>> {
        if !fit.effect.passes_sensor_filter() {
            return before.map(<[f64]>::to_vec);
        }
        self.realised_with(before, fit).or_else(|| before.map(<[f64]>::to_vec))
    }

    /// The estimators' view of it, on `model` with its ADC `channel` (`None`: the analog rate); `recorded` are the
    /// training samples as recorded, gaps filled ([`TrainingData::recorded_dps`]).
    pub fn training<'a>(
        &'a self,
        recorded: &'a [f64],
        model: &'a GyroSim,
        channel: Option<&Channel>,
        temp_c: Option<&'a [f64]>,
        rate_hz: f64,
    ) -> TrainingData<'a> {
        TrainingData {
            lattice_dps: channel.map(Channel::dps_per_code),
            rate_dps: &self.rate_dps,
            recorded_dps: recorded,
            temp_c,
            rate_hz,
            base: model,
            base_fit: &self.base_fit,
            gaps: &self.gaps,
            shaped_dps: self.shaped.as_deref(),
        }
    }
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

    /// On a model with a bandwidth, the step's samples are the record less the shaped realisations through the
    /// model's filter (written out here as `y = a y + (1 - a) x` from the first input): a record of a small
    /// sinusoid and jumps through that filter, the jumps taken out sharp, comes back to the sinusoid; on a model
    /// without a bandwidth, the samples are the series as the jumps were taken out.
    #[test]
    fn shaped_realisations_are_taken_out_through_the_models_filter() {
        let (rate_hz, n) = (50.0, 4000);
        let a = (-2.0 * std::f64::consts::PI * 2.0 / rate_hz).exp();
        let wave: Vec<f64> = (0..n).map(|i| 0.05 * (i as f64 * 0.37).sin()).collect();
        let jumps: Vec<f64> = (0..n).map(|i| if (i / 500) % 2 == 1 { 0.8 } else { 0.0 }).collect();
        let mut y = 0.0;
        let record: Vec<f64> = (0..n)
            .map(|i| {
                y = if i == 0 { jumps[0] } else { a * y + (1.0 - a) * jumps[i] };
                wave[i] + y
            })
            .collect();
        let series: Vec<f64> = record.iter().zip(&jumps).map(|(x, j)| x - j).collect();
        let (_, fit) = fit_base(&series, rate_hz, &FitOptions::default()).unwrap();
        let model = GyroSim { n_deg_per_rt_s: 0.01, bandwidth_hz: Some(2.0), ..Default::default() };
        let d = StepData::new(&model, &series, Some(&jumps), &[], None, rate_hz, &fit, false);
        for i in 0..n {
            assert!((d.rate_dps[i] - wave[i]).abs() < 1e-12, "sample {i}");
        }
        let plain = GyroSim { bandwidth_hz: None, ..model };
        let d = StepData::new(&plain, &series, Some(&jumps), &[], None, rate_hz, &fit, false);
        assert_eq!(d.rate_dps, series);
    }
}

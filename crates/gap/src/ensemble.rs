//! The simulated ensemble: one model, many seeds, the whole record (training then holdout) per seed.
//!
//! Each member is a [`VirtualGyro`] run for as many samples as the record has, at its rate, through the model's
//! ADC when it has one (the measured rate is `channel.code_to_dps(code)`, looked up in a table of every code;
//! without one, the analog rate, as a record of unknown ADC is compared), driven by the real
//! temperature sequence when there is one, so a temperature coupling acts through the temperature the sensor saw.
//! Simulating training and holdout as one run keeps sinusoid phases and drifts continuous across the split; the
//! real record's gaps are copied into each member, then each part is measured on its own [`Plan`] (the
//! temperature view on the member less the model's own temperature response, [`temperature_response`]). Members
//! run in parallel (rayon) and only their measures are kept, so memory is two records per core, not one per seed.

use std::borrow::Cow;

use octavar_shared::sensor::Channel;
use octavar_shared::sim::temperature::ThermalLag;
use octavar_shared::sim::{GyroSim, SimError, VirtualGyro};
use rayon::prelude::*;

use super::effects::ParamSpread;
use super::fill::{fill_gaps, gap_runs, with_gaps};
use super::views::{Measure, Plan};

/// The target the ensemble imitates: a recording split into its training part and its holdout.
#[derive(Clone, Copy, Debug)]
pub struct Target<'a> {
    /// Rate, deg/s, training then holdout; NaN marks a gap.
    pub rate_dps: &'a [f64],
    /// The temperature at every sample (gaps filled), degC, if there is a temperature channel.
    pub temp_c: Option<&'a [f64]>,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Samples of the training part (the rest is the holdout).
    pub n_train: usize,
    /// Sub-samples per sample: each record sample is the mean of this many (1: the record is the sensor's own
    /// sampling). A record of block means (the demo's 1 Hz means of 2 kS/s codes) has the block mean's sinc
    /// response in its spectrum, which a member simulated at the block rate would not have.
    pub oversample: usize,
}

impl Target<'_> {
    /// The training samples.
    pub fn training(&self) -> &[f64] {
        &self.rate_dps[..self.n_train]
    }

    /// The held-out samples.
    pub fn holdout(&self) -> &[f64] {
        &self.rate_dps[self.n_train..]
    }

    /// The temperature of the training part.
    pub fn training_temp(&self) -> Option<&[f64]> {
        self.temp_c.map(|t| &t[..self.n_train])
    }

    /// The temperature of the holdout part.
    pub fn holdout_temp(&self) -> Option<&[f64]> {
        self.temp_c.map(|t| &t[self.n_train..])
    }
}

/// Every member's measures on each part.
#[derive(Clone, Debug)]
pub struct Ensemble {
    /// On the training part, one per seed.
    pub training: Vec<Measure>,
    /// On the holdout part, one per seed (empty without a holdout plan).
    pub holdout: Vec<Measure>,
}

/// The model's own response to the record's temperature, sample by sample over the whole record (training then
/// holdout), as the simulation adds it: the coupling through its thermal lag at the simulation rate, averaged
/// over the oversampled sub-samples. `None` when the model has no coupling or the record no temperature.
pub fn temperature_response(gyro: &GyroSim, rec: &Target) -> Option<Vec<f64>> {
    let (coupling, temp) = (gyro.temperature.as_ref()?, rec.temp_c?);
    let d = rec.oversample.max(1);
    let mut lag = ThermalLag::new(coupling, 1.0 / (rec.rate_hz * d as f64));
    Some(temp.iter().map(|&tc| (0..d).map(|_| lag.next(tc)).sum::<f64>() / d as f64).collect())
}

/// Temperature used when the record has none (the model's reference is 25 degC; nothing couples to it).
const NO_TEMP_C: f64 = 25.0;

/// Simulate `gyro` on `channel` once per seed over the whole record and measure both parts; `explained` is the
/// model's [`temperature_response`] over the whole record, taken out for the temperature view; each member draws
/// the parameters of the model's effects from their `spreads` ([`ParamSpread::draw`]).
///
/// # Errors
/// The model's [`SimError`] (a parameter out of range).
#[allow(clippy::too_many_arguments)] // the record's two plans, the model, its spread and channel, the seeds
pub fn simulate(
    gyro: &GyroSim,
    spreads: &[ParamSpread],
    channel: Option<&Channel>,
    rec: &Target,
    train_plan: &Plan,
    holdout_plan: Option<&Plan>,
    seeds: &[u64],
    explained: Option<&[f64]>,
) -> Result<Ensemble, SimError> {
    let (fs_sim, table) = checked(gyro, channel, rec)?;
    let (resp_train, resp_hold) = match explained {
        Some(r) => (Some(&r[..rec.n_train]), Some(&r[rec.n_train..])),
        None => (None, None),
    };
    let members: Vec<(Measure, Option<Measure>)> = seeds
        .par_iter()
        .map(|&seed| {
            let g = drawn_model(gyro, spreads, channel, fs_sim, seed);
            let x = member(&g, channel, &table, rec, rec.rate_dps.len(), seed);
            let train = train_plan.measure_explained(&x[..rec.n_train], rec.training_temp(), resp_train, false);
            let hold =
                holdout_plan.map(|p| p.measure_explained(&x[rec.n_train..], rec.holdout_temp(), resp_hold, false));
            (train, hold)
        })
        .collect();
    let mut out = Ensemble { training: Vec::with_capacity(seeds.len()), holdout: Vec::new() };
    for (t, h) in members {
        out.training.push(t);
        if let Some(h) = h {
            out.holdout.push(h);
        }
    }
    Ok(out)
}

/// The training part of each member of `gyro`'s ensemble (as [`simulate`] draws it) with `less` applied to it,
/// measured on `train_plan`: `less` gets the member's training samples with the record's gaps filled
/// ([`fill_gaps`]), and the gaps are copied back in before the measure.
///
/// # Errors
/// The model's [`SimError`] (a parameter out of range).
pub fn simulate_less(
    gyro: &GyroSim,
    spreads: &[ParamSpread],
    channel: Option<&Channel>,
    rec: &Target,
    train_plan: &Plan,
    seeds: &[u64],
    less: &(dyn Fn(&mut [f64]) + Sync),
) -> Result<Vec<Measure>, SimError> {
    let (fs_sim, table) = checked(gyro, channel, rec)?;
    Ok(seeds
        .par_iter()
        .map(|&seed| {
            let g = drawn_model(gyro, spreads, channel, fs_sim, seed);
            let x = member(&g, channel, &table, rec, rec.n_train, seed);
            train_plan.measure(&less_in_gaps(&x, less), rec.training_temp(), false)
        })
        .collect())
}

/// `x` (NaN in its gaps) with `less` applied to it gaps filled, and its gaps back in.
pub fn less_in_gaps(x: &[f64], less: &(dyn Fn(&mut [f64]) + Sync)) -> Vec<f64> {
    let runs = gap_runs(x);
    let mut y = fill_gaps(x);
    less(&mut y);
    with_gaps(&y, &runs)
}

/// The rate the members of `gyro` on `channel` are simulated at (the record's, oversampled), once the simulator
/// has accepted the model there (a bad model fails early, and once), with the channel's code table.
fn checked(gyro: &GyroSim, channel: Option<&Channel>, rec: &Target) -> Result<(f64, Vec<f64>), SimError> {
    let fs_sim = rec.rate_hz * rec.oversample.max(1) as f64;
    VirtualGyro::new(gyro, adc_of(channel), fs_sim, 0)?;
    Ok((fs_sim, code_table(channel)))
}

/// The model the member of `seed` simulates: `gyro` with its effects' parameters drawn from `spreads`
/// ([`draw_all`]), or `gyro` itself without spreads or where the simulator rejects the draw at `fs_sim`.
fn drawn_model<'g>(
    gyro: &'g GyroSim,
    spreads: &[ParamSpread],
    channel: Option<&Channel>,
    fs_sim: f64,
    seed: u64,
) -> Cow<'g, GyroSim> {
    if spreads.is_empty() {
        return Cow::Borrowed(gyro);
    }
    let g = draw_all(spreads, gyro, seed);
    match VirtualGyro::new(&g, adc_of(channel), fs_sim, 0) {
        Ok(_) => Cow::Owned(g),
        Err(_) => Cow::Borrowed(gyro),
    }
}

/// `gyro` with the parameters of each spread drawn for the member of `seed` (the k-th spread with its own salt, so
/// the draws of two effects are independent).
fn draw_all(spreads: &[ParamSpread], gyro: &GyroSim, seed: u64) -> GyroSim {
    spreads.iter().enumerate().fold(gyro.clone(), |g, (k, s)| s.draw(&g, seed ^ ((k as u64) << 48)))
}

/// The first `n` samples of one member: `gyro` on `channel` (its code table `table`; the analog rate without a
/// channel) at the record's rate (oversampled and block-averaged as the record says), driven by the record's
/// temperature, with the record's gaps copied in. `gyro` must have been checked by [`VirtualGyro::new`].
fn member(gyro: &GyroSim, channel: Option<&Channel>, table: &[f64], rec: &Target, n: usize, seed: u64) -> Vec<f64> {
    // Output samples simulated per block (each `d` simulated samples).
    const BLOCK: usize = 4096;
    let d = rec.oversample.max(1);
    let mut g =
        VirtualGyro::new(gyro, adc_of(channel), rec.rate_hz * d as f64, seed).expect("model checked by the caller");
    let analog = channel.is_none();
    let mut temps: Vec<f64> = Vec::with_capacity(BLOCK * d);
    let mut rates = vec![0.0; BLOCK * d];
    let mut codes = vec![0u16; if analog { 0 } else { BLOCK * d }];
    let mut out = Vec::with_capacity(n);
    for start in (0..n).step_by(BLOCK) {
        let end = (start + BLOCK).min(n);
        temps.clear();
        for i in start..end {
            let tc = rec.temp_c.map_or(NO_TEMP_C, |t| t[i]);
            temps.extend(std::iter::repeat_n(tc, d));
        }
        let m = temps.len();
        if analog {
            g.fill_rates_at(&temps, &mut rates[..m]);
        } else {
            g.fill_codes_at(&temps, &mut codes[..m]);
            for (r, &c) in rates.iter_mut().zip(&codes[..m]) {
                *r = table[c as usize];
            }
        }
        for (j, &real) in rec.rate_dps[start..end].iter().enumerate() {
            let v = if d == 1 { rates[j] } else { rates[j * d..(j + 1) * d].iter().sum::<f64>() / d as f64 };
            out.push(if real.is_nan() { f64::NAN } else { v });
        }
    }
    out
}

/// The code-to-rate table of every code of `channel` (empty without one).
fn code_table(channel: Option<&Channel>) -> Vec<f64> {
    channel.map_or_else(Vec::new, |ch| (0..=ch.adc.max_code()).map(|c| ch.code_to_dps(c)).collect())
}

/// The channel a [`VirtualGyro`] is built with: the model's, or, for the analog rate (its codes unused), any.
fn adc_of(channel: Option<&Channel>) -> Channel {
    channel.copied().unwrap_or(Channel::bench(octavar_shared::sensor::GENERIC))
}

/// What a member's training part teaches: the model (and its channel; `None`: the analog rate) that the
/// diagnosis's own procedure learns from it.
pub type Relearn<'a> = dyn Fn(&[f64]) -> (GyroSim, Option<Channel>) + Sync + 'a;

/// Added to a member's seed for the simulation of the model it re-learnt, so its holdout is a fresh draw.
pub(crate) const PREDICT_SALT: u64 = 0x5eed_0000_0000;

/// The predictive ensemble of the holdout (a parametric bootstrap of train-then-predict): member `i` simulates
/// the training part of `gyro` with seed `i`, re-learns the model from it with `relearn` (the same procedure that
/// learnt `gyro` from the real training part), simulates that re-learnt model over the whole record with a fresh
/// seed, and measures its holdout part, with `explained_hold` (the response of `gyro`, the model learnt from the
/// real data, over the holdout) taken out for the temperature view as on the real holdout. Where the plain
/// ensemble asks whether the holdout looks like `gyro`, this one asks whether it looks like what a model learnt
/// from a training part like the real one predicts: the spread then carries the error of the learnt parameters,
/// which the plain ensemble leaves out.
///
/// # Errors
/// The model's [`SimError`] (a parameter out of range); a re-learnt model the simulator rejects falls back to
/// `gyro`.
pub fn predict_holdout(
    gyro: &GyroSim,
    channel: Option<&Channel>,
    rec: &Target,
    holdout_plan: &Plan,
    seeds: &[u64],
    explained_hold: Option<&[f64]>,
    relearn: &Relearn,
) -> Result<Vec<Measure>, SimError> {
    let (fs_sim, table) = checked(gyro, channel, rec)?;
    Ok(seeds
        .par_iter()
        .map(|&seed| {
            let train = member(gyro, channel, &table, rec, rec.n_train, seed);
            let (mut g, ch) = relearn(&train);
            // The bias enters no view; a member's own training mean, off by its drift, would only move the
            // member towards the ADC's rails.
            g.bias_dps = gyro.bias_dps;
            let (g, ch, t) = match VirtualGyro::new(&g, adc_of(ch.as_ref()), fs_sim, 0) {
                Ok(_) if ch.as_ref() == channel => (g, ch, None),
                Ok(_) => (g, ch, Some(code_table(ch.as_ref()))),
                Err(_) => (gyro.clone(), channel.copied(), None),
            };
            let table = t.as_deref().unwrap_or(&table);
            let x = member(&g, ch.as_ref(), table, rec, rec.rate_dps.len(), seed.wrapping_add(PREDICT_SALT));
            holdout_plan.measure_explained(&x[rec.n_train..], rec.holdout_temp(), explained_hold, false)
        })
        .collect())
}

/// One simulated record of `n` samples (for tests and examples): the measured rate of `gyro` on `channel`.
///
/// # Errors
/// The model's [`SimError`].
pub fn one_record(
    gyro: &GyroSim,
    channel: &Channel,
    rate_hz: f64,
    n: usize,
    temp_c: Option<&[f64]>,
    seed: u64,
) -> Result<Vec<f64>, SimError> {
    let mut g = VirtualGyro::new(gyro, *channel, rate_hz, seed)?;
    Ok((0..n).map(|i| channel.code_to_dps(g.next(temp_c.map_or(NO_TEMP_C, |t| t[i])).code)).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::views::ViewKind;

    /// A record of unknown ADC is compared with the analog rate: a member whose ramp carries it a hundred times
    /// beyond the record's range keeps its white noise on the holdout, whose Allan deviation at tau0 is the closed
    /// form N / sqrt(tau0) (the ramp adds R tau0 / sqrt(2), a thousandth of it). An ADC sized from the record's
    /// range clipped such a member flat.
    #[test]
    fn members_of_a_record_of_unknown_adc_are_not_clipped() {
        let rate_hz = 10.0;
        let n = 1 << 14;
        let x: Vec<f64> = octavar_stats::test_signals::white(n, 3).iter().map(|v| 0.1 * v).collect();
        let rec = Target { rate_dps: &x, temp_c: None, rate_hz, n_train: n / 2, oversample: 1 };
        let n_coef = 0.1 / rate_hz.sqrt();
        // 0.02 deg/s^2 over 1638 s: 33 deg/s, against a record within +-0.5.
        let gyro = GyroSim { n_deg_per_rt_s: n_coef, r_dps_per_s: 0.02, ..Default::default() };
        let train = Plan::new(rec.training(), None, rate_hz);
        let hold = Plan::new(rec.holdout(), None, rate_hz);
        let e = simulate(&gyro, &[], None, &rec, &train, Some(&hold), &[1, 2, 3], None).unwrap();
        let closed = (n_coef * rate_hz.sqrt()).ln();
        for m in &e.holdout {
            let got = m.values[ViewKind::Adev as usize][0];
            // ln ADEV at tau0 from 8192 samples: sd 0.008.
            assert!((got - closed).abs() < 0.04, "holdout ln ADEV at tau0 {got:.4}, closed form {closed:.4}");
        }
    }
}

//! The sim-to-real gap diagnosis (`octavar gap`): where a gyro and its fitted simulation part, which unmodelled
//! effect causes it, and how far the gap shrinks on data the fit never saw.
//!
//! 1. **Split**: training is the first part of the record, the holdout the rest ([`GapInput::split`]), or a
//!    second record ([`GapInput::joined`]).
//! 2. **Base model**: the IEEE 952 fit ([`crate::fit::fit`], default options) on the training OADEV at octave tau;
//!    its fitted terms and the training mean as the bias, on the record's ADC when it is known
//!    ([`GapOptions::channel`]), else as the analog rate (no ADC: nothing quantises or clips it; a fine ADC over
//!    a few times the record's range clipped members whose random walk or ramp wandered further than the
//!    record's, and their stuck samples read as a heavy-tailed distribution).
//! 3. **Ensemble** ([`ensemble`]): the model simulated with [`GapOptions::seeds`] seeds over the whole record,
//!    driven by the real temperature; measured on each part and compared with the real record ([`Judge`]).
//! 4. **Views** ([`views`]): ADEV, PSD, distribution, temperature; z-scores of the real values against the
//!    ensemble.
//! 5. **Gap and location** ([`rank`]): the worst view's RMS z over its worst decade of tau, that band, its sign
//!    and size.
//! 6. **Candidates** ([`effects`]): each effect of the vocabulary fitted on the training data, re-simulated with the
//!    same seeds, re-measured; ranked by total gap with a penalty per parameter; the best is named, or `none` when
//!    the base gap is not significant.
//! 7. **Holdout**: every parameter frozen from training, the gap on the holdout before and after each candidate.
//!
//! [`report`] turns the result into text, the JSON document and the plot's data.
//!
//! # Examples
//! ```
//! use octavar::gap::{diagnose, GapInput, GapOptions};
//! // White noise of 0.01 deg/sqrt(s) at 10 Hz: the fitted model explains it; no gap.
//! let mut s: u64 = 7;
//! let x: Vec<f64> = (0..40_000).map(|_| {
//!     let mut a = 0.0;
//!     for _ in 0..12 { s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407); a += (s >> 11) as f64 / (1u64 << 53) as f64; }
//!     (a - 6.0) * 0.01 * 10f64.sqrt()
//! }).collect();
//! let input = GapInput::split(x, None, 10.0, 0.5).unwrap();
//! let r = diagnose(&input, &GapOptions { seeds: 20, ..Default::default() }, &|_, _, _| {}).unwrap();
//! assert_eq!(r.effect_name(), "none");
//! ```

pub mod effects;
pub mod ensemble;
pub mod holdout;
pub mod judge;
pub mod rank;
pub mod report;
pub mod views;

use octavar_shared::sensor::Channel;
use octavar_shared::sim::GyroSim;
use rayon::prelude::*;

use crate::fit::{fit, FitError, FitOptions, FitPoint, NoiseFit};
use crate::stats::{analyze_series, DataKind, DevPoint, Options, Series, Statistic, StatsError, TauSpec};

pub use effects::{Effect, EffectFit};
pub use judge::{Evaluated, Judge};
pub use report::{CandidateResult, GapReport, HoldoutCheck, PartGap};
pub use views::{ViewGap, ViewKind};

/// Fewest samples a part may have.
pub const MIN_PART: usize = 256;

/// What went wrong.
#[derive(Debug, thiserror::Error)]
pub enum GapError {
    /// A part of the record is too short.
    #[error(
        "the {part} part has {} samples{}; the gap diagnosis needs at least {needed}",
        n - missing,
        if *missing > 0 { format!(" that are not gaps ({missing} of its {n} are NaN)") } else { String::new() }
    )]
    TooShort {
        /// `training` or `holdout`.
        part: &'static str,
        /// Samples it has, gaps included.
        n: usize,
        /// Of them, gaps (NaN samples).
        missing: usize,
        /// Samples it needs.
        needed: usize,
    },
    /// The holdout fraction is not in [0, 1).
    #[error("holdout fraction {0} must be at least 0 and below 1")]
    BadFraction(f64),
    /// The temperature column is not as long as the rate column, or has no value at all.
    #[error("the temperature column has {temp} values for {rate} rate samples, or none that is a number")]
    BadTemperature {
        /// Temperature values.
        temp: usize,
        /// Rate samples.
        rate: usize,
    },
    /// A sample that is infinite or beyond [`crate::stats::series::MAX_SAMPLE`] in magnitude.
    #[error(
        "the {part} part's {column} sample {index} (sample {record_index} of the record) is {value:e}: no sensor \
         reports a value beyond 1e100 (a corrupted sample?)"
    )]
    BadSample {
        /// `rate` or `temperature`.
        column: &'static str,
        /// `training` or `holdout`.
        part: &'static str,
        /// Index of the sample in its part.
        index: usize,
        /// Index of the sample in the whole record (training, then holdout).
        record_index: usize,
        /// Its value.
        value: f64,
    },
    /// Fewer than 3 seeds.
    #[error("the ensemble needs at least 3 seeds (20 or more recommended); got {0}")]
    TooFewSeeds(usize),
    /// The training OADEV could not be computed.
    #[error("training Allan deviation: {0}")]
    Stats(#[from] StatsError),
    /// The base fit failed.
    #[error("base fit on the training data: {0}")]
    Fit(#[from] FitError),
    /// A model could not be simulated.
    #[error("simulating the {model} model: {err}")]
    Sim {
        /// `base` or the effect's name.
        model: String,
        /// The simulator's reason.
        err: octavar_shared::sim::SimError,
    },
}

/// The record to diagnose: training then holdout, one rate series (deg/s, NaN gaps) and its temperature.
#[derive(Clone, Debug, PartialEq)]
pub struct GapInput {
    /// Rate, deg/s: the training samples, then the held-out ones.
    pub rate_dps: Vec<f64>,
    /// Temperature at every sample, degC (NaN gaps allowed), if there is a temperature channel.
    pub temp_c: Option<Vec<f64>>,
    /// Sample rate, Hz.
    pub fs_hz: f64,
    /// Samples of the training part.
    pub n_train: usize,
}

impl GapInput {
    /// One record split in time: the first `1 - holdout_fraction` trains, the rest is held out.
    ///
    /// # Errors
    /// [`GapError::BadFraction`], [`GapError::BadTemperature`].
    pub fn split(
        rate_dps: Vec<f64>,
        temp_c: Option<Vec<f64>>,
        fs_hz: f64,
        holdout_fraction: f64,
    ) -> Result<GapInput, GapError> {
        if !(0.0..1.0).contains(&holdout_fraction) {
            return Err(GapError::BadFraction(holdout_fraction));
        }
        let n_train = ((1.0 - holdout_fraction) * rate_dps.len() as f64).round() as usize;
        let input = GapInput { rate_dps, temp_c, fs_hz, n_train };
        input.check_temperature()?;
        Ok(input)
    }

    /// A training record and a separate holdout record (same columns, same rate), diagnosed as one continuous
    /// run.
    ///
    /// # Errors
    /// [`GapError::BadTemperature`] when only one has a temperature column or the lengths differ.
    pub fn joined(
        training: Vec<f64>,
        training_temp: Option<Vec<f64>>,
        holdout: Vec<f64>,
        holdout_temp: Option<Vec<f64>>,
        fs_hz: f64,
    ) -> Result<GapInput, GapError> {
        let n_train = training.len();
        let n = n_train + holdout.len();
        let temp_c = match (training_temp, holdout_temp) {
            (Some(mut a), Some(b)) => {
                a.extend(b);
                Some(a)
            }
            (None, None) => None,
            (Some(a), None) | (None, Some(a)) => return Err(GapError::BadTemperature { temp: a.len(), rate: n }),
        };
        let mut rate_dps = training;
        rate_dps.extend(holdout);
        let input = GapInput { rate_dps, temp_c, fs_hz, n_train };
        input.check_temperature()?;
        Ok(input)
    }

    fn check_temperature(&self) -> Result<(), GapError> {
        if let Some(t) = &self.temp_c {
            if t.len() != self.rate_dps.len() || !t.iter().any(|v| v.is_finite()) {
                return Err(GapError::BadTemperature { temp: t.len(), rate: self.rate_dps.len() });
            }
        }
        Ok(())
    }

    /// Every sample a number of a sensor's size or a gap: an infinity or a value beyond
    /// [`crate::stats::series::MAX_SAMPLE`] is a corrupted sample, which would otherwise leave a view of the
    /// holdout empty or a fit without points.
    fn check_values(&self) -> Result<(), GapError> {
        let columns = [("rate", Some(&self.rate_dps)), ("temperature", self.temp_c.as_ref())];
        for (column, values) in columns {
            let Some(values) = values else { continue };
            let bad = values.iter().position(|&v| crate::stats::series::is_corrupted(v));
            if let Some(i) = bad {
                let (part, index) = if i < self.n_train { ("training", i) } else { ("holdout", i - self.n_train) };
                return Err(GapError::BadSample { column, part, index, record_index: i, value: values[i] });
            }
        }
        Ok(())
    }

    /// Held-out samples.
    pub fn n_holdout(&self) -> usize {
        self.rate_dps.len() - self.n_train
    }
}

/// Options of [`diagnose`].
#[derive(Clone, Debug)]
pub struct GapOptions {
    /// Ensemble size (at least 3; 20 by default).
    pub seeds: usize,
    /// The first seed; member i uses `first_seed + i`.
    pub first_seed: u64,
    /// The record's ADC, when known and the record is its codes at the sensor's rate; `None`: the ensembles
    /// simulate the analog rate (the CLI, and the demo, whose 1 Hz means of 2000 codes show no ADC step).
    pub channel: Option<Channel>,
    /// The base fit's options.
    pub fit: FitOptions,
    /// Candidates to try (every effect of [`Effect::ALL`] by default).
    pub effects: Vec<Effect>,
    /// A base fit made elsewhere on the training part (for example on the device's full-rate snapshot when the
    /// record diagnosed is a decimated one, whose short taus cannot show N); `None`: fit the training record.
    pub base_fit: Option<NoiseFit>,
    /// When each sample of the record is the mean of a block of the sensor's samples: the ensemble members are
    /// simulated at this many times the record's rate and averaged the same way (see
    /// [`ensemble::Record::oversample`]); 1 (the default) for a record at the sensor's own rate.
    pub oversample: usize,
    /// How the holdout is judged: [`HoldoutCheck::Plain`] by default; [`HoldoutCheck::Predictive`] adds the check
    /// against predictive ensembles (see [`holdout`]).
    pub holdout_check: HoldoutCheck,
}

impl Default for GapOptions {
    fn default() -> Self {
        GapOptions {
            seeds: 20,
            first_seed: 1_000,
            channel: None,
            fit: FitOptions::default(),
            effects: Effect::ALL.to_vec(),
            base_fit: None,
            oversample: 1,
            holdout_check: HoldoutCheck::Plain,
        }
    }
}

/// Progress: `(stage, done, total)`, called after each ensemble.
pub type ProgressFn<'a> = dyn Fn(&str, usize, usize) + Sync + 'a;

/// Diagnose the gap between a record and the simulation of its fitted model (see the module doc).
///
/// # Errors
/// A part too short, a bad temperature column, too few seeds, a base fit that fails, or a model the simulator
/// rejects.
pub fn diagnose(input: &GapInput, opts: &GapOptions, progress: &ProgressFn) -> Result<GapReport, GapError> {
    if opts.seeds < 3 {
        return Err(GapError::TooFewSeeds(opts.seeds));
    }
    input.check_temperature()?;
    input.check_values()?;
    let n_train = input.n_train;
    let n_hold = input.n_holdout();
    let missing =
        [&input.rate_dps[..n_train], &input.rate_dps[n_train..]].map(|part| part.iter().filter(|v| v.is_nan()).count());
    if n_train - missing[0] < MIN_PART {
        return Err(GapError::TooShort { part: "training", n: n_train, missing: missing[0], needed: MIN_PART });
    }
    let has_holdout = n_hold > 0;
    if has_holdout && n_hold - missing[1] < MIN_PART {
        return Err(GapError::TooShort { part: "holdout", n: n_hold, missing: missing[1], needed: MIN_PART });
    }
    let fs = input.fs_hz;
    let predictive = has_holdout && opts.holdout_check == HoldoutCheck::Predictive;
    let total_steps = 2 + opts.effects.len() + usize::from(predictive);
    progress("base fit", 0, total_steps);

    // Base model on the training part.
    let training = &input.rate_dps[..n_train];
    let (real_adev, base_fit) = match &opts.base_fit {
        Some(f) => (training_adev(training, fs)?, f.clone()),
        None => fit_base(training, fs, &opts.fit)?,
    };
    let base = base_model(&base_fit, training);
    let channel = opts.channel;

    // Plans and the real measures, against which every model is judged.
    let judge = Judge::new(input, opts);
    let rec = judge.record();
    let seeds = judge.seeds();
    progress("base fit", 1, total_steps);

    let base_eval = judge.evaluate(&base, None, channel.as_ref(), "base")?;
    progress("base ensemble", 2, total_steps);

    // Candidates: estimate all (in parallel), then simulate each.
    let filled_train = fill_gaps(training);
    let data = effects::TrainingData {
        rate_dps: &filled_train,
        temp_c: rec.training_temp(),
        fs_hz: fs,
        base: &base,
        base_fit: &base_fit,
    };
    let fits: Vec<(Effect, Option<EffectFit>)> =
        opts.effects.par_iter().map(|&e| (e, effects::estimate(e, &data))).collect();
    let mut candidates = Vec::new();
    for (i, (effect, f)) in fits.into_iter().enumerate() {
        let eval = match &f {
            Some(f) => {
                Some(judge.evaluate(&f.gyro, f.spread.as_ref(), f.channel.or(channel).as_ref(), effect.name())?)
            }
            None => None,
        };
        candidates.push((effect, f, eval));
        progress(effect.name(), 3 + i, total_steps);
    }
    let mut report = report::assemble(report::Parts {
        fs_hz: fs,
        n_train,
        n_holdout: n_hold,
        missing,
        seeds: opts.seeds,
        has_temperature: input.temp_c.is_some(),
        channel,
        base,
        base_fit,
        real_adev,
        base_eval,
        candidates,
    });

    // The held-out check against predictive ensembles (see [`holdout`]).
    if let (true, Some(hp), Some(real_hold)) = (predictive, judge.hold_plan(), judge.real_holdout()) {
        let learner = holdout::Learner {
            fs_hz: fs,
            temp_c: rec.training_temp(),
            fit: &opts.fit,
            fixed_base: opts.base_fit.as_ref(),
            fallback: &report.base_fit,
            channel,
        };
        // A base model not learnt from the record predicts what its plain ensemble does.
        let base_views = match opts.base_fit {
            Some(_) => None,
            None => {
                let relearn = |t: &[f64]| (learner.base(t).1, channel);
                let m = ensemble::predict_holdout(&report.base, channel.as_ref(), &rec, hp, seeds, None, &relearn)
                    .map_err(|err| GapError::Sim { model: "base".into(), err })?;
                Some(views::compare(hp, real_hold, &m))
            }
        };
        let chosen = report.chosen().and_then(|c| c.fit.as_ref().zip(c.eval.as_ref()));
        let chosen_views = match chosen {
            Some((f, eval)) => {
                let effect = f.effect;
                let explained = ensemble::temperature_response(&f.gyro, &rec);
                let resp_hold = explained.as_deref().map(|r| &r[n_train..]);
                let relearn = |t: &[f64]| learner.with_effect(effect, t);
                let ch = f.channel.or(channel);
                let m = ensemble::predict_holdout(&f.gyro, ch.as_ref(), &rec, hp, seeds, resp_hold, &relearn)
                    .map_err(|err| GapError::Sim { model: effect.name().to_string(), err })?;
                // The real holdout as this model was judged on it (less its own temperature response).
                eval.real_holdout.as_ref().map(|real| views::compare(hp, real, &m))
            }
            None => None,
        };
        report.apply_predictive(base_views, chosen_views);
        progress("holdout check", total_steps, total_steps);
    }
    Ok(report)
}

/// The octave OADEV of a training part.
fn training_adev(training: &[f64], fs_hz: f64) -> Result<Vec<DevPoint>, GapError> {
    let series = Series::new(training, DataKind::Frequency, 1.0 / fs_hz)?;
    Ok(analyze_series(&series, Statistic::Oadev, &TauSpec::Octave, &Options::default())?)
}

/// The base fit of a training part: its octave OADEV and the IEEE 952 fit of it.
pub(crate) fn fit_base(training: &[f64], fs_hz: f64, opts: &FitOptions) -> Result<(Vec<DevPoint>, NoiseFit), GapError> {
    let real_adev = training_adev(training, fs_hz)?;
    let pts: Vec<FitPoint> = real_adev
        .iter()
        .filter(|p| p.edf.is_finite() && p.edf > 0.0)
        .map(|p| FitPoint { tau_s: p.tau_s, avar: p.dev * p.dev, edf: p.edf })
        .collect();
    let f = fit(&pts, opts)?;
    Ok((real_adev, f))
}

/// The base simulation model of a fit: every fitted term ([`NoiseFit::sim_terms`]), with the mean of `training`
/// as the bias.
pub fn base_model(f: &NoiseFit, training: &[f64]) -> GyroSim {
    let (sum, n) = training.iter().filter(|x| x.is_finite()).fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    f.sim_terms(GyroSim { bias_dps: if n > 0 { sum / n as f64 } else { 0.0 }, ..Default::default() })
}

/// A copy with NaN runs filled by linear interpolation between their neighbours (the ends by the nearest value);
/// the estimators want gap-free samples, and the few gaps of a real record hardly move them.
pub fn fill_gaps(x: &[f64]) -> Vec<f64> {
    let mut out = x.to_vec();
    let Some(first) = x.iter().position(|v| v.is_finite()) else { return out };
    for v in out.iter_mut().take(first) {
        *v = x[first];
    }
    let mut last = first;
    for i in first + 1..x.len() {
        if x[i].is_finite() {
            if i > last + 1 {
                let (a, b) = (x[last], x[i]);
                for (j, v) in out.iter_mut().enumerate().take(i).skip(last + 1) {
                    *v = a + (b - a) * (j - last) as f64 / (i - last) as f64;
                }
            }
            last = i;
        }
    }
    for v in out.iter_mut().skip(last + 1) {
        *v = x[last];
    }
    out
}

/// The real OADEV points of the training part (kept for the plot).
pub type RealAdev = Vec<DevPoint>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaps_are_filled_linearly() {
        let x = [f64::NAN, 1.0, f64::NAN, f64::NAN, 4.0, f64::NAN];
        assert_eq!(fill_gaps(&x), vec![1.0, 1.0, 2.0, 3.0, 4.0, 4.0]);
    }

    /// Gaps are counted per part and reported (text and JSON); a part that is mostly gaps is refused with the
    /// count of its valid samples, before any statistic is tried on it.
    #[test]
    fn gaps_are_reported_and_a_part_of_gaps_is_too_short() {
        let mut x = crate::test_signals::white(8192, 3);
        for i in [10, 11, 500, 6000] {
            x[i] = f64::NAN;
        }
        let opts = GapOptions { seeds: 3, effects: vec![], ..Default::default() };
        let r = diagnose(&GapInput::split(x.clone(), None, 100.0, 0.5).unwrap(), &opts, &|_, _, _| {}).unwrap();
        assert_eq!(r.missing, [3, 1]);
        let text = r.text();
        assert!(
            text.starts_with("gap diagnosis: 4096 training samples (3 missing) at 100 Hz, 4096 held out (1 missing)"),
            "{text}"
        );
        assert_eq!(r.to_json()["missing_samples"], serde_json::json!({"training": 3, "holdout": 1}));

        // The holdout keeps one sample in 20 (sample 6000 was a gap already): 204 that are not gaps.
        for (i, v) in x.iter_mut().enumerate().skip(4096) {
            if i % 20 != 0 {
                *v = f64::NAN;
            }
        }
        let e = diagnose(&GapInput::split(x, None, 100.0, 0.5).unwrap(), &opts, &|_, _, _| {}).unwrap_err();
        assert!(matches!(e, GapError::TooShort { part: "holdout", n: 4096, missing: 3892, .. }), "{e:?}");
        assert_eq!(
            e.to_string(),
            "the holdout part has 204 samples that are not gaps (3892 of its 4096 are NaN); the gap diagnosis needs \
             at least 256"
        );
    }

    /// A corrupted sample (infinite, or too large for any sensor) is refused up front, named by its column, part
    /// and index in the part, wherever it falls: a holdout's would otherwise leave that part's Allan view empty.
    #[test]
    fn a_corrupted_sample_is_named_by_part_and_index() {
        let x = crate::test_signals::white(2048, 4);
        let opts = GapOptions { seeds: 3, effects: vec![], ..Default::default() };
        for (at, value, part, index) in
            [(5, 1e200, "training", 5), (1500, -3e101, "holdout", 476), (2047, f64::INFINITY, "holdout", 1023)]
        {
            let mut y = x.clone();
            y[at] = value;
            let e = diagnose(&GapInput::split(y, None, 10.0, 0.5).unwrap(), &opts, &|_, _, _| {}).unwrap_err();
            assert!(
                matches!(e, GapError::BadSample { column: "rate", part: p, index: i, .. } if p == part && i == index),
                "{e:?}"
            );
        }
        let mut t = vec![23.0; 2048];
        t[2000] = 1e150;
        let e = diagnose(&GapInput::split(x, Some(t), 10.0, 0.5).unwrap(), &opts, &|_, _, _| {}).unwrap_err();
        assert_eq!(
            e.to_string(),
            "the holdout part's temperature sample 976 (sample 2000 of the record) is 1e150: no sensor reports a \
             value beyond 1e100 (a corrupted sample?)"
        );
    }

    #[test]
    fn split_and_join() {
        let i = GapInput::split(vec![0.0; 1000], None, 1.0, 0.25).unwrap();
        assert_eq!((i.n_train, i.n_holdout()), (750, 250));
        assert!(GapInput::split(vec![0.0; 10], None, 1.0, 1.0).is_err());
        let j = GapInput::joined(vec![0.0; 3], Some(vec![1.0; 3]), vec![0.0; 2], Some(vec![2.0; 2]), 1.0).unwrap();
        assert_eq!(j.temp_c.unwrap(), vec![1.0, 1.0, 1.0, 2.0, 2.0]);
        assert!(GapInput::joined(vec![0.0; 3], Some(vec![1.0; 3]), vec![0.0; 2], None, 1.0).is_err());
    }
}

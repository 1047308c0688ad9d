//! What a gap diagnosis is given: the record split into its training and held-out parts ([`GapInput`]), checked
//! for corrupted samples and a usable temperature column, and the diagnosis's options ([`GapOptions`]).

use octavar_shared::sensor::Channel;
use serde::Serialize;

use super::effects::Effect;
use super::error::GapError;
use octavar_stats::fit::{FitOptions, NoiseFit};
use octavar_stats::quantity::Quantity;

/// Fewest samples a part may have.
pub const MIN_PART: usize = 256;

/// The record to diagnose: training then holdout, one rate series (deg/s, NaN gaps) and its temperature.
#[derive(Clone, Debug, PartialEq)]
pub struct GapInput {
    /// Rate, deg/s: the training samples, then the held-out ones.
    pub rate_dps: Vec<f64>,
    /// Temperature at every sample, degC (NaN gaps allowed), if there is a temperature channel.
    pub temp_c: Option<Vec<f64>>,
    /// Sample rate, Hz.
    pub rate_hz: f64,
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
        rate_hz: f64,
        holdout_fraction: f64,
    ) -> Result<GapInput, GapError> {
        if !(0.0..1.0).contains(&holdout_fraction) {
            return Err(GapError::BadFraction(holdout_fraction));
        }
        let n_train = ((1.0 - holdout_fraction) * rate_dps.len() as f64).round() as usize;
        let input = GapInput { rate_dps, temp_c, rate_hz, n_train };
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
        rate_hz: f64,
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
        let input = GapInput { rate_dps, temp_c, rate_hz, n_train };
        input.check_temperature()?;
        Ok(input)
    }

    pub(crate) fn check_temperature(&self) -> Result<(), GapError> {
        if let Some(t) = &self.temp_c {
            if t.len() != self.rate_dps.len() || !t.iter().any(|v| v.is_finite()) {
                return Err(GapError::BadTemperature { temp: t.len(), rate: self.rate_dps.len() });
            }
        }
        Ok(())
    }

    /// Every sample a number of a sensor's size or a gap: an infinity or a value beyond
    /// [`octavar_stats::series::MAX_SAMPLE`] is a corrupted sample, which would otherwise leave a view of the
    /// holdout empty or a fit without points.
    pub(crate) fn check_values(&self) -> Result<(), GapError> {
        let columns = [("rate", Some(&self.rate_dps)), ("temperature", self.temp_c.as_ref())];
        for (column, values) in columns {
            let Some(values) = values else { continue };
            let bad = values.iter().position(|&v| octavar_stats::series::is_corrupted(v));
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

/// Options of [`super::diagnose`].
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
    /// [`super::ensemble::Target::oversample`]); 1 (the default) for a record at the sensor's own rate.
    pub oversample: usize,
    /// How the holdout is judged: [`HoldoutCheck::Plain`] by default; [`HoldoutCheck::Predictive`] adds the check
    /// against predictive ensembles (see [`super::holdout`]).
    pub holdout_check: HoldoutCheck,
    /// Leave transient disturbances in the record (`--keep-transients`); by default they are found in both parts
    /// and masked as gaps before anything else is done ([`super::transients`]).
    pub keep_transients: bool,
    /// What the record measures: the report names its units (deg/s for a gyro, m/s^2 for an accelerometer).
    pub quantity: Quantity,
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
            keep_transients: false,
            quantity: Quantity::AngularRate,
        }
    }
}

/// How the held-out gap is judged.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum HoldoutCheck {
    /// Against the ensembles of the models learnt from the real training part: their spread is the noise's.
    #[default]
    Plain,
    /// Also against predictive ensembles: each member re-learns the model from a simulated training part and
    /// predicts the holdout ([`super::ensemble::predict_holdout`]), so the spread carries the error of the
    /// parameters learnt on training as well as the noise.
    Predictive,
}

impl HoldoutCheck {
    /// `predictive` or `plain`.
    pub fn name(self) -> &'static str {
        match self {
            HoldoutCheck::Predictive => "predictive",
            HoldoutCheck::Plain => "plain",
        }
    }
}

//! What can go wrong in a gap diagnosis, each error naming the part, the column or the model it is about.

use octavar_stats::fit::FitError;
use octavar_stats::StatsError;

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
    /// A sample that is infinite or beyond [`octavar_stats::series::MAX_SAMPLE`] in magnitude.
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

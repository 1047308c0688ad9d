//! The errors of `octavar_stats`: what was wrong with the data or the request.

use thiserror::Error;

/// Why a stability analysis could not be done.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum StatsError {
    /// A stride of the streamed engine that is not a power of two from 1 to 2^16.
    #[error("stride {0}: use a power of two from 1 to 65536")]
    BadStride(usize),
    /// The sample interval must be a positive, finite number of seconds.
    #[error("tau0 must be positive and finite, got {tau0_s} s")]
    BadTau0 {
        /// The rejected sample interval, seconds.
        tau0_s: f64,
    },
    /// Too few valid samples for any estimate (after trimming leading and trailing NaNs).
    #[error("too few valid samples: {valid} (need at least {needed})")]
    TooFewSamples {
        /// Samples left after trimming NaNs at both ends.
        valid: usize,
        /// The least number this statistic needs.
        needed: usize,
    },
    /// A sample is infinite (NaN marks a gap; infinities are not data).
    #[error("sample {index} is infinite")]
    Infinite {
        /// Index of the sample in the input.
        index: usize,
    },
    /// A sample beyond [`super::series::MAX_SAMPLE`] in magnitude: a corrupted value, whose square would overflow
    /// the Allan sums.
    #[error(
        "sample {index} is {value:e}: no sensor reports a value beyond 1e100 (a corrupted sample?), and its square \
         would overflow the Allan sums"
    )]
    TooLarge {
        /// Index of the sample in the input.
        index: usize,
        /// Its value.
        value: f64,
    },
    /// The confidence level must lie strictly between 0 and 1.
    #[error("confidence must be in (0, 1), got {0}")]
    BadConfidence(f64),
    /// An explicit tau list held a value that is not positive and finite, or a per-decade count of 0.
    #[error("bad tau request: {0}")]
    BadTau(String),
    /// The tau request left no averaging factor that the data can support.
    #[error("no tau value can be computed from {n_phase} phase points{}", gap_hint(*gaps, *n_phase))]
    NoTau {
        /// Number of phase points available.
        n_phase: usize,
        /// How many of them fall in gaps (NaN samples): where gaps are dense, no averaging time has two whole
        /// clusters beside each other.
        gaps: usize,
    },
}

/// The note on gaps in [`StatsError::NoTau`]'s message.
fn gap_hint(gaps: usize, n_phase: usize) -> String {
    if gaps == 0 {
        return String::new();
    }
    let share = 100.0 * gaps as f64 / n_phase.max(1) as f64;
    format!(
        " ({gaps} of them, {share:.0}%, fall in gaps: no averaging time has two whole clusters side by side without \
         a NaN sample)"
    )
}

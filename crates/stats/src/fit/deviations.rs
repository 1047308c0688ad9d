//! The route from rate samples to the noise-term fit, in one place: the overlapping Allan deviation at octave
//! tau (the curve the fit reads), and the fit of deviation points wherever they were computed (a series in
//! memory, the bounded-memory engine, a device's snapshots). `analyze`, its streamed path, `gap` and the demo all
//! fit this way, so a channel gets the same fit whichever reader brought it.

use super::{fit, fit_input, FitError, FitOptions, NoiseFit};
use crate::{analyze_series, DevPoint, Options, Series, Statistic, StatsError, TauSpec};

/// The overlapping Allan deviation of `series` at octave tau, with intervals at `confidence`: the points the fit
/// reads.
///
/// # Errors
/// As [`analyze_series`]: a series too short for one octave.
pub fn octave_oadev(series: &Series, confidence: f64) -> Result<Vec<DevPoint>, StatsError> {
    analyze_series(series, Statistic::Oadev, &TauSpec::Octave, &Options { confidence, ..Default::default() })
}

/// The noise-term fit of deviation points, each point's EDF and estimator shape carried into the fit; `None`
/// for the options when no fit is asked for.
///
/// # Errors
/// [`FitError::NotAsked`] without options; otherwise as [`fit`].
pub fn fit_deviations(points: &[DevPoint], opts: Option<&FitOptions>) -> Result<NoiseFit, FitError> {
    match opts {
        Some(opts) => fit(&fit_input(points), opts),
        None => Err(FitError::NotAsked),
    }
}

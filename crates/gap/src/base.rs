//! The base model of the diagnosis: the IEEE 952 fit on the training part's octave OADEV, and the simulation
//! model it gives (every fitted term, Q as white angle noise included, so that the simulation draws the fitted
//! curve, with the training mean as the bias).

use octavar_shared::sim::GyroSim;

use crate::error::GapError;
use octavar_stats::fit::{fit_deviations, octave_oadev, FitOptions, NoiseFit};
use octavar_stats::{DataKind, DevPoint, Options, Series};

/// The octave OADEV of a training part.
pub(crate) fn training_adev(training: &[f64], rate_hz: f64) -> Result<Vec<DevPoint>, GapError> {
    let series = Series::new(training, DataKind::Frequency, 1.0 / rate_hz)?;
    Ok(octave_oadev(&series, Options::default().confidence)?)
}

/// The base fit of a training part: its octave OADEV and the IEEE 952 fit of it.
///
/// # Errors
/// A part too short for an Allan deviation, or a fit that fails.
pub fn fit_base(training: &[f64], rate_hz: f64, opts: &FitOptions) -> Result<(Vec<DevPoint>, NoiseFit), GapError> {
    let real_adev = training_adev(training, rate_hz)?;
    let f = fit_deviations(&real_adev, Some(opts))?;
    Ok((real_adev, f))
}

/// The base simulation model of a fit: every fitted term ([`NoiseFit::sim_terms`]), with the mean of `training`
/// as the bias.
pub fn base_model(f: &NoiseFit, training: &[f64]) -> GyroSim {
    let (sum, n) = training.iter().filter(|x| x.is_finite()).fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    f.sim_terms(GyroSim { bias_dps: if n > 0 { sum / n as f64 } else { 0.0 }, ..Default::default() })
}

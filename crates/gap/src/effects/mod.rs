//! The candidate effects of the gap diagnosis and their estimators, from the training samples only.
//!
//! Each [`Effect`] is a term the IEEE 952 base model (Q, N, B, K, R) lacks. [`fit_effect`] fits its parameters on
//! the training data and returns the base model with the effect added ([`EffectFit::gyro`]), re-fitting the base
//! terms the effect overlaps (N under a bandwidth, a resonance or with quantisation or outliers, K under bias
//! steps, a bistable bias or a warm-up, all of them jointly with a Gauss-Markov process), or `None` when the data
//! carry no trace of it.
//!
//! | effect | method | parameters |
//! |--------|--------|------------|
//! | temperature | generalised least squares (Whittle) of the block-averaged rate on the temperature through a first-order lag, lag by grid + golden search, kept beyond 5 standard errors | `dps_per_c`, `lag_s`, `ref_c` |
//! | sinusoid | Hann-windowed periodogram against a log-band median background, each frequency refined on the whole record's joint least squares, amplitude/phase by that fit | `amplitude_dps`, `period_s`, `phase_rad` (up to 4) |
//! | bandwidth | joint weighted fit of the short-tau OADEV with the exact Allan form of sampled first-order low-passed white noise, f3dB by grid + golden search | `bandwidth_hz` |
//! | gauss_markov | joint fit of the OADEV with the base terms plus the exact Gauss-Markov Allan form, T by grid + golden search | `sigma_dps`, `tau_s` |
//! | quantization | lattice step of the sample values (distinct-value gaps, verified on 99% of samples) | `step_dps` |
//! | bias_steps | MOSUM scan of windowed mean differences at the bias-instability tau, robust (MAD) threshold; truncated-normal size fit | `per_hour`, `sigma_dps` |
//! | outliers | residual from the median of 8 neighbours; its magnitudes fitted by maximum likelihood as a Gaussian core plus spikes of a uniform magnitude law; runs from the same-sign excess of adjacent spikes | `per_sample`, `size_dps`, `spread_dps`, `run_mean` |
//! | resonance | Welch spectrum (Hann, a 32nd of the record a segment) against a median background; the sampled oscillator's spectrum (shared::sim's resonance) plus a background quadratic in ln f, fitted in ln P by Levenberg-Marquardt; kept when it lowers the chi-square by 100, peaks at half the background or more and is at least 4 bins wide (a line is a sinusoid); base terms re-fitted on the OADEV less its exact Allan variance, a Gauss-Markov process the model carries re-fitted beside them (its time constant held) | `sigma_dps`, `freq_hz`, `q` |
//! | bistable | the bias-steps MOSUM scan at windows on an octave grid; jumps in time order must alternate in sign beyond chance (binomial tail, 1e-4 over the windows) and have one size (robust spread under 35%); dwell means from the states between jumps, corrected for unseen short excursions, then read again with the base terms from the Allan curve beside the telegraph's exact Allan variance, the step held | `step_dps`, `dwell_low_s`, `dwell_high_s` |
//! | warm_up | generalised least squares of block means (octave block lengths, 256 blocks from the start) on the block-averaged `exp(-t / tau)`, covariance from the base terms' semivariogram, a trend beside it where the base has a ramp; tau on a grid of 8-16 blocks; kept beyond 5 standard errors | `size_dps`, `tau_s` |
//!
//! One module per effect, each with a unit type `Kind` implementing [`EffectKind`] (the estimator, the typed
//! parameters of [`params`], the test statistic and what a joint re-estimation moves); `common` holds the small helpers they share, `curve` the Allan-curve forms and
//! joint fit of the bandwidth and Gauss-Markov estimators (and the resonance's exact Allan variance), and
//! `joint_curve` the chain's joint re-estimation of the base terms with every stochastic effect on that curve.
//!
//! All of them run in well under a second on a million samples (one FFT or a few, a few O(N) passes, small fits
//! on the octave OADEV curve or a window of the spectrum, a 255-point Cholesky factor per block length).

use std::ops::Range;
use std::sync::Arc;

use octavar_shared::sensor::Channel;
use octavar_shared::sim::rng::SimRng;
use octavar_shared::sim::GyroSim;
use serde::Serialize;

use octavar_stats::fit::NoiseFit;

mod bandwidth;
mod bias_steps;
mod bistable;
mod common;
mod curve;
mod filter_input;
mod gauss_markov;
pub mod joint_curve;
mod jump_scan;
mod lattice;
mod lowpass;
pub(crate) mod noise_spectrum;
mod outliers;
pub mod params;
pub(crate) use common::jumps_through_filter;
pub use jump_scan::JumpScan;
pub use params::EffectParams;
mod quantization;
mod resonance;
mod sinusoid;
mod temperature;
#[cfg(test)]
pub(crate) mod tests;
mod warm_up;

/// The outliers estimator's own acceptance, which its evidence test shares ([`crate::evidence`]).
pub(crate) use outliers::MIN_LR as OUTLIERS_MIN_LR;
pub use sinusoid::SHORT_PERIOD_CYCLES;

/// A candidate effect: something the IEEE 952 base model does not have.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Effect {
    /// Bias coupled to the temperature through a thermal lag.
    Temperature,
    /// Sinusoids on the rate (vibration, supply ripple, a daily cycle without a temperature channel).
    Sinusoid,
    /// A first-order output bandwidth (the sensor's or an anti-alias filter).
    Bandwidth,
    /// Exponentially correlated (Gauss-Markov) rate noise.
    GaussMarkov,
    /// ADC quantisation: sample values on a lattice.
    Quantization,
    /// Random bias steps.
    BiasSteps,
    /// Isolated spikes.
    Outliers,
    /// Narrowband random vibration: a second-order Gauss-Markov process (a spectral bump wider than a line).
    Resonance,
    /// A bias that flips between two levels at random (random telegraph, popcorn noise).
    Bistable,
    /// The bias settling exponentially after power-on.
    WarmUp,
}

impl Effect {
    /// Every effect, in the vocabulary's order.
    pub const ALL: [Effect; 10] = [
        Effect::Temperature,
        Effect::Sinusoid,
        Effect::Bandwidth,
        Effect::GaussMarkov,
        Effect::Quantization,
        Effect::BiasSteps,
        Effect::Outliers,
        Effect::Resonance,
        Effect::Bistable,
        Effect::WarmUp,
    ];

    /// The name in the vocabulary (CLI, JSON).
    pub fn name(self) -> &'static str {
        match self {
            Effect::Temperature => "temperature",
            Effect::Sinusoid => "sinusoid",
            Effect::Bandwidth => "bandwidth",
            Effect::GaussMarkov => "gauss_markov",
            Effect::Quantization => "quantization",
            Effect::BiasSteps => "bias_steps",
            Effect::Outliers => "outliers",
            Effect::Resonance => "resonance",
            Effect::Bistable => "bistable",
            Effect::WarmUp => "warm_up",
        }
    }

    /// Whether the sensor's output filter shapes the effect's realisation, as the simulator applies it: bias steps
    /// and a bistable bias are jumps of the sensor's bias, which reach the output through its bandwidth; spikes
    /// are added after it.
    pub fn passes_sensor_filter(self) -> bool {
        matches!(self, Effect::BiasSteps | Effect::Bistable)
    }

    /// `gyro` without this effect: its field of the model cleared (every sinusoid, for [`Effect::Sinusoid`]).
    /// `None` for quantisation, which is the ADC channel's lattice and no field of the model.
    pub fn taken_from(self, gyro: &GyroSim) -> Option<GyroSim> {
        let mut g = gyro.clone();
        match self {
            Effect::Temperature => g.temperature = None,
            Effect::Sinusoid => g.sinusoids.clear(),
            Effect::Bandwidth => g.bandwidth_hz = None,
            Effect::GaussMarkov => g.gauss_markov = None,
            Effect::Quantization => return None,
            Effect::BiasSteps => g.bias_steps = None,
            Effect::Outliers => g.outliers = None,
            Effect::Resonance => g.resonance = None,
            Effect::Bistable => g.bistable = None,
            Effect::WarmUp => g.warm_up = None,
        }
        Some(g)
    }

    /// The effect of a name (as [`Effect::name`] gives it; `-` is accepted for `_`, case is ignored).
    pub fn parse(s: &str) -> Option<Effect> {
        let s = s.trim().to_ascii_lowercase().replace('-', "_");
        Effect::ALL.into_iter().find(|e| e.name() == s)
    }
}

impl core::fmt::Display for Effect {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name())
    }
}

/// An effect of the vocabulary: its estimator and its typed parameters, with what the chain asks of them. Each
/// effect's module has one unit type `Kind` that implements it; [`fit_effect`] and [`EffectParams`] dispatch to them.
pub trait EffectKind {
    /// Which effect.
    const EFFECT: Effect;
    /// Its parameters, each named with its unit.
    type Params: Clone + Into<EffectParams>;

    /// Fit the effect on the training data; `None` when the data carry no trace of it.
    fn estimate(data: &TrainingData) -> Option<EffectFit>;

    /// The estimator's own test statistic, where it has one that can name the effect alone
    /// ([`crate::evidence`]).
    fn test_statistic(_params: &Self::Params) -> Option<f64> {
        None
    }

    /// `params` with the values `gyro` carries for them: the sizes and time scales a joint re-estimation of the
    /// chain's model moves. The estimator's own statistics (standard errors, tests) stay as it found them.
    fn reestimated(params: &Self::Params, _gyro: &GyroSim) -> Self::Params {
        params.clone()
    }
}

/// `$body` with `$kind` the [`EffectKind`] of `$params`'s variant and `$p` its parameters.
macro_rules! with_kind {
    ($params:expr, |$kind:ident, $p:ident| $body:expr) => {
        match $params {
            EffectParams::Temperature($p) => with_kind!(@ temperature::Kind, $kind, $body),
            EffectParams::Sinusoid($p) => with_kind!(@ sinusoid::Kind, $kind, $body),
            EffectParams::Bandwidth($p) => with_kind!(@ bandwidth::Kind, $kind, $body),
            EffectParams::GaussMarkov($p) => with_kind!(@ gauss_markov::Kind, $kind, $body),
            EffectParams::Quantization($p) => with_kind!(@ quantization::Kind, $kind, $body),
            EffectParams::BiasSteps($p) => with_kind!(@ bias_steps::Kind, $kind, $body),
            EffectParams::Outliers($p) => with_kind!(@ outliers::Kind, $kind, $body),
            EffectParams::Resonance($p) => with_kind!(@ resonance::Kind, $kind, $body),
            EffectParams::Bistable($p) => with_kind!(@ bistable::Kind, $kind, $body),
            EffectParams::WarmUp($p) => with_kind!(@ warm_up::Kind, $kind, $body),
        }
    };
    (@ $path:path, $kind:ident, $body:expr) => {{
        type $kind = $path;
        $body
    }};
}

impl EffectParams {
    /// The effect these parameters belong to.
    pub fn effect(&self) -> Effect {
        with_kind!(self, |K, _p| K::EFFECT)
    }

    /// The estimator's test statistic where it has one that can name the effect alone: the t of a temperature
    /// coupling's or a warm-up's size, the fall of the chi-square with a resonance's bump or a bandwidth's corner
    /// (see [`crate::evidence`]).
    pub fn test_statistic(&self) -> Option<f64> {
        with_kind!(self, |K, p| K::test_statistic(p)).filter(|v| v.is_finite())
    }

    /// These parameters with the values `gyro` carries for them ([`EffectKind::reestimated`]).
    pub fn reestimated(&self, gyro: &GyroSim) -> EffectParams {
        with_kind!(self, |K, p| K::reestimated(p, gyro).into())
    }
}

/// What an estimator sees: the training samples and the base model fitted on them.
#[derive(Clone, Copy, Debug)]
pub struct TrainingData<'a> {
    /// Rate samples, deg/s (no gaps): the training samples less what the chain's earlier steps explained (the
    /// model's deterministic part, the realisations recovered).
    pub rate_dps: &'a [f64],
    /// The training samples as recorded (gaps filled the same way): the sample values an ADC lattice lies on,
    /// which taking anything out moves off it.
    pub recorded_dps: &'a [f64],
    /// The temperature at each sample, degC, where there is a temperature channel.
    pub temp_c: Option<&'a [f64]>,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// The base simulation model (IEEE terms fitted on these samples).
    pub base: &'a GyroSim,
    /// The base fit itself.
    pub base_fit: &'a NoiseFit,
    /// The runs of samples that were missing or masked, filled by interpolation in `rate_dps`
    /// ([`crate::fill::gap_runs`]). The base terms are re-fitted with them as gaps, and an estimator that
    /// takes a component out fills them again from what it leaves ([`crate::fill::refill`]).
    pub gaps: &'a [Range<usize>],
    /// The step of the ADC lattice the model's channel rounds the rate to, deg/s (`None`: an analog rate). Its
    /// quantisation noise, white with `step^2 / 12` per sample and added after the sensor's filter, is in the
    /// samples but is not the sensor's: the estimators that fit the Allan curve take it off first.
    pub lattice_dps: Option<f64>,
    /// The realisations earlier steps took out that the sensor's filter shapes ([`Effect::passes_sensor_filter`]),
    /// as they were taken out (sharp-edged), training length; `None`: none. Where the model has no bandwidth,
    /// `rate_dps` is the samples less them; a bandwidth estimator tries each corner on the samples less them
    /// through that corner, as the sensor passed them.
    pub shaped_dps: Option<&'a [f64]>,
}

/// An effect fitted on the training data.
#[derive(Clone, Debug, PartialEq)]
pub struct EffectFit {
    /// Which effect.
    pub effect: Effect,
    /// Its parameters, each named with its unit.
    pub params: EffectParams,
    /// Number of free parameters the effect adds (for the ranking's penalty).
    pub n_params: usize,
    /// The base model with the effect added (base terms it overlaps re-fitted).
    pub gyro: GyroSim,
    /// For quantisation: a channel whose ADC step is the data's lattice step (`None`: keep the base channel).
    pub channel: Option<Channel>,
    /// The sampling spread of the effect's parameters, which each ensemble member draws its own values from
    /// (`None`: every member simulates `gyro` itself).
    pub spread: Option<ParamSpread>,
    /// The training samples with the realisation of the effect that the estimator recovered taken out (the
    /// bistable bias's levels, the bias steps, the spikes). Later steps of the chain learn from these, as they
    /// learn from the samples less the model's deterministic part: a temperature coupling cannot be read under a
    /// bias that jumps between two levels. `None` where there is nothing to take out: a deterministic effect,
    /// which the chain subtracts through the model, or a process with no one realisation to recover.
    pub cleaned: Option<Arc<Vec<f64>>>,
}

impl EffectFit {
    /// This fit with the parameters a joint re-estimation gave its effect in `gyro` (the chain's model, which holds
    /// every effect): the model replaced, and the parameters the re-estimation moves (sizes, time scales) read
    /// from it; the estimator's own statistics (standard errors, tests) stay as it found them.
    pub fn reestimated(&self, gyro: &GyroSim) -> EffectFit {
        EffectFit { params: self.params.reestimated(gyro), gyro: gyro.clone(), ..self.clone() }
    }
}

/// The sampling spread of an effect's fitted parameters. An ensemble of the fitted values alone has next to no
/// spread where a deterministic component dominates a view (a sinusoid's Allan hump, its spectral line), so an
/// estimate one standard error off, which the training part cannot tell, reads as a gap of two on the holdout.
/// Each member draws its parameters from their sampling distribution instead, as the base model's allowance
/// ([`crate::views::ViewKind::model_floor`]) stands in for the error of its fitted terms.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamSpread {
    /// Per sinusoid of the model, in its order: the standard errors of the amplitude (deg/s), of the phase at
    /// `centre_s` (rad) and of the frequency (Hz). `centre_s` is the training part's centre, where the
    /// least-squares errors of phase and frequency are uncorrelated.
    Sinusoids {
        /// `[amplitude, phase, frequency]` standard errors per sinusoid.
        se: Vec<[f64; 3]>,
        /// Time of the training part's centre from the record's start, s.
        centre_s: f64,
    },
    /// A temperature coupling's: the standard error of its coefficient and the frequency its estimate rests on
    /// (the GLS weights' mean). At that frequency the coupling is one complex coefficient, `k` through the lag's
    /// gain and phase; its in-phase and quadrature parts are each uncertain by the standard error through the
    /// same gain, so a member draws both and reads its coefficient and lag back. Without it a coupling estimated
    /// off its truth leaves a residual that the temperature view's coherence, which no member of the fitted
    /// coupling shares, reads as a gap (a coupling read 9% low with its lag a tenth of the truth's leaves a
    /// held-out gap near 5 without the draw, nearer 4 with it).
    Coupling {
        /// Standard error of the coefficient, deg/s per degC.
        se_dps_per_c: f64,
        /// Frequency of the estimate, Hz.
        f_hz: f64,
    },
    /// Spikes': the number of runs their rate rests on. The runs of the training part are a Poisson count, so
    /// the rate read from `runs` of them is uncertain by `1 / sqrt(runs)` of itself; each member draws its
    /// share of spiked samples from the rate's posterior (a gamma law of shape `runs + 1/2`, Jeffreys' prior,
    /// scaled to the fitted share on average). Without it a dozen spikes read as eight in training leave the
    /// held-out kurtosis two ensemble spreads above every member, a gap of 2.6 where the true model gives 1.6.
    SpikeRate {
        /// Runs of spikes counted in the training part (the fitted share times its samples over the run length).
        runs: f64,
    },
    /// Bias steps': the number of steps their rate and size rest on. Each member draws the rate as a spike rate
    /// is drawn, and the steps' variance from its posterior under as many Gaussian steps (a scaled inverse
    /// chi-square law of `steps` degrees of freedom).
    StepRate {
        /// Steps found in the training part.
        steps: f64,
    },
    /// A bistable bias's: the completed dwells each state's mean dwell rests on. The time spent in a state over
    /// its dwells is a gamma law in the dwells' rate, so each member draws each state's leaving rate from the
    /// gamma law of shape `dwells + 1/2` about the fitted one.
    Dwells {
        /// Completed dwells in the low state.
        low: f64,
        /// Completed dwells in the high state.
        high: f64,
    },
}

impl ParamSpread {
    /// The model of the member simulated with `seed`: `gyro` with its parameters drawn from their spread
    /// (Gaussian, independent of the member's noise).
    pub fn draw(&self, gyro: &GyroSim, seed: u64) -> GyroSim {
        let mut rng = SimRng::new(seed ^ SPREAD_SALT);
        let mut g = gyro.clone();
        match self {
            ParamSpread::Sinusoids { se, centre_s } => {
                let two_pi = 2.0 * std::f64::consts::PI;
                for (s, [sa, sp, sf]) in g.sinusoids.iter_mut().zip(se) {
                    let f = 1.0 / s.period_s;
                    let f_new = (f + sf * rng.normal()).max(0.5 * f);
                    // The phase at the centre moves by its own error; the frequency's turns about the centre.
                    s.phase_rad += sp * rng.normal() - two_pi * (f_new - f) * centre_s;
                    s.period_s = 1.0 / f_new;
                    s.amplitude_dps = (s.amplitude_dps + sa * rng.normal()).abs();
                }
            }
            ParamSpread::Coupling { se_dps_per_c, f_hz } => {
                if let Some(c) = g.temperature.as_mut() {
                    let w = 2.0 * std::f64::consts::PI * f_hz;
                    let phase = (w * c.lag_s).atan();
                    let gain = phase.cos();
                    // The in-band coefficient k gain e^{-i phase}, each part moved by se gain.
                    let re = c.dps_per_c * gain * phase.cos() + se_dps_per_c * gain * rng.normal();
                    let im = c.dps_per_c * gain * phase.sin() + se_dps_per_c * gain * rng.normal();
                    let sign = re.signum();
                    let drawn = (im * sign).atan2(re.abs()).clamp(0.0, 1.5);
                    c.dps_per_c = sign * re.hypot(im) / drawn.cos();
                    c.lag_s = drawn.tan() / w;
                }
            }
            ParamSpread::SpikeRate { runs } => {
                if let Some(o) = g.outliers.as_mut() {
                    o.per_sample = (o.per_sample * rate_factor(&mut rng, *runs)).min(1.0);
                }
            }
            ParamSpread::StepRate { steps } => {
                if let Some(b) = g.bias_steps.as_mut() {
                    b.per_hour *= rate_factor(&mut rng, *steps);
                    let dof = steps.max(1.0);
                    b.sigma_dps *= (dof / (2.0 * gamma(&mut rng, dof / 2.0))).sqrt();
                }
            }
            ParamSpread::Dwells { low, high } => {
                if let Some(b) = g.bistable.as_mut() {
                    b.dwell_low_s /= rate_factor(&mut rng, *low);
                    b.dwell_high_s /= rate_factor(&mut rng, *high);
                }
            }
        }
        g
    }
}

/// A rate read from `count` Poisson events, as a factor on the fitted rate: a draw of its posterior under
/// Jeffreys' prior (the gamma law of shape `count + 1/2`), scaled to a mean of one.
fn rate_factor(rng: &mut SimRng, count: f64) -> f64 {
    let shape = count.max(0.0) + 0.5;
    gamma(rng, shape) / shape
}

/// A draw of the gamma law of shape `k` (> 0) and unit scale: Marsaglia and Tsang's squeeze (ACM TOMS 26, 2000),
/// with the shape raised by one and a uniform's power for `k < 1`.
fn gamma(rng: &mut SimRng, k: f64) -> f64 {
    if k < 1.0 {
        return gamma(rng, k + 1.0) * rng.uniform().max(f64::MIN_POSITIVE).powf(1.0 / k);
    }
    let d = k - 1.0 / 3.0;
    let c = 1.0 / (9.0 * d).sqrt();
    loop {
        let x = rng.normal();
        let v = (1.0 + c * x).powi(3);
        if v <= 0.0 {
            continue;
        }
        let u = rng.uniform().max(f64::MIN_POSITIVE);
        if u.ln() < 0.5 * x * x + d - d * v + d * v.ln() {
            return d * v;
        }
    }
}

/// Mixed into a member's seed for its parameter draw, so the draw is independent of the member's noise.
const SPREAD_SALT: u64 = 0x5a7e_ad00_0000;

/// Fit `effect` on the training data; `None` when the data show no trace of it.
pub fn fit_effect(effect: Effect, data: &TrainingData) -> Option<EffectFit> {
    let n = data.rate_dps.len();
    if n < 64 || !(data.rate_hz.is_finite() && data.rate_hz > 0.0) {
        return None;
    }
    if data.rate_dps.iter().any(|v| !v.is_finite()) {
        return None;
    }
    match effect {
        Effect::Temperature => temperature::Kind::estimate(data),
        Effect::Sinusoid => sinusoid::Kind::estimate(data),
        Effect::Bandwidth => bandwidth::Kind::estimate(data),
        Effect::GaussMarkov => gauss_markov::Kind::estimate(data),
        Effect::Quantization => quantization::Kind::estimate(data),
        Effect::BiasSteps => bias_steps::Kind::estimate(data),
        Effect::Outliers => outliers::Kind::estimate(data),
        Effect::Resonance => resonance::Kind::estimate(data),
        Effect::Bistable => bistable::Kind::estimate(data),
        Effect::WarmUp => warm_up::Kind::estimate(data),
    }
}

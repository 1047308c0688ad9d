//! The simulation model: what a `model.toml` holds, per gyro channel and for the bench.
//!
//! Every term defaults to absent (zero or `None`), so a model file names only what it uses. Units are in the
//! field names: `q_deg` is deg, `n_deg_per_rt_s` is deg/sqrt(s), `b_dps` deg/s, `k_dps_per_rt_s` deg/s/sqrt(s),
//! `r_dps_per_s` deg/s^2.
//!
//! ```toml
//! fs_hz = 2000.0
//! seed = 42
//!
//! [temperature]          # one profile shared by every channel
//! min_c = 22.0
//! max_c = 25.0
//! period_s = 86400.0
//! wander = { sigma_c = 0.1, tau_s = 1800.0 }
//!
//! [[channels]]
//! sensor = "adxrs300"    # the bench wiring of that part (sensor::Channel::bench)
//! [channels.gyro]
//! bias_dps = 0.2
//! n_deg_per_rt_s = 0.046
//! b_dps = 0.026
//! bandwidth_hz = 40.0
//! temperature = { dps_per_c = 0.01, lag_s = 600.0 }
//! resonance = { sigma_dps = 0.02, freq_hz = 20.0, q = 10.0 }
//! bistable = { step_dps = 0.01, dwell_low_s = 30.0, dwell_high_s = 10.0 }
//! warm_up = { size_dps = 0.05, tau_s = 600.0 }
//! outliers = { per_sample = 0.05, size_sigma = 9.5, spread_sigma = 3.5, run_mean = 1.3 }
//! [[channels.gyro.sinusoids]]
//! amplitude_dps = 0.05
//! period_s = 0.02
//! ```

use serde::{Deserialize, Serialize};

use crate::sensor::{Channel, SensorKind};

/// Most sinusoids one channel carries.
pub const MAX_SINUSOIDS: usize = 4;
/// Most channels one bench drives.
pub const MAX_CHANNELS: usize = 8;

/// The noise terms and effects of one gyro channel, in deg/s units.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GyroSim {
    /// Constant bias, deg/s.
    pub bias_dps: f64,
    /// White angle noise (IEEE 952 quantization noise) Q, deg: the rate gets `Q rate_hz (w_n - w_(n-1))`, w unit
    /// white Gaussian, whose Allan variance is `3 Q^2 / tau^2` at every tau.
    pub q_deg: f64,
    /// White rate noise (angle random walk) N, deg/sqrt(s): per-sample sd `N sqrt(rate_hz)`.
    pub n_deg_per_rt_s: f64,
    /// Flicker (bias instability) B, deg/s: Allan deviation floor 0.6643 B.
    pub b_dps: f64,
    /// Rate random walk K, deg/s/sqrt(s).
    pub k_dps_per_rt_s: f64,
    /// Rate ramp R, deg/s^2.
    pub r_dps_per_s: f64,
    /// A Gauss-Markov (exponentially correlated) rate noise.
    pub gauss_markov: Option<GaussMarkovSim>,
    /// The sensor's first-order output bandwidth (-3 dB), Hz; applied to the sum of all rate terms.
    pub bandwidth_hz: Option<f64>,
    /// Sinusoids on the rate (vibration, supply ripple).
    pub sinusoids: heapless::Vec<Sinusoid, MAX_SINUSOIDS>,
    /// Temperature sensitivity of the bias.
    pub temperature: Option<TempCoupling>,
    /// Random bias steps.
    pub bias_steps: Option<BiasSteps>,
    /// Outliers (spikes after the sensor's filter, before the ADC).
    pub outliers: Option<Outliers>,
    /// Narrowband random vibration: a second-order Gauss-Markov process (a resonance).
    pub resonance: Option<ResonanceSim>,
    /// A bias that flips between two levels at random (random telegraph, popcorn noise).
    pub bistable: Option<BistableSim>,
    /// The bias settling exponentially after power-on.
    pub warm_up: Option<WarmUpSim>,
}

/// Gauss-Markov rate noise: stationary sd and correlation time.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GaussMarkovSim {
    /// Stationary standard deviation, deg/s.
    pub sigma_dps: f64,
    /// Correlation time T, s.
    pub tau_s: f64,
}

/// A sinusoid on the rate: `amplitude_dps * sin(2 pi t / period_s + phase_rad)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sinusoid {
    /// Amplitude, deg/s.
    pub amplitude_dps: f64,
    /// Period, s.
    pub period_s: f64,
    /// Phase at t = 0, rad.
    #[serde(default)]
    pub phase_rad: f64,
}

/// Bias temperature coupling: `bias += dps_per_c * (T_lag - ref_c)`, where `T_lag` follows the temperature
/// through a first-order lag of time constant `lag_s` (the sensor's thermal mass).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TempCoupling {
    /// Coefficient, deg/s per degC.
    pub dps_per_c: f64,
    /// Temperature of zero added bias, degC.
    #[serde(default = "default_ref_c")]
    pub ref_c: f64,
    /// Thermal time constant, s (0: no lag).
    #[serde(default)]
    pub lag_s: f64,
}

fn default_ref_c() -> f64 {
    25.0
}

/// Random bias steps.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BiasSteps {
    /// Mean number of steps per hour.
    pub per_hour: f64,
    /// Standard deviation of one step, deg/s.
    pub sigma_dps: f64,
}

/// Narrowband random vibration: a damped oscillator driven by white noise (a second-order Gauss-Markov
/// process), read at each sample: the ARMA(2,1) process whose poles are `exp((-zeta w0 +- i w0 sqrt(1 - zeta^2))
/// tau0)`, `w0 = 2 pi freq_hz`, `zeta = 1 / (2 q)`, and whose zero gives it the oscillator's autocovariance at every
/// lag ([`crate::sim::noise::Resonance`]), started stationary. Its spectrum is a bump of half-power width about
/// `freq_hz / q` at `freq_hz`: a mount's resonance, or the sensor's own aliased through its decimation filter.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResonanceSim {
    /// Stationary standard deviation, deg/s.
    pub sigma_dps: f64,
    /// Centre (undamped natural) frequency, Hz; below half the sample rate.
    pub freq_hz: f64,
    /// Quality factor, above 0.5 (an underdamped oscillator).
    pub q: f64,
}

/// A bias that flips between two levels at random (random telegraph noise, popcorn noise): a two-state Markov
/// process whose dwell times in each level are exponential with the given means. The levels are `step_dps` apart
/// and placed so that the process has zero mean (`-step p_high` and `step p_low`, `p_high` the share of time in
/// the high level, `dwell_high / (dwell_low + dwell_high)`), so the model's bias stays `bias_dps`. Its
/// autocovariance is `var exp(-(l1 + l2) |t|)`, `var = step^2 l1 l2 / (l1 + l2)^2`, `l = 1 / dwell`: the Allan
/// variance of a Gauss-Markov process of that variance and correlation time `1 / (l1 + l2)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BistableSim {
    /// Distance between the two levels, deg/s.
    pub step_dps: f64,
    /// Mean dwell time in the low level, s.
    pub dwell_low_s: f64,
    /// Mean dwell time in the high level, s.
    pub dwell_high_s: f64,
}

/// The bias settling after power-on: `size_dps * exp(-t / tau_s)`, t from the record's first sample.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WarmUpSim {
    /// Added bias at the first sample, deg/s (either sign).
    pub size_dps: f64,
    /// Time constant, s.
    pub tau_s: f64,
}

/// Outliers: spikes on a share `per_sample` of the samples, added after the sensor's filter (epsilon-contaminated
/// noise when the share is large).
///
/// Each spike's magnitude is uniform on `centre +- spread`, `centre = size_dps + size_sigma sigma_w` and
/// `spread = spread_dps + spread_sigma sigma_w` (`sigma_w = N sqrt(rate_hz)`, the white noise's per-sample sd), so
/// the magnitude's moments are `E s^2 = centre^2 + spread^2 / 3` and `E s^4 = centre^4 + 2 centre^2 spread^2 +
/// spread^4 / 5`. Spikes come in runs of one sign, each spike its own magnitude: a run's first spike is followed
/// by a second with probability `c1`, and every later one by another with probability `c2 = run_continue`;
/// `c1 = (run_mean - 1)(1 - c2)` makes `run_mean` the mean run length. So `run_mean = 1.5` alone gives runs of one
/// or two samples, half each, and `c2 = 1 - 1 / run_mean` geometric lengths. A run starts at a clean sample with
/// probability `q = per_sample / (run_mean (1 - per_sample) + per_sample)`, which makes `per_sample` the share of
/// spiked samples; the run after a run may start at once (with its own sign). The autocovariance is
/// `per_sample E s^2` at lag 0 and `per_sample centre^2 rho_k` at lag k, `rho_k = (1 - 1 / run_mean) c2^(k-1)`.
/// With `run_mean <= 1` and no spread, spikes are a Bernoulli process of one size and a random sign.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Outliers {
    /// Share of samples that carry a spike (in `[0, 1]`).
    pub per_sample: f64,
    /// Centre of the magnitude law, deg/s.
    #[serde(default)]
    pub size_dps: f64,
    /// Centre of the magnitude law, in units of the white noise's per-sample sd (added to `size_dps`).
    #[serde(default)]
    pub size_sigma: f64,
    /// Half-width of the uniform magnitude law, deg/s (0: one size).
    #[serde(default)]
    pub spread_dps: f64,
    /// Half-width of the magnitude law, in units of the white noise's per-sample sd (added to `spread_dps`).
    #[serde(default)]
    pub spread_sigma: f64,
    /// Mean run length, samples (1, or 0 when absent: isolated spikes).
    #[serde(default)]
    pub run_mean: f64,
    /// Probability that a run of two or more samples goes on to another (0: runs of at most two).
    #[serde(default)]
    pub run_continue: f64,
}

/// The bench temperature: a sinusoidal cycle between `min_c` and `max_c` plus an optional slow wander.
/// `T(t) = mid + half * sin(2 pi t / period_s + phase_rad) + wander(t)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TemperatureProfile {
    /// Lowest temperature of the cycle, degC.
    pub min_c: f64,
    /// Highest temperature of the cycle, degC.
    pub max_c: f64,
    /// Cycle period, s (a day by default).
    pub period_s: f64,
    /// Phase at t = 0, rad.
    pub phase_rad: f64,
    /// A slow Gauss-Markov wander on top.
    pub wander: Option<Wander>,
}

impl Default for TemperatureProfile {
    fn default() -> Self {
        TemperatureProfile { min_c: 25.0, max_c: 25.0, period_s: 86_400.0, phase_rad: 0.0, wander: None }
    }
}

/// A Gauss-Markov temperature wander.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Wander {
    /// Stationary sd, degC.
    pub sigma_c: f64,
    /// Correlation time, s.
    pub tau_s: f64,
}

/// One channel of a simulated bench: which part (wired as on octavar's bench, or fully described) and its noise.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChannelSim {
    /// The part; its bench wiring comes from [`Channel::bench`] unless `channel` is given.
    pub sensor: SensorKind,
    /// A full channel description that overrides the bench wiring.
    #[serde(default)]
    pub channel: Option<Channel>,
    /// The noise model.
    #[serde(default)]
    pub gyro: GyroSim,
}

/// A simulated bench: channels sampled together at one rate, one shared temperature.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BenchSim {
    /// Sample rate per channel, Hz (the `fs_hz` key of a `model.toml`).
    #[serde(rename = "fs_hz")]
    pub rate_hz: f64,
    /// Seed of the whole run.
    #[serde(default)]
    pub seed: u64,
    /// The temperature profile.
    #[serde(default)]
    pub temperature: TemperatureProfile,
    /// The channels, in ADC scan order.
    pub channels: heapless::Vec<ChannelSim, MAX_CHANNELS>,
}

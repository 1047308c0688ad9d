//! A deterministic virtual gyro + ADC that streams sample by sample in constant memory.
//!
//! The firmware feeds it to the accumulator as a self-test input (and on QEMU, whose ADC model is a toy); the
//! host generates days of data from a `model.toml` to compare with a recording. A model ([`GyroSim`]) lists the
//! terms of one channel in the conventions of IEEE Std 952 (rate data in deg/s, tau0 = 1/rate_hz):
//!
//! | term | model field | Allan variance |
//! |------|-------------|----------------|
//! | white angle noise (quantization noise) Q | `q_deg` | `3 Q^2 / tau^2` |
//! | white rate noise N | `n_deg_per_rt_s` | `N^2 / tau` |
//! | flicker B | `b_dps` | `(2 ln 2 / pi) B^2` ([`flicker`]: 9 decades) |
//! | rate random walk K | `k_dps_per_rt_s` | `K^2 tau / 3` |
//! | ramp R | `r_dps_per_s` | `R^2 tau^2 / 2` |
//! | Gauss-Markov, first-order bandwidth | `gauss_markov`, `bandwidth_hz` | Gauss-Markov form, T = 1/(2 pi f3dB) |
//! | sinusoid A, f0 | `sinusoids` | `A^2 sin^4(pi f0 tau) / (pi f0 tau)^2` |
//! | temperature coupling | `temperature` | through the thermal lag ([`temperature`]) |
//! | bias steps, outliers | `bias_steps`, `outliers` | random-walk-like; white `p E s^2 / m`, plus an AR(1) form for runs ([`model::Outliers`]) |
//! | resonance (second-order Gauss-Markov) | `resonance` | the sampled oscillator's, an exact ARMA(2,1) form ([`noise::Resonance`]) |
//! | bistable bias (random telegraph) | `bistable` | Gauss-Markov form, T = 1/(l1 + l2) ([`effects::Telegraph`]) |
//! | warm-up | `warm_up` | deterministic, `size exp(-t / tau)` |
//!
//! ADC quantisation and clipping come from the channel's [`crate::sensor::Channel`]. A [`Bench`] drives several
//! channels and one shared temperature profile ([`BenchSim`]).
//!
//! # Determinism and cost
//! One model and one seed give the same samples bit for bit (xoshiro256++, a ziggurat Gaussian, and only `+ - *`
//! in the per-sample path, which IEEE 754 rounds the same everywhere). Memory is fixed: a [`VirtualGyro`] is
//! about 1.1 KiB whatever the run length. Per sample and channel, with every term on: five Gaussian draws (white,
//! random walk, Gauss-Markov, resonance, a bias step's size only on a step; a sixth for white angle noise Q), the
//! flicker bank's six multiply-adds on about 3.3 random words, some forty multiply-adds in all,
//! and one decrement for each of bias steps, bistable flips and outliers; no division and no transcendental call
//! except on rare events (a bias step, a flip, an outlier, a ziggurat tail). The block methods
//! ([`VirtualGyro::fill_codes_at`], [`Bench::fill_block`]) run a loop with the state in registers, and a gyro with
//! only the base terms (N, B, K, temperature, bandwidth) skips the checks of the others: about 230 instructions
//! per sample for the demo's channel. Criterion bench `crates/octavar/benches/sim.rs`. A [`VirtualGyro`] is about 1.1 KiB, a
//! [`Bench`] of up to eight channels about 10 KiB. On the Cortex-M4 the `f64`
//! arithmetic is software, so a channel costs a few thousand cycles per sample: enough for a self-test at a few
//! kS/s, not for five channels at 2 kS/s while the firmware does its real work.
//!
//! # Examples
//! ```
//! use octavar_shared::sensor::{Channel, ADXRS300};
//! use octavar_shared::sim::{GyroSim, VirtualGyro};
//! let model = GyroSim { n_deg_per_rt_s: 0.046, b_dps: 0.026, bias_dps: 0.1, ..Default::default() };
//! let mut gyro = VirtualGyro::new(&model, Channel::bench(ADXRS300), 2000.0, 42).unwrap();
//! let a = gyro.next(25.0);
//! let mut again = VirtualGyro::new(&model, Channel::bench(ADXRS300), 2000.0, 42).unwrap();
//! assert_eq!(again.next(25.0), a); // same seed, same sample
//! assert!(!a.clipped);
//! ```

pub mod adc;
pub mod bench;
pub mod effects;
pub mod flicker;
pub mod gyro;
pub mod model;
pub mod noise;
pub mod rng;
pub mod temperature;

pub use bench::{Bench, BenchSample};
pub use gyro::{Sample, SimError, VirtualGyro};
pub use model::{
    BenchSim, BiasSteps, BistableSim, ChannelSim, GaussMarkovSim, GyroSim, Outliers, ResonanceSim, Sinusoid,
    TempCoupling, TemperatureProfile, Wander, WarmUpSim, MAX_CHANNELS, MAX_SINUSOIDS,
};

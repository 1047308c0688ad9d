//! A second gyro generator, sharing no code with `octavar_shared::sim`: every effect of the gap diagnosis's
//! vocabulary with the same continuous-time meaning as shared::sim's, made by other routes, so that a claim about
//! the diagnosis can be measured on records from two generators.
//!
//! The base noise (N, B, K) is [`crate::fft_gyro`]'s. Every other term draws from its own `StdRng` stream (normals
//! and exponentials from `rand_distr`) and is made as follows:
//!
//! | term | meaning (as shared::sim's) | route here |
//! |---|---|---|
//! | bias coupled to temperature | `dps_per_c (T_lag - ref_c)`, `T_lag` the bench temperature through a first-order lag `lag_s` | the lag by its exact discretisation for a temperature linear between samples (first-order hold), started settled |
//! | bench temperature | a cycle plus a slow wander | its own: a daily-like cycle (fundamental and a second harmonic) plus a Gauss-Markov wander by circulant embedding |
//! | sinusoids | `A sin(2 pi t / P + phi)`, t = i / rate_hz | `sin` evaluated at each sample |
//! | Gauss-Markov | stationary, autocovariance `sigma^2 exp(-|t| / T)` | circulant embedding of that autocovariance (Davies-Harte) |
//! | resonance | a damped oscillator driven by white noise, stationary sd `sigma`, natural frequency `f0`, `Q` | circulant embedding of the oscillator's autocovariance `sigma^2 e^(-zeta w0 t) (cos wd t + zeta / sqrt(1 - zeta^2) sin wd t)` |
//! | bias steps | Poisson jumps at `per_hour`, Gaussian sizes `sigma_dps`, accumulated | arrival times from exponential gaps in continuous time; a jump counts from the first sample at or after it |
//! | bistable bias | two zero-mean levels `step_dps` apart, exponential dwells | the continuous-time telegraph (stationary start, exponential dwells) read at each sample time |
//! | warm-up | `size exp(-t / tau)` | evaluated at each sample |
//! | bandwidth | first-order low-pass at `bandwidth_hz` of every rate term (outliers added after it) | in the frequency domain: the record less its first value, zero-padded past the filter's memory, times `(1 - a) / (1 - a e^(-i w))`, `a = exp(-2 pi f3dB / rate_hz)` (the discrete filter of a rate sample, started settled) |
//! | outliers, contamination | a share of samples carrying spikes of either sign, sized in sigmas of the white noise | events (isolated, or runs of 2-3 samples of one sign, each its own sign and size) started at Bernoulli samples outside an event, so that the share spiked is the one asked for; sizes uniform over a range |
//! | quantisation | values on a lattice of step `step_dps` | rounding to `offset + step Z`, last of all |
//!
//! The truth maps to shared::sim's `GyroSim` for the oracle in [`oracle`], apart from the generator.

pub mod oracle;
#[cfg(test)]
mod tests;

use std::f64::consts::PI;
use std::sync::{Arc, Mutex, OnceLock};

use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Exp1, StandardNormal};
use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};

use crate::fft_gyro::fft_gyro;

/// The bench temperature: `mean_c + half_swing (sin(p) + h2 sin(2 p + phase2)) / (1 + h2)`, `p = 2 pi t / period_s
/// + phase_rad`, plus a Gauss-Markov wander; a daily-like cycle, warmer for longer than it is cool.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BenchTemperature {
    /// Mid temperature, degC.
    pub mean_c: f64,
    /// Peak-to-peak swing of the cycle, degC.
    pub swing_c: f64,
    /// Cycle period, s.
    pub period_s: f64,
    /// Phase at t = 0, rad.
    pub phase_rad: f64,
    /// Relative size of the second harmonic.
    pub harmonic: f64,
    /// Stationary sd of the wander, degC.
    pub wander_sd_c: f64,
    /// Correlation time of the wander, s.
    pub wander_tau_s: f64,
}

/// The bias's coupling to the temperature through the sensor's thermal lag.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coupling {
    /// deg/s per degC.
    pub dps_per_c: f64,
    /// Thermal time constant, s.
    pub lag_s: f64,
    /// Temperature of no added bias, degC.
    pub ref_c: f64,
}

/// `amplitude_dps sin(2 pi t / period_s + phase_rad)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sine {
    /// deg/s.
    pub amplitude_dps: f64,
    /// s.
    pub period_s: f64,
    /// rad.
    pub phase_rad: f64,
}

/// First-order Gauss-Markov rate noise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Markov {
    /// Stationary sd, deg/s.
    pub sigma_dps: f64,
    /// Correlation time, s.
    pub tau_s: f64,
}

/// A lattice the recorded values sit on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lattice {
    /// Step, deg/s.
    pub step_dps: f64,
    /// Offset of the lattice from zero, deg/s.
    pub offset_dps: f64,
}

/// Poisson bias jumps, accumulated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Jumps {
    /// Mean jumps per hour.
    pub per_hour: f64,
    /// Sd of one jump, deg/s.
    pub sigma_dps: f64,
}

/// Spikes on a share of the samples, after the filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contamination {
    /// Expected share of samples carrying a spike.
    pub per_sample: f64,
    /// Spike sizes are uniform over this range, in sigmas of the white noise (`N sqrt(rate_hz)`).
    pub size_sigma: [f64; 2],
    /// Longest run of spiked samples (1: isolated spikes; up to 3). Runs of 1, 2, 3 have weights 4, 2, 1.
    pub longest_run: usize,
}

/// Second-order Gauss-Markov noise (a damped oscillator driven by white noise).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Oscillator {
    /// Stationary sd, deg/s.
    pub sigma_dps: f64,
    /// Natural frequency, Hz.
    pub freq_hz: f64,
    /// Quality factor, above 0.5.
    pub q: f64,
}

/// A random telegraph bias.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Telegraph {
    /// Distance between the levels, deg/s.
    pub step_dps: f64,
    /// Mean dwell in the low level, s.
    pub dwell_low_s: f64,
    /// Mean dwell in the high level, s.
    pub dwell_high_s: f64,
}

/// Exponential settling after power-on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settling {
    /// Added bias at t = 0, deg/s.
    pub size_dps: f64,
    /// Time constant, s.
    pub tau_s: f64,
}

/// One gyro channel: base noise and every effect, each absent by default.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct IndepGyro {
    /// Constant bias, deg/s.
    pub bias_dps: f64,
    /// White rate noise N, deg/sqrt(s).
    pub n_deg_per_rt_s: f64,
    /// Flicker B, deg/s.
    pub b_dps: f64,
    /// Rate random walk K, deg/s/sqrt(s).
    pub k_dps_per_rt_s: f64,
    /// A temperature channel (recorded whether or not the rate follows it).
    pub bench: Option<BenchTemperature>,
    /// The bias's temperature coupling (needs `bench`).
    pub coupling: Option<Coupling>,
    pub sinusoids: Vec<Sine>,
    /// First-order output bandwidth, Hz.
    pub bandwidth_hz: Option<f64>,
    pub gauss_markov: Option<Markov>,
    pub lattice: Option<Lattice>,
    pub jumps: Option<Jumps>,
    pub contamination: Option<Contamination>,
    pub resonance: Option<Oscillator>,
    pub telegraph: Option<Telegraph>,
    pub settling: Option<Settling>,
}

/// A generated record.
#[derive(Clone, Debug)]
pub struct Record {
    /// Rate, deg/s.
    pub rate_dps: Vec<f64>,
    /// Temperature, degC, where the gyro has a bench temperature.
    pub temp_c: Option<Vec<f64>>,
}

/// SplitMix64's finaliser: well-spread 64-bit seeds from small ones.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The random stream of one term of record `seed`: each term has its own.
fn stream(seed: u64, term: u64) -> StdRng {
    StdRng::seed_from_u64(mix(mix(seed) ^ (term << 40) ^ 0x1de9))
}

fn normal(rng: &mut StdRng) -> f64 {
    StandardNormal.sample(rng)
}

fn exp1(rng: &mut StdRng) -> f64 {
    Exp1.sample(rng)
}

fn fft(len: usize, inverse: bool) -> Arc<dyn Fft<f64>> {
    static PLANNER: OnceLock<Mutex<FftPlanner<f64>>> = OnceLock::new();
    let mut p = PLANNER.get_or_init(|| Mutex::new(FftPlanner::new())).lock().unwrap();
    if inverse {
        p.plan_fft_inverse(len)
    } else {
        p.plan_fft_forward(len)
    }
}

/// `n` samples at `rate_hz` of the stationary Gaussian process of autocovariance `acf(t)` (t in s), by circulant
/// embedding (Davies and Harte 1987): the autocovariance at lags 0 .. L/2 mirrored into a circulant of length
/// `L >= 2 n` (a power of two), whose eigenvalues (its DFT) weight complex Gaussian amplitudes; the real part of
/// their DFT has exactly the autocovariance `acf` at lags below `L/2`. Negative eigenvalues (a covariance that
/// does not embed) are set to zero; their share of the trace is returned beside the samples.
pub fn from_autocovariance(acf: impl Fn(f64) -> f64, rate_hz: f64, n: usize, rng: &mut StdRng) -> (Vec<f64>, f64) {
    let l = (2 * n).next_power_of_two().max(4);
    let mut c: Vec<Complex<f64>> = (0..l).map(|k| Complex::new(acf(k.min(l - k) as f64 / rate_hz), 0.0)).collect();
    fft(l, false).process(&mut c);
    let trace: f64 = c.iter().map(|v| v.re.abs()).sum();
    let negative: f64 = c.iter().map(|v| (-v.re).max(0.0)).sum();
    for v in &mut c {
        let s = (v.re.max(0.0) / l as f64).sqrt();
        *v = Complex::new(s * normal(rng), s * normal(rng));
    }
    fft(l, false).process(&mut c);
    (c[..n].iter().map(|v| v.re).collect(), negative / trace.max(f64::MIN_POSITIVE))
}

/// The autocovariance of a damped oscillator driven by white noise, stationary sd `sigma`, at lag `t` s.
pub fn oscillator_acf(o: &Oscillator, t: f64) -> f64 {
    let zeta = 0.5 / o.q;
    let w0 = 2.0 * PI * o.freq_hz;
    let wd = w0 * (1.0 - zeta * zeta).sqrt();
    let t = t.abs();
    o.sigma_dps.powi(2) * (-zeta * w0 * t).exp() * ((wd * t).cos() + zeta / (1.0 - zeta * zeta).sqrt() * (wd * t).sin())
}

/// The bench temperature at `n` samples of `rate_hz`, degC.
pub fn bench_temperature(b: &BenchTemperature, rate_hz: f64, n: usize, seed: u64) -> Vec<f64> {
    let mut rng = stream(seed, 1);
    let wander = if b.wander_sd_c > 0.0 {
        let (sd, tau) = (b.wander_sd_c, b.wander_tau_s);
        from_autocovariance(|t| sd * sd * (-t / tau).exp(), rate_hz, n, &mut rng).0
    } else {
        vec![0.0; n]
    };
    let phase2 = rng.random::<f64>() * 2.0 * PI;
    let half = 0.5 * b.swing_c / (1.0 + b.harmonic);
    wander
        .iter()
        .enumerate()
        .map(|(i, w)| {
            let p = 2.0 * PI * i as f64 / rate_hz / b.period_s + b.phase_rad;
            b.mean_c + half * (p.sin() + b.harmonic * (2.0 * p + phase2).sin()) + w
        })
        .collect()
}

/// The temperature through a first-order lag of `lag_s`: the exact response over each sample interval to a
/// temperature linear between the samples, `y1 = a y0 + u1 - a u0 - (u1 - u0) (lag / h) (1 - a)`, `a = exp(-h /
/// lag)`, started settled at the first temperature.
pub fn thermal_lag(temp_c: &[f64], lag_s: f64, rate_hz: f64) -> Vec<f64> {
    let h = 1.0 / rate_hz;
    let Some(&first) = temp_c.first() else { return Vec::new() };
    if lag_s <= 0.0 {
        return temp_c.to_vec();
    }
    let a = (-h / lag_s).exp();
    let ramp = lag_s / h * (1.0 - a);
    let mut y = first;
    let mut out = Vec::with_capacity(temp_c.len());
    out.push(y);
    for w in temp_c.windows(2) {
        let (u0, u1) = (w[0], w[1]);
        y = a * y + u1 - a * u0 - (u1 - u0) * ramp;
        out.push(y);
    }
    out
}

/// The first-order low-pass of every rate term (see the module doc), in place.
pub fn low_pass(x: &mut [f64], f3db_hz: f64, rate_hz: f64) {
    let n = x.len();
    if n == 0 {
        return;
    }
    let a = (-2.0 * PI * f3db_hz / rate_hz).exp();
    // The impulse response falls as a^k: 40 / (1 - a) samples take it below e^-40 of its start.
    let memory = (40.0 / (1.0 - a)).ceil() as usize;
    let l = (n + memory).next_power_of_two();
    let x0 = x[0];
    let mut buf: Vec<Complex<f64>> = x.iter().map(|&v| Complex::new(v - x0, 0.0)).collect();
    buf.resize(l, Complex::new(0.0, 0.0));
    fft(l, false).process(&mut buf);
    for (k, v) in buf.iter_mut().enumerate() {
        let w = 2.0 * PI * k as f64 / l as f64;
        *v *= (1.0 - a) / (Complex::new(1.0, 0.0) - a * Complex::from_polar(1.0, -w));
    }
    fft(l, true).process(&mut buf);
    for (xi, v) in x.iter_mut().zip(&buf) {
        *xi = x0 + v.re / l as f64;
    }
}

/// Accumulated Poisson jumps at each of `n` samples.
pub fn jumps(j: &Jumps, rate_hz: f64, n: usize, rng: &mut StdRng) -> Vec<f64> {
    let mut delta = vec![0.0; n];
    let per_s = j.per_hour / 3600.0;
    if per_s > 0.0 {
        let mut t = exp1(rng) / per_s;
        while t < n as f64 / rate_hz {
            let at = (t * rate_hz).ceil() as usize;
            if at < n {
                delta[at] += j.sigma_dps * normal(rng);
            }
            t += exp1(rng) / per_s;
        }
    }
    let mut level = 0.0;
    for d in &mut delta {
        level += *d;
        *d = level;
    }
    delta
}

/// The telegraph bias at each of `n` samples: levels `-step p_high` and `step p_low` (zero mean), `p_high =
/// dwell_high / (dwell_low + dwell_high)`, the state at t = 0 drawn from that law, each dwell exponential.
pub fn telegraph(tg: &Telegraph, rate_hz: f64, n: usize, rng: &mut StdRng) -> Vec<f64> {
    let p_high = tg.dwell_high_s / (tg.dwell_low_s + tg.dwell_high_s);
    let (low, high) = (-tg.step_dps * p_high, tg.step_dps * (1.0 - p_high));
    let mut is_high = rng.random::<f64>() < p_high;
    let mut until = 0.0;
    let mut out = Vec::with_capacity(n);
    let mut first = true;
    for i in 0..n {
        let t = i as f64 / rate_hz;
        while first || t >= until {
            if !first {
                is_high = !is_high;
            }
            first = false;
            until += exp1(rng) * if is_high { tg.dwell_high_s } else { tg.dwell_low_s };
        }
        out.push(if is_high { high } else { low });
    }
    out
}

/// The spikes of `c` on `n` samples (mostly zero), white noise sd `white_sd`.
pub fn contamination(c: &Contamination, white_sd: f64, n: usize, rng: &mut StdRng) -> Vec<f64> {
    let runs = c.longest_run.clamp(1, 3);
    let weights = [4.0, 2.0, 1.0];
    let total: f64 = weights[..runs].iter().sum();
    let mean_run: f64 = weights[..runs].iter().enumerate().map(|(i, w)| (i + 1) as f64 * w).sum::<f64>() / total;
    // An event starts with probability p at each sample outside one, so a share `p L / (1 - p + p L)` of the
    // samples is spiked (L the mean run): p is what makes that share `per_sample`.
    let f = c.per_sample.clamp(0.0, 0.5);
    let p_start = f / (mean_run - f * (mean_run - 1.0));
    let mut out = vec![0.0; n];
    let mut i = 0;
    while i < n {
        if rng.random::<f64>() < p_start {
            let mut u = rng.random::<f64>() * total;
            let mut len = 1;
            for (k, w) in weights[..runs].iter().enumerate() {
                if u < *w {
                    len = k + 1;
                    break;
                }
                u -= w;
            }
            let sign = if rng.random::<f64>() < 0.5 { -1.0 } else { 1.0 };
            let size = c.size_sigma[0] + (c.size_sigma[1] - c.size_sigma[0]) * rng.random::<f64>();
            for v in out.iter_mut().skip(i).take(len) {
                *v = sign * size * white_sd;
            }
            i += len;
        } else {
            i += 1;
        }
    }
    out
}

impl IndepGyro {
    /// The white noise's per-sample sd at `rate_hz`, deg/s.
    pub fn white_sd(&self, rate_hz: f64) -> f64 {
        self.n_deg_per_rt_s * rate_hz.sqrt()
    }

    /// `n` samples at `rate_hz` of this gyro, random stream `seed`: the rate and, with a bench, the temperature.
    pub fn generate(&self, rate_hz: f64, n: usize, seed: u64) -> Record {
        let mut x = fft_gyro(rate_hz, n, self.n_deg_per_rt_s, self.b_dps, self.k_dps_per_rt_s, mix(seed ^ 0xba5e));
        let add = |x: &mut Vec<f64>, y: &[f64]| x.iter_mut().zip(y).for_each(|(a, b)| *a += b);
        for v in &mut x {
            *v += self.bias_dps;
        }
        if let Some(g) = self.gauss_markov {
            let (s, t) = (g.sigma_dps, g.tau_s);
            add(&mut x, &from_autocovariance(|l| s * s * (-l / t).exp(), rate_hz, n, &mut stream(seed, 2)).0);
        }
        for s in &self.sinusoids {
            for (i, v) in x.iter_mut().enumerate() {
                *v += s.amplitude_dps * (2.0 * PI * i as f64 / rate_hz / s.period_s + s.phase_rad).sin();
            }
        }
        let temp_c = self.bench.map(|b| bench_temperature(&b, rate_hz, n, seed));
        if let (Some(c), Some(t)) = (self.coupling, &temp_c) {
            let lagged = thermal_lag(t, c.lag_s, rate_hz);
            x.iter_mut().zip(&lagged).for_each(|(v, tl)| *v += c.dps_per_c * (tl - c.ref_c));
        }
        if let Some(j) = self.jumps {
            add(&mut x, &jumps(&j, rate_hz, n, &mut stream(seed, 3)));
        }
        if let Some(o) = self.resonance {
            add(&mut x, &from_autocovariance(|t| oscillator_acf(&o, t), rate_hz, n, &mut stream(seed, 4)).0);
        }
        if let Some(tg) = self.telegraph {
            add(&mut x, &telegraph(&tg, rate_hz, n, &mut stream(seed, 5)));
        }
        if let Some(w) = self.settling {
            for (i, v) in x.iter_mut().enumerate() {
                *v += w.size_dps * (-(i as f64) / rate_hz / w.tau_s).exp();
            }
        }
        if let Some(f) = self.bandwidth_hz {
            low_pass(&mut x, f, rate_hz);
        }
        if let Some(c) = self.contamination {
            add(&mut x, &contamination(&c, self.white_sd(rate_hz), n, &mut stream(seed, 6)));
        }
        if let Some(q) = self.lattice {
            for v in &mut x {
                *v = q.offset_dps + q.step_dps * ((*v - q.offset_dps) / q.step_dps).round();
            }
        }
        Record { rate_dps: x, temp_c }
    }
}

//! The effects a real bench adds to the noise terms: sinusoids, bias steps and outliers.
//!
//! Sinusoids turn a phasor by a fixed rotation each sample (four multiplies, no `sin` call), renormalised every
//! 4096 samples. Bias steps and outliers are Bernoulli events: the gap to the next event is drawn once per event
//! (a geometric deviate), so a sample without an event costs one decrement and compare.

use super::model::{BiasSteps, Outliers, Sinusoid, MAX_SINUSOIDS};
use super::rng::SimRng;

/// One sinusoid as a rotating phasor: value `amplitude * sin(phase_n)`.
#[derive(Clone, Debug, PartialEq)]
struct Phasor {
    c: f64,
    s: f64,
    cos_d: f64,
    sin_d: f64,
    amplitude: f64,
}

/// Up to [`MAX_SINUSOIDS`] sinusoids on the rate, `A sin(2 pi t / P + phi)` with t = n tau0.
#[derive(Clone, Debug, PartialEq)]
pub struct Sinusoids {
    phasors: [Phasor; MAX_SINUSOIDS],
    len: usize,
}

impl Sinusoids {
    /// The sinusoids of a model, sampled every `tau0_s`.
    pub fn new(list: &[Sinusoid], tau0_s: f64) -> Self {
        let zero = Phasor { c: 1.0, s: 0.0, cos_d: 1.0, sin_d: 0.0, amplitude: 0.0 };
        let mut phasors = [zero.clone(), zero.clone(), zero.clone(), zero];
        let len = list.len().min(MAX_SINUSOIDS);
        for (p, s) in phasors.iter_mut().zip(list) {
            let d = 2.0 * core::f64::consts::PI * tau0_s / s.period_s;
            *p = Phasor {
                c: libm::cos(s.phase_rad),
                s: libm::sin(s.phase_rad),
                cos_d: libm::cos(d),
                sin_d: libm::sin(d),
                amplitude: s.amplitude_dps,
            };
        }
        Sinusoids { phasors, len }
    }

    /// True when there is nothing to add.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The sum of the sinusoids at sample `n` (n counts from 0, one call per sample), in deg/s.
    #[inline]
    pub fn next(&mut self, n: u64) -> f64 {
        let renorm = n & 4095 == 4095;
        let mut sum = 0.0;
        for p in &mut self.phasors[..self.len] {
            sum += p.amplitude * p.s;
            let c = p.c * p.cos_d - p.s * p.sin_d;
            let s = p.s * p.cos_d + p.c * p.sin_d;
            // One Newton step towards |phasor| = 1 (no sqrt): the rounding drift never accumulates.
            let g = if renorm { 1.5 - 0.5 * (c * c + s * s) } else { 1.0 };
            p.c = c * g;
            p.s = s * g;
        }
        sum
    }
}

/// Bias steps: at Bernoulli instants (rate `per_hour`), the bias jumps by a Gaussian of sd `sigma_dps`.
///
/// The accumulated steps are a random walk with per-sample increment variance `p sigma^2`
/// (`p = per_hour / 3600 / fs`): the same Allan variance as rate random walk with `K^2 = p sigma^2 / tau0`.
#[derive(Clone, Debug, PartialEq)]
pub struct Steps {
    p: f64,
    sigma: f64,
    left: u64,
    level: f64,
    count: u64,
}

impl Steps {
    /// Steps as the model gives them, at `fs_hz`.
    pub fn new(m: &BiasSteps, fs_hz: f64, rng: &mut SimRng) -> Self {
        let p = (m.per_hour / 3600.0 / fs_hz).min(1.0);
        Steps { p, sigma: m.sigma_dps, left: rng.gap(p), level: 0.0, count: 0 }
    }

    /// The accumulated bias after this sample, in deg/s.
    #[inline]
    pub fn next(&mut self, rng: &mut SimRng) -> f64 {
        self.left -= 1;
        if self.left == 0 {
            self.level += self.sigma * rng.normal();
            self.count += 1;
            self.left = rng.gap(self.p);
        }
        self.level
    }

    /// Steps taken so far.
    pub fn count(&self) -> u64 {
        self.count
    }
}

/// Outliers: on Bernoulli samples (probability `per_sample`), a spike of fixed size and random sign.
///
/// As a process they are white with variance `p size^2`.
#[derive(Clone, Debug, PartialEq)]
pub struct Spikes {
    p: f64,
    size: f64,
    left: u64,
    count: u64,
}

impl Spikes {
    /// Outliers as the model gives them; `white_sigma` is the per-sample sd of the white noise N.
    pub fn new(m: &Outliers, white_sigma: f64, rng: &mut SimRng) -> Self {
        let p = m.per_sample.min(1.0);
        Spikes { p, size: m.size_dps + m.size_sigma * white_sigma, left: rng.gap(p), count: 0 }
    }

    /// The spike on this sample (usually 0), in deg/s.
    #[inline]
    pub fn next(&mut self, rng: &mut SimRng) -> f64 {
        self.left -= 1;
        if self.left == 0 {
            self.count += 1;
            self.left = rng.gap(self.p);
            self.size * rng.sign()
        } else {
            0.0
        }
    }

    /// Outliers so far.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// The spike magnitude, in deg/s.
    pub fn size_dps(&self) -> f64 {
        self.size
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phasor_tracks_sin_for_a_long_time() {
        let s = Sinusoid { amplitude_dps: 2.0, period_s: 0.37, phase_rad: 0.3 };
        let tau0 = 1e-3;
        let mut sines = Sinusoids::new(&[s], tau0);
        let mut worst: f64 = 0.0;
        for n in 0..2_000_000u64 {
            let got = sines.next(n);
            if n % 9973 == 0 {
                let want = 2.0 * libm::sin(2.0 * core::f64::consts::PI * n as f64 * tau0 / 0.37 + 0.3);
                worst = worst.max((got - want).abs());
            }
        }
        // Phase error grows like n * eps; 2e6 samples leave it near 1e-9.
        assert!(worst < 1e-7, "{worst}");
    }

    #[test]
    fn event_counts_follow_the_rate() {
        let mut rng = SimRng::new(9);
        let mut spikes = Spikes::new(&Outliers { per_sample: 1e-3, size_dps: 5.0, size_sigma: 0.0 }, 1.0, &mut rng);
        let n = 1_000_000;
        let mut sum_abs = 0.0;
        for _ in 0..n {
            sum_abs += spikes.next(&mut rng).abs();
        }
        // Binomial(1e6, 1e-3): mean 1000, sd 31.6; 5 sigma.
        let c = spikes.count() as f64;
        assert!((c - 1000.0).abs() < 160.0, "{c}");
        assert_eq!(sum_abs, 5.0 * c);
    }
}

//! The effects a real bench adds to the noise terms: sinusoids, bias steps, outliers, a bistable bias and the
//! warm-up.
//!
//! Sinusoids turn a phasor by a fixed rotation each sample (four multiplies, no `sin` call), renormalised every
//! 4096 samples. Bias steps, outliers and the flips of a bistable bias are Bernoulli events: the gap to the next
//! event is drawn once per event (a geometric deviate), so a sample without an event costs one decrement and
//! compare. The warm-up decays by one multiply per sample.

use super::model::{BiasSteps, BistableSim, Outliers, Sinusoid, WarmUpSim, MAX_SINUSOIDS};
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

impl Phasor {
    /// The phasor `(c, s)` of sample `n` turned on by one sample; at every 4096th sample one Newton step towards
    /// |phasor| = 1 (no sqrt), so the rounding drift never accumulates.
    #[inline(always)]
    fn turn(&self, c: f64, s: f64, n: u64) -> (f64, f64) {
        let c2 = c * self.cos_d - s * self.sin_d;
        let s2 = s * self.cos_d + c * self.sin_d;
        let g = if n & 4095 == 4095 { 1.5 - 0.5 * (c2 * c2 + s2 * s2) } else { 1.0 };
        (c2 * g, s2 * g)
    }
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

    /// The sums of the sinusoids at samples `n0 .. n0 + count`, handed to `out(k, sum)` in order: the values of
    /// as many calls of [`Sinusoids::next`]. The phasors turn in registers, and the renormalising Newton step is
    /// taken only at its samples, so that the turn between two of them is four multiplies and two adds.
    #[inline(always)]
    pub fn for_each(&mut self, n0: u64, count: usize, mut out: impl FnMut(usize, f64)) {
        match self.len {
            0 => (0..count).for_each(|k| out(k, 0.0)),
            1 => {
                let p = &mut self.phasors[0];
                let (mut c, mut s) = (p.c, p.s);
                let (cos_d, sin_d, amplitude) = (p.cos_d, p.sin_d, p.amplitude);
                let mut k = 0;
                while k < count {
                    // Samples up to the next renormalisation (n & 4095 == 4095), then that one.
                    let plain = ((4095 - ((n0 + k as u64) & 4095)) as usize).min(count - k);
                    for j in k..k + plain {
                        out(j, 0.0 + amplitude * s);
                        (c, s) = (c * cos_d - s * sin_d, s * cos_d + c * sin_d);
                    }
                    k += plain;
                    if k < count {
                        out(k, 0.0 + amplitude * s);
                        (c, s) = p.turn(c, s, n0 + k as u64);
                        k += 1;
                    }
                }
                (p.c, p.s) = (c, s);
            }
            _ => (0..count).for_each(|k| {
                let n = n0 + k as u64;
                out(k, self.next(n));
            }),
        }
    }

    /// The sum of the sinusoids at sample `n` (n counts from 0, one call per sample), in deg/s.
    #[inline]
    pub fn next(&mut self, n: u64) -> f64 {
        let mut sum = 0.0;
        for p in &mut self.phasors[..self.len] {
            sum += p.amplitude * p.s;
            (p.c, p.s) = p.turn(p.c, p.s, n);
        }
        sum
    }
}

/// Bias steps: at Bernoulli instants (rate `per_hour`), the bias jumps by a Gaussian of sd `sigma_dps`.
///
/// The accumulated steps are a random walk with per-sample increment variance `p sigma^2`
/// (`p = per_hour / 3600 / rate_hz`): the same Allan variance as rate random walk with `K^2 = p sigma^2 / tau0`.
#[derive(Clone, Debug, PartialEq)]
pub struct Steps {
    p: f64,
    sigma: f64,
    left: u64,
    level: f64,
    count: u64,
}

impl Steps {
    /// Steps as the model gives them, at `rate_hz`.
    pub fn new(m: &BiasSteps, rate_hz: f64, rng: &mut SimRng) -> Self {
        let p = (m.per_hour / 3600.0 / rate_hz).min(1.0);
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

/// Outliers ([`Outliers`]): spikes on a share `per_sample` of the samples, magnitudes uniform on `centre +-
/// spread`, random sign, in runs of one sign (the law of their lengths is [`Outliers`]'s).
///
/// Isolated spikes of one size (no spread, `run_mean <= 1`) are a Bernoulli process drawing one geometric gap and
/// one sign per spike, and nothing else. A spread adds one uniform draw per spike; runs add one uniform draw per
/// spike (does the run go on?). Between spikes a sample costs one decrement and compare.
#[derive(Clone, Debug, PartialEq)]
pub struct Spikes {
    /// Probability that a run starts at a clean sample.
    p: f64,
    /// Centre of the magnitude law, deg/s.
    size: f64,
    /// Half-width of the magnitude law, deg/s.
    spread: f64,
    /// Probability that a run's first spike is followed by a second.
    cont_first: f64,
    /// Probability that a later spike of a run is followed by another.
    cont_next: f64,
    /// The last spike was its run's first.
    first: bool,
    /// Samples up to and including the next run's start.
    left: u64,
    /// The sign of the current run, 0 outside a run.
    sign: f64,
    count: u64,
}

impl Spikes {
    /// Outliers as the model gives them; `white_sigma` is the per-sample sd of the white noise N.
    pub fn new(m: &Outliers, white_sigma: f64, rng: &mut SimRng) -> Self {
        let f = m.per_sample.min(1.0);
        let run_mean = m.run_mean.max(1.0);
        let cont_next = m.run_continue.clamp(0.0, 1.0);
        let cont_first = ((run_mean - 1.0) * (1.0 - cont_next)).min(1.0);
        // The start probability that makes `f` the share of spiked samples (`f` itself without runs).
        let p = if cont_first > 0.0 { f / (run_mean * (1.0 - f) + f) } else { f };
        let size = m.size_dps + m.size_sigma * white_sigma;
        let spread = m.spread_dps + m.spread_sigma * white_sigma;
        Spikes { p, size, spread, cont_first, cont_next, first: false, left: rng.gap(p), sign: 0.0, count: 0 }
    }

    /// The spike on this sample (usually 0), in deg/s.
    #[inline]
    pub fn next(&mut self, rng: &mut SimRng) -> f64 {
        if self.sign != 0.0 {
            // The sample after a spike of a run: the run goes on, or a gap to the next run starts here.
            let cont = if self.first { self.cont_first } else { self.cont_next };
            if rng.uniform() < cont {
                self.first = false;
                self.count += 1;
                return self.sign * self.magnitude(rng);
            }
            self.sign = 0.0;
            self.left = rng.gap(self.p);
        }
        self.left -= 1;
        if self.left != 0 {
            return 0.0;
        }
        self.count += 1;
        if self.cont_first > 0.0 {
            self.first = true;
            self.sign = rng.sign();
            self.sign * self.magnitude(rng)
        } else {
            self.left = rng.gap(self.p);
            rng.sign() * self.magnitude(rng)
        }
    }

    /// One spike's magnitude: the centre, or a uniform draw on centre +- spread.
    #[inline]
    fn magnitude(&self, rng: &mut SimRng) -> f64 {
        if self.spread == 0.0 {
            self.size
        } else {
            self.size + self.spread * (2.0 * rng.uniform() - 1.0)
        }
    }

    /// Outliers so far.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// The centre of the spike magnitudes, in deg/s.
    pub fn size_dps(&self) -> f64 {
        self.size
    }
}

/// A bistable bias (random telegraph): the two-state Markov chain that the continuous-time process with leaving
/// rates `l_low = 1 / dwell_low` and `l_high = 1 / dwell_high` is at the sampling instants. From a level, the next
/// sample is in the other with probability `p = l / (l_low + l_high) (1 - exp(-(l_low + l_high) tau0))` (`l`
/// that level's leaving rate), so the sampled autocovariance is exactly `var a^|k|`, `a = exp(-(l_low + l_high)
/// tau0)`: an AR(1)'s. The level at the start is drawn from the stationary law (high with probability
/// `l_low / (l_low + l_high)`), the time to each flip as a geometric gap.
#[derive(Clone, Debug, PartialEq)]
pub struct Telegraph {
    level: f64,
    other: f64,
    p_leave: f64,
    p_other: f64,
    left: u64,
    flips: u64,
}

impl Telegraph {
    /// The process of `m`, sampled every `tau0_s`.
    pub fn new(m: &BistableSim, tau0_s: f64, rng: &mut SimRng) -> Self {
        let (l_low, l_high) = (1.0 / m.dwell_low_s, 1.0 / m.dwell_high_s);
        let total = l_low + l_high;
        let p_high = l_low / total;
        let switch = -libm::expm1(-total * tau0_s);
        let (low, high) = (-m.step_dps * p_high, m.step_dps * (1.0 - p_high));
        let (p_up, p_down) = ((l_low / total * switch).min(1.0), (l_high / total * switch).min(1.0));
        let (level, other, p_leave, p_other) =
            if rng.uniform() < p_high { (high, low, p_down, p_up) } else { (low, high, p_up, p_down) };
        Telegraph { level, other, p_leave, p_other, left: rng.gap(p_leave), flips: 0 }
    }

    /// The level at this sample, in deg/s.
    #[inline]
    pub fn next(&mut self, rng: &mut SimRng) -> f64 {
        self.left -= 1;
        if self.left == 0 {
            core::mem::swap(&mut self.level, &mut self.other);
            core::mem::swap(&mut self.p_leave, &mut self.p_other);
            self.flips += 1;
            self.left = rng.gap(self.p_leave);
        }
        self.level
    }

    /// Flips so far.
    pub fn flips(&self) -> u64 {
        self.flips
    }
}

/// The warm-up: `size exp(-n tau0 / tau)` at sample n, by one multiply per sample; exactly zero once it falls
/// below 1e-200 of a deg/s (far below any rate, and before the multiply reaches subnormal numbers).
#[derive(Clone, Debug, PartialEq)]
pub struct WarmUp {
    value: f64,
    decay: f64,
}

impl WarmUp {
    /// The warm-up of `m`, sampled every `tau0_s`.
    pub fn new(m: &WarmUpSim, tau0_s: f64) -> Self {
        WarmUp { value: m.size_dps, decay: libm::exp(-tau0_s / m.tau_s) }
    }

    /// The added bias at this sample, in deg/s.
    #[inline]
    pub fn next_dps(&mut self) -> f64 {
        let v = self.value;
        self.value *= self.decay;
        if self.value.abs() < 1e-200 {
            self.value = 0.0;
        }
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The block form gives the values of sample-by-sample calls bit for bit, for none, one and two sinusoids,
    /// over blocks that start anywhere and cross the renormalisation at every 4096th sample.
    #[test]
    fn for_each_equals_next() {
        let list = [
            Sinusoid { amplitude_dps: 1.5, period_s: 3.7, phase_rad: 0.2 },
            Sinusoid { amplitude_dps: 0.3, period_s: 0.011, phase_rad: -1.0 },
        ];
        for len in 0..=2 {
            let mut blocks = Sinusoids::new(&list[..len], 1e-3);
            let mut scans = blocks.clone();
            let mut n = 0u64;
            for count in [1, 4094, 1, 1, 4095, 5000, 4096, 9000, 0, 3] {
                let mut got = [0.0f64; 9000];
                blocks.for_each(n, count, |k, v| got[k] = v);
                for g in &got[..count] {
                    assert_eq!(g.to_bits(), scans.next(n).to_bits(), "{len} sinusoid(s), sample {n}");
                    n += 1;
                }
            }
            assert_eq!(blocks, scans);
        }
    }

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

    /// A bistable bias takes only its two zero-mean levels, `-step p_high` and `step p_low`, and its first
    /// level follows the stationary law.
    #[test]
    fn telegraph_has_two_zero_mean_levels() {
        let m = BistableSim { step_dps: 0.4, dwell_low_s: 3.0, dwell_high_s: 1.0 };
        let (low, high) = (-0.4 * 0.25, 0.4 * 0.75);
        let mut starts_high = 0;
        for seed in 0..2000 {
            let mut rng = SimRng::new(seed);
            let mut t = Telegraph::new(&m, 0.1, &mut rng);
            let first = t.next(&mut rng);
            assert!(first == low || first == high, "{first}");
            starts_high += usize::from(first == high);
        }
        // Binomial(2000, 0.25): sd 19.4; 5 sigma.
        assert!((starts_high as f64 - 500.0).abs() < 97.0, "{starts_high}");
        let mut rng = SimRng::new(1);
        let mut t = Telegraph::new(&m, 0.1, &mut rng);
        let (mut sum, mut changes, mut last) = (0.0, 0u64, t.next(&mut rng));
        let flips_before = t.flips();
        for _ in 0..100_000 {
            let v = t.next(&mut rng);
            assert!(v == low || v == high);
            changes += u64::from(v != last);
            sum += v;
            last = v;
        }
        assert_eq!(changes, t.flips() - flips_before);
        assert!(sum.abs() / 1e5 < 0.02, "mean {}", sum / 1e5);
    }

    #[test]
    fn warm_up_is_the_exponential() {
        let mut w = WarmUp::new(&WarmUpSim { size_dps: -0.3, tau_s: 2.0 }, 0.01);
        for n in 0..100_000u32 {
            let want = -0.3 * (-f64::from(n) * 0.01 / 2.0).exp();
            let got = w.next_dps();
            assert!((got - want).abs() <= 1e-12 * want.abs() + 1e-200, "sample {n}: {got} vs {want}");
        }
        assert_eq!(w.next_dps(), 0.0);
    }

    #[test]
    fn event_counts_follow_the_rate() {
        let mut rng = SimRng::new(9);
        let mut spikes =
            Spikes::new(&Outliers { per_sample: 1e-3, size_dps: 5.0, ..Default::default() }, 1.0, &mut rng);
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

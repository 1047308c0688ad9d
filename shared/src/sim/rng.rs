//! The simulator's random source: a seeded xoshiro256++ stream with a ziggurat Gaussian.
//!
//! Everything random in [`crate::sim`] comes from one [`SimRng`] per channel, so a model and a seed fix every
//! sample bit for bit on every target. xoshiro256++ (`rand_xoshiro`) costs about a nanosecond per 64-bit word on
//! the host and needs only integer operations; the Gaussian is `rand_distr`'s 256-layer ziggurat, which takes one
//! word and one table look-up in about 99% of draws (the tail and wedge cases call `exp`/`ln` through `libm`).

use rand_distr::{Distribution, Geometric, StandardNormal};
use rand_xoshiro::rand_core::{Rng, SeedableRng};
use rand_xoshiro::{SplitMix64, Xoshiro256PlusPlus};

/// A deterministic random stream for one simulated channel.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SimRng(Xoshiro256PlusPlus);

impl SimRng {
    /// The stream for `seed` (seeded through SplitMix64, as `SeedableRng::seed_from_u64` does).
    pub fn new(seed: u64) -> Self {
        SimRng(Xoshiro256PlusPlus::seed_from_u64(seed))
    }

    /// The seed of sub-stream `index` of `seed`: distinct, well-mixed seeds for the channels of a bench.
    pub fn derive_seed(seed: u64, index: u64) -> u64 {
        let mut mix = SplitMix64::seed_from_u64(seed ^ index.wrapping_mul(0x9E37_79B9_7F4A_7C15));
        mix.next_u64()
    }

    /// A uniform 64-bit word.
    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        self.0.next_u64()
    }

    /// A standard normal deviate (mean 0, variance 1).
    #[inline]
    pub fn normal(&mut self) -> f64 {
        StandardNormal.sample(&mut self.0)
    }

    /// A uniform deviate in [0, 1), 53 bits.
    #[inline]
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Two independent uniform deviates with mean 0 and variance 1 (on (-sqrt 3, sqrt 3)), one from each half of
    /// a 64-bit word: the cheap innovations of the flicker bank, whose output is Gaussian by summation.
    #[inline]
    pub fn unit_uniform_pair(&mut self) -> (f64, f64) {
        const SCALE: f64 = 1.732_050_807_568_877_2 / 2_147_483_648.0; // sqrt(3) / 2^31
        let w = self.next_u64();
        let lo = (f64::from(w as u32 as i32) + 0.5) * SCALE;
        let hi = (f64::from((w >> 32) as u32 as i32) + 0.5) * SCALE;
        (lo, hi)
    }

    /// +1.0 or -1.0 with equal probability.
    #[inline]
    pub fn sign(&mut self) -> f64 {
        if self.next_u64() >> 63 == 0 {
            1.0
        } else {
            -1.0
        }
    }

    /// Samples up to and including the next event of a Bernoulli process with probability `p` per sample
    /// (a geometric gap, at least 1); `u64::MAX` when `p` is 0. Called once per event, not per sample.
    pub fn gap(&mut self, p: f64) -> u64 {
        match Geometric::new(p) {
            Ok(g) if p > 0.0 => g.sample(&mut self.0).saturating_add(1),
            _ => u64::MAX,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_stream_and_seeds_differ() {
        let mut a = SimRng::new(7);
        let mut b = SimRng::new(7);
        let mut c = SimRng::new(8);
        let xa: [u64; 4] = core::array::from_fn(|_| a.next_u64());
        let xb: [u64; 4] = core::array::from_fn(|_| b.next_u64());
        let xc: [u64; 4] = core::array::from_fn(|_| c.next_u64());
        assert_eq!(xa, xb);
        assert_ne!(xa, xc);
        assert_ne!(SimRng::derive_seed(1, 0), SimRng::derive_seed(1, 1));
    }

    #[test]
    fn normal_moments() {
        // Mean and variance of 10^6 draws: 5-sigma bounds (sd of the mean 1e-3, of the variance sqrt(2/n)).
        let mut r = SimRng::new(1);
        let n = 1_000_000;
        let (mut s1, mut s2, mut s4) = (0.0, 0.0, 0.0);
        for _ in 0..n {
            let x = r.normal();
            s1 += x;
            s2 += x * x;
            s4 += x * x * x * x;
        }
        let n = n as f64;
        assert!((s1 / n).abs() < 5e-3);
        assert!((s2 / n - 1.0).abs() < 5.0 * (2.0 / n).sqrt());
        assert!((s4 / n - 3.0).abs() < 5.0 * (96.0 / n).sqrt(), "kurtosis {}", s4 / n);
    }

    #[test]
    fn unit_uniform_pair_moments() {
        let mut r = SimRng::new(3);
        let n = 500_000;
        let (mut s1, mut s2, mut s12) = (0.0, 0.0, 0.0);
        for _ in 0..n {
            let (a, b) = r.unit_uniform_pair();
            assert!(a.abs() < 3f64.sqrt() && b.abs() < 3f64.sqrt());
            s1 += a + b;
            s2 += a * a + b * b;
            s12 += a * b;
        }
        let n = 2.0 * n as f64;
        // sd of the mean 1/sqrt(n); of the mean square sqrt(0.8/n) (uniform kurtosis 1.8); 5 sigma each.
        assert!((s1 / n).abs() < 5.0 / n.sqrt());
        assert!((s2 / n - 1.0).abs() < 5.0 * (0.8 / n).sqrt());
        assert!((s12 / (n / 2.0)).abs() < 5.0 / (n / 2.0).sqrt());
        assert!((3f64.sqrt() - 1.732_050_807_568_877_2).abs() < 1e-15);
    }

    #[test]
    fn uniform_range_and_mean() {
        let mut r = SimRng::new(2);
        let mut s = 0.0;
        for _ in 0..100_000 {
            let u = r.uniform();
            assert!((0.0..1.0).contains(&u));
            s += u;
        }
        assert!((s / 1e5 - 0.5).abs() < 5.0 * (1.0f64 / 12.0 / 1e5).sqrt());
    }

    #[test]
    fn gap_mean_is_one_over_p() {
        let mut r = SimRng::new(3);
        let p = 0.01;
        let n = 20_000;
        let total: u64 = (0..n).map(|_| r.gap(p)).sum();
        let mean = total as f64 / n as f64;
        // Geometric on {1, 2, ..}: mean 1/p = 100, sd sqrt(1-p)/p = 99.5; 5 sigma of the mean is 3.5.
        assert!((mean - 100.0).abs() < 3.6, "{mean}");
        assert_eq!(r.gap(0.0), u64::MAX);
        assert!(r.gap(1.0) == 1);
    }
}

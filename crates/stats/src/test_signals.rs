//! Deterministic test signals for the unit tests of every host crate: one 64-bit LCG (Knuth's MMIX constants) and what
//! the tests draw from it, so every module's fixtures come from the same generator.

/// A 64-bit linear congruential generator.
pub struct Lcg(u64);

impl Lcg {
    /// A generator started at `seed`.
    pub fn new(seed: u64) -> Self {
        Lcg(seed)
    }

    /// The next state.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        self.0
    }

    /// A uniform deviate in [0, 1) from the top 53 bits.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A near-Gaussian deviate of unit variance: the sum of 12 uniforms, less 6.
    pub fn gauss12(&mut self) -> f64 {
        let mut acc = 0.0;
        for _ in 0..12 {
            acc += self.uniform();
        }
        acc - 6.0
    }
}

/// `n` near-Gaussian white samples of unit variance ([`Lcg::gauss12`]) from `seed`.
pub fn white(n: usize, seed: u64) -> Vec<f64> {
    let mut g = Lcg::new(seed);
    (0..n).map(|_| g.gauss12()).collect()
}

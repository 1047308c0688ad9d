//! Flicker (1/f) rate noise from a bank of Gauss-Markov processes with octave-spaced correlation times.
//!
//! Process j has correlation time `T_j = 2^j` samples (j = 0 .. [`FLICKER_PROCESSES`]) and the same
//! stationary variance `s^2 = B^2 ln 2 / pi`. A log-uniform mixture of Lorentzians with density `1 / ln 2` per
//! octave has the spectrum `S_y(f) = s^2 / (f ln 2)`, so `h_-1 = s^2 / ln 2` and the Allan floor is
//! `2 ln 2 h_-1 = 2 s^2 = (2 ln 2 / pi) B^2`: sigma = 0.6643 B. The processes faster than one sample that the
//! bank leaves out are stood in for by the fastest process itself: its variance is [`FIRST_WEIGHT`] `s^2`
//! instead of `s^2` (a least-squares fit of the design to the floor over m = 1 .. 2^33). A white completion
//! would match the missing variance at long tau only; it overshot the floor by 4x at one sample when the bank
//! started at four samples, which a fit took for angle random walk and a simulation of that fit added twice.
//!
//! Cost: the [`FAST`] processes with `T <= 16` samples update every sample; the process with `T = 2^j`, j > 4,
//! updates every `2^(j-4)` samples (`T / D = 16`, held in between), so the slow part averages one update per
//! sample: six multiply-adds and about 3.3 random words per sample, whatever the number of decades. The
//! innovations are uniform deviates of unit variance, two per 64-bit word, not Gaussians: the Allan variance
//! depends only on second moments, so it is unchanged, and each process sums many innovations while the bank
//! sums 44 processes, so the flicker value is near Gaussian (the fastest processes sum few innovations; their
//! share of the variance is a few percent).
//!
//! Design accuracy ([`FlickerBank::design_avar`], every process treated as updated each sample): within 1.8%
//! of the floor at every tau from tau0 to 2^33 tau0, 0.7% from 8 tau0, 0.25% from 32 tau0 up to 2^33 tau0; it
//! falls off above, where the slowest processes stop (-0.13% at 2^35, -26% at 2^43). Holding the slow processes
//! adds a small ripple: the end-to-end tests bound the whole bank within 1% of the floor from 32 tau0 to
//! 2^26 tau0 through the ADC, and within 5% from tau0.

use super::rng::SimRng;

/// Number of Gauss-Markov processes in the bank (correlation times 1 .. 2^43 samples).
pub const FLICKER_PROCESSES: usize = 44;
/// log2 of T / D for the held processes.
const HOLD_RATIO_LOG2: u32 = 4;
/// Processes updated every sample (T = 1, 2, 4, 8, 16 samples).
pub const FAST: usize = HOLD_RATIO_LOG2 as usize + 1;
const SLOW: usize = FLICKER_PROCESSES - FAST;
/// Variance of the fastest process (T = 1 sample), in units of the per-process variance: it also stands in for
/// the processes faster than a sample.
pub const FIRST_WEIGHT: f64 = 1.84;

/// `sqrt(2 ln 2 / pi)`: the Allan deviation floor of flicker noise per unit B.
pub const FLICKER_FLOOR: f64 = 0.664_282_470_267_960_1;

/// The flicker bank of one channel (constant memory: about 100 `f64`s).
#[derive(Clone, Debug, PartialEq)]
pub struct FlickerBank {
    pub(crate) fast: FastProcesses,
    pub(crate) slow: SlowProcesses,
    var: f64,
}

/// The processes updated every sample. Small and `Copy`, so that a block loop can hold them in registers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct FastProcesses {
    x: [f64; FAST],
    a: [f64; FAST],
    b: [f64; FAST],
}

/// The held processes (one updates per sample, at an index that varies) and their running sum.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct SlowProcesses {
    x: [f64; SLOW],
    a: f64,
    b: f64,
    sum: f64,
}

impl FlickerBank {
    /// A bank for flicker coefficient `b_dps` (deg/s), started stationary.
    pub fn new(b_dps: f64, rng: &mut SimRng) -> Self {
        let var = b_dps * b_dps * core::f64::consts::LN_2 / core::f64::consts::PI;
        let s = libm::sqrt(var);
        let mut fast = FastProcesses { x: [0.0; FAST], a: [0.0; FAST], b: [0.0; FAST] };
        for j in 0..FAST {
            let a = libm::exp(-1.0 / (1u64 << j) as f64);
            let sd = if j == 0 { s * libm::sqrt(FIRST_WEIGHT) } else { s };
            fast.a[j] = a;
            fast.b[j] = sd * libm::sqrt(1.0 - a * a);
            fast.x[j] = sd * rng.normal();
        }
        let slow_a = libm::exp(-1.0 / (1u64 << HOLD_RATIO_LOG2) as f64);
        let mut x = [0.0; SLOW];
        for v in &mut x {
            *v = s * rng.normal();
        }
        let slow = SlowProcesses { x, a: slow_a, b: s * libm::sqrt(1.0 - slow_a * slow_a), sum: x.iter().sum() };
        FlickerBank { fast, slow, var }
    }

    /// The per-process variance `s^2 = B^2 ln 2 / pi`, in (deg/s)^2.
    pub fn process_var(&self) -> f64 {
        self.var
    }

    /// The flicker value at sample `n` (n counts from 0, one call per sample), in deg/s.
    #[inline]
    pub fn next(&mut self, n: u64, rng: &mut SimRng) -> f64 {
        step(&mut self.fast, &mut self.slow, n, rng)
    }

    /// The bank's Allan variance at `m` samples, in (deg/s)^2, as designed: the exact discrete AR(1) variance of
    /// every process (as if each were updated every sample). Used to show the design flat; the simulation
    /// itself is checked against the closed form in the end-to-end tests.
    pub fn design_avar(b_dps: f64, m: f64) -> f64 {
        let var = b_dps * b_dps * core::f64::consts::LN_2 / core::f64::consts::PI;
        let mut total = (FIRST_WEIGHT - 1.0) * ar1_avar(var, 1.0, m);
        for j in 0..FLICKER_PROCESSES as u32 {
            total += ar1_avar(var, (1u64 << j) as f64, m);
        }
        total
    }
}

/// One sample of the bank: the fast processes updated, and the held ones whose hold ends here; their sum
/// returned (deg/s). Slow process i has hold 2^(i+1): it updates when n is a multiple of that.
#[inline(always)]
pub(crate) fn step(fast: &mut FastProcesses, slow: &mut SlowProcesses, n: u64, rng: &mut SimRng) -> f64 {
    let (u0, u1) = rng.unit_uniform_pair();
    let (u2, u3) = rng.unit_uniform_pair();
    let (u4, u5) = rng.unit_uniform_pair();
    let u = [u0, u1, u2, u3, u4];
    let mut sum = 0.0;
    for j in 0..FAST {
        fast.x[j] = fast.a[j] * fast.x[j] + fast.b[j] * u[j];
        sum += fast.x[j];
    }
    if n & 1 == 0 {
        let top = (n.trailing_zeros() as usize).min(SLOW);
        let (a, b) = (slow.a, slow.b);
        let x0 = slow.x[0];
        slow.x[0] = a * x0 + b * u5;
        let mut delta = slow.x[0] - x0;
        let mut i = 1;
        while i < top {
            let (v0, v1) = rng.unit_uniform_pair();
            for (k, v) in [(i, v0), (i + 1, v1)] {
                if k < top {
                    let old = slow.x[k];
                    let new = a * old + b * v;
                    delta += new - old;
                    slow.x[k] = new;
                }
            }
            i += 2;
        }
        if top >= 12 {
            // Re-sum now and then so rounding in the running sum cannot build up.
            slow.sum = slow.x.iter().sum();
        } else {
            slow.sum += delta;
        }
    }
    sum + slow.sum
}

/// The exact Allan variance at `m` samples of a stationary AR(1) sequence with variance `var` and
/// `a = exp(-1 / t_samples)`: `var [m b (2 - b) - (1 - b)(2u + u^2)] / (b m)^2`, `b = 1 - a`, `u = 1 - a^m`,
/// evaluated with `expm1` so that it stays accurate when `t_samples` is huge.
pub fn ar1_avar(var: f64, t_samples: f64, m: f64) -> f64 {
    let b = -libm::expm1(-1.0 / t_samples);
    let u = -libm::expm1(-m / t_samples);
    var * (m * b * (2.0 - b) - (1.0 - b) * (2.0 * u + u * u)) / (b * b * m * m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ar1_avar_matches_direct_sum() {
        // Direct: AVAR = (4 G(m) - G(2m)) / (2 m^2), G(n) = sum_{i,j<n} a^|i-j|.
        for (t, m) in [(3.0, 5usize), (50.0, 7), (0.7, 1), (1000.0, 64)] {
            let a: f64 = (-1.0f64 / t).exp();
            let g = |n: usize| -> f64 {
                let mut s = 0.0;
                for i in 0..n {
                    for j in 0..n {
                        s += a.powi((i as i32 - j as i32).abs());
                    }
                }
                s
            };
            let direct = (4.0 * g(m) - g(2 * m)) / (2.0 * (m * m) as f64);
            let closed = ar1_avar(1.0, t, m as f64);
            assert!((closed / direct - 1.0).abs() < 1e-9, "t {t} m {m}: {closed} vs {direct}");
        }
    }

    #[test]
    fn design_is_flat_over_ten_decades() {
        let floor = FLICKER_FLOOR * FLICKER_FLOOR;
        for k in 0..=35 {
            let r = FlickerBank::design_avar(1.0, (1u64 << k) as f64) / floor - 1.0;
            let bound = match k {
                0..=2 => 0.018,
                3..=4 => 0.007,
                _ => 0.0025,
            };
            assert!(r.abs() < bound, "2^{k}: {r}");
        }
    }

    #[test]
    fn floor_constant() {
        assert!((FLICKER_FLOOR - (2.0 * core::f64::consts::LN_2 / core::f64::consts::PI).sqrt()).abs() < 1e-15);
    }
}

//! The basic noise processes: rate random walk, ramp, first-order Gauss-Markov and its decimated ("held") form,
//! and the second-order Gauss-Markov process of a resonance.
//!
//! Each process is a few `f64`s of state and does a multiply-add or two per update; coefficients that need `exp`
//! or `sqrt` are computed once in `new`. White rate noise is a single scaled Gaussian and lives in the gyro itself.

use super::rng::SimRng;

/// Rate random walk: `x_n = x_{n-1} + K sqrt(tau0) w_n` (deg/s), starting at 0.
///
/// Its exact discrete Allan variance is `K^2 tau0 (2m^2 + 1) / (6m)` = `K^2 tau / 3 + K^2 tau0^2 / (6 tau)`.
#[derive(Clone, Debug, PartialEq)]
pub struct RandomWalk {
    x: f64,
    step: f64,
}

impl RandomWalk {
    /// K in deg/s/sqrt(s) at a sample interval of `tau0_s`.
    pub fn new(k_dps_per_rt_s: f64, tau0_s: f64) -> Self {
        RandomWalk { x: 0.0, step: k_dps_per_rt_s * libm::sqrt(tau0_s) }
    }

    /// The next value, in deg/s.
    #[inline]
    pub fn next(&mut self, rng: &mut SimRng) -> f64 {
        self.x += self.step * rng.normal();
        self.x
    }
}

/// A first-order Gauss-Markov (AR(1)) process updated every sample, started stationary:
/// `x_n = a x_{n-1} + sigma sqrt(1 - a^2) w_n`, `a = exp(-tau0 / T)`.
///
/// Its autocovariance is `sigma^2 a^|k|` exactly, so its Allan variance at `m` samples is the discrete form
/// `sigma^2 [m (1+a)/(1-a) - a (2u + u^2)/(1-a)^2] / m^2` with `u = 1 - a^m`, which tends to the continuous
/// `(q_c T^2 / tau)[1 - T/(2 tau)(3 - 4 e^{-tau/T} + e^{-2 tau/T})]`, `q_c = 2 sigma^2 / T`, when T >> tau0.
#[derive(Clone, Debug, PartialEq)]
pub struct GaussMarkov {
    x: f64,
    a: f64,
    b: f64,
}

impl GaussMarkov {
    /// Stationary standard deviation `sigma` and correlation time `tau_s`, sampled every `tau0_s`.
    pub fn new(sigma: f64, tau_s: f64, tau0_s: f64, rng: &mut SimRng) -> Self {
        let a = libm::exp(-tau0_s / tau_s);
        GaussMarkov { x: sigma * rng.normal(), a, b: sigma * libm::sqrt(1.0 - a * a) }
    }

    /// The next value.
    #[inline]
    pub fn next(&mut self, rng: &mut SimRng) -> f64 {
        self.x = self.a * self.x + self.b * rng.normal();
        self.x
    }

    /// The current value.
    #[inline]
    pub fn value(&self) -> f64 {
        self.x
    }
}

/// A first-order low-pass `y_n = a y_{n-1} + (1 - a) x_n`, `a = exp(-2 pi f3dB tau0)`, DC gain 1.
///
/// Driven by white noise of variance `s^2` it is exactly the AR(1) process above with
/// `sigma^2 = s^2 (1 - a)/(1 + a)` and `T = 1 / (2 pi f3dB)`. The first input sets the state (no start-up ramp).
#[derive(Clone, Debug, PartialEq)]
pub struct LowPass {
    y: f64,
    a: f64,
    started: bool,
}

impl LowPass {
    /// A low-pass with its -3 dB corner at `f3db_hz`, sampled at `rate_hz`.
    pub fn new(f3db_hz: f64, rate_hz: f64) -> Self {
        LowPass { y: 0.0, a: libm::exp(-2.0 * core::f64::consts::PI * f3db_hz / rate_hz), started: false }
    }

    /// The pole `a`.
    pub fn pole(&self) -> f64 {
        self.a
    }

    /// Filter one sample.
    #[inline]
    pub fn next(&mut self, x: f64) -> f64 {
        if !self.started {
            self.started = true;
            self.y = x;
        }
        self.y = x + self.a * (self.y - x);
        self.y
    }
}

/// A resonance: the second-order Gauss-Markov process (a damped oscillator driven by white noise) sampled as the
/// AR(2) process `x_n = a1 x_{n-1} + a2 x_{n-2} + b w_n` whose poles are `r e^{+-i theta}`,
/// `r = exp(-zeta w0 tau0)`, `theta = w0 tau0 sqrt(1 - zeta^2)`, `w0 = 2 pi f0`, `zeta = 1 / (2 Q)`; so
/// `a1 = 2 r cos theta`, `a2 = -r^2`, and `b` makes the stationary variance `sigma^2`:
/// `gamma_0 = b^2 (1 - a2) / ((1 + a2) ((1 - a2)^2 - a1^2))`. The two values before the first sample are drawn
/// from the stationary law (variance `sigma^2`, lag-one correlation `a1 / (1 - a2)`), so the process is stationary
/// from sample 0.
///
/// Its autocovariance is `sigma^2 r^k (cos k theta + c sin k theta)`, `c = (1 - r^2) / (1 + r^2) cot theta`, and
/// its one-sided spectrum `2 tau0 b^2 / |1 - a1 e^{-i w} - a2 e^{-2 i w}|^2`, `w = 2 pi f tau0`: a bump at about
/// `f0` of half-power width about `f0 / Q`.
#[derive(Clone, Debug, PartialEq)]
pub struct Resonance {
    x1: f64,
    x2: f64,
    a1: f64,
    a2: f64,
    b: f64,
}

impl Resonance {
    /// The AR(2) coefficients `(a1, a2)` and the innovation sd per unit stationary sd of a resonance at `freq_hz`
    /// with quality factor `q` (above 0.5), sampled every `tau0_s`.
    pub fn coefficients(freq_hz: f64, q: f64, tau0_s: f64) -> (f64, f64, f64) {
        let zeta = 0.5 / q;
        let w0 = 2.0 * core::f64::consts::PI * freq_hz * tau0_s;
        let r = libm::exp(-zeta * w0);
        let theta = w0 * libm::sqrt(1.0 - zeta * zeta);
        let (a1, a2) = (2.0 * r * libm::cos(theta), -r * r);
        let b = libm::sqrt((1.0 + a2) * ((1.0 - a2) * (1.0 - a2) - a1 * a1) / (1.0 - a2));
        (a1, a2, b)
    }

    /// Stationary standard deviation `sigma`, centre `freq_hz`, quality factor `q`, sampled every `tau0_s`.
    pub fn new(sigma: f64, freq_hz: f64, q: f64, tau0_s: f64, rng: &mut SimRng) -> Self {
        let (a1, a2, b) = Self::coefficients(freq_hz, q, tau0_s);
        let rho = a1 / (1.0 - a2);
        let x2 = sigma * rng.normal();
        let x1 = rho * x2 + sigma * libm::sqrt(1.0 - rho * rho) * rng.normal();
        Resonance { x1, x2, a1, a2, b: sigma * b }
    }

    /// The next value.
    #[inline]
    pub fn next(&mut self, rng: &mut SimRng) -> f64 {
        let x = self.a1 * self.x1 + self.a2 * self.x2 + self.b * rng.normal();
        self.x2 = self.x1;
        self.x1 = x;
        x
    }
}

/// Power-of-two hold for a Gauss-Markov process of correlation time `tau_samples`: the largest `D <= T / 16`.
pub fn hold_log2(tau_samples: f64) -> u32 {
    let r = tau_samples / 16.0;
    if r < 2.0 {
        0
    } else {
        (libm::log2(r) as u32).min(62)
    }
}

/// A Gauss-Markov process updated only every `2^hold_log2` samples and held in between (zero-order hold):
/// the exact AR(1) at the update instants, so the stationary variance stays `sigma^2`. Slow processes cost
/// one update per hold interval instead of one per sample.
#[derive(Clone, Debug, PartialEq)]
pub struct HeldGaussMarkov {
    x: f64,
    a: f64,
    b: f64,
    mask: u64,
}

impl HeldGaussMarkov {
    /// Stationary `sigma`, correlation time `tau_samples` (in samples), updated every `2^hold_log2` samples.
    pub fn new(sigma: f64, tau_samples: f64, hold_log2: u32, rng: &mut SimRng) -> Self {
        let d = (1u64 << hold_log2) as f64;
        let a = libm::exp(-d / tau_samples);
        HeldGaussMarkov {
            x: sigma * rng.normal(),
            a,
            b: sigma * libm::sqrt(1.0 - a * a),
            mask: (1u64 << hold_log2) - 1,
        }
    }

    /// The value at sample `n` (updates when `n` is a multiple of the hold).
    #[inline]
    pub fn next(&mut self, n: u64, rng: &mut SimRng) -> f64 {
        if n & self.mask == 0 {
            self.x = self.a * self.x + self.b * rng.normal();
        }
        self.x
    }

    /// [`HeldGaussMarkov::next`] with the update out of line: for loops where the hold is long and the update
    /// (a Gaussian draw) would only crowd the registers.
    #[inline(always)]
    pub(crate) fn next_held(&mut self, n: u64, rng: &mut SimRng) -> f64 {
        if n & self.mask == 0 {
            self.update(rng);
        }
        self.x
    }

    #[inline(never)]
    fn update(&mut self, rng: &mut SimRng) {
        self.x = self.a * self.x + self.b * rng.normal();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_markov_lag_one_correlation() {
        let mut rng = SimRng::new(11);
        let mut gm = GaussMarkov::new(2.0, 10.0, 1.0, &mut rng);
        let n = 400_000;
        let (mut s2, mut s11) = (0.0, 0.0);
        let mut prev = gm.value();
        for _ in 0..n {
            let x = gm.next(&mut rng);
            s2 += x * x;
            s11 += x * prev;
            prev = x;
        }
        let var = s2 / n as f64;
        let rho = s11 / s2;
        // Effective sample size n (1-a)/(1+a) ~ 19000: 5 sigma of the variance is about 5%.
        assert!((var / 4.0 - 1.0).abs() < 0.05, "{var}");
        assert!((rho - (-0.1f64).exp()).abs() < 0.01, "{rho}");
    }

    /// The AR(2) recursion against the resonance's closed forms, written from r and theta rather than from the
    /// coefficients: lag-k autocorrelation `r^k (cos k theta + c sin k theta)` and stationary variance sigma^2.
    #[test]
    fn resonance_autocorrelation_is_the_damped_cosine() {
        let (sigma, f0, q) = (2.0, 0.1, 5.0); // 10 samples per period
        let mut rng = SimRng::new(12);
        let mut res = Resonance::new(sigma, f0, q, 1.0, &mut rng);
        let n = 1_000_000;
        const LAGS: usize = 8;
        let mut hist = [0.0f64; LAGS];
        let mut acc = [0.0f64; LAGS];
        let mut s2 = 0.0;
        for i in 0..n {
            let x = res.next(&mut rng);
            s2 += x * x;
            for k in 1..LAGS {
                if i >= k {
                    acc[k] += x * hist[(i - k) % LAGS];
                }
            }
            hist[i % LAGS] = x;
        }
        let var = s2 / n as f64;
        let zeta = 0.5 / q;
        let w0 = 2.0 * core::f64::consts::PI * f0;
        let r = (-zeta * w0).exp();
        let theta = w0 * (1.0 - zeta * zeta).sqrt();
        let c = (1.0 - r * r) / (1.0 + r * r) / theta.tan();
        // Correlation time about Q / (pi f0) = 16 samples: some 30000 independent stretches; 5% on the variance
        // and 0.02 on each correlation are beyond 5 sigma.
        assert!((var / (sigma * sigma) - 1.0).abs() < 0.05, "{var}");
        for (k, a) in acc.iter().enumerate().skip(1) {
            let want = r.powi(k as i32) * ((k as f64 * theta).cos() + c * (k as f64 * theta).sin());
            let got = a / (n - k) as f64 / var;
            assert!((got - want).abs() < 0.02, "lag {k}: {got} vs {want}");
        }
    }

    #[test]
    fn low_pass_dc_gain_and_step() {
        let mut lp = LowPass::new(10.0, 1000.0);
        assert_eq!(lp.next(3.0), 3.0);
        for _ in 0..1000 {
            lp.next(3.0);
        }
        assert!((lp.next(3.0) - 3.0).abs() < 1e-12);
        // A step from 3 to 4: after one time constant (1/(2 pi 10) s = 15.9 samples) 1 - 1/e of the way.
        let a = lp.pole();
        let mut y = 0.0;
        for _ in 0..16 {
            y = lp.next(4.0);
        }
        assert!((y - (4.0 - a.powi(16))).abs() < 1e-12);
    }

    #[test]
    fn held_process_changes_only_on_hold_edges() {
        let mut rng = SimRng::new(5);
        let mut h = HeldGaussMarkov::new(1.0, 1000.0, 3, &mut rng);
        let mut last = h.next(0, &mut rng);
        for n in 1..64u64 {
            let x = h.next(n, &mut rng);
            if n % 8 != 0 {
                assert_eq!(x, last);
            }
            last = x;
        }
        assert_eq!(hold_log2(16.0), 0);
        assert_eq!(hold_log2(64.0), 2);
    }
}

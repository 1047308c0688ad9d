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

/// A resonance: the second-order Gauss-Markov process (a damped oscillator driven by white noise) read at each
/// sample. Its autocovariance at lag `k` samples is the oscillator's,
/// `sigma^2 r^k (cos k theta + c sin k theta)`, `r = exp(-zeta w0 tau0)`, `theta = w0 tau0 sqrt(1 - zeta^2)`,
/// `c = zeta / sqrt(1 - zeta^2)`, `w0 = 2 pi f0`, `zeta = 1 / (2 Q)`. A sampled continuous second-order process is
/// the ARMA(2,1) process `x_n = a1 x_{n-1} + a2 x_{n-2} + s (w_n + m w_{n-1})` whose poles `r e^{+-i theta}` are the
/// oscillator's (`a1 = 2 r cos theta`, `a2 = -r^2`) and whose zero `-m` carries the rest: the AR(2) alone has
/// `c = (1 - r^2) / (1 + r^2) cot theta`, close to the oscillator's only for a centre far below the rate
/// ([`ResonanceCoefficients::of`] derives `m` and `s`). The two values and the innovation before the first sample
/// are drawn from the stationary law, so the process is stationary from sample 0.
///
/// Its one-sided spectrum is `2 tau0 s^2 |1 + m e^{-iw}|^2 / |1 - a1 e^{-iw} - a2 e^{-2iw}|^2`, `w = 2 pi f tau0`:
/// a bump at about `f0` of half-power width about `f0 / Q`.
#[derive(Clone, Debug, PartialEq)]
pub struct Resonance {
    x1: f64,
    x2: f64,
    /// The last innovation, `s w_{n-1}`.
    e1: f64,
    a1: f64,
    a2: f64,
    ma: f64,
    /// The innovation sd, deg/s.
    s: f64,
}

/// The ARMA(2,1) form of a unit-variance resonance sampled every `tau0`:
/// `x_n = a1 x_{n-1} + a2 x_{n-2} + s (w_n + ma w_{n-1})`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ResonanceCoefficients {
    /// `2 r cos theta`.
    pub a1: f64,
    /// `-r^2`.
    pub a2: f64,
    /// The moving-average coefficient `m`, in (0, 1) (the zero inside the unit circle).
    pub ma: f64,
    /// The innovation sd per unit stationary sd.
    pub s: f64,
    /// The lag-one autocorrelation, `r (cos theta + c sin theta)`.
    pub rho1: f64,
}

/// Below this `w0 tau0` the sampled oscillator's MA part is taken at its limit, where the exact form loses its
/// digits to cancellation (`1e-16 / (w0 tau0)^2` relative); the limit's own error is of order `w0 tau0`.
const DENSE_SAMPLING_W: f64 = 1e-3;

impl ResonanceCoefficients {
    /// The coefficients of a resonance at `freq_hz` with quality factor `q` (above 0.5), sampled every `tau0_s`.
    ///
    /// With `phi(B) = 1 - a1 B - a2 B^2`, the filtered series `phi(B) x` is an MA(1) whose lag-0 and lag-1
    /// autocovariances follow from the oscillator's: `h1 = rho1 (1 + r^2) - a1`, `h0 = 1 - a1 rho1 + r^2 rho2`,
    /// `g1 = h1`, `g0 = h0 - a1 h1`; then `m / (1 + m^2) = g1 / g0` (the invertible root) and `s^2 = g0 / (1 + m^2)`.
    /// Far below the rate the sampled oscillator is a sampled double integral of white noise, whose second
    /// differences have lag-one correlation 1/4: `m = 2 - sqrt 3` and `g0 = (8 / 3) zeta (w0 tau0)^3`.
    pub fn of(freq_hz: f64, q: f64, tau0_s: f64) -> Self {
        let zeta = 0.5 / q;
        let w0 = 2.0 * core::f64::consts::PI * freq_hz * tau0_s;
        let r = libm::exp(-zeta * w0);
        let root = libm::sqrt(1.0 - zeta * zeta);
        let theta = w0 * root;
        let c = zeta / root;
        let rho = |k: f64| libm::pow(r, k) * (libm::cos(k * theta) + c * libm::sin(k * theta));
        let (a1, a2) = (2.0 * r * libm::cos(theta), -r * r);
        let rho1 = rho(1.0);
        let (ma, s2) = if w0 < DENSE_SAMPLING_W {
            let m = 2.0 - libm::sqrt(3.0);
            (m, 8.0 / 3.0 * zeta * w0 * w0 * w0 / (1.0 + m * m))
        } else {
            let h1 = rho1 * (1.0 + r * r) - a1;
            let h0 = 1.0 - a1 * rho1 + r * r * rho(2.0);
            let (g0, g1) = (h0 - a1 * h1, h1);
            let ratio = (g1 / g0).clamp(-0.5, 0.5);
            let m =
                if ratio.abs() < 1e-12 { ratio } else { (1.0 - libm::sqrt(1.0 - 4.0 * ratio * ratio)) / (2.0 * ratio) };
            (m, g0 / (1.0 + m * m))
        };
        ResonanceCoefficients { a1, a2, ma, s: libm::sqrt(s2.max(0.0)), rho1 }
    }
}

impl Resonance {
    /// Stationary standard deviation `sigma`, centre `freq_hz`, quality factor `q`, sampled every `tau0_s`.
    pub fn new(sigma: f64, freq_hz: f64, q: f64, tau0_s: f64, rng: &mut SimRng) -> Self {
        let c = ResonanceCoefficients::of(freq_hz, q, tau0_s);
        // (x_{-2}, x_{-1}, e_{-1}) from their joint law: unit variances, lag-one correlation rho1, the innovation
        // of variance s^2 correlated only with the value it entered (covariance s^2).
        let rho = c.rho1;
        let tail = libm::sqrt((1.0 - rho * rho).max(0.0));
        let (n1, n2, n3) = (rng.normal(), rng.normal(), rng.normal());
        let s2 = c.s * c.s;
        let beta = if tail > 0.0 { s2 / tail } else { 0.0 };
        let delta = libm::sqrt((s2 - beta * beta).max(0.0));
        let x2 = sigma * n1;
        let x1 = sigma * (rho * n1 + tail * n2);
        let e1 = sigma * (beta * n2 + delta * n3);
        Resonance { x1, x2, e1, a1: c.a1, a2: c.a2, ma: c.ma, s: sigma * c.s }
    }

    /// The next value.
    #[inline]
    pub fn next(&mut self, rng: &mut SimRng) -> f64 {
        let e = self.s * rng.normal();
        let x = self.a1 * self.x1 + self.a2 * self.x2 + e + self.ma * self.e1;
        self.x2 = self.x1;
        self.x1 = x;
        self.e1 = e;
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

    /// The oscillator's lag-k autocorrelation `r^k (cos k theta + c sin k theta)`, `c = zeta / sqrt(1 - zeta^2)`,
    /// written from the continuous process's `e^(-zeta w0 t) (cos wd t + zeta / sqrt(1 - zeta^2) sin wd t)`.
    fn oscillator_rho(f0_rel: f64, q: f64, k: usize) -> f64 {
        let zeta = 0.5 / q;
        let w0 = 2.0 * core::f64::consts::PI * f0_rel;
        let wd = w0 * (1.0 - zeta * zeta).sqrt();
        let t = k as f64;
        (-zeta * w0 * t).exp() * ((wd * t).cos() + zeta / (1.0 - zeta * zeta).sqrt() * (wd * t).sin())
    }

    /// The ARMA(2,1) coefficients give the oscillator's autocovariance exactly: summed from the recursion's impulse
    /// response `psi`, `s^2 sum_j psi_j psi_{j+k}` is the oscillator's correlation within 1e-6 at every lag (the
    /// exact form keeps 7 digits at its densest sampling), from a centre far below the rate to near Nyquist with a
    /// low Q, where the AR(2) alone is off by up to 0.2; and the dense-sampling limit joins the exact form where it
    /// takes over.
    #[test]
    fn resonance_coefficients_give_the_oscillator_autocovariance() {
        for (f0, q) in [(0.0002, 3.0), (0.01, 30.0), (0.05, 0.6), (0.1, 5.0), (0.22, 3.4), (0.3, 1.5), (0.45, 10.0)] {
            let c = ResonanceCoefficients::of(f0, q, 1.0);
            let len = 200_000;
            let mut psi = vec![0.0f64; len];
            for j in 0..len {
                let drive = if j == 0 {
                    1.0
                } else if j == 1 {
                    c.ma
                } else {
                    0.0
                };
                let p1 = if j >= 1 { psi[j - 1] } else { 0.0 };
                let p2 = if j >= 2 { psi[j - 2] } else { 0.0 };
                psi[j] = c.a1 * p1 + c.a2 * p2 + drive;
            }
            for k in 0..20 {
                let got: f64 = c.s * c.s * (0..len - k).map(|j| psi[j] * psi[j + k]).sum::<f64>();
                let want = oscillator_rho(f0, q, k);
                assert!((got - want).abs() < 1e-6, "f0 {f0} Q {q} lag {k}: {got} vs {want}");
            }
        }
        let w = DENSE_SAMPLING_W / (2.0 * core::f64::consts::PI);
        let (below, above) =
            (ResonanceCoefficients::of(w * 0.999_999, 4.0, 1.0), ResonanceCoefficients::of(w, 4.0, 1.0));
        assert!(
            (below.ma / above.ma - 1.0).abs() < 1e-3 && (below.s / above.s - 1.0).abs() < 1e-3,
            "{below:?} {above:?}"
        );
    }

    /// The recursion as it runs, from its stationary start, against the oscillator's closed forms: lag-k
    /// autocorrelation and stationary variance sigma^2, and the first values already at the stationary law.
    #[test]
    fn resonance_autocorrelation_is_the_damped_cosine() {
        for (sigma, f0, q) in [(2.0, 0.1, 5.0), (0.5, 0.3, 1.5)] {
            let mut rng = SimRng::new(12);
            let n = 1_000_000;
            const LAGS: usize = 8;
            let mut hist = [0.0f64; LAGS];
            let mut acc = [0.0f64; LAGS];
            let mut s2 = 0.0;
            let mut res = Resonance::new(sigma, f0, q, 1.0, &mut rng);
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
            // Correlation time at most Q / (pi f0) = 16 samples: some 30000 independent stretches; 5% on the
            // variance and 0.02 on each correlation are beyond 5 sigma.
            assert!((var / (sigma * sigma) - 1.0).abs() < 0.05, "{var}");
            for (k, a) in acc.iter().enumerate().skip(1) {
                let want = oscillator_rho(f0, q, k);
                let got = a / (n - k) as f64 / var;
                assert!((got - want).abs() < 0.02, "f0 {f0} lag {k}: {got} vs {want}");
            }
            // The first two values over 20000 fresh starts: variance sigma^2 (5 sigma of a variance: 5%).
            let (mut v0, mut v1) = (0.0, 0.0);
            let starts = 20_000;
            for _ in 0..starts {
                let mut res = Resonance::new(sigma, f0, q, 1.0, &mut rng);
                let (a, b) = (res.next(&mut rng), res.next(&mut rng));
                v0 += a * a;
                v1 += b * b;
            }
            for v in [v0, v1] {
                assert!((v / starts as f64 / (sigma * sigma) - 1.0).abs() < 0.05, "f0 {f0}: start variance {v}");
            }
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

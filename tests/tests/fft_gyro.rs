//! A gyro noise generator independent of octavar's simulator, for the coverage study of the fit's intervals
//! (`interval_coverage`): white rate noise (N), flicker rate noise (B) by Timmer & Koenig's spectral synthesis,
//! and a rate random walk (K), drawn from their own random streams (ChaCha12 from `rand`, normals from
//! `rand_distr`) and transformed with `rustfft`; no code of `octavar_shared::sim` is used. Its test checks each
//! term alone against the closed-form Allan variance, averaged over 100 seeds, with an overlapping Allan variance
//! computed directly in the test.
//!
//! J. Timmer and M. Koenig, "On generating power law noise", Astron. Astrophys. 300, 707 (1995).

use std::sync::{Arc, Mutex, OnceLock};

use rand::rngs::StdRng;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};

/// (2 ln 2 / pi): the Allan variance floor of flicker rate noise is this times B^2.
const FLICKER_AVAR_FACTOR: f64 = 2.0 * std::f64::consts::LN_2 / std::f64::consts::PI;

/// The random stream of one part (0 white, 1 flicker, 2 random walk) of record `seed`: each part has its own,
/// so a record's white noise is the same whether or not it has the other parts.
fn stream(seed: u64, part: u64) -> StdRng {
    StdRng::seed_from_u64(seed.wrapping_mul(4).wrapping_add(part))
}

fn normal(rng: &mut StdRng) -> f64 {
    StandardNormal.sample(rng)
}

/// `n` rate samples (deg/s) at `rate_hz` of a zero-mean gyro with angle random walk `n_coef` (deg/sqrt(s)), bias
/// instability `b_coef` (deg/s) and rate random walk `k_coef` (deg/s/sqrt(s)), random stream `seed`:
/// - white rate noise of one-sided PSD `2 N^2`, per-sample sd `N sqrt(rate_hz)` (Allan variance `N^2 / tau`);
/// - flicker rate noise of one-sided PSD `B^2 / (pi f)` (Allan floor `(2 ln 2 / pi) B^2`), see [`flicker`];
/// - a rate random walk, the cumulative sum of Gaussian steps of sd `K sqrt(1 / rate_hz)` (Allan variance
///   `K^2 tau / 3 + K^2 tau0^2 / (6 tau)`: the second term is the walk's sampling, half of it at one sample).
///
/// A term with a zero coefficient draws nothing.
pub fn fft_gyro(rate_hz: f64, n: usize, n_coef: f64, b_coef: f64, k_coef: f64, seed: u64) -> Vec<f64> {
    let mut x = if b_coef > 0.0 { flicker(rate_hz, n, b_coef, &mut stream(seed, 1)) } else { vec![0.0; n] };
    if n_coef > 0.0 {
        let sd = n_coef * rate_hz.sqrt();
        let mut rng = stream(seed, 0);
        for v in &mut x {
            *v += sd * normal(&mut rng);
        }
    }
    if k_coef > 0.0 {
        let step = k_coef * (1.0 / rate_hz).sqrt();
        let mut rng = stream(seed, 2);
        let mut walk = 0.0;
        for v in &mut x {
            walk += step * normal(&mut rng);
            *v += walk;
        }
    }
    x
}

/// The padded length of the flicker synthesis for `n` samples: the next power of two from `4 n`.
fn padded_len(n: usize) -> usize {
    (4 * n).next_power_of_two().max(4)
}

/// `E |X_k|^2` of the DFT `X_k = sum_j x_j e^(-2 pi i j k / L)` of `L` samples at `rate_hz` of a process of
/// one-sided PSD `psd` at `f_k = k rate_hz / L`: `L rate_hz S(f_k) / 2` (white noise of variance s^2, S = 2 s^2 / rate_hz,
/// gives `L s^2`, as it must).
fn dft_power(l: usize, rate_hz: f64, psd: f64) -> f64 {
    l as f64 * rate_hz * psd / 2.0
}

/// One-sided PSD of flicker rate noise of coefficient `b`, (deg/s)^2/Hz.
fn flicker_psd(b: f64, f_hz: f64) -> f64 {
    b * b / (std::f64::consts::PI * f_hz)
}

/// Flicker rate noise by Timmer & Koenig: on the padded length `L` ([`padded_len`]) each Fourier frequency
/// `f_k = k rate_hz / L`, k = 1 .. L/2 - 1, gets a complex Gaussian amplitude of `E |X_k|^2 = L rate_hz S(f_k) / 2`
/// (real and imaginary parts each of half that variance), `X_0 = 0`, the Nyquist amplitude real of the same
/// variance, the negative frequencies the conjugates; the inverse DFT (with its 1/L) is a real stationary series
/// of one-sided PSD `S` on the Fourier frequencies, of which the first `n` samples are kept.
fn flicker(rate_hz: f64, n: usize, b: f64, rng: &mut StdRng) -> Vec<f64> {
    let l = padded_len(n);
    let m = l / 2;
    let sd = |k: usize| dft_power(l, rate_hz, flicker_psd(b, k as f64 * rate_hz / l as f64)).sqrt();
    let mut half = vec![Complex::new(0.0, 0.0); m];
    for (k, h) in half.iter_mut().enumerate().skip(1) {
        let s = sd(k) * std::f64::consts::FRAC_1_SQRT_2;
        *h = Complex::new(s * normal(rng), s * normal(rng));
    }
    let nyquist = sd(m) * normal(rng);
    real_inverse(half, nyquist, n)
}

/// The inverse FFTs, planned once per length for all records.
fn inverse_fft(len: usize) -> Arc<dyn Fft<f64>> {
    static PLANNER: OnceLock<Mutex<FftPlanner<f64>>> = OnceLock::new();
    PLANNER.get_or_init(|| Mutex::new(FftPlanner::new())).lock().unwrap().plan_fft_inverse(len)
}

/// `e^(2 pi i k / l)` for k = 0 .. l/2 from two tables of `e^(2 pi i j / l)`: j below [`FINE`], and j a
/// multiple of it (one complex product per k instead of a sine and a cosine).
struct Twiddles {
    fine: Vec<Complex<f64>>,
    coarse: Vec<Complex<f64>>,
}

const FINE: usize = 1024;

impl Twiddles {
    fn new(l: usize) -> Self {
        let at = |j: usize| Complex::from_polar(1.0, 2.0 * std::f64::consts::PI * j as f64 / l as f64);
        Twiddles { fine: (0..FINE).map(at).collect(), coarse: (0..=l / 2 / FINE).map(|c| at(c * FINE)).collect() }
    }

    fn get(&self, k: usize) -> Complex<f64> {
        self.coarse[k / FINE] * self.fine[k % FINE]
    }
}

/// The first `n` samples of the real inverse DFT `x_j = (1/L) sum_k X_k e^(2 pi i j k / L)`, j = 0 .. L-1, of a
/// Hermitian spectrum given by `X_0 .. X_(L/2 - 1)` (`half`, L/2 a power of two) and the real Nyquist amplitude
/// `X_(L/2)`, with one complex FFT of length L/2: `z_j = x_(2j) + i x_(2j+1)` has the DFT `Z_k = E_k + i O_k`,
/// with `E_k = (X_k + conj X_(L/2-k)) / 2` and `O_k = (X_k - conj X_(L/2-k)) e^(2 pi i k / L) / 2` the DFTs of
/// the even and odd samples. The work is done in `half`'s memory.
fn real_inverse(mut half: Vec<Complex<f64>>, nyquist: f64, n: usize) -> Vec<f64> {
    let m = half.len();
    let twiddles = Twiddles::new(2 * m);
    let i = Complex::new(0.0, 1.0);
    let z = |a: Complex<f64>, b: Complex<f64>, k: usize| {
        let e = (a + b.conj()) * 0.5;
        let o = (a - b.conj()) * twiddles.get(k) * 0.5;
        e + i * o
    };
    // k = 0 pairs with the Nyquist amplitude; k and m - k pair with each other (k = m/2 with itself).
    half[0] = z(half[0], Complex::new(nyquist, 0.0), 0);
    for k in 1..=m / 2 {
        let (a, b) = (half[k], half[m - k]);
        half[k] = z(a, b, k);
        half[m - k] = z(b, a, m - k);
    }
    inverse_fft(m).process(&mut half);
    let scale = 1.0 / m as f64;
    let mut x = Vec::with_capacity(n + 1);
    for c in &half[..n.div_ceil(2)] {
        x.push(c.re * scale);
        x.push(c.im * scale);
    }
    x.truncate(n);
    x
}

#[cfg(test)]
mod tests {
    use super::*;
    use octavar::stats::{analyze_series, DataKind, Options, Series, Statistic, TauSpec};
    use rayon::prelude::*;

    /// The overlapping Allan variance of rate samples `y` (interval `tau0`) at `m` samples, from the phase.
    fn oavar(y: &[f64], tau0: f64, m: usize) -> f64 {
        let mut x = Vec::with_capacity(y.len() + 1);
        let mut acc = 0.0;
        x.push(0.0);
        for v in y {
            acc += v * tau0;
            x.push(acc);
        }
        let terms = x.len() - 2 * m;
        let sum: f64 = (0..terms).map(|i| (x[i + 2 * m] - 2.0 * x[i + m] + x[i]).powi(2)).sum();
        sum / (2.0 * (m * m) as f64 * tau0 * tau0 * terms as f64)
    }

    /// The expected overlapping Allan variance at `m` samples of the synthesised flicker of `n` samples: the
    /// padded series is stationary (circulant), so every term of the estimator has the expectation
    /// `(1/L^2) sum_k E|X_k|^2 |G_m(k)|^2 / 2` with `|G_m|^2 = 4 sin^4(m t / 2) / (m^2 sin^2(t / 2))`,
    /// t = 2 pi k / L, the gain of the difference of two adjacent m-sample means.
    fn flicker_expected(rate_hz: f64, n: usize, b: f64, m: usize) -> f64 {
        let l = padded_len(n);
        let mf = m as f64;
        let sum: f64 = (1..l)
            .map(|k| {
                let f = k.min(l - k) as f64 * rate_hz / l as f64;
                let t = 2.0 * std::f64::consts::PI * k as f64 / l as f64;
                let g = 4.0 * (mf * t / 2.0).sin().powi(4) / (mf * mf * (t / 2.0).sin().powi(2));
                dft_power(l, rate_hz, flicker_psd(b, f)) * g
            })
            .sum();
        sum / (2.0 * (l * l) as f64)
    }

    /// The half-length real inverse equals the full-length complex inverse DFT of the Hermitian spectrum (by
    /// definition, O(L^2), for L = 32; by rustfft for L = 8192, where the coarse twiddle table is used), on random
    /// spectra with X_0 and X_(L/2) real; an odd `n` keeps the first n samples.
    #[test]
    fn real_inverse_is_the_inverse_dft() {
        let mut rng = stream(7, 0);
        for m in [16, 4096] {
            let mut half: Vec<Complex<f64>> =
                (0..m).map(|_| Complex::new(normal(&mut rng), normal(&mut rng))).collect();
            half[0].im = 0.0;
            let nyquist = normal(&mut rng);
            let l = 2 * m;
            let mut full: Vec<Complex<f64>> = (0..l)
                .map(|k| match k {
                    k if k < m => half[k],
                    k if k == m => Complex::new(nyquist, 0.0),
                    k => half[l - k].conj(),
                })
                .collect();
            let want: Vec<Complex<f64>> = if m == 16 {
                (0..l)
                    .map(|j| {
                        let w =
                            |k: usize| Complex::from_polar(1.0, 2.0 * std::f64::consts::PI * (j * k) as f64 / l as f64);
                        (0..l).map(|k| full[k] * w(k)).sum::<Complex<f64>>() / l as f64
                    })
                    .collect()
            } else {
                FftPlanner::new().plan_fft_inverse(l).process(&mut full);
                full.iter().map(|c| c / l as f64).collect()
            };
            let x = real_inverse(half.clone(), nyquist, l);
            assert_eq!(x.len(), l);
            for (j, (&xj, w)) in x.iter().zip(&want).enumerate() {
                assert!((xj - w.re).abs() < 1e-12 && w.im.abs() < 1e-12, "L {l}: x[{j}] = {xj}, want {w}");
            }
            assert_eq!(real_inverse(half, nyquist, 7), x[..7]);
        }
    }

    /// Each term alone, 100 seeds of 2^16 samples at 10 Hz: the seed average of the overlapping Allan variance
    /// at m = 1, 4, 16, 256, 2048 samples (tau up to n tau0 / 32) against
    /// - the closed form (`N^2/tau`, `0.4413 B^2`, `K^2 tau/3`) within 4 standard errors of the seed average plus
    ///   a stated bias allowance. Flicker: 20% at m = 1 and 4% at m = 4 (the spectrum stops at rate_hz/2 and the
    ///   samples are point values, not tau0 means: the exact expectation is +18.9% and +2.9% there, +0.9% at
    ///   m = 8, under 0.3% from m = 16), and 1% at the largest tau (the finite padded record has no frequency
    ///   below rate_hz/L: -0.007% at m = 2048). Random walk: its sampling term `1 / (2 m^2)` (+50% at m = 1, +3.1% at
    ///   m = 4). White: none;
    /// - the exact expectation of the synthesised process (white `N^2/tau`, the walk with its sampling term, the
    ///   flicker by the sum over its Fourier frequencies) within 4 standard errors: this checks the spectral
    ///   scaling itself.
    ///
    /// The direct formula is checked against octavar's OADEV on one record.
    #[test]
    fn generator_matches_the_closed_form_allan_variance() {
        const FS: f64 = 10.0;
        const LEN: usize = 1 << 16;
        const SEEDS: u64 = 100;
        const MS: [usize; 5] = [1, 4, 16, 256, 2048];
        let (n, b, k) = (3e-3, 1.3e-3, 1e-4);
        let tau0 = 1.0 / FS;

        let y = fft_gyro(FS, LEN, n, b, k, 1);
        let series = Series::new(&y, DataKind::Frequency, tau0).unwrap();
        let pts = analyze_series(&series, Statistic::Oadev, &TauSpec::Octave, &Options::default()).unwrap();
        for p in pts.iter().filter(|p| MS.contains(&(p.m as usize))) {
            let direct = oavar(&y, tau0, p.m as usize);
            assert!((p.dev * p.dev / direct - 1.0).abs() < 1e-9, "m {}: octavar {} direct {direct}", p.m, p.dev);
        }

        let closed = |name: &str, m: usize| {
            let tau = m as f64 * tau0;
            match name {
                "N" => n * n / tau,
                "B" => FLICKER_AVAR_FACTOR * b * b,
                _ => k * k * tau / 3.0,
            }
        };
        let allowance = |name: &str, m: usize| match (name, m) {
            ("B", 1) => 0.20,
            ("B", 4) => 0.04,
            ("B", 2048) => 0.01,
            ("K", m) => 0.5 / (m * m) as f64,
            _ => 0.0,
        };
        let mut failures = Vec::new();
        println!("| term | m | closed form | exact | seed mean | 4 SE | mean/closed - 1 | mean/exact - 1 |");
        println!("|---|---|---|---|---|---|---|---|");
        for (name, coefs) in [("N", [n, 0.0, 0.0]), ("B", [0.0, b, 0.0]), ("K", [0.0, 0.0, k])] {
            let avars: Vec<[f64; 5]> = (1..=SEEDS)
                .into_par_iter()
                .map(|s| {
                    let y = fft_gyro(FS, LEN, coefs[0], coefs[1], coefs[2], s);
                    MS.map(|m| oavar(&y, tau0, m))
                })
                .collect();
            for (i, &m) in MS.iter().enumerate() {
                let v: Vec<f64> = avars.iter().map(|a| a[i]).collect();
                let mean = v.iter().sum::<f64>() / v.len() as f64;
                let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64;
                let se4 = 4.0 * (var / v.len() as f64).sqrt();
                let c = closed(name, m);
                let exact = match name {
                    "N" => c,
                    "B" => flicker_expected(FS, LEN, b, m),
                    _ => c * (1.0 + 0.5 / (m * m) as f64),
                };
                println!(
                    "| {name} | {m} | {c:.4e} | {exact:.4e} | {mean:.4e} | {se4:.2e} | {:+.4} | {:+.4} |",
                    mean / c - 1.0,
                    mean / exact - 1.0
                );
                if (mean - c).abs() > se4 + allowance(name, m) * c {
                    failures.push(format!("{name} m {m}: mean {mean:.4e} vs closed form {c:.4e}"));
                }
                if (mean - exact).abs() > se4 {
                    failures.push(format!("{name} m {m}: mean {mean:.4e} vs exact expectation {exact:.4e}"));
                }
            }
        }
        assert!(failures.is_empty(), "{failures:#?}");
    }
}

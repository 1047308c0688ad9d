//! The power spectral density of a model's noise: what a generalised least-squares estimator weighs each
//! frequency by when it looks for a deterministic effect (a temperature coupling, a sinusoid) in samples that
//! still carry the model's stochastic parts.

use octavar_shared::sim::GyroSim;

use super::common::ieee_squares;
use super::lowpass::lowpass_gain;
use super::resonance::unit_spectrum_at;

/// The two-sided PSD, (deg/s)^2/Hz, of the stochastic parts of a model whose realisation stays in the samples:
/// white rate noise N, differenced white angle Q, flicker B and random walk K (IEEE 952 Annex C: `N^2`,
/// `B^2 / (2 pi f)`, `K^2 / (2 pi f)^2`), a Gauss-Markov process and a resonance, all through the sensor's
/// first-order bandwidth as shared::sim applies it. Deterministic parts (ramp, sinusoids, temperature, warm-up)
/// have no spectrum here, and the realisations a chain step takes out of the samples (bias steps, a bistable
/// bias, outliers) are no longer in them.
#[derive(Clone, Debug)]
pub(crate) struct NoiseSpectrum {
    squares: [f64; 4],
    gauss_markov: Option<(f64, f64)>,
    resonance: Option<(f64, f64, f64)>,
    bandwidth_hz: Option<f64>,
    rate_hz: f64,
    /// The rate of the series the angle noise Q is differenced at: the sample rate, or the block rate of block
    /// means (a block mean of differenced white angle is the difference across the block).
    q_rate_hz: f64,
}

impl NoiseSpectrum {
    /// The noise spectrum of `gyro` sampled at `rate_hz`.
    pub(crate) fn of(gyro: &GyroSim, rate_hz: f64) -> Self {
        NoiseSpectrum {
            squares: ieee_squares(gyro),
            gauss_markov: gyro.gauss_markov.map(|g| (g.sigma_dps * g.sigma_dps, g.tau_s)),
            resonance: gyro.resonance.map(|r| (r.sigma_dps * r.sigma_dps, r.freq_hz, r.q)),
            bandwidth_hz: gyro.bandwidth_hz,
            rate_hz,
            q_rate_hz: rate_hz,
        }
    }

    /// The noise spectrum of the means of blocks of `m` samples of `gyro` sampled at `rate_hz`, at frequencies
    /// below the block rate's Nyquist: the same as the samples' (averaging passes them), except the angle noise
    /// Q, whose block mean `Q (fs/m) (w_end - w_start)` is differenced white angle at the block rate.
    pub(crate) fn of_block_means(gyro: &GyroSim, rate_hz: f64, m: usize) -> Self {
        NoiseSpectrum { q_rate_hz: rate_hz / m.max(1) as f64, ..Self::of(gyro, rate_hz) }
    }

    /// The two-sided PSD at `f` > 0 Hz, never below a billionth of the white, flicker and random-walk levels
    /// together (a weight of zero would make the estimator trust one frequency without limit).
    pub(crate) fn at(&self, f: f64) -> f64 {
        use std::f64::consts::PI;
        let [q2, n2, b2, k2] = self.squares;
        let (fs, w) = (self.rate_hz, 2.0 * PI * f);
        let mut s = n2 + b2 / w + k2 / (w * w);
        // Q fq (w_n - w_(n-1)) at the rate fq: |1 - e^{-i 2 pi f/fq}|^2 = 4 sin^2(pi f/fq), per-sample variance
        // 2 Q^2 fq^2 spread over fq.
        let fq = self.q_rate_hz;
        s += 4.0 * q2 * fq * (PI * f / fq).sin().powi(2);
        if let Some((var, t_s)) = self.gauss_markov {
            // The sampled AR(1) of pole a = exp(-1/(fs T)) and variance var.
            let a = (-1.0 / (fs * t_s)).exp();
            s += var * (1.0 - a * a) / (fs * (1.0 - 2.0 * a * (w / fs).cos() + a * a));
        }
        if let Some((var, f0, q)) = self.resonance {
            s += 0.5 * var * unit_spectrum_at(f0, q, fs, f);
        }
        if let Some(bw) = self.bandwidth_hz {
            s *= lowpass_gain(bw, fs, f);
        }
        let floor = (n2 + b2 + k2).max(1e-300) * 1e-9;
        if s.is_finite() {
            s.max(floor)
        } else {
            floor
        }
    }
}

/// Half the mean square first difference of the samples that `gyro`'s coloured processes (a Gauss-Markov
/// process and a resonance, through its bandwidth) contribute at `rate_hz`: `integral S(f) 2 sin^2(pi f / fs) df`
/// over (-fs/2, fs/2), by the midpoint rule on 4096 bins. White noise N contributes `N^2 fs` to the same
/// statistic, the per-sample variance; this is what a white level read from first differences must not count.
pub(crate) fn coloured_half_difference(gyro: &GyroSim, rate_hz: f64) -> f64 {
    if gyro.gauss_markov.is_none() && gyro.resonance.is_none() {
        return 0.0;
    }
    let coloured = GyroSim {
        gauss_markov: gyro.gauss_markov,
        resonance: gyro.resonance,
        bandwidth_hz: gyro.bandwidth_hz,
        ..GyroSim::default()
    };
    let s = NoiseSpectrum::of(&coloured, rate_hz);
    const BINS: usize = 4096;
    let df = 0.5 * rate_hz / BINS as f64;
    2.0 * (0..BINS)
        .map(|i| {
            let f = (i as f64 + 0.5) * df;
            s.at(f) * 2.0 * (std::f64::consts::PI * f / rate_hz).sin().powi(2) * df
        })
        .sum::<f64>()
}

#[cfg(test)]
mod tests {
    use super::*;
    use octavar_shared::sim::{GaussMarkovSim, ResonanceSim};

    /// Integrated over (-fs/2, fs/2), the spectrum of white noise, of a Gauss-Markov process and of a resonance
    /// gives each one's per-sample variance, the sum for all three together, and the low-pass takes away what
    /// the closed form of a filtered white noise says: `fs (1 - a)/(1 + a)` for unit N.
    #[test]
    fn the_spectrum_integrates_to_each_parts_variance() {
        let fs = 50.0;
        let integral = |g: &GyroSim| {
            let s = NoiseSpectrum::of(g, fs);
            let n = 200_000;
            let df = 0.5 * fs / n as f64;
            2.0 * (0..n).map(|i| s.at((i as f64 + 0.5) * df) * df).sum::<f64>()
        };
        let white = GyroSim { n_deg_per_rt_s: 0.01, ..Default::default() };
        assert!((integral(&white) / (1e-4 * fs) - 1.0).abs() < 1e-6);
        let gm = GyroSim { gauss_markov: Some(GaussMarkovSim { sigma_dps: 0.2, tau_s: 0.5 }), ..Default::default() };
        assert!((integral(&gm) / 0.04 - 1.0).abs() < 1e-3, "{}", integral(&gm));
        let res =
            GyroSim { resonance: Some(ResonanceSim { sigma_dps: 0.3, freq_hz: 4.0, q: 10.0 }), ..Default::default() };
        assert!((integral(&res) / 0.09 - 1.0).abs() < 1e-3, "{}", integral(&res));
        let all = GyroSim { gauss_markov: gm.gauss_markov, resonance: res.resonance, ..white.clone() };
        assert!((integral(&all) / (1e-4 * fs + 0.04 + 0.09) - 1.0).abs() < 1e-3);
        let filtered = GyroSim { bandwidth_hz: Some(2.0), ..white };
        let a = (-2.0 * std::f64::consts::PI * 2.0 / fs).exp();
        let expected = 1e-4 * fs * (1.0 - a) / (1.0 + a);
        assert!((integral(&filtered) / expected - 1.0).abs() < 1e-4, "{} {expected}", integral(&filtered));
    }

    /// A Gauss-Markov process's half mean square first difference is `var (1 - a)`, `a` its lag-one correlation;
    /// white noise adds nothing to the coloured part.
    #[test]
    fn the_coloured_half_difference_of_a_gauss_markov_process_is_its_closed_form() {
        let fs = 6.0;
        let (sigma, t_s) = (0.05, 1.2);
        let g = GyroSim {
            n_deg_per_rt_s: 0.01,
            gauss_markov: Some(GaussMarkovSim { sigma_dps: sigma, tau_s: t_s }),
            ..Default::default()
        };
        let a = (-1.0 / (fs * t_s)).exp();
        let expected = sigma * sigma * (1.0 - a);
        let got = coloured_half_difference(&g, fs);
        assert!((got / expected - 1.0).abs() < 1e-4, "{got} against {expected}");
        assert_eq!(coloured_half_difference(&GyroSim { n_deg_per_rt_s: 0.01, ..Default::default() }, fs), 0.0);
    }

    /// Q's differenced white angle has the per-sample variance `2 Q^2 fs^2` (and its block means `2 Q^2 fb^2` at
    /// the block rate fb), and flicker and random walk follow
    /// IEEE 952's `B^2/(2 pi f)` and `K^2/(2 pi f)^2`.
    #[test]
    fn quantization_flicker_and_random_walk_follow_their_closed_forms() {
        let fs = 10.0;
        let q = GyroSim { q_deg: 0.001, ..Default::default() };
        let s = NoiseSpectrum::of(&q, fs);
        let n = 100_000;
        let df = 0.5 * fs / n as f64;
        let var = 2.0 * (0..n).map(|i| s.at((i as f64 + 0.5) * df) * df).sum::<f64>();
        assert!((var / (2.0 * 1e-6 * fs * fs) - 1.0).abs() < 1e-6, "{var}");
        // Means of blocks of 5 samples: the difference of the angle across a block, over the block's length.
        let blocks = NoiseSpectrum::of_block_means(&q, fs, 5);
        let fb = fs / 5.0;
        let dfb = 0.5 * fb / n as f64;
        let var_b = 2.0 * (0..n).map(|i| blocks.at((i as f64 + 0.5) * dfb) * dfb).sum::<f64>();
        assert!((var_b / (2.0 * 1e-6 * fb * fb) - 1.0).abs() < 1e-6, "{var_b}");
        let bk = NoiseSpectrum::of(&GyroSim { b_dps: 0.02, k_dps_per_rt_s: 0.003, ..Default::default() }, fs);
        let w = 2.0 * std::f64::consts::PI * 0.01;
        assert!((bk.at(0.01) / (4e-4 / w + 9e-6 / (w * w)) - 1.0).abs() < 1e-12);
    }
}

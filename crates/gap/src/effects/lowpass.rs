//! The sensor's output bandwidth as shared::sim applies it, a sampled first-order low-pass: its pole and its
//! power gain, which the Allan-curve forms, the lattice's rounding and the noise spectrum read; and the effects
//! read at the sensor's output (sinusoids, a resonance) referred to the filter's input, where the model puts them.

/// The pole of shared::sim's sampled first-order low-pass `y = a y + (1 - a) x` at `f3db_hz`: `exp(-2 pi f3dB /
/// rate_hz)`.
pub(super) fn lowpass_pole(f3db_hz: f64, rate_hz: f64) -> f64 {
    (-2.0 * std::f64::consts::PI * f3db_hz / rate_hz).exp()
}

/// The power gain of that low-pass at `f`: `(1 - a)^2 / |1 - a e^{-i w}|^2`, `w = 2 pi f / rate_hz`.
pub(super) fn lowpass_gain(f3db_hz: f64, rate_hz: f64, f: f64) -> f64 {
    let a = lowpass_pole(f3db_hz, rate_hz);
    let w = 2.0 * std::f64::consts::PI * f / rate_hz;
    (1.0 - a) * (1.0 - a) / (1.0 - 2.0 * a * w.cos() + a * a)
}

/// The complex response of that low-pass at `f`, `H = (1 - a) / (1 - a e^{-i w})`: its amplitude gain and its
/// phase, rad (a lag: zero or negative).
pub(super) fn lowpass_response(f3db_hz: f64, rate_hz: f64, f: f64) -> (f64, f64) {
    let a = lowpass_pole(f3db_hz, rate_hz);
    let w = 2.0 * std::f64::consts::PI * f / rate_hz;
    let (re, im) = (1.0 - a * w.cos(), a * w.sin());
    ((1.0 - a) / re.hypot(im), -im.atan2(re))
}

/// The response of the output bandwidth `f3db_hz` (`None`: none, a gain of one) at `f`.
fn response(f3db_hz: Option<f64>, rate_hz: f64, f: f64) -> (f64, f64) {
    f3db_hz.map_or((1.0, 0.0), |c| lowpass_response(c, rate_hz, f))
}

/// The sinusoid `s` at the input of the bandwidth `to` (`None`: none), where it stood at the input of `from`: the
/// same sinusoid at the sensor's output. The simulator passes a sinusoid through the filter, so one read from the
/// output under a corner is larger at the input by the filter's gain at its frequency, and ahead by its lag.
pub(crate) fn sinusoid_moved(
    s: &octavar_shared::sim::Sinusoid,
    from: Option<f64>,
    to: Option<f64>,
    rate_hz: f64,
) -> octavar_shared::sim::Sinusoid {
    let f = 1.0 / s.period_s;
    let ((g0, p0), (g1, p1)) = (response(from, rate_hz, f), response(to, rate_hz, f));
    octavar_shared::sim::Sinusoid { amplitude_dps: s.amplitude_dps * g0 / g1, phase_rad: s.phase_rad + p0 - p1, ..*s }
}

/// The share of a resonance's variance that the bandwidth `f3db_hz` (`None`: none) passes: its spectrum weighed
/// by the filter's power gain, integrated on a log grid over the band.
fn resonance_power_gain(r: &octavar_shared::sim::ResonanceSim, f3db_hz: Option<f64>, rate_hz: f64) -> f64 {
    let Some(c) = f3db_hz else { return 1.0 };
    const POINTS: usize = 4000;
    let (lo, hi) = ((r.freq_hz / 1000.0).ln(), (0.5 * rate_hz).ln());
    let (mut all, mut passed) = (0.0, 0.0);
    for k in 0..POINTS {
        let f = (lo + (hi - lo) * (k as f64 + 0.5) / POINTS as f64).exp();
        let s = super::resonance::unit_spectrum_at(r.freq_hz, r.q, rate_hz, f) * f;
        all += s;
        passed += s * lowpass_gain(c, rate_hz, f);
    }
    if all > 0.0 {
        passed / all
    } else {
        1.0
    }
}

/// `gyro`'s effects read from the sensor's output, which the simulator passes through the output bandwidth,
/// referred from the input of the bandwidth `from` (`None`: none) to the input of `gyro`'s own: each sinusoid's
/// amplitude and phase, and a resonance's variance, so that the output they give stays what was read. The slow
/// effects (a temperature response, a warm-up) are left: a corner well above them passes them whole.
pub(crate) fn refer_to_bandwidth(gyro: &mut octavar_shared::sim::GyroSim, from: Option<f64>, rate_hz: f64) {
    let to = gyro.bandwidth_hz;
    if from == to {
        return;
    }
    for s in gyro.sinusoids.iter_mut() {
        *s = sinusoid_moved(s, from, to, rate_hz);
    }
    if let Some(r) = gyro.resonance.as_mut() {
        let (g0, g1) = (resonance_power_gain(r, from, rate_hz), resonance_power_gain(r, to, rate_hz));
        if g1 > 0.0 {
            r.sigma_dps *= (g0 / g1).sqrt();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use octavar_shared::sim::noise::{LowPass, Resonance};
    use octavar_shared::sim::rng::SimRng;
    use octavar_shared::sim::{GyroSim, ResonanceSim, Sinusoid};

    /// The amplitude and phase of the sinusoid of period `p` samples in `y` (after the first `skip`), by least
    /// squares on sine and cosine: `A sin(w n + phi)`.
    fn read(y: &[f64], p: f64, skip: usize) -> (f64, f64) {
        let w = 2.0 * std::f64::consts::PI / p;
        let (mut ss, mut sc, mut cc, mut ys, mut yc) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for (n, &v) in y.iter().enumerate().skip(skip) {
            let (s, c) = ((w * n as f64).sin(), (w * n as f64).cos());
            (ss, sc, cc, ys, yc) = (ss + s * s, sc + s * c, cc + c * c, ys + v * s, yc + v * c);
        }
        let det = ss * cc - sc * sc;
        let (b, a) = ((ys * cc - yc * sc) / det, (yc * ss - ys * sc) / det);
        (a.hypot(b), a.atan2(b))
    }

    /// A sinusoid read at the output of shared::sim's low-pass, referred to its input, is the one that went in:
    /// below, at and above the corner.
    #[test]
    fn a_sinusoid_read_through_the_filter_is_referred_back_to_its_input() {
        let (rate_hz, corner) = (50.0, 2.5);
        for period_samples in [200.0, 20.0, 9.1] {
            let input = Sinusoid { amplitude_dps: 0.6, period_s: period_samples / rate_hz, phase_rad: 0.4 };
            let mut lp = LowPass::new(corner, rate_hz);
            let w = 2.0 * std::f64::consts::PI / period_samples;
            let y: Vec<f64> = (0..20_000).map(|n| lp.next(0.6 * (w * n as f64 + 0.4).sin())).collect();
            let (a, phi) = read(&y, period_samples, 2_000);
            let out = Sinusoid { amplitude_dps: a, phase_rad: phi, ..input };
            let back = sinusoid_moved(&out, None, Some(corner), rate_hz);
            assert!((back.amplitude_dps - 0.6).abs() < 1e-6, "{period_samples}: amplitude {}", back.amplitude_dps);
            let dphi = (back.phase_rad - 0.4).sin().abs();
            assert!(dphi < 1e-6, "{period_samples}: phase {}", back.phase_rad);
            // And from one corner to another: the output through the second is the one read.
            let moved = sinusoid_moved(&back, Some(corner), Some(5.0), rate_hz);
            let (g, p) = lowpass_response(5.0, rate_hz, 1.0 / input.period_s);
            assert!((moved.amplitude_dps * g - a).abs() < 1e-6 && ((moved.phase_rad + p - phi).sin()).abs() < 1e-6);
        }
    }

    /// A resonance referred to the input of a corner gives, through shared::sim's low-pass, the variance it had
    /// without one: a bump below, at and beside the corner, within the sample variance's spread.
    #[test]
    fn a_resonance_referred_to_a_corner_keeps_its_output_variance() {
        let rate_hz = 20.0;
        for (f0, q, corner) in [(0.86, 3.4, 1.8), (2.0, 8.0, 2.0), (4.0, 2.0, 1.0)] {
            let read = ResonanceSim { sigma_dps: 0.01, freq_hz: f0, q };
            let mut g = GyroSim { resonance: Some(read), bandwidth_hz: Some(corner), ..Default::default() };
            refer_to_bandwidth(&mut g, None, rate_hz);
            let sigma = g.resonance.unwrap().sigma_dps;
            assert!(sigma > 0.01, "the input is larger: {sigma}");
            let mut rng = SimRng::new(7);
            let mut res = Resonance::new(sigma, f0, q, 1.0 / rate_hz, &mut rng);
            let mut lp = LowPass::new(corner, rate_hz);
            let n = 2_000_000;
            let var = (0..n).map(|_| lp.next(res.next(&mut rng)).powi(2)).sum::<f64>() / n as f64;
            // A record of 2e6 samples holds about 2e6 / (rate Q / (pi f0)) independent stretches of the bump: the
            // sample variance's relative sd is under 1.5% for these; 5% is over three of it.
            assert!((var.sqrt() / 0.01 - 1.0).abs() < 0.05, "f0 {f0} Q {q} corner {corner}: sd {}", var.sqrt());
        }
    }
}

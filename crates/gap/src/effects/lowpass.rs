//! The sensor's output bandwidth as shared::sim applies it, a sampled first-order low-pass: its pole and its
//! power gain, which the Allan-curve forms, the lattice's rounding and the noise spectrum read; and its complex
//! response, which refers a sinusoid read at the sensor's output to the filter's input, where the model puts it.

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
pub(super) fn sinusoid_moved(
    s: &octavar_shared::sim::Sinusoid,
    from: Option<f64>,
    to: Option<f64>,
    rate_hz: f64,
) -> octavar_shared::sim::Sinusoid {
    let f = 1.0 / s.period_s;
    let ((g0, p0), (g1, p1)) = (response(from, rate_hz, f), response(to, rate_hz, f));
    octavar_shared::sim::Sinusoid { amplitude_dps: s.amplitude_dps * g0 / g1, phase_rad: s.phase_rad + p0 - p1, ..*s }
}

#[cfg(test)]
mod tests {
    use super::*;
    use octavar_shared::sim::noise::LowPass;
    use octavar_shared::sim::Sinusoid;

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
}

//! The sensor's output bandwidth as shared::sim applies it, a sampled first-order low-pass: its pole and its
//! power gain, which the Allan-curve forms, the lattice's rounding and the noise spectrum read.

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

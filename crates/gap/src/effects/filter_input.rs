//! The effects read at the sensor's output, referred to the input of the model's output bandwidth: the simulator
//! passes every rate the sensor sees through that first-order low-pass, so a sinusoid or a resonance read from the
//! record is what came out of it, and the model must carry what went in.

use octavar_shared::sim::{GyroSim, ResonanceSim};

use super::lowpass::{lowpass_gain, sinusoid_moved};
use super::resonance::unit_spectrum_at;

/// The share of a resonance's variance that the bandwidth `f3db_hz` (`None`: none) passes: its spectrum weighed
/// by the filter's power gain, integrated on a log grid over the band.
fn resonance_power_gain(r: &ResonanceSim, f3db_hz: Option<f64>, rate_hz: f64) -> f64 {
    let Some(c) = f3db_hz else { return 1.0 };
    const POINTS: usize = 4000;
    let (lo, hi) = ((r.freq_hz / 1000.0).ln(), (0.5 * rate_hz).ln());
    let (mut all, mut passed) = (0.0, 0.0);
    for k in 0..POINTS {
        let f = (lo + (hi - lo) * (k as f64 + 0.5) / POINTS as f64).exp();
        let s = unit_spectrum_at(r.freq_hz, r.q, rate_hz, f) * f;
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
pub(super) fn refer_to_bandwidth(gyro: &mut GyroSim, from: Option<f64>, rate_hz: f64) {
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

//! The bench temperature and its coupling into a gyro's bias.
//!
//! [`Thermal`] makes the temperature every sample: a daily (or any period) sinusoid between `min_c` and `max_c`
//! from a rotating phasor, plus an optional Gauss-Markov wander updated every `T / 16` or so samples (held
//! between updates). [`ThermalLag`] passes it through the sensor's first-order thermal lag and scales it into
//! bias. A temperature sinusoid of amplitude `A_T` at frequency f therefore adds a rate sinusoid of amplitude
//! `k A_T |H|`, `|H| = (1 - a) / |1 - a e^{-i 2 pi f tau0}|` with `a = exp(-tau0 / lag)` (about
//! `1 / sqrt(1 + (2 pi f lag)^2)`).

use super::effects::Sinusoids;
use super::model::{Sinusoid, TempCoupling, TemperatureProfile};
use super::noise::{hold_log2, HeldGaussMarkov};
use super::rng::SimRng;

/// The shared temperature of a bench, degC.
#[derive(Clone, Debug, PartialEq)]
pub struct Thermal {
    mid: f64,
    cycle: Sinusoids,
    wander: Option<HeldGaussMarkov>,
    n: u64,
}

impl Thermal {
    /// The profile sampled at `rate_hz`; the wander draws from `rng`.
    pub fn new(p: &TemperatureProfile, rate_hz: f64, rng: &mut SimRng) -> Self {
        let half = 0.5 * (p.max_c - p.min_c);
        let cycle = Sinusoid { amplitude_dps: half, period_s: p.period_s, phase_rad: p.phase_rad };
        let list: &[Sinusoid] = if half != 0.0 && p.period_s > 0.0 { &[cycle] } else { &[] };
        let wander = p.wander.filter(|w| w.sigma_c > 0.0).map(|w| {
            let t = w.tau_s * rate_hz;
            HeldGaussMarkov::new(w.sigma_c, t, hold_log2(t), rng)
        });
        Thermal { mid: 0.5 * (p.max_c + p.min_c), cycle: Sinusoids::new(list, 1.0 / rate_hz), wander, n: 0 }
    }

    /// The temperature of the next sample, degC.
    #[inline]
    pub fn next(&mut self, rng: &mut SimRng) -> f64 {
        let n = self.n;
        self.n += 1;
        let mut t = self.mid + self.cycle.next(n);
        if let Some(w) = &mut self.wander {
            t += w.next(n, rng);
        }
        t
    }

    /// The temperatures of the next `out.len()` samples, degC: the values of as many calls of [`Thermal::next`].
    pub fn fill(&mut self, rng: &mut SimRng, out: &mut [f64]) {
        let (n0, mid) = (self.n, self.mid);
        let mut wander = self.wander.clone();
        self.cycle.for_each(n0, out.len(), |k, cycle| {
            let mut t = mid + cycle;
            if let Some(w) = &mut wander {
                t += w.next_held(n0 + k as u64, rng);
            }
            out[k] = t;
        });
        self.wander = wander;
        self.n += out.len() as u64;
    }
}

/// One channel's thermal lag and bias coefficient.
#[derive(Clone, Debug, PartialEq)]
pub struct ThermalLag {
    a: f64,
    y: f64,
    k: f64,
    ref_c: f64,
    started: bool,
}

impl ThermalLag {
    /// The coupling of a model, sampled every `tau0_s`.
    pub fn new(c: &TempCoupling, tau0_s: f64) -> Self {
        let a = if c.lag_s > 0.0 { libm::exp(-tau0_s / c.lag_s) } else { 0.0 };
        ThermalLag { a, y: 0.0, k: c.dps_per_c, ref_c: c.ref_c, started: false }
    }

    /// The pole `a` of the lag.
    pub fn pole(&self) -> f64 {
        self.a
    }

    /// Bias added at this sample for the temperature `temp_c`, in deg/s (the lag starts settled at the first
    /// temperature it sees).
    #[inline]
    pub fn next(&mut self, temp_c: f64) -> f64 {
        if !self.started {
            self.started = true;
            self.y = temp_c;
        }
        self.y = temp_c + self.a * (self.y - temp_c);
        self.k * (self.y - self.ref_c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::model::Wander;

    #[test]
    fn cycle_spans_min_to_max() {
        let p = TemperatureProfile { min_c: 22.0, max_c: 25.0, period_s: 100.0, phase_rad: 0.0, wander: None };
        let mut rng = SimRng::new(1);
        let mut th = Thermal::new(&p, 10.0, &mut rng);
        let (mut lo, mut hi) = (f64::MAX, f64::MIN);
        for _ in 0..1000 {
            let t = th.next(&mut rng);
            lo = lo.min(t);
            hi = hi.max(t);
        }
        assert!((lo - 22.0).abs() < 1e-3 && (hi - 25.0).abs() < 1e-3, "{lo} {hi}");
    }

    #[test]
    fn wander_moves_and_lag_settles() {
        let p = TemperatureProfile { wander: Some(Wander { sigma_c: 0.5, tau_s: 10.0 }), ..Default::default() };
        let mut rng = SimRng::new(2);
        let mut th = Thermal::new(&p, 100.0, &mut rng);
        let xs: [f64; 4000] = core::array::from_fn(|_| th.next(&mut rng));
        assert!(xs.iter().any(|&x| (x - xs[0]).abs() > 0.05));
        let mut lag = ThermalLag::new(&TempCoupling { dps_per_c: 0.1, ref_c: 25.0, lag_s: 1.0 }, 0.01);
        assert_eq!(lag.next(30.0), 0.5);
        for _ in 0..2000 {
            lag.next(27.0);
        }
        assert!((lag.next(27.0) - 0.2).abs() < 1e-9);
    }
}

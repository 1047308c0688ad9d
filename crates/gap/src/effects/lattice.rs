//! What an ADC lattice does to the Allan curve of a Gaussian rate: the exact Allan variance of the rounded
//! record, less the analog record's, for a lattice whose offset the rate's slow wander spreads over a step.
//!
//! Rounding to `offset + step Z` with the offset uniform over a step changes an increment `delta` of the analog
//! rate into an increment of the rounded one whose mean square is `g(delta) = step^2 (k^2 + f (2k + 1))`,
//! `|delta| / step = k + f`: the number of lattice lines between the two values, squared, on average over the
//! offset. Over a Gaussian increment of variance `D` (the analog rate's structure function at that lag) the mean of
//! `g(delta) - delta^2` is `h(D) = step^2 [1/6 - (1/pi^2) sum_n exp(-2 pi^2 n^2 D / step^2) / n^2]`: `step^2 / 6`
//! (white rounding noise of `step^2 / 12` a sample) once `D` reaches a step squared, and `step sqrt(2 D / pi) - D`
//! when the increments are far smaller than a step, where the rounded record holds a value for many samples. The
//! Allan variance at `m` samples is a weighted sum of the structure function, `-(1 / 4 m^2) sum_d w_m(d) D(d)`, so
//! the lattice adds `-(1 / 4 m^2) sum_d w_m(d) h(D(d))`.
//!
//! On a signal several steps wide per sample that is the white `step^2 / 12 / m`; on a rate the sensor's output
//! bandwidth or a slow process has smoothed to below a step per sample it is not. White noise low-passed to a
//! third of its sd and rounded to four times that: the white form puts 1.5 times the rounded record's Allan
//! variance at one sample and 0.8 times it at 8 to 16, a bent curve that a fit reads as a different corner or a
//! Gauss-Markov process.

use octavar_shared::sim::flicker::{FIRST_WEIGHT, FLICKER_PROCESSES};
use octavar_shared::sim::GyroSim;
use std::f64::consts::PI;

use super::lowpass::lowpass_pole;

/// The lags summed one by one; beyond, in bins of [`BIN_GROWTH`] relative width.
const EXACT_LAGS: usize = 256;
/// The relative width of the bins of lags beyond [`EXACT_LAGS`], over which `h` is taken at the bin's middle.
const BIN_GROWTH: f64 = 1.02;
/// `D / step^2` beyond which `h` is `step^2 / 6` to 1e-12 of it (`exp(-2 pi^2 x) < 1e-12`).
const WHITE_FROM: f64 = 1.4;

/// The structure function `E[(x_{i+d} - x_i)^2]` of the analog rate of `model` at a lag of `d` samples, as
/// shared::sim makes it: white noise through the output bandwidth `f3db_hz` (an AR(1)), the flicker bank's
/// Gauss-Markov processes, the rate random walk, and a Gauss-Markov process or a resonance the model carries
/// (their own filtering by the bandwidth left out: it changes the structure at lags within the corner's time,
/// where the white noise's dominates).
fn analog_structure(model: &GyroSim, f3db_hz: Option<f64>, d: f64, rate_hz: f64) -> f64 {
    let white_var = model.n_deg_per_rt_s * model.n_deg_per_rt_s * rate_hz;
    let white = match f3db_hz.filter(|f| *f > 0.0) {
        Some(f) => {
            let a = lowpass_pole(f, rate_hz);
            2.0 * white_var * (1.0 - a) / (1.0 + a) * -(d * a.ln()).exp_m1()
        }
        None => 2.0 * white_var,
    };
    let per_process = model.b_dps * model.b_dps * std::f64::consts::LN_2 / PI;
    let flicker: f64 = if per_process > 0.0 {
        (0..FLICKER_PROCESSES as i32)
            .map(|j| {
                let weight = if j == 0 { FIRST_WEIGHT } else { 1.0 };
                weight * -(-d / 2f64.powi(j)).exp_m1()
            })
            .sum::<f64>()
            * 2.0
            * per_process
    } else {
        0.0
    };
    let walk = model.k_dps_per_rt_s * model.k_dps_per_rt_s * d / rate_hz;
    let markov =
        model.gauss_markov.map_or(0.0, |g| 2.0 * g.sigma_dps * g.sigma_dps * -(-d / (g.tau_s * rate_hz)).exp_m1());
    let resonance = model.resonance.map_or(0.0, |r| {
        let w = 2.0 * PI * r.freq_hz / rate_hz;
        let zeta = 0.5 / r.q;
        let root = (1.0 - zeta * zeta).max(f64::MIN_POSITIVE).sqrt();
        let decay = (-zeta * w * d).exp();
        let rho = decay * ((w * d * root).cos() + zeta / root * (w * d * root).sin());
        2.0 * r.sigma_dps * r.sigma_dps * (1.0 - rho)
    });
    white + flicker + walk + markov + resonance
}

/// `step^2 / 6 - h(D)`: what the lattice leaves out of the white rounding noise's share of the structure function
/// at an analog increment variance `d_var` (`step^2 / 6` at `D = 0`, where the rounded record stands still).
fn short_of_white(step: f64, d_var: f64) -> f64 {
    let x = d_var / (step * step);
    if x >= WHITE_FROM {
        return 0.0;
    }
    // (step^2 / pi^2) sum_n exp(-a n^2) / n^2 with a = 2 pi^2 x: by its theta-function dual where a is small
    // (the dual's first neglected term is exp(-pi^2 / a) < 1e-9 below a = 0.44), by the series above.
    let a = 2.0 * PI * PI * x;
    let sum = if a < 0.44 {
        PI * PI / 6.0 + a / 2.0 - (PI * a).sqrt()
    } else {
        let mut s = 0.0;
        let mut n = 1.0f64;
        while a * n * n < 40.0 {
            s += (-a * n * n).exp() / (n * n);
            n += 1.0;
        }
        s
    };
    step * step / (PI * PI) * sum.max(0.0)
}

/// `sum_{k=1}^{x} w_m(k)`, the weights of the structure function in the Allan variance at `m` samples,
/// `w_m(k) = 2 [2 (m - k)^+ - min(k, 2m - k)]` (the sums of two adjacent blocks of `m`, differenced, squared).
fn weight_sum(m: f64, x: f64) -> f64 {
    if x <= m {
        4.0 * m * x - 3.0 * x * (x + 1.0)
    } else {
        m * m - 3.0 * m + (x * (x + 1.0) - m * (m + 1.0)) - 4.0 * m * (x - m)
    }
}

/// Whether a lattice of step `step_dps` rounds the analog rate of `model` through `f3db_hz` as white noise: the rate
/// moves by more than a step from one sample to the next (or there is no step).
pub(super) fn rounds_white(step_dps: f64, model: &GyroSim, f3db_hz: Option<f64>, rate_hz: f64) -> bool {
    !(step_dps > 0.0 && analog_structure(model, f3db_hz, 1.0, rate_hz) < WHITE_FROM * step_dps * step_dps)
}

/// The Allan variance at `tau` of a lattice's rounding taken as white noise: `step^2 / 12` a sample.
pub(super) fn white_rounding_avar(step_dps: f64, tau: f64, rate_hz: f64) -> f64 {
    step_dps * step_dps / 12.0 / (tau * rate_hz).max(1.0)
}

/// The Allan variance an ADC lattice adds to the analog rate of a model, at every number of samples: built once
/// per model ([`LatticeExcess::new`]), read per tau ([`LatticeExcess::at`]).
pub(super) struct LatticeExcess {
    step: f64,
    /// Bins of lags `(first, last, step^2 / 6 - h at the middle)`, in order; empty where the rounding is white.
    bins: Vec<(f64, f64, f64)>,
}

impl LatticeExcess {
    /// The lattice of step `step_dps` over the analog rate of `model` through `f3db_hz`, sampled at `rate_hz`, for
    /// averaging times up to `max_m` samples.
    pub(super) fn new(step_dps: f64, model: &GyroSim, f3db_hz: Option<f64>, rate_hz: f64, max_m: f64) -> Self {
        let mut bins = Vec::new();
        if !rounds_white(step_dps, model, f3db_hz, rate_hz) {
            let last_lag = (2.0 * max_m.max(1.0)).round() - 1.0;
            let mut lo = 1.0f64;
            while lo <= last_lag {
                let hi = if lo < EXACT_LAGS as f64 { lo } else { (lo * BIN_GROWTH).floor().min(last_lag) };
                let short = short_of_white(step_dps, analog_structure(model, f3db_hz, 0.5 * (lo + hi), rate_hz));
                bins.push((lo, hi, short));
                lo = hi + 1.0;
            }
        }
        LatticeExcess { step: step_dps, bins }
    }

    /// Whether the rounding is white noise at every tau: the analog rate moves by more than a step from one sample
    /// to the next.
    pub(super) fn is_white(&self) -> bool {
        self.bins.is_empty()
    }

    /// The Allan variance the lattice adds at `tau` (the white `step^2 / 12 / m` less what the record's smoothness
    /// leaves out of it; negative where the rounded record stands still for longer than `m` samples).
    pub(super) fn at(&self, tau: f64, rate_hz: f64) -> f64 {
        if self.is_white() {
            return white_rounding_avar(self.step, tau, rate_hz);
        }
        let m = (tau * rate_hz).round().max(1.0);
        let last_lag = 2.0 * m - 1.0;
        let mut sum = 0.0;
        for &(lo, hi, short) in self.bins.iter().take_while(|b| b.0 <= last_lag) {
            let hi = hi.min(last_lag);
            sum += (weight_sum(m, hi) - weight_sum(m, lo - 1.0)) * short;
        }
        self.step * self.step / 12.0 / m + sum / (4.0 * m * m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::common::oadev_points;

    /// The weights of the structure function sum to the Allan variance's: white noise of variance `v` (structure
    /// `2 v` at every lag) has `v / m`, and a constant structure adds nothing beyond it.
    #[test]
    fn the_structure_weights_give_white_noise_its_allan_variance() {
        for m in [1.0, 2.0, 3.0, 17.0, 1024.0] {
            // The closed-form running sum against the weights summed one by one, at every lag.
            let mut direct = 0.0;
            for k in 1..(2 * m as usize) {
                let k = k as f64;
                direct += 2.0 * (2.0 * (m - k).max(0.0) - k.min(2.0 * m - k));
                assert_eq!(weight_sum(m, k), direct, "m {m} lag {k}");
            }
            assert_eq!(direct, -2.0 * m, "m {m}");
        }
        // h(D) is step E|delta| - D at small D and step^2 / 6 at large D; the two forms meet at a = 0.44.
        let step = 1.0;
        let tiny = 1e-6;
        let h = step * step / 6.0 - short_of_white(step, tiny);
        assert!((h - (step * (2.0 * tiny / PI).sqrt() - tiny)).abs() < 1e-12, "{h}");
        assert!(short_of_white(step, 2.0) == 0.0);
        let x = 0.44 / (2.0 * PI * PI);
        let (below, above) = (short_of_white(step, x * (1.0 - 1e-9)), short_of_white(step, x * (1.0 + 1e-9)));
        assert!((below - above).abs() < 1e-8, "{below} vs {above}");
    }

    /// Rounding a low-passed or slowly correlated Gaussian rate to a lattice a few times its sample-to-sample
    /// change: the Allan variance of the rounded record, written out here from the definition (an AR(1) of white
    /// Gaussian deviates and a random walk that carries the offset over many steps, rounded to the lattice), is
    /// the analog record's plus [`LatticeExcess`] at every octave, where the white `step^2 / 12 / m` is off by
    /// a third or more at the short taus.
    #[test]
    fn a_lattice_over_a_smooth_rate_adds_its_exact_allan_variance() {
        let rate_hz = 100.0;
        let n = 1 << 21;
        for (case, (pole, step_in_sd)) in [(0.8f64, 4.0), (0.95, 2.5), (0.0, 3.0)].into_iter().enumerate() {
            // White deviates of unit variance through y = a y + (1 - a) x, and a walk of K.
            let white = octavar_stats::test_signals::white(n, 31 + case as u64);
            let walk_steps = octavar_stats::test_signals::white(n, 71 + case as u64);
            let sd = ((1.0 - pole) / (1.0 + pole)).sqrt();
            let step = step_in_sd * sd;
            let k = 40.0 * step / (n as f64 / rate_hz).sqrt();
            let (mut y, mut w) = (0.0, 0.0);
            let analog: Vec<f64> = white
                .iter()
                .zip(&walk_steps)
                .map(|(x, s)| {
                    y = pole * y + (1.0 - pole) * x;
                    w += k / rate_hz.sqrt() * s;
                    y + w
                })
                .collect();
            let rounded: Vec<f64> = analog.iter().map(|v| (v / step).round() * step).collect();
            let n_dps = 1.0 / rate_hz.sqrt();
            let f3db = (pole > 0.0).then(|| -pole.ln() * rate_hz / (2.0 * PI));
            let model = GyroSim { n_deg_per_rt_s: n_dps, k_dps_per_rt_s: k, ..Default::default() };
            let excess = LatticeExcess::new(step, &model, f3db, rate_hz, n as f64 / 4.0);
            let (plain, with) = (oadev_points(&analog, rate_hz), oadev_points(&rounded, rate_hz));
            let mut white_off = 0.0f64;
            for (p, r) in plain.iter().zip(&with).filter(|(p, _)| p.edf > 3000.0) {
                let want = p.avar + excess.at(p.tau_s, rate_hz);
                // The walk spreads the offset over a step only nearly evenly: 1.5% at least.
                let tol = (6.0 / p.edf.sqrt()).max(0.015);
                assert!((r.avar / want - 1.0).abs() < tol, "case {case} tau {}: {} for {want}", p.tau_s, r.avar);
                let white_form = p.avar + step * step / 12.0 / (p.tau_s * rate_hz);
                white_off = white_off.max((white_form / r.avar - 1.0).abs());
            }
            if pole > 0.0 {
                assert!(white_off > 0.3, "case {case}: the white form is off by {white_off} at most");
            }
        }
    }
}

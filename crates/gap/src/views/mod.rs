//! The four views in which a record is compared with its simulated ensemble.
//!
//! A [`Plan`] is laid out once per part of the record (training, holdout) from the real samples: which taus, which
//! frequency bands, which lattice step, which temperature bands. [`Plan::measure`] then reduces any series of that
//! length (the real one, or each simulated member with the same gaps) to one number per point of each view, in a
//! domain where the ensemble spread is close to Gaussian. One module per view says how and why:
//!
//! | view | module | points | value |
//! |------|--------|--------|-------|
//! | `adev` | [`adev`] | octave taus of the overlapping Allan deviation | ln OADEV |
//! | `psd` | [`psd`] | log-spaced frequency bands (5 per decade) down to one cycle per part | ln of the one-sided PSD: Welch levels, then the whole part's sine multitaper |
//! | `distribution` | [`distribution`] | skewness, kurtosis, tail share, lattice share at tau0; Allan-difference kurtosis per octave | moments and shares |
//! | `temperature` | [`temperature`] | octave bands of frequency from one cycle per part | atanh of the coherence's root between the rate, less the model's own temperature response, and the temperature |
//!
//! The spectral tools they share are in [`crate::spectral`]; the comparison of a real measure with an
//! ensemble's (z-scores, the worst window) is [`crate::compare`].

mod adev;
mod distribution;
mod psd;
mod temperature;

use std::sync::Arc;

use rayon::prelude::*;
use rustfft::FftPlanner;
use serde::Serialize;

pub use distribution::{lattice_of, lattice_share, LATTICE_TAIL_STEPS, TAIL_SIGMA};

use adev::AdevPlan;
use distribution::DistributionPlan;
use psd::PsdPlan;
use temperature::TemperaturePlan;

use super::spectral::Multitaper;

/// A view of the comparison.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ViewKind {
    /// Overlapping Allan deviation over tau.
    Adev,
    /// Power spectral density over frequency (reported as 1/f, s).
    Psd,
    /// The distribution of the sample values.
    Distribution,
    /// Correlation with the temperature channel.
    Temperature,
}

impl ViewKind {
    /// Every view, in report order.
    pub const ALL: [ViewKind; 4] = [ViewKind::Adev, ViewKind::Psd, ViewKind::Distribution, ViewKind::Temperature];

    /// The name in reports and JSON.
    pub fn name(self) -> &'static str {
        match self {
            ViewKind::Adev => "adev",
            ViewKind::Psd => "psd",
            ViewKind::Distribution => "distribution",
            ViewKind::Temperature => "temperature",
        }
    }

    /// The model-error allowance added in quadrature to every point's sd: the base fit allows 3% in Allan
    /// variance (`FitOptions::model_error`), which is 0.015 in ln ADEV; the PSD, which the fit never saw, gets
    /// twice that; moments and shares get none (their floors are absolute, see [`Plan::new`]).
    pub fn model_floor(self) -> f64 {
        match self {
            ViewKind::Adev => 0.015,
            ViewKind::Psd => 0.03,
            ViewKind::Distribution | ViewKind::Temperature => 0.0,
        }
    }
}

/// One point of a view: what it is and where it lies in tau.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PointInfo {
    /// Short name (`tau`, `band`, `kurtosis`, ...).
    pub label: &'static str,
    /// Representative tau, s (1/f for a PSD or temperature band, tau0 for the distribution).
    pub tau_s: f64,
    /// Lower tau edge, s.
    pub tau_lo_s: f64,
    /// Upper tau edge, s.
    pub tau_hi_s: f64,
    /// Smallest sd the point's z may use (its own statistical spread).
    pub floor_sd: f64,
}

/// What to measure on a part of the record; built from the real samples, applied to every series of that part.
#[derive(Clone)]
pub struct Plan {
    n: usize,
    adev: AdevPlan,
    psd: PsdPlan,
    distribution: DistributionPlan,
    temperature: TemperaturePlan,
    /// The points of each view, in [`ViewKind::ALL`] order (an empty list: the view does not apply).
    pub points: [Vec<PointInfo>; 4],
}

/// One series reduced to its view values (NaN where a point could not be computed), in [`ViewKind::ALL`] order.
#[derive(Clone, Debug, PartialEq)]
pub struct Measure {
    /// Values per view, aligned with [`Plan::points`].
    pub values: [Vec<f64>; 4],
    /// The OADEV itself (deviation, not its log) at the plan's taus, for plots.
    pub adev: Vec<f64>,
}

impl Plan {
    /// Lay out the views for `real` (deg/s, NaN gaps) sampled at `rate_hz`, with the temperature if there is one.
    pub fn new(real: &[f64], temp_c: Option<&[f64]>, rate_hz: f64) -> Plan {
        let n = real.len();
        let mut planner = FftPlanner::new();
        // The whole-part multitaper layout of the PSD's long periods and the temperature view.
        let taper = Multitaper::new(n, &mut planner).map(Arc::new);
        let (adev, adev_pts) = AdevPlan::new(real, rate_hz);
        let (psd, psd_pts) = PsdPlan::new(n, rate_hz, taper.clone(), &mut planner);
        let (distribution, dist_pts) = DistributionPlan::new(real, rate_hz);
        let (temperature, temp_pts) = TemperaturePlan::new(n, rate_hz, temp_c, taper);
        Plan { n, adev, psd, distribution, temperature, points: [adev_pts, psd_pts, dist_pts, temp_pts] }
    }

    /// Number of samples this plan is for.
    pub fn len(&self) -> usize {
        self.n
    }

    /// True for a plan of no samples.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The lattice step of the real part, deg/s, when it has a visible one.
    pub fn lattice_step(&self) -> Option<f64> {
        self.distribution.lattice_step
    }

    /// Reduce a series of this part (same length, gaps where the real one has them) to its view values.
    /// `parallel`: let the Allan deviation use rayon (off when the caller already runs members in parallel).
    pub fn measure(&self, x: &[f64], temp_c: Option<&[f64]>, parallel: bool) -> Measure {
        self.measure_explained(x, temp_c, None, parallel)
    }

    /// As [`Plan::measure`], with the temperature view taken on `x` less `explained` (the response to the
    /// temperature that the model under test carries): the view then asks whether the series still follows the
    /// temperature once the model's coupling is taken out. For a model that has the coupling right, real and
    /// simulated residual coherences both scatter about the level noise alone gives; a coherence near one,
    /// compared as such, has a spread so small that a 2% difference in unexplained noise between real and model
    /// reads as a large gap.
    pub fn measure_explained(
        &self,
        x: &[f64],
        temp_c: Option<&[f64]>,
        explained: Option<&[f64]>,
        parallel: bool,
    ) -> Measure {
        let adev = self.adev.deviations(x, parallel);
        let ln_adev = adev.iter().map(|v| if *v > 0.0 { v.ln() } else { f64::NAN }).collect();
        let psd = self.psd.values(x);
        let dist = self.distribution.values(x);
        let temp = self.temperature_view(x, temp_c, explained);
        Measure { values: [ln_adev, psd, dist, temp], adev }
    }

    /// `measured` (this plan's [`Measure`] of `x`) with only its temperature view taken again, on `x` less
    /// `explained`: what [`Plan::measure_explained`] gives, without measuring the other views a second time.
    pub fn with_explained(&self, measured: &Measure, x: &[f64], temp_c: Option<&[f64]>, explained: &[f64]) -> Measure {
        let mut m = measured.clone();
        m.values[ViewKind::Temperature as usize] = self.temperature_view(x, temp_c, Some(explained));
        m
    }

    /// The temperature view's values of `x` (less `explained`, when given); NaN without a temperature.
    fn temperature_view(&self, x: &[f64], temp_c: Option<&[f64]>, explained: Option<&[f64]>) -> Vec<f64> {
        match temp_c {
            Some(t) if !self.temperature.is_empty() => match explained {
                Some(e) => {
                    let residual: Vec<f64> = x.iter().zip(e).map(|(v, c)| v - c).collect();
                    self.temperature.values(&residual, t)
                }
                None => self.temperature.values(x, t),
            },
            _ => self.temperature.nan(),
        }
    }
}

/// Measure many series in parallel (rayon), each without inner parallelism.
pub fn measure_all(plan: &Plan, series: &[Vec<f64>], temp_c: Option<&[f64]>) -> Vec<Measure> {
    series.par_iter().map(|x| plan.measure(x, temp_c, false)).collect()
}

#[cfg(test)]
mod tests {
    use super::distribution::difference_kurtosis;
    use super::*;
    use crate::compare::compare;

    use std::f64::consts::PI;

    use octavar_stats::test_signals::white;

    #[test]
    fn white_noise_agrees_with_white_noise() {
        let real = white(50_000, 1);
        let plan = Plan::new(&real, None, 10.0);
        assert!(plan.points[0].len() >= 10 && plan.points[1].len() >= 10, "{:?}", plan.points[1].len());
        assert!(plan.lattice_step().is_none());
        let m = plan.measure(&real, None, true);
        let sims: Vec<Vec<f64>> = (2..22).map(|s| white(50_000, s)).collect();
        let ms = measure_all(&plan, &sims, None);
        let gaps = compare(&plan, &m, &ms);
        assert_eq!(gaps.len(), 3);
        for g in &gaps {
            assert!(g.rms < 2.0, "{:?} {}", g.view, g.rms);
        }
        // Twice the noise: a gap of the right sign in ADEV and PSD.
        let loud: Vec<f64> = real.iter().map(|v| 2.0 * v).collect();
        let gaps = compare(&plan, &plan.measure(&loud, None, true), &ms);
        assert!(gaps[0].rms > 10.0 && gaps[0].points.iter().all(|p| p.z > 0.0));
        assert!(gaps[1].rms > 10.0);
    }

    #[test]
    fn psd_reaches_one_cycle_per_part_in_physical_units_and_sees_a_slow_line() {
        // White noise of unit variance at 10 Hz: a one-sided PSD of 2 / rate_hz in every band, Welch's and the
        // multitaper's alike, down to one cycle per part.
        let (n, rate_hz) = (1usize << 16, 10.0);
        let noise = white(n, 21);
        let plan = Plan::new(&noise, None, rate_hz);
        let pts = &plan.points[1];
        let part_s = n as f64 / rate_hz;
        let longest = pts.iter().map(|p| p.tau_hi_s).fold(0.0, f64::max);
        assert!(longest > 0.99 * part_s && longest <= part_s, "{longest} of {part_s}");
        assert!(pts.iter().filter(|p| p.tau_lo_s >= part_s / 16.5).count() >= 5, "{pts:?}");
        let psd = plan.measure(&noise, None, true).values[1].clone();
        for (p, v) in pts.iter().zip(&psd) {
            let sd = p.floor_sd.max(0.02);
            assert!(
                (v - (2.0 / rate_hz).ln()).abs() < 4.0 * sd,
                "band at {:.1} s: {v} vs {}",
                p.tau_s,
                (2.0 / rate_hz).ln()
            );
        }
        // A sinusoid of 8 cycles per part with a quarter of the noise's power: its band sees a line far above
        // the noise; the Welch bands, from a sixteenth of the part down, do not move.
        let line: Vec<f64> =
            noise.iter().enumerate().map(|(i, v)| v + 0.7 * (2.0 * PI * 8.0 * i as f64 / n as f64).sin()).collect();
        let with_line = plan.measure(&line, None, true).values[1].clone();
        let band = pts.iter().position(|p| p.tau_lo_s <= part_s / 8.0 && part_s / 8.0 < p.tau_hi_s).unwrap();
        assert!(with_line[band] - psd[band] > 3.0, "{} vs {}", with_line[band], psd[band]);
        for (i, p) in pts.iter().enumerate().filter(|(_, p)| p.tau_hi_s < part_s / 16.0) {
            assert!((with_line[i] - psd[i]).abs() < 0.1, "band at {:.1} s moved", p.tau_s);
        }
    }

    #[test]
    fn the_long_psd_bands_see_through_a_linear_drift() {
        // White noise of unit variance with a drift of 40 sds over the part. A line is no stationary noise: the
        // multitaper bands take it out and keep the white level 2 / rate_hz within 4 of their sds; centred only, the
        // antisymmetric tapers would turn it into power 6 (in ln) above the noise at a cycle per part.
        let (n, rate_hz) = (1usize << 16, 10.0);
        let drifted: Vec<f64> = white(n, 22).iter().enumerate().map(|(i, v)| v + 40.0 * i as f64 / n as f64).collect();
        let plan = Plan::new(&drifted, None, rate_hz);
        let part_s = n as f64 / rate_hz;
        let psd = plan.measure(&drifted, None, true).values[1].clone();
        let long: Vec<(&PointInfo, f64)> =
            plan.points[1].iter().zip(psd).filter(|(p, _)| p.tau_lo_s >= part_s / 16.5).collect();
        assert!(long.len() >= 5);
        for (p, v) in long {
            assert!((v - (2.0 / rate_hz).ln()).abs() < 4.0 * p.floor_sd, "band at {:.1} s: {v}", p.tau_s);
        }
    }

    #[test]
    fn difference_kurtosis_has_its_closed_forms() {
        // Gaussian white noise: the Allan differences are Gaussian, excess kurtosis 0 (sd sqrt(24/n)).
        let x = white(1 << 18, 11);
        let ms = [2usize, 8, 64];
        for (m, k) in ms.iter().zip(difference_kurtosis(&x, &ms)) {
            let n = ((1 << 18) / m - 1) as f64;
            assert!(k.abs() < 5.0 * (24.0 / n).sqrt() + 0.02, "m {m}: {k}");
        }
        // A pure sinusoid: its differences are a sinusoid, excess kurtosis -1.5.
        let sine: Vec<f64> = (0..1 << 16).map(|i| (2.0 * std::f64::consts::PI * i as f64 / 1000.0).sin()).collect();
        for k in difference_kurtosis(&sine, &[2, 4, 8]) {
            assert!((k + 1.5).abs() < 0.01, "{k}");
        }
        // Rare large steps on white noise: heavy tails.
        let mut steps = white(1 << 18, 12);
        let mut level = 0.0;
        for (i, v) in steps.iter_mut().enumerate() {
            if i % 20_000 == 10_000 {
                level += 20.0;
            }
            *v += level;
        }
        assert!(difference_kurtosis(&steps, &[64])[0] > 10.0);
        // Too few differences: NaN.
        assert!(difference_kurtosis(&x[..200], &[4])[0].is_nan());
    }

    #[test]
    fn lattice_and_spikes_are_seen() {
        let lattice = |q: f64| -> Vec<f64> { white(20_000, 3).iter().map(|v| (v / q).round() * q + 0.1).collect() };
        let q = 0.75;
        let x = lattice(q);
        assert!((lattice_of(&x).unwrap() - q).abs() < 1e-12);
        // A step of a quarter of the noise sd is on a lattice too, but too fine to matter.
        assert!(lattice_of(&lattice(0.25)).is_none());
        assert!(lattice_of(&white(20_000, 3)).is_none());
        let plan = Plan::new(&x, None, 1.0);
        let mut spiky = white(20_000, 4);
        for i in (0..20_000).step_by(200) {
            spiky[i] += 8.0;
        }
        let d = plan.measure(&spiky, None, true).values[2].clone();
        let c = plan.measure(&white(20_000, 5), None, true).values[2].clone();
        assert!(d[1] > c[1] + 1.0, "kurtosis {d:?} {c:?}");
        assert!(d[2] > 0.004 && c[2] < 0.001, "tails {d:?} {c:?}");
        assert!(d[0] > 0.3, "skewness {d:?}");
        assert!(d[3] < 0.2 && plan.measure(&x, None, true).values[2][3] > 0.99);
    }

    /// The band of the temperature view that holds `cycles` cycles per part.
    fn band_of(plan: &Plan, n: usize, rate_hz: f64, cycles: f64) -> usize {
        let tau = n as f64 / rate_hz / cycles;
        plan.points[3].iter().position(|p| p.tau_lo_s <= tau && tau < p.tau_hi_s).unwrap()
    }

    #[test]
    fn temperature_coherence_is_found_in_the_cycles_band_at_any_lag() {
        // 20 cycles of 2000 s; the rate follows the temperature a quarter cycle late, where the two are
        // uncorrelated sample by sample: the coherence of the cycle's band is the same as without a lag.
        let n = 40_000;
        let temp: Vec<f64> = (0..n).map(|i| 20.0 + 3.0 * (2.0 * PI * i as f64 / 2000.0).sin()).collect();
        let noise = white(n, 7);
        let coupled = |lag: usize| -> Vec<f64> {
            (0..n).map(|i| 0.2 * noise[i] + if i >= lag { 0.5 * (temp[i - lag] - 20.0) } else { 0.0 }).collect()
        };
        let late = coupled(500);
        let plan = Plan::new(&late, Some(&temp), 1.0);
        let cycle = band_of(&plan, n, 1.0, 20.0);
        let m = plan.measure(&late, Some(&temp), true).values[3].clone();
        let m0 = plan.measure(&coupled(0), Some(&temp), true).values[3].clone();
        assert!(m[cycle].tanh() > 0.99, "{m:?}");
        assert!((m[cycle].tanh() - m0[cycle].tanh()).abs() < 0.01, "{m:?} {m0:?}");
        let quadrature: f64 = late.iter().zip(&temp).map(|(r, t)| r * (t - 20.0)).sum::<f64>()
            / (late.iter().map(|r| r * r).sum::<f64>() * temp.iter().map(|t| (t - 20.0).powi(2)).sum::<f64>()).sqrt();
        assert!(quadrature.abs() < 0.1, "sample correlation {quadrature}");
        // Noise alone follows it in no band.
        let m = plan.measure(&noise, Some(&temp), true).values[3].clone();
        assert!(m.iter().all(|v| v.tanh() < 0.6), "{m:?}");
    }

    #[test]
    fn a_model_coupling_is_taken_out_of_the_temperature_view_only() {
        // rate = 0.5 T (lagged) + noise. Less the true response, it correlates with T no more than the noise does;
        // less half of it, the other half still shows; the other views do not change.
        let n = 40_000;
        let temp: Vec<f64> = (0..n).map(|i| 20.0 + 3.0 * (i as f64 / 3000.0).sin()).collect();
        let noise = white(n, 7);
        let response: Vec<f64> = (0..n).map(|i| if i >= 500 { 0.5 * temp[i - 500] } else { 0.0 }).collect();
        let rate: Vec<f64> = noise.iter().zip(&response).map(|(e, r)| 0.2 * e + r).collect();
        let plan = Plan::new(&rate, Some(&temp), 1.0);
        let whole = plan.measure(&rate, Some(&temp), true);
        let rest = plan.measure_explained(&rate, Some(&temp), Some(&response), true);
        let noise_only = plan.measure(&noise, Some(&temp), true);
        for (r, e) in rest.values[3].iter().zip(&noise_only.values[3]) {
            assert!((r - e).abs() < 1e-9, "{r} vs the noise's {e}");
        }
        let half: Vec<f64> = response.iter().map(|r| 0.5 * r).collect();
        let part = plan.measure_explained(&rate, Some(&temp), Some(&half), true);
        let cycle = band_of(&plan, n, 1.0, n as f64 / (2.0 * PI * 3000.0));
        assert!(part.values[3][cycle].tanh() > 0.9, "{:?}", part.values[3]);
        for k in 0..3 {
            assert_eq!(format!("{:?}", rest.values[k]), format!("{:?}", whole.values[k]));
        }
        // Re-taking only the temperature view of a measure gives the same, bit for bit.
        let again = plan.with_explained(&whole, &rate, Some(&temp), &response);
        assert_eq!(format!("{:?}", again.values), format!("{:?}", rest.values));
    }
}

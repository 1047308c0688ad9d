//! Joint re-estimation of a chain's model: once the chain is found, the base terms and every effect in it
//! estimated again together on the training samples, so that an effect the base fit or an earlier step absorbed
//! (a sinusoid read as bias instability, a filter corner read under a resonance) comes back out, and the answer
//! does not hang on the order the effects were found in.
//!
//! Two parts, as the model has two:
//! - **deterministic** (a temperature response, sinusoids, a warm-up): where the model has two or more, their
//!   linear parameters (the coupling coefficient, each sinusoid's cosine and sine amplitudes, the warm-up's size)
//!   are fitted together by least squares beside a quadratic trend, their time scales (the thermal lag, the
//!   periods, the warm-up's time constant) held as their estimators found them. One such effect alone keeps its
//!   estimator's generalised least squares, which weighs the red noise a plain least squares does not.
//! - **stochastic** (the base terms, an output bandwidth, a Gauss-Markov process, a resonance): fitted together
//!   on the octave Allan variances of the samples less the deterministic part
//!   ([`crate::effects::joint_curve`], GMWM-style).
//!
//! The realisations the chain recovered (bias steps, a bistable bias's levels, spikes) are out of the samples
//! both parts see, and their parameters stay as found; so does quantisation, a property of the ADC channel.

use std::ops::Range;

use octavar_shared::sensor::Channel;
use octavar_shared::sim::{GyroSim, Sinusoid, TempCoupling, WarmUpSim};

use super::data::deterministic_part;
use super::model::Model;
use crate::effects::{joint_curve, jumps_through_filter};
use crate::fill::refill;

/// Columns of the trend beside the deterministic effects: `1`, `u`, `u^2 - 1/3` over `u` from -1 to 1.
const TREND: usize = 3;

/// `model` re-estimated jointly on `series` (the training samples less the recovered realisations, the runs
/// `gaps` filled) with the temperature `temp_c`: its deterministic part by least squares where it has two or more
/// deterministic effects, then its stochastic part on the Allan curve of what the deterministic part leaves.
/// `shaped` is the part of the recovered realisations the sensor's filter shapes (bias jumps, taken out sharp):
/// under the model's bandwidth they are taken out through it instead, as the sensor passed them. `None` when
/// neither part changes the model (no stochastic curve to fit, a singular design).
pub fn reestimate(
    model: &Model,
    series: &[f64],
    shaped: Option<&[f64]>,
    gaps: &[Range<usize>],
    temp_c: Option<&[f64]>,
    rate_hz: f64,
) -> Option<Model> {
    let mut gyro = model.gyro.clone();
    let through_filter: Vec<f64>;
    let series = match (shaped, gyro.bandwidth_hz) {
        (Some(s), Some(f)) => {
            through_filter = jumps_through_filter(series, s, f, rate_hz);
            &through_filter[..]
        }
        _ => series,
    };
    let mut changed = false;
    if let Some(g) = deterministic(&gyro, series, gaps, temp_c, rate_hz) {
        gyro = g;
        changed = true;
    }
    let mut rest = match deterministic_part(&gyro, rate_hz, temp_c, series.len()) {
        Some(d) => series.iter().zip(&d).map(|(x, d)| x - d).collect(),
        None => series.to_vec(),
    };
    refill(&mut rest, gaps);
    if let Some(j) =
        joint_curve::stochastic(&gyro, &rest, gaps, rate_hz, model.channel.as_ref().map(Channel::dps_per_code))
            .filter(|j| j.chi2 < j.chi2_before)
    {
        gyro = j.gyro;
        changed = true;
    }
    changed.then(|| Model { gyro, ..model.clone() })
}

/// How many deterministic effects `gyro` carries (with the temperature channel `temp_c`): a coupling, each
/// sinusoid, a warm-up.
fn deterministic_count(gyro: &GyroSim, has_temp: bool) -> usize {
    usize::from(gyro.temperature.is_some() && has_temp) + gyro.sinusoids.len() + usize::from(gyro.warm_up.is_some())
}

/// The linear parameters of `gyro`'s deterministic effects fitted together by least squares on `series` (the
/// samples in the runs `gaps` left out) beside a quadratic trend, each effect's time scale held; `None` with
/// fewer than two such effects or a singular design.
fn deterministic(
    gyro: &GyroSim,
    series: &[f64],
    gaps: &[Range<usize>],
    temp_c: Option<&[f64]>,
    rate_hz: f64,
) -> Option<GyroSim> {
    if deterministic_count(gyro, temp_c.is_some()) < 2 {
        return None;
    }
    let n = series.len();
    // Each effect's response to a unit parameter, through the model's bandwidth as the simulator applies it.
    let unit = |g: GyroSim| deterministic_part(&GyroSim { bandwidth_hz: gyro.bandwidth_hz, ..g }, rate_hz, temp_c, n);
    let mut cols: Vec<Vec<f64>> = Vec::new();
    if let (Some(c), Some(_)) = (gyro.temperature, temp_c) {
        let coupling = TempCoupling { dps_per_c: 1.0, ..c };
        cols.push(unit(GyroSim { temperature: Some(coupling), ..Default::default() })?);
    }
    for s in &gyro.sinusoids {
        for phase_rad in [std::f64::consts::FRAC_PI_2, 0.0] {
            let mut g = GyroSim::default();
            g.sinusoids.push(Sinusoid { amplitude_dps: 1.0, period_s: s.period_s, phase_rad }).ok()?;
            cols.push(unit(g)?);
        }
    }
    if let Some(w) = gyro.warm_up {
        cols.push(unit(GyroSim { warm_up: Some(WarmUpSim { size_dps: 1.0, ..w }), ..Default::default() })?);
    }
    let coef = least_squares(series, gaps, &cols)?;
    let mut out = gyro.clone();
    let mut next = 0;
    if let (Some(c), Some(_)) = (out.temperature.as_mut(), temp_c) {
        c.dps_per_c = coef[next];
        next += 1;
    }
    for s in out.sinusoids.iter_mut() {
        // a cos + b sin = A sin(w t + phi) with a = A sin phi, b = A cos phi.
        let (a, b) = (coef[next], coef[next + 1]);
        s.amplitude_dps = a.hypot(b);
        s.phase_rad = a.atan2(b);
        next += 2;
    }
    if let Some(w) = out.warm_up.as_mut() {
        w.size_dps = coef[next];
    }
    Some(out)
}

/// The least-squares coefficients of `cols` (each `series.len()` long) beside a quadratic trend, fitted to
/// `series` with the samples in `gaps` left out; the trend's coefficients are dropped.
fn least_squares(series: &[f64], gaps: &[Range<usize>], cols: &[Vec<f64>]) -> Option<Vec<f64>> {
    let n = series.len();
    let p = TREND + cols.len();
    let mut ata = vec![vec![0.0; p]; p];
    let mut atb = vec![0.0; p];
    let mut row = vec![0.0; p];
    let mut gap = gaps.iter().peekable();
    for (i, &y) in series.iter().enumerate() {
        while gap.peek().is_some_and(|g| g.end <= i) {
            gap.next();
        }
        if gap.peek().is_some_and(|g| g.contains(&i)) {
            continue;
        }
        let u = 2.0 * i as f64 / n as f64 - 1.0;
        row[0] = 1.0;
        row[1] = u;
        row[2] = u * u - 1.0 / 3.0;
        for (r, c) in row[TREND..].iter_mut().zip(cols) {
            *r = c[i];
        }
        for r in 0..p {
            atb[r] += row[r] * y;
            for c in r..p {
                ata[r][c] += row[r] * row[c];
            }
        }
    }
    for r in 0..p {
        for c in 0..r {
            ata[r][c] = ata[c][r];
        }
    }
    // Scaled to a unit diagonal, so the pivot threshold means the same for every column's units.
    let scale: Vec<f64> = (0..p).map(|r| ata[r][r].sqrt()).collect();
    if scale.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
        return None;
    }
    for r in 0..p {
        atb[r] /= scale[r];
        for c in 0..p {
            ata[r][c] /= scale[r] * scale[c];
        }
    }
    let sol = octavar_stats::linalg::solve(ata, atb, 1e-12)?;
    Some((TREND..p).map(|r| sol[r] / scale[r]).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two deterministic effects that share the record (a temperature cycle and a sinusoid at a nearby period)
    /// are recovered together from a record of them plus white noise, started from wrong sizes: the least squares
    /// is exact for the linear parameters, so each comes back within a few of its standard errors.
    #[test]
    fn temperature_and_sinusoid_come_back_together() {
        let rate_hz = 5.0;
        let n = 60_000;
        let mut truth = GyroSim {
            temperature: Some(TempCoupling { dps_per_c: 0.02, ref_c: 25.0, lag_s: 40.0 }),
            ..Default::default()
        };
        truth.sinusoids.push(Sinusoid { amplitude_dps: 0.05, period_s: 900.0, phase_rad: 1.0 }).unwrap();
        let temp: Vec<f64> = (0..n).map(|i| 25.0 + 2.0 * (i as f64 / (rate_hz * 1100.0)).sin()).collect();
        let det = deterministic_part(&truth, rate_hz, Some(&temp), n).unwrap();
        // Unit white noise scaled to sd 0.1.
        let noise = octavar_stats::test_signals::white(n, 12345);
        let series: Vec<f64> = det.iter().zip(&noise).map(|(d, w)| d + 0.1 * w).collect();
        let mut start = truth.clone();
        start.temperature.as_mut().unwrap().dps_per_c = 0.005;
        start.sinusoids[0].amplitude_dps = 0.01;
        start.sinusoids[0].phase_rad = 0.0;
        let got = deterministic(&start, &series, &[], Some(&temp), rate_hz).unwrap();
        // Standard errors under white noise of sd 0.1 over 60000 samples: the sinusoid's amplitude sqrt(2/n) 0.1
        // = 5.8e-4; the coupling's about 0.1 / (sqrt(n) 1.4 degC) = 2.9e-4.
        let k = got.temperature.unwrap().dps_per_c;
        assert!((k - 0.02).abs() < 4.0 * 2.9e-4, "coupling {k}");
        let s = got.sinusoids[0];
        assert!((s.amplitude_dps - 0.05).abs() < 4.0 * 5.8e-4, "amplitude {}", s.amplitude_dps);
        assert!((s.phase_rad - 1.0).abs() < 4.0 * 5.8e-4 / 0.05, "phase {}", s.phase_rad);
        // One deterministic effect alone is left to its estimator.
        let mut one = truth.clone();
        one.sinusoids.clear();
        assert!(deterministic(&one, &series, &[], Some(&temp), rate_hz).is_none());
    }
}

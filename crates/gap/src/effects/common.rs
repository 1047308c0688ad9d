//! Small helpers the estimators share: means and medians, block means, the octave OADEV as fit points, the
//! IEEE re-fit of a cleaned record, the normal tail, one-dimensional searches (golden section, log grid) and the
//! FFT.

use std::cell::RefCell;
use std::ops::Range;
use std::sync::Arc;

use octavar_shared::sim::noise::LowPass;
use octavar_shared::sim::{GaussMarkovSim, GyroSim};
use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};

use super::curve::{
    base_columns, base_curve, coarse_lattice, filtered_gm_avar, filtered_resonance_avar, joint_fit_keeping, less_known,
    less_known_as_recorded, weighed_by_fit_error, with_base_terms, BASE_COLS,
};
use super::TrainingData;
use crate::fill::with_gaps;
pub(super) use crate::spectral::{block_means, sine_tapers};
use octavar_stats::fit::{fit, fit_input, octave_oadev, FitOptions, FitPoint, Term};
use octavar_stats::{DataKind, Options, Series};

pub(super) fn mean(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    x.iter().sum::<f64>() / x.len() as f64
}

pub(super) use octavar_stats::robust::median;

/// The overlapping Allan variance at octave tau, with Greenhall EDFs, as fit points.
pub(super) fn oadev_points(x: &[f64], rate_hz: f64) -> Vec<FitPoint> {
    let Ok(s) = Series::new(x, DataKind::Frequency, 1.0 / rate_hz) else {
        return Vec::new();
    };
    octave_oadev(&s, Options::default().confidence).map(|rows| fit_input(&rows)).unwrap_or_default()
}

/// [`oadev_points`] of `x` with the runs `gaps` (filled in `x`) taken as gaps: a stretch filled by a line has no
/// noise, and would read the short-tau Allan deviation low by the share of the record it spans.
pub(super) fn gapped_oadev_points(x: &[f64], gaps: &[Range<usize>], rate_hz: f64) -> Vec<FitPoint> {
    if gaps.is_empty() {
        return oadev_points(x, rate_hz);
    }
    oadev_points(&with_gaps(x, gaps), rate_hz)
}

/// The samples of `x` outside the runs `gaps` (in order; the few differences across a join are the only ones
/// that span a gap).
pub(super) fn outside_gaps<'a>(x: &'a [f64], gaps: &[Range<usize>]) -> std::borrow::Cow<'a, [f64]> {
    if gaps.is_empty() {
        return std::borrow::Cow::Borrowed(x);
    }
    let mut out = Vec::with_capacity(x.len());
    let mut at = 0;
    for r in gaps {
        let (a, b) = (r.start.min(x.len()), r.end.min(x.len()));
        if a > at {
            out.extend_from_slice(&x[at..a]);
        }
        at = at.max(b);
    }
    out.extend_from_slice(&x[at.min(x.len())..]);
    std::borrow::Cow::Owned(out)
}

/// The IEEE fit (default options, the base's bandwidth) on a record cleaned of an effect's fitted component (the
/// step's data `d` otherwise): the base model with its Q, N, B, K, R replaced by the fitted terms of that fit (and
/// the variances of a Gauss-Markov process or a resonance it carries by theirs), and the fit's squares.
///
/// The rate ramp R enters only when the base fit has one: a ramp is a deterministic drift, and taking an
/// effect's component out of the record cannot create one. Where the re-fit found one anyway, it was the
/// remainder of an imperfectly fitted component at the last one or two Allan points (a sinusoid of a few
/// cycles per record whose amplitude is read 27% high), and a ramp extrapolated over the holdout is a gap of
/// its own.
///
/// `gaps` are the runs of samples that were missing or masked (filled in `cleaned`): the Allan deviation is taken
/// with them as gaps, as the base fit took it. The quantisation noise of the model's ADC lattice ([`less_known`])
/// is taken off the curve first, so that the IEEE terms do not absorb it a second time; a Gauss-Markov process or
/// a resonance the base already carries is fitted beside the terms ([`refit_beside_processes`]).
///
/// Where an earlier step took jumps out of the samples (bias steps, a bistable bias's levels: `d.shaped_dps`),
/// the samples carry that recovery's residue (a flip placed a sample late leaves a one-sample pulse), and the
/// model's base terms were fitted beside the process on the curve as recorded, where its Allan variance hides the
/// flicker beneath. The model is simulated whole and compared with the record as recorded, so there its terms
/// are re-fitted on its own base curve less what this effect's component takes out of the samples' curve
/// ([`less_taken_out`]); what the samples carry, for a generalised least-squares test, is [`refit_noise`]'s.
///
/// Elsewhere, where the component was fitted `t` standard errors from zero (a coupling's coefficient, a warm-up's
/// size, the weakest sinusoid's amplitude), the curve's points weigh less where the fit took noise out with it
/// ([`weighed_by_fit_error`]); `t` infinite for a component that was not fitted so (bias jumps' levels).
///
/// Where the model carries spikes an earlier step found, its white noise and quantisation stay as they are: that
/// step read them off the record's curve less the spikes' law, while the samples here lack only the spikes it
/// flagged, and the ones too small to flag (a mixture of 5-sigma spikes on 5% of the samples) are white noise on
/// their curve; a re-fit there puts them in N, and the model, which draws the whole law beside N, carries them
/// twice.
pub(super) fn refit_base(d: &TrainingData, cleaned: &[f64], t: f64) -> Option<(GyroSim, [f64; 5])> {
    let pts = gapped_oadev_points(cleaned, d.gaps, d.rate_hz);
    let pts = match d.shaped_dps {
        Some(_) => return ieee_refit(d.base, &less_taken_out(d, &pts), d.base.outliers.is_some()),
        None if t.is_finite() => weighed_by_fit_error(&pts, &gapped_oadev_points(d.rate_dps, d.gaps, d.rate_hz), t),
        None => pts,
    };
    match d.base.gauss_markov.is_some() || d.base.resonance.is_some() {
        true => refit_beside_processes(d, &pts),
        false => ieee_refit(
            d.base,
            &less_known(&pts, d.base, d.base.bandwidth_hz, d.rate_hz, d.lattice_dps),
            d.base.outliers.is_some(),
        ),
    }
}

/// [`refit_base`] where the model carries a Gauss-Markov process or a resonance: they are fitted beside the base
/// terms (GMWM's joint fit on the octave Allan variances), each variance free, the resonance's centre and Q held
/// (its own step read them off the spectrum), the process's time constant read again within a factor of
/// [`MARKOV_REREAD`] of the one it had (its step read it on a curve that still held the component this re-fit
/// takes out). Taken off the curve at the variance its own step read instead, a process leaves a small
/// difference of large numbers where it dominates: beside a Gauss-Markov process of 1.2 s, a temperature
/// coupling's re-fit read a flicker floor of 8.6e-3 deg/s out of it where the process's own joint fit read none,
/// and the Allan view went from 0.8 to 5.8. The ramp enters only where the model has one, as in [`ieee_refit`];
/// where the model carries spikes, its white noise and quantisation stay as they are (see [`refit_base`]).
fn refit_beside_processes(d: &TrainingData, pts: &[FitPoint]) -> Option<(GyroSim, [f64; 5])> {
    let (base, rate_hz, bw) = (d.base, d.rate_hz, d.base.bandwidth_hz);
    let known = GyroSim { gauss_markov: None, resonance: None, ..base.clone() };
    let pts = less_known(pts, &known, bw, rate_hz, d.lattice_dps);
    let mut cols = base_columns(&pts, rate_hz, bw, base.q_deg > 0.0);
    if base.r_dps_per_s == 0.0 {
        cols[3].iter_mut().for_each(|v| *v = 0.0);
    }
    if let Some(r) = &base.resonance {
        cols.push(
            pts.iter().map(|p| filtered_resonance_avar(r.freq_hz, r.q, bw, p.tau_s * rate_hz, rate_hz)).collect(),
        );
    }
    let resonance_col = base.resonance.as_ref().map(|_| cols.len() - 1);
    let keep = (1u32 << cols.len()) - (1 << BASE_COLS);
    let with_markov = |t: f64| {
        let mut c = cols.clone();
        c.push(pts.iter().map(|p| filtered_gm_avar(t, bw, p.tau_s, rate_hz)).collect());
        c
    };
    let (j, markov) = match base.gauss_markov {
        Some(g) => {
            let (lo, hi) = (g.tau_s / MARKOV_REREAD, g.tau_s * MARKOV_REREAD);
            let keep = keep | 1 << cols.len();
            let chi = |t: f64| joint_fit_keeping(&pts, &with_markov(t), keep).map_or(f64::INFINITY, |j| j.chi2);
            let (t, _) = log_search(lo.max(2.0 / rate_hz), hi.max(2.0 / rate_hz), 9, chi);
            let j = joint_fit_keeping(&pts, &with_markov(t), keep)?;
            let sigma = j.theta[cols.len()].max(0.0).sqrt();
            (j, Some(GaussMarkovSim { sigma_dps: sigma, tau_s: t }))
        }
        None => (joint_fit_keeping(&pts, &cols, keep)?, None),
    };
    let mut gyro = with_base_terms(base, &j.theta);
    gyro.gauss_markov = markov;
    if let (Some(r), Some(c)) = (gyro.resonance.as_mut(), resonance_col) {
        r.sigma_dps = j.theta[c].max(0.0).sqrt();
    }
    // The fit's squares in the IEEE fit's order (Q, N, B, K, R); the columns' order is N, B, K, R, Q.
    let t = &j.theta;
    let mut squares = [t[4], t[0], t[1], t[2], t[3]].map(|v| v.max(0.0));
    if base.outliers.is_some() {
        keep_white_noise(base, &mut gyro, &mut squares);
    }
    Some((gyro, squares))
}

/// How far either way of its step's time constant a Gauss-Markov process's is read again by [`refit_base`].
const MARKOV_REREAD: f64 = 3.0;

/// The IEEE fit on the curve of `cleaned` (the step's samples less an effect's component), less the effects the
/// model already carries ([`less_known`]): the noise those samples carry, which a generalised least-squares test
/// on them weighs its frequencies by. It is [`refit_base`]'s model except after a step that took jumps out.
pub(super) fn refit_noise(d: &TrainingData, cleaned: &[f64]) -> Option<(GyroSim, [f64; 5])> {
    let (base, rate_hz) = (d.base, d.rate_hz);
    let pts = gapped_oadev_points(cleaned, d.gaps, rate_hz);
    ieee_refit(base, &less_known_as_recorded(&pts, base, base.bandwidth_hz, rate_hz, d.lattice_dps), false)
}

/// The noise of the step's samples as they are: the model's base where they are the record less deterministic
/// parts, the IEEE fit of the samples themselves where jumps were taken out or an ADC lattice rounds them coarser
/// than white noise ([`refit_noise`]).
pub(super) fn samples_noise(d: &TrainingData) -> GyroSim {
    let recorded = d.shaped_dps.is_some() || coarse_lattice(d.base, d.rate_hz, d.lattice_dps);
    match recorded {
        true => refit_noise(d, d.rate_dps).map_or_else(|| d.base.clone(), |r| r.0),
        false => d.base.clone(),
    }
}

/// `base` with its IEEE terms fitted on `pts` (default options, its bandwidth; the ramp only where it has one);
/// `keep_white` keeps `base`'s N and Q in place of the fitted ones (the fit still has them, so that white noise on
/// the curve is not read as flicker).
fn ieee_refit(base: &GyroSim, pts: &[FitPoint], keep_white: bool) -> Option<(GyroSim, [f64; 5])> {
    let terms = Term::ALL.into_iter().filter(|t| *t != Term::R || base.r_dps_per_s != 0.0).collect();
    let opts = FitOptions { bandwidth_hz: base.bandwidth_hz, terms, ..Default::default() };
    let f = fit(pts, &opts).ok()?;
    let (mut gyro, mut squares) = (f.sim_terms(base.clone()), f.squares);
    if keep_white {
        keep_white_noise(base, &mut gyro, &mut squares);
    }
    Some((gyro, squares))
}

/// `gyro` and its fit's `squares` (Q, N, B, K, R) with `base`'s N and Q in place of the fitted ones: a model with
/// spikes keeps the white noise its spike step read ([`refit_base`]).
fn keep_white_noise(base: &GyroSim, gyro: &mut GyroSim, squares: &mut [f64; 5]) {
    (gyro.n_deg_per_rt_s, gyro.q_deg) = (base.n_deg_per_rt_s, base.q_deg);
    squares[Term::N as usize] = base.n_deg_per_rt_s.powi(2);
    squares[Term::Q as usize] = base.q_deg.powi(2);
}

/// The base terms' Allan variance under `d.base` at the points `cleaned` (the samples less an effect's component),
/// less what the component took out of the samples' curve there (`d.rate_dps`'s Allan variance less `cleaned`'s),
/// each point kept at no less than a tenth of the base curve.
fn less_taken_out(d: &TrainingData, cleaned: &[FitPoint]) -> Vec<FitPoint> {
    let before = gapped_oadev_points(d.rate_dps, d.gaps, d.rate_hz);
    let base = base_curve(d.base, cleaned, d.rate_hz);
    cleaned
        .iter()
        .zip(&base)
        .map(|(p, m)| {
            let model = m.avar;
            let taken = before.iter().find(|q| q.tau_s == p.tau_s).map_or(0.0, |q| q.avar - p.avar);
            FitPoint { avar: (model - taken).max(0.1 * model), ..*p }
        })
        .collect()
}

/// `x`, samples that bias jumps `shaped` were taken out of sharp, with those jumps taken out through the sensor's
/// first-order low-pass at `bandwidth_hz` instead, as the simulator passes them ([`LowPass`]): `x + s - lp(s')`,
/// where `s'` is `s` with each jump placed again where, through that filter, it fits the record
/// ([`jumps_placed_through_filter`]).
pub(crate) fn jumps_through_filter(x: &[f64], shaped: &[f64], bandwidth_hz: f64, rate_hz: f64) -> Vec<f64> {
    let placed = jumps_placed_through_filter(x, shaped, bandwidth_hz, rate_hz);
    let mut lp = LowPass::new(bandwidth_hz, rate_hz);
    x.iter().zip(shaped).zip(&placed).map(|((&v, &s), &p)| v + s - lp.next(p)).collect()
}

/// Farthest a jump is moved by [`jumps_placed_through_filter`], samples.
const MAX_JUMP_SHIFT: usize = 16;

/// `shaped` (piecewise-constant bias jumps taken out of `x` sharp) with each jump moved to the sample where, passed
/// through the first-order low-pass at `bandwidth_hz` (pole `a`), it best fits the record `x + shaped`: where the
/// record less the filtered jumps, `y`, has the least sum of squared innovations `y[i] - a y[i-1]` about their
/// mean over the jump's reach and the filter's settling after it. White noise through the filter has white
/// innovations, so this is the jump's least-squares place under the sensor's white noise; a constant bias adds the
/// same `(1 - a) bias` to each innovation (taken out with their mean: left in, it pulls every jump to whichever end
/// of its reach keeps the record less the jumps nearer zero), and a slow drift hardly enters them.
///
/// The scans that find jumps place each at the middle of its edge, and through a filter the edge's middle comes
/// the filter's delay after the jump: taken out a sample or two late, each jump leaves a filtered pulse of its own
/// size in the record, and a few hundred of them raise the short-tau variance by a tenth or more (a bistable bias
/// of 300 flips at 15 Hz read N 6% high beside a corner of 0.8 Hz). Each jump moves within twice the filter's
/// time constant (and two samples; at most [`MAX_JUMP_SHIFT`]) and no nearer its neighbours than a sample, the
/// jumps in time order, each against the ones before it as placed.
pub(super) fn jumps_placed_through_filter(x: &[f64], shaped: &[f64], bandwidth_hz: f64, rate_hz: f64) -> Vec<f64> {
    let n = shaped.len().min(x.len());
    let scale = shaped.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    // Realisations are differences of series, so equal levels may differ in the last bits.
    let tol = 1e-9 * scale;
    let edges: Vec<usize> = (1..n).filter(|&i| (shaped[i] - shaped[i - 1]).abs() > tol).collect();
    let mut placed = shaped.to_vec();
    if edges.is_empty() || !(bandwidth_hz > 0.0) {
        return placed;
    }
    let mut lp = LowPass::new(bandwidth_hz, rate_hz);
    let a = lp.pole();
    let time_constant = a / (1.0 - a).max(1e-12);
    let reach = ((2.0 * time_constant).ceil() as usize + 2).min(MAX_JUMP_SHIFT);
    let settle = (5.0 * time_constant).ceil().min(8.0 * MAX_JUMP_SHIFT as f64) as usize + 2;
    let record: Vec<f64> = x.iter().zip(shaped).map(|(v, s)| v + s).collect();
    let (mut done, mut last) = (0usize, 0usize);
    for (k, &e) in edges.iter().enumerate() {
        let next = edges.get(k + 1).copied().unwrap_or(n);
        let lo = e.saturating_sub(reach).max(last + 1);
        let hi = (e + reach).min(next - 1);
        // The filter's state at `lo`: the jumps before are placed.
        for &v in &placed[done..lo] {
            lp.next(v);
        }
        done = lo;
        let (before, after) = (placed[e - 1], placed[e]);
        let end = (hi + settle).min(n);
        let roughness = |p: usize| {
            let mut f = lp.clone();
            let mut prev = f64::NAN;
            let (mut count, mut sum, mut sum_sq) = (0.0, 0.0, 0.0);
            for i in lo..end {
                let s = match i {
                    i if i < p => before,
                    i if i <= hi => after,
                    i => placed[i],
                };
                let y = record[i] - f.next(s);
                let d = y - a * prev;
                if d.is_finite() {
                    count += 1.0;
                    sum += d;
                    sum_sq += d * d;
                }
                prev = y;
            }
            // About their mean: the bias's share `(1 - a) bias` is the same in every innovation.
            if count > 0.0 {
                sum_sq - sum * sum / count
            } else {
                0.0
            }
        };
        let best = (lo..=hi).map(|p| (p, roughness(p))).min_by(|a, b| a.1.total_cmp(&b.1)).map_or(e, |b| b.0);
        placed[lo..best].iter_mut().for_each(|v| *v = before);
        placed[best..=hi].iter_mut().for_each(|v| *v = after);
        last = best;
    }
    placed
}

/// The powers of `gyro`'s IEEE noise terms that stay in the samples, `[Q^2, N^2, B^2, K^2]`: deg^2, (deg/s)^2 s,
/// (deg/s)^2 and (deg/s)^2/s (the ramp is a trend, not noise).
pub(super) fn ieee_squares(gyro: &GyroSim) -> [f64; 4] {
    [gyro.q_deg, gyro.n_deg_per_rt_s, gyro.b_dps, gyro.k_dps_per_rt_s].map(|v| v * v)
}

pub(super) use octavar_stats::tails::normal_sf;

/// `P(X >= k)` for X binomial with `n` trials of probability 1/2 (a sign test's significance), summed in the log
/// domain.
pub(super) fn binomial_half_tail(n: usize, k: usize) -> f64 {
    let ln_half = -(n as f64) * std::f64::consts::LN_2;
    // ln C(n, j) from j = 0 up, summed from j = k.
    let (mut ln_c, mut sum) = (0.0f64, 0.0f64);
    for j in 0..=n {
        if j > 0 {
            ln_c += ((n - j + 1) as f64 / j as f64).ln();
        }
        if j >= k {
            sum += (ln_c + ln_half).exp();
        }
    }
    sum.min(1.0)
}

/// Golden-section minimisation of `f` on [lo, hi].
pub(super) fn golden(mut lo: f64, mut hi: f64, iters: usize, f: impl Fn(f64) -> f64) -> (f64, f64) {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let mut x1 = hi - g * (hi - lo);
    let mut x2 = lo + g * (hi - lo);
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..iters {
        if f1 <= f2 {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - g * (hi - lo);
            f1 = f(x1);
        } else {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + g * (hi - lo);
            f2 = f(x2);
        }
    }
    if f1 <= f2 {
        (x1, f1)
    } else {
        (x2, f2)
    }
}

/// Brent's minimisation of `f` on [lo, hi]: parabolic steps through the three best points where they fall inside
/// the bracket and shrink it, golden sections where not, until the minimum is placed to `tol` (absolute, in x) or
/// `max_evals` evaluations are spent. On a smooth minimum it needs a few evaluations where [`golden`] needs one per
/// factor 0.618 of the bracket; NaN counts as worse than any number.
pub(super) fn brent(lo: f64, hi: f64, tol: f64, max_evals: usize, f: impl Fn(f64) -> f64) -> (f64, f64) {
    const CGOLD: f64 = 0.381_966_011_250_105_1;
    let (mut a, mut b) = (lo.min(hi), lo.max(hi));
    let tol1 = tol.max(f64::EPSILON * (a.abs() + b.abs()));
    let tol2 = 2.0 * tol1;
    let mut x = a + CGOLD * (b - a);
    let (mut w, mut v) = (x, x);
    let mut fx = f(x);
    let (mut fw, mut fv) = (fx, fx);
    let (mut d, mut e) = (0.0f64, 0.0f64);
    for _ in 1..max_evals {
        let xm = 0.5 * (a + b);
        if (x - xm).abs() <= tol2 - 0.5 * (b - a) {
            break;
        }
        let mut parabolic = false;
        if e.abs() > tol1 {
            let r = (x - w) * (fx - fv);
            let mut q = (x - v) * (fx - fw);
            let mut p = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            }
            q = q.abs();
            let e_before = e;
            e = d;
            if p.abs() < (0.5 * q * e_before).abs() && p > q * (a - x) && p < q * (b - x) {
                d = p / q;
                let u = x + d;
                if u - a < tol2 || b - u < tol2 {
                    d = tol1.copysign(xm - x);
                }
                parabolic = true;
            }
        }
        if !parabolic {
            e = if x >= xm { a - x } else { b - x };
            d = CGOLD * e;
        }
        let u = if d.abs() >= tol1 { x + d } else { x + tol1.copysign(d) };
        let fu = f(u);
        if fu <= fx {
            if u >= x {
                a = x;
            } else {
                b = x;
            }
            (v, fv, w, fw, x, fx) = (w, fw, x, fx, u, fu);
        } else {
            if u < x {
                a = u;
            } else {
                b = u;
            }
            if fu <= fw || w == x {
                (v, fv, w, fw) = (w, fw, u, fu);
            } else if fu <= fv || v == x || v == w {
                (v, fv) = (u, fu);
            }
        }
    }
    (x, fx)
}

/// Whether `x`, found by [`log_search`] on `[lo, hi]` with `n` points, sits at `hi`: within a thousandth of a grid
/// step of it, so the criterion was still falling where the search stopped and the estimate is the search's bound,
/// not the data's. Such an estimate is not identified: past the bound, a filter corner above the Nyquist frequency
/// or a temperature lag longer than the record trades its value against the coefficient beside it.
pub(super) fn at_top(x: f64, lo: f64, hi: f64, n: usize) -> bool {
    let step = (hi / lo).ln() / (n - 1) as f64;
    (hi / x).ln() < 1e-3 * step
}

/// Whether `x`, found by [`log_search`] on `[lo, hi]` with `n` points, sits at `lo`: the mirror of [`at_top`]. A
/// Gauss-Markov time constant at the search's floor of two samples is not identified either: below it the process
/// is white noise to the curve, and what the fit took for it is the first octaves' shape from something else (a
/// corner, a lattice).
pub(super) fn at_bottom(x: f64, lo: f64, hi: f64, n: usize) -> bool {
    let step = (hi / lo).ln() / (n - 1) as f64;
    (x / lo).ln() < 1e-3 * step
}

/// Grid search over `ln x` on [lo, hi] (n points), then golden refinement between the best point's neighbours.
pub(super) fn log_search(lo: f64, hi: f64, n: usize, f: impl Fn(f64) -> f64) -> (f64, f64) {
    let (l0, l1) = (lo.ln(), hi.ln());
    let grid: Vec<f64> = (0..n).map(|i| l0 + (l1 - l0) * i as f64 / (n - 1) as f64).collect();
    let vals: Vec<f64> = grid.iter().map(|&u| f(u.exp())).collect();
    let (ib, _) = vals.iter().enumerate().min_by(|a, b| a.1.total_cmp(b.1)).unwrap_or((0, &f64::INFINITY));
    let a = grid[ib.saturating_sub(1)];
    let b = grid[(ib + 1).min(n - 1)];
    let (u, v) = golden(a, b, 24, |u| f(u.exp()));
    if v <= vals[ib] {
        (u.exp(), v)
    } else {
        (grid[ib].exp(), vals[ib])
    }
}

thread_local! {
    /// Each thread's FFT planner: rustfft keeps the plans it made, so a length planned once (a million-point
    /// transform builds its twiddles in about as long as it runs) is not planned again.
    static PLANNER: RefCell<FftPlanner<f64>> = RefCell::new(FftPlanner::new());
}

/// The forward FFT of `len` points, from this thread's planner.
pub(super) fn forward_plan(len: usize) -> Arc<dyn Fft<f64>> {
    PLANNER.with(|p| p.borrow_mut().plan_fft_forward(len))
}

/// In-place forward FFT of the complex sequence `re + i im` (rustfft; any length).
pub(super) fn fft(re: &mut [f64], im: &mut [f64]) {
    let mut buf: Vec<Complex<f64>> = re.iter().zip(im.iter()).map(|(&r, &i)| Complex::new(r, i)).collect();
    forward_plan(buf.len()).process(&mut buf);
    for ((r, i), c) in re.iter_mut().zip(im.iter_mut()).zip(&buf) {
        *r = c.re;
        *i = c.im;
    }
}

#[cfg(test)]
mod tests {
    use std::cell::Cell;

    use super::brent;

    /// `f` with a count of its evaluations.
    fn counted(f: impl Fn(f64) -> f64) -> (impl Fn(f64) -> f64, std::rc::Rc<Cell<usize>>) {
        let n = std::rc::Rc::new(Cell::new(0));
        let m = n.clone();
        (
            move |x| {
                m.set(m.get() + 1);
                f(x)
            },
            n,
        )
    }

    #[test]
    fn brent_places_a_smooth_minimum_in_few_evaluations() {
        // A smooth, asymmetric minimum at ln 2 (d/dx of exp(x) - 2x).
        let (f, evals) = counted(|x: f64| x.exp() - 2.0 * x);
        let (x, fx) = brent(-1.0, 3.0, 1e-9, 100, f);
        assert!((x - 2f64.ln()).abs() < 1e-8, "{x}");
        assert!((fx - (2.0 - 2.0 * 2f64.ln())).abs() < 1e-12);
        // Golden sections need ln(4e9 / 2) / ln(1 / 0.618) = 45 steps for the same bracket; Brent half as many.
        assert!(evals.get() <= 23, "{} evaluations", evals.get());
    }

    #[test]
    fn brent_falls_back_to_golden_sections_where_parabolas_fail() {
        // A kink (no parabola fits it), a minimum at the bracket's edge, and NaN on half the bracket.
        let (x, _) = brent(0.0, 1.0, 1e-7, 200, |x: f64| (x - 0.77).abs());
        assert!((x - 0.77).abs() < 1e-6, "{x}");
        let (x, _) = brent(0.0, 1.0, 1e-7, 200, |x: f64| x);
        assert!(x < 1e-6, "{x}");
        let (x, fx) = brent(0.0, 1.0, 1e-7, 200, |x: f64| if x > 0.5 { f64::NAN } else { (x - 0.2).powi(2) });
        assert!((x - 0.2).abs() < 1e-6 && fx.is_finite(), "{x} {fx}");
    }
}

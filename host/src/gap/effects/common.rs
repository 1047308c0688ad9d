//! Small helpers the estimators share: means and medians, block means, the octave OADEV as fit points, the
//! IEEE re-fit of a cleaned record, the normal tail, one-dimensional searches (golden section, log grid) and the
//! FFT.

use std::ops::Range;

use octavar_shared::sim::GyroSim;
use rustfft::num_complex::Complex;
use rustfft::FftPlanner;

use crate::fit::{fit, fit_input, octave_oadev, FitOptions, FitPoint, Term};
use crate::gap::fill::with_gaps;
pub(super) use crate::gap::spectral::{block_means, sine_tapers};
use crate::stats::{DataKind, Options, Series};

pub(super) fn mean(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    x.iter().sum::<f64>() / x.len() as f64
}

pub(super) use crate::stats::robust::median;

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

/// The IEEE fit (default options, the base's bandwidth) on a record cleaned of an effect's fitted component: the
/// base model with its Q, N, B, K, R replaced by the fitted terms of that fit, and the fit's squares.
///
/// The rate ramp R enters only when the base fit has one: a ramp is a deterministic drift, and taking an
/// effect's component out of the record cannot create one. Where the re-fit found one anyway, it was the
/// remainder of an imperfectly fitted component at the last one or two Allan points (a sinusoid of a few
/// cycles per record whose amplitude is read 27% high), and a ramp extrapolated over the holdout is a gap of
/// its own.
///
/// `gaps` are the runs of samples that were missing or masked (filled in `cleaned`): the Allan deviation is taken
/// with them as gaps, as the base fit took it.
pub(super) fn refit_base(
    base: &GyroSim,
    gaps: &[Range<usize>],
    cleaned: &[f64],
    rate_hz: f64,
) -> Option<(GyroSim, [f64; 5])> {
    let pts = gapped_oadev_points(cleaned, gaps, rate_hz);
    let terms = Term::ALL.into_iter().filter(|t| *t != Term::R || base.r_dps_per_s != 0.0).collect();
    let opts = FitOptions { bandwidth_hz: base.bandwidth_hz, terms, ..Default::default() };
    let f = fit(&pts, &opts).ok()?;
    Some((f.sim_terms(base.clone()), f.squares))
}

/// The standard normal upper tail.
pub(super) fn normal_sf(z: f64) -> f64 {
    0.5 * statrs::function::erf::erfc(z / std::f64::consts::SQRT_2)
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

/// In-place forward FFT of the complex sequence `re + i im` (rustfft; any length).
pub(super) fn fft(re: &mut [f64], im: &mut [f64]) {
    let mut buf: Vec<Complex<f64>> = re.iter().zip(im.iter()).map(|(&r, &i)| Complex::new(r, i)).collect();
    FftPlanner::new().plan_fft_forward(buf.len()).process(&mut buf);
    for ((r, i), c) in re.iter_mut().zip(im.iter_mut()).zip(&buf) {
        *r = c.re;
        *i = c.im;
    }
}

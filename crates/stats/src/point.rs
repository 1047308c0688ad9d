//! One row of a deviation table: the options that shape it, the row itself ([`DevPoint`]) and how a row is built
//! from an estimate (noise type, Greenhall's EDF, the chi-square interval). Shared by the table of
//! [`super::analysis`] and the octave path of [`super::octave`].

use super::deviation::{RawDeviation, Statistic};
use super::edf::{confidence_interval, greenhall_edf, totdev_edf};
use super::noise_id::NoiseMethod;

/// How to choose the noise type behind each confidence interval.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoiseSpec {
    /// Identify it at every tau (lag-1 autocorrelation, B1/R(n) fallback).
    Auto,
    /// Use this alpha everywhere (2 white PM ... -4 random run FM).
    Fixed(i32),
}

/// Analysis options.
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// Two-sided confidence of the interval; Stable32's default confidence factor is 0.683.
    pub confidence: f64,
    /// Noise type for the EDF.
    pub noise: NoiseSpec,
    /// Compute the taus in parallel (rayon).
    pub parallel: bool,
    /// Compute noise type, EDF and interval (off: deviations and counts only, fastest).
    pub intervals: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options { confidence: 0.683, noise: NoiseSpec::Auto, parallel: true, intervals: true }
    }
}

/// One row of the result.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DevPoint {
    /// Averaging factor.
    pub m: u64,
    /// tau = m tau0, seconds.
    pub tau_s: f64,
    /// Number of terms averaged (Stable32's `#`).
    pub n: u64,
    /// Samples between the starts of consecutive terms: 1 for the overlapping statistics, m for the
    /// non-overlapping ones, m / S for an octave accumulator of stride S.
    pub stride: u64,
    /// The deviation.
    pub dev: f64,
    /// Noise type used for the interval (power-law alpha of S_y); 0 when intervals are off.
    pub alpha: i32,
    /// How alpha was obtained.
    pub noise_method: NoiseMethod,
    /// Equivalent degrees of freedom (NaN when intervals are off or the EDF is undefined).
    pub edf: f64,
    /// Lower bound of the interval (NaN when not computed).
    pub lo: f64,
    /// Upper bound of the interval (NaN when not computed).
    pub hi: f64,
}

/// One row at averaging factor m of a record of `n_phase` points; `identify` gives the noise type when it is
/// identified.
pub(crate) fn row(
    m: usize,
    tau0_s: f64,
    n_phase: usize,
    stat: Statistic,
    est: RawDeviation,
    opts: &Options,
    identify: impl FnOnce() -> (i32, NoiseMethod),
) -> DevPoint {
    let mut p = DevPoint {
        m: m as u64,
        tau_s: m as f64 * tau0_s,
        n: est.n as u64,
        stride: stat.stride(m) as u64,
        dev: est.dev,
        alpha: 0,
        noise_method: NoiseMethod::Default,
        edf: f64::NAN,
        lo: f64::NAN,
        hi: f64::NAN,
    };
    if !opts.intervals {
        return p;
    }
    let (alpha, method) = match opts.noise {
        NoiseSpec::Fixed(a) => (a, NoiseMethod::Fixed),
        NoiseSpec::Auto => identify(),
    };
    p.alpha = alpha;
    p.noise_method = method;
    p.edf = edf_for(stat, alpha, m as f64, n_phase as f64);
    let (lo, hi) = confidence_interval(est.dev, p.edf, opts.confidence);
    p.lo = lo;
    p.hi = hi;
    p
}

/// The EDF Stable32 uses for `stat` at averaging factor m with `n_phase` phase points and noise type alpha.
pub fn edf_for(stat: Statistic, alpha: i32, m: f64, n_phase: f64) -> f64 {
    match stat {
        Statistic::Adev => greenhall_edf(alpha, 2, m, m, 1.0, n_phase),
        Statistic::Oadev => greenhall_edf(alpha, 2, m, m, m, n_phase),
        Statistic::Mdev | Statistic::Tdev => greenhall_edf(alpha, 2, m, 1.0, m, n_phase),
        Statistic::Hdev => greenhall_edf(alpha, 3, m, m, 1.0, n_phase),
        Statistic::Ohdev => greenhall_edf(alpha, 3, m, m, m, n_phase),
        Statistic::Totdev => totdev_edf(alpha, m, n_phase),
    }
}

/// EDF of an Allan variance whose clusters start every m/S samples (the octave accumulator's stride S: S = 1
/// non-overlapping, S = m fully overlapping), from `n_phase` phase points.
pub fn strided_avar_edf(alpha: i32, m: f64, stride_factor: f64, n_phase: f64) -> f64 {
    greenhall_edf(alpha, 2, m, m, stride_factor.clamp(1.0, m), n_phase)
}

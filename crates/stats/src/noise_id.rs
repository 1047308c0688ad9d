//! Power-law noise identification at each averaging factor: the alpha that picks the EDF.
//!
//! Primary method: the lag-1 autocorrelation (W. J. Riley and C. A. Greenhall, "Power law noise identification
//! using the lag 1 autocorrelation", Proc. 18th EFTF, 2004), as allantools' `autocorr_noise_id` does it: phase
//! data are decimated by m and lose a quadratic fit, frequency data are averaged in blocks of m and lose a linear
//! fit; then with r1 the lag-1 autocorrelation and `delta = r1 / (1 + r1)`, the series is differenced until
//! `delta < 0.25` or d reaches dmax (2 for the Allan family, 3 for Hadamard), and
//! `alpha = -round(2 delta) - 2 d` (+2 for phase data). It needs at least 30 points after decimation.
//!
//! Fallback for fewer points (large m), as Stable32: the B1 bias ratio (Barnes; Howe et al.; NIST SP 1065
//! section 5.6) of the standard variance of the m-averages to the Allan variance, compared with its expected value
//! for each power law (boundaries at geometric means), and for the white/flicker PM pair the R(n) = MVAR/AVAR ratio.
//!
//! Gaps: NaN points stay NaN after decimation, an average over a block holding a NaN is NaN, fits and
//! correlations use only the valid points (and pairs).

use super::deviation::{deviation_at, Statistic};
use super::series::{DataKind, Series};

/// The least number of points the lag-1 autocorrelation method is used with.
pub const ACF_MIN_POINTS: usize = 30;

/// How the noise type was identified.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoiseMethod {
    /// Lag-1 autocorrelation.
    Acf,
    /// B1 bias ratio (with R(n) for PM noise).
    B1,
    /// Given by the caller.
    Fixed,
    /// Could not be identified (too few points): white FM assumed.
    Default,
}

/// Records with more averages than this at an averaging factor are identified on [`ACF_RUNS`] runs of
/// [`ACF_RUN`] consecutive averages spread evenly over the record (the standard error of r1 is then about 0.004,
/// far inside the decision margins); every record of the Stable32 tables is below it and uses all its points.
pub const ACF_FULL_MAX: usize = 1 << 18;
/// Runs of the subsampled lag-1 autocorrelation.
pub const ACF_RUNS: usize = 16;
/// Averages per run of the subsampled lag-1 autocorrelation.
pub const ACF_RUN: usize = 4096;

/// The lag-1 autocorrelation estimate: integer alpha (rounded), the continuous estimate, and the differences taken.
///
/// Above [`ACF_FULL_MAX`] averages, the runs are detrended and differenced each on its own, and r1 pools their
/// lag products and squares.
pub fn acf_noise_id(series: &Series, m: usize, dmax: u32) -> Option<(i32, f64)> {
    let m = m.max(1);
    let x = &series.x;
    let total = match series.kind {
        DataKind::Phase => x.len().div_ceil(m),
        DataKind::Frequency => (x.len() - 1) / m,
    };
    acf_noise_id_from(series.kind, total, dmax, |j0, j1| averages(series, m, j0, j1))
}

/// As [`acf_noise_id`], with `total` points at the averaging factor and `averages(j0, j1)` giving points j0..j1
/// (what `averages` gives for a [`Series`]).
pub(crate) fn acf_noise_id_from(
    kind: DataKind,
    total: usize,
    dmax: u32,
    averages: impl Fn(usize, usize) -> Vec<f64>,
) -> Option<(i32, f64)> {
    if total < ACF_MIN_POINTS {
        return None;
    }
    let runs: Vec<(usize, usize)> = if total <= ACF_FULL_MAX {
        vec![(0, total)]
    } else {
        (0..ACF_RUNS).map(|r| (r * (total - ACF_RUN) / (ACF_RUNS - 1), ACF_RUN)).map(|(a, n)| (a, a + n)).collect()
    };
    let deg = if kind == DataKind::Phase { 2 } else { 1 };
    let mut vs: Vec<Vec<f64>> = runs
        .iter()
        .map(|&(j0, j1)| {
            let mut v = averages(j0, j1);
            detrend(&mut v, deg);
            v
        })
        .collect();
    let mut d = 0u32;
    loop {
        let r1 = pooled_lag1_acf(&vs);
        let rho = r1 / (1.0 + r1);
        if rho < 0.25 || d >= dmax || vs.iter().any(|v| v.len() < 3) {
            let add = if kind == DataKind::Phase { 2.0 } else { 0.0 };
            let p = -2.0 * (rho + d as f64);
            let alpha_int = (-(2.0 * rho).round_ties_even() - 2.0 * d as f64 + add) as i32;
            return Some((alpha_int, p + add));
        }
        // Difference in place.
        for v in &mut vs {
            for k in 0..v.len() - 1 {
                v[k] = v[k + 1] - v[k];
            }
            v.pop();
        }
        d += 1;
    }
}

/// Points j0..j1 of the series the ACF method looks at, at averaging factor m: phase decimated by m (a missing
/// point stays missing), or frequency averaged over blocks of m samples (a block touching a gap is missing).
fn averages(series: &Series, m: usize, j0: usize, j1: usize) -> Vec<f64> {
    let x = &series.x;
    match series.kind {
        DataKind::Phase => (j0..j1).map(|j| j * m).map(|k| if series.is_gap(k) { f64::NAN } else { x[k] }).collect(),
        DataKind::Frequency => {
            let scale = 1.0 / (m as f64 * series.tau0_s);
            let bad = series.bad.as_deref();
            (j0..j1)
                .map(|b| {
                    let (k0, k1) = (b * m, b * m + m);
                    if bad.is_some_and(|bb| !Series::valid(bb, series.kind, k0, k1)) {
                        f64::NAN
                    } else {
                        (x[k1] - x[k0]) * scale
                    }
                })
                .collect()
        }
    }
}

/// Lag-1 autocorrelation pooled over runs (each with its own mean): the sum of their lag products over the sum
/// of their squares. One run: the plain lag-1 autocorrelation.
fn pooled_lag1_acf(vs: &[Vec<f64>]) -> f64 {
    let (mut a, mut b) = (0.0, 0.0);
    for v in vs {
        let (x, y) = lag1_sums(v);
        a += x;
        b += y;
    }
    a / b
}

/// The lag-1 product sum and the sum of squares of `x` less its mean (Riley & Greenhall 2004 eq. 2: their ratio is
/// the lag-1 autocorrelation); NaNs skipped.
fn lag1_sums(x: &[f64]) -> (f64, f64) {
    let (s, n) = x.iter().filter(|v| !v.is_nan()).fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    let mu = s / n as f64;
    let (mut a, mut b) = (0.0, 0.0);
    let mut prev = f64::NAN;
    for &v in x {
        let c = v - mu;
        if !c.is_nan() {
            b += c * c;
            if !prev.is_nan() {
                a += prev * c;
            }
        }
        prev = c;
    }
    (a, b)
}

/// Remove the least-squares polynomial of degree `deg` (1 or 2) in the index, fitted to the non-NaN points.
fn detrend(x: &mut [f64], deg: usize) {
    let n = x.len();
    if n < deg + 1 {
        return;
    }
    // Normalised abscissa in [-1, 1] keeps the normal equations well conditioned.
    let half = (n - 1) as f64 / 2.0;
    let t = |i: usize| if half > 0.0 { (i as f64 - half) / half } else { 0.0 };
    let k = deg + 1;
    let mut ata = [[0.0f64; 3]; 3];
    let mut atb = [0.0f64; 3];
    for (i, &v) in x.iter().enumerate() {
        if v.is_nan() {
            continue;
        }
        let ti = t(i);
        let p = [1.0, ti, ti * ti];
        for r in 0..k {
            atb[r] += p[r] * v;
            for c in 0..k {
                ata[r][c] += p[r] * p[c];
            }
        }
    }
    let a = ata[..k].iter().map(|row| row[..k].to_vec()).collect();
    let Some(coef) = super::linalg::solve(a, atb[..k].to_vec(), 0.0) else { return };
    for (i, v) in x.iter_mut().enumerate() {
        let ti = t(i);
        let p = [1.0, ti, ti * ti];
        let fit: f64 = (0..k).map(|r| coef[r] * p[r]).sum();
        *v -= fit;
    }
}

/// Expected B1 ratio for `n` averages and tau exponent `mu` of the Allan variance (Howe, Beard, Greenhall,
/// Riley 2000, Table 3; allantools `b1_theory`).
fn b1_theory(n: f64, mu: i32) -> f64 {
    match mu {
        2 => n * (n + 1.0) / 6.0,
        1 => n / 2.0,
        0 => n * n.ln() / (2.0 * (n - 1.0) * 2f64.ln()),
        -1 => 1.0,
        -2 => (n * n - 1.0) / (1.5 * n * (n - 1.0)),
        _ => {
            let muf = mu as f64;
            n * (1.0 - n.powf(muf)) / (2.0 * (n - 1.0) * (1.0 - 2f64.powf(muf)))
        }
    }
}

/// Expected R(n) = MVAR/AVAR for white PM (`b = 0`) and flicker PM (`b = -1`), after IEEE 1139 and allantools
/// `rn_theory` (flicker PM with f_h = 1/(2 tau0)).
fn rn_theory(m: f64, b: i32) -> f64 {
    match b {
        0 => 1.0 / m,
        -1 => {
            let pi = std::f64::consts::PI;
            let avar = (1.038 + 3.0 * (2.0 * pi * 0.5 * m).ln()) / (4.0 * pi * pi);
            let mvar = 3.0 * (256.0f64 / 27.0).ln() / (8.0 * pi * pi);
            mvar / avar
        }
        _ => 1.0,
    }
}

/// B1 / R(n) noise identification at averaging factor m; `avar_stat` is the Allan-type statistic whose variance
/// is the denominator (non-overlapping or overlapping), `min_alpha` the most divergent alpha allowed.
pub fn b1_noise_id(series: &Series, m: usize, avar_stat: Statistic, min_alpha: i32) -> Option<i32> {
    b1_noise_id_with(series, m, avar_stat, min_alpha, None)
}

/// As [`b1_noise_id`], given the deviation of `avar_stat` at m when the caller already has it (it is not
/// computed again).
pub fn b1_noise_id_with(
    series: &Series,
    m: usize,
    avar_stat: Statistic,
    min_alpha: i32,
    known_dev: Option<f64>,
) -> Option<i32> {
    // Standard variance of the frequency averages over m.
    let x = &series.x;
    let tau = m as f64 * series.tau0_s;
    let mut ybar = Vec::new();
    let mut k = 0;
    while k + m < x.len() {
        let ok = series.bad.as_deref().is_none_or(|b| Series::valid(b, series.kind, k, k + m));
        if ok {
            ybar.push((x[k + m] - x[k]) / tau);
        }
        k += m;
    }
    let avar_dev = || match known_dev {
        Some(d) => Some(d),
        None => deviation_at(series, avar_stat, m).map(|e| e.dev),
    };
    let oavar = || match (avar_stat, known_dev) {
        (Statistic::Oadev, Some(d)) => Some(d * d),
        _ => deviation_at(series, Statistic::Oadev, m).map(|e| e.dev.powi(2)),
    };
    b1_decide(
        &ybar,
        m,
        min_alpha,
        avar_dev,
        oavar,
        || series.mvar_coarse(m),
        || deviation_at(series, Statistic::Mdev, m).map(|e| e.dev.powi(2)),
    )
}

/// The B1 / R(n) decision from the frequency averages `ybar` at m: `avar_dev` gives the Allan deviation of the
/// denominator, `oavar` the overlapping Allan variance, `mvar_coarse` a cheap strided MVAR when there is one
/// (tried first) and `mvar` the exact MVAR (each asked only when needed).
pub(crate) fn b1_decide(
    ybar: &[f64],
    m: usize,
    min_alpha: i32,
    avar_dev: impl FnOnce() -> Option<f64>,
    oavar: impl FnOnce() -> Option<f64>,
    mvar_coarse: impl FnOnce() -> Option<f64>,
    mvar: impl FnOnce() -> Option<f64>,
) -> Option<i32> {
    let nb = ybar.len();
    if nb < 3 {
        return None;
    }
    let mean = ybar.iter().sum::<f64>() / nb as f64;
    let var = ybar.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (nb as f64 - 1.0);
    let avar_dev = avar_dev()?;
    let avar = avar_dev.powi(2);
    if !(avar > 0.0) {
        return None;
    }
    let b1 = var / avar;
    let n = nb as f64;
    // mu from -2 (PM) up to the most divergent allowed; alpha = -mu - 1 for mu >= -1.
    let mu_max = -min_alpha - 1;
    let mut mu = -2;
    for cand in -1..=mu_max {
        let boundary = (b1_theory(n, cand) * b1_theory(n, cand - 1)).sqrt();
        if b1 > boundary {
            mu = cand;
        }
    }
    if mu >= -1 {
        return Some(-mu - 1);
    }
    // White or flicker PM: R(n) = MVAR / AVAR.
    if m == 1 {
        return Some(2);
    }
    let oavar = oavar()?;
    let boundary = (rn_theory(m as f64, 0) * rn_theory(m as f64, -1)).sqrt();
    // A long record first tries MVAR from its coarse window sums (strided, cheap); only a ratio within 10% of the
    // boundary takes the exact MVAR.
    if let Some(mvar) = mvar_coarse() {
        let rn = mvar / oavar;
        if (rn / boundary).ln().abs() > 0.1 {
            return Some(if rn > boundary { 1 } else { 2 });
        }
    }
    let mvar = mvar()?;
    let rn = mvar / oavar;
    Some(if rn > boundary { 1 } else { 2 })
}
/// The noise type at averaging factor m for the interval of `stat`, and how it was found.
pub fn identify(series: &Series, stat: Statistic, m: usize) -> (i32, NoiseMethod) {
    identify_with(series, stat, m, None)
}

/// As [`identify`], given the deviation of `stat` at m when it is known (saves a pass over the record).
pub(crate) fn identify_with(series: &Series, stat: Statistic, m: usize, dev: Option<f64>) -> (i32, NoiseMethod) {
    let d = stat.difference_order();
    let min_alpha = if d == 3 { -4 } else { -2 };
    if let Some((a, _)) = acf_noise_id(series, m, d) {
        return (a.clamp(min_alpha, 2), NoiseMethod::Acf);
    }
    let avar_stat = match stat {
        Statistic::Adev | Statistic::Hdev => Statistic::Adev,
        _ => Statistic::Oadev,
    };
    // The deviation is the B1 denominator's when the statistic is that Allan variance itself.
    let known = dev.filter(|_| stat == avar_stat);
    match b1_noise_id_with(series, m, avar_stat, min_alpha, known) {
        Some(a) => (a.clamp(min_alpha, 2), NoiseMethod::B1),
        None => (0, NoiseMethod::Default),
    }
}

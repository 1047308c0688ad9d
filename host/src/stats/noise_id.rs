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

use super::deviation::{estimate, Statistic};
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

/// The lag-1 autocorrelation estimate: integer alpha (rounded), the continuous estimate, and the differences taken.
pub fn acf_noise_id(series: &Series, m: usize, dmax: u32) -> Option<(i32, f64)> {
    let m = m.max(1);
    let x = &series.x;
    let mut v: Vec<f64> = match series.kind {
        // Phase decimated by m (a missing point stays missing).
        DataKind::Phase => {
            (0..x.len()).step_by(m).map(|k| if series.is_gap(k) { f64::NAN } else { x[k] }).collect()
        }
        // Frequency averaged over blocks of m samples (cut to whole blocks); a block touching a gap is missing.
        DataKind::Frequency => {
            let scale = 1.0 / (m as f64 * series.tau0_s);
            let blocks = (x.len() - 1) / m;
            let bad = series.bad.as_deref();
            (0..blocks)
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
    };
    if v.len() < ACF_MIN_POINTS {
        return None;
    }
    let deg = if series.kind == DataKind::Phase { 2 } else { 1 };
    detrend(&mut v, deg);
    let mut d = 0u32;
    loop {
        let r1 = lag1_acf(&v);
        let rho = r1 / (1.0 + r1);
        if rho < 0.25 || d >= dmax {
            let add = if series.kind == DataKind::Phase { 2.0 } else { 0.0 };
            let p = -2.0 * (rho + d as f64);
            let alpha_int = (-(2.0 * rho).round_ties_even() - 2.0 * d as f64 + add) as i32;
            return Some((alpha_int, p + add));
        }
        // Difference in place.
        for k in 0..v.len() - 1 {
            v[k] = v[k + 1] - v[k];
        }
        v.pop();
        d += 1;
    }
}

/// Lag-1 autocorrelation with the mean removed (Riley & Greenhall 2004 eq. 2); NaNs skipped.
fn lag1_acf(x: &[f64]) -> f64 {
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
    a / b
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
    let Some(coef) = solve(ata, atb, k) else { return };
    for (i, v) in x.iter_mut().enumerate() {
        let ti = t(i);
        let p = [1.0, ti, ti * ti];
        let fit: f64 = (0..k).map(|r| coef[r] * p[r]).sum();
        *v -= fit;
    }
}

/// Gaussian elimination with partial pivoting on a k x k system (k <= 3).
fn solve(mut a: [[f64; 3]; 3], mut b: [f64; 3], k: usize) -> Option<[f64; 3]> {
    for col in 0..k {
        let piv = (col..k).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[piv][col] == 0.0 {
            return None;
        }
        a.swap(col, piv);
        b.swap(col, piv);
        for r in col + 1..k {
            let f = a[r][col] / a[col][col];
            for c in col..k {
                a[r][c] -= f * a[col][c];
            }
            b[r] -= f * b[col];
        }
    }
    let mut x = [0.0; 3];
    for r in (0..k).rev() {
        let s: f64 = (r + 1..k).map(|c| a[r][c] * x[c]).sum();
        x[r] = (b[r] - s) / a[r][r];
    }
    Some(x)
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
    let nb = ybar.len();
    if nb < 3 {
        return None;
    }
    let mean = ybar.iter().sum::<f64>() / nb as f64;
    let var = ybar.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (nb as f64 - 1.0);
    let avar = estimate(series, avar_stat, m)?.dev.powi(2);
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
    let mvar = estimate(series, Statistic::Mdev, m)?.dev.powi(2);
    let oavar = estimate(series, Statistic::Oadev, m)?.dev.powi(2);
    let rn = mvar / oavar;
    let boundary = (rn_theory(m as f64, 0) * rn_theory(m as f64, -1)).sqrt();
    Some(if rn > boundary { 1 } else { 2 })
}

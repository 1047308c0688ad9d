//! The estimators: ADEV, OADEV, MDEV, TDEV, HDEV, OHDEV and TOTDEV at one averaging factor, in O(N) each.
//!
//! Definitions as NIST SP 1065 (W. J. Riley, 2008) and allantools, on N phase points x (see [`super::series`]):
//! - ADEV (eq. 7) / OADEV (eq. 11): `sum (x[i+2m] - 2x[i+m] + x[i])^2 / (2 n tau^2)`, stride m / stride 1,
//!   n = floor((N-1)/m) - 1 / N - 2m;
//! - MDEV (eq. 14): `sum (sum_{i=j}^{j+m-1} x[i+2m] - 2x[i+m] + x[i])^2 / (2 m^2 n tau^2)`, n = N - 3m + 1, with
//!   the inner sums as running sums of third differences ([`super::modified`]; with gaps, from double-double
//!   prefix sums), O(1) per term; TDEV = tau MDEV / sqrt(3) (eq. 15);
//! - HDEV (eq. 18) / OHDEV (eq. 20): `sum (x[i+3m] - 3x[i+2m] + 3x[i+m] - x[i])^2 / (6 n tau^2)`, stride m / 1,
//!   n = floor((N-1)/m) - 2 / N - 3m;
//! - TOTDEV (eq. 25): OADEV's terms over the record extended at both ends by odd reflection
//!   (`x*[-j] = 2x[0] - x[j]`, `x*[N-1+j] = 2x[N-1] - x[N-1-j]`), i = 1..N-2, n = N - 2.
//!
//! The term counts are Stable32's `#` column. With gaps, terms touching a gap are skipped and n counts the rest.

use rayon::prelude::*;

use super::kernel::{oadev_sums, sumsq_o2, sumsq_o3, BLOCK, FEW_BLOCKS, LEVEL_GROUP};
use super::modified::mdev_sums;
use super::ordered::ordered_sums;
use super::series::Series;
use super::total::totdev_sums;

/// A statistic of the Allan family.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Statistic {
    /// Non-overlapping Allan deviation.
    Adev,
    /// Fully overlapping Allan deviation.
    Oadev,
    /// Modified Allan deviation.
    Mdev,
    /// Time deviation (seconds for phase in seconds): tau MDEV / sqrt(3).
    Tdev,
    /// Non-overlapping Hadamard deviation.
    Hdev,
    /// Fully overlapping Hadamard deviation.
    Ohdev,
    /// Total deviation.
    Totdev,
}

impl Statistic {
    /// Every statistic, in table order.
    pub const ALL: [Statistic; 7] = [
        Statistic::Adev,
        Statistic::Oadev,
        Statistic::Mdev,
        Statistic::Tdev,
        Statistic::Hdev,
        Statistic::Ohdev,
        Statistic::Totdev,
    ];

    /// Upper-case short name as in Stable32 and allantools (ADEV, OADEV, ...).
    pub fn name(self) -> &'static str {
        match self {
            Statistic::Adev => "ADEV",
            Statistic::Oadev => "OADEV",
            Statistic::Mdev => "MDEV",
            Statistic::Tdev => "TDEV",
            Statistic::Hdev => "HDEV",
            Statistic::Ohdev => "OHDEV",
            Statistic::Totdev => "TOTDEV",
        }
    }

    /// Samples between the starts of consecutive terms at averaging factor m: m for the non-overlapping
    /// statistics, 1 for the overlapping ones.
    pub fn stride(self, m: usize) -> usize {
        match self {
            Statistic::Adev | Statistic::Hdev => m,
            Statistic::Oadev | Statistic::Mdev | Statistic::Tdev | Statistic::Ohdev | Statistic::Totdev => 1,
        }
    }

    /// Stable32's stop ratio: generated tau lists end at m <= N_freq / ratio (see [`super::taus`]).
    pub fn stop_ratio(self) -> u64 {
        match self {
            Statistic::Adev | Statistic::Hdev => 5,
            Statistic::Oadev | Statistic::Mdev | Statistic::Tdev | Statistic::Ohdev => 4,
            Statistic::Totdev => 2,
        }
    }

    /// Order of the phase difference: 2 for the Allan family, 3 for Hadamard.
    pub fn difference_order(self) -> u32 {
        match self {
            Statistic::Hdev | Statistic::Ohdev => 3,
            _ => 2,
        }
    }

    /// Number of terms for `n_phase` points at averaging factor m, for a record without gaps (Stable32's `#`).
    /// 0 when m is too large.
    pub fn terms(self, n_phase: usize, m: usize) -> usize {
        let n = n_phase as i64;
        let mi = m as i64;
        let t = match self {
            Statistic::Adev => (n - 1) / mi - 1,
            Statistic::Oadev => n - 2 * mi,
            Statistic::Mdev | Statistic::Tdev => n - 3 * mi + 1,
            Statistic::Hdev => (n - 1) / mi - 2,
            Statistic::Ohdev => n - 3 * mi,
            Statistic::Totdev => {
                if mi <= n - 2 {
                    n - 2
                } else {
                    0
                }
            }
        };
        t.max(0) as usize
    }

    /// The largest m with at least one term.
    pub(crate) fn m_limit(self, n_phase: usize) -> u64 {
        let n = n_phase as u64;
        match self {
            Statistic::Adev | Statistic::Oadev => (n - 1) / 2,
            Statistic::Mdev | Statistic::Tdev | Statistic::Hdev | Statistic::Ohdev => (n - 1) / 3,
            Statistic::Totdev => n.saturating_sub(2),
        }
    }
}

/// A deviation before its interval: the value and the number of terms averaged.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RawDeviation {
    /// The deviation (frequency units; TDEV in the phase's time unit).
    pub dev: f64,
    /// Number of terms averaged.
    pub n: usize,
}

/// The estimate of `stat` at averaging factor `m`, or None when no term can be formed.
pub fn deviation_at(series: &Series, stat: Statistic, m: usize) -> Option<RawDeviation> {
    if m == 0 {
        return None;
    }
    let (sum, n) = match stat {
        Statistic::Adev => diff_sumsq(series, m, m, 2),
        Statistic::Oadev => diff_sumsq(series, m, 1, 2),
        Statistic::Hdev => diff_sumsq(series, m, m, 3),
        Statistic::Ohdev => diff_sumsq(series, m, 1, 3),
        Statistic::Mdev | Statistic::Tdev if series.bad.is_none() => {
            (mdev_sums(&series.x, &[m])[0], stat.terms(series.n_phase(), m))
        }
        Statistic::Mdev | Statistic::Tdev => mod_sumsq(series, m),
        Statistic::Totdev if series.bad.is_none() => (totdev_sums(&series.x, &[m])[0], stat.terms(series.n_phase(), m)),
        Statistic::Totdev => tot_sumsq(series, m),
    };
    from_sum(stat, m, series.tau0_s, sum, n)
}

/// The deviation from the sum of the squared terms and their number n (None when n is 0).
pub(crate) fn from_sum(stat: Statistic, m: usize, tau0_s: f64, sum: f64, n: usize) -> Option<RawDeviation> {
    if n == 0 {
        return None;
    }
    let tau = m as f64 * tau0_s;
    let norm = match stat {
        Statistic::Adev | Statistic::Oadev | Statistic::Totdev => 2.0,
        Statistic::Hdev | Statistic::Ohdev => 6.0,
        Statistic::Mdev | Statistic::Tdev => 2.0 * (m as f64) * (m as f64),
    };
    let mut dev = (sum / (norm * n as f64)).sqrt() / tau;
    if stat == Statistic::Tdev {
        dev *= tau / 3f64.sqrt();
    }
    Some(RawDeviation { dev, n })
}

/// The estimates at many averaging factors, each in one pass over the record shared by all of them where the
/// statistic allows: OADEV from the cache-blocked multi-level kernel (and the sums taken while the series was
/// built), OHDEV from cache-blocked passes, MDEV and TDEV from running sums ([`super::modified`]), TOTDEV from
/// OADEV's kernel and the reflected ends ([`super::total`]). ADEV and HDEV (O(N/m) each) and records with gaps
/// take one pass per m. Returns None for an m without terms.
pub fn deviations_at(series: &Series, stat: Statistic, ms: &[usize]) -> Vec<Option<RawDeviation>> {
    if series.bad.is_some() || ms.contains(&0) || matches!(stat, Statistic::Adev | Statistic::Hdev) {
        return ms.par_iter().map(|&m| deviation_at(series, stat, m)).collect();
    }
    let x = &series.x;
    let n_phase = x.len();
    let sums = match stat {
        Statistic::Oadev => {
            // Sums taken while the series was built are reused (sorted by m); the rest is summed here.
            let fused = |m: usize| {
                let f = &series.oadev_fused;
                f.binary_search_by_key(&m, |e| e.0).ok().map(|k| f[k].1)
            };
            let rest: Vec<usize> = ms.iter().map(|&m| if fused(m).is_some() { 0 } else { m }).collect();
            let mut sums = oadev_sums(x, &rest);
            for (s, &m) in sums.iter_mut().zip(ms) {
                if let Some(f) = fused(m) {
                    *s = f;
                }
            }
            sums
        }
        Statistic::Ohdev => ohdev_sums(x, ms),
        Statistic::Mdev | Statistic::Tdev => mdev_sums(x, ms),
        Statistic::Totdev => totdev_sums(x, ms),
        Statistic::Adev | Statistic::Hdev => unreachable!("one pass per m above"),
    };
    ms.iter().zip(sums).map(|(&m, s)| from_sum(stat, m, series.tau0_s, s, stat.terms(n_phase, m))).collect()
}

/// OHDEV's sums `sum_i (x[i+3m] - 3x[i+2m] + 3x[i+m] - x[i])^2` for every m of `ms`, in blocks of
/// [`MANY_BLOCK`] start indices processed in parallel, each adding its terms for every m while its phase points
/// are still in cache.
fn ohdev_sums(x: &[f64], ms: &[usize]) -> Vec<f64> {
    let n_phase = x.len();
    let count = |m: usize| n_phase.saturating_sub(3 * m);
    let max_count = ms.iter().map(|&m| count(m)).max().unwrap_or(0);
    // A short record has few blocks: its levels are split into groups as well, so that every core has work.
    let group = if max_count.div_ceil(MANY_BLOCK) >= FEW_BLOCKS { ms.len().max(1) } else { LEVEL_GROUP };
    let groups: Vec<Vec<f64>> = ms
        .par_chunks(group)
        .map(|g| {
            let top = g.iter().map(|&m| count(m)).max().unwrap_or(0);
            ordered_sums((0..top.div_ceil(MANY_BLOCK)).into_par_iter(), g.len(), |acc, b| {
                let i0 = b * MANY_BLOCK;
                for (k, &m) in g.iter().enumerate() {
                    let end = (i0 + MANY_BLOCK).min(count(m));
                    if end > i0 {
                        acc[k] += sumsq_o3(&x[i0..], m, end - i0);
                    }
                }
            })
        })
        .collect();
    groups.concat()
}

/// Start indices per block of OHDEV's blocked pass: a block's four runs of points at every octave level fit in
/// L2 together, so each point is read from memory about once for all of them.
const MANY_BLOCK: usize = 1 << 12;

/// Sum of squared differences of order `d` (2 or 3) at lag m, every `stride` points, and the number of terms.
fn diff_sumsq(series: &Series, m: usize, stride: usize, d: usize) -> (f64, usize) {
    let x = &series.x;
    let n_phase = x.len();
    if n_phase <= d * m {
        return (0.0, 0);
    }
    let last = n_phase - 1 - d * m; // last start index
    match (&series.bad, stride, d) {
        (None, 1, 2) => (sumsq_o2(x, m, last + 1), last + 1),
        (None, 1, 3) => (sumsq_o3(x, m, last + 1), last + 1),
        _ => {
            let bad = series.bad.as_deref();
            let mut s = 0.0;
            let mut n = 0usize;
            let mut i = 0;
            while i <= last {
                if bad.is_none_or(|b| Series::valid(b, series.kind, i, i + d * m)) {
                    let v = if d == 2 {
                        x[i + 2 * m] - 2.0 * x[i + m] + x[i]
                    } else {
                        x[i + 3 * m] - 3.0 * x[i + 2 * m] + 3.0 * x[i + m] - x[i]
                    };
                    s += v * v;
                    n += 1;
                }
                i += stride;
            }
            (s, n)
        }
    }
}

/// MDEV: sum over j of (W(j+2m) - 2 W(j+m) + W(j))^2 with W(j) = x[j] + ... + x[j+m-1] from the double-double
/// prefix sums (each window difference is formed before combining, so the error stays relative to the window).
fn mod_sumsq(series: &Series, m: usize) -> (f64, usize) {
    let n_phase = series.x.len();
    if n_phase < 3 * m {
        return (0.0, 0);
    }
    let count = n_phase + 1 - 3 * m;
    let (hi, lo) = series.prefix();
    let w = |j: usize| (hi[j + m] - hi[j]) + (lo[j + m] - lo[j]);
    let bad = series.bad.as_deref();
    let mut total = 0.0;
    let mut n = 0usize;
    let mut start = 0;
    while start < count {
        let end = (start + BLOCK).min(count);
        let mut s = 0.0;
        for j in start..end {
            if let Some(b) = bad {
                if !Series::valid(b, series.kind, j, j + 3 * m - 1) {
                    continue;
                }
            }
            let v = w(j + 2 * m) - 2.0 * w(j + m) + w(j);
            s += v * v;
            n += 1;
        }
        total += s;
        start = end;
    }
    (total, n)
}

/// TOTDEV: OADEV's terms on the reflected extension, centre index i = 1..=N-2.
fn tot_sumsq(series: &Series, m: usize) -> (f64, usize) {
    let x = &series.x;
    let n_phase = x.len();
    if n_phase < 3 || m > n_phase - 2 {
        return (0.0, 0);
    }
    let last = n_phase - 1;
    let (x0, xl) = (x[0], x[last]);
    // Extended point at signed original index k, and the original span it depends on.
    let ext = |k: i64| -> f64 {
        if k < 0 {
            2.0 * x0 - x[(-k) as usize]
        } else if k as usize > last {
            2.0 * xl - x[2 * last - k as usize]
        } else {
            x[k as usize]
        }
    };
    let span = |k: i64| -> (usize, usize) {
        if k < 0 {
            (0, (-k) as usize)
        } else if k as usize > last {
            (2 * last - k as usize, last)
        } else {
            (k as usize, k as usize)
        }
    };
    let mi = m as i64;
    let bad = series.bad.as_deref();
    let mut total = 0.0;
    let mut n = 0usize;
    // Interior terms (no reflection): i in [m, last - m], contiguous, vectorisable when there is no gap.
    let lo_int = m.max(1);
    let hi_int = last.saturating_sub(m).min(last - 1);
    let edge = |i: usize, total: &mut f64, n: &mut usize| {
        let k = i as i64;
        if let Some(b) = bad {
            let (a0, b0) = span(k - mi);
            let (a2, b2) = span(k + mi);
            let lo = a0.min(i).min(a2);
            let hi = b0.max(i).max(b2);
            if !Series::valid(b, series.kind, lo, hi) {
                return;
            }
        }
        let v = ext(k - mi) - 2.0 * ext(k) + ext(k + mi);
        *total += v * v;
        *n += 1;
    };
    if lo_int <= hi_int {
        for i in 1..lo_int {
            edge(i, &mut total, &mut n);
        }
        if bad.is_none() {
            total += sumsq_o2(&x[lo_int - m..], m, hi_int - lo_int + 1);
            n += hi_int - lo_int + 1;
        } else {
            for i in lo_int..=hi_int {
                edge(i, &mut total, &mut n);
            }
        }
        for i in hi_int + 1..=last - 1 {
            edge(i, &mut total, &mut n);
        }
    } else {
        for i in 1..=last - 1 {
            edge(i, &mut total, &mut n);
        }
    }
    (total, n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::{sumsq_o2_body, FAR_PITCH};
    use crate::series::DataKind;

    fn data(n: usize) -> Vec<f64> {
        let mut g = crate::test_signals::Lcg::new(12345);
        (0..n).map(|_| g.uniform()).collect()
    }

    /// A NaN frequency sample removes exactly the OADEV terms whose window holds it; the others are averaged as
    /// usual (computed here straight from the definition on frequency averages).
    #[test]
    fn gaps_skip_the_terms_that_touch_them() {
        let mut y = data(300);
        y[50] = f64::NAN;
        let s = Series::new(&y, DataKind::Frequency, 1.0).unwrap();
        for m in [1usize, 3, 8] {
            let (mut sum, mut n) = (0.0, 0usize);
            for i in 0..=(y.len() - 2 * m) {
                let w = &y[i..i + 2 * m];
                if w.iter().any(|v| v.is_nan()) {
                    continue;
                }
                let a: f64 = w[..m].iter().sum::<f64>() / m as f64;
                let b: f64 = w[m..].iter().sum::<f64>() / m as f64;
                sum += (b - a) * (b - a);
                n += 1;
            }
            let want = (sum / (2.0 * n as f64)).sqrt();
            let got = deviation_at(&s, Statistic::Oadev, m).unwrap();
            assert_eq!(got.n, n);
            assert_eq!(got.n, Statistic::Oadev.terms(301, m) - 2 * m);
            assert!(((got.dev - want) / want).abs() < 1e-12, "m={m}: {} vs {want}", got.dev);
        }
        // Leading and trailing NaNs are trimmed, not counted as gaps.
        let mut z = vec![f64::NAN; 3];
        z.extend(data(100));
        z.push(f64::NAN);
        let t = Series::new(&z, DataKind::Frequency, 1.0).unwrap();
        assert!(!t.has_gaps());
        assert_eq!(t.n_phase(), 101);
    }

    /// The two-pass sums (near blocks, far columns) equal one straightforward pass per m, for octave and other
    /// averaging factors, including the record's last partial column and levels whose terms end inside a block.
    #[test]
    fn oadev_sums_match_one_pass_per_m() {
        let y = data(5 * FAR_PITCH + 4321);
        let s = Series::new(&y, DataKind::Frequency, 1.0).unwrap();
        let ms = [1usize, 2, 3, 5, 64, 4095, 4096, 9999, FAR_PITCH, 2 * FAR_PITCH, 3 * FAR_PITCH, FAR_PITCH + 1, 0];
        let got = oadev_sums(&s.x, &ms);
        for (&m, &g) in ms.iter().zip(&got) {
            let want = if m == 0 || 2 * m >= s.x.len() { 0.0 } else { sumsq_o2_body(&s.x, m, s.x.len() - 2 * m) };
            assert!((g - want).abs() <= 1e-12 * want, "m={m}: {g} vs {want}");
        }
        let many = deviations_at(&s, Statistic::Oadev, &[2 * FAR_PITCH]);
        assert_eq!(many[0].unwrap().n, s.x.len() - 4 * FAR_PITCH);
    }

    /// The OADEV sums taken while the phase is built (inside each integration group, then across the group
    /// boundaries and from x[0]) equal the separate pass, and deviations_at gives the same estimates from them.
    #[test]
    fn fused_oadev_sums_match_the_separate_pass() {
        let y = data(3 * (8 * ((1 << 15) + 72)) + 12345);
        let ms = [1usize, 2, 3, 4, 64, 1000, 4096, 8192, 16384, 40_000];
        let plain = Series::new(&y, DataKind::Frequency, 0.5).unwrap();
        let fused = Series::with_oadev(&y, DataKind::Frequency, 0.5, |_| ms.to_vec()).unwrap();
        assert_eq!(plain.x, fused.x);
        assert_eq!(fused.oadev_fused.iter().map(|f| f.0).collect::<Vec<_>>(), ms[..8].to_vec());
        let want = oadev_sums(&plain.x, &ms);
        for &(m, got) in &fused.oadev_fused {
            let w = want[ms.iter().position(|&k| k == m).unwrap()];
            assert!((got - w).abs() <= 1e-12 * w, "m={m}: {got} vs {w}");
        }
        for (a, b) in
            deviations_at(&plain, Statistic::Oadev, &ms).iter().zip(deviations_at(&fused, Statistic::Oadev, &ms))
        {
            let (a, b) = (a.unwrap(), b.unwrap());
            assert_eq!(a.n, b.n);
            assert!(((a.dev - b.dev) / a.dev).abs() < 1e-12);
        }
    }

    /// The cache-blocked multi-tau pass gives the same numbers as one pass per m.
    #[test]
    fn deviations_at_match_deviation_at() {
        let y = data(100_000);
        let s = Series::new(&y, DataKind::Frequency, 0.5).unwrap();
        let ms = [1usize, 2, 7, 64, 1000, 20_000, 33_333];
        for stat in [Statistic::Oadev, Statistic::Ohdev] {
            let many = deviations_at(&s, stat, &ms);
            for (&m, e) in ms.iter().zip(&many) {
                let one = deviation_at(&s, stat, m).unwrap();
                let e = e.unwrap();
                assert_eq!(e.n, one.n);
                assert!(((e.dev - one.dev) / one.dev).abs() < 1e-12);
            }
        }
    }
}

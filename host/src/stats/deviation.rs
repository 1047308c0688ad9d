//! The estimators: ADEV, OADEV, MDEV, TDEV, HDEV, OHDEV and TOTDEV at one averaging factor, in O(N) each.
//!
//! Definitions as NIST SP 1065 (W. J. Riley, 2008) and allantools, on N phase points x (see [`super::series`]):
//! - ADEV (eq. 7) / OADEV (eq. 11): `sum (x[i+2m] - 2x[i+m] + x[i])^2 / (2 n tau^2)`, stride m / stride 1,
//!   n = floor((N-1)/m) - 1 / N - 2m;
//! - MDEV (eq. 14): `sum (sum_{i=j}^{j+m-1} x[i+2m] - 2x[i+m] + x[i])^2 / (2 m^2 n tau^2)`, n = N - 3m + 1, with
//!   the inner sums from double-double prefix sums (O(1) per term); TDEV = tau MDEV / sqrt(3) (eq. 15);
//! - HDEV (eq. 18) / OHDEV (eq. 20): `sum (x[i+3m] - 3x[i+2m] + 3x[i+m] - x[i])^2 / (6 n tau^2)`, stride m / 1,
//!   n = floor((N-1)/m) - 2 / N - 3m;
//! - TOTDEV (eq. 25): OADEV's terms over the record extended at both ends by odd reflection
//!   (`x*[-j] = 2x[0] - x[j]`, `x*[N-1+j] = 2x[N-1] - x[N-1-j]`), i = 1..N-2, n = N - 2.
//!
//! The term counts are Stable32's `#` column. With gaps, terms touching a gap are skipped and n counts the rest.

use rayon::prelude::*;

use super::ordered::{ordered_sums, ordered_sums_with};
use super::series::Series;

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

/// One estimate: the deviation and the number of terms averaged.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// The deviation (frequency units; TDEV in the phase's time unit).
    pub dev: f64,
    /// Number of terms averaged.
    pub n: usize,
}

/// The estimate of `stat` at averaging factor `m`, or None when no term can be formed.
pub fn estimate(series: &Series, stat: Statistic, m: usize) -> Option<Estimate> {
    if m == 0 {
        return None;
    }
    let tau = m as f64 * series.tau0_s;
    let (sum, n, norm) = match stat {
        Statistic::Adev => {
            let (s, n) = diff_sumsq(series, m, m, 2);
            (s, n, 2.0)
        }
        Statistic::Oadev => {
            let (s, n) = diff_sumsq(series, m, 1, 2);
            (s, n, 2.0)
        }
        Statistic::Hdev => {
            let (s, n) = diff_sumsq(series, m, m, 3);
            (s, n, 6.0)
        }
        Statistic::Ohdev => {
            let (s, n) = diff_sumsq(series, m, 1, 3);
            (s, n, 6.0)
        }
        Statistic::Mdev | Statistic::Tdev => {
            let (s, n) = mod_sumsq(series, m);
            (s, n, 2.0 * (m as f64) * (m as f64))
        }
        Statistic::Totdev => {
            let (s, n) = tot_sumsq(series, m);
            (s, n, 2.0)
        }
    };
    if n == 0 {
        return None;
    }
    let mut dev = (sum / (norm * n as f64)).sqrt() / tau;
    if stat == Statistic::Tdev {
        dev *= tau / 3f64.sqrt();
    }
    Some(Estimate { dev, n })
}

/// The fully overlapping estimates (OADEV, OHDEV) at many averaging factors in one cache-blocked pass: the
/// record is cut into blocks of `MANY_BLOCK` start indices, and each block (processed in parallel) adds its terms
/// for every m while its phase points are still in cache. Falls back to one pass per m for other statistics or
/// records with gaps. Returns None for an m without terms.
pub fn estimate_many(series: &Series, stat: Statistic, ms: &[usize]) -> Vec<Option<Estimate>> {
    let d = match stat {
        Statistic::Oadev => 2,
        Statistic::Ohdev => 3,
        _ => return ms.par_iter().map(|&m| estimate(series, stat, m)).collect(),
    };
    if series.bad.is_some() || ms.contains(&0) {
        return ms.par_iter().map(|&m| estimate(series, stat, m)).collect();
    }
    let x = &series.x;
    let n_phase = x.len();
    if d == 2 {
        // Sums taken while the series was built are reused; the rest is summed here.
        let fused = |m: usize| series.oadev_fused.iter().find(|f| f.0 == m).map(|f| f.1);
        let rest: Vec<usize> = ms.iter().map(|&m| if fused(m).is_some() { 0 } else { m }).collect();
        let mut sums = oadev_sums(x, &rest);
        for (s, &m) in sums.iter_mut().zip(ms) {
            if let Some(f) = fused(m) {
                *s = f;
            }
        }
        return ms
            .iter()
            .zip(&sums)
            .map(|(&m, &s)| {
                let n = n_phase.saturating_sub(2 * m);
                (n > 0).then(|| Estimate { dev: (s / (2.0 * n as f64)).sqrt() / (m as f64 * series.tau0_s), n })
            })
            .collect();
    }
    let counts: Vec<usize> = ms.iter().map(|&m| n_phase.saturating_sub(d * m)).collect();
    let max_count = counts.iter().copied().max().unwrap_or(0);
    let blocks = max_count.div_ceil(MANY_BLOCK);
    let sums = ordered_sums((0..blocks).into_par_iter(), ms.len(), |acc, b| {
        let i0 = b * MANY_BLOCK;
        for (k, &m) in ms.iter().enumerate() {
            let end = (i0 + MANY_BLOCK).min(counts[k]);
            if end > i0 {
                acc[k] += if d == 2 { sumsq_o2(&x[i0..], m, end - i0) } else { sumsq_o3(&x[i0..], m, end - i0) };
            }
        }
    });
    let norm = if d == 2 { 2.0 } else { 6.0 };
    ms.iter()
        .zip(&counts)
        .zip(&sums)
        .map(|((&m, &n), &s)| {
            (n > 0).then(|| Estimate { dev: (s / (norm * n as f64)).sqrt() / (m as f64 * series.tau0_s), n })
        })
        .collect()
}

/// Start indices per block of [`estimate_many`]: with the largest small-m windows it stays within L2.
const MANY_BLOCK: usize = 1 << 14;

/// Column pitch of the far levels of [`oadev_sums`]: averaging factors that are multiples of it (and at least it)
/// are summed column-wise.
pub(crate) const FAR_PITCH: usize = 1 << 14;
/// Width of one column of [`oadev_sums`] (eight cache lines): a column of a 1e7-point record is 300 KB, in L2.
pub(crate) const FAR_WIDTH: usize = 64;
/// Rows ahead that the gather of a far column prefetches.
pub(crate) const PREFETCH_ROWS: usize = 6;
/// Start indices per block of the near levels of [`oadev_sums`].
const NEAR_BLOCK: usize = 4096;
/// Levels summed together by one pass of the kernel (registers: one accumulator each).
const GROUP: usize = 8;

/// The fully overlapping Allan sums `sum_i (x[i+2m] - 2x[i+m] + x[i])^2`, i < N - 2m, for every m of `ms` (any
/// order; 0 for an m without terms), in two passes that each read the phase from memory once:
///
/// - near levels (m < [`FAR_PITCH`] or not a multiple of it): the start indices in blocks of [`NEAR_BLOCK`]; a
///   block sums its terms for every near level, eight levels per sweep, while the block and its windows
///   (within 2 FAR_PITCH points) are in L2;
/// - far levels (m = j FAR_PITCH): the start indices i = r + q FAR_PITCH + l are taken column by column: column
///   r (l < [`FAR_WIDTH`]) is gathered into a buffer of rows q, where level m is the row lag j, so every far
///   level runs on L2-resident data.
///
/// Blocks and columns are spread over the rayon pool; each block or column adds its own partial sums (four lanes
/// over at most a few ten thousand terms) to the totals, which keeps the rounding error near 1e-15 relative.
pub(crate) fn oadev_sums(x: &[f64], ms: &[usize]) -> Vec<f64> {
    let n = x.len();
    let mut order: Vec<usize> = (0..ms.len()).filter(|&k| ms[k] > 0 && 2 * ms[k] < n).collect();
    order.sort_by_key(|&k| ms[k]);
    let (far, near): (Vec<usize>, Vec<usize>) =
        order.into_iter().partition(|&k| ms[k] >= FAR_PITCH && ms[k].is_multiple_of(FAR_PITCH));
    let near_ms: Vec<usize> = near.iter().map(|&k| ms[k]).collect();
    let far_ms: Vec<usize> = far.iter().map(|&k| ms[k]).collect();
    let near_sums = if near_ms.is_empty() {
        Vec::new()
    } else {
        let count0 = n - 2 * near_ms[0];
        ordered_sums((0..count0.div_ceil(NEAR_BLOCK)).into_par_iter(), near_ms.len(), |acc, b| {
            let i0 = b * NEAR_BLOCK;
            oadev_range_sums(x, &near_ms, i0, (i0 + NEAR_BLOCK).min(count0), acc);
        })
    };
    let far_sums = far_sums(n, &far_ms, |r0, buf| gather_column(x, r0, buf));
    let mut out = vec![0.0f64; ms.len()];
    for (k, s) in near.iter().zip(near_sums).chain(far.iter().zip(far_sums)) {
        out[*k] = s;
    }
    out
}

/// Adds to `out[k]` the Allan sum of `ms[k]` (ascending) over the start indices i in [i0, i1) that have terms
/// (i + 2m < x.len()), on the calling thread, in blocks that stay in cache: the streaming path's kernel.
pub(crate) fn oadev_range_sums(x: &[f64], ms: &[usize], i0: usize, i1: usize, out: &mut [f64]) {
    debug_assert!(ms.windows(2).all(|w| w[0] <= w[1]) && out.len() == ms.len());
    let n = x.len();
    let kernel = Kernel::detect();
    let end = |m: usize| n.saturating_sub(2 * m).min(i1);
    let top = ms.first().map_or(i0, |&m| end(m));
    let mut b0 = i0;
    while b0 < top {
        let b1 = (b0 + NEAR_BLOCK).min(top);
        let full = ms.iter().take_while(|&&m| end(m) >= b1).count();
        let mut k = 0;
        while k < full {
            let g = (full - k).min(GROUP);
            kernel.sums(x, &ms[k..k + g], b0, b1, &mut out[k..k + g]);
            k += g;
        }
        for k in full..ms.len() {
            let e = end(ms[k]).min(b1);
            if e > b0 {
                kernel.sums(x, &ms[k..k + 1], b0, e, &mut out[k..k + 1]);
            }
        }
        b0 = b1;
    }
}

/// The far levels of [`oadev_sums`] (`far_ms` ascending, multiples of [`FAR_PITCH`]) of a record of `n` phase
/// points, column by column: `fill(r0, buf)` writes row q of column r0 (`x[r0 + q FAR_PITCH + l]`, l <
/// [`FAR_WIDTH`]) to `buf[q FAR_WIDTH + l]`, the points beyond the record as 0.
pub(crate) fn far_sums(n: usize, far_ms: &[usize], fill: impl Fn(usize, &mut [f64]) + Sync) -> Vec<f64> {
    if far_ms.is_empty() {
        return Vec::new();
    }
    let kernel = Kernel::detect();
    // Runs of 16 columns: each run fills one buffer of a sixteenth of the record.
    ordered_sums_with((0..FAR_PITCH / FAR_WIDTH).into_par_iter(), 16, far_ms.len(), Vec::new, |acc, buf, c| {
        let r0 = c * FAR_WIDTH;
        if r0 < n {
            let rows = (n - r0).div_ceil(FAR_PITCH);
            // (Zeroed once per buffer size: fill overwrites the rows.)
            buf.resize(rows * FAR_WIDTH, 0.0);
            fill(r0, &mut buf[..rows * FAR_WIDTH]);
            far_column(n, far_ms, r0, kernel, &buf[..rows * FAR_WIDTH], acc);
        }
    })
}

/// Row q of column r0 of the far levels: `x[r0 + q P .. + W]` (the last row cut at the end of the record, padded
/// with zeros never read).
fn gather_column(x: &[f64], r0: usize, buf: &mut [f64]) {
    let n = x.len();
    for (q, row) in buf.chunks_exact_mut(FAR_WIDTH).enumerate() {
        let a = r0 + q * FAR_PITCH;
        // The rows are FAR_PITCH apart (one cache set each): ask for a row a few ahead while this one is copied.
        #[cfg(target_arch = "x86_64")]
        if a + PREFETCH_ROWS * FAR_PITCH + FAR_WIDTH <= n {
            for l in (0..FAR_WIDTH).step_by(8) {
                // SAFETY: a prefetch hint on an address inside x; nothing is read or written.
                unsafe {
                    std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
                        x.as_ptr().add(a + PREFETCH_ROWS * FAR_PITCH + l) as *const i8,
                    )
                };
            }
        }
        let b = (a + FAR_WIDTH).min(n);
        row[..b - a].copy_from_slice(&x[a..b]);
        row[b - a..].fill(0.0);
    }
}

/// One column of the far levels: start indices r0 + q FAR_PITCH + l, l < FAR_WIDTH, from its rows in `buf`.
fn far_column(n: usize, far_ms: &[usize], r0: usize, kernel: Kernel, buf: &[f64], acc: &mut [f64]) {
    // Term (q, l) exists when r0 + q P + l + 2m <= n - 1. Whole rows: q + 2j <= (n - 1 - r0 - (W - 1)) / P.
    let last = n - 1 - r0; // the largest offset from r0 inside the record
    let whole = if last + 1 >= FAR_WIDTH { (last + 1 - FAR_WIDTH) / FAR_PITCH + 1 } else { 0 };
    let lags: Vec<usize> = far_ms.iter().map(|&m| m / FAR_PITCH * FAR_WIDTH).collect();
    // Level k (ascending m) has its whole rows in [0, ends[k]), ends non-increasing: the rows all levels share go
    // through the kernel together (up to GROUP levels per sweep), then each shorter range with the levels left.
    let ends: Vec<usize> = far_ms.iter().map(|&m| whole.saturating_sub(2 * (m / FAR_PITCH)) * FAR_WIDTH).collect();
    let mut lo = 0;
    for k in (0..far_ms.len()).rev() {
        let hi = ends[k];
        if hi > lo {
            let mut g0 = 0;
            while g0 <= k {
                let g1 = (g0 + GROUP).min(k + 1);
                kernel.sums(buf, &lags[g0..g1], lo, hi, &mut acc[g0..g1]);
                g0 = g1;
            }
            lo = hi;
        }
    }
    for (k, &m) in far_ms.iter().enumerate() {
        let j = m / FAR_PITCH;
        // At most one row more is partly inside.
        let q = ends[k] / FAR_WIDTH;
        let mut s = 0.0;
        for l in 0..FAR_WIDTH {
            let i = q * FAR_PITCH + l; // offset from r0
            if i + 2 * m > last {
                break;
            }
            let (a, b, c) = (buf[q * FAR_WIDTH + l], buf[(q + j) * FAR_WIDTH + l], buf[(q + 2 * j) * FAR_WIDTH + l]);
            let v = c - 2.0 * b + a;
            s += v * v;
        }
        acc[k] += s;
    }
}

/// The kernel of [`oadev_sums`] for this CPU.
#[derive(Clone, Copy)]
enum Kernel {
    #[cfg(target_arch = "x86_64")]
    Avx2,
    Portable,
}

impl Kernel {
    fn detect() -> Kernel {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
                return Kernel::Avx2;
            }
        }
        Kernel::Portable
    }

    /// Adds `sum_{i0 <= i < i1} (x[i+2m] - 2x[i+m] + x[i])^2` to `out[g]` for each `ms[g]` (at most [`GROUP`]).
    ///
    /// # Panics
    /// When a term would read beyond `x` (`i1 - 1 + 2 m >= x.len()`).
    fn sums(self, x: &[f64], ms: &[usize], i0: usize, i1: usize, out: &mut [f64]) {
        if i1 <= i0 {
            return;
        }
        let top = ms.iter().copied().max().unwrap_or(0);
        assert!(i1 - 1 + 2 * top < x.len() && ms.len() <= GROUP && out.len() == ms.len());
        match self {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: AVX2 and FMA were detected; every read is at most i1 - 1 + 2 max(ms) < x.len().
            Kernel::Avx2 => unsafe {
                macro_rules! go {
                    ($($g:literal)*) => {
                        match ms.len() {
                            $($g => avx2_sums::<$g>(x, ms.try_into().unwrap(), i0, i1, out),)*
                            _ => unreachable!(),
                        }
                    };
                }
                go!(1 2 3 4 5 6 7 8)
            },
            Kernel::Portable => {
                for (o, &m) in out.iter_mut().zip(ms) {
                    *o += sumsq_o2(&x[i0..], m, i1 - i0);
                }
            }
        }
    }
}

/// G levels at once, four start indices per step: one load of x[i..i+4] for all levels, then per level two loads,
/// an FMA, an add and an FMA into the level's accumulator (register-resident for G <= 8).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn avx2_sums<const G: usize>(x: &[f64], ms: &[usize; G], i0: usize, i1: usize, out: &mut [f64]) {
    use std::arch::x86_64::*;
    let p = x.as_ptr();
    let mut acc = [_mm256_setzero_pd(); G];
    let m2 = _mm256_set1_pd(-2.0);
    let mut i = i0;
    // SAFETY (whole body): the caller guarantees i1 - 1 + 2 max(ms) < x.len().
    unsafe {
        if G <= 4 {
            // Few levels: two accumulators each, so the FMA latency does not bound the loop.
            let mut acc2 = [_mm256_setzero_pd(); G];
            while i + 8 <= i1 {
                let a = _mm256_loadu_pd(p.add(i));
                let a2 = _mm256_loadu_pd(p.add(i + 4));
                for g in 0..G {
                    let b = _mm256_loadu_pd(p.add(i + ms[g]));
                    let c = _mm256_loadu_pd(p.add(i + 2 * ms[g]));
                    let b2 = _mm256_loadu_pd(p.add(i + 4 + ms[g]));
                    let c2 = _mm256_loadu_pd(p.add(i + 4 + 2 * ms[g]));
                    let v = _mm256_add_pd(_mm256_fmadd_pd(m2, b, c), a);
                    let v2 = _mm256_add_pd(_mm256_fmadd_pd(m2, b2, c2), a2);
                    acc[g] = _mm256_fmadd_pd(v, v, acc[g]);
                    acc2[g] = _mm256_fmadd_pd(v2, v2, acc2[g]);
                }
                i += 8;
            }
            for g in 0..G {
                acc[g] = _mm256_add_pd(acc[g], acc2[g]);
            }
        }
        while i + 4 <= i1 {
            let a = _mm256_loadu_pd(p.add(i));
            for g in 0..G {
                let b = _mm256_loadu_pd(p.add(i + ms[g]));
                let c = _mm256_loadu_pd(p.add(i + 2 * ms[g]));
                let v = _mm256_add_pd(_mm256_fmadd_pd(m2, b, c), a);
                acc[g] = _mm256_fmadd_pd(v, v, acc[g]);
            }
            i += 4;
        }
        for g in 0..G {
            let m = ms[g];
            let mut t = [0.0f64; 4];
            _mm256_storeu_pd(t.as_mut_ptr(), acc[g]);
            let mut s = (t[0] + t[1]) + (t[2] + t[3]);
            for j in i..i1 {
                let v = *p.add(j + 2 * m) - 2.0 * *p.add(j + m) + *p.add(j);
                s += v * v;
            }
            out[g] += s;
        }
    }
}

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

/// Block length for the partial sums: keeps rounding error low and the working set in cache.
const BLOCK: usize = 4096;

/// sum over i < count of (x[i+2m] - 2x[i+m] + x[i])^2: eight independent accumulators (vectorises), summed per
/// block.
#[inline(always)]
fn sumsq_o2_body(x: &[f64], m: usize, count: usize) -> f64 {
    let a = &x[..count];
    let b = &x[m..m + count];
    let c = &x[2 * m..2 * m + count];
    let mut total = 0.0;
    for ((ab, bb), cb) in a.chunks(BLOCK).zip(b.chunks(BLOCK)).zip(c.chunks(BLOCK)) {
        let mut acc = [0.0f64; 8];
        let mut ai = ab.chunks_exact(8);
        let mut bi = bb.chunks_exact(8);
        let mut ci = cb.chunks_exact(8);
        for ((a8, b8), c8) in (&mut ai).zip(&mut bi).zip(&mut ci) {
            for k in 0..8 {
                let v = c8[k] - 2.0 * b8[k] + a8[k];
                acc[k] += v * v;
            }
        }
        let mut s: f64 = acc.iter().sum();
        for ((av, bv), cv) in ai.remainder().iter().zip(bi.remainder()).zip(ci.remainder()) {
            let v = cv - 2.0 * bv + av;
            s += v * v;
        }
        total += s;
    }
    total
}

/// sum over i < count of (x[i+3m] - 3x[i+2m] + 3x[i+m] - x[i])^2, as [`sumsq_o2`].
#[inline(always)]
fn sumsq_o3_body(x: &[f64], m: usize, count: usize) -> f64 {
    let a = &x[..count];
    let b = &x[m..m + count];
    let c = &x[2 * m..2 * m + count];
    let e = &x[3 * m..3 * m + count];
    let mut total = 0.0;
    let mut start = 0;
    while start < count {
        let end = (start + BLOCK).min(count);
        let mut acc = [0.0f64; 8];
        let mut i = start;
        while i + 8 <= end {
            for k in 0..8 {
                let v = e[i + k] - 3.0 * c[i + k] + 3.0 * b[i + k] - a[i + k];
                acc[k] += v * v;
            }
            i += 8;
        }
        let mut s: f64 = acc.iter().sum();
        while i < end {
            let v = e[i] - 3.0 * c[i] + 3.0 * b[i] - a[i];
            s += v * v;
            i += 1;
        }
        total += s;
        start = end;
    }
    total
}

/// [`sumsq_o2_body`] compiled for AVX2 + FMA when the CPU has them (checked once at run time), else for the
/// baseline target.
fn sumsq_o2(x: &[f64], m: usize, count: usize) -> f64 {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
            // SAFETY: the features were just detected on this CPU.
            return unsafe { sumsq_o2_avx2(x, m, count) };
        }
    }
    sumsq_o2_body(x, m, count)
}

/// [`sumsq_o3_body`], dispatched as [`sumsq_o2`].
fn sumsq_o3(x: &[f64], m: usize, count: usize) -> f64 {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
            // SAFETY: the features were just detected on this CPU.
            return unsafe { sumsq_o3_avx2(x, m, count) };
        }
    }
    sumsq_o3_body(x, m, count)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn sumsq_o2_avx2(x: &[f64], m: usize, count: usize) -> f64 {
    sumsq_o2_body(x, m, count)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn sumsq_o3_avx2(x: &[f64], m: usize, count: usize) -> f64 {
    sumsq_o3_body(x, m, count)
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
    use crate::stats::series::DataKind;

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
            let got = estimate(&s, Statistic::Oadev, m).unwrap();
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
        let many = estimate_many(&s, Statistic::Oadev, &[2 * FAR_PITCH]);
        assert_eq!(many[0].unwrap().n, s.x.len() - 4 * FAR_PITCH);
    }

    /// The OADEV sums taken while the phase is built (inside each integration group, then across the group
    /// boundaries and from x[0]) equal the separate pass, and estimate_many gives the same estimates from them.
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
            estimate_many(&plain, Statistic::Oadev, &ms).iter().zip(estimate_many(&fused, Statistic::Oadev, &ms))
        {
            let (a, b) = (a.unwrap(), b.unwrap());
            assert_eq!(a.n, b.n);
            assert!(((a.dev - b.dev) / a.dev).abs() < 1e-12);
        }
    }

    /// The cache-blocked multi-tau pass gives the same numbers as one pass per m.
    #[test]
    fn estimate_many_matches_single() {
        let y = data(100_000);
        let s = Series::new(&y, DataKind::Frequency, 0.5).unwrap();
        let ms = [1usize, 2, 7, 64, 1000, 20_000, 33_333];
        for stat in [Statistic::Oadev, Statistic::Ohdev] {
            let many = estimate_many(&s, stat, &ms);
            for (&m, e) in ms.iter().zip(&many) {
                let one = estimate(&s, stat, m).unwrap();
                let e = e.unwrap();
                assert_eq!(e.n, one.n);
                assert!(((e.dev - one.dev) / one.dev).abs() < 1e-12);
            }
        }
    }
}

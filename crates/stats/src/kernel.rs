//! The sums of squared phase differences under every deviation: `sum (x[i+2m] - 2x[i+m] + x[i])^2` (and the
//! third difference for the Hadamard family), vectorised (AVX2 and FMA where the CPU has them) and summed in
//! blocks so the rounding error stays near 1e-15 relative. [`oadev_sums`] takes every level of an OADEV at once;
//! [`oadev_range_sums`] is the same kernel over a range of start indices, which the fused phase pass of
//! [`super::series`] and the streamed engine ([`super::stream_oadev`]) use.

use rayon::prelude::*;

use super::ordered::{ordered_sums, ordered_sums_with};

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
/// Below this many blocks of start indices, the levels are split into groups of [`LEVEL_GROUP`] for the
/// parallel passes ([`oadev_sums`], OHDEV's blocked pass).
pub(crate) const FEW_BLOCKS: usize = 8;
/// Levels per group when a record has few blocks.
pub(crate) const LEVEL_GROUP: usize = 32;

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
        // A short record has few blocks: its levels are split into groups as well, so that every core has work.
        let blocks = (n - 2 * near_ms[0]).div_ceil(NEAR_BLOCK);
        let group = if blocks >= FEW_BLOCKS { near_ms.len() } else { LEVEL_GROUP };
        let groups: Vec<Vec<f64>> = near_ms
            .par_chunks(group)
            .map(|g| {
                let count0 = n - 2 * g[0];
                ordered_sums((0..count0.div_ceil(NEAR_BLOCK)).into_par_iter(), g.len(), |acc, b| {
                    let i0 = b * NEAR_BLOCK;
                    oadev_range_sums(x, g, i0, (i0 + NEAR_BLOCK).min(count0), acc);
                })
            })
            .collect();
        groups.concat()
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

/// Block length for the partial sums: keeps rounding error low and the working set in cache.
pub(crate) const BLOCK: usize = 4096;

/// sum over i < count of (x[i+2m] - 2x[i+m] + x[i])^2: eight independent accumulators (vectorises), summed per
/// block.
#[inline(always)]
pub(crate) fn sumsq_o2_body(x: &[f64], m: usize, count: usize) -> f64 {
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

/// sum over i < count of (x[i+3m] - 3x[i+2m] + 3x[i+m] - x[i])^2, as [`sumsq_o2_body`] (whole chunks of eight:
/// no bounds checks in the loop, so it vectorises).
#[inline(always)]
fn sumsq_o3_body(x: &[f64], m: usize, count: usize) -> f64 {
    let a = &x[..count];
    let b = &x[m..m + count];
    let c = &x[2 * m..2 * m + count];
    let e = &x[3 * m..3 * m + count];
    let mut total = 0.0;
    for (((ab, bb), cb), eb) in a.chunks(BLOCK).zip(b.chunks(BLOCK)).zip(c.chunks(BLOCK)).zip(e.chunks(BLOCK)) {
        let mut acc = [0.0f64; 8];
        let (mut ai, mut bi, mut ci, mut ei) =
            (ab.chunks_exact(8), bb.chunks_exact(8), cb.chunks_exact(8), eb.chunks_exact(8));
        for (((a8, b8), c8), e8) in (&mut ai).zip(&mut bi).zip(&mut ci).zip(&mut ei) {
            for k in 0..8 {
                let v = (e8[k] - a8[k]) + 3.0 * (b8[k] - c8[k]);
                acc[k] += v * v;
            }
        }
        let mut s: f64 = acc.iter().sum();
        for (((av, bv), cv), ev) in ai.remainder().iter().zip(bi.remainder()).zip(ci.remainder()).zip(ei.remainder()) {
            let v = (ev - av) + 3.0 * (bv - cv);
            s += v * v;
        }
        total += s;
    }
    total
}

/// [`sumsq_o2_body`] compiled for AVX2 + FMA when the CPU has them (checked once at run time), else for the
/// baseline target.
pub(crate) fn sumsq_o2(x: &[f64], m: usize, count: usize) -> f64 {
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
pub(crate) fn sumsq_o3(x: &[f64], m: usize, count: usize) -> f64 {
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

//! MDEV's (and TDEV's) sums of squares on a gap-free phase record, at many averaging factors, in O(N) each
//! without prefix sums.
//!
//! The term at start j is `T(j) = sum_{i=j}^{j+m-1} (x[i+2m] - 2x[i+m] + x[i])`, and consecutive terms differ
//! by one third difference: `T(j+1) = T(j) + x[j+3m] - 3x[j+2m] + 3x[j+m] - x[j]` (allantools computes MDEV the
//! same way, with a cumulative sum). So each term costs four loads after the first, and the range of j is cut
//! into segments, each starting from its T computed directly (O(m)): segments run in parallel, and the
//! rounding the running sum gathers stays within one segment.
//!
//! # Precision
//! Each step adds the rounding of one third difference, which is relative to the differences of phase points
//! m apart (not to the phase itself: nearby points subtract exactly), so T(j) carries about sqrt(segment) ulps
//! of the terms' own size: near 1e-14 relative. Records with gaps take the double-double prefix sums of
//! [`super::series::Series::prefix`] instead: a gap stores 0 in the phase, and a running sum across it would
//! carry the rounding of that jump into the terms after it.

use rayon::prelude::*;

use super::kernel::{FEW_BLOCKS, LEVEL_GROUP};
use super::ordered::ordered_sums;

/// Terms per segment (at least; a segment is at least 2m long, so its direct start costs at most half a load a
/// term).
const SEG: usize = 1 << 15;
/// Levels up to this m share the segments of start indices (see [`mdev_sums`]).
const NEAR_M: usize = 1 << 12;

/// `sum_j T(j)^2` over the `n - 3m + 1` terms, for each m of `ms` (0 where m is 0 or has no term). The same bits
/// on any number of threads: every segment is summed alone and the segments of an m are added in order.
pub(crate) fn mdev_sums(x: &[f64], ms: &[usize]) -> Vec<f64> {
    let n = x.len();
    let count = |m: usize| if m == 0 || n < 3 * m { 0 } else { n + 1 - 3 * m };
    let seg_len = |m: usize| SEG.max(2 * m);
    // Near levels: a segment's window (SEG + 3m points) stays in L2 while every near level sums its terms from it,
    // so the record is read from memory once for all of them.
    let near: Vec<usize> = (0..ms.len()).filter(|&k| count(ms[k]) > 0 && ms[k] <= NEAR_M).collect();
    let near_ms: Vec<usize> = near.iter().map(|&k| ms[k]).collect();
    // A short record has few segments: its levels are split into groups as well, so that every core has work.
    let segs = |g: &[usize]| g.iter().map(|&m| count(m)).max().unwrap_or(0).div_ceil(SEG);
    let group = if segs(&near_ms) >= FEW_BLOCKS { near_ms.len().max(1) } else { LEVEL_GROUP };
    let near_sums: Vec<f64> = near_ms
        .par_chunks(group)
        .map(|g| {
            ordered_sums((0..segs(g)).into_par_iter(), g.len(), |acc, s| {
                let j0 = s * SEG;
                for (a, &m) in acc.iter_mut().zip(g) {
                    if j0 < count(m) {
                        *a += segment(x, m, j0, SEG.min(count(m) - j0));
                    }
                }
            })
        })
        .collect::<Vec<_>>()
        .concat();
    // Far levels: each segment alone.
    let items: Vec<(usize, usize)> = ms
        .iter()
        .enumerate()
        .filter(|&(_, &m)| m > NEAR_M)
        .flat_map(|(k, &m)| (0..count(m).div_ceil(seg_len(m))).map(move |s| (k, s)))
        .collect();
    let parts: Vec<f64> = items
        .par_iter()
        .map(|&(k, s)| {
            let m = ms[k];
            let j0 = s * seg_len(m);
            segment(x, m, j0, seg_len(m).min(count(m) - j0))
        })
        .collect();
    let mut out = vec![0.0f64; ms.len()];
    for (&k, s) in near.iter().zip(near_sums) {
        out[k] = s;
    }
    for (&(k, _), p) in items.iter().zip(parts) {
        out[k] += p;
    }
    out
}

/// `sum_{j0 <= j < j0 + len} T(j)^2` (len >= 1, `j0 + len - 1 + 3m <= x.len()`).
fn segment(x: &[f64], m: usize, j0: usize, len: usize) -> f64 {
    assert!(len >= 1 && j0 + len - 1 + 3 * m <= x.len());
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
            // SAFETY: the features were just detected on this CPU; the bounds were checked above.
            return unsafe { segment_avx2(x, m, j0, len) };
        }
    }
    segment_portable(x, m, j0, len)
}

/// Four steps per vector: the third differences h, their prefix within the vector (two shifts), T at the four
/// starts as the carried T plus the prefix, and the carried T moved on by the vector's total (one addition per
/// four terms on the dependency chain). Two vectors per iteration.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn segment_avx2(x: &[f64], m: usize, j0: usize, len: usize) -> f64 {
    use std::arch::x86_64::*;
    let t0 = direct(x, m, j0);
    let steps = len - 1;
    let p = x[j0..].as_ptr();
    // SAFETY (whole block): the caller checked j0 + len - 1 + 3m <= x.len(), so every load at p + i + 3m with
    // i < len - 1 (vectors: i + 3 < len - 1) is inside x.
    unsafe {
        let three = _mm256_set1_pd(3.0);
        let zero = _mm256_setzero_pd();
        // The prefix of the four steps of h at i ([0, h0, h1, h2] added, then [0, 0, s0, s1]), and its total
        // broadcast.
        macro_rules! prefix {
            ($i:expr) => {{
                let i = $i;
                let a = _mm256_loadu_pd(p.add(i));
                let b = _mm256_loadu_pd(p.add(i + m));
                let c = _mm256_loadu_pd(p.add(i + 2 * m));
                let d = _mm256_loadu_pd(p.add(i + 3 * m));
                let h = _mm256_fmadd_pd(three, _mm256_sub_pd(b, c), _mm256_sub_pd(d, a));
                let s = _mm256_add_pd(h, _mm256_blend_pd::<0b0001>(_mm256_permute4x64_pd::<0b10_01_00_00>(h), zero));
                let s = _mm256_add_pd(s, _mm256_permute2f128_pd::<0x08>(s, s));
                (s, _mm256_permute4x64_pd::<0b11_11_11_11>(s))
            }};
        }
        let mut t = _mm256_set1_pd(t0);
        let (mut acc0, mut acc1) = (zero, zero);
        let mut i = 0;
        while i + 8 <= steps {
            let (s0, tot0) = prefix!(i);
            let (s1, tot1) = prefix!(i + 4);
            let v0 = _mm256_add_pd(t, s0);
            let t1 = _mm256_add_pd(t, tot0);
            let v1 = _mm256_add_pd(t1, s1);
            t = _mm256_add_pd(t1, tot1);
            acc0 = _mm256_fmadd_pd(v0, v0, acc0);
            acc1 = _mm256_fmadd_pd(v1, v1, acc1);
            i += 8;
        }
        let mut lanes = [0.0f64; 4];
        _mm256_storeu_pd(lanes.as_mut_ptr(), _mm256_add_pd(acc0, acc1));
        let mut total = t0 * t0 + (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
        let mut tv = _mm256_cvtsd_f64(t);
        while i < steps {
            tv += (*p.add(i + 3 * m) - *p.add(i)) + 3.0 * (*p.add(i + m) - *p.add(i + 2 * m));
            total += tv * tv;
            i += 1;
        }
        total
    }
}

/// [`segment`] without AVX2: the same steps, eight at a time.
fn segment_portable(x: &[f64], m: usize, j0: usize, len: usize) -> f64 {
    const STEP: usize = 8;
    let mut t = direct(x, m, j0);
    let mut total = t * t;
    // The steps j0 .. j0 + len - 1: each moves T from j to j + 1, and the T it reaches is squared.
    let steps = len - 1;
    let a = &x[j0..j0 + steps];
    let b = &x[j0 + m..j0 + m + steps];
    let c = &x[j0 + 2 * m..j0 + 2 * m + steps];
    let d = &x[j0 + 3 * m..j0 + 3 * m + steps];
    let mut acc = [0.0f64; STEP];
    let mut i = 0;
    while i + STEP <= steps {
        let mut h = [0.0f64; STEP];
        for k in 0..STEP {
            h[k] = (d[i + k] - a[i + k]) + 3.0 * (b[i + k] - c[i + k]);
        }
        // Inclusive prefix of the block's steps.
        for k in 1..STEP {
            h[k] += h[k - 1];
        }
        for k in 0..STEP {
            let v = t + h[k];
            acc[k] += v * v;
        }
        t += h[STEP - 1];
        i += STEP;
    }
    while i < steps {
        t += (d[i] - a[i]) + 3.0 * (b[i] - c[i]);
        total += t * t;
        i += 1;
    }
    total + acc.iter().sum::<f64>()
}

/// T(j) from its definition: m second differences, eight lanes.
#[inline(always)]
fn direct(x: &[f64], m: usize, j: usize) -> f64 {
    let a = &x[j..j + m];
    let b = &x[j + m..j + 2 * m];
    let c = &x[j + 2 * m..j + 3 * m];
    let mut acc = [0.0f64; 8];
    let mut i = 0;
    while i + 8 <= m {
        for k in 0..8 {
            acc[k] += (c[i + k] - 2.0 * b[i + k]) + a[i + k];
        }
        i += 8;
    }
    let mut s = acc.iter().sum::<f64>();
    while i < m {
        s += (c[i] - 2.0 * b[i]) + a[i];
        i += 1;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each term from its definition.
    fn reference(x: &[f64], m: usize) -> f64 {
        (0..=x.len() - 3 * m)
            .map(|j| {
                let t: f64 = (j..j + m).map(|i| x[i + 2 * m] - 2.0 * x[i + m] + x[i]).sum();
                t * t
            })
            .sum()
    }

    /// The running sums equal the definition, for segment starts inside and at the end of the record, for m
    /// whose segments are longer than SEG, and for the last m with a term.
    #[test]
    fn running_sums_match_the_definition() {
        let mut g = crate::test_signals::Lcg::new(99);
        let mut walk = 0.0;
        let x: Vec<f64> = (0..3 * SEG + 777)
            .map(|_| {
                walk += g.uniform() - 0.5;
                walk
            })
            .collect();
        let ms = [1usize, 2, 3, 7, 8, 9, 100, 4096, SEG + 5, x.len() / 3, x.len() / 3 + 1, 0];
        let got = mdev_sums(&x, &ms);
        let portable = segment_portable(&x, 5, 3, x.len() - 15 - 3 + 1);
        let want = (3..=x.len() - 15).map(|j| direct(&x, 5, j).powi(2)).sum::<f64>();
        assert!((portable - want).abs() <= 1e-11 * want);
        for (&m, &g) in ms.iter().zip(&got) {
            let want = if m == 0 || 3 * m > x.len() { 0.0 } else { reference(&x, m) };
            assert!((g - want).abs() <= 1e-11 * want, "m={m}: {g} vs {want}");
        }
    }
}

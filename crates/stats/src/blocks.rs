//! ADEV and HDEV of a gap-free frequency record at power-of-two averaging factors, from the sums of the samples
//! over consecutive blocks, without the phase array: [`super::analyze`]'s path for those two statistics on
//! frequency data when every averaging factor is a power of two (the octave list is).
//!
//! The phase differences the non-overlapping estimators take are block sums of the samples: with
//! `b_k = y[km] + ... + y[km+m-1]`, `x[(k+1)m] - x[km] = tau0 (b_k - m mean)`, so ADEV's term k is
//! `tau0 (b_{k+1} - b_k)` and HDEV's `tau0 (b_{k+2} - 2 b_{k+1} + b_k)` (the mean cancels). The blocks of 2m are
//! pairs of blocks of m, so one pass over the samples, in chunks of [`CHUNK`] samples (a multiple of every m up
//! to it), builds every level up to CHUNK in cache and sums the terms inside the chunk; the terms across chunk
//! borders come from each chunk's first and last two blocks, and the levels above CHUNK from the chunks'
//! totals. The samples are summed less the first one, in pairs: the block sums are more exact than the
//! differences of an integrated phase.

use std::sync::OnceLock;

use rayon::prelude::*;

use super::deviation::{from_sum, Statistic};
use super::error::StatsError;
use super::noise_id::NoiseMethod;
use super::octave::sum8;
use super::point::{row, DevPoint, Options};
use super::series::{DataKind, Series, MAX_SAMPLE};
use super::taus::{averaging_factors, TauSpec};

/// log2 of [`CHUNK`].
const CHUNK_LOG: usize = 16;
/// Samples per chunk of the pass: its levels fit in L2.
const CHUNK: usize = 1 << CHUNK_LOG;

/// ADEV or HDEV at `taus` of the frequency record `data` by the block sums, or None when the path does not
/// apply (an averaging factor that is not a power of two, gaps, or an input error: the caller's path reports
/// it).
pub(crate) fn analyze_blocks(
    data: &[f64],
    tau0_s: f64,
    stat: Statistic,
    taus: &TauSpec,
    opts: &Options,
) -> Option<Result<Vec<DevPoint>, StatsError>> {
    if !matches!(stat, Statistic::Adev | Statistic::Hdev) || !opts.parallel || !(tau0_s > 0.0 && tau0_s.is_finite()) {
        return None;
    }
    if opts.intervals && !(opts.confidence > 0.0 && opts.confidence < 1.0) {
        return None;
    }
    let first = data.iter().position(|v| !v.is_nan())?;
    let last = data.iter().rposition(|v| !v.is_nan())? + 1;
    let y = &data[first..last];
    let n_phase = y.len() + 1;
    if n_phase < 3 {
        return None;
    }
    let ms = averaging_factors(taus, stat.stop_ratio(), stat.m_limit(n_phase), n_phase, tau0_s).ok()?;
    if !ms.iter().all(|m| m.is_power_of_two()) {
        return None;
    }
    let top = ms.last().map_or(0, |m| m.trailing_zeros() as usize);
    let levels = level_sums(y, top, stat.difference_order())?;
    let series: OnceLock<Option<Series>> = OnceLock::new();
    let one = |&m: &u64| {
        let (m, level) = (m as usize, &levels[m.trailing_zeros() as usize]);
        let (sum, n) = match stat {
            Statistic::Adev => (level.d1, level.blocks.saturating_sub(1)),
            _ => (level.d2, level.blocks.saturating_sub(2)),
        };
        let est = from_sum(stat, m, tau0_s, sum * tau0_s * tau0_s, n)?;
        Some(row(m, tau0_s, n_phase, stat, est, opts, || {
            // The noise identification reads the phase: built once, when a row first needs it.
            let s = series.get_or_init(|| Series::new(data, DataKind::Frequency, tau0_s).ok());
            s.as_ref().map_or((0, NoiseMethod::Default), |s| super::noise_id::identify(s, stat, m))
        }))
    };
    let rows: Vec<DevPoint> =
        if opts.intervals { ms.par_iter().filter_map(one).collect() } else { ms.iter().filter_map(one).collect() };
    if rows.is_empty() {
        return Some(Err(StatsError::NoTau { n_phase, gaps: 0 }));
    }
    Some(Ok(rows))
}

/// The sums of one level (m = 2^j) of block sums b: `d1 = sum (b_{k+1} - b_k)^2`, `d2 = sum (b_{k+2} - 2 b_{k+1}
/// + b_k)^2`, over the whole blocks of the record.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Level {
    pub d1: f64,
    pub d2: f64,
    /// Whole blocks of m samples in the record.
    pub blocks: usize,
}

/// What one chunk gives for one level: its sums inside the chunk, its first and last two blocks and their number.
#[derive(Debug, Clone, Copy, Default)]
struct ChunkLevel {
    d1: f64,
    d2: f64,
    head: [f64; 2],
    tail: [f64; 2],
    blocks: usize,
}

/// The levels m = 2^0 .. 2^top of the samples `y` (less y[0]), with the sums of the differences of `order` 2 or
/// 3; None when a sample is NaN, infinite or beyond
/// [`MAX_SAMPLE`].
pub(crate) fn level_sums(y: &[f64], top: usize, order: u32) -> Option<Vec<Level>> {
    let reference = y[0];
    let in_chunk = top.min(CHUNK_LOG);
    let chunks: Option<Vec<Vec<ChunkLevel>>> = y
        .par_chunks(CHUNK)
        .map_init(Vec::new, |buf: &mut Vec<f64>, ch| chunk_levels(ch, reference, in_chunk, order, buf))
        .collect();
    let chunks = chunks?;
    let mut levels = vec![Level::default(); top + 1];
    // Levels inside the chunks: their own sums, and the terms across each border from the last two blocks so far.
    for (j, level) in levels.iter_mut().enumerate().take(in_chunk + 1) {
        let mut prev: Vec<f64> = Vec::with_capacity(3);
        for cl in &chunks {
            let c = cl[j];
            level.d1 += c.d1;
            level.d2 += c.d2;
            level.blocks += c.blocks;
            let head = &c.head[..c.blocks.min(2)];
            if let (Some(&p1), Some(&h0)) = (prev.last(), head.first()) {
                level.d1 += (h0 - p1) * (h0 - p1);
                if prev.len() == 2 {
                    let v = h0 - 2.0 * p1 + prev[0];
                    level.d2 += v * v;
                }
                if let Some(&h1) = head.get(1) {
                    let v = h1 - 2.0 * h0 + p1;
                    level.d2 += v * v;
                }
            }
            // The last two blocks of the record so far.
            match c.blocks {
                0 => {}
                1 => {
                    prev.push(c.tail[1]);
                    if prev.len() > 2 {
                        prev.remove(0);
                    }
                }
                _ => prev = c.tail.to_vec(),
            }
        }
    }
    // Levels above the chunk: pairs of the whole chunks' single blocks of CHUNK samples.
    let mut b: Vec<f64> = if top > CHUNK_LOG {
        chunks[..y.len() / CHUNK].iter().map(|cl| cl[CHUNK_LOG].head[0]).collect()
    } else {
        Vec::new()
    };
    for level in levels.iter_mut().skip(CHUNK_LOG + 1) {
        b = b.chunks_exact(2).map(|p| p[0] + p[1]).collect();
        let (d1, d2) = if order == 2 { (d1(&b), 0.0) } else { (0.0, d2(&b)) };
        *level = Level { d1, d2, blocks: b.len() };
    }
    Some(levels)
}

/// Levels 0 ..= top of one chunk (top <= [`CHUNK_LOG`]); None when the chunk holds a NaN, an infinity or a
/// sample beyond [`MAX_SAMPLE`] (its sum is then not finite, or that large). Compiled for AVX2 + FMA where the
/// CPU has them.
fn chunk_levels(ch: &[f64], reference: f64, top: usize, order: u32, buf: &mut Vec<f64>) -> Option<Vec<ChunkLevel>> {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
            // SAFETY: the features were just detected on this CPU.
            return unsafe { chunk_levels_avx2(ch, reference, top, order, buf) };
        }
    }
    chunk_levels_body(ch, reference, top, order, buf)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn chunk_levels_avx2(
    ch: &[f64],
    reference: f64,
    top: usize,
    order: u32,
    buf: &mut Vec<f64>,
) -> Option<Vec<ChunkLevel>> {
    chunk_levels_body(ch, reference, top, order, buf)
}

/// [`chunk_levels`]: level 0 is the samples themselves (the reference cancels in the differences), level 1 the
/// pairs less twice the reference, each next level the pairs of the one before, in the two halves of `buf`.
#[inline(always)]
fn chunk_levels_body(
    ch: &[f64],
    reference: f64,
    top: usize,
    order: u32,
    buf: &mut Vec<f64>,
) -> Option<Vec<ChunkLevel>> {
    let mut out = Vec::with_capacity(top + 1);
    out.push(level(ch, order));
    let half = ch.len() / 2;
    if buf.len() < 2 * half.max(1) {
        buf.resize(2 * half.max(1), 0.0);
    }
    let (lo, hi) = buf[..2 * half.max(1)].split_at_mut(half.max(1));
    let r2 = 2.0 * reference;
    for (o, p) in lo[..half].iter_mut().zip(ch.chunks_exact(2)) {
        *o = (p[0] + p[1]) - r2;
    }
    // The chunk's sum less the reference, from the pairs (and an odd last sample).
    let odd = if ch.len() % 2 == 1 { ch[ch.len() - 1] - reference } else { 0.0 };
    if !((sum8(&lo[..half]) + odd).abs() <= MAX_SAMPLE) {
        return None;
    }
    if top == 0 {
        return Some(out);
    }
    out.push(level(&lo[..half], order));
    // Level j from level j - 1, alternating between the halves.
    let (mut src, mut dst) = (lo, hi);
    let mut len = half;
    for _ in 2..=top {
        len /= 2;
        for (o, p) in dst[..len].iter_mut().zip(src.chunks_exact(2)) {
            *o = p[0] + p[1];
        }
        out.push(level(&dst[..len], order));
        std::mem::swap(&mut src, &mut dst);
    }
    Some(out)
}

/// One level of a chunk from its blocks `b`: the sums of the differences of `order` 2 (ADEV) or 3 (HDEV).
#[inline(always)]
fn level(b: &[f64], order: u32) -> ChunkLevel {
    let len = b.len();
    let (d1, d2) = if order == 2 { (d1(b), 0.0) } else { (0.0, d2(b)) };
    let mut c = ChunkLevel { d1, d2, blocks: len, ..Default::default() };
    c.head[..len.min(2)].copy_from_slice(&b[..len.min(2)]);
    if len >= 2 {
        c.tail = [b[len - 2], b[len - 1]];
    } else if len == 1 {
        c.tail[1] = b[0];
    }
    c
}

/// `sum (b[k+1] - b[k])^2`, four lanes.
#[inline(always)]
fn d1(b: &[f64]) -> f64 {
    let n = b.len().saturating_sub(1);
    let (p, q) = (&b[..n], &b[b.len() - n..]);
    let mut acc = [0.0f64; 4];
    let mut i = 0;
    while i + 4 <= n {
        for k in 0..4 {
            let v = q[i + k] - p[i + k];
            acc[k] += v * v;
        }
        i += 4;
    }
    let mut s = (acc[0] + acc[1]) + (acc[2] + acc[3]);
    for k in i..n {
        s += (q[k] - p[k]) * (q[k] - p[k]);
    }
    s
}

/// `sum (b[k+2] - 2 b[k+1] + b[k])^2`, four lanes.
#[inline(always)]
fn d2(b: &[f64]) -> f64 {
    let n = b.len().saturating_sub(2);
    let (p, q, r) = (&b[..n], &b[b.len().min(1)..][..n], &b[b.len().min(2)..][..n]);
    let mut acc = [0.0f64; 4];
    let mut i = 0;
    while i + 4 <= n {
        for k in 0..4 {
            let v = (r[i + k] - 2.0 * q[i + k]) + p[i + k];
            acc[k] += v * v;
        }
        i += 4;
    }
    let mut s = (acc[0] + acc[1]) + (acc[2] + acc[3]);
    for k in i..n {
        let v = (r[k] - 2.0 * q[k]) + p[k];
        s += v * v;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::analyze_series;

    /// The block-sum path gives the phase-array path's rows (counts, and deviations within 1e-12), for records
    /// shorter than a chunk, ending inside a chunk and on a chunk border, at every octave up to the largest
    /// above the chunk; a record with a gap, or an averaging factor that is not a power of two, takes the
    /// phase-array path.
    #[test]
    fn matches_the_phase_array_path() {
        let mut g = crate::test_signals::Lcg::new(31);
        let mut walk = 0.0;
        let y: Vec<f64> = (0..9 * CHUNK + 1234)
            .map(|_| {
                let u = g.uniform() - 0.5;
                walk += 1e-3 * u;
                7.0 + u + walk
            })
            .collect();
        let ms: Vec<f64> = (0..20).map(|k| f64::from(1u32 << k) * 0.01).collect();
        for stat in [Statistic::Adev, Statistic::Hdev] {
            for len in [1000, CHUNK, 2 * CHUNK + 1, 8 * CHUNK, y.len()] {
                for (taus, intervals) in
                    [(TauSpec::Octave, false), (TauSpec::Explicit(ms.clone()), false), (TauSpec::Octave, true)]
                {
                    let opts = Options { intervals, ..Options::default() };
                    let got = analyze_blocks(&y[..len], 0.01, stat, &taus, &opts).expect("takes the path").unwrap();
                    let series = Series::new(&y[..len], DataKind::Frequency, 0.01).unwrap();
                    let want = analyze_series(&series, stat, &taus, &opts).unwrap();
                    assert_eq!(got.len(), want.len(), "{stat:?} {len}");
                    for (g, w) in got.iter().zip(&want) {
                        assert_eq!((g.m, g.n, g.alpha), (w.m, w.n, w.alpha), "{stat:?} {len}");
                        assert!(
                            ((g.dev - w.dev) / w.dev).abs() < 1e-12,
                            "{stat:?} {len} m={}: {} vs {}",
                            g.m,
                            g.dev,
                            w.dev
                        );
                    }
                }
            }
        }
        let mut gap = y.clone();
        gap[5000] = f64::NAN;
        assert!(analyze_blocks(&gap, 0.01, Statistic::Adev, &TauSpec::Octave, &Options::default()).is_none());
        let decade = TauSpec::Decade;
        assert!(analyze_blocks(&y, 0.01, Statistic::Adev, &decade, &Options::default()).is_none());
    }
}

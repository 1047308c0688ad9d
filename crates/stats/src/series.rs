//! The prepared input of every estimator: phase points, their prefix sums and the gap map.
//!
//! Frequency data y (each sample the average over tau0) become phase as allantools does:
//! `x[0] = 0, x[k+1] = x[k] + y[k] tau0`, so N frequency samples give N + 1 phase points.
//! Phase data are used as given.
//!
//! # Precision
//! A constant frequency offset (phase: a constant and a linear ramp are removed the same way) cancels in every
//! statistic here, so it is removed first: frequency data lose their mean before integration, phase data lose the
//! straight line through their end points. The integration is a plain running sum (the mean removed first keeps it small;
//! each parallel chunk starts from the offset its chunk sum gives), and the prefix sums of the
//! phase that MDEV/TDEV use on a record with gaps are kept as double-double, so long records keep their precision.
//!
//! # Gaps (NaN)
//! NaN marks a missing sample. Leading and trailing NaNs are trimmed. Inside the record, a NaN frequency sample
//! breaks the phase between its two phase points; a NaN phase point is missing itself. Every estimator term (a
//! difference) whose span touches a gap is skipped and not counted: the reported number of terms `n` is the
//! number actually averaged, and nothing is interpolated or averaged over a gap. Without gaps, `n` is Stable32's
//! `#` column.

use rayon::prelude::*;

use super::error::StatsError;
use super::kernel::oadev_range_sums;
use super::ordered::ordered_sums;

/// Work unit of the parallel passes over the samples.
const CHUNK: usize = 1 << 18;
/// Segment of the frequency integration: each starts from its own offset (from the scan's segment sums). Not a
/// power of two: the interleaved segments then fall into different cache sets (576 bytes apart modulo 4 KiB).
pub(crate) const SEG: usize = (1 << 15) + 72;
/// Segments integrated together by one thread, interleaved (independent running sums: the additions overlap
/// instead of waiting for each other).
pub(crate) const LANES: usize = 8;

/// Sum of the non-NaN samples of `ch` less `reference`, and their number (eight lanes: vectorises).
fn scan_segment(ch: &[f64], reference: f64) -> (f64, usize) {
    let (mut s, mut n) = ([0.0f64; 8], [0u64; 8]);
    let mut it = ch.chunks_exact(8);
    for q in &mut it {
        for k in 0..8 {
            let v = q[k];
            let ok = !v.is_nan();
            s[k] += if ok { v - reference } else { 0.0 };
            n[k] += ok as u64;
        }
    }
    for (k, &v) in it.remainder().iter().enumerate() {
        let ok = !v.is_nan();
        s[k] += if ok { v - reference } else { 0.0 };
        n[k] += ok as u64;
    }
    (s.iter().sum(), n.iter().sum::<u64>() as usize)
}

/// The largest magnitude a sample may have: far beyond any rate or phase a sensor reports in any unit, and small
/// enough that the squares of its differences, summed over 2^40 samples, stay finite. Beyond it a sample is taken
/// for a corrupted value ([`StatsError::TooLarge`]) instead of overflowing every Allan sum to infinity.
pub const MAX_SAMPLE: f64 = 1e100;

/// Whether `v` is a corrupted sample: infinite, or beyond [`MAX_SAMPLE`] in magnitude (NaN is a gap, not this).
pub fn is_corrupted(v: f64) -> bool {
    !(v.abs() <= MAX_SAMPLE || v.is_nan())
}

/// One parallel scan of the trimmed record `d`: per segment of SEG samples the sum of the valid samples less a
/// reference (the first sample, which is valid after trimming: the segment sums stay small and exact enough to
/// give each segment's offset), their number, and the index of the first infinity or sample beyond
/// [`MAX_SAMPLE`] when the segment has one. No branch per sample: such a sample makes the segment's sum
/// non-finite or larger than the limit, and only then is the segment searched for it.
pub(crate) fn scan(d: &[f64]) -> (f64, Vec<(f64, usize, Option<usize>)>) {
    let reference = d.first().copied().unwrap_or(0.0);
    let reference = if reference.is_finite() { reference } else { 0.0 };
    let chunks = d
        .par_chunks(SEG)
        .enumerate()
        .map(|(c, ch)| {
            let (s, n) = scan_segment(ch, reference);
            // A sum beyond the limit (or not finite) is searched for the sample that put it there. Two samples of
            // opposite sign beyond the limit in one segment could cancel and slip through; their Allan sums then
            // overflow to infinity instead.
            let bad = if s.abs() <= MAX_SAMPLE { None } else { ch.iter().position(|&v| is_corrupted(v)) };
            (s, n, bad.map(|k| c * SEG + k))
        })
        .collect();
    (reference, chunks)
}

/// Phase of up to LANES consecutive segments of SEG samples: `o[k] = off[seg] + sum_{j <= k in seg} (y[j] -
/// mean) tau0` (a NaN sample adds 0), the segments advanced together while they are all whole.
pub(crate) fn integrate_lanes(o: &mut [std::mem::MaybeUninit<f64>], y: &[f64], off: &[f64], mean: f64, tau0_s: f64) {
    let step = |v: f64| if v.is_nan() { 0.0 } else { (v - mean) * tau0_s };
    if y.len() == LANES * SEG && off.len() == LANES {
        let mut acc: [f64; LANES] = off.try_into().unwrap();
        let (ys, os) = (y.as_ptr(), o.as_mut_ptr());
        for j in 0..SEG {
            for (l, a) in acc.iter_mut().enumerate() {
                // SAFETY: l SEG + j < LANES SEG = y.len() = o.len().
                unsafe {
                    *a += step(*ys.add(l * SEG + j));
                    (*os.add(l * SEG + j)).write(*a);
                }
            }
        }
        return;
    }
    for ((o, y), &off) in o.chunks_mut(SEG).zip(y.chunks(SEG)).zip(off) {
        let mut s = off;
        for (o, &v) in o.iter_mut().zip(y) {
            s += step(v);
            o.write(s);
        }
    }
}

/// An empty vector with room for `n` phase points; a large one is backed by transparent huge pages where the
/// kernel offers them (Linux `madvise`), which cuts the page faults of its first write by 512.
fn phase_vec(n: usize) -> Vec<f64> {
    let v: Vec<f64> = Vec::with_capacity(n);
    #[cfg(target_os = "linux")]
    if n >= 1 << 20 {
        const HUGE: usize = 2 << 20;
        let p = v.as_ptr() as usize;
        let a = p.next_multiple_of(HUGE);
        let end = (p + n * 8) & !(HUGE - 1);
        if end > a {
            // SAFETY: advice on whole pages inside this vector's own allocation; no memory is accessed.
            unsafe {
                libc::madvise(a as *mut libc::c_void, end - a, libc::MADV_HUGEPAGE);
            }
        }
    }
    v
}

/// The strided MVAR at m (a multiple of [`COARSE`]) from the sums `q` of the phase over consecutive blocks of
/// COARSE points (see [`Series::mvar_coarse`]).
pub(crate) fn mvar_from_coarse(q: &[f64], m: usize, tau0_s: f64) -> Option<f64> {
    let w = m / COARSE;
    let n_terms = (q.len() + 1).checked_sub(3 * w)?;
    if n_terms == 0 {
        return None;
    }
    let win = |b: usize| q[b..b + w].iter().sum::<f64>();
    let sum: f64 = (0..n_terms)
        .map(|b| {
            let v = win(b + 2 * w) - 2.0 * win(b + w) + win(b);
            v * v
        })
        .sum();
    let (mf, tau) = (m as f64, m as f64 * tau0_s);
    Some(sum / (2.0 * mf * mf * n_terms as f64) / (tau * tau))
}

/// The gap map of the trimmed record `d`: entry k is the number of gap elements before k (see [`Series`]'s `bad`).
fn gap_map(d: &[f64], kind: DataKind, n_phase: usize) -> Vec<u32> {
    let mut b = Vec::with_capacity(n_phase + 1);
    let mut c = 0u32;
    b.push(0);
    for v in d {
        c += v.is_nan() as u32;
        b.push(c);
    }
    if kind == DataKind::Frequency {
        b.push(c);
    }
    b
}

/// The frequency record's mean and each segment's phase offset, from the scan's segment sums less `reference`.
fn segment_offsets(
    chunks: &[(f64, usize, Option<usize>)],
    reference: f64,
    n_valid: usize,
    tau0_s: f64,
) -> (f64, Vec<f64>) {
    let shift = chunks.iter().map(|c| c.0).sum::<f64>() / n_valid as f64; // mean - reference
    let mean = reference + shift;
    // Segment offsets from the segment sums of the scan: each segment then integrates from its
    // offset, in the same pass that writes the phase (the array is written once).
    let mut offsets = Vec::with_capacity(chunks.len());
    let mut acc = 0.0;
    for &(s, n, _) in chunks {
        offsets.push(acc);
        acc += (s - n as f64 * shift) * tau0_s;
    }
    (mean, offsets)
}

/// The levels of `ms` whose OADEV sums the integration takes (up to [`FUSED_MAX_M`]), sorted, without repeats.
fn fused_levels(mut ms: Vec<usize>, n_phase: usize) -> Vec<usize> {
    ms.retain(|&m| m > 0 && m <= FUSED_MAX_M && 2 * m < n_phase);
    ms.sort_unstable();
    ms.dedup();
    ms
}

/// Integrate the frequency record `d` into `out` (the phase after x[0]): the OADEV sums of `ms` inside each group.
fn integrate_frequency(
    out: &mut [std::mem::MaybeUninit<f64>],
    d: &[f64],
    offsets: &[f64],
    mean: f64,
    tau0_s: f64,
    ms: &[usize],
) -> Vec<f64> {
    // LANES segments at a time on each thread, interleaved: LANES independent running sums; then,
    // while that group's phase is in cache, the OADEV terms that lie inside it.
    let groups = out.par_chunks_mut(GROUP_LEN).zip(d.par_chunks(GROUP_LEN)).zip(offsets.par_chunks(LANES));
    ordered_sums(groups, ms.len(), |acc, ((o, ch), off)| {
        integrate_lanes(o, ch, off, mean, tau0_s);
        if !ms.is_empty() {
            // SAFETY: integrate_lanes wrote every element of o.
            let xs = unsafe { &*(o as *const [std::mem::MaybeUninit<f64>] as *const [f64]) };
            oadev_range_sums(xs, ms, 0, xs.len(), acc);
        }
    })
}

/// Write the phase record `d` into `out` less the line through its end points, gaps as 0.
fn detrend_phase(out: &mut [std::mem::MaybeUninit<f64>], d: &[f64]) {
    // Remove the line through the first and last points (both valid after trimming).
    let n1 = (d.len() - 1) as f64;
    let (a, b) = (d[0], d[d.len() - 1]);
    let slope = (b - a) / n1;
    out.par_chunks_mut(CHUNK).zip(d.par_chunks(CHUNK)).enumerate().for_each(|(c, (o, ch))| {
        for (j, (o, &v)) in o.iter_mut().zip(ch).enumerate() {
            let i = (c * CHUNK + j) as f64;
            o.write(if v.is_nan() { 0.0 } else { v - a - slope * i });
        }
    });
}

/// Add to the OADEV sums `sums` of the levels `ms` their terms over the phase `x` that cross a group boundary.
fn add_boundary_sums(x: &[f64], ms: &[usize], sums: &mut [f64]) {
    let n_phase = x.len();
    // The terms that cross from one group into the next (or start at x[0]): i in [b - 2m, b) for each
    // group start b = 1 + g GROUP_LEN (2m <= GROUP_LEN: one boundary per term at most).
    let extra = ordered_sums((0..(n_phase - 1).div_ceil(GROUP_LEN)).into_par_iter(), ms.len(), |acc, g| {
        let b = g * GROUP_LEN + 1;
        for (k, &m) in ms.iter().enumerate() {
            oadev_range_sums(x, &ms[k..k + 1], b.saturating_sub(2 * m), b, &mut acc[k..k + 1]);
        }
    });
    sums.iter_mut().zip(&extra).for_each(|(u, v)| *u += v);
}

/// What a sample is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DataKind {
    /// Phase (time error) x in seconds, one point every tau0.
    Phase,
    /// Fractional frequency (or any rate, e.g. deg/s), each sample the average over tau0.
    Frequency,
}

/// Phase points ready for the estimators, with the gap map; build once, then analyse any statistic.
#[derive(Debug, Clone)]
pub struct Series {
    /// Data kind of the input.
    pub(crate) kind: DataKind,
    /// Sample interval, seconds.
    pub(crate) tau0_s: f64,
    /// Phase points, gaps replaced by 0 (never read inside a gap: see `valid`).
    pub(crate) x: Vec<f64>,
    /// `bad[k]`: number of gap elements before k (phase: bad points in [0, k); frequency: bad intervals in [0, k)),
    /// or None when the record has no gap.
    pub(crate) bad: Option<Vec<u32>>,
    /// Prefix sums of x as double-double (hi, lo), built on first use by MDEV/TDEV on a record with gaps.
    pub(crate) prefix: std::sync::OnceLock<(Vec<f64>, Vec<f64>)>,
    /// Sums of x over consecutive blocks of [`COARSE`] points, built on first use by [`Series::mvar_coarse`].
    pub(crate) coarse: std::sync::OnceLock<Vec<f64>>,
    /// OADEV sums `(m, sum_i (x[i+2m] - 2x[i+m] + x[i])^2)` taken while the phase was written (see
    /// [`Series::with_oadev`]); empty for [`Series::new`].
    pub(crate) oadev_fused: Vec<(usize, f64)>,
}

/// The largest averaging factor whose OADEV sum [`Series::with_oadev`] takes in the integration pass.
pub(crate) const FUSED_MAX_M: usize = 1 << 13;
/// Samples per group of the frequency integration: LANES segments, in cache while their OADEV terms are summed.
pub(crate) const GROUP_LEN: usize = LANES * SEG;
const _: () = assert!(2 * FUSED_MAX_M <= GROUP_LEN);

/// Block length of the coarse phase sums.
pub(crate) const COARSE: usize = 1 << 12;
/// Records from this many phase points on use the coarse MVAR in the noise identification.
pub(crate) const COARSE_MIN_POINTS: usize = 1 << 22;

impl Series {
    /// Prepare `data` of the given kind sampled every `tau0_s` seconds.
    ///
    /// # Errors
    /// [`StatsError::BadTau0`], [`StatsError::Infinite`], or [`StatsError::TooFewSamples`] when fewer than 3 phase
    /// points remain after trimming NaNs at both ends.
    pub fn new(data: &[f64], kind: DataKind, tau0_s: f64) -> Result<Self, StatsError> {
        Series::build(data, kind, tau0_s, |_| Vec::new())
    }

    /// As [`Series::new`], and the OADEV sums of the averaging factors `oadev_ms(n_phase)` up to [`FUSED_MAX_M`]
    /// taken in the same pass, from the phase while it is still in cache (a record without gaps; otherwise
    /// none). [`super::deviation::deviations_at`] uses them.
    ///
    /// # Errors
    /// As [`Series::new`].
    pub(crate) fn with_oadev(
        data: &[f64],
        kind: DataKind,
        tau0_s: f64,
        oadev_ms: impl FnOnce(usize) -> Vec<usize>,
    ) -> Result<Self, StatsError> {
        Series::build(data, kind, tau0_s, oadev_ms)
    }

    fn build(
        data: &[f64],
        kind: DataKind,
        tau0_s: f64,
        oadev_ms: impl FnOnce(usize) -> Vec<usize>,
    ) -> Result<Self, StatsError> {
        if !(tau0_s > 0.0 && tau0_s.is_finite()) {
            return Err(StatsError::BadTau0 { tau0_s });
        }
        let first = data.iter().position(|v| !v.is_nan()).unwrap_or(data.len());
        let last = data.iter().rposition(|v| !v.is_nan()).map_or(first, |i| i + 1);
        let d = &data[first..last.max(first)];
        let n_phase = match kind {
            DataKind::Phase => d.len(),
            DataKind::Frequency => d.len() + 1,
        };
        // One parallel scan: per segment of SEG samples the sum of the valid samples less a reference (the first
        // sample, which is valid after trimming: the segment sums stay small and exact enough to give each
        // segment's offset) and their number. No branch per sample: an infinity makes the segment's sum
        // non-finite, and only then is the segment searched for it.
        let (reference, chunks) = scan(d);
        if let Some(i) = chunks.iter().find_map(|c| c.2) {
            let (index, value) = (first + i, d[i]);
            return Err(if value.is_infinite() {
                StatsError::Infinite { index }
            } else {
                StatsError::TooLarge { index, value }
            });
        }
        let n_valid: usize = chunks.iter().map(|c| c.1).sum();
        let n_nan = d.len() - n_valid;
        if d.is_empty() || n_phase < 3 {
            return Err(StatsError::TooFewSamples { valid: n_valid, needed: 3 });
        }
        let bad = (n_nan > 0).then(|| gap_map(d, kind, n_phase));
        let mut x = phase_vec(n_phase);
        let out = &mut x.spare_capacity_mut()[..n_phase];
        let mut fused = (Vec::new(), Vec::new());
        match kind {
            DataKind::Frequency => {
                let (mean, offsets) = segment_offsets(&chunks, reference, n_valid, tau0_s);
                out[0].write(0.0);
                let ms = fused_levels(if bad.is_none() { oadev_ms(n_phase) } else { Vec::new() }, n_phase);
                let sums = integrate_frequency(&mut out[1..], d, &offsets, mean, tau0_s, &ms);
                fused = (ms, sums);
            }
            DataKind::Phase => detrend_phase(out, d),
        }
        // SAFETY: every one of the n_phase elements was written above.
        unsafe { x.set_len(n_phase) };
        let (ms, mut sums) = fused;
        if !ms.is_empty() {
            add_boundary_sums(&x, &ms, &mut sums);
        }
        let oadev_fused = ms.into_iter().zip(sums).collect();
        Ok(Series {
            kind,
            tau0_s,
            x,
            bad,
            prefix: std::sync::OnceLock::new(),
            coarse: std::sync::OnceLock::new(),
            oadev_fused,
        })
    }

    /// Whether phase point k is missing (phase data) or interval [k, k+1) is (frequency data).
    #[inline]
    pub(crate) fn is_gap(&self, k: usize) -> bool {
        self.bad.as_deref().is_some_and(|b| b[k + 1] != b[k])
    }

    /// Number of phase points (frequency samples + 1 for frequency data), after trimming.
    pub fn n_phase(&self) -> usize {
        self.x.len()
    }

    /// Number of gap elements (phase points or frequency intervals that a NaN sample left undefined).
    pub fn gap_count(&self) -> usize {
        self.bad.as_ref().and_then(|b| b.last()).map_or(0, |&n| n as usize)
    }

    /// The sample interval, seconds.
    pub fn tau0_s(&self) -> f64 {
        self.tau0_s
    }

    /// The data kind the series was built from.
    pub fn kind(&self) -> DataKind {
        self.kind
    }

    /// True when the record has gaps (NaN samples inside it).
    pub fn has_gaps(&self) -> bool {
        self.bad.is_some()
    }

    /// Whether a term spanning phase points `a..=b` touches no gap.
    #[inline]
    pub(crate) fn valid(bad: &[u32], kind: DataKind, a: usize, b: usize) -> bool {
        match kind {
            DataKind::Phase => bad[b + 1] == bad[a],
            DataKind::Frequency => bad[b] == bad[a],
        }
    }

    /// The modified Allan variance at m from window sums taken every [`COARSE`] points (a strided MVAR, stride
    /// factor m / COARSE >= 16, nearly the fully overlapping one), for long gap-free records
    /// (>= [`COARSE_MIN_POINTS`]) and m a multiple of COARSE; None otherwise. One pass over the phase, shared by
    /// every m.
    pub(crate) fn mvar_coarse(&self, m: usize) -> Option<f64> {
        if self.bad.is_some() || self.x.len() < COARSE_MIN_POINTS || !m.is_multiple_of(COARSE) || m < 16 * COARSE {
            return None;
        }
        let q = self.coarse.get_or_init(|| self.x.par_chunks_exact(COARSE).map(|c| c.iter().sum::<f64>()).collect());
        mvar_from_coarse(q, m, self.tau0_s)
    }

    /// Double-double prefix sums P[k] = x[0] + ... + x[k-1], k = 0..=N.
    pub(crate) fn prefix(&self) -> &(Vec<f64>, Vec<f64>) {
        self.prefix.get_or_init(|| {
            let n = self.x.len();
            let mut hi = Vec::with_capacity(n + 1);
            let mut lo = Vec::with_capacity(n + 1);
            let (mut h, mut l) = (0.0f64, 0.0f64);
            hi.push(0.0);
            lo.push(0.0);
            for &v in &self.x {
                // TwoSum(h, v), then renormalise (h, l).
                let s = h + v;
                let bb = s - h;
                let e = (h - (s - bb)) + (v - bb);
                let l2 = l + e;
                h = s + l2;
                l = l2 - (h - s);
                hi.push(h);
                lo.push(l);
            }
            (hi, lo)
        })
    }
}

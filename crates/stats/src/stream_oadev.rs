//! Any length in bounded memory: the overlapping Allan deviation at octave tau, streamed.
//!
//! [`StreamOadev`] takes a channel's samples (rate, or ADC codes) in pieces of any size and never holds the
//! record: memory is a few chunks of [`CHUNK`] samples, whatever the length. It is the octave accumulator of
//! [`octavar_shared::acc`] in f64 with a large stride S (default [`DEFAULT_STRIDE`] = 1024):
//!
//! - levels m <= S are fully overlapping: every start index, the same terms as the in-memory OADEV;
//! - levels m > S take clusters every d = m / S samples (Greenhall's stride factor S): with S = 1024 they keep
//!   more than 99% of the fully overlapping EDF, and the EDF reported is Greenhall's for that stride
//!   ([`crate::strided_avar_edf`]).
//!
//! # How it works
//! The record is cut into chunks of [`CHUNK`] start indices; a chunk also reads the next 2^17 samples (its
//! lookahead), integrates its own local phase (from 0, less a reference rate: constants cancel in every second
//! difference) and sums, on its own, the terms that start inside it for m <= 2^16: the fully overlapping levels
//! with the vectorised kernel of [`crate::deviation`], the strided ones at multiples of d. Chunks run in
//! parallel (rayon). Levels m >= 2^17 have d >= 128 samples: each chunk hands on its 128-sample block sums, and
//! one sequential accumulator (rings of 2S phases per level, as the integer accumulator) integrates them into
//! the coarse phase and sums those levels. Integer codes are exact in f64 here (a chunk's phase stays below
//! 2^53), so a capture's raw samples give the integer accumulator's sums up to the final f64 rounding.
//!
//! # Gaps
//! A NaN sample (or a break in a capture's sample numbering) ends a segment: the terms that would span it are
//! not formed, and the segments' sums are pooled (as [`octavar_shared::acc::Snapshot::merge`]); a strided level
//! restarts its cluster grid at each segment.
//!

use rayon::prelude::*;

use crate::kernel::oadev_range_sums;
use crate::strided::{octave_points, StridedShape};
use crate::{DevPoint, Statistic, StatsError};

/// Start indices per chunk (a multiple of the coarse block).
pub const CHUNK: usize = 1 << 21;
/// The stride used unless asked otherwise.
pub const DEFAULT_STRIDE: usize = 1024;
/// Levels up to this one (m = 2^16) are summed inside the chunks.
const NEAR_LOG2: u32 = 16;
/// Lookahead of a chunk: the longest term of the in-chunk levels, 2 m.
const LOOKAHEAD: usize = 2 << NEAR_LOG2;
/// Coarse block: the step of level NEAR_LOG2 + 1 for the largest stride, 2^17 / S samples at S = 1024.
const COARSE_LOG2: u32 = NEAR_LOG2 + 1;
/// Octave levels kept (m up to 2^47 samples).
pub const LEVELS: usize = 48;

/// One level's totals.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LevelTotal {
    /// Terms summed.
    pub n: u64,
    /// Sum of squared second differences of the phase (in sample units times m: D = m (ybar2 - ybar1)).
    pub sum_sq: f64,
}

/// The streaming OADEV of one channel. Push samples, then [`StreamOadev::finish`].
pub struct StreamOadev {
    stride: usize,
    /// Samples of the current segment not yet owned by a processed chunk, plus the lookahead.
    buf: Vec<f64>,
    /// Reference subtracted from the samples of the current segment (its first sample).
    reference: Option<f64>,
    coarse: Coarse,
    levels: [LevelTotal; LEVELS],
    samples: u64,
    gaps: u64,
    segments: u64,
    seg_samples: u64,
    /// Chunks processed together (one per rayon thread).
    batch: usize,
}

impl StreamOadev {
    /// An empty accumulator with stride `stride` (a power of two, 1..=65536).
    ///
    /// # Errors
    /// [`StatsError::BadStride`].
    pub fn new(stride: usize) -> Result<Self, StatsError> {
        if !stride.is_power_of_two() || stride > 1 << NEAR_LOG2 {
            return Err(StatsError::BadStride(stride));
        }
        Ok(StreamOadev {
            stride,
            buf: Vec::new(),
            reference: None,
            coarse: Coarse::new(stride),
            levels: [LevelTotal::default(); LEVELS],
            samples: 0,
            gaps: 0,
            segments: 0,
            seg_samples: 0,
            batch: rayon::current_num_threads().clamp(1, 8),
        })
    }

    /// The stride S.
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// Samples pushed, gaps included.
    pub fn samples(&self) -> u64 {
        self.samples
    }

    /// Push samples; NaN is a gap (ends the segment).
    pub fn push(&mut self, y: &[f64]) {
        let mut rest = y;
        while !rest.is_empty() {
            match rest.iter().position(|v| v.is_nan()) {
                None => {
                    self.push_valid(rest);
                    rest = &[];
                }
                Some(k) => {
                    self.push_valid(&rest[..k]);
                    self.samples += 1;
                    self.gaps += 1;
                    self.end_segment();
                    rest = &rest[k + 1..];
                }
            }
        }
    }

    /// End the current segment here (a break in the record): no term spans the break.
    pub fn end_segment(&mut self) {
        if self.seg_samples > 0 {
            self.process(true);
            self.segments += 1;
            for (l, c) in self.levels.iter_mut().zip(self.coarse.done.iter()) {
                l.n += c.n;
                l.sum_sq += c.sum_sq;
            }
        }
        self.buf.clear();
        self.reference = None;
        self.coarse = Coarse::new(self.stride);
        self.seg_samples = 0;
    }

    fn push_valid(&mut self, y: &[f64]) {
        if y.is_empty() {
            return;
        }
        self.samples += y.len() as u64;
        self.seg_samples += y.len() as u64;
        let mut rest = y;
        while !rest.is_empty() {
            let want = self.batch * CHUNK + LOOKAHEAD;
            let take = (want - self.buf.len().min(want)).min(rest.len()).max(1);
            self.buf.extend_from_slice(&rest[..take]);
            rest = &rest[take..];
            if self.buf.len() >= want {
                self.process(false);
            }
        }
    }

    /// Process the whole chunks in `buf` (all of it when `last`), in parallel, then their coarse blocks in order.
    fn process(&mut self, last: bool) {
        let len = self.buf.len();
        let owned_total = if last { len } else { len - LOOKAHEAD };
        let n_chunks = owned_total.div_ceil(CHUNK);
        if n_chunks == 0 {
            return;
        }
        // The segment's reference rate: the mean of its first samples (keeps the coarse phase small).
        let head = &self.buf[..len.min(1 << 16)];
        let reference = *self.reference.get_or_insert_with(|| head.iter().sum::<f64>() / head.len() as f64);
        let stride = self.stride;
        let buf = &self.buf;
        let outs: Vec<ChunkOut> = (0..n_chunks)
            .into_par_iter()
            .map(|c| {
                let a = c * CHUNK;
                let owned = CHUNK.min(owned_total - a);
                let end = (a + owned + LOOKAHEAD).min(len);
                chunk_sums(&buf[a..end], owned, reference, stride)
            })
            .collect();
        for o in &outs {
            for (l, (&n, &s)) in self.levels.iter_mut().zip(o.n.iter().zip(&o.sum)) {
                l.n += n;
                l.sum_sq += s;
            }
            for &inc in &o.coarse {
                self.coarse.push(inc);
            }
        }
        if last {
            self.buf.clear();
        } else {
            self.buf.drain(..owned_total);
        }
    }

    /// Finish: the totals per level (level k: m = 2^k), with counts.
    pub fn finish(mut self) -> StreamTotals {
        self.end_segment();
        StreamTotals {
            stride: self.stride,
            samples: self.samples,
            gaps: self.gaps,
            segments: self.segments,
            levels: self.levels,
        }
    }
}

/// What [`StreamOadev::finish`] returns.
#[derive(Clone, Debug, PartialEq)]
pub struct StreamTotals {
    /// The stride S.
    pub stride: usize,
    /// Samples, gaps included.
    pub samples: u64,
    /// Gap samples (NaN).
    pub gaps: u64,
    /// Segments (gap-free runs).
    pub segments: u64,
    /// Level k: m = 2^k.
    pub levels: [LevelTotal; LEVELS],
}

impl StreamTotals {
    /// The Allan variance at level k, in the samples' unit squared (times `scale^2`).
    pub fn avar(&self, k: usize) -> Option<f64> {
        let l = self.levels.get(k)?;
        (l.n > 0).then(|| {
            let m = (1u64 << k) as f64;
            l.sum_sq / (2.0 * l.n as f64 * m * m)
        })
    }

    /// OADEV points at octave tau (m <= samples / 4, Stable32's stop ratio), in the samples' unit times
    /// `scale`, with `confidence` intervals: Greenhall's EDF for the stride, the noise type from the local slope
    /// of the Allan variance (as [`crate::strided`]).
    pub fn points(&self, tau0_s: f64, scale: f64, confidence: f64) -> Vec<DevPoint> {
        let m_stop = (self.samples - self.gaps) / Statistic::Oadev.stop_ratio();
        let avars: Vec<Option<f64>> =
            (0..LEVELS).map(|k| self.avar(k).filter(|_| (1u64 << k) <= m_stop).map(|v| v * scale * scale)).collect();
        let n_phase = (self.samples - self.gaps) as f64 + 1.0;
        let shape = StridedShape { stride: self.stride as u64, n_phase, confidence };
        octave_points(&avars, |k| self.levels[k].n, |m| m * tau0_s, &shape)
    }
}

/// One chunk's contribution.
struct ChunkOut {
    n: [u64; NEAR_LOG2 as usize + 1],
    sum: [f64; NEAR_LOG2 as usize + 1],
    /// Increments of the phase over the chunk's whole coarse blocks.
    coarse: Vec<f64>,
}

/// Terms starting at local indices [0, owned) of `y` (the chunk and its lookahead; the segment's end when the
/// lookahead is short) for levels 0..=NEAR_LOG2, and the chunk's coarse increments (of the phase less the
/// segment's `reference` rate).
fn chunk_sums(y: &[f64], owned: usize, reference: f64, stride: usize) -> ChunkOut {
    // The chunk integrates less its own reference (the mean of its first samples: a small local phase); the
    // coarse increments are corrected back to the segment's reference.
    let head = &y[..y.len().min(1 << 12)];
    let local = head.iter().sum::<f64>() / head.len().max(1) as f64;
    // The phase buffer is kept per thread: no 16 MB allocation (and its page faults) per chunk.
    thread_local! {
        static PHASE: std::cell::RefCell<Vec<f64>> = const { std::cell::RefCell::new(Vec::new()) };
    }
    PHASE.with_borrow_mut(|p| {
        p.clear();
        p.reserve(y.len() + 1);
        p.push(0.0);
        let mut s = 0.0;
        p.extend(y.iter().map(|&v| {
            s += v - local;
            s
        }));
        chunk_terms(p, owned, local, reference, stride)
    })
}

/// The sums of [`chunk_sums`] from the chunk's local phase `p` (integrated less `local`).
fn chunk_terms(p: &[f64], owned: usize, local: f64, reference: f64, stride: usize) -> ChunkOut {
    let len = p.len() - 1; // phase points 0..=len
    let mut out = ChunkOut { n: [0; NEAR_LOG2 as usize + 1], sum: [0.0; NEAR_LOG2 as usize + 1], coarse: Vec::new() };
    let s_log2 = stride.trailing_zeros();
    // Fully overlapping levels.
    let full: Vec<usize> = (0..=s_log2.min(NEAR_LOG2)).map(|k| 1usize << k).collect();
    let mut sums = vec![0.0; full.len()];
    oadev_range_sums(p, &full, 0, owned, &mut sums);
    for (k, (&m, &sum)) in full.iter().zip(&sums).enumerate() {
        out.sum[k] = sum;
        out.n[k] = owned.min((len + 1).saturating_sub(2 * m)) as u64;
    }
    // Strided levels inside the chunk: starts at multiples of d = m / S (chunk starts are multiples of every d).
    for k in s_log2 + 1..=NEAR_LOG2 {
        let m = 1usize << k;
        let d = m / stride;
        let end = owned.min((len + 1).saturating_sub(2 * m));
        let (mut sum, mut n) = (0.0, 0u64);
        let mut i = 0;
        while i < end {
            let v = p[i + 2 * m] - 2.0 * p[i + m] + p[i];
            sum += v * v;
            n += 1;
            i += d;
        }
        out.sum[k as usize] = sum;
        out.n[k as usize] = n;
    }
    // Coarse increments over whole blocks inside the owned part (all of a non-final chunk).
    let c = 1usize << (COARSE_LOG2 - s_log2.min(COARSE_LOG2));
    let shift = (local - reference) * c as f64;
    out.coarse = (0..owned.min(len) / c).map(|q| (p[(q + 1) * c] - p[q * c]) + shift).collect();
    out
}

/// The levels above NEAR_LOG2, on the coarse phase (one point every c = 2^17 / S samples): level k's step is
/// d = 2^k / S samples = 2^(k - 17) coarse points, and its ring holds the last 2S phases at multiples of it.
struct Coarse {
    stride: usize,
    /// Coarse points so far (the phase X_j at sample j c).
    j: u64,
    x: f64,
    rings: Vec<Vec<f64>>,
    done: [LevelTotal; LEVELS],
}

impl Coarse {
    fn new(stride: usize) -> Self {
        Coarse { stride, j: 0, x: 0.0, rings: Vec::new(), done: [LevelTotal::default(); LEVELS] }
    }

    fn push(&mut self, inc: f64) {
        let s = self.stride;
        // Coarse point spacing c = 2^(17 - log2 S); level 17 + r has d = 2^(17 + r - log2 S) = 2^r c.
        let first = COARSE_LOG2 as usize;
        if self.rings.is_empty() {
            self.rings = (first..LEVELS).map(|_| vec![0.0; 2 * s]).collect();
        }
        self.j += 1;
        self.x += inc;
        let mask = 2 * s as u64 - 1;
        for (r, k) in (first..LEVELS).enumerate() {
            let dc = 1u64 << r;
            if !self.j.is_multiple_of(dc) {
                break;
            }
            let u = self.j / dc;
            let slot = (u & mask) as usize;
            let ring = &mut self.rings[r];
            if u >= 2 * s as u64 {
                let v = self.x - 2.0 * ring[slot ^ s] + ring[slot];
                self.done[k].sum_sq += v * v;
                self.done[k].n += 1;
            }
            ring[slot] = self.x;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{deviation_at, DataKind, Series};

    /// Uniform white noise of mean 3.
    fn white(n: usize, seed: u64) -> Vec<f64> {
        let mut g = crate::test_signals::Lcg::new(seed);
        (0..n).map(|_| g.uniform() - 0.5 + 3.0).collect()
    }

    fn phase(y: &[f64]) -> Vec<f64> {
        let mut x = vec![0.0];
        for v in y {
            x.push(x.last().unwrap() + v - 3.0);
        }
        x
    }

    /// Direct strided reference: starts at multiples of d = max(1, m / S), i + 2m <= N.
    fn reference(y: &[f64], m: usize, stride: usize) -> (u64, f64) {
        strided(&phase(y), m, stride)
    }

    fn strided(x: &[f64], m: usize, stride: usize) -> (u64, f64) {
        let y = &x[1..];
        let d = (m / stride).max(1);
        let (mut n, mut s) = (0u64, 0.0);
        let mut i = 0;
        while i + 2 * m <= y.len() {
            let v = x[i + 2 * m] - 2.0 * x[i + m] + x[i];
            s += v * v;
            n += 1;
            i += d;
        }
        (n, s)
    }

    /// Fully overlapping levels equal the in-memory OADEV; strided levels equal the direct strided sums, for
    /// pieces of any size across chunk boundaries, and with strides small enough to use the coarse levels.
    #[test]
    fn stream_matches_in_memory_and_strided_reference() {
        let y = white(3 * CHUNK + 12_345, 5);
        let series = Series::new(&y, DataKind::Frequency, 1.0).unwrap();
        let x = phase(&y);
        for stride in [1024usize, 4] {
            let mut acc = StreamOadev::new(stride).unwrap();
            acc.batch = 2;
            let mut rest = &y[..];
            let mut piece = 1usize;
            while !rest.is_empty() {
                let k = piece.min(rest.len());
                acc.push(&rest[..k]);
                rest = &rest[k..];
                piece = piece * 3 + 7;
            }
            let t = acc.finish();
            assert_eq!(t.samples, y.len() as u64);
            for k in 0..21 {
                let m = 1usize << k;
                let (n, s) = strided(&x, m, stride);
                assert_eq!(t.levels[k].n, n, "S={stride} k={k}");
                assert!((t.levels[k].sum_sq - s).abs() <= 1e-9 * s, "S={stride} k={k}: {} vs {s}", t.levels[k].sum_sq);
                if m <= stride {
                    let e = deviation_at(&series, Statistic::Oadev, m).unwrap();
                    assert_eq!(e.n as u64, n);
                    let dev = t.avar(k).unwrap().sqrt();
                    assert!((dev / e.dev - 1.0).abs() < 1e-10, "S={stride} m={m}: {dev} vs {}", e.dev);
                }
            }
            // Above the stride: the same quantity within the strided estimator's own sampling difference.
            let pts = t.points(1.0, 1.0, 0.683);
            for p in pts.iter().filter(|p| p.m > stride as u64 && p.m <= 1 << 16) {
                let e = deviation_at(&series, Statistic::Oadev, p.m as usize).unwrap();
                assert!((p.dev / e.dev - 1.0).abs() < 3.0 / p.edf.sqrt(), "m={}: {} vs {}", p.m, p.dev, e.dev);
            }
        }
    }

    /// A NaN splits the record: the pooled sums are those of the two parts.
    #[test]
    fn a_gap_splits_the_record() {
        let mut y = white(50_000, 9);
        let cut = 20_000;
        y[cut] = f64::NAN;
        let mut acc = StreamOadev::new(1024).unwrap();
        acc.push(&y);
        let t = acc.finish();
        assert_eq!((t.gaps, t.segments), (1, 2));
        for k in 0..12 {
            let (n1, s1) = reference(&y[..cut], 1 << k, 1024);
            let (n2, s2) = reference(&y[cut + 1..], 1 << k, 1024);
            assert_eq!(t.levels[k].n, n1 + n2);
            assert!((t.levels[k].sum_sq - s1 - s2).abs() <= 1e-9 * (s1 + s2));
        }
    }
}

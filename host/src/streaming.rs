//! Any length in bounded memory: the overlapping Allan deviation at octave tau, streamed.
//!
//! [`StreamOadev`] takes a channel's samples (rate, or ADC codes) in pieces of any size and never holds the
//! record: memory is a few chunks of [`CHUNK`] samples, whatever the length. It is the octave accumulator of
//! [`octavar_shared::acc`] in f64 with a large stride S (default [`DEFAULT_STRIDE`] = 1024):
//!
//! - levels m <= S are fully overlapping: every start index, the same terms as the in-memory OADEV;
//! - levels m > S take clusters every d = m / S samples (Greenhall's stride factor S): with S = 1024 they keep
//!   more than 99% of the fully overlapping EDF, and the EDF reported is Greenhall's for that stride
//!   ([`crate::stats::strided_avar_edf`]).
//!
//! # How it works
//! The record is cut into chunks of [`CHUNK`] start indices; a chunk also reads the next 2^17 samples (its
//! lookahead), integrates its own local phase (from 0, less a reference rate: constants cancel in every second
//! difference) and sums, on its own, the terms that start inside it for m <= 2^16: the fully overlapping levels
//! with the vectorised kernel of [`crate::stats::deviation`], the strided ones at multiples of d. Chunks run in
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
//! # Inputs
//! [`BinaryFormat`] reads raw little-endian samples (f64, f32, i16, u16; one channel or interleaved);
//! [`analyze_capture`] reads a capture's raw samples (or, without raw samples, its device snapshots); and
//! [`analyze_csv`] streams a CSV through [`crate::recording::read_csv_stream`].

use std::io::{BufRead, Read};

use rayon::prelude::*;

use crate::analyze::ChannelAnalysis;
use crate::decode::{CaptureReader, DecodeError, Record};
use crate::fit::{fit, FitError, FitOptions, FitPoint};
use crate::recording::{CsvOptions, RecordingError};
use crate::snapshot_stats::{octave_points, StridedShape};
use crate::stats::deviation::oadev_range_sums;
use crate::stats::{DevPoint, Statistic};

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

/// What went wrong.
#[derive(Debug, thiserror::Error)]
pub enum StreamError {
    /// Reading failed.
    #[error("reading {name}: {source}")]
    Io {
        /// The input.
        name: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A binary input that is not a whole number of sample sets.
    #[error("{name}: {bytes} bytes is not a whole number of {channels}-channel {format} sample sets ({set} bytes each): {rest} bytes left over at the end")]
    Truncated {
        /// The input.
        name: String,
        /// Its length.
        bytes: u64,
        /// Channels per set.
        channels: usize,
        /// The format's name.
        format: &'static str,
        /// Bytes per set.
        set: usize,
        /// Bytes after the last whole set.
        rest: usize,
    },
    /// No sample at all.
    #[error("{name}: no samples")]
    Empty {
        /// The input.
        name: String,
    },
    /// A stride that is not a power of two from 1 to 2^16.
    #[error("stride {0}: use a power of two from 1 to 65536")]
    BadStride(usize),
    /// A sample rate that is not positive and finite.
    #[error("sample rate {0} Hz: must be positive and finite")]
    BadRate(f64),
    /// Too few samples for any tau.
    #[error("{name}: channel {channel}: {samples} samples are too few for an Allan deviation (need at least 8)")]
    TooShort {
        /// The input.
        name: String,
        /// The channel.
        channel: String,
        /// Samples seen.
        samples: u64,
    },
    /// A capture that could not be decoded.
    #[error(transparent)]
    Decode(#[from] DecodeError),
    /// A capture without a hello (no sample rate) or without samples and snapshots.
    #[error("{name}: {what}")]
    Capture {
        /// The capture.
        name: String,
        /// What is missing.
        what: String,
    },
    /// A CSV that could not be read.
    #[error(transparent)]
    Csv(#[from] RecordingError),
}

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
    /// [`StreamError::BadStride`].
    pub fn new(stride: usize) -> Result<Self, StreamError> {
        if !stride.is_power_of_two() || stride > 1 << NEAR_LOG2 {
            return Err(StreamError::BadStride(stride));
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
    /// of the Allan variance (as [`crate::snapshot_stats`]).
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

/// Raw little-endian sample formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BinaryFormat {
    /// IEEE 754 double.
    F64,
    /// IEEE 754 single.
    F32,
    /// Signed 16-bit integer.
    I16,
    /// Unsigned 16-bit integer (ADC codes).
    U16,
}

impl BinaryFormat {
    /// Parse `f64le`, `f32le`, `i16le`, `u16le`.
    pub fn parse(name: &str) -> Option<BinaryFormat> {
        Some(match name.trim().to_ascii_lowercase().as_str() {
            "f64le" | "f64" => BinaryFormat::F64,
            "f32le" | "f32" => BinaryFormat::F32,
            "i16le" | "i16" => BinaryFormat::I16,
            "u16le" | "u16" => BinaryFormat::U16,
            _ => return None,
        })
    }

    /// Bytes per sample.
    pub fn size(self) -> usize {
        match self {
            BinaryFormat::F64 => 8,
            BinaryFormat::F32 => 4,
            BinaryFormat::I16 | BinaryFormat::U16 => 2,
        }
    }

    /// The name, as parsed.
    pub fn name(self) -> &'static str {
        match self {
            BinaryFormat::F64 => "f64le",
            BinaryFormat::F32 => "f32le",
            BinaryFormat::I16 => "i16le",
            BinaryFormat::U16 => "u16le",
        }
    }

    pub(crate) fn decode(self, b: &[u8]) -> f64 {
        match self {
            BinaryFormat::F64 => f64::from_le_bytes(b.try_into().unwrap_or([0; 8])),
            BinaryFormat::F32 => f64::from(f32::from_le_bytes(b.try_into().unwrap_or([0; 4]))),
            BinaryFormat::I16 => f64::from(i16::from_le_bytes(b.try_into().unwrap_or([0; 2]))),
            BinaryFormat::U16 => f64::from(u16::from_le_bytes(b.try_into().unwrap_or([0; 2]))),
        }
    }
}

/// Options of the streamed analysis.
#[derive(Clone, Debug)]
pub struct StreamOptions {
    /// Sample rate, Hz (a capture's hello overrides it).
    pub rate_hz: f64,
    /// Stride S.
    pub stride: usize,
    /// Confidence of the intervals.
    pub confidence: f64,
    /// Multiply samples by this (a unit conversion to deg/s; a capture uses each channel's deg/s per code).
    pub scale: f64,
    /// The fit.
    pub fit: FitOptions,
    /// Skip the fit.
    pub no_fit: bool,
}

impl Default for StreamOptions {
    fn default() -> Self {
        StreamOptions {
            rate_hz: 1.0,
            stride: DEFAULT_STRIDE,
            confidence: 0.683,
            scale: 1.0,
            fit: FitOptions::default(),
            no_fit: false,
        }
    }
}

/// A streamed analysis: the channels (OADEV at octave tau and the fit, in the shape the in-memory path gives).
#[derive(Clone, Debug)]
pub struct StreamAnalysis {
    /// The input's name.
    pub source: String,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Samples per channel.
    pub samples: u64,
    /// The channels.
    pub channels: Vec<ChannelAnalysis>,
    /// Where the numbers came from (for the report): "samples, stride S" or "device snapshots".
    pub method: String,
}

/// Progress callback: units done so far (bytes read).
pub type Progress<'a> = &'a (dyn Fn(u64) + Sync);

fn channel_result(
    name: &str,
    totals: &StreamTotals,
    tau0_s: f64,
    scale: f64,
    opts: &StreamOptions,
    source: &str,
) -> Result<ChannelAnalysis, StreamError> {
    let points = totals.points(tau0_s, scale, opts.confidence);
    if points.is_empty() {
        return Err(StreamError::TooShort { name: source.into(), channel: name.into(), samples: totals.samples });
    }
    Ok(from_points(name, points, tau0_s, totals.samples as usize, totals.gaps as usize, opts))
}

fn from_points(
    name: &str,
    points: Vec<DevPoint>,
    tau0_s: f64,
    n_samples: usize,
    n_gaps: usize,
    opts: &StreamOptions,
) -> ChannelAnalysis {
    let fit_result = if opts.no_fit {
        Err(FitError::TooFewPoints(0))
    } else {
        let pts: Vec<FitPoint> = points
            .iter()
            .filter(|p| p.edf.is_finite() && p.edf > 0.0)
            .map(|p| FitPoint { tau_s: p.tau_s, avar: p.dev * p.dev, edf: p.edf })
            .collect();
        fit(&pts, &opts.fit)
    };
    ChannelAnalysis {
        name: name.to_string(),
        unit: "deg/s".to_string(),
        tau0_s,
        n_samples,
        n_gaps,
        stats: vec![(Statistic::Oadev, points.clone())],
        fit_points: points,
        fit: fit_result,
    }
}

/// Read exactly `buf.len()` bytes or up to the end; returns the bytes read.
fn read_full(r: &mut dyn Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut got = 0;
    while got < buf.len() {
        match r.read(&mut buf[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(got)
}

/// Analyse a raw binary input: `channels` interleaved channels of `format`, named `names` (or ch0, ch1...).
///
/// # Errors
/// I/O errors, [`StreamError::Truncated`] for a length that is not a whole number of sample sets,
/// [`StreamError::Empty`], [`StreamError::TooShort`].
pub fn analyze_binary(
    mut reader: impl Read + Send,
    name: &str,
    format: BinaryFormat,
    channels: usize,
    names: &[String],
    opts: &StreamOptions,
    progress: Progress<'_>,
) -> Result<StreamAnalysis, StreamError> {
    if !(opts.rate_hz.is_finite() && opts.rate_hz > 0.0) {
        return Err(StreamError::BadRate(opts.rate_hz));
    }
    let channels = channels.max(1);
    let set = format.size() * channels;
    let sets_per_read = (1usize << 20).div_ceil(channels);
    let mut accs: Vec<StreamOadev> = (0..channels).map(|_| StreamOadev::new(opts.stride)).collect::<Result<_, _>>()?;
    // A reader thread reads and converts blocks while the accumulators work; used blocks go back to it.
    type Block = (Vec<Vec<f64>>, u64);
    let (tx, rx) = std::sync::mpsc::sync_channel::<Result<Block, StreamError>>(2);
    let (back_tx, back_rx) = std::sync::mpsc::channel::<Vec<Vec<f64>>>();
    let bytes = std::thread::scope(|sc| -> Result<u64, StreamError> {
        sc.spawn(move || {
            let mut raw = vec![0u8; sets_per_read * set];
            let mut bytes: u64 = 0;
            let sz = format.size();
            loop {
                let got = match read_full(&mut reader, &mut raw) {
                    Ok(g) => g,
                    Err(source) => {
                        let _ = tx.send(Err(StreamError::Io { name: name.into(), source }));
                        return;
                    }
                };
                bytes += got as u64;
                if got % set != 0 {
                    let _ = tx.send(Err(StreamError::Truncated {
                        name: name.into(),
                        bytes,
                        channels,
                        format: format.name(),
                        set,
                        rest: (bytes % set as u64) as usize,
                    }));
                    return;
                }
                let mut cols = back_rx.try_recv().unwrap_or_else(|_| vec![Vec::with_capacity(sets_per_read); channels]);
                let body = &raw[..got];
                for (c, col) in cols.iter_mut().enumerate() {
                    col.clear();
                    col.extend(body.chunks_exact(set).map(|b| format.decode(&b[c * sz..(c + 1) * sz])));
                }
                if tx.send(Ok((cols, bytes))).is_err() || got < raw.len() {
                    return;
                }
            }
        });
        let mut bytes = 0;
        for msg in rx {
            let (cols, b) = msg?;
            for (acc, col) in accs.iter_mut().zip(&cols) {
                acc.push(col);
            }
            bytes = b;
            progress(bytes);
            let _ = back_tx.send(cols);
        }
        Ok(bytes)
    })?;
    if bytes == 0 {
        return Err(StreamError::Empty { name: name.into() });
    }
    let tau0 = 1.0 / opts.rate_hz;
    let mut out = Vec::new();
    let mut samples = 0;
    for (c, acc) in accs.into_iter().enumerate() {
        let totals = acc.finish();
        samples = totals.samples;
        let ch = names.get(c).cloned().unwrap_or_else(|| format!("ch{c}"));
        out.push(channel_result(&ch, &totals, tau0, opts.scale, opts, name)?);
    }
    Ok(StreamAnalysis {
        source: name.into(),
        rate_hz: opts.rate_hz,
        samples,
        channels: out,
        method: format!("streamed {} samples, stride {}", format.name(), opts.stride),
    })
}

/// Analyse a CSV recording in a stream (the columns of `csv`, converted to deg/s by the reader).
///
/// # Errors
/// The reader's errors (file, line, column), [`StreamError::TooShort`].
pub fn analyze_csv(
    reader: impl BufRead + Send,
    name: &str,
    csv: &CsvOptions,
    opts: &StreamOptions,
    progress: Progress<'_>,
) -> Result<StreamAnalysis, StreamError> {
    let n = csv.columns.len();
    let mut accs: Vec<StreamOadev> = (0..n).map(|_| StreamOadev::new(opts.stride)).collect::<Result<_, _>>()?;
    let mut cols: Vec<Vec<f64>> = vec![Vec::with_capacity(1 << 16); n];
    let mut rows: u64 = 0;
    let info = crate::recording::read_csv_stream(reader, name, csv, |row, _| {
        for (c, v) in cols.iter_mut().zip(row) {
            c.push(*v);
        }
        rows += 1;
        if cols[0].len() == 1 << 16 {
            for (acc, col) in accs.iter_mut().zip(cols.iter_mut()) {
                acc.push(col);
                col.clear();
            }
            progress(rows);
        }
    })?;
    for (acc, col) in accs.iter_mut().zip(&cols) {
        acc.push(col);
    }
    let tau0 = 1.0 / info.rate_hz;
    let mut out = Vec::new();
    for (c, acc) in accs.into_iter().enumerate() {
        let totals = acc.finish();
        out.push(channel_result(&info.columns[c], &totals, tau0, 1.0, opts, name)?);
    }
    Ok(StreamAnalysis {
        source: name.into(),
        rate_hz: info.rate_hz,
        samples: info.samples,
        channels: out,
        method: format!("streamed CSV, stride {}", opts.stride),
    })
}

/// Analyse a capture: its raw samples through the streaming accumulator (scaled by each channel's deg/s per
/// code), or, when it has none, the device's accumulator snapshots (the last of each session, pooled).
///
/// # Errors
/// Decoding errors, a capture without hello, or with neither samples nor snapshots.
pub fn analyze_capture<R: Read>(
    mut capture: CaptureReader<R>,
    opts: &StreamOptions,
    progress: Progress<'_>,
) -> Result<StreamAnalysis, StreamError> {
    let name = capture.name().to_string();
    let mut hello = None;
    let mut accs: Vec<StreamOadev> = Vec::new();
    let mut next_sample: Vec<Option<u64>> = Vec::new();
    let mut cols: Vec<Vec<f64>> = Vec::new();
    // Per channel: the snapshots of finished sessions (pooled) and the latest of the current one.
    let mut snaps: Vec<(Option<octavar_shared::acc::Snapshot>, Option<octavar_shared::acc::Snapshot>)> = Vec::new();
    let mut records = 0u64;
    for item in capture.by_ref() {
        let d = item?;
        records += 1;
        if records.is_multiple_of(4096) {
            progress(d.meta.offset);
        }
        if d.meta.restart {
            for (pooled, cur) in snaps.iter_mut() {
                if let Some(c) = cur.take() {
                    match pooled {
                        Some(p) => {
                            let _ = p.merge(&c);
                        }
                        None => *pooled = Some(c),
                    }
                }
            }
        }
        match d.record {
            Record::Hello(h) => {
                let n = h.channels.len();
                if accs.len() < n {
                    for _ in accs.len()..n {
                        accs.push(StreamOadev::new(opts.stride)?);
                    }
                    next_sample.resize(n, None);
                    cols.resize(n, Vec::new());
                    snaps.resize(n, (None, None));
                }
                hello = Some(h);
            }
            Record::Samples(s) => {
                let k = s.channels();
                if k == 0 {
                    continue;
                }
                let chans: Vec<usize> = s.mask_channels().collect();
                for &c in &chans {
                    if c >= accs.len() {
                        for _ in accs.len()..=c {
                            accs.push(StreamOadev::new(opts.stride)?);
                        }
                        next_sample.resize(c + 1, None);
                        cols.resize(c + 1, Vec::new());
                        snaps.resize(c + 1, (None, None));
                    }
                    if next_sample[c].is_some_and(|n| n != s.first_sample) {
                        accs[c].end_segment();
                    }
                    next_sample[c] = Some(s.first_sample + s.sets() as u64);
                }
                for (j, &c) in chans.iter().enumerate() {
                    cols[c].clear();
                    cols[c].extend(s.slot_codes(j).map(f64::from));
                    accs[c].push(&cols[c]);
                }
            }
            Record::Snapshot(cs) => {
                let c = cs.channel as usize;
                if c >= snaps.len() {
                    snaps.resize(c + 1, (None, None));
                }
                snaps[c].1 = Some(cs.snapshot);
            }
            _ => {}
        }
    }
    let Some(hello) = hello else {
        return Err(StreamError::Capture { name, what: "no hello frame: the sample rate is unknown".into() });
    };
    let rate = f64::from(hello.sample_rate_hz);
    if rate.is_nan() || rate <= 0.0 {
        return Err(StreamError::BadRate(rate));
    }
    let tau0 = 1.0 / rate;
    let ch_name = |c: usize| hello.channels.get(c).map_or_else(|| format!("ch{c}"), |i| i.name.as_str().to_string());
    let ch_scale = |c: usize| hello.channels.get(c).map_or(1.0, |i| octavar_shared::sensor::dps_per_code(i.kind));
    let mut out = Vec::new();
    let have_samples = accs.iter().any(|a| a.samples() > 0);
    let mut samples = 0;
    if have_samples {
        for (c, acc) in accs.into_iter().enumerate() {
            if acc.samples() == 0 {
                continue;
            }
            let totals = acc.finish();
            samples = samples.max(totals.samples);
            out.push(channel_result(&ch_name(c), &totals, tau0, ch_scale(c), opts, &name)?);
        }
        return Ok(StreamAnalysis {
            source: name,
            rate_hz: rate,
            samples,
            channels: out,
            method: format!("raw samples of the capture, stride {}", opts.stride),
        });
    }
    for (c, (pooled, cur)) in snaps.into_iter().enumerate() {
        let snap = match (pooled, cur) {
            (Some(mut p), Some(c)) => {
                let _ = p.merge(&c);
                p
            }
            (Some(p), None) | (None, Some(p)) => p,
            (None, None) => continue,
        };
        samples = samples.max(snap.samples);
        let points = crate::snapshot_stats::snapshot_points(&snap, rate, ch_scale(c), opts.confidence);
        if points.is_empty() {
            continue;
        }
        out.push(from_points(&ch_name(c), points, tau0, snap.samples as usize, 0, opts));
    }
    if out.is_empty() {
        return Err(StreamError::Capture { name, what: "neither raw samples nor snapshots".into() });
    }
    Ok(StreamAnalysis { source: name, rate_hz: rate, samples, channels: out, method: "device snapshots".into() })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::{estimate, DataKind, Series};

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
                    let e = estimate(&series, Statistic::Oadev, m).unwrap();
                    assert_eq!(e.n as u64, n);
                    let dev = t.avar(k).unwrap().sqrt();
                    assert!((dev / e.dev - 1.0).abs() < 1e-10, "S={stride} m={m}: {dev} vs {}", e.dev);
                }
            }
            // Above the stride: the same quantity within the strided estimator's own sampling difference.
            let pts = t.points(1.0, 1.0, 0.683);
            for p in pts.iter().filter(|p| p.m > stride as u64 && p.m <= 1 << 16) {
                let e = estimate(&series, Statistic::Oadev, p.m as usize).unwrap();
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

    /// A capture's raw samples (two channels, split across frames, with a break in the numbering) give the
    /// same numbers as the same codes through the binary path, scaled by each channel's deg/s per code.
    #[test]
    fn capture_raw_samples_are_streamed() {
        use octavar_shared::proto::{ChannelInfo, Encoder, Frame, Hello, Samples, MAX_CODES};
        use octavar_shared::sensor::SensorKind;
        let mut enc = Encoder::new();
        let mut bytes = Vec::new();
        let mut hello = Hello::new("t", "b", 500, 12, 3300, 8);
        let _ = hello.channels.push(ChannelInfo::new(SensorKind::Adxrs300, "gx"));
        let _ = hello.channels.push(ChannelInfo::new(SensorKind::Env05h, "gy"));
        bytes.extend_from_slice(&enc.encode_to_vec(&Frame::Hello(hello)).unwrap());
        let codes: Vec<u16> = white(20_000, 4).iter().map(|v| (v * 1000.0) as u16).collect();
        let sets = MAX_CODES / 2;
        let mut first = 0u64;
        for (f, part) in codes.chunks(sets).enumerate() {
            if f == 3 {
                first += 1000; // lost frames: a break
            }
            let mut s = Samples::new(first, 0b11);
            for &c in part {
                let _ = s.codes.push(c);
                let _ = s.codes.push(4095 - c);
            }
            first += part.len() as u64;
            bytes.extend_from_slice(&enc.encode_to_vec(&Frame::Samples(s)).unwrap());
        }
        let opts = StreamOptions::default();
        let a = analyze_capture(CaptureReader::new(&bytes[..], "t.capture"), &opts, &|_| {}).unwrap();
        assert_eq!((a.rate_hz, a.channels.len()), (500.0, 2));
        assert_eq!((a.channels[0].name.as_str(), a.channels[1].name.as_str()), ("gx", "gy"));
        // The same codes as one binary channel with the break as a NaN.
        let mut y: Vec<f64> = codes.iter().map(|&c| f64::from(c)).collect();
        y.insert(3 * sets, f64::NAN);
        let mut acc = StreamOadev::new(DEFAULT_STRIDE).unwrap();
        acc.push(&y);
        let t = acc.finish();
        let scale = octavar_shared::sensor::dps_per_code(SensorKind::Adxrs300);
        let want = t.points(1.0 / 500.0, scale, 0.683);
        for (p, q) in a.channels[0].fit_points.iter().zip(&want) {
            assert_eq!(p.n, q.n);
            assert!((p.dev / q.dev - 1.0).abs() < 1e-12, "m={}: {} vs {}", p.m, p.dev, q.dev);
        }
    }

    #[test]
    fn binary_inputs_parse_and_odd_lengths_are_errors() {
        let y = white(40_000, 3);
        let mut bytes = Vec::new();
        for v in &y {
            bytes.extend_from_slice(&(*v as f32).to_le_bytes());
            bytes.extend_from_slice(&((v * 1000.0) as i16).to_le_bytes());
        }
        // Two channels of different formats cannot be one file; use f32 pairs instead.
        let mut f32s = Vec::new();
        for v in &y {
            f32s.extend_from_slice(&(*v as f32).to_le_bytes());
            f32s.extend_from_slice(&(-*v as f32).to_le_bytes());
        }
        let opts = StreamOptions { rate_hz: 100.0, ..Default::default() };
        let a = analyze_binary(&f32s[..], "t.bin", BinaryFormat::F32, 2, &[], &opts, &|_| {}).unwrap();
        assert_eq!(a.channels.len(), 2);
        assert_eq!(a.channels[1].name, "ch1");
        assert_eq!(a.samples, y.len() as u64);
        let (p0, p1) = (&a.channels[0].fit_points[0], &a.channels[1].fit_points[0]);
        assert!((p0.dev / p1.dev - 1.0).abs() < 1e-12 && (p0.tau_s - 0.01).abs() < 1e-15);
        let u16s: Vec<u8> = y.iter().flat_map(|v| ((v * 1000.0) as u16).to_le_bytes()).collect();
        let b = analyze_binary(&u16s[..], "c.bin", BinaryFormat::U16, 1, &["gx".into()], &opts, &|_| {}).unwrap();
        assert_eq!(b.channels[0].name, "gx");
        let err = analyze_binary(&u16s[..u16s.len() - 1], "odd.bin", BinaryFormat::U16, 1, &[], &opts, &|_| {})
            .unwrap_err()
            .to_string();
        assert!(err.contains("odd.bin") && err.contains("1 bytes left over"), "{err}");
        let err = analyze_binary(&f32s[..12], "short.bin", BinaryFormat::F32, 2, &[], &opts, &|_| {}).unwrap_err();
        assert!(err.to_string().contains("left over"), "{err}");
        assert!(matches!(
            analyze_binary(&[][..], "e.bin", BinaryFormat::F64, 1, &[], &opts, &|_| {}),
            Err(StreamError::Empty { .. })
        ));
        let _ = bytes;
    }
}

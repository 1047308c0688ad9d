//! The prepared input of every estimator: phase points, their prefix sums and the gap map.
//!
//! Frequency data y (each sample the average over tau0) become phase as allantools does:
//! `x[0] = 0, x[k+1] = x[k] + y[k] tau0`, so N frequency samples give N + 1 phase points.
//! Phase data are used as given.
//!
//! # Precision
//! A constant frequency offset (phase: a constant and a linear ramp are removed the same way) cancels in every
//! statistic here, so it is removed first: frequency data lose their mean before integration, phase data lose the
//! straight line through their end points. The integration is a plain running sum (the mean removed first keeps it small), and the prefix sums of the
//! phase that MDEV/TDEV use are kept as double-double, so long records keep their precision.
//!
//! # Gaps (NaN)
//! NaN marks a missing sample. Leading and trailing NaNs are trimmed. Inside the record, a NaN frequency sample
//! breaks the phase between its two phase points; a NaN phase point is missing itself. Every estimator term (a
//! difference) whose span touches a gap is skipped and not counted: the reported number of terms `n` is the
//! number actually averaged, and nothing is interpolated or averaged over a gap. Without gaps, `n` is Stable32's
//! `#` column.

use rayon::prelude::*;

use super::error::StatsError;

/// Work unit of the parallel passes over the samples.
const CHUNK: usize = 1 << 18;

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
    /// Prefix sums of x as double-double (hi, lo), built on first use by MDEV/TDEV.
    pub(crate) prefix: std::sync::OnceLock<(Vec<f64>, Vec<f64>)>,
}

impl Series {
    /// Prepare `data` of the given kind sampled every `tau0_s` seconds.
    ///
    /// # Errors
    /// [`StatsError::BadTau0`], [`StatsError::Infinite`], or [`StatsError::TooFewSamples`] when fewer than 3 phase
    /// points remain after trimming NaNs at both ends.
    pub fn new(data: &[f64], kind: DataKind, tau0_s: f64) -> Result<Self, StatsError> {
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
        // One parallel scan: sum of the valid samples, number of NaNs, first infinity.
        let (sum, n_nan, inf) = d
            .par_chunks(CHUNK)
            .enumerate()
            .map(|(c, ch)| {
                let (mut s, mut nan, mut inf) = ([0.0f64; 4], 0usize, None);
                for (j, q) in ch.chunks(4).enumerate() {
                    for (k, &v) in q.iter().enumerate() {
                        if v.is_nan() {
                            nan += 1;
                        } else if v.is_infinite() {
                            inf = inf.or(Some(c * CHUNK + j * 4 + k));
                        } else {
                            s[k] += v;
                        }
                    }
                }
                (s.iter().sum::<f64>(), nan, inf)
            })
            .reduce(|| (0.0, 0, None), |a, b| (a.0 + b.0, a.1 + b.1, a.2.or(b.2)));
        if let Some(i) = inf {
            return Err(StatsError::Infinite { index: first + i });
        }
        if d.is_empty() || n_phase < 3 {
            return Err(StatsError::TooFewSamples { valid: d.len() - n_nan, needed: 3 });
        }
        let bad = (n_nan > 0).then(|| {
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
        });
        let x = match kind {
            DataKind::Frequency => {
                let mean = sum / (d.len() - n_nan) as f64;
                let step = |v: f64| if v.is_nan() { 0.0 } else { (v - mean) * tau0_s };
                // Parallel prefix sum: chunk totals, their exclusive scan, then each chunk from its offset.
                let totals: Vec<f64> =
                    d.par_chunks(CHUNK).map(|ch| ch.iter().map(|&v| step(v)).sum::<f64>()).collect();
                let mut offsets = Vec::with_capacity(totals.len());
                let mut acc = 0.0;
                for t in &totals {
                    offsets.push(acc);
                    acc += t;
                }
                let mut x = vec![0.0f64; n_phase];
                x[1..].par_chunks_mut(CHUNK).zip(d.par_chunks(CHUNK)).zip(offsets.par_iter()).for_each(
                    |((out, ch), &off)| {
                        let mut s = off;
                        for (o, &v) in out.iter_mut().zip(ch) {
                            s += step(v);
                            *o = s;
                        }
                    },
                );
                x
            }
            DataKind::Phase => {
                // Remove the line through the first and last points (both valid after trimming).
                let n1 = (d.len() - 1) as f64;
                let (a, b) = (d[0], d[d.len() - 1]);
                let slope = (b - a) / n1;
                let mut x = vec![0.0f64; n_phase];
                x.par_chunks_mut(CHUNK).zip(d.par_chunks(CHUNK)).enumerate().for_each(|(c, (out, ch))| {
                    for (j, (o, &v)) in out.iter_mut().zip(ch).enumerate() {
                        let i = (c * CHUNK + j) as f64;
                        *o = if v.is_nan() { 0.0 } else { v - a - slope * i };
                    }
                });
                x
            }
        };
        Ok(Series { kind, tau0_s, x, bad, prefix: std::sync::OnceLock::new() })
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

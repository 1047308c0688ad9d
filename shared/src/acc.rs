//! The exact octave Allan accumulator: integer ADC codes in, Allan variance at tau = 2^k / rate_hz out.
//!
//! It runs on the microcontroller at 2 kS/s per channel for days, in constant memory, and the host replays the
//! same codes through the same code to reproduce every device snapshot bit for bit. So the update path uses
//! integers only; the Allan variance is formed in floating point only on read-out.
//!
//! # How it works
//! The accumulator keeps the running *phase* x_t = y_1 + ... + y_t (the sum of the codes, x_0 = 0). For cluster
//! size m the Allan difference of the clusters that end at t - m and at t is the second difference
//! `D = x_t - 2 x_{t-m} + x_{t-2m}`, and
//!
//! ```text
//! AVAR(tau = m / rate_hz) = sum D^2 / (2 n m^2)        (codes^2)
//! ```
//!
//! over the n differences taken. Level k has m = 2^k. With stride `S` (a power of two, the const parameter)
//! clusters start every `m / S` samples where m > S, and at every sample where m <= S (fully overlapping), so
//! level k needs the phase at the last 2S multiples of its step `d_k = max(1, m / S)`: a ring of 2S entries.
//! `S = 1` is the classic non-overlapping estimator (allantools `adev`); larger `S` approaches the fully
//! overlapping `oadev` (Greenhall's stride factor: S = 8 keeps about 98% of its degrees of freedom).
//!
//! Work per sample: the levels with step 1 (log2 S + 1 of them) plus, amortised, one more.
//!
//! # Exactness and overflow bound
//! Codes are `u16`. Phases wrap modulo 2^32 (levels 0..16) or 2^64 (levels 16..32); a second difference computed
//! with wrapping arithmetic is exact as long as its true value fits the signed width. At level k the true
//! |D| <= m * 65535 < 2^(k+16), so levels k < 16 fit `i32` and all levels fit `i64`. D^2 is summed in `u128` per
//! level: after `count` samples, `sum_sq <= count * S * m * 65535^2 < count * 2^(6 + 31 + 32)` for S <= 64 and
//! m <= 2^31, so nothing overflows below 2^59 samples (the requirement is 2^40: 2^109 < 2^128). The sample count
//! is a `u64`. See [`SUM_SQ_BOUND_LOG2`] and the tests at the end of this file.
//!
//! # Merging
//! [`Snapshot::merge`] pools two snapshots: counts and sums add. That is the Allan variance of a record with a gap
//! between the two parts (a power cut, two sessions): the differences that would straddle the boundary are not
//! formed. Where the boundary falls on a cluster edge of every level read, this equals the whole record's
//! estimate less exactly those straddling differences; the tests check that identity.
//!
//! # Examples
//! ```
//! use octavar_shared::acc::OctaveAllan;
//! let mut acc = OctaveAllan::<1>::new();
//! for i in 0..1000u32 {
//!     acc.push((2048 + (i % 2) * 2) as u16); // alternating 2048, 2050: AVAR(m = 1) = 4 / 2 = 2
//! }
//! let snap = acc.snapshot();
//! assert_eq!(snap.levels[0].n, 999);
//! assert_eq!(snap.avar_codes2(0), Some(2.0));
//! ```

use serde::{Deserialize, Serialize};

/// Number of octave levels: tau = 2^0 .. 2^31 samples.
pub const LEVELS: usize = 32;
/// Levels whose phases are kept modulo 2^32 (|D| < 2^31 there); the rest keep 64-bit phases.
const LOW_LEVELS: usize = 16;
/// The largest stride the accumulator accepts.
pub const MAX_STRIDE: usize = 64;
/// Levels with u64 partial sums: 0..=log2 S (every sample) and the next two (steps of 2 and 4 samples), so
/// 0..=log2 MAX_STRIDE + 2.
const FAST_LEVELS: usize = 9;
/// The every-sample levels' u64 partial sums are folded into u128 every 2^16 samples.
const FLUSH_LOG2: u32 = 16;
const FLUSH_MASK: u64 = (1 << FLUSH_LOG2) - 1;
/// log2 of the bound on any level's sum of squares after 2^40 samples with the largest stride:
/// `2^40 * 64 * 2^31 * 65535^2 < 2^109`, well inside the `u128` sum.
pub const SUM_SQ_BOUND_LOG2: u32 = 40 + 6 + 31 + 32;

/// Errors of the accumulator and its snapshots.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AccError {
    /// A code outside 0..=65535 was pushed through [`OctaveAllan::push_checked`].
    CodeOutOfRange,
    /// Two snapshots with different strides cannot be merged.
    StrideMismatch,
    /// A stride that is not a power of two in 1..=64.
    BadStride,
}

impl core::fmt::Display for AccError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            AccError::CodeOutOfRange => "ADC code outside 0..=65535",
            AccError::StrideMismatch => "snapshots with different strides cannot be merged",
            AccError::BadStride => "stride must be a power of two from 1 to 64",
        })
    }
}

impl core::error::Error for AccError {}

/// The exact octave Allan accumulator for one channel, with stride `S` (1, 2, 4, 8, ... 64).
///
/// Its size is fixed at compile time (`size_of::<OctaveAllan<1>>()` is under 1 KiB, `OctaveAllan<8>` under
/// 4 KiB) and it never allocates.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OctaveAllan<const S: usize> {
    /// Samples pushed so far (t).
    count: u64,
    /// Phase x_t, modulo 2^64.
    phase: u64,
    /// Per level k < 16: the phase modulo 2^32 at the last 2S multiples of the level's step, slot
    /// `(t / d) mod 2S` stored as `[slot / S][slot % S]`. Levels below log2 S read the ring of level log2 S.
    low_ring: [[[u32; S]; 2]; LOW_LEVELS],
    /// The same for levels 16..32, modulo 2^64.
    high_ring: [[[u64; S]; 2]; LEVELS - LOW_LEVELS],
    /// Per level: the exact sum of the squared second differences (for levels 0..=log2 S, less `fast`).
    sum_sq: [u128; LEVELS],
    /// Partial sums of levels 0..=log2 S + 2, folded into `sum_sq` every 2^FLUSH_LOG2 samples. Bound: level
    /// k = log2 S + r (r <= 2; levels below log2 S count as r = 0) takes at most 2^(16 - r) terms of
    /// D^2 < 2^(32 + 2k) between folds, so its sum stays below 2^(48 + 2 log2 S + r) <= 2^62 for S <= 64.
    fast: [u64; FAST_LEVELS],
}

impl<const S: usize> Default for OctaveAllan<S> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const S: usize> OctaveAllan<S> {
    /// log2 of the stride: the highest level whose step is one sample.
    const SHIFT: u32 = S.trailing_zeros();
    const RING_MASK: u64 = 2 * S as u64 - 1;

    /// An empty accumulator.
    pub const fn new() -> Self {
        const {
            assert!(S.is_power_of_two() && S <= MAX_STRIDE, "stride must be a power of two in 1..=64");
        }
        Self {
            count: 0,
            phase: 0,
            low_ring: [[[0; S]; 2]; LOW_LEVELS],
            high_ring: [[[0; S]; 2]; LEVELS - LOW_LEVELS],
            sum_sq: [0; LEVELS],
            fast: [0; FAST_LEVELS],
        }
    }

    /// The stride S: clusters start every `m / S` samples.
    pub const fn stride(&self) -> usize {
        S
    }

    /// Samples pushed since the last reset.
    pub const fn count(&self) -> u64 {
        self.count
    }

    /// Forget everything: back to the state of [`OctaveAllan::new`].
    pub fn reset(&mut self) {
        *self = Self::new();
    }

    /// Push one code that may be out of range (a host reading text); rejects codes outside 0..=65535.
    ///
    /// # Errors
    /// [`AccError::CodeOutOfRange`], and the accumulator is left unchanged.
    pub fn push_checked(&mut self, code: i64) -> Result<(), AccError> {
        let code = u16::try_from(code).map_err(|_| AccError::CodeOutOfRange)?;
        self.push(code);
        Ok(())
    }

    /// Push a block of codes. Count, phase and the partial sums stay in registers across the block, the
    /// every-sample levels and the next two are straight-line code with 32-bit indices, and only one sample in
    /// eight calls out for the higher levels.
    pub fn push_slice(&mut self, codes: &[u16]) {
        let (mut t, mut x, mut fast) = (self.count, self.phase, self.fast);
        let mut rest = codes;
        while t + 1 < Self::WARM && !rest.is_empty() {
            t += 1;
            x = x.wrapping_add(u64::from(rest[0]));
            rest = &rest[1..];
            Self::warm_levels(&mut self.low_ring[Self::SHIFT as usize], &mut fast, t, x as u32);
            self.strided_levels(t, x, &mut fast);
        }
        for &c in rest {
            t += 1;
            x = x.wrapping_add(u64::from(c));
            Self::every_sample_levels(&mut self.low_ring[Self::SHIFT as usize], &mut fast, t as u32, x as u32);
            self.strided_levels(t, x, &mut fast);
        }
        (self.count, self.phase, self.fast) = (t, x, fast);
    }

    /// Push one ADC code: integer work only.
    #[inline]
    pub fn push(&mut self, code: u16) {
        self.push_slice(core::slice::from_ref(&code));
    }

    /// Samples after which every level 0..=log2 S takes a difference at each sample.
    const WARM: u64 = 2 * S as u64;

    /// Levels 0..=log2 S once t >= 2S (m <= S: fully overlapping): each takes a difference at every sample. They
    /// all read the ring of level log2 S, which holds x_{t-1} .. x_{t-2S} in slot `t mod 2S` (its
    /// `[slot / S][slot % S]` layout is exactly the flat order) before x_t is stored. Their squares go to u64
    /// partial sums, folded into the u128 sums every 2^FLUSH_LOG2 samples (see `fast`).
    #[inline(always)]
    fn every_sample_levels(ring: &mut [[u32; S]; 2], fast: &mut [u64; FAST_LEVELS], t: u32, x32: u32) {
        let ring = ring.as_flattened_mut();
        let mask = Self::RING_MASK as u32;
        // Written out per level (the conditions are constants), so that even an opt-level "s" build keeps
        // straight-line code with constant offsets.
        macro_rules! below_shift {
            ($k:literal) => {
                if $k < Self::SHIFT {
                    let m = 1u32 << $k;
                    let mid = ring[(t.wrapping_sub(m) & mask) as usize];
                    let old = ring[(t.wrapping_sub(2 * m) & mask) as usize];
                    fast[$k] += square32(x32.wrapping_sub(mid << 1).wrapping_add(old));
                }
            };
        }
        below_shift!(0);
        below_shift!(1);
        below_shift!(2);
        below_shift!(3);
        below_shift!(4);
        below_shift!(5);
        let j = (t & mask) as usize;
        let old = ring[j]; // x_{t - 2S}
        let mid = ring[j ^ S]; // x_{t - S}
        fast[Self::SHIFT as usize] += square32(x32.wrapping_sub(mid << 1).wrapping_add(old));
        ring[j] = x32;
    }

    /// The first 2S samples: a level takes its first difference only once 2m samples are in.
    fn warm_levels(ring: &mut [[u32; S]; 2], fast: &mut [u64; FAST_LEVELS], t: u64, x32: u32) {
        let shift = Self::SHIFT as usize;
        let ring = ring.as_flattened_mut();
        let mask = Self::RING_MASK;
        for (k, f) in fast.iter_mut().enumerate().take(shift) {
            let m = 1u64 << k;
            if t >= 2 * m {
                let mid = ring[((t - m) & mask) as usize];
                let old = ring[((t - 2 * m) & mask) as usize];
                *f += square32(x32.wrapping_sub(mid << 1).wrapping_add(old));
            }
        }
        ring[(t & mask) as usize] = x32;
    }

    /// Levels log2 S + 1 and + 2 (steps of 2 and 4 samples) inline, into partial sums; every eighth sample the
    /// higher levels, and every 2^16 samples the fold of the partial sums.
    #[inline(always)]
    fn strided_levels(&mut self, t: u64, x: u64, fast: &mut [u64; FAST_LEVELS]) {
        if t & 1 != 0 {
            return;
        }
        let shift = Self::SHIFT as usize;
        Self::near_level::<1>(&mut self.low_ring[shift + 1], &mut fast[shift + 1], t, x as u32);
        if t & 2 != 0 {
            return;
        }
        Self::near_level::<2>(&mut self.low_ring[shift + 2], &mut fast[shift + 2], t, x as u32);
        if t & 4 != 0 {
            return;
        }
        self.push_upper(t, x);
        if t & FLUSH_MASK == 0 {
            for k in 0..=shift + 2 {
                self.sum_sq[k] += u128::from(core::mem::take(&mut fast[k]));
            }
        }
    }

    /// Level log2 S + R, whose step is 2^R samples, at a multiple of 2^R.
    #[inline(always)]
    fn near_level<const R: u32>(ring: &mut [[u32; S]; 2], fast: &mut u64, t: u64, x32: u32) {
        let ring = ring.as_flattened_mut();
        let j = (t as u32) >> R;
        let slot = (j & Self::RING_MASK as u32) as usize;
        let old = ring[slot]; // x_{t - 2m}
        let mid = ring[slot ^ S]; // x_{t - m}
        if t >= (2 * S as u64) << R {
            *fast += square32(x32.wrapping_sub(mid << 1).wrapping_add(old));
        }
        ring[slot] = x32;
    }

    /// Levels log2 S + 3 and up: level k takes a phase every d = 2^(k - log2 S) samples, so this runs every
    /// eighth sample and, amortised, touches one level per eight samples.
    #[inline]
    fn push_upper(&mut self, t: u64, x: u64) {
        let shift = Self::SHIFT as usize;
        let t_lo = t as u32;
        let beyond_32_bits = t >> 32 != 0;
        let tz = if t_lo != 0 { t_lo.trailing_zeros() } else { 32 + (t >> 32).trailing_zeros() };
        let top = (shift + tz as usize).min(LEVELS - 1);
        let mask = Self::RING_MASK as u32;
        let x32 = x as u32;
        // Levels below 16: 32-bit phases. The slot (t >> (k - log2 S)) mod 2S needs bits up to k + 1 <= 16 of
        // t, so the low word of t gives it exactly; the level counts once t >= 2m.
        for k in shift + 3..=top.min(LOW_LEVELS - 1) {
            let j = t_lo >> (k - shift);
            let slot = (j & mask) as usize;
            let ring = self.low_ring[k].as_flattened_mut();
            let old = ring[slot]; // x_{t - 2m}
            let mid = ring[slot ^ S]; // x_{t - m}
            if beyond_32_bits || j >= 2 * S as u32 {
                self.sum_sq[k] += u128::from(square32(x32.wrapping_sub(mid << 1).wrapping_add(old)));
            }
            ring[slot] = x32;
        }
        // Levels 16 and up: 64-bit phases, a 128-bit square; reached once every 2^(16 - log2 S) samples at most.
        for k in (shift + 3).max(LOW_LEVELS)..=top {
            let j = t >> (k - shift);
            let slot = (j & Self::RING_MASK) as usize;
            let ring = self.high_ring[k - LOW_LEVELS].as_flattened_mut();
            let old = ring[slot];
            let mid = ring[slot ^ S];
            if j >= 2 * S as u64 {
                let d = x.wrapping_sub(mid << 1).wrapping_add(old) as i64;
                let a = u128::from(d.unsigned_abs());
                self.sum_sq[k] += a * a;
            }
            ring[slot] = x;
        }
    }

    /// Number of second differences taken so far at `level` (cluster size m = 2^level).
    pub fn pairs(&self, level: usize) -> u64 {
        pairs_after(self.count, level, S)
    }

    /// The exact sum of squared second differences at `level`, in codes^2 (times m^2).
    pub fn sum_sq(&self, level: usize) -> u128 {
        self.sum_sq[level] + self.fast.get(level).map_or(0, |&f| u128::from(f))
    }

    /// A copy of the counts and sums: what the device sends and the host compares.
    pub fn snapshot(&self) -> Snapshot {
        let mut levels = [LevelSum::default(); LEVELS];
        for (k, l) in levels.iter_mut().enumerate() {
            *l = LevelSum { n: self.pairs(k), sum_sq: self.sum_sq(k) };
        }
        Snapshot { stride: S as u8, samples: self.count, levels }
    }
}

/// The square of a second difference known to fit `i32` (computed modulo 2^32), exactly, as u64.
#[inline(always)]
fn square32(d: u32) -> u64 {
    let d = i64::from(d as i32);
    (d * d) as u64
}

/// Number of second differences at `level` after `count` samples with stride `stride`:
/// `floor(count / d) - 2 m / d + 1` (zero if negative), with step `d = max(1, m / stride)`.
pub const fn pairs_after(count: u64, level: usize, stride: usize) -> u64 {
    let m = 1u64 << level;
    let s = stride as u64;
    let d = if m > s { m / s } else { 1 };
    let steps = count / d;
    let need = 2 * m / d;
    if steps >= need {
        steps - need + 1
    } else {
        0
    }
}

/// One level of a snapshot: the number of second differences and the exact sum of their squares.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LevelSum {
    /// Number of second differences.
    pub n: u64,
    /// Sum of their squares, in codes^2 (each D is m times a difference of cluster means).
    pub sum_sq: u128,
}

/// The counts and exact sums of an accumulator at one moment: all the host needs for the Allan variance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Snapshot {
    /// The stride S of the accumulator that made it.
    pub stride: u8,
    /// Samples accumulated (for a merged snapshot, the total).
    pub samples: u64,
    /// Level k has cluster size m = 2^k.
    pub levels: [LevelSum; LEVELS],
}

impl Snapshot {
    /// An empty snapshot of an accumulator with stride `S` (a power of two in 1..=64, checked when it builds).
    pub const fn empty_for<const S: usize>() -> Self {
        assert!(S.is_power_of_two() && S <= MAX_STRIDE, "the stride is a power of two in 1..=64");
        Self { stride: S as u8, samples: 0, levels: [LevelSum { n: 0, sum_sq: 0 }; LEVELS] }
    }

    /// An empty snapshot for stride `stride`.
    ///
    /// # Errors
    /// [`AccError::BadStride`] for a stride that is not a power of two in 1..=64.
    pub fn empty(stride: usize) -> Result<Self, AccError> {
        if !stride.is_power_of_two() || stride > MAX_STRIDE {
            return Err(AccError::BadStride);
        }
        Ok(Self { stride: stride as u8, samples: 0, levels: [LevelSum::default(); LEVELS] })
    }

    /// Allan variance at `level` in codes^2: `sum_sq / (2 n m^2)`; `None` where no difference was taken.
    pub fn avar_codes2(&self, level: usize) -> Option<f64> {
        let l = self.levels.get(level)?;
        if l.n == 0 {
            return None;
        }
        let m = (1u64 << level) as f64;
        Some(l.sum_sq as f64 / (2.0 * l.n as f64 * m * m))
    }

    /// Allan deviation at `level` in codes.
    pub fn adev_codes(&self, level: usize) -> Option<f64> {
        self.avar_codes2(level).map(libm::sqrt)
    }

    /// Allan variance at `level` in (deg/s)^2, for a channel whose code step is `dps_per_code` deg/s
    /// (see [`crate::sensor::Channel::dps_per_code`]).
    pub fn avar_dps2(&self, level: usize, dps_per_code: f64) -> Option<f64> {
        self.avar_codes2(level).map(|v| v * dps_per_code * dps_per_code)
    }

    /// Greenhall's stride factor at `level`: clusters start every `m / factor` samples. It is what his
    /// equivalent-degrees-of-freedom algorithm calls S (1 non-overlapping, m fully overlapping).
    pub fn stride_factor(&self, level: usize) -> u64 {
        (1u64 << level).min(u64::from(self.stride))
    }

    /// Pool `other` into `self`: counts and sums add (the estimate of a record with a gap between the parts).
    ///
    /// # Errors
    /// [`AccError::StrideMismatch`] when the strides differ; `self` is then unchanged.
    pub fn merge(&mut self, other: &Snapshot) -> Result<(), AccError> {
        if self.stride != other.stride {
            return Err(AccError::StrideMismatch);
        }
        self.samples += other.samples;
        for (a, b) in self.levels.iter_mut().zip(other.levels.iter()) {
            a.n += b.n;
            a.sum_sq += b.sum_sq;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Independent reference: the textbook non-overlapping / strided Allan sums from cluster means, in i128.
    fn reference(codes: &[u16], level: usize, stride: usize) -> (u64, u128) {
        let m = 1usize << level;
        let step = if m > stride { m / stride } else { 1 };
        let mut prefix = vec![0i128; codes.len() + 1];
        for (i, &c) in codes.iter().enumerate() {
            prefix[i + 1] = prefix[i] + i128::from(c);
        }
        let (mut n, mut sum) = (0u64, 0u128);
        let mut start = 0;
        while start + 2 * m <= codes.len() {
            let c1 = prefix[start + m] - prefix[start];
            let c2 = prefix[start + 2 * m] - prefix[start + m];
            let d = c2 - c1;
            sum += (d * d) as u128;
            n += 1;
            start += step;
        }
        (n, sum)
    }

    fn lcg_codes(n: usize, seed: u64, bits: u32) -> Vec<u16> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((s >> 32) as u32 >> (32 - bits)) as u16
            })
            .collect()
    }

    fn check_all<const S: usize>(codes: &[u16]) {
        let mut acc = OctaveAllan::<S>::new();
        acc.push_slice(codes);
        for level in 0..LEVELS {
            let (n, sum) = reference(codes, level, S);
            assert_eq!(acc.pairs(level), n, "S={S} level {level} pair count");
            assert_eq!(acc.sum_sq(level), sum, "S={S} level {level} sum");
        }
    }

    #[test]
    fn matches_reference_for_every_stride() {
        for (len, seed) in [(1usize, 1u64), (2, 2), (3, 3), (17, 4), (1000, 5), (4099, 6)] {
            let codes = lcg_codes(len, seed, 12);
            check_all::<1>(&codes);
            check_all::<2>(&codes);
            check_all::<4>(&codes);
            check_all::<8>(&codes);
            check_all::<16>(&codes);
        }
    }

    /// One code at a time, whole slices, and random chunkings all give the same state, including across the
    /// warm-up and the 2^16-sample fold of the partial sums.
    #[test]
    fn push_and_push_slice_agree_in_any_chunking() {
        fn run<const S: usize>(codes: &[u16]) {
            let mut one = OctaveAllan::<S>::new();
            for &c in codes {
                one.push(c);
            }
            let mut whole = OctaveAllan::<S>::new();
            whole.push_slice(codes);
            let mut chunked = OctaveAllan::<S>::new();
            let mut rest = codes;
            let mut n = 1usize;
            while !rest.is_empty() {
                let k = n.min(rest.len());
                chunked.push_slice(&rest[..k]);
                rest = &rest[k..];
                n = (n * 7 + 3) % 1000;
            }
            assert_eq!(one, whole, "S={S}");
            assert_eq!(one, chunked, "S={S}");
        }
        let codes = lcg_codes((1 << 17) + 123, 21, 16);
        run::<1>(&codes);
        run::<2>(&codes);
        run::<8>(&codes);
        run::<64>(&codes);
    }

    #[test]
    fn size_is_within_budget() {
        assert!(core::mem::size_of::<OctaveAllan<1>>() <= 1024, "{}", core::mem::size_of::<OctaveAllan<1>>());
        assert!(core::mem::size_of::<OctaveAllan<8>>() <= 4096, "{}", core::mem::size_of::<OctaveAllan<8>>());
    }

    /// Square waves of full-scale codes maximise |D| at the level whose cluster matches the half period; the
    /// 32-bit phases wrap many times over. Every level must still agree exactly with the i128 reference.
    #[test]
    fn extreme_inputs_are_exact() {
        for half_period_log2 in [0u32, 3, 9, 15, 16, 17] {
            let hp = 1usize << half_period_log2;
            let len = (1usize << 19).max(8 * hp);
            let codes: Vec<u16> = (0..len).map(|i| if (i / hp).is_multiple_of(2) { 65535 } else { 0 }).collect();
            check_all::<1>(&codes);
            check_all::<8>(&codes);
            check_all::<64>(&codes);
        }
    }

    #[test]
    fn overflow_bound_holds_for_2_pow_40_samples() {
        // Worst case over levels: sum_sq <= pairs * (m * 65535)^2 with pairs <= count * S / m.
        for level in 0..LEVELS {
            let m = 1u128 << level;
            let count = 1u128 << 40;
            let pairs = count * MAX_STRIDE as u128 / m.max(1);
            let bound = pairs.checked_mul((m * 65535) * (m * 65535)).expect("bound itself fits u128");
            assert!(bound < 1u128 << SUM_SQ_BOUND_LOG2, "level {level}");
        }
        const { assert!(SUM_SQ_BOUND_LOG2 < 127) };
    }

    #[test]
    fn snapshot_merge_is_the_whole_less_the_straddling_pairs() {
        let codes = lcg_codes(1 << 14, 9, 12);
        let cut = 1 << 13; // a cluster edge of every level up to 13
        let mut a = OctaveAllan::<8>::new();
        a.push_slice(&codes[..cut]);
        let mut b = OctaveAllan::<8>::new();
        b.push_slice(&codes[cut..]);
        let mut merged = a.snapshot();
        merged.merge(&b.snapshot()).unwrap();
        assert_eq!(merged.samples, codes.len() as u64);
        for level in 0..12 {
            let (n_a, s_a) = reference(&codes[..cut], level, 8);
            let (n_b, s_b) = reference(&codes[cut..], level, 8);
            assert_eq!(merged.levels[level], LevelSum { n: n_a + n_b, sum_sq: s_a + s_b });
        }
        let other = OctaveAllan::<1>::new().snapshot();
        assert_eq!(merged.merge(&other), Err(AccError::StrideMismatch));
    }

    #[test]
    fn reset_and_checked_push() {
        let mut acc = OctaveAllan::<4>::new();
        assert_eq!(acc.push_checked(65536), Err(AccError::CodeOutOfRange));
        assert_eq!(acc.push_checked(-1), Err(AccError::CodeOutOfRange));
        assert_eq!(acc.count(), 0);
        for c in 0..100 {
            acc.push_checked(c * 7).unwrap();
        }
        assert!(acc.sum_sq(0) > 0);
        acc.reset();
        assert_eq!(acc, OctaveAllan::<4>::new());
    }

    #[test]
    fn white_noise_avar_has_the_right_scale() {
        // Uniform 12-bit codes: variance (4096^2 - 1) / 12; AVAR(m=1) of white noise equals the variance.
        let codes = lcg_codes(1 << 18, 77, 12);
        let mut acc = OctaveAllan::<1>::new();
        acc.push_slice(&codes);
        let v = acc.snapshot().avar_codes2(0).unwrap();
        let expected = (4096.0f64 * 4096.0 - 1.0) / 12.0;
        assert!((v / expected - 1.0).abs() < 0.01, "{v} vs {expected}");
    }
}

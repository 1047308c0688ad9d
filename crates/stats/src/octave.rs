//! OADEV of a long gap-free frequency record without its phase array: [`super::analyze`]'s path for
//! [`Statistic::Oadev`] when every averaging factor is near (m <= [`FUSED_MAX_M`]) or a multiple of
//! [`FAR_PITCH`] (the octave list is), from [`MIN_SAMPLES`] samples on.
//!
//! The phase `x[k+1] = x[k] + (y[k] - mean) tau0` is never stored whole (writing 8 bytes a point, and the kernel
//! zeroing the fresh pages first, was a third of the time). Instead:
//!
//! 1. one scan of the samples gives the mean and each segment's offset, as in [`Series::new`];
//! 2. each group of [`GROUP_LEN`] samples is integrated into a per-thread buffer (the group's phase, and the
//!    [`HEAD`] points before it, integrated backwards from the group's offset), and the near levels' terms that
//!    end inside the group are summed from it while it is in cache; the group keeps every [`DEC`]-th phase
//!    point and, for the noise identification, the phase sums over blocks of [`COARSE`] points;
//! 3. the far levels (m = j FAR_PITCH) are summed column by column as in [`super::deviation`], each row of a
//!    column integrated afresh from the samples, starting at its kept phase point.
//!
//! The noise identification reads the kept points (averaging factors that are multiples of DEC) or averages the
//! samples (the others), and the block sums for the coarse MVAR; the exact MVAR, needed only when R(n) falls
//! within 10% of its boundary, builds the full [`Series`] once. The rounding differs from the phase-array path
//! by a few units in the last place of the phase: about 1e-14 relative in the deviations.

use std::mem::MaybeUninit;
use std::sync::OnceLock;

use rayon::prelude::*;

use super::deviation::{deviation_at, RawDeviation, Statistic};
use super::error::StatsError;
use super::kernel::{far_sums, oadev_range_sums, FAR_PITCH, FAR_WIDTH};
use super::noise_id::{acf_noise_id_from, b1_decide, NoiseMethod};
use super::point::{row, DevPoint, Options};
use super::series::{
    mvar_from_coarse, DataKind, Series, COARSE, COARSE_MIN_POINTS, FUSED_MAX_M, GROUP_LEN, LANES, MAX_SAMPLE,
};
use super::taus::{averaging_factors, TauSpec};

/// Records from this many samples on take this path (shorter ones: the phase array, which is cheap there).
pub(crate) const MIN_SAMPLES: usize = 1 << 20;
/// Every DEC-th phase point is kept.
pub(crate) const DEC: usize = 64;
/// Phase points before its group that a group's buffer holds: the near terms that end in the group start there.
const HEAD: usize = 2 * FUSED_MAX_M;
const _: () = assert!(FAR_PITCH.is_multiple_of(DEC) && FAR_WIDTH.is_multiple_of(DEC) && COARSE.is_multiple_of(DEC));

/// What the noise identification needs of the record: the samples, the kept phase points and block sums.
struct Prepared<'a> {
    /// The data as given (for the full series on demand).
    data: &'a [f64],
    /// The samples, trimmed.
    y: &'a [f64],
    tau0_s: f64,
    mean: f64,
    n_phase: usize,
    /// `dec[k] = x[DEC k]`, every phase point with DEC k < n_phase.
    dec: Vec<f64>,
    /// Sums of x over the whole blocks of COARSE points (empty below [`COARSE_MIN_POINTS`] or without intervals).
    coarse: Vec<f64>,
    full: OnceLock<Option<Series>>,
}

/// What a group returns: its near sums, its kept phase points and its parts of the block sums.
struct GroupOut {
    sums: Vec<f64>,
    /// Kept points less x[s0], on the group's mean c.
    dec: Vec<f64>,
    coarse_first: usize,
    /// Block sums of the buffer less x[s0] (their part in this group).
    coarse: Vec<f64>,
    /// First sample, number of samples it owns, its mean, and the owned samples' sum less c.
    s0: usize,
    n: usize,
    c: f64,
    owned: f64,
}

/// OADEV at `taus` of the frequency record `data` by the path above, or None when it does not apply (short
/// record, gaps, an averaging factor it does not handle, or an input error: the caller's path reports it).
pub(crate) fn analyze_octave(
    data: &[f64],
    tau0_s: f64,
    taus: &TauSpec,
    opts: &Options,
) -> Option<Result<Vec<DevPoint>, StatsError>> {
    if !opts.parallel || !(tau0_s > 0.0 && tau0_s.is_finite()) {
        return None;
    }
    if opts.intervals && !(opts.confidence > 0.0 && opts.confidence < 1.0) {
        return None;
    }
    let first = data.iter().position(|v| !v.is_nan())?;
    let last = data.iter().rposition(|v| !v.is_nan())? + 1;
    let y = &data[first..last];
    if y.len() < MIN_SAMPLES {
        return None;
    }
    let n_phase = y.len() + 1;
    let stat = Statistic::Oadev;
    let ms = averaging_factors(taus, stat.stop_ratio(), stat.m_limit(n_phase), n_phase, tau0_s).ok()?;
    let ms: Vec<usize> = ms.iter().map(|&m| m as usize).collect();
    if !ms.iter().all(|&m| m >= 1 && (m <= FUSED_MAX_M || m.is_multiple_of(FAR_PITCH))) {
        return None;
    }
    let (rec, sums) = prepare(data, y, tau0_s, &ms, opts.intervals)?;
    let estimates: Vec<Option<RawDeviation>> = ms
        .iter()
        .map(|&m| {
            let n = n_phase.saturating_sub(2 * m);
            let s = sums.iter().find(|f| f.0 == m)?.1;
            (n > 0).then(|| RawDeviation { dev: (s / (2.0 * n as f64)).sqrt() / (m as f64 * tau0_s), n })
        })
        .collect();
    let one = |(&m, est): (&usize, &Option<RawDeviation>)| {
        est.map(|e| row(m, tau0_s, n_phase, stat, e, opts, || rec.identify(m, e.dev)))
    };
    let rows: Vec<DevPoint> = if opts.intervals {
        ms.par_iter().zip(estimates.par_iter()).filter_map(one).collect()
    } else {
        ms.iter().zip(estimates.iter()).filter_map(one).collect()
    };
    if rows.is_empty() {
        return Some(Err(StatsError::NoTau { n_phase, gaps: 0 }));
    }
    Some(Ok(rows))
}

/// The record's kept points and block sums (`with_coarse`), and the Allan sums `(m, sum)` of the averaging
/// factors `ms`; None when the samples `y` (trimmed from `data`) hold a NaN or an infinity.
fn prepare<'a>(
    data: &'a [f64],
    y: &'a [f64],
    tau0_s: f64,
    ms: &[usize],
    with_coarse: bool,
) -> Option<(Prepared<'a>, Vec<(usize, f64)>)> {
    let n_phase = y.len() + 1;
    let (near_ms, far_ms) = (levels(ms, n_phase, true), levels(ms, n_phase, false));
    let n_coarse = if with_coarse && n_phase >= COARSE_MIN_POINTS { n_phase / COARSE } else { 0 };

    // One pass over the samples, a group at a time: no scan before it, so each group integrates less its own
    // mean c (the near terms are second differences: the ramp of c - mean cancels in them); its kept points and
    // block sums are put on the record's mean afterwards.
    let outs: Option<Vec<GroupOut>> = (0..y.len().div_ceil(GROUP_LEN))
        .into_par_iter()
        .map_init(Vec::new, |buf: &mut Vec<f64>, g| integrate_group(buf, y, g, tau0_s, &near_ms, n_coarse))
        .collect();
    let outs = outs?;
    let (mean, near_sums, dec, coarse) = merge_groups(&outs, y.len(), near_ms.len(), n_coarse, tau0_s);
    debug_assert_eq!(dec.len(), (n_phase - 1) / DEC + 1);
    let far = far_sums(n_phase, &far_ms, |r0, buf| fill_column(y, &dec, mean, tau0_s, r0, buf));
    let sums = near_ms.into_iter().zip(near_sums).chain(far_ms.into_iter().zip(far)).collect();
    Some((Prepared { data, y, tau0_s, mean, n_phase, dec, coarse, full: OnceLock::new() }, sums))
}

/// The near (m <= [`FUSED_MAX_M`]) or far levels of `ms` with 2m below `n_phase`, sorted and without repeats.
fn levels(ms: &[usize], n_phase: usize, near: bool) -> Vec<usize> {
    let mut v: Vec<usize> = ms.iter().copied().filter(|&m| 2 * m < n_phase && (m <= FUSED_MAX_M) == near).collect();
    v.sort_unstable();
    v.dedup();
    v
}

/// Group `g` of the samples `y`, integrated in `buf`: its near sums of `near_ms`, kept points and block sums.
fn integrate_group(
    buf: &mut Vec<f64>,
    y: &[f64],
    g: usize,
    tau0_s: f64,
    near_ms: &[usize],
    n_coarse: usize,
) -> Option<GroupOut> {
    let s0 = g * GROUP_LEN;
    let s1 = (s0 + GROUP_LEN).min(y.len());
    let h = HEAD.min(s0);
    let base = s0 - h; // the phase point in buf[0]
    let c = group_phase(buf, &y[base..s1], tau0_s)?;
    let x: &[f64] = buf;
    let len = x.len();
    // The terms i..i+2m that end in this group (i + 2m > h in the buffer): from h + 1 on for every level,
    // then each level's 2m before.
    let mut sums = vec![0.0f64; near_ms.len()];
    oadev_range_sums(x, near_ms, h + 1, len, &mut sums);
    for (k, &m) in near_ms.iter().enumerate() {
        oadev_range_sums(x, &near_ms[k..k + 1], (h + 1).saturating_sub(2 * m), h + 1, &mut sums[k..k + 1]);
    }
    // The phase points this group owns: s0 + 1 ..= s1 (and 0 for the first), relative to x[s0].
    let (p_lo, p_hi) = (if g == 0 { 0 } else { s0 + 1 }, s1);
    let xs = x[h];
    let dec = (p_lo.div_ceil(DEC)..=p_hi / DEC).map(|k| x[k * DEC - base] - xs).collect();
    let coarse_first = p_lo / COARSE;
    let coarse = if n_coarse == 0 || coarse_first >= n_coarse {
        Vec::new()
    } else {
        (coarse_first..=(p_hi / COARSE).min(n_coarse - 1))
            .map(|b| {
                let (a, e) = ((b * COARSE).max(p_lo), (b * COARSE + COARSE - 1).min(p_hi));
                sum8(&x[a - base..=e - base]) - (e + 1 - a) as f64 * xs
            })
            .collect()
    };
    // The owned samples' sum less c: x[s1] - x[s0] in the buffer.
    let owned = (x[len - 1] - xs) / tau0_s;
    Some(GroupOut { sums, dec, coarse_first, coarse, s0, n: s1 - s0, c, owned })
}

/// The phase of `ys` less their mean c, from 0, into `buf`: c, or None for a sample not finite or too large.
fn group_phase(buf: &mut Vec<f64>, ys: &[f64], tau0_s: f64) -> Option<f64> {
    let len = ys.len() + 1;
    // Piece sums less the first sample (any NaN or infinity makes them non-finite, a sample beyond
    // MAX_SAMPLE makes them that large: that record takes the phase-array path, which names it), the group's
    // mean c, and each piece's starting point.
    let c0 = ys[0];
    let piece = ys.len() / LANES;
    let sums: [f64; LANES + 1] = std::array::from_fn(|l| {
        let e = if l == LANES { ys.len() } else { (l + 1) * piece };
        sum8(&ys[(l * piece).min(e)..e]) - (e - (l * piece).min(e)) as f64 * c0
    });
    let total: f64 = sums.iter().sum();
    if !(total.abs() <= MAX_SAMPLE) {
        return None;
    }
    let shift = total / ys.len() as f64;
    let c = c0 + shift;
    let mut off = [0.0f64; LANES + 1];
    for l in 1..=LANES {
        off[l] = off[l - 1] + (sums[l - 1] - piece as f64 * shift) * tau0_s;
    }
    buf.clear();
    buf.reserve(len);
    let sp = &mut buf.spare_capacity_mut()[..len];
    sp[0].write(0.0);
    integrate_pieces(&mut sp[1..], ys, &off, piece, c, tau0_s);
    // SAFETY: all len elements were written just above.
    unsafe { buf.set_len(len) };
    Some(c)
}

/// The groups' outputs put on the record's mean: the mean, the near sums, the kept points and the block sums.
fn merge_groups(
    outs: &[GroupOut],
    n_samples: usize,
    n_near: usize,
    n_coarse: usize,
    tau0_s: f64,
) -> (f64, Vec<f64>, Vec<f64>, Vec<f64>) {
    // The record's mean, then x[s0] of each group on it: x[p] = X[s0] + (buffer) + (c - mean) tau0 (p - s0).
    let mean = outs.iter().map(|o| o.n as f64 * o.c + o.owned).sum::<f64>() / n_samples as f64;
    let mut near_sums = vec![0.0f64; n_near];
    let mut dec = Vec::with_capacity(n_samples / DEC + 1);
    let mut coarse = vec![0.0f64; n_coarse];
    let mut x_s0 = 0.0;
    for o in outs {
        near_sums.iter_mut().zip(&o.sums).for_each(|(a, b)| *a += b);
        let slope = (o.c - mean) * tau0_s;
        let k0 = dec.len();
        dec.extend(o.dec.iter().enumerate().map(|(j, v)| x_s0 + v + slope * ((k0 + j) * DEC - o.s0) as f64));
        for (k, v) in o.coarse.iter().enumerate() {
            let b = o.coarse_first + k;
            let (a, e) =
                ((b * COARSE).max(if o.s0 == 0 { 0 } else { o.s0 + 1 }), (b * COARSE + COARSE - 1).min(o.s0 + o.n));
            // sum over p in a..=e of x_s0 + slope (p - s0), added to the buffer's part.
            let cnt = (e + 1 - a) as f64;
            let mid = (a + e) as f64 / 2.0 - o.s0 as f64;
            coarse[b] += v + cnt * (x_s0 + slope * mid);
        }
        x_s0 += (o.owned + o.n as f64 * (o.c - mean)) * tau0_s;
    }
    (mean, near_sums, dec, coarse)
}

/// Rows integrated together by [`fill_column`] (independent running sums: the additions overlap).
const FILL_ROWS: usize = 8;

/// Row q of far column r0: `x[a + l]`, a = r0 + q FAR_PITCH, from the kept point x[a] and the samples after it;
/// the points beyond the record as 0.
fn fill_column(y: &[f64], dec: &[f64], mean: f64, tau0_s: f64, r0: usize, buf: &mut [f64]) {
    let n = y.len() + 1;
    let rows = buf.len() / FAR_WIDTH;
    // Rows with all their points inside the record (a + W <= n), FILL_ROWS at a time.
    let whole = if n >= r0 + FAR_WIDTH { ((n - r0 - FAR_WIDTH) / FAR_PITCH + 1).min(rows) } else { 0 };
    let mut q = 0;
    while q + FILL_ROWS <= whole {
        #[cfg(target_arch = "x86_64")]
        for r in 0..FILL_ROWS {
            let a = r0 + (q + r + FILL_ROWS) * FAR_PITCH;
            if a + FAR_WIDTH <= y.len() {
                for l in (0..FAR_WIDTH).step_by(8) {
                    // SAFETY: a prefetch hint on an address inside y; nothing is read or written.
                    unsafe {
                        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
                            y.as_ptr().add(a + l) as *const i8
                        )
                    };
                }
            }
        }
        let a: [usize; FILL_ROWS] = std::array::from_fn(|r| r0 + (q + r) * FAR_PITCH);
        let mut v: [f64; FILL_ROWS] = std::array::from_fn(|r| dec[a[r] / DEC]);
        let out = &mut buf[q * FAR_WIDTH..(q + FILL_ROWS) * FAR_WIDTH];
        // a[r] + W - 1 <= n - 1 = y.len(): the samples a[r] .. a[r] + W - 1 exist.
        let ys: [&[f64]; FILL_ROWS] = std::array::from_fn(|r| &y[a[r]..a[r] + FAR_WIDTH - 1]);
        for r in 0..FILL_ROWS {
            out[r * FAR_WIDTH] = v[r];
        }
        for l in 1..FAR_WIDTH {
            for r in 0..FILL_ROWS {
                v[r] += (ys[r][l - 1] - mean) * tau0_s;
                out[r * FAR_WIDTH + l] = v[r];
            }
        }
        q += FILL_ROWS;
    }
    for (q, row) in buf.chunks_exact_mut(FAR_WIDTH).enumerate().skip(q) {
        let a = r0 + q * FAR_PITCH;
        let b = (a + FAR_WIDTH).min(n);
        let mut v = dec[a / DEC];
        row[0] = v;
        for l in 1..b - a {
            v += (y[a + l - 1] - mean) * tau0_s;
            row[l] = v;
        }
        row[b - a..].fill(0.0);
    }
}

/// Phase less c of LANES pieces of `piece` samples (and the rest after them), each from its offset `off[l]`:
/// `o[k] = off[l] + sum_{j <= k in piece l} (y[j] - c) tau0`, the pieces advanced together.
fn integrate_pieces(o: &mut [MaybeUninit<f64>], y: &[f64], off: &[f64; LANES + 1], piece: usize, c: f64, tau0_s: f64) {
    assert_eq!(o.len(), y.len());
    assert!(LANES * piece <= y.len());
    let mut acc: [f64; LANES] = off[..LANES].try_into().unwrap();
    let (ys, os) = (y.as_ptr(), o.as_mut_ptr());
    for j in 0..piece {
        for (l, a) in acc.iter_mut().enumerate() {
            // SAFETY: l piece + j < LANES piece <= y.len() = o.len().
            unsafe {
                *a += (*ys.add(l * piece + j) - c) * tau0_s;
                (*os.add(l * piece + j)).write(*a);
            }
        }
    }
    let mut a = off[LANES];
    for k in LANES * piece..y.len() {
        a += (y[k] - c) * tau0_s;
        o[k].write(a);
    }
}

/// The sum of `x`, eight lanes (vectorises; inlined, so that it takes the caller's target features).
#[inline(always)]
pub(super) fn sum8(x: &[f64]) -> f64 {
    let mut acc = [0.0f64; 8];
    let mut it = x.chunks_exact(8);
    for c in &mut it {
        for k in 0..8 {
            acc[k] += c[k];
        }
    }
    acc.iter().sum::<f64>() + it.remainder().iter().sum::<f64>()
}

/// The sum of `x - mean`, four lanes.
fn sum_less(x: &[f64], mean: f64) -> f64 {
    let mut acc = [0.0f64; 4];
    let mut it = x.chunks_exact(4);
    for c in &mut it {
        for k in 0..4 {
            acc[k] += c[k] - mean;
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + it.remainder().iter().map(|v| v - mean).sum::<f64>()
}

impl Prepared<'_> {
    /// Points j0..j1 of the noise identification at m: the frequency averaged over blocks of m samples, less
    /// the mean (as `noise_id`'s averages of a gap-free frequency series).
    fn averages(&self, m: usize, j0: usize, j1: usize) -> Vec<f64> {
        if m.is_multiple_of(DEC) {
            let (w, scale) = (m / DEC, 1.0 / (m as f64 * self.tau0_s));
            (j0..j1).map(|j| (self.dec[(j + 1) * w] - self.dec[j * w]) * scale).collect()
        } else {
            let inv = 1.0 / m as f64;
            (j0..j1).map(|j| sum_less(&self.y[j * m..j * m + m], self.mean) * inv).collect()
        }
    }

    /// The noise type at m for OADEV (deviation `dev`), as `analysis::identify_with` on the full series.
    fn identify(&self, m: usize, dev: f64) -> (i32, NoiseMethod) {
        let total = (self.n_phase - 1) / m;
        if let Some((a, _)) = acf_noise_id_from(DataKind::Frequency, total, 2, |j0, j1| self.averages(m, j0, j1)) {
            return (a.clamp(-2, 2), NoiseMethod::Acf);
        }
        let ybar = self.averages(m, 0, total);
        let coarse = || {
            (!self.coarse.is_empty() && m.is_multiple_of(COARSE) && m >= 16 * COARSE)
                .then(|| mvar_from_coarse(&self.coarse, m, self.tau0_s))
                .flatten()
        };
        let exact = || {
            let full = self.full.get_or_init(|| Series::new(self.data, DataKind::Frequency, self.tau0_s).ok());
            full.as_ref().and_then(|s| deviation_at(s, Statistic::Mdev, m)).map(|e| e.dev.powi(2))
        };
        match b1_decide(&ybar, m, -2, || Some(dev), || Some(dev * dev), coarse, exact) {
            Some(a) => (a.clamp(-2, 2), NoiseMethod::B1),
            None => (0, NoiseMethod::Default),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::{analyze, analyze_series};
    use crate::point::NoiseSpec;

    /// A random walk of frequency on white frequency noise, with an offset (deterministic).
    fn data(n: usize) -> Vec<f64> {
        let mut g = crate::test_signals::Lcg::new(0x2545_F491_4F6C_DD1D);
        let mut walk = 0.0;
        (0..n)
            .map(|_| {
                let u = g.uniform() - 0.5;
                walk += 1e-3 * u;
                3.0 + u + walk
            })
            .collect()
    }

    /// The path without the phase array gives the rows of the phase-array path: the same counts, noise types,
    /// EDFs, and deviations and bounds within 1e-12 relative; a record with a gap falls back to that path.
    #[test]
    fn matches_the_phase_array_path() {
        let mut y = data(MIN_SAMPLES + 300_001);
        y.insert(0, f64::NAN);
        for intervals in [false, true] {
            for noise in [NoiseSpec::Auto, NoiseSpec::Fixed(0)] {
                let opts = Options { intervals, noise, ..Options::default() };
                let got = analyze_octave(&y, 0.01, &TauSpec::Octave, &opts).expect("takes the path").unwrap();
                let series = Series::new(&y, DataKind::Frequency, 0.01).unwrap();
                let want = analyze_series(&series, Statistic::Oadev, &TauSpec::Octave, &opts).unwrap();
                assert_eq!(got.len(), want.len());
                assert!(got.iter().any(|p| p.m as usize >= 4 * FAR_PITCH));
                for (g, w) in got.iter().zip(&want) {
                    assert_eq!((g.m, g.n, g.alpha, g.noise_method), (w.m, w.n, w.alpha, w.noise_method));
                    let close = |a: f64, b: f64| (a.is_nan() && b.is_nan()) || ((a - b) / b).abs() < 1e-12;
                    assert!(close(g.dev, w.dev), "m={}: {} vs {}", g.m, g.dev, w.dev);
                    assert!(close(g.edf, w.edf) && close(g.lo, w.lo) && close(g.hi, w.hi), "m={}", g.m);
                }
            }
        }
        let mut gap = y.clone();
        gap[1000] = f64::NAN;
        assert!(analyze_octave(&gap, 0.01, &TauSpec::Octave, &Options::default()).is_none());
        let short = &y[..MIN_SAMPLES - 10];
        assert!(analyze_octave(short, 0.01, &TauSpec::Octave, &Options::default()).is_none());
        let rows = analyze(&gap, DataKind::Frequency, 0.01, Statistic::Oadev, &TauSpec::Octave, &Options::default());
        assert!(rows.unwrap().len() > 10);
    }

    /// The kept phase points and block sums (put on the record's mean after each group integrated less its own)
    /// equal those of the phase array.
    #[test]
    fn kept_points_and_block_sums_match_the_phase() {
        let y = data(COARSE_MIN_POINTS + 123_457);
        let (rec, _) = prepare(&y, &y, 0.5, &[1, 4096, FAR_PITCH], true).unwrap();
        let series = Series::new(&y, DataKind::Frequency, 0.5).unwrap();
        let scale = series.x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        assert_eq!(rec.dec.len(), (series.x.len() - 1) / DEC + 1);
        for (k, &d) in rec.dec.iter().enumerate() {
            assert!((d - series.x[k * DEC]).abs() < 1e-12 * scale, "k={k}: {d} vs {}", series.x[k * DEC]);
        }
        assert_eq!(rec.coarse.len(), series.x.len() / COARSE);
        for (b, &q) in rec.coarse.iter().enumerate() {
            let want: f64 = series.x[b * COARSE..(b + 1) * COARSE].iter().sum();
            assert!((q - want).abs() < 1e-11 * scale * COARSE as f64, "b={b}: {q} vs {want}");
        }
        let m = 64 * COARSE;
        let (a, b) = (rec.identify(m, deviation_at(&series, Statistic::Oadev, m).unwrap().dev), {
            let e = deviation_at(&series, Statistic::Oadev, m).unwrap();
            crate::point::row(m, 0.5, series.n_phase(), Statistic::Oadev, e, &Options::default(), || {
                crate::identify(&series, Statistic::Oadev, m)
            })
        });
        assert_eq!(a, (b.alpha, b.noise_method));
    }
}

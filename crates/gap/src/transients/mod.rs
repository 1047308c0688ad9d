//! Transient disturbances in a gyro record (a bump of the bench, a tug on a cable, a burst of spikes), found so
//! that the gap diagnosis can mask them as NaN gaps before it measures anything: one disturbance of a few dozen
//! samples is enough to wreck the distribution view of a day-long record. [`scan`] finds them in one part of a
//! record (training and holdout are scanned apart); [`mask`] sets their samples to NaN; [`parts`] does both on a
//! diagnosis's two parts.
//!
//! What is *not* a disturbance matters as much. Every noise process and effect the diagnosis models must come out
//! clean: white noise, flicker, random walk, a ramp, temperature coupling, sinusoids, bandwidth, Gauss-Markov
//! noise, quantisation, bias steps, isolated spikes at a steady rate (outliers) and a bistable bias. So an
//! excursion becomes an event only when it is significant at a level that controls false alarms over the whole
//! part, short (at most [`MAX_EVENT_S`] and an eighth of the part), back at its level afterwards (a step is not),
//! and not explained by the part's own processes of spikes or steps. The excursions found and not masked are
//! reported with the reason ([`Scan::left_alone`]).
//!
//! # Method
//! - **Baseline.** Every series the scan tests (the samples, block means, block energies) is compared point by
//!   point with the medians of the 16 values on each side, less the point and the blocks overlapping it. A bump
//!   stands out from both sides in the same direction, a step from one side only, a ramp from the two in opposite
//!   directions: the statistic is the smaller of the two differences when they agree in sign, else 0. Leaving the
//!   point out matters where a smooth component dominates a block length (a ramp, a drift, a slow Gauss-Markov
//!   process): a median that included it returns the point itself on every monotone stretch, and the residuals and
//!   their scale collapse to 0. The series is continued at each end by its point reflection about the end value.
//! - **Scale.** The robust scale of the two-sided residual (the value less the mean of its side medians): the
//!   largest of 1.4826 MAD, the 1%-trimmed mean absolute deviation (both Gaussian-consistent; the second keeps
//!   working on a coarse lattice where the MAD is 0 or jumps by whole steps) and, for block means and energies
//!   with at least 200 blocks, the scale that puts the quantile leaving about 10 blocks above it where a Gaussian's
//!   would be (residuals near the turning points of a smooth process are heavier-tailed than the bulk says). On a
//!   lattice of step q (the values of an ADC) the scale is at least `q / sqrt(12 L)` where the noise dithers the
//!   lattice (a per-sample scale of at least q/2, Widrow's condition), `q / sqrt(12)` where it does not.
//! - **Threshold.** At block length L, with m = n/L independent blocks, `kappa = max(5.5, sqrt(2 ln m) + 1.5)`
//!   robust scales: `sqrt(2 ln m)` is about the largest of m Gaussian values, and the margin leaves a Gaussian part
//!   about 3e-4 false alarms over all block lengths.
//! - **Spikes and bursts.** Samples beyond `kappa(n)` scales of their sides are large samples. Under the null they
//!   are a Poisson process at the part's own rate p (counted without the bursts found, iterated to a fixed point).
//!   Two of them g apart, with `m (m - 1) g / n <= alpha / 2` (the law of the smallest gap of m uniform points), or
//!   k >= 3 within an octave window w, with `n p P(Poisson(p w) >= k - 1) <= alpha / 2` over all windows, make a
//!   burst (alpha = 1e-3 per part); a burst is cut to its most significant run of large samples, so a lone spike
//!   that opened the window stays out. The spikes of a steady outlier process are not dense enough to be a burst;
//!   they are replaced by the median of the nearer side for everything that follows (so a spike does not show at
//!   every block length), and counted ([`Scan::spikes`]). A large sample whose two neighbours both stand beyond 3
//!   scales on its side is the peak of a short excursion (a swell of three samples), not a spike: it stays in and
//!   is grown like a flagged block.
//! - **Block lengths.** Block means at L = 2, 4, 8, ... up to half the longest event (and a 32nd of the part), with
//!   a stride of L/2, of the series with its large samples replaced: offsets. From L = 8, block energies: the mean
//!   of the squared scale-1 residual, each sample's capped at 9 (3 sigmas squared) so that no lone sample lifts a
//!   block by more than a few scales, cube-rooted (Wilson-Hilferty: close to Gaussian), tested for an excess only:
//!   an oscillation or a stretch of raised variance that has no mean.
//! - **Growing.** Each flagged block (or burst), the most significant first, is grown into an excursion. The
//!   baseline is the line through the medians of the record on either side of a search window 3 block lengths
//!   wider than the block; the deviations d from it are scored, and the interval of largest score sum that
//!   overlaps the block is the excursion (a burst keeps its whole span and only grows outward; a burst of separate
//!   spikes, whose large samples fill less than half its span or have both signs, is its span from first to last
//!   spike, and a burst whatever its span's mean, which the red noise under a long burst moves more than its
//!   spikes do). An offset (mean d
//!   at least half the mean |d|) scores `sign * d - k` with `k = min(|mean| / 2, 1.5 sigma)` (the CUSUM
//!   reference; the edges go where the samples are clearly raised); a burst scores its energy
//!   `min(d^2 / sigma^2, 16) - c`, c between 2 and 4 (between the noise's energy and the block's).
//! - **Judging.** Longer than the longest event: left alone ([`Reason::TooLong`]). An offset whose two sides
//!   differ by more than half its mean: a step, left alone ([`Reason::LevelChange`]). An offset whose edges the
//!   part's own steps explain: excursions that recur at a steady rate (a bistable bias, a random walk of bias
//!   steps) are a process, not events. Steps of at least half the offset are counted elsewhere in the part by a
//!   moving-sum scan at the offset's block length h and at 2h, 4h and 8h (beyond `max(3.5, sqrt(2 ln(n/h)))`
//!   robust scales, where noise alone gives about one); with k of them, `E = k (1 - exp(-k d / n))` is the
//!   expected number of pairs at most the offset's duration d apart, and `E >= 0.01` leaves it alone
//!   ([`Reason::StepProcess`]): it is masked only when fewer than one part in a hundred of that step process would
//!   show so close a pair.
//! - **Edges.** Events closer than the shorter one's length merge; each is padded by `1 + len/32` samples.
//!
//! # Cost
//! One sliding median of 15-16 values per series tested (the samples, and the block means and energies of each
//! length, 4n values in all), prefix sums for the block means, and a few selections: O(n log 16) time, O(n)
//! memory; a million samples in about 0.2 s of one core.
//!
//! # Examples
//! ```
//! use octavar_gap::transients::{mask, scan};
//! // White noise of sd 0.01 deg/s at 100 Hz, with a 2-s bump of 5 sigmas.
//! let mut s: u64 = 1;
//! let mut x: Vec<f64> = (0..100_000)
//!     .map(|_| {
//!         let mut a = 0.0;
//!         for _ in 0..12 {
//!             s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
//!             a += (s >> 11) as f64 / (1u64 << 53) as f64;
//!         }
//!         (a - 6.0) * 0.01
//!     })
//!     .collect();
//! x[40_000..40_200].iter_mut().for_each(|v| *v += 0.05);
//! let found = scan(&x, 100.0);
//! assert_eq!(found.events.len(), 1);
//! let e = &found.events[0];
//! assert!(e.start <= 40_000 && e.end() >= 40_200 && e.len < 220);
//! mask(&mut x, &found.events);
//! assert!(x[40_100].is_nan() && x[39_000].is_finite());
//! ```
//!
//! # Layout
//! This module holds the public types, [`scan`] (the pass over a part, from the large samples to the judged
//! excursions) and [`mask`]; `stats` the robust local statistics every series is tested with (side medians,
//! residuals, scales, thresholds, prefix sums); `bursts` the Poisson test that groups large samples into bursts;
//! `excursion` the growing of a flagged block into an excursion, the step-process test of an offset and the
//! merging and padding of the events.

mod bursts;
mod excursion;
pub mod parts;
mod stats;
#[cfg(test)]
mod tests;

use std::collections::HashMap;

use serde::Serialize;

use bursts::find_bursts;
use excursion::{merge_and_pad, Core, Ctx};
pub use parts::{Masked, Part};
use stats::{kappa, normal_sf, prev_pow2, quantum, residuals, robust_scale, Prefix};

/// The longest disturbance accepted as an event, s: a longer excursion is a change of level, not a transient.
pub const MAX_EVENT_S: f64 = 600.0;
/// The longest event as a fraction of the part scanned.
const MAX_EVENT_FRACTION: f64 = 0.125;
/// The baseline of a point: the medians of the `WINDOW_BLOCKS / 2` values on each side.
const WINDOW_BLOCKS: usize = 33;
/// A large sample whose two neighbours both stand this many robust scales beyond their sides, on its side, is the
/// peak of a short excursion, not a spike: an isolated spike's neighbours are noise, and both beyond 3 scales on
/// the spike's side happens about twice in a million spikes.
const SHOULDER_Z: f64 = 3.0;
/// An offset whose two sides differ by more than this fraction of its mean does not return: a level change.
const RETURN_FRACTION: f64 = 0.5;
/// The cap on one sample's energy, in squared per-sample scales.
const ENERGY_CAP: f64 = 9.0;
/// The shortest block whose energy is tested, samples: shorter bursts are found by their large samples.
const MIN_ENERGY_BLOCK: usize = 8;
/// Fewest valid samples a part needs to be scanned.
const MIN_SAMPLES: usize = 2 * WINDOW_BLOCKS + 1;

/// The shape of a disturbance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Shape {
    /// Mostly of one sign: the samples are offset from the baseline (a bump, a tug).
    Offset,
    /// Both signs: large samples scattered about the baseline (a burst of spikes, an oscillation).
    Burst,
}

/// One transient disturbance found in a series.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Transient {
    /// First sample (its edge margin included).
    pub start: usize,
    /// Samples, edge margins included.
    pub len: usize,
    /// The largest |x - local baseline| within it, deg/s.
    pub peak_dps: f64,
    /// The mean of x - local baseline over it, deg/s.
    pub mean_dps: f64,
    /// Offset or burst.
    pub shape: Shape,
    /// The block length at which it stands out most, samples (1: a burst of large samples).
    pub scale: usize,
    /// How far it stands out there, in robust scales of that block length (for a burst, its largest sample's).
    pub z: f64,
}

impl Transient {
    /// One past the last sample.
    pub fn end(&self) -> usize {
        self.start + self.len
    }
}

/// Why an excursion was left alone.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "reason", rename_all = "snake_case")]
pub enum Reason {
    /// Longer than the longest event accepted.
    TooLong {
        /// The longest event accepted, samples.
        max_len: usize,
    },
    /// An offset that does not return to its level before: a step.
    LevelChange {
        /// Level before, deg/s.
        before_dps: f64,
        /// Level after, deg/s.
        after_dps: f64,
    },
    /// An offset whose two edges the record's own steps explain (a bistable bias, bias steps).
    StepProcess {
        /// Steps at least half the offset's size elsewhere in the part.
        other_steps: usize,
        /// Expected number of pairs of such steps at most the offset's duration apart.
        expected_pairs: f64,
    },
}

/// An excursion found and not masked.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LeftAlone {
    /// Where and how large.
    pub excursion: Transient,
    /// Why it is not an event.
    pub reason: Reason,
}

/// What [`scan`] found in a part.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Scan {
    /// The disturbances to mask, in time order.
    pub events: Vec<Transient>,
    /// Excursions found and left alone (steps, recurring excursions, too long), in time order.
    pub left_alone: Vec<LeftAlone>,
    /// Isolated large samples set aside as spikes (a process, not events).
    pub spikes: usize,
    /// Their rate per valid sample (the burst test's null rate).
    pub spike_rate: f64,
    /// The robust per-sample scale of x about its running median, deg/s.
    pub sigma_dps: f64,
    /// The value lattice's step, deg/s (0 when the values are not on one).
    pub quantum_dps: f64,
    /// The longest event accepted, samples.
    pub max_len: usize,
    /// Each block length scanned.
    pub scales: Vec<ScaleStat>,
}

/// One block length of the scan.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ScaleStat {
    /// Block length, samples.
    pub len: usize,
    /// Robust scale of the block means about their running median, deg/s.
    pub sigma_dps: f64,
    /// The threshold, in those scales.
    pub threshold: f64,
    /// Blocks beyond it.
    pub flagged: usize,
    /// The largest |block mean - baseline|, in those scales.
    pub max_z: f64,
    /// Blocks whose energy (mean squared deviation) stands out beyond the threshold.
    pub energy_flagged: usize,
    /// The largest energy excess, in robust scales.
    pub energy_max_z: f64,
}

impl Scan {
    fn empty() -> Scan {
        Scan {
            events: Vec::new(),
            left_alone: Vec::new(),
            spikes: 0,
            spike_rate: 0.0,
            sigma_dps: f64::NAN,
            quantum_dps: 0.0,
            max_len: 0,
            scales: Vec::new(),
        }
    }
}

/// Find the transient disturbances of `x` (deg/s at `rate_hz`; NaN and infinities are gaps). See the module doc for
/// the method. A part with fewer than 67 valid samples, or an invalid rate, gives an empty scan; nothing panics.
pub fn scan(x: &[f64], rate_hz: f64) -> Scan {
    let n = x.len();
    let n_valid = x.iter().filter(|v| v.is_finite()).count();
    let mut out = Scan::empty();
    if !(rate_hz.is_finite() && rate_hz > 0.0) || n_valid < MIN_SAMPLES {
        return out;
    }
    let q = quantum(x);
    out.quantum_dps = q;
    let max_len = (MAX_EVENT_S * rate_hz).min(MAX_EVENT_FRACTION * n as f64).max(1.0) as usize;
    out.max_len = max_len;

    // Scale 1: each sample against the medians of its sides.
    let half = WINDOW_BLOCKS / 2;
    let (r1_two, r1) = residuals(x, half, 0);
    let s1_raw = robust_scale(&r1_two, false);
    // Quantisation error averages out in a block when the noise spans half a step or more (Widrow); else a block
    // mean can sit up to a step from its neighbours whatever its length.
    let dithered = s1_raw >= 0.5 * q;
    let floor = |l: usize| if dithered { q / (12.0 * l as f64).sqrt() } else { q / 12f64.sqrt() };
    let s1 = s1_raw.max(floor(1));
    if !(s1 > 0.0) {
        return out;
    }
    out.sigma_dps = s1;
    let k1 = kappa(n_valid as f64);
    let exceed: Vec<usize> = (0..n).filter(|&i| r1[i].abs() > k1 * s1).collect();
    let p_floor = 2.0 * normal_sf(k1);
    let (bursts, spike_rate) = find_bursts(&exceed, n_valid, max_len, p_floor);
    out.spike_rate = spike_rate;
    let Despiked { mut cores, despiked, clean, spikes } = despike(x, &r1, s1, &exceed, &bursts);
    out.spikes = spikes;

    // Block lengths 2, 4, ...: block means (and energies) against the medians of their sides.
    let prefix = Prefix::new(&clean);
    let l_max = prev_pow2((max_len / 2).min(n / 32)).max(2);
    // The energy of each sample against both its sides, in per-sample scales, capped so that no single sample
    // (a spike below the spike threshold) can make a block stand out; only where the noise dithers the lattice
    // (else the flips between two codes come and go with the analog level).
    let energy = dithered.then(|| {
        // (NaN stays NaN: `f64::min` would return the cap.)
        let u: Vec<f64> =
            r1.iter().map(|v| if v.is_finite() { (v / s1).powi(2).min(ENERGY_CAP) } else { f64::NAN }).collect();
        Prefix::new(&u)
    });
    let mut l = 2;
    while l <= l_max {
        let blocks = Blocks { n, len: l, n_valid: n_valid as f64, floor: floor(l) };
        out.scales.push(blocks.scan(&prefix, energy.as_ref(), &mut cores));
        l *= 2;
    }
    cores.sort_by(|a, b| b.burst.cmp(&a.burst).then(b.z.total_cmp(&a.z)));

    let mut ctx = Ctx { x: &despiked, raw: x, prefix: &prefix, n_valid, sigma: s1, steps: HashMap::new() };
    let found = judged(&mut ctx, &cores, max_len, n);
    let mut events: Vec<Transient> = Vec::new();
    for (t, reason) in found {
        match reason {
            Some(reason) => out.left_alone.push(LeftAlone { excursion: t, reason }),
            None => events.push(t),
        }
    }
    out.events = merge_and_pad(events, n);
    out
}

/// Each core, strongest first, grown into an excursion and judged: kept (no reason) or left alone (why), in the
/// record's order. A core inside an excursion already grown is skipped.
fn judged(ctx: &mut Ctx, cores: &[Core], max_len: usize, n: usize) -> Vec<(Transient, Option<Reason>)> {
    let mut covered = vec![false; n];
    let mut found: Vec<(Transient, Option<Reason>)> = Vec::new();
    for core in cores {
        if covered[core.start..core.end].iter().any(|&c| c) {
            continue;
        }
        let Some(e) = ctx.refine(core, &covered) else { continue };
        covered[e.start..e.end].iter_mut().for_each(|c| *c = true);
        let t = Transient {
            start: e.start,
            len: e.end - e.start,
            peak_dps: e.peak,
            mean_dps: e.mean,
            shape: e.shape,
            scale: core.scale,
            z: core.z,
        };
        let reason = if t.len > max_len {
            Some(Reason::TooLong { max_len })
        } else if let (Shape::Offset, Some(before), Some(after)) = (e.shape, e.before, e.after) {
            if (after - before).abs() > RETURN_FRACTION * e.mean.abs() {
                Some(Reason::LevelChange { before_dps: before, after_dps: after })
            } else {
                ctx.step_process(&t)
            }
        } else if e.shape == Shape::Offset {
            ctx.step_process(&t)
        } else {
            None
        };
        found.push((t, reason));
    }
    found.sort_by_key(|f| f.0.start);
    found
}

/// The record after its spikes are taken out, and the cores of excursions found on single samples.
struct Despiked {
    /// The bursts' cores, and the peaks of short swells.
    cores: Vec<Core>,
    /// The record with the spikes outside bursts replaced.
    despiked: Vec<f64>,
    /// The record with every large sample replaced, bursts' included: what the block means see.
    clean: Vec<f64>,
    /// The spikes replaced outside bursts.
    spikes: usize,
}

/// Large samples outside bursts are spikes: replaced by the median of the nearer side for everything that
/// follows; the block means see the bursts' samples replaced too. `r1` holds each sample's residual against the
/// medians of its sides, `s1` their robust scale, `exceed` the samples beyond the threshold.
fn despike(x: &[f64], r1: &[f64], s1: f64, exceed: &[usize], bursts: &[(usize, usize)]) -> Despiked {
    let n = x.len();
    let mut in_burst = vec![false; n];
    for &(a, b) in bursts {
        in_burst[a..=b].iter_mut().for_each(|v| *v = true);
    }
    let mut despiked = x.to_vec();
    let mut clean = x.to_vec();
    let mut spikes = 0;
    let mut cores: Vec<Core> = bursts
        .iter()
        .map(|&(a, b)| {
            let z = (a..=b).map(|i| r1[i].abs() / s1).filter(|v| v.is_finite()).fold(0.0, f64::max);
            let large: Vec<f64> = exceed.iter().filter(|&&i| i >= a && i <= b).map(|&i| r1[i]).collect();
            let up = large.iter().filter(|v| **v > 0.0).count() as f64 / large.len().max(1) as f64;
            let spiky = (large.len() as f64) < 0.5 * (b + 1 - a) as f64 || (0.2..=0.8).contains(&up);
            Core { start: a, end: b + 1, scale: 1, z, burst: true, spiky }
        })
        .collect();
    // A large sample whose two neighbours both stand out on the same side is the peak of a short excursion (a
    // swell of a few samples), not a spike: it stays in, as a core of its own.
    let shouldered = |i: usize| {
        i > 0
            && i + 1 < n
            && [r1[i - 1], r1[i + 1]].iter().all(|v| v.is_finite() && v * r1[i].signum() > SHOULDER_Z * s1)
    };
    for &i in exceed {
        if !in_burst[i] && shouldered(i) {
            cores.push(Core { start: i - 1, end: i + 2, scale: 1, z: r1[i].abs() / s1, burst: false, spiky: false });
            continue;
        }
        // The side nearer to the sample: x less its residual against that side.
        let fill = x[i] - r1[i];
        if !in_burst[i] {
            despiked[i] = fill;
            spikes += 1;
        }
        clean[i] = fill;
    }
    Despiked { cores, despiked, clean, spikes }
}

/// One block length of the scan over a record of `n` samples.
struct Blocks {
    n: usize,
    /// The block length, samples.
    len: usize,
    /// The record's valid samples.
    n_valid: f64,
    /// The least robust scale of a block mean (the ADC lattice's).
    floor: f64,
}

impl Blocks {
    /// The blocks (half-overlapping) whose means, or energies where `energy` is given, stand out against the
    /// medians of their sides: each pushed to `cores`; the block length's figures returned.
    fn scan(&self, prefix: &Prefix, energy: Option<&Prefix>, cores: &mut Vec<Core>) -> ScaleStat {
        let (n, l) = (self.n, self.len);
        let half = WINDOW_BLOCKS / 2;
        let h = l / 2;
        let nb = if n >= l { (n - l) / h + 1 } else { 0 };
        let means: Vec<f64> = (0..nb).map(|j| prefix.mean(j * h, j * h + l, l / 2)).collect();
        let (two, r) = residuals(&means, half, 1);
        let s = robust_scale(&two, true).max(self.floor);
        let kap = kappa(self.n_valid / l as f64);
        let mut stat = ScaleStat {
            len: l,
            sigma_dps: s,
            threshold: kap,
            flagged: 0,
            max_z: 0.0,
            energy_flagged: 0,
            energy_max_z: 0.0,
        };
        if s > 0.0 {
            for (j, v) in r.iter().enumerate() {
                let z = v.abs() / s;
                stat.max_z = stat.max_z.max(z);
                if z > kap {
                    stat.flagged += 1;
                    cores.push(Core { start: j * h, end: j * h + l, scale: l, z, burst: false, spiky: false });
                }
            }
        }
        if let Some(energy) = energy.filter(|_| l >= MIN_ENERGY_BLOCK) {
            // The cube root of a mean of squares is close to Gaussian (Wilson-Hilferty).
            let g: Vec<f64> = (0..nb).map(|j| energy.mean(j * h, j * h + l, l / 2).cbrt()).collect();
            let (two, r) = residuals(&g, half, 1);
            let s = robust_scale(&two, true);
            if s > 0.0 {
                for (j, v) in r.iter().enumerate() {
                    let z = v / s;
                    stat.energy_max_z = stat.energy_max_z.max(z);
                    if z > kap {
                        stat.energy_flagged += 1;
                        cores.push(Core { start: j * h, end: j * h + l, scale: l, z, burst: false, spiky: false });
                    }
                }
            }
        }
        stat
    }
}

/// Set the samples of `events` to NaN (gaps).
pub fn mask(x: &mut [f64], events: &[Transient]) {
    let n = x.len();
    for e in events {
        let (a, b) = (e.start.min(n), e.end().min(n));
        x[a..b].iter_mut().for_each(|v| *v = f64::NAN);
    }
}

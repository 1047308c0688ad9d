//! Transient disturbances in a gyro record (a bump of the bench, a tug on a cable, a burst of spikes), found so
//! that the gap diagnosis can mask them as NaN gaps before it measures anything: one disturbance of a few dozen
//! samples is enough to wreck the distribution view of a day-long record. [`scan`] finds them in one part of a
//! record (training and holdout are scanned apart); [`mask`] sets their samples to NaN.
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
//! use octavar::gap::transients::{mask, scan};
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

use std::collections::HashMap;

use serde::Serialize;

/// The longest disturbance accepted as an event, s: a longer excursion is a change of level, not a transient.
pub const MAX_EVENT_S: f64 = 600.0;
/// The longest event as a fraction of the part scanned.
const MAX_EVENT_FRACTION: f64 = 0.125;
/// The baseline of a point: the medians of the `WINDOW_BLOCKS / 2` values on each side.
const WINDOW_BLOCKS: usize = 33;
/// The threshold at a scale with `m` independent blocks, in robust scales: `max(FLOOR, sqrt(2 ln m) + MARGIN)`.
const KAPPA_MARGIN: f64 = 1.5;
/// The threshold's floor, in robust scales.
const KAPPA_FLOOR: f64 = 5.5;
/// Family-wise false-alarm probability of the burst test over a part.
const BURST_ALPHA: f64 = 1e-3;
/// A large sample whose two neighbours both stand this many robust scales beyond their sides, on its side, is the
/// peak of a short excursion, not a spike: an isolated spike's neighbours are noise, and both beyond 3 scales on
/// the spike's side happens about twice in a million spikes.
const SHOULDER_Z: f64 = 3.0;
/// Fewest large samples in a burst found by the window test (pairs have their own test).
const MIN_BURST_SPIKES: usize = 3;
/// A large sample at the end of a burst stands apart from it beyond this many median gaps of the burst.
const BURST_TRIM_GAPS: usize = 8;
/// An offset whose two sides differ by more than this fraction of its mean does not return: a level change.
const RETURN_FRACTION: f64 = 0.5;
/// An offset is explained by the record's own steps when the expected number of pairs of steps as close as its
/// duration is at least this.
const STEP_PAIR_ALPHA: f64 = 0.01;
/// The step count's threshold at a MOSUM window of `m` independent windows, in robust scales of the MOSUM:
/// `max(FLOOR, sqrt(2 ln m))`, about where noise alone gives one step in the part.
const STEP_KAPPA_FLOOR: f64 = 3.5;
/// The cap on one sample's energy, in squared per-sample scales.
const ENERGY_CAP: f64 = 9.0;
/// The shortest block whose energy is tested, samples: shorter bursts are found by their large samples.
const MIN_ENERGY_BLOCK: usize = 8;
/// Fewest valid samples a part needs to be scanned.
const MIN_SAMPLES: usize = 2 * WINDOW_BLOCKS + 1;
/// Gaussian consistency of 1.4826 MAD.
const MAD_TO_SD: f64 = 1.482_602_218_505_602;

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

/// Find the transient disturbances of `x` (deg/s at `fs_hz`; NaN and infinities are gaps). See the module doc for
/// the method. A part with fewer than 67 valid samples, or an invalid rate, gives an empty scan; nothing panics.
pub fn scan(x: &[f64], fs_hz: f64) -> Scan {
    let n = x.len();
    let n_valid = x.iter().filter(|v| v.is_finite()).count();
    let mut out = Scan::empty();
    if !(fs_hz.is_finite() && fs_hz > 0.0) || n_valid < MIN_SAMPLES {
        return out;
    }
    let q = quantum(x);
    out.quantum_dps = q;
    let max_len = (MAX_EVENT_S * fs_hz).min(MAX_EVENT_FRACTION * n as f64).max(1.0) as usize;
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

    // Large samples outside bursts are spikes: replaced by the median of the nearer side for everything that
    // follows; the block means see the bursts' samples replaced too.
    let mut in_burst = vec![false; n];
    for &(a, b) in &bursts {
        in_burst[a..=b].iter_mut().for_each(|v| *v = true);
    }
    let mut despiked = x.to_vec();
    let mut clean = x.to_vec();
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
    for &i in &exceed {
        if !in_burst[i] && shouldered(i) {
            cores.push(Core { start: i - 1, end: i + 2, scale: 1, z: r1[i].abs() / s1, burst: false, spiky: false });
            continue;
        }
        // The side nearer to the sample: x less its residual against that side.
        let fill = x[i] - r1[i];
        if !in_burst[i] {
            despiked[i] = fill;
            out.spikes += 1;
        }
        clean[i] = fill;
    }

    // Block lengths 2, 4, ...: block means (and energies) against the medians of their sides.
    let l_max = prev_pow2((max_len / 2).min(n / 32)).max(2);
    let prefix = Prefix::new(&clean);
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
        let h = l / 2;
        let nb = if n >= l { (n - l) / h + 1 } else { 0 };
        let means: Vec<f64> = (0..nb).map(|j| prefix.mean(j * h, j * h + l, l / 2)).collect();
        let (two, r) = residuals(&means, half, 1);
        let s = robust_scale(&two, true).max(floor(l));
        let kap = kappa(n_valid as f64 / l as f64);
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
        if let Some(energy) = energy.as_ref().filter(|_| l >= MIN_ENERGY_BLOCK) {
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
        out.scales.push(stat);
        l *= 2;
    }
    cores.sort_by(|a, b| b.burst.cmp(&a.burst).then(b.z.total_cmp(&a.z)));

    // Each core, strongest first, grown into an excursion and judged.
    let mut ctx = Ctx { x: &despiked, raw: x, prefix: &prefix, n_valid, sigma: s1, steps: HashMap::new() };
    let mut covered = vec![false; n];
    let mut found: Vec<(Transient, Option<Reason>)> = Vec::new();
    for core in &cores {
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

/// Set the samples of `events` to NaN (gaps).
pub fn mask(x: &mut [f64], events: &[Transient]) {
    let n = x.len();
    for e in events {
        let (a, b) = (e.start.min(n), e.end().min(n));
        x[a..b].iter_mut().for_each(|v| *v = f64::NAN);
    }
}

/// A flagged block (or burst): where, at which scale, how many robust scales from its baseline.
#[derive(Clone, Copy, Debug)]
struct Core {
    start: usize,
    end: usize,
    scale: usize,
    z: f64,
    burst: bool,
    /// A burst of separate spikes: its large samples fill less than half its span or have both signs (a fifth of
    /// them or more each way). Its shape is a burst whatever the mean of its span, which the red noise under a
    /// long burst can lift or lower more than its few spikes.
    spiky: bool,
}

/// An excursion grown from a core.
struct Grown {
    start: usize,
    end: usize,
    mean: f64,
    peak: f64,
    shape: Shape,
    /// Median level on each side, deg/s, where there is a side.
    before: Option<f64>,
    after: Option<f64>,
}

/// Steps found at one MOSUM window: the robust threshold and each step's index and |size|, largest first.
struct StepScan {
    threshold: f64,
    steps: Vec<(usize, f64)>,
}

struct Ctx<'a> {
    /// The record with its isolated spikes replaced.
    x: &'a [f64],
    /// The record.
    raw: &'a [f64],
    prefix: &'a Prefix,
    n_valid: usize,
    sigma: f64,
    steps: HashMap<usize, StepScan>,
}

impl Ctx<'_> {
    /// Grow `core` into an excursion: a baseline from the medians on both sides, then the interval about the core
    /// that maximises a CUSUM of the deviations (signed for an offset, absolute for a burst).
    fn refine(&self, core: &Core, covered: &[bool]) -> Option<Grown> {
        let x = self.x;
        let n = x.len();
        let ext = 3 * core.scale.max(core.end - core.start) + 8;
        // The search window, stopping at excursions already taken.
        let mut w0 = core.start;
        while w0 > 0 && core.start - w0 < ext && !covered[w0 - 1] {
            w0 -= 1;
        }
        let mut w1 = core.end;
        while w1 < n && w1 - core.end < ext && !covered[w1] {
            w1 += 1;
        }
        let f = (w1 - w0).max(32);
        let side = |a: usize, b: usize| -> Option<(f64, f64)> {
            let v: Vec<f64> = (a..b).filter(|&i| !covered[i] && x[i].is_finite()).map(|i| x[i]).collect();
            (v.len() >= 8).then(|| (median(&v), 0.5 * (a + b) as f64))
        };
        let before = side(w0.saturating_sub(f), w0);
        let after = side(w1, (w1 + f).min(n));
        let base = |i: usize| -> f64 {
            match (before, after) {
                (Some((ml, cl)), Some((mr, cr))) => ml + (mr - ml) * (i as f64 - cl) / (cr - cl),
                (Some((m, _)), None) | (None, Some((m, _))) => m,
                (None, None) => f64::NAN,
            }
        };
        before.or(after)?;
        let d: Vec<f64> = (w0..w1).map(|i| x[i] - base(i)).collect();
        let core_d: Vec<f64> = d[core.start - w0..core.end - w0].iter().copied().filter(|v| v.is_finite()).collect();
        if core_d.is_empty() {
            return None;
        }
        let m = mean(&core_d);
        let ma = core_d.iter().map(|v| v.abs()).sum::<f64>() / core_d.len() as f64;
        let shape = if m.abs() >= 0.5 * ma && !core.spiky { Shape::Offset } else { Shape::Burst };
        let s = self.sigma;
        let g: Vec<f64> = match shape {
            Shape::Offset => {
                // Half the offset (the CUSUM's optimal reference), at most 1.5 sigma: the edges go where the
                // samples are clearly raised, not into a stretch of noise that happens to lean the same way.
                let k = (0.5 * m.abs()).min(1.5 * s);
                d.iter().map(|v| if v.is_finite() { m.signum() * v - k } else { 0.0 }).collect()
            }
            Shape::Burst => {
                // The energy of each deviation in per-sample scales, capped at 16 (4 sigma) so a lone spike cannot
                // bridge a long stretch of noise, less a reference between the noise's energy (1) and the core's.
                let u = |v: f64| (v / s).powi(2).min(16.0);
                let e_core = core_d.iter().map(|&v| u(v)).sum::<f64>() / core_d.len() as f64;
                let c = (0.5 * (1.0 + e_core)).clamp(2.0, 4.0);
                d.iter().map(|&v| if v.is_finite() { u(v) - c } else { 0.0 }).collect()
            }
        };
        let (a, b) = (core.start - w0, core.end - w0);
        let (lo, hi) = if core.spiky {
            // Separate spikes: their span, first to last; the energy of the samples between them and around is the
            // noise's, and on a wandering level a line through the sides' medians would take the wander for more.
            (a, b - 1)
        } else if core.burst {
            // A burst's large samples belong together (the Poisson test said so): the whole span, extended outward
            // over weaker edges.
            (a - best_run(g[..a].iter().rev()), b - 1 + best_run(g[b..].iter()))
        } else {
            best_interval(&g, a, b)
        };
        let fin: Vec<f64> = d[lo..=hi].iter().copied().filter(|v| v.is_finite()).collect();
        // The peak from the record itself: spikes within the excursion are part of it.
        let peak =
            (w0 + lo..=w0 + hi).map(|i| (self.raw[i] - base(i)).abs()).filter(|v| v.is_finite()).fold(0.0, f64::max);
        Some(Grown {
            start: w0 + lo,
            end: w0 + hi + 1,
            mean: mean(&fin),
            peak,
            shape,
            before: before.map(|b| b.0),
            after: after.map(|a| a.0),
        })
    }

    /// The step-process test of an offset: steps at least half its size elsewhere in the part, found by a MOSUM
    /// at the offset's block length and at 2, 4 and 8 times it (a process's steps, each as marginal as the offset at
    /// its own length, stand out at a longer window when they are far enough apart); explained when, at one of
    /// them, pairs of such steps as close as the offset's duration are to be expected.
    fn step_process(&mut self, t: &Transient) -> Option<Reason> {
        let n = self.x.len();
        let h0 = t.scale.min(prev_pow2((t.len / 2).max(1)));
        let mut best: Option<(usize, f64)> = None;
        for h in [h0, 2 * h0, 4 * h0, 8 * h0] {
            if 16 * h > n {
                break;
            }
            let (prefix, n_valid) = (self.prefix, self.n_valid);
            let sc = self.steps.entry(h).or_insert_with(|| step_scan(prefix, n_valid, h));
            let thr = sc.threshold.max(0.5 * t.mean_dps.abs());
            let (a, b) = (t.start.saturating_sub(2 * h), t.end() + 2 * h);
            let k = sc.steps.iter().take_while(|s| s.1 >= thr).filter(|s| s.0 < a || s.0 > b).count();
            let lambda = k as f64 / self.n_valid as f64;
            let expected = k as f64 * (1.0 - (-lambda * t.len as f64).exp());
            if best.is_none_or(|b| expected > b.1) {
                best = Some((k, expected));
            }
        }
        let (k, expected) = best?;
        (expected >= STEP_PAIR_ALPHA).then_some(Reason::StepProcess { other_steps: k, expected_pairs: expected })
    }
}

/// How many of `g`'s leading values to take for the largest sum (0 when no prefix sum is positive).
fn best_run<'a>(g: impl Iterator<Item = &'a f64>) -> usize {
    let (mut acc, mut best, mut len) = (0.0, 0.0, 0);
    for (i, v) in g.enumerate() {
        acc += v;
        if acc > best {
            best = acc;
            len = i + 1;
        }
    }
    len
}

/// The interval `[lo, hi]` of largest sum of `g` among those that overlap `[a, b)`: for each point p of the core,
/// the best sum ending at p plus the best starting at p (Kadane both ways), O(len).
fn best_interval(g: &[f64], a: usize, b: usize) -> (usize, usize) {
    let n = g.len();
    let mut left = vec![(0.0, 0usize); n];
    let mut run = (f64::NEG_INFINITY, 0usize);
    for i in 0..n {
        run = if run.0 > 0.0 { (run.0 + g[i], run.1) } else { (g[i], i) };
        left[i] = run;
    }
    let mut right = vec![(0.0, 0usize); n];
    let mut run = (f64::NEG_INFINITY, n - 1);
    for i in (0..n).rev() {
        run = if run.0 > 0.0 { (run.0 + g[i], run.1) } else { (g[i], i) };
        right[i] = run;
    }
    let mut best = (f64::NEG_INFINITY, a, a);
    for p in a..b.min(n) {
        let sum = left[p].0 + right[p].0 - g[p];
        if sum > best.0 {
            best = (sum, left[p].1, right[p].1);
        }
    }
    (best.1, best.2)
}

/// The MOSUM scan of the cleaned series at window `h`: `D(t) = mean(x[t..t+h]) - mean(x[t-h..t])` on a grid of
/// h/4, steps where |D| is a local maximum beyond the scale's threshold, at least 2h apart.
fn step_scan(prefix: &Prefix, n_valid: usize, h: usize) -> StepScan {
    let n = prefix.len();
    let stride = (h / 4).max(1);
    let grid: Vec<usize> = if n >= 2 * h { (h..=n - h).step_by(stride).collect() } else { Vec::new() };
    let dv: Vec<f64> =
        grid.iter().map(|&t| prefix.mean(t, t + h, h.div_ceil(2)) - prefix.mean(t - h, t, h.div_ceil(2))).collect();
    let m = (n_valid as f64 / h as f64).max(2.0);
    let threshold = (2.0 * m.ln()).sqrt().max(STEP_KAPPA_FLOOR) * robust_scale(&dv, false);
    let mut cand: Vec<usize> = (0..grid.len()).filter(|&i| dv[i].abs() > threshold).collect();
    cand.sort_by(|&a, &b| dv[b].abs().total_cmp(&dv[a].abs()));
    let mut steps: Vec<(usize, f64)> = Vec::new();
    for i in cand {
        let t = grid[i];
        if steps.iter().all(|s| s.0.abs_diff(t) >= 2 * h) {
            steps.push((t, dv[i].abs()));
        }
    }
    StepScan { threshold, steps }
}

/// Spans `[first, last]` of large samples denser than the part's own rate of them allows.
///
/// Under the null the large samples are a Poisson process of rate p per sample (estimated from the part, less the
/// spans found, iterated to a fixed point); the expected number of large samples followed within `w` samples by at
/// least `k - 1` others is `n p P(Poisson(p w) >= k - 1)`. At each octave window w up to the longest event, the
/// smallest k that keeps this under [`BURST_ALPHA`] over all windows makes a burst.
fn find_bursts(ex: &[usize], n_valid: usize, max_len: usize, p_floor: f64) -> (Vec<(usize, usize)>, f64) {
    let windows: Vec<usize> = (1..40).map(|k| 1usize << k).take_while(|&w| w <= max_len.max(2)).collect();
    // Half the level for pairs, half for the windows of three or more.
    let alpha = 0.5 * BURST_ALPHA / windows.len() as f64;
    let mut p = p_floor.max(ex.len() as f64 / n_valid as f64);
    let mut spans: Vec<(usize, usize)> = Vec::new();
    for _ in 0..8 {
        let mut marks: Vec<(usize, usize)> = Vec::new();
        // Pairs: of m large samples uniform over the part, two lie within g of each other with probability
        // about m (m - 1) g / n (the smallest gap's law; no window lengths to correct for).
        let m = (p * n_valid as f64).max(2.0);
        for w in ex.windows(2) {
            let g = (w[1] - w[0]) as f64;
            if m * (m - 1.0) * g / n_valid as f64 <= 0.5 * BURST_ALPHA {
                marks.push((w[0], w[1]));
            }
        }
        for &w in &windows {
            let Some(k_min) = burst_count(n_valid, p, w, alpha) else { continue };
            let mut j = 0;
            for i in 0..ex.len() {
                j = j.max(i);
                while j < ex.len() && ex[j] < ex[i] + w {
                    j += 1;
                }
                if j - i >= k_min {
                    marks.push((ex[i], ex[j - 1]));
                }
            }
        }
        marks.sort_unstable();
        spans.clear();
        for (a, b) in marks {
            match spans.last_mut() {
                Some(last) if a <= last.1 + 1 => last.1 = last.1.max(b),
                _ => spans.push((a, b)),
            }
        }
        for span in &mut spans {
            *span = trim_span(ex, *span, p);
        }
        let mut inside = 0;
        let mut s = 0;
        for &i in ex {
            while s < spans.len() && spans[s].1 < i {
                s += 1;
            }
            if s < spans.len() && spans[s].0 <= i {
                inside += 1;
            }
        }
        let p_new = p_floor.max((ex.len() - inside) as f64 / n_valid as f64);
        if p_new >= p {
            break;
        }
        p = p_new;
    }
    (spans, p)
}

/// A burst span reduced to its most significant run of large samples: of every run of consecutive ones, the one
/// whose count is least likely within its length at the null rate `p` (a window that starts at a lone spike, or
/// at two that happen to be close, holds the burst too, and they are not part of it). Spans of more than 256 large
/// samples (dense runs) only lose ends that stand apart by more than [`BURST_TRIM_GAPS`] median gaps.
fn trim_span(ex: &[usize], (a, b): (usize, usize), p: f64) -> (usize, usize) {
    let lo = ex.partition_point(|&i| i < a);
    let hi = ex.partition_point(|&i| i <= b);
    let mut pts = &ex[lo..hi];
    if pts.len() < 3 {
        return (a, b);
    }
    if pts.len() <= 256 {
        let mut best = (f64::INFINITY, 0, pts.len() - 1);
        for i in 0..pts.len() {
            for j in i + 1..pts.len() {
                let w = pts[j] - pts[i] + 1;
                let score = ln_poisson_sf(p * (w - 1) as f64, j - i);
                if score < best.0 {
                    best = (score, i, j);
                }
            }
        }
        return (pts[best.1], pts[best.2]);
    }
    let mut gaps: Vec<usize> = pts.windows(2).map(|w| w[1] - w[0]).collect();
    gaps.sort_unstable();
    let limit = BURST_TRIM_GAPS * gaps[gaps.len() / 2].max(1);
    while pts.len() > 2 && pts[1] - pts[0] > limit {
        pts = &pts[1..];
    }
    while pts.len() > 2 && pts[pts.len() - 1] - pts[pts.len() - 2] > limit {
        pts = &pts[..pts.len() - 1];
    }
    (pts[0], pts[pts.len() - 1])
}

/// The fewest large samples within `w` that the null rate `p` makes unexpected at level `alpha`.
fn burst_count(n_valid: usize, p: f64, w: usize, alpha: f64) -> Option<usize> {
    let mu = p * (w - 1) as f64;
    let lead = n_valid as f64 * p;
    let start = MIN_BURST_SPIKES.max(mu.ceil() as usize + 1);
    (start..=w).find(|&k| lead * poisson_sf(mu, k - 1) <= alpha)
}

/// P(Poisson(mu) >= k).
fn poisson_sf(mu: f64, k: usize) -> f64 {
    ln_poisson_sf(mu, k).exp().min(1.0)
}

/// ln P(Poisson(mu) >= k), accurate far in the tail: the first term's logarithm plus that of the ratio sum.
fn ln_poisson_sf(mu: f64, k: usize) -> f64 {
    if k == 0 {
        return 0.0;
    }
    if mu <= 0.0 {
        return f64::NEG_INFINITY;
    }
    let lead = -mu + k as f64 * mu.ln() - statrs::function::gamma::ln_gamma(k as f64 + 1.0);
    let (mut term, mut sum, mut j) = (1.0, 1.0, k);
    while term > sum * 1e-17 && j < k + 100_000 {
        j += 1;
        term *= mu / j as f64;
        sum += term;
    }
    (lead + sum.ln()).min(0.0)
}

/// Events sorted by start, merged when the gap between two is shorter than the shorter of them, then padded by
/// their edge margin (1 + len/32 samples each side).
fn merge_and_pad(events: Vec<Transient>, n: usize) -> Vec<Transient> {
    let mut merged: Vec<Transient> = Vec::new();
    for e in events {
        if let Some(last) = merged.last_mut() {
            let gap = e.start.saturating_sub(last.end());
            if gap <= last.len.min(e.len) {
                let end = last.end().max(e.end());
                let (la, lb) = (last.len as f64, e.len as f64);
                last.mean_dps = (last.mean_dps * la + e.mean_dps * lb) / (la + lb);
                last.peak_dps = last.peak_dps.max(e.peak_dps);
                if e.shape == Shape::Burst {
                    last.shape = Shape::Burst;
                }
                last.len = end - last.start;
                continue;
            }
        }
        merged.push(e);
    }
    for e in &mut merged {
        let pad = 1 + e.len / 32;
        let start = e.start.saturating_sub(pad);
        let end = (e.end() + pad).min(n);
        e.start = start;
        e.len = end - start;
    }
    // Padding can make neighbours touch: join them.
    let mut out: Vec<Transient> = Vec::new();
    for e in merged {
        match out.last_mut() {
            Some(last) if e.start <= last.end() => {
                let end = last.end().max(e.end());
                last.peak_dps = last.peak_dps.max(e.peak_dps);
                last.len = end - last.start;
            }
            _ => out.push(e),
        }
    }
    out
}

/// Prefix sums of the finite values (less their first value, for precision) and their count.
struct Prefix {
    sum: Vec<f64>,
    count: Vec<u32>,
    offset: f64,
}

impl Prefix {
    fn new(x: &[f64]) -> Prefix {
        let offset = x.iter().copied().find(|v| v.is_finite()).unwrap_or(0.0);
        let mut sum = Vec::with_capacity(x.len() + 1);
        let mut count = Vec::with_capacity(x.len() + 1);
        let (mut s, mut c) = (0.0, 0u32);
        sum.push(s);
        count.push(c);
        for v in x {
            if v.is_finite() {
                s += v - offset;
                c += 1;
            }
            sum.push(s);
            count.push(c);
        }
        Prefix { sum, count, offset }
    }

    fn len(&self) -> usize {
        self.sum.len() - 1
    }

    /// The mean of the finite values in `[a, b)`, NaN with fewer than `min_count` of them.
    fn mean(&self, a: usize, b: usize, min_count: usize) -> f64 {
        let c = (self.count[b] - self.count[a]) as usize;
        if c == 0 || c < min_count {
            return f64::NAN;
        }
        (self.sum[b] - self.sum[a]) / c as f64 + self.offset
    }
}

/// The running medians of `v` on each side of every point: over offsets `-h..-e` (left) and `e+1..=h` (right),
/// NaN skipped. The point itself and the `e` on each side that share samples with it (overlapping blocks) are
/// left out, so a point is always compared with values it does not contain: where the series is locally monotone
/// (a ramp, a drift that dominates the noise) a median that included it would return the point itself, a residual
/// of exactly 0 whatever the noise. At each end the series is continued by its point reflection about the end
/// value (`2 v[0] - v[j]`), which keeps a ramp, a step near the end and a random walk on their course.
fn side_medians(v: &[f64], h: usize, e: usize) -> (Vec<f64>, Vec<f64>) {
    let n = v.len();
    let (Some(first), Some(last)) = (v.iter().position(|x| x.is_finite()), v.iter().rposition(|x| x.is_finite()))
    else {
        return (vec![f64::NAN; n], vec![f64::NAN; n]);
    };
    let (pa, pb) = (v[first], v[last]);
    let at = |j: isize| -> f64 {
        if j < 0 {
            let m = (-j) as usize;
            if m < n {
                2.0 * pa - v[m]
            } else {
                f64::NAN
            }
        } else if (j as usize) < n {
            v[j as usize]
        } else {
            let m = 2 * (n as isize - 1) - j;
            if m >= 0 {
                2.0 * pb - v[m as usize]
            } else {
                f64::NAN
            }
        }
    };
    let (h, e) = (h as isize, e as isize);
    let min_count = ((h - e) as usize / 4).max(1);
    // M(j), the median over [j - h, j - e - 1], for j in 0..n + h + e + 1: the left side of i is M(i), the
    // right side M(i + h + e + 1), so one sliding window serves both.
    let shift = (h + e + 1) as usize;
    let mut win: Vec<f64> = Vec::with_capacity((h - e + 1) as usize);
    let insert = |win: &mut Vec<f64>, x: f64| {
        if x.is_finite() {
            let p = win.partition_point(|a| a.total_cmp(&x).is_lt());
            win.insert(p, x);
        }
    };
    let remove = |win: &mut Vec<f64>, x: f64| {
        if x.is_finite() {
            let p = win.partition_point(|a| a.total_cmp(&x).is_lt());
            win.remove(p);
        }
    };
    for j in -h..-e {
        insert(&mut win, at(j));
    }
    let mut m = Vec::with_capacity(n + shift);
    for j in 0..(n + shift) as isize {
        let c = win.len();
        m.push(if c < min_count {
            f64::NAN
        } else if c % 2 == 1 {
            win[c / 2]
        } else {
            0.5 * (win[c / 2 - 1] + win[c / 2])
        });
        remove(&mut win, at(j - h));
        insert(&mut win, at(j - e));
    }
    let keep = |i: usize, x: f64| if v[i].is_finite() { x } else { f64::NAN };
    let left = (0..n).map(|i| keep(i, m[i])).collect();
    let right = (0..n).map(|i| keep(i, m[i + shift])).collect();
    (left, right)
}

/// Residuals of `v` against its two sides (see [`side_medians`]): `(two_sided, both)`. `two_sided` is `v` less
/// the mean of the two side medians: its robust scale is the scale's noise (a step adds to it only at the few
/// points next to it). `both` is how far `v` stands out from both sides in the same direction (the smaller of
/// the two differences), 0 where it lies between them: a bump stands out from both sides, a step from one, a
/// ramp from the two in opposite directions. With one side missing (a gap), the other decides.
fn residuals(v: &[f64], h: usize, e: usize) -> (Vec<f64>, Vec<f64>) {
    let (left, right) = side_medians(v, h, e);
    let mut two = Vec::with_capacity(v.len());
    let mut both = Vec::with_capacity(v.len());
    for ((x, l), r) in v.iter().zip(&left).zip(&right) {
        let (dl, dr) = (x - l, x - r);
        let (t, b) = match (dl.is_finite(), dr.is_finite()) {
            (true, true) => (x - 0.5 * (l + r), if dl * dr > 0.0 { dl.signum() * dl.abs().min(dr.abs()) } else { 0.0 }),
            (true, false) => (dl, dl),
            (false, true) => (dr, dr),
            (false, false) => (f64::NAN, f64::NAN),
        };
        two.push(t);
        both.push(b);
    }
    (two, both)
}

/// A robust scale of the finite values of `r`: the larger of 1.4826 MAD and the mean absolute deviation of the
/// 99% closest to the median (Gaussian-consistent). The MAD resists a large share of outlying values; the trimmed
/// mean stays positive and continuous where the values sit on a coarse lattice and the MAD is 0 or jumps by whole
/// steps. With `tail` and at least 200 values, also the scale that puts the quantile leaving about 10 values above
/// it (between the 95% and 99.9% ones) where a Gaussian's would be: where a smooth process dominates a block
/// length, the residuals near its turning points are heavier-tailed than the bulk says, and the threshold
/// extrapolates from the tail.
fn robust_scale(r: &[f64], tail: bool) -> f64 {
    let v: Vec<f64> = r.iter().copied().filter(|x| x.is_finite()).collect();
    if v.len() < 3 {
        return f64::NAN;
    }
    let m = median(&v);
    let mut dev: Vec<f64> = v.iter().map(|x| (x - m).abs()).collect();
    let len = dev.len();
    let k = len / 2;
    dev.select_nth_unstable_by(k, f64::total_cmp);
    let mad = dev[k];
    let tail_scale = if tail && len >= 200 {
        let q = (1.0 - 10.0 / len as f64).clamp(0.95, 0.999);
        let i = ((q * len as f64) as usize).min(len - 1);
        dev.select_nth_unstable_by(i, f64::total_cmp);
        dev[i] / (std::f64::consts::SQRT_2 * statrs::function::erf::erf_inv(q))
    } else {
        0.0
    };
    let keep = ((len as f64 * 0.99) as usize).max(1);
    if keep < len {
        dev.select_nth_unstable_by(keep, f64::total_cmp);
    }
    // E|Z| over |Z| below its 99% quantile: 2 (phi(0) - phi(2.5758)) / 0.99.
    let trimmed = dev[..keep].iter().sum::<f64>() / keep as f64 / 0.776_745;
    (MAD_TO_SD * mad).max(trimmed).max(tail_scale)
}

/// The step of the lattice the values sit on: the smallest absolute difference of neighbours above a millionth
/// of their median non-zero difference (rounding noise aside); about a millionth of the noise when there is no
/// lattice, where it is harmless.
fn quantum(x: &[f64]) -> f64 {
    let d: Vec<f64> = x.windows(2).map(|w| (w[1] - w[0]).abs()).filter(|v| v.is_finite() && *v > 0.0).collect();
    if d.is_empty() {
        return 0.0;
    }
    let tiny = 1e-6 * median(&d);
    d.iter().copied().filter(|&v| v > tiny).fold(f64::INFINITY, f64::min)
}

/// The threshold, in robust scales, at a scale of `m` independent blocks.
fn kappa(m: f64) -> f64 {
    ((2.0 * m.max(2.0).ln()).sqrt() + KAPPA_MARGIN).max(KAPPA_FLOOR)
}

/// The standard normal upper tail.
fn normal_sf(z: f64) -> f64 {
    0.5 * statrs::function::erf::erfc(z / std::f64::consts::SQRT_2)
}

fn median(x: &[f64]) -> f64 {
    if x.is_empty() {
        return f64::NAN;
    }
    let mut v = x.to_vec();
    let k = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(k, f64::total_cmp);
    *m
}

fn mean(x: &[f64]) -> f64 {
    if x.is_empty() {
        return f64::NAN;
    }
    x.iter().sum::<f64>() / x.len() as f64
}

/// The largest power of two at most `v` (1 for 0).
fn prev_pow2(v: usize) -> usize {
    if v <= 1 {
        1
    } else {
        1 << (usize::BITS - 1 - v.leading_zeros())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_signals::{white, Lcg};

    #[test]
    fn white_noise_has_no_events() {
        for seed in 0..5 {
            let x = white(1 << 17, seed);
            let s = scan(&x, 100.0);
            assert!(s.events.is_empty(), "seed {seed}: {:?}", s.events);
        }
    }

    /// Empty, short, all-gap, constant, infinite and coarse-lattice inputs and invalid rates: no panic, no event.
    #[test]
    fn odd_inputs_give_no_events() {
        let gappy: Vec<f64> = (0..1000).map(|i| if i % 7 == 0 { f64::NAN } else { 0.25 }).collect();
        for x in [vec![], vec![1.0], vec![f64::NAN; 1000], vec![0.5; 1000], gappy] {
            assert!(scan(&x, 10.0).events.is_empty());
        }
        for n in 0..200 {
            assert!(scan(&white(n, n as u64), 1.0).events.is_empty());
        }
        let mut x = white(5000, 2);
        x[100] = f64::INFINITY;
        x[200..300].iter_mut().for_each(|v| *v = f64::NAN);
        assert!(scan(&x, 10.0).events.is_empty());
        // An invalid rate gives an empty scan (its sigma NaN, which no equality holds for).
        for fs in [0.0, f64::NAN, -1.0] {
            let s = scan(&x, fs);
            assert!(s.events.is_empty() && s.left_alone.is_empty() && s.scales.is_empty() && s.spikes == 0, "{s:?}");
        }
        // A lattice much coarser than the noise: a few percent of the samples flip to a neighbouring code.
        let lattice: Vec<f64> = white(20_000, 4).iter().map(|v| (0.2 * v).round()).collect();
        assert!(scan(&lattice, 10.0).events.is_empty());
        // Masking clamps to the series.
        let mut y = vec![0.0; 10];
        mask(
            &mut y,
            &[Transient { start: 8, len: 5, peak_dps: 0.0, mean_dps: 0.0, shape: Shape::Offset, scale: 1, z: 0.0 }],
        );
        assert!(y[8].is_nan() && y[9].is_nan() && y[7] == 0.0);
    }

    /// The side medians against a direct computation, with gaps and the reflected ends.
    #[test]
    fn side_medians_match_a_direct_computation() {
        let mut v = white(300, 5);
        for i in [0, 7, 8, 150, 151, 152, 299] {
            v[i] = f64::NAN;
        }
        let (first, last) = (1, 298);
        let at = |j: isize| -> f64 {
            if j < 0 {
                2.0 * v[first] - v[(-j) as usize]
            } else if j as usize >= v.len() {
                2.0 * v[last] - v[2 * (v.len() - 1) - j as usize]
            } else {
                v[j as usize]
            }
        };
        let med = |lo: isize, hi: isize| -> f64 {
            let w: Vec<f64> = (lo..=hi).map(at).filter(|x| x.is_finite()).collect();
            let mut w = w.clone();
            w.sort_by(f64::total_cmp);
            let c = w.len();
            if c < 3 {
                f64::NAN
            } else if c % 2 == 1 {
                w[c / 2]
            } else {
                0.5 * (w[c / 2 - 1] + w[c / 2])
            }
        };
        for (h, e) in [(16, 0), (16, 1)] {
            let (left, right) = side_medians(&v, h, e);
            for i in 0..v.len() {
                let ii = i as isize;
                let (h, e) = (h as isize, e as isize);
                let (l, r) = if v[i].is_finite() {
                    (med(ii - h, ii - e - 1), med(ii + e + 1, ii + h))
                } else {
                    (f64::NAN, f64::NAN)
                };
                assert!(
                    l.total_cmp(&left[i]).is_eq() && r.total_cmp(&right[i]).is_eq(),
                    "{i}: {l} {r} {:?}",
                    (left[i], right[i])
                );
            }
        }
    }

    /// Ad-hoc timing (`cargo test -p octavar --release --lib gap::transients::tests::timing -- --ignored
    /// --nocapture`): a million samples of white noise with a bump.
    #[test]
    #[ignore = "timing, by hand"]
    fn timing() {
        let mut x = white(1_000_000, 9);
        x[500_000..501_000].iter_mut().for_each(|v| *v += 2.0);
        for _ in 0..3 {
            let t0 = std::time::Instant::now();
            let s = scan(&x, 100.0);
            println!("{} events in {:.3} s", s.events.len(), t0.elapsed().as_secs_f64());
        }
    }

    /// A swell of three samples (half a sine: 6, 12 and 6 sigmas) is an event, though only its peak is a large
    /// sample; 40 lone spikes of 12 sigmas at a steady rate are not, and are counted as spikes.
    #[test]
    fn a_three_sample_swell_is_an_event_and_lone_spikes_are_not() {
        for seed in 0..4 {
            let mut x = white(1 << 18, seed);
            let at = 100_000 + 7_919 * seed as usize;
            for (v, w) in x[at..at + 3].iter_mut().zip([6.0, 12.0, 6.0]) {
                *v += w;
            }
            let s = scan(&x, 1.0);
            assert_eq!(s.events.len(), 1, "seed {seed}: {:?}", s.events);
            assert!(s.events[0].start <= at && s.events[0].end() >= at + 3, "seed {seed}: {:?}", s.events);
            let mut y = white(1 << 18, seed + 10);
            for k in 0..40 {
                y[3_001 + 6_469 * k] += if k % 2 == 0 { 12.0 } else { -12.0 };
            }
            let s = scan(&y, 1.0);
            assert!(s.events.is_empty(), "seed {seed}: {:?}", s.events);
            assert!(s.spikes >= 40, "seed {seed}: {} spikes", s.spikes);
        }
    }

    /// A burst of 8 spikes of both signs spread over 6000 samples of a record that wanders (white noise and a
    /// random walk that moves the level by several sigmas over the burst) is a burst, not an offset that does not
    /// return: it is found, as one event over its spikes.
    #[test]
    fn a_spread_burst_on_a_wandering_level_is_found() {
        for seed in 0..3 {
            let w = white(1 << 18, seed + 20);
            let steps = white(1 << 18, seed + 40);
            let mut level = 0.0;
            let mut x: Vec<f64> = w
                .iter()
                .zip(&steps)
                .map(|(v, s)| {
                    level += 0.05 * s;
                    v + level
                })
                .collect();
            let at = 50_000 + 10_007 * seed as usize;
            for k in 0..8 {
                x[at + 750 * k + 11] += if k % 3 == 0 { -30.0 } else { 30.0 };
            }
            let s = scan(&x, 100.0);
            let hit: Vec<&Transient> = s.events.iter().filter(|e| e.start <= at + 11 && e.end() > at + 5261).collect();
            assert_eq!(hit.len(), 1, "seed {seed}: {:?} left alone {:?}", s.events, s.left_alone);
            assert_eq!(hit[0].shape, Shape::Burst, "seed {seed}");
        }
    }

    #[test]
    fn a_bump_is_found() {
        let mut x = white(1 << 16, 3);
        for v in &mut x[20_000..20_500] {
            *v += 3.0;
        }
        let s = scan(&x, 100.0);
        println!("{s:#?}");
        assert_eq!(s.events.len(), 1);
        let _ = Lcg::new(1);
    }
}

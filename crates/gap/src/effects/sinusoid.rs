//! The sinusoid candidate: up to four sinusoids on the rate, from the periodogram and a joint least squares.

use super::params::{SinusoidParams, SinusoidsParams};
use octavar_shared::sim::{GyroSim, Sinusoid, MAX_SINUSOIDS};
use rayon::prelude::*;

use super::common::*;
use super::curve::*;
use super::lowpass::sinusoid_moved;
use super::noise_spectrum::NoiseSpectrum;
use super::{Effect, EffectFit, EffectKind, ParamSpread, TrainingData};

/// `|sum w_n x_n e^{-i 2 pi f n dt}|^2` with the Hann window, by a rotating phasor (renormalised).
pub(super) fn hann_power(y: &[f64], f: f64, dt: f64) -> f64 {
    let n = y.len();
    let d = 2.0 * std::f64::consts::PI * f * dt;
    let (cd, sd) = (d.cos(), d.sin());
    let wd = 2.0 * std::f64::consts::PI / n as f64;
    let (cw, sw) = (wd.cos(), wd.sin());
    let (mut c, mut s) = (1.0f64, 0.0f64);
    let (mut wc, mut ws) = (1.0f64, 0.0f64);
    let (mut re, mut im) = (0.0, 0.0);
    for (i, &v) in y.iter().enumerate() {
        let w = 0.5 * (1.0 - wc);
        re += w * v * c;
        im -= w * v * s;
        let c2 = c * cd - s * sd;
        s = s * cd + c * sd;
        c = c2;
        let wc2 = wc * cw - ws * sw;
        ws = ws * cw + wc * sw;
        wc = wc2;
        if i & 1023 == 1023 {
            let g = 1.5 - 0.5 * (c * c + s * s);
            c *= g;
            s *= g;
        }
    }
    re * re + im * im
}

/// What [`sinusoid_ls`] finds.
pub(super) struct LeastSquares {
    /// The coefficients: the trend's three, then (cos, sin) per frequency.
    pub coef: Vec<f64>,
    /// The design's `A'A`.
    pub ata: Vec<Vec<f64>>,
}

/// Joint least squares of `y` (sampled every `dt`, the first sample at `t_off`) on a quadratic trend (so slow
/// wander does not leak into long periods) and a (cos, sin) pair per frequency, in one pass with rotating
/// phasors.
pub(super) fn sinusoid_ls(y: &[f64], freqs: &[f64], dt: f64, t_off: f64) -> Option<LeastSquares> {
    let (ata, atb, _) = normal_equations(y, freqs, dt, t_off);
    let coef = solve(ata.clone(), atb)?;
    Some(LeastSquares { coef, ata })
}

/// The rows of [`sinusoid_ls`]'s design, sample after sample: the quadratic trend `1, u, u^2 - 1/3` over
/// `u = 2i/n - 1`, then `cos, sin` of each frequency at `t = t_off + i dt`, by rotating phasors (renormalised
/// every 1024 samples).
struct DesignRows {
    n: usize,
    i: usize,
    rot: Vec<(f64, f64)>,
    ph: Vec<(f64, f64)>,
}

impl DesignRows {
    fn new(n: usize, freqs: &[f64], dt: f64, t_off: f64) -> Self {
        Self::from(n, 0, freqs, dt, t_off)
    }

    /// The rows from sample `i` on.
    fn from(n: usize, i: usize, freqs: &[f64], dt: f64, t_off: f64) -> Self {
        let phasor = |a: f64| (a.cos(), a.sin());
        let two_pi = 2.0 * std::f64::consts::PI;
        DesignRows {
            n,
            i,
            rot: freqs.iter().map(|f| phasor(two_pi * f * dt)).collect(),
            ph: freqs.iter().map(|f| phasor(two_pi * f * (t_off + i as f64 * dt))).collect(),
        }
    }

    /// Columns: the trend's three and two per frequency.
    fn width(&self) -> usize {
        3 + 2 * self.rot.len()
    }

    /// Write the next sample's row into `row` (of [`DesignRows::width`]).
    fn next_row(&mut self, row: &mut [f64]) {
        let u = 2.0 * self.i as f64 / self.n as f64 - 1.0;
        row[0] = 1.0;
        row[1] = u;
        row[2] = u * u - 1.0 / 3.0;
        for (j, ((c, s), &(cr, sr))) in self.ph.iter_mut().zip(&self.rot).enumerate() {
            row[3 + 2 * j] = *c;
            row[4 + 2 * j] = *s;
            let c2 = *c * cr - *s * sr;
            *s = *s * cr + *c * sr;
            *c = c2;
            if self.i & 1023 == 1023 {
                let g = 1.5 - 0.5 * (*c * *c + *s * *s);
                *c *= g;
                *s *= g;
            }
        }
        self.i += 1;
    }
}

/// The tolerance of the frequency on the windowed projection, in bins: a start for the least squares' refinement,
/// which searches half a bin either side of it.
const HANN_TOL: f64 = 1e-3;
/// The tolerance of the least squares' frequency, in bins: a phase error of 2 pi x 1e-5 rad over the training part,
/// well below the frequency's own standard error at any amplitude the periodogram can show.
const RSS_TOL: f64 = 1e-5;

/// The fewest cycles in the record of a sinusoid looked for beyond the periodogram's reach (three cycles).
const LONG_PERIOD_CYCLES: f64 = 1.5;
/// Cycles in the training part from which a sinusoid's amplitude z is its estimator's test
/// ([`crate::evidence`]): an eighth of the part and shorter, clear of the lowest periodogram bins (a third to a
/// fifth of the part), where flicker, random walk and any slow wander the noise model lacks lift the peaks of a
/// short record. On 1,000 effect-free records of each generator the z of a sinusoid of 8 cycles or more stays at
/// or below 4.6 and 5.5 (`sinusoid_z_by_cycles` in tests/tests/gap_evidence.rs).
pub const SHORT_PERIOD_CYCLES: f64 = 8.0;
/// The amplitude, in its standard deviations under the base fit's noise, that a sinusoid of fewer than three
/// cycles in the record must reach to be a candidate.
const LONG_PERIOD_Z: f64 = 4.0;

/// Samples per chunk of [`OneVarying::rss`]'s pass (a multiple of the phasors' renormalisation period, 1024).
const RSS_CHUNK: usize = 1 << 16;

/// The residual sum of squares of [`sinusoid_ls`] as a function of the frequency of sinusoid `j` alone, the
/// other frequencies held: the rows of the held columns are stored once, with their `A'A`, `A'y` and `y'y`, so
/// each trial passes over the record for the two columns that change (a fifth of the work of a whole
/// [`sinusoid_ls`] with four sinusoids). The refinement below calls it a dozen times per frequency.
struct OneVarying<'a> {
    y: &'a [f64],
    dt: f64,
    t_off: f64,
    /// The held columns' rows, `p` per sample.
    rows: Vec<f64>,
    p: usize,
    ata: Vec<Vec<f64>>,
    atb: Vec<f64>,
    yy: f64,
}

impl<'a> OneVarying<'a> {
    fn new(y: &'a [f64], freqs: &[f64], j: usize, dt: f64, t_off: f64) -> Self {
        let held: Vec<f64> = freqs.iter().enumerate().filter(|&(i, _)| i != j).map(|(_, &f)| f).collect();
        let mut design = DesignRows::new(y.len(), &held, dt, t_off);
        let p = design.width();
        let mut rows = vec![0.0; y.len() * p];
        for row in rows.chunks_exact_mut(p) {
            design.next_row(row);
        }
        let (ata, atb, yy) = normal_equations(y, &held, dt, t_off);
        OneVarying { y, dt, t_off, rows, p, ata, atb, yy }
    }

    /// The residual sum of squares with sinusoid `j` at `f` (infinite where the system is singular). The pass over
    /// the record runs in chunks of [`RSS_CHUNK`] samples in parallel (their sums added in order, so the result
    /// does not depend on the threads): the refinement is the longest of the estimators, and the others are done
    /// before it.
    fn rss(&self, f: f64) -> f64 {
        let p = self.p;
        let n = self.y.len();
        let chunk = |k: usize| -> ChunkSums {
            let i0 = k * RSS_CHUNK;
            let i1 = (i0 + RSS_CHUNK).min(n);
            let mut phase = DesignRows::from(n, i0, &[f], self.dt, self.t_off);
            let mut cs = [0.0; 5];
            let mut sums = ChunkSums::zero(p);
            for (row, &v) in self.rows[i0 * p..i1 * p].chunks_exact(p).zip(&self.y[i0..i1]) {
                phase.next_row(&mut cs);
                let (c, s) = (cs[3], cs[4]);
                sums.cc += c * c;
                sums.csx += c * s;
                sums.ss += s * s;
                sums.yc += v * c;
                sums.ys += v * s;
                for ((a, b), r) in sums.cf.iter_mut().zip(sums.sf.iter_mut()).zip(row) {
                    *a += c * r;
                    *b += s * r;
                }
            }
            sums
        };
        let parts: Vec<ChunkSums> = (0..n.div_ceil(RSS_CHUNK)).into_par_iter().map(chunk).collect();
        let ChunkSums { cc, csx, ss, yc, ys, cf, sf } =
            parts.into_iter().fold(ChunkSums::zero(p), |mut total, part| {
                total.add(&part);
                total
            });
        let mut ata = vec![vec![0.0; p + 2]; p + 2];
        for (r, row) in self.ata.iter().enumerate() {
            ata[r][..p].copy_from_slice(row);
            ata[r][p] = cf[r];
            ata[r][p + 1] = sf[r];
            ata[p][r] = cf[r];
            ata[p + 1][r] = sf[r];
        }
        ata[p][p] = cc;
        ata[p][p + 1] = csx;
        ata[p + 1][p] = csx;
        ata[p + 1][p + 1] = ss;
        let mut atb = self.atb.clone();
        atb.extend([yc, ys]);
        match solve(ata, atb.clone()) {
            Some(coef) => self.yy - coef.iter().zip(&atb).map(|(a, b)| a * b).sum::<f64>(),
            None => f64::INFINITY,
        }
    }
}

/// The sums one chunk of [`OneVarying::rss`]'s pass adds up: the varying sinusoid's cos and sin against each
/// other, the record and the held columns.
struct ChunkSums {
    cc: f64,
    csx: f64,
    ss: f64,
    yc: f64,
    ys: f64,
    cf: Vec<f64>,
    sf: Vec<f64>,
}

impl ChunkSums {
    fn zero(p: usize) -> Self {
        ChunkSums { cc: 0.0, csx: 0.0, ss: 0.0, yc: 0.0, ys: 0.0, cf: vec![0.0; p], sf: vec![0.0; p] }
    }

    fn add(&mut self, o: &ChunkSums) {
        self.cc += o.cc;
        self.csx += o.csx;
        self.ss += o.ss;
        self.yc += o.yc;
        self.ys += o.ys;
        self.cf.iter_mut().zip(&o.cf).for_each(|(x, y)| *x += y);
        self.sf.iter_mut().zip(&o.sf).for_each(|(x, y)| *x += y);
    }
}

/// `A'A`, `A'y` and `y'y` of the design of the record `y`.
fn normal_equations(y: &[f64], freqs: &[f64], dt: f64, t_off: f64) -> (Vec<Vec<f64>>, Vec<f64>, f64) {
    let mut rows = DesignRows::new(y.len(), freqs, dt, t_off);
    let p = rows.width();
    let mut ata = vec![vec![0.0; p]; p];
    let mut atb = vec![0.0; p];
    let mut yy = 0.0;
    let mut row = vec![0.0; p];
    for &v in y {
        rows.next_row(&mut row);
        yy += v * v;
        for (b, r) in atb.iter_mut().zip(&row) {
            *b += r * v;
        }
        for r in 0..p {
            for c in r..p {
                ata[r][c] += row[r] * row[c];
            }
        }
    }
    for r in 0..p {
        for c in 0..r {
            ata[r][c] = ata[c][r];
        }
    }
    (ata, atb, yy)
}

/// The standard deviations of the amplitude and of the phase (rad) of sinusoid `j` of the least squares `ls` of
/// [`sinusoid_ls`] (on `n` samples) under noise of two-sided spectrum `N^2 + B^2 / (2 pi f) + K^2 / (2 pi f)^2`
/// (`squares` of the IEEE fit): each coefficient is linear in the record, `a = sum g_i y_i`, so its variance is the
/// integral of `|G(f)|^2 S(f)`, taken on a twice zero-padded grid, leakage of red noise through the record's
/// rectangular window included.
fn ls_amplitude_sd(
    ls: &LeastSquares,
    n: usize,
    dt: f64,
    t_off: f64,
    freqs: &[f64],
    j: usize,
    noise: &NoiseSpectrum,
) -> Option<(f64, f64)> {
    let ata = &ls.ata;
    let p = ata.len();
    // The rows of (A'A)^-1 for the two coefficients.
    let col = |c: usize| {
        let mut e = vec![0.0; p];
        e[c] = 1.0;
        solve(ata.to_vec(), e)
    };
    let (ma, mb) = (col(3 + 2 * j)?, col(4 + 2 * j)?);
    // The two real weight sequences in one complex transform, g_a + i g_b, whose halves come apart by symmetry:
    // G_a[m] = (Z[m] + conj Z[-m]) / 2, G_b[m] = (Z[m] - conj Z[-m]) / 2i.
    let big = (2 * n).next_power_of_two();
    let (mut zr, mut zi) = (vec![0.0; big], vec![0.0; big]);
    let mut rows = DesignRows::new(n, freqs, dt, t_off);
    let mut r = vec![0.0; p];
    for i in 0..n {
        rows.next_row(&mut r);
        zr[i] = r.iter().zip(&ma).map(|(x, m)| x * m).sum();
        zi[i] = r.iter().zip(&mb).map(|(x, m)| x * m).sum();
    }
    fft(&mut zr, &mut zi);
    let df = 1.0 / (big as f64 * dt);
    let (mut va, mut vb, mut cab) = (0.0, 0.0, 0.0);
    for m in 1..=big / 2 {
        let k = big - m;
        let (ar, ai) = (0.5 * (zr[m] + zr[k]), 0.5 * (zi[m] - zi[k]));
        let (br, bi) = (0.5 * (zi[m] + zi[k]), -0.5 * (zr[m] - zr[k]));
        let f = m as f64 * df;
        let s = noise.at(f);
        va += 2.0 * (ar * ar + ai * ai) * s * df;
        vb += 2.0 * (br * br + bi * bi) * s * df;
        cab += 2.0 * (ar * br + ai * bi) * s * df;
    }
    let (a, b) = (ls.coef[3 + 2 * j], ls.coef[4 + 2 * j]);
    let amp2 = a * a + b * b;
    if !(amp2 > 0.0 && va > 0.0 && vb > 0.0) {
        return None;
    }
    // A = |(a, b)|: its error is the coefficients' along (a, b); the phase's across it, over A.
    let var_amp = (a * a * va + b * b * vb + 2.0 * a * b * cab) / amp2;
    let var_ph = (b * b * va + a * a * vb - 2.0 * a * b * cab) / (amp2 * amp2);
    Some((var_amp.max(0.0).sqrt(), var_ph.max(0.0).sqrt()))
}

/// The share of the temperature's variance about a quadratic trend above which one sinusoid describes a
/// temperature cycle: the sim's and a chamber's cycles give nearly all of it, a temperature that only wanders
/// spreads its variance over many periods.
const TEMPERATURE_CYCLE_SHARE: f64 = 0.25;

/// The share of the variance of `temp` (sampled every `dt`, the first sample at `t_off`) about a quadratic trend
/// that one sinusoid of frequency `f` describes.
fn temperature_share(temp: &[f64], f: f64, dt: f64, t_off: f64) -> f64 {
    let rss = |freqs: &[f64]| -> Option<f64> {
        let (ata, atb, yty) = normal_equations(temp, freqs, dt, t_off);
        let c = solve(ata, atb.clone())?;
        Some(yty - c.iter().zip(&atb).map(|(c, b)| c * b).sum::<f64>())
    };
    match (rss(&[]), rss(&[f])) {
        (Some(r0), Some(r1)) if r0 > 0.0 => (1.0 - r1 / r0).clamp(0.0, 1.0),
        _ => 0.0,
    }
}

/// The sinusoid effect: [`sinusoid`] and its parameters.
pub(super) struct Kind;

impl EffectKind for Kind {
    const EFFECT: Effect = Effect::Sinusoid;
    type Params = SinusoidsParams;

    fn estimate(data: &TrainingData) -> Option<EffectFit> {
        sinusoid(data)
    }

    /// The amplitude's z among the sinusoids of many cycles ([`SHORT_PERIOD_CYCLES`]): the false peaks of
    /// effect-free records lie at a third to a fifth of the record, where flicker and random walk leak.
    fn test_statistic(p: &SinusoidsParams) -> Option<f64> {
        Some(p.short_period_z)
    }

    /// The joint fit moves each sinusoid's amplitude and phase; the periods are held.
    fn reestimated(p: &SinusoidsParams, gyro: &GyroSim) -> SinusoidsParams {
        let mut out = p.clone();
        if let Some(first) = gyro.sinusoids.first() {
            out.amplitude_dps = first.amplitude_dps;
            out.phase_rad = first.phase_rad;
        }
        for (one, m) in out.sinusoids.iter_mut().zip(&gyro.sinusoids) {
            one.amplitude_dps = m.amplitude_dps;
            one.phase_rad = m.phase_rad;
        }
        out
    }
}

/// Sinusoids on the rate.
///
/// Method: the Hann-windowed periodogram of the mean-removed record (block-averaged to at most 2^21 points, so a
/// record of days still resolves periods of a day; each block's time is its centre and the amplitude is
/// corrected for the block average's sinc), zero-padded to a power of two. The background at each bin is the
/// median of the periodogram in a band around it (+-16 bins at low frequency, log bands of 1/8 relative width
/// above, interpolated in log-log), so 1/f and 1/f^2 noise set their own level; a bin is a peak where it is a local
/// maximum beyond `ln(bins) + 7` times the background mean (the periodogram ordinate is exponential, so about
/// 1e-3 false peaks per record). Periods from a third of the record to two samples are searched, and down to 1.5
/// cycles by the least squares (below). Each peak's frequency is refined by Brent's search on the windowed
/// projection within +-1 bin; amplitudes and phases of up to four peaks come from one joint least-squares fit of sines and cosines (plus a quadratic trend). The base
/// terms are re-fitted on the record without the sinusoids (the base fit covered their Allan bump with B or K).
pub(super) fn sinusoid(d: &TrainingData) -> Option<EffectFit> {
    let b = Blocks::of(d.rate_dps, d.rate_hz)?;
    let p = Periodogram::of(&b.y, b.dt);
    let half = p.pw.len();
    let record = b.y.len() as f64 * b.dt;
    let k_lo = ((3.0 / record) / p.df).ceil().max(2.0) as usize;
    let k_hi = half - 2;
    if k_lo + 8 >= k_hi {
        return None;
    }
    let bg = band_background(&p.pw, p.pad);
    let (mut chosen, peak_excess) = periodogram_peaks(&p, &bg, k_lo, k_hi);
    if chosen.len() < MAX_SINUSOIDS {
        chosen.extend(long_period_peak(d, &b, &p, &chosen, k_lo.min(k_hi)));
    }
    // A rate component at a period where the recorded temperature has a cycle of its own is the temperature's
    // response, left to the temperature estimator: the temperature explains it with a measured cause and two
    // parameters, where a sinusoid would copy it with three and go on after the temperature changes its rhythm.
    let n0 = d.rate_dps.len();
    if let Some(temp) = d.temp_c.filter(|t| t.len() >= n0) {
        let temp_blocks = if b.dec == 1 { temp[..n0].to_vec() } else { block_means(&temp[..n0], b.dec) };
        chosen.retain(|&k| temperature_share(&temp_blocks, k as f64 * p.df, b.dt, b.t_off) < TEMPERATURE_CYCLE_SHARE);
    }
    if chosen.is_empty() {
        return None;
    }
    let freqs = refined_frequencies(&b, &chosen, p.df);
    let ls = sinusoid_ls(&b.y, &freqs, b.dt, b.t_off)?;
    let found = found_sinusoids(&ls, &freqs, &chosen, &bg, &b, d.rate_hz);
    Some(sinusoids_fit(d, &b, &ls, &freqs, found, peak_excess))
}

/// The record the periodogram is taken of: the mean-removed rate, block-averaged to at most 2^21 points.
struct Blocks {
    /// The mean-removed block means.
    y: Vec<f64>,
    /// Samples per block.
    dec: usize,
    /// The blocks' spacing, s.
    dt: f64,
    /// The first block's centre, s.
    t_off: f64,
}

impl Blocks {
    /// The blocks of the rate `x` sampled at `rate_hz`; `None` for fewer than 64.
    fn of(x: &[f64], rate_hz: f64) -> Option<Blocks> {
        let dec = x.len().div_ceil(1 << 21).max(1);
        let mu = mean(x);
        let y: Vec<f64> = if dec == 1 {
            x.iter().map(|v| v - mu).collect()
        } else {
            block_means(x, dec).iter().map(|v| v - mu).collect()
        };
        if y.len() < 64 {
            return None;
        }
        Some(Blocks { y, dec, dt: dec as f64 / rate_hz, t_off: (dec as f64 - 1.0) / 2.0 / rate_hz })
    }
}

/// The Hann-windowed periodogram of a record zero-padded to a power of two.
struct Periodogram {
    /// Power per bin, from zero to below Nyquist.
    pw: Vec<f64>,
    /// The padded length over the record's.
    pad: f64,
    /// The bin width, Hz.
    df: f64,
}

impl Periodogram {
    /// The periodogram of `y`, spaced by `dt`.
    fn of(y: &[f64], dt: f64) -> Periodogram {
        let n = y.len();
        let nfft = n.next_power_of_two();
        let mut re = vec![0.0; nfft];
        let mut im = vec![0.0; nfft];
        let wd = 2.0 * std::f64::consts::PI / n as f64;
        for (i, v) in y.iter().enumerate() {
            re[i] = v * 0.5 * (1.0 - (wd * i as f64).cos());
        }
        fft(&mut re, &mut im);
        let pw = (0..nfft / 2).map(|k| re[k] * re[k] + im[k] * im[k]).collect();
        Periodogram { pw, pad: nfft as f64 / n as f64, df: 1.0 / (nfft as f64 * dt) }
    }
}

/// The periodogram's background at each bin: the median of a band around it, +-16 bins (times the padding) at
/// low frequency, log bands of 1/8 relative width above, interpolated in log-log.
fn band_background(pw: &[f64], pad: f64) -> Vec<f64> {
    let half = pw.len();
    let excl = (3.0 * pad).ceil() as usize;
    let w_low = (16.0 * pad).ceil() as usize;
    let switch = (8 * w_low).max(64);
    let mut bg = vec![0.0; half];
    for (k, b) in bg.iter_mut().enumerate().take(switch.min(half)).skip(1) {
        let lo = k.saturating_sub(w_low).max(1);
        let hi = (k + w_low).min(half - 1);
        let v: Vec<f64> = (lo..=hi).filter(|j| j.abs_diff(k) > excl).map(|j| pw[j]).collect();
        *b = median(&v);
    }
    if switch < half {
        let mut centres: Vec<(f64, f64)> = Vec::new();
        let mut lo = switch / 2;
        while lo < half {
            let hi = ((lo as f64 * 1.125).ceil() as usize).max(lo + 2 * w_low).min(half);
            let med = median(&pw[lo..hi]);
            centres.push((((lo as f64) * (hi as f64)).sqrt().ln(), med.max(1e-300).ln()));
            lo = hi;
        }
        let mut c = 0;
        for (k, b) in bg.iter_mut().enumerate().skip(switch) {
            let lk = (k as f64).ln();
            while c + 1 < centres.len() && centres[c + 1].0 < lk {
                c += 1;
            }
            let v = if c + 1 >= centres.len() || lk <= centres[c].0 {
                centres[c].1
            } else {
                let (a, b2) = (centres[c], centres[c + 1]);
                a.1 + (b2.1 - a.1) * (lk - a.0) / (b2.0 - a.0)
            };
            *b = v.exp();
        }
    }
    bg
}

/// The bins of up to [`MAX_SINUSOIDS`] peaks in `k_lo..k_hi` beyond the look-elsewhere level plus 7 times their
/// background mean, strongest first and 8 bins (times the padding) apart, and the strongest peak's excess over the
/// look-elsewhere level (the estimator's own test statistic; NaN without a peak).
fn periodogram_peaks(p: &Periodogram, bg: &[f64], k_lo: usize, k_hi: usize) -> (Vec<usize>, f64) {
    let pw = &p.pw;
    // The look-elsewhere level: the largest of `bins` exponential ordinates is about ln(bins).
    let look_elsewhere = ((k_hi - k_lo) as f64).ln();
    let thr = look_elsewhere + 7.0;
    let mut peaks: Vec<(usize, f64)> = (k_lo..k_hi)
        .filter(|&k| pw[k] >= pw[k - 1] && pw[k] >= pw[k + 1] && bg[k] > 0.0)
        .map(|k| (k, pw[k] / (bg[k] / std::f64::consts::LN_2)))
        .filter(|&(_, z)| z > thr)
        .collect();
    peaks.sort_by(|a, b| b.1.total_cmp(&a.1));
    let peak_excess = peaks.first().map_or(f64::NAN, |p| p.1 - look_elsewhere);
    let mut chosen: Vec<usize> = Vec::new();
    let sep = peak_separation(p.pad);
    for (k, _) in peaks {
        if chosen.iter().all(|&c| c.abs_diff(k) > sep) {
            chosen.push(k);
            if chosen.len() == MAX_SINUSOIDS {
                break;
            }
        }
    }
    (chosen, peak_excess)
}

/// The least distance in bins between two peaks taken apart.
fn peak_separation(pad: f64) -> usize {
    (8.0 * pad).ceil() as usize
}

/// A peak at a period beyond a third of the record (bins below `k_lo`), where red noise lifts the lowest bins
/// above any band median, so the least squares judges it instead: the strongest local maximum down to 1.5 cycles,
/// kept when its amplitude stands beyond [`LONG_PERIOD_Z`] of its own standard deviation under the base fit's
/// noise (flicker and random walk leaking through the record's window included).
fn long_period_peak(d: &TrainingData, b: &Blocks, p: &Periodogram, chosen: &[usize], k_lo: usize) -> Option<usize> {
    let (pw, df) = (&p.pw, p.df);
    let record = b.y.len() as f64 * b.dt;
    let k_long = ((LONG_PERIOD_CYCLES / record) / df).ceil().max(2.0) as usize;
    let sep = peak_separation(p.pad);
    let k = (k_long..k_lo)
        .filter(|&k| pw[k] >= pw[k - 1] && pw[k] >= pw[k + 1])
        .max_by(|&a, &b| pw[a].total_cmp(&pw[b]))
        .filter(|&k| chosen.iter().all(|&c| c.abs_diff(k) > sep))?;
    let f0 = k as f64 * df;
    let (f, _) = brent((f0 - df).max(df * 0.5), f0 + df, HANN_TOL * df, 40, |f| -hann_power(&b.y, f, b.dt));
    let z = sinusoid_ls(&b.y, &[f], b.dt, b.t_off).and_then(|ls| {
        let noise = NoiseSpectrum::of(&samples_noise(d), d.rate_hz);
        let sd = ls_amplitude_sd(&ls, b.y.len(), b.dt, b.t_off, &[f], 0, &noise)?.0;
        Some(ls.coef[3].hypot(ls.coef[4]) / sd)
    });
    z.is_some_and(|z| z > LONG_PERIOD_Z).then_some(k)
}

/// The frequencies of the `chosen` bins, refined first on the windowed projection, then on the whole record: the
/// windowed projection gives away the record's ends, and a period learnt on 8 cycles 1.5% off has drifted by an
/// eighth of a cycle over an equal holdout. Each frequency in turn minimises the residual of the joint least
/// squares, within half a bin of where it is.
fn refined_frequencies(b: &Blocks, chosen: &[usize], df: f64) -> Vec<f64> {
    let mut freqs: Vec<f64> = chosen
        .iter()
        .map(|&k| {
            let f0 = k as f64 * df;
            let (f, _) = brent((f0 - df).max(df * 0.5), f0 + df, HANN_TOL * df, 40, |f| -hann_power(&b.y, f, b.dt));
            f
        })
        .collect();
    for _ in 0..2 {
        for j in 0..freqs.len() {
            let f0 = freqs[j];
            let varying = OneVarying::new(&b.y, &freqs, j, b.dt, b.t_off);
            let (f, _) = brent(f0 - 0.5 * df, f0 + 0.5 * df, RSS_TOL * df, 30, |f| varying.rss(f));
            freqs[j] = f;
        }
    }
    freqs
}

/// A sinusoid found by the least squares: its first standard errors (amplitude, phase, frequency), its index in
/// the frequencies and the block average's gain at its frequency.
struct Found {
    sinusoid: Sinusoid,
    se: [f64; 3],
    index: usize,
    gain: f64,
}

/// The sinusoids of the joint least squares `ls` at `freqs` (found at the bins `chosen` over the background
/// `bg`), largest first, with their first standard errors.
fn found_sinusoids(
    ls: &LeastSquares,
    freqs: &[f64],
    chosen: &[usize],
    bg: &[f64],
    b: &Blocks,
    rate_hz: f64,
) -> Vec<Found> {
    let n = b.y.len();
    let record_s = n as f64 * b.dt;
    let mut list: Vec<Found> = Vec::new();
    for (j, &f) in freqs.iter().enumerate() {
        let (a, bc) = (ls.coef[3 + 2 * j], ls.coef[4 + 2 * j]);
        // Block averaging scales a sinusoid by sin(pi f D/rate_hz) / (D sin(pi f/rate_hz)).
        let g = if b.dec > 1 {
            let u = std::f64::consts::PI * f / rate_hz;
            ((u * b.dec as f64).sin() / (b.dec as f64 * u.sin())).abs().max(1e-3)
        } else {
            1.0
        };
        // a cos + b sin = A sin(w t + phi): a = A sin phi, b = A cos phi.
        let amplitude = (a * a + bc * bc).sqrt() / g;
        // First standard errors from the noise's one-sided PSD at the peak, S1 = 16 dt E[P] / (3 n) for the
        // Hann periodogram P (whose mean is the background median / ln 2): var(a) = var(b) = S1 / T over a
        // record of T, so se(A) = sqrt(S1 / T) and se(phase at the centre) = se(A) / A; the frequency's is the
        // least-squares (Cramer-Rao) bound sqrt(3 S1 / (pi^2 A^2 T^3)). The amplitude's and phase's are taken
        // again under the noise model, and the frequency's scaled with them.
        let s1 = 16.0 * b.dt * bg[chosen[j]] / std::f64::consts::LN_2 / (3.0 * n as f64) / (g * g);
        let se_a = (s1 / record_s).sqrt();
        let se_f = (3.0 * s1 / (std::f64::consts::PI.powi(2) * amplitude.powi(2) * record_s.powi(3))).sqrt();
        let se = [se_a, se_a / amplitude.max(1e-300), se_f];
        let sinusoid = Sinusoid { amplitude_dps: amplitude, period_s: 1.0 / f, phase_rad: a.atan2(bc) };
        list.push(Found { sinusoid, se, index: j, gain: g });
    }
    list.sort_by(|a, b| b.sinusoid.amplitude_dps.total_cmp(&a.sinusoid.amplitude_dps));
    list
}

/// The sinusoids' fit: the base terms re-fitted on the record without them (the base fit covered their Allan bump
/// with B or K), and the least squares' own errors under that noise model, leakage of its red noise included (the
/// Hann background sees only the noise at the peak's bins).
fn sinusoids_fit(
    d: &TrainingData,
    b: &Blocks,
    ls: &LeastSquares,
    freqs: &[f64],
    found: Vec<Found>,
    peak_excess: f64,
) -> EffectFit {
    let list: Vec<Sinusoid> = found.iter().map(|f| f.sinusoid).collect();
    let two_pi = 2.0 * std::f64::consts::PI;
    let cleaned: Vec<f64> = d
        .rate_dps
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            let t = i as f64 / d.rate_hz;
            v - list.iter().map(|s| s.amplitude_dps * (two_pi * t / s.period_s + s.phase_rad).sin()).sum::<f64>()
        })
        .collect();
    // The weakest sinusoid's amplitude over its first standard error.
    let t = found.iter().map(|f| (f.sinusoid.amplitude_dps / f.se[0]).abs()).fold(f64::INFINITY, f64::min);
    let mut gyro = refit_base(d, &cleaned, t).map_or_else(|| d.base.clone(), |r| r.0);
    let noise = match d.shaped_dps {
        Some(_) => NoiseSpectrum::of(&refit_noise(d, &cleaned).map_or_else(|| gyro.clone(), |r| r.0), d.rate_hz),
        None => NoiseSpectrum::of(&gyro, d.rate_hz),
    };
    let se: Vec<[f64; 3]> = found
        .iter()
        .map(|f| match ls_amplitude_sd(ls, b.y.len(), b.dt, b.t_off, freqs, f.index, &noise) {
            Some((sd_a, sd_p)) => {
                let sd_a = sd_a / f.gain;
                [sd_a, sd_p, f.se[2] * sd_a / f.se[0].max(1e-300)]
            }
            None => f.se,
        })
        .collect();
    // Read from the output; the model sends its sinusoids through the sensor's bandwidth, so under a corner each
    // is the larger input that gives what was read, its standard error scaled alike.
    let bw = d.base.bandwidth_hz;
    let list: Vec<Sinusoid> = list.iter().map(|s| sinusoid_moved(s, None, bw, d.rate_hz)).collect();
    let se: Vec<[f64; 3]> = se
        .iter()
        .zip(&found)
        .zip(&list)
        .map(|((e, f), s)| {
            let g = s.amplitude_dps / f.sinusoid.amplitude_dps.max(1e-300);
            [e[0] * g, e[1], e[2]]
        })
        .collect();
    gyro.sinusoids.clear();
    for s in &list {
        let _ = gyro.sinusoids.push(*s);
    }
    let s0 = list[0];
    let amplitude_z = list.iter().zip(&se).map(|(s, e)| s.amplitude_dps / e[0]).fold(f64::NAN, f64::max);
    let training_s = d.rate_dps.len() as f64 / d.rate_hz;
    let short_period_z = list
        .iter()
        .zip(&se)
        .filter(|(s, _)| training_s / s.period_s >= SHORT_PERIOD_CYCLES)
        .map(|(s, e)| s.amplitude_dps / e[0])
        .fold(0.0, f64::max);
    let all: Vec<SinusoidParams> = list
        .iter()
        .zip(&se)
        .map(|(s, e)| SinusoidParams {
            amplitude_dps: s.amplitude_dps,
            period_s: s.period_s,
            phase_rad: s.phase_rad,
            amplitude_se_dps: e[0],
            period_se_s: e[2] * s.period_s * s.period_s,
        })
        .collect();
    EffectFit {
        effect: Effect::Sinusoid,
        params: SinusoidsParams {
            amplitude_dps: s0.amplitude_dps,
            period_s: s0.period_s,
            phase_rad: s0.phase_rad,
            peak_excess,
            amplitude_z,
            short_period_z,
            sinusoids: all,
        }
        .into(),
        n_params: 3 * list.len(),
        gyro,
        channel: None,
        spread: Some(ParamSpread::Sinusoids { se, centre_s: d.rate_dps.len() as f64 / d.rate_hz / 2.0 }),
        cleaned: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The one-varying residual is the whole joint least squares' at every trial frequency, on a record of three
    /// chunks of its parallel pass.
    #[test]
    fn one_varying_residual_is_the_joint_least_squares() {
        let dt = 0.01;
        let y: Vec<f64> = octavar_stats::test_signals::white(150_000, 3)
            .iter()
            .enumerate()
            .map(|(i, w)| {
                let t = i as f64 * dt;
                w + 0.3 * (2.0 * std::f64::consts::PI * 1.7 * t).sin()
                    + 0.2 * (2.0 * std::f64::consts::PI * 7.3 * t).cos()
            })
            .collect();
        let freqs = [1.7, 7.3, 12.1];
        for j in 0..freqs.len() {
            let varying = OneVarying::new(&y, &freqs, j, dt, 0.002);
            for f in [freqs[j] - 0.004, freqs[j], freqs[j] + 0.0031] {
                let mut trial = freqs;
                trial[j] = f;
                let (ata, atb, yy) = normal_equations(&y, &trial, dt, 0.002);
                let coef = solve(ata, atb.clone()).unwrap();
                let whole = yy - coef.iter().zip(&atb).map(|(a, b)| a * b).sum::<f64>();
                let one = varying.rss(f);
                assert!((one - whole).abs() <= 1e-9 * whole, "j {j} f {f}: {one} against {whole}");
            }
        }
    }
}

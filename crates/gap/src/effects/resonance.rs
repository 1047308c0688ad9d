//! The resonance candidate: a spectral bump wider than a line (narrowband random vibration, a second-order
//! Gauss-Markov process), found in a Welch spectrum against its local background and fitted with the
//! sampled oscillator's spectrum that shared::sim simulates.
//!
//! A mount's resonance, or a MEMS sensor's own resonance aliased through its decimation filter, puts a band of
//! random power around a centre frequency: the ADIS16405's z axis shows ten times the power around it at 19-21 Hz.
//! The Allan deviation smears such a bump over an octave or two of tau, where the base fit takes it for white or
//! angle noise; the spectrum shows its centre, width and power directly. A sinusoid is a line, as narrow as the
//! spectral window: that is the `sinusoid` candidate, and a bump no wider than a few bins is left to it.

use super::params::ResonanceParams;
use octavar_shared::sim::noise::ResonanceCoefficients;
use octavar_shared::sim::{GaussMarkovSim, GyroSim, ResonanceSim};
use octavar_stats::fit::FitPoint;
use rustfft::num_complex::Complex;

use super::common::*;
use super::curve::*;
use super::lowpass::lowpass_gain;
use super::{Effect, EffectFit, EffectKind, TrainingData};

/// Fewest Welch segments: the spectrum's log has a standard deviation of about `1 / sqrt(segments)`.
const MIN_SEGMENTS: usize = 16;
/// The bump's fit must lower the chi-square of the spectrum's log over its window by this much against the
/// background alone (in units of the fit's own residual variance).
const DELTA_CHI2: f64 = 100.0;
/// The bump's power at its centre, as a share of the background's there, at least.
const MIN_PEAK_RATIO: f64 = 0.5;
/// The bump's half-power width, in Welch bins, at least: narrower is a line (the Hann window's half-power width is
/// 1.44 bins), the sinusoid candidate's.
const MIN_WIDTH_BINS: f64 = 4.0;
/// Adjacent bins above the fitted background by three of the spectrum's log standard deviations, at least.
const MIN_RUN_BINS: usize = 5;
/// Lowest quality factor: a broader hump is a shape of the background (a filter's knee, a Gauss-Markov plateau),
/// not a resonance.
const MIN_Q: f64 = 1.5;
/// Candidate bumps fitted (the largest local excesses over the median background).
const CANDIDATES: usize = 3;

/// The one-sided Welch spectrum of `x`, (deg/s)^2/Hz: Hann segments of `seg` samples, 50% overlap, each segment's
/// mean removed, the segments that overlap a run of `gaps` (filled in `x`) left out; bins `k df`, `k =
/// 0..seg/2`. Also the number of segments.
fn welch(x: &[f64], gaps: &[std::ops::Range<usize>], rate_hz: f64, seg: usize) -> (Vec<f64>, usize) {
    let fft = forward_plan(seg);
    let window: Vec<f64> =
        (0..seg).map(|i| 0.5 * (1.0 - (2.0 * std::f64::consts::PI * i as f64 / seg as f64).cos())).collect();
    let w2: f64 = window.iter().map(|w| w * w).sum();
    let mut acc = vec![0.0; seg / 2 + 1];
    let mut buf = vec![Complex::new(0.0, 0.0); seg];
    let mut count = 0;
    let mut start = 0;
    while start + seg <= x.len() {
        if gaps.iter().any(|g| g.start < start + seg && g.end > start) {
            start += seg / 2;
            continue;
        }
        let part = &x[start..start + seg];
        let mu = mean(part);
        for ((b, v), w) in buf.iter_mut().zip(part).zip(&window) {
            *b = Complex::new((v - mu) * w, 0.0);
        }
        fft.process(&mut buf);
        for (a, b) in acc.iter_mut().zip(&buf) {
            *a += b.norm_sqr();
        }
        count += 1;
        start += seg / 2;
    }
    let scale = 2.0 / (rate_hz * w2 * count.max(1) as f64);
    (acc.iter().map(|a| a * scale).collect(), count)
}

/// The median of `ln_p` over bins within a factor `2^(1/2)` of each bin's frequency (at least 8 bins each way),
/// taken at centres 1/16 octave apart and interpolated in ln f: a background that a bump a fraction of an octave
/// wide hardly moves.
fn median_background(ln_p: &[f64], k_lo: usize, k_hi: usize) -> Vec<f64> {
    let span = 2f64.sqrt();
    let mut centres: Vec<(f64, f64)> = Vec::new();
    let mut c = k_lo as f64;
    while c <= k_hi as f64 {
        let ci = c as usize;
        let lo = ((c / span).floor() as usize).min(ci.saturating_sub(8)).max(k_lo);
        let hi = ((c * span).ceil() as usize).max(ci + 8).min(k_hi);
        centres.push((c.ln(), median(&ln_p[lo..=hi])));
        c *= 2f64.powf(1.0 / 16.0);
    }
    let mut bg = vec![f64::NAN; ln_p.len()];
    let mut j = 0;
    for (k, b) in bg.iter_mut().enumerate().take(k_hi + 1).skip(k_lo) {
        let lk = (k as f64).ln();
        while j + 1 < centres.len() && centres[j + 1].0 < lk {
            j += 1;
        }
        *b = if j + 1 >= centres.len() || lk <= centres[j].0 {
            centres[j].1
        } else {
            let (a, b2) = (centres[j], centres[j + 1]);
            a.1 + (b2.1 - a.1) * (lk - a.0) / (b2.0 - a.0)
        };
    }
    bg
}

/// The unit-variance resonance's one-sided spectrum, 1/Hz, at frequencies given by their [`phasors`]: the sampled
/// oscillator's (the ARMA(2,1) of shared::sim), `2 tau0 s^2 |1 + m e^{-iw}|^2 / |1 - a1 e^{-iw} - a2 e^{-2iw}|^2`,
/// `w = 2 pi f / rate_hz`.
fn unit_spectrum<'a>(
    freq_hz: f64,
    q: f64,
    rate_hz: f64,
    phasors: impl Iterator<Item = &'a [f64; 4]> + 'a,
) -> impl Iterator<Item = f64> + 'a {
    let ResonanceCoefficients { a1, a2, ma, s, .. } = ResonanceCoefficients::of(freq_hz, q, 1.0 / rate_hz);
    phasors.map(move |&[c1, s1, c2, s2]| {
        let re = 1.0 - a1 * c1 - a2 * c2;
        let im = a1 * s1 + a2 * s2;
        2.0 / rate_hz * s * s * (1.0 + 2.0 * ma * c1 + ma * ma) / (re * re + im * im)
    })
}

/// `[cos w, sin w, cos 2w, sin 2w]` at `w = 2 pi f / rate_hz`: what [`unit_spectrum`] needs of a frequency, the
/// same at every parameter a fit tries.
fn phasors(f: f64, rate_hz: f64) -> [f64; 4] {
    let w = 2.0 * std::f64::consts::PI * f / rate_hz;
    [w.cos(), w.sin(), (2.0 * w).cos(), (2.0 * w).sin()]
}

/// The unit-variance resonance's one-sided spectrum at one frequency.
pub(super) fn unit_spectrum_at(freq_hz: f64, q: f64, rate_hz: f64, f: f64) -> f64 {
    unit_spectrum(freq_hz, q, rate_hz, std::iter::once(&phasors(f, rate_hz))).next().unwrap_or(f64::NAN)
}

/// A bump fitted over one window of the spectrum.
#[derive(Clone, Debug)]
struct Bump {
    freq_hz: f64,
    q: f64,
    /// The bump's variance, (deg/s)^2.
    power: f64,
    /// The chi-square drop against the background alone.
    delta_chi2: f64,
    /// The bump's spectrum over the background's at its centre.
    peak_ratio: f64,
    /// Longest run of adjacent bins above the fitted background by 3 standard deviations of ln P.
    run_bins: usize,
    /// Standard errors of ln power, ln f0 and ln Q.
    se_ln: [f64; 3],
}

/// The spectrum's log over a window, and the model `ln(exp(c0 + c1 u + c2 u^2) + s2 H(f; f0, Q) L(f))`,
/// `u = ln(f / centre)`, `L` the power gain of the model's output bandwidth, in the parameters
/// `[c0, c1, c2, ln s2, ln f0, ln Q]`.
struct Window<'a> {
    f: &'a [f64],
    u: Vec<f64>,
    y: &'a [f64],
    rate_hz: f64,
    /// Each bin's [`phasors`].
    phasors: Vec<[f64; 4]>,
    /// The power gain of the model's output bandwidth at each bin (1 without one): the simulator passes the
    /// resonance through it, so the bump in the record is the resonance's spectrum times this gain.
    gain: Vec<f64>,
}

impl Window<'_> {
    /// The model's ln P at every bin of the window; `None` outside the parameters' range.
    fn model(&self, th: &[f64; 6]) -> Option<Vec<f64>> {
        let (f0, q) = (th[4].exp(), th[5].exp());
        if !(q > 0.5 && f0 > 0.0 && f0 < 0.5 * self.rate_hz && th.iter().all(|v| v.is_finite())) {
            return None;
        }
        let s2 = th[3].exp();
        let v: Vec<f64> = unit_spectrum(f0, q, self.rate_hz, self.phasors.iter())
            .zip(self.u.iter().zip(&self.gain))
            .map(|(h, (&u, g))| ((th[0] + th[1] * u + th[2] * u * u).exp() + s2 * h * g).ln())
            .collect();
        v.iter().all(|x| x.is_finite()).then_some(v)
    }

    fn rss(&self, th: &[f64; 6]) -> f64 {
        self.model(th).map_or(f64::INFINITY, |m| self.y.iter().zip(&m).map(|(y, m)| (y - m).powi(2)).sum())
    }

    /// The quadratic background alone, by linear least squares: its coefficients and residual sum of squares.
    fn background(&self) -> Option<([f64; 3], f64)> {
        let mut a = vec![vec![0.0; 3]; 3];
        let mut b = vec![0.0; 3];
        for (&u, &y) in self.u.iter().zip(self.y) {
            let row = [1.0, u, u * u];
            for r in 0..3 {
                b[r] += row[r] * y;
                for c in 0..3 {
                    a[r][c] += row[r] * row[c];
                }
            }
        }
        let c = solve(a, b)?;
        let rss = self.u.iter().zip(self.y).map(|(&u, &y)| (y - c[0] - c[1] * u - c[2] * u * u).powi(2)).sum();
        Some(([c[0], c[1], c[2]], rss))
    }

    /// The residuals at `th` and the model's forward-difference Jacobian there; `None` outside the range.
    fn jacobian(&self, th: &[f64; 6]) -> Option<(Vec<f64>, Vec<[f64; 6]>)> {
        let m0 = self.model(th)?;
        let r: Vec<f64> = self.y.iter().zip(&m0).map(|(y, m)| y - m).collect();
        let mut jac = vec![[0.0; 6]; self.y.len()];
        for p in 0..6 {
            let h = 1e-6 * th[p].abs().max(1e-3);
            let mut t2 = *th;
            t2[p] += h;
            let m1 = self.model(&t2)?;
            for (row, (a, b)) in jac.iter_mut().zip(m1.iter().zip(&m0)) {
                row[p] = (a - b) / h;
            }
        }
        Some((r, jac))
    }

    /// The standard errors of the parameters at `th` for a residual variance `sigma2` per bin: the diagonal of
    /// `sigma2 (J'J)^-1`, times sqrt(1.5) for the correlation of neighbouring bins of a Hann-windowed periodogram
    /// (1/4 each side).
    fn standard_errors(&self, th: &[f64; 6], sigma2: f64) -> Option<[f64; 6]> {
        let (_, jac) = self.jacobian(th)?;
        let mut jtj = vec![vec![0.0; 6]; 6];
        for row in &jac {
            for a in 0..6 {
                for b in 0..6 {
                    jtj[a][b] += row[a] * row[b];
                }
            }
        }
        let mut se = [0.0; 6];
        for (p, out) in se.iter_mut().enumerate() {
            let mut e = vec![0.0; 6];
            e[p] = 1.0;
            let col = solve(jtj.clone(), e)?;
            *out = (1.5 * sigma2 * col[p]).max(0.0).sqrt();
        }
        Some(se)
    }

    /// Levenberg-Marquardt from `th`; the parameters and their residual sum of squares.
    fn fit(&self, mut th: [f64; 6]) -> ([f64; 6], f64) {
        let mut rss = self.rss(&th);
        let mut lambda = 1e-3;
        for _ in 0..100 {
            let Some((r, jac)) = self.jacobian(&th) else { break };
            let mut jtj = [[0.0; 6]; 6];
            let mut jtr = [0.0; 6];
            for (row, ri) in jac.iter().zip(&r) {
                for a in 0..6 {
                    jtr[a] += row[a] * ri;
                    for b in 0..6 {
                        jtj[a][b] += row[a] * row[b];
                    }
                }
            }
            let mut improved = false;
            for _ in 0..12 {
                let a: Vec<Vec<f64>> = (0..6)
                    .map(|i| {
                        (0..6).map(|j| jtj[i][j] + if i == j { lambda * jtj[i][i].max(1e-12) } else { 0.0 }).collect()
                    })
                    .collect();
                let Some(step) = solve(a, jtr.to_vec()) else { break };
                let mut t2 = th;
                for p in 0..6 {
                    t2[p] += step[p];
                }
                let r2 = self.rss(&t2);
                if r2 < rss {
                    let done = rss - r2 < 1e-10 * rss;
                    th = t2;
                    rss = r2;
                    lambda = (lambda / 3.0).max(1e-9);
                    improved = !done;
                    break;
                }
                lambda *= 4.0;
            }
            if !improved {
                break;
            }
        }
        (th, rss)
    }
}

/// Fit a bump near bin `k0` (its initial half-power half-width `hw` bins) over a window of the spectrum; `None`
/// when the window is too small or the fit fails.
fn fit_bump(
    f: &[f64],
    ln_p: &[f64],
    k_range: (usize, usize),
    k0: usize,
    hw: f64,
    rate_hz: f64,
    bw: Option<f64>,
) -> Option<Bump> {
    let gain_at = |x: f64| bw.map_or(1.0, |b| lowpass_gain(b, rate_hz, x));
    let (k_lo, k_hi) = k_range;
    let df = f[1] - f[0];
    let mut f0 = f[k0];
    let mut q = (f0 / (2.0 * hw.max(1.0) * df)).clamp(1.0, 1e4);
    let mut best: Option<Bump> = None;
    for _ in 0..2 {
        // From six half-widths below f0 to twelve above (about even in ln f), at least a tenth of f0 and 24 bins
        // below, at most half of f0.
        let half = (6.0 * f0 / (2.0 * q)).max(0.1 * f0).max(24.0 * df).min(f0 * 0.5);
        let lo = (((f0 - half) / df).floor().max(k_lo as f64)) as usize;
        let hi = (((f0 + 2.0 * half) / df).ceil().min(k_hi as f64)) as usize;
        if hi < lo + 20 {
            return best;
        }
        let w = Window {
            f: &f[lo..=hi],
            u: f[lo..=hi].iter().map(|x| (x / f0).ln()).collect(),
            y: &ln_p[lo..=hi],
            rate_hz,
            phasors: f[lo..=hi].iter().map(|&x| phasors(x, rate_hz)).collect(),
            gain: f[lo..=hi].iter().map(|&x| gain_at(x)).collect(),
        };
        let (bg, rss0) = w.background()?;
        // Start: the background under the bump's shoulders and the excess power under it.
        let core: Vec<usize> = (0..w.y.len()).filter(|&i| (w.f[i] - f0).abs() <= f0 / (2.0 * q)).collect();
        let bg_at = |i: usize| (bg[0] + bg[1] * w.u[i] + bg[2] * w.u[i] * w.u[i]).exp();
        let excess: f64 = (0..w.y.len()).map(|i| (w.y[i].exp() - bg_at(i)).max(0.0)).sum::<f64>() * df;
        let start = [bg[0] - 0.3, bg[1], bg[2], excess.max(1e-300).ln(), f0.ln(), q.ln()];
        let (th, rss1) = w.fit(start);
        let (f_fit, q_fit) = (th[4].exp(), th[5].exp());
        if !(rss1.is_finite() && f_fit > w.f[0] && f_fit < w.f[w.f.len() - 1] && !core.is_empty()) {
            return best;
        }
        let dof = (w.y.len() - 6) as f64;
        let sigma2 = rss1 / dof;
        let bg_fit = |i: usize| (th[0] + th[1] * w.u[i] + th[2] * w.u[i] * w.u[i]).exp();
        let i0 = (0..w.f.len()).min_by(|&a, &b| (w.f[a] - f_fit).abs().total_cmp(&(w.f[b] - f_fit).abs()))?;
        let power = th[3].exp();
        let peak_ratio = power * unit_spectrum_at(f_fit, q_fit, rate_hz, f_fit) * gain_at(f_fit) / bg_fit(i0);
        let thr = 3.0 * sigma2.sqrt();
        let (mut run, mut longest) = (0, 0);
        for i in 0..w.y.len() {
            run = if w.y[i] - bg_fit(i).ln() > thr { run + 1 } else { 0 };
            longest = longest.max(run);
        }
        let se = w.standard_errors(&th, sigma2)?;
        let bump = Bump {
            se_ln: [se[3], se[4], se[5]],
            freq_hz: f_fit,
            q: q_fit,
            power,
            delta_chi2: (rss0 - rss1) / sigma2,
            peak_ratio,
            run_bins: longest,
        };
        f0 = f_fit;
        q = q_fit.clamp(1.0, 1e4);
        best = Some(bump);
    }
    best
}

/// The resonance effect: [`resonance`] and its parameters.
pub(super) struct Kind;

impl EffectKind for Kind {
    const EFFECT: Effect = Effect::Resonance;
    type Params = ResonanceParams;

    fn estimate(data: &TrainingData) -> Option<EffectFit> {
        resonance(data)
    }

    fn test_statistic(p: &ResonanceParams) -> Option<f64> {
        Some(p.delta_chi2)
    }

    fn reestimated(p: &ResonanceParams, gyro: &GyroSim) -> ResonanceParams {
        match gyro.resonance {
            Some(r) => ResonanceParams {
                sigma_dps: r.sigma_dps,
                freq_hz: r.freq_hz,
                q: r.q,
                width_hz: r.freq_hz / r.q,
                ..p.clone()
            },
            None => p.clone(),
        }
    }
}

/// Narrowband random vibration: a resonance.
///
/// Method: the Welch spectrum (Hann segments of a power of two near a 32nd of the record, at least 256 samples
/// and 16 segments, 50% overlap; where no bump passes, again with segments twice as long), in ln P. A median background over a window of one octave around each bin (a
/// bump a fraction of an octave wide hardly moves it); the up to three largest local maxima of the excess over it
/// (smoothed over 5 bins) are candidate centres. Each is fitted by Levenberg-Marquardt in ln P over a window from
/// six half-widths below its centre to twelve above: a background quadratic in ln f plus the bump, the exact
/// spectrum of shared::sim's resonance (centre, quality factor, variance); twice, the window re-centred on the
/// first fit. The most significant bump counts when the fit lowers the chi-square of ln P over its window by
/// [`DELTA_CHI2`] against the background alone (in units of its own residual variance), its peak is at least half
/// the background there, it is wider than a line ([`MIN_WIDTH_BINS`]: a sinusoid is the sinusoid candidate's), its
/// Q is at least [`MIN_Q`] and five adjacent bins stand three standard deviations above the fitted background. The
/// standard errors are the least squares' (widened for the neighbouring bins' correlation). The base terms are
/// re-fitted on the OADEV less the resonance's own exact Allan variance (the base fit took its Allan bump for
/// white or angle noise), leaving out the points where the resonance makes up more than 80% of it. On a model
/// that already has an output bandwidth (a later step of the chain, or a backfitting round) the bump is fitted,
/// and its Allan variance taken off, through that low-pass, as the simulator applies it to the resonance: read
/// on the filtered record as it is, a resonance at 0.6 of the corner comes out with three quarters of its power
/// and is filtered once more in the simulation.
pub(super) fn resonance(d: &TrainingData) -> Option<EffectFit> {
    let n = d.rate_dps.len();
    let target = (n / 32).max(256);
    let seg = (1usize << (usize::BITS - 1 - target.leading_zeros())).min(1 << 16);
    // A bump narrower than the default segments resolve (the power of two below a 32nd of the record can leave a
    // Q of 10 at a few bins) is looked for again at twice their length, where the segments still number enough.
    let bump =
        most_significant_bump(d, seg).or_else(|| most_significant_bump(d, 2 * seg).filter(|_| 2 * seg <= 1 << 16))?;
    let sigma = bump.power.sqrt();
    let gyro = refit_without(d, &bump);
    let gyro = octavar_shared::sim::GyroSim {
        resonance: Some(ResonanceSim { sigma_dps: sigma, freq_hz: bump.freq_hz, q: bump.q }),
        ..gyro
    };
    Some(EffectFit {
        effect: Effect::Resonance,
        params: ResonanceParams {
            sigma_dps: sigma,
            freq_hz: bump.freq_hz,
            q: bump.q,
            width_hz: bump.freq_hz / bump.q,
            peak_ratio: bump.peak_ratio,
            sigma_se_dps: 0.5 * sigma * bump.se_ln[0],
            freq_se_hz: bump.freq_hz * bump.se_ln[1],
            q_se: bump.q * bump.se_ln[2],
            delta_chi2: bump.delta_chi2,
        }
        .into(),
        n_params: 3,
        gyro,
        channel: None,
        spread: None,
        cleaned: None,
    })
}

/// The most significant bump of the Welch spectrum of the training samples in segments of `seg` samples that
/// passes every test of [`resonance`]; `None` where there are too few segments or no bump passes.
fn most_significant_bump(d: &TrainingData, seg: usize) -> Option<Bump> {
    let x = d.rate_dps;
    let rate_hz = d.rate_hz;
    if x.len() < seg * (MIN_SEGMENTS / 2 + 1) {
        return None;
    }
    let (p, segments) = welch(x, d.gaps, rate_hz, seg);
    if segments < MIN_SEGMENTS {
        return None;
    }
    let df = rate_hz / seg as f64;
    let f: Vec<f64> = (0..p.len()).map(|k| k as f64 * df).collect();
    let ln_p: Vec<f64> = p.iter().map(|v| v.max(1e-300).ln()).collect();
    let (k_lo, k_hi) = (4, p.len() - 3);
    let bg = median_background(&ln_p, k_lo, k_hi);
    // The excess over the median background, smoothed over 5 bins; candidates at its largest local maxima.
    let ex: Vec<f64> = (0..p.len())
        .map(|k| {
            if k < k_lo + 2 || k + 2 > k_hi {
                f64::NEG_INFINITY
            } else {
                (k - 2..=k + 2).map(|j| ln_p[j] - bg[j]).sum::<f64>() / 5.0
            }
        })
        .collect();
    let mut peaks: Vec<usize> =
        (k_lo + 3..k_hi - 2).filter(|&k| ex[k] > 0.0 && ex[k] >= ex[k - 1] && ex[k] >= ex[k + 1]).collect();
    peaks.sort_by(|&a, &b| ex[b].total_cmp(&ex[a]));
    let mut chosen: Vec<usize> = Vec::new();
    for k in peaks {
        if chosen.iter().all(|&c| (k as f64 / c as f64).ln().abs() > 0.2) {
            chosen.push(k);
            if chosen.len() == CANDIDATES {
                break;
            }
        }
    }
    let bumps: Vec<Bump> = chosen
        .iter()
        .filter_map(|&k| {
            // Half-width: where the smoothed excess falls by ln 2 from its peak, each way.
            let drop = ex[k] - std::f64::consts::LN_2;
            let right = (k..k_hi - 2).find(|&j| ex[j] < drop).unwrap_or(k_hi - 2) - k;
            let left = k - (k_lo + 2..=k).rev().find(|&j| ex[j] < drop).unwrap_or(k_lo + 2);
            fit_bump(&f, &ln_p, (k_lo, k_hi), k, 0.5 * (left + right) as f64, rate_hz, d.base.bandwidth_hz)
        })
        .collect();
    bumps
        .into_iter()
        .filter(|b| {
            b.delta_chi2 >= DELTA_CHI2
                && b.peak_ratio >= MIN_PEAK_RATIO
                && b.freq_hz / b.q >= MIN_WIDTH_BINS * df
                && b.run_bins >= MIN_RUN_BINS
                && b.freq_hz < 0.49 * rate_hz
                && b.q >= MIN_Q
                && b.peak_ratio.is_finite()
        })
        .max_by(|a, b| a.delta_chi2.total_cmp(&b.delta_chi2))
}

/// The base terms re-fitted on the OADEV less the resonance's exact Allan variance, without the points where the
/// resonance makes up more than 80% of the Allan variance, and without a ramp where the base fit has none; the
/// base model itself where that fit fails. What the model already carries is taken off too ([`less_known`]): on a
/// coarse ADC lattice an earlier step read, the rounding's white noise is the channel's, and a re-fit that kept it
/// put it in N a second time (N 7.6e-3 where the lattice's step had left 6.3e-3, and the resonance's candidate
/// then widened the spectrum's gap it was to close). A Gauss-Markov process the model carries is fitted beside
/// the base terms instead ([`refit_beside_markov`]).
fn refit_without(d: &TrainingData, bump: &Bump) -> octavar_shared::sim::GyroSim {
    let rate_hz = d.rate_hz;
    let pts: Vec<_> = gapped_oadev_points(d.rate_dps, d.gaps, rate_hz)
        .into_iter()
        .filter_map(|mut p| {
            let own = bump.power
                * filtered_resonance_avar(bump.freq_hz, bump.q, d.base.bandwidth_hz, p.tau_s * rate_hz, rate_hz);
            (own < 0.8 * p.avar).then(|| {
                p.avar -= own;
                p
            })
        })
        .collect();
    if let Some(gyro) = d.base.gauss_markov.and_then(|g| refit_beside_markov(d, &pts, g)) {
        return gyro;
    }
    refit_base_terms(d.base, &less_known(&pts, d.base, d.base.bandwidth_hz, rate_hz, d.lattice_dps), rate_hz)
}

/// The base terms and the variance of the Gauss-Markov process `g` the model carries, re-fitted jointly on `pts`
/// (the OADEV less the resonance's own Allan variance), the process's time constant held; `None` where the fit
/// fails. Taken off at the variance its own step read, the process leaves at the taus it dominates a small
/// difference of large numbers that the base terms then follow: beside a process of 1.2 s read before a resonance
/// at 1.4 Hz (6.1 Hz samples), N came out 20% above what the process's step had read, B appeared from nothing, and
/// the resonance's candidate raised the spectrum's white level it was to leave alone.
fn refit_beside_markov(d: &TrainingData, pts: &[FitPoint], g: GaussMarkovSim) -> Option<GyroSim> {
    let (rate_hz, bw) = (d.rate_hz, d.base.bandwidth_hz);
    let known = GyroSim { gauss_markov: None, ..d.base.clone() };
    let pts = less_known_over(pts, &known, d.base, bw, rate_hz, d.lattice_dps);
    if pts.len() < 4 {
        return None;
    }
    let mut cols = base_columns(&pts, rate_hz, bw, d.base.q_deg > 0.0);
    if d.base.r_dps_per_s == 0.0 {
        cols[3].iter_mut().for_each(|v| *v = 0.0);
    }
    cols.push(pts.iter().map(|p| filtered_gm_avar(g.tau_s, bw, p.tau_s, rate_hz)).collect());
    let j = joint_fit_keeping(&pts, &cols, 1 << BASE_COLS)?;
    let variance = *j.theta.get(BASE_COLS)?;
    (variance > 0.0).then(|| GyroSim {
        gauss_markov: Some(GaussMarkovSim { sigma_dps: variance.sqrt(), ..g }),
        ..with_base_terms(d.base, &j.theta)
    })
}

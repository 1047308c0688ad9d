//! The four views in which a record is compared with its simulated ensemble, and their z-scores.
//!
//! A [`Plan`] is laid out once per part of the record (training, holdout) from the real samples: which taus, which
//! frequency bands, which lattice step, which temperature bands. [`Plan::measure`] then reduces any series of that
//! length (the real one, or each simulated member with the same gaps) to one number per point of each view, in a
//! domain where the ensemble spread is close to Gaussian:
//!
//! | view | points | value |
//! |------|--------|-------|
//! | `adev` | octave taus of the overlapping Allan deviation | ln OADEV |
//! | `psd` | log-spaced frequency bands (5 per decade) down to one cycle per part | ln of the one-sided PSD over the band's bins: Welch-averaged periodograms (Hann, 50% overlap, low bands through block-mean decimation by 8) down to a sixteenth of the part, the sine-multitaper estimate of the whole part, less its least-squares line, below |
//! | `distribution` | skewness, kurtosis, tail share, lattice share | moments; share beyond 5 robust sigmas (the rms winsorised at 4 sigmas of the interquartile range); share of first differences on the lattice step |
//! | `temperature` | octave bands of frequency from one cycle per part (the point's tau is 1/f) | atanh of the magnitude-squared coherence's root between the rate, less the model's own temperature response, and the temperature, block-averaged to at most 8192 points, over the band's bins and five sine tapers |
//!
//! The distribution view is about shape, not scale: the scale at tau0 is the Allan deviation's first point,
//! which carries the fit's model allowance; a scale point here, floored only by its sampling spread
//! (`sqrt(0.5 / n)`, a tenth of a percent on a long record), turned any 2% error of the fitted N into the worst
//! gap of the whole diagnosis. The distribution's points are taken on the local residual `x[i] - (x[i-1] + x[i+1]) / 2`, which removes drifts
//! (flicker, random walk, temperature) and keeps the sign of a one-sided spike; the lattice share is taken on the
//! first differences, which keep the ADC step and drop its offset. The lattice point exists only when the real
//! part is on a lattice (99% of its first differences on multiples of one step) coarse enough to matter (a step
//! of at least half the per-sample noise sd, where quantisation adds 2% or more to the white variance).
//!
//! The temperature view is a coherence, not a correlation at a searched lag: coherence takes any lag within a
//! band for free (a lag is a phase), it looks where the temperature moves rather than at block means that red
//! noise dominates, and the multitaper estimate weighs the whole part evenly. On the 20 withheld temperature cases
//! (the same fitted couplings) the view's held-out gap before a fix is a median 1.3 times the correlation's
//! (0.6-1.8 times), the gap after a fix has a median of 0.90, and the lowest held-out shrink went from 0.48 to 0.73.
//! Its points are independent bands, not one correlation repeated at every block length.
//!
//! The PSD view reaches one cycle per part, four octaves beyond the Welch levels (which need four segments and
//! four bins above DC, so they stop at a sixteenth of the part) and two beyond the last Allan point: a
//! sinusoid of eight cycles per part (the withheld cases' slowest) is a line there, seen at its full power,
//! where the Allan deviation sees only the hump that the base fit took as flicker or random walk, and a
//! Gauss-Markov plateau parts from the random walk the base fit gave its hump. The multitaper estimate (five
//! sine tapers on the block means of the whole part, as the temperature view) keeps the leakage of strong low
//! frequencies local; its values are in (deg/s)^2/Hz like the Welch levels', so the view is one spectrum.
//! The block means are detrended first (their least-squares line removed, as is usual before estimating a red
//! spectrum): a random walk's or a ramp's line over the part is no stationary noise, and through the
//! antisymmetric tapers it lands in the lowest bands. Centred only, the lowest three bands of a random walk
//! (40 draws, white noise beside it) read 0.7-1.0 higher in ln and scattered by 0.71-0.84; detrended, by
//! 0.51-0.73. A Gauss-Markov plateau or a slow sinusoid stands out further against the base fit's random walk
//! (withheld sinusoid seed 11 went from a held-out shrink of 0.69 to a pass).
//!
//! [`compare`] turns the real values and the ensemble's into z-scores, `z = (real - mean) / sd`, with `sd` the
//! ensemble's standard deviation floored by the statistical spread the point has anyway (from the EDF for ADEV,
//! the number of averaged periodogram bins for PSD, the sample count for the moments) and widened in quadrature by
//! a model-error allowance (see [`ViewKind::model_floor`]), so a tight ensemble cannot make z explode.

use std::sync::Arc;

use rayon::prelude::*;
use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};
use serde::Serialize;

use crate::stats::{analyze_series, DataKind, Options, Series, Statistic, TauSpec};

/// A view of the comparison.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ViewKind {
    /// Overlapping Allan deviation over tau.
    Adev,
    /// Power spectral density over frequency (reported as 1/f, s).
    Psd,
    /// The distribution of the sample values.
    Distribution,
    /// Correlation with the temperature channel.
    Temperature,
}

impl ViewKind {
    /// Every view, in report order.
    pub const ALL: [ViewKind; 4] = [ViewKind::Adev, ViewKind::Psd, ViewKind::Distribution, ViewKind::Temperature];

    /// The name in reports and JSON.
    pub fn name(self) -> &'static str {
        match self {
            ViewKind::Adev => "adev",
            ViewKind::Psd => "psd",
            ViewKind::Distribution => "distribution",
            ViewKind::Temperature => "temperature",
        }
    }

    /// The model-error allowance added in quadrature to every point's sd: the base fit allows 3% in Allan
    /// variance (`FitOptions::model_error`), which is 0.015 in ln ADEV; the PSD, which the fit never saw, gets
    /// twice that; moments and shares get none (their floors are absolute, see [`Plan::new`]).
    pub fn model_floor(self) -> f64 {
        match self {
            ViewKind::Adev => 0.015,
            ViewKind::Psd => 0.03,
            ViewKind::Distribution | ViewKind::Temperature => 0.0,
        }
    }
}

/// One point of a view: what it is and where it lies in tau.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PointInfo {
    /// Short name (`tau`, `band`, `kurtosis`, ...).
    pub label: &'static str,
    /// Representative tau, s (1/f for a PSD or temperature band, tau0 for the distribution).
    pub tau_s: f64,
    /// Lower tau edge, s.
    pub tau_lo_s: f64,
    /// Upper tau edge, s.
    pub tau_hi_s: f64,
    /// Smallest sd the point's z may use (its own statistical spread).
    pub floor_sd: f64,
}

/// The layout of a Welch level: block-mean decimation factor, segment length and its FFT.
#[derive(Clone)]
struct Level {
    decim: usize,
    seg: usize,
    fft: Arc<dyn Fft<f64>>,
    window: Vec<f64>,
}

#[derive(Clone, Debug)]
struct PsdBand {
    level: usize,
    bin_lo: usize,
    bin_hi: usize,
}

/// What to measure on a part of the record; built from the real samples, applied to every series of that part.
#[derive(Clone)]
pub struct Plan {
    fs_hz: f64,
    n: usize,
    adev_ms: Vec<u64>,
    levels: Vec<Level>,
    bands: Vec<PsdBand>,
    lattice_step: Option<f64>,
    /// Block lengths (samples) of the Allan-difference kurtosis points.
    kurt_ms: Vec<usize>,
    /// The whole-part multitaper layout (block means, sine tapers, FFT) of the PSD's long periods and the
    /// temperature view.
    taper: Option<Multitaper>,
    /// FFT bin ranges (inclusive) of the PSD bands below the Welch levels' reach, in increasing tau.
    psd_taper_bands: Vec<(usize, usize)>,
    /// FFT bin ranges (inclusive) of the temperature view's bands `[2^i, 2^(i+1))` cycles per part (empty
    /// without a temperature).
    temp_bands: Vec<(usize, usize)>,
    /// The points of each view, in [`ViewKind::ALL`] order (an empty list: the view does not apply).
    pub points: [Vec<PointInfo>; 4],
}

/// One series reduced to its view values (NaN where a point could not be computed), in [`ViewKind::ALL`] order.
#[derive(Clone, Debug, PartialEq)]
pub struct Measure {
    /// Values per view, aligned with [`Plan::points`].
    pub values: [Vec<f64>; 4],
    /// The OADEV itself (deviation, not its log) at the plan's taus, for plots.
    pub adev: Vec<f64>,
}

/// Points per decade of the PSD bands.
const BANDS_PER_DECADE: f64 = 5.0;
/// Longest Welch segment.
const MAX_SEG: usize = 1024;
/// Shortest Welch segment.
const MIN_SEG: usize = 32;
/// Decimation factor between Welch levels.
const DECIM: usize = 8;
/// Tail threshold of the distribution view, robust sigmas.
pub const TAIL_SIGMA: f64 = 5.0;
/// Fewest Allan differences a kurtosis point needs.
const MIN_DIFFERENCES: usize = 64;
/// Clip of the winsorised scale, in sigmas from the interquartile range.
const WINSOR_SIGMA: f64 = 4.0;

impl Plan {
    /// Lay out the views for `real` (deg/s, NaN gaps) sampled at `fs_hz`, with the temperature if there is one.
    pub fn new(real: &[f64], temp_c: Option<&[f64]>, fs_hz: f64) -> Plan {
        let n = real.len();
        let tau0 = 1.0 / fs_hz;
        // ADEV: octave taus with the EDF of the real curve as the floor.
        let mut adev_ms = Vec::new();
        let mut adev_pts = Vec::new();
        if let Ok(series) = Series::new(real, DataKind::Frequency, tau0) {
            let opts = Options { intervals: true, ..Default::default() };
            if let Ok(rows) = analyze_series(&series, Statistic::Oadev, &TauSpec::Octave, &opts) {
                for r in rows.iter().filter(|r| r.dev > 0.0 && r.n >= 2) {
                    let edf = if r.edf.is_finite() && r.edf > 0.0 { r.edf } else { r.n as f64 / 2.0 };
                    adev_ms.push(r.m);
                    adev_pts.push(PointInfo {
                        label: "tau",
                        tau_s: r.tau_s,
                        tau_lo_s: r.tau_s / std::f64::consts::SQRT_2,
                        tau_hi_s: r.tau_s * std::f64::consts::SQRT_2,
                        floor_sd: (0.5 / edf).sqrt(),
                    });
                }
            }
        }
        // PSD: levels of block-mean decimation while a few segments fit.
        let mut planner = FftPlanner::new();
        let mut levels = Vec::new();
        let mut decim = 1usize;
        loop {
            let nk = n / decim;
            let mut seg = MAX_SEG;
            while seg > MIN_SEG && seg * 4 > nk {
                seg /= 2;
            }
            if seg * 4 > nk {
                break;
            }
            let window: Vec<f64> =
                (0..seg).map(|i| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / seg as f64).cos()).collect();
            levels.push(Level { decim, seg, fft: planner.plan_fft_forward(seg), window });
            decim *= DECIM;
        }
        let mut bands = Vec::new();
        let mut psd_pts = Vec::new();
        // The ratio of a band's edges, and the top of the next band down.
        let step = 10f64.powf(1.0 / BANDS_PER_DECADE);
        let mut f_hi = fs_hz / 2.0;
        if !levels.is_empty() {
            loop {
                let f_lo = f_hi / step;
                // The finest level that puts at least 4 bins between DC and the band.
                let found = levels.iter().enumerate().find_map(|(k, l)| {
                    let fs_k = fs_hz / l.decim as f64;
                    let df = fs_k / l.seg as f64;
                    let lo = (f_lo / df).ceil() as usize;
                    let hi = ((f_hi / df).floor() as usize).min(l.seg / 2);
                    let hi = if hi as f64 * df >= f_hi && hi > lo { hi - 1 } else { hi };
                    (lo >= 4 && hi >= lo).then_some((k, lo, hi))
                });
                let Some((k, lo, hi)) = found else { break };
                let l = &levels[k];
                let segs = (n / l.decim).saturating_sub(l.seg) / (l.seg / 2) + 1;
                let bins = (hi - lo + 1) as f64;
                psd_pts.push(PointInfo {
                    label: "band",
                    tau_s: 1.0 / (f_lo * f_hi).sqrt(),
                    tau_lo_s: 1.0 / f_hi,
                    tau_hi_s: 1.0 / f_lo,
                    floor_sd: (1.0 / (bins * segs as f64 * 0.9)).sqrt(),
                });
                bands.push(PsdBand { level: k, bin_lo: lo, bin_hi: hi });
                f_hi = f_lo;
            }
        }
        // Below the Welch levels' reach (a sixteenth of the part): the same ladder of bands down to one cycle
        // per part, from the multitaper estimate on the whole part.
        let taper = Multitaper::new(n, &mut planner);
        let mut psd_taper_bands = Vec::new();
        if let (Some(mt), false) = (&taper, bands.is_empty()) {
            let part_s = mt.part_s(tau0);
            loop {
                let (mut u0, u1) = (f_hi / step * part_s, f_hi * part_s);
                if u0 < 1.0 {
                    // The last band reaches down to one cycle per part when a third of a band is left.
                    if u1 < step.powf(1.0 / 3.0) {
                        break;
                    }
                    u0 = 1.0;
                }
                if let Some((k0, k1)) = mt.bins(u0, u1) {
                    psd_pts.push(PointInfo {
                        label: "band",
                        tau_s: part_s / (u0 * u1).sqrt(),
                        tau_lo_s: part_s / u1,
                        tau_hi_s: part_s / u0,
                        floor_sd: mt.floor_sd(u1 - u0),
                    });
                    psd_taper_bands.push((k0, k1));
                }
                if u0 <= 1.0 {
                    break;
                }
                f_hi /= step;
            }
        }
        // Distribution.
        let valid = real.iter().filter(|v| v.is_finite()).count().max(1) as f64;
        let dist_pt = |label: &'static str, floor_sd: f64| PointInfo {
            label,
            tau_s: tau0,
            tau_lo_s: tau0,
            tau_hi_s: tau0,
            floor_sd,
        };
        let mut dist_pts = vec![
            dist_pt("skewness", 0.02 + (6.0 / valid).sqrt()),
            dist_pt("kurtosis", 0.05 + (24.0 / valid).sqrt()),
            dist_pt("tail_share", (3.0 / valid).sqrt() / valid.sqrt()),
        ];
        let lattice_step = lattice_of(real);
        if lattice_step.is_some() {
            dist_pts.push(dist_pt("lattice_share", 0.02));
        }
        // The kurtosis of the Allan differences at octave taus from 2 tau0, while there are enough of them.
        let mut kurt_ms = Vec::new();
        let mut m = 2usize;
        while n / m > MIN_DIFFERENCES {
            let tau = m as f64 * tau0;
            let k = (n / m - 1) as f64;
            dist_pts.push(PointInfo {
                label: "difference_kurtosis",
                tau_s: tau,
                tau_lo_s: tau / std::f64::consts::SQRT_2,
                tau_hi_s: tau * std::f64::consts::SQRT_2,
                floor_sd: 0.05 + (24.0 / k).sqrt(),
            });
            kurt_ms.push(m);
            m *= 2;
        }
        // Temperature: octave bands of frequency, from one cycle per part up.
        let mut temp_bands = Vec::new();
        let mut temp_pts = Vec::new();
        if let (Some(t), Some(mt)) = (temp_c, &taper) {
            if t.iter().any(|v| v.is_finite()) && t.len() == n {
                let part_s = mt.part_s(tau0);
                let mut u = 1.0f64;
                while u < mt.nb as f64 / 4.0 {
                    if let Some((k0, k1)) = mt.bins(u, 2.0 * u) {
                        let per_cycle = mt.nb as f64 / mt.nfft as f64;
                        let (u0, u1) = (k0 as f64 * per_cycle, (k1 + 1) as f64 * per_cycle);
                        let dof = (k1 + 1 - k0) as f64 * per_cycle * WHOLE_PART_TAPERS as f64;
                        temp_pts.push(PointInfo {
                            label: "band",
                            tau_s: part_s / (u0 * u1).sqrt(),
                            tau_lo_s: part_s / u1,
                            tau_hi_s: part_s / u0,
                            floor_sd: 0.4 / dof.sqrt(),
                        });
                        temp_bands.push((k0, k1));
                    }
                    u *= 2.0;
                }
            }
        }
        Plan {
            fs_hz,
            n,
            adev_ms,
            levels,
            bands,
            lattice_step,
            kurt_ms,
            taper,
            psd_taper_bands,
            temp_bands,
            points: [adev_pts, psd_pts, dist_pts, temp_pts],
        }
    }

    /// Number of samples this plan is for.
    pub fn len(&self) -> usize {
        self.n
    }

    /// True for a plan of no samples.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The lattice step of the real part, deg/s, when it has a visible one.
    pub fn lattice_step(&self) -> Option<f64> {
        self.lattice_step
    }

    /// Reduce a series of this part (same length, gaps where the real one has them) to its view values.
    /// `parallel`: let the Allan deviation use rayon (off when the caller already runs members in parallel).
    pub fn measure(&self, x: &[f64], temp_c: Option<&[f64]>, parallel: bool) -> Measure {
        self.measure_explained(x, temp_c, None, parallel)
    }

    /// As [`Plan::measure`], with the temperature view taken on `x` less `explained` (the response to the
    /// temperature that the model under test carries): the view then asks whether the series still follows the
    /// temperature once the model's coupling is taken out. For a model that has the coupling right, real and
    /// simulated residual coherences both scatter about the level noise alone gives; a coherence near one,
    /// compared as such, has a spread so small that a 2% difference in unexplained noise between real and model
    /// reads as a large gap.
    pub fn measure_explained(
        &self,
        x: &[f64],
        temp_c: Option<&[f64]>,
        explained: Option<&[f64]>,
        parallel: bool,
    ) -> Measure {
        let adev = self.adev(x, parallel);
        let ln_adev = adev.iter().map(|v| if *v > 0.0 { v.ln() } else { f64::NAN }).collect();
        let psd = self.psd(x);
        let dist = self.distribution(x);
        let temp = self.temperature_view(x, temp_c, explained);
        Measure { values: [ln_adev, psd, dist, temp], adev }
    }

    /// `measured` (this plan's [`Measure`] of `x`) with only its temperature view taken again, on `x` less
    /// `explained`: what [`Plan::measure_explained`] gives, without measuring the other views a second time.
    pub fn with_explained(&self, measured: &Measure, x: &[f64], temp_c: Option<&[f64]>, explained: &[f64]) -> Measure {
        let mut m = measured.clone();
        m.values[ViewKind::Temperature as usize] = self.temperature_view(x, temp_c, Some(explained));
        m
    }

    /// The temperature view's values of `x` (less `explained`, when given); NaN without a temperature.
    fn temperature_view(&self, x: &[f64], temp_c: Option<&[f64]>, explained: Option<&[f64]>) -> Vec<f64> {
        match temp_c {
            Some(t) if !self.temp_bands.is_empty() => match explained {
                Some(e) => {
                    let residual: Vec<f64> = x.iter().zip(e).map(|(v, c)| v - c).collect();
                    self.temperature(&residual, t)
                }
                None => self.temperature(x, t),
            },
            _ => vec![f64::NAN; self.temp_bands.len()],
        }
    }

    fn adev(&self, x: &[f64], parallel: bool) -> Vec<f64> {
        let mut out = vec![f64::NAN; self.adev_ms.len()];
        let Ok(series) = Series::new(x, DataKind::Frequency, 1.0 / self.fs_hz) else { return out };
        let opts = Options { intervals: false, parallel, ..Default::default() };
        if let Ok(rows) = analyze_series(&series, Statistic::Oadev, &TauSpec::Octave, &opts) {
            for r in rows {
                if let Ok(i) = self.adev_ms.binary_search(&r.m) {
                    out[i] = r.dev;
                }
            }
        }
        out
    }

    fn psd(&self, x: &[f64]) -> Vec<f64> {
        let mut spectra: Vec<Option<Vec<f64>>> = Vec::with_capacity(self.levels.len());
        for (k, l) in self.levels.iter().enumerate() {
            if !self.bands.iter().any(|b| b.level == k) {
                spectra.push(None);
                continue;
            }
            let dec: Vec<f64>;
            let data: &[f64] = if l.decim == 1 {
                x
            } else {
                dec = x.chunks_exact(l.decim).map(|c| c.iter().sum::<f64>() / l.decim as f64).collect();
                &dec
            };
            spectra.push(welch(data, l, self.fs_hz / l.decim as f64));
        }
        let mut out: Vec<f64> = self
            .bands
            .iter()
            .map(|b| match &spectra[b.level] {
                Some(s) => {
                    let m = s[b.bin_lo..=b.bin_hi].iter().sum::<f64>() / (b.bin_hi - b.bin_lo + 1) as f64;
                    if m > 0.0 {
                        m.ln()
                    } else {
                        f64::NAN
                    }
                }
                None => f64::NAN,
            })
            .collect();
        out.extend(self.psd_long(x));
        out
    }

    /// The PSD bands below the Welch levels: the sine-multitaper estimate of the whole part's centred block
    /// means, averaged over each band's bins and the tapers (one-sided, (deg/s)^2/Hz, as the Welch levels).
    fn psd_long(&self, x: &[f64]) -> Vec<f64> {
        let bands = &self.psd_taper_bands;
        let nan = vec![f64::NAN; bands.len()];
        let Some(mt) = self.taper.as_ref().filter(|_| !bands.is_empty()) else { return nan };
        let mut rate = block_means(x, mt.decim);
        rate.truncate(mt.nb);
        let valid: Vec<bool> = rate.iter().map(|r| r.is_finite()).collect();
        let Some(rate) = detrended(&rate, &valid) else { return nan };
        let mut power = vec![0.0; bands.len()];
        let mut buf = vec![Complex::new(0.0, 0.0); mt.nfft];
        let mut scratch = vec![Complex::new(0.0, 0.0); mt.fft.get_inplace_scratch_len()];
        for w in &mt.tapers {
            mt.transform(&rate, w, &mut buf, &mut scratch);
            for (p, &(k0, k1)) in power.iter_mut().zip(bands) {
                *p += buf[k0..=k1].iter().map(|c| c.norm_sqr()).sum::<f64>();
            }
        }
        power
            .iter()
            .zip(bands)
            .map(|(p, &(k0, k1))| {
                let fs_blocks = self.fs_hz / mt.decim as f64;
                let mean = 2.0 * p / ((k1 + 1 - k0) * mt.tapers.len()) as f64 / fs_blocks;
                if mean > 0.0 {
                    mean.ln()
                } else {
                    f64::NAN
                }
            })
            .collect()
    }

    fn distribution(&self, x: &[f64]) -> Vec<f64> {
        let mut r: Vec<f64> = x.windows(3).map(|w| w[1] - 0.5 * (w[0] + w[2])).filter(|v| v.is_finite()).collect();
        let k = if self.lattice_step.is_some() { 4 } else { 3 } + self.kurt_ms.len();
        if r.len() < 16 {
            return vec![f64::NAN; k];
        }
        let n = r.len() as f64;
        let mean = r.iter().sum::<f64>() / n;
        let (mut m2, mut m3, mut m4) = (0.0, 0.0, 0.0);
        for &v in &r {
            let d = v - mean;
            let d2 = d * d;
            m2 += d2;
            m3 += d2 * d;
            m4 += d2 * d2;
        }
        let (m2, m3, m4) = (m2 / n, m3 / n, m4 / n);
        let skew = if m2 > 0.0 { m3 / m2.powf(1.5) } else { f64::NAN };
        let kurt = if m2 > 0.0 { m4 / (m2 * m2) - 3.0 } else { f64::NAN };
        let med = median(&mut r);
        let iqr_sigma = (quantile(&mut r, 0.75) - quantile(&mut r, 0.25)) / 1.349;
        for v in r.iter_mut() {
            *v = (*v - med).abs();
        }
        // Winsorised at 4 IQR sigmas: outliers count at most 4 sigma each, and a lattice finer than the noise,
        // which biases the MAD and the IQR by a share of its step, moves only the clip point.
        let clip = WINSOR_SIGMA * iqr_sigma;
        let scale = (r.iter().map(|&v| v.min(clip) * v.min(clip)).sum::<f64>() / n).sqrt();
        let tail = if scale > 0.0 {
            r.iter().filter(|&&v| v > TAIL_SIGMA * scale).count() as f64 / n
        } else {
            // A lattice so coarse that most residuals are zero: the share of non-zero residuals.
            r.iter().filter(|&&v| v > 0.0).count() as f64 / n
        };
        let mut out = vec![skew, kurt, tail];
        if let Some(q) = self.lattice_step {
            out.push(lattice_share(x, q));
        }
        out.extend(difference_kurtosis(x, &self.kurt_ms));
        out
    }

    fn temperature(&self, x: &[f64], t: &[f64]) -> Vec<f64> {
        let bands = &self.temp_bands;
        let nan = vec![f64::NAN; bands.len()];
        let Some(l) = &self.taper else { return nan };
        let mut rate = block_means(x, l.decim);
        let mut temp = block_means(t, l.decim);
        rate.truncate(l.nb);
        temp.truncate(l.nb);
        // A block missing in either is left out of both (zero after the mean is removed).
        let valid: Vec<bool> = rate.iter().zip(&temp).map(|(r, t)| r.is_finite() && t.is_finite()).collect();
        let (Some(rate), Some(temp)) = (centred(&rate, &valid), centred(&temp, &valid)) else { return nan };
        let mut sxy = vec![Complex::new(0.0, 0.0); bands.len()];
        let mut sxx = vec![0.0; bands.len()];
        let mut syy = vec![0.0; bands.len()];
        let mut bx = vec![Complex::new(0.0, 0.0); l.nfft];
        let mut by = vec![Complex::new(0.0, 0.0); l.nfft];
        let mut scratch = vec![Complex::new(0.0, 0.0); l.fft.get_inplace_scratch_len()];
        for w in &l.tapers {
            l.transform(&temp, w, &mut bx, &mut scratch);
            l.transform(&rate, w, &mut by, &mut scratch);
            for (b, &(k0, k1)) in bands.iter().enumerate() {
                for k in k0..=k1 {
                    sxy[b] += bx[k].conj() * by[k];
                    sxx[b] += bx[k].norm_sqr();
                    syy[b] += by[k].norm_sqr();
                }
            }
        }
        (0..bands.len())
            .map(|b| {
                if sxx[b] > 0.0 && syy[b] > 0.0 {
                    let c = (sxy[b].norm_sqr() / (sxx[b] * syy[b])).sqrt();
                    c.min(1.0 - 1e-12).atanh()
                } else {
                    f64::NAN
                }
            })
            .collect()
    }
}

/// `v` less the mean of its valid entries, with the invalid ones set to zero; `None` when fewer than half are
/// valid.
fn centred(v: &[f64], valid: &[bool]) -> Option<Vec<f64>> {
    let count = valid.iter().filter(|ok| **ok).count();
    if count * 2 < v.len() || count == 0 {
        return None;
    }
    let m = v.iter().zip(valid).filter(|(_, ok)| **ok).map(|(x, _)| x).sum::<f64>() / count as f64;
    Some(v.iter().zip(valid).map(|(x, ok)| if *ok { x - m } else { 0.0 }).collect())
}

/// `v` less its least-squares line over the valid points (invalid ones set to 0), as [`centred`].
fn detrended(v: &[f64], valid: &[bool]) -> Option<Vec<f64>> {
    let c = centred(v, valid)?;
    let pts = || c.iter().zip(valid).enumerate().filter(|(_, (_, ok))| **ok).map(|(i, (x, _))| (i as f64, *x));
    let n = pts().count() as f64;
    let ti = pts().map(|(t, _)| t).sum::<f64>() / n;
    let (sxy, sxx) = pts().fold((0.0, 0.0), |(a, b), (t, x)| (a + (t - ti) * x, b + (t - ti) * (t - ti)));
    let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    Some(
        c.iter()
            .zip(valid)
            .enumerate()
            .map(|(i, (x, ok))| if *ok { x - slope * (i as f64 - ti) } else { 0.0 })
            .collect(),
    )
}

/// Sine tapers of the whole-part multitaper estimates (the temperature view's coherence, the PSD's long
/// periods): five, so that a band holds at least ten degrees of freedom where it is one cycle per part wide.
pub(crate) const WHOLE_PART_TAPERS: usize = 5;
/// The whole-part multitaper estimates work on block means, at most this many (they look at periods from a
/// sixteenth of the part to the whole part).
const WHOLE_PART_BLOCKS: usize = 8192;

/// The whole-part multitaper layout: block-mean decimation, sine tapers and the FFT of the zero-padded blocks.
#[derive(Clone)]
struct Multitaper {
    decim: usize,
    nb: usize,
    nfft: usize,
    fft: Arc<dyn Fft<f64>>,
    tapers: Vec<Vec<f64>>,
}

impl Multitaper {
    fn new(n: usize, planner: &mut FftPlanner<f64>) -> Option<Multitaper> {
        let decim = (n / WHOLE_PART_BLOCKS).max(1);
        let nb = n / decim;
        if nb < 64 {
            return None;
        }
        let nfft = nb.next_power_of_two();
        Some(Multitaper {
            decim,
            nb,
            nfft,
            fft: planner.plan_fft_forward(nfft),
            tapers: sine_tapers(nb, WHOLE_PART_TAPERS),
        })
    }

    /// The length of the part the blocks cover, s.
    fn part_s(&self, tau0: f64) -> f64 {
        (self.nb * self.decim) as f64 * tau0
    }

    /// The FFT bins (inclusive) whose frequency lies in `[u0, u1)` cycles per part, up to Nyquist.
    fn bins(&self, u0: f64, u1: f64) -> Option<(usize, usize)> {
        let per_cycle = self.nfft as f64 / self.nb as f64;
        let k0 = (u0 * per_cycle).ceil() as usize;
        let k1 = ((u1 * per_cycle).ceil() as usize).saturating_sub(1).min(self.nfft / 2);
        (k1 >= k0).then_some((k0, k1))
    }

    /// The smallest sd of the ln of a band `width` cycles per part wide: the tapers' estimates are independent
    /// about every `tapers + 1` cycles, each with `2 tapers` degrees of freedom.
    fn floor_sd(&self, width: f64) -> f64 {
        let k = self.tapers.len() as f64;
        (1.0 / (0.9 * k * (1.0 + width / (k + 1.0)))).sqrt()
    }

    /// The FFT of `x` (the centred blocks) times the taper `w`, into `buf`.
    fn transform(&self, x: &[f64], w: &[f64], buf: &mut [Complex<f64>], scratch: &mut [Complex<f64>]) {
        buf.fill(Complex::new(0.0, 0.0));
        for ((b, &v), &wi) in buf.iter_mut().zip(x).zip(w) {
            *b = Complex::new(v * wi, 0.0);
        }
        self.fft.process_with_scratch(buf, scratch);
    }
}

/// The first `k` orthonormal sine tapers of length `n` (Riedel and Sidorenko, 1995): together they weigh a
/// record nearly uniformly, and each keeps leakage from strong low frequencies (flicker, random walk) local.
pub(crate) fn sine_tapers(n: usize, k: usize) -> Vec<Vec<f64>> {
    let norm = (2.0 / (n as f64 + 1.0)).sqrt();
    (1..=k)
        .map(|j| {
            let a = std::f64::consts::PI * j as f64 / (n as f64 + 1.0);
            (0..n).map(|i| norm * (a * (i as f64 + 1.0)).sin()).collect()
        })
        .collect()
}

/// Welch's averaged periodogram of one level whose samples come at `fs_hz` (one-sided, (deg/s)^2/Hz), `None`
/// without a complete segment free of gaps.
fn welch(data: &[f64], l: &Level, fs_hz: f64) -> Option<Vec<f64>> {
    let seg = l.seg;
    let hop = seg / 2;
    if data.len() < seg {
        return None;
    }
    let mut acc = vec![0.0f64; seg / 2 + 1];
    let mut buf = vec![Complex::new(0.0, 0.0); seg];
    let mut scratch = vec![Complex::new(0.0, 0.0); l.fft.get_inplace_scratch_len()];
    let mut count = 0usize;
    let mut start = 0usize;
    while start + seg <= data.len() {
        let s = &data[start..start + seg];
        start += hop;
        if s.iter().any(|v| !v.is_finite()) {
            continue;
        }
        let mean = s.iter().sum::<f64>() / seg as f64;
        for ((b, &v), &w) in buf.iter_mut().zip(s).zip(&l.window) {
            *b = Complex::new((v - mean) * w, 0.0);
        }
        l.fft.process_with_scratch(&mut buf, &mut scratch);
        for (a, c) in acc.iter_mut().zip(&buf) {
            *a += c.norm_sqr();
        }
        count += 1;
    }
    if count == 0 {
        return None;
    }
    let w2: f64 = l.window.iter().map(|w| w * w).sum();
    let norm = 2.0 / (count as f64 * w2 * fs_hz);
    Some(acc.into_iter().map(|a| a * norm).collect())
}

/// Block means of `b` samples (NaN for a block with a gap).
/// The excess kurtosis of the differences of adjacent non-overlapping block means (the Allan differences) for
/// each block length of `ms` (increasing octaves from 2); NaN where fewer than [`MIN_DIFFERENCES`] are free of
/// gaps. Block means at 2m are the pairwise means at m, so all lengths cost O(n).
fn difference_kurtosis(x: &[f64], ms: &[usize]) -> Vec<f64> {
    let mut out = Vec::with_capacity(ms.len());
    let mut means: Vec<f64> = x.to_vec();
    let mut m = 1usize;
    for &target in ms {
        while m < target {
            means = means.chunks_exact(2).map(|c| 0.5 * (c[0] + c[1])).collect();
            m *= 2;
        }
        let d: Vec<f64> = means.windows(2).map(|w| w[1] - w[0]).filter(|v| v.is_finite()).collect();
        if d.len() < MIN_DIFFERENCES {
            out.push(f64::NAN);
            continue;
        }
        let n = d.len() as f64;
        let mean = d.iter().sum::<f64>() / n;
        let (mut m2, mut m4) = (0.0, 0.0);
        for v in &d {
            let e = (v - mean) * (v - mean);
            m2 += e;
            m4 += e * e;
        }
        let (m2, m4) = (m2 / n, m4 / n);
        out.push(if m2 > 0.0 { m4 / (m2 * m2) - 3.0 } else { f64::NAN });
    }
    out
}

/// Block means of `x` over blocks of `m` samples (the last partial block dropped); the estimators use it too.
pub(crate) fn block_means(x: &[f64], m: usize) -> Vec<f64> {
    let m = m.max(1);
    x.chunks_exact(m).map(|c| c.iter().sum::<f64>() / m as f64).collect()
}

/// The `p` quantile (nearest rank) of `v`, reordering it.
fn quantile(v: &mut [f64], p: f64) -> f64 {
    let k = ((v.len() - 1) as f64 * p).round() as usize;
    let (_, m, _) = v.select_nth_unstable_by(k, f64::total_cmp);
    *m
}

fn median(v: &mut [f64]) -> f64 {
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, f64::total_cmp);
    *m
}

/// The lattice step of a record: the smallest non-zero first difference, kept when 99% of the differences are
/// multiples of it and it is at least half the per-sample noise sd (robust scale of the differences / sqrt 2).
pub fn lattice_of(x: &[f64]) -> Option<f64> {
    let mut d: Vec<f64> = x.windows(2).map(|w| (w[1] - w[0]).abs()).filter(|v| v.is_finite()).collect();
    if d.len() < 16 {
        return None;
    }
    let mut tmp = d.clone();
    let scale = 1.4826 * median(&mut tmp);
    let big = d.iter().copied().fold(0.0f64, f64::max);
    if big <= 0.0 {
        return None;
    }
    let tiny = 1e-9 * big;
    d.retain(|&v| v > tiny);
    let q = d.iter().copied().fold(f64::INFINITY, f64::min);
    // Visible: the step is at least half the per-sample noise sd (the differences' scale / sqrt 2), where its
    // q^2/12 adds at least 2% to the white variance; a finer lattice changes nothing the other views could see.
    if !q.is_finite() || (scale > 0.0 && q < 0.5 * scale / std::f64::consts::SQRT_2) {
        return None;
    }
    (lattice_share(x, q) >= 0.99).then_some(q)
}

/// Share of the first differences of `x` that are whole multiples of `q` (within 1% of `q`).
pub fn lattice_share(x: &[f64], q: f64) -> f64 {
    let (mut on, mut n) = (0usize, 0usize);
    for w in x.windows(2) {
        let d = w[1] - w[0];
        if d.is_finite() {
            n += 1;
            let k = d / q;
            if (k - k.round()).abs() < 0.01 {
                on += 1;
            }
        }
    }
    if n == 0 {
        f64::NAN
    } else {
        on as f64 / n as f64
    }
}

/// One point's comparison.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PointZ {
    /// What the point is and where.
    #[serde(flatten)]
    pub info: PointInfo,
    /// The real value (in the view's domain: ln, atanh, or plain).
    pub real: f64,
    /// The ensemble mean.
    pub sim_mean: f64,
    /// The sd used (ensemble sd, floored, with the model allowance).
    pub sd: f64,
    /// (real - mean) / sd.
    pub z: f64,
}

/// One view's comparison: its points and the RMS of their z.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ViewGap {
    /// Which view.
    pub view: ViewKind,
    /// Its points, in increasing tau (the distribution's in their fixed order).
    pub points: Vec<PointZ>,
    /// RMS of the z-scores (0 without points).
    pub rms: f64,
    /// The view's gap: the largest RMS z over a window of its points one decade wide in tau
    /// ([`super::rank::worst_window`]).
    pub gap: f64,
    /// That window: the index range of its points.
    pub window: (usize, usize),
}

/// Compare the real measure with the ensemble's, view by view (views without points are left out).
pub fn compare(plan: &Plan, real: &Measure, sims: &[Measure]) -> Vec<ViewGap> {
    let mut out = Vec::new();
    for (v, kind) in ViewKind::ALL.iter().enumerate() {
        let mut points = Vec::new();
        for (i, info) in plan.points[v].iter().enumerate() {
            let r = real.values[v][i];
            let s: Vec<f64> = sims.iter().map(|m| m.values[v][i]).filter(|x| x.is_finite()).collect();
            if !r.is_finite() || s.len() < 3 {
                continue;
            }
            let n = s.len() as f64;
            let mean = s.iter().sum::<f64>() / n;
            let var = s.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0);
            let sd0 = var.sqrt().max(info.floor_sd);
            let m = kind.model_floor();
            let sd = (sd0 * sd0 + m * m).sqrt();
            let z = if sd > 0.0 { (r - mean) / sd } else { 0.0 };
            points.push(PointZ { info: info.clone(), real: r, sim_mean: mean, sd, z });
        }
        if points.is_empty() {
            continue;
        }
        // Stable: the distribution's points at tau0 keep their order.
        points.sort_by(|a, b| a.info.tau_s.total_cmp(&b.info.tau_s));
        let rms = (points.iter().map(|p| p.z * p.z).sum::<f64>() / points.len() as f64).sqrt();
        let (a, b, gap) = super::rank::worst_window(&points);
        out.push(ViewGap { view: *kind, points, rms, gap, window: (a, b) });
    }
    out
}

/// Measure many series in parallel (rayon), each without inner parallelism.
pub fn measure_all(plan: &Plan, series: &[Vec<f64>], temp_c: Option<&[f64]>) -> Vec<Measure> {
    series.par_iter().map(|x| plan.measure(x, temp_c, false)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    use std::f64::consts::PI;

    use crate::test_signals::white;

    #[test]
    fn white_noise_agrees_with_white_noise() {
        let real = white(50_000, 1);
        let plan = Plan::new(&real, None, 10.0);
        assert!(plan.points[0].len() >= 10 && plan.points[1].len() >= 10, "{:?}", plan.points[1].len());
        assert!(plan.lattice_step().is_none());
        let m = plan.measure(&real, None, true);
        let sims: Vec<Vec<f64>> = (2..22).map(|s| white(50_000, s)).collect();
        let ms = measure_all(&plan, &sims, None);
        let gaps = compare(&plan, &m, &ms);
        assert_eq!(gaps.len(), 3);
        for g in &gaps {
            assert!(g.rms < 2.0, "{:?} {}", g.view, g.rms);
        }
        // Twice the noise: a gap of the right sign in ADEV and PSD.
        let loud: Vec<f64> = real.iter().map(|v| 2.0 * v).collect();
        let gaps = compare(&plan, &plan.measure(&loud, None, true), &ms);
        assert!(gaps[0].rms > 10.0 && gaps[0].points.iter().all(|p| p.z > 0.0));
        assert!(gaps[1].rms > 10.0);
    }

    #[test]
    fn psd_reaches_one_cycle_per_part_in_physical_units_and_sees_a_slow_line() {
        // White noise of unit variance at 10 Hz: a one-sided PSD of 2 / fs in every band, Welch's and the
        // multitaper's alike, down to one cycle per part.
        let (n, fs) = (1usize << 16, 10.0);
        let noise = white(n, 21);
        let plan = Plan::new(&noise, None, fs);
        let pts = &plan.points[1];
        let part_s = n as f64 / fs;
        let longest = pts.iter().map(|p| p.tau_hi_s).fold(0.0, f64::max);
        assert!(longest > 0.99 * part_s && longest <= part_s, "{longest} of {part_s}");
        assert!(pts.iter().filter(|p| p.tau_lo_s >= part_s / 16.5).count() >= 5, "{pts:?}");
        let psd = plan.measure(&noise, None, true).values[1].clone();
        for (p, v) in pts.iter().zip(&psd) {
            let sd = p.floor_sd.max(0.02);
            assert!((v - (2.0 / fs).ln()).abs() < 4.0 * sd, "band at {:.1} s: {v} vs {}", p.tau_s, (2.0 / fs).ln());
        }
        // A sinusoid of 8 cycles per part with a quarter of the noise's power: its band sees a line far above
        // the noise; the Welch bands, from a sixteenth of the part down, do not move.
        let line: Vec<f64> =
            noise.iter().enumerate().map(|(i, v)| v + 0.7 * (2.0 * PI * 8.0 * i as f64 / n as f64).sin()).collect();
        let with_line = plan.measure(&line, None, true).values[1].clone();
        let band = pts.iter().position(|p| p.tau_lo_s <= part_s / 8.0 && part_s / 8.0 < p.tau_hi_s).unwrap();
        assert!(with_line[band] - psd[band] > 3.0, "{} vs {}", with_line[band], psd[band]);
        for (i, p) in pts.iter().enumerate().filter(|(_, p)| p.tau_hi_s < part_s / 16.0) {
            assert!((with_line[i] - psd[i]).abs() < 0.1, "band at {:.1} s moved", p.tau_s);
        }
    }

    #[test]
    fn the_long_psd_bands_see_through_a_linear_drift() {
        // White noise of unit variance with a drift of 40 sds over the part. A line is no stationary noise: the
        // multitaper bands take it out and keep the white level 2 / fs within 4 of their sds; centred only, the
        // antisymmetric tapers would turn it into power 6 (in ln) above the noise at a cycle per part.
        let (n, fs) = (1usize << 16, 10.0);
        let drifted: Vec<f64> = white(n, 22).iter().enumerate().map(|(i, v)| v + 40.0 * i as f64 / n as f64).collect();
        let plan = Plan::new(&drifted, None, fs);
        let part_s = n as f64 / fs;
        let psd = plan.measure(&drifted, None, true).values[1].clone();
        let long: Vec<(&PointInfo, f64)> =
            plan.points[1].iter().zip(psd).filter(|(p, _)| p.tau_lo_s >= part_s / 16.5).collect();
        assert!(long.len() >= 5);
        for (p, v) in long {
            assert!((v - (2.0 / fs).ln()).abs() < 4.0 * p.floor_sd, "band at {:.1} s: {v}", p.tau_s);
        }
    }

    #[test]
    fn difference_kurtosis_has_its_closed_forms() {
        // Gaussian white noise: the Allan differences are Gaussian, excess kurtosis 0 (sd sqrt(24/n)).
        let x = white(1 << 18, 11);
        let ms = [2usize, 8, 64];
        for (m, k) in ms.iter().zip(difference_kurtosis(&x, &ms)) {
            let n = ((1 << 18) / m - 1) as f64;
            assert!(k.abs() < 5.0 * (24.0 / n).sqrt() + 0.02, "m {m}: {k}");
        }
        // A pure sinusoid: its differences are a sinusoid, excess kurtosis -1.5.
        let sine: Vec<f64> = (0..1 << 16).map(|i| (2.0 * std::f64::consts::PI * i as f64 / 1000.0).sin()).collect();
        for k in difference_kurtosis(&sine, &[2, 4, 8]) {
            assert!((k + 1.5).abs() < 0.01, "{k}");
        }
        // Rare large steps on white noise: heavy tails.
        let mut steps = white(1 << 18, 12);
        let mut level = 0.0;
        for (i, v) in steps.iter_mut().enumerate() {
            if i % 20_000 == 10_000 {
                level += 20.0;
            }
            *v += level;
        }
        assert!(difference_kurtosis(&steps, &[64])[0] > 10.0);
        // Too few differences: NaN.
        assert!(difference_kurtosis(&x[..200], &[4])[0].is_nan());
    }

    #[test]
    fn lattice_and_spikes_are_seen() {
        let lattice = |q: f64| -> Vec<f64> { white(20_000, 3).iter().map(|v| (v / q).round() * q + 0.1).collect() };
        let q = 0.75;
        let x = lattice(q);
        assert!((lattice_of(&x).unwrap() - q).abs() < 1e-12);
        // A step of a quarter of the noise sd is on a lattice too, but too fine to matter.
        assert!(lattice_of(&lattice(0.25)).is_none());
        assert!(lattice_of(&white(20_000, 3)).is_none());
        let plan = Plan::new(&x, None, 1.0);
        let mut spiky = white(20_000, 4);
        for i in (0..20_000).step_by(200) {
            spiky[i] += 8.0;
        }
        let d = plan.measure(&spiky, None, true).values[2].clone();
        let c = plan.measure(&white(20_000, 5), None, true).values[2].clone();
        assert!(d[1] > c[1] + 1.0, "kurtosis {d:?} {c:?}");
        assert!(d[2] > 0.004 && c[2] < 0.001, "tails {d:?} {c:?}");
        assert!(d[0] > 0.3, "skewness {d:?}");
        assert!(d[3] < 0.2 && plan.measure(&x, None, true).values[2][3] > 0.99);
    }

    /// The band of the temperature view that holds `cycles` cycles per part.
    fn band_of(plan: &Plan, n: usize, fs: f64, cycles: f64) -> usize {
        let tau = n as f64 / fs / cycles;
        plan.points[3].iter().position(|p| p.tau_lo_s <= tau && tau < p.tau_hi_s).unwrap()
    }

    #[test]
    fn temperature_coherence_is_found_in_the_cycles_band_at_any_lag() {
        // 20 cycles of 2000 s; the rate follows the temperature a quarter cycle late, where the two are
        // uncorrelated sample by sample: the coherence of the cycle's band is the same as without a lag.
        let n = 40_000;
        let temp: Vec<f64> = (0..n).map(|i| 20.0 + 3.0 * (2.0 * PI * i as f64 / 2000.0).sin()).collect();
        let noise = white(n, 7);
        let coupled = |lag: usize| -> Vec<f64> {
            (0..n).map(|i| 0.2 * noise[i] + if i >= lag { 0.5 * (temp[i - lag] - 20.0) } else { 0.0 }).collect()
        };
        let late = coupled(500);
        let plan = Plan::new(&late, Some(&temp), 1.0);
        let cycle = band_of(&plan, n, 1.0, 20.0);
        let m = plan.measure(&late, Some(&temp), true).values[3].clone();
        let m0 = plan.measure(&coupled(0), Some(&temp), true).values[3].clone();
        assert!(m[cycle].tanh() > 0.99, "{m:?}");
        assert!((m[cycle].tanh() - m0[cycle].tanh()).abs() < 0.01, "{m:?} {m0:?}");
        let quadrature: f64 = late.iter().zip(&temp).map(|(r, t)| r * (t - 20.0)).sum::<f64>()
            / (late.iter().map(|r| r * r).sum::<f64>() * temp.iter().map(|t| (t - 20.0).powi(2)).sum::<f64>()).sqrt();
        assert!(quadrature.abs() < 0.1, "sample correlation {quadrature}");
        // Noise alone follows it in no band.
        let m = plan.measure(&noise, Some(&temp), true).values[3].clone();
        assert!(m.iter().all(|v| v.tanh() < 0.6), "{m:?}");
    }

    #[test]
    fn a_model_coupling_is_taken_out_of_the_temperature_view_only() {
        // rate = 0.5 T (lagged) + noise. Less the true response, it correlates with T no more than the noise does;
        // less half of it, the other half still shows; the other views do not change.
        let n = 40_000;
        let temp: Vec<f64> = (0..n).map(|i| 20.0 + 3.0 * (i as f64 / 3000.0).sin()).collect();
        let noise = white(n, 7);
        let response: Vec<f64> = (0..n).map(|i| if i >= 500 { 0.5 * temp[i - 500] } else { 0.0 }).collect();
        let rate: Vec<f64> = noise.iter().zip(&response).map(|(e, r)| 0.2 * e + r).collect();
        let plan = Plan::new(&rate, Some(&temp), 1.0);
        let whole = plan.measure(&rate, Some(&temp), true);
        let rest = plan.measure_explained(&rate, Some(&temp), Some(&response), true);
        let noise_only = plan.measure(&noise, Some(&temp), true);
        for (r, e) in rest.values[3].iter().zip(&noise_only.values[3]) {
            assert!((r - e).abs() < 1e-9, "{r} vs the noise's {e}");
        }
        let half: Vec<f64> = response.iter().map(|r| 0.5 * r).collect();
        let part = plan.measure_explained(&rate, Some(&temp), Some(&half), true);
        let cycle = band_of(&plan, n, 1.0, n as f64 / (2.0 * PI * 3000.0));
        assert!(part.values[3][cycle].tanh() > 0.9, "{:?}", part.values[3]);
        for k in 0..3 {
            assert_eq!(format!("{:?}", rest.values[k]), format!("{:?}", whole.values[k]));
        }
        // Re-taking only the temperature view of a measure gives the same, bit for bit.
        let again = plan.with_explained(&whole, &rate, Some(&temp), &response);
        assert_eq!(format!("{:?}", again.values), format!("{:?}", rest.values));
    }
}

//! The `psd` view: ln of the one-sided PSD ((deg/s)^2/Hz) in log-spaced bands, 5 per decade, from Nyquist down to
//! one cycle per part.
//!
//! Down to a sixteenth of the part the bands come from Welch levels (Hann, 50% overlap, the low ones through
//! block-mean decimation by 8, each band from the finest level that puts four bins between DC and it). Below,
//! the sine-multitaper estimate of the whole part's block means, less their least-squares line (a random walk's
//! or a ramp's line over the part is no stationary noise, and through the antisymmetric tapers it would land in
//! the lowest bands), carries the same ladder of bands down to one cycle per part: a sinusoid of eight cycles per
//! part is a line there at its full power, where the Allan deviation sees only a hump.

use std::sync::Arc;

use rustfft::num_complex::Complex;
use rustfft::FftPlanner;

use super::PointInfo;
use crate::spectral::{block_means, detrended, welch, Multitaper, WelchLevel};

/// Points per decade of the PSD bands.
const BANDS_PER_DECADE: f64 = 5.0;
/// Longest Welch segment.
const MAX_SEG: usize = 1024;
/// Shortest Welch segment.
const MIN_SEG: usize = 32;
/// Decimation factor between Welch levels.
const DECIM: usize = 8;

/// One Welch band: its level and FFT bin range (inclusive).
#[derive(Clone, Debug)]
struct WelchBand {
    level: usize,
    bin_lo: usize,
    bin_hi: usize,
}

/// The bands of a part's PSD.
#[derive(Clone)]
pub(super) struct PsdPlan {
    rate_hz: f64,
    levels: Vec<WelchLevel>,
    bands: Vec<WelchBand>,
    /// The whole-part multitaper layout (shared with the temperature view).
    taper: Option<Arc<Multitaper>>,
    /// FFT bin ranges (inclusive) of the bands below the Welch levels' reach, in increasing tau.
    taper_bands: Vec<(usize, usize)>,
}

impl PsdPlan {
    /// The bands of a part of `n` samples at `rate_hz`, with the part's multitaper layout.
    pub fn new(
        n: usize,
        rate_hz: f64,
        taper: Option<Arc<Multitaper>>,
        planner: &mut FftPlanner<f64>,
    ) -> (PsdPlan, Vec<PointInfo>) {
        let tau0 = 1.0 / rate_hz;
        // Levels of block-mean decimation while four segments fit.
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
            levels.push(WelchLevel::new(decim, seg, planner));
            decim *= DECIM;
        }
        let mut bands = Vec::new();
        let mut points = Vec::new();
        // The ratio of a band's edges, and the top of the next band down.
        let step = 10f64.powf(1.0 / BANDS_PER_DECADE);
        let mut f_hi = rate_hz / 2.0;
        if !levels.is_empty() {
            loop {
                let f_lo = f_hi / step;
                // The finest level that puts at least 4 bins between DC and the band.
                let found = levels.iter().enumerate().find_map(|(k, l)| {
                    let fs_k = rate_hz / l.decim as f64;
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
                points.push(PointInfo {
                    label: "band",
                    tau_s: 1.0 / (f_lo * f_hi).sqrt(),
                    tau_lo_s: 1.0 / f_hi,
                    tau_hi_s: 1.0 / f_lo,
                    floor_sd: (1.0 / (bins * segs as f64 * 0.9)).sqrt(),
                });
                bands.push(WelchBand { level: k, bin_lo: lo, bin_hi: hi });
                f_hi = f_lo;
            }
        }
        // Below the Welch levels' reach (a sixteenth of the part): the same ladder of bands down to one cycle
        // per part, from the multitaper estimate on the whole part.
        let mut taper_bands = Vec::new();
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
                    points.push(PointInfo {
                        label: "band",
                        tau_s: part_s / (u0 * u1).sqrt(),
                        tau_lo_s: part_s / u1,
                        tau_hi_s: part_s / u0,
                        floor_sd: mt.floor_sd(u1 - u0),
                    });
                    taper_bands.push((k0, k1));
                }
                if u0 <= 1.0 {
                    break;
                }
                f_hi /= step;
            }
        }
        (PsdPlan { rate_hz, levels, bands, taper, taper_bands }, points)
    }

    /// ln PSD of `x` in every band (NaN where a band cannot be estimated), Welch bands first.
    pub fn values(&self, x: &[f64]) -> Vec<f64> {
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
                dec = block_means(x, l.decim);
                &dec
            };
            spectra.push(welch(data, l, self.rate_hz / l.decim as f64));
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
        out.extend(self.long(x));
        out
    }

    /// The bands below the Welch levels: the sine-multitaper estimate of the whole part's detrended block means,
    /// averaged over each band's bins and the tapers (one-sided, (deg/s)^2/Hz, as the Welch levels).
    fn long(&self, x: &[f64]) -> Vec<f64> {
        let bands = &self.taper_bands;
        let nan = vec![f64::NAN; bands.len()];
        let Some(mt) = self.taper.as_ref().filter(|_| !bands.is_empty()) else { return nan };
        let mut rate = block_means(x, mt.decim);
        rate.truncate(mt.nb);
        let valid: Vec<bool> = rate.iter().map(|r| r.is_finite()).collect();
        let Some(rate) = detrended(&rate, &valid) else { return nan };
        let mut power = vec![0.0; bands.len()];
        let mut buf = vec![Complex::new(0.0, 0.0); mt.nfft];
        let mut scratch = vec![Complex::new(0.0, 0.0); mt.scratch_len()];
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
                let fs_blocks = self.rate_hz / mt.decim as f64;
                let mean = 2.0 * p / ((k1 + 1 - k0) * mt.tapers.len()) as f64 / fs_blocks;
                if mean > 0.0 {
                    mean.ln()
                } else {
                    f64::NAN
                }
            })
            .collect()
    }
}

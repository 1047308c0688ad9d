//! The spectral tools the views and the estimators share: block means, Welch's averaged periodogram, the
//! whole-part sine multitaper, and the centring and detrending of gappy block means before a transform.
//!
//! Welch levels ([`WelchLevel`]) look at short periods: Hann segments of at most 1024 points, 50% overlap, on the
//! samples or on their block means (decimation by 8 per level). The whole-part multitaper ([`Multitaper`]) looks
//! at the longest periods, from a sixteenth of the part to the whole part: five sine tapers (Riedel and
//! Sidorenko, 1995) on at most 8192 block means, which weigh the part nearly evenly and keep the leakage of strong
//! low frequencies (flicker, random walk) local.

use std::sync::Arc;

use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};

/// The layout of a Welch level: block-mean decimation factor, segment length, its FFT and its Hann window.
#[derive(Clone)]
pub(crate) struct WelchLevel {
    /// Samples averaged into one point of this level.
    pub decim: usize,
    /// Segment length, points.
    pub seg: usize,
    fft: Arc<dyn Fft<f64>>,
    window: Vec<f64>,
}

impl WelchLevel {
    /// A level of `seg`-point Hann segments on block means of `decim` samples.
    pub fn new(decim: usize, seg: usize, planner: &mut FftPlanner<f64>) -> WelchLevel {
        let window: Vec<f64> =
            (0..seg).map(|i| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / seg as f64).cos()).collect();
        WelchLevel { decim, seg, fft: planner.plan_fft_forward(seg), window }
    }
}

/// Welch's averaged periodogram of one level whose points come at `rate_hz` (one-sided, (deg/s)^2/Hz), `None`
/// without a complete segment free of gaps.
pub(crate) fn welch(data: &[f64], l: &WelchLevel, rate_hz: f64) -> Option<Vec<f64>> {
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
    let norm = 2.0 / (count as f64 * w2 * rate_hz);
    Some(acc.into_iter().map(|a| a * norm).collect())
}

/// `v` less the mean of its valid entries, with the invalid ones set to zero; `None` when fewer than half are
/// valid.
pub(crate) fn centred(v: &[f64], valid: &[bool]) -> Option<Vec<f64>> {
    let count = valid.iter().filter(|ok| **ok).count();
    if count * 2 < v.len() || count == 0 {
        return None;
    }
    let m = v.iter().zip(valid).filter(|(_, ok)| **ok).map(|(x, _)| x).sum::<f64>() / count as f64;
    Some(v.iter().zip(valid).map(|(x, ok)| if *ok { x - m } else { 0.0 }).collect())
}

/// `v` less its least-squares line over the valid points (invalid ones set to 0), as [`centred`].
pub(crate) fn detrended(v: &[f64], valid: &[bool]) -> Option<Vec<f64>> {
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
pub(crate) const WHOLE_PART_BLOCKS: usize = 8192;

/// The whole-part multitaper layout: block-mean decimation, sine tapers and the FFT of the zero-padded blocks.
#[derive(Clone)]
pub(crate) struct Multitaper {
    /// Samples averaged into one block.
    pub decim: usize,
    /// Blocks used (the part's whole blocks, at most [`WHOLE_PART_BLOCKS`]).
    pub nb: usize,
    /// FFT length (the blocks zero-padded to a power of two).
    pub nfft: usize,
    fft: Arc<dyn Fft<f64>>,
    /// The sine tapers, each of `nb` points.
    pub tapers: Vec<Vec<f64>>,
}

impl Multitaper {
    /// The layout for a part of `n` samples; `None` when it has fewer than 64 blocks.
    pub fn new(n: usize, planner: &mut FftPlanner<f64>) -> Option<Multitaper> {
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
    pub fn part_s(&self, tau0: f64) -> f64 {
        (self.nb * self.decim) as f64 * tau0
    }

    /// The FFT bins (inclusive) whose frequency lies in `[u0, u1)` cycles per part, up to Nyquist.
    pub fn bins(&self, u0: f64, u1: f64) -> Option<(usize, usize)> {
        let per_cycle = self.nfft as f64 / self.nb as f64;
        let k0 = (u0 * per_cycle).ceil() as usize;
        let k1 = ((u1 * per_cycle).ceil() as usize).saturating_sub(1).min(self.nfft / 2);
        (k1 >= k0).then_some((k0, k1))
    }

    /// The smallest sd of the ln of a band `width` cycles per part wide: the tapers' estimates are independent
    /// about every `tapers + 1` cycles, each with `2 tapers` degrees of freedom.
    pub fn floor_sd(&self, width: f64) -> f64 {
        let k = self.tapers.len() as f64;
        (1.0 / (0.9 * k * (1.0 + width / (k + 1.0)))).sqrt()
    }

    /// The scratch length [`Multitaper::transform`] needs.
    pub fn scratch_len(&self) -> usize {
        self.fft.get_inplace_scratch_len()
    }

    /// The FFT of `x` (the centred blocks) times the taper `w`, into `buf`.
    pub fn transform(&self, x: &[f64], w: &[f64], buf: &mut [Complex<f64>], scratch: &mut [Complex<f64>]) {
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

/// Block means of `x` over blocks of `m` samples (the last partial block dropped); the estimators use it too.
pub(crate) fn block_means(x: &[f64], m: usize) -> Vec<f64> {
    let m = m.max(1);
    x.chunks_exact(m).map(|c| c.iter().sum::<f64>() / m as f64).collect()
}

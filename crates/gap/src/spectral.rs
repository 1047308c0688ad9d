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
    // The segments free of gaps, two per complex transform (one as the real part, the next as the imaginary):
    // for real x and y and z = x + i y, |X_k|^2 + |Y_k|^2 = (|Z_k|^2 + |Z_{-k}|^2) / 2.
    let valid: Vec<&[f64]> = (0..=(data.len() - seg) / hop)
        .map(|k| &data[k * hop..k * hop + seg])
        .filter(|s| s.iter().all(|v| v.is_finite()))
        .collect();
    if valid.is_empty() {
        return None;
    }
    fn windowed<'a>(s: &'a [f64], window: &'a [f64]) -> impl Iterator<Item = f64> + 'a {
        let mean = s.iter().sum::<f64>() / s.len() as f64;
        s.iter().zip(window).map(move |(&v, &w)| (v - mean) * w)
    }
    for pair in valid.chunks(2) {
        match pair {
            [a, b] => {
                for ((z, x), y) in buf.iter_mut().zip(windowed(a, &l.window)).zip(windowed(b, &l.window)) {
                    *z = Complex::new(x, y);
                }
                l.fft.process_with_scratch(&mut buf, &mut scratch);
                for (k, a) in acc.iter_mut().enumerate() {
                    *a += 0.5 * (buf[k].norm_sqr() + buf[(seg - k) % seg].norm_sqr());
                }
            }
            _ => {
                for (z, x) in buf.iter_mut().zip(windowed(pair[0], &l.window)) {
                    *z = Complex::new(x, 0.0);
                }
                l.fft.process_with_scratch(&mut buf, &mut scratch);
                for (a, c) in acc.iter_mut().zip(&buf) {
                    *a += c.norm_sqr();
                }
            }
        }
    }
    let w2: f64 = l.window.iter().map(|w| w * w).sum();
    let norm = 2.0 / (valid.len() as f64 * w2 * rate_hz);
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

#[cfg(test)]
mod tests {
    use rustfft::FftPlanner;

    use super::{welch, WelchLevel};

    /// Welch's estimate by the definition: each whole segment free of gaps, its mean out, Hann-windowed, its
    /// periodogram by a direct DFT, averaged and scaled to a one-sided density.
    fn welch_by_definition(x: &[f64], seg: usize, rate_hz: f64) -> Vec<f64> {
        let two_pi = 2.0 * std::f64::consts::PI;
        let w: Vec<f64> = (0..seg).map(|i| 0.5 - 0.5 * (two_pi * i as f64 / seg as f64).cos()).collect();
        let w2: f64 = w.iter().map(|v| v * v).sum();
        let mut acc = vec![0.0; seg / 2 + 1];
        let mut count = 0;
        for s in (0..=(x.len() - seg) / (seg / 2)).map(|k| &x[k * seg / 2..k * seg / 2 + seg]) {
            if s.iter().any(|v| v.is_nan()) {
                continue;
            }
            let mean = s.iter().sum::<f64>() / seg as f64;
            for (k, a) in acc.iter_mut().enumerate() {
                let (mut re, mut im) = (0.0, 0.0);
                for (i, (&v, &wi)) in s.iter().zip(&w).enumerate() {
                    let ph = two_pi * (k * i) as f64 / seg as f64;
                    re += (v - mean) * wi * ph.cos();
                    im -= (v - mean) * wi * ph.sin();
                }
                *a += re * re + im * im;
            }
            count += 1;
        }
        acc.iter().map(|a| a * 2.0 / (count as f64 * w2 * rate_hz)).collect()
    }

    #[test]
    fn paired_segments_give_welchs_estimate() {
        let seg = 64;
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut x: Vec<f64> = (0..1000)
            .map(|i| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5 + (0.3 * i as f64).sin() + 1e-3 * i as f64
            })
            .collect();
        let level = WelchLevel::new(1, seg, &mut FftPlanner::new());
        // 30 whole segments, then 29 (a gap in the first half of the first segment takes it alone out).
        for gap in [None, Some(10)] {
            if let Some(i) = gap {
                x[i] = f64::NAN;
            }
            let got = welch(&x, &level, 10.0).expect("segments free of gaps");
            let want = welch_by_definition(&x, seg, 10.0);
            for (k, (g, w)) in got.iter().zip(&want).enumerate() {
                assert!((g - w).abs() <= 1e-10 * w.abs().max(1e-6), "gap {gap:?} bin {k}: {g} against {w}");
            }
        }
    }
}

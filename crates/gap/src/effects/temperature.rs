//! The temperature candidate: a bias coupled to the recorded temperature through a first-order thermal lag.

use super::params::TemperatureParams;
use octavar_shared::sim::{GyroSim, TempCoupling};

use super::common::*;
use super::noise_spectrum::NoiseSpectrum;
use super::{Effect, EffectFit, EffectKind, ParamSpread, TrainingData};
use crate::fill::refill;

/// The temperature effect: [`temperature`] and its parameters.
pub(super) struct Kind;

impl EffectKind for Kind {
    const EFFECT: Effect = Effect::Temperature;
    type Params = TemperatureParams;

    fn estimate(data: &TrainingData) -> Option<EffectFit> {
        temperature(data)
    }

    fn test_statistic(p: &TemperatureParams) -> Option<f64> {
        Some(p.t_stat)
    }

    fn reestimated(p: &TemperatureParams, gyro: &GyroSim) -> TemperatureParams {
        TemperatureParams { dps_per_c: gyro.temperature.map_or(p.dps_per_c, |c| c.dps_per_c), ..p.clone() }
    }
}

/// Bias coupled to the temperature through a first-order thermal lag.
///
/// Method: rate and temperature are block-averaged to blocks of at most a second (at least 8192 blocks where the
/// record allows; the temperature moves over minutes to days). For each lag the temperature goes through the
/// discrete first-order lag (`y = T + a (y - T)`, `a = exp(-dt/lag)`, started settled, as shared::sim's
/// `ThermalLag`), and the coefficient comes from a generalised least-squares regression in the frequency domain
/// (Whittle): with the transforms X (lagged temperature) and R (rate) under each of five sine tapers,
/// `k = sum Re(X* R)/S / sum |X|^2/S` over the tapers and the non-zero frequencies, S the two-sided PSD of the
/// gyro's noise, `N^2 + B^2/(2 pi f) + K^2/(4 pi^2 f^2)` (IEEE 952 Annex C). Ordinary least squares would let the
/// flicker and random walk at the lowest frequencies, where a slow temperature wander also lives, dominate the
/// estimate; GLS weighs each frequency by its noise. The tapers together weigh the record nearly uniformly (one
/// Hann taper counts mainly the middle half, and noise there can move the coupling by several times the scatter
/// of the record's other draws). The lag minimises the GLS residual
/// `sum |R - k X|^2 / S` on a log grid from the block length to three record lengths, refined by golden-section
/// search, and is compared with no lag. Two passes: S from the base fit, then from the IEEE fit of the record
/// without the fitted coupling (the base fit took part of the temperature bump for flicker or random walk), which
/// also gives the model's base terms. The first pass runs twice, under the base fit's noise and under it without
/// K and R (which a few slow temperature cycles may have become), and the stronger second pass is kept. The
/// coefficient counts when it exceeds [`T_PROPOSE`] standard errors, the standard error being that of the
/// estimate under S exactly ([`gls_sd`]): slow bias wander that happens to correlate with a slow temperature is
/// not taken for coupling.
pub(super) fn temperature(d: &TrainingData) -> Option<EffectFit> {
    let g = Regression::of(d)?;
    // The first pass's noises: the base fit's, and the base fit's without its random walk and ramp, which a slow
    // temperature cycle of a few periods per record may have become (the GLS then weighs the cycle against its
    // own power and finds nothing); the stronger test is kept.
    let noise = samples_noise(d);
    let quiet = GyroSim { k_dps_per_rt_s: 0.0, r_dps_per_s: 0.0, ..noise.clone() };
    let pass = [&noise, &quiet]
        .into_iter()
        .filter_map(|first| g.second_pass(first))
        .filter(|p| p.se > 0.0)
        .max_by(|a, b| (a.k / a.se).abs().total_cmp(&(b.k / b.se).abs()))?;
    if !(pass.k.abs() > T_PROPOSE * pass.se) {
        return None;
    }
    g.fit(&pass)
}

/// The rate and the temperature in block means on an FFT-friendly grid, and their sine-tapered transforms: what
/// every pass of the GLS regression of the rate on the lagged temperature reads.
struct Regression<'a> {
    d: &'a TrainingData<'a>,
    /// The recorded temperature, degC.
    temp: &'a [f64],
    /// Samples read (the shorter of rate and temperature).
    n: usize,
    /// Samples per block.
    m: usize,
    /// Blocks.
    nb: usize,
    /// The blocks' spacing, s.
    dt: f64,
    /// The rate's block means.
    r: Vec<f64>,
    /// The temperature's block means.
    t: Vec<f64>,
    tapers: Vec<Vec<f64>>,
    fft_plan: std::sync::Arc<dyn rustfft::Fft<f64>>,
    /// The rate's tapered transforms.
    rt1: Vec<(Vec<f64>, Vec<f64>)>,
    /// The unlagged temperature's tapered transforms.
    unlagged: Vec<(Vec<f64>, Vec<f64>)>,
    /// Bins up to Nyquist.
    half: usize,
    /// The bin width, Hz.
    df: f64,
}

impl<'a> Regression<'a> {
    /// The regression's data; `None` without a usable temperature (missing, non-finite, constant, too short).
    fn of(d: &'a TrainingData<'a>) -> Option<Regression<'a>> {
        let temp = d.temp_c?;
        let n = d.rate_dps.len().min(temp.len());
        if n < 64 || temp[..n].iter().any(|v| !v.is_finite()) {
            return None;
        }
        let m = ((n / 8192).max(1)).min((d.rate_hz.max(1.0)) as usize).max(1);
        let mut r = block_means(&d.rate_dps[..n], m);
        let mut t = block_means(&temp[..n], m);
        // The FFT grid is 2 (nb + 1) long: trim a few blocks (under 1%) so that it has no prime factor above 7.
        let nb = fft_friendly(r.len());
        r.truncate(nb);
        t.truncate(nb);
        if nb < 16 {
            return None;
        }
        let dt = m as f64 / d.rate_hz;
        let t_spread = t.iter().fold(f64::MIN, |a, &b| a.max(b)) - t.iter().fold(f64::MAX, |a, &b| a.min(b));
        if !(t_spread > 0.0) {
            return None;
        }
        // On a grid of 2 (nb + 1) bins, a sine taper's transform is two neighbours of the plain one: one FFT gives
        // all five ([`sine_tapered`]).
        let nfft = 2 * (nb + 1);
        let fft_plan = forward_plan(nfft);
        let rt1 = sine_tapered(&r, TAPERS, &*fft_plan);
        let unlagged = sine_tapered(&t, TAPERS, &*fft_plan);
        let tapers = sine_tapers(nb, TAPERS);
        let df = 1.0 / (nfft as f64 * dt);
        Some(Regression { d, temp, n, m, nb, dt, r, t, tapers, fft_plan, rt1, unlagged, half: nfft / 2, df })
    }

    /// The sine-tapered transforms of a series of block means.
    fn transform(&self, v: &[f64]) -> Vec<(Vec<f64>, Vec<f64>)> {
        sine_tapered(v, TAPERS, &*self.fft_plan)
    }

    /// The block-mean temperature through a first-order lag of time constant `lag` s.
    fn lagged(&self, lag: f64) -> Vec<f64> {
        let a = if lag > 0.0 { (-self.dt / lag).exp() } else { 0.0 };
        let mut y = self.t[0];
        self.t
            .iter()
            .map(|&x| {
                y = x + a * (y - x);
                y
            })
            .collect()
    }

    /// `noise`'s spectrum at every bin.
    fn spectrum(&self, noise: &NoiseSpectrum) -> Vec<f64> {
        (0..=self.half).map(|k| noise.at((k as f64 * self.df).max(self.df))).collect()
    }

    /// (k, GLS residual, sum |X|^2/S) for a lagged temperature's transforms, summed over the tapers.
    fn gls(&self, xt: &[(Vec<f64>, Vec<f64>)], rt: &[(Vec<f64>, Vec<f64>)], s: &[f64]) -> (f64, f64, f64) {
        let (mut sxx, mut sxr, mut srr) = (0.0, 0.0, 0.0);
        for ((xr, xi), (rr, ri)) in xt.iter().zip(rt) {
            for k in 1..=self.half {
                sxx += (xr[k] * xr[k] + xi[k] * xi[k]) / s[k];
                sxr += (xr[k] * rr[k] + xi[k] * ri[k]) / s[k];
                srr += (rr[k] * rr[k] + ri[k] * ri[k]) / s[k];
            }
        }
        if !(sxx > 0.0) {
            return (0.0, f64::INFINITY, 0.0);
        }
        (sxr / sxx, srr - sxr * sxr / sxx, sxx)
    }

    /// The lag of least GLS residual on a log grid from the block length to three record lengths, or 0 where no
    /// lag does better; `None` where the residual still falls at three record lengths. A lag that long makes the
    /// lagged temperature a slow ramp whose size trades against the coefficient: the coupling is not identified,
    /// and a ramp-like effect (a warm-up, a drift) is the likelier driver of the rate.
    fn best_lag(&self, rt: &[(Vec<f64>, Vec<f64>)], s: &[f64]) -> Option<f64> {
        let (lo, hi) = (self.dt, 3.0 * self.nb as f64 * self.dt);
        let (lag, crit) = log_search(lo, hi, LAG_GRID, |lag| self.gls(&self.transform(&self.lagged(lag)), rt, s).1);
        if self.gls(&self.unlagged, rt, s).1 <= crit {
            Some(0.0)
        } else {
            (!at_top(lag, lo, hi, LAG_GRID)).then_some(lag)
        }
    }

    /// The lagged temperature at every sample.
    fn response(&self, lag: f64) -> Vec<f64> {
        let a_full = if lag > 0.0 { (-1.0 / (self.d.rate_hz * lag)).exp() } else { 0.0 };
        let mut y = self.temp[0];
        self.temp[..self.n]
            .iter()
            .map(|&tc| {
                y = tc + a_full * (y - tc);
                y
            })
            .collect()
    }

    /// The rate less the coupling, its gaps filled from what is left.
    fn cleaned_of(&self, k: f64, lag: f64) -> Vec<f64> {
        let mut c: Vec<f64> =
            self.d.rate_dps[..self.n].iter().zip(self.response(lag)).map(|(&r, y)| r - k * y).collect();
        refill(&mut c, self.d.gaps);
        c
    }

    /// One proposal and its test: pass 1 under the noise `first`; pass 2 under the noise of the record without
    /// pass 1's coupling (where the record had gaps, the rate with them filled from pass 1's coupling: a line
    /// through a gap lacks the response there, and reads the coupling low). The test is always pass 2's, under
    /// the IEEE fit of the record less the coupling it tests.
    fn second_pass(&self, first: &GyroSim) -> Option<Pass> {
        let (d, m, nb) = (self.d, self.m, self.nb);
        let s1 = self.spectrum(&NoiseSpectrum::of_block_means(first, d.rate_hz, m));
        let lag1 = self.best_lag(&self.rt1, &s1)?;
        let (k1, _, _) = self.gls(&self.transform(&self.lagged(lag1)), &self.rt1, &s1);
        let cleaned1 = self.cleaned_of(k1, lag1);
        let (refit1, _) = refit_noise(d, &cleaned1)?;
        let noise = NoiseSpectrum::of_block_means(&refit1, d.rate_hz, m);
        let mut r2 = self.r.clone();
        if !d.gaps.is_empty() {
            let refilled: Vec<f64> = cleaned1.iter().zip(self.response(lag1)).map(|(c, y)| c + k1 * y).collect();
            r2 = block_means(&refilled, m);
            r2.truncate(nb);
        }
        let rt = if d.gaps.is_empty() { self.rt1.clone() } else { self.transform(&r2) };
        let s2 = self.spectrum(&noise);
        let lag = self.best_lag(&rt, &s2)?;
        let x = self.lagged(lag);
        let xt = self.transform(&x);
        let (k, _, sxx) = self.gls(&xt, &rt, &s2);
        if !(k.is_finite() && k != 0.0 && sxx > 0.0) {
            return None;
        }
        let se = gls_sd(&self.tapers, &xt, &s2, sxx, self.dt, |f| noise.at(f));
        Some(Pass { k, lag, se, sxx, x, xt, s2, r: r2 })
    }

    /// The coupling's fit from its accepted pass: the base terms re-fitted on the record less it, the reference
    /// temperature that keeps the bias, and the frequency its estimate rests on (for the ensemble's spread).
    fn fit(&self, pass: &Pass) -> Option<EffectFit> {
        let Pass { k, lag, se, sxx, ref x, ref xt, ref s2, ref r } = *pass;
        let (d, half, df) = (self.d, self.half, self.df);
        // The frequency the estimate rests on: the mean of the GLS weights |X|^2 / S, whose sum is `sxx`; the lag's
        // phase is read there.
        let f_hz = xt
            .iter()
            .map(|(xr, xi)| (1..=half).map(|k| (xr[k] * xr[k] + xi[k] * xi[k]) / s2[k] * k as f64 * df).sum::<f64>())
            .sum::<f64>()
            / sxx;
        // Where the base terms cannot be re-fitted (a model with none left, whose curve the re-fit reads its
        // points against), the coupling stands on the model's base terms as they are.
        let refit = refit_base(d, &self.cleaned_of(k, lag), k / se).map_or_else(|| d.base.clone(), |r| r.0);
        // The sim adds bias + k (T_lag - ref): ref keeps the intercept (mean rate - k mean T_lag) with the base bias.
        let c0 = mean(r) - k * mean(x);
        let ref_c = (d.base.bias_dps - c0) / k;
        let gyro = GyroSim { temperature: Some(TempCoupling { dps_per_c: k, ref_c, lag_s: lag }), ..refit };
        Some(EffectFit {
            effect: Effect::Temperature,
            params: TemperatureParams { dps_per_c: k, lag_s: lag, ref_c, t_stat: k / se, dps_per_c_se: se }.into(),
            n_params: 2,
            gyro,
            channel: None,
            spread: (f_hz > 0.0 && se > 0.0).then_some(ParamSpread::Coupling { se_dps_per_c: se, f_hz }),
            cleaned: None,
        })
    }
}

/// The candidate is proposed when its coefficient is this many standard errors from zero. Below 5 it is named only
/// when the views judge that it takes away a significant gap that the temperature view locates
/// (`crate::rank::choose`); where no view's gap is significant, only by its own test at 5 standard errors
/// (`crate::evidence::test`): two tests where the first alone would need the stricter bar. A coupling at 4.6
/// standard errors over two temperature cycles can show plainly in the temperature view (coherence 0.9 real
/// against 0.4 simulated).
const T_PROPOSE: f64 = 3.0;

/// One proposal's second pass: the coupling, its lag and standard error, the GLS weight `sum |X|^2/S`, the lagged
/// temperature's block means and transforms, the noise PSD it was weighed under, and the rate's block means.
struct Pass {
    k: f64,
    lag: f64,
    se: f64,
    sxx: f64,
    x: Vec<f64>,
    xt: Vec<(Vec<f64>, Vec<f64>)>,
    s2: Vec<f64>,
    r: Vec<f64>,
}

/// Points of the lag's log grid.
const LAG_GRID: usize = 40;

/// Sine tapers in the GLS regression: five give near-uniform weight over the record (one Hann taper weighs its
/// middle and lets only half the record count, a variance 1.9 times the uniform one) while keeping leakage from
/// the strong low frequencies of flicker and random walk away from the temperature's cycle.
const TAPERS: usize = 5;

/// The largest `m <= n`, and above `0.99 n`, with `m + 1` free of prime factors above 7 (`n` itself if none):
/// an FFT of `2 (m + 1)` points is then a few times faster than one with large prime factors.
fn fft_friendly(n: usize) -> usize {
    let smooth = |mut v: usize| {
        for p in [2, 3, 5, 7] {
            while v.is_multiple_of(p) {
                v /= p;
            }
        }
        v == 1
    };
    let lo = n - n / 100;
    (lo..=n).rev().find(|&m| smooth(m + 1)).unwrap_or(n)
}

/// The transforms of the mean-removed `v` under the first `k` sine tapers of its length n, at the bins 0..=n+1 of
/// a grid of `2 (n + 1)` (the length of `fft`). The taper `sqrt(2/(n+1)) sin(pi j (i+1)/(n+1))` is two complex
/// exponentials that shift the plain transform V by j bins of that grid each way:
/// `T_j(m) = sqrt(2/(n+1)) / 2i * (e^{i a} V(m-j) - e^{-i a} V(m+j))`, `a = pi j/(n+1)`; one FFT instead of `k`.
pub(super) fn sine_tapered(v: &[f64], k: usize, fft: &dyn rustfft::Fft<f64>) -> Vec<(Vec<f64>, Vec<f64>)> {
    use rustfft::num_complex::Complex;
    let n = v.len();
    let nfft = fft.len();
    debug_assert_eq!(nfft, 2 * (n + 1));
    let mu = mean(v);
    let mut buf: Vec<Complex<f64>> =
        (0..nfft).map(|i| Complex::new(if i < n { v[i] - mu } else { 0.0 }, 0.0)).collect();
    fft.process(&mut buf);
    let half = nfft / 2;
    let c = (2.0 / (n as f64 + 1.0)).sqrt() / 2.0;
    (1..=k)
        .map(|j| {
            let a = std::f64::consts::PI * j as f64 / (n as f64 + 1.0);
            let (ea, eb) = (Complex::from_polar(1.0, a), Complex::from_polar(1.0, -a));
            let mut re = Vec::with_capacity(half + 1);
            let mut im = Vec::with_capacity(half + 1);
            // Bins m - j and m + j, wrapped around the grid (j < nfft, m <= nfft / 2: one wrap at most each).
            let wrap = |b: usize| if b >= nfft { b - nfft } else { b };
            for m in 0..=half {
                let lo = buf[wrap(m + nfft - j)];
                let hi = buf[wrap(m + j)];
                // (ea lo - eb hi) / 2i = -i (ea lo - eb hi) / 2
                let d = ea * lo - eb * hi;
                re.push(c * d.im);
                im.push(-c * d.re);
            }
            (re, im)
        })
        .collect()
}

/// The standard deviation of the GLS coefficient `k = sum Re(X* R)/S / sxx` under the noise spectrum `s_at`
/// (two-sided, of the block means every `dt`): the coefficient is linear in the rate, `k = sum g_i r_i`, and its
/// variance is the integral of `|G(f)|^2 S(f)` over frequency, taken on a four-times zero-padded grid. Exact for
/// the model spectrum, leakage and the tapers' correlation of neighbouring bins included.
fn gls_sd(
    tapers: &[Vec<f64>],
    xt: &[(Vec<f64>, Vec<f64>)],
    s: &[f64],
    sxx: f64,
    dt: f64,
    s_at: impl Fn(f64) -> f64,
) -> f64 {
    let nb = tapers.first().map_or(0, Vec::len);
    let half = s.len() - 1;
    let nfft = 2 * half;
    let mut g = vec![0.0; nb];
    for (w, (xr, xi)) in tapers.iter().zip(xt) {
        // Re(DFT(conj(X/S))) over the bins the regression sums.
        let mut re = vec![0.0; nfft];
        let mut im = vec![0.0; nfft];
        for k in 1..=half {
            re[k] = xr[k] / s[k];
            im[k] = -xi[k] / s[k];
        }
        fft(&mut re, &mut im);
        for (gi, (wi, v)) in g.iter_mut().zip(w.iter().zip(&re)) {
            *gi += wi * v / sxx;
        }
    }
    let gm = mean(&g);
    let big = 4 * nfft;
    let mut re = vec![0.0; big];
    let mut im = vec![0.0; big];
    for (r, gi) in re.iter_mut().zip(&g) {
        *r = gi - gm;
    }
    fft(&mut re, &mut im);
    let df = 1.0 / (big as f64 * dt);
    let var: f64 = (1..=big / 2).map(|m| 2.0 * (re[m] * re[m] + im[m] * im[m]) * s_at(m as f64 * df)).sum::<f64>() * df;
    var.sqrt()
}

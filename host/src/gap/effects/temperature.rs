//! The temperature candidate: a bias coupled to the recorded temperature through a first-order thermal lag.

use octavar_shared::sim::{GyroSim, TempCoupling};
use serde_json::json;

use super::common::*;
use super::{Effect, EffectFit, TrainingData};

/// Bias coupled to the temperature through a first-order thermal lag.
///
/// Method: rate and temperature are block-averaged to blocks of at most a second (at least 8192 blocks where the
/// record allows; the temperature moves over minutes to days). For each lag the temperature goes through the
/// discrete first-order lag (`y = T + a (y - T)`, `a = exp(-dt/lag)`, started settled, as shared::sim's
/// `ThermalLag`), and the coefficient comes from a generalised least-squares regression in the frequency domain
/// (Whittle): with Hann-tapered transforms X (lagged temperature) and R (rate), `k = sum Re(X* R)/S / sum |X|^2/S`
/// over the non-zero frequencies, S the two-sided PSD of the gyro's noise, `N^2 + B^2/(2 pi f) + K^2/(4 pi^2 f^2)`
/// (IEEE 952 Annex C). Ordinary least squares would let the flicker and random walk at the lowest frequencies,
/// where a slow temperature wander also lives, dominate the estimate; GLS weighs each frequency by its noise. The
/// lag minimises the GLS residual `sum |R - k X|^2 / S` on a log grid from the block length to three record
/// lengths, refined by golden-section search, and is compared with no lag. Two passes: S from the base fit, then
/// from the IEEE fit of the record without the fitted coupling (the base fit took part of the temperature bump
/// for flicker or random walk), which also gives the model's base terms. The coefficient counts when it exceeds 5
/// standard errors, `Var k = (sum w^2/dt) / sum |X|^2/S` (twice the independent-bin value, for the taper's
/// correlation of neighbouring bins): slow bias wander that happens to correlate with a slow temperature is not
/// taken for coupling.
pub(super) fn temperature(d: &TrainingData) -> Option<EffectFit> {
    let temp = d.temp_c?;
    let n = d.rate_dps.len().min(temp.len());
    if n < 64 || temp[..n].iter().any(|v| !v.is_finite()) {
        return None;
    }
    let m = ((n / 8192).max(1)).min((d.fs_hz.max(1.0)) as usize).max(1);
    let r = block_means(&d.rate_dps[..n], m);
    let t = block_means(&temp[..n], m);
    let nb = r.len();
    if nb < 16 {
        return None;
    }
    let dt = m as f64 / d.fs_hz;
    let t_spread = t.iter().fold(f64::MIN, |a, &b| a.max(b)) - t.iter().fold(f64::MAX, |a, &b| a.min(b));
    if !(t_spread > 0.0) {
        return None;
    }
    let lagged = |lag: f64| -> Vec<f64> {
        let a = if lag > 0.0 { (-dt / lag).exp() } else { 0.0 };
        let mut y = t[0];
        t.iter()
            .map(|&x| {
                y = x + a * (y - x);
                y
            })
            .collect()
    };
    let nfft = nb.next_power_of_two();
    let half = nfft / 2;
    let wd = 2.0 * std::f64::consts::PI / nb as f64;
    let taper: Vec<f64> = (0..nb).map(|i| 0.5 * (1.0 - (wd * (i as f64 + 0.5)).cos())).collect();
    let sum_w2: f64 = taper.iter().map(|w| w * w).sum();
    let transform = |v: &[f64]| -> (Vec<f64>, Vec<f64>) {
        let mu = mean(v);
        let mut re = vec![0.0; nfft];
        let mut im = vec![0.0; nfft];
        for (i, (x, w)) in v.iter().zip(&taper).enumerate() {
            re[i] = (x - mu) * w;
        }
        fft(&mut re, &mut im);
        re.truncate(half + 1);
        im.truncate(half + 1);
        (re, im)
    };
    let (rr, ri) = transform(&r);
    let df = 1.0 / (nfft as f64 * dt);
    let two_pi = 2.0 * std::f64::consts::PI;
    let spectrum = |sq: &[f64; 5]| -> Vec<f64> {
        let floor = (sq[1] + sq[2] + sq[3]).max(1e-300) * 1e-9;
        (0..=half)
            .map(|k| {
                let f = (k as f64 * df).max(df);
                (sq[1] + sq[2] / (two_pi * f) + sq[3] / (two_pi * two_pi * f * f)).max(floor)
            })
            .collect()
    };
    // (k, GLS residual, sum |X|^2/S) for a lagged temperature.
    let gls = |x: &[f64], s: &[f64]| -> (f64, f64, f64) {
        let (xr, xi) = transform(x);
        let (mut sxx, mut sxr, mut srr) = (0.0, 0.0, 0.0);
        for k in 1..=half {
            sxx += (xr[k] * xr[k] + xi[k] * xi[k]) / s[k];
            sxr += (xr[k] * rr[k] + xi[k] * ri[k]) / s[k];
            srr += (rr[k] * rr[k] + ri[k] * ri[k]) / s[k];
        }
        if !(sxx > 0.0) {
            return (0.0, f64::INFINITY, 0.0);
        }
        (sxr / sxx, srr - sxr * sxr / sxx, sxx)
    };
    let record = nb as f64 * dt;
    let best_lag = |s: &[f64]| -> f64 {
        let (lag, crit) = log_search(dt, 3.0 * record, 40, |lag| gls(&lagged(lag), s).1);
        if gls(&t, s).1 <= crit {
            0.0
        } else {
            lag
        }
    };
    // Pass 1: the base fit's noise.
    let s1 = spectrum(&d.base_fit.squares);
    let lag1 = best_lag(&s1);
    let (k1, _, _) = gls(&lagged(lag1), &s1);
    let cleaned_of = |k: f64, lag: f64| -> Vec<f64> {
        let a_full = if lag > 0.0 { (-1.0 / (d.fs_hz * lag)).exp() } else { 0.0 };
        let mut y = temp[0];
        d.rate_dps[..n]
            .iter()
            .zip(&temp[..n])
            .map(|(&r, &tc)| {
                y = tc + a_full * (y - tc);
                r - k * y
            })
            .collect()
    };
    // Pass 2: the noise of the record without the coupling.
    let (_, squares) = refit_base(d.base, &cleaned_of(k1, lag1), d.fs_hz)?;
    let s2 = spectrum(&squares);
    let lag = best_lag(&s2);
    let x = lagged(lag);
    let (k, _, sxx) = gls(&x, &s2);
    if !(k.is_finite() && k != 0.0 && sxx > 0.0) {
        return None;
    }
    let se = (sum_w2 / dt / sxx).sqrt();
    if !(k.abs() > 5.0 * se) {
        return None;
    }
    let (refit, _) = refit_base(d.base, &cleaned_of(k, lag), d.fs_hz)?;
    // The sim adds bias + k (T_lag - ref): ref keeps the intercept (mean rate - k mean T_lag) with the base bias.
    let c0 = mean(&r) - k * mean(&x);
    let ref_c = (d.base.bias_dps - c0) / k;
    let gyro = GyroSim { temperature: Some(TempCoupling { dps_per_c: k, ref_c, lag_s: lag }), ..refit };
    Some(EffectFit {
        effect: Effect::Temperature,
        params: json!({"dps_per_c": k, "lag_s": lag, "ref_c": ref_c, "t_stat": k / se}),
        n_params: 2,
        gyro,
        channel: None,
    })
}

//! The distribution of a residual as a Gaussian core plus a contaminating component, fitted by maximum likelihood.
//!
//! Model of a residual `r` (its median taken out): with probability `1 - eps` Gaussian noise of sd `sigma`; with
//! probability `eps` a spike `+-s` on that noise, its magnitude `s` uniform on `centre +- spread` (the law of
//! `octavar_shared::sim::Outliers`). The fit is on `|r|`, binned: bins of a tenth of a starting scale up to 8 of
//! them, then 4% wide, then one open bin, so a million residuals cost a few hundred bins. The survival function of
//! `|r|` has a closed form: `(1 - eps) 2 Q(x / sigma) + eps E_s[Q((x - s) / sigma) + Q((x + s) / sigma)]`, and the
//! mean over the uniform law is `sigma / (2 spread) [Psi((centre + spread - x) / sigma) - Psi((centre - spread -
//! x) / sigma)]` with `Psi(t) = t Phi(t) + phi(t)`, the antiderivative of the normal CDF.
//!
//! Why a likelihood on the whole distribution rather than a threshold: the core's scale is read where the core
//! dominates (a 20% contamination at 3 sigmas inflates the MAD by about a fifth, and spikes that stand under any
//! threshold would be lost), the share and the magnitude law from the tails, and the core and the spikes buried
//! in it are told apart by their shapes. The Gaussian alone is fitted the same way; twice the log-likelihood
//! gained is the evidence for contamination.

use super::super::common::normal_sf;

/// A fitted Gaussian core with a contaminating spike component.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Mixture {
    /// The core's sd, in the residual's units.
    pub sigma: f64,
    /// Share of residuals that carry a spike.
    pub eps: f64,
    /// Centre of the spikes' magnitude law.
    pub centre: f64,
    /// Half-width of the spikes' magnitude law.
    pub spread: f64,
    /// Twice the log-likelihood gained over the Gaussian alone.
    pub lr: f64,
}

/// `Psi(t) = t Phi(t) + phi(t)`, the antiderivative of the standard normal CDF.
fn psi(t: f64) -> f64 {
    t * normal_sf(-t) + (-0.5 * t * t).exp() / (2.0 * std::f64::consts::PI).sqrt()
}

impl Mixture {
    /// The mean over the magnitude law of `Phi((s - a) / sigma)`: P(s + noise > a) for a positive spike.
    fn mean_phi(&self, a: f64, sign: f64) -> f64 {
        let (c, w, sg) = (sign * self.centre, self.spread, self.sigma);
        if w <= 1e-6 * sg {
            return normal_sf((a - c) / sg);
        }
        (sg / (2.0 * w) * (psi((c + w - a) / sg) - psi((c - w - a) / sg))).clamp(0.0, 1.0)
    }

    /// P(|spike + noise| > x), x >= 0: P(s + noise > x) + P(-s - noise > x) for a positive spike of the magnitude
    /// law (the sign is symmetric).
    pub fn spike_sf(&self, x: f64) -> f64 {
        self.mean_phi(x, 1.0) + self.mean_phi(x, -1.0)
    }

    /// P(|r| > x), x >= 0.
    pub fn sf(&self, x: f64) -> f64 {
        (1.0 - self.eps) * 2.0 * normal_sf(x / self.sigma) + self.eps * self.spike_sf(x)
    }

    /// The density of |r| at x from the spike component against the core's (both weighted by their shares): the
    /// odds that a residual of size x is a spike.
    pub fn spike_odds(&self, x: f64) -> f64 {
        let h = 1e-3 * self.sigma;
        let core = (1.0 - self.eps) * 2.0 * (normal_sf((x - h) / self.sigma) - normal_sf((x + h) / self.sigma));
        let spike = self.eps * (self.spike_sf((x - h).max(0.0)) - self.spike_sf(x + h));
        spike / core.max(1e-300)
    }
}

/// Residual magnitudes, binned.
pub(super) struct Binned {
    /// Lower edges; the last bin is open above.
    edges: Vec<f64>,
    counts: Vec<f64>,
    n: f64,
}

impl Binned {
    /// Bin `|r|` (`abs`, every value finite and non-negative) on a grid of `scale` (a rough sd of the core).
    pub fn new(abs: &[f64], scale: f64) -> Binned {
        let top = abs.iter().copied().fold(0.0f64, f64::max);
        let mut edges: Vec<f64> = (0..80).map(|k| 0.1 * k as f64 * scale).collect();
        let mut e = 8.0 * scale;
        while e < top {
            edges.push(e);
            e *= 1.04;
        }
        let mut counts = vec![0.0; edges.len()];
        for &v in abs {
            let j = edges.partition_point(|&lo| lo <= v).saturating_sub(1);
            counts[j] += 1.0;
        }
        Binned { edges, counts, n: abs.len() as f64 }
    }

    /// The log-likelihood of a law given by its survival function.
    fn log_lik(&self, sf: impl Fn(f64) -> f64) -> f64 {
        let s: Vec<f64> = self.edges.iter().map(|&x| sf(x)).collect();
        let mut ll = 0.0;
        for j in 0..s.len() {
            if self.counts[j] == 0.0 {
                continue;
            }
            let p = if j + 1 < s.len() { s[j] - s[j + 1] } else { s[j] };
            ll += self.counts[j] * p.max(1e-300).ln();
        }
        ll
    }

    /// Share of the values at or beyond the bin edge nearest `x`.
    fn share_beyond(&self, x: f64) -> f64 {
        let j = self.edges.partition_point(|&lo| lo < x);
        self.counts[j.min(self.counts.len())..].iter().sum::<f64>() / self.n
    }
}

/// The Gaussian alone: its sd and log-likelihood.
fn fit_gaussian(b: &Binned, scale: f64) -> (f64, f64) {
    let (u, nll) = super::super::common::golden(scale.ln() - 1.5, scale.ln() + 1.5, 60, |u| {
        let sg = u.exp();
        -b.log_lik(|x| 2.0 * normal_sf(x / sg))
    });
    (u.exp(), -nll)
}

/// The mixture of the parameter vector `(ln sigma, logit(2 eps), ln (centre - least), logit(spread / (centre -
/// least)))`: the magnitude law's lower edge held beyond `least`.
fn decode(th: &[f64; 4], least: f64) -> Mixture {
    let logistic = |v: f64| 1.0 / (1.0 + (-v).exp());
    let above = th[2].exp();
    Mixture {
        sigma: th[0].exp(),
        eps: 0.5 * logistic(th[1]),
        centre: least + above,
        spread: above * logistic(th[3]),
        lr: 0.0,
    }
}

fn encode(m: &Mixture, least: f64) -> [f64; 4] {
    let logit = |p: f64| (p / (1.0 - p)).ln();
    let above = (m.centre - least).max(1e-3 * m.centre);
    [m.sigma.ln(), logit(2.0 * m.eps), above.ln(), logit((m.spread / above).clamp(1e-4, 1.0 - 1e-4))]
}

/// The mixture of largest likelihood for residual magnitudes `abs` (finite, non-negative, at least 64), the
/// spikes' magnitudes beyond `least` (0: anywhere), from a few starts over the magnitude law's centre; `None` when the
/// data have no scale.
pub(super) fn fit(abs: &[f64], least: f64) -> Option<Mixture> {
    if abs.len() < 64 {
        return None;
    }
    // A rough core scale from the quarter quantile of |r| (0.3186 sd for a Gaussian): a contamination of 20%
    // moves it by about a quarter, which the fit corrects.
    let mut tmp = abs.to_vec();
    let k = tmp.len() / 4;
    let (_, q25, _) = tmp.select_nth_unstable_by(k, f64::total_cmp);
    let mut scale = *q25 / 0.3186;
    if !(scale > 0.0) {
        scale = 1.2533 * abs.iter().sum::<f64>() / abs.len() as f64;
    }
    if !(scale > 0.0 && scale.is_finite()) {
        return None;
    }
    let b = Binned::new(abs, scale);
    let (sigma_g, ll_g) = fit_gaussian(&b, scale);
    let nll = |th: &[f64; 4]| -b.log_lik(|x| decode(th, least).sf(x));
    let mut best: Option<([f64; 4], f64)> = None;
    for centre in [3.0, 4.5, 7.0, 11.0, 18.0, 30.0, 50.0] {
        let c = (centre * sigma_g).max(1.25 * least);
        // The share beyond the centre less a sd, less what the Gaussian puts there: where the spikes are.
        let excess = b.share_beyond((centre - 1.0) * sigma_g) - 2.0 * normal_sf(centre - 1.0);
        let eps = (2.0 * excess).clamp(1e-6, 0.45);
        let start = Mixture { sigma: sigma_g, eps, centre: c, spread: 0.3 * c, lr: 0.0 };
        let (th, v) = nelder_mead(encode(&start, least), 0.3, 400, nll);
        if best.is_none_or(|(_, bv)| v < bv) {
            best = Some((th, v));
        }
    }
    let (th, _) = best?;
    let (th, v) = nelder_mead(th, 0.1, 600, nll);
    let mut m = decode(&th, least);
    m.lr = 2.0 * (-v - ll_g);
    (m.sigma.is_finite() && m.sigma > 0.0).then_some(m)
}

/// Nelder-Mead minimisation of `f` from `x0` with initial steps `step`, at most `iters` iterations.
fn nelder_mead(x0: [f64; 4], step: f64, iters: usize, f: impl Fn(&[f64; 4]) -> f64) -> ([f64; 4], f64) {
    const D: usize = 4;
    let mut pts: Vec<([f64; D], f64)> = (0..=D)
        .map(|i| {
            let mut x = x0;
            if i > 0 {
                x[i - 1] += step;
            }
            (x, f(&x))
        })
        .collect();
    let fin = |v: f64| if v.is_finite() { v } else { f64::INFINITY };
    for p in &mut pts {
        p.1 = fin(p.1);
    }
    for _ in 0..iters {
        pts.sort_by(|a, b| a.1.total_cmp(&b.1));
        if (pts[D].1 - pts[0].1).abs() < 1e-9 * (1.0 + pts[0].1.abs()) {
            break;
        }
        let mut cen = [0.0; D];
        for p in &pts[..D] {
            for k in 0..D {
                cen[k] += p.0[k] / D as f64;
            }
        }
        let along = |t: f64| -> [f64; D] { core::array::from_fn(|k| cen[k] + t * (pts[D].0[k] - cen[k])) };
        let xr = along(-1.0);
        let fr = fin(f(&xr));
        if fr < pts[0].1 {
            let xe = along(-2.0);
            let fe = fin(f(&xe));
            pts[D] = if fe < fr { (xe, fe) } else { (xr, fr) };
        } else if fr < pts[D - 1].1 {
            pts[D] = (xr, fr);
        } else {
            let xc = if fr < pts[D].1 { along(-0.5) } else { along(0.5) };
            let fc = fin(f(&xc));
            if fc < pts[D].1.min(fr) {
                pts[D] = (xc, fc);
            } else {
                let best = pts[0].0;
                for p in &mut pts[1..] {
                    p.0 = core::array::from_fn(|k| best[k] + 0.5 * (p.0[k] - best[k]));
                    p.1 = fin(f(&p.0));
                }
            }
        }
    }
    pts.sort_by(|a, b| a.1.total_cmp(&b.1));
    pts[0]
}

//! Fitting effects on the Allan curve: the exact Allan forms of an AR(1), a Gauss-Markov process and low-passed
//! white noise, the base-term columns (N, B, K, R, Q), and the weighted non-negative joint fit over subsets of
//! terms that the bandwidth and Gauss-Markov estimators share.

use octavar_shared::sim::flicker::{FIRST_WEIGHT, FLICKER_PROCESSES};
use octavar_shared::sim::noise::ResonanceCoefficients;
use octavar_shared::sim::{GaussMarkovSim, GyroSim};
use rustfft::num_complex::Complex64;

use super::lattice::{rounds_white, white_rounding_avar, LatticeExcess};
use super::lowpass::lowpass_pole;

use octavar_stats::fit::{FitPoint, FLICKER_AVAR_FACTOR};

/// Allan variance at `m` samples of a unit-variance discrete AR(1) of pole `a` (autocovariance `a^|k|`):
/// `[m (1+a)/(1-a) - a (2u + u^2)/(1-a)^2] / m^2`, `u = 1 - a^m` (the form in shared::sim::noise).
pub(super) fn ar1_avar(a: f64, m: f64) -> f64 {
    if a <= 0.0 {
        return 1.0 / m;
    }
    let la = a.ln();
    let oma = -la.exp_m1();
    let u = -(m * la).exp_m1();
    (m * (1.0 + a) / oma - a * (2.0 * u + u * u) / (oma * oma)) / (m * m)
}

/// Allan variance of a unit-variance Gauss-Markov process of correlation time `t_s`, sampled every `tau0`, at
/// `tau`: the exact discrete AR(1) form while T is within a thousand samples, else the continuous form
/// `2 T/tau [1 - T/(2 tau)(3 - 4 e^{-tau/T} + e^{-2 tau/T})]` (IEEE 952 Annex C; series at small tau/T).
pub(super) fn gm_avar(t_s: f64, tau: f64, tau0: f64) -> f64 {
    let m = (tau / tau0).round().max(1.0);
    if t_s / tau0 <= 1000.0 {
        return ar1_avar((-tau0 / t_s).exp(), m);
    }
    let x = tau / t_s;
    let shape = if x < 1e-3 {
        x * x / 3.0 - x * x * x / 4.0
    } else {
        1.0 - (4.0 * (-(-x).exp_m1()) - (-(-2.0 * x).exp_m1())) / (2.0 * x)
    };
    2.0 * shape / x
}

/// Allan variance at `m` samples of the unit-variance resonance (the damped oscillator read at each sample, as
/// [`octavar_shared::sim::noise::Resonance`] draws it), from its autocovariance `Re((1 - i c) z^k)`,
/// `z = r e^{i theta}`, `c = zeta / sqrt(1 - zeta^2)`: `(4 G(m) - G(2m)) / (2 m^2)`, with the variance of a
/// sum of n samples `G(n) = n + 2 Re((1 - i c) S(n))`, `S(n) = sum_{k=1}^{n-1} (n - k) z^k
/// = (z^{n+1} - n z^2 + (n - 1) z) / (1 - z)^2`.
pub(super) fn resonance_avar(freq_hz: f64, q: f64, m: f64, rate_hz: f64) -> f64 {
    type Complex = Complex64;
    let zeta = 0.5 / q;
    let w0 = 2.0 * std::f64::consts::PI * freq_hz / rate_hz;
    let r = (-zeta * w0).exp();
    let theta = w0 * (1.0 - zeta * zeta).sqrt();
    let c = zeta / (1.0 - zeta * zeta).sqrt();
    let z = Complex::from_polar(r, theta);
    let one = Complex::new(1.0, 0.0);
    let g = |n: f64| {
        let s = (z.powf(n + 1.0) - z * z * n + z * (n - 1.0)) / ((one - z) * (one - z));
        n + 2.0 * (Complex::new(1.0, -c) * s).re
    };
    let m = m.round().max(1.0);
    (4.0 * g(m) - g(2.0 * m)) / (2.0 * m * m)
}

/// Allan variance at `m` samples of the discrete autoregressive process with the distinct poles `poles`, driven
/// by white noise of unit variance: its autocovariance is `gamma(k) = sum_i A_i p_i^k`, `A_i = p_i^(P-1) /
/// (prod_{j != i} (p_i - p_j) prod_j (1 - p_i p_j))` for P poles (the AR(p) covariance in partial fractions), and
/// the Allan variance `(4 G(m) - G(2m)) / (2 m^2)` with `G(n) = n gamma(0) + 2 Re sum_i A_i S_i(n)`, `S_i` as in
/// [`resonance_avar`]. Poles closer than 1e-9 are moved apart by that much (the form has no limit written out).
///
/// With a moving-average term `ma` (`ma = 0`: the autoregressive process itself), the process is `x_n + ma x_{n-1}`
/// for the autoregressive `x`: its autocovariance is `(1 + ma^2) gamma(k) + ma (gamma(k - 1) + gamma(k + 1))`, so
/// each coefficient becomes `A_i ((1 + ma^2) + ma (p_i + 1 / p_i))` at lags from one, and
/// `gamma(0) = sum_i A_i (1 + ma^2 + 2 ma p_i)`.
pub(super) fn arma_avar(poles: &[Complex64], ma: f64, m: f64) -> f64 {
    let one = Complex64::new(1.0, 0.0);
    let mut p: Vec<Complex64> = poles.to_vec();
    for i in 1..p.len() {
        for j in 0..i {
            if (p[i] - p[j]).norm() < 1e-9 {
                p[i] *= 1.0 - 2e-9;
            }
        }
    }
    let order = p.len() as i32;
    // Per pole, `A_i` and `A_i / p_i` (written as `p_i^(P-2) / den`, finite where a pole sits at zero: a corner
    // far above the band).
    let parts: Vec<(Complex64, Complex64)> = p
        .iter()
        .enumerate()
        .map(|(i, &pi)| {
            let mut den = one;
            for (j, &pj) in p.iter().enumerate() {
                if j != i {
                    den *= pi - pj;
                }
                den *= one - pi * pj;
            }
            let over_p = if ma == 0.0 { Complex64::new(0.0, 0.0) } else { pi.powi(order - 2) / den };
            (pi.powi(order - 1) / den, over_p)
        })
        .collect();
    let gamma0: f64 = parts.iter().zip(&p).map(|((a, _), &pi)| (a * (1.0 + ma * ma + 2.0 * ma * pi)).re).sum();
    let coeffs: Vec<Complex64> =
        parts.iter().zip(&p).map(|(&(a, over_p), &pi)| a * (1.0 + ma * ma + ma * pi) + ma * over_p).collect();
    let g = |n: f64| {
        let s: f64 = coeffs
            .iter()
            .zip(&p)
            .map(|(a, &z)| (a * (z.powf(n + 1.0) - z * z * n + z * (n - 1.0)) / ((one - z) * (one - z))).re)
            .sum();
        n * gamma0 + 2.0 * s
    };
    let m = m.round().max(1.0);
    (4.0 * g(m) - g(2.0 * m)) / (2.0 * m * m)
}

/// Allan variance at `m` samples of the unit-variance ARMA process with `poles` and the moving-average term `ma`
/// (`innovation_var`, the variance of the white noise driving it, gives the unit variance) after the low-pass at
/// `f3db_hz` (none: the process itself), as shared::sim adds a resonance, a Gauss-Markov process or a bistable
/// bias before its output bandwidth: the low-pass adds its pole and scales the driving noise by `(1 - a)^2`.
fn through_lowpass(
    poles: &[Complex64],
    ma: f64,
    innovation_var: f64,
    f3db_hz: Option<f64>,
    m: f64,
    rate_hz: f64,
) -> f64 {
    match f3db_hz {
        Some(f) if f > 0.0 => {
            let a = lowpass_pole(f, rate_hz);
            let mut all = poles.to_vec();
            all.push(Complex64::new(a, 0.0));
            innovation_var * (1.0 - a) * (1.0 - a) * arma_avar(&all, ma, m)
        }
        _ => innovation_var * arma_avar(poles, ma, m),
    }
}

/// Allan variance at `m` samples of the unit-variance resonance of shared::sim after the low-pass at `f3db_hz`
/// ([`resonance_avar`] without one).
pub(super) fn filtered_resonance_avar(freq_hz: f64, q: f64, f3db_hz: Option<f64>, m: f64, rate_hz: f64) -> f64 {
    if f3db_hz.is_none() {
        return resonance_avar(freq_hz, q, m, rate_hz);
    }
    let c = ResonanceCoefficients::of(freq_hz, q, 1.0 / rate_hz);
    // The roots of z^2 - a1 z - a2: a complex pair for Q > 1/2.
    let disc = Complex64::new(c.a1 * c.a1 + 4.0 * c.a2, 0.0).sqrt();
    let poles = [(Complex64::new(c.a1, 0.0) + disc) / 2.0, (Complex64::new(c.a1, 0.0) - disc) / 2.0];
    through_lowpass(&poles, c.ma, c.s * c.s, f3db_hz, m, rate_hz)
}

/// Allan variance at `tau` of a unit-variance Gauss-Markov process of correlation time `t_s` after the low-pass at
/// `f3db_hz` ([`gm_avar`] without one, or where T is beyond a thousand samples: the low-pass, whose corner is at
/// least rate_hz/2000, then hardly touches it).
pub(super) fn filtered_gm_avar(t_s: f64, f3db_hz: Option<f64>, tau: f64, rate_hz: f64) -> f64 {
    let tau0 = 1.0 / rate_hz;
    match f3db_hz {
        Some(_) if t_s / tau0 <= 1000.0 => {
            let a = (-tau0 / t_s).exp();
            through_lowpass(&[Complex64::new(a, 0.0)], 0.0, 1.0 - a * a, f3db_hz, tau / tau0, rate_hz)
        }
        _ => gm_avar(t_s, tau, tau0),
    }
}

/// The Allan variance at `tau` of the stochastic effects `model` already carries beyond the base terms whose
/// realisation is still in the samples (a resonance, a Gauss-Markov process, each with its closed form), after the
/// output bandwidth `f3db_hz` as the simulator applies it, which an estimator fitting the base terms and one more
/// effect on the Allan curve must not take for its own. A bistable bias is not among them: the step that names it
/// takes its levels out of the samples ([`TrainingData::shaped_dps`] carries them).
pub(super) fn known_avar(model: &GyroSim, f3db_hz: Option<f64>, tau: f64, rate_hz: f64) -> f64 {
    let mut v = 0.0;
    if let Some(r) = &model.resonance {
        v += r.sigma_dps * r.sigma_dps * filtered_resonance_avar(r.freq_hz, r.q, f3db_hz, tau * rate_hz, rate_hz);
    }
    if let Some(g) = &model.gauss_markov {
        v += g.sigma_dps * g.sigma_dps * filtered_gm_avar(g.tau_s, f3db_hz, tau, rate_hz);
    }
    v
}

/// `pts` less the Allan variance of the effects `model` already carries ([`known_avar`], through the bandwidth
/// `f3db_hz`) and of the rounding to an ADC lattice of step `lattice_dps` over the analog rate `model` describes
/// ([`LatticeExcess`]), each point kept at no less than a tenth of its own value (the rest is what the fit has to
/// explain): the analog rate's curve, which the model sends through the lattice.
pub(super) fn less_known(
    pts: &[FitPoint],
    model: &GyroSim,
    f3db_hz: Option<f64>,
    rate_hz: f64,
    lattice_dps: Option<f64>,
) -> Vec<FitPoint> {
    less_known_over(pts, model, model, f3db_hz, rate_hz, lattice_dps)
}

/// [`less_known`] with the lattice's share taken over the analog rate of `analog` (the base terms a fit on this
/// curve just read) rather than of `model`.
pub(super) fn less_known_over(
    pts: &[FitPoint],
    model: &GyroSim,
    analog: &GyroSim,
    f3db_hz: Option<f64>,
    rate_hz: f64,
    lattice_dps: Option<f64>,
) -> Vec<FitPoint> {
    let lattice = lattice_excess(pts, analog, f3db_hz, rate_hz, lattice_dps);
    less_model_and(pts, model, f3db_hz, rate_hz, |tau| lattice.as_ref().map_or(0.0, |l| l.at(tau, rate_hz)))
}

/// `raw` less what `known` carries, under the output bandwidth `f3db_hz` ([`less_known`]); under an ADC lattice of
/// step `lattice_dps`, the rounding's share depends on how smooth the analog rate is, so N, B and K are read on
/// that curve once (Q where `with_q`) and the lattice taken off over them, with `markov` beside them: each corner a
/// search tries gets the analog rate's curve as that corner would have it.
pub(super) fn analog_curve(
    raw: &[FitPoint],
    known: &GyroSim,
    markov: Option<GaussMarkovSim>,
    f3db_hz: Option<f64>,
    rate_hz: f64,
    lattice_dps: Option<f64>,
    with_q: bool,
) -> Vec<FitPoint> {
    let pts = less_known(raw, known, f3db_hz, rate_hz, lattice_dps);
    if lattice_dps.is_none() {
        return pts;
    }
    match joint_fit_keeping(&pts, &base_columns(&pts, rate_hz, f3db_hz, with_q), 0) {
        Some(j) => {
            let analog = GyroSim { gauss_markov: markov, ..with_base_terms(known, &j.theta) };
            less_known_over(raw, known, &analog, f3db_hz, rate_hz, lattice_dps)
        }
        None => pts,
    }
}

/// `pts` less the Allan variance of the effects `model` already carries ([`known_avar`]): the noise of the samples
/// as recorded, which a generalised least-squares test on them weighs by. An ADC lattice's rounding is part of it:
/// where the rounding is white (the rate moves by more than a step from sample to sample) its `step^2 / 12` a
/// sample is taken off, and the IEEE terms hold the analog white noise it joins; where it is not, the rounded
/// record holds a value and then moves a whole step, no IEEE term has that shape, and the analog terms
/// ([`less_known`]) would weigh its block means as far steadier than they are.
pub(super) fn less_known_as_recorded(
    pts: &[FitPoint],
    model: &GyroSim,
    f3db_hz: Option<f64>,
    rate_hz: f64,
    lattice_dps: Option<f64>,
) -> Vec<FitPoint> {
    let white = lattice_dps.filter(|&q| rounds_white(q, model, f3db_hz, rate_hz));
    less_model_and(pts, model, f3db_hz, rate_hz, |tau| white.map_or(0.0, |q| white_rounding_avar(q, tau, rate_hz)))
}

/// `pts` less [`known_avar`] of `model` and `rounding` (the lattice's share at a tau), each point kept at no less
/// than a tenth of its own value.
fn less_model_and(
    pts: &[FitPoint],
    model: &GyroSim,
    f3db_hz: Option<f64>,
    rate_hz: f64,
    rounding: impl Fn(f64) -> f64,
) -> Vec<FitPoint> {
    pts.iter()
        .map(|p| {
            let known = known_avar(model, f3db_hz, p.tau_s, rate_hz) + rounding(p.tau_s);
            FitPoint { avar: (p.avar - known).max(0.1 * p.avar), ..*p }
        })
        .collect()
}

/// Whether an ADC lattice of step `lattice_dps` rounds the analog rate of `model` coarser than white noise (the
/// rate moves by less than a step from sample to sample).
pub(super) fn coarse_lattice(model: &GyroSim, rate_hz: f64, lattice_dps: Option<f64>) -> bool {
    lattice_dps.is_some_and(|q| !rounds_white(q, model, model.bandwidth_hz, rate_hz))
}

/// The lattice's share of the Allan variance at the taus of `pts`, over the analog rate of `analog` through
/// `f3db_hz`; `None` without a lattice.
pub(super) fn lattice_excess(
    pts: &[FitPoint],
    analog: &GyroSim,
    f3db_hz: Option<f64>,
    rate_hz: f64,
    lattice_dps: Option<f64>,
) -> Option<LatticeExcess> {
    let max_m = pts.iter().map(|p| p.tau_s * rate_hz).fold(1.0, f64::max);
    lattice_dps.map(|q| LatticeExcess::new(q, analog, f3db_hz, rate_hz, max_m))
}

/// Allan variance of white rate noise of unit N (per-sample variance rate_hz) through the sampled first-order
/// low-pass `y = a y + (1 - a) x`, `a = exp(-2 pi f3dB / rate_hz)`, as shared::sim applies it: an AR(1) of variance
/// `fs (1 - a)/(1 + a)`. Tends to `fit::lowpass_white_factor(tau/T) / tau` when T >> tau0.
pub(super) fn lowpass_white_avar(f3db: Option<f64>, tau: f64, rate_hz: f64) -> f64 {
    let m = (tau * rate_hz).round().max(1.0);
    match f3db {
        Some(f) if f > 0.0 => {
            let a = lowpass_pole(f, rate_hz);
            rate_hz * (1.0 - a) / (1.0 + a) * ar1_avar(a, m)
        }
        _ => rate_hz / m,
    }
}

/// Allan variance at `tau` per unit B^2 of flicker noise after the low-pass at `f3db` (the flat floor
/// [`FLICKER_AVAR_FACTOR`] without one). A sensor's output bandwidth filters its flicker as it filters its white
/// noise, and at taus near the corner the floor bends down; a fit that kept the flat column there would read B
/// (and with it N) wrong. shared::sim makes flicker as a bank of AR(1) processes of correlation time `2^j` samples,
/// each of variance `B^2 ln 2 / pi` (the fastest [`FIRST_WEIGHT`] times that), and sends their sum through the
/// low-pass: the floor is corrected by what the low-pass takes from each process, for the processes within 64
/// filter time constants (slower ones it leaves as they are).
pub(super) fn lowpass_flicker_avar(f3db: Option<f64>, tau: f64, rate_hz: f64) -> f64 {
    let Some(f) = f3db.filter(|f| *f > 0.0) else {
        return FLICKER_AVAR_FACTOR;
    };
    let m = (tau * rate_hz).round().max(1.0);
    let var = std::f64::consts::LN_2 / std::f64::consts::PI;
    let filter_samples = rate_hz / (2.0 * std::f64::consts::PI * f);
    let mut v = FLICKER_AVAR_FACTOR;
    for j in 0..FLICKER_PROCESSES as i32 {
        let t = 2f64.powi(j);
        if t > 64.0 * filter_samples.max(1.0) {
            break;
        }
        let weight = if j == 0 { FIRST_WEIGHT } else { 1.0 };
        let a = (-1.0 / t).exp();
        let filtered = through_lowpass(&[Complex64::new(a, 0.0)], 0.0, 1.0 - a * a, Some(f), m, rate_hz);
        v += weight * var * (filtered - ar1_avar(a, m));
    }
    v.max(0.0)
}

/// A weighted non-negative least-squares fit of AVAR = sum theta_j col_j, weights from the model (IRLS), every
/// subset of columns tried; the score is the log-domain chi-square sum (ln avar - ln model)^2 / (2/edf + e^2)
/// that `fit::fit` minimises.
pub(super) struct Joint {
    pub(super) theta: Vec<f64>,
    pub(super) chi2: f64,
}

pub(super) const MODEL_ERROR2: f64 = 0.03 * 0.03;

pub(super) fn joint_fit(pts: &[FitPoint], cols: &[Vec<f64>]) -> Option<Joint> {
    joint_fit_keeping(pts, cols, 0)
}

/// [`joint_fit`] over the subsets of columns that hold every column of the bit mask `keep` (a joint
/// re-estimation keeps the effects the chain named, however small the curve finds them).
pub(super) fn joint_fit_keeping(pts: &[FitPoint], cols: &[Vec<f64>], keep: u32) -> Option<Joint> {
    let p = cols.len();
    let np = pts.len();
    if np < 2 || p == 0 {
        return None;
    }
    let rel: Vec<f64> = pts.iter().map(|q| 2.0 / q.edf + MODEL_ERROR2).collect();
    let mut var: Vec<f64> = pts.iter().zip(&rel).map(|(q, r)| q.avar * q.avar * r).collect();
    let mut best: Option<Vec<f64>> = None;
    for _ in 0..5 {
        let mut round: Option<(f64, Vec<f64>)> = None;
        for mask in (1u32..(1 << p)).filter(|m| m & keep == keep) {
            let act: Vec<usize> = (0..p).filter(|j| mask & (1 << j) != 0).collect();
            if act.len() > np {
                continue;
            }
            let k = act.len();
            let mut a = vec![vec![0.0; k]; k];
            let mut b = vec![0.0; k];
            let scale: Vec<f64> =
                act.iter().map(|&j| (0..np).map(|i| cols[j][i] * cols[j][i] / var[i]).sum::<f64>().sqrt()).collect();
            if scale.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
                continue;
            }
            for i in 0..np {
                for (r, &jr) in act.iter().enumerate() {
                    let xr = cols[jr][i] / scale[r];
                    b[r] += xr * pts[i].avar / var[i];
                    for (c, &jc) in act.iter().enumerate() {
                        a[r][c] += xr * cols[jc][i] / scale[c] / var[i];
                    }
                }
            }
            let Some(sol) = solve(a, b) else { continue };
            if sol.iter().any(|v| *v < 0.0 || !v.is_finite()) {
                continue;
            }
            let mut theta = vec![0.0; p];
            for (r, &j) in act.iter().enumerate() {
                theta[j] = sol[r] / scale[r];
            }
            let chi: f64 = (0..np)
                .map(|i| {
                    let m: f64 = (0..p).map(|j| theta[j] * cols[j][i]).sum();
                    (pts[i].avar - m).powi(2) / var[i]
                })
                .sum();
            // Akaike's penalty per active term: a term must buy more than 2 in chi-square (a ramp bending the
            // top two octaves would otherwise trade against the flicker floor and a Gauss-Markov time).
            let aic = chi + 2.0 * k as f64;
            if round.as_ref().is_none_or(|(c, _)| aic < *c) {
                round = Some((aic, theta));
            }
        }
        let (_, theta) = round?;
        for i in 0..np {
            let m: f64 = (0..p).map(|j| theta[j] * cols[j][i]).sum();
            let m = if m > 0.0 { m } else { pts[i].avar };
            var[i] = m * m * rel[i];
        }
        best = Some(theta);
    }
    let theta = best?;
    let chi2 = log_chi2(pts, |i| (0..p).map(|j| theta[j] * cols[j][i]).sum());
    Some(Joint { theta, chi2 })
}

pub(super) fn log_chi2(pts: &[FitPoint], model: impl Fn(usize) -> f64) -> f64 {
    pts.iter()
        .enumerate()
        .map(|(i, q)| {
            let m = model(i).max(1e-300);
            (q.avar.ln() - m.ln()).powi(2) / (2.0 / q.edf + MODEL_ERROR2)
        })
        .sum()
}

/// Solve the normal equations of an effect's fit; `None` when singular (a pivot of at most 1e-13).
pub(super) fn solve(a: Vec<Vec<f64>>, b: Vec<f64>) -> Option<Vec<f64>> {
    octavar_stats::linalg::solve(a, b, 1e-13)
}

/// Number of base-term columns ([`base_columns`]); an effect's own column comes after them.
pub(super) const BASE_COLS: usize = 5;

/// The columns of the base terms N (shaped by `bw`), B, K, R and Q at the points' taus, N per unit N^2. The Q
/// column is all zero (so [`joint_fit`] never uses it) unless `with_q`: the base fit's choice, for at the
/// shortest taus angle white noise and a low-pass corner or a fast Gauss-Markov trade against each other.
pub(super) fn base_columns(pts: &[FitPoint], rate_hz: f64, bw: Option<f64>, with_q: bool) -> Vec<Vec<f64>> {
    let q = if with_q { 3.0 } else { 0.0 };
    vec![
        pts.iter().map(|p| lowpass_white_avar(bw, p.tau_s, rate_hz)).collect(),
        pts.iter().map(|p| lowpass_flicker_avar(bw, p.tau_s, rate_hz)).collect(),
        pts.iter().map(|p| p.tau_s / 3.0).collect(),
        pts.iter().map(|p| p.tau_s * p.tau_s / 2.0).collect(),
        pts.iter().map(|p| q / (p.tau_s * p.tau_s)).collect(),
    ]
}

/// The Allan variance of `base`'s IEEE terms (N, B, K, R, Q, through its bandwidth) at the taus of `pts`, each
/// point's EDF kept.
pub(super) fn base_curve(base: &GyroSim, pts: &[FitPoint], rate_hz: f64) -> Vec<FitPoint> {
    let cols = base_columns(pts, rate_hz, base.bandwidth_hz, true);
    let b = base;
    let squares = [b.n_deg_per_rt_s, b.b_dps, b.k_dps_per_rt_s, b.r_dps_per_s, b.q_deg].map(|v| v * v);
    pts.iter()
        .enumerate()
        .map(|(i, p)| FitPoint { avar: (0..squares.len()).map(|j| squares[j] * cols[j][i]).sum(), ..*p })
        .collect()
}

/// The base model with its N, B, K, R and Q replaced by the fitted squares.
pub(super) fn with_base_terms(base: &GyroSim, theta: &[f64]) -> GyroSim {
    GyroSim {
        n_deg_per_rt_s: theta[0].max(0.0).sqrt(),
        b_dps: theta[1].max(0.0).sqrt(),
        k_dps_per_rt_s: theta[2].max(0.0).sqrt(),
        r_dps_per_s: theta[3].max(0.0).sqrt(),
        q_deg: theta[4].max(0.0).sqrt(),
        ..base.clone()
    }
}

/// Minimum log-domain chi-square improvement for an effect fitted on the OADEV curve to count (the model-error
/// floor of 3% already keeps the first octaves from dominating).
pub(super) const CURVE_DELTA_CHI2: f64 = 30.0;

/// `cleaned`'s points (the curve of samples less a component fitted to them, `t` standard errors from zero) with
/// their uncertainty widened by what the fit took of the noise. A component fitted by least squares takes the
/// noise's projection on it too, as much as its own estimation error: at each tau about `1 / t^2` of the
/// component's Allan variance there (`record`'s less `cleaned`'s). Where the component dominated the record's
/// curve and was fitted loosely (a temperature response at t = 7.6 over 1.75 cycles of its driver), what is
/// left is the noise less a part fitted away, low by more than its chi-square spread: the flicker at 330 s stood
/// at a quarter of the truth, and the base fit read B at two thirds of it. Each point's log-domain variance
/// `2 / edf` grows by the square of that share of its Allan variance; a sinusoid fitted hundreds of standard
/// errors from zero leaves its points as they are.
pub(super) fn weighed_by_fit_error(cleaned: &[FitPoint], record: &[FitPoint], t: f64) -> Vec<FitPoint> {
    cleaned
        .iter()
        .map(|p| {
            let taken = record.iter().find(|q| q.tau_s == p.tau_s).map_or(0.0, |q| (q.avar - p.avar).max(0.0));
            let error = if p.avar > 0.0 { taken / p.avar / (t * t) } else { 0.0 };
            FitPoint { edf: 2.0 / (2.0 / p.edf + error * error), ..*p }
        })
        .collect()
}

/// `base` with its IEEE terms re-fitted jointly on the OADEV points `pts` (a component's own Allan variance
/// already taken out of them), with no ramp the base fit did not have (an all-zero column is never used); `base`
/// as it is when fewer than three points are left or the fit fails.
pub(super) fn refit_base_terms(base: &GyroSim, pts: &[FitPoint], rate_hz: f64) -> GyroSim {
    if pts.len() < 3 {
        return base.clone();
    }
    let mut cols = base_columns(pts, rate_hz, base.bandwidth_hz, base.q_deg > 0.0);
    if base.r_dps_per_s == 0.0 {
        cols[3].iter_mut().for_each(|v| *v = 0.0);
    }
    match joint_fit(pts, &cols) {
        Some(j) => with_base_terms(base, &j.theta),
        None => base.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::common::oadev_points;

    /// The quantisation noise of a lattice over noise several steps wide is white of `step^2 / 12` per sample:
    /// the Allan variance of the rounding error itself is `step^2 / 12 / m` at every octave, and [`less_known`]
    /// takes it off the rounded record's curve, leaving the analog record's.
    #[test]
    fn an_adc_lattice_comes_off_the_allan_curve() {
        let rate_hz = 100.0;
        let step = 0.01;
        let analog: Vec<f64> = octavar_stats::test_signals::white(1 << 20, 11).iter().map(|v| 4.0 * step * v).collect();
        let rounded: Vec<f64> = analog.iter().map(|v| (v / step).round() * step).collect();
        let error: Vec<f64> = rounded.iter().zip(&analog).map(|(r, a)| r - a).collect();
        for p in oadev_points(&error, rate_hz).iter().filter(|p| p.edf > 1000.0) {
            let want = step * step / 12.0 / (p.tau_s * rate_hz);
            assert!((p.avar / want - 1.0).abs() < 6.0 / p.edf.sqrt(), "tau {}: {} for {want}", p.tau_s, p.avar);
        }
        let plain = oadev_points(&analog, rate_hz);
        let with_lattice = oadev_points(&rounded, rate_hz);
        let model = GyroSim { n_deg_per_rt_s: 4.0 * step / rate_hz.sqrt(), ..Default::default() };
        let cleaned = less_known(&with_lattice, &model, None, rate_hz, Some(step));
        // At the shortest tau the lattice's noise is a 1/192 share of the rounded curve: taken off, the analog
        // curve is met to a tenth of that.
        let ratio = |a: &FitPoint, b: &FitPoint| a.avar / b.avar - 1.0;
        assert!(ratio(&with_lattice[0], &plain[0]) > 0.004, "the lattice shows at tau0");
        assert!(ratio(&cleaned[0], &plain[0]).abs() < 0.0005, "{} vs {}", cleaned[0].avar, plain[0].avar);
    }

    /// Flicker through the output bandwidth: the Allan variance of shared::sim's flicker after its low-pass
    /// follows [`lowpass_flicker_avar`] at every octave, down to the taus near the corner, where the flat floor is
    /// several times too high (a bandwidth fitted with the flat column read B and N wrong there).
    #[test]
    fn flicker_through_the_output_bandwidth_bends_below_its_floor() {
        use octavar_shared::sensor::{Channel, ADXRS300};
        use octavar_shared::sim::VirtualGyro;
        let (rate_hz, f3db) = (100.0, 5.0);
        let model = GyroSim { b_dps: 0.01, bandwidth_hz: Some(f3db), ..Default::default() };
        let mut g = VirtualGyro::new(&model, Channel::bench(ADXRS300), rate_hz, 5).unwrap();
        let x: Vec<f64> = (0..1 << 21).map(|_| g.next_rate(25.0)).collect();
        let b2 = model.b_dps * model.b_dps;
        let mut flat_off = 0.0f64;
        for p in oadev_points(&x, rate_hz).iter().filter(|p| p.edf > 2000.0) {
            let want = b2 * lowpass_flicker_avar(Some(f3db), p.tau_s, rate_hz);
            // From 4 samples the bank's design is within 1% of flicker, beside the estimate's scatter of a few
            // 1/sqrt(edf); at 1-2 samples its fastest processes stand in for all the faster ones, and the filter
            // has left a fifteenth of the floor there.
            let tol = if p.tau_s * rate_hz < 4.0 { 0.15 } else { 0.015 + 4.0 / p.edf.sqrt() };
            assert!((p.avar / want - 1.0).abs() < tol, "tau {}: {} for {want}", p.tau_s, p.avar);
            flat_off = flat_off.max(b2 * FLICKER_AVAR_FACTOR / p.avar - 1.0);
        }
        assert!(flat_off > 2.0, "the flat floor is {flat_off} above the filtered flicker at most");
        assert_eq!(lowpass_flicker_avar(None, 0.01, rate_hz), FLICKER_AVAR_FACTOR);
    }
}

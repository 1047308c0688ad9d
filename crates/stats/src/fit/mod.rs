//! The IEEE 952 noise-term fit: Q, N, B, K, R from an Allan variance curve, with confidence intervals.
//!
//! The Allan variance of the five classic gyro terms is linear in their squares:
//!
//! ```text
//! AVAR(tau) = 3 Q^2 / tau^2 + N^2 / tau + (2 ln 2 / pi) B^2 + K^2 tau / 3 + R^2 tau^2 / 2
//! ```
//!
//! so the squares are fitted, never negative, in two stages:
//!
//! 1. a weighted linear least squares on AVAR seeds the fit: each tau weighted by the variance of its own
//!    estimate, `AVAR^2 (2 / edf + e^2)` (chi-square with `edf` equivalent degrees of freedom, plus a model-error
//!    floor `e`), the variance taken from the model and iterated, every subset of the terms solved and the
//!    feasible one of least chi-square kept;
//! 2. the estimate proper is a fit in the log domain: `ln AVAR` errs by about `sqrt(2 / edf + e^2)` whichever
//!    way it errs, so `chi2 = sum (ln avar - ln model)^2 / (2 / edf + e^2)` is minimised over every subset of the
//!    terms (Levenberg-Marquardt in the logs of the squares, from the seed), and the subset is chosen by AIC
//!    (`chi2 + 2 p`). A model that overshoots a noisy tail cannot look good here, as it can in the linear weights.
//!
//! Each coefficient gets a confidence interval that accounts for the correlation of the Allan variance errors
//! across taus ([`covariance`], [`intervals`]). A term whose square is not at least twice its standard error is
//! *not identifiable*: the data cannot tell it from zero or from its neighbours (B and K trade off when neither
//! dominates anywhere), and it is reported as such, with no value and a one-sided upper bound.
//!
//! The classic graphical readouts are given beside it for comparison: N where the curve's slope is closest to
//! -1/2, read at tau = 1 s; K where it is closest to +1/2, read at tau = 3 s; B = floor / 0.6643.

mod covariance;
mod deviations;
mod gauss_markov;
mod intervals;
mod record_length;

use serde::Serialize;

pub use covariance::{avar_covariance, CovarianceBasis, EstimatorShape};
pub use deviations::{fit_deviations, octave_oadev};
pub use gauss_markov::{fit_gauss_markov, gauss_markov_avar, GaussMarkovFit};
pub use record_length::{duration, record_length, target_precision, TermPrecision, TAUS_PER_RECORD};

use crate::quantity::Quantity;
use crate::DevPoint;

/// (2 ln 2 / pi): the flicker floor of the Allan variance is this times B^2.
pub const FLICKER_AVAR_FACTOR: f64 = 2.0 * std::f64::consts::LN_2 / std::f64::consts::PI;

/// The five IEEE 952 terms, in the order of the fit's parameter vector.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Term {
    /// Angle quantization Q, deg: 3 Q^2 / tau^2.
    Q,
    /// Angle random walk N, deg/sqrt(s): N^2 / tau.
    N,
    /// Bias instability B, deg/s: (2 ln 2 / pi) B^2.
    B,
    /// Rate random walk K, deg/s/sqrt(s): K^2 tau / 3.
    K,
    /// Rate ramp R, deg/s^2: R^2 tau^2 / 2.
    R,
}

impl Term {
    /// All five, in parameter order.
    pub const ALL: [Term; 5] = [Term::Q, Term::N, Term::B, Term::K, Term::R];

    /// The Allan variance of a unit coefficient at `tau`, with the white term shaped by a known bandwidth.
    pub fn basis_with(self, tau: f64, bandwidth_hz: Option<f64>) -> f64 {
        match (self, bandwidth_hz) {
            (Term::N, Some(f)) if f > 0.0 => {
                let t = 1.0 / (2.0 * std::f64::consts::PI * f);
                lowpass_white_factor(tau / t) / tau
            }
            _ => self.basis(tau),
        }
    }

    /// The Allan variance of a unit coefficient at `tau`.
    pub fn basis(self, tau: f64) -> f64 {
        match self {
            Term::Q => 3.0 / (tau * tau),
            Term::N => 1.0 / tau,
            Term::B => FLICKER_AVAR_FACTOR,
            Term::K => tau / 3.0,
            Term::R => tau * tau / 2.0,
        }
    }

    /// The unit of the coefficient, for rate data in deg/s.
    pub fn unit(self) -> &'static str {
        self.unit_of(Quantity::AngularRate)
    }

    /// The unit of the coefficient for a series of `q` in its base unit (deg/s or m/s^2).
    pub fn unit_of(self, q: Quantity) -> &'static str {
        match (q, self) {
            (Quantity::AngularRate, Term::Q) => "deg",
            (Quantity::AngularRate, Term::N) => "deg/sqrt(s)",
            (Quantity::AngularRate, Term::B) => "deg/s",
            (Quantity::AngularRate, Term::K) => "deg/s/sqrt(s)",
            (Quantity::AngularRate, Term::R) => "deg/s^2",
            (Quantity::Acceleration, Term::Q) => "m/s",
            (Quantity::Acceleration, Term::N) => "m/s/sqrt(s)",
            (Quantity::Acceleration, Term::B) => "m/s^2",
            (Quantity::Acceleration, Term::K) => "m/s^2/sqrt(s)",
            (Quantity::Acceleration, Term::R) => "m/s^3",
        }
    }

    /// The customary second unit and the factor to it (deg/sqrt(h), deg/h, ...), for a gyro.
    pub fn alt_unit(self) -> (&'static str, f64) {
        self.alt_unit_of(Quantity::AngularRate)
    }

    /// The customary second unit of the coefficient for a series of `q`, and the factor to it: deg/sqrt(h) and
    /// deg/h for a gyro's N and B, m/s/sqrt(h) and mg for an accelerometer's.
    pub fn alt_unit_of(self, q: Quantity) -> (&'static str, f64) {
        let mg = 1000.0 / crate::quantity::STANDARD_GRAVITY;
        match (q, self) {
            (Quantity::AngularRate, Term::Q) => ("arcsec", 3600.0),
            (Quantity::AngularRate, Term::N) => ("deg/sqrt(h)", 60.0),
            (Quantity::AngularRate, Term::B) => ("deg/h", 3600.0),
            (Quantity::AngularRate, Term::K) => ("deg/h/sqrt(h)", 3600.0 * 60.0),
            (Quantity::AngularRate, Term::R) => ("deg/h^2", 3600.0 * 3600.0),
            (Quantity::Acceleration, Term::Q) => ("mm/s", 1000.0),
            (Quantity::Acceleration, Term::N) => ("m/s/sqrt(h)", 60.0),
            (Quantity::Acceleration, Term::B) => ("mg", mg),
            (Quantity::Acceleration, Term::K) => ("mg/sqrt(h)", mg * 60.0),
            (Quantity::Acceleration, Term::R) => ("mg/h", mg * 3600.0),
        }
    }

    /// The name used in JSON and tables.
    pub fn name(self) -> &'static str {
        match self {
            Term::Q => "Q",
            Term::N => "N",
            Term::B => "B",
            Term::K => "K",
            Term::R => "R",
        }
    }
}

/// One point of an Allan variance curve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitPoint {
    /// Averaging time, s.
    pub tau_s: f64,
    /// Allan variance, (deg/s)^2.
    pub avar: f64,
    /// Equivalent degrees of freedom of that estimate.
    pub edf: f64,
    /// Where the estimate's differences lie in the record, when known: the intervals then account for the
    /// correlation between taus ([`avar_covariance`]).
    pub shape: Option<EstimatorShape>,
}

impl FitPoint {
    /// A point whose estimator shape is unknown (the intervals then treat each tau as independent).
    pub fn new(tau_s: f64, avar: f64, edf: f64) -> Self {
        FitPoint { tau_s, avar, edf, shape: None }
    }
}

/// The fit's input from Allan deviation points: AVAR and EDF per tau, leaving out the points without a usable
/// EDF or deviation (NaN, infinite, zero).
pub fn fit_input(points: &[DevPoint]) -> Vec<FitPoint> {
    points
        .iter()
        .filter(|p| p.edf.is_finite() && p.edf > 0.0 && p.dev.is_finite() && p.dev > 0.0)
        .map(|p| FitPoint {
            tau_s: p.tau_s,
            avar: p.dev * p.dev,
            edf: p.edf,
            shape: (p.m > 0 && p.n > 0 && p.stride > 0).then_some(EstimatorShape {
                m: p.m as f64,
                terms: p.n as f64,
                stride: p.stride as f64,
            }),
        })
        .collect()
}

/// Options of [`fit`].
#[derive(Clone, Debug)]
pub struct FitOptions {
    /// Which terms may enter the model.
    pub terms: Vec<Term>,
    /// Ignore points below this tau (for example where an anti-alias filter bends the white-noise line).
    pub tau_min_s: f64,
    /// Ignore points above this tau.
    pub tau_max_s: f64,
    /// Two-sided confidence of the intervals (0.95 by default).
    pub confidence: f64,
    /// A known first-order output bandwidth (-3 dB, Hz): the white-noise term then takes the exact Allan form of
    /// low-passed white noise, `N^2/tau [1 - T/(2 tau) (3 - 4 e^(-tau/T) + e^(-2 tau/T))]`, T = 1/(2 pi f3dB),
    /// instead of bending the fit at short tau.
    pub bandwidth_hz: Option<f64>,
    /// Relative model error added to every point's own uncertainty (in AVAR, so 0.03 is 3%): real sensors are
    /// never exactly the five-term model, and without a floor the first octaves, with their enormous EDF, would
    /// let a small misfit there decide the whole curve.
    pub model_error: f64,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            terms: Term::ALL.to_vec(),
            tau_min_s: 0.0,
            tau_max_s: f64::INFINITY,
            confidence: 0.95,
            bandwidth_hz: None,
            model_error: 0.03,
        }
    }
}

/// The Allan variance factor of first-order low-passed white noise relative to N^2 / tau, at tau / T = x.
pub fn lowpass_white_factor(x: f64) -> f64 {
    if x > 50.0 {
        return 1.0 - 1.5 / x;
    }
    1.0 - (3.0 - 4.0 * (-x).exp() + (-2.0 * x).exp()) / (2.0 * x)
}

/// What went wrong.
#[derive(Clone, Debug, thiserror::Error, PartialEq)]
pub enum FitError {
    /// Fewer usable points than one.
    #[error("the fit needs at least 2 Allan variance points with positive values and degrees of freedom; it has {0}")]
    TooFewPoints(usize),
    /// The fit was not asked for (`--no-fit`).
    #[error("no fit was asked for")]
    NotAsked,
}

/// One coefficient of the fit.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TermEstimate {
    /// The estimate (`None` when not identifiable).
    pub value: Option<f64>,
    /// Lower confidence bound.
    pub lo: Option<f64>,
    /// Upper confidence bound (also given, as a bound, for a term that is not identifiable).
    pub hi: Option<f64>,
    /// Unit of value, lo and hi.
    pub unit: &'static str,
    /// Whether the data determine it.
    pub identifiable: bool,
}

impl TermEstimate {
    /// The value in the term's customary second unit (deg/sqrt(h) for N, deg/h for B, ...).
    pub fn alt(&self, term: Term) -> Option<(f64, &'static str)> {
        let (unit, f) = term.alt_unit();
        self.value.map(|v| (v * f, unit))
    }
}

/// The classic graphical readouts of IEEE 952.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ClassicReadouts {
    /// N: the -1/2 line through the point of slope closest to -1/2, at tau = 1 s (deg/sqrt(s)).
    pub n: Option<f64>,
    /// B: the lowest Allan deviation / 0.6643 (deg/s).
    pub b: Option<f64>,
    /// tau of that floor, s.
    pub b_tau_s: Option<f64>,
    /// K: the +1/2 line through the point of slope closest to +1/2, at tau = 3 s (deg/s/sqrt(s)).
    pub k: Option<f64>,
}

/// The result of [`fit`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NoiseFit {
    /// Angle quantization.
    #[serde(rename = "Q")]
    pub q: TermEstimate,
    /// Angle random walk.
    #[serde(rename = "N")]
    pub n: TermEstimate,
    /// Bias instability.
    #[serde(rename = "B")]
    pub b: TermEstimate,
    /// Rate random walk.
    #[serde(rename = "K")]
    pub k: TermEstimate,
    /// Rate ramp.
    #[serde(rename = "R")]
    pub r: TermEstimate,
    /// The fitted squares (Q^2, N^2, B^2, K^2, R^2), zero where a term is not in the model.
    #[serde(skip)]
    pub squares: [f64; 5],
    /// Chi-square of the fit (in units of each point's own variance).
    pub chi2: f64,
    /// Points used minus parameters fitted.
    pub dof: usize,
    /// tau range used, s.
    pub tau_range_s: [f64; 2],
    /// Confidence of the intervals.
    pub confidence: f64,
    /// The bandwidth the white term was shaped with, Hz.
    pub bandwidth_hz: Option<f64>,
    /// The classic readouts.
    pub classic: ClassicReadouts,
}

impl NoiseFit {
    /// `gyro` with its Q, N, B, K and R replaced by this fit's fitted terms, so that a simulation of it has the
    /// fitted curve ([`NoiseFit::model_avar`]). A term in the model that is not identifiable keeps its fitted
    /// square: the report gives an upper bound for it, but dropping it would simulate a curve the fit did not
    /// draw (a poor fit, whose reduced chi-square inflates every interval, would lose its white noise).
    pub fn sim_terms(&self, gyro: octavar_shared::sim::GyroSim) -> octavar_shared::sim::GyroSim {
        let v = |t: Term| self.squares[t as usize].max(0.0).sqrt();
        octavar_shared::sim::GyroSim {
            q_deg: v(Term::Q),
            n_deg_per_rt_s: v(Term::N),
            b_dps: v(Term::B),
            k_dps_per_rt_s: v(Term::K),
            r_dps_per_s: v(Term::R),
            ..gyro
        }
    }

    /// This fit with every term's unit named for a series of `q` (the fit itself is the same for any unit).
    pub fn in_units_of(mut self, q: Quantity) -> Self {
        for t in Term::ALL {
            self.term_mut(t).unit = t.unit_of(q);
        }
        self
    }

    fn term_mut(&mut self, t: Term) -> &mut TermEstimate {
        match t {
            Term::Q => &mut self.q,
            Term::N => &mut self.n,
            Term::B => &mut self.b,
            Term::K => &mut self.k,
            Term::R => &mut self.r,
        }
    }

    /// The estimate of one term.
    pub fn term(&self, t: Term) -> &TermEstimate {
        match t {
            Term::Q => &self.q,
            Term::N => &self.n,
            Term::B => &self.b,
            Term::K => &self.k,
            Term::R => &self.r,
        }
    }

    /// The fitted model's Allan variance at `tau`, (deg/s)^2 (every term with its fitted square).
    pub fn model_avar(&self, tau: f64) -> f64 {
        Term::ALL.iter().zip(self.squares).map(|(t, s)| s * t.basis_with(tau, self.bandwidth_hz)).sum()
    }

    /// One term's share of the model at `tau`, (deg/s)^2.
    pub fn term_avar(&self, term: Term, tau: f64) -> f64 {
        self.squares[term as usize] * term.basis_with(tau, self.bandwidth_hz)
    }
}

/// Fit the IEEE 952 terms to an Allan variance curve.
///
/// # Errors
/// [`FitError::TooFewPoints`] when fewer than two points have a positive variance and EDF in the tau range.
pub fn fit(points: &[FitPoint], opts: &FitOptions) -> Result<NoiseFit, FitError> {
    let pts: Vec<FitPoint> = points
        .iter()
        .copied()
        .filter(|p| {
            p.tau_s >= opts.tau_min_s
                && p.tau_s <= opts.tau_max_s
                && p.avar.is_finite()
                && p.avar > 0.0
                && p.edf.is_finite()
                && p.edf > 0.0
        })
        .collect();
    if pts.len() < 2 {
        return Err(FitError::TooFewPoints(pts.len()));
    }
    let allowed: Vec<usize> = opts.terms.iter().map(|&t| t as usize).collect();

    // IRLS: variances from the model, starting from the measured values.
    let e2 = opts.model_error * opts.model_error;
    let mut var_of: Vec<f64> = pts.iter().map(|p| p.avar * p.avar * (2.0 / p.edf + e2)).collect();
    let bw = opts.bandwidth_hz;
    let mut best = solve_nonnegative(&pts, &var_of, &allowed, bw);
    for _ in 0..8 {
        let model: Vec<f64> = pts.iter().map(|p| predict(&best.theta, p.tau_s, bw)).collect();
        var_of = pts
            .iter()
            .zip(&model)
            .map(|(p, &m)| {
                let m = if m > 0.0 { m } else { p.avar };
                m * m * (2.0 / p.edf + e2)
            })
            .collect();
        let next = solve_nonnegative(&pts, &var_of, &allowed, bw);
        let converged = next
            .theta
            .iter()
            .zip(&best.theta)
            .all(|(a, b)| (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(f64::MIN_POSITIVE));
        best = next;
        if converged {
            break;
        }
    }

    // The estimate proper: the log-domain fit, the subset chosen by AIC (see the module doc); the linear
    // solution only seeds it.
    if let Some(refined) = log_domain_fit(&pts, &allowed, bw, &best.theta, e2) {
        best = refined;
    }

    let dof = pts.len().saturating_sub(best.active.len());
    let estimates = intervals::estimates(&intervals::Inputs {
        pts: &pts,
        best: &best,
        e2,
        var_of: &var_of,
        allowed: &allowed,
        opts,
    });
    let mut squares = [0.0; 5];
    for &j in &best.active {
        squares[j] = best.theta[j];
    }
    let mut it = estimates.into_iter();
    let mut next = || it.next().expect("five terms");
    Ok(NoiseFit {
        q: next(),
        n: next(),
        b: next(),
        k: next(),
        r: next(),
        squares,
        chi2: best.chi2,
        dof,
        tau_range_s: [pts[0].tau_s, pts[pts.len() - 1].tau_s],
        confidence: opts.confidence,
        bandwidth_hz: bw,
        classic: classic_readouts(&pts),
    })
}

fn predict(theta: &[f64; 5], tau: f64, bw: Option<f64>) -> f64 {
    Term::ALL.iter().zip(theta).map(|(t, th)| th * t.basis_with(tau, bw)).sum()
}

struct Solution {
    theta: [f64; 5],
    active: Vec<usize>,
    /// Covariance of the active parameters (in `active` order).
    cov: Vec<Vec<f64>>,
    chi2: f64,
}

/// The log-domain weighted fit over every subset of the allowed terms (see [`fit`]); `None` if none converges.
fn log_domain_fit(pts: &[FitPoint], allowed: &[usize], bw: Option<f64>, seed: &[f64; 5], e2: f64) -> Option<Solution> {
    // A positive start for each term: the linear solution where it has one, else a third of the largest value
    // the term could take without exceeding the data anywhere.
    let mut start = [0.0f64; 5];
    for (j, st) in start.iter_mut().enumerate() {
        let cap = pts
            .iter()
            .map(|p| p.avar / Term::ALL[j].basis_with(p.tau_s, bw))
            .filter(|v| v.is_finite() && *v > 0.0)
            .fold(f64::INFINITY, f64::min);
        *st = if seed[j] > 0.0 { seed[j] } else { cap / 3.0 };
    }
    let n_allowed = allowed.len();
    let mut best: Option<(f64, Solution)> = None;
    for mask in 1u32..(1 << n_allowed) {
        let active: Vec<usize> = (0..n_allowed).filter(|i| mask & (1 << i) != 0).map(|i| allowed[i]).collect();
        if active.len() >= pts.len() || active.iter().any(|&j| !(start[j].is_finite() && start[j] > 0.0)) {
            continue;
        }
        let Some(sol) = log_fit_subset(pts, &active, bw, &start, e2) else { continue };
        let aic = sol.chi2 + 2.0 * active.len() as f64;
        if best.as_ref().is_none_or(|(a, _)| aic < *a) {
            best = Some((aic, sol));
        }
    }
    best.map(|(_, s)| s)
}

/// Levenberg-Marquardt in u = ln(theta) on the residuals sqrt(edf/2) (ln avar - ln model).
fn log_fit_subset(pts: &[FitPoint], active: &[usize], bw: Option<f64>, start: &[f64; 5], e2: f64) -> Option<Solution> {
    let p = active.len();
    let w: Vec<f64> = pts.iter().map(|q| 1.0 / (2.0 / q.edf + e2).sqrt()).collect();
    let basis: Vec<Vec<f64>> =
        pts.iter().map(|q| active.iter().map(|&j| Term::ALL[j].basis_with(q.tau_s, bw)).collect()).collect();
    let eval = |u: &[f64]| -> (Vec<f64>, Vec<f64>, f64) {
        let theta: Vec<f64> = u.iter().map(|v| v.exp()).collect();
        let model: Vec<f64> = basis.iter().map(|b| b.iter().zip(&theta).map(|(x, t)| x * t).sum()).collect();
        let r: Vec<f64> = pts.iter().zip(&model).zip(&w).map(|((q, m), wk)| wk * (q.avar.ln() - m.ln())).collect();
        let chi2 = r.iter().map(|v| v * v).sum();
        (model, r, chi2)
    };
    let mut u: Vec<f64> = active.iter().map(|&j| start[j].ln()).collect();
    let (mut model, mut r, mut chi2) = eval(&u);
    let mut lambda = 1e-3;
    let jacobian = |u: &[f64], model: &[f64]| -> Vec<Vec<f64>> {
        basis
            .iter()
            .zip(model)
            .zip(&w)
            .map(|((b, m), wk)| (0..p).map(|c| -wk * u[c].exp() * b[c] / m).collect())
            .collect()
    };
    for _ in 0..200 {
        let jac = jacobian(&u, &model);
        let mut a = vec![vec![0.0; p]; p];
        let mut g = vec![0.0; p];
        for (row, rk) in jac.iter().zip(&r) {
            for i in 0..p {
                g[i] += row[i] * rk;
                for k in 0..p {
                    a[i][k] += row[i] * row[k];
                }
            }
        }
        let mut improved = false;
        for _ in 0..30 {
            let mut damped = a.clone();
            for (i, row) in damped.iter_mut().enumerate() {
                row[i] += lambda * a[i][i].max(1e-12);
            }
            let Some(inv) = invert(&damped) else {
                lambda *= 10.0;
                continue;
            };
            let step: Vec<f64> = (0..p).map(|i| -(0..p).map(|k| inv[i][k] * g[k]).sum::<f64>()).collect();
            let trial: Vec<f64> = u.iter().zip(&step).map(|(v, d)| (v + d.clamp(-20.0, 20.0)).max(-700.0)).collect();
            let (m2, r2, c2) = eval(&trial);
            if c2.is_finite() && c2 <= chi2 {
                let done = chi2 - c2 <= 1e-12 * chi2.max(1e-300);
                u = trial;
                model = m2;
                r = r2;
                chi2 = c2;
                lambda = (lambda / 3.0).max(1e-12);
                improved = !done;
                break;
            }
            lambda *= 4.0;
        }
        if !improved {
            break;
        }
    }
    let jac = jacobian(&u, &model);
    let mut a = vec![vec![0.0; p]; p];
    for row in &jac {
        for i in 0..p {
            for k in 0..p {
                a[i][k] += row[i] * row[k];
            }
        }
    }
    let cov_u = invert(&a)?;
    let mut theta = [0.0; 5];
    for (&j, v) in active.iter().zip(&u) {
        theta[j] = v.exp();
    }
    let cov: Vec<Vec<f64>> =
        (0..p).map(|i| (0..p).map(|k| cov_u[i][k] * theta[active[i]] * theta[active[k]]).collect()).collect();
    chi2.is_finite().then(|| Solution { theta, active: active.to_vec(), cov, chi2 })
}

/// Exact NNLS for at most five parameters: the feasible subset of least chi-square.
fn solve_nonnegative(pts: &[FitPoint], var: &[f64], allowed: &[usize], bw: Option<f64>) -> Solution {
    let mut best: Option<Solution> = None;
    let n_allowed = allowed.len();
    for mask in 1u32..(1 << n_allowed) {
        let active: Vec<usize> = (0..n_allowed).filter(|i| mask & (1 << i) != 0).map(|i| allowed[i]).collect();
        if active.len() > pts.len() {
            continue;
        }
        let Some((theta_a, cov)) = weighted_lsq(pts, var, &active, bw) else { continue };
        if theta_a.iter().any(|&t| t < 0.0) {
            continue;
        }
        let mut theta = [0.0; 5];
        for (&j, &t) in active.iter().zip(&theta_a) {
            theta[j] = t;
        }
        let chi2: f64 = pts
            .iter()
            .zip(var)
            .map(|(p, v)| {
                let r = p.avar - predict(&theta, p.tau_s, bw);
                r * r / v
            })
            .sum();
        // Prefer fewer parameters when chi-square is the same to rounding.
        let better = match &best {
            None => true,
            Some(b) => chi2 < b.chi2 * (1.0 - 1e-12) || (chi2 <= b.chi2 && active.len() < b.active.len()),
        };
        if better {
            best = Some(Solution { theta, active, cov, chi2 });
        }
    }
    best.unwrap_or(Solution { theta: [0.0; 5], active: Vec::new(), cov: Vec::new(), chi2: f64::INFINITY })
}

/// Weighted least squares over the `active` columns, with columns scaled for conditioning.
/// Returns the parameters and their covariance, or `None` if singular.
fn weighted_lsq(pts: &[FitPoint], var: &[f64], active: &[usize], bw: Option<f64>) -> Option<(Vec<f64>, Vec<Vec<f64>>)> {
    let p = active.len();
    let terms: Vec<Term> = active.iter().map(|&j| Term::ALL[j]).collect();
    // Column scales: the weighted norm of each column.
    let mut scale = vec![0.0f64; p];
    for (pt, v) in pts.iter().zip(var) {
        for (c, t) in terms.iter().enumerate() {
            let x = t.basis_with(pt.tau_s, bw);
            scale[c] += x * x / v;
        }
    }
    for s in &mut scale {
        *s = s.sqrt();
        if *s == 0.0 || !s.is_finite() {
            return None;
        }
    }
    let mut a = vec![vec![0.0f64; p]; p];
    let mut b = vec![0.0f64; p];
    for (pt, v) in pts.iter().zip(var) {
        let xs: Vec<f64> = terms.iter().zip(&scale).map(|(t, s)| t.basis_with(pt.tau_s, bw) / s).collect();
        for i in 0..p {
            b[i] += xs[i] * pt.avar / v;
            for j in 0..p {
                a[i][j] += xs[i] * xs[j] / v;
            }
        }
    }
    let inv = invert(&a)?;
    let theta: Vec<f64> = (0..p).map(|i| (0..p).map(|j| inv[i][j] * b[j]).sum::<f64>() / scale[i]).collect();
    let cov: Vec<Vec<f64>> = (0..p).map(|i| (0..p).map(|j| inv[i][j] / (scale[i] * scale[j])).collect()).collect();
    Some((theta, cov))
}

/// The inverse of a small symmetric positive matrix; `None` if singular (a pivot below 1e-12).
fn invert(a: &[Vec<f64>]) -> Option<Vec<Vec<f64>>> {
    crate::linalg::invert(a, 1e-12)
}

fn classic_readouts(pts: &[FitPoint]) -> ClassicReadouts {
    let adev: Vec<(f64, f64)> = pts.iter().map(|p| (p.tau_s, p.avar.sqrt())).collect();
    let mut out = ClassicReadouts::default();
    if let Some(&(tau, a)) = adev.iter().min_by(|x, y| x.1.total_cmp(&y.1)) {
        out.b = Some(a / FLICKER_AVAR_FACTOR.sqrt());
        out.b_tau_s = Some(tau);
    }
    // Local slopes between neighbours, attributed to their geometric mid-point.
    let slopes: Vec<(f64, f64, f64)> = adev
        .windows(2)
        .map(|w| {
            let s = (w[1].1 / w[0].1).ln() / (w[1].0 / w[0].0).ln();
            let tau = (w[0].0 * w[1].0).sqrt();
            let a = (w[0].1 * w[1].1).sqrt();
            (tau, a, s)
        })
        .collect();
    let nearest = |target: f64| {
        slopes
            .iter()
            .filter(|(_, _, s)| (s - target).abs() < 0.15)
            .min_by(|x, y| (x.2 - target).abs().total_cmp(&(y.2 - target).abs()))
            .copied()
    };
    out.n = nearest(-0.5).map(|(tau, a, _)| a * tau.sqrt());
    out.k = nearest(0.5).map(|(tau, a, _)| a * (3.0 / tau).sqrt());
    out
}

#[cfg(test)]
mod tests;

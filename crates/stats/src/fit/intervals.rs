//! The confidence intervals of the fitted terms and the upper bounds of the terms the data cannot determine.
//!
//! Where the points carry their estimator's shape ([`EstimatorShape`], as every octave OADEV does), the errors of
//! the Allan variances are taken as they are: correlated across taus, with the covariance of
//! [`super::avar_covariance`] at the fitted model.
//!
//! - **Fitted terms.** The estimate is the log-domain fit, whose weights treat each tau as independent (with the
//!   fit's model-error floor, a weighting device that keeps the first octaves from deciding the whole curve).
//!   Its covariance under the correlated errors is the sandwich `A^-1 J^T W S W J A^-1`: `J` the Jacobian of
//!   `ln model` in the logs of the squares, `W` the fit's weights, `S` the statistical covariance of `ln AVAR`,
//!   `A = J^T W J`. Where the model fits worse than `S` and the model-error floor `E = e^2 I` together allow,
//!   it is inflated by the generalised reduced chi-square `r^T (S + E)^-1 r / dof`, `dof = tr((S + E)^-1 S) -
//!   p` (a Birge ratio whose degrees of freedom are those the residuals have when the model holds), so a misfit
//!   widens the intervals by what it shows and no more, and a misfit inside the floor at taus whose statistical
//!   errors are tiny (a sensor's roll-off in the first octaves of a long record) widens nothing. The interval is in the log of the square and found by test inversion: its ends are the values `v`
//!   with `ln theta - ln v = -+ z sd_u(v)`, the spread taken as if the term were `v`, the other terms as
//!   fitted. A term estimated high by chance also looks more precise than it is (its share of the curve is
//!   larger), so a spread taken at the estimate alone draws the lower end too high; the inverted ends are where
//!   the truth would have to be for the estimate to lie at the edge of its own spread.
//! - **Upper bounds.** A term the data do not determine is bounded by a generalised least squares fit in the
//!   squares with the term forced in, unconstrained: `max(theta_j, 0) + z sd_j` at the one-sided confidence.
//!   The covariance is taken with the term at the bound itself (the test of "theta_j = bound" is made under that
//!   hypothesis), iterated to a fixed point; a bound computed with the term at zero would be too tight, since a
//!   larger term also scatters its own estimates more.
//!
//! Points without a shape (a curve typed in by hand, a test) keep the independent-error intervals: the linear
//! covariance of the squares from each point's own EDF.

use super::covariance::{CovarianceBasis, EstimatorShape};
use super::{predict, FitOptions, FitPoint, Solution, Term, TermEstimate};
use crate::linalg::{cholesky, forward_solve, invert, solve};

/// A relative ridge on the diagonal of the covariance of ln AVAR, so that neighbouring octaves of a long
/// record, correlated almost to one, still factor.
const RIDGE: f64 = 1e-9;

/// What the intervals are built from.
pub(super) struct Inputs<'a> {
    pub pts: &'a [FitPoint],
    pub best: &'a Solution,
    /// The squared model-error floor (relative, in AVAR).
    pub e2: f64,
    /// The independent variances of the points at the final model (the fallback's weights).
    pub var_of: &'a [f64],
    pub allowed: &'a [usize],
    pub opts: &'a FitOptions,
}

/// The five terms' estimates, in [`Term`] order.
pub(super) fn estimates(inp: &Inputs) -> Vec<TermEstimate> {
    let z = normal_quantile(0.5 + inp.opts.confidence / 2.0);
    let z1 = normal_quantile(inp.opts.confidence);
    let correlated = Correlated::new(inp);
    let best = inp.best;
    let bw = inp.opts.bandwidth_hz;
    let independent_inflation = {
        let dof = inp.pts.len().saturating_sub(best.active.len());
        if dof > 0 {
            (best.chi2 / dof as f64).max(1.0)
        } else {
            1.0
        }
    };
    let sandwich = correlated.as_ref().and_then(|c| c.sandwich(best));
    Term::ALL
        .iter()
        .map(|&t| {
            let j = t as usize;
            let unit = t.unit();
            let none = TermEstimate { value: None, lo: None, hi: None, unit, identifiable: false };
            if let Some(pos) = best.active.iter().position(|&a| a == j) {
                let theta = best.theta[j];
                if let (Some(c), Some(sw)) = (&correlated, &sandwich) {
                    // sd of ln(theta), inflated.
                    let sd_u = (sw.cov_u[pos][pos] * sw.inflation).max(0.0).sqrt();
                    if sd_u < 0.5 {
                        let lo = c.interval_end(best, j, pos, -z, sw.inflation, sd_u);
                        let hi = c.interval_end(best, j, pos, z, sw.inflation, sd_u);
                        return TermEstimate {
                            value: Some(theta.sqrt()),
                            lo: Some(lo.sqrt()),
                            hi: Some(hi.sqrt()),
                            unit,
                            identifiable: true,
                        };
                    }
                    let hi = c.upper_bound(best, &best.active, j, z1, sw.inflation);
                    return TermEstimate { hi, ..none };
                }
                let sd = (best.cov[pos][pos] * independent_inflation).max(0.0).sqrt();
                let hi = (theta + z * sd).sqrt();
                if theta > 2.0 * sd {
                    TermEstimate {
                        value: Some(theta.sqrt()),
                        lo: Some((theta - z * sd).max(0.0).sqrt()),
                        hi: Some(hi),
                        unit,
                        identifiable: true,
                    }
                } else {
                    TermEstimate { hi: Some(hi), ..none }
                }
            } else if inp.allowed.contains(&j) {
                // Not in the best model: bound it by a fit that forces it in.
                let mut with = best.active.clone();
                with.push(j);
                with.sort_unstable();
                let hi = match (&correlated, &sandwich) {
                    (Some(c), Some(sw)) => c.upper_bound(best, &with, j, z1, sw.inflation),
                    _ => forced_bound(inp.pts, inp.var_of, &with, j, z, independent_inflation, bw),
                };
                TermEstimate { hi, ..none }
            } else {
                none
            }
        })
        .collect()
}

/// The correlated-error machinery: the covariance basis of the points' estimates.
struct Correlated<'a> {
    inp: &'a Inputs<'a>,
    basis: CovarianceBasis,
}

/// The covariance of the log-domain estimate and its inflation.
struct Sandwich {
    /// Covariance of ln(theta) of the active terms (in `active` order), not inflated.
    cov_u: Vec<Vec<f64>>,
    /// max(1, generalised reduced chi-square).
    inflation: f64,
}

impl<'a> Correlated<'a> {
    /// `None` unless every point has a shape and they agree on tau0.
    fn new(inp: &'a Inputs<'a>) -> Option<Self> {
        let shapes: Vec<EstimatorShape> = inp.pts.iter().map(|p| p.shape).collect::<Option<_>>()?;
        let tau0_s = inp.pts[0].tau_s / shapes[0].m;
        let agree = inp.pts.iter().zip(&shapes).all(|(p, s)| (p.tau_s / s.m / tau0_s - 1.0).abs() < 1e-9);
        (agree && tau0_s > 0.0 && tau0_s.is_finite())
            .then(|| Correlated { inp, basis: CovarianceBasis::new(&shapes, tau0_s) })
    }

    /// The covariance of ln AVAR at the model `theta` (its statistical part, from the estimators alone), and
    /// the model's AVAR.
    fn log_covariance(&self, theta: &[f64; 5]) -> Option<(Vec<Vec<f64>>, Vec<f64>)> {
        let bw = self.inp.opts.bandwidth_hz;
        let f: Vec<f64> = self.inp.pts.iter().map(|p| predict(theta, p.tau_s, bw)).collect();
        if f.iter().any(|v| !(*v > 0.0 && v.is_finite())) {
            return None;
        }
        let c = self.basis.at(theta);
        let s: Vec<Vec<f64>> = (0..f.len())
            .map(|k| (0..f.len()).map(|l| c[k][l] / (f[k] * f[l]) * if k == l { 1.0 + RIDGE } else { 1.0 }).collect())
            .collect();
        Some((s, f))
    }

    /// The sandwich covariance of the log-domain estimate (see the module doc) and its inflation, at the fit.
    fn sandwich(&self, best: &Solution) -> Option<Sandwich> {
        let (cov_u, s, f) = self.sandwich_at(&best.theta, &best.active)?;
        // Generalised chi-square of the log residuals against the statistical covariance plus the fit's own
        // model-error floor (independent per tau, as its weights take it), over the degrees of freedom it has when
        // the model holds: `tr((S + E)^-1 S) - p`. A point whose statistical error is tiny beside the floor (the
        // first octaves of a long record) then counts for neither: a misfit there that the floor allows, such as
        // a sensor's roll-off, widens nothing, while a misfit of the taus the statistics do weigh widens every
        // interval by what it shows.
        let r: Vec<f64> = self.inp.pts.iter().zip(&f).map(|(q, fk)| q.avar.ln() - fk.ln()).collect();
        let e2 = self.inp.e2;
        let mut total = s;
        for (k, row) in total.iter_mut().enumerate() {
            row[k] += e2;
        }
        let l = cholesky(&total)?;
        let chi2: f64 = forward_solve(&l, &r).iter().map(|v| v * v).sum();
        let n = r.len();
        // tr((S + E)^-1) = sum of the squares of L^-1's entries.
        let trace_inv: f64 = (0..n)
            .map(|i| {
                let mut unit = vec![0.0; n];
                unit[i] = 1.0;
                forward_solve(&l, &unit).iter().map(|v| v * v).sum::<f64>()
            })
            .sum();
        let dof = n as f64 - e2 * trace_inv - best.active.len() as f64;
        let inflation = if dof > 0.5 { (chi2 / dof).max(1.0) } else { 1.0 };
        Some(Sandwich { cov_u, inflation })
    }

    /// The sandwich covariance of ln(theta) over `active` were the model `theta` (not inflated), with the
    /// covariance of ln AVAR and the model's AVAR it was computed from.
    #[allow(clippy::type_complexity)]
    fn sandwich_at(&self, theta: &[f64; 5], active: &[usize]) -> Option<(Vec<Vec<f64>>, Vec<Vec<f64>>, Vec<f64>)> {
        let (s, f) = self.log_covariance(theta)?;
        let pts = self.inp.pts;
        let bw = self.inp.opts.bandwidth_hz;
        let p = active.len();
        let w2: Vec<f64> = pts.iter().map(|q| 1.0 / (2.0 / q.edf + self.inp.e2)).collect();
        let jac: Vec<Vec<f64>> = pts
            .iter()
            .zip(&f)
            .map(|(q, fk)| active.iter().map(|&j| theta[j] * Term::ALL[j].basis_with(q.tau_s, bw) / fk).collect())
            .collect();
        let mut a = vec![vec![0.0; p]; p];
        for (row, w) in jac.iter().zip(&w2) {
            for i in 0..p {
                for k in 0..p {
                    a[i][k] += w * row[i] * row[k];
                }
            }
        }
        let a_inv = invert(&a, 1e-300)?;
        // G = J^T W: p x n; middle = G S G^T.
        let g: Vec<Vec<f64>> = (0..p).map(|i| jac.iter().zip(&w2).map(|(row, w)| w * row[i]).collect()).collect();
        let n = pts.len();
        let mut middle = vec![vec![0.0; p]; p];
        for i in 0..p {
            let gs: Vec<f64> = (0..n).map(|l| (0..n).map(|k| g[i][k] * s[k][l]).sum()).collect();
            for k in 0..p {
                middle[i][k] = (0..n).map(|l| gs[l] * g[k][l]).sum();
            }
        }
        let cov_u: Vec<Vec<f64>> = (0..p)
            .map(|i| {
                (0..p)
                    .map(|k| {
                        (0..p).map(|x| (0..p).map(|y| a_inv[i][x] * middle[x][y] * a_inv[y][k]).sum::<f64>()).sum()
                    })
                    .collect()
            })
            .collect();
        Some((cov_u, s, f))
    }

    /// One end of the interval of fitted term `j` (at `pos` in the active set) by test inversion: the value `v`
    /// with `ln theta_j - ln v = -+ z sd_u(v)`, the spread taken as if the term were `v` (a term estimated high
    /// by chance looks more precise than it is; the lower end is where the truth would have to be for that).
    fn interval_end(&self, best: &Solution, j: usize, pos: usize, z_signed: f64, inflation: f64, sd_u: f64) -> f64 {
        let theta = best.theta[j];
        let mut v = theta * (z_signed * sd_u).exp();
        for _ in 0..8 {
            let mut model = best.theta;
            model[j] = v;
            let Some((cov, _, _)) = self.sandwich_at(&model, &best.active) else { break };
            let next = theta * (z_signed * (cov[pos][pos] * inflation).max(0.0).sqrt()).exp();
            let done = (next / v - 1.0).abs() < 1e-3;
            v = next;
            if done {
                break;
            }
        }
        v
    }

    /// The one-sided upper bound of term `j` from the generalised least squares over `with` (which holds `j`),
    /// the covariance taken with the term at the bound (see the module doc).
    fn upper_bound(&self, best: &Solution, with: &[usize], j: usize, z1: f64, inflation: f64) -> Option<f64> {
        let mut model = best.theta;
        let mut bound: Option<f64> = None;
        for _ in 0..12 {
            if let Some(b) = bound {
                model[j] = b;
            }
            let (theta_j, sd_j) = self.gls_term(&model, with, j)?;
            let next = theta_j.max(0.0) + z1 * (sd_j * sd_j * inflation).sqrt();
            if !(next > 0.0 && next.is_finite()) {
                return None;
            }
            let done = bound.is_some_and(|b| (next / b - 1.0).abs() < 1e-3);
            bound = Some(next);
            if done {
                break;
            }
        }
        bound.map(f64::sqrt)
    }

    /// The generalised least squares estimate of the squares over `with`, the covariance from the model `model`:
    /// term `j`'s estimate and standard deviation.
    fn gls_term(&self, model: &[f64; 5], with: &[usize], j: usize) -> Option<(f64, f64)> {
        let (s, f) = self.log_covariance(model)?;
        let l = cholesky(&s)?;
        let bw = self.inp.opts.bandwidth_hz;
        let pts = self.inp.pts;
        // Relative rows: y / f = sum_c theta_c basis_c / f, whitened by L^-1.
        let y = forward_solve(&l, &pts.iter().zip(&f).map(|(q, fk)| q.avar / fk).collect::<Vec<_>>());
        let cols: Vec<Vec<f64>> = with
            .iter()
            .map(|&c| {
                let col: Vec<f64> =
                    pts.iter().zip(&f).map(|(q, fk)| Term::ALL[c].basis_with(q.tau_s, bw) / fk).collect();
                forward_solve(&l, &col)
            })
            .collect();
        let p = with.len();
        let scale: Vec<f64> = cols.iter().map(|c| c.iter().map(|v| v * v).sum::<f64>().sqrt()).collect();
        if scale.iter().any(|s| !(*s > 0.0 && s.is_finite())) {
            return None;
        }
        let a: Vec<Vec<f64>> =
            (0..p).map(|i| (0..p).map(|k| dot(&cols[i], &cols[k]) / (scale[i] * scale[k])).collect()).collect();
        let b: Vec<f64> = (0..p).map(|i| dot(&cols[i], &y) / scale[i]).collect();
        let pos = with.iter().position(|&c| c == j)?;
        let theta = solve(a.clone(), b, 1e-12)?;
        let inv = invert(&a, 1e-12)?;
        Some((theta[pos] / scale[pos], inv[pos][pos].max(0.0).sqrt() / scale[pos]))
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The independent-error upper bound of a term the best model leaves out: the weighted linear fit with it
/// forced in, unconstrained.
fn forced_bound(
    pts: &[FitPoint],
    var: &[f64],
    with: &[usize],
    j: usize,
    z: f64,
    inflation: f64,
    bw: Option<f64>,
) -> Option<f64> {
    let (theta, cov) = super::weighted_lsq(pts, var, with, bw)?;
    let pos = with.iter().position(|&a| a == j)?;
    let sd = (cov[pos][pos] * inflation).max(0.0).sqrt();
    let hi = theta[pos].max(0.0) + z * sd;
    Some(hi.max(0.0).sqrt())
}

/// The standard normal quantile at `p` (0 < p < 1; statrs).
pub(super) fn normal_quantile(p: f64) -> f64 {
    use statrs::distribution::{ContinuousCDF, Normal};
    Normal::standard().inverse_cdf(p)
}

//! Tests of the noise-term fit: closed-form curves recovered, identifiability, intervals.

use super::intervals::normal_quantile;
use super::*;

/// Exact model curves at octave tau with a given EDF: the fit must return the coefficients.
fn curve(sq: [f64; 5], edf: impl Fn(f64) -> f64) -> Vec<FitPoint> {
    (0..25)
        .map(|k| {
            let tau = 1e-3 * 2f64.powi(k);
            let avar = predict(&sq, tau, None);
            FitPoint::new(tau, avar, edf(tau))
        })
        .collect()
}

#[test]
fn recovers_exact_curves() {
    let (n, b, k) = (3e-3, 13e-3, 2e-4);
    let pts = curve([0.0, n * n, b * b, k * k, 0.0], |tau| 1e5 / tau);
    let f = fit(&pts, &FitOptions::default()).unwrap();
    assert!((f.n.value.unwrap() / n - 1.0).abs() < 1e-6, "{:?}", f.n);
    assert!((f.b.value.unwrap() / b - 1.0).abs() < 1e-6, "{:?}", f.b);
    assert!((f.k.value.unwrap() / k - 1.0).abs() < 1e-6, "{:?}", f.k);
    assert!(!f.q.identifiable && !f.r.identifiable);
    assert!(f.chi2 < 1e-12);
    assert!(f.n.lo.unwrap() <= n && n <= f.n.hi.unwrap());
}

#[test]
fn a_term_that_never_dominates_is_not_identifiable() {
    // White noise dominates everywhere the data reach (tau <= 16 s); a K that would show only past
    // 1e5 s cannot be told from zero.
    let n = 3e-3;
    let kk = 1e-10;
    let pts: Vec<FitPoint> = (0..15)
        .map(|j| {
            let tau = 1e-3 * 2f64.powi(j);
            FitPoint::new(tau, n * n / tau + kk * kk * tau / 3.0, 1e4 / tau)
        })
        .collect();
    let f = fit(&pts, &FitOptions::default()).unwrap();
    assert!(f.n.identifiable);
    assert!(!f.k.identifiable && f.k.value.is_none(), "{:?}", f.k);
    assert!(f.k.hi.is_some(), "an upper bound is still given");
}

#[test]
fn a_simulation_of_the_fit_draws_the_fitted_curve() {
    // A hump the five terms cannot follow (a Gauss-Markov bump) inflates every interval by the reduced
    // chi-square, so some fitted term is not identifiable; the model to simulate must keep it all the same:
    // its closed-form Allan variance (IEEE 952 forms of q_deg, N, B, K, R) is the fit's curve at every tau.
    let (n, b, sigma, t) = (3e-3, 2e-3, 2e-2, 50.0);
    let pts: Vec<FitPoint> = (0..20)
        .map(|j| {
            let tau: f64 = 1e-2 * 2f64.powi(j);
            let gm = sigma * sigma * 2.0 * t / tau
                * (1.0 - t / (2.0 * tau) * (3.0 - 4.0 * (-tau / t).exp() + (-2.0 * tau / t).exp()));
            FitPoint::new(tau, n * n / tau + FLICKER_AVAR_FACTOR * b * b + gm, 1e4 / tau)
        })
        .collect();
    let f = fit(&pts, &FitOptions::default()).unwrap();
    let in_model_not_identifiable =
        Term::ALL.iter().filter(|&&t| f.squares[t as usize] > 0.0 && !f.term(t).identifiable).count();
    assert!(in_model_not_identifiable > 0, "{f:?}");
    let g = f.sim_terms(octavar_shared::sim::GyroSim::default());
    for p in &pts {
        let tau = p.tau_s;
        let sim = 3.0 * g.q_deg.powi(2) / (tau * tau)
            + g.n_deg_per_rt_s.powi(2) / tau
            + FLICKER_AVAR_FACTOR * g.b_dps.powi(2)
            + g.k_dps_per_rt_s.powi(2) * tau / 3.0
            + g.r_dps_per_s.powi(2) * tau * tau / 2.0;
        assert!((sim / f.model_avar(tau) - 1.0).abs() < 1e-12, "tau {tau}: {sim} vs {}", f.model_avar(tau));
    }
}

#[test]
fn classic_readouts_on_a_white_plus_flicker_curve() {
    let (n, b) = (4e-4, 9.5e-4);
    let pts = curve([0.0, n * n, b * b, 0.0, 0.0], |_| 100.0);
    let c = fit(&pts, &FitOptions::default()).unwrap().classic;
    // The -1/2 line is read where white noise dominates: close to N, not exact (the floor adds a little).
    assert!((c.n.unwrap() / n - 1.0).abs() < 0.05, "{:?}", c.n);
    // The curve flattens only at its last points: the floor read there is B to a few percent.
    assert!((c.b.unwrap() / b - 1.0).abs() < 0.05, "{:?}", c.b);
}

#[test]
fn known_bandwidth_shapes_the_white_term() {
    // Low-passed white noise at 600 Hz: the plain N^2/tau model would read N low from the bent short taus.
    let n = 3e-3;
    let t = 1.0 / (2.0 * std::f64::consts::PI * 600.0);
    let pts: Vec<FitPoint> = (0..14)
        .map(|k| {
            let tau = 5e-4 * 2f64.powi(k);
            FitPoint::new(tau, n * n / tau * lowpass_white_factor(tau / t), 1e6 / tau)
        })
        .collect();
    let shaped = fit(&pts, &FitOptions { bandwidth_hz: Some(600.0), ..Default::default() }).unwrap();
    assert!((shaped.n.value.unwrap() / n - 1.0).abs() < 1e-6, "{:?}", shaped.n);
    let plain = fit(&pts, &FitOptions { terms: vec![Term::N], ..Default::default() }).unwrap();
    assert!(plain.n.value.unwrap() < 0.99 * n, "{:?}", plain.n);
    // lowpass_white_factor tends to 1 - 3T/(2 tau) and is continuous at its switch point.
    assert!((lowpass_white_factor(50.0) - lowpass_white_factor(50.0 + 1e-9)).abs() < 1e-9);
}

#[test]
fn too_few_points() {
    let pts = [FitPoint::new(1.0, 1.0, 3.0)];
    assert_eq!(fit(&pts, &FitOptions::default()), Err(FitError::TooFewPoints(1)));
}

#[test]
fn normal_quantile_is_right() {
    assert!((normal_quantile(0.975) - 1.959964).abs() < 1e-5);
    assert!((normal_quantile(0.8415) - 1.0).abs() < 1e-3);
}

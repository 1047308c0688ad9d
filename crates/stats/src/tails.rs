//! Upper-tail probabilities the diagnosis's tests are read against: the standard normal's and the Poisson law's,
//! accurate far into the tail where the tests' thresholds sit.

/// The standard normal upper tail, P(Z > z).
pub fn normal_sf(z: f64) -> f64 {
    0.5 * statrs::function::erf::erfc(z / std::f64::consts::SQRT_2)
}

/// P(Poisson(mu) >= k).
pub fn poisson_sf(mu: f64, k: usize) -> f64 {
    ln_poisson_sf(mu, k).exp().min(1.0)
}

/// ln P(Poisson(mu) >= k), accurate far in the tail: the first term's logarithm plus that of the ratio sum.
pub fn ln_poisson_sf(mu: f64, k: usize) -> f64 {
    if k == 0 {
        return 0.0;
    }
    if mu <= 0.0 {
        return f64::NEG_INFINITY;
    }
    let lead = -mu + k as f64 * mu.ln() - statrs::function::gamma::ln_gamma(k as f64 + 1.0);
    let (mut term, mut sum, mut j) = (1.0, 1.0, k);
    while term > sum * 1e-17 && j < k + 100_000 {
        j += 1;
        term *= mu / j as f64;
        sum += term;
    }
    (lead + sum.ln()).min(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against the regularised lower incomplete gamma function (P(Poisson(mu) >= k) = P(k, mu), statrs's), and the
    /// normal tail's tabulated values.
    #[test]
    fn tails_match_the_incomplete_gamma_and_tables() {
        for mu in [0.01f64, 0.14, 0.57, 3.0, 40.0] {
            for k in [1usize, 2, 5, 9, 60] {
                let reference = statrs::function::gamma::gamma_lr(k as f64, mu);
                let ours = poisson_sf(mu, k);
                assert!((ours / reference - 1.0).abs() < 1e-9, "mu {mu} k {k}: {ours} vs {reference}");
            }
            assert_eq!(poisson_sf(mu, 0), 1.0);
        }
        // Far in the tail, where 1 - sum cancels: the leading term dominates.
        let lead = (-0.14f64).exp() * 0.14f64.powi(30) / statrs::function::gamma::gamma(31.0);
        assert!((poisson_sf(0.14, 30) / lead - 1.0).abs() < 0.01);
        assert!((normal_sf(0.0) - 0.5).abs() < 1e-15);
        assert!((normal_sf(1.959_963_984_540_054) / 0.025 - 1.0).abs() < 1e-9);
        assert!((normal_sf(5.0) / 2.866_515_718_791_939e-7 - 1.0).abs() < 1e-9);
    }
}

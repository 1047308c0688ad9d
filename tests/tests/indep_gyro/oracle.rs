//! The independent generator's truth as shared::sim's model: the oracle's `GyroSim` (and channel), and the
//! bench temperature as a shared::sim profile for records of the same truth made by shared::sim.
//!
//! The mapping is exact term by term except where shared::sim has no such term: the bench cycle's second
//! harmonic (the oracle is driven by the recorded temperature, so only shared::sim's own records lose it), the
//! lattice's offset (shared::sim's coarse channel has its lattice at zero), and the spikes ([`outliers`]).

use octavar_shared::sensor::Channel;
use octavar_shared::sim::{
    BiasSteps, BistableSim, GaussMarkovSim, GyroSim, Outliers, ResonanceSim, Sinusoid, TempCoupling,
    TemperatureProfile, Wander, WarmUpSim,
};

use super::{BenchTemperature, Contamination, IndepGyro};
use crate::util::coarse_channel;

/// shared::sim's outliers for a contamination: the same share of samples carrying a spike, the same uniform law
/// of sizes, and runs of the same chance to reach two and three samples (shared::sim's lengths have a geometric
/// tail where this generator stops at three, a share of 1 run in 21 of four samples or more).
pub fn outliers(c: &Contamination) -> Outliers {
    let [lo, hi] = c.size_sigma;
    // Runs of 1, 2, 3 samples weigh 4, 2, 1 up to the longest.
    let weights: Vec<f64> = [4.0, 2.0, 1.0].into_iter().take(c.longest_run.clamp(1, 3)).collect();
    let total: f64 = weights.iter().sum();
    let c1 = weights[1..].iter().sum::<f64>() / total;
    let c2 = if weights.len() == 3 { weights[2] / (weights[1] + weights[2]) } else { 0.0 };
    Outliers {
        per_sample: c.per_sample,
        size_sigma: 0.5 * (lo + hi),
        spread_sigma: 0.5 * (hi - lo),
        run_mean: 1.0 + c1 / (1.0 - c2),
        run_continue: c2,
        ..Default::default()
    }
}

/// shared::sim's profile for a bench temperature: the same mid, swing, period, phase and wander; no harmonic.
pub fn profile(b: &BenchTemperature) -> TemperatureProfile {
    TemperatureProfile {
        min_c: b.mean_c - 0.5 * b.swing_c,
        max_c: b.mean_c + 0.5 * b.swing_c,
        period_s: b.period_s,
        phase_rad: b.phase_rad,
        wander: (b.wander_sd_c > 0.0).then_some(Wander { sigma_c: b.wander_sd_c, tau_s: b.wander_tau_s }),
    }
}

/// The model that made a record of `g`, as shared::sim's `GyroSim`, and a channel where values sit on a lattice.
pub fn gyro_sim(g: &IndepGyro) -> (GyroSim, Option<Channel>) {
    let mut m = GyroSim {
        bias_dps: g.bias_dps,
        n_deg_per_rt_s: g.n_deg_per_rt_s,
        b_dps: g.b_dps,
        k_dps_per_rt_s: g.k_dps_per_rt_s,
        bandwidth_hz: g.bandwidth_hz,
        temperature: g.coupling.map(|c| TempCoupling { dps_per_c: c.dps_per_c, ref_c: c.ref_c, lag_s: c.lag_s }),
        gauss_markov: g.gauss_markov.map(|m| GaussMarkovSim { sigma_dps: m.sigma_dps, tau_s: m.tau_s }),
        bias_steps: g.jumps.map(|j| BiasSteps { per_hour: j.per_hour, sigma_dps: j.sigma_dps }),
        outliers: g.contamination.as_ref().map(outliers),
        resonance: g.resonance.map(|o| ResonanceSim { sigma_dps: o.sigma_dps, freq_hz: o.freq_hz, q: o.q }),
        bistable: g.telegraph.map(|t| BistableSim {
            step_dps: t.step_dps,
            dwell_low_s: t.dwell_low_s,
            dwell_high_s: t.dwell_high_s,
        }),
        warm_up: g.settling.map(|w| WarmUpSim { size_dps: w.size_dps, tau_s: w.tau_s }),
        ..Default::default()
    };
    for s in &g.sinusoids {
        let _ =
            m.sinusoids.push(Sinusoid { amplitude_dps: s.amplitude_dps, period_s: s.period_s, phase_rad: s.phase_rad });
    }
    (m, g.lattice.map(|q| coarse_channel(q.step_dps)))
}

//! The parameters each effect reports, as types: the `effect_params` objects of the gap report's JSON and the
//! parameter lines of its text. Every value carries its unit in its name; `_se` marks a standard error.

use serde::Serialize;

/// An effect's fitted parameters, typed: one variant per effect. It serialises as the variant's own object (the
/// report's `effect_params`), without a tag, since the report names the effect beside it.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum EffectParams {
    Temperature(TemperatureParams),
    Sinusoid(SinusoidsParams),
    Bandwidth(BandwidthParams),
    GaussMarkov(GaussMarkovParams),
    Quantization(QuantizationParams),
    BiasSteps(BiasStepsParams),
    Outliers(OutliersParams),
    Resonance(ResonanceParams),
    Bistable(BistableParams),
    WarmUp(WarmUpParams),
}

macro_rules! params_of {
    ($($ty:ident => $variant:ident),* $(,)?) => {
        $(impl From<$ty> for EffectParams {
            fn from(p: $ty) -> EffectParams {
                EffectParams::$variant(p)
            }
        })*
    };
}

params_of! {
    TemperatureParams => Temperature,
    SinusoidsParams => Sinusoid,
    BandwidthParams => Bandwidth,
    GaussMarkovParams => GaussMarkov,
    QuantizationParams => Quantization,
    BiasStepsParams => BiasSteps,
    OutliersParams => Outliers,
    ResonanceParams => Resonance,
    BistableParams => Bistable,
    WarmUpParams => WarmUp,
}

/// A first-order bandwidth of the sensor.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BandwidthParams {
    pub bandwidth_hz: f64,
    pub n_deg_per_rt_s: f64,
    pub delta_chi2: f64,
}

/// Bias steps: a random walk of jumps.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BiasStepsParams {
    pub per_hour: f64,
    pub sigma_dps: f64,
    pub count: usize,
    pub at_s: Vec<f64>,
    pub sizes_dps: Vec<f64>,
    pub threshold_dps: f64,
}

/// A bistable bias (random telegraph).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BistableParams {
    pub step_dps: f64,
    pub dwell_low_s: f64,
    pub dwell_high_s: f64,
    pub step_se_dps: f64,
    pub dwell_low_se_s: f64,
    pub dwell_high_se_s: f64,
    pub jumps: usize,
    /// Of the jumps, how many alternate in sign with the one before.
    pub alternating: usize,
    pub window_s: f64,
    /// The least distance between two jumps the scan kept, in windows: 2, or 1 where the rarer state's excursions
    /// last one to two windows and the scan at 2 saw one edge of them.
    pub jumps_apart_windows: usize,
    pub shortest_seen_s: f64,
    pub p_value: f64,
    pub size_spread: f64,
}

/// A first-order Gauss-Markov process.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GaussMarkovParams {
    pub sigma_dps: f64,
    pub tau_s: f64,
    pub delta_chi2: f64,
}

/// Outliers: spikes on a share of the samples, magnitudes uniform on `size_dps +- spread_dps`, in runs of mean
/// length `run_mean` (a run of two goes on with probability `run_continue`); `robust_sigma_dps` is the residual's
/// Gaussian core sd, `count` the spikes flagged.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OutliersParams {
    pub per_sample: f64,
    pub size_dps: f64,
    pub spread_dps: f64,
    pub run_mean: f64,
    pub run_continue: f64,
    pub count: usize,
    pub robust_sigma_dps: f64,
    /// Twice the log-likelihood the spike law gains over the Gaussian core alone: the estimator's test.
    pub lr: f64,
}

/// A quantisation lattice in the rate.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct QuantizationParams {
    pub step_dps: f64,
    pub lattice_point_dps: f64,
    pub n_deg_per_rt_s: f64,
}

/// A resonance: a second-order Gauss-Markov bump in the spectrum.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ResonanceParams {
    pub sigma_dps: f64,
    pub freq_hz: f64,
    pub q: f64,
    pub width_hz: f64,
    pub peak_ratio: f64,
    pub sigma_se_dps: f64,
    pub freq_se_hz: f64,
    pub q_se: f64,
    pub delta_chi2: f64,
}

/// One sinusoid.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SinusoidParams {
    pub amplitude_dps: f64,
    pub period_s: f64,
    pub phase_rad: f64,
    pub amplitude_se_dps: f64,
    pub period_se_s: f64,
}

/// Sinusoids: the strongest one's amplitude, period and phase, then every one.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SinusoidsParams {
    pub amplitude_dps: f64,
    pub period_s: f64,
    pub phase_rad: f64,
    /// The strongest peak of the periodogram over its background, less the look-elsewhere level `ln(bins)`
    /// (a peak counts beyond 7).
    pub peak_excess: f64,
    /// The largest amplitude over its standard error under the noise model (flicker and random walk leaking
    /// through the record's window included).
    pub amplitude_z: f64,
    /// The same among the sinusoids of at least [`crate::effects::SHORT_PERIOD_CYCLES`] cycles in the training
    /// part (0 where there is none): the estimator's own test, where slow noise cannot raise a false peak.
    pub short_period_z: f64,
    pub sinusoids: Vec<SinusoidParams>,
}

/// A coupling to temperature through a first-order lag.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TemperatureParams {
    pub dps_per_c: f64,
    pub lag_s: f64,
    pub ref_c: f64,
    pub t_stat: f64,
    pub dps_per_c_se: f64,
}

/// A warm-up: an exponential settling from the first sample.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct WarmUpParams {
    pub size_dps: f64,
    pub tau_s: f64,
    pub size_se_dps: f64,
    pub t_stat: f64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::Effect;
    use octavar_shared::sim::GyroSim;
    use serde_json::Value;

    fn to_value(params: impl Into<EffectParams>) -> Value {
        serde_json::to_value(params.into()).unwrap()
    }

    fn keys(v: &Value) -> Vec<&str> {
        v.as_object().map(|o| o.keys().map(String::as_str).collect()).unwrap_or_default()
    }

    /// The keys are an interface (the gap report's `effect_params`, read by users' scripts): each set, exactly,
    /// with the names docs/gap.md's vocabulary table gives.
    #[test]
    fn every_effects_keys_are_pinned() {
        let t = to_value(TemperatureParams { dps_per_c: 1.0, lag_s: 1.0, ref_c: 1.0, t_stat: 1.0, dps_per_c_se: 1.0 });
        assert_eq!(keys(&t), ["dps_per_c", "dps_per_c_se", "lag_s", "ref_c", "t_stat"]);
        let one = SinusoidParams {
            amplitude_dps: 1.0,
            period_s: 1.0,
            phase_rad: 0.0,
            amplitude_se_dps: 0.1,
            period_se_s: 0.1,
        };
        let s = to_value(SinusoidsParams {
            amplitude_dps: 1.0,
            period_s: 1.0,
            phase_rad: 0.0,
            peak_excess: 9.0,
            amplitude_z: 12.0,
            short_period_z: 12.0,
            sinusoids: vec![one],
        });
        assert_eq!(
            keys(&s),
            ["amplitude_dps", "amplitude_z", "peak_excess", "period_s", "phase_rad", "short_period_z", "sinusoids"]
        );
        assert_eq!(
            keys(&s["sinusoids"][0]),
            ["amplitude_dps", "amplitude_se_dps", "period_s", "period_se_s", "phase_rad"]
        );
        let b = to_value(BandwidthParams { bandwidth_hz: 1.0, n_deg_per_rt_s: 1.0, delta_chi2: 1.0 });
        assert_eq!(keys(&b), ["bandwidth_hz", "delta_chi2", "n_deg_per_rt_s"]);
        let g = to_value(GaussMarkovParams { sigma_dps: 1.0, tau_s: 1.0, delta_chi2: 1.0 });
        assert_eq!(keys(&g), ["delta_chi2", "sigma_dps", "tau_s"]);
        let q = to_value(QuantizationParams { step_dps: 1.0, lattice_point_dps: 0.0, n_deg_per_rt_s: 1.0 });
        assert_eq!(keys(&q), ["lattice_point_dps", "n_deg_per_rt_s", "step_dps"]);
        let steps = BiasStepsParams {
            per_hour: 1.0,
            sigma_dps: 1.0,
            count: 2,
            at_s: vec![1.0, 2.0],
            sizes_dps: vec![0.1, -0.1],
            threshold_dps: 0.05,
        };
        assert_eq!(keys(&to_value(steps)), ["at_s", "count", "per_hour", "sigma_dps", "sizes_dps", "threshold_dps"]);
        let o = OutliersParams {
            per_sample: 1e-4,
            size_dps: 1.0,
            spread_dps: 0.2,
            run_mean: 1.0,
            run_continue: 0.0,
            count: 3,
            robust_sigma_dps: 0.1,
            lr: 80.0,
        };
        assert_eq!(
            keys(&to_value(o)),
            ["count", "lr", "per_sample", "robust_sigma_dps", "run_continue", "run_mean", "size_dps", "spread_dps"]
        );
        let r = ResonanceParams {
            sigma_dps: 1.0,
            freq_hz: 1.0,
            q: 1.0,
            width_hz: 1.0,
            peak_ratio: 1.0,
            sigma_se_dps: 1.0,
            freq_se_hz: 1.0,
            q_se: 1.0,
            delta_chi2: 1.0,
        };
        let r = to_value(r);
        assert_eq!(
            keys(&r),
            ["delta_chi2", "freq_hz", "freq_se_hz", "peak_ratio", "q", "q_se", "sigma_dps", "sigma_se_dps", "width_hz"]
        );
        let bi = BistableParams {
            step_dps: 1.0,
            dwell_low_s: 1.0,
            dwell_high_s: 1.0,
            step_se_dps: 1.0,
            dwell_low_se_s: 1.0,
            dwell_high_se_s: 1.0,
            jumps: 4,
            alternating: 3,
            window_s: 1.0,
            jumps_apart_windows: 2,
            shortest_seen_s: 1.0,
            p_value: 0.01,
            size_spread: 0.1,
        };
        let bi = to_value(bi);
        assert_eq!(
            keys(&bi),
            [
                "alternating",
                "dwell_high_s",
                "dwell_high_se_s",
                "dwell_low_s",
                "dwell_low_se_s",
                "jumps",
                "jumps_apart_windows",
                "p_value",
                "shortest_seen_s",
                "size_spread",
                "step_dps",
                "step_se_dps",
                "window_s"
            ]
        );
        let w = to_value(WarmUpParams { size_dps: 1.0, tau_s: 1.0, size_se_dps: 0.1, t_stat: 10.0 });
        assert_eq!(keys(&w), ["size_dps", "size_se_dps", "t_stat", "tau_s"]);
        // A NaN is written as null, never an error.
        let nan = to_value(WarmUpParams { size_dps: f64::NAN, tau_s: 1.0, size_se_dps: 0.1, t_stat: 10.0 });
        assert!(nan["size_dps"].is_null());
    }

    /// A joint re-estimation moves the sizes and time scales the model carries and nothing else: the estimator's
    /// standard error and test stay, and an effect the model does not carry keeps its values.
    #[test]
    fn reestimated_parameters_come_from_the_model() {
        use octavar_shared::sim::{GaussMarkovSim, WarmUpSim};
        let gm = EffectParams::from(GaussMarkovParams { sigma_dps: 1.0, tau_s: 10.0, delta_chi2: 50.0 });
        let w = EffectParams::from(WarmUpParams { size_dps: 0.5, tau_s: 60.0, size_se_dps: 0.1, t_stat: 5.0 });
        let gyro = GyroSim {
            gauss_markov: Some(GaussMarkovSim { sigma_dps: 2.0, tau_s: 30.0 }),
            warm_up: Some(WarmUpSim { size_dps: 0.4, tau_s: 90.0 }),
            ..Default::default()
        };
        assert_eq!(
            gm.reestimated(&gyro),
            EffectParams::from(GaussMarkovParams { sigma_dps: 2.0, tau_s: 30.0, delta_chi2: 50.0 })
        );
        // The warm-up's time scale is held in the joint fit: only its size moves.
        assert_eq!(
            w.reestimated(&gyro),
            EffectParams::from(WarmUpParams { size_dps: 0.4, tau_s: 60.0, size_se_dps: 0.1, t_stat: 5.0 })
        );
        assert_eq!(gm.reestimated(&GyroSim::default()), gm);
        assert_eq!(w.effect(), Effect::WarmUp);
        assert_eq!(w.test_statistic(), Some(5.0));
        assert_eq!(gm.test_statistic(), None);
    }
}

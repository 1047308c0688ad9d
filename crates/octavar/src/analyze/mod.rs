//! `octavar analyze`: a rate recording in, the Allan deviation family with intervals and the IEEE 952 fit out.
//!
//! Per channel: the statistics asked for (ADEV, OADEV, MDEV, HDEV, OHDEV, TDEV, TOTDEV) at the taus asked for,
//! each with its chi-square interval (Greenhall's EDF, noise identified per tau), and the noise-term fit on the
//! overlapping Allan variance at octave tau. The writers are modules of their own, one per output, apart from the
//! computation: [`text`] (the Stable32-style tables and the fit), [`json`], [`csv`] (every point), [`model`]
//! (a `model.toml` for `simulate` and `gap`); `crate::export` writes the estimators' configs from them. [`streamed`] gives the same
//! analysis of inputs too large for memory.

pub mod csv;
pub mod json;
pub mod model;
pub mod streamed;
pub mod text;

pub use csv::{points_csv, to_csv};
pub use json::{to_json, to_json_with, Document};
pub use model::{fine_channel, model_from_fits};
pub use text::{fit_report, table, write_report};

use rayon::prelude::*;
use serde::Serialize;

use crate::fit::{fit_deviations, fit_gauss_markov, FitError, FitOptions, GaussMarkovFit, NoiseFit};
use crate::quantity::Quantity;
use crate::stats::{analyze, DataKind, DevPoint, Options, Statistic, StatsError, TauSpec};

/// What went wrong.
#[derive(Debug, thiserror::Error)]
pub enum AnalyzeError {
    /// The statistics could not be computed (too short a record, all gaps...).
    #[error("channel {channel}: {err}")]
    Stats { channel: String, err: StatsError },
}

/// Options of [`analyze_channel`].
#[derive(Clone, Debug)]
pub struct AnalyzeOptions {
    /// Statistics to compute.
    pub stats: Vec<Statistic>,
    /// Their taus.
    pub taus: TauSpec,
    /// Confidence of the deviation intervals (Stable32's 0.683 by default).
    pub confidence: f64,
    /// The noise-term fit (on OADEV at octave tau); `None` skips it.
    pub fit: Option<FitOptions>,
}

impl Default for AnalyzeOptions {
    fn default() -> Self {
        AnalyzeOptions {
            stats: vec![Statistic::Oadev],
            taus: TauSpec::Octave,
            confidence: 0.683,
            fit: Some(FitOptions::default()),
        }
    }
}

/// The analysis of one channel.
#[derive(Clone, Debug)]
pub struct ChannelAnalysis {
    /// Channel (column) name.
    pub name: String,
    /// What the channel measures.
    pub quantity: Quantity,
    /// Unit of the deviations.
    pub unit: String,
    /// Sample period, s.
    pub tau0_s: f64,
    /// Samples, gaps included.
    pub n_samples: usize,
    /// Samples that are gaps (NaN).
    pub n_gaps: usize,
    /// The channel's mean, its static bias (gravity's share included on an accelerometer), where known.
    pub mean: Option<f64>,
    /// Each statistic's points.
    pub stats: Vec<(Statistic, Vec<DevPoint>)>,
    /// The OADEV octave points the fit used.
    pub fit_points: Vec<DevPoint>,
    /// The fit, or why there is none.
    pub fit: Result<NoiseFit, FitError>,
    /// The first-order Gauss-Markov bias matched to the fit's bias region (a Kalman filter's bias model).
    pub bias_model: Option<GaussMarkovFit>,
}

/// Analyse one channel of rate data (deg/s, NaN for gaps) sampled at `rate_hz`.
///
/// # Errors
/// [`AnalyzeError::Stats`] when the series cannot be analysed at all.
pub fn analyze_channel(
    name: &str,
    data: &[f64],
    rate_hz: f64,
    opts: &AnalyzeOptions,
) -> Result<ChannelAnalysis, AnalyzeError> {
    let err = |err| AnalyzeError::Stats { channel: name.to_string(), err };
    // Each statistic through `stats::analyze`, which takes its fastest route: a long gap-free record's octave
    // OADEV without a phase array, ADEV and HDEV from block sums, the others from a prepared series.
    let dev_opts = Options { confidence: opts.confidence, ..Default::default() };
    let tau0_s = 1.0 / rate_hz;
    let deviations = |s: Statistic, taus: &TauSpec| analyze(data, DataKind::Frequency, tau0_s, s, taus, &dev_opts);
    let mut stats = Vec::new();
    for &s in &opts.stats {
        stats.push((s, deviations(s, &opts.taus).map_err(err)?));
    }
    let reuse = stats
        .iter()
        .find(|(s, _)| *s == Statistic::Oadev)
        .filter(|_| opts.taus == TauSpec::Octave)
        .map(|(_, p)| p.clone());
    let fit_points = match reuse {
        Some(p) => p,
        None => deviations(Statistic::Oadev, &TauSpec::Octave).map_err(err)?,
    };
    // The gaps, and the sum of the finite samples, in one pass.
    let (sum, kept, n_gaps) = data
        .par_iter()
        .map(|&v| if v.is_finite() { (v, 1usize, 0usize) } else { (0.0, 0, usize::from(v.is_nan())) })
        .reduce(|| (0.0, 0, 0), |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2));
    let counts = Counts { tau0_s, n_samples: data.len(), n_gaps };
    let mean = (kept > 0).then(|| sum / kept as f64);
    Ok(ChannelAnalysis { mean, ..ChannelAnalysis::fitted(name, counts, stats, fit_points, opts.fit.as_ref()) })
}

/// The sample period and counts of a channel.
#[derive(Clone, Copy, Debug)]
pub struct Counts {
    /// Sample period, s.
    pub tau0_s: f64,
    /// Samples, gaps included.
    pub n_samples: usize,
    /// Samples that are gaps (NaN).
    pub n_gaps: usize,
}

impl ChannelAnalysis {
    /// A channel's analysis from its statistics and its octave OADEV points, fitted here with `fit` (none when
    /// `None`): the one place where every reader's channel gets its fit.
    pub fn fitted(
        name: &str,
        counts: Counts,
        stats: Vec<(Statistic, Vec<DevPoint>)>,
        fit_points: Vec<DevPoint>,
        fit: Option<&FitOptions>,
    ) -> Self {
        let fit = fit_deviations(&fit_points, fit);
        let bias_model = fit.as_ref().ok().and_then(|f| fit_gauss_markov(&fit_points, f));
        ChannelAnalysis {
            name: name.to_string(),
            quantity: Quantity::AngularRate,
            unit: Quantity::AngularRate.unit().to_string(),
            tau0_s: counts.tau0_s,
            n_samples: counts.n_samples,
            n_gaps: counts.n_gaps,
            mean: None,
            fit,
            bias_model,
            stats,
            fit_points,
        }
    }
}

impl ChannelAnalysis {
    /// This analysis as one of a channel of `q` (a series in its base unit): the units of the deviations and of
    /// the fit's terms named for it.
    pub fn with_quantity(mut self, q: Quantity) -> Self {
        self.quantity = q;
        self.unit = q.unit().to_string();
        self.fit = self.fit.map(|f| f.in_units_of(q));
        self
    }
}

/// A short summary row, for `Serialize` users.
#[derive(Clone, Debug, Serialize)]
pub struct FitSummary {
    /// Channel.
    pub name: String,
    /// N, deg/sqrt(s).
    pub n: Option<f64>,
    /// B, deg/s.
    pub b: Option<f64>,
    /// K, deg/s/sqrt(s).
    pub k: Option<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn white(n: usize, sigma: f64, seed: u64) -> Vec<f64> {
        crate::test_signals::white(n, seed).into_iter().map(|v| v * sigma).collect()
    }

    #[test]
    fn white_noise_gives_n_and_a_json_of_the_documented_shape() {
        let rate_hz: f64 = 100.0;
        let n_true = 0.01;
        let data = white(200_000, n_true * rate_hz.sqrt(), 3);
        let opts = AnalyzeOptions { stats: vec![Statistic::Adev, Statistic::Oadev], ..Default::default() };
        let a = analyze_channel("gx", &data, rate_hz, &opts).unwrap();
        let f = a.fit.as_ref().unwrap();
        let n = f.n.value.unwrap();
        assert!((n / n_true - 1.0).abs() < 0.02, "N {n}");
        assert!(f.n.lo.unwrap() <= n_true && n_true <= f.n.hi.unwrap(), "{:?}", f.n);
        // The document's keys are an interface (users' scripts read them): every object's keys, exactly.
        let j = serde_json::to_value(to_json(std::slice::from_ref(&a))).unwrap();
        let keys = |v: &serde_json::Value| -> Vec<String> {
            let mut k: Vec<String> = v.as_object().unwrap().keys().cloned().collect();
            k.sort();
            k
        };
        let ch = &j["channels"][0];
        assert_eq!(keys(&j), ["channels"]);
        assert_eq!(
            keys(ch),
            [
                "bias",
                "bias_model",
                "fit",
                "kind",
                "n_gaps",
                "n_samples",
                "name",
                "record_length",
                "stats",
                "tau0_s",
                "unit"
            ]
        );
        assert_eq!(keys(&ch["record_length"][0]), ["identifiable", "needed_s", "note", "precision", "target", "term"]);
        let mean = data.iter().sum::<f64>() / data.len() as f64;
        assert!((ch["bias"].as_f64().unwrap() - mean).abs() < 1e-12, "{}", ch["bias"]);
        assert_eq!(ch["kind"], "gyro");
        assert_eq!(keys(&ch["stats"]), ["adev", "oadev"]);
        assert_eq!(keys(&ch["stats"]["oadev"][0]), ["alpha", "dev", "edf", "hi", "lo", "m", "n", "tau_s"]);
        assert_eq!(keys(&ch["fit"]), ["B", "K", "N", "Q", "R", "chi2", "classic", "confidence", "dof", "tau_range_s"]);
        for t in ["N", "B", "K", "R", "Q"] {
            assert_eq!(keys(&ch["fit"][t]), ["alt", "hi", "identifiable", "lo", "unit", "value"], "fit.{t}");
            assert_eq!(keys(&ch["fit"][t]["alt"]), ["unit", "value"], "fit.{t}.alt");
        }
        assert_eq!(keys(&ch["fit"]["classic"]), keys(&serde_json::to_value(&f.classic).unwrap()));
        let unfitted = ChannelAnalysis { fit: Err(FitError::TooFewPoints(1)), ..a.clone() };
        let j = serde_json::to_value(to_json(std::slice::from_ref(&unfitted))).unwrap();
        assert_eq!(keys(&j["channels"][0]["fit"]), ["error"]);
        assert_eq!(ch["fit"]["N"]["unit"], "deg/sqrt(s)");
        // The CSV of every point: its header, and one row per point of each statistic, in order.
        let csv = to_csv(std::slice::from_ref(&a));
        let mut lines = csv.lines();
        assert_eq!(lines.next(), Some("channel,stat,m,tau_s,n,alpha,lo,dev,hi,edf"));
        let first = &a.stats[0].1[0];
        let row: Vec<&str> = lines.next().unwrap().split(',').collect();
        assert_eq!((row[0], row[1], row[2]), ("gx", "adev", "1"));
        assert_eq!(row[7].parse::<f64>().unwrap(), first.dev);
        assert_eq!(csv.lines().count(), 1 + a.stats.iter().map(|(_, p)| p.len()).sum::<usize>());
        let m = model_from_fits(std::slice::from_ref(&a), rate_hz, 1.0);
        assert_eq!(m.channels[0].gyro.n_deg_per_rt_s, n);
    }

    #[test]
    fn table_has_stable32_columns() {
        let data = white(10_000, 1.0, 1);
        let a = analyze_channel("g", &data, 1.0, &AnalyzeOptions::default()).unwrap();
        let t = table(Statistic::Oadev, &a.stats[0].1);
        assert!(t.lines().next().unwrap().contains("min sigma"));
        assert_eq!(t.lines().count(), a.stats[0].1.len() + 1);
    }
}

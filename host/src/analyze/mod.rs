//! `octavar analyze`: a rate recording in, the Allan deviation family with intervals and the IEEE 952 fit out.
//!
//! Per channel: the statistics asked for (ADEV, OADEV, MDEV, HDEV, OHDEV, TDEV, TOTDEV) at the taus asked for,
//! each with its chi-square interval (Greenhall's EDF, noise identified per tau), and the noise-term fit on the
//! overlapping Allan variance at octave tau. Writers for the Stable32-style table, the JSON document, a CSV of
//! every point, a `model.toml` for `simulate` and `gap`, and a Kalibr `imu.yaml`.

pub mod json;
pub mod streamed;

pub use json::{to_json, Document};

use std::fmt::Write as _;

use octavar_shared::sensor::{Channel, SensorKind, GENERIC};
use octavar_shared::sim::{BenchSim, ChannelSim, GyroSim};
use rayon::prelude::*;
use serde::Serialize;

use crate::fit::{fit, fit_input, FitError, FitOptions, NoiseFit, Term};
use crate::stats::{analyze_series, DataKind, DevPoint, Options, Series, Statistic, StatsError, TauSpec};

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
    /// The noise-term fit (on OADEV at octave tau).
    pub fit: FitOptions,
    /// Skip the fit.
    pub no_fit: bool,
}

impl Default for AnalyzeOptions {
    fn default() -> Self {
        AnalyzeOptions {
            stats: vec![Statistic::Oadev],
            taus: TauSpec::Octave,
            confidence: 0.683,
            fit: FitOptions::default(),
            no_fit: false,
        }
    }
}

/// The analysis of one channel.
#[derive(Clone, Debug)]
pub struct ChannelAnalysis {
    /// Channel (column) name.
    pub name: String,
    /// Unit of the deviations.
    pub unit: String,
    /// Sample period, s.
    pub tau0_s: f64,
    /// Samples, gaps included.
    pub n_samples: usize,
    /// Samples that are gaps (NaN).
    pub n_gaps: usize,
    /// Each statistic's points.
    pub stats: Vec<(Statistic, Vec<DevPoint>)>,
    /// The OADEV octave points the fit used.
    pub fit_points: Vec<DevPoint>,
    /// The fit, or why there is none.
    pub fit: Result<NoiseFit, FitError>,
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
    let series = Series::new(data, DataKind::Frequency, 1.0 / rate_hz).map_err(err)?;
    let dev_opts = Options { confidence: opts.confidence, ..Default::default() };
    let mut stats = Vec::new();
    for &s in &opts.stats {
        stats.push((s, analyze_series(&series, s, &opts.taus, &dev_opts).map_err(err)?));
    }
    let reuse = stats
        .iter()
        .find(|(s, _)| *s == Statistic::Oadev)
        .filter(|_| opts.taus == TauSpec::Octave)
        .map(|(_, p)| p.clone());
    let fit_points = match reuse {
        Some(p) => p,
        None => analyze_series(&series, Statistic::Oadev, &TauSpec::Octave, &dev_opts).map_err(err)?,
    };
    let fit = if opts.no_fit { Err(FitError::TooFewPoints(0)) } else { fit(&fit_input(&fit_points), &opts.fit) };
    Ok(ChannelAnalysis {
        name: name.to_string(),
        unit: "deg/s".to_string(),
        tau0_s: 1.0 / rate_hz,
        n_samples: data.len(),
        n_gaps: data.par_iter().filter(|v| v.is_nan()).count(),
        stats,
        fit_points,
        fit,
    })
}

/// The Stable32-style table of one statistic: AF, tau, #, alpha, min sigma, sigma, max sigma.
pub fn table(stat: Statistic, points: &[DevPoint]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{:>10} {:>12} {:>10} {:>6} {:>12} {:>12} {:>12}   {}",
        "AF",
        "tau (s)",
        "#",
        "alpha",
        "min sigma",
        "sigma",
        "max sigma",
        stat.name()
    );
    for p in points {
        let _ = writeln!(
            s,
            "{:>10} {:>12.4e} {:>10} {:>6} {:>12.4e} {:>12.4e} {:>12.4e}",
            p.m, p.tau_s, p.n, p.alpha, p.lo, p.dev, p.hi
        );
    }
    s
}

/// The fit as text: each term with its interval and second unit, then the classic readouts.
pub fn fit_report(f: &NoiseFit) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "IEEE 952 fit (weighted NNLS on OADEV, {:.0}% intervals, tau {:.3e}..{:.3e} s, chi2/dof {:.2})",
        f.confidence * 100.0,
        f.tau_range_s[0],
        f.tau_range_s[1],
        if f.dof > 0 { f.chi2 / f.dof as f64 } else { f64::NAN }
    );
    for t in Term::ALL {
        let e = f.term(t);
        let (alt_unit, k) = t.alt_unit();
        let line = match (e.value, e.lo, e.hi) {
            (Some(v), Some(lo), Some(hi)) => {
                format!("{:>3} = {v:.4e} {} ({lo:.3e} .. {hi:.3e})   = {:.4e} {alt_unit}", t.name(), e.unit, v * k)
            }
            (_, _, Some(hi)) => format!("{:>3}   not identifiable (at most {hi:.3e} {})", t.name(), e.unit),
            _ => format!("{:>3}   not fitted", t.name()),
        };
        let _ = writeln!(s, "{line}");
    }
    let c = &f.classic;
    let show = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.4e}"));
    let _ = writeln!(
        s,
        "classic readouts: N (-1/2 line at 1 s) {} deg/sqrt(s), B (floor/0.6643) {} deg/s, K (+1/2 line at 3 s) {} deg/s/sqrt(s)",
        show(c.n),
        show(c.b),
        show(c.k)
    );
    s
}

/// Every point of every statistic as CSV: `channel,stat,m,tau_s,n,alpha,lo,dev,hi,edf`.
pub fn to_csv(channels: &[ChannelAnalysis]) -> String {
    points_csv(channels.iter().flat_map(|c| c.stats.iter().map(|(stat, pts)| (c.name.as_str(), *stat, &pts[..]))))
}

/// The CSV of deviation points: a header, then one row per point of each (channel, statistic, points), as
/// `analyze --csv` and the demo's `adev.csv` write it (`channel,stat,m,tau_s,n,alpha,lo,dev,hi,edf`).
pub fn points_csv<'a>(series: impl IntoIterator<Item = (&'a str, Statistic, &'a [DevPoint])>) -> String {
    let mut s = String::from("channel,stat,m,tau_s,n,alpha,lo,dev,hi,edf\n");
    for (channel, stat, pts) in series {
        for p in pts {
            let _ = writeln!(
                s,
                "{},{},{},{},{},{},{},{},{},{}",
                channel,
                stat.name().to_ascii_lowercase(),
                p.m,
                p.tau_s,
                p.n,
                p.alpha,
                p.lo,
                p.dev,
                p.hi,
                p.edf
            );
        }
    }
    s
}

/// A simulation model from the fits: one generic channel per analysed channel, with the identifiable terms
/// (a term that is not identifiable is left out). The channel's ADC is fine enough (16 bits over +/-range)
/// that it adds no visible quantisation; `gap` adds quantisation as an effect where the data show a lattice.
pub fn model_from_fits(channels: &[ChannelAnalysis], rate_hz: f64, data_range_dps: f64) -> BenchSim {
    let mut out = heapless::Vec::new();
    for c in channels.iter().take(octavar_shared::sim::MAX_CHANNELS) {
        let Ok(f) = &c.fit else { continue };
        let gyro = f.sim_terms(GyroSim::default());
        let _ = out.push(ChannelSim { sensor: SensorKind::Generic, channel: Some(fine_channel(data_range_dps)), gyro });
    }
    BenchSim { fs_hz: rate_hz, seed: 0, temperature: Default::default(), channels: out }
}

/// A generic channel whose 16-bit ADC spans +/-`range_dps`.
pub fn fine_channel(range_dps: f64) -> Channel {
    let range = if range_dps.is_finite() && range_dps > 0.0 { range_dps } else { 100.0 };
    let adc = octavar_shared::sensor::Adc { bits: 16, vref_mv: 3300.0 };
    let gyro = octavar_shared::sensor::GyroModel {
        sensitivity_mv_per_dps: 1650.0 / range,
        null_mv: 1650.0,
        range_dps: range,
        ..GENERIC
    };
    Channel { gyro, front: octavar_shared::sensor::FrontEnd::WIRE, adc }
}

/// A Kalibr `imu.yaml` for one channel's fit. Kalibr wants continuous-time densities in SI units:
/// `gyroscope_noise_density` = N in rad/s/sqrt(Hz) (N deg/sqrt(s) times pi/180), and `gyroscope_random_walk` =
/// the bias random walk K in rad/s^2/sqrt(Hz) (K deg/s/sqrt(s) times pi/180). Where K is not identifiable the
/// bias-instability line is used as a conservative stand-in, B / sqrt(tau_B) (documented in the file).
pub fn kalibr_yaml(c: &ChannelAnalysis, rate_hz: f64) -> Option<String> {
    let f = c.fit.as_ref().ok()?;
    let d2r = std::f64::consts::PI / 180.0;
    let n = f.n.value.or(f.classic.n)?;
    let (rw, note) = match f.k.value {
        Some(k) => (k * d2r, "K, the rate random walk of the fit".to_string()),
        None => {
            let (b, tau) = (f.b.value.or(f.classic.b)?, f.classic.b_tau_s?);
            (b * d2r / tau.sqrt(), format!("K not identifiable: B / sqrt(tau_B) with tau_B = {tau:.3e} s"))
        }
    };
    Some(format!(
        "# octavar analyze: gyro channel {name}. Gyroscope terms only; add your accelerometer's.\n\
         # gyroscope_noise_density = N [rad/s/sqrt(Hz)] = {n:.6e} deg/sqrt(s) * pi/180\n\
         # gyroscope_random_walk   = {note} [rad/s^2/sqrt(Hz)]\n\
         rostopic: /imu0\n\
         update_rate: {rate_hz}\n\
         gyroscope_noise_density: {gnd:.6e}\n\
         gyroscope_random_walk: {rw:.6e}\n",
        name = c.name,
        gnd = n * d2r,
    ))
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
        let fs: f64 = 100.0;
        let n_true = 0.01;
        let data = white(200_000, n_true * fs.sqrt(), 3);
        let opts = AnalyzeOptions { stats: vec![Statistic::Adev, Statistic::Oadev], ..Default::default() };
        let a = analyze_channel("gx", &data, fs, &opts).unwrap();
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
        assert_eq!(keys(ch), ["fit", "n_gaps", "n_samples", "name", "stats", "tau0_s", "unit"]);
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
        let y = kalibr_yaml(&a, fs).unwrap();
        let gnd: f64 = y.lines().find_map(|l| l.strip_prefix("gyroscope_noise_density: ")).unwrap().parse().unwrap();
        assert!((gnd / (n * std::f64::consts::PI / 180.0) - 1.0).abs() < 1e-5);
        // The CSV of every point: its header, and one row per point of each statistic, in order.
        let csv = to_csv(std::slice::from_ref(&a));
        let mut lines = csv.lines();
        assert_eq!(lines.next(), Some("channel,stat,m,tau_s,n,alpha,lo,dev,hi,edf"));
        let first = &a.stats[0].1[0];
        let row: Vec<&str> = lines.next().unwrap().split(',').collect();
        assert_eq!((row[0], row[1], row[2]), ("gx", "adev", "1"));
        assert_eq!(row[7].parse::<f64>().unwrap(), first.dev);
        assert_eq!(csv.lines().count(), 1 + a.stats.iter().map(|(_, p)| p.len()).sum::<usize>());
        let m = model_from_fits(std::slice::from_ref(&a), fs, 1.0);
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

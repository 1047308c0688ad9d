//! The JSON document `octavar analyze --json` writes, as types: per channel its statistics (one row per tau,
//! NaN written as null) and its noise-term fit (each term with its interval and second unit, the fit's quality
//! and the classic readouts), or why there is no fit.
//!
//! `{"channels": [{"name", "kind" (gyro or accel), "unit", "tau0_s", "n_samples", "n_gaps", "bias", "stats":
//! {"<stat>": [{"m", "tau_s", "n", "dev", "lo", "hi", "alpha", "edf"}]}, "fit": {"N": {"value", "lo", "hi", "unit",
//! "identifiable", "alt": {"unit", "value"}}, ..., "chi2", "dof", "confidence", "tau_range_s", "classic"} or
//! {"error"}, "bias_model": {"sigma", "tau_c_s", "tau_range_s", "points", "max_misfit", "chi2_per_dof"} or null,
//! "record_length": [{"term", "identifiable", "precision", "target", "needed_s", "note"}] or null, and with
//! `--datasheet` "datasheet": [{"term", "datasheet", "written", "measured", "ratio", "ratio_lo", "ratio_hi",
//! "verdict"}]}]}`.

use std::collections::BTreeMap;

use serde::Serialize;

use super::ChannelAnalysis;
use crate::datasheet::{compare, Comparison, Datasheet};
use crate::fit::{record_length, ClassicReadouts, GaussMarkovFit, NoiseFit, Term, TermPrecision};
use crate::quantity::Quantity;
use crate::stats::DevPoint;

/// The whole document.
#[derive(Debug, Serialize)]
pub struct Document<'a> {
    /// One entry per channel, in the order analysed.
    pub channels: Vec<ChannelDoc<'a>>,
}

/// One channel.
#[derive(Debug, Serialize)]
pub struct ChannelDoc<'a> {
    pub name: &'a str,
    /// `gyro` or `accel`.
    pub kind: &'static str,
    pub unit: &'a str,
    pub tau0_s: f64,
    pub n_samples: usize,
    pub n_gaps: usize,
    /// The static bias (the channel's mean, gravity included on an accelerometer), in `unit`; null if unknown.
    pub bias: Option<f64>,
    /// By the statistic's lower-case name (`oadev`, `mdev`, ...).
    pub stats: BTreeMap<String, Vec<PointDoc>>,
    pub fit: FitDoc<'a>,
    /// Each term the datasheet gives against the fit, where `--datasheet` was given; absent otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub datasheet: Option<Vec<Comparison>>,
    /// Per term, the precision reached and the record length that reaches its target; null without a fit.
    pub record_length: Option<Vec<TermPrecision>>,
    /// The first-order Gauss-Markov bias model, or null.
    pub bias_model: Option<&'a GaussMarkovFit>,
}

/// One row of a statistic; the bounds and EDF are null where they were not computed.
#[derive(Debug, Serialize)]
pub struct PointDoc {
    pub m: u64,
    pub tau_s: f64,
    pub n: u64,
    pub dev: f64,
    pub lo: Option<f64>,
    pub hi: Option<f64>,
    pub alpha: i32,
    pub edf: Option<f64>,
}

/// The fit, or why there is none.
#[derive(Debug, Serialize)]
#[serde(untagged)]
pub enum FitDoc<'a> {
    Fit(Box<FitTerms<'a>>),
    Error { error: String },
}

/// The five terms and the fit's quality.
#[derive(Debug, Serialize)]
pub struct FitTerms<'a> {
    #[serde(rename = "Q")]
    pub q: TermDoc,
    #[serde(rename = "N")]
    pub n: TermDoc,
    #[serde(rename = "B")]
    pub b: TermDoc,
    #[serde(rename = "K")]
    pub k: TermDoc,
    #[serde(rename = "R")]
    pub r: TermDoc,
    pub chi2: f64,
    pub dof: usize,
    pub confidence: f64,
    pub tau_range_s: [f64; 2],
    pub classic: &'a ClassicReadouts,
}

/// One term: the value and interval in its IEEE 952 unit, and the value in its customary second unit.
#[derive(Debug, Serialize)]
pub struct TermDoc {
    pub value: Option<f64>,
    pub lo: Option<f64>,
    pub hi: Option<f64>,
    pub unit: &'static str,
    pub identifiable: bool,
    pub alt: AltDoc,
}

/// A term's value in its second unit (deg/sqrt(h) for N, deg/h for B, ...).
#[derive(Debug, Serialize)]
pub struct AltDoc {
    pub unit: &'static str,
    pub value: Option<f64>,
}

/// The document of `channels`.
pub fn to_json(channels: &[ChannelAnalysis]) -> Document<'_> {
    to_json_with(channels, None)
}

/// The document of `channels`, each fit compared with `sheet` where given.
pub fn to_json_with<'a>(channels: &'a [ChannelAnalysis], sheet: Option<&Datasheet>) -> Document<'a> {
    Document { channels: channels.iter().map(|c| channel(c, sheet)).collect() }
}

fn channel<'a>(c: &'a ChannelAnalysis, sheet: Option<&Datasheet>) -> ChannelDoc<'a> {
    let stats = c.stats.iter().map(|(s, pts)| (s.name().to_ascii_lowercase(), pts.iter().map(point).collect()));
    let fit = match &c.fit {
        Ok(f) => FitDoc::Fit(Box::new(terms(f, c.quantity))),
        Err(e) => FitDoc::Error { error: e.to_string() },
    };
    ChannelDoc {
        name: &c.name,
        kind: c.quantity.kind(),
        unit: &c.unit,
        tau0_s: c.tau0_s,
        n_samples: c.n_samples,
        n_gaps: c.n_gaps,
        bias: c.mean,
        stats: stats.collect(),
        fit,
        bias_model: c.bias_model.as_ref(),
        record_length: c.fit.as_ref().ok().map(|f| record_length(f, c.n_samples as f64 * c.tau0_s)),
        datasheet: c.fit.as_ref().ok().zip(sheet.and_then(|d| d.sensor(c.quantity))).map(|(f, s)| compare(f, s)),
    }
}

fn point(p: &DevPoint) -> PointDoc {
    PointDoc {
        m: p.m,
        tau_s: p.tau_s,
        n: p.n,
        dev: p.dev,
        lo: finite(p.lo),
        hi: finite(p.hi),
        alpha: p.alpha,
        edf: finite(p.edf),
    }
}

fn terms(f: &NoiseFit, q: Quantity) -> FitTerms<'_> {
    let term = |t: Term| {
        let e = f.term(t);
        let (unit, k) = t.alt_unit_of(q);
        TermDoc {
            value: e.value,
            lo: e.lo,
            hi: e.hi,
            unit: e.unit,
            identifiable: e.identifiable,
            alt: AltDoc { unit, value: e.value.map(|v| v * k) },
        }
    };
    FitTerms {
        q: term(Term::Q),
        n: term(Term::N),
        b: term(Term::B),
        k: term(Term::K),
        r: term(Term::R),
        chi2: f.chi2,
        dof: f.dof,
        confidence: f.confidence,
        tau_range_s: f.tau_range_s,
        classic: &f.classic,
    }
}

fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

//! The transient disturbances of a gap diagnosis's two parts (training and holdout), found before anything else
//! is done and masked as gaps.
//!
//! A bump of the bench, a tug on a cable, a burst of spikes lasting seconds to minutes is an event, not a noise
//! process: left in, one 70 s disturbance makes the distribution view's gap thousands and every candidate is then
//! judged on that one number. Each part is scanned on its own ([`super::scan`]), the events become
//! NaN gaps in a copy of the record, and the statistics, the fit, every view and every ensemble member (which
//! copies the record's gaps) then see the rest. Isolated single-sample spikes at a steady rate are left in: they
//! are the `outliers` process, which the diagnosis models.

use serde::Serialize;

use super::{mask, scan, Transient};
use crate::input::GapInput;

/// Which part of the record.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Part {
    /// The training part.
    Training,
    /// The held-out part.
    Holdout,
}

impl Part {
    /// `training` or `holdout`.
    pub fn name(self) -> &'static str {
        match self {
            Part::Training => "training",
            Part::Holdout => "holdout",
        }
    }
}

/// One transient disturbance masked from the record.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Masked {
    /// The part it lies in.
    pub part: Part,
    /// Its start, s from the start of its part.
    pub start_s: f64,
    /// Its duration, s.
    pub duration_s: f64,
    /// Its largest excursion from the local baseline, deg/s.
    pub peak_dps: f64,
    /// The event as the scan found it (samples from the start of its part).
    #[serde(skip)]
    pub event: Transient,
}

/// The transient disturbances of both parts of `input`, in time order.
pub fn find(input: &GapInput) -> Vec<Masked> {
    let rate_hz = input.rate_hz;
    let n = input.n_train;
    let parts = [(Part::Training, &input.rate_dps[..n]), (Part::Holdout, &input.rate_dps[n..])];
    let mut out = Vec::new();
    for (part, x) in parts {
        if x.is_empty() {
            continue;
        }
        for e in scan(x, rate_hz).events {
            out.push(Masked {
                part,
                start_s: e.start as f64 / rate_hz,
                duration_s: e.len as f64 / rate_hz,
                peak_dps: e.peak_dps,
                event: e,
            });
        }
    }
    out
}

/// `input` with the samples of `found` set to NaN (gaps).
pub fn masked(input: &GapInput, found: &[Masked]) -> GapInput {
    let mut out = input.clone();
    let n = input.n_train;
    let (train, hold) = out.rate_dps.split_at_mut(n);
    for (part, x) in [(Part::Training, train), (Part::Holdout, hold)] {
        let events: Vec<Transient> = found.iter().filter(|m| m.part == part).map(|m| m.event.clone()).collect();
        mask(x, &events);
    }
    out
}

/// Seconds masked in each part: `[training, holdout]`.
pub fn seconds(found: &[Masked]) -> [f64; 2] {
    // An empty sum of f64 is -0.0; adding 0.0 makes it read as 0.
    let sum = |p: Part| found.iter().filter(|m| m.part == p).map(|m| m.duration_s).sum::<f64>() + 0.0;
    [sum(Part::Training), sum(Part::Holdout)]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bump in each part is found in its own part, at its own time, and masked there; nothing else moves.
    #[test]
    fn a_bump_in_each_part_is_found_and_masked_where_it_lies() {
        let rate_hz = 10.0;
        let mut x: Vec<f64> = octavar_stats::test_signals::white(40_000, 5).iter().map(|v| 0.01 * v).collect();
        for v in &mut x[5_000..5_100] {
            *v += 0.5;
        }
        for v in &mut x[30_000..30_030] {
            *v -= 0.8;
        }
        let input = GapInput::split(x.clone(), None, rate_hz, 0.5).unwrap();
        let found = find(&input);
        assert_eq!(found.len(), 2, "{found:?}");
        let (a, b) = (&found[0], &found[1]);
        assert_eq!((a.part, b.part), (Part::Training, Part::Holdout));
        assert!((a.start_s - 500.0).abs() < 1.0 && (a.duration_s - 10.0).abs() < 2.0, "{a:?}");
        assert!((b.start_s - 1000.0).abs() < 1.0 && (b.duration_s - 3.0).abs() < 2.0, "{b:?}");
        assert!((a.peak_dps - 0.5).abs() < 0.06 && (b.peak_dps - 0.8).abs() < 0.06, "{a:?} {b:?}");
        let m = masked(&input, &found);
        let nan: Vec<usize> = (0..x.len()).filter(|&i| m.rate_dps[i].is_nan()).collect();
        assert!(nan.contains(&5_050) && nan.contains(&30_015), "the bumps are masked");
        assert!(nan.len() < 150, "{} samples masked", nan.len());
        let s = seconds(&found);
        assert!((s[0] - a.duration_s).abs() < 1e-12 && (s[1] - b.duration_s).abs() < 1e-12);
    }
}

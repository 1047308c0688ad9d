//! How long to record: for each term of a fit, the relative precision the record reached (from its interval) and
//! the record length that would reach a target precision; for a term the record cannot see, how long a record
//! would show one as large as its upper bound.
//!
//! The half-width of a term's interval shrinks about as `1 / sqrt(T)` with the record length T: every octave's
//! EDF grows as T. That is the law used here; for K and R it is conservative, since a longer record also reaches
//! longer taus where they dominate. A term the fit kept but could not tell from zero is identified once its square
//! is twice its standard error, which shrinks by the same law. A term the fit left out is placed by where one a
//! tenth of its upper bound would show: it reaches the rest of the curve at some tau, and a record of
//! [`TAUS_PER_RECORD`] times that tau has octaves there with the EDF to see it. Q and N live at the shortest taus, set by the sample rate, not the
//! length: a record cannot be made long enough to show them.

use serde::Serialize;

use super::{NoiseFit, Term};

/// The target relative precision (interval half-width over value) of each term: 10%, and 25% for K and R.
pub fn target_precision(t: Term) -> f64 {
    match t {
        Term::K | Term::R => 0.25,
        _ => 0.10,
    }
}

/// A record spans this many times the longest tau it can judge a term at (its top octaves have the EDF of a few
/// independent differences beyond it).
pub const TAUS_PER_RECORD: f64 = 8.0;

/// A term that is not identifiable is placed for one this many times smaller than its upper bound.
pub const SMALLER: f64 = 10.0;

/// One term's precision and the record it needs.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TermPrecision {
    /// The term's name (Q, N, B, K, R).
    pub term: &'static str,
    /// Whether the fit identified it.
    pub identifiable: bool,
    /// The half-width of its interval over its value, where it has both.
    pub precision: Option<f64>,
    /// The target precision.
    pub target: f64,
    /// The record length that reaches the target (identifiable), or that would show a term a tenth of its upper
    /// bound (not identifiable), s; `None` where no record length can.
    pub needed_s: Option<f64>,
    /// The reading in words.
    pub note: String,
}

/// Each term's precision for a fit made on a record of `record_s` seconds.
pub fn record_length(fit: &NoiseFit, record_s: f64) -> Vec<TermPrecision> {
    Term::ALL.iter().map(|&t| one(fit, t, record_s)).collect()
}

fn one(fit: &NoiseFit, t: Term, record_s: f64) -> TermPrecision {
    let e = fit.term(t);
    let unit = e.unit;
    let target = target_precision(t);
    let base = TermPrecision {
        term: t.name(),
        identifiable: e.identifiable,
        precision: None,
        target,
        needed_s: None,
        note: String::new(),
    };
    if let (true, Some(v), Some(lo), Some(hi)) = (e.identifiable, e.value, e.lo, e.hi) {
        let p = (hi - lo) / (2.0 * v);
        let needed = record_s * (p / target).powi(2);
        let note = if p <= target {
            format!("+-{:.0}%: the record reaches the +-{:.0}% target", p * 100.0, target * 100.0)
        } else {
            format!("+-{:.0}%: a record of {} would reach +-{:.0}%", p * 100.0, duration(needed), target * 100.0)
        };
        return TermPrecision { precision: Some(p), needed_s: Some(needed), note, ..base };
    }
    let Some(bound) = e.hi.filter(|b| *b > 0.0) else {
        return TermPrecision { note: "not fitted".to_string(), ..base };
    };
    match t {
        Term::Q | Term::N => TermPrecision {
            note: format!(
                "not identifiable (at most {bound:.3e} {unit}): it lives at the shortest taus, so a longer record does not \
                 show it; a higher sample rate would"
            ),
            ..base
        },
        _ => {
            // A term the fit kept but could not tell from zero: its square's deviation shrinks as 1 / sqrt(T),
            // and it is identified once its square is twice that deviation.
            let theta = fit.squares[t as usize];
            let z = super::intervals::normal_quantile(fit.confidence);
            let sd = (bound * bound - theta) / z;
            if theta > 0.0 && sd > 0.0 {
                let needed = record_s * (2.0 * sd / theta).powi(2);
                return TermPrecision {
                    needed_s: Some(needed),
                    note: format!(
                        "not identifiable (at most {bound:.3e} {unit}): if it is as large as the fit's {:.3e}, a record of \
                         about {} would identify it",
                        theta.sqrt(),
                        duration(needed)
                    ),
                    ..base
                };
            }
            // A term the fit left out: placed for one a tenth of its bound, by the tau where it would reach the
            // rest of the curve.
            let v = bound / SMALLER;
            let others = |tau: f64| -> f64 {
                Term::ALL.iter().filter(|&&u| u != t).map(|&u| fit.term_avar(u, tau)).sum::<f64>()
            };
            let mine = |tau: f64| v * v * t.basis_with(tau, fit.bandwidth_hz);
            let start = (record_s / TAUS_PER_RECORD).max(1e-9);
            let reach = (0..400).map(|i| start * 2f64.powf(i as f64 / 4.0)).find(|&tau| mine(tau) >= others(tau));
            match reach {
                Some(tau) => {
                    let needed = tau * TAUS_PER_RECORD;
                    TermPrecision {
                        needed_s: Some(needed),
                        note: format!(
                            "not identifiable (at most {bound:.3e} {unit}): one a tenth as large would show in a record of \
                             about {}",
                            duration(needed)
                        ),
                        ..base
                    }
                }
                None => TermPrecision {
                    note: format!(
                        "not identifiable (at most {bound:.3e} {unit}): one a tenth as large stays under the other terms \
                         at every tau"
                    ),
                    ..base
                },
            }
        }
    }
}

/// A duration in the unit that reads best: s, min, h or days.
pub fn duration(s: f64) -> String {
    if s < 120.0 {
        format!("{s:.0} s")
    } else if s < 7200.0 {
        format!("{:.0} min", s / 60.0)
    } else if s < 4.0 * 86400.0 {
        format!("{:.1} h", s / 3600.0)
    } else {
        format!("{:.1} days", s / 86400.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::{fit_deviations, octave_oadev, FitOptions};
    use crate::{DataKind, Series};

    fn fitted(k: f64, n: usize, rate: f64) -> NoiseFit {
        let w = crate::test_signals::white(n, 31);
        let v = crate::test_signals::white(n, 32);
        let mut walk = 0.0;
        let data: Vec<f64> = (0..n)
            .map(|i| {
                walk += k / rate.sqrt() * v[i];
                0.01 * rate.sqrt() * w[i] + walk
            })
            .collect();
        let series = Series::new(&data, DataKind::Frequency, 1.0 / rate).unwrap();
        fit_deviations(&octave_oadev(&series, 0.683).unwrap(), Some(&FitOptions::default())).unwrap()
    }

    #[test]
    fn the_record_needed_follows_the_inverse_square_law_and_a_longer_record_gets_there() {
        let (rate, n) = (100.0, 400_000);
        let fit = fitted(1e-3, n, rate);
        let record = n as f64 / rate;
        let k = record_length(&fit, record).into_iter().find(|p| p.term == "K").unwrap();
        let p = k.precision.expect("K identifiable");
        assert!((k.needed_s.unwrap() / (record * (p / 0.25).powi(2)) - 1.0).abs() < 1e-12);
        // Eight times the record: the precision the law predicts, within the estimates' own scatter.
        let long = fitted(1e-3, 8 * n, rate);
        let k8 = record_length(&long, 8.0 * record).into_iter().find(|p| p.term == "K").unwrap();
        let predicted = p / 8f64.sqrt();
        let got = k8.precision.unwrap();
        assert!(got < p && (got / predicted).ln().abs() < 0.5, "{p} -> {got}, law {predicted}");
    }

    #[test]
    fn a_term_the_record_cannot_see_says_how_long_would_show_it() {
        let (rate, n) = (100.0, 200_000);
        let fit = fitted(0.0, n, rate);
        let out = record_length(&fit, n as f64 / rate);
        let k = out.iter().find(|p| p.term == "K").unwrap();
        assert!(!k.identifiable);
        let needed = k.needed_s.expect("a bound places it");
        assert!(needed > n as f64 / rate, "{k:?}");
        assert!(k.note.contains("would show") || k.note.contains("would identify"), "{k:?}");
        let q = out.iter().find(|p| p.term == "Q").unwrap();
        assert!(q.needed_s.is_none() && (q.note.contains("sample rate") || q.note == "not fitted"), "{q:?}");
    }
}

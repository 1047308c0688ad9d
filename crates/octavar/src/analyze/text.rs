//! The text `octavar analyze` prints: per channel a header line, Stable32's table for each statistic, and the
//! fit with its intervals and the classic readouts.

use std::fmt::Write as _;
use std::io;

use super::ChannelAnalysis;
use crate::datasheet::Datasheet;
use crate::fit::{NoiseFit, Term};
use crate::quantity::Quantity;
use crate::stats::{DevPoint, Statistic};

/// Write the whole report to `w`: a line naming the source, then each channel's tables and fit (or why it has
/// none), and the fit against `sheet` where a datasheet was given.
///
/// # Errors
/// The sink's.
pub fn write_report(
    w: &mut dyn io::Write,
    source: &str,
    samples: u64,
    rate_hz: f64,
    channels: &[ChannelAnalysis],
    sheet: Option<&Datasheet>,
) -> io::Result<()> {
    writeln!(w, "# {source}: {samples} samples at {rate_hz} Hz")?;
    for c in channels {
        writeln!(w, "\n== {} ({}, {}; {} samples, {} gaps)", c.name, c.quantity.kind(), c.unit, c.n_samples, c.n_gaps)?;
        if let Some(m) = c.mean {
            let extra = match c.quantity {
                Quantity::Acceleration => format!(" = {:.4} mg", m / crate::quantity::STANDARD_GRAVITY * 1000.0),
                Quantity::AngularRate => format!(" = {:.4e} deg/h", m * 3600.0),
            };
            writeln!(w, "bias (the static mean) {m:.6e} {}{extra}", c.unit)?;
        }
        for (stat, pts) in &c.stats {
            w.write_all(table(*stat, pts).as_bytes())?;
        }
        match &c.fit {
            Ok(f) => {
                w.write_all(fit_report(f, c.quantity).as_bytes())?;
                w.write_all(bias_model_line(c).as_bytes())?;
                w.write_all(record_length_lines(f, c.n_samples as f64 * c.tau0_s).as_bytes())?;
                if let Some(sensor) = sheet.and_then(|d| d.sensor(c.quantity)) {
                    let comparison =
                        crate::datasheet::comparison_text(&crate::datasheet::compare(f, sensor), c.quantity);
                    w.write_all(comparison.as_bytes())?;
                }
            }
            Err(e) => writeln!(w, "no fit: {e}")?,
        }
    }
    Ok(())
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

/// The fit of a channel of `q` as text: each term with its interval and second unit, then the classic readouts.
pub fn fit_report(f: &NoiseFit, q: Quantity) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "IEEE 952 fit (log-domain fit on OADEV, {:.0}% intervals, tau {:.3e}..{:.3e} s, chi2/dof {:.2})",
        f.confidence * 100.0,
        f.tau_range_s[0],
        f.tau_range_s[1],
        if f.dof > 0 { f.chi2 / f.dof as f64 } else { f64::NAN }
    );
    for t in Term::ALL {
        let e = f.term(t);
        let (alt_unit, k) = t.alt_unit_of(q);
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
        "classic readouts: N (-1/2 line at 1 s) {} {}, B (floor/0.6643) {} {}, K (+1/2 line at 3 s) {} {}",
        show(c.n),
        Term::N.unit_of(q),
        show(c.b),
        Term::B.unit_of(q),
        show(c.k),
        Term::K.unit_of(q),
    );
    s
}

/// The Gauss-Markov bias model of a channel, for a Kalman filter, with its match's quality.
pub fn bias_model_line(c: &ChannelAnalysis) -> String {
    match &c.bias_model {
        Some(gm) => format!(
            "bias model for a filter (first-order Gauss-Markov): sigma {:.4e} {}, correlation time {:.4e} s; matched \
             over tau {:.3e}..{:.3e} s ({} points, within {:.0}% where precise, chi2/dof {:.2})\n",
            gm.sigma,
            c.unit,
            gm.tau_c_s,
            gm.tau_range_s[0],
            gm.tau_range_s[1],
            gm.points,
            gm.max_misfit * 100.0,
            gm.chi2_per_dof
        ),
        None => "bias model for a filter: none (the curve has no bias region of three points)\n".to_string(),
    }
}

/// How long to record: each term's precision and the record that reaches its target, or shows it.
pub fn record_length_lines(f: &NoiseFit, record_s: f64) -> String {
    let mut s = format!("how long to record (this record: {}):\n", crate::fit::duration(record_s));
    for p in crate::fit::record_length(f, record_s) {
        let _ = writeln!(s, "{:>3}   {}", p.term, p.note);
    }
    s
}

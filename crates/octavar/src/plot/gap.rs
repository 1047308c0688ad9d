//! The data of the sim-to-real gap figure (`octavar gap --plot`, the demo's `gap_<channel>.png`), [`GapFigure`],
//! built from a diagnosis and the record it was made from ([`GapFigure::new`]); [`super::gap_plot`] draws it.
//!
//! Where a gyro and the simulation of its fitted model part is often not in the Allan deviation: a spectral line,
//! heavy tails, a coherence with the temperature. So the figure has one panel per view the diagnosis compared
//! (a view the report lacks gets none, the temperature view only comes with a temperature), each showing, on the
//! training part the model was fitted on:
//!
//! - the record's value at each point of the view (dots). A model with a temperature coupling is judged in the
//!   temperature view on what its coupling leaves, so there the record less the chain's response is drawn too
//!   (open dots): that is what the chain's band is compared with;
//! - the band of the base model's ensemble and the band of the model with every effect of the chain: the
//!   ensemble mean ± 2 sd, with the sd the z-scores are judged against, taken in the view's own domain and then
//!   converted to the panel's quantity (see the table);
//! - where the gap lay before each step of the chain (the first strongly, each numbered with its step and
//!   effect), or the located gap when no effect was found, and what is left unexplained.
//!
//! | view | x axis (log) | y axis | from the view's domain |
//! |------|--------------|--------|------------------------|
//! | adev | tau, s | Allan deviation, deg/s (log) | exp of ln OADEV |
//! | psd | frequency f = 1/tau, Hz | one-sided PSD, (deg/s)²/Hz (log) | exp of ln PSD |
//! | distribution | tau, s | excess kurtosis (linear): of the Allan differences at each octave tau, and of the local residual at tau0 (its own marker); skewness, tail share and lattice share as text | plain |
//! | temperature | period, s | coherence magnitude with the temperature, 0..1 | tanh of atanh |
//!
//! A time panel below shows the whole record (a min/max envelope per column, not every sample), the split
//! between training and holdout, and the transient disturbances masked before the diagnosis, shaded in red.
//! Rates are in deg/s, as the diagnosis works in them. The located bands are in tau seconds in the report; on the
//! PSD panel they become frequencies (f = 1/tau), on the temperature panel they are periods already.
//!
//! # Examples
//!
//! ```no_run
//! use octavar::gap::{diagnose, GapInput, GapOptions};
//! use octavar::plot::{gap_plot, GapFigure, PlotOptions};
//! # let rate_dps: Vec<f64> = Vec::new();
//! let input = GapInput::split(rate_dps, None, 10.0, 0.5)?;
//! let report = diagnose(&input, &GapOptions::default(), &|_, _, _| {})?;
//! let opts = PlotOptions::gap_figure("Sim-to-real gap");
//! gap_plot(&GapFigure::new(&report, &input), &opts, std::path::Path::new("gap.png"))?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::gap::compare::{PointZ, ViewGap};
use crate::gap::transients::Part;
use crate::gap::{GapInput, GapReport, ViewKind};

/// Columns of the time panel's envelope: more than a figure has pixels across.
pub const TIME_COLUMNS: usize = 2400;

/// A record longer than this is drawn against hours, s.
const HOURS_FROM_S: f64 = 3.0 * 3600.0;

/// The ensemble band is the mean plus and minus this many of the sd the z-scores use.
pub const BAND_SDS: f64 = 2.0;

/// The data of the gap figure.
#[derive(Clone, Debug, PartialEq)]
pub struct GapFigure {
    /// One panel per view of the diagnosis, in report order.
    pub panels: Vec<ViewPanel>,
    /// The record over time.
    pub time: TimePanel,
    /// Legend name of the base model's ensemble.
    pub base_label: String,
    /// Legend name of the chain's ensemble (`None`: no effect was found, the figure has the base only).
    pub chain_label: Option<String>,
    /// What the gap left after the chain looks like, as the report says it (`None`: nothing significant is left).
    pub unexplained: Option<String>,
}

/// How an axis maps its values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    /// Logarithmic: only positive values.
    Log,
    /// Linear.
    Linear,
}

/// One view's panel.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewPanel {
    /// The view.
    pub view: ViewKind,
    /// Its title: the view and its gap, base -> chain.
    pub title: String,
    /// The x axis's label (the x axis is logarithmic).
    pub x_label: String,
    /// The y axis's label.
    pub y_label: String,
    /// The y axis's scale.
    pub y_scale: Scale,
    /// Fixed limits of the y axis (the coherence's 0..1); `None`: the data's.
    pub y_limits: Option<(f64, f64)>,
    /// The record and the base model's ensemble band at each point.
    pub base: Vec<PanelPoint>,
    /// The record as the chain's model was judged on it and the chain's band (`None` without a chain).
    pub chain: Option<Vec<PanelPoint>>,
    /// Whether the chain's record values differ from the base's (the temperature view less the chain's
    /// temperature response), so both are drawn.
    pub chain_real_differs: bool,
    /// The located bands.
    pub marks: Vec<BandMark>,
    /// Statistics that have no place on the axes (the distribution's skewness, tail share, lattice share).
    pub notes: Vec<String>,
}

/// One point of a panel, in the panel's quantities.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PanelPoint {
    /// Position on the x axis: tau or period (s), or frequency (Hz).
    pub x: f64,
    /// The record's value.
    pub real: f64,
    /// The ensemble band, lower and upper edge: the mean ± [`BAND_SDS`] sd converted from the view's domain.
    pub band: [f64; 2],
    /// Drawn on its own, not joined to the others: the kurtosis at tau0 beside the Allan differences'.
    pub apart: bool,
}

/// What a marked band is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MarkKind {
    /// Where the gap lay before step `step` of the chain (0: the base model's gap), or the base model's gap when
    /// no effect was found.
    Located {
        /// The step, from 0.
        step: usize,
    },
    /// The gap the chain leaves unexplained.
    Unexplained,
}

/// A band marked on a panel.
#[derive(Clone, Debug, PartialEq)]
pub struct BandMark {
    /// Its edges on the panel's x axis (frequencies on the PSD panel), increasing.
    pub x: [f64; 2],
    /// Its label (`1: temperature`, `left: spectral bump`).
    pub label: String,
    /// What it is.
    pub kind: MarkKind,
}

/// The record over time.
#[derive(Clone, Debug, PartialEq)]
pub struct TimePanel {
    /// Seconds per unit of the x axis: 1, or 3600 for a long record drawn in hours.
    pub unit_s: f64,
    /// The x axis's label.
    pub x_label: String,
    /// The samples' envelope, in time order (columns of gaps only are left out).
    pub columns: Vec<Column>,
    /// Where the holdout starts, s from the start of the record (`None` without a holdout).
    pub split_s: Option<f64>,
    /// The masked transients, start and end, s from the start of the record.
    pub transients: Vec<[f64; 2]>,
    /// The record's length, s.
    pub duration_s: f64,
}

/// The samples of one stretch of the record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Column {
    /// Its start and end, s from the start of the record.
    pub t_s: [f64; 2],
    /// The smallest sample, deg/s.
    pub min: f64,
    /// The largest sample, deg/s.
    pub max: f64,
}

impl GapFigure {
    /// The figure of `report`, a diagnosis of `input` (the record as given to [`crate::gap::diagnose`], transients
    /// and all).
    pub fn new(report: &GapReport, input: &GapInput) -> GapFigure {
        let final_eval = (!report.chain.steps.is_empty()).then(|| report.final_eval());
        let marks = band_marks(report);
        let panels = report
            .base
            .eval
            .training
            .iter()
            .map(|base| {
                let chain = final_eval.and_then(|e| e.training.iter().find(|v| v.view == base.view));
                let marks = marks.iter().filter(|(v, _)| *v == base.view).map(|(_, m)| m.clone()).collect();
                view_panel(base, chain, marks)
            })
            .collect();
        let chain_label = (!report.chain.steps.is_empty()).then(|| {
            let names: Vec<&str> = report.chain.steps.iter().map(|s| s.effect.name()).collect();
            format!("simulated, + {}", names.join(" + "))
        });
        GapFigure {
            panels,
            time: time_panel(report, input),
            base_label: "simulated, base model".to_string(),
            chain_label,
            unexplained: report.chain.unexplained.as_ref().map(|u| u.text.clone()),
        }
    }

    /// Whether the figure has anything to draw.
    pub fn is_empty(&self) -> bool {
        self.panels.iter().all(|p| p.base.is_empty()) && self.time.columns.is_empty()
    }
}

// ---------------------------------------------------------------------------------------------------------------
// The view panels

/// A point's position on its panel's x axis: frequency for the PSD, tau or period otherwise.
fn x_of(view: ViewKind, tau_s: f64) -> f64 {
    match view {
        ViewKind::Psd => 1.0 / tau_s,
        _ => tau_s,
    }
}

/// A band in tau seconds on a panel's x axis, increasing.
fn band_x(view: ViewKind, [lo, hi]: [f64; 2]) -> [f64; 2] {
    let (a, b) = (x_of(view, lo), x_of(view, hi));
    [a.min(b), a.max(b)]
}

/// A value of the view's domain as the panel's quantity.
fn from_domain(view: ViewKind, v: f64) -> f64 {
    match view {
        ViewKind::Adev | ViewKind::Psd => v.exp(),
        ViewKind::Temperature => v.tanh(),
        ViewKind::Distribution => v,
    }
}

/// Whether a point goes on the axes (the distribution's shares and skewness go in the notes).
fn on_axes(view: ViewKind, p: &PointZ) -> bool {
    view != ViewKind::Distribution || matches!(p.info.label, "kurtosis" | "difference_kurtosis")
}

fn panel_points(v: &ViewGap) -> Vec<PanelPoint> {
    let mut out: Vec<PanelPoint> = v
        .points
        .iter()
        .filter(|p| on_axes(v.view, p))
        .map(|p| PanelPoint {
            x: x_of(v.view, p.info.tau_s),
            real: from_domain(v.view, p.real),
            band: [
                from_domain(v.view, p.sim_mean - BAND_SDS * p.sd),
                from_domain(v.view, p.sim_mean + BAND_SDS * p.sd),
            ],
            apart: v.view == ViewKind::Distribution && p.info.label == "kurtosis",
        })
        .collect();
    out.sort_by(|a, b| a.x.total_cmp(&b.x));
    out
}

fn view_panel(base: &ViewGap, chain: Option<&ViewGap>, marks: Vec<BandMark>) -> ViewPanel {
    let view = base.view;
    let (name, x_label, y_label, y_scale, y_limits) = match view {
        ViewKind::Adev => ("Allan deviation", "tau (s)", "Allan deviation (deg/s)", Scale::Log, None),
        ViewKind::Psd => ("Power spectral density", "frequency (Hz)", "PSD ((deg/s)²/Hz)", Scale::Log, None),
        ViewKind::Distribution => ("Distribution", "tau (s)", "excess kurtosis", Scale::Linear, None),
        ViewKind::Temperature => {
            ("Temperature", "period (s)", "coherence with temperature", Scale::Linear, Some((0.0, 1.0)))
        }
    };
    let title = match chain {
        Some(c) => format!("{name}: gap {:.1} → {:.1}", base.gap, c.gap),
        None => format!("{name}: gap {:.1}", base.gap),
    };
    let base_points = panel_points(base);
    let chain_points = chain.map(panel_points);
    let chain_real_differs = chain_points.as_ref().is_some_and(|c| {
        c.iter().any(|p| {
            base_points
                .iter()
                .find(|b| b.x == p.x && b.apart == p.apart)
                .is_none_or(|b| (b.real - p.real).abs() > 1e-9 * b.real.abs().max(1e-12))
        })
    });
    let notes = if view == ViewKind::Distribution { distribution_notes(base, chain) } else { Vec::new() };
    ViewPanel {
        view,
        title,
        x_label: x_label.to_string(),
        y_label: y_label.to_string(),
        y_scale,
        y_limits,
        base: base_points,
        chain: chain_points,
        chain_real_differs,
        marks,
        notes,
    }
}

/// The distribution's statistics at tau0 that have no place on the kurtosis axes: the record's value, and the
/// ensembles' mean ± 2 sd.
fn distribution_notes(base: &ViewGap, chain: Option<&ViewGap>) -> Vec<String> {
    let find = |v: &ViewGap, label: &str| v.points.iter().find(|p| p.info.label == label).cloned();
    let band = |p: &PointZ| format!("{} ± {}", number(p.sim_mean), number(BAND_SDS * p.sd));
    ["skewness", "tail_share", "lattice_share"]
        .into_iter()
        .filter_map(|label| {
            let b = find(base, label)?;
            let name = label.replace('_', " ");
            let sims = match chain.and_then(|c| find(c, label)) {
                Some(c) => format!("base {}, chain {}", band(&b), band(&c)),
                None => format!("simulated {}", band(&b)),
            };
            Some(format!("{name} {} ({sims})", number(b.real)))
        })
        .collect()
}

/// Three significant digits, fixed between 0.001 and 1000.
fn number(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let e = v.abs().log10().floor() as i32;
    if (-3..3).contains(&e) {
        let digits = (2 - e).max(0) as usize;
        format!("{v:.digits$}")
    } else {
        format!("{v:.2e}")
    }
}

/// The located bands of the report, with their views: where the gap lay before each step of the chain, or the
/// base model's gap when the chain is empty and the gap significant; then what is left unexplained (which takes
/// the place of the base model's located gap when no effect was found: it is the core of the same band).
fn band_marks(report: &GapReport) -> Vec<(ViewKind, BandMark)> {
    let mut out: Vec<(ViewKind, BandMark)> = report
        .chain
        .steps
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let l = &s.location;
            let label = format!("{}: {}", k + 1, s.effect.name());
            (l.view, BandMark { x: band_x(l.view, l.band_s), label, kind: MarkKind::Located { step: k } })
        })
        .collect();
    if let Some(u) = &report.chain.unexplained {
        let label = format!("left: {}", u.kind.replace('_', " "));
        out.push((u.view, BandMark { x: band_x(u.view, u.band_s), label, kind: MarkKind::Unexplained }));
    } else if let (true, true, Some(l)) =
        (report.chain.steps.is_empty(), report.base.significant, &report.base.location)
    {
        let label = format!("gap: real {}", l.sign.name());
        out.push((l.view, BandMark { x: band_x(l.view, l.band_s), label, kind: MarkKind::Located { step: 0 } }));
    }
    out
}

// ---------------------------------------------------------------------------------------------------------------
// The time panel

fn time_panel(report: &GapReport, input: &GapInput) -> TimePanel {
    let rate_hz = input.rate_hz;
    let x = &input.rate_dps;
    let n = x.len();
    let duration_s = n as f64 / rate_hz;
    let (unit_s, x_label) = if duration_s > HOURS_FROM_S { (3600.0, "time (h)") } else { (1.0, "time (s)") };
    let cols = TIME_COLUMNS.min(n);
    let columns = (0..cols)
        .filter_map(|c| {
            let (a, b) = (c * n / cols, (c + 1) * n / cols);
            let finite = x[a..b].iter().copied().filter(|v| v.is_finite());
            let (min, max) = finite.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
            (min <= max).then_some(Column { t_s: [a as f64 / rate_hz, b as f64 / rate_hz], min, max })
        })
        .collect();
    let train_s = input.n_train as f64 / rate_hz;
    let transients = report
        .input
        .transients
        .iter()
        .map(|m| {
            let start = m.start_s + if m.part == Part::Holdout { train_s } else { 0.0 };
            [start, start + m.duration_s]
        })
        .collect();
    TimePanel {
        unit_s,
        x_label: x_label.to_string(),
        columns,
        split_s: (input.n_train < n).then_some(train_s),
        transients,
        duration_s,
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::gap::views::PointInfo;
    use crate::gap::{diagnose, GapOptions};

    use octavar_shared::sensor::{Channel, ADXRS300};
    use octavar_shared::sim::rng::SimRng;
    use octavar_shared::sim::temperature::Thermal;
    use octavar_shared::sim::{GyroSim, TempCoupling, TemperatureProfile, VirtualGyro, Wander};

    /// A small record of a gyro with a temperature coupling the base model lacks, and a bump of the bench in its
    /// training part: 2^16 samples at 5 Hz (3.6 h), a temperature cycle of 20 min.
    pub fn record() -> (GapInput, usize) {
        let rate_hz = 5.0;
        let n = 1 << 16;
        let model = GyroSim {
            n_deg_per_rt_s: 0.01,
            b_dps: 0.004,
            temperature: Some(TempCoupling { dps_per_c: 0.02, ref_c: 23.5, lag_s: 60.0 }),
            ..Default::default()
        };
        let profile = TemperatureProfile {
            min_c: 22.0,
            max_c: 25.0,
            period_s: 1200.0,
            wander: Some(Wander { sigma_c: 0.1, tau_s: 600.0 }),
            ..Default::default()
        };
        let mut g = VirtualGyro::new(&model, Channel::bench(ADXRS300), rate_hz, 5).unwrap();
        let mut rng = SimRng::new(6);
        let mut th = Thermal::new(&profile, rate_hz, &mut rng);
        let (mut x, mut t) = (Vec::with_capacity(n), Vec::with_capacity(n));
        for _ in 0..n {
            let tc = th.next(&mut rng);
            x.push(g.next_rate(tc));
            t.push(tc);
        }
        // A bump of 40 s, 1.5 deg/s, at 2000 s.
        let bump = (2000.0 * rate_hz) as usize;
        for v in &mut x[bump..bump + 200] {
            *v += 1.5;
        }
        (GapInput::split(x, Some(t), rate_hz, 0.5).unwrap(), bump)
    }

    pub fn diagnosis() -> (GapReport, GapInput, usize) {
        let (input, bump) = record();
        let report = diagnose(&input, &GapOptions { seeds: 5, ..Default::default() }, &|_, _, _| {}).unwrap();
        (report, input, bump)
    }

    fn point(label: &'static str, tau_s: f64, real: f64, sim_mean: f64, sd: f64) -> PointZ {
        let info = PointInfo { label, tau_s, tau_lo_s: tau_s / 1.2, tau_hi_s: tau_s * 1.2, floor_sd: 0.0 };
        PointZ { info, real, sim_mean, sd, z: (real - sim_mean) / sd }
    }

    fn view(view: ViewKind, points: Vec<PointZ>) -> ViewGap {
        ViewGap { view, points, rms: 1.0, gap: 1.0, window: (0, 1) }
    }

    /// The band of each view is the mean ± 2 sd of the view's domain, converted: exp for ln ADEV and ln PSD, tanh
    /// for atanh coherence, plain for the distribution; the PSD's x is the frequency, 1/tau.
    #[test]
    fn the_band_is_the_mean_plus_minus_two_sd_in_each_views_quantity() {
        let adev = view_panel(&view(ViewKind::Adev, vec![point("tau", 2.0, -4.0, -4.5, 0.1)]), None, vec![]);
        let p = adev.base[0];
        assert_eq!((p.x, p.real), (2.0, (-4.0f64).exp()));
        assert!((p.band[0] - (-4.7f64).exp()).abs() < 1e-15 && (p.band[1] - (-4.3f64).exp()).abs() < 1e-15, "{p:?}");
        let psd = view_panel(&view(ViewKind::Psd, vec![point("band", 100.0, -9.0, -9.0, 0.25)]), None, vec![]);
        let p = psd.base[0];
        assert_eq!(p.x, 0.01);
        assert!((p.band[0] - (-9.5f64).exp()).abs() < 1e-15 && (p.band[1] - (-8.5f64).exp()).abs() < 1e-15);
        let temp = view_panel(&view(ViewKind::Temperature, vec![point("band", 500.0, 1.2, 0.3, 0.2)]), None, vec![]);
        let p = temp.base[0];
        assert_eq!((p.x, p.real), (500.0, 1.2f64.tanh()));
        assert!((p.band[0] + 0.1f64.tanh()).abs() < 1e-15 && (p.band[1] - 0.7f64.tanh()).abs() < 1e-15, "{p:?}");
        assert_eq!((temp.y_scale, temp.y_limits), (Scale::Linear, Some((0.0, 1.0))));
        let dist = view_panel(
            &view(
                ViewKind::Distribution,
                vec![
                    point("skewness", 0.2, 0.05, 0.0, 0.02),
                    point("kurtosis", 0.2, 0.4, 0.0, 0.1),
                    point("tail_share", 0.2, 1e-3, 1e-4, 1e-4),
                    point("difference_kurtosis", 0.4, 0.3, 0.1, 0.05),
                ],
            ),
            None,
            vec![],
        );
        assert_eq!(dist.base.len(), 2, "{:?}", dist.base);
        assert_eq!(dist.base[0], PanelPoint { x: 0.2, real: 0.4, band: [-0.2, 0.2], apart: true });
        assert_eq!(dist.base[1], PanelPoint { x: 0.4, real: 0.3, band: [0.0, 0.2], apart: false });
        assert_eq!(
            dist.notes,
            ["skewness 0.0500 (simulated 0 ± 0.0400)", "tail share 0.00100 (simulated 1.00e-4 ± 2.00e-4)"]
        );
    }

    /// On a real diagnosis: one panel per view the report has (the temperature with a temperature), the located
    /// bands where the report says, in each panel's x units; the transient shaded where the bump is.
    #[test]
    fn a_diagnosis_has_one_panel_per_view_with_its_bands_and_transients() {
        let (report, input, bump) = diagnosis();
        let fig = GapFigure::new(&report, &input);
        let views: Vec<ViewKind> = report.base.eval.training.iter().map(|v| v.view).collect();
        assert!(views.contains(&ViewKind::Temperature), "{views:?}");
        assert_eq!(fig.panels.iter().map(|p| p.view).collect::<Vec<_>>(), views);
        for (panel, v) in fig.panels.iter().zip(&report.base.eval.training) {
            assert!(panel.title.contains(&format!("gap {:.1}", v.gap)), "{}", panel.title);
            assert!(!panel.base.is_empty());
        }
        // The chain found the coupling, and its label and bands are there.
        assert!(report.effects().contains(&crate::gap::Effect::Temperature), "{}", report.text());
        assert!(fig.chain_label.as_deref().unwrap().contains("temperature"), "{:?}", fig.chain_label);
        assert!(fig.panels.iter().all(|p| p.chain.is_some()));
        // The first step's band is marked on its view's panel, in that panel's x units.
        let first = &report.chain.steps[0].location;
        let panel = fig.panels.iter().find(|p| p.view == first.view).unwrap();
        let mark = panel.marks.iter().find(|m| m.kind == MarkKind::Located { step: 0 }).unwrap();
        let expect =
            if first.view == ViewKind::Psd { [1.0 / first.band_s[1], 1.0 / first.band_s[0]] } else { first.band_s };
        assert_eq!(mark.x, expect);
        assert!(mark.label.starts_with("1: "), "{}", mark.label);
        // The bump was masked, reported, and is shaded at its time (it starts at 2000 s of the training part).
        assert_eq!(report.input.transients.len(), 1, "{:?}", report.input.transients);
        let [a, b] = fig.time.transients[0];
        let t = bump as f64 / input.rate_hz;
        assert!(a <= t + 5.0 && b >= t + 35.0 && a > t - 60.0 && b < t + 100.0, "{a}..{b}");
        assert_eq!(fig.time.split_s, Some(input.n_train as f64 / input.rate_hz));
        assert_eq!(fig.time.unit_s, 3600.0);
        assert!(fig.time.columns.len() == TIME_COLUMNS);
    }

    /// A record without a temperature gets no temperature panel. Here the rate has a sinusoid of 20 s that no
    /// candidate is allowed to explain: the gap is a line in the PSD, marked on the PSD panel at frequencies
    /// (f = 1/tau) around 0.05 Hz.
    #[test]
    fn a_line_is_marked_at_its_frequency_and_no_temperature_gets_no_panel() {
        let (input, _) = record();
        let rate_hz = input.rate_hz;
        let rate_dps = input
            .rate_dps
            .iter()
            .enumerate()
            .map(|(i, v)| v + 0.02 * (2.0 * std::f64::consts::PI * i as f64 / (20.0 * rate_hz)).sin())
            .collect();
        let input = GapInput { rate_dps, temp_c: None, ..input };
        let opts = GapOptions { seeds: 5, effects: vec![], ..Default::default() };
        let report = diagnose(&input, &opts, &|_, _, _| {}).unwrap();
        let fig = GapFigure::new(&report, &input);
        let views: Vec<ViewKind> = fig.panels.iter().map(|p| p.view).collect();
        assert_eq!(views, [ViewKind::Adev, ViewKind::Psd, ViewKind::Distribution]);
        assert!(fig.chain_label.is_none() && fig.panels.iter().all(|p| p.chain.is_none()));
        let left = report.chain.unexplained.as_ref().expect("a gap no candidate may explain");
        assert_eq!(left.view, ViewKind::Psd, "{}", report.text());
        let psd = &fig.panels[1];
        assert_eq!(psd.marks.len(), 1);
        let m = &psd.marks[0];
        assert_eq!(m.kind, MarkKind::Unexplained);
        assert_eq!(m.x, [1.0 / left.band_s[1], 1.0 / left.band_s[0]]);
        assert!(m.x[0] < 0.05 && 0.05 < m.x[1], "{:?}", m.x);
        assert_eq!(fig.unexplained.as_deref(), Some(left.text.as_str()));
    }

    #[test]
    fn psd_bands_become_frequencies_and_the_others_stay_in_seconds() {
        assert_eq!(band_x(ViewKind::Psd, [2.0, 50.0]), [0.02, 0.5]);
        for v in [ViewKind::Adev, ViewKind::Distribution, ViewKind::Temperature] {
            assert_eq!(band_x(v, [2.0, 50.0]), [2.0, 50.0]);
        }
    }
}

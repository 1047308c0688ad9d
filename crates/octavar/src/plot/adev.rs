//! The Allan deviation figure: several channels on one log-log plot, each with its own colour (Okabe-Ito, safe for
//! colour-blind readers) and marker: the points with their confidence intervals as error bars, the fitted IEEE 952
//! model as a solid line and each identifiable fitted term (Q, N, B, K, R) as a dashed, lighter line where it
//! matters (within a factor of four of the model), both over the channel's own tau span. The legend sits to the
//! right of the axes, names each channel with its fitted values, and explains the line styles once.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::axis::{clip, close_frame, logspace, tick_label, value_label, LogAxis};
use super::legend::{frame, marker_polygon, Entry, Legend, Sample};
use super::{check_size, colour, err, format_of, lighter, positive, title, Look, PlotError, PlotOptions};
use super::{GREY, INK};
use crate::fit::{NoiseFit, Term};
use crate::quantity::Quantity;
use crate::stats::DevPoint;

/// One channel of an Allan deviation plot.
#[derive(Clone, Debug)]
pub struct AdevSeries {
    /// Legend name.
    pub name: String,
    /// The points (deviation, interval lo..hi; NaN bounds draw no error bar).
    pub points: Vec<DevPoint>,
    /// The IEEE 952 fit, drawn as a solid line with its identifiable terms dashed.
    pub fit: Option<NoiseFit>,
    /// What the channel measures: gyros and accelerometers are drawn in panels of their own.
    pub quantity: Quantity,
}

/// Draw an Allan deviation plot of `series` into `path` (`.png` or `.svg`).
///
/// # Errors
/// [`PlotError::UnknownFormat`], [`PlotError::Empty`] when no series has a plottable point,
/// [`PlotError::TooSmall`], [`PlotError::Write`].
pub fn adev_plot(series: &[AdevSeries], opts: &PlotOptions, path: &Path) -> Result<(), PlotError> {
    let format = format_of(path)?;
    check_size(opts)?;
    // One panel per quantity, gyros first; each with its own axes, unit and legend.
    let mut panels: Vec<Panel> = Vec::new();
    for q in [Quantity::AngularRate, Quantity::Acceleration] {
        let prepared: Vec<Prepared> = series.iter().filter(|s| s.quantity == q).map(Prepared::new).collect();
        let mut ext = Extent::default();
        for p in &prepared {
            for m in &p.marks {
                ext.add(m.tau, m.dev);
                if let Some((lo, hi)) = m.bar {
                    ext.add_y(lo);
                    ext.add_y(hi);
                }
            }
        }
        if !ext.is_empty() {
            // A panel of gyros alone keeps the caller's unit (a plot of counts, say); otherwise the quantity's.
            let unit = if q == Quantity::AngularRate && series.iter().all(|s| s.quantity == q) {
                opts.unit.clone()
            } else {
                q.unit().to_string()
            };
            panels.push(Panel { series: prepared, ext, unit });
        }
    }
    if panels.is_empty() {
        return Err(PlotError::Empty);
    }
    let mut opts = opts.clone();
    if panels.len() > 1 {
        opts.height = opts.height * 8 / 5;
    }
    let opts = &opts;
    render!(format, path, opts, |root| draw_adev(root, &panels, opts))
}

/// One panel of the figure: the channels of one quantity, their extent and the unit of its y axis.
struct Panel<'a> {
    series: Vec<Prepared<'a>>,
    ext: Extent,
    unit: String,
}

// ---------------------------------------------------------------------------------------------------------------
// Data

/// A plottable point: positive tau and deviation, and its interval when it has one.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Mark {
    tau: f64,
    dev: f64,
    /// lo..hi (lo may be 0 or below: the bar then runs to the bottom of the axes).
    bar: Option<(f64, f64)>,
}

fn marks(points: &[DevPoint]) -> Vec<Mark> {
    let mut v: Vec<Mark> = points
        .iter()
        .filter(|p| positive(p.tau_s) && positive(p.dev))
        .map(|p| {
            let bar = (p.lo.is_finite() && positive(p.hi) && p.lo <= p.hi).then_some((p.lo, p.hi));
            Mark { tau: p.tau_s, dev: p.dev, bar }
        })
        .collect();
    v.sort_by(|a, b| a.tau.total_cmp(&b.tau));
    v
}

/// One channel, ready to draw.
struct Prepared<'a> {
    name: &'a str,
    marks: Vec<Mark>,
    fit: Option<&'a NoiseFit>,
}

impl<'a> Prepared<'a> {
    fn new(s: &'a AdevSeries) -> Self {
        Prepared { name: &s.name, marks: marks(&s.points), fit: s.fit.as_ref() }
    }

    /// The tau span the model line covers: the points', or the fit's range without points.
    fn model_span(&self) -> Option<(f64, f64)> {
        match (self.marks.first(), self.marks.last()) {
            (Some(a), Some(b)) => Some((a.tau, b.tau)),
            _ => self.fit.map(|f| (f.tau_range_s[0], f.tau_range_s[1])).filter(|(a, b)| positive(*a) && b > a),
        }
    }

    /// The terms drawn for this channel: identifiable, with a positive square.
    fn terms(&self) -> Vec<Term> {
        match self.fit {
            Some(f) => Term::ALL
                .into_iter()
                .filter(|&t| f.term(t).identifiable && f.squares[t as usize] > 0.0 && f.term(t).value.is_some())
                .collect(),
            None => Vec::new(),
        }
    }
}

/// The positive extent of the data on both axes.
#[derive(Clone, Copy, Debug, Default)]
struct Extent {
    x: Option<(f64, f64)>,
    y: Option<(f64, f64)>,
}

fn widen(r: &mut Option<(f64, f64)>, v: f64) {
    if positive(v) {
        *r = Some(match *r {
            None => (v, v),
            Some((a, b)) => (a.min(v), b.max(v)),
        });
    }
}

impl Extent {
    fn add(&mut self, x: f64, y: f64) {
        if positive(x) && positive(y) {
            widen(&mut self.x, x);
            widen(&mut self.y, y);
        }
    }

    fn add_y(&mut self, y: f64) {
        if self.y.is_some() {
            widen(&mut self.y, y);
        }
    }

    fn is_empty(&self) -> bool {
        self.x.is_none() || self.y.is_none()
    }

    fn axes(&self) -> (LogAxis, LogAxis) {
        (LogAxis::new(self.x.unwrap_or((1.0, 10.0))), LogAxis::new(self.y.unwrap_or((1.0, 10.0))))
    }
}

/// The unit of a term's coefficient for deviations in `unit`.
fn term_unit(term: Term, unit: &str) -> String {
    if unit == "deg/s" {
        return match term {
            Term::Q => "deg",
            Term::N => "deg/√s",
            Term::B => "deg/s",
            Term::K => "deg/s/√s",
            Term::R => "deg/s²",
        }
        .to_string();
    }
    if unit == "m/s^2" {
        return match term {
            Term::Q => "m/s",
            Term::N => "m/s/√s",
            Term::B => "m/s²",
            Term::K => "m/s²/√s",
            Term::R => "m/s³",
        }
        .to_string();
    }
    match term {
        Term::Q => format!("{unit}·s"),
        Term::N => format!("{unit}·√s"),
        Term::B => unit.to_string(),
        Term::K => format!("{unit}/√s"),
        Term::R => format!("{unit}/s"),
    }
}

/// The slope of a term on the ADEV plot.
fn term_slope(term: Term) -> &'static str {
    match term {
        Term::Q => "−1",
        Term::N => "−½",
        Term::B => "0",
        Term::K => "+½",
        Term::R => "+1",
    }
}

type LogAx = plotters::coord::combinators::WithKeyPoints<LogCoord<f64>>;
type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<LogAx, LogAx>>;

/// Log-log axes with decade labels, a grid, a frame and the axis labels.
fn axes<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    xa: &LogAxis,
    ya: &LogAxis,
    unit: &str,
    look: &Look,
) -> Result<Chart<'a, DB>, String> {
    let mut chart = ChartBuilder::on(area)
        .margin_top(look.px(8.0))
        .margin_right(look.px(24.0))
        .margin_bottom(look.px(12.0))
        .margin_left(look.px(10.0))
        .x_label_area_size(look.px(64.0))
        .y_label_area_size(look.px(96.0))
        .build_cartesian_2d(
            (xa.lo..xa.hi).log_scale().with_key_points(xa.major.clone()).with_light_points(xa.minor.clone()),
            (ya.lo..ya.hi).log_scale().with_key_points(ya.major.clone()).with_light_points(ya.minor.clone()),
        )
        .map_err(err)?;
    let fmt = |v: &f64| tick_label(*v);
    chart
        .configure_mesh()
        .x_desc("tau (s)")
        .y_desc(format!("Allan deviation ({unit})"))
        .x_label_formatter(&fmt)
        .y_label_formatter(&fmt)
        .label_style(look.font(17.0))
        .axis_desc_style(look.font(19.0))
        .bold_line_style(BLACK.mix(0.16).stroke_width(1))
        .light_line_style(BLACK.mix(0.06).stroke_width(1))
        .axis_style(INK.stroke_width(1))
        .set_all_tick_mark_size(look.px(6.0))
        .draw()
        .map_err(err)?;
    close_frame(chart.plotting_area())?;
    Ok(chart)
}

/// Points with error bars (bars clipped to the axes).
fn draw_points<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    marks: &[Mark],
    ya: &LogAxis,
    shape: usize,
    c: RGBColor,
    look: &Look,
) -> Result<(), String> {
    let bar = c.stroke_width(look.px(1.5).max(1) as u32);
    let cap = look.px(5.0);
    for m in marks {
        if let Some((lo, hi)) = m.bar {
            let lo = if lo > ya.lo { lo } else { ya.lo };
            let hi = hi.min(ya.hi);
            if lo < hi {
                chart
                    .draw_series(std::iter::once(PathElement::new(vec![(m.tau, lo), (m.tau, hi)], bar)))
                    .map_err(err)?;
                for (v, open) in [(lo, lo == ya.lo), (hi, hi == ya.hi)] {
                    if !open {
                        chart
                            .draw_series(std::iter::once(
                                EmptyElement::at((m.tau, v)) + PathElement::new(vec![(-cap, 0), (cap, 0)], bar),
                            ))
                            .map_err(err)?;
                    }
                }
            }
        }
    }
    let r = look.px(5.0);
    let fill = c.filled();
    let edge = WHITE.stroke_width(1);
    let pts = marks.iter().filter(|m| m.dev >= ya.lo && m.dev <= ya.hi).map(|m| (m.tau, m.dev));
    if shape.is_multiple_of(5) {
        chart
            .draw_series(pts.map(|p| EmptyElement::at(p) + Circle::new((0, 0), r, fill) + Circle::new((0, 0), r, edge)))
            .map_err(err)?;
    } else {
        let poly = marker_polygon(shape, r);
        let mut outline = poly.clone();
        outline.push(poly[0]);
        chart
            .draw_series(pts.map(|p| {
                EmptyElement::at(p) + Polygon::new(poly.clone(), fill) + PathElement::new(outline.clone(), edge)
            }))
            .map_err(err)?;
    }
    Ok(())
}

/// A term is drawn where its ADEV is at least this fraction of the model's (about a decade of tau past where it
/// stops dominating, for the +-1/2 slopes).
const TERM_SHARE: f64 = 0.25;

fn draw_adev<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    panels: &[Panel<'_>],
    opts: &PlotOptions,
) -> Result<(), String> {
    let look = Look::new(opts);
    root.fill(&WHITE).map_err(err)?;
    let body = title(root, &opts.title, &look)?;
    let areas = body.split_evenly((panels.len(), 1));
    for (panel, area) in panels.iter().zip(&areas) {
        draw_panel(area, panel, opts, &look)?;
    }
    Ok(())
}

fn draw_panel<DB: DrawingBackend>(
    body: &DrawingArea<DB, Shift>,
    panel: &Panel<'_>,
    opts: &PlotOptions,
    look: &Look,
) -> Result<(), String> {
    let (series, look) = (&panel.series[..], *look);
    let (xa, ya) = panel.ext.axes();
    let mut legend = adev_legend(series, opts, &panel.unit);
    let (plot_area, legend_area) = frame(body, &mut legend, &look)?;
    let mut chart = axes(&plot_area, &xa, &ya, &panel.unit, &look)?;
    let (bx, by) = ((xa.lo, xa.hi), (ya.lo, ya.hi));
    if opts.terms {
        for (i, p) in series.iter().enumerate() {
            let (Some(fit), Some((t0, t1))) = (p.fit, p.model_span()) else { continue };
            let style = lighter(colour(i), 0.3).stroke_width(look.px(2.0) as u32);
            for term in p.terms() {
                let curve: Vec<(f64, f64, bool)> = logspace(t0, t1, 240)
                    .map(|t| {
                        let v = fit.term_avar(term, t);
                        (t, v.sqrt(), v >= TERM_SHARE * TERM_SHARE * fit.model_avar(t))
                    })
                    .collect();
                for run in curve.split(|p| !p.2) {
                    let pts: Vec<(f64, f64)> = run.iter().map(|p| (p.0, p.1)).collect();
                    for piece in clip(&pts, bx, by) {
                        chart
                            .draw_series(DashedLineSeries::new(piece, look.px(8.0), look.px(5.0), style))
                            .map_err(err)?;
                    }
                }
            }
        }
    }
    for (i, p) in series.iter().enumerate() {
        let (Some(fit), Some((t0, t1))) = (p.fit, p.model_span()) else { continue };
        let pts: Vec<(f64, f64)> = logspace(t0, t1, 400).map(|t| (t, fit.model_avar(t).sqrt())).collect();
        for piece in clip(&pts, bx, by) {
            chart.draw_series(LineSeries::new(piece, colour(i).stroke_width(look.px(2.2) as u32))).map_err(err)?;
        }
    }
    for (i, p) in series.iter().enumerate() {
        draw_points(&mut chart, &p.marks, &ya, i, colour(i), &look)?;
    }
    legend.draw(&legend_area, 0, look.px(8.0), &look)
}

fn adev_legend(series: &[Prepared<'_>], opts: &PlotOptions, unit: &str) -> Legend {
    let mut entries = Vec::new();
    let mut any_fit = false;
    let mut drawn_terms: Vec<Term> = Vec::new();
    for (i, p) in series.iter().enumerate() {
        entries.push(Entry::main(Sample::Channel(colour(i), i), p.name));
        if let Some(fit) = p.fit {
            any_fit = true;
            let terms = p.terms();
            if opts.fit_values {
                for &t in &terms {
                    if let Some(v) = fit.term(t).value {
                        entries.push(Entry::detail(format!(
                            "{} = {} {}",
                            t.name(),
                            value_label(v),
                            term_unit(t, unit)
                        )));
                    }
                }
                if terms.is_empty() {
                    entries.push(Entry::detail("no identifiable term"));
                }
            }
            drawn_terms.extend(terms.iter().filter(|t| !drawn_terms.contains(t)).collect::<Vec<_>>());
        }
    }
    if any_fit {
        entries.push(Entry::spacer());
        entries.push(Entry::main(Sample::Solid(GREY), "IEEE 952 fit"));
        if opts.terms && !drawn_terms.is_empty() {
            drawn_terms.sort_by_key(|&t| t as usize);
            entries.push(Entry::main(Sample::Dashed(lighter(GREY, 0.3)), "fitted terms"));
            let slopes: Vec<String> = drawn_terms.iter().map(|&t| format!("{} {}", t.name(), term_slope(t))).collect();
            entries.push(Entry::detail(format!("slopes: {}", slopes.join(", "))));
        }
    }
    Legend { entries }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::{fit_deviations, FitOptions, FLICKER_AVAR_FACTOR};
    use crate::plot::test_util::{out_dir, png_size};
    use crate::stats::NoiseMethod;

    /// A deterministic jitter in -1..1.
    fn jitter(i: u64) -> f64 {
        let x = i.wrapping_mul(0x9E37_79B9_7F4A_7C15).rotate_left(17).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        (x >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }

    /// An octave ADEV curve of N, B, K over `hours` at 2 kS/s, with the scatter and 68% intervals of its EDF,
    /// and the IEEE 952 fit of it.
    fn channel(name: &str, n: f64, b: f64, k: f64, hours: f64, seed: u64) -> AdevSeries {
        let tau0 = 1.0 / 2000.0;
        let len = hours * 3600.0 / tau0;
        let mut points = Vec::new();
        let mut m = 1u64;
        while (m as f64) * 4.0 <= len {
            let tau = m as f64 * tau0;
            let avar = n * n / tau + FLICKER_AVAR_FACTOR * b * b + k * k * tau / 3.0;
            let edf = (len / m as f64 - 1.0).max(1.0);
            let sd = (2.0 / edf).sqrt() / 2.0;
            let dev = avar.sqrt() * (1.0 + sd * jitter(seed * 1000 + m));
            points.push(DevPoint {
                m,
                tau_s: tau,
                n: (len as u64).saturating_sub(2 * m - 1),
                stride: 1,
                dev,
                alpha: 0,
                noise_method: NoiseMethod::Default,
                edf,
                lo: dev / (1.0 + sd),
                hi: dev * (1.0 + sd * 1.3),
            });
            m *= 2;
        }
        let fit = fit_deviations(&points, Some(&FitOptions::default())).ok();
        AdevSeries { name: name.to_string(), points, fit, quantity: Quantity::AngularRate }
    }

    /// The paper's four gyros (Table 1's N and B), 72 h.
    fn figure5() -> Vec<AdevSeries> {
        vec![
            channel("ENV-05H", 4.0e-4, 9.5e-4, 1.2e-5, 72.0, 1),
            channel("IDG1215 Y", 3.0e-3, 13e-3, 1.6e-4, 72.0, 2),
            channel("IDG1215 X", 3.2e-3, 14e-3, 1.7e-4, 72.0, 3),
            channel("ADXRS300", 46e-3, 26e-3, 3.2e-4, 72.0, 4),
        ]
    }

    #[test]
    fn adev_plot_writes_svg_and_png() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = out_dir(&tmp);
        let series = figure5();
        assert!(series.iter().all(|s| s.fit.is_some()));
        let opts =
            PlotOptions { title: "Allan deviation of the four gyros, 72 h at 2 kS/s".into(), ..Default::default() };
        let svg = dir.join("figure5.svg");
        adev_plot(&series, &opts, &svg).unwrap();
        let text = std::fs::read_to_string(&svg).unwrap();
        for name in ["ENV-05H", "IDG1215 Y", "IDG1215 X", "ADXRS300", "tau (s)", "Allan deviation (deg/s)"] {
            assert!(text.contains(name), "{name} missing from the SVG");
        }
        let png = dir.join("figure5.png");
        adev_plot(&series, &opts, &png).unwrap();
        assert_eq!(png_size(&std::fs::read(&png).unwrap()), (1200, 800));
        let img = image::open(&png).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (1200, 800));
        // Every channel's colour is there, and the text is (dark pixels).
        for i in 0..series.len() {
            let RGBColor(r, g, b) = colour(i);
            let n = img.pixels().filter(|p| p.0 == [r, g, b]).count();
            assert!(n > 200, "channel {i}: {n} pixels of its colour");
        }
        assert!(img.pixels().filter(|p| p.0.iter().all(|&v| v < 60)).count() > 2000);

        let small = PlotOptions { width: 600, height: 400, ..opts.clone() };
        let png = dir.join("figure5-small.PNG");
        adev_plot(&series, &small, &png).unwrap();
        assert_eq!(png_size(&std::fs::read(&png).unwrap()), (600, 400));
    }

    #[test]
    fn unknown_extension_is_an_error_naming_it() {
        let tmp = tempfile::tempdir().unwrap();
        let e = adev_plot(&figure5(), &PlotOptions::default(), &tmp.path().join("f.jpg")).unwrap_err();
        assert!(matches!(&e, PlotError::UnknownFormat { ext, .. } if ext == "jpg"));
        assert!(e.to_string().contains("\"jpg\""), "{e}");
        let e = adev_plot(&figure5(), &PlotOptions::default(), &tmp.path().join("f")).unwrap_err();
        assert!(matches!(e, PlotError::UnknownFormat { .. }));
    }

    #[test]
    fn empty_data_is_an_error() {
        let tmp = tempfile::tempdir().unwrap();
        let path = tmp.path().join("f.png");
        assert!(matches!(adev_plot(&[], &PlotOptions::default(), &path), Err(PlotError::Empty)));
        let mut s = figure5().remove(0);
        for p in &mut s.points {
            p.dev = 0.0;
        }
        s.fit = None;
        assert!(matches!(adev_plot(&[s], &PlotOptions::default(), &path), Err(PlotError::Empty)));
        assert!(!path.exists());
    }

    #[test]
    fn non_positive_values_are_skipped() {
        let tmp = tempfile::tempdir().unwrap();
        let mut s = figure5().remove(0);
        s.points[0].dev = -1.0;
        s.points[1].dev = f64::NAN;
        s.points[2].lo = -1.0;
        s.points[3].tau_s = 0.0;
        adev_plot(&[s], &PlotOptions::default(), &tmp.path().join("f.svg")).unwrap();
    }

    #[test]
    fn write_failure_names_the_path() {
        let tmp = tempfile::tempdir().unwrap();
        let path = tmp.path().join("no/such/dir/f.png");
        let e = adev_plot(&figure5(), &PlotOptions::default(), &path).unwrap_err();
        assert!(matches!(&e, PlotError::Write { path: p, .. } if *p == path), "{e}");
        // The system's reason, not a backend's debug dump.
        assert!(e.to_string().ends_with("No such file or directory (os error 2)"), "{e}");
        // A full disk: /dev/full takes no byte (reached through a link that has the plot's extension).
        #[cfg(target_os = "linux")]
        for name in ["f.svg", "f.png"] {
            let link = tmp.path().join(name);
            std::os::unix::fs::symlink("/dev/full", &link).unwrap();
            let e = adev_plot(&figure5(), &PlotOptions::default(), &link).unwrap_err();
            assert!(e.to_string().ends_with("No space left on device (os error 28)"), "{name}: {e}");
        }
    }
}

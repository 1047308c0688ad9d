//! Allan deviation plots: the log-log ADEV figure (`octavar analyze --plot`, `octavar demo`'s `figure5.png`) and
//! the sim-to-real gap figure (`octavar gap`).
//!
//! The figures are drawn with plotters, in pure Rust: SVG through its SVG backend (text is left to the viewer's
//! sans-serif font), PNG through its bitmap backend with text rasterised by ab_glyph from the DejaVu Sans bytes
//! the `dejavu` crate embeds, so no fontconfig or freetype is needed. The output format follows the file's
//! extension (`.png` or `.svg`).
//!
//! [`adev_plot`] draws several channels on one log-log plot, each with its own colour (Okabe-Ito, safe for
//! colour-blind readers) and marker: the points with their confidence intervals as error bars, the fitted
//! IEEE 952 model as a solid line and each identifiable fitted term (Q, N, B, K, R) as a dashed, lighter line
//! where it matters (within a factor of four of the model), both over the channel's own tau span. The legend sits to the right of the axes, names each
//! channel with its fitted values, and explains the line styles once.
//!
//! [`gap_plot`] draws a measured ADEV curve against one or two ensembles of simulated curves, each as a shaded
//! band (its lower and upper curve per tau), and highlights the tau interval where they part.
//!
//! Values that cannot go on a log axis (zero, negative, NaN) are left out, not reported.
//!
//! # Examples
//!
//! ```no_run
//! use octavar::plot::{adev_plot, AdevSeries, PlotOptions};
//! # let points = Vec::new();
//! let series = vec![AdevSeries { name: "ENV-05H".into(), points, fit: None }];
//! let opts = PlotOptions { title: "Allan deviation, 72 h at 2 kS/s".into(), ..Default::default() };
//! adev_plot(&series, &opts, std::path::Path::new("figure5.png"))?;
//! # Ok::<(), octavar::plot::PlotError>(())
//! ```

use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::fit::{NoiseFit, Term};
use crate::stats::DevPoint;

/// Draw with the backend the format asks for, into memory, then write the file in one piece: a file that cannot
/// be written (no such directory, a full disk) is reported with the system's own reason, and nothing is drawn
/// into a half-written file.
macro_rules! render {
    ($format:expr, $path:expr, $opts:expr, |$root:ident| $draw:expr) => {{
        register_fonts();
        let size = ($opts.width, $opts.height);
        let path: &Path = $path;
        let fail = |message: String| PlotError::Write { path: path.to_path_buf(), message };
        let bytes: Vec<u8> = match $format {
            Format::Svg => {
                let mut text = String::new();
                {
                    let area = SVGBackend::with_string(&mut text, size).into_drawing_area();
                    let $root = &area;
                    $draw.map_err(fail)?;
                    area.present().map_err(|e| fail(e.to_string()))?;
                }
                text.into_bytes()
            }
            Format::Png => {
                let mut rgb = vec![0u8; size.0 as usize * size.1 as usize * 3];
                {
                    let area = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
                    let $root = &area;
                    $draw.map_err(fail)?;
                    area.present().map_err(|e| fail(e.to_string()))?;
                }
                png_bytes(&rgb, size).map_err(|e| fail(e.to_string()))?
            }
        };
        std::fs::write(path, bytes).map_err(|e| fail(e.to_string()))
    }};
}

/// An RGB buffer as a PNG file's bytes.
fn png_bytes(rgb: &[u8], (width, height): (u32, u32)) -> image::ImageResult<Vec<u8>> {
    use image::ImageEncoder;
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out).write_image(rgb, width, height, image::ColorType::Rgb8)?;
    Ok(out)
}

/// One channel of an Allan deviation plot.
#[derive(Clone, Debug)]
pub struct AdevSeries {
    /// Legend name.
    pub name: String,
    /// The points (deviation, interval lo..hi; NaN bounds draw no error bar).
    pub points: Vec<DevPoint>,
    /// The IEEE 952 fit, drawn as a solid line with its identifiable terms dashed.
    pub fit: Option<NoiseFit>,
}

/// Options of both plots.
#[derive(Clone, Debug, PartialEq)]
pub struct PlotOptions {
    /// Title above the axes.
    pub title: String,
    /// Unit of the deviation, as in the y label `Allan deviation (UNIT)`.
    pub unit: String,
    /// Width, pixels (SVG: user units).
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Draw each identifiable fitted term as a dashed line.
    pub terms: bool,
    /// List the fitted values under each channel's name in the legend.
    pub fit_values: bool,
}

impl Default for PlotOptions {
    fn default() -> Self {
        PlotOptions {
            title: "Allan deviation".to_string(),
            unit: "deg/s".to_string(),
            width: 1200,
            height: 800,
            terms: true,
            fit_values: true,
        }
    }
}

/// One tau of a simulated ensemble: the band from `lo` to `hi` (min..max, or 5%..95%, of the simulated ADEV).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Band {
    /// Averaging time, s.
    pub tau_s: f64,
    /// Lower edge of the band.
    pub lo: f64,
    /// Upper edge of the band.
    pub hi: f64,
}

/// The data of a sim-to-real gap plot.
#[derive(Clone, Debug)]
pub struct GapPlot {
    /// Legend name of the measured curve.
    pub real_label: String,
    /// The measured ADEV (points with error bars).
    pub real: Vec<DevPoint>,
    /// Legend name of the first ensemble.
    pub before_label: String,
    /// The simulated ensemble before the model was corrected.
    pub before: Vec<Band>,
    /// Legend name of the second ensemble.
    pub after_label: String,
    /// The simulated ensemble after the correction, if any.
    pub after: Option<Vec<Band>>,
    /// The tau interval where the gap lies, s (highlighted).
    pub band_s: Option<(f64, f64)>,
    /// Short label of that interval.
    pub band_label: String,
}

impl GapPlot {
    /// A gap plot with the default labels ("measured", "simulated, before", "simulated, after", "gap").
    pub fn new(real: Vec<DevPoint>, before: Vec<Band>) -> Self {
        GapPlot {
            real_label: "measured".to_string(),
            real,
            before_label: "simulated, before".to_string(),
            before,
            after_label: "simulated, after".to_string(),
            after: None,
            band_s: None,
            band_label: "gap".to_string(),
        }
    }

    /// The gap plot of a diagnosis: the real training OADEV, the base ensemble's band, the band of the model with
    /// the whole chain, and the located band when the gap lies in a view with a tau axis.
    pub fn from_report(r: &crate::gap::GapReport) -> GapPlot {
        let to_bands = |e: &crate::gap::Evaluated| -> Vec<Band> {
            e.adev_band.iter().map(|&(tau_s, lo, hi)| Band { tau_s, lo, hi }).collect()
        };
        let mut p = GapPlot::new(r.real_adev.clone(), to_bands(&r.base_eval));
        p.before_label = "simulated, base model".to_string();
        if let Some(last) = r.chain.last() {
            p.after = Some(to_bands(&last.eval));
            let names: Vec<&str> = r.chain.iter().map(|s| s.effect.name()).collect();
            p.after_label = format!("simulated, + {}", names.join(" + "));
        }
        if let Some(l) = &r.location {
            if r.significant && l.view != crate::gap::ViewKind::Distribution {
                p.band_s = Some((l.band_s[0], l.band_s[1]));
                p.band_label = format!("gap: {} ({})", l.view.name(), l.sign.name());
            }
        }
        p
    }
}

/// What went wrong.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The file's extension is neither `.png` nor `.svg`.
    #[error("{path}: unknown plot format {ext:?} (use .png or .svg)")]
    UnknownFormat {
        /// The file.
        path: PathBuf,
        /// Its extension ("" when it has none).
        ext: String,
    },
    /// No point with a positive tau and value.
    #[error("nothing to plot: no point with a positive tau and deviation")]
    Empty,
    /// Too small to lay out.
    #[error("plot size {width}x{height} is too small (at least 400x300)")]
    TooSmall {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
    },
    /// Drawing or writing the file failed.
    #[error("writing {path}: {message}")]
    Write {
        /// The file.
        path: PathBuf,
        /// What the backend said.
        message: String,
    },
}

/// Draw an Allan deviation plot of `series` into `path` (`.png` or `.svg`).
///
/// # Errors
/// [`PlotError::UnknownFormat`], [`PlotError::Empty`] when no series has a plottable point,
/// [`PlotError::TooSmall`], [`PlotError::Write`].
pub fn adev_plot(series: &[AdevSeries], opts: &PlotOptions, path: &Path) -> Result<(), PlotError> {
    let format = format_of(path)?;
    check_size(opts)?;
    let prepared: Vec<Prepared> = series.iter().map(Prepared::new).collect();
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
    if ext.is_empty() {
        return Err(PlotError::Empty);
    }
    render!(format, path, opts, |root| draw_adev(root, &prepared, &ext, opts))
}

/// Draw a sim-to-real gap plot into `path` (`.png` or `.svg`).
///
/// # Errors
/// [`PlotError::UnknownFormat`], [`PlotError::Empty`] when neither the measured curve nor the ensembles have a
/// plottable point, [`PlotError::TooSmall`], [`PlotError::Write`].
pub fn gap_plot(gap: &GapPlot, opts: &PlotOptions, path: &Path) -> Result<(), PlotError> {
    let format = format_of(path)?;
    check_size(opts)?;
    let real = marks(&gap.real);
    let before = bands(&gap.before);
    let after = gap.after.as_deref().map(bands);
    let mut ext = Extent::default();
    for m in &real {
        ext.add(m.tau, m.dev);
        if let Some((lo, hi)) = m.bar {
            ext.add_y(lo);
            ext.add_y(hi);
        }
    }
    for b in before.iter().chain(after.iter().flatten()) {
        ext.add(b.tau_s, b.hi);
        ext.add_y(b.lo);
    }
    if ext.is_empty() {
        return Err(PlotError::Empty);
    }
    render!(format, path, opts, |root| draw_gap(root, gap, &real, &before, after.as_deref(), &ext, opts))
}

// ---------------------------------------------------------------------------------------------------------------
// Formats and backends

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Png,
    Svg,
}

fn format_of(path: &Path) -> Result<Format, PlotError> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_string();
    match ext.to_ascii_lowercase().as_str() {
        "png" => Ok(Format::Png),
        "svg" => Ok(Format::Svg),
        _ => Err(PlotError::UnknownFormat { path: path.to_path_buf(), ext }),
    }
}

fn check_size(opts: &PlotOptions) -> Result<(), PlotError> {
    if opts.width < 400 || opts.height < 300 || opts.width > 20_000 || opts.height > 20_000 {
        return Err(PlotError::TooSmall { width: opts.width, height: opts.height });
    }
    Ok(())
}

/// The family name the bundled font is registered under (also what SVG files ask their viewer for).
const FAMILY: &str = "sans-serif";

/// Register DejaVu Sans (regular and bold) for plotters' text layout and bitmap text, once.
fn register_fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bytes are a valid TrueType font, so these cannot fail; a failure would only lose the text.
        let _ = plotters::style::register_font(FAMILY, FontStyle::Normal, dejavu::sans::regular());
        let _ = plotters::style::register_font(FAMILY, FontStyle::Bold, dejavu::sans::bold());
    });
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

fn positive(v: f64) -> bool {
    v.is_finite() && v > 0.0
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

fn bands(b: &[Band]) -> Vec<Band> {
    let mut v: Vec<Band> =
        b.iter().copied().filter(|b| positive(b.tau_s) && positive(b.hi) && b.lo.is_finite() && b.lo <= b.hi).collect();
    v.sort_by(|a, b| a.tau_s.total_cmp(&b.tau_s));
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

// ---------------------------------------------------------------------------------------------------------------
// Axes

/// A log axis: limits on the 1-2-5 sequence, labelled ticks (decades) and light grid lines (2..9 of each decade).
#[derive(Clone, Debug, PartialEq)]
struct LogAxis {
    lo: f64,
    hi: f64,
    major: Vec<f64>,
    minor: Vec<f64>,
}

const STEPS: [f64; 3] = [1.0, 2.0, 5.0];

impl LogAxis {
    fn new((min, max): (f64, f64)) -> Self {
        // A little air on both sides, then the nearest 1-2-5 value outwards.
        let (min, max) = (min / 1.12, max * 1.12);
        let lo = {
            let e = min.log10().floor();
            let d = 10f64.powf(e);
            let m = STEPS.iter().rev().find(|&&s| s * d <= min * (1.0 + 1e-9)).copied().unwrap_or(1.0);
            m * d
        };
        let hi = {
            let e = max.log10().floor();
            let d = 10f64.powf(e);
            STEPS.iter().find(|&&s| s * d >= max * (1.0 - 1e-9)).map(|s| s * d).unwrap_or(10.0 * d)
        };
        let hi = if hi / lo < 2.0 { lo * 10.0 } else { hi };
        let (e0, e1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
        let inside = |v: f64| v >= lo * (1.0 - 1e-9) && v <= hi * (1.0 + 1e-9);
        let decades: Vec<f64> = (e0..=e1).map(|e| 10f64.powi(e)).filter(|&v| inside(v)).collect();
        // At most about 12 labels.
        let step = decades.len().div_ceil(12).max(1);
        let mut major: Vec<f64> = decades.iter().copied().step_by(step).collect();
        let mut minor: Vec<f64> =
            (e0..=e1).flat_map(|e| (2..=9).map(move |m| f64::from(m) * 10f64.powi(e))).filter(|&v| inside(v)).collect();
        minor.extend(decades.iter().copied().filter(|d| !major.contains(d)));
        if major.len() < 3 {
            // Two decades or less: label the 2s and 5s too.
            major =
                (e0..=e1).flat_map(|e| STEPS.iter().map(move |s| s * 10f64.powi(e))).filter(|&v| inside(v)).collect();
            minor.retain(|v| !major.iter().any(|m| (m / v - 1.0).abs() < 1e-9));
        }
        LogAxis { lo, hi, major, minor }
    }
}

/// `10⁻³`, or `2×10⁻³` off the decades.
fn tick_label(v: f64) -> String {
    let e = v.log10().floor();
    let m = v / 10f64.powf(e);
    let (m, e) = if m > 9.999 { (1.0, e + 1.0) } else { (m, e) };
    if (m - 1.0).abs() < 1e-6 {
        format!("10{}", superscript(e as i32))
    } else {
        format!("{}×10{}", m.round(), superscript(e as i32))
    }
}

fn superscript(n: i32) -> String {
    n.to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            '0' => '⁰',
            '1' => '¹',
            '2' => '²',
            '3' => '³',
            '4' => '⁴',
            '5' => '⁵',
            '6' => '⁶',
            '7' => '⁷',
            '8' => '⁸',
            _ => '⁹',
        })
        .collect()
}

/// A value with three significant digits: `4.02×10⁻⁴`, `1.30×10⁻²`, `0.261`, `2.61`, `261`.
fn value_label(v: f64) -> String {
    if !v.is_finite() || v == 0.0 {
        return format!("{v}");
    }
    let e = v.abs().log10().floor() as i32;
    if (-1..=2).contains(&e) {
        let digits = (2 - e).max(0) as usize;
        return format!("{v:.digits$}");
    }
    let m = v / 10f64.powi(e);
    let (m, e) = if m.abs() >= 9.995 { (m / 10.0, e + 1) } else { (m, e) };
    format!("{m:.2}×10{}", superscript(e))
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

// ---------------------------------------------------------------------------------------------------------------
// Looks

/// Okabe-Ito, in an order that keeps the first channels far apart (yellow left out: too pale on white).
const PALETTE: [RGBColor; 7] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(0, 0, 0),
];

fn colour(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

/// `c` mixed with white (`f` = 0: unchanged, 1: white).
fn lighter(c: RGBColor, f: f64) -> RGBColor {
    let m = |v: u8| (f64::from(v) + (255.0 - f64::from(v)) * f).round() as u8;
    RGBColor(m(c.0), m(c.1), m(c.2))
}

const INK: RGBColor = RGBColor(30, 30, 30);
const GREY: RGBColor = RGBColor(100, 100, 100);

/// Sizes scaled with the picture (1 at 1200x800, more slowly below).
#[derive(Clone, Copy, Debug)]
struct Look {
    s: f64,
}

impl Look {
    fn new(opts: &PlotOptions) -> Self {
        let s = (f64::from(opts.width) / 1200.0).min(f64::from(opts.height) / 800.0).clamp(0.3, 8.0);
        // Larger pictures scale as a whole (the same figure at a higher resolution); smaller ones keep their
        // text readable.
        Look { s: if s >= 1.0 { s } else { s.powf(0.6) } }
    }

    fn px(&self, v: f64) -> i32 {
        (v * self.s).round() as i32
    }

    fn font(&self, size: f64) -> TextStyle<'static> {
        (FAMILY, size * self.s).into_font().color(&INK)
    }
}

fn err<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

type LogAx = plotters::coord::combinators::WithKeyPoints<LogCoord<f64>>;
type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<LogAx, LogAx>>;
type Area<DB> = DrawingArea<DB, Shift>;

/// The title strip; returns the area below it.
fn title<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    text: &str,
    look: &Look,
) -> Result<DrawingArea<DB, Shift>, String> {
    let h = look.px(48.0);
    let (top, body) = root.split_vertically(h);
    let (w, _) = top.dim_in_pixel();
    let style = (FAMILY, 24.0 * look.s, FontStyle::Bold).into_font().color(&INK);
    top.draw(&Text::new(text.to_string(), (w as i32 / 2, look.px(14.0)), style.pos(Pos::new(HPos::Center, VPos::Top))))
        .map_err(err)?;
    Ok(body)
}

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
    // Close the frame (the mesh draws the left and bottom axes only).
    let (xr, yr) = chart.plotting_area().get_pixel_range();
    let frame = [(xr.start, yr.start), (xr.end - 1, yr.start), (xr.end - 1, yr.end - 1)];
    let root = chart.plotting_area().strip_coord_spec();
    let (x0, y0) = (xr.start, yr.start);
    root.draw(&PathElement::new(frame.iter().map(|&(x, y)| (x - x0, y - y0)).collect::<Vec<_>>(), INK.stroke_width(1)))
        .map_err(err)?;
    Ok(chart)
}

/// Split a log-log polyline into the runs that lie inside the box, cut exactly at its edges.
fn clip(points: &[(f64, f64)], x: (f64, f64), y: (f64, f64)) -> Vec<Vec<(f64, f64)>> {
    let l = |(a, b): (f64, f64)| (a.log10(), b.log10());
    let (bx, by) = (l(x), l(y));
    let mut runs = Vec::new();
    let mut cur: Vec<(f64, f64)> = Vec::new();
    for w in points.windows(2) {
        if !(positive(w[0].0) && positive(w[0].1) && positive(w[1].0) && positive(w[1].1)) {
            if cur.len() >= 2 {
                runs.push(std::mem::take(&mut cur));
            }
            cur.clear();
            continue;
        }
        match clip_segment(l(w[0]), l(w[1]), bx, by) {
            Some((p, q)) => {
                if cur.last() != Some(&p) {
                    if cur.len() >= 2 {
                        runs.push(std::mem::take(&mut cur));
                    }
                    cur.clear();
                    cur.push(p);
                }
                cur.push(q);
            }
            None => {
                if cur.len() >= 2 {
                    runs.push(std::mem::take(&mut cur));
                }
                cur.clear();
            }
        }
    }
    if cur.len() >= 2 {
        runs.push(cur);
    }
    runs.into_iter().map(|r| r.into_iter().map(|(a, b)| (10f64.powf(a), 10f64.powf(b))).collect()).collect()
}

/// Liang-Barsky; the endpoints that are inside come back unchanged.
fn clip_segment(
    a: (f64, f64),
    b: (f64, f64),
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
) -> Option<((f64, f64), (f64, f64))> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [(-dx, a.0 - x0), (dx, x1 - a.0), (-dy, a.1 - y0), (dy, y1 - a.1)] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    if t0 > t1 {
        return None;
    }
    let at = |t: f64| {
        if t == 0.0 {
            a
        } else if t == 1.0 {
            b
        } else {
            (a.0 + t * dx, a.1 + t * dy)
        }
    };
    Some((at(t0), at(t1)))
}

/// `n` log-spaced values from `a` to `b`.
fn logspace(a: f64, b: f64, n: usize) -> impl Iterator<Item = f64> {
    let (la, lb) = (a.log10(), b.log10());
    (0..n).map(move |i| 10f64.powf(la + (lb - la) * i as f64 / (n - 1) as f64))
}

/// Marker shapes, one per channel: circle, square, triangle, diamond, inverted triangle.
fn marker_polygon(shape: usize, r: i32) -> Vec<(i32, i32)> {
    let f = |v: f64| (v * f64::from(r)).round() as i32;
    match shape % 5 {
        1 => vec![(f(-0.9), f(-0.9)), (f(0.9), f(-0.9)), (f(0.9), f(0.9)), (f(-0.9), f(0.9))],
        2 => vec![(0, f(-1.3)), (f(1.15), f(0.75)), (f(-1.15), f(0.75))],
        3 => vec![(0, f(-1.3)), (f(1.1), 0), (0, f(1.3)), (f(-1.1), 0)],
        _ => vec![(0, f(1.3)), (f(1.15), f(-0.75)), (f(-1.15), f(-0.75))],
    }
}

/// Draw one marker on a pixel-coordinate area.
fn draw_marker<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    at: (i32, i32),
    shape: usize,
    r: i32,
    style: ShapeStyle,
) -> Result<(), String> {
    if shape.is_multiple_of(5) {
        area.draw(&Circle::new(at, r, style)).map_err(err)
    } else {
        area.draw(&(EmptyElement::at(at) + Polygon::new(marker_polygon(shape, r), style))).map_err(err)
    }
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

// ---------------------------------------------------------------------------------------------------------------
// Legend

#[derive(Clone, Copy, Debug)]
enum Sample {
    /// No sample (a detail row or a spacer).
    None,
    /// A channel: line and marker.
    Channel(RGBColor, usize),
    /// A solid line.
    Solid(RGBColor),
    /// A dashed line.
    Dashed(RGBColor),
    /// A filled swatch with an edge.
    Swatch(RGBAColor, RGBColor),
    /// A marker with an error bar, no line.
    Points(RGBColor, usize),
}

#[derive(Clone, Debug)]
struct Entry {
    sample: Sample,
    text: String,
    /// A detail row: smaller, grey, indented; dropped first when the legend does not fit.
    detail: bool,
}

impl Entry {
    fn main(sample: Sample, text: impl Into<String>) -> Self {
        Entry { sample, text: text.into(), detail: false }
    }

    fn detail(text: impl Into<String>) -> Self {
        Entry { sample: Sample::None, text: text.into(), detail: true }
    }

    fn spacer() -> Self {
        Entry { sample: Sample::None, text: String::new(), detail: false }
    }

    fn font(&self, look: &Look) -> TextStyle<'static> {
        if self.detail {
            (FAMILY, 14.0 * look.s).into_font().color(&GREY)
        } else {
            look.font(16.0)
        }
    }

    fn height(&self, look: &Look) -> i32 {
        match (self.detail, self.text.is_empty()) {
            (_, true) => look.px(10.0),
            (true, false) => look.px(20.0),
            (false, false) => look.px(27.0),
        }
    }
}

/// A legend box to the right of the axes.
struct Legend {
    entries: Vec<Entry>,
}

impl Legend {
    const PAD: f64 = 12.0;
    const SAMPLE: f64 = 38.0;
    const GAP: f64 = 10.0;

    /// The entries that fit in `height` (details dropped when they do not).
    fn fitted(&self, height: i32, look: &Look) -> Vec<Entry> {
        let total = |es: &[Entry]| es.iter().map(|e| e.height(look)).sum::<i32>() + 2 * look.px(Self::PAD);
        if total(&self.entries) <= height {
            return self.entries.clone();
        }
        self.entries.iter().filter(|e| !e.detail).cloned().collect()
    }

    /// The width the entries need.
    fn width<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>, look: &Look) -> Result<i32, String> {
        let mut w = 0;
        for e in &self.entries {
            let (tw, _) = area.estimate_text_size(&e.text, &e.font(look)).map_err(err)?;
            w = w.max(tw as i32);
        }
        Ok(w + look.px(2.0 * Self::PAD + Self::SAMPLE + Self::GAP))
    }

    /// Draw at (`x`, `y`) of `area` (pixels).
    fn draw<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        x: i32,
        y: i32,
        look: &Look,
    ) -> Result<(), String> {
        let (aw, ah) = area.dim_in_pixel();
        let entries = self.fitted(ah as i32 - y, look);
        let pad = look.px(Self::PAD);
        let height: i32 = entries.iter().map(|e| e.height(look)).sum::<i32>() + 2 * pad;
        let right = aw as i32 - look.px(10.0);
        area.draw(&Rectangle::new([(x, y), (right, y + height)], WHITE.filled())).map_err(err)?;
        area.draw(&Rectangle::new([(x, y), (right, y + height)], BLACK.mix(0.35).stroke_width(1))).map_err(err)?;
        let (sx, sw) = (x + pad, look.px(Self::SAMPLE));
        let tx = sx + sw + look.px(Self::GAP);
        let mut cy = y + pad;
        for e in &entries {
            let h = e.height(look);
            let mid = cy + h / 2;
            let line =
                |c: RGBColor| PathElement::new(vec![(sx, mid), (sx + sw, mid)], c.stroke_width(look.px(2.2) as u32));
            match e.sample {
                Sample::None => {}
                Sample::Channel(c, shape) => {
                    area.draw(&line(c)).map_err(err)?;
                    draw_marker(area, (sx + sw / 2, mid), shape, look.px(5.0), c.filled())?;
                }
                Sample::Solid(c) => area.draw(&line(c)).map_err(err)?,
                Sample::Dashed(c) => {
                    let dash = look.px(7.0);
                    let mut x0 = sx;
                    while x0 < sx + sw {
                        let x1 = (x0 + dash).min(sx + sw);
                        area.draw(&PathElement::new(vec![(x0, mid), (x1, mid)], c.stroke_width(look.px(2.0) as u32)))
                            .map_err(err)?;
                        x0 += dash + look.px(5.0);
                    }
                }
                Sample::Swatch(fill, edge) => {
                    let r = [(sx, mid - look.px(7.0)), (sx + sw, mid + look.px(7.0))];
                    area.draw(&Rectangle::new(r, fill.filled())).map_err(err)?;
                    area.draw(&Rectangle::new(r, edge.stroke_width(1))).map_err(err)?;
                }
                Sample::Points(c, shape) => {
                    let bar = c.stroke_width(look.px(1.5).max(1) as u32);
                    let (cx, half) = (sx + sw / 2, look.px(9.0));
                    area.draw(&PathElement::new(vec![(cx, mid - half), (cx, mid + half)], bar)).map_err(err)?;
                    for yy in [mid - half, mid + half] {
                        area.draw(&PathElement::new(vec![(cx - look.px(5.0), yy), (cx + look.px(5.0), yy)], bar))
                            .map_err(err)?;
                    }
                    draw_marker(area, (cx, mid), shape, look.px(5.0), c.filled())?;
                }
            }
            if !e.text.is_empty() {
                let style = e.font(look).pos(Pos::new(HPos::Left, VPos::Center));
                area.draw(&Text::new(e.text.clone(), (tx, mid), style)).map_err(err)?;
            }
            cy += h;
        }
        Ok(())
    }
}

/// Lay out title, axes and a legend to the right; returns the axes and the legend's area.
/// A legend that would take more than a third of the width loses its detail rows.
fn frame<DB: DrawingBackend>(
    body: &DrawingArea<DB, Shift>,
    legend: &mut Legend,
    look: &Look,
) -> Result<(Area<DB>, Area<DB>), String> {
    let (w, _) = body.dim_in_pixel();
    if legend.width(body, look)? > w as i32 / 3 {
        legend.entries.retain(|e| !e.detail);
    }
    let lw = legend.width(body, look)?.clamp(look.px(150.0), (w as i32) * 2 / 5);
    Ok(body.split_horizontally(w as i32 - lw - look.px(10.0)))
}

// ---------------------------------------------------------------------------------------------------------------
// The ADEV plot

/// A term is drawn where its ADEV is at least this fraction of the model's (about a decade of tau past where it
/// stops dominating, for the +-1/2 slopes).
const TERM_SHARE: f64 = 0.25;

fn draw_adev<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    series: &[Prepared<'_>],
    ext: &Extent,
    opts: &PlotOptions,
) -> Result<(), String> {
    let look = Look::new(opts);
    root.fill(&WHITE).map_err(err)?;
    let (xa, ya) = ext.axes();
    let body = title(root, &opts.title, &look)?;
    let mut legend = adev_legend(series, opts);
    let (plot_area, legend_area) = frame(&body, &mut legend, &look)?;
    let mut chart = axes(&plot_area, &xa, &ya, &opts.unit, &look)?;
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

fn adev_legend(series: &[Prepared<'_>], opts: &PlotOptions) -> Legend {
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
                            term_unit(t, &opts.unit)
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

// ---------------------------------------------------------------------------------------------------------------
// The gap plot

const BEFORE: RGBColor = RGBColor(213, 94, 0);
const AFTER: RGBColor = RGBColor(0, 114, 178);
const HIGHLIGHT: RGBColor = RGBColor(240, 228, 66);
const HIGHLIGHT_EDGE: RGBColor = RGBColor(175, 150, 0);

fn draw_gap<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    gap: &GapPlot,
    real: &[Mark],
    before: &[Band],
    after: Option<&[Band]>,
    ext: &Extent,
    opts: &PlotOptions,
) -> Result<(), String> {
    let look = Look::new(opts);
    root.fill(&WHITE).map_err(err)?;
    let (xa, ya) = ext.axes();
    let body = title(root, &opts.title, &look)?;
    let band = gap.band_s.filter(|(a, b)| positive(*a) && positive(*b) && a < b);
    let mut entries = Vec::new();
    if !real.is_empty() {
        entries.push(Entry::main(Sample::Points(INK, 0), gap.real_label.as_str()));
    }
    if !before.is_empty() {
        entries.push(Entry::main(Sample::Swatch(BEFORE.mix(0.25), BEFORE), gap.before_label.as_str()));
    }
    if after.is_some_and(|a| !a.is_empty()) {
        entries.push(Entry::main(Sample::Swatch(AFTER.mix(0.25), AFTER), gap.after_label.as_str()));
    }
    if band.is_some() {
        entries.push(Entry::main(Sample::Swatch(HIGHLIGHT.mix(0.3), HIGHLIGHT_EDGE), gap.band_label.as_str()));
    }
    let mut legend = Legend { entries };
    let (plot_area, legend_area) = frame(&body, &mut legend, &look)?;
    let mut chart = axes(&plot_area, &xa, &ya, &opts.unit, &look)?;

    let band = band.map(|(a, b)| (a.max(xa.lo), b.min(xa.hi))).filter(|(a, b)| a < b);
    if let Some((a, b)) = band {
        chart
            .draw_series(std::iter::once(Rectangle::new([(a, ya.lo), (b, ya.hi)], HIGHLIGHT.mix(0.3).filled())))
            .map_err(err)?;
        let edge = HIGHLIGHT_EDGE.stroke_width(look.px(1.5).max(1) as u32);
        for t in [a, b].into_iter().filter(|&t| t > xa.lo && t < xa.hi) {
            chart
                .draw_series(DashedLineSeries::new([(t, ya.lo), (t, ya.hi)], look.px(6.0), look.px(4.0), edge))
                .map_err(err)?;
        }
    }
    for (data, c) in [(Some(before), BEFORE), (after, AFTER)] {
        let Some(data) = data.filter(|d| !d.is_empty()) else { continue };
        let clamp = |v: f64| v.clamp(ya.lo, ya.hi);
        let mut poly: Vec<(f64, f64)> = data.iter().map(|b| (b.tau_s, clamp(b.lo))).collect();
        poly.extend(data.iter().rev().map(|b| (b.tau_s, clamp(b.hi))));
        chart.draw_series(std::iter::once(Polygon::new(poly, c.mix(0.25).filled()))).map_err(err)?;
        for edge in
            [data.iter().map(|b| (b.tau_s, b.lo)).collect::<Vec<_>>(), data.iter().map(|b| (b.tau_s, b.hi)).collect()]
        {
            for piece in clip(&edge, (xa.lo, xa.hi), (ya.lo, ya.hi)) {
                chart
                    .draw_series(LineSeries::new(piece, c.mix(0.8).stroke_width(look.px(1.2).max(1) as u32)))
                    .map_err(err)?;
            }
        }
    }
    if !real.is_empty() {
        let line: Vec<(f64, f64)> = real.iter().map(|m| (m.tau, m.dev)).collect();
        for piece in clip(&line, (xa.lo, xa.hi), (ya.lo, ya.hi)) {
            chart
                .draw_series(LineSeries::new(piece, INK.mix(0.6).stroke_width(look.px(1.2).max(1) as u32)))
                .map_err(err)?;
        }
        draw_points(&mut chart, real, &ya, 0, INK, &look)?;
    }
    if let Some((a, b)) = band.filter(|_| !gap.band_label.is_empty()) {
        // The label at the top of the band, kept inside the frame.
        let style = (FAMILY, 16.0 * look.s, FontStyle::Bold).into_font().color(&INK);
        let (w, _) = root.estimate_text_size(&gap.band_label, &style).map_err(err)?;
        let (xr, yr) = chart.plotting_area().get_pixel_range();
        let (mid, _) = chart.backend_coord(&((a * b).sqrt(), ya.hi));
        let half = w as i32 / 2 + look.px(6.0);
        let x = if xr.end - xr.start > 2 * half { mid.clamp(xr.start + half, xr.end - half) } else { mid };
        let at = (x, yr.start + look.px(8.0));
        root.draw(&Text::new(gap.band_label.clone(), at, style.pos(Pos::new(HPos::Center, VPos::Top)))).map_err(err)?;
    }
    legend.draw(&legend_area, 0, look.px(8.0), &look)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::{fit, FitOptions, FitPoint, FLICKER_AVAR_FACTOR};
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
                dev,
                alpha: 0,
                noise_method: NoiseMethod::Default,
                edf,
                lo: dev / (1.0 + sd),
                hi: dev * (1.0 + sd * 1.3),
            });
            m *= 2;
        }
        let fp: Vec<FitPoint> =
            points.iter().map(|p| FitPoint { tau_s: p.tau_s, avar: p.dev * p.dev, edf: p.edf }).collect();
        let fit = fit(&fp, &FitOptions::default()).ok();
        AdevSeries { name: name.to_string(), points, fit }
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

    fn png_size(bytes: &[u8]) -> (u32, u32) {
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "PNG signature");
        assert_eq!(&bytes[12..16], b"IHDR");
        let be = |b: &[u8]| u32::from_be_bytes([b[0], b[1], b[2], b[3]]);
        (be(&bytes[16..20]), be(&bytes[20..24]))
    }

    /// Keep the pictures for a look when OCTAVAR_PLOT_DIR is set.
    fn out_dir(tmp: &tempfile::TempDir) -> PathBuf {
        match std::env::var_os("OCTAVAR_PLOT_DIR") {
            Some(d) => {
                std::fs::create_dir_all(&d).unwrap();
                PathBuf::from(d)
            }
            None => tmp.path().to_path_buf(),
        }
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
    fn gap_plot_writes_svg_and_png() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = out_dir(&tmp);
        let real = channel("real", 3.0e-3, 13e-3, 1.6e-4, 24.0, 7).points;
        let model = |n: f64, b: f64, k: f64, t: f64| (n * n / t + FLICKER_AVAR_FACTOR * b * b + k * k * t / 3.0).sqrt();
        let ens = |k: f64| -> Vec<Band> {
            real.iter()
                .map(|p| {
                    let v = model(3.0e-3, 13e-3, k, p.tau_s);
                    let w = 1.0 + 2.0 * (2.0 / p.edf).sqrt();
                    Band { tau_s: p.tau_s, lo: v / w, hi: v * w }
                })
                .collect()
        };
        let mut gap = GapPlot::new(real.clone(), ens(1.0e-5));
        gap.after = Some(ens(1.6e-4));
        gap.band_s = Some((200.0, 20_000.0));
        gap.band_label = "gap: rate random walk missing".into();
        let opts = PlotOptions { title: "IDG1215 Y: measured vs simulated".into(), ..Default::default() };
        let svg = dir.join("gap.svg");
        gap_plot(&gap, &opts, &svg).unwrap();
        let text = std::fs::read_to_string(&svg).unwrap();
        for s in ["measured", "simulated, before", "simulated, after", "gap: rate random walk missing", "tau (s)"] {
            assert!(text.contains(s), "{s} missing from the SVG");
        }
        let png = dir.join("gap.png");
        gap_plot(&gap, &opts, &png).unwrap();
        assert_eq!(png_size(&std::fs::read(&png).unwrap()), (1200, 800));
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
        let gap = GapPlot::new(Vec::new(), Vec::new());
        assert!(matches!(gap_plot(&gap, &PlotOptions::default(), &path), Err(PlotError::Empty)));
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

    #[test]
    fn axes_and_labels() {
        let a = LogAxis::new((5e-4, 1.3e5));
        assert_eq!((a.lo, a.hi), (2e-4, 2e5));
        assert_eq!(a.major.len(), 9);
        assert_eq!(tick_label(1e-3), "10⁻³");
        assert_eq!(tick_label(1.0), "10⁰");
        assert_eq!(tick_label(2e4), "2×10⁴");
        assert_eq!(value_label(4.0e-4), "4.00×10⁻⁴");
        assert_eq!(value_label(0.013), "1.30×10⁻²");
        assert_eq!(value_label(0.26), "0.260");
        assert_eq!(value_label(26.0), "26.0");
        let narrow = LogAxis::new((3e-3, 4e-3));
        assert!(narrow.major.len() >= 2, "{narrow:?}");
        let runs = clip(&[(0.1, 0.1), (10.0, 10.0), (1000.0, 1000.0)], (1.0, 100.0), (1e-3, 1e3));
        assert_eq!(runs.len(), 1);
        let r = &runs[0];
        assert!((r[0].0 - 1.0).abs() < 1e-9 && (r.last().unwrap().0 - 100.0).abs() < 1e-9, "{r:?}");
    }
}

//! Drawing the gap figure ([`GapFigure`], see [`super::gap`] for what it shows): [`gap_plot`] writes it, laid out
//! as the title, the legend in rows, a grid of view panels (two across, three when there are three), the time
//! panel across the bottom, and a footnote of what is left unexplained. Sizes are given for [`REFERENCE_SIZE`]
//! ([`PlotOptions::gap_figure`]) and scale with the picture.

use std::path::Path;

use plotters::coord::ranged1d::{AsRangedCoord, Ranged, ValueFormatter};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::axis::{clip_scaled, close_frame, tick_label, LinAxis, LogAxis};
use super::gap::{BandMark, Column, GapFigure, MarkKind, PanelPoint, Scale, TimePanel, ViewPanel};
use super::legend::{draw_marker, Entry, Legend, Sample};
use super::{check_size, err, format_of, lighter, positive, title, Area, Look, PlotError, PlotOptions};
use super::{FAMILY, GREY, INK};

/// The size the figure's text and lines are given for, pixels.
pub(super) const REFERENCE_SIZE: (u32, u32) = (1600, 1200);

/// The base model's ensemble (Okabe-Ito vermillion).
const BASE: RGBColor = RGBColor(213, 94, 0);
/// The chain's ensemble (Okabe-Ito blue).
const CHAIN: RGBColor = RGBColor(0, 114, 178);
/// Located bands.
const HIGHLIGHT: RGBColor = RGBColor(240, 228, 66);
const HIGHLIGHT_EDGE: RGBColor = RGBColor(160, 135, 0);
/// What is left unexplained (Okabe-Ito reddish purple).
const LEFT: RGBColor = RGBColor(204, 121, 167);
const LEFT_EDGE: RGBColor = RGBColor(150, 60, 110);
/// Masked transients.
const TRANSIENT: RGBColor = RGBColor(215, 25, 28);

/// Share of a view row's height the time panel gets.
const TIME_ROW: f64 = 0.8;

type LogAx = plotters::coord::combinators::WithKeyPoints<LogCoord<f64>>;
/// A view panel's axes: log x, and `Y`.
type PanelChart<'a, DB, Y> = ChartContext<'a, DB, Cartesian2d<LogAx, Y>>;

impl PlotOptions {
    /// The options of a gap figure: `title`, at 1600x1200 pixels (the size its text is laid out for).
    pub fn gap_figure(title: impl Into<String>) -> PlotOptions {
        let (width, height) = REFERENCE_SIZE;
        PlotOptions { title: title.into(), width, height, ..Default::default() }
    }
}

/// Draw the gap figure `fig` into `path` (`.png` or `.svg`); [`PlotOptions::gap_figure`] gives the size it is laid
/// out for (the title is `opts.title`; the units are deg/s whatever `opts.unit` says, as the diagnosis's are).
///
/// # Errors
/// [`PlotError::UnknownFormat`], [`PlotError::Empty`] when no panel has a point and the record has no sample,
/// [`PlotError::TooSmall`], [`PlotError::Write`].
pub fn gap_plot(fig: &GapFigure, opts: &PlotOptions, path: &Path) -> Result<(), PlotError> {
    let format = format_of(path)?;
    check_size(opts)?;
    if fig.is_empty() {
        return Err(PlotError::Empty);
    }
    render!(format, path, opts, |root| draw(root, fig, opts))
}

/// Draw `fig` on `root`.
fn draw<DB: DrawingBackend>(root: &Area<DB>, fig: &GapFigure, opts: &PlotOptions) -> Result<(), String> {
    let look = Look::relative_to(opts, REFERENCE_SIZE);
    root.fill(&WHITE).map_err(err)?;
    let body = title(root, &opts.title, &look)?;
    let side = look.px(16.0);
    let (w, _) = body.dim_in_pixel();
    let legend = legend(fig);
    let legend_h = legend.rows_height(&body, w as i32 - 2 * side, &look)? + look.px(8.0);
    let (top, body) = body.split_vertically(legend_h);
    legend.draw_rows(&top.margin(0, 0, side, side), &look)?;

    let body = match &fig.unexplained {
        Some(text) => {
            let style = (FAMILY, 15.0 * look.s).into_font().color(&GREY);
            let text = format!("Left unexplained: {text}");
            let lines = wrap(&body, text.split(' '), " ", &style, w as i32 - 2 * side)?;
            let line_h = look.px(20.0);
            let (_, h) = body.dim_in_pixel();
            let (rest, foot) = body.split_vertically(h as i32 - lines.len() as i32 * line_h - look.px(10.0));
            for (i, line) in lines.iter().enumerate() {
                let at = (side, look.px(4.0) + i as i32 * line_h);
                foot.draw(&Text::new(line.clone(), at, style.pos(Pos::new(HPos::Left, VPos::Top)))).map_err(err)?;
            }
            rest
        }
        None => body,
    };

    let n = fig.panels.len();
    let cols = match n {
        0 | 1 => 1,
        3 => 3,
        _ => 2,
    };
    let rows = n.div_ceil(cols);
    let (_, h) = body.dim_in_pixel();
    let grid_h = (f64::from(h) * rows as f64 / (rows as f64 + TIME_ROW)).round() as i32;
    let (grid, time) = body.split_vertically(grid_h);
    if n > 0 {
        for (panel, area) in fig.panels.iter().zip(grid.split_evenly((rows, cols))) {
            draw_view(&area, panel, &look)?;
        }
    }
    draw_time(&time, &fig.time, &look)
}

/// The legend: what each colour and marker is, with only the entries the figure uses.
fn legend(fig: &GapFigure) -> Legend {
    let mut entries = vec![Entry::main(Sample::Marker(INK, 0, false), "measured (training part)")];
    if fig.panels.iter().any(|p| p.chain_real_differs) {
        entries.push(Entry::main(Sample::Marker(CHAIN, 0, true), "measured less the chain's temperature response"));
    }
    if fig.panels.iter().any(|p| p.base.iter().any(|q| q.apart)) {
        entries.push(Entry::main(Sample::Marker(INK, 3, false), "kurtosis at tau0"));
    }
    entries.push(Entry::main(Sample::Swatch(BASE.mix(0.25), BASE), format!("{} (mean ± 2 sd)", fig.base_label)));
    if let Some(label) = &fig.chain_label {
        entries.push(Entry::main(Sample::Swatch(CHAIN.mix(0.25), CHAIN), label.as_str()));
    }
    let marks = || fig.panels.iter().flat_map(|p| &p.marks);
    if marks().any(|m| matches!(m.kind, MarkKind::Located { .. })) {
        let text = if fig.chain_label.is_some() { "gap located (n: the chain's step)" } else { "gap located" };
        entries.push(Entry::main(Sample::Swatch(HIGHLIGHT.mix(0.4), HIGHLIGHT_EDGE), text));
    }
    if marks().any(|m| m.kind == MarkKind::Unexplained) {
        entries.push(Entry::main(Sample::Swatch(LEFT.mix(0.3), LEFT_EDGE), "gap left unexplained"));
    }
    if !fig.time.transients.is_empty() {
        entries.push(Entry::main(Sample::Swatch(TRANSIENT.mix(0.35), TRANSIENT), "transient, masked"));
    }
    Legend { entries }
}

/// `units` joined by `sep` into lines no wider than `width` (a unit wider than that gets a line of its own).
fn wrap<'a, DB: DrawingBackend>(
    area: &Area<DB>,
    units: impl IntoIterator<Item = &'a str>,
    sep: &str,
    style: &TextStyle<'_>,
    width: i32,
) -> Result<Vec<String>, String> {
    let mut lines: Vec<String> = Vec::new();
    for u in units {
        if let Some(last) = lines.last_mut() {
            let joined = format!("{last}{sep}{u}");
            if area.estimate_text_size(&joined, style).map_err(err)?.0 as i32 <= width {
                *last = joined;
                continue;
            }
        }
        lines.push(u.to_string());
    }
    Ok(lines)
}

// ---------------------------------------------------------------------------------------------------------------
// The view panels

/// The range of `values`' positive (`log`) or finite members.
fn extent(values: impl Iterator<Item = f64>, log: bool) -> Option<(f64, f64)> {
    values
        .filter(|&v| if log { positive(v) } else { v.is_finite() })
        .fold(None, |r, v| Some(r.map_or((v, v), |(a, b): (f64, f64)| (a.min(v), b.max(v)))))
}

fn draw_view<DB: DrawingBackend>(area: &Area<DB>, panel: &ViewPanel, look: &Look) -> Result<(), String> {
    let (w, _) = area.dim_in_pixel();
    let note_style = (FAMILY, 13.0 * look.s).into_font().color(&GREY);
    let notes = wrap(area, panel.notes.iter().map(String::as_str), ";  ", &note_style, w as i32 - look.px(24.0))?;
    let (title_h, note_h) = (look.px(28.0), look.px(17.0));
    // A strip for the located bands' labels, above the plotting area.
    let labels_h = if panel.marks.is_empty() { 0 } else { look.px(16.0) };
    let (header, plot) = area.split_vertically(title_h + notes.len() as i32 * note_h + labels_h);
    let centre = w as i32 / 2;
    let bold = (FAMILY, 16.0 * look.s, FontStyle::Bold).into_font().color(&INK);
    header
        .draw(&Text::new(panel.title.clone(), (centre, look.px(8.0)), bold.pos(Pos::new(HPos::Center, VPos::Top))))
        .map_err(err)?;
    for (i, line) in notes.iter().enumerate() {
        let at = (centre, title_h + i as i32 * note_h);
        header.draw(&Text::new(line.clone(), at, note_style.pos(Pos::new(HPos::Center, VPos::Top)))).map_err(err)?;
    }

    let points = || panel.base.iter().chain(panel.chain.iter().flatten());
    let Some(xr) = extent(points().map(|p| p.x), true) else { return Ok(()) };
    let xa = LogAxis::new(xr);
    let x = (xa.lo..xa.hi).log_scale().with_key_points(xa.major.clone()).with_light_points(xa.minor.clone());
    let values = || points().flat_map(|p| [p.real, p.band[0], p.band[1]]);
    match panel.y_scale {
        Scale::Log => {
            let Some(yr) = extent(values(), true) else { return Ok(()) };
            let ya = LogAxis::new(yr);
            let y = (ya.lo..ya.hi).log_scale().with_key_points(ya.major.clone()).with_light_points(ya.minor.clone());
            let fmt = |v: &f64| tick_label(*v);
            let mut chart = panel_chart(&plot, x, y, (&panel.x_label, &panel.y_label), &fmt, look)?;
            let labels = draw_content(&mut chart, panel, ((xa.lo, xa.hi), (ya.lo, ya.hi)), true, look)?;
            draw_labels(area, labels, chart.plotting_area().get_base_pixel().1, look)
        }
        Scale::Linear => {
            let (lo, hi) = match panel.y_limits {
                Some(l) => l,
                // The distribution's excess kurtosis: 0 is a Gaussian's, always in view.
                None => extent(values().chain([0.0]), false).unwrap_or((0.0, 1.0)),
            };
            let ya = LinAxis::new((lo, hi));
            let y = ya.coord();
            let fmt = |v: &f64| ya.label(*v);
            let mut chart = panel_chart(&plot, x, y, (&panel.x_label, &panel.y_label), &fmt, look)?;
            let labels = draw_content(&mut chart, panel, ((xa.lo, xa.hi), (ya.lo, ya.hi)), false, look)?;
            draw_labels(area, labels, chart.plotting_area().get_base_pixel().1, look)
        }
    }
}

/// Axes on a panel: a log x axis with decade labels, the y axis `y`, a grid, a frame and the axis labels.
fn panel_chart<'a, DB, Y>(
    area: &'a Area<DB>,
    x: LogAx,
    y: Y,
    (x_label, y_label): (&str, &str),
    y_fmt: &dyn Fn(&f64) -> String,
    look: &Look,
) -> Result<PanelChart<'a, DB, Y::CoordDescType>, String>
where
    DB: DrawingBackend,
    Y: AsRangedCoord<Value = f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let mut chart = ChartBuilder::on(area)
        .margin_top(look.px(4.0))
        .margin_right(look.px(20.0))
        .margin_bottom(look.px(6.0))
        .margin_left(look.px(8.0))
        .x_label_area_size(look.px(46.0))
        .y_label_area_size(look.px(78.0))
        .build_cartesian_2d(x, y)
        .map_err(err)?;
    let x_fmt = |v: &f64| tick_label(*v);
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .x_label_formatter(&x_fmt)
        .y_label_formatter(y_fmt)
        .label_style(look.font(13.5))
        .axis_desc_style(look.font(15.0))
        .bold_line_style(BLACK.mix(0.16).stroke_width(1))
        .light_line_style(BLACK.mix(0.05).stroke_width(1))
        .axis_style(INK.stroke_width(1))
        .set_all_tick_mark_size(look.px(5.0))
        .draw()
        .map_err(err)?;
    close_frame(chart.plotting_area())?;
    Ok(chart)
}

/// The plotting area in pixels (its own origin at its top left) and a map from data to those pixels.
fn pixels<'c, 'a, DB: DrawingBackend, X: Ranged<ValueType = f64>, Y: Ranged<ValueType = f64>>(
    chart: &'c ChartContext<'a, DB, Cartesian2d<X, Y>>,
) -> (Area<DB>, impl Fn(f64, f64) -> (i32, i32) + use<'c, 'a, DB, X, Y>) {
    let (x0, y0) = chart.plotting_area().get_base_pixel();
    let to = move |x: f64, y: f64| {
        let (px, py) = chart.backend_coord(&(x, y));
        (px - x0, py - y0)
    };
    (chart.plotting_area().strip_coord_spec(), to)
}

/// Marks, bands, then the record, on a panel's axes (`bounds`: the x and y limits); returns the marks' labels.
fn draw_content<DB: DrawingBackend, Y: Ranged<ValueType = f64>>(
    chart: &mut PanelChart<'_, DB, Y>,
    panel: &ViewPanel,
    bounds: ((f64, f64), (f64, f64)),
    y_log: bool,
    look: &Look,
) -> Result<Vec<Label>, String> {
    let (bx, by) = bounds;
    let labels = draw_marks(chart, &panel.marks, bounds, look)?;
    draw_band(chart, &panel.base, BASE, bounds, y_log, look)?;
    if let Some(chain) = &panel.chain {
        draw_band(chart, chain, CHAIN, bounds, y_log, look)?;
    }
    let chain_real = panel.chain.as_deref().filter(|_| panel.chain_real_differs);
    for (points, c, hollow) in [(Some(&panel.base[..]), INK, false), (chain_real, CHAIN, true)] {
        let Some(points) = points else { continue };
        let line: Vec<(f64, f64)> = points.iter().filter(|p| !p.apart).map(|p| (p.x, p.real)).collect();
        for piece in clip_scaled(&line, bx, by, y_log) {
            chart
                .draw_series(LineSeries::new(piece, c.mix(0.55).stroke_width(look.px(1.2).max(1) as u32)))
                .map_err(err)?;
        }
        let (pix, to) = pixels(chart);
        let inside = |v: f64| v >= by.0 && v <= by.1;
        for p in points.iter().filter(|p| inside(p.real) && p.x >= bx.0 && p.x <= bx.1) {
            let shape = if p.apart { 3 } else { 0 };
            draw_marker(&pix, to(p.x, p.real), shape, look.px(if p.apart { 5.5 } else { 4.5 }), c, hollow)?;
        }
    }
    Ok(labels)
}

/// An ensemble's band: a shaded area with its edges over the points joined in x, a bar at a point drawn apart.
fn draw_band<DB: DrawingBackend, Y: Ranged<ValueType = f64>>(
    chart: &mut PanelChart<'_, DB, Y>,
    points: &[PanelPoint],
    c: RGBColor,
    (bx, by): ((f64, f64), (f64, f64)),
    y_log: bool,
    look: &Look,
) -> Result<(), String> {
    // Below a log axis (a lower edge of 0 or less) the band runs to the bottom.
    let clamp = |v: f64| if v.is_nan() { by.0 } else { v.clamp(by.0, by.1) };
    let joined: Vec<&PanelPoint> = points.iter().filter(|p| !p.apart).collect();
    let edge = c.mix(0.8).stroke_width(look.px(1.2).max(1) as u32);
    if joined.len() >= 2 {
        let mut poly: Vec<(f64, f64)> = joined.iter().map(|p| (p.x, clamp(p.band[0]))).collect();
        poly.extend(joined.iter().rev().map(|p| (p.x, clamp(p.band[1]))));
        chart.draw_series(std::iter::once(Polygon::new(poly, c.mix(0.22).filled()))).map_err(err)?;
        for k in 0..2 {
            let line: Vec<(f64, f64)> = joined.iter().map(|p| (p.x, p.band[k])).collect();
            for piece in clip_scaled(&line, bx, by, y_log) {
                chart.draw_series(LineSeries::new(piece, edge)).map_err(err)?;
            }
        }
    }
    let (pix, to) = pixels(chart);
    let half = look.px(7.0);
    for p in points.iter().filter(|p| p.apart || joined.len() < 2) {
        let ((x, top), (_, bottom)) = (to(p.x, clamp(p.band[1])), to(p.x, clamp(p.band[0])));
        let r = [(x - half, top), (x + half, bottom)];
        pix.draw(&Rectangle::new(r, c.mix(0.22).filled())).map_err(err)?;
        pix.draw(&Rectangle::new(r, edge)).map_err(err)?;
    }
    Ok(())
}

/// The located bands: shaded across the panel's height with dashed edges; returns their labels, to be drawn
/// above the plotting area ([`draw_labels`]).
fn draw_marks<DB: DrawingBackend, Y: Ranged<ValueType = f64>>(
    chart: &mut PanelChart<'_, DB, Y>,
    marks: &[BandMark],
    (bx, by): ((f64, f64), (f64, f64)),
    look: &Look,
) -> Result<Vec<Label>, String> {
    let (pix, to) = pixels(chart);
    let (w, h) = pix.dim_in_pixel();
    let (w, h) = (w as i32, h as i32);
    // Later steps first (lightest), so the first step's band is on top of them.
    let mut order: Vec<&BandMark> = marks.iter().collect();
    order.sort_by_key(|m| match m.kind {
        MarkKind::Located { step } => usize::MAX - step,
        MarkKind::Unexplained => usize::MAX,
    });
    let mut labels = Vec::new();
    for m in order {
        let (a, b) = (m.x[0].max(bx.0), m.x[1].min(bx.1));
        if !(a <= b) {
            continue;
        }
        let (mut x0, mut x1) = (to(a, by.1).0.clamp(0, w - 1), to(b, by.1).0.clamp(0, w - 1));
        // A band of one point (the distribution's tau0) or narrower than a few pixels is widened to be seen.
        let least = look.px(10.0);
        if x1 - x0 < least {
            let mid = (x0 + x1) / 2;
            (x0, x1) = ((mid - least / 2).max(0), (mid + least / 2).min(w - 1));
        }
        let (fill, edge, text) = match m.kind {
            MarkKind::Located { step: 0 } => (HIGHLIGHT.mix(0.4), HIGHLIGHT_EDGE, RGBColor(110, 90, 0)),
            MarkKind::Located { .. } => (HIGHLIGHT.mix(0.18), lighter(HIGHLIGHT_EDGE, 0.4), HIGHLIGHT_EDGE),
            MarkKind::Unexplained => (LEFT.mix(0.25), LEFT_EDGE, LEFT_EDGE),
        };
        pix.draw(&Rectangle::new([(x0, 0), (x1, h - 1)], fill.filled())).map_err(err)?;
        let dash = edge.stroke_width(look.px(1.3).max(1) as u32);
        for x in [x0, x1] {
            let mut y = 0;
            while y < h {
                pix.draw(&PathElement::new(vec![(x, y), (x, (y + look.px(6.0)).min(h - 1))], dash)).map_err(err)?;
                y += look.px(10.0);
            }
        }
        let (base_x, _) = pix.get_base_pixel();
        labels.push(Label { text: m.label.clone(), x: base_x + (x0 + x1) / 2, colour: text });
    }
    Ok(labels)
}

/// A located band's label: its text, its centre (backend pixels) and colour.
struct Label {
    text: String,
    x: i32,
    colour: RGBColor,
}

/// The labels of the located bands in the strip above the plotting area whose top is at backend pixel `top`, each
/// centred on its band as far as the others let it (they are pushed right of each other, not stacked).
fn draw_labels<DB: DrawingBackend>(
    area: &Area<DB>,
    mut labels: Vec<Label>,
    top: i32,
    look: &Look,
) -> Result<(), String> {
    let (ax, ay) = area.get_base_pixel();
    let (w, _) = area.dim_in_pixel();
    labels.sort_by_key(|l| l.x);
    let mut right = i32::MIN;
    for l in labels {
        let style = (FAMILY, 13.5 * look.s, FontStyle::Bold).into_font().color(&l.colour);
        let (tw, _) = area.estimate_text_size(&l.text, &style).map_err(err)?;
        let tw = tw as i32;
        let left = (l.x - ax - tw / 2).max(right + look.px(12.0)).min(w as i32 - tw - look.px(4.0)).max(0);
        right = left + tw;
        let at = (left, top - ay - look.px(3.0));
        area.draw(&Text::new(l.text, at, style.pos(Pos::new(HPos::Left, VPos::Bottom)))).map_err(err)?;
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------------------------
// The time panel

fn draw_time<DB: DrawingBackend>(area: &Area<DB>, t: &TimePanel, look: &Look) -> Result<(), String> {
    let (w, _) = area.dim_in_pixel();
    let title_h = look.px(28.0);
    let (header, plot) = area.split_vertically(title_h);
    let bold = (FAMILY, 16.0 * look.s, FontStyle::Bold).into_font().color(&INK);
    let text = if t.transients.is_empty() {
        "The record".to_string()
    } else {
        let n = t.transients.len();
        format!("The record, {n} transient{} masked", if n == 1 { "" } else { "s" })
    };
    header
        .draw(&Text::new(text, (w as i32 / 2, look.px(8.0)), bold.pos(Pos::new(HPos::Center, VPos::Top))))
        .map_err(err)?;
    // The rate axis fits the record outside its transients, whose excursions (often tens of times the noise) would
    // flatten the rest: they run off the axes where they are shaded.
    let calm = |c: &&Column| !t.transients.iter().any(|&[a, b]| c.t_s[0] < b && c.t_s[1] > a);
    let values = |keep: &dyn Fn(&&Column) -> bool| -> Option<(f64, f64)> {
        extent(t.columns.iter().filter(|c| keep(c)).flat_map(|c| [c.min, c.max]), false)
    };
    let Some(yr) = values(&calm).or_else(|| values(&|_| true)) else { return Ok(()) };
    let u = t.unit_s;
    let xa = LinAxis::exact((0.0, t.duration_s / u));
    let ya = LinAxis::new(yr);
    let clamp = |v: f64| v.clamp(ya.lo, ya.hi);
    let (x, y) = (xa.coord(), ya.coord());
    let y_fmt = |v: &f64| ya.label(*v);
    let mut chart = ChartBuilder::on(&plot)
        .margin_top(look.px(4.0))
        .margin_right(look.px(20.0))
        .margin_bottom(look.px(6.0))
        .margin_left(look.px(8.0))
        .x_label_area_size(look.px(46.0))
        .y_label_area_size(look.px(78.0))
        .build_cartesian_2d(x, y)
        .map_err(err)?;
    let x_fmt = |v: &f64| xa.label(*v);
    chart
        .configure_mesh()
        .x_desc(t.x_label.as_str())
        .y_desc("rate (deg/s)")
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .label_style(look.font(13.5))
        .axis_desc_style(look.font(15.0))
        .bold_line_style(BLACK.mix(0.12).stroke_width(1))
        .light_line_style(BLACK.mix(0.0).stroke_width(0))
        .axis_style(INK.stroke_width(1))
        .set_all_tick_mark_size(look.px(5.0))
        .draw()
        .map_err(err)?;
    close_frame(chart.plotting_area())?;
    let (pix, to) = pixels(&chart);
    let (pw, ph) = pix.dim_in_pixel();
    let (pw, ph) = (pw as i32, ph as i32);

    // The transients, at least a few pixels wide so that a short one is seen on a long record.
    for &[a, b] in &t.transients {
        let (x0, x1) = (to(a / u, ya.lo).0.clamp(0, pw - 1), to(b / u, ya.lo).0.clamp(0, pw - 1));
        let least = look.px(4.0);
        let (x0, x1) = if x1 - x0 < least { ((x0 + x1) / 2 - least / 2, (x0 + x1) / 2 + least / 2) } else { (x0, x1) };
        pix.draw(&Rectangle::new([(x0, 0), (x1, ph - 1)], TRANSIENT.mix(0.35).filled())).map_err(err)?;
        pix.draw(&Rectangle::new([(x0, 0), (x1, ph - 1)], TRANSIENT.stroke_width(1))).map_err(err)?;
    }
    // The envelope: one polygon per run of columns without a gap between them.
    let mut runs: Vec<Vec<&Column>> = Vec::new();
    for c in &t.columns {
        match runs.last_mut() {
            Some(run) if run.last().is_some_and(|p| p.t_s[1] >= c.t_s[0]) => run.push(c),
            _ => runs.push(vec![c]),
        }
    }
    for run in runs {
        let mut poly: Vec<(i32, i32)> = Vec::with_capacity(4 * run.len());
        for c in &run {
            poly.push(to(c.t_s[0] / u, clamp(c.max)));
            poly.push(to(c.t_s[1] / u, clamp(c.max)));
        }
        for c in run.iter().rev() {
            poly.push(to(c.t_s[1] / u, clamp(c.min)));
            poly.push(to(c.t_s[0] / u, clamp(c.min)));
        }
        pix.draw(&Polygon::new(poly.clone(), INK.mix(0.75).filled())).map_err(err)?;
        // A thin outline keeps a run narrower than a pixel (a short run, or a flat record) visible.
        poly.push(poly[0]);
        pix.draw(&PathElement::new(poly, INK.mix(0.75).stroke_width(1))).map_err(err)?;
    }
    // The split, with the parts named either side of it at the top.
    if let Some(s) = t.split_s {
        let (x, _) = to(s / u, ya.lo);
        let dash = INK.stroke_width(look.px(1.5).max(1) as u32);
        let mut y = 0;
        while y < ph {
            pix.draw(&PathElement::new(vec![(x, y), (x, (y + look.px(7.0)).min(ph - 1))], dash)).map_err(err)?;
            y += look.px(11.0);
        }
        let style = (FAMILY, 14.0 * look.s, FontStyle::Bold).into_font().color(&INK);
        let gap = look.px(6.0);
        for (text, at, left) in [("training", x - gap, true), ("holdout", x + gap, false)] {
            let (tw, th) = pix.estimate_text_size(text, &style).map_err(err)?;
            let (x0, h) = if left { (at - tw as i32, HPos::Right) } else { (at, HPos::Left) };
            let r = [(x0 - 2, look.px(4.0) - 1), (x0 + tw as i32 + 2, look.px(4.0) + th as i32 + 2)];
            pix.draw(&Rectangle::new(r, WHITE.mix(0.8).filled())).map_err(err)?;
            pix.draw(&Text::new(text, (at, look.px(4.0)), style.pos(Pos::new(h, VPos::Top)))).map_err(err)?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::gap::tests::diagnosis;
    use super::*;
    use crate::plot::test_util::{out_dir, png_size};

    /// A real diagnosis (a coupled gyro with a bump) as a PNG and an SVG: every view's panel, the legend, the
    /// located band's label, the transient's red; and at the ADEV plot's smaller size.
    #[test]
    fn a_diagnosis_is_drawn_as_png_and_svg() {
        let (report, input, _) = diagnosis();
        let fig = GapFigure::new(&report, &input);
        let tmp = tempfile::tempdir().unwrap();
        let dir = out_dir(&tmp);
        let opts = PlotOptions::gap_figure("Sim-to-real gap: a coupled gyro");
        let svg = dir.join("gap.svg");
        gap_plot(&fig, &opts, &svg).unwrap();
        let text = std::fs::read_to_string(&svg).unwrap();
        for s in [
            "Sim-to-real gap: a coupled gyro",
            "measured",
            "simulated, base model",
            "simulated, + temperature",
            "1: temperature",
            "Allan deviation",
            "tau (s)",
            "frequency (Hz)",
            "coherence with temperature",
            "excess kurtosis",
            "time (h)",
            "training",
            "holdout",
            "transient",
        ] {
            assert!(text.contains(s), "{s} missing from the SVG");
        }
        let png = dir.join("gap.png");
        gap_plot(&fig, &opts, &png).unwrap();
        assert_eq!(png_size(&std::fs::read(&png).unwrap()), (1600, 1200));
        // The transient's red, the located band's yellow, and text (dark pixels) are there.
        let img = image::open(&png).unwrap().to_rgb8();
        let count = |f: &dyn Fn([u8; 3]) -> bool| img.pixels().filter(|p| f(p.0)).count();
        let red = count(&|[r, g, b]| r > 180 && g < 120 && b < 120);
        assert!(red > 100, "{red} red pixels");
        let yellow = count(&|[r, g, b]| r > 220 && g > 210 && b < 190);
        assert!(yellow > 2000, "{yellow} yellow pixels");
        assert!(count(&|p| p.iter().all(|&v| v < 60)) > 2000);

        let small = PlotOptions { width: 1200, height: 800, ..opts };
        let png = dir.join("gap-small.png");
        gap_plot(&fig, &small, &png).unwrap();
        assert_eq!(png_size(&std::fs::read(&png).unwrap()), (1200, 800));
    }

    #[test]
    fn an_empty_figure_is_an_error_and_a_bad_path_is_named() {
        let tmp = tempfile::tempdir().unwrap();
        let mut fig = GapFigure {
            panels: Vec::new(),
            time: TimePanel {
                unit_s: 1.0,
                x_label: "time (s)".into(),
                columns: Vec::new(),
                split_s: None,
                transients: Vec::new(),
                duration_s: 0.0,
            },
            base_label: String::new(),
            chain_label: None,
            unexplained: None,
        };
        let path = tmp.path().join("f.png");
        assert!(matches!(gap_plot(&fig, &PlotOptions::gap_figure("x"), &path), Err(PlotError::Empty)));
        assert!(!path.exists());
        // A record alone is drawn; into a folder that does not exist, the error names the file.
        fig.time.columns.push(Column { t_s: [0.0, 1.0], min: -1.0, max: 1.0 });
        fig.time.duration_s = 1.0;
        for name in ["f.png", "f.svg"] {
            gap_plot(&fig, &PlotOptions::gap_figure("x"), &tmp.path().join(name)).unwrap();
            let bad = tmp.path().join("no/such/dir").join(name);
            let e = gap_plot(&fig, &PlotOptions::gap_figure("x"), &bad).unwrap_err();
            assert!(matches!(&e, PlotError::Write { path, .. } if *path == bad), "{e}");
        }
    }

    #[test]
    fn extent_keeps_what_the_axis_can_show() {
        let v = [f64::NAN, -1.0, 0.0, 2.0, 5.0];
        assert_eq!(extent(v.into_iter(), true), Some((2.0, 5.0)));
        assert_eq!(extent(v.into_iter(), false), Some((-1.0, 5.0)));
        assert_eq!(extent([f64::NAN].into_iter(), false), None);
    }
}

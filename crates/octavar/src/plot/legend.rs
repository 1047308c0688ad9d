//! Legends: the entries (a sample of what is drawn and its text) and two layouts, a box to the right of the axes
//! ([`Legend`], [`frame`]) and rows under a figure's title ([`Legend::draw_rows`]); and the marker shapes the
//! entries and the points share.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::{err, Area, Look, FAMILY, GREY};

/// Marker shapes, one per channel: circle, square, triangle, diamond, inverted triangle.
pub(super) fn marker_polygon(shape: usize, r: i32) -> Vec<(i32, i32)> {
    let f = |v: f64| (v * f64::from(r)).round() as i32;
    match shape % 5 {
        1 => vec![(f(-0.9), f(-0.9)), (f(0.9), f(-0.9)), (f(0.9), f(0.9)), (f(-0.9), f(0.9))],
        2 => vec![(0, f(-1.3)), (f(1.15), f(0.75)), (f(-1.15), f(0.75))],
        3 => vec![(0, f(-1.3)), (f(1.1), 0), (0, f(1.3)), (f(-1.1), 0)],
        _ => vec![(0, f(1.3)), (f(1.15), f(-0.75)), (f(-1.15), f(-0.75))],
    }
}

/// Draw one marker on a pixel-coordinate area: filled with `c`, or (`hollow`) white with an edge of `c`.
pub(super) fn draw_marker<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    at: (i32, i32),
    shape: usize,
    r: i32,
    c: RGBColor,
    hollow: bool,
) -> Result<(), String> {
    let fill = if hollow { WHITE.filled() } else { c.filled() };
    let edge = if hollow { c.stroke_width((r / 3).max(1) as u32) } else { WHITE.stroke_width(1) };
    if shape.is_multiple_of(5) {
        area.draw(&Circle::new(at, r, fill)).map_err(err)?;
        area.draw(&Circle::new(at, r, edge)).map_err(err)
    } else {
        let poly = marker_polygon(shape, r);
        let mut outline = poly.clone();
        outline.push(poly[0]);
        area.draw(&(EmptyElement::at(at) + Polygon::new(poly, fill))).map_err(err)?;
        area.draw(&(EmptyElement::at(at) + PathElement::new(outline, edge))).map_err(err)
    }
}

// ---------------------------------------------------------------------------------------------------------------
// Entries

/// What an entry shows before its text.
#[derive(Clone, Copy, Debug)]
pub(super) enum Sample {
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
    /// A marker alone, filled (`false`) or hollow (`true`).
    Marker(RGBColor, usize, bool),
}

/// One row of a legend.
#[derive(Clone, Debug)]
pub(super) struct Entry {
    sample: Sample,
    text: String,
    /// A detail row: smaller, grey, indented; dropped first when the legend does not fit.
    detail: bool,
}

impl Entry {
    pub fn main(sample: Sample, text: impl Into<String>) -> Self {
        Entry { sample, text: text.into(), detail: false }
    }

    pub fn detail(text: impl Into<String>) -> Self {
        Entry { sample: Sample::None, text: text.into(), detail: true }
    }

    pub fn spacer() -> Self {
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

/// Draw `sample` in the box from `sx` to `sx + sw`, centred on the row `mid` (pixels of `area`).
fn draw_sample<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    sample: Sample,
    (sx, sw, mid): (i32, i32, i32),
    look: &Look,
) -> Result<(), String> {
    let line = |c: RGBColor| PathElement::new(vec![(sx, mid), (sx + sw, mid)], c.stroke_width(look.px(2.2) as u32));
    match sample {
        Sample::None => {}
        Sample::Channel(c, shape) => {
            area.draw(&line(c)).map_err(err)?;
            draw_marker(area, (sx + sw / 2, mid), shape, look.px(5.0), c, false)?;
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
        Sample::Marker(c, shape, hollow) => draw_marker(area, (sx + sw / 2, mid), shape, look.px(5.0), c, hollow)?,
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------------------------
// Layouts

/// A legend: a box to the right of the axes ([`Legend::draw`]) or rows across a figure ([`Legend::draw_rows`]).
pub(super) struct Legend {
    pub entries: Vec<Entry>,
}

impl Legend {
    const PAD: f64 = 12.0;
    const SAMPLE: f64 = 38.0;
    const GAP: f64 = 10.0;
    /// Space between two entries of a row.
    const SPACING: f64 = 28.0;

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

    /// Draw as a box at (`x`, `y`) of `area` (pixels), reaching to its right edge.
    pub fn draw<DB: DrawingBackend>(
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
            draw_sample(area, e.sample, (sx, sw, mid), look)?;
            if !e.text.is_empty() {
                let style = e.font(look).pos(Pos::new(HPos::Left, VPos::Center));
                area.draw(&Text::new(e.text.clone(), (tx, mid), style)).map_err(err)?;
            }
            cy += h;
        }
        Ok(())
    }

    /// The rows of [`Legend::draw_rows`] in a width of `width` pixels: each row's entries with their widths.
    fn rows<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        width: i32,
        look: &Look,
    ) -> Result<Vec<Vec<(&Entry, i32)>>, String> {
        let mut rows: Vec<Vec<(&Entry, i32)>> = vec![Vec::new()];
        let mut used = 0;
        for e in self.entries.iter().filter(|e| !e.text.is_empty()) {
            let (tw, _) = area.estimate_text_size(&e.text, &e.font(look)).map_err(err)?;
            let w = tw as i32 + look.px(Self::SAMPLE + Self::GAP);
            let row = rows.last_mut().expect("one row at least");
            if !row.is_empty() && used + look.px(Self::SPACING) + w > width {
                rows.push(vec![(e, w)]);
                used = w;
            } else {
                used += if row.is_empty() { 0 } else { look.px(Self::SPACING) } + w;
                row.push((e, w));
            }
        }
        Ok(rows)
    }

    /// The height [`Legend::draw_rows`] takes in a width of `width` pixels.
    pub fn rows_height<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        width: i32,
        look: &Look,
    ) -> Result<i32, String> {
        Ok(self.rows(area, width, look)?.len() as i32 * look.px(27.0))
    }

    /// Draw as centred rows across `area` (pixels), wrapping where an entry would not fit; details and spacers
    /// are left out.
    pub fn draw_rows<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>, look: &Look) -> Result<(), String> {
        let (aw, _) = area.dim_in_pixel();
        let h = look.px(27.0);
        for (i, row) in self.rows(area, aw as i32, look)?.iter().enumerate() {
            let total: i32 = row.iter().map(|(_, w)| w).sum::<i32>() + look.px(Self::SPACING) * (row.len() as i32 - 1);
            let mut x = (aw as i32 - total).max(0) / 2;
            let mid = i as i32 * h + h / 2;
            for (e, w) in row {
                let sw = look.px(Self::SAMPLE);
                draw_sample(area, e.sample, (x, sw, mid), look)?;
                let style = e.font(look).pos(Pos::new(HPos::Left, VPos::Center));
                area.draw(&Text::new(e.text.clone(), (x + sw + look.px(Self::GAP), mid), style)).map_err(err)?;
                x += w + look.px(Self::SPACING);
            }
        }
        Ok(())
    }
}

/// Lay out axes and a legend to the right of them in `body`; returns the axes' area and the legend's.
/// A legend that would take more than a third of the width loses its detail rows.
pub(super) fn frame<DB: DrawingBackend>(
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

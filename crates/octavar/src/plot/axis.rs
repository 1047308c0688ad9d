//! The axes the figures share: log axes with limits on the 1-2-5 sequence and decade labels ([`LogAxis`]), linear
//! axes with 1-2-5 steps ([`LinAxis`]), tick and value labels, and the clipping of polylines to the axes' box
//! (plotters maps points outside an axis beyond the plotting area, and an SVG does not clip them).

use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::CoordTranslate;
use plotters::prelude::*;

use super::{err, positive, INK};

/// A log axis: limits on the 1-2-5 sequence, labelled ticks (decades) and light grid lines (2..9 of each decade).
#[derive(Clone, Debug, PartialEq)]
pub(super) struct LogAxis {
    pub lo: f64,
    pub hi: f64,
    pub major: Vec<f64>,
    pub minor: Vec<f64>,
}

const STEPS: [f64; 3] = [1.0, 2.0, 5.0];

impl LogAxis {
    pub fn new((min, max): (f64, f64)) -> Self {
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
pub(super) fn tick_label(v: f64) -> String {
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
pub(super) fn value_label(v: f64) -> String {
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

/// Close the frame of a chart's plotting area: its mesh draws the left and bottom axes only.
pub(super) fn close_frame<DB: DrawingBackend, CT: CoordTranslate>(area: &DrawingArea<DB, CT>) -> Result<(), String> {
    let root = area.strip_coord_spec();
    let (w, h) = root.dim_in_pixel();
    let (w, h) = (w as i32, h as i32);
    root.draw(&PathElement::new(vec![(0, 0), (w - 1, 0), (w - 1, h - 1)], INK.stroke_width(1))).map_err(err)
}

/// Split a log-log polyline into the runs that lie inside the box, cut exactly at its edges.
pub(super) fn clip(points: &[(f64, f64)], x: (f64, f64), y: (f64, f64)) -> Vec<Vec<(f64, f64)>> {
    clip_scaled(points, x, y, true)
}

/// Split a polyline on a log x axis and a log (`y_log`) or linear y axis into the runs that lie inside the box,
/// cut exactly at its edges (straight in the plot's own scales). Points that cannot go on an axis break the line.
pub(super) fn clip_scaled(points: &[(f64, f64)], x: (f64, f64), y: (f64, f64), y_log: bool) -> Vec<Vec<(f64, f64)>> {
    let fy = |v: f64| if y_log { v.log10() } else { v };
    let to = |(a, b): (f64, f64)| (a.log10(), fy(b));
    let from = |(a, b): (f64, f64)| (10f64.powf(a), if y_log { 10f64.powf(b) } else { b });
    let ok = |(a, b): (f64, f64)| positive(a) && if y_log { positive(b) } else { b.is_finite() };
    let (bx, by) = ((x.0.log10(), x.1.log10()), (fy(y.0), fy(y.1)));
    let mut runs = Vec::new();
    let mut cur: Vec<(f64, f64)> = Vec::new();
    fn close(cur: &mut Vec<(f64, f64)>, runs: &mut Vec<Vec<(f64, f64)>>) {
        if cur.len() >= 2 {
            runs.push(std::mem::take(cur));
        }
        cur.clear();
    }
    for w in points.windows(2) {
        if !(ok(w[0]) && ok(w[1])) {
            close(&mut cur, &mut runs);
            continue;
        }
        match clip_segment(to(w[0]), to(w[1]), bx, by) {
            Some((p, q)) => {
                if cur.last() != Some(&p) {
                    close(&mut cur, &mut runs);
                    cur.push(p);
                }
                cur.push(q);
            }
            None => close(&mut cur, &mut runs),
        }
    }
    close(&mut cur, &mut runs);
    runs.into_iter().map(|r| r.into_iter().map(from).collect()).collect()
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
pub(super) fn logspace(a: f64, b: f64, n: usize) -> impl Iterator<Item = f64> {
    let (la, lb) = (a.log10(), b.log10());
    (0..n).map(move |i| 10f64.powf(la + (lb - la) * i as f64 / (n - 1) as f64))
}

/// A linear axis: limits and labelled ticks on a 1-2-5 step, four to eight ticks.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct LinAxis {
    pub lo: f64,
    pub hi: f64,
    pub step: f64,
    pub major: Vec<f64>,
}

impl LinAxis {
    /// An axis over `min..max` with a little air on both sides (none beyond a limit that is exactly a tick, as
    /// 0 or 1 of a coherence), its limits on its ticks; a single value gets a span around it.
    pub fn new((min, max): (f64, f64)) -> Self {
        let (min, max) = span(min, max);
        let step = step_125((max - min) / 5.0);
        let air = 0.02 * (max - min);
        let on_tick = |v: f64| ((v / step).round() * step - v).abs() < 1e-9 * step;
        let lo = if on_tick(min) { min } else { ((min - air) / step).floor() * step };
        let hi = if on_tick(max) { max } else { ((max + air) / step).ceil() * step };
        LinAxis::with_limits(lo, hi, step)
    }

    /// An axis from exactly `min` to `max` (a record's start and end), ticked inside.
    pub fn exact((min, max): (f64, f64)) -> Self {
        let (min, max) = span(min, max);
        LinAxis::with_limits(min, max, step_125((max - min) / 6.0))
    }

    fn with_limits(lo: f64, hi: f64, step: f64) -> Self {
        let first = (lo / step - 1e-9).ceil() as i64;
        let last = (hi / step + 1e-9).floor() as i64;
        let major = (first..=last).map(|i| i as f64 * step).collect();
        LinAxis { lo, hi, step, major }
    }

    /// The axis as a plotters coordinate: its ticks are the bold grid lines, and it has no light ones.
    pub fn coord(&self) -> LinCoord {
        LinCoord { inner: RangedCoordf64::from(self.lo..self.hi), ticks: self.major.clone() }
    }

    /// A tick's label: as many decimals as the step needs, or a power of ten for very small or large values.
    pub fn label(&self, v: f64) -> String {
        let v = if v.abs() < 1e-9 * self.step { 0.0 } else { v };
        let big = self.lo.abs().max(self.hi.abs());
        if self.step < 1e-4 || big >= 1e6 {
            return if v == 0.0 { "0".to_string() } else { value_label(v) };
        }
        // A 1-2-5 step needs the decimals of its own decade.
        let decimals = (-self.step.log10().floor()).max(0.0) as usize;
        format!("{v:.decimals$}").replace('-', "−")
    }
}

/// `min..max`, or a span around a single value.
fn span(min: f64, max: f64) -> (f64, f64) {
    if max > min {
        (min, max)
    } else {
        let d = if min != 0.0 { min.abs() * 0.1 } else { 1.0 };
        (min - d, max + d)
    }
}

/// The smallest step on the 1-2-5 sequence of at least `raw`.
fn step_125(raw: f64) -> f64 {
    let d = 10f64.powf(raw.log10().floor());
    STEPS.iter().chain(&[10.0]).map(|s| s * d).find(|&s| s >= raw * (1.0 - 1e-9)).unwrap_or(10.0 * d)
}

/// A [`LinAxis`] for plotters: linear, with the axis's ticks (plotters' own f64 axis with key points set would not
/// take a label formatter).
#[derive(Clone)]
pub(super) struct LinCoord {
    inner: RangedCoordf64,
    ticks: Vec<f64>,
}

impl Ranged for LinCoord {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.inner.map(value, limit)
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            Vec::new()
        } else {
            self.ticks.clone()
        }
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.inner.range()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn linear_axes_step_on_1_2_5_and_keep_exact_limits() {
        let a = LinAxis::new((0.0, 1.0));
        assert_eq!((a.lo, a.hi, a.step), (0.0, 1.0, 0.2));
        assert_eq!(a.major.len(), 6);
        assert_eq!(a.label(0.4), "0.4");
        let b = LinAxis::new((-0.37, 2.9));
        assert_eq!(b.step, 1.0);
        assert!(b.lo <= -0.37 && b.hi >= 2.9 && b.lo > -1.5 && b.hi < 3.5, "{b:?}");
        assert_eq!(b.label(-1.0), "−1");
        let tiny = LinAxis::new((1e-6, 5e-6));
        assert_eq!(tiny.label(2e-6), "2.00×10⁻⁶");
        let t = LinAxis::exact((0.0, 50.8));
        assert_eq!((t.lo, t.hi, t.step), (0.0, 50.8, 10.0));
        assert_eq!(t.major, [0.0, 10.0, 20.0, 30.0, 40.0, 50.0]);
        let flat = LinAxis::new((3.0, 3.0));
        assert!(flat.lo < 3.0 && flat.hi > 3.0);
        // A line on a linear y axis is cut at the box, negative values and all.
        let runs = clip_scaled(&[(1.0, -2.0), (10.0, 0.0), (100.0, 2.0)], (1.0, 100.0), (-1.0, 1.0), false);
        assert_eq!(runs.len(), 1);
        let r = &runs[0];
        assert!((r[0].1 + 1.0).abs() < 1e-9 && (r.last().unwrap().1 - 1.0).abs() < 1e-9, "{r:?}");
        assert!((r[0].0 - 10f64.sqrt()).abs() < 1e-9, "{r:?}");
    }
}

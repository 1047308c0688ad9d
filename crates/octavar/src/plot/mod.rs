//! Plots: the log-log Allan deviation figure ([`adev_plot`]: `octavar analyze --plot`, `octavar demo`'s
//! `figure5.png`) and the sim-to-real gap figure ([`gap_plot`]: `octavar gap --plot`, the demo's
//! `gap_<channel>.png`), one module each; this module holds what they share: the output formats, the bundled
//! font, sizes and colours, and [`PlotOptions`] and [`PlotError`].
//!
//! The figures are drawn with plotters, in pure Rust: SVG through its SVG backend (text is left to the viewer's
//! sans-serif font), PNG through its bitmap backend with text rasterised by ab_glyph from the DejaVu Sans bytes
//! the `dejavu` crate embeds, so no fontconfig or freetype is needed. The output format follows the file's
//! extension (`.png` or `.svg`). Both are drawn into memory and written in one piece.
//!
//! - [`adev`]: several channels on one log-log plot, points with confidence intervals, the IEEE 952 fit and its
//!   terms, a legend to the right.
//! - [`gap`]: the gap figure's data, built from a gap diagnosis ([`GapFigure::new`]): one panel per view of the
//!   comparison (Allan deviation, PSD, distribution, temperature) with the record, the base model's ensemble band
//!   and the band of the model with every effect found, the located bands marked; and a time panel of the record
//!   with its masked transients. `gap_draw` lays it out and draws it ([`gap_plot`]).
//! - `axis` (log and linear axes, tick labels, clipping) and `legend` (legend entries and their layouts) are the
//!   shared drawing pieces.
//!
//! Values that cannot go on a log axis (zero, negative, NaN) are left out, not reported.
//!
//! # Examples
//!
//! ```no_run
//! use octavar::plot::{adev_plot, AdevSeries, PlotOptions};
//! # let points = Vec::new();
//! let series = vec![AdevSeries { name: "ENV-05H".into(), points, fit: None, quantity: Default::default() }];
//! let opts = PlotOptions { title: "Allan deviation, 72 h at 2 kS/s".into(), ..Default::default() };
//! adev_plot(&series, &opts, std::path::Path::new("figure5.png"))?;
//! # Ok::<(), octavar::plot::PlotError>(())
//! ```

use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// Draw with the backend the format asks for, into memory, then write the file in one piece: a file that cannot
/// be written (no such directory, a full disk) is reported with the system's own reason, and nothing is drawn
/// into a half-written file.
macro_rules! render {
    ($format:expr, $path:expr, $opts:expr, |$root:ident| $draw:expr) => {{
        $crate::plot::register_fonts();
        let size = ($opts.width, $opts.height);
        let path: &std::path::Path = $path;
        let fail = |message: String| $crate::plot::PlotError::Write { path: path.to_path_buf(), message };
        let bytes: Vec<u8> = match $format {
            $crate::plot::Format::Svg => {
                let mut text = String::new();
                {
                    let backend = plotters::prelude::SVGBackend::with_string(&mut text, size);
                    let area = plotters::prelude::IntoDrawingArea::into_drawing_area(backend);
                    let $root = &area;
                    $draw.map_err(fail)?;
                    area.present().map_err(|e| fail(e.to_string()))?;
                }
                text.into_bytes()
            }
            $crate::plot::Format::Png => {
                let mut rgb = vec![0u8; size.0 as usize * size.1 as usize * 3];
                {
                    let backend = plotters::prelude::BitMapBackend::with_buffer(&mut rgb, size);
                    let area = plotters::prelude::IntoDrawingArea::into_drawing_area(backend);
                    let $root = &area;
                    $draw.map_err(fail)?;
                    area.present().map_err(|e| fail(e.to_string()))?;
                }
                $crate::plot::png_bytes(&rgb, size).map_err(|e| fail(e.to_string()))?
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

pub mod adev;
mod axis;
pub mod gap;
mod gap_draw;
mod legend;

pub use adev::{adev_plot, AdevSeries};
pub use gap::GapFigure;
pub use gap_draw::gap_plot;

/// Options of both figures.
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
    /// No point that can be drawn: none with a positive tau and value (the gap figure: no view point and no
    /// sample of the record either).
    #[error("nothing to plot: no point with a positive tau and value")]
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

/// A value that can go on a log axis.
fn positive(v: f64) -> bool {
    v.is_finite() && v > 0.0
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

/// Sizes scaled with the picture (1 at the figure's reference size, 1200x800 for the ADEV plot; more slowly
/// below).
#[derive(Clone, Copy, Debug)]
struct Look {
    s: f64,
}

impl Look {
    fn new(opts: &PlotOptions) -> Self {
        Look::relative_to(opts, (1200, 800))
    }

    /// The sizes of a figure drawn at `opts`'s size whose sizes are given for `reference`.
    fn relative_to(opts: &PlotOptions, reference: (u32, u32)) -> Self {
        let s = (f64::from(opts.width) / f64::from(reference.0))
            .min(f64::from(opts.height) / f64::from(reference.1))
            .clamp(0.3, 8.0);
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

/// What the figures' tests share.
#[cfg(test)]
pub(crate) mod test_util {
    use std::path::PathBuf;

    /// The size a PNG file's header gives.
    pub fn png_size(bytes: &[u8]) -> (u32, u32) {
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "PNG signature");
        assert_eq!(&bytes[12..16], b"IHDR");
        let be = |b: &[u8]| u32::from_be_bytes([b[0], b[1], b[2], b[3]]);
        (be(&bytes[16..20]), be(&bytes[20..24]))
    }

    /// Where a test writes its pictures: `tmp`, or OCTAVAR_PLOT_DIR when it is set (to keep them for a look).
    pub fn out_dir(tmp: &tempfile::TempDir) -> PathBuf {
        match std::env::var_os("OCTAVAR_PLOT_DIR") {
            Some(d) => {
                std::fs::create_dir_all(&d).unwrap();
                PathBuf::from(d)
            }
            None => tmp.path().to_path_buf(),
        }
    }
}

//! `octavar accumulate`: run the exact octave accumulator (shared::acc) over integer ADC codes from text.
//!
//! Input is one integer per line, or one column of a CSV with a header (`column`). The result is, per octave,
//! the cluster size m, tau, the number of second differences n, the exact integer sum of their squares and the
//! Allan variance and deviation in codes. The same [`StridedAllan`] replays device samples in `verify`.

use std::io::BufRead;

use octavar_shared::acc::{OctaveAllan, Snapshot, LEVELS};
use serde::Serialize;

/// What went wrong, and where.
#[derive(Debug, thiserror::Error)]
pub enum AccumulateError {
    /// A value that is not an integer.
    #[error("{source_name}, line {line}{col}: {text:?} is not an integer code", col = column_note(column))]
    NotAnInteger { source_name: String, line: u64, column: Option<String>, text: String },
    /// An integer outside the code range.
    #[error("{source_name}, line {line}{col}: code {value} is outside {range}", col = column_note(column))]
    OutOfRange { source_name: String, line: u64, column: Option<String>, value: i64, range: &'static str },
    /// The named column is not in the header.
    #[error("{source_name}, line 1: no column {column:?} (the header has: {available})")]
    MissingColumn { source_name: String, column: String, available: String },
    /// A CSV row that could not be read (for example, too few fields).
    #[error("{source_name}, line {line}: {message}")]
    Csv { source_name: String, line: u64, message: String },
    /// No samples at all.
    #[error("{source_name}: no samples (the input is empty)")]
    Empty { source_name: String },
    /// A stride the accumulator does not have.
    #[error("stride {0} is not one of 1, 2, 4, 8, 16, 32, 64")]
    BadStride(usize),
    /// A sample rate that is not a positive finite number.
    #[error("sample rate {0} Hz must be a positive number")]
    BadRate(f64),
    /// Reading failed.
    #[error("reading {source_name}: {err}")]
    Io { source_name: String, err: std::io::Error },
}

fn column_note(column: &Option<String>) -> String {
    column.as_ref().map(|c| format!(", column {c:?}")).unwrap_or_default()
}

/// An octave accumulator whose stride is chosen at run time.
#[derive(Clone, Debug)]
pub enum StridedAllan {
    /// Non-overlapping.
    S1(Box<OctaveAllan<1>>),
    /// Stride 2.
    S2(Box<OctaveAllan<2>>),
    /// Stride 4.
    S4(Box<OctaveAllan<4>>),
    /// Stride 8 (the firmware's).
    S8(Box<OctaveAllan<8>>),
    /// Stride 16.
    S16(Box<OctaveAllan<16>>),
    /// Stride 32.
    S32(Box<OctaveAllan<32>>),
    /// Stride 64.
    S64(Box<OctaveAllan<64>>),
}

macro_rules! each {
    ($self:expr, $a:ident => $body:expr) => {
        match $self {
            StridedAllan::S1($a) => $body,
            StridedAllan::S2($a) => $body,
            StridedAllan::S4($a) => $body,
            StridedAllan::S8($a) => $body,
            StridedAllan::S16($a) => $body,
            StridedAllan::S32($a) => $body,
            StridedAllan::S64($a) => $body,
        }
    };
}

impl StridedAllan {
    /// An empty accumulator with stride `stride`, or `None` if there is no such stride.
    pub fn new(stride: usize) -> Option<Self> {
        Some(match stride {
            1 => Self::S1(Box::default()),
            2 => Self::S2(Box::default()),
            4 => Self::S4(Box::default()),
            8 => Self::S8(Box::default()),
            16 => Self::S16(Box::default()),
            32 => Self::S32(Box::default()),
            64 => Self::S64(Box::default()),
            _ => return None,
        })
    }

    /// Push one code.
    #[inline]
    pub fn push(&mut self, code: u16) {
        each!(self, a => a.push(code))
    }

    /// Push a block of codes.
    pub fn push_slice(&mut self, codes: &[u16]) {
        each!(self, a => a.push_slice(codes))
    }

    /// Samples pushed.
    pub fn count(&self) -> u64 {
        each!(self, a => a.count())
    }

    /// The counts and exact sums now.
    pub fn snapshot(&self) -> Snapshot {
        each!(self, a => a.snapshot())
    }
}

/// Options of [`accumulate`].
#[derive(Clone, Debug)]
pub struct AccumulateOptions {
    /// Read this column of a CSV with a header; `None`: one integer per line.
    pub column: Option<String>,
    /// Sample rate in Hz (tau = m / rate).
    pub rate_hz: f64,
    /// Stride S.
    pub stride: usize,
    /// Codes are signed 16-bit (-32768..=32767); they are offset by 32768, which leaves the Allan variance as is.
    pub signed: bool,
}

/// One octave of the result.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct OctaveRow {
    /// Cluster size in samples, 2^level.
    pub m: u64,
    /// Averaging time, s.
    pub tau_s: f64,
    /// Number of second differences.
    pub n: u64,
    /// The exact sum of squared second differences (codes^2), as a decimal string in JSON.
    #[serde(serialize_with = "as_decimal_string")]
    pub sum_sq: u128,
    /// Allan variance, codes^2.
    pub avar: f64,
    /// Allan deviation, codes.
    pub adev: f64,
}

fn as_decimal_string<S: serde::Serializer>(v: &u128, s: S) -> Result<S::Ok, S::Error> {
    s.collect_str(v)
}

/// The result of [`accumulate`]: every octave with at least one difference.
#[derive(Clone, Debug, Serialize)]
pub struct AccumulateReport {
    /// Samples read.
    pub samples: u64,
    /// Stride used.
    pub stride: usize,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// One row per octave with n > 0.
    pub octaves: Vec<OctaveRow>,
    /// The snapshot itself.
    #[serde(skip)]
    pub snapshot: Snapshot,
}

impl AccumulateReport {
    /// Rows from a snapshot at a sample rate.
    pub fn from_snapshot(snapshot: Snapshot, rate_hz: f64) -> Self {
        let octaves = (0..LEVELS)
            .filter_map(|k| {
                let l = snapshot.levels[k];
                let avar = snapshot.avar_codes2(k)?;
                let m = 1u64 << k;
                Some(OctaveRow { m, tau_s: m as f64 / rate_hz, n: l.n, sum_sq: l.sum_sq, avar, adev: avar.sqrt() })
            })
            .collect();
        AccumulateReport { samples: snapshot.samples, stride: usize::from(snapshot.stride), rate_hz, octaves, snapshot }
    }
}

/// Read codes from `reader` (named `source_name` in errors) and accumulate them.
///
/// # Errors
/// A value that is not an integer or out of range (with its line and column), a missing column, an empty input,
/// a bad stride or rate, or an I/O error.
pub fn accumulate<R: BufRead>(
    reader: R,
    source_name: &str,
    opts: &AccumulateOptions,
) -> Result<AccumulateReport, AccumulateError> {
    if !(opts.rate_hz.is_finite() && opts.rate_hz > 0.0) {
        return Err(AccumulateError::BadRate(opts.rate_hz));
    }
    let mut acc = StridedAllan::new(opts.stride).ok_or(AccumulateError::BadStride(opts.stride))?;
    let (offset, range) = if opts.signed { (32768i64, "-32768..=32767") } else { (0, "0..=65535") };
    let to_code = |text: &str, line: u64, column: &Option<String>| -> Result<u16, AccumulateError> {
        let t = text.trim();
        let value: i64 = t.parse().map_err(|_| AccumulateError::NotAnInteger {
            source_name: source_name.to_string(),
            line,
            column: column.clone(),
            text: t.to_string(),
        })?;
        u16::try_from(value + offset).map_err(|_| AccumulateError::OutOfRange {
            source_name: source_name.to_string(),
            line,
            column: column.clone(),
            value,
            range,
        })
    };
    let mut block = Vec::with_capacity(4096);
    let flush = |block: &mut Vec<u16>, acc: &mut StridedAllan| {
        acc.push_slice(block);
        block.clear();
    };
    match &opts.column {
        None => {
            let mut line_no = 0u64;
            for line in reader.lines() {
                line_no += 1;
                let line = line.map_err(|err| AccumulateError::Io { source_name: source_name.to_string(), err })?;
                if line.trim().is_empty() {
                    continue;
                }
                block.push(to_code(&line, line_no, &None)?);
                if block.len() == block.capacity() {
                    flush(&mut block, &mut acc);
                }
            }
        }
        Some(name) => {
            // The recordings' own row splitter (io::csv::rows): the delimiter read off the header, quotes
            // honoured, each cell's text parsed here as an exact integer.
            use crate::io::csv::rows::{clean_header, split, trim_line_end, Delimiter, Dialect};
            let io_err = |err| AccumulateError::Io { source_name: source_name.to_string(), err };
            let mut lines = reader.lines();
            let header = match lines.next() {
                Some(line) => line.map_err(io_err)?,
                None => return Err(AccumulateError::Empty { source_name: source_name.to_string() }),
            };
            let header = clean_header(trim_line_end(&header)).to_string();
            let delimiter = Dialect::detect_delimiter(&header).unwrap_or(Delimiter::Byte(b','));
            let mut header_cells = Vec::new();
            let bad_row = |line: u64, message: String| AccumulateError::Csv {
                source_name: source_name.to_string(),
                line,
                message,
            };
            split(&header, delimiter, &mut header_cells).map_err(|e| bad_row(1, e.to_string()))?;
            let names: Vec<String> = header_cells.iter().map(|c| c.to_string()).collect();
            let idx = names.iter().position(|h| h == name).ok_or_else(|| {
                if header.trim().is_empty() {
                    AccumulateError::Empty { source_name: source_name.to_string() }
                } else {
                    AccumulateError::MissingColumn {
                        source_name: source_name.to_string(),
                        column: name.clone(),
                        available: names.join(", "),
                    }
                }
            })?;
            let column = Some(name.clone());
            for (i, line) in lines.enumerate() {
                let line_no = i as u64 + 2;
                let line = line.map_err(io_err)?;
                let row = trim_line_end(&line);
                if row.trim().is_empty() {
                    continue;
                }
                let mut cells = Vec::with_capacity(names.len());
                split(row, delimiter, &mut cells).map_err(|e| bad_row(line_no, e.to_string()))?;
                if cells.len() != names.len() {
                    let why = format!("{} fields where the header has {}", cells.len(), names.len());
                    return Err(bad_row(line_no, why));
                }
                block.push(to_code(cells[idx], line_no, &column)?);
                if block.len() == block.capacity() {
                    flush(&mut block, &mut acc);
                }
            }
        }
    }
    flush(&mut block, &mut acc);
    if acc.count() == 0 {
        return Err(AccumulateError::Empty { source_name: source_name.to_string() });
    }
    Ok(AccumulateReport::from_snapshot(acc.snapshot(), opts.rate_hz))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn opts() -> AccumulateOptions {
        AccumulateOptions { column: None, rate_hz: 2000.0, stride: 1, signed: false }
    }

    #[test]
    fn plain_lines() {
        let text = "892\n809\n823\n798\n671\n644\n883\n903\n677\n";
        let r = accumulate(text.as_bytes(), "t", &opts()).unwrap();
        assert_eq!(r.samples, 9);
        assert_eq!(r.octaves[0].n, 8);
        assert_eq!(r.octaves[0].tau_s, 1.0 / 2000.0);
    }

    #[test]
    fn errors_name_the_line() {
        let e = accumulate("1\n2\nx3\n".as_bytes(), "f.txt", &opts()).unwrap_err();
        assert_eq!(e.to_string(), "f.txt, line 3: \"x3\" is not an integer code");
        let e = accumulate("1\n70000\n".as_bytes(), "f.txt", &opts()).unwrap_err();
        assert!(matches!(e, AccumulateError::OutOfRange { line: 2, value: 70000, .. }), "{e}");
        let e = accumulate("".as_bytes(), "f.txt", &opts()).unwrap_err();
        assert!(matches!(e, AccumulateError::Empty { .. }));
    }

    #[test]
    fn csv_column_and_errors() {
        let o = AccumulateOptions { column: Some("b".into()), ..opts() };
        let r = accumulate("a,b\n1,10\n2,12\n3,10\n".as_bytes(), "c.csv", &o).unwrap();
        assert_eq!(r.octaves[0].sum_sq, 8);
        let e = accumulate("a,b\n1,10\n2,zz\n".as_bytes(), "c.csv", &o).unwrap_err();
        assert_eq!(e.to_string(), "c.csv, line 3, column \"b\": \"zz\" is not an integer code");
        let o2 = AccumulateOptions { column: Some("q".into()), ..opts() };
        let e = accumulate("a,b\n1,10\n".as_bytes(), "c.csv", &o2).unwrap_err();
        assert!(e.to_string().contains("no column \"q\""), "{e}");
        let e = accumulate("a,b\n1,10\n2\n".as_bytes(), "c.csv", &o).unwrap_err();
        assert_eq!(e.to_string(), "c.csv, line 3: 1 fields where the header has 2");
        // The recordings' dialects: another delimiter, quoted names, CRLF line ends.
        let r = accumulate("\"a\";\"b\"\r\n1;10\r\n2;12\r\n3;10\r\n".as_bytes(), "c.csv", &o).unwrap();
        assert_eq!(r.octaves[0].sum_sq, 8);
    }

    #[test]
    fn signed_codes_give_the_same_variance() {
        let o = AccumulateOptions { signed: true, ..opts() };
        let a = accumulate("-5\n3\n-1\n7\n".as_bytes(), "s", &o).unwrap();
        let b = accumulate("32763\n32771\n32767\n32775\n".as_bytes(), "u", &opts()).unwrap();
        assert_eq!(a.octaves, b.octaves);
    }
}

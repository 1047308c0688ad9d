//! Reading rate recordings from CSV (or CSV.gz, or stdin): any column, any unit, a time column or a fixed rate.
//!
//! The reader streams: rows are handed to a callback one at a time, so a 72-hour file never has to fit in memory
//! ([`read_csv_stream`]); [`read_csv`] collects them for in-memory analysis. Empty cells, `NaN` and samples
//! missing from the time column (a jump of more than 1.5 sample periods) become NaN gaps, never interpolated or
//! averaged in; the statistics skip every difference that touches one. A cell that is not a number, a missing
//! column, an unknown unit or an empty file is an error that names the file, the line and the column.

pub mod rows;

use std::io::BufRead;

use serde::Serialize;

use crate::io::csv::rows::{clean_header, parse_number, parse_plain, split, trim_line_end, Delimiter, Dialect};

/// Units a rate column may be in; everything is converted to deg/s.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum RateUnit {
    /// deg/s.
    DegPerS,
    /// rad/s.
    RadPerS,
    /// mrad/s.
    MradPerS,
    /// deg/h.
    DegPerH,
}

impl RateUnit {
    /// Every unit with the names it is known by.
    pub const NAMES: [(&'static str, RateUnit); 8] = [
        ("deg/s", RateUnit::DegPerS),
        ("dps", RateUnit::DegPerS),
        ("rad/s", RateUnit::RadPerS),
        ("rads", RateUnit::RadPerS),
        ("mrad/s", RateUnit::MradPerS),
        ("mrads", RateUnit::MradPerS),
        ("deg/h", RateUnit::DegPerH),
        ("dph", RateUnit::DegPerH),
    ];

    /// Parse a unit name.
    ///
    /// # Errors
    /// [`RecordingError::UnknownUnit`] listing the known names.
    pub fn parse(name: &str) -> Result<RateUnit, RecordingError> {
        let n = name.trim().to_ascii_lowercase();
        Self::NAMES.iter().find(|(k, _)| *k == n).map(|(_, u)| *u).ok_or_else(|| RecordingError::UnknownUnit {
            unit: name.to_string(),
            known: "deg/s (dps), rad/s, mrad/s, deg/h (dph)".to_string(),
        })
    }

    /// Multiply a value in this unit by this to get deg/s.
    pub fn to_dps(self) -> f64 {
        match self {
            RateUnit::DegPerS => 1.0,
            RateUnit::RadPerS => 180.0 / std::f64::consts::PI,
            RateUnit::MradPerS => 0.18 / std::f64::consts::PI,
            RateUnit::DegPerH => 1.0 / 3600.0,
        }
    }
}

/// What went wrong, and where.
#[derive(Debug, thiserror::Error)]
pub enum RecordingError {
    /// A requested column is not in the header.
    #[error("{path}, line {line}: no column {column:?} (the header has: {available})")]
    MissingColumn { path: String, line: u64, column: String, available: String },
    /// A cell that should be a number is not.
    #[error("{path}, line {line}, column {column:?}: {text:?} is not a number")]
    NotANumber { path: String, line: u64, column: String, text: String },
    /// A cell that reads as an infinity (`inf`, `1e999`): no sensor reports one, and it would poison every sum.
    #[error(
        "{path}, line {line}, column {column:?}: {text:?} is not a finite number (leave the cell empty or write NaN \
         for a missing sample)"
    )]
    NotFinite { path: String, line: u64, column: String, text: String },
    /// A cell with a comma that is not a number, in a file read with a decimal point.
    #[error(
        "{path}, line {line}, column {column:?}: {text:?} is not a number (a decimal comma? give --decimal-comma)"
    )]
    NotANumberDecimalComma { path: String, line: u64, column: String, text: String },
    /// A row with more or fewer cells than the header.
    #[error("{path}, line {line}: {found} fields where the header has {expected}{hint}")]
    FieldCount { path: String, line: u64, found: usize, expected: usize, hint: String },
    /// A column name that appears twice in the header.
    #[error("{path}, line {line}: column {column:?} appears twice in the header (fields {first} and {second})")]
    DuplicateColumn { path: String, line: u64, column: String, first: usize, second: usize },
    /// A row that cannot be read.
    #[error("{path}, line {line}: {message}")]
    BadRow { path: String, line: u64, message: String },
    /// Nothing to read.
    #[error("{path}: no samples (the file is empty, or every row was filtered out)")]
    Empty { path: String },
    /// A unit octavar does not know.
    #[error("unknown unit {unit:?}: octavar knows {known}")]
    UnknownUnit { unit: String, known: String },
    /// No sample rate: neither --rate nor a time column.
    #[error("{path}: no sample rate: give --rate HZ or --time-column NAME")]
    NoRate { path: String },
    /// A time column that does not increase.
    #[error("{path}, line {line}, column {column:?}: time {t} does not increase (previous {previous})")]
    TimeNotIncreasing { path: String, line: u64, column: String, t: f64, previous: f64 },
    /// A `--where` filter that is not `COLUMN=VALUE`.
    #[error("filter {0:?} is not COLUMN=VALUE")]
    BadFilter(String),
    /// A sample rate that is not a positive number.
    #[error("sample rate {0} Hz must be a positive number")]
    BadRate(f64),
    /// Reading failed.
    #[error("reading {path}: {err}")]
    Io { path: String, err: std::io::Error },
}

/// A row filter `COLUMN=VALUE`: keep rows whose cell equals VALUE (as text, or as a number).
#[derive(Clone, Debug, PartialEq)]
pub struct RowFilter {
    /// Column name.
    pub column: String,
    /// Value to match.
    pub value: String,
}

impl RecordingError {
    /// The line the error names, to move a parallel task's line numbers (counted from its first line) to the
    /// file's.
    fn line_mut(&mut self) -> Option<&mut u64> {
        use RecordingError as E;
        match self {
            E::MissingColumn { line, .. }
            | E::NotANumber { line, .. }
            | E::NotANumberDecimalComma { line, .. }
            | E::NotFinite { line, .. }
            | E::FieldCount { line, .. }
            | E::DuplicateColumn { line, .. }
            | E::BadRow { line, .. }
            | E::TimeNotIncreasing { line, .. } => Some(line),
            _ => None,
        }
    }
}

impl RowFilter {
    /// Parse `COLUMN=VALUE`.
    ///
    /// # Errors
    /// [`RecordingError::BadFilter`].
    pub fn parse(text: &str) -> Result<RowFilter, RecordingError> {
        match text.split_once('=') {
            Some((c, v)) if !c.trim().is_empty() => {
                Ok(RowFilter { column: c.trim().to_string(), value: v.trim().to_string() })
            }
            _ => Err(RecordingError::BadFilter(text.to_string())),
        }
    }

    fn matches(&self, cell: &str) -> bool {
        let cell = cell.trim();
        if cell == self.value {
            return true;
        }
        matches!((cell.parse::<f64>(), self.value.parse::<f64>()), (Ok(a), Ok(b)) if a == b)
    }
}

/// How to read a CSV recording.
#[derive(Clone, Debug)]
pub struct CsvOptions {
    /// Rate columns to read (at least one).
    pub columns: Vec<String>,
    /// A temperature column to carry along (degC), if any.
    pub temp_column: Option<String>,
    /// Fixed sample rate, Hz (or use `time_column`).
    pub rate_hz: Option<f64>,
    /// A time column in seconds; the rate is its median step, and jumps become gaps.
    pub time_column: Option<String>,
    /// Unit of the rate columns.
    pub unit: RateUnit,
    /// Lines to skip before the header.
    pub skip_rows: usize,
    /// Keep only rows matching every filter.
    pub filters: Vec<RowFilter>,
    /// The delimiter, or `None` to detect it from the header.
    pub delimiter: Option<Delimiter>,
    /// Numbers with a decimal comma (`Some(true)`), with a point (`Some(false)`), or `None` to detect it from the
    /// first rows (only where the delimiter is not a comma).
    pub decimal_comma: Option<bool>,
    /// Accept rows with more or fewer fields than the header (missing cells of a wanted column still fail).
    pub flexible: bool,
}

impl Default for CsvOptions {
    fn default() -> Self {
        CsvOptions {
            columns: Vec::new(),
            temp_column: None,
            rate_hz: None,
            time_column: None,
            unit: RateUnit::DegPerS,
            skip_rows: 0,
            filters: Vec::new(),
            delimiter: None,
            decimal_comma: None,
            flexible: false,
        }
    }
}

/// What a streamed read found.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct StreamInfo {
    /// Column names read, in order.
    pub columns: Vec<String>,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Samples delivered (rows kept plus gap samples inserted), per channel.
    pub samples: u64,
    /// Samples that are NaN (empty cells, NaN text, time gaps), summed over channels.
    pub gaps: u64,
    /// Rows dropped by the filters.
    pub filtered_out: u64,
}

/// A recording in memory: one series per column, in deg/s, NaN for gaps.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Recording {
    /// Where it came from.
    pub source: String,
    /// Column names.
    pub names: Vec<String>,
    /// One series per column, deg/s.
    pub channels: Vec<Vec<f64>>,
    /// The temperature column, degC, if asked for.
    pub temp_c: Option<Vec<f64>>,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Counters of the read.
    pub info: StreamInfo,
}

/// Read a whole CSV recording into memory.
///
/// # Errors
/// See [`read_csv_stream`].
pub fn read_csv<R: BufRead + Send>(reader: R, path: &str, opts: &CsvOptions) -> Result<Recording, RecordingError> {
    read_csv_sized(reader, path, opts, None)
}

/// [`read_csv`] of an input of `input_bytes` bytes, when known (an uncompressed file): the channels are given
/// room for all their samples at once.
///
/// # Errors
/// See [`read_csv_stream`].
pub fn read_csv_sized<R: BufRead + Send>(
    reader: R,
    path: &str,
    opts: &CsvOptions,
    input_bytes: Option<u64>,
) -> Result<Recording, RecordingError> {
    let n = opts.columns.len();
    let mut channels: Vec<Vec<f64>> = vec![Vec::new(); n];
    let mut temps: Vec<f64> = Vec::new();
    let info = read_csv_rows(reader, path, opts, input_bytes, |rows, temp, expected_rows| {
        if channels[0].capacity() == 0 && expected_rows > 0 {
            for c in &mut channels {
                c.reserve(expected_rows);
            }
            if temp.is_some() {
                temps.reserve(expected_rows);
            }
        }
        if n == 1 {
            channels[0].extend_from_slice(rows);
        } else {
            for row in rows.chunks_exact(n) {
                for (c, v) in channels.iter_mut().zip(row) {
                    c.push(*v);
                }
            }
        }
        if let Some(t) = temp {
            temps.extend_from_slice(t);
        }
    })?;
    Ok(Recording {
        source: path.to_string(),
        names: info.columns.clone(),
        channels,
        temp_c: opts.temp_column.as_ref().map(|_| temps),
        rate_hz: info.rate_hz,
        info,
    })
}

/// Bytes of input parsed at a time (then as many whole lines as complete the last one): the memory a streamed
/// read holds, whatever the file's size.
const BLOCK_BYTES: usize = 8 << 20;
/// Data lines looked at to detect a decimal comma.
const DETECT_ROWS: usize = 20;

/// A line of a block that gave no row.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Skip {
    /// An empty line.
    Blank,
    /// Dropped by a `--where` filter.
    Filtered,
}

/// The parsed lines of one task: flat arrays, one entry per row that gave values (`ncols` values at a time),
/// and the lines that gave none.
#[derive(Default)]
struct Parsed {
    values: Vec<f64>,
    temps: Vec<f64>,
    times: Vec<f64>,
    /// The lines without a row, as (line within the task, counted from 1; why), in order.
    skips: Vec<(u64, Skip)>,
    /// Lines looked at (up to and including the faulty one).
    lines: u64,
    /// The first fault, which ends the read; the arrays stop just before its line.
    error: Option<RecordingError>,
    /// NaN values (gaps) among `values`.
    gaps: u64,
}

impl Parsed {
    /// Empty, keeping the arrays' room for the next block.
    fn clear(&mut self) {
        self.values.clear();
        self.temps.clear();
        self.times.clear();
        self.skips.clear();
        (self.lines, self.error, self.gaps) = (0, None, 0);
    }
}

/// Everything the line parser needs, shared by the tasks.
struct LineParser<'a> {
    path: &'a str,
    dialect: Dialect,
    header_fields: usize,
    flexible: bool,
    cols: Vec<usize>,
    names: &'a [String],
    temp: Option<(usize, &'a str)>,
    time: Option<(usize, &'a str)>,
    filters: Vec<(usize, &'a RowFilter)>,
    scale: f64,
    /// Per header field, whether a row reads it: the plan of [`LineParser::plain_row`], `None` where a filter
    /// asks for the careful path on every line.
    roles: Option<Vec<bool>>,
}

impl LineParser<'_> {
    /// The fields a row reads, for [`LineParser::plain_row`]: `None` with a filter (which compares text).
    fn plain_roles(&self) -> Option<Vec<bool>> {
        if !self.filters.is_empty() || self.header_fields == 0 {
            return None;
        }
        let mut roles = vec![false; self.header_fields];
        let read = self.cols.iter().chain(self.temp.iter().map(|(i, _)| i)).chain(self.time.iter().map(|(i, _)| i));
        for &i in read {
            roles[i] = true;
        }
        Some(roles)
    }

    fn cell(&self, text: &str, line: u64, column: &str) -> Result<f64, RecordingError> {
        if text.is_empty() || text.eq_ignore_ascii_case("nan") || text.eq_ignore_ascii_case("na") {
            return Ok(f64::NAN);
        }
        match parse_number(text, self.dialect.decimal_comma) {
            Some(v) if v.is_finite() => Ok(v),
            parsed => {
                let (path, column, text) = (self.path.to_string(), column.to_string(), text.to_string());
                Err(if parsed.is_some() {
                    RecordingError::NotFinite { path, line, column, text }
                } else if !self.dialect.decimal_comma && text.contains(',') {
                    RecordingError::NotANumberDecimalComma { path, line, column, text }
                } else {
                    RecordingError::NotANumber { path, line, column, text }
                })
            }
        }
    }

    /// Parse the whole lines of `text` into `out` (emptied by the caller), numbering them from 1. With a
    /// delimiter byte, a plain line is read in one pass over its bytes ([`LineParser::plain_row`]) and any other
    /// is split with the quote rules; whitespace-delimited text goes line by line.
    fn parse(&self, text: &str, out: &mut Parsed) {
        out.values.reserve(text.len() / 16 * self.cols.len());
        let mut cells = Vec::with_capacity(self.header_fields + 1);
        let result = match self.dialect.delimiter {
            Delimiter::Byte(d) => self.parse_delimited(text, d, &mut cells, out),
            Delimiter::Whitespace => self.parse_lines(text, &mut cells, out),
        };
        if let Err(e) = result {
            out.error = Some(e);
        }
        out.gaps = out.values.iter().filter(|v| v.is_nan()).count() as u64;
    }

    /// [`LineParser::parse`] for a delimiter byte: each line through [`LineParser::plain_row`], or where that
    /// declines, split with the quote rules.
    fn parse_delimited<'t>(
        &self,
        text: &'t str,
        d: u8,
        cells: &mut Vec<&'t str>,
        out: &mut Parsed,
    ) -> Result<(), RecordingError> {
        let bytes = text.as_bytes();
        let mut fields = vec![0.0; self.header_fields];
        let mut start = 0;
        while start < bytes.len() {
            out.lines += 1;
            if let Some(next) = self.plain_row(bytes, start, d, &mut fields, out) {
                start = next;
                continue;
            }
            let end = memchr::memchr(b'\n', &bytes[start..]).map_or(bytes.len(), |i| start + i);
            let line = out.lines;
            if let Some(skip) = self.parse_line(&text[start..end], line, cells, out)? {
                out.skips.push((line, skip));
            }
            start = end + 1;
        }
        Ok(())
    }

    /// The row of the line at `start` when it is plain: the header's number of fields, each wanted cell a plain
    /// number ([`parse_plain`]) with at most spaces around it, no quotes, no filter to apply. Returns where the next
    /// line starts, or `None` (nothing pushed) for the careful path to read the line.
    fn plain_row(&self, bytes: &[u8], start: usize, d: u8, fields: &mut [f64], out: &mut Parsed) -> Option<usize> {
        let roles = self.roles.as_deref()?;
        let point = if self.dialect.decimal_comma { b',' } else { b'.' };
        let skip_spaces = |mut p: usize| {
            while bytes.get(p) == Some(&b' ') {
                p += 1;
            }
            p
        };
        let mut p = start;
        for (f, &wanted) in roles.iter().enumerate() {
            if wanted {
                p = skip_spaces(p);
                let (v, n) = parse_plain(&bytes[p..], point)?;
                fields[f] = v;
                p = skip_spaces(p + n);
            } else {
                while let Some(&b) = bytes.get(p) {
                    if b == d || b == b'\n' {
                        break;
                    }
                    if b == b'"' {
                        return None;
                    }
                    p += 1;
                }
            }
            if f + 1 < roles.len() {
                if bytes.get(p) != Some(&d) {
                    return None;
                }
                p += 1;
            }
        }
        let next = match bytes.get(p) {
            None => p,
            Some(b'\n') => p + 1,
            Some(b'\r') if bytes.get(p + 1) == Some(&b'\n') => p + 2,
            _ => return None,
        };
        for &c in &self.cols {
            out.values.push(fields[c] * self.scale);
        }
        if let Some((i, _)) = self.temp {
            out.temps.push(fields[i]);
        }
        if let Some((i, _)) = self.time {
            out.times.push(fields[i]);
        }
        Some(next)
    }

    /// [`LineParser::parse`] line by line.
    fn parse_lines<'t>(&self, text: &'t str, cells: &mut Vec<&'t str>, out: &mut Parsed) -> Result<(), RecordingError> {
        let mut start = 0;
        let ends = memchr::memchr_iter(b'\n', text.as_bytes()).chain((!text.ends_with('\n')).then_some(text.len()));
        for end in ends {
            if end == start && end == text.len() {
                break;
            }
            out.lines += 1;
            let line = out.lines;
            if let Some(skip) = self.parse_line(&text[start..end], line, cells, out)? {
                out.skips.push((line, skip));
            }
            start = end + 1;
        }
        Ok(())
    }

    fn parse_line<'t>(
        &self,
        text: &'t str,
        line: u64,
        cells: &mut Vec<&'t str>,
        out: &mut Parsed,
    ) -> Result<Option<Skip>, RecordingError> {
        let text = trim_line_end(text);
        if text.trim_ascii().is_empty() {
            return Ok(Some(Skip::Blank));
        }
        split(text, self.dialect.delimiter, cells).map_err(|e| RecordingError::BadRow {
            path: self.path.to_string(),
            line,
            message: e.to_string(),
        })?;
        self.row(cells, line, out)
    }

    /// The values of a line split into `cells` (not blank): field count, filters, wanted cells.
    fn row(&self, cells: &[&str], line: u64, out: &mut Parsed) -> Result<Option<Skip>, RecordingError> {
        if cells.len() != self.header_fields && !self.flexible {
            let hint = if !self.dialect.decimal_comma
                && cells.len() > self.header_fields
                && self.dialect.delimiter == Delimiter::Byte(b',')
            {
                "; a decimal comma? give --decimal-comma (and --delimiter for a file with several columns)"
            } else {
                "; give --flexible to read such rows anyway"
            };
            return Err(RecordingError::FieldCount {
                path: self.path.to_string(),
                line,
                found: cells.len(),
                expected: self.header_fields,
                hint: hint.to_string(),
            });
        }
        if self.filters.iter().any(|(i, f)| cells.get(*i).is_none_or(|cell| !f.matches(cell))) {
            return Ok(Some(Skip::Filtered));
        }
        let missing = |name: &str, c: usize| RecordingError::BadRow {
            path: self.path.to_string(),
            line,
            message: format!("{} fields, column {name:?} is field {}", cells.len(), c + 1),
        };
        for (&c, name) in self.cols.iter().zip(self.names) {
            let cell = cells.get(c).ok_or_else(|| missing(name, c))?;
            out.values.push(self.cell(cell, line, name)? * self.scale);
        }
        if let Some((i, name)) = self.temp {
            out.temps.push(self.cell(cells.get(i).copied().unwrap_or(""), line, name)?);
        }
        if let Some((i, name)) = self.time {
            let cell = cells.get(i).copied().unwrap_or("");
            let t = self.cell(cell, line, name)?;
            if t.is_nan() {
                let (path, column, text) = (self.path.to_string(), name.to_string(), cell.to_string());
                return Err(RecordingError::NotANumber { path, line, column, text });
            }
            out.times.push(t);
        }
        Ok(None)
    }
}

/// A block of whole lines of the input: about [`BLOCK_BYTES`] and the rest of its last line, read straight into a
/// buffer that is kept (never shrunk or zeroed again) from block to block.
#[derive(Default)]
struct Block {
    buf: Vec<u8>,
    len: usize,
}

impl Block {
    fn bytes(&self) -> &[u8] {
        &self.buf[..self.len]
    }

    /// Read the next block; empty at the end of the input.
    fn read<R: BufRead>(&mut self, reader: &mut R) -> std::io::Result<()> {
        if self.buf.len() < BLOCK_BYTES {
            self.buf.resize(BLOCK_BYTES, 0);
        }
        self.len = 0;
        while self.len < BLOCK_BYTES {
            match reader.read(&mut self.buf[self.len..BLOCK_BYTES]) {
                Ok(0) => return Ok(()),
                Ok(n) => self.len += n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
        if self.buf[self.len - 1] != b'\n' {
            self.buf.truncate(self.len);
            reader.read_until(b'\n', &mut self.buf)?;
            self.len = self.buf.len();
        }
        Ok(())
    }
}

/// Stream a CSV recording: `sink` gets each sample's values (deg/s, one per column, NaN for a gap) and the
/// temperature when a temperature column was named. The rate is known before the first call.
///
/// The dialect is [`CsvOptions::delimiter`] and [`CsvOptions::decimal_comma`], or detected from the header and
/// the first rows (see [`crate::io::csv::rows::Dialect`]). Lines are read in blocks of about 8 MB and parsed on
/// every core while the next block is read; the samples are then handed on in order, so memory
/// stays bounded (two blocks).
///
/// # Errors
/// A missing or duplicated column, a cell that is not a number, a row whose field count differs from the
/// header's (unless [`CsvOptions::flexible`]), a time column that does not increase, no rate, an empty result,
/// text that is not UTF-8, or an I/O error; each names the file, line and column.
pub fn read_csv_stream<R: BufRead + Send>(
    reader: R,
    path: &str,
    opts: &CsvOptions,
    mut sink: impl FnMut(&[f64], Option<f64>),
) -> Result<StreamInfo, RecordingError> {
    let n = opts.columns.len();
    read_csv_rows(reader, path, opts, None, |rows, temps, _| {
        for (k, row) in rows.chunks_exact(n).enumerate() {
            sink(row, temps.map(|t| t[k]));
        }
    })
}

/// [`read_csv_stream`] with the rows handed on in batches: `sink` gets the values of consecutive rows (`ncols`
/// per row, row after row), their temperatures when a temperature column was named, and the rows expected in
/// all (from the first block and `input_bytes`, the input's size when known; 0 when not).
fn read_csv_rows<R: BufRead + Send>(
    mut reader: R,
    path: &str,
    opts: &CsvOptions,
    input_bytes: Option<u64>,
    mut sink: impl FnMut(&[f64], Option<&[f64]>, usize),
) -> Result<StreamInfo, RecordingError> {
    let io = |err| RecordingError::Io { path: path.to_string(), err };
    let not_utf8 =
        |line: u64| RecordingError::BadRow { path: path.to_string(), line, message: "not valid UTF-8".into() };
    let mut line_no: u64 = 0;
    let mut raw = Vec::new();
    for _ in 0..opts.skip_rows {
        raw.clear();
        if reader.read_until(b'\n', &mut raw).map_err(io)? == 0 {
            return Err(RecordingError::Empty { path: path.to_string() });
        }
        line_no += 1;
    }
    if let Some(r) = opts.rate_hz {
        if !(r.is_finite() && r > 0.0) {
            return Err(RecordingError::BadRate(r));
        }
    }
    raw.clear();
    reader.read_until(b'\n', &mut raw).map_err(io)?;
    line_no += 1;
    let header_line = line_no;
    let header_text = std::str::from_utf8(&raw).map_err(|_| not_utf8(header_line))?;
    let header_text = clean_header(header_text);
    if header_text.trim().is_empty() {
        return Err(RecordingError::Empty { path: path.to_string() });
    }
    // `None`: a one-field header, which says nothing about the delimiter (read as a comma).
    let detected = Dialect::detect_delimiter(header_text);
    let one_field = opts.delimiter.is_none() && detected.is_none();
    let mut delimiter = opts.delimiter.or(detected).unwrap_or(Delimiter::Byte(b','));
    let (mut block, mut next) = (Block::default(), Block::default());
    block.read(&mut reader).map_err(io)?;
    let decimal_comma = match opts.decimal_comma {
        Some(dc) => dc,
        // No decimal comma is guessed where nothing is known of the delimiter.
        None if one_field => false,
        None => {
            let text = String::from_utf8_lossy(&block.bytes()[..block.len.min(1 << 16)]);
            let rows: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).take(DETECT_ROWS).collect();
            Dialect::detect_decimal_comma(delimiter, &rows)
        }
    };
    if decimal_comma && delimiter == Delimiter::Byte(b',') {
        if one_field {
            // One column: nothing separates cells, so no delimiter can clash with the comma.
            delimiter = Delimiter::Byte(b';');
        } else {
            return Err(RecordingError::BadRow {
                path: path.to_string(),
                line: header_line,
                message: "a decimal comma needs a delimiter other than the comma (give --delimiter)".to_string(),
            });
        }
    }
    let dialect = Dialect { delimiter, decimal_comma };
    let mut header_cells = Vec::new();
    split(header_text, delimiter, &mut header_cells).map_err(|e| RecordingError::BadRow {
        path: path.to_string(),
        line: header_line,
        message: e.to_string(),
    })?;
    let headers: Vec<String> = header_cells.iter().map(|h| h.to_string()).collect();
    for (i, h) in headers.iter().enumerate() {
        if let Some(j) = headers[..i].iter().position(|g| g == h) {
            return Err(RecordingError::DuplicateColumn {
                path: path.to_string(),
                line: header_line,
                column: h.clone(),
                first: j + 1,
                second: i + 1,
            });
        }
    }
    let find = |name: &str| {
        headers.iter().position(|h| h == name).ok_or_else(|| RecordingError::MissingColumn {
            path: path.to_string(),
            line: header_line,
            column: name.to_string(),
            available: format!("{}; split at {delimiter}", headers.join(", ")),
        })
    };
    let cols: Vec<usize> = opts.columns.iter().map(|c| find(c)).collect::<Result<_, _>>()?;
    let temp_col = opts.temp_column.as_deref().map(find).transpose()?;
    let time_col = opts.time_column.as_deref().map(find).transpose()?;
    let filters: Vec<(usize, &RowFilter)> =
        opts.filters.iter().map(|f| find(&f.column).map(|i| (i, f))).collect::<Result<_, _>>()?;
    if opts.rate_hz.is_none() && time_col.is_none() {
        return Err(RecordingError::NoRate { path: path.to_string() });
    }
    let parser = LineParser {
        path,
        dialect,
        header_fields: headers.len(),
        flexible: opts.flexible,
        cols,
        names: &opts.columns,
        temp: temp_col.zip(opts.temp_column.as_deref()),
        time: time_col.zip(opts.time_column.as_deref()),
        roles: None,
        filters,
        scale: opts.unit.to_dps(),
    };
    let parser = LineParser { roles: parser.plain_roles(), ..parser };
    let mut info = StreamInfo { columns: opts.columns.clone(), ..Default::default() };
    let ncols = parser.cols.len();
    let with_temp = parser.temp.is_some();
    // Without a time column the rows go on in batches; with one, row by row, with NaN rows for the samples
    // missing from the time column, once the rate is known from the median step of the first rows (buffered).
    let mut timed = parser.time.map(|_| Timed {
        rate: opts.rate_hz.unwrap_or(0.0),
        last_t: None,
        pending: Vec::new(),
        nan_row: vec![f64::NAN; ncols],
        column: opts.time_column.as_deref().unwrap_or(""),
    });
    if timed.is_none() {
        info.rate_hz = opts.rate_hz.unwrap_or(0.0);
    }
    let mut emit = |values: &[f64], temps: Option<&[f64]>, gaps: u64, expected_rows: usize, info: &mut StreamInfo| {
        let rows = values.len() / ncols.max(1);
        info.samples += rows as u64;
        info.gaps += gaps;
        sink(values, temps.filter(|_| with_temp), expected_rows);
    };
    let count_gaps = |values: &[f64]| values.iter().filter(|v| v.is_nan()).count() as u64;
    // The tasks' outputs, kept from block to block.
    let mut parts: Vec<Parsed> = Vec::new();
    let mut expected_rows = 0;
    while block.len > 0 {
        // The block in byte ranges of whole lines, one per task; each task checks its UTF-8, finds its lines and
        // parses them, numbering from 1; the numbers are made absolute after, in order.
        // The next block is read (and decompressed) while this one is parsed.
        let bytes = block.bytes();
        let ranges = task_ranges(bytes, 4 * rayon::current_num_threads());
        parts.resize_with(ranges.len(), Parsed::default);
        let ((), read) = rayon::join(
            || {
                use rayon::prelude::*;
                parts.par_iter_mut().zip(&ranges).for_each(|(part, &(a, b))| {
                    part.clear();
                    match std::str::from_utf8(&bytes[a..b]) {
                        Ok(text) => parser.parse(text, part),
                        Err(e) => {
                            let line = 1 + memchr::memchr_iter(b'\n', &bytes[a..a + e.valid_up_to()]).count() as u64;
                            part.error = Some(not_utf8(line));
                        }
                    }
                })
            },
            || next.read(&mut reader),
        );
        if expected_rows == 0 {
            // The rows the whole input will give, from this first block, so that a collector can make room once.
            let rows: u64 = parts.iter().map(|p| p.lines).sum();
            if let Some(total) = input_bytes {
                expected_rows = (total as f64 / block.len as f64 * rows as f64 * 1.01) as usize + 16;
            }
        }
        for part in &mut parts {
            let first = line_no + 1;
            let filtered = part.skips.iter().filter(|(_, k)| *k == Skip::Filtered).count() as u64;
            info.filtered_out += filtered;
            let rows = part.lines - part.skips.len() as u64 - u64::from(part.error.is_some());
            let values = &part.values[..rows as usize * ncols];
            let temps = &part.temps[..if with_temp { rows as usize } else { 0 }];
            match &mut timed {
                None => emit(values, Some(temps), part.gaps, expected_rows, &mut info),
                Some(timed) => {
                    // The file line of each row: the task's lines less its skipped ones.
                    let mut skips = part.skips.iter().peekable();
                    let mut line = first;
                    for k in 0..rows as usize {
                        while skips.peek().is_some_and(|(l, _)| first + l - 1 == line) {
                            skips.next();
                            line += 1;
                        }
                        let row = TimedRow {
                            values: &values[k * ncols..(k + 1) * ncols],
                            temp: with_temp.then(|| temps[k]),
                            t: part.times[k],
                            line,
                        };
                        timed.row(row, path, &mut |v, t| emit(v, t, count_gaps(v), expected_rows, &mut info))?;
                        line += 1;
                    }
                    info.rate_hz = timed.rate;
                }
            }
            if let Some(mut e) = part.error.take() {
                if let Some(line) = e.line_mut() {
                    *line += first - 1;
                }
                return Err(e);
            }
            line_no += part.lines;
        }
        read.map_err(io)?;
        std::mem::swap(&mut block, &mut next);
    }
    if let Some(timed) = &mut timed {
        timed.finish(path, &mut |v, t| emit(v, t, count_gaps(v), expected_rows, &mut info))?;
        info.rate_hz = timed.rate;
    }
    if info.samples == 0 {
        return Err(RecordingError::Empty { path: path.to_string() });
    }
    Ok(info)
}

/// Where rows go: the values of consecutive rows (`ncols` per row) and their temperatures, if read.
type RowSink<'a> = dyn FnMut(&[f64], Option<&[f64]>) + 'a;

/// Rows with a time column: the rate from the median step of the first rows (buffered until then), and NaN rows
/// for the samples missing where the time jumps.
struct Timed<'a> {
    /// Hz; 0 until known.
    rate: f64,
    last_t: Option<f64>,
    /// The first rows while the rate is not known: (line, values, temperature, time).
    pending: Vec<(u64, Vec<f64>, Option<f64>, f64)>,
    nan_row: Vec<f64>,
    column: &'a str,
}

/// Rows that fix the rate of a time column.
const RATE_ROWS: usize = 1001;

/// One row of a timed read: its values, temperature, time and file line.
#[derive(Clone, Copy)]
struct TimedRow<'r> {
    values: &'r [f64],
    temp: Option<f64>,
    t: f64,
    line: u64,
}

impl Timed<'_> {
    /// One row (the rate known, or its first rows buffered until it is).
    fn row(&mut self, row: TimedRow<'_>, path: &str, emit: &mut RowSink<'_>) -> Result<(), RecordingError> {
        if self.rate == 0.0 {
            self.pending.push((row.line, row.values.to_vec(), row.temp, row.t));
            if self.pending.len() == RATE_ROWS {
                self.flush(path, emit)?;
            }
            return Ok(());
        }
        self.deliver(row, path, emit)
    }

    /// The end of the input: a rate from the rows buffered so far, if still unknown.
    fn finish(&mut self, path: &str, emit: &mut RowSink<'_>) -> Result<(), RecordingError> {
        if self.rate == 0.0 && !self.pending.is_empty() {
            self.flush(path, emit)?;
        }
        Ok(())
    }

    fn flush(&mut self, path: &str, emit: &mut RowSink<'_>) -> Result<(), RecordingError> {
        self.rate = median_rate(&self.pending, path, self.column)?;
        for (line, values, temp, t) in std::mem::take(&mut self.pending) {
            self.deliver(TimedRow { values: &values, temp, t, line }, path, emit)?;
        }
        Ok(())
    }

    fn deliver(&mut self, row: TimedRow<'_>, path: &str, emit: &mut RowSink<'_>) -> Result<(), RecordingError> {
        let temp = row.temp.map(|x| [x]);
        let temp = temp.as_ref().map(|x| &x[..]);
        if let Some(prev) = self.last_t {
            if row.t <= prev {
                return Err(RecordingError::TimeNotIncreasing {
                    path: path.to_string(),
                    line: row.line,
                    column: self.column.to_string(),
                    t: row.t,
                    previous: prev,
                });
            }
            let steps = ((row.t - prev) * self.rate).round() as i64;
            for _ in 1..steps.max(1) {
                emit(&self.nan_row, temp.map(|_| &[f64::NAN][..]));
            }
        }
        self.last_t = Some(row.t);
        emit(row.values, temp);
        Ok(())
    }
}

/// Split `block` into about `n` byte ranges of whole lines.
fn task_ranges(block: &[u8], n: usize) -> Vec<(usize, usize)> {
    let target = block.len().div_ceil(n.max(1)).max(1 << 16);
    let mut ranges = Vec::with_capacity(n + 1);
    let mut a = 0;
    while a < block.len() {
        let b = (a + target).min(block.len());
        let b =
            if b == block.len() { b } else { memchr::memchr(b'\n', &block[b..]).map_or(block.len(), |k| b + k + 1) };
        ranges.push((a, b));
        a = b;
    }
    ranges
}

fn median_rate(rows: &[(u64, Vec<f64>, Option<f64>, f64)], path: &str, column: &str) -> Result<f64, RecordingError> {
    let mut steps: Vec<f64> = rows.windows(2).map(|w| w[1].3 - w[0].3).collect();
    for (w, step) in rows.windows(2).zip(&steps) {
        if !(*step > 0.0) {
            return Err(RecordingError::TimeNotIncreasing {
                path: path.to_string(),
                line: w[1].0,
                column: column.to_string(),
                t: w[1].3,
                previous: w[0].3,
            });
        }
    }
    if steps.is_empty() {
        return Err(RecordingError::NoRate { path: path.to_string() });
    }
    steps.sort_by(f64::total_cmp);
    Ok(1.0 / steps[steps.len() / 2])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn opts(cols: &[&str]) -> CsvOptions {
        CsvOptions { columns: cols.iter().map(|s| s.to_string()).collect(), rate_hz: Some(10.0), ..Default::default() }
    }

    #[test]
    fn reads_columns_with_units() {
        let text = "a,b\n1,2\n3,4\n";
        let mut o = opts(&["b", "a"]);
        o.unit = RateUnit::parse("deg/h").unwrap();
        let r = read_csv(text.as_bytes(), "f.csv", &o).unwrap();
        assert_eq!(
            r.channels,
            vec![vec![2.0 * (1.0 / 3600.0), 4.0 * (1.0 / 3600.0)], vec![1.0 / 3600.0, 3.0 * (1.0 / 3600.0)]]
        );
        assert_eq!(r.rate_hz, 10.0);
        let o = CsvOptions { unit: RateUnit::MradPerS, ..opts(&["a"]) };
        let r = read_csv("a\n1000\n".as_bytes(), "f.csv", &o).unwrap();
        assert!((r.channels[0][0] - 180.0 / std::f64::consts::PI).abs() < 1e-9);
    }

    #[test]
    fn errors_locate_the_fault() {
        let e = read_csv("a,b\n1,2\n3,x\n".as_bytes(), "f.csv", &opts(&["b"])).unwrap_err();
        assert_eq!(e.to_string(), "f.csv, line 3, column \"b\": \"x\" is not a number");
        let e = read_csv("a,b\n1,2\n".as_bytes(), "f.csv", &opts(&["c"])).unwrap_err();
        assert_eq!(e.to_string(), "f.csv, line 1: no column \"c\" (the header has: a, b; split at ',')");
        let e = read_csv("".as_bytes(), "f.csv", &opts(&["a"])).unwrap_err();
        assert!(matches!(e, RecordingError::Empty { .. }), "{e}");
        let e = read_csv("a,b\n1\n".as_bytes(), "f.csv", &opts(&["b"])).unwrap_err();
        assert!(e.to_string().starts_with("f.csv, line 2:"), "{e}");
        assert!(RateUnit::parse("furlong/fortnight").unwrap_err().to_string().contains("furlong"));
        let e = read_csv("a\n1\n".as_bytes(), "f.csv", &CsvOptions { rate_hz: None, ..opts(&["a"]) }).unwrap_err();
        assert!(matches!(e, RecordingError::NoRate { .. }));
    }

    #[test]
    fn empty_cells_and_time_jumps_are_gaps() {
        let text = "t,g\n0.0,1\n0.1,\n0.2,NaN\n0.5,4\n0.6,5\n";
        let o = CsvOptions { rate_hz: None, time_column: Some("t".into()), ..opts(&["g"]) };
        let r = read_csv(text.as_bytes(), "f.csv", &o).unwrap();
        let g = &r.channels[0];
        assert!((r.rate_hz - 10.0).abs() < 1e-9);
        // 0.2 -> 0.5 is three steps: two samples missing.
        assert_eq!(g.len(), 7);
        assert_eq!(g.iter().filter(|v| v.is_nan()).count(), 4);
        assert_eq!(g[6], 5.0);
        let bad = "t,g\n0.0,1\n0.1,2\n0.1,3\n";
        let e = read_csv(bad.as_bytes(), "f.csv", &o).unwrap_err();
        assert!(e.to_string().contains("line 4") && e.to_string().contains("does not increase"), "{e}");
    }

    #[test]
    fn an_infinite_cell_is_an_error_that_names_its_line_and_column() {
        for cell in ["inf", "-Infinity", "1e999"] {
            let text = format!("g,temp\n1,20\n2,20\n{cell},20\n");
            let e = read_csv(text.as_bytes(), "f.csv", &opts(&["g"])).unwrap_err();
            assert!(matches!(e, RecordingError::NotFinite { line: 4, .. }), "{cell}: {e:?}");
            assert!(e.to_string().contains("column \"g\"") && e.to_string().contains("not a finite number"), "{e}");
        }
        // The temperature column is read by the same rule.
        let text = "g,temp\n1,20\n2,inf\n";
        let o = CsvOptions { temp_column: Some("temp".into()), ..opts(&["g"]) };
        let e = read_csv(text.as_bytes(), "f.csv", &o).unwrap_err();
        assert!(matches!(e, RecordingError::NotFinite { line: 3, .. }), "{e:?}");
    }

    #[test]
    fn filters_and_skipped_rows() {
        let text = "# logger v2\n# units: deg/s\nperiod,g,temp\n0,9,20\n1,1,21\n1,2,22\n2,3,23\n";
        let o = CsvOptions {
            skip_rows: 2,
            filters: vec![RowFilter::parse("period=1").unwrap()],
            temp_column: Some("temp".into()),
            ..opts(&["g"])
        };
        let r = read_csv(text.as_bytes(), "f.csv", &o).unwrap();
        assert_eq!(r.channels[0], vec![1.0, 2.0]);
        assert_eq!(r.temp_c, Some(vec![21.0, 22.0]));
        assert_eq!(r.info.filtered_out, 2);
        let e = read_csv(
            "p,g\n1,2\n".as_bytes(),
            "f.csv",
            &CsvOptions { filters: vec![RowFilter::parse("q=1").unwrap()], ..opts(&["g"]) },
        )
        .unwrap_err();
        assert!(e.to_string().contains("no column \"q\""), "{e}");
        assert!(RowFilter::parse("novalue").is_err());
    }

    fn read(text: &str, o: &CsvOptions) -> Result<Recording, RecordingError> {
        read_csv(text.as_bytes(), "f.csv", o)
    }

    #[test]
    fn dialects_are_read_right_without_flags() {
        // Semicolons with decimal commas (a European spreadsheet export).
        let r = read("t;rate\n0,001;1,25\n0,002;-3,5e-3\n", &opts(&["rate"])).unwrap();
        assert_eq!(r.channels[0], vec![1.25, -3.5e-3]);
        // Semicolons with points, tabs, whitespace, quoted names.
        assert_eq!(read("t;rate\n1;2.5\n", &opts(&["rate"])).unwrap().channels[0], vec![2.5]);
        assert_eq!(read("t\trate\n1\t2.5\n", &opts(&["rate"])).unwrap().channels[0], vec![2.5]);
        assert_eq!(read("t   rate\n 1   2.5\n2 3\n", &opts(&["rate"])).unwrap().channels[0], vec![2.5, 3.0]);
        assert_eq!(read("t rate\n1 2,5\n", &opts(&["rate"])).unwrap().channels[0], vec![2.5]);
        assert_eq!(read("\"t\",\"rate\"\n1,\"2.5\"\n", &opts(&["rate"])).unwrap().channels[0], vec![2.5]);
        // A byte-order mark before the first name, CRLF line ends.
        let r = read("\u{feff}rate,t\r\n1.5,0\r\n2.5,1\r\n", &opts(&["rate"])).unwrap();
        assert_eq!(r.channels[0], vec![1.5, 2.5]);
    }

    #[test]
    fn a_decimal_comma_in_a_one_column_file_is_an_error_until_it_is_named() {
        // The file that was read as its integer parts, exit 0: now an error naming the line and the likely cause.
        let text = "rate\n1,2881847531554629\n-0,5\n";
        let e = read(text, &opts(&["rate"])).unwrap_err();
        assert!(matches!(e, RecordingError::FieldCount { line: 2, found: 2, expected: 1, .. }), "{e:?}");
        assert!(e.to_string().contains("decimal comma?"), "{e}");
        let o = CsvOptions { decimal_comma: Some(true), ..opts(&["rate"]) };
        assert_eq!(read(text, &o).unwrap().channels[0], vec![1.2881847531554629, -0.5]);
        // Given a comma delimiter explicitly, a decimal comma cannot be told apart: an error, not a guess.
        let o = CsvOptions { decimal_comma: Some(true), delimiter: Some(Delimiter::Byte(b',')), ..opts(&["rate"]) };
        assert!(read(text, &o).unwrap_err().to_string().contains("needs a delimiter other than the comma"));
        // A semicolon file whose cells carry a comma but are read with a point: the cell's error says why.
        let o = CsvOptions { decimal_comma: Some(false), ..opts(&["rate"]) };
        let e = read("t;rate\n1;2,5\n", &o).unwrap_err();
        assert!(e.to_string().contains("line 2") && e.to_string().contains("decimal comma?"), "{e}");
    }

    #[test]
    fn field_counts_and_duplicate_names_are_checked() {
        let e = read("a,b\n1,2\n1,2,3\n", &opts(&["b"])).unwrap_err();
        assert_eq!(e.to_string(), "f.csv, line 3: 3 fields where the header has 2; a decimal comma? give --decimal-comma (and --delimiter for a file with several columns)");
        let e = read("a;b\n1;2;3\n", &opts(&["b"])).unwrap_err();
        assert!(e.to_string().ends_with("give --flexible to read such rows anyway"), "{e}");
        let o = CsvOptions { flexible: true, ..opts(&["b"]) };
        assert_eq!(read("a,b\n1,2,3\n4,5\n", &o).unwrap().channels[0], vec![2.0, 5.0]);
        let e = read("a,b,a\n1,2,3\n", &opts(&["b"])).unwrap_err();
        assert_eq!(e.to_string(), "f.csv, line 1: column \"a\" appears twice in the header (fields 1 and 3)");
        let e = read("a,b\n\"1,2\n", &opts(&["b"])).unwrap_err();
        assert!(e.to_string().contains("line 2") && e.to_string().contains("quoted"), "{e}");
        let e = read("a;b\n1;2\n", &opts(&["c"])).unwrap_err();
        assert!(e.to_string().contains("split at ';'"), "{e}");
    }

    #[test]
    fn faults_far_into_a_file_name_their_line_across_blocks_and_tasks() {
        // Lines beyond the first parallel task (and a blank line to count): the error's line is exact.
        const ROWS: usize = 120_000; // about 1.3 MB: several tasks of 64 KiB or more
        let mut text = String::from("# a logger's banner\ng,t\n");
        for i in 0..ROWS {
            if i == 100 {
                text.push('\n');
            }
            let cell = if i == ROWS - 1000 { "1.5x".to_string() } else { format!("{}.25", i % 7) };
            text.push_str(&format!("{cell},{i}\n"));
        }
        let o = CsvOptions { skip_rows: 1, ..opts(&["g"]) };
        let e = read(&text, &o).unwrap_err();
        // Line 1 the banner, 2 the header, 3.. the rows, one blank line before row 100.
        let want = 3 + (ROWS - 1000) as u64 + 1;
        assert!(matches!(e, RecordingError::NotANumber { line, .. } if line == want), "{e}");
    }

    #[test]
    fn the_values_are_those_of_the_csv_crate() {
        // An independent reader (the csv crate with str::parse) on the same file, with gaps and odd spacing.
        // Lines in many spellings, so that both the plain-row path and the careful one are taken: exponents
        // short and long, 17 and 9 digits, plain decimals, huge and tiny magnitudes, spaces, CRLF, quoted and
        // empty cells.
        let mut text = String::from("time, g ,temp\n");
        let mut s = 7u64;
        for i in 0..20000 {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let g = ((s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0) * 10f64.powi((s % 61) as i32 - 30);
            let cell = match i % 11 {
                _ if i % 997 == 3 => String::new(),
                0 => format!("{g:.17e}"),
                1 => format!("{g}"),
                2 => format!("{g:.9e}"),
                3 => format!(" {g:.6} "),
                4 => format!("\"{g:e}\""),
                5 => format!("{g:+.3E}"),
                6 => format!("{:.25}", g.abs()),
                7 => format!("{g:.30e}"),
                _ => format!("{g:e}"),
            };
            let end = if i % 3 == 0 { "\r\n" } else { "\n" };
            let time = if i % 7 == 0 { format!("\"{i}\"") } else { format!("{}", i as f64 * 0.01) };
            text.push_str(&format!("{time},{cell},{:.4}{end}", 20.0 + g.clamp(-1.0, 1.0)));
        }
        let o = CsvOptions { temp_column: Some("temp".into()), ..opts(&["g"]) };
        let r = read(&text, &o).unwrap();
        let (mut reference, mut temps) = (Vec::new(), Vec::new());
        let mut rdr = csv::ReaderBuilder::new().trim(csv::Trim::All).from_reader(text.as_bytes());
        for rec in rdr.records() {
            let rec = rec.unwrap();
            reference.push(if rec[1].is_empty() { f64::NAN } else { rec[1].parse::<f64>().unwrap() });
            temps.push(rec[2].parse::<f64>().unwrap());
        }
        assert_eq!(r.channels[0].len(), reference.len());
        for (a, b) in r.channels[0].iter().zip(&reference) {
            assert!(a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()), "{a} vs {b}");
        }
        assert_eq!(r.temp_c.as_deref(), Some(&temps[..]));
    }
}

//! Reading rate recordings from CSV (or CSV.gz, or stdin): any column, any unit, a time column or a fixed rate.
//!
//! The reader streams: rows are handed to a callback one at a time, so a 72-hour file never has to fit in memory
//! ([`read_csv_stream`]); [`read_csv`] collects them for in-memory analysis. Empty cells, `NaN` and samples
//! missing from the time column (a jump of more than 1.5 sample periods) become NaN gaps, never interpolated or
//! averaged in; the statistics skip every difference that touches one. A cell that is not a number, a missing
//! column, an unknown unit or an empty file is an error that names the file, the line and the column.

mod lines;
pub mod rows;
mod timed;

#[cfg(test)]
mod tests;

use std::io::BufRead;

use crate::recording::{AccelUnit, RateUnit, Recording, StreamInfo, UnknownUnit};
use lines::{task_ranges, Block, LineParser, Parsed, Skip};
use octavar_stats::quantity::Quantity;
use rows::{clean_header, split, Delimiter, Dialect};
use timed::{Timed, TimedRow};

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
    #[error(transparent)]
    UnknownUnit(#[from] UnknownUnit),
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
    /// Rate columns to read (at least one of these or of `accel_columns`).
    pub columns: Vec<String>,
    /// Accelerometer columns to read after the rate columns (x, y, z in order), in `accel_unit`.
    pub accel_columns: Vec<String>,
    /// Unit of the accelerometer columns.
    pub accel_unit: AccelUnit,
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
            accel_columns: Vec::new(),
            accel_unit: AccelUnit::MPerS2,
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

impl CsvOptions {
    /// Every column read, in the order of the samples' values: the rate columns, then the accelerometer columns.
    pub fn read_columns(&self) -> Vec<String> {
        self.columns.iter().chain(&self.accel_columns).cloned().collect()
    }

    /// What each column of [`CsvOptions::read_columns`] measures.
    pub fn quantities(&self) -> Vec<Quantity> {
        let accel = std::iter::repeat_n(Quantity::Acceleration, self.accel_columns.len());
        std::iter::repeat_n(Quantity::AngularRate, self.columns.len()).chain(accel).collect()
    }

    /// The factor from each column's unit to its quantity's (deg/s, m/s^2).
    fn scales(&self) -> Vec<f64> {
        let accel = std::iter::repeat_n(self.accel_unit.to_m_per_s2(), self.accel_columns.len());
        std::iter::repeat_n(self.unit.to_dps(), self.columns.len()).chain(accel).collect()
    }
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
    let n = opts.columns.len() + opts.accel_columns.len();
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
            for (k, c) in channels.iter_mut().enumerate() {
                c.extend(rows[k..].iter().step_by(n));
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
        quantities: opts.quantities(),
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

/// Stream a CSV recording: `sink` gets each sample's values (deg/s, one per column, NaN for a gap) and the
/// temperature when a temperature column was named. The rate is known before the first call.
///
/// The dialect is [`CsvOptions::delimiter`] and [`CsvOptions::decimal_comma`], or detected from the header and
/// the first rows (see [`crate::csv::rows::Dialect`]). Lines are read in blocks of about 8 MB and parsed on
/// every core while the rows of the block before are handed on, in order, and the block after is read, so memory
/// stays bounded (two blocks of text and two of parsed rows).
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
    let n = opts.columns.len() + opts.accel_columns.len();
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
    sink: impl FnMut(&[f64], Option<&[f64]>, usize),
) -> Result<StreamInfo, RecordingError> {
    let io = |err| RecordingError::Io { path: path.to_string(), err };
    let mut raw = Vec::new();
    let mut line_no = skip_lines(&mut reader, opts.skip_rows, path, &mut raw)?;
    if let Some(r) = opts.rate_hz {
        if !(r.is_finite() && r > 0.0) {
            return Err(RecordingError::BadRate(r));
        }
    }
    raw.clear();
    reader.read_until(b'\n', &mut raw).map_err(io)?;
    line_no += 1;
    let header_line = line_no;
    let header_text = std::str::from_utf8(&raw).map_err(|_| not_utf8(path, header_line))?;
    let header_text = clean_header(header_text);
    if header_text.trim().is_empty() {
        return Err(RecordingError::Empty { path: path.to_string() });
    }
    let (mut block, mut next) = (Block::default(), Block::default());
    block.read(&mut reader).map_err(io)?;
    let dialect = choose_dialect(header_text, opts, &block, path, header_line)?;
    let headers = header_names(header_text, dialect.delimiter, path, header_line)?;
    let columns = opts.read_columns();
    let parser = line_parser(opts, path, &headers, header_line, dialect, &columns)?;
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
    let info = StreamInfo { columns: columns.clone(), ..Default::default() };
    let mut out = Emitter { sink, ncols, with_temp, expected_rows: 0, info };
    if timed.is_none() {
        out.info.rate_hz = opts.rate_hz.unwrap_or(0.0);
    }
    // A pipeline of three stages on the cores at once: the tasks parse one block (split into byte ranges of whole
    // lines, each task checking its UTF-8 and numbering its lines from 1) while this thread hands on the rows of
    // the block before it, in order, and reads (and decompresses) the block after it.
    let (mut parts, mut ready): (Vec<Parsed>, Vec<Parsed>) = (Vec::new(), Vec::new());
    let mut read_error = None;
    loop {
        let parsing = block.len > 0;
        let bytes = block.bytes();
        let ranges = if parsing { task_ranges(bytes, 16 * rayon::current_num_threads()) } else { Vec::new() };
        parts.resize_with(ranges.len(), Parsed::default);
        let mut handed_on = Ok(());
        rayon::in_place_scope(|scope| {
            if parsing {
                let (parser, ranges, parts) = (&parser, &ranges, &mut parts);
                scope.spawn(move |_| parse_tasks(parser, bytes, ranges, parts));
            }
            for part in &mut ready {
                handed_on = out.part(part, line_no + 1, timed.as_mut(), path);
                if handed_on.is_err() {
                    break;
                }
                line_no += part.lines;
            }
            next.len = 0;
            if parsing && read_error.is_none() {
                read_error = next.read(&mut reader).err();
                if read_error.is_some() {
                    next.len = 0;
                }
            }
        });
        handed_on?;
        if !parsing {
            break;
        }
        if let (0, Some(total)) = (out.expected_rows, input_bytes) {
            // The rows the whole input will give, from this first block, so that a collector can make room once.
            let rows: u64 = parts.iter().map(|p| p.lines).sum();
            out.expected_rows = (total as f64 / block.len as f64 * rows as f64 * 1.01) as usize + 16;
        }
        std::mem::swap(&mut ready, &mut parts);
        std::mem::swap(&mut block, &mut next);
    }
    if let Some(err) = read_error {
        return Err(io(err));
    }
    if let Some(timed) = &mut timed {
        timed.finish(path, &mut |v, t| out.emit(v, t, count_gaps(v)))?;
        out.info.rate_hz = timed.rate;
    }
    if out.info.samples == 0 {
        return Err(RecordingError::Empty { path: path.to_string() });
    }
    Ok(out.info)
}

/// The error for a line that is not UTF-8.
fn not_utf8(path: &str, line: u64) -> RecordingError {
    RecordingError::BadRow { path: path.to_string(), line, message: "not valid UTF-8".into() }
}

/// The NaN values (gaps) among `values`.
#[inline]
fn count_gaps(values: &[f64]) -> u64 {
    values.iter().filter(|v| v.is_nan()).count() as u64
}

/// Skip the `skip` lines before the header (read into `raw`): their number; an input that ends first is empty.
fn skip_lines<R: BufRead>(reader: &mut R, skip: usize, path: &str, raw: &mut Vec<u8>) -> Result<u64, RecordingError> {
    let mut line_no: u64 = 0;
    for _ in 0..skip {
        raw.clear();
        if reader.read_until(b'\n', raw).map_err(|err| RecordingError::Io { path: path.to_string(), err })? == 0 {
            return Err(RecordingError::Empty { path: path.to_string() });
        }
        line_no += 1;
    }
    Ok(line_no)
}

/// The dialect: the options' delimiter and decimal comma, or those detected from the header and the first block.
fn choose_dialect(
    header_text: &str,
    opts: &CsvOptions,
    block: &Block,
    path: &str,
    header_line: u64,
) -> Result<Dialect, RecordingError> {
    // `None`: a one-field header, which says nothing about the delimiter (read as a comma).
    let detected = Dialect::detect_delimiter(header_text);
    let one_field = opts.delimiter.is_none() && detected.is_none();
    let mut delimiter = opts.delimiter.or(detected).unwrap_or(Delimiter::Byte(b','));
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
    Ok(Dialect { delimiter, decimal_comma })
}

/// The header's column names, split at `delimiter`; a name that appears twice is an error.
fn header_names(
    header_text: &str,
    delimiter: Delimiter,
    path: &str,
    header_line: u64,
) -> Result<Vec<String>, RecordingError> {
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
    Ok(headers)
}

/// The line parser of the options' columns and filters, found in `headers`; an error for a missing one or no rate.
fn line_parser<'a>(
    opts: &'a CsvOptions,
    path: &'a str,
    headers: &[String],
    header_line: u64,
    dialect: Dialect,
    columns: &'a [String],
) -> Result<LineParser<'a>, RecordingError> {
    let delimiter = dialect.delimiter;
    let find = |name: &str| {
        headers.iter().position(|h| h == name).ok_or_else(|| RecordingError::MissingColumn {
            path: path.to_string(),
            line: header_line,
            column: name.to_string(),
            available: format!("{}; split at {delimiter}", headers.join(", ")),
        })
    };
    let cols: Vec<usize> = columns.iter().map(|c| find(c)).collect::<Result<_, _>>()?;
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
        names: columns,
        temp: temp_col.zip(opts.temp_column.as_deref()),
        time: time_col.zip(opts.time_column.as_deref()),
        roles: None,
        filters,
        scales: opts.scales(),
    };
    Ok(LineParser { roles: parser.plain_roles(), ..parser })
}

/// Parse each task's byte range of `bytes` into its part, in parallel (text that is not UTF-8: its fault).
fn parse_tasks(parser: &LineParser<'_>, bytes: &[u8], ranges: &[(usize, usize)], parts: &mut [Parsed]) {
    use rayon::prelude::*;
    parts.par_iter_mut().zip(ranges).for_each(|(part, &(a, b))| {
        part.clear();
        match simdutf8::basic::from_utf8(&bytes[a..b]) {
            Ok(text) => parser.parse(text, part),
            Err(_) => {
                // The whole lines before the fault are read as any others, and the fault is the next line's.
                let bytes = &bytes[a..b];
                let valid = std::str::from_utf8(bytes).map_or_else(|e| e.valid_up_to(), |t| t.len());
                let whole = memchr::memrchr(b'\n', &bytes[..valid]).map_or(0, |i| i + 1);
                let text = std::str::from_utf8(&bytes[..whole]).expect("checked up to the fault");
                parser.parse(text, part);
                if part.error.is_none() {
                    part.lines += 1;
                    part.error = Some(not_utf8(parser.path, part.lines));
                }
            }
        }
    })
}

/// Where the parsed rows go: counted into the read's [`StreamInfo`], then handed to the caller's sink.
struct Emitter<F> {
    sink: F,
    ncols: usize,
    with_temp: bool,
    /// The rows the whole input is expected to give (0 until known).
    expected_rows: usize,
    info: StreamInfo,
}

impl<F: FnMut(&[f64], Option<&[f64]>, usize)> Emitter<F> {
    /// Hand on consecutive rows (`ncols` values each) and their temperatures, with the gaps among them.
    #[inline]
    fn emit(&mut self, values: &[f64], temps: Option<&[f64]>, gaps: u64) {
        let rows = values.len() / self.ncols.max(1);
        self.info.samples += rows as u64;
        self.info.gaps += gaps;
        let with_temp = self.with_temp;
        (self.sink)(values, temps.filter(|_| with_temp), self.expected_rows);
    }

    /// Hand on a task's rows (through `timed` with a time column), its first line the file's `first`; then its fault.
    fn part(
        &mut self,
        part: &mut Parsed,
        first: u64,
        timed: Option<&mut Timed<'_>>,
        path: &str,
    ) -> Result<(), RecordingError> {
        let (ncols, with_temp) = (self.ncols, self.with_temp);
        let filtered = part.skips.iter().filter(|(_, k)| *k == Skip::Filtered).count() as u64;
        self.info.filtered_out += filtered;
        let rows = part.lines - part.skips.len() as u64 - u64::from(part.error.is_some());
        let values = &part.values[..rows as usize * ncols];
        let temps = &part.temps[..if with_temp { rows as usize } else { 0 }];
        match timed {
            None => self.emit(values, Some(temps), part.gaps),
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
                    timed.row(row, path, &mut |v, t| self.emit(v, t, count_gaps(v)))?;
                    line += 1;
                }
                self.info.rate_hz = timed.rate;
            }
        }
        if let Some(mut e) = part.error.take() {
            if let Some(line) = e.line_mut() {
                *line += first - 1;
            }
            return Err(e);
        }
        Ok(())
    }
}

//! Reading rate recordings from CSV (or CSV.gz, or stdin): any column, any unit, a time column or a fixed rate.
//!
//! The reader streams: rows are handed to a callback one at a time, so a 72-hour file never has to fit in memory
//! ([`read_csv_stream`]); [`read_csv`] collects them for in-memory analysis. Empty cells, `NaN` and samples
//! missing from the time column (a jump of more than 1.5 sample periods) become NaN gaps, never interpolated or
//! averaged in; the statistics skip every difference that touches one. A cell that is not a number, a missing
//! column, an unknown unit or an empty file is an error that names the file, the line and the column.

use std::io::BufRead;

use serde::Serialize;

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
    /// A row with fewer cells than the header.
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
pub fn read_csv<R: BufRead>(reader: R, path: &str, opts: &CsvOptions) -> Result<Recording, RecordingError> {
    let n = opts.columns.len();
    let mut channels: Vec<Vec<f64>> = vec![Vec::new(); n];
    let mut temps: Vec<f64> = Vec::new();
    let info = read_csv_stream(reader, path, opts, |row, temp| {
        for (c, v) in channels.iter_mut().zip(row) {
            c.push(*v);
        }
        if let Some(t) = temp {
            temps.push(t);
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

/// Stream a CSV recording: `sink` gets each sample's values (deg/s, one per column, NaN for a gap) and the
/// temperature when a temperature column was named. The rate is known before the first call.
///
/// # Errors
/// A missing column, a cell that is not a number, a row too short, a time column that does not increase, no
/// rate, an empty result, or an I/O error; each names the file, line and column.
pub fn read_csv_stream<R: BufRead>(
    mut reader: R,
    path: &str,
    opts: &CsvOptions,
    mut sink: impl FnMut(&[f64], Option<f64>),
) -> Result<StreamInfo, RecordingError> {
    let io = |err| RecordingError::Io { path: path.to_string(), err };
    let mut line_no: u64 = 0;
    let mut skip = String::new();
    for _ in 0..opts.skip_rows {
        skip.clear();
        if reader.read_line(&mut skip).map_err(io)? == 0 {
            return Err(RecordingError::Empty { path: path.to_string() });
        }
        line_no += 1;
    }
    if let Some(r) = opts.rate_hz {
        if !(r.is_finite() && r > 0.0) {
            return Err(RecordingError::BadRate(r));
        }
    }
    let mut rdr = csv::ReaderBuilder::new().has_headers(true).flexible(true).trim(csv::Trim::All).from_reader(reader);
    let headers = rdr.headers().map_err(|e| csv_error(path, line_no, e))?.clone();
    let header_line = line_no + 1;
    if headers.is_empty() || (headers.len() == 1 && headers[0].is_empty()) {
        return Err(RecordingError::Empty { path: path.to_string() });
    }
    let find = |name: &str| {
        headers.iter().position(|h| h == name).ok_or_else(|| RecordingError::MissingColumn {
            path: path.to_string(),
            line: header_line,
            column: name.to_string(),
            available: headers.iter().collect::<Vec<_>>().join(", "),
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
    let scale = opts.unit.to_dps();
    let mut info = StreamInfo { columns: opts.columns.clone(), ..Default::default() };

    let parse_cell = |text: &str, line: u64, column: &str| -> Result<f64, RecordingError> {
        if text.is_empty() || text.eq_ignore_ascii_case("nan") || text.eq_ignore_ascii_case("na") {
            return Ok(f64::NAN);
        }
        match text.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            parsed => {
                let (path, column, text) = (path.to_string(), column.to_string(), text.to_string());
                Err(if parsed.is_ok() {
                    RecordingError::NotFinite { path, line, column, text }
                } else {
                    RecordingError::NotANumber { path, line, column, text }
                })
            }
        }
    };

    // With a time column the rate comes from the median step of the first rows, which are buffered.
    let mut pending: Vec<(u64, Vec<f64>, Option<f64>, f64)> = Vec::new();
    let mut rate = opts.rate_hz.unwrap_or(0.0);
    let mut last_t: Option<f64> = None;
    let mut values = vec![0.0; cols.len()];
    let mut record = csv::StringRecord::new();
    let mut emit = |vals: &[f64], temp: Option<f64>, info: &mut StreamInfo| {
        info.samples += 1;
        info.gaps += vals.iter().filter(|v| v.is_nan()).count() as u64;
        sink(vals, temp);
    };
    let nan_row = vec![f64::NAN; cols.len()];
    // Hand one row on, inserting NaN samples for a jump in the time column.
    let mut deliver = |vals: &[f64], temp: Option<f64>, t: Option<f64>, line: u64, rate: f64, info: &mut StreamInfo| {
        if let (Some(t), Some(prev)) = (t, last_t) {
            if t <= prev {
                return Err(RecordingError::TimeNotIncreasing {
                    path: path.to_string(),
                    line,
                    column: opts.time_column.clone().unwrap_or_default(),
                    t,
                    previous: prev,
                });
            }
            let steps = ((t - prev) * rate).round() as i64;
            for _ in 1..steps.max(1) {
                emit(&nan_row, temp.map(|_| f64::NAN), info);
            }
        }
        if t.is_some() {
            last_t = t;
        }
        emit(vals, temp, info);
        Ok(())
    };
    loop {
        match rdr.read_record(&mut record) {
            Ok(false) => break,
            Ok(true) => {}
            Err(e) => return Err(csv_error(path, line_no, e)),
        }
        let line = record.position().map_or(0, |p| p.line()) + line_no;
        if record.len() == 1 && record[0].is_empty() {
            continue; // a blank line
        }
        if filters.iter().any(|(i, f)| record.get(*i).is_none_or(|cell| !f.matches(cell))) {
            info.filtered_out += 1;
            continue;
        }
        for (v, (&c, name)) in values.iter_mut().zip(cols.iter().zip(&opts.columns)) {
            let cell = record.get(c).ok_or_else(|| RecordingError::BadRow {
                path: path.to_string(),
                line,
                message: format!("{} fields, column {name:?} is field {}", record.len(), c + 1),
            })?;
            *v = parse_cell(cell, line, name)? * scale;
        }
        let temp = match (temp_col, &opts.temp_column) {
            (Some(i), Some(name)) => Some(parse_cell(record.get(i).unwrap_or(""), line, name)?),
            _ => None,
        };
        let t = match (time_col, &opts.time_column) {
            (Some(i), Some(name)) => {
                let t = parse_cell(record.get(i).unwrap_or(""), line, name)?;
                if t.is_nan() {
                    return Err(RecordingError::NotANumber {
                        path: path.to_string(),
                        line,
                        column: name.clone(),
                        text: record.get(i).unwrap_or("").to_string(),
                    });
                }
                Some(t)
            }
            _ => None,
        };
        if rate == 0.0 {
            pending.push((line, values.clone(), temp, t.unwrap_or(f64::NAN)));
            if pending.len() == 1001 {
                rate = median_rate(&pending, path, opts)?;
                info.rate_hz = rate;
                for (l, v, tc, tt) in pending.drain(..) {
                    deliver(&v, tc, Some(tt), l, rate, &mut info)?;
                }
            }
            continue;
        }
        info.rate_hz = rate;
        deliver(&values, temp, t, line, rate, &mut info)?;
    }
    if rate == 0.0 && !pending.is_empty() {
        rate = median_rate(&pending, path, opts)?;
        info.rate_hz = rate;
        for (l, v, tc, tt) in pending.drain(..) {
            deliver(&v, tc, Some(tt), l, rate, &mut info)?;
        }
    }
    if info.samples == 0 {
        return Err(RecordingError::Empty { path: path.to_string() });
    }
    info.rate_hz = rate;
    Ok(info)
}

fn median_rate(
    rows: &[(u64, Vec<f64>, Option<f64>, f64)],
    path: &str,
    opts: &CsvOptions,
) -> Result<f64, RecordingError> {
    let mut steps: Vec<f64> = rows.windows(2).map(|w| w[1].3 - w[0].3).collect();
    for (w, step) in rows.windows(2).zip(&steps) {
        if !(*step > 0.0) {
            return Err(RecordingError::TimeNotIncreasing {
                path: path.to_string(),
                line: w[1].0,
                column: opts.time_column.clone().unwrap_or_default(),
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

fn csv_error(path: &str, line_offset: u64, e: csv::Error) -> RecordingError {
    let line = e.position().map_or(0, |p| p.line()) + line_offset;
    match e.into_kind() {
        csv::ErrorKind::Io(err) => RecordingError::Io { path: path.to_string(), err },
        csv::ErrorKind::Utf8 { .. } => {
            RecordingError::BadRow { path: path.to_string(), line, message: "not valid UTF-8".to_string() }
        }
        other => RecordingError::BadRow { path: path.to_string(), line, message: format!("{other:?}") },
    }
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
        assert_eq!(e.to_string(), "f.csv, line 1: no column \"c\" (the header has: a, b)");
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
}

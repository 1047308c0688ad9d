//! The CSV reader's line parsing: a block of whole lines read from the input, cut into byte ranges for the tasks,
//! and each task's lines parsed into flat arrays of values (a plain line in one pass, any other split with the
//! quote rules), with the lines that gave no row and the first fault.

use std::io::BufRead;

use super::rows::{parse_number, parse_plain, split, trim_line_end, Delimiter, Dialect};
use super::{RecordingError, RowFilter, BLOCK_BYTES};

/// A line of a block that gave no row.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Skip {
    /// An empty line.
    Blank,
    /// Dropped by a `--where` filter.
    Filtered,
}

/// The parsed lines of one task: flat arrays, one entry per row that gave values (`ncols` values at a time),
/// and the lines that gave none.
#[derive(Default)]
pub(super) struct Parsed {
    pub(super) values: Vec<f64>,
    pub(super) temps: Vec<f64>,
    pub(super) times: Vec<f64>,
    /// The lines without a row, as (line within the task, counted from 1; why), in order.
    pub(super) skips: Vec<(u64, Skip)>,
    /// Lines looked at (up to and including the faulty one).
    pub(super) lines: u64,
    /// The first fault, which ends the read; the arrays stop just before its line.
    pub(super) error: Option<RecordingError>,
    /// NaN values (gaps) among `values`.
    pub(super) gaps: u64,
}

impl Parsed {
    /// Empty, keeping the arrays' room for the next block.
    pub(super) fn clear(&mut self) {
        self.values.clear();
        self.temps.clear();
        self.times.clear();
        self.skips.clear();
        (self.lines, self.error, self.gaps) = (0, None, 0);
    }
}

/// Everything the line parser needs, shared by the tasks.
pub(super) struct LineParser<'a> {
    pub(super) path: &'a str,
    pub(super) dialect: Dialect,
    pub(super) header_fields: usize,
    pub(super) flexible: bool,
    pub(super) cols: Vec<usize>,
    pub(super) names: &'a [String],
    pub(super) temp: Option<(usize, &'a str)>,
    pub(super) time: Option<(usize, &'a str)>,
    pub(super) filters: Vec<(usize, &'a RowFilter)>,
    /// Per column of `cols`, the factor to its quantity's unit (deg/s or m/s^2).
    pub(super) scales: Vec<f64>,
    /// Per header field, whether a row reads it: the plan of [`LineParser::plain_row`], `None` where a filter
    /// asks for the careful path on every line.
    pub(super) roles: Option<Vec<bool>>,
}

impl LineParser<'_> {
    /// The fields a row reads, for [`LineParser::plain_row`]: `None` with a filter (which compares text).
    pub(super) fn plain_roles(&self) -> Option<Vec<bool>> {
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

    pub(super) fn cell(&self, text: &str, line: u64, column: &str) -> Result<f64, RecordingError> {
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
    pub(super) fn parse(&self, text: &str, out: &mut Parsed) {
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
    pub(super) fn parse_delimited<'t>(
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
    pub(super) fn plain_row(
        &self,
        bytes: &[u8],
        start: usize,
        d: u8,
        fields: &mut [f64],
        out: &mut Parsed,
    ) -> Option<usize> {
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
        for (&c, &k) in self.cols.iter().zip(&self.scales) {
            out.values.push(fields[c] * k);
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
    pub(super) fn parse_lines<'t>(
        &self,
        text: &'t str,
        cells: &mut Vec<&'t str>,
        out: &mut Parsed,
    ) -> Result<(), RecordingError> {
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

    pub(super) fn parse_line<'t>(
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
    pub(super) fn row(&self, cells: &[&str], line: u64, out: &mut Parsed) -> Result<Option<Skip>, RecordingError> {
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
        for ((&c, name), &k) in self.cols.iter().zip(self.names).zip(&self.scales) {
            let cell = cells.get(c).ok_or_else(|| missing(name, c))?;
            out.values.push(self.cell(cell, line, name)? * k);
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
pub(super) struct Block {
    pub(super) buf: Vec<u8>,
    pub(super) len: usize,
}

impl Block {
    pub(super) fn bytes(&self) -> &[u8] {
        &self.buf[..self.len]
    }

    /// Read the next block; empty at the end of the input.
    pub(super) fn read<R: BufRead>(&mut self, reader: &mut R) -> std::io::Result<()> {
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

/// Split `block` into about `n` byte ranges of whole lines.
pub(super) fn task_ranges(block: &[u8], n: usize) -> Vec<(usize, usize)> {
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

//! Rows with a time column: the rate from the median step of the first rows, and NaN rows for the samples
//! missing where the time jumps.

use super::RecordingError;

/// Where rows go: the values of consecutive rows (`ncols` per row) and their temperatures, if read.
pub(super) type RowSink<'a> = dyn FnMut(&[f64], Option<&[f64]>) + 'a;

/// Rows with a time column: the rate from the median step of the first rows (buffered until then), and NaN rows
/// for the samples missing where the time jumps.
pub(super) struct Timed<'a> {
    /// Hz; 0 until known.
    pub(super) rate: f64,
    pub(super) last_t: Option<f64>,
    /// The first rows while the rate is not known: (line, values, temperature, time).
    pub(super) pending: Vec<(u64, Vec<f64>, Option<f64>, f64)>,
    pub(super) nan_row: Vec<f64>,
    pub(super) column: &'a str,
}

/// Rows that fix the rate of a time column.
pub(super) const RATE_ROWS: usize = 1001;

/// One row of a timed read: its values, temperature, time and file line.
#[derive(Clone, Copy)]
pub(super) struct TimedRow<'r> {
    pub(super) values: &'r [f64],
    pub(super) temp: Option<f64>,
    pub(super) t: f64,
    pub(super) line: u64,
}

impl Timed<'_> {
    /// One row (the rate known, or its first rows buffered until it is).
    pub(super) fn row(&mut self, row: TimedRow<'_>, path: &str, emit: &mut RowSink<'_>) -> Result<(), RecordingError> {
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
    pub(super) fn finish(&mut self, path: &str, emit: &mut RowSink<'_>) -> Result<(), RecordingError> {
        if self.rate == 0.0 && !self.pending.is_empty() {
            self.flush(path, emit)?;
        }
        Ok(())
    }

    pub(super) fn flush(&mut self, path: &str, emit: &mut RowSink<'_>) -> Result<(), RecordingError> {
        self.rate = median_rate(&self.pending, path, self.column)?;
        for (line, values, temp, t) in std::mem::take(&mut self.pending) {
            self.deliver(TimedRow { values: &values, temp, t, line }, path, emit)?;
        }
        Ok(())
    }

    pub(super) fn deliver(
        &mut self,
        row: TimedRow<'_>,
        path: &str,
        emit: &mut RowSink<'_>,
    ) -> Result<(), RecordingError> {
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

pub(super) fn median_rate(
    rows: &[(u64, Vec<f64>, Option<f64>, f64)],
    path: &str,
    column: &str,
) -> Result<f64, RecordingError> {
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
    Ok(1.0 / octavar_stats::robust::median_in_place(&mut steps))
}

//! `read(path, column, ...)`: a recording in any format `octavar analyze` reads (CSV or CSV.gz, NI TDMS, ROS 2
//! bags in MCAP or SQLite, ROS 1 bags, a device capture's raw samples, raw little-endian samples), with the same
//! options as the command's flags, through the same readers. Each channel comes back in its quantity's unit
//! (deg/s for a gyro column, m/s^2 for an accelerometer column), NaN where a sample is missing.

use std::path::PathBuf;

use numpy::PyArray1;
use octavar::io::csv::rows::Delimiter;
use octavar::io::csv::{CsvOptions, RowFilter};
use octavar::io::formats::{self, ReadOptions, RecordingFormat};
use octavar::io::recording::{AccelUnit, RateUnit};
use pyo3::prelude::*;

use crate::errors::{read_error, value_error};

/// What `read` hands the Python half: one array per channel (each takes over the reader's vector, no copy), the
/// rate, the temperature, the channel names and the source.
type Read<'py> = (Vec<Bound<'py, PyArray1<f64>>>, f64, Option<Bound<'py, PyArray1<f64>>>, Vec<String>, String);

/// Read the channels `columns` (rate) and `accel_columns` of the recording at `path`.
#[pyfunction]
#[pyo3(signature = (path, columns, accel_columns, rate, time_column, unit, accel_unit, format, topic, temp_column,
    skip_rows, filters, delimiter, decimal_comma, flexible, channels))]
#[allow(clippy::too_many_arguments)]
pub fn read<'py>(
    py: Python<'py>,
    path: PathBuf,
    columns: Vec<String>,
    accel_columns: Vec<String>,
    rate: Option<f64>,
    time_column: Option<String>,
    unit: &str,
    accel_unit: &str,
    format: Option<String>,
    topic: Option<String>,
    temp_column: Option<String>,
    skip_rows: usize,
    filters: Vec<String>,
    delimiter: Option<String>,
    decimal_comma: bool,
    flexible: bool,
    channels: usize,
) -> PyResult<Read<'py>> {
    let format = RecordingFormat::of(&path, format.as_deref()).ok_or_else(|| {
        value_error(format!("format {format:?}: use csv, tdms, mcap, db3, bag, capture, f64le, f32le, i16le or u16le"))
    })?;
    let bag = matches!(format, RecordingFormat::Mcap | RecordingFormat::Db3 | RecordingFormat::Ros1Bag);
    if columns.is_empty() && accel_columns.is_empty() && !bag {
        let what = if format == RecordingFormat::Tdms { "'GROUP/CHANNEL' of a TDMS file" } else { "a column's name" };
        return Err(value_error(format!("column= is required for this input: give {what}")));
    }
    if let Some(r) = rate.filter(|r| !(*r > 0.0 && r.is_finite())) {
        return Err(value_error(format!("rate must be a positive, finite number of samples per second, got {r}")));
    }
    let csv = CsvOptions {
        columns,
        accel_columns,
        accel_unit: AccelUnit::parse(accel_unit).map_err(|e| value_error(e.to_string()))?,
        temp_column,
        rate_hz: rate,
        time_column,
        unit: RateUnit::parse(unit).map_err(|e| value_error(e.to_string()))?,
        skip_rows,
        filters: filters
            .iter()
            .map(|f| RowFilter::parse(f))
            .collect::<Result<_, _>>()
            .map_err(|e| value_error(e.to_string()))?,
        delimiter: delimiter.as_deref().map(Delimiter::parse).transpose().map_err(value_error)?,
        decimal_comma: decimal_comma.then_some(true),
        flexible,
    };
    let opts = ReadOptions { csv, topic, channels: channels.max(1) };
    let rec = py.detach(|| formats::read_recording(&path, format, &opts)).map_err(read_error)?;
    let arrays = rec.channels.into_iter().map(|c| PyArray1::from_vec(py, c)).collect();
    let temp = rec.temp_c.map(|t| PyArray1::from_vec(py, t));
    Ok((arrays, rec.rate_hz, temp, rec.names, rec.source))
}

//! Reading rate channels from National Instruments TDMS files (LabVIEW, DAQmx logging, nptdms) into a
//! [`Recording`].
//!
//! Each requested `group/channel` becomes one series in deg/s, with the channel's NI scaling applied (the
//! `NI_Scale[n]` properties: Linear, Polynomial, Add, Subtract and AdvancedAPI scales, chained through their input
//! sources, unless `NI_Scaling_Status` says the data is already scaled) and the sample rate taken from the
//! channel's `wf_increment`. The reader follows NI's published format: any number of segments, metadata carried
//! over from earlier segments (segments without metadata, raw data indexes marked "same as previous", objects
//! appended to the previous list), interleaved data, big-endian segments, and a final segment whose length was
//! never written (a crashed writer), of which the whole chunks are read. The file is read into memory; one walk
//! over the segments finds where the requested channels' values are, then each channel is decoded, scaled and
//! converted straight into an array of its final size (the channels in parallel), and the rest is skipped.
//!
//! It does not read DAQmx raw data (the raw data index `0x69120000`/`0x69130000`: scaler-encoded samples), string,
//! boolean, time stamp or complex channels, or scale types that need a sensor model (thermocouple, RTD, strain,
//! table, thermistor): each is an error that names the channel, never data read unscaled or misread. A
//! `.tdms_index` file is never needed (everything it holds is in the `.tdms` file) and is not read. A file that
//! ends inside a segment whose length is written, or whose sizes do not add up, is an error that gives the segment
//! (counted from 1) and the byte offset.

mod data;
mod format;
mod metadata;
mod scaling;
mod segment;
#[cfg(test)]
mod tests;

use std::path::Path;

use rayon::prelude::*;

use crate::recording::{RateUnit, Recording, StreamInfo};

use data::{is_numeric, type_name};
use metadata::Prop;
use scaling::{Scale, ScaleFault};
use segment::FileReader;

/// What went wrong, and where.
#[derive(Debug, thiserror::Error)]
pub enum TdmsError {
    /// The file cannot be read.
    #[error("reading {path}: {err}")]
    Io { path: String, err: std::io::Error },
    /// The file does not start with a TDMS segment.
    #[error("{path}: not a TDMS file (it starts with {start}, not \"TDSm\")")]
    NotTdms { path: String, start: String },
    /// A `.tdms_index` file, which holds metadata only.
    #[error(
        "{path}: a TDMS index file (it starts with \"TDSh\"); give the .tdms file beside it, which holds the data"
    )]
    IndexFile { path: String },
    /// The file ends inside a segment.
    #[error(
        "{path}, byte {offset} (segment {segment}, which starts at byte {start}): the file is truncated: {message}"
    )]
    Truncated { path: String, segment: usize, start: u64, offset: u64, message: String },
    /// Bytes that do not follow the format.
    #[error("{path}, byte {offset} (segment {segment}, which starts at byte {start}): corrupt: {message}")]
    Corrupt { path: String, segment: usize, start: u64, offset: u64, message: String },
    /// DAQmx raw data, which needs the DAQmx scalers to decode.
    #[error(
        "{path}, byte {offset} (segment {segment}): {object} holds DAQmx raw data, which octavar does not read \
         (log the task's scaled data, or convert the file to plain TDMS with NI's tools)"
    )]
    Daqmx { path: String, segment: usize, offset: u64, object: String },
    /// No channel was asked for.
    #[error("{path}: no channel asked for (give --column 'group/channel'; the file has: {available})")]
    NoColumns { path: String, available: String },
    /// A requested channel is not in the file.
    #[error("{path}: no channel {column:?} (the file has: {available})")]
    MissingChannel { path: String, column: String, available: String },
    /// Two channels whose `group/channel` names are the same string.
    #[error("{path}: {column:?} names two channels: {first} and {second}")]
    Ambiguous { path: String, column: String, first: String, second: String },
    /// A requested channel whose values are not numbers.
    #[error("{path}: channel {channel:?} holds {data_type} values, not numbers")]
    NotNumeric { path: String, channel: String, data_type: String },
    /// A requested channel without samples.
    #[error("{path}: channel {channel:?} holds no samples")]
    Empty { path: String, channel: String },
    /// Requested channels of different lengths.
    #[error("{path}: channels {first:?} ({first_len} samples) and {second:?} ({second_len} samples) differ in length")]
    UnequalLengths { path: String, first: String, first_len: usize, second: String, second_len: usize },
    /// A scale type octavar does not apply.
    #[error(
        "{path}: channel {channel:?}: scale {index} is of type {scale_type:?}, which octavar does not apply (it \
         applies Linear, Polynomial, Add, Subtract and AdvancedAPI scales); export the channel scaled"
    )]
    UnsupportedScale { path: String, channel: String, index: u32, scale_type: String },
    /// Scaling properties that do not make a scale.
    #[error("{path}: channel {channel:?}: {message}")]
    BadScale { path: String, channel: String, message: String },
    /// The file's sample interval and `--rate` disagree.
    #[error("{path}: channel {channel:?} has wf_increment {increment} s ({file_hz} Hz), but --rate is {given_hz} Hz")]
    RateMismatch { path: String, channel: String, increment: f64, file_hz: f64, given_hz: f64 },
    /// Requested channels with different sample intervals.
    #[error(
        "{path}: channels {first:?} (wf_increment {first_increment} s) and {second:?} (wf_increment \
         {second_increment} s) have different sample intervals"
    )]
    IncrementMismatch { path: String, first: String, first_increment: f64, second: String, second_increment: f64 },
    /// A `wf_increment` that is not a positive number of seconds.
    #[error("{path}: channel {channel:?} has wf_increment {increment}, which is not a positive number of seconds")]
    BadIncrement { path: String, channel: String, increment: String },
    /// Neither `wf_increment` nor `--rate`.
    #[error("{path}: no sample rate: the channels have no wf_increment property; give --rate HZ")]
    NoRate { path: String },
    /// A `--rate` that is not a positive number.
    #[error("sample rate {0} Hz must be a positive number")]
    BadRate(f64),
    /// An infinite value (after scaling): no sensor reports one, and it would poison every sum.
    #[error("{path}: channel {channel:?}, sample {index}: {value} is not finite")]
    NotFinite { path: String, channel: String, index: usize, value: f64 },
}

/// Read `columns` (each `group/channel`) of the TDMS file at `path` as a recording in deg/s.
///
/// Values are scaled by the channel's NI scales, then converted from `unit`. The rate is `1 / wf_increment` of the
/// channels (which must agree); `rate_hz` is needed where they have none, and must agree with it (to 1e-6
/// relative) where they have one. NaN samples are gaps.
///
/// # Errors
/// A [`TdmsError`] naming the file and what is wrong: for a damaged file the segment and byte offset, for a missing
/// channel the channels the file has.
pub fn read_tdms(
    path: &Path,
    columns: &[String],
    unit: RateUnit,
    rate_hz: Option<f64>,
) -> Result<Recording, TdmsError> {
    let source = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|err| TdmsError::Io { path: source.clone(), err })?;
    read_bytes(&bytes, &source, columns, unit, rate_hz)
}

/// [`read_tdms`] on the file's bytes; `source` names it in the recording and the errors.
fn read_bytes(
    bytes: &[u8],
    source: &str,
    columns: &[String],
    unit: RateUnit,
    rate_hz: Option<f64>,
) -> Result<Recording, TdmsError> {
    if let Some(r) = rate_hz {
        if !(r > 0.0) || !r.is_finite() {
            return Err(TdmsError::BadRate(r));
        }
    }
    let mut file = FileReader::new(bytes, source, columns);
    file.read_segments()?;
    if columns.is_empty() {
        return Err(TdmsError::NoColumns { path: source.to_string(), available: file.channel_list() });
    }
    let objects = column_objects(&file, columns, source)?;
    let len = common_length(&file, columns, &objects, source)?;
    let rate = sample_rate(&file, columns, &objects, rate_hz, source)?;
    // Each distinct series with its scale, then decoded (in parallel) into its final place in one pass.
    let series = scaled_series(&file, columns, &objects, source)?;
    let (mut done, gaps) = decode_series(&file, series, len, unit.to_dps(), columns.len(), source)?;
    let (channels, repeated_gaps) = column_channels(&objects, &mut done);
    let gaps = gaps + repeated_gaps;
    let info = StreamInfo { columns: columns.to_vec(), rate_hz: rate, samples: len as u64, gaps, filtered_out: 0 };
    Ok(Recording {
        source: source.to_string(),
        names: columns.to_vec(),
        channels,
        quantities: Vec::new(),
        temp_c: None,
        rate_hz: rate,
        info,
    })
}

/// Each column's object and series (a repeat shares the first's); a missing or non-numeric channel is an error.
fn column_objects(file: &FileReader, columns: &[String], source: &str) -> Result<Vec<(usize, usize)>, TdmsError> {
    let path = || source.to_string();
    let mut objects = Vec::with_capacity(columns.len());
    for (i, column) in columns.iter().enumerate() {
        let slot = file.wanted.get(column.as_str()).copied().unwrap_or(i);
        match file.slot_object[slot] {
            Some(id) => objects.push((id, slot)),
            None => {
                return Err(TdmsError::MissingChannel {
                    path: path(),
                    column: column.clone(),
                    available: file.channel_list(),
                })
            }
        }
    }
    for (column, &(id, _)) in columns.iter().zip(&objects) {
        if let Some(index) = file.objects[id].index {
            if !is_numeric(index.data_type) {
                return Err(TdmsError::NotNumeric {
                    path: path(),
                    channel: column.clone(),
                    data_type: type_name(index.data_type),
                });
            }
        }
    }
    Ok(objects)
}

/// The columns' common number of samples; columns of different lengths, or without samples, are an error.
fn common_length(
    file: &FileReader,
    columns: &[String],
    objects: &[(usize, usize)],
    source: &str,
) -> Result<usize, TdmsError> {
    let path = || source.to_string();
    let len = file.lengths[objects[0].1];
    for (column, &(_, slot)) in columns.iter().zip(objects) {
        let n = file.lengths[slot];
        if n != len {
            return Err(TdmsError::UnequalLengths {
                path: path(),
                first: columns[0].clone(),
                first_len: len,
                second: column.clone(),
                second_len: n,
            });
        }
    }
    if len == 0 {
        return Err(TdmsError::Empty { path: path(), channel: columns[0].clone() });
    }
    Ok(len)
}

/// A distinct series to decode: its slot, the first column that names it, and its scale.
type SeriesPlan<'c> = (usize, &'c String, Option<Scale>);

/// Each distinct series with its scale; a scale octavar cannot apply is an error.
fn scaled_series<'c>(
    file: &FileReader,
    columns: &'c [String],
    objects: &[(usize, usize)],
    source: &str,
) -> Result<Vec<SeriesPlan<'c>>, TdmsError> {
    let path = || source.to_string();
    let mut series = Vec::new();
    for (column, &(id, slot)) in columns.iter().zip(objects) {
        if series.iter().any(|&(s, _, _)| s == slot) {
            continue;
        }
        let scale = file.scale_of(id).map_err(|fault| match fault {
            ScaleFault::Unsupported { index, scale_type } => {
                TdmsError::UnsupportedScale { path: path(), channel: column.clone(), index, scale_type }
            }
            ScaleFault::Bad(message) => TdmsError::BadScale { path: path(), channel: column.clone(), message },
        })?;
        series.push((slot, column, scale));
    }
    Ok(series)
}

/// The decoded values of each slot (`None` where no series has that slot).
type SlotValues = Vec<Option<Vec<f64>>>;

/// Decode, scale and convert each series in parallel: the values by slot, and their NaNs; an infinity is an error.
fn decode_series(
    file: &FileReader,
    series: Vec<SeriesPlan<'_>>,
    len: usize,
    to_dps: f64,
    slots: usize,
    source: &str,
) -> Result<(SlotValues, u64), TdmsError> {
    let path = || source.to_string();
    // Each series' slot, values and NaN count; the errors in column order, whichever thread met them first.
    type Decoded = (usize, Vec<f64>, u64);
    let decoded: Vec<Result<Decoded, TdmsError>> = series
        .into_par_iter()
        .map(|(slot, column, scale)| {
            let mut values = Vec::with_capacity(len);
            let mut gaps = 0u64;
            for job in file.jobs.iter().filter(|j| j.slot == slot) {
                let from = values.len();
                job.decode(file.bytes, &mut values);
                let new = &mut values[from..];
                let (nan, inf) = match &scale {
                    Some(s) => finish(new, |v| s.apply(v) * to_dps),
                    None if to_dps != 1.0 => finish(new, |v| v * to_dps),
                    None => finish(new, |v| v),
                };
                gaps += nan;
                if inf {
                    let at = new.iter().position(|v| v.is_infinite()).unwrap_or(0);
                    return Err(TdmsError::NotFinite {
                        path: path(),
                        channel: column.clone(),
                        index: from + at,
                        value: new[at],
                    });
                }
            }
            Ok((slot, values, gaps))
        })
        .collect();
    let mut done: SlotValues = vec![None; slots];
    let mut gaps = 0;
    for d in decoded {
        let (slot, values, nan) = d?;
        done[slot] = Some(values);
        gaps += nan;
    }
    Ok((done, gaps))
}

/// Each column's channel from the decoded series `done`, and the gaps of the repeated columns.
fn column_channels(objects: &[(usize, usize)], done: &mut [Option<Vec<f64>>]) -> (Vec<Vec<f64>>, u64) {
    // A repeated column is a copy of the first, and its gaps count again.
    let mut gaps = 0;
    let mut channels = Vec::with_capacity(objects.len());
    for (i, &(_, slot)) in objects.iter().enumerate() {
        let first = objects[..i].iter().any(|o| o.1 == slot);
        let again = objects[i + 1..].iter().any(|o| o.1 == slot);
        let values = if again { done[slot].clone() } else { done[slot].take() }.unwrap_or_default();
        if first {
            gaps += values.iter().filter(|v| v.is_nan()).count() as u64;
        }
        channels.push(values);
    }
    (channels, gaps)
}

/// Apply `f` to each value in place: the NaNs among the results, and whether one is infinite.
fn finish(values: &mut [f64], f: impl Fn(f64) -> f64) -> (u64, bool) {
    let (mut nan, mut inf) = (0u64, false);
    for v in values {
        let x = f(*v);
        *v = x;
        nan += u64::from(x.is_nan());
        inf |= x.is_infinite();
    }
    (nan, inf)
}

/// The sample rate from the channels' `wf_increment` and `--rate`.
fn sample_rate(
    file: &FileReader,
    columns: &[String],
    objects: &[(usize, usize)],
    rate_hz: Option<f64>,
    source: &str,
) -> Result<f64, TdmsError> {
    let path = || source.to_string();
    let mut increment: Option<(f64, &String)> = None;
    for (column, &(id, _)) in columns.iter().zip(objects) {
        let Some(prop) = file.objects[id].props.get("wf_increment") else { continue };
        let inc = match prop {
            Prop::Num(v) if *v > 0.0 && v.is_finite() => *v,
            other => {
                return Err(TdmsError::BadIncrement { path: path(), channel: column.clone(), increment: other.show() })
            }
        };
        match increment {
            None => increment = Some((inc, column)),
            Some((first, first_column)) if (inc - first).abs() > 1e-6 * first => {
                return Err(TdmsError::IncrementMismatch {
                    path: path(),
                    first: first_column.clone(),
                    first_increment: first,
                    second: column.clone(),
                    second_increment: inc,
                });
            }
            Some(_) => {}
        }
    }
    match (increment, rate_hz) {
        (Some((inc, column)), Some(given)) => {
            let file_hz = 1.0 / inc;
            if (file_hz - given).abs() > 1e-6 * file_hz {
                return Err(TdmsError::RateMismatch {
                    path: path(),
                    channel: column.clone(),
                    increment: inc,
                    file_hz,
                    given_hz: given,
                });
            }
            Ok(file_hz)
        }
        (Some((inc, _)), None) => Ok(1.0 / inc),
        (None, Some(given)) => Ok(given),
        (None, None) => Err(TdmsError::NoRate { path: path() }),
    }
}

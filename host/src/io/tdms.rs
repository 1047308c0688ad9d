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

use std::collections::HashMap;
use std::path::Path;

use rayon::prelude::*;

use crate::io::csv::{RateUnit, Recording, StreamInfo};

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
    let path = || source.to_string();
    if columns.is_empty() {
        return Err(TdmsError::NoColumns { path: path(), available: file.channel_list() });
    }

    // Each column's object and series (a repeated column shares the first one's).
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
    let len = file.lengths[objects[0].1];
    for (column, &(_, slot)) in columns.iter().zip(&objects) {
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

    let rate = sample_rate(&file, columns, &objects, rate_hz, source)?;

    // Each distinct series with its scale, then decoded (in parallel) into its final place in one pass.
    let mut series = Vec::new();
    for (column, &(id, slot)) in columns.iter().zip(&objects) {
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
    let to_dps = unit.to_dps();
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
    let mut done: Vec<Option<Vec<f64>>> = vec![None; columns.len()];
    let mut gaps = 0;
    for d in decoded {
        let (slot, values, nan) = d?;
        done[slot] = Some(values);
        gaps += nan;
    }
    // A repeated column is a copy of the first, and its gaps count again.
    let mut channels = Vec::with_capacity(columns.len());
    for (i, &(_, slot)) in objects.iter().enumerate() {
        let first = objects[..i].iter().any(|o| o.1 == slot);
        let again = objects[i + 1..].iter().any(|o| o.1 == slot);
        let values = if again { done[slot].clone() } else { done[slot].take() }.unwrap_or_default();
        if first {
            gaps += values.iter().filter(|v| v.is_nan()).count() as u64;
        }
        channels.push(values);
    }
    let info = StreamInfo { columns: columns.to_vec(), rate_hz: rate, samples: len as u64, gaps, filtered_out: 0 };
    Ok(Recording { source: source.to_string(), names: columns.to_vec(), channels, temp_c: None, rate_hz: rate, info })
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

// The lead-in's table of contents flags.
const TOC_META_DATA: u32 = 1 << 1;
const TOC_NEW_OBJ_LIST: u32 = 1 << 2;
const TOC_RAW_DATA: u32 = 1 << 3;
const TOC_INTERLEAVED: u32 = 1 << 5;
const TOC_BIG_ENDIAN: u32 = 1 << 6;
const TOC_DAQMX_RAW_DATA: u32 = 1 << 7;
/// Bytes of a segment's lead-in: tag, table of contents, version, next segment offset, raw data offset.
const LEAD_IN: usize = 28;
/// The next segment offset of a segment whose writer never finished it: the segment runs to the end of the file.
const LENGTH_UNWRITTEN: u64 = u64::MAX;
// Raw data index headers with a meaning of their own.
const INDEX_NO_DATA: u32 = 0xFFFF_FFFF;
const INDEX_SAME_AS_PREVIOUS: u32 = 0;
const INDEX_DAQMX_FORMAT_CHANGING: u32 = 0x6912_0000;
const INDEX_DAQMX_DIGITAL_LINE: u32 = 0x6913_0000;
// Data type codes.
const TYPE_STRING: u32 = 0x20;
const TYPE_DAQMX: u32 = 0xFFFF_FFFF;

/// Bytes per value of a data type, where it has a fixed size.
fn type_size(code: u32) -> Option<u64> {
    Some(match code {
        0 => 0,
        1 | 5 | 0x21 => 1,
        2 | 6 => 2,
        3 | 7 | 9 | 0x19 => 4,
        4 | 8 | 10 | 0x1A | 0x08_000C => 8,
        0x44 | 0x10_000D => 16,
        _ => return None,
    })
}

/// Whether a data type is a real number octavar reads.
fn is_numeric(code: u32) -> bool {
    matches!(code, 1..=10 | 0x19 | 0x1A)
}

/// A data type's name, for errors.
fn type_name(code: u32) -> String {
    match code {
        0 => "void",
        1 => "i8",
        2 => "i16",
        3 => "i32",
        4 => "i64",
        5 => "u8",
        6 => "u16",
        7 => "u32",
        8 => "u64",
        9 => "f32",
        10 => "f64",
        11 => "extended float",
        0x19 => "f32 with unit",
        0x1A => "f64 with unit",
        0x1B => "extended float with unit",
        TYPE_STRING => "string",
        0x21 => "boolean",
        0x44 => "time stamp",
        0x4F => "fixed point",
        0x08_000C => "complex f32",
        0x10_000D => "complex f64",
        TYPE_DAQMX => "DAQmx raw",
        other => return format!("unknown (type code {other:#x})"),
    }
    .to_string()
}

/// A property's value.
#[derive(Clone, Debug, PartialEq)]
enum Prop {
    /// Any integer or real number.
    Num(f64),
    /// A string.
    Str(String),
    /// A value octavar has no use for (boolean, time stamp, complex), by type name.
    Other(&'static str),
}

impl Prop {
    fn num(&self) -> Option<f64> {
        match self {
            Prop::Num(v) => Some(*v),
            _ => None,
        }
    }

    fn show(&self) -> String {
        match self {
            Prop::Num(v) => v.to_string(),
            Prop::Str(s) => format!("{s:?}"),
            Prop::Other(t) => format!("a {t}"),
        }
    }
}

/// Where an object's values are in each chunk of a segment with data.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct RawIndex {
    data_type: u32,
    values: u64,
    bytes: u64,
}

/// One object (root, group or channel) of the file, with what the segments so far have said about it.
#[derive(Debug)]
struct Object {
    path: String,
    /// Group and channel names; the channel is `None` for the root and for a group.
    group: Option<String>,
    channel: Option<String>,
    props: HashMap<String, Prop>,
    /// The latest raw data index, which a later "same as previous" index reuses.
    index: Option<RawIndex>,
    /// The requested column whose series this channel's values go to.
    slot: Option<usize>,
    /// Position in the current segment's object list.
    in_list: Option<usize>,
}

/// A fault in a segment, before the file's name and the segment are put to it.
enum Fault {
    Corrupt { offset: usize, message: String },
    Truncated { offset: usize, message: String },
    Daqmx { offset: usize, object: String },
    NotNumeric { channel: String, data_type: String },
    Ambiguous { column: String, first: String, second: String },
}

/// A scale that cannot be applied.
enum ScaleFault {
    Unsupported { index: u32, scale_type: String },
    Bad(String),
}

/// The parser's state across segments.
struct FileReader<'a> {
    bytes: &'a [u8],
    source: &'a str,
    /// Requested column name -> its first slot.
    wanted: HashMap<&'a str, usize>,
    objects: Vec<Object>,
    by_path: HashMap<String, usize>,
    /// The current segment's objects, in order, and whether each has data in it.
    list: Vec<(usize, bool)>,
    /// Whether a segment has set the object list.
    have_list: bool,
    /// Where each requested channel's values are, segment by segment.
    jobs: Vec<Job>,
    /// Values per slot.
    lengths: Vec<usize>,
    /// The object of each slot.
    slot_object: Vec<Option<usize>>,
}

/// A bounded reader of a segment's metadata.
struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
    end: usize,
    big: bool,
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], Fault> {
        if self.end - self.pos < n {
            return Err(Fault::Corrupt {
                offset: self.pos,
                message: format!("{what} needs {n} bytes, but the segment's metadata has {} left", self.end - self.pos),
            });
        }
        let s = &self.bytes[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    fn array<const N: usize>(&mut self, what: &str) -> Result<[u8; N], Fault> {
        let mut a: [u8; N] = self.take(N, what)?.try_into().unwrap_or([0; N]);
        if self.big {
            a.reverse();
        }
        Ok(a)
    }

    fn u32(&mut self, what: &str) -> Result<u32, Fault> {
        self.array::<4>(what).map(u32::from_le_bytes)
    }

    fn u64(&mut self, what: &str) -> Result<u64, Fault> {
        self.array::<8>(what).map(u64::from_le_bytes)
    }

    fn string(&mut self, what: &str) -> Result<String, Fault> {
        let at = self.pos;
        let n = self.u32(what)? as usize;
        if self.end - self.pos < n {
            return Err(Fault::Corrupt {
                offset: at,
                message: format!("{what} of {n} bytes runs past the segment's metadata"),
            });
        }
        Ok(String::from_utf8_lossy(self.take(n, what)?).into_owned())
    }

    /// A property value of data type `code`.
    fn prop(&mut self, code: u32, name: &str) -> Result<Prop, Fault> {
        let what = format!("property {name:?}");
        let at = self.pos;
        Ok(match code {
            1 => Prop::Num(f64::from(i8::from_le_bytes(self.array::<1>(&what)?))),
            2 => Prop::Num(f64::from(i16::from_le_bytes(self.array::<2>(&what)?))),
            3 => Prop::Num(f64::from(i32::from_le_bytes(self.array::<4>(&what)?))),
            4 => Prop::Num(i64::from_le_bytes(self.array::<8>(&what)?) as f64),
            5 => Prop::Num(f64::from(self.array::<1>(&what)?[0])),
            6 => Prop::Num(f64::from(u16::from_le_bytes(self.array::<2>(&what)?))),
            7 => Prop::Num(f64::from(u32::from_le_bytes(self.array::<4>(&what)?))),
            8 => Prop::Num(u64::from_le_bytes(self.array::<8>(&what)?) as f64),
            9 | 0x19 => Prop::Num(f64::from(f32::from_le_bytes(self.array::<4>(&what)?))),
            10 | 0x1A => Prop::Num(f64::from_le_bytes(self.array::<8>(&what)?)),
            TYPE_STRING => Prop::Str(self.string(&what)?),
            0x21 => {
                self.take(1, &what)?;
                Prop::Other("boolean")
            }
            0x44 => {
                self.take(16, &what)?;
                Prop::Other("time stamp")
            }
            0x08_000C => {
                self.take(8, &what)?;
                Prop::Other("complex f32")
            }
            0x10_000D => {
                self.take(16, &what)?;
                Prop::Other("complex f64")
            }
            other => {
                return Err(Fault::Corrupt {
                    offset: at,
                    message: format!("property {name:?} has data type {}, which has no known size", type_name(other)),
                })
            }
        })
    }
}

impl<'a> FileReader<'a> {
    fn new(bytes: &'a [u8], source: &'a str, columns: &'a [String]) -> FileReader<'a> {
        let mut wanted = HashMap::new();
        for (i, c) in columns.iter().enumerate() {
            wanted.entry(c.as_str()).or_insert(i);
        }
        FileReader {
            bytes,
            source,
            wanted,
            objects: Vec::new(),
            by_path: HashMap::new(),
            list: Vec::new(),
            have_list: false,
            jobs: Vec::new(),
            lengths: vec![0; columns.len()],
            slot_object: vec![None; columns.len()],
        }
    }

    /// The file's channels as `group/channel`, in order of appearance.
    fn channel_list(&self) -> String {
        const SHOWN: usize = 60;
        let names: Vec<String> = self
            .objects
            .iter()
            .filter_map(|o| Some(format!("{}/{}", o.group.as_ref()?, o.channel.as_ref()?)))
            .collect();
        if names.is_empty() {
            return "no channels".to_string();
        }
        let mut s = names.iter().take(SHOWN).map(String::as_str).collect::<Vec<_>>().join(", ");
        if names.len() > SHOWN {
            s += &format!(" and {} more", names.len() - SHOWN);
        }
        s
    }

    /// Walk every segment, decoding the requested channels.
    fn read_segments(&mut self) -> Result<(), TdmsError> {
        let len = self.bytes.len();
        let start = &self.bytes[..len.min(4)];
        if start == b"TDSh" {
            return Err(TdmsError::IndexFile { path: self.source.to_string() });
        }
        // A file cut inside its first tag is a truncated TDMS file, not another kind of file.
        if len == 0 || !b"TDSm".starts_with(start) {
            let start = if len == 0 { "nothing: the file is empty".to_string() } else { show_bytes(start) };
            return Err(TdmsError::NotTdms { path: self.source.to_string(), start });
        }
        let mut pos = 0usize;
        let mut segment = 1usize;
        while pos < len {
            match self.read_segment(pos, segment) {
                Ok(next) => pos = next,
                Err(fault) => return Err(self.locate(fault, segment, pos)),
            }
            segment += 1;
        }
        Ok(())
    }

    /// The error for a fault in the segment that starts at `start`.
    fn locate(&self, fault: Fault, segment: usize, start: usize) -> TdmsError {
        let path = self.source.to_string();
        let start = start as u64;
        match fault {
            Fault::Corrupt { offset, message } => {
                TdmsError::Corrupt { path, segment, start, offset: offset as u64, message }
            }
            Fault::Truncated { offset, message } => {
                TdmsError::Truncated { path, segment, start, offset: offset as u64, message }
            }
            Fault::Daqmx { offset, object } => TdmsError::Daqmx { path, segment, offset: offset as u64, object },
            Fault::NotNumeric { channel, data_type } => TdmsError::NotNumeric { path, channel, data_type },
            Fault::Ambiguous { column, first, second } => TdmsError::Ambiguous { path, column, first, second },
        }
    }

    /// Read the segment at `pos`; the position of the next one.
    fn read_segment(&mut self, pos: usize, segment: usize) -> Result<usize, Fault> {
        let bytes = self.bytes;
        let len = bytes.len();
        let corrupt = |offset: usize, message: String| Fault::Corrupt { offset, message };
        if len - pos < LEAD_IN {
            return Err(Fault::Truncated {
                offset: len,
                message: format!("the file ends {} bytes into the segment's {LEAD_IN}-byte lead-in", len - pos),
            });
        }
        let tag = &bytes[pos..pos + 4];
        if tag != b"TDSm" {
            return Err(corrupt(
                pos,
                format!(
                    "no segment tag \"TDSm\" (found {}){}",
                    show_bytes(tag),
                    if segment > 1 { "; the previous segment's length is wrong, or the file is damaged" } else { "" }
                ),
            ));
        }
        let toc = u32::from_le_bytes(bytes[pos + 4..pos + 8].try_into().unwrap_or([0; 4]));
        let mut lead = Cursor { bytes, pos: pos + 8, end: pos + LEAD_IN, big: toc & TOC_BIG_ENDIAN != 0 };
        let version = lead.u32("the version")?;
        let next_offset = lead.u64("the next segment offset")?;
        let raw_offset = lead.u64("the raw data offset")?;
        if version != 4712 && version != 4713 {
            return Err(corrupt(pos + 8, format!("version {version} is not a TDMS version (4712 or 4713)")));
        }
        let meta_start = pos + LEAD_IN;
        let unwritten = next_offset == LENGTH_UNWRITTEN;
        let end = if unwritten {
            len
        } else {
            match usize::try_from(next_offset).ok().and_then(|n| meta_start.checked_add(n)) {
                Some(end) if end <= len => end,
                _ => {
                    return Err(Fault::Truncated {
                        offset: len,
                        message: format!(
                            "the segment's lead-in says {next_offset} bytes follow it, but the file ends {} bytes \
                             after it",
                            len - meta_start
                        ),
                    })
                }
            }
        };
        let data_start = match usize::try_from(raw_offset).ok().and_then(|n| meta_start.checked_add(n)) {
            Some(d) if d <= end => d,
            _ => {
                return Err(corrupt(
                    pos + 20,
                    format!(
                        "the raw data offset {raw_offset} is past the segment's end ({} bytes after the lead-in)",
                        end - meta_start
                    ),
                ))
            }
        };
        if toc & TOC_META_DATA != 0 {
            let new_list = toc & TOC_NEW_OBJ_LIST != 0 || !self.have_list;
            let mut cur = Cursor { bytes, pos: meta_start, end: data_start, big: toc & TOC_BIG_ENDIAN != 0 };
            self.read_metadata(&mut cur, new_list)?;
            self.have_list = true;
        } else if toc & TOC_RAW_DATA != 0 && !self.have_list {
            return Err(corrupt(pos + 4, "raw data without metadata, and no earlier segment to take it from".into()));
        }
        if toc & TOC_RAW_DATA != 0 {
            self.read_data(toc, data_start, end, unwritten)?;
        } else if toc & TOC_DAQMX_RAW_DATA != 0 {
            let object = self.list.iter().find(|e| e.1).map_or_else(|| "a channel".to_string(), |e| self.name(e.0));
            return Err(Fault::Daqmx { offset: data_start, object });
        }
        Ok(end)
    }

    /// An object's name for errors: `group/channel`, or its path.
    fn name(&self, id: usize) -> String {
        let o = &self.objects[id];
        match (&o.group, &o.channel) {
            (Some(g), Some(c)) => format!("channel \"{g}/{c}\""),
            _ => format!("object {}", o.path),
        }
    }

    /// The object with this path, registered on first sight.
    fn object_id(&mut self, path: String, at: usize) -> Result<usize, Fault> {
        if let Some(&id) = self.by_path.get(&path) {
            return Ok(id);
        }
        let Some((group, channel)) = parse_path(&path) else {
            return Err(Fault::Corrupt { offset: at, message: format!("{path:?} is not a TDMS object path") });
        };
        let mut slot = None;
        if let (Some(g), Some(c)) = (&group, &channel) {
            let display = format!("{g}/{c}");
            if let Some(&s) = self.wanted.get(display.as_str()) {
                if let Some(other) = self.slot_object[s] {
                    return Err(Fault::Ambiguous {
                        column: display,
                        first: self.objects[other].path.clone(),
                        second: path,
                    });
                }
                slot = Some(s);
            }
        }
        let id = self.objects.len();
        if let Some(s) = slot {
            self.slot_object[s] = Some(id);
        }
        self.by_path.insert(path.clone(), id);
        self.objects.push(Object { path, group, channel, props: HashMap::new(), index: None, slot, in_list: None });
        Ok(id)
    }

    /// Read a segment's metadata, updating the object list and the objects' indexes and properties.
    fn read_metadata(&mut self, cur: &mut Cursor, new_list: bool) -> Result<(), Fault> {
        if new_list {
            for &(id, _) in &self.list {
                self.objects[id].in_list = None;
            }
            self.list.clear();
        }
        let count = cur.u32("the object count")?;
        for _ in 0..count {
            let at = cur.pos;
            let path = cur.string("an object path")?;
            let id = self.object_id(path, at)?;
            let index_at = cur.pos;
            let header = cur.u32("a raw data index")?;
            let has_data = match header {
                INDEX_NO_DATA => false,
                INDEX_SAME_AS_PREVIOUS => {
                    if self.objects[id].index.is_none() {
                        return Err(Fault::Corrupt {
                            offset: index_at,
                            message: format!(
                                "{} reuses the previous raw data index, but none came before",
                                self.name(id)
                            ),
                        });
                    }
                    true
                }
                INDEX_DAQMX_FORMAT_CHANGING | INDEX_DAQMX_DIGITAL_LINE => {
                    return Err(Fault::Daqmx { offset: index_at, object: self.name(id) })
                }
                _ => {
                    let data_type = cur.u32("a data type")?;
                    let dimension = cur.u32("an array dimension")?;
                    let values = cur.u64("a value count")?;
                    if data_type == TYPE_DAQMX {
                        return Err(Fault::Daqmx { offset: index_at, object: self.name(id) });
                    }
                    if data_type == 0 && values != 0 {
                        return Err(Fault::Corrupt {
                            offset: index_at + 4,
                            message: format!("{} has {values} values of type void", self.name(id)),
                        });
                    }
                    if dimension != 1 {
                        return Err(Fault::Corrupt {
                            offset: index_at + 8,
                            message: format!(
                                "{} has array dimension {dimension}, where TDMS has only 1",
                                self.name(id)
                            ),
                        });
                    }
                    let bytes = if data_type == TYPE_STRING {
                        cur.u64("a string data size")?
                    } else if values == 0 {
                        0
                    } else {
                        match type_size(data_type).and_then(|s| s.checked_mul(values)) {
                            Some(b) => b,
                            None => {
                                return Err(Fault::Corrupt {
                                    offset: index_at + 4,
                                    message: format!(
                                        "{} has {values} values of type {}, whose size is unknown or too large",
                                        self.name(id),
                                        type_name(data_type)
                                    ),
                                })
                            }
                        }
                    };
                    self.objects[id].index = Some(RawIndex { data_type, values, bytes });
                    true
                }
            };
            match self.objects[id].in_list {
                Some(i) => self.list[i].1 = has_data,
                None => {
                    self.objects[id].in_list = Some(self.list.len());
                    self.list.push((id, has_data));
                }
            }
            let props = cur.u32("a property count")?;
            for _ in 0..props {
                let name = cur.string("a property name")?;
                let code = cur.u32("a property's data type")?;
                let value = cur.prop(code, &name)?;
                self.objects[id].props.insert(name, value);
            }
        }
        Ok(())
    }

    /// Decode the requested channels' values in the raw data `start..end` of a segment.
    fn read_data(&mut self, toc: u32, start: usize, end: usize, unwritten: bool) -> Result<(), Fault> {
        let mut with_data = Vec::new();
        let mut chunk = 0u64;
        for &(id, has) in &self.list {
            if !has {
                continue;
            }
            let Some(index) = self.objects[id].index else { continue };
            if index.values == 0 {
                continue;
            }
            chunk = chunk.checked_add(index.bytes).ok_or_else(|| Fault::Corrupt {
                offset: start,
                message: "the channels' data sizes overflow".to_string(),
            })?;
            with_data.push((id, index));
        }
        let total = (end - start) as u64;
        if chunk == 0 {
            if total != 0 {
                return Err(Fault::Corrupt {
                    offset: start,
                    message: format!("{total} bytes of raw data, but no channel has data in this segment"),
                });
            }
            return Ok(());
        }
        let (chunks, rest) = (total / chunk, total % chunk);
        if rest != 0 && !unwritten {
            return Err(Fault::Corrupt {
                offset: start,
                message: format!(
                    "{total} bytes of raw data are not a whole number of chunks of {chunk} bytes (the channels' \
                     values)"
                ),
            });
        }
        for &(id, index) in &with_data {
            let o = &self.objects[id];
            if o.slot.is_some() && !is_numeric(index.data_type) {
                return Err(Fault::NotNumeric {
                    channel: format!("{}/{}", o.group.as_deref().unwrap_or(""), o.channel.as_deref().unwrap_or("")),
                    data_type: type_name(index.data_type),
                });
            }
        }
        let big = toc & TOC_BIG_ENDIAN != 0;
        if toc & TOC_INTERLEAVED != 0 {
            let values = with_data[0].1.values;
            let mut width = 0usize;
            for &(id, index) in &with_data {
                if index.values != values {
                    return Err(Fault::Corrupt {
                        offset: start,
                        message: format!(
                            "interleaved data whose channels differ in length ({} has {values} values, {} has {})",
                            self.name(with_data[0].0),
                            self.name(id),
                            index.values
                        ),
                    });
                }
                match type_size(index.data_type) {
                    Some(s) if index.data_type != TYPE_STRING => width += s as usize,
                    _ => {
                        return Err(Fault::Corrupt {
                            offset: start,
                            message: format!(
                                "interleaved data with {} of type {}, which has no fixed size",
                                self.name(id),
                                type_name(index.data_type)
                            ),
                        })
                    }
                }
            }
            // Whole rows only: an unfinished segment may stop inside a chunk.
            let rows = (end - start) / width;
            let mut offset = start;
            for &(id, index) in &with_data {
                if let Some(slot) = self.objects[id].slot {
                    let data_type = index.data_type;
                    let job =
                        Job { slot, data_type, big, start: offset, stride: width, count: rows, runs: 1, run_stride: 0 };
                    self.add(job);
                }
                offset += type_size(index.data_type).unwrap_or(0) as usize;
            }
        } else if chunks > 0 {
            // Every value counted here lies inside `start..end`, so the sizes fit in usize.
            let mut offset = start;
            for &(id, index) in &with_data {
                if let Some(slot) = self.objects[id].slot {
                    let job = Job {
                        slot,
                        data_type: index.data_type,
                        big,
                        start: offset,
                        stride: type_size(index.data_type).unwrap_or(1) as usize,
                        count: index.values as usize,
                        runs: chunks as usize,
                        run_stride: chunk as usize,
                    };
                    self.add(job);
                }
                offset += index.bytes as usize;
            }
        }
        Ok(())
    }

    fn add(&mut self, job: Job) {
        self.lengths[job.slot] += job.count * job.runs;
        self.jobs.push(job);
    }

    /// The scale of a channel: from its own properties, else its group's, else the file's; `None` for none (or
    /// data already scaled).
    fn scale_of(&self, id: usize) -> Result<Option<Scale>, ScaleFault> {
        let o = &self.objects[id];
        let group = o.group.as_ref().and_then(|g| self.by_path.get(&object_path(Some(g))));
        let root = self.by_path.get("/");
        let levels =
            std::iter::once(&o.props).chain([group, root].into_iter().flatten().map(|&i| &self.objects[i].props));
        for props in levels {
            let n = number_of_scales(props)?;
            if n == 0 {
                continue;
            }
            let scaled =
                matches!(props.get("NI_Scaling_Status"), Some(Prop::Str(s)) if s.eq_ignore_ascii_case("scaled"));
            if scaled {
                return Ok(None);
            }
            return build_scale(props, n - 1, n, &mut Vec::new()).map(Some);
        }
        Ok(None)
    }
}

/// Where a requested channel's values are in one segment: `runs` runs (chunks) of `count` values `stride` bytes
/// apart, the runs `run_stride` bytes apart from byte `start` of the file.
#[derive(Clone, Copy, Debug)]
struct Job {
    slot: usize,
    data_type: u32,
    big: bool,
    start: usize,
    stride: usize,
    count: usize,
    runs: usize,
    run_stride: usize,
}

impl Job {
    fn decode(&self, bytes: &[u8], out: &mut Vec<f64>) {
        for r in 0..self.runs {
            decode(self.data_type, self.big, &bytes[self.start + r * self.run_stride..], self.stride, self.count, out);
        }
    }
}

/// Append `count` values of `data_type` to `out`, one every `stride` bytes of `src` from its start.
fn decode(data_type: u32, big: bool, src: &[u8], stride: usize, count: usize, out: &mut Vec<f64>) {
    fn push<const N: usize>(src: &[u8], stride: usize, count: usize, out: &mut Vec<f64>, f: impl Fn([u8; N]) -> f64) {
        if count == 0 {
            return;
        }
        let bytes = |c: &[u8]| -> [u8; N] { c[..N].try_into().unwrap_or([0; N]) };
        if stride == N {
            out.extend(src[..count * N].chunks_exact(N).map(|c| f(bytes(c))));
        } else {
            out.extend(src[..(count - 1) * stride + N].chunks(stride).map(|c| f(bytes(c))));
        }
    }
    macro_rules! number {
        ($t:ty, $n:literal) => {
            if big {
                push::<$n>(src, stride, count, out, |b| <$t>::from_be_bytes(b) as f64)
            } else {
                push::<$n>(src, stride, count, out, |b| <$t>::from_le_bytes(b) as f64)
            }
        };
    }
    match data_type {
        1 => number!(i8, 1),
        2 => number!(i16, 2),
        3 => number!(i32, 4),
        4 => number!(i64, 8),
        5 => number!(u8, 1),
        6 => number!(u16, 2),
        7 => number!(u32, 4),
        8 => number!(u64, 8),
        9 | 0x19 => number!(f32, 4),
        10 | 0x1A => number!(f64, 8),
        _ => {}
    }
}

/// The TDMS path of the root (`None`) or a group.
fn object_path(group: Option<&str>) -> String {
    match group {
        None => "/".to_string(),
        Some(g) => format!("/'{}'", g.replace('\'', "''")),
    }
}

/// Split an object path (`/`, `/'group'`, `/'group'/'channel'`, a quote inside a name doubled) into its group and
/// channel names; `None` where it is not one.
fn parse_path(path: &str) -> Option<(Option<String>, Option<String>)> {
    let mut names = Vec::new();
    let mut chars = path.chars().peekable();
    if path == "/" {
        return Some((None, None));
    }
    while chars.peek().is_some() {
        if chars.next()? != '/' || chars.next()? != '\'' {
            return None;
        }
        let mut name = String::new();
        loop {
            match chars.next()? {
                '\'' if chars.peek() == Some(&'\'') => {
                    chars.next();
                    name.push('\'');
                }
                '\'' => break,
                c => name.push(c),
            }
        }
        names.push(name);
    }
    let mut names = names.into_iter();
    match (names.next(), names.next(), names.next()) {
        (Some(g), c, None) => Some((Some(g), c)),
        _ => None,
    }
}

/// A raw input or a chain of NI scales.
#[derive(Clone, Debug, PartialEq)]
enum Scale {
    Raw,
    Linear {
        slope: f64,
        intercept: f64,
        input: Box<Scale>,
    },
    /// Coefficients from the constant term up.
    Polynomial {
        coefficients: Vec<f64>,
        input: Box<Scale>,
    },
    Add {
        left: Box<Scale>,
        right: Box<Scale>,
    },
    /// `right - left`, as NI's Excel importer and nptdms compute it.
    Subtract {
        left: Box<Scale>,
        right: Box<Scale>,
    },
}

impl Scale {
    fn apply(&self, x: f64) -> f64 {
        match self {
            Scale::Raw => x,
            Scale::Linear { slope, intercept, input } => input.apply(x) * slope + intercept,
            Scale::Polynomial { coefficients, input } => {
                let x = input.apply(x);
                // Horner's rule from the highest power down, as numpy's polyval.
                coefficients
                    .iter()
                    .rev()
                    .fold(None, |acc: Option<f64>, &c| Some(acc.map_or(c, |a| c + a * x)))
                    .unwrap_or(0.0)
            }
            Scale::Add { left, right } => left.apply(x) + right.apply(x),
            Scale::Subtract { left, right } => right.apply(x) - left.apply(x),
        }
    }
}

/// The input source that means the raw data.
const RAW_INPUT: f64 = 4_294_967_295.0;
/// More scales than any writer makes: a count past this is a damaged property.
const MAX_SCALES: u32 = 1024;

/// How many scales the properties define: `NI_Number_Of_Scales`, else one past the highest `NI_Scale[n]_Scale_Type`.
fn number_of_scales(props: &HashMap<String, Prop>) -> Result<u32, ScaleFault> {
    if let Some(p) = props.get("NI_Number_Of_Scales") {
        return match p.num() {
            Some(n) if n >= 0.0 && n <= f64::from(MAX_SCALES) && n.fract() == 0.0 => Ok(n as u32),
            _ => Err(ScaleFault::Bad(format!("NI_Number_Of_Scales is {}, not a count of scales", p.show()))),
        };
    }
    let highest = props
        .keys()
        .filter_map(|k| k.strip_prefix("NI_Scale[")?.strip_suffix("]_Scale_Type")?.parse::<u32>().ok())
        .filter(|&i| i < MAX_SCALES)
        .max();
    Ok(highest.map_or(0, |i| i + 1))
}

/// Scale `index` of `count`, with the scales it takes its input from; `visiting` holds the scales under way.
fn build_scale(
    props: &HashMap<String, Prop>,
    index: u32,
    count: u32,
    visiting: &mut Vec<u32>,
) -> Result<Scale, ScaleFault> {
    let key = |name: &str| format!("NI_Scale[{index}]_{name}");
    let num = |name: &str| -> Result<f64, ScaleFault> {
        let k = key(name);
        match props.get(&k) {
            Some(Prop::Num(v)) => Ok(*v),
            Some(other) => Err(ScaleFault::Bad(format!("{k} is {}, not a number", other.show()))),
            None => Err(ScaleFault::Bad(format!("scale {index} has no {k}"))),
        }
    };
    if visiting.contains(&index) {
        return Err(ScaleFault::Bad(format!("scale {index} takes its own output as input (the input sources loop)")));
    }
    visiting.push(index);
    let input = |name: &str, required: bool, visiting: &mut Vec<u32>| -> Result<Box<Scale>, ScaleFault> {
        let k = key(name);
        let source = match props.get(&k) {
            None if !required => return Ok(Box::new(Scale::Raw)),
            None => return Err(ScaleFault::Bad(format!("scale {index} has no {k}"))),
            Some(p) => p.num().ok_or_else(|| ScaleFault::Bad(format!("{k} is {}, not a number", p.show())))?,
        };
        if source == RAW_INPUT || source == -1.0 {
            return Ok(Box::new(Scale::Raw));
        }
        if !(source >= 0.0) || source >= f64::from(count) || source.fract() != 0.0 {
            return Err(ScaleFault::Bad(format!(
                "{k} is {source}, neither the raw data (4294967295) nor one of the {count} scales"
            )));
        }
        build_scale(props, source as u32, count, visiting).map(Box::new)
    };
    let scale_type = match props.get(&key("Scale_Type")) {
        Some(Prop::Str(s)) => s.clone(),
        Some(other) => {
            return Err(ScaleFault::Bad(format!("{} is {}, not a scale type", key("Scale_Type"), other.show())))
        }
        None => return Err(ScaleFault::Unsupported { index, scale_type: "DAQmx scaler (no Scale_Type)".to_string() }),
    };
    let scale = match scale_type.as_str() {
        "Linear" => Scale::Linear {
            slope: num("Linear_Slope")?,
            intercept: num("Linear_Y_Intercept")?,
            input: input("Linear_Input_Source", false, visiting)?,
        },
        "Polynomial" => {
            let size = match props.get(&key("Polynomial_Coefficients_Size")) {
                None => 4.0,
                Some(_) => num("Polynomial_Coefficients_Size")?,
            };
            if !(size >= 0.0) || size > 64.0 || size.fract() != 0.0 {
                return Err(ScaleFault::Bad(format!(
                    "{} is {size}, not a count of coefficients",
                    key("Polynomial_Coefficients_Size")
                )));
            }
            let coefficients =
                (0..size as u32).map(|k| num(&format!("Polynomial_Coefficients[{k}]"))).collect::<Result<_, _>>()?;
            Scale::Polynomial { coefficients, input: input("Polynomial_Input_Source", false, visiting)? }
        }
        "Add" | "Subtract" => {
            let left = input(&format!("{scale_type}_Left_Operand_Input_Source"), true, visiting)?;
            let right = input(&format!("{scale_type}_Right_Operand_Input_Source"), true, visiting)?;
            if scale_type == "Add" {
                Scale::Add { left, right }
            } else {
                Scale::Subtract { left, right }
            }
        }
        "AdvancedAPI" => *input("AdvancedAPI_Input_Source", false, visiting)?,
        _ => return Err(ScaleFault::Unsupported { index, scale_type }),
    };
    visiting.pop();
    Ok(scale)
}

/// The first bytes of a file, for an error.
fn show_bytes(b: &[u8]) -> String {
    if b.iter().all(|c| c.is_ascii_graphic() || *c == b' ') {
        format!("{:?}", String::from_utf8_lossy(b))
    } else {
        b.iter().map(|c| format!("{c:02x}")).collect::<Vec<_>>().join(" ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    // A TDMS writer written from NI's description of the format, enough to build every case the reader handles.

    /// A raw data index to write.
    #[derive(Clone, Copy)]
    enum Ix {
        NoData,
        Same,
        New(u32, u64),
        /// A string channel: value count and total bytes.
        Strings(u64, u64),
        Daqmx,
    }

    /// A property value to write.
    enum Pv {
        I32(i32),
        U32(u32),
        F64(f64),
        Str(&'static str),
        Bool,
        Time,
    }

    struct Obj {
        path: String,
        index: Ix,
        props: Vec<(String, Pv)>,
    }

    fn obj(path: &str, index: Ix, props: Vec<(&str, Pv)>) -> Obj {
        Obj { path: path.to_string(), index, props: props.into_iter().map(|(k, v)| (k.to_string(), v)).collect() }
    }

    fn chan(group: &str, channel: &str) -> String {
        format!("/'{group}'/'{channel}'")
    }

    struct W {
        out: Vec<u8>,
        big: bool,
    }

    impl W {
        fn u32(&mut self, v: u32) {
            self.out.extend(if self.big { v.to_be_bytes() } else { v.to_le_bytes() });
        }
        fn u64(&mut self, v: u64) {
            self.out.extend(if self.big { v.to_be_bytes() } else { v.to_le_bytes() });
        }
        fn str(&mut self, s: &str) {
            self.u32(s.len() as u32);
            self.out.extend(s.as_bytes());
        }
    }

    fn metadata(objs: &[Obj], big: bool) -> Vec<u8> {
        let mut w = W { out: Vec::new(), big };
        w.u32(objs.len() as u32);
        for o in objs {
            w.str(&o.path);
            match o.index {
                Ix::NoData => w.u32(INDEX_NO_DATA),
                Ix::Same => w.u32(INDEX_SAME_AS_PREVIOUS),
                Ix::Daqmx => w.u32(INDEX_DAQMX_FORMAT_CHANGING),
                Ix::New(t, n) => {
                    w.u32(20);
                    w.u32(t);
                    w.u32(1);
                    w.u64(n);
                }
                Ix::Strings(n, bytes) => {
                    w.u32(28);
                    w.u32(TYPE_STRING);
                    w.u32(1);
                    w.u64(n);
                    w.u64(bytes);
                }
            }
            w.u32(o.props.len() as u32);
            for (k, v) in &o.props {
                w.str(k);
                match v {
                    Pv::I32(x) => {
                        w.u32(3);
                        w.u32(*x as u32);
                    }
                    Pv::U32(x) => {
                        w.u32(7);
                        w.u32(*x);
                    }
                    Pv::F64(x) => {
                        w.u32(10);
                        w.u64(x.to_bits());
                    }
                    Pv::Str(s) => {
                        w.u32(TYPE_STRING);
                        w.str(s);
                    }
                    Pv::Bool => {
                        w.u32(0x21);
                        w.out.push(1);
                    }
                    Pv::Time => {
                        w.u32(0x44);
                        w.out.extend([7u8; 16]);
                    }
                }
            }
        }
        w.out
    }

    /// A segment: lead-in, metadata (when `objs` is given), raw data.
    fn segment(toc: u32, objs: Option<&[Obj]>, data: &[u8]) -> Vec<u8> {
        let big = toc & TOC_BIG_ENDIAN != 0;
        let meta = objs.map(|o| metadata(o, big)).unwrap_or_default();
        let toc = toc | if objs.is_some() { TOC_META_DATA } else { 0 } | if data.is_empty() { 0 } else { TOC_RAW_DATA };
        let mut w = W { out: b"TDSm".to_vec(), big };
        w.out.extend(toc.to_le_bytes());
        w.u32(4713);
        w.u64((meta.len() + data.len()) as u64);
        w.u64(meta.len() as u64);
        w.out.extend(meta);
        w.out.extend(data);
        w.out
    }

    fn f64s(v: &[f64], big: bool) -> Vec<u8> {
        v.iter().flat_map(|x| if big { x.to_be_bytes() } else { x.to_le_bytes() }).collect()
    }

    fn i16s(v: &[i16], big: bool) -> Vec<u8> {
        v.iter().flat_map(|x| if big { x.to_be_bytes() } else { x.to_le_bytes() }).collect()
    }

    /// Rows of interleaved (f64, i16) values.
    fn rows(a: &[f64], b: &[i16], big: bool) -> Vec<u8> {
        a.iter().zip(b).flat_map(|(x, y)| [f64s(&[*x], big), i16s(&[*y], big)].concat()).collect()
    }

    fn read(bytes: &[u8], cols: &[&str], rate: Option<f64>) -> Result<Recording, TdmsError> {
        let cols: Vec<String> = cols.iter().map(|s| s.to_string()).collect();
        read_bytes(bytes, "test.tdms", &cols, RateUnit::DegPerS, rate)
    }

    fn seq_f64(from: usize, n: usize) -> Vec<f64> {
        (from..from + n).map(|i| (i as f64 * 0.37).sin() * 100.0 + 0.125).collect()
    }

    fn seq_i16(from: usize, n: usize) -> Vec<i16> {
        (from..from + n).map(|i| ((i * 7919) % 65536) as u16 as i16).collect()
    }

    fn as_f64(v: &[i16]) -> Vec<f64> {
        v.iter().map(|&x| f64::from(x)).collect()
    }

    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    /// The first segment of most cases: root and group with properties of every kind, channels a (f64) and b
    /// (i16), `n` values each, 10 ms apart.
    fn first_segment(a: &[f64], b: &[i16], toc: u32) -> Vec<u8> {
        let big = toc & TOC_BIG_ENDIAN != 0;
        let n = a.len() as u64;
        let objs = [
            obj(
                "/",
                Ix::NoData,
                vec![
                    ("name", Pv::Str("hand-built")),
                    ("flag", Pv::Bool),
                    ("when", Pv::Time),
                    ("count", Pv::I32(-3)),
                    ("u", Pv::U32(7)),
                ],
            ),
            obj("/'g'", Ix::NoData, vec![("gain", Pv::F64(2.0))]),
            obj(
                &chan("g", "a"),
                Ix::New(10, n),
                vec![("wf_increment", Pv::F64(0.01)), ("unit_string", Pv::Str("deg/s"))],
            ),
            obj(&chan("g", "b"), Ix::New(2, n), vec![("wf_increment", Pv::F64(0.01))]),
        ];
        let data = if toc & TOC_INTERLEAVED != 0 { rows(a, b, big) } else { [f64s(a, big), i16s(b, big)].concat() };
        segment(toc | TOC_NEW_OBJ_LIST, Some(&objs), &data)
    }

    #[test]
    fn contiguous_segments_give_values_names_and_rate() {
        let (a0, b0, a1, b1) = (seq_f64(0, 5), seq_i16(0, 5), seq_f64(5, 5), seq_i16(5, 5));
        let mut file = first_segment(&a0, &b0, 0);
        file.extend(first_segment(&a1, &b1, 0));
        let rec = read(&file, &["g/a", "g/b"], None).unwrap();
        assert_eq!(rec.names, ["g/a", "g/b"]);
        assert_eq!(bits(&rec.channels[0]), bits(&[a0, a1].concat()));
        let b = as_f64(&[b0, b1].concat());
        assert_eq!(rec.channels[1], b);
        assert_eq!(rec.rate_hz, 100.0);
        assert_eq!(rec.info.samples, 10);
        assert_eq!(rec.info.gaps, 0);
        assert_eq!(rec.info.columns, rec.names);
        assert_eq!(rec.source, "test.tdms");
        assert!(rec.temp_c.is_none());
        // The same channel twice, and in the other order.
        let rec = read(&file, &["g/b", "g/a", "g/b"], Some(100.0)).unwrap();
        assert_eq!(rec.channels[0], rec.channels[2]);
        assert_eq!(rec.channels[0], b);
    }

    #[test]
    fn metadata_carries_over_between_segments() {
        let (mut a, mut b, mut c) = (Vec::new(), Vec::new(), Vec::new());
        let next = |n: usize, a: &mut Vec<f64>, b: &mut Vec<i16>| {
            let (x, y) = (seq_f64(a.len(), n), seq_i16(b.len() + 1000, n));
            a.extend(&x);
            b.extend(&y);
            (x, y)
        };
        // 1: a and b, 3 values each.
        let (x, y) = next(3, &mut a, &mut b);
        let mut file = first_segment(&x, &y, 0);
        // 2: no metadata, two chunks of the same layout.
        let (x0, y0) = next(3, &mut a, &mut b);
        let (x1, y1) = next(3, &mut a, &mut b);
        file.extend(segment(
            0,
            None,
            &[f64s(&x0, false), i16s(&y0, false), f64s(&x1, false), i16s(&y1, false)].concat(),
        ));
        // 3: a "same as previous", c (u8) appended; b, unmentioned, keeps its data.
        let (x, y) = next(3, &mut a, &mut b);
        let z = [200u8, 3];
        c.extend(z.map(f64::from));
        let objs = [obj(&chan("g", "a"), Ix::Same, vec![]), obj(&chan("g", "c"), Ix::New(5, 2), vec![])];
        file.extend(segment(0, Some(&objs), &[f64s(&x, false), i16s(&y, false), z.to_vec()].concat()));
        // 4: b has no data here; a gets a new index; c carries on.
        let x = seq_f64(a.len(), 4);
        a.extend(&x);
        let z = [9u8, 10];
        c.extend(z.map(f64::from));
        let objs = [obj(&chan("g", "b"), Ix::NoData, vec![]), obj(&chan("g", "a"), Ix::New(10, 4), vec![])];
        file.extend(segment(0, Some(&objs), &[f64s(&x, false), z.to_vec()].concat()));
        // 5: a has no data; b comes back with its old index (3 values).
        let y = seq_i16(b.len() + 1000, 3);
        b.extend(&y);
        let objs = [obj(&chan("g", "a"), Ix::NoData, vec![]), obj(&chan("g", "b"), Ix::Same, vec![])];
        file.extend(segment(0, Some(&objs), &[i16s(&y, false), vec![11, 12]].concat()));
        c.extend([11.0, 12.0]);

        let rec = read(&file, &["g/a"], None).unwrap();
        assert_eq!(bits(&rec.channels[0]), bits(&a));
        let rec = read(&file, &["g/b"], None).unwrap();
        assert_eq!(rec.channels[0], as_f64(&b));
        let rec = read(&file, &["g/c"], Some(1.0)).unwrap();
        assert_eq!(rec.channels[0], c);
        // a and b have 16 and 15 values.
        let err = read(&file, &["g/a", "g/b"], None).unwrap_err().to_string();
        assert!(err.contains("\"g/a\" (16 samples) and \"g/b\" (15 samples) differ in length"), "{err}");
    }

    #[test]
    fn interleaved_and_big_endian_segments() {
        let (a0, b0) = (seq_f64(0, 8), seq_i16(0, 8));
        // 1: interleaved, little-endian, two chunks of 4 rows.
        let objs = [
            obj(&chan("g", "a"), Ix::New(10, 4), vec![("wf_increment", Pv::F64(0.5))]),
            obj(&chan("g", "b"), Ix::New(2, 4), vec![]),
        ];
        let mut file = segment(TOC_NEW_OBJ_LIST | TOC_INTERLEAVED, Some(&objs), &rows(&a0, &b0, false));
        // 2: big-endian, contiguous, a new list (the property updated in big-endian too).
        let (a1, b1) = (seq_f64(8, 2), seq_i16(8, 2));
        let objs = [
            obj(&chan("g", "a"), Ix::New(10, 2), vec![("wf_increment", Pv::F64(0.25))]),
            obj(&chan("g", "b"), Ix::New(2, 2), vec![]),
        ];
        let big = TOC_BIG_ENDIAN | TOC_NEW_OBJ_LIST;
        file.extend(segment(big, Some(&objs), &[f64s(&a1, true), i16s(&b1, true)].concat()));
        // 3: big-endian and interleaved, indexes "same as previous".
        let (a2, b2) = (seq_f64(10, 2), seq_i16(10, 2));
        let objs = [obj(&chan("g", "a"), Ix::Same, vec![]), obj(&chan("g", "b"), Ix::Same, vec![])];
        file.extend(segment(TOC_BIG_ENDIAN | TOC_INTERLEAVED, Some(&objs), &rows(&a2, &b2, true)));
        // 4: no metadata: big-endian interleaved again, three chunks.
        let (a3, b3) = (seq_f64(12, 6), seq_i16(12, 6));
        file.extend(segment(TOC_BIG_ENDIAN | TOC_INTERLEAVED, None, &rows(&a3, &b3, true)));

        let rec = read(&file, &["g/a", "g/b"], None).unwrap();
        assert_eq!(bits(&rec.channels[0]), bits(&[a0, a1, a2, a3].concat()));
        assert_eq!(rec.channels[1], as_f64(&[b0, b1, b2, b3].concat()));
        assert_eq!(rec.rate_hz, 4.0);
    }

    #[test]
    fn every_numeric_type() {
        let cases: Vec<(u32, Vec<u8>, Vec<f64>, usize)> = vec![
            (1, vec![0x80, 0x7f, 0xff], vec![-128.0, 127.0, -1.0], 1),
            (
                2,
                [i16::MIN, i16::MAX, -2].iter().flat_map(|v| v.to_le_bytes()).collect(),
                vec![-32768.0, 32767.0, -2.0],
                2,
            ),
            (
                3,
                [i32::MIN, i32::MAX, -3].iter().flat_map(|v| v.to_le_bytes()).collect(),
                vec![-2147483648.0, 2147483647.0, -3.0],
                4,
            ),
            (
                4,
                [i64::MIN, 1 << 53, -4].iter().flat_map(|v| v.to_le_bytes()).collect(),
                vec![-9.223372036854776e18, 9007199254740992.0, -4.0],
                8,
            ),
            (5, vec![0, 255, 1], vec![0.0, 255.0, 1.0], 1),
            (6, [0u16, u16::MAX, 6].iter().flat_map(|v| v.to_le_bytes()).collect(), vec![0.0, 65535.0, 6.0], 2),
            (7, [0u32, u32::MAX, 7].iter().flat_map(|v| v.to_le_bytes()).collect(), vec![0.0, 4294967295.0, 7.0], 4),
            (
                8,
                [0u64, u64::MAX, 8].iter().flat_map(|v| v.to_le_bytes()).collect(),
                vec![0.0, 1.8446744073709552e19, 8.0],
                8,
            ),
            (
                9,
                [0.1f32, -3.5, 1e30].iter().flat_map(|v| v.to_le_bytes()).collect(),
                vec![f64::from(0.1f32), -3.5, f64::from(1e30f32)],
                4,
            ),
            (
                0x19,
                [0.1f32, -3.5, 2.0].iter().flat_map(|v| v.to_le_bytes()).collect(),
                vec![f64::from(0.1f32), -3.5, 2.0],
                4,
            ),
            (10, f64s(&[0.1, -1e300, 5e-324], false), vec![0.1, -1e300, 5e-324], 8),
            (0x1A, f64s(&[0.1, 2.5, -0.0], false), vec![0.1, 2.5, -0.0], 8),
        ];
        for (code, data, expected, size) in cases {
            assert_eq!(data.len(), 3 * size);
            let objs = [obj(&chan("t", "x"), Ix::New(code, 3), vec![])];
            let file = segment(TOC_NEW_OBJ_LIST, Some(&objs), &data);
            let rec = read(&file, &["t/x"], Some(1.0)).unwrap();
            assert_eq!(bits(&rec.channels[0]), bits(&expected), "type {code:#x}");
            // Big-endian: the same values.
            let data: Vec<u8> = data.chunks(size).flat_map(|c| c.iter().rev().copied().collect::<Vec<_>>()).collect();
            let file = segment(TOC_NEW_OBJ_LIST | TOC_BIG_ENDIAN, Some(&objs), &data);
            let rec = read(&file, &["t/x"], Some(1.0)).unwrap();
            assert_eq!(bits(&rec.channels[0]), bits(&expected), "big-endian type {code:#x}");
        }
    }

    #[test]
    fn other_channels_are_skipped_whatever_their_type() {
        // A string channel (offsets then bytes) and a time stamp channel between two numeric ones.
        let strings = [3u32.to_le_bytes().to_vec(), 5u32.to_le_bytes().to_vec(), b"abcde".to_vec()].concat();
        let objs = [
            obj(&chan("g", "a"), Ix::New(10, 2), vec![]),
            obj(&chan("g", "s"), Ix::Strings(2, strings.len() as u64), vec![]),
            obj(&chan("g", "t"), Ix::New(0x44, 1), vec![]),
            obj(&chan("g", "b"), Ix::New(2, 2), vec![]),
        ];
        let data = [f64s(&[1.5, 2.5], false), strings, vec![0; 16], i16s(&[-7, 8], false)].concat();
        let mut file = segment(TOC_NEW_OBJ_LIST, Some(&objs), &data);
        file.extend(segment(0, None, &data));
        let rec = read(&file, &["g/a", "g/b"], Some(1.0)).unwrap();
        assert_eq!(rec.channels, [vec![1.5, 2.5, 1.5, 2.5], vec![-7.0, 8.0, -7.0, 8.0]]);
        let err = read(&file, &["g/s"], Some(1.0)).unwrap_err().to_string();
        assert!(err.contains("channel \"g/s\" holds string values, not numbers"), "{err}");
        let err = read(&file, &["g/t"], Some(1.0)).unwrap_err().to_string();
        assert!(err.contains("channel \"g/t\" holds time stamp values, not numbers"), "{err}");
    }

    #[test]
    fn units_nan_gaps_and_infinities() {
        let objs = [obj(&chan("g", "a"), Ix::New(10, 3), vec![])];
        let file = segment(TOC_NEW_OBJ_LIST, Some(&objs), &f64s(&[1.0, f64::NAN, -2.0], false));
        let cols = ["g/a".to_string()];
        let rec = read_bytes(&file, "x", &cols, RateUnit::RadPerS, Some(10.0)).unwrap();
        let k = RateUnit::RadPerS.to_dps();
        assert_eq!(rec.channels[0][0], k);
        assert!(rec.channels[0][1].is_nan());
        assert_eq!(rec.channels[0][2], -2.0 * k);
        assert_eq!(rec.info.gaps, 1);
        let file = segment(TOC_NEW_OBJ_LIST, Some(&objs), &f64s(&[1.0, 2.0, f64::INFINITY], false));
        let err = read(&file, &["g/a"], Some(1.0)).unwrap_err().to_string();
        assert_eq!(err, "test.tdms: channel \"g/a\", sample 2: inf is not finite");
    }

    /// A file with one i16 channel "g/x" holding -2, 0, 3, 1000 and these properties (and group `group_props`).
    fn scaled_file(props: Vec<(&str, Pv)>, group_props: Vec<(&str, Pv)>) -> Vec<u8> {
        let objs = [obj("/'g'", Ix::NoData, group_props), obj(&chan("g", "x"), Ix::New(2, 4), props)];
        segment(TOC_NEW_OBJ_LIST, Some(&objs), &i16s(&[-2, 0, 3, 1000], false))
    }

    fn scaled(props: Vec<(&str, Pv)>) -> Result<Vec<f64>, String> {
        read(&scaled_file(props, vec![]), &["g/x"], Some(1.0)).map(|r| r.channels[0].clone()).map_err(|e| e.to_string())
    }

    fn linear(i: u32, slope: f64, intercept: f64) -> Vec<(String, Pv)> {
        vec![
            (format!("NI_Scale[{i}]_Scale_Type"), Pv::Str("Linear")),
            (format!("NI_Scale[{i}]_Linear_Slope"), Pv::F64(slope)),
            (format!("NI_Scale[{i}]_Linear_Y_Intercept"), Pv::F64(intercept)),
        ]
    }

    fn props(v: &[(String, Pv)]) -> Vec<(&str, Pv)> {
        v.iter()
            .map(|(k, p)| {
                let p = match p {
                    Pv::I32(x) => Pv::I32(*x),
                    Pv::U32(x) => Pv::U32(*x),
                    Pv::F64(x) => Pv::F64(*x),
                    Pv::Str(s) => Pv::Str(s),
                    Pv::Bool => Pv::Bool,
                    Pv::Time => Pv::Time,
                };
                (k.as_str(), p)
            })
            .collect()
    }

    #[test]
    fn linear_and_polynomial_scales() {
        let raw = [-2.0, 0.0, 3.0, 1000.0];
        let mut p = linear(0, 0.00875, -0.25);
        p.push(("NI_Number_Of_Scales".into(), Pv::I32(1)));
        p.push(("NI_Scaling_Status".into(), Pv::Str("unscaled")));
        let expect: Vec<f64> = raw.iter().map(|x| x * 0.00875 + -0.25).collect();
        assert_eq!(scaled(props(&p)).unwrap(), expect);
        // Without NI_Number_Of_Scales and NI_Scaling_Status: the scale types count them, and unscaled is assumed.
        assert_eq!(scaled(props(&linear(0, 0.00875, -0.25))).unwrap(), expect);
        // Already scaled: left alone.
        p[4] = ("NI_Scaling_Status".into(), Pv::Str("scaled"));
        assert_eq!(scaled(props(&p)).unwrap(), raw);

        // Polynomial 1 - 0.5 x + 0.25 x^2 (size given), fed by a linear scale 2x + 1: the last scale applies.
        let mut p = linear(0, 2.0, 1.0);
        p.extend([
            ("NI_Scale[1]_Scale_Type".to_string(), Pv::Str("Polynomial")),
            ("NI_Scale[1]_Polynomial_Coefficients_Size".to_string(), Pv::I32(3)),
            ("NI_Scale[1]_Polynomial_Coefficients[0]".to_string(), Pv::F64(1.0)),
            ("NI_Scale[1]_Polynomial_Coefficients[1]".to_string(), Pv::F64(-0.5)),
            ("NI_Scale[1]_Polynomial_Coefficients[2]".to_string(), Pv::F64(0.25)),
            ("NI_Scale[1]_Polynomial_Input_Source".to_string(), Pv::U32(0)),
            ("NI_Number_Of_Scales".to_string(), Pv::I32(2)),
        ]);
        let poly = |y: f64| 1.0 + y * (-0.5 + y * 0.25);
        let expect: Vec<f64> = raw.iter().map(|x| poly(x * 2.0 + 1.0)).collect();
        assert_eq!(scaled(props(&p)).unwrap(), expect);
        // Fed by the raw data instead.
        p[8] = ("NI_Scale[1]_Polynomial_Input_Source".to_string(), Pv::U32(0xFFFF_FFFF));
        assert_eq!(scaled(props(&p)).unwrap(), raw.iter().map(|&x| poly(x)).collect::<Vec<_>>());
        // Four coefficients when the size is not given.
        let p: Vec<(String, Pv)> = vec![
            ("NI_Scale[0]_Scale_Type".into(), Pv::Str("Polynomial")),
            ("NI_Scale[0]_Polynomial_Coefficients[0]".into(), Pv::F64(0.0)),
            ("NI_Scale[0]_Polynomial_Coefficients[1]".into(), Pv::F64(0.0)),
            ("NI_Scale[0]_Polynomial_Coefficients[2]".into(), Pv::F64(0.0)),
            ("NI_Scale[0]_Polynomial_Coefficients[3]".into(), Pv::F64(1.0)),
        ];
        assert_eq!(scaled(props(&p)).unwrap(), raw.iter().map(|x| x * x * x).collect::<Vec<_>>());
    }

    #[test]
    fn add_subtract_and_advanced_api_scales() {
        // Scale 0: 2x; scale 1: x + 10; scale 2: Subtract (right - left) of 0 and 1; scale 3: AdvancedAPI of 2.
        let mut p = linear(0, 2.0, 0.0);
        p.extend(linear(1, 1.0, 10.0));
        p.extend([
            ("NI_Scale[2]_Scale_Type".to_string(), Pv::Str("Subtract")),
            ("NI_Scale[2]_Subtract_Left_Operand_Input_Source".to_string(), Pv::U32(0)),
            ("NI_Scale[2]_Subtract_Right_Operand_Input_Source".to_string(), Pv::U32(1)),
            ("NI_Scale[3]_Scale_Type".to_string(), Pv::Str("AdvancedAPI")),
            ("NI_Scale[3]_AdvancedAPI_Input_Source".to_string(), Pv::U32(2)),
            ("NI_Number_Of_Scales".to_string(), Pv::I32(4)),
        ]);
        let raw = [-2.0, 0.0, 3.0, 1000.0];
        assert_eq!(scaled(props(&p)).unwrap(), raw.iter().map(|x| (x + 10.0) - 2.0 * x).collect::<Vec<_>>());
        p[6] = ("NI_Scale[2]_Scale_Type".to_string(), Pv::Str("Add"));
        p[7] = ("NI_Scale[2]_Add_Left_Operand_Input_Source".to_string(), Pv::U32(0));
        p[8] = ("NI_Scale[2]_Add_Right_Operand_Input_Source".to_string(), Pv::I32(-1));
        assert_eq!(scaled(props(&p)).unwrap(), raw.iter().map(|x| 2.0 * x + x).collect::<Vec<_>>());
    }

    #[test]
    fn group_and_file_scales_apply_where_the_channel_has_none() {
        let file = scaled_file(vec![], props(&linear(0, 3.0, 1.0)));
        let rec = read(&file, &["g/x"], Some(1.0)).unwrap();
        assert_eq!(rec.channels[0], [-5.0, 1.0, 10.0, 3001.0]);
        // The channel's own scale wins.
        let file = scaled_file(props(&linear(0, 1.0, 0.5)), props(&linear(0, 3.0, 1.0)));
        let rec = read(&file, &["g/x"], Some(1.0)).unwrap();
        assert_eq!(rec.channels[0], [-1.5, 0.5, 3.5, 1000.5]);
    }

    #[test]
    fn scales_octavar_cannot_apply_are_errors() {
        let mut p = linear(0, 1.0, 0.0);
        p[0].1 = Pv::Str("Thermocouple");
        let err = scaled(props(&p)).unwrap_err();
        assert_eq!(
            err,
            "test.tdms: channel \"g/x\": scale 0 is of type \"Thermocouple\", which octavar does not apply (it \
             applies Linear, Polynomial, Add, Subtract and AdvancedAPI scales); export the channel scaled"
        );
        // A DAQmx scaler: counted, but without a type.
        let err = scaled(vec![("NI_Number_Of_Scales", Pv::I32(1))]).unwrap_err();
        assert!(err.contains("scale 0 is of type \"DAQmx scaler (no Scale_Type)\""), "{err}");
        // A missing slope.
        let err = scaled(props(
            &linear(0, 1.0, 0.0)[..2].iter().map(|(k, _)| (k.clone(), Pv::Str("Linear"))).collect::<Vec<_>>(),
        ));
        assert!(err.unwrap_err().contains("NI_Scale[0]_Linear_Slope is \"Linear\", not a number"));
        let mut p = linear(0, 1.0, 0.0);
        p.truncate(2);
        assert!(scaled(props(&p)).unwrap_err().ends_with("scale 0 has no NI_Scale[0]_Linear_Y_Intercept"));
        // Input sources in a loop, and out of range.
        let mut p = linear(0, 1.0, 0.0);
        p.push(("NI_Scale[0]_Linear_Input_Source".into(), Pv::U32(0)));
        assert!(scaled(props(&p)).unwrap_err().contains("loop"));
        p[3].1 = Pv::U32(5);
        assert!(scaled(props(&p)).unwrap_err().contains("neither the raw data (4294967295) nor one of the 1 scales"));
    }

    #[test]
    fn rate_from_wf_increment_and_rate() {
        let (a, b) = (seq_f64(0, 3), seq_i16(0, 3));
        let file = first_segment(&a, &b, 0);
        assert_eq!(read(&file, &["g/a"], Some(100.0)).unwrap().rate_hz, 100.0);
        assert_eq!(read(&file, &["g/a"], Some(100.00001)).unwrap().rate_hz, 100.0);
        let err = read(&file, &["g/a"], Some(200.0)).unwrap_err().to_string();
        assert_eq!(err, "test.tdms: channel \"g/a\" has wf_increment 0.01 s (100 Hz), but --rate is 200 Hz");
        assert!(matches!(read(&file, &["g/a"], Some(-1.0)), Err(TdmsError::BadRate(_))));
        // No wf_increment: --rate is needed.
        let objs = [
            obj(&chan("g", "a"), Ix::New(10, 3), vec![]),
            obj(&chan("g", "c"), Ix::New(10, 3), vec![("wf_increment", Pv::F64(0.02))]),
        ];
        let file = segment(TOC_NEW_OBJ_LIST, Some(&objs), &f64s(&[1.0; 6], false));
        let err = read(&file, &["g/a"], None).unwrap_err().to_string();
        assert_eq!(err, "test.tdms: no sample rate: the channels have no wf_increment property; give --rate HZ");
        assert_eq!(read(&file, &["g/a"], Some(7.0)).unwrap().rate_hz, 7.0);
        // One of two channels has it.
        assert_eq!(read(&file, &["g/a", "g/c"], None).unwrap().rate_hz, 50.0);
        // Channels that disagree.
        let objs = [
            obj(&chan("g", "a"), Ix::New(10, 3), vec![("wf_increment", Pv::F64(0.01))]),
            obj(&chan("g", "c"), Ix::New(10, 3), vec![("wf_increment", Pv::F64(0.02))]),
        ];
        let file = segment(TOC_NEW_OBJ_LIST, Some(&objs), &f64s(&[1.0; 6], false));
        let err = read(&file, &["g/a", "g/c"], None).unwrap_err().to_string();
        assert!(err.contains("\"g/a\" (wf_increment 0.01 s) and \"g/c\" (wf_increment 0.02 s)"), "{err}");
        let objs = [obj(&chan("g", "a"), Ix::New(10, 3), vec![("wf_increment", Pv::Str("fast"))])];
        let file = segment(TOC_NEW_OBJ_LIST, Some(&objs), &f64s(&[1.0; 3], false));
        let err = read(&file, &["g/a"], None).unwrap_err().to_string();
        assert!(err.contains("wf_increment \"fast\", which is not a positive number"), "{err}");
    }

    #[test]
    fn missing_channels_list_what_the_file_has() {
        let file = first_segment(&seq_f64(0, 3), &seq_i16(0, 3), 0);
        let err = read(&file, &["g/a", "g/z"], None).unwrap_err().to_string();
        assert_eq!(err, "test.tdms: no channel \"g/z\" (the file has: g/a, g/b)");
        let err = read(&file, &[], None).unwrap_err().to_string();
        assert_eq!(err, "test.tdms: no channel asked for (give --column 'group/channel'; the file has: g/a, g/b)");
    }

    #[test]
    fn object_paths() {
        assert_eq!(parse_path("/"), Some((None, None)));
        assert_eq!(parse_path("/'g'"), Some((Some("g".into()), None)));
        assert_eq!(parse_path("/'it''s'/'a/b'"), Some((Some("it's".into()), Some("a/b".into()))));
        assert_eq!(parse_path("/''/''"), Some((Some(String::new()), Some(String::new()))));
        for bad in ["", "g", "/g", "/'g", "/'g'x", "/'a'/'b'/'c'", "//"] {
            assert_eq!(parse_path(bad), None, "{bad}");
        }
        assert_eq!(object_path(Some("it's")), "/'it''s'");
        // Names with quotes and slashes are found by their plain group/channel.
        let objs = [obj("/'it''s'/'a/b'", Ix::New(10, 1), vec![])];
        let file = segment(TOC_NEW_OBJ_LIST, Some(&objs), &f64s(&[4.0], false));
        assert_eq!(read(&file, &["it's/a/b"], Some(1.0)).unwrap().channels[0], [4.0]);
        // Two channels whose names read the same.
        let objs = [obj("/'x/y'/'z'", Ix::New(10, 1), vec![]), obj("/'x'/'y/z'", Ix::New(10, 1), vec![])];
        let file = segment(TOC_NEW_OBJ_LIST, Some(&objs), &f64s(&[4.0, 5.0], false));
        let err = read(&file, &["x/y/z"], Some(1.0)).unwrap_err().to_string();
        assert!(err.contains("\"x/y/z\" names two channels: /'x/y'/'z' and /'x'/'y/z'"), "{err}");
    }

    #[test]
    fn not_tdms_index_files_and_daqmx() {
        let err = read(b"time,gx\n0,1\n", &["g/a"], None).unwrap_err().to_string();
        assert_eq!(err, "test.tdms: not a TDMS file (it starts with \"time\", not \"TDSm\")");
        let err = read(&[0u8, 1, 2, 250], &["g/a"], None).unwrap_err().to_string();
        assert_eq!(err, "test.tdms: not a TDMS file (it starts with 00 01 02 fa, not \"TDSm\")");
        assert!(read(b"", &["g/a"], None).unwrap_err().to_string().contains("the file is empty"));
        let mut index = first_segment(&[1.0], &[1], 0);
        index[3] = b'h';
        assert!(matches!(read(&index, &["g/a"], None), Err(TdmsError::IndexFile { .. })));
        let objs = [obj(&chan("g", "a"), Ix::Daqmx, vec![])];
        let file = segment(TOC_NEW_OBJ_LIST | TOC_DAQMX_RAW_DATA, Some(&objs), &[0; 8]);
        let err = read(&file, &["g/a"], None).unwrap_err().to_string();
        assert!(err.contains("segment 1): channel \"g/a\" holds DAQmx raw data, which octavar does not read"), "{err}");
    }

    /// A file of every kind of segment.
    fn mixed_file() -> Vec<u8> {
        let mut file = first_segment(&seq_f64(0, 4), &seq_i16(0, 4), TOC_INTERLEAVED);
        file.extend(segment(0, None, &rows(&seq_f64(4, 4), &seq_i16(4, 4), false)));
        let objs = [
            obj(&chan("g", "a"), Ix::Same, vec![("wf_increment", Pv::F64(0.01))]),
            obj(&chan("g", "b"), Ix::Same, vec![]),
        ];
        file.extend(segment(
            TOC_BIG_ENDIAN,
            Some(&objs),
            &[f64s(&seq_f64(8, 4), true), i16s(&seq_i16(8, 4), true)].concat(),
        ));
        file
    }

    #[test]
    fn truncated_files_are_errors_that_locate_the_cut() {
        let file = mixed_file();
        let whole = read(&file, &["g/a", "g/b"], None).unwrap();
        assert_eq!(whole.info.samples, 12);
        let mut boundaries = 0;
        for n in 1..file.len() {
            match read(&file[..n], &["g/a", "g/b"], None) {
                // A cut between segments leaves a shorter file that is whole.
                Ok(rec) => {
                    boundaries += 1;
                    assert!(rec.info.samples == 4 || rec.info.samples == 8, "{n}");
                    assert_eq!(rec.channels[0][..], whole.channels[0][..rec.channels[0].len()]);
                }
                Err(TdmsError::Truncated { segment, offset, .. }) => {
                    assert_eq!(offset, n as u64);
                    assert!((1..=3).contains(&segment));
                }
                Err(e) => panic!("cut at {n}: {e}"),
            }
        }
        assert_eq!(boundaries, 2);
        let err = read(&file[..file.len() - 3], &["g/a"], None).unwrap_err().to_string();
        assert!(err.contains("(segment 3, which starts at byte"), "{err}");
        assert!(err.contains("the file is truncated: the segment's lead-in says"), "{err}");
    }

    #[test]
    fn damaged_bytes_never_panic() {
        let file = mixed_file();
        for i in 0..file.len() {
            for flip in [0xff, 0x01, 0x80] {
                let mut f = file.clone();
                f[i] ^= flip;
                let _ = read(&f, &["g/a", "g/b"], None);
            }
        }
        // Garbage after a good file: the next "segment" has no tag.
        let mut f = file.clone();
        f.extend([0x55; 40]);
        let err = read(&f, &["g/a"], None).unwrap_err().to_string();
        assert!(
            err.contains(&format!(
                "byte {} (segment 4, which starts at byte {}): corrupt: no segment tag",
                file.len(),
                file.len()
            )),
            "{err}"
        );
    }

    #[test]
    fn inconsistent_sizes_are_corrupt() {
        // Raw data that is not a whole number of chunks.
        let objs = [obj(&chan("g", "a"), Ix::New(10, 2), vec![])];
        let file = segment(TOC_NEW_OBJ_LIST, Some(&objs), &[0; 24]);
        let err = read(&file, &["g/a"], Some(1.0)).unwrap_err().to_string();
        assert!(err.contains("corrupt: 24 bytes of raw data are not a whole number of chunks of 16 bytes"), "{err}");
        // "Same as previous" for an object never seen.
        let objs = [obj(&chan("g", "a"), Ix::Same, vec![])];
        let file = segment(TOC_NEW_OBJ_LIST, Some(&objs), &[0; 16]);
        let err = read(&file, &["g/a"], Some(1.0)).unwrap_err().to_string();
        let want = "byte 44 (segment 1, which starts at byte 0): corrupt: channel \"g/a\" reuses the previous raw \
                    data index, but none came before";
        assert!(err.contains(want), "{err}");
        // Raw data and no metadata in the first segment.
        let file = segment(0, None, &[0; 16]);
        assert!(read(&file, &["g/a"], Some(1.0)).unwrap_err().to_string().contains("no earlier segment"));
        // A version that is not TDMS's.
        let mut file = first_segment(&[1.0], &[1], 0);
        file[8] = 0;
        assert!(read(&file, &["g/a"], None).unwrap_err().to_string().contains("is not a TDMS version"));
        // Interleaved channels of different lengths.
        let objs = [obj(&chan("g", "a"), Ix::New(10, 2), vec![]), obj(&chan("g", "b"), Ix::New(10, 1), vec![])];
        let file = segment(TOC_NEW_OBJ_LIST | TOC_INTERLEAVED, Some(&objs), &[0; 24]);
        assert!(read(&file, &["g/a"], Some(1.0))
            .unwrap_err()
            .to_string()
            .contains("interleaved data whose channels differ"));
    }

    #[test]
    fn an_unfinished_last_segment_gives_its_whole_chunks() {
        let (a, b) = (seq_f64(0, 6), seq_i16(0, 6));
        let mut file = first_segment(&a[..2], &b[..2], 0);
        let start = file.len();
        // Two whole chunks of 2 values each, then half of a third; the length was never written.
        let chunk = |i: usize| [f64s(&a[2 * i..2 * i + 2], false), i16s(&b[2 * i..2 * i + 2], false)].concat();
        file.extend(segment(0, None, &[chunk(1), chunk(2)[..10].to_vec()].concat()));
        file[start + 12..start + 20].copy_from_slice(&u64::MAX.to_le_bytes());
        let rec = read(&file, &["g/a", "g/b"], None).unwrap();
        assert_eq!(rec.channels[0], a[..4]);
        assert_eq!(rec.channels[1], as_f64(&b[..4]));
        // Interleaved: the whole rows.
        let mut file = first_segment(&a[..2], &b[..2], TOC_INTERLEAVED);
        let start = file.len();
        file.extend(segment(TOC_INTERLEAVED, None, &rows(&a[2..], &b[2..], false)[..3 * 10 + 4]));
        file[start + 12..start + 20].copy_from_slice(&u64::MAX.to_le_bytes());
        let rec = read(&file, &["g/a", "g/b"], None).unwrap();
        assert_eq!(rec.channels[0], a[..5]);
    }

    #[test]
    fn empty_channels_are_errors() {
        let objs = [obj(&chan("g", "a"), Ix::NoData, vec![])];
        let file = segment(TOC_NEW_OBJ_LIST, Some(&objs), &[]);
        let err = read(&file, &["g/a"], Some(1.0)).unwrap_err().to_string();
        assert_eq!(err, "test.tdms: channel \"g/a\" holds no samples");
    }

    #[test]
    fn reads_a_file_from_disk() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.tdms");
        std::fs::write(&path, first_segment(&[1.0, 2.0], &[3, 4], 0)).unwrap();
        let rec = read_tdms(&path, &["g/b".to_string()], RateUnit::DegPerS, None).unwrap();
        assert_eq!(rec.channels[0], [3.0, 4.0]);
        assert_eq!(rec.source, path.display().to_string());
        let err = read_tdms(&dir.path().join("none.tdms"), &[], RateUnit::DegPerS, None).unwrap_err().to_string();
        assert!(err.starts_with("reading ") && err.contains("none.tdms"), "{err}");
    }
}

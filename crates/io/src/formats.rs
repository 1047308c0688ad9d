//! Which reader a recording goes through, and the recording in memory whatever the format: CSV (also gzipped,
//! or stdin), NI TDMS ([`crate::tdms`]), ROS bags of `sensor_msgs` Imu messages (ROS 2 in MCAP,
//! [`crate::ros2_bag`]; ROS 2 in rosbag2's SQLite storage, a `.db3` file or a bag directory,
//! [`crate::ros2_db3`]; ROS 1, [`crate::ros1_bag`]), raw little-endian samples, or the raw samples of a
//! device capture. `analyze` and `gap` read through here, so both take every format. The format is the `--format`
//! flag, or else the file's extension (`.tdms`, `.mcap`, `.bag`, `.db3`, and rosbag2's compressed `.mcap.zstd`
//! and `.db3.zstd`; a folder with `metadata.yaml` and `.db3` or `.mcap` files is a rosbag2 bag), or else CSV.
use std::io::Read;
use std::path::Path;

use crate::binary::BinaryFormat;
use crate::csv::{CsvOptions, RecordingError};
use crate::imu_topic::{BagError, ImuBag};
use crate::recording::{RateUnit, Recording, StreamInfo};
use crate::rosbag2_dir::Storage;
use crate::tdms::{self, TdmsError};
use crate::{ros1_bag, ros2_bag, ros2_db3};

/// A recording's file format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RecordingFormat {
    /// Text with a header line (any delimiter; also gzipped).
    Csv,
    /// National Instruments TDMS; columns are `group/channel`.
    Tdms,
    /// A ROS 2 bag in MCAP with `sensor_msgs/msg/Imu` messages; channels `x`, `y`, `z` (and `ax`, `ay`, `az`).
    Mcap,
    /// A ROS 2 bag in rosbag2's SQLite storage (a `.db3` file or a bag directory), channels as [`Self::Mcap`].
    Db3,
    /// A ROS 1 bag with `sensor_msgs/Imu` messages, channels as [`Self::Mcap`].
    Ros1Bag,
    /// Raw interleaved little-endian samples.
    Binary(BinaryFormat),
    /// A device capture's raw sample frames; columns are the hello's channel names.
    Capture,
}

impl RecordingFormat {
    /// The format named by `flag` (csv, tdms, mcap, db3, bag, capture, f64le, f32le, i16le, u16le), or else the
    /// one `path`'s extension says (a rosbag2 folder of `.db3` files is [`Self::Db3`], of `.mcap` files
    /// [`Self::Mcap`]), or else CSV. `None` for
    /// a flag naming no format read here.
    pub fn of(path: &Path, flag: Option<&str>) -> Option<RecordingFormat> {
        match flag.map(|f| f.trim().to_ascii_lowercase()) {
            Some(f) => match f.as_str() {
                "csv" => Some(RecordingFormat::Csv),
                "tdms" => Some(RecordingFormat::Tdms),
                "mcap" => Some(RecordingFormat::Mcap),
                "db3" => Some(RecordingFormat::Db3),
                "bag" => Some(RecordingFormat::Ros1Bag),
                "capture" => Some(RecordingFormat::Capture),
                _ => BinaryFormat::parse(&f).map(RecordingFormat::Binary),
            },
            None if Storage::Sqlite.is_bag_dir(path) || Storage::Sqlite.is_file_name(path) => {
                Some(RecordingFormat::Db3)
            }
            None if Storage::Mcap.is_bag_dir(path) || Storage::Mcap.is_file_name(path) => Some(RecordingFormat::Mcap),
            None => {
                let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
                Some(match ext.as_str() {
                    "tdms" => RecordingFormat::Tdms,
                    "mcap" => RecordingFormat::Mcap,
                    "db3" => RecordingFormat::Db3,
                    "bag" => RecordingFormat::Ros1Bag,
                    "cap" | "capture" => RecordingFormat::Capture,
                    _ => RecordingFormat::Csv,
                })
            }
        }
    }
}

/// How to read a recording: the CSV options (columns, unit, rate; the rest are CSV's own), a bag's topic and a
/// raw input's channel count.
#[derive(Clone, Debug, Default)]
pub struct ReadOptions {
    /// Columns, unit, rate, temperature column and the CSV-only options.
    pub csv: CsvOptions,
    /// The IMU topic of a bag (`None`: its only one).
    pub topic: Option<String>,
    /// Interleaved channels of a raw input.
    pub channels: usize,
}

/// Why a recording could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The CSV reader's error (it names the line and column).
    #[error(transparent)]
    Csv(#[from] RecordingError),
    /// The TDMS reader's error.
    #[error(transparent)]
    Tdms(#[from] TdmsError),
    /// The bag reader's error.
    #[error(transparent)]
    Bag(#[from] BagError),
    /// An option that this format does not take.
    #[error("{path}: {option} applies to CSV recordings only, not to {format}")]
    CsvOnly { path: String, option: &'static str, format: &'static str },
    /// A bag's channel that is not one of its axes.
    #[error("{path}: no channel {column:?} in the IMU topic (its channels are {axes})")]
    NoSuchAxis { path: String, column: String, axes: &'static str },
    /// A raw input needs the rate.
    #[error("{path}: --rate HZ is required for a raw binary input")]
    NoRate { path: String },
    /// A raw input whose length is not a whole number of sample sets.
    #[error("{path}: {bytes} bytes is not a whole number of {set}-byte sample sets ({channels} channels of {format})")]
    PartialSet { path: String, bytes: u64, set: usize, channels: usize, format: &'static str },
    /// A capture that gives no recording.
    #[error("{path}: {what}")]
    Capture { path: String, what: String },
    /// Reading a raw input.
    #[error("{path}: {err}")]
    Io { path: String, err: std::io::Error },
}

/// Read a whole recording into memory in `format`.
///
/// # Errors
/// The format reader's error ([`ReadError`]), or an option the format does not take.
pub fn read_recording(path: &Path, format: RecordingFormat, opts: &ReadOptions) -> Result<Recording, ReadError> {
    let name = path.display().to_string();
    let csv = &opts.csv;
    let csv_only =
        |option: &'static str, format: &'static str| ReadError::CsvOnly { path: name.clone(), option, format };
    if format != RecordingFormat::Csv {
        let label = match format {
            RecordingFormat::Tdms => "TDMS",
            RecordingFormat::Mcap | RecordingFormat::Db3 => "a ROS 2 bag",
            RecordingFormat::Ros1Bag => "a ROS 1 bag",
            RecordingFormat::Capture => "a capture",
            _ => "raw samples",
        };
        if csv.time_column.is_some() {
            return Err(csv_only("--time-column", label));
        }
        if !csv.filters.is_empty() {
            return Err(csv_only("--where", label));
        }
        if csv.skip_rows > 0 {
            return Err(csv_only("--skip-rows", label));
        }
    }
    match format {
        RecordingFormat::Csv => {
            let input = crate::input::open(path).map_err(|err| ReadError::Io { path: name.clone(), err })?;
            Ok(crate::csv::read_csv_sized(input.reader, &input.name, csv, input.size)?)
        }
        RecordingFormat::Tdms => {
            let mut rec = tdms::read_tdms(path, &csv.columns, csv.unit, csv.rate_hz)?;
            if let Some(t) = &csv.temp_column {
                let temp = tdms::read_tdms(path, std::slice::from_ref(t), RateUnit::DegPerS, Some(rec.rate_hz))?;
                rec.temp_c = temp.channels.into_iter().next();
            }
            Ok(rec)
        }
        RecordingFormat::Mcap | RecordingFormat::Db3 | RecordingFormat::Ros1Bag => {
            type Reader = fn(&Path, Option<&str>, Option<f64>) -> Result<ImuBag, BagError>;
            let (read, label): (Reader, _) = match format {
                RecordingFormat::Mcap => (ros2_bag::read_imu_bag, "a ROS 2 bag"),
                RecordingFormat::Db3 => (ros2_db3::read_imu_bag, "a ROS 2 bag"),
                _ => (ros1_bag::read_imu_bag, "a ROS 1 bag"),
            };
            if csv.temp_column.is_some() {
                return Err(csv_only("--temp-column", label));
            }
            let mut bag = read(path, opts.topic.as_deref(), csv.rate_hz)?;
            let notes = stamp_notes(&bag);
            let mut rec = std::mem::take(&mut bag.recording);
            if !csv.columns.is_empty() || !csv.accel_columns.is_empty() {
                pick_bag_channels(&mut rec, csv, &name)?;
            }
            rec.source = format!("{} ({}{notes})", rec.source, bag.topic);
            Ok(rec)
        }
        RecordingFormat::Binary(format) => read_binary(path, format, opts),
        RecordingFormat::Capture => read_capture(path, csv),
    }
}

/// What the reader did with a bag's stamps, for the report's source line: the time source where it is not the
/// header stamps, the messages sorted into place and the repeated stamps dropped (empty where none).
fn stamp_notes(bag: &ImuBag) -> String {
    let mut notes = Vec::new();
    if bag.time_source != crate::imu_topic::TimeSource::HeaderStamp {
        notes.push(format!("times from {}, every header stamp being zero", bag.time_source.as_str()));
    }
    if bag.out_of_order > 0 {
        notes.push(format!("{} message(s) out of order, sorted by stamp", bag.out_of_order));
    }
    if bag.duplicates > 0 {
        notes.push(format!("{} repeated stamp(s), the later message(s) dropped", bag.duplicates));
    }
    notes.iter().map(|n| format!("; {n}")).collect()
}

/// Keep the channels of a bag's recording that the options name: `--column` x, y, z of the angular velocity and
/// `--accel-column` of the linear acceleration (ax, ay, az, or x, y, z of it), in that order.
fn pick_bag_channels(rec: &mut Recording, csv: &CsvOptions, path: &str) -> Result<(), ReadError> {
    let no_axis = |column: &str, accel: bool| ReadError::NoSuchAxis {
        path: path.to_string(),
        column: column.to_string(),
        axes: if accel { "ax, ay, az (or x, y, z)" } else { "x, y, z" },
    };
    let mut picked = Vec::new();
    for c in &csv.columns {
        picked.push(rec.names.iter().take(3).position(|n| n == c).ok_or_else(|| no_axis(c, false))?);
    }
    for c in &csv.accel_columns {
        let axis = if c.len() == 1 { format!("a{c}") } else { c.clone() };
        let i = rec.names.iter().skip(3).position(|n| *n == axis).ok_or_else(|| no_axis(c, true))?;
        picked.push(3 + i);
    }
    rec.channels = picked.iter().map(|&i| rec.channels[i].clone()).collect();
    rec.quantities = picked.iter().map(|&i| rec.quantity(i)).collect();
    rec.names = picked.iter().map(|&i| rec.names[i].clone()).collect();
    rec.info.columns = rec.names.clone();
    rec.info.gaps = rec.channels.iter().flatten().filter(|v| v.is_nan()).count() as u64;
    Ok(())
}

/// The raw sample frames of a device capture in memory: each named channel in deg/s through its part's bench
/// channel (the temperature channel in degC), the rate from the hello, and the samples the device lost (a jump
/// in the frames' hardware sample index) as NaN.
fn read_capture(path: &Path, csv: &CsvOptions) -> Result<Recording, ReadError> {
    use crate::decode::Message;
    use octavar_shared::sensor::{Channel, GyroModel, SensorKind};
    let name = path.display().to_string();
    let capture_err = |what: String| ReadError::Capture { path: name.clone(), what };
    let reader = crate::decode::open(path).map_err(|e| capture_err(e.to_string()))?;
    let mut hello = None;
    // Per channel index: its values so far (one per hardware sample index from the first frame on).
    let mut series: Vec<Vec<f64>> = Vec::new();
    let mut first: Option<u64> = None;
    for item in reader {
        let d = item.map_err(|e| capture_err(e.to_string()))?;
        match d.message {
            Message::Hello(h) => {
                series.resize(series.len().max(h.channels.len()), Vec::new());
                hello = Some(h);
            }
            Message::Samples(s) => {
                let Some(h) = &hello else { continue };
                let start = *first.get_or_insert(s.first_sample);
                let Some(at) = s.first_sample.checked_sub(start) else { continue };
                for (j, c) in s.mask_channels().enumerate() {
                    let Some(info) = h.channels.get(c) else { continue };
                    let to_value = |code: u16| match info.kind {
                        SensorKind::Temperature => f64::from(octavar_shared::sensor::temperature_c(f64::from(code))),
                        kind => GyroModel::of(kind).map_or(f64::from(code), |g| Channel::bench(g).code_to_dps(code)),
                    };
                    let out = &mut series[c];
                    if (out.len() as u64) < at {
                        out.resize(at as usize, f64::NAN);
                    }
                    if out.len() as u64 == at {
                        out.extend(s.slot_codes(j).map(to_value));
                    }
                }
            }
            _ => {}
        }
    }
    let hello = hello.ok_or_else(|| capture_err("no hello frame: the sample rate is unknown".into()))?;
    let rate = f64::from(hello.rate_hz);
    let names: Vec<String> = hello.channels.iter().map(|c| c.name.as_str().to_string()).collect();
    let find = |column: &str| {
        names
            .iter()
            .position(|n| n == column)
            .ok_or_else(|| capture_err(format!("no channel {column:?} (the capture's channels: {})", names.join(", "))))
    };
    let mut channels = Vec::new();
    for c in &csv.columns {
        let i = find(c)?;
        if series[i].is_empty() {
            return Err(capture_err(format!("no raw samples of channel {c:?} (record with raw streaming on)")));
        }
        channels.push(series[i].clone());
    }
    let mut temp_c = match &csv.temp_column {
        Some(t) => Some(series[find(t)?].clone()),
        None => None,
    };
    let len = channels.iter().chain(&temp_c).map(Vec::len).min().unwrap_or(0);
    for c in channels.iter_mut().chain(temp_c.iter_mut()) {
        c.truncate(len);
    }
    let gaps = channels.iter().flatten().filter(|v| v.is_nan()).count() as u64;
    Ok(Recording {
        source: name,
        names: csv.columns.clone(),
        channels,
        quantities: Vec::new(),
        temp_c,
        rate_hz: rate,
        info: StreamInfo { columns: csv.columns.clone(), rate_hz: rate, samples: len as u64, gaps, filtered_out: 0 },
    })
}

/// A raw interleaved binary recording in memory.
fn read_binary(path: &Path, format: BinaryFormat, opts: &ReadOptions) -> Result<Recording, ReadError> {
    let name = path.display().to_string();
    let rate =
        opts.csv.rate_hz.filter(|r| r.is_finite() && *r > 0.0).ok_or(ReadError::NoRate { path: name.clone() })?;
    let channels = opts.channels.max(1);
    let mut input = crate::input::open(path).map_err(|err| ReadError::Io { path: name.clone(), err })?;
    let mut bytes = Vec::new();
    input.reader.read_to_end(&mut bytes).map_err(|err| ReadError::Io { path: name.clone(), err })?;
    let set = format.size() * channels;
    if bytes.len() % set != 0 {
        return Err(ReadError::PartialSet {
            path: name,
            bytes: bytes.len() as u64,
            set,
            channels,
            format: format.name(),
        });
    }
    let scale = opts.csv.unit.to_dps();
    let mut series = vec![Vec::with_capacity(bytes.len() / set); channels];
    for sample in bytes.chunks_exact(set) {
        for (c, s) in series.iter_mut().zip(sample.chunks_exact(format.size())) {
            c.push(format.decode(s) * scale);
        }
    }
    let names: Vec<String> =
        (0..channels).map(|i| opts.csv.columns.get(i).cloned().unwrap_or_else(|| format!("ch{i}"))).collect();
    let samples = series.first().map_or(0, Vec::len) as u64;
    let gaps = series.iter().flatten().filter(|v| v.is_nan()).count() as u64;
    Ok(Recording {
        source: input.name,
        names: names.clone(),
        channels: series,
        quantities: Vec::new(),
        temp_c: None,
        rate_hz: rate,
        info: StreamInfo { columns: names, rate_hz: rate, samples, gaps, filtered_out: 0 },
    })
}

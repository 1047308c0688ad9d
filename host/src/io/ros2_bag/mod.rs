//! Reading ROS 2 bags in MCAP format: the gyro rates of one `sensor_msgs/msg/Imu` topic as a [`Recording`].
//!
//! Reads MCAP files (rosbag2's default storage, and what the `mcap` writers make), with chunks uncompressed,
//! zstd or lz4 (decompressed in pure Rust and checked against their CRC), or no chunks at all. Of each message
//! of the topic (schema `sensor_msgs/msg/Imu`, definition `ros2msg` or `ros2idl`, message encoding `cdr`, plain
//! CDR in either byte order) it keeps `header.stamp` and `angular_velocity`, which ROS gives in rad/s (REP 103)
//! and octavar converts to deg/s as channels `x`, `y`, `z`. Orientation, acceleration and the covariances are
//! decoded (to check the message's layout) but not kept: octavar characterises gyros.
//!
//! Not read: rosbag2's SQLite3 storage (`.db3`; `ros2 bag convert` writes MCAP), ROS 1 bags, XCDR2
//! encapsulation (ROS 2 middlewares send plain CDR), and files cut short or damaged anywhere in the data: an Allan
//! deviation of silently partial data is worse than an error naming the byte offset.
//!
//! Time comes from `header.stamp`, the driver's sample time, rather than the time the recorder logged the
//! message; when every stamp is zero (some drivers never set it) it comes from the MCAP log time instead, and
//! [`ImuBag::time_source`] says so. Messages are sorted by stamp (the recorder's log order may differ slightly);
//! a repeated stamp is dropped and counted. Missing messages become NaN samples placed by [`grid_positions`],
//! never interpolated.

mod chunks;
mod grid;
mod imu;
mod scan;
#[cfg(test)]
mod tests;

use std::path::Path;

use serde::Serialize;

use crate::io::recording::Recording;

use grid::build;
pub use grid::grid_positions;
pub use imu::{decode_imu, msg};
use scan::{scan, Scan, Topic, Want};

/// The ROS 2 message type read.
pub const IMU_TYPE: &str = "sensor_msgs/msg/Imu";

/// What went wrong, and where.
#[derive(Debug, thiserror::Error)]
pub enum BagError {
    /// Reading the file failed.
    #[error("reading {path}: {err}")]
    Io { path: String, err: std::io::Error },
    /// The file does not start with the MCAP magic.
    #[error("{path}: not an MCAP file (it does not start with the MCAP magic bytes{hint})")]
    NotMcap { path: String, hint: &'static str },
    /// The file ends inside a record, or a record claims more bytes than the file has.
    #[error(
        "{path}: truncated or corrupt: the file ends at byte {len}, inside the record that starts at byte offset \
         {offset} (a recording that was cut off? the mcap CLI's `mcap recover` rescues the complete chunks)"
    )]
    Truncated { path: String, offset: u64, len: u64 },
    /// A record that does not parse, a chunk that does not decompress or fails its CRC.
    #[error("{path}: corrupt MCAP at byte offset {offset}: {what}")]
    Corrupt { path: String, offset: u64, what: String },
    /// A chunk compressed with something other than zstd or lz4.
    #[error(
        "{path}: the chunk at byte offset {offset} is compressed with {compression:?}, which octavar does not read \
         (it reads zstd, lz4 and uncompressed chunks)"
    )]
    UnsupportedCompression { path: String, offset: u64, compression: String },
    /// No topic named, and the bag has no Imu topic.
    #[error("{path}: no {IMU_TYPE} topic (the bag has: {topics})")]
    NoImuTopic { path: String, topics: String },
    /// No topic named, and the bag has several Imu topics.
    #[error("{path}: several {IMU_TYPE} topics: {imu_topics}; choose one with --topic")]
    SeveralImuTopics { path: String, imu_topics: String },
    /// The topic asked for is not in the bag.
    #[error("{path}: no topic {topic:?} (the {IMU_TYPE} topics are: {imu_topics})")]
    TopicNotFound { path: String, topic: String, imu_topics: String },
    /// The topic asked for is there but is not an Imu topic octavar can read.
    #[error("{path}: topic {topic:?} is {found}, not {IMU_TYPE} in CDR (the {IMU_TYPE} topics are: {imu_topics})")]
    NotImu { path: String, topic: String, found: String, imu_topics: String },
    /// A message of the topic that does not decode.
    #[error("{path}: message {index} of topic {topic:?} does not decode as {IMU_TYPE}: {what}")]
    Decode { path: String, topic: String, index: u64, what: String },
    /// An infinite angular velocity: no sensor reports one, and it would poison every sum.
    #[error("{path}: message {index} of topic {topic:?}: angular_velocity.{axis} is {value}")]
    NotFinite { path: String, topic: String, index: u64, axis: &'static str, value: f64 },
    /// Too few messages to read (or to infer the sample rate from).
    #[error("{path}: topic {topic:?} has {messages} message(s){hint}")]
    TooFewMessages { path: String, topic: String, messages: u64, hint: &'static str },
    /// The stamps jump so far that the gaps would dwarf the data.
    #[error(
        "{path}: topic {topic:?}: the stamps jump by {jump_s} s (from {from_ns} ns to {to_ns} ns), which makes \
         {gap_samples} missing samples at {rate_hz} Hz for {messages} messages: a clock jump?"
    )]
    ClockJump {
        path: String,
        topic: String,
        jump_s: f64,
        from_ns: i64,
        to_ns: i64,
        gap_samples: u64,
        rate_hz: f64,
        messages: u64,
    },
    /// A sample rate that is not a positive number.
    #[error("sample rate {0} Hz must be a positive number")]
    BadRate(f64),
}

/// Where the sample times came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum TimeSource {
    /// The messages' `header.stamp`.
    HeaderStamp,
    /// The MCAP log time (when the recorder received the message), used when every stamp is zero.
    LogTime,
}

impl TimeSource {
    /// A short name: `header.stamp` or `log_time`.
    pub fn as_str(self) -> &'static str {
        match self {
            TimeSource::HeaderStamp => "header.stamp",
            TimeSource::LogTime => "log_time",
        }
    }
}

/// One Imu topic of a bag, read.
#[derive(Clone, Debug, PartialEq)]
pub struct ImuBag {
    /// The angular velocities as channels `x`, `y`, `z` in deg/s, NaN for missing messages.
    pub recording: Recording,
    /// The topic read.
    pub topic: String,
    /// `header.frame_id` of the first message read.
    pub frame_id: String,
    /// Where the sample times came from.
    pub time_source: TimeSource,
    /// Messages of the topic in the bag.
    pub messages: u64,
    /// Messages logged after one with a later stamp (sorted into place, kept).
    pub out_of_order: u64,
    /// Messages whose stamp repeats an earlier one's (dropped: the first logged is kept).
    pub duplicates: u64,
    /// Time of the first sample, ns (since the epoch for a stamped bag).
    pub start_ns: i64,
}

/// The Imu topics of a bag with their message counts (for listing in errors and for the CLI), by name.
///
/// # Errors
/// A file that cannot be read, is not MCAP, or is truncated or corrupt.
pub fn imu_topics(path: &Path) -> Result<Vec<(String, u64)>, BagError> {
    let scan = scan(path, Want::Nothing)?;
    let mut topics: Vec<(String, u64)> =
        scan.topics.iter().filter(|t| t.imu).map(|t| (t.name.clone(), t.messages)).collect();
    topics.sort();
    Ok(topics)
}

/// Read the angular velocities of one Imu topic of a bag.
///
/// `topic` names it; without one the bag must have exactly one Imu topic. `rate_hz` sets the sample rate; without
/// it the rate is the median step of the stamps. Gaps (a step of more than 1.5 periods) become NaN samples.
///
/// # Errors
/// See [`BagError`]: a file that is not a readable MCAP file, a topic that is missing, ambiguous or not an Imu
/// topic, a message that does not decode, too few messages, a clock jump.
pub fn read_imu_bag(path: &Path, topic: Option<&str>, rate_hz: Option<f64>) -> Result<ImuBag, BagError> {
    if let Some(r) = rate_hz {
        if !(r.is_finite() && r > 0.0) {
            return Err(BagError::BadRate(r));
        }
    }
    let name = path.display().to_string();
    let want = match topic {
        Some(t) => Want::Topic(t.to_string()),
        None => Want::AllImu,
    };
    let mut scan = scan(path, want)?;
    let idx = pick_topic(&scan, &name, topic)?;
    let data = std::mem::take(&mut scan.topics[idx]);
    if let Some(err) = data.error {
        return Err(err);
    }
    build(name, data, rate_hz)
}

/// `name (N messages), ...` for the topics `keep` selects, by name, or `none`.
fn listing(scan: &Scan, keep: impl Fn(&Topic) -> bool, with_type: bool) -> String {
    let mut items: Vec<String> = scan
        .topics
        .iter()
        .filter(|t| keep(t))
        .map(|t| {
            let kind = match (&t.other, t.imu) {
                (_, true) => IMU_TYPE.to_string(),
                (Some(o), false) => o.clone(),
                (None, false) => "?".to_string(),
            };
            if with_type {
                format!("{} ({kind}, {} messages)", t.name, t.messages)
            } else {
                format!("{} ({} messages)", t.name, t.messages)
            }
        })
        .collect();
    items.sort();
    if items.is_empty() {
        "none".to_string()
    } else {
        items.join(", ")
    }
}

/// The index of the topic to read, or the error that lists the choices.
fn pick_topic(scan: &Scan, path: &str, topic: Option<&str>) -> Result<usize, BagError> {
    let imu_topics = || listing(scan, |t| t.imu, false);
    match topic {
        None => {
            let imu: Vec<usize> = (0..scan.topics.len()).filter(|&i| scan.topics[i].imu).collect();
            match imu[..] {
                [i] => Ok(i),
                [] => Err(BagError::NoImuTopic { path: path.to_string(), topics: listing(scan, |_| true, true) }),
                _ => Err(BagError::SeveralImuTopics { path: path.to_string(), imu_topics: imu_topics() }),
            }
        }
        Some(name) => match scan.topics.iter().position(|t| t.name == name) {
            None => Err(BagError::TopicNotFound {
                path: path.to_string(),
                topic: name.to_string(),
                imu_topics: imu_topics(),
            }),
            Some(i) if !scan.topics[i].imu => Err(BagError::NotImu {
                path: path.to_string(),
                topic: name.to_string(),
                found: scan.topics[i].other.clone().unwrap_or_default(),
                imu_topics: imu_topics(),
            }),
            Some(i) => Ok(i),
        },
    }
}

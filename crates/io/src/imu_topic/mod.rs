//! One `sensor_msgs` Imu topic of a bag as a [`Recording`], whatever the container: the part the MCAP
//! ([`crate::ros2_bag`]), ROS 1 ([`crate::ros1_bag`]) and rosbag2 SQLite ([`crate::ros2_db3`]) readers
//! share.
//!
//! Each reader scans its file into [`Topics`]: every topic with its message count and whether it is an Imu topic,
//! and the decoded messages of the wanted topic as [`Sample`]s (`header.stamp`, the recorder's log time, angular
//! velocity and linear acceleration). From there the path is one: the topic is chosen (the only Imu topic, or the
//! one named), the samples are sorted by stamp and repeated stamps dropped (both counted in [`ImuBag`]), the rate
//! is the median step where none is given, and each sample is placed on the grid by [`grid_positions`] with NaN
//! where messages are missing, never interpolated. When every stamp is zero (some drivers never set it) the times
//! come from the log time instead, and [`ImuBag::time_source`] says so.
//!
//! The angular velocity, which ROS gives in rad/s (REP 103), becomes channels `x`, `y`, `z` in deg/s; the linear
//! acceleration channels `ax`, `ay`, `az` in m/s^2, where the messages give it.

mod grid;
#[cfg(test)]
mod tests;
mod topics;

use serde::Serialize;

use crate::recording::Recording;

pub(crate) use grid::build;
pub use grid::grid_positions;
pub(crate) use topics::{Message, Topics, Want};

/// What went wrong reading a bag, and where.
#[derive(Debug, thiserror::Error)]
pub enum BagError {
    /// Reading the file failed.
    #[error("reading {path}: {err}")]
    Io { path: String, err: std::io::Error },
    /// The file does not start with the MCAP magic.
    #[error("{path}: not an MCAP file (it does not start with the MCAP magic bytes{hint})")]
    NotMcap { path: String, hint: &'static str },
    /// The file does not start with the ROS 1 bag magic of format 2.0.
    #[error("{path}: not a ROS 1 bag (it does not start with \"#ROSBAG V2.0\"{hint})")]
    NotRos1Bag { path: String, hint: &'static str },
    /// The file ends inside a record, or a record claims more bytes than the file has.
    #[error(
        "{path}: truncated or corrupt: the file ends at byte {len}, inside the record that starts at byte offset \
         {offset}{hint}"
    )]
    Truncated { path: String, offset: u64, len: u64, hint: &'static str },
    /// A record that does not parse, a chunk that does not decompress or fails its check.
    #[error("{path}: corrupt {format} at byte offset {offset}: {what}")]
    Corrupt { path: String, format: &'static str, offset: u64, what: String },
    /// A chunk compressed with something octavar does not read.
    #[error(
        "{path}: the chunk at byte offset {offset} is compressed with {compression:?}, which octavar does not read \
         (it reads {reads})"
    )]
    UnsupportedCompression { path: String, offset: u64, compression: String, reads: &'static str },
    /// A rosbag2 SQLite file that SQLite cannot read, or whose tables are not rosbag2's.
    #[error("{path}: {what}")]
    Sqlite { path: String, what: String },
    /// A storage file compressed by rosbag2 (zstd, file mode) that does not decompress.
    #[error("{path}: {what}")]
    Decompress { path: String, what: String },
    /// A bag directory without the bag files octavar reads.
    #[error("{path}: a directory with no {wanted} files (a rosbag2 bag folder holds its storage files)")]
    EmptyBagDir { path: String, wanted: String },
    /// No topic named, and the bag has no Imu topic.
    #[error("{path}: no {kind} topic (the bag has: {topics})")]
    NoImuTopic { path: String, kind: &'static str, topics: String },
    /// No topic named, and the bag has several Imu topics.
    #[error("{path}: several {kind} topics: {imu_topics}; choose one with --topic")]
    SeveralImuTopics { path: String, kind: &'static str, imu_topics: String },
    /// The topic asked for is not in the bag.
    #[error("{path}: no topic {topic:?} (the {kind} topics are: {imu_topics})")]
    TopicNotFound { path: String, kind: &'static str, topic: String, imu_topics: String },
    /// The topic asked for is there but is not an Imu topic octavar can read.
    #[error("{path}: topic {topic:?} is {found}, not {kind} (the {kind} topics are: {imu_topics})")]
    NotImu { path: String, kind: &'static str, topic: String, found: String, imu_topics: String },
    /// A message of the topic that does not decode; `at` places it in the file where the index alone does not.
    #[error("{path}: message {index}{at} of topic {topic:?} does not decode as {kind}: {what}")]
    Decode { path: String, topic: String, index: u64, at: String, kind: &'static str, what: String },
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
    /// When the recorder logged the message (MCAP log time, a ROS 1 message record's time, a rosbag2 row's
    /// timestamp), used when every stamp is zero.
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
    /// The angular velocities as channels `x`, `y`, `z` in deg/s (and the linear accelerations as `ax`, `ay`,
    /// `az` in m/s^2 where the messages give them), NaN for missing messages.
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

/// The error for a sample rate that is not a positive number.
pub(crate) fn check_rate(rate_hz: Option<f64>) -> Result<(), BagError> {
    match rate_hz {
        Some(r) if !(r.is_finite() && r > 0.0) => Err(BagError::BadRate(r)),
        _ => Ok(()),
    }
}

/// What a scan asks for to read `topic` (`None`: the only Imu topic).
pub(crate) fn want(topic: Option<&str>) -> Want {
    match topic {
        Some(t) => Want::Topic(t.to_string()),
        None => Want::AllImu,
    }
}

/// The chosen topic of a scan, on its grid.
pub(crate) fn read(topics: Topics, topic: Option<&str>, rate_hz: Option<f64>) -> Result<ImuBag, BagError> {
    let path = topics.path.clone();
    build(path, topics.pick(topic)?, rate_hz)
}

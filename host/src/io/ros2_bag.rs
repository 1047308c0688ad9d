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

use std::collections::HashMap;
use std::io::Read;
use std::path::Path;

use byteorder::{BigEndian, LittleEndian};
use mcap::records::{op, Record};
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
use mcap::McapError;
use serde::Serialize;

use crate::io::csv::{RateUnit, Recording, StreamInfo};

/// The ROS 2 message type read.
pub const IMU_TYPE: &str = "sensor_msgs/msg/Imu";

/// The largest chunk octavar decompresses (writers make chunks of about a megabyte): a bigger size in a chunk
/// header is taken for corruption rather than allocated.
const MAX_CHUNK_BYTES: u64 = 1 << 32;

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

/// `sensor_msgs/msg/Imu` and the types it contains, as serde structs in CDR field order.
pub mod msg {
    use serde::Deserialize;

    /// `builtin_interfaces/Time`.
    #[derive(Clone, Debug, Deserialize, PartialEq)]
    pub struct Time {
        pub sec: i32,
        pub nanosec: u32,
    }

    /// `std_msgs/Header`.
    #[derive(Clone, Debug, Deserialize, PartialEq)]
    pub struct Header {
        pub stamp: Time,
        pub frame_id: String,
    }

    /// `geometry_msgs/Quaternion`.
    #[derive(Clone, Debug, Deserialize, PartialEq)]
    pub struct Quaternion {
        pub x: f64,
        pub y: f64,
        pub z: f64,
        pub w: f64,
    }

    /// `geometry_msgs/Vector3`.
    #[derive(Clone, Debug, Deserialize, PartialEq)]
    pub struct Vector3 {
        pub x: f64,
        pub y: f64,
        pub z: f64,
    }

    /// `sensor_msgs/msg/Imu`.
    #[derive(Clone, Debug, Deserialize, PartialEq)]
    pub struct Imu {
        pub header: Header,
        pub orientation: Quaternion,
        pub orientation_covariance: [f64; 9],
        pub angular_velocity: Vector3,
        pub angular_velocity_covariance: [f64; 9],
        pub linear_acceleration: Vector3,
        pub linear_acceleration_covariance: [f64; 9],
    }
}

/// Decode one CDR-encoded `sensor_msgs/msg/Imu` (the 4-byte encapsulation header, then the message).
///
/// # Errors
/// What is wrong, as text: a short payload, an encapsulation other than plain CDR, bytes left over.
pub fn decode_imu(data: &[u8]) -> Result<msg::Imu, String> {
    let Some((head, body)) = data.split_first_chunk::<4>() else {
        return Err(format!("{} bytes, shorter than the 4-byte CDR encapsulation header", data.len()));
    };
    let decoded = match [head[0], head[1]] {
        [0, 1] => cdr_encoding::from_bytes::<msg::Imu, LittleEndian>(body),
        [0, 0] => cdr_encoding::from_bytes::<msg::Imu, BigEndian>(body),
        [a, b] => {
            return Err(format!(
                "encapsulation {a:#04x}{b:02x} is not plain CDR (octavar reads CDR_LE 0x0001 and CDR_BE 0x0000)"
            ))
        }
    };
    let (imu, used) = decoded.map_err(|e| format!("{e} (a {}-byte message)", data.len()))?;
    // A message ends on an 8-byte boundary at most 7 bytes of padding away; more left over is another layout.
    let left = body.len() - used;
    if left >= 8 {
        return Err(format!("{left} bytes left over after the message (a different message layout?)"));
    }
    Ok(imu)
}

/// Place samples on a sample grid from their timestamps: the position of each sample, the first at 0.
///
/// `stamps_ns` are increasing times in ns, `rate_hz` the grid's rate. A step of up to 1.5 sample periods is the
/// next sample (real stamps jitter); a longer step of `d` periods skips `round(d) - 1` positions, the samples
/// missing there. The positions increase; the last plus one is the grid's length, and the positions not listed
/// are the gaps. A step that is not positive (stamps out of order or repeated) counts as one sample.
pub fn grid_positions(stamps_ns: &[i64], rate_hz: f64) -> Vec<u64> {
    let mut out = Vec::with_capacity(stamps_ns.len());
    let mut pos = 0u64;
    for (i, &t) in stamps_ns.iter().enumerate() {
        if i > 0 {
            // The step is exact in i128; dividing last keeps a step of exactly 1.5 periods at 1.5.
            let periods = (i128::from(t) - i128::from(stamps_ns[i - 1])) as f64 * rate_hz / 1e9;
            pos += if periods > 1.5 { periods.round() as u64 } else { 1 };
        }
        out.push(pos);
    }
    out
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

/// Which messages a scan decodes.
enum Want {
    /// None: count them.
    Nothing,
    /// Those of every Imu topic.
    AllImu,
    /// Those of one topic.
    Topic(String),
}

/// One message kept: its times and angular velocity (rad/s).
#[derive(Clone, Copy)]
struct Sample {
    stamp_ns: i64,
    log_time: u64,
    w: [f64; 3],
}

/// One topic of the bag.
#[derive(Default)]
struct Topic {
    name: String,
    /// Whether some channel of it is an Imu channel octavar reads.
    imu: bool,
    /// What a channel of it that is not such carries (for errors).
    other: Option<String>,
    messages: u64,
    samples: Vec<Sample>,
    frame_id: Option<String>,
    /// The first message that failed to decode.
    error: Option<BagError>,
}

struct Channel {
    topic: usize,
    imu: bool,
}

struct Schema {
    name: String,
    encoding: String,
}

/// The state of one pass over a bag.
struct Scan {
    path: String,
    want: Want,
    schemas: HashMap<u16, Schema>,
    channels: HashMap<u16, Channel>,
    topics: Vec<Topic>,
    zstd: Option<ruzstd::decoding::FrameDecoder>,
    /// Decompressed chunk content, reused.
    scratch: Vec<u8>,
}

/// A failed walk over records: the reader's error at a record's offset, or the caller's.
enum WalkError {
    Mcap { offset: u64, err: McapError },
    Stop(BagError),
}

/// Walk the records of `buf`, a whole file (`chunk` false) or a chunk's content, calling `f` with each record
/// that octavar reads (schemas, channels, messages, chunks) and the byte offset it starts at.
fn walk_records(
    buf: &[u8],
    chunk: bool,
    mut f: impl FnMut(u64, Record<'_>) -> Result<(), BagError>,
) -> Result<(), WalkError> {
    let opts = LinearReaderOptions::default()
        .with_skip_start_magic(chunk)
        .with_skip_end_magic(chunk)
        .with_emit_chunks(true)
        .with_validate_data_section_crc(!chunk)
        .with_record_length_limit(buf.len());
    let mut reader = LinearReader::new_with_options(opts);
    // Fed exactly the bytes it asks for, the reader has consumed all it was fed when it yields a record: `fed`
    // is then that record's end.
    let mut fed = 0usize;
    let mut end = if chunk { 0 } else { mcap::MAGIC.len() };
    while let Some(event) = reader.next_event() {
        match event.map_err(|err| WalkError::Mcap { offset: end as u64, err })? {
            LinearReadEvent::ReadRequest(need) => {
                let n = need.min(buf.len() - fed);
                reader.insert(n).copy_from_slice(&buf[fed..fed + n]);
                reader.notify_read(n);
                fed += n;
            }
            LinearReadEvent::Record { opcode, data } => {
                let start = end as u64;
                end = fed;
                if matches!(opcode, op::SCHEMA | op::CHANNEL | op::MESSAGE | op::CHUNK) {
                    let record =
                        mcap::parse_record(opcode, data).map_err(|err| WalkError::Mcap { offset: start, err })?;
                    f(start, record).map_err(WalkError::Stop)?;
                }
            }
        }
    }
    Ok(())
}

/// One pass over the bag at `path`: its topics, and the samples of those `want` names.
fn scan(path: &Path, want: Want) -> Result<Scan, BagError> {
    let name = path.display().to_string();
    let buf = std::fs::read(path).map_err(|err| BagError::Io { path: name.clone(), err })?;
    if !buf.starts_with(mcap::MAGIC) {
        let hint = match buf.len() {
            0 => ": the file is empty",
            n if n < mcap::MAGIC.len() && mcap::MAGIC.starts_with(&buf) => ": the file is cut short",
            _ if buf.starts_with(b"SQLite format 3") => {
                ": it is SQLite, rosbag2's older storage; `ros2 bag convert` writes MCAP"
            }
            _ if buf.starts_with(b"#ROSBAG") => ": it is a ROS 1 bag",
            _ => "",
        };
        return Err(BagError::NotMcap { path: name, hint });
    }
    let mut scan = Scan {
        path: name,
        want,
        schemas: HashMap::new(),
        channels: HashMap::new(),
        topics: Vec::new(),
        zstd: None,
        scratch: Vec::new(),
    };
    let len = buf.len() as u64;
    walk_records(&buf, false, |offset, record| scan.record(offset, record, false)).map_err(|e| match e {
        WalkError::Stop(err) => err,
        WalkError::Mcap { offset, err } => scan.mcap_error(offset, len, err),
    })?;
    Ok(scan)
}

impl Scan {
    /// The error for the reader's `err` at the record starting at `offset` of a file of `len` bytes.
    fn mcap_error(&self, offset: u64, len: u64, err: McapError) -> BagError {
        let path = self.path.clone();
        match err {
            McapError::UnexpectedEof => BagError::Truncated { path, offset, len },
            McapError::RecordTooLarge { len: record, .. } | McapError::ChunkTooLarge(record)
                if offset.saturating_add(9).saturating_add(record) > len =>
            {
                BagError::Truncated { path, offset, len }
            }
            err => BagError::Corrupt { path, offset, what: err.to_string() },
        }
    }

    /// Take one record: top-level, or (`in_chunk`) from a chunk that starts at `offset`.
    fn record(&mut self, offset: u64, record: Record<'_>, in_chunk: bool) -> Result<(), BagError> {
        match record {
            Record::Schema { header, .. } => {
                self.schemas.insert(header.id, Schema { name: header.name, encoding: header.encoding });
            }
            Record::Channel(c) => self.channel(offset, c)?,
            Record::Message { header, data } => self.message(offset, header.channel_id, header.log_time, &data)?,
            // Chunks hold schemas, channels and messages only; one inside another is damage (and would recurse).
            Record::Chunk { .. } if in_chunk => {
                let what = "a chunk inside the chunk".to_string();
                return Err(BagError::Corrupt { path: self.path.clone(), offset, what });
            }
            Record::Chunk { header, data } => self.chunk(offset, &header, &data)?,
            _ => {}
        }
        Ok(())
    }

    fn channel(&mut self, offset: u64, c: mcap::records::Channel) -> Result<(), BagError> {
        if self.channels.contains_key(&c.id) {
            return Ok(()); // The summary repeats the channels.
        }
        let schema = match c.schema_id {
            0 => None,
            id => Some(self.schemas.get(&id).ok_or_else(|| BagError::Corrupt {
                path: self.path.clone(),
                offset,
                what: format!(
                    "channel {} ({:?}) refers to schema {id}, which no record before it defines",
                    c.id, c.topic
                ),
            })?),
        };
        let imu = schema.is_some_and(|s| s.name == IMU_TYPE && matches!(s.encoding.as_str(), "ros2msg" | "ros2idl"))
            && c.message_encoding == "cdr";
        let topic = match self.topics.iter().position(|t| t.name == c.topic) {
            Some(i) => i,
            None => {
                self.topics.push(Topic { name: c.topic.clone(), ..Topic::default() });
                self.topics.len() - 1
            }
        };
        let t = &mut self.topics[topic];
        if imu {
            t.imu = true;
        } else if t.other.is_none() {
            t.other = Some(match schema {
                None => format!("schemaless {:?}", c.message_encoding),
                Some(s) if s.name == IMU_TYPE => {
                    format!("{IMU_TYPE} with a {:?} schema in {:?}", s.encoding, c.message_encoding)
                }
                Some(s) => format!("{} ({:?})", s.name, c.message_encoding),
            });
        }
        self.channels.insert(c.id, Channel { topic, imu });
        Ok(())
    }

    fn message(&mut self, offset: u64, channel: u16, log_time: u64, data: &[u8]) -> Result<(), BagError> {
        let Some(c) = self.channels.get(&channel) else {
            return Err(BagError::Corrupt {
                path: self.path.clone(),
                offset,
                what: format!("a message on channel {channel}, which no record before it defines"),
            });
        };
        let (imu, t) = (c.imu, &mut self.topics[c.topic]);
        t.messages += 1;
        let wanted = match &self.want {
            Want::Nothing => false,
            Want::AllImu => imu,
            Want::Topic(name) => imu && *name == t.name,
        };
        if !wanted || t.error.is_some() {
            return Ok(());
        }
        let index = t.messages;
        let fail = |what: String| BagError::Decode { path: self.path.clone(), topic: t.name.clone(), index, what };
        let m = match decode_imu(data) {
            Ok(m) => m,
            Err(what) => {
                t.error = Some(fail(what));
                return Ok(());
            }
        };
        let w = [m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z];
        if let Some(axis) = (0..3).find(|&a| w[a].is_infinite()) {
            let err = BagError::NotFinite {
                path: self.path.clone(),
                topic: t.name.clone(),
                index,
                axis: ["x", "y", "z"][axis],
                value: w[axis],
            };
            t.error = Some(err);
            return Ok(());
        }
        if t.frame_id.is_none() {
            t.frame_id = Some(m.header.frame_id);
        }
        let stamp_ns = i64::from(m.header.stamp.sec) * 1_000_000_000 + i64::from(m.header.stamp.nanosec);
        t.samples.push(Sample { stamp_ns, log_time, w });
        Ok(())
    }

    /// Decompress a chunk, check its CRC, and take the records in it.
    fn chunk(&mut self, offset: u64, header: &mcap::records::ChunkHeader, data: &[u8]) -> Result<(), BagError> {
        let path = self.path.clone();
        let corrupt = |what: String| BagError::Corrupt { path: path.clone(), offset, what };
        let size = header.uncompressed_size;
        let compression = header.compression.as_str();
        if size > MAX_CHUNK_BYTES {
            return Err(corrupt(format!("the chunk claims {size} bytes uncompressed")));
        }
        let mut out = std::mem::take(&mut self.scratch);
        let content: &[u8] = match compression {
            "" => data,
            "zstd" | "lz4" => {
                out.clear();
                out.try_reserve_exact(size as usize)
                    .map_err(|_| corrupt(format!("the chunk claims {size} bytes uncompressed")))?;
                out.resize(size as usize, 0);
                let done = if compression == "zstd" {
                    let dec = self.zstd.get_or_insert_with(ruzstd::decoding::FrameDecoder::new);
                    dec.decode_all(data, &mut out).map_err(|e| e.to_string()).and_then(|n| {
                        if n as u64 == size {
                            Ok(())
                        } else {
                            Err(format!("{n} bytes decompressed where the chunk header says {size}"))
                        }
                    })
                } else {
                    lz4_flex::frame::FrameDecoder::new(data).read_exact(&mut out).map_err(|e| e.to_string())
                };
                done.map_err(|e| corrupt(format!("the {compression} chunk does not decompress: {e}")))?;
                &out
            }
            _ => {
                return Err(BagError::UnsupportedCompression {
                    path: self.path.clone(),
                    offset,
                    compression: compression.to_string(),
                })
            }
        };
        if content.len() as u64 != size {
            return Err(corrupt(format!("the chunk holds {} bytes where its header says {size}", content.len())));
        }
        if header.uncompressed_crc != 0 {
            let crc = crc32fast::hash(content);
            if crc != header.uncompressed_crc {
                return Err(corrupt(format!(
                    "the chunk's CRC is {crc:08x} where its header says {:08x}",
                    header.uncompressed_crc
                )));
            }
        }
        let walked = walk_records(content, true, |_, record| self.record(offset, record, true));
        let walked = walked.map_err(|e| match e {
            WalkError::Stop(err) => err,
            WalkError::Mcap { offset: inner, err } => BagError::Corrupt {
                path: self.path.clone(),
                offset,
                what: format!("in the chunk, at byte {inner} of its {size} uncompressed bytes: {err}"),
            },
        });
        self.scratch = out;
        walked
    }
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

/// The recording of one topic's samples: sorted, de-duplicated, placed on the grid.
fn build(path: String, t: Topic, rate_hz: Option<f64>) -> Result<ImuBag, BagError> {
    let mut samples = t.samples;
    let too_few =
        |hint| BagError::TooFewMessages { path: path.clone(), topic: t.name.clone(), messages: t.messages, hint };
    if samples.is_empty() || (samples.len() < 2 && rate_hz.is_none()) {
        return Err(too_few(if samples.is_empty() { "" } else { ": give --rate to read one sample" }));
    }
    let time_source = if samples.iter().all(|s| s.stamp_ns == 0) {
        for s in &mut samples {
            s.stamp_ns = i64::try_from(s.log_time).unwrap_or(i64::MAX);
        }
        TimeSource::LogTime
    } else {
        TimeSource::HeaderStamp
    };

    let mut out_of_order = 0u64;
    let mut latest = i64::MIN;
    for s in &samples {
        if s.stamp_ns < latest {
            out_of_order += 1;
        }
        latest = latest.max(s.stamp_ns);
    }
    if out_of_order > 0 {
        samples.sort_by_key(|s| s.stamp_ns); // Stable: of equal stamps, the first logged stays first.
    }
    let before = samples.len();
    samples.dedup_by_key(|s| s.stamp_ns);
    let duplicates = (before - samples.len()) as u64;
    if samples.len() < 2 && rate_hz.is_none() {
        return Err(too_few(": one distinct stamp; give --rate to read one sample"));
    }

    let stamps: Vec<i64> = samples.iter().map(|s| s.stamp_ns).collect();
    let rate_hz = match rate_hz {
        Some(r) => r,
        None => {
            let mut steps: Vec<i64> = stamps.windows(2).map(|w| w[1] - w[0]).collect();
            let mid = steps.len() / 2;
            let (_, &mut upper, _) = steps.select_nth_unstable(mid);
            let median = if steps.len() % 2 == 1 {
                upper as f64
            } else {
                let lower = *steps[..mid].iter().max().expect("an even count of at least 2");
                (lower as f64 + upper as f64) / 2.0
            };
            1e9 / median
        }
    };

    let positions = grid_positions(&stamps, rate_hz);
    let n = positions.len() as u64;
    let len = positions.last().map_or(0, |p| p + 1);
    if len - n > 9 * n && len > 10_000_000 {
        let (i, jump) = (1..stamps.len()).map(|i| (i, stamps[i] - stamps[i - 1])).max_by_key(|p| p.1).unwrap_or((0, 0));
        return Err(BagError::ClockJump {
            path,
            topic: t.name,
            jump_s: jump as f64 * 1e-9,
            from_ns: stamps[i.saturating_sub(1)],
            to_ns: stamps[i],
            gap_samples: len - n,
            rate_hz,
            messages: n,
        });
    }

    let k = RateUnit::RadPerS.to_dps();
    let mut channels = vec![vec![f64::NAN; len as usize]; 3];
    for (s, &p) in samples.iter().zip(&positions) {
        for (c, w) in channels.iter_mut().zip(s.w) {
            c[p as usize] = w * k;
        }
    }
    let gaps = channels.iter().flatten().filter(|v| v.is_nan()).count() as u64;
    let names: Vec<String> = ["x", "y", "z"].iter().map(|s| s.to_string()).collect();
    let info = StreamInfo { columns: names.clone(), rate_hz, samples: len, gaps, filtered_out: 0 };
    Ok(ImuBag {
        recording: Recording { source: path, names, channels, temp_c: None, rate_hz, info },
        topic: t.name,
        frame_id: t.frame_id.unwrap_or_default(),
        time_source,
        messages: t.messages,
        out_of_order,
        duplicates,
        start_ns: stamps[0],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_steps_jitter_and_gaps() {
        let ms = 1_000_000i64; // 200 Hz: 5 ms periods
        assert_eq!(grid_positions(&[], 200.0), Vec::<u64>::new());
        assert_eq!(grid_positions(&[7], 200.0), vec![0]);
        // Regular, then jittered steps up to 1.5 periods: one sample each.
        let t = [0, 5 * ms, 10 * ms, 13 * ms, 20 * ms, 27 * ms + ms / 2];
        assert_eq!(grid_positions(&t, 200.0), vec![0, 1, 2, 3, 4, 5]);
        // 1.6 periods: one missing; 3 periods: two; 2.5 rounds to 3 (two missing); 10.4 periods: nine.
        let t = [0, 8 * ms, 23 * ms, 35 * ms + ms / 2, 87 * ms + ms / 2];
        assert_eq!(grid_positions(&t, 200.0), vec![0, 2, 5, 8, 18]);
        // Steps that are not positive count as one sample.
        assert_eq!(grid_positions(&[10, 10, 5], 200.0), vec![0, 1, 2]);
        // Stamps far from zero (since the epoch) lose nothing.
        let base = 1_700_000_000_123_456_789i64;
        let t: Vec<i64> = [0, 1, 2, 5, 6].iter().map(|k| base + k * 5 * ms).collect();
        assert_eq!(grid_positions(&t, 200.0), vec![0, 1, 2, 5, 6]);
    }

    /// A CDR_LE `sensor_msgs/msg/Imu` written byte by byte: the encapsulation header, then fields aligned to their
    /// size counted from after the header.
    fn hand_built(frame_id: &str, w: [f64; 3]) -> Vec<u8> {
        let mut b = vec![0x00, 0x01, 0x00, 0x00];
        let body = |b: &Vec<u8>| b.len() - 4;
        b.extend(1_700_000_123i32.to_le_bytes()); // stamp.sec
        b.extend(456_789_012u32.to_le_bytes()); // stamp.nanosec
        b.extend((frame_id.len() as u32 + 1).to_le_bytes());
        b.extend(frame_id.as_bytes());
        b.push(0);
        while body(&b) % 8 != 0 {
            b.push(0xAA); // padding before the first float64 (its content is not read)
        }
        fn f(b: &mut Vec<u8>, v: f64) {
            b.extend(v.to_le_bytes());
        }
        for v in [0.1, 0.2, 0.3, 0.9] {
            f(&mut b, v); // orientation
        }
        for i in 0..9 {
            f(&mut b, i as f64); // orientation_covariance
        }
        for v in w {
            f(&mut b, v);
        }
        for i in 0..9 {
            f(&mut b, 10.0 + i as f64);
        }
        for v in [0.0, 0.0, 9.81] {
            f(&mut b, v);
        }
        for i in 0..9 {
            f(&mut b, 20.0 + i as f64);
        }
        b
    }

    fn topic(stamps: &[i64]) -> Topic {
        let samples = stamps
            .iter()
            .enumerate()
            .map(|(i, &t)| Sample { stamp_ns: t, log_time: 1000 + i as u64 * 10, w: [i as f64, 0.0, -1.0] })
            .collect::<Vec<_>>();
        Topic { name: "/imu".into(), imu: true, messages: stamps.len() as u64, samples, ..Topic::default() }
    }

    #[test]
    fn build_sorts_drops_repeats_and_places_gaps() {
        let ms = 1_000_000;
        // Logged out of order (3 before 2), 4 repeated, 6 missing; the rate is the median step, 1 ms.
        let b = build("b.mcap".into(), topic(&[0, ms, 3 * ms, 2 * ms, 4 * ms, 4 * ms, 5 * ms, 7 * ms]), None).unwrap();
        assert_eq!((b.out_of_order, b.duplicates, b.messages), (1, 1, 8));
        assert_eq!(b.recording.rate_hz, 1000.0);
        assert_eq!(b.time_source, TimeSource::HeaderStamp);
        let k = RateUnit::RadPerS.to_dps();
        let want = [0.0, 1.0, 3.0, 2.0, 4.0, 6.0, f64::NAN, 7.0];
        let x = &b.recording.channels[0];
        assert_eq!(x.len(), want.len());
        for (i, (g, w)) in x.iter().zip(want).enumerate() {
            assert!(g.to_bits() == (w * k).to_bits() || (g.is_nan() && w.is_nan()), "{i}: {x:?}");
        }
        assert_eq!((b.recording.info.samples, b.recording.info.gaps), (8, 3));
        // An even count of steps: the median is the mean of the middle two (1 and 3 ms).
        let b = build("b.mcap".into(), topic(&[0, ms, 4 * ms]), None).unwrap();
        assert_eq!(b.recording.rate_hz, 500.0);
        // Every stamp zero: the log times (10 ns apart) instead.
        let b = build("b.mcap".into(), topic(&[0, 0, 0, 0]), None).unwrap();
        assert_eq!((b.time_source, b.start_ns, b.recording.rate_hz), (TimeSource::LogTime, 1000, 1e8));
        // One message needs a rate; none is an error.
        assert!(matches!(build("b".into(), topic(&[5]), None), Err(BagError::TooFewMessages { .. })));
        assert_eq!(build("b".into(), topic(&[5]), Some(100.0)).unwrap().recording.info.samples, 1);
        assert!(matches!(build("b".into(), topic(&[]), Some(100.0)), Err(BagError::TooFewMessages { .. })));
        // A clock jump of a day at 1 kHz is refused rather than filled with 86 million NaN.
        let mut stamps: Vec<i64> = (0..1000).map(|i| i * ms).collect();
        stamps.push(86_400_000 * ms);
        let err = build("b".into(), topic(&stamps), None).unwrap_err();
        assert!(matches!(err, BagError::ClockJump { messages: 1001, .. }), "{err}");
    }

    #[test]
    fn decodes_a_hand_built_message() {
        for frame in ["imu_link", "", "abc", "imu"] {
            let b = hand_built(frame, [0.01, -0.02, 1.5e-4]);
            let m = decode_imu(&b).unwrap();
            assert_eq!(m.header.stamp, msg::Time { sec: 1_700_000_123, nanosec: 456_789_012 });
            assert_eq!(m.header.frame_id, frame);
            assert_eq!(m.orientation, msg::Quaternion { x: 0.1, y: 0.2, z: 0.3, w: 0.9 });
            assert_eq!(m.orientation_covariance[8], 8.0);
            assert_eq!(m.angular_velocity, msg::Vector3 { x: 0.01, y: -0.02, z: 1.5e-4 });
            assert_eq!(m.angular_velocity_covariance[0], 10.0);
            assert_eq!(m.linear_acceleration.z, 9.81);
            assert_eq!(m.linear_acceleration_covariance[8], 28.0);
        }
        // Big-endian: the same fields, each byte-swapped.
        let mut be = vec![0x00, 0x00, 0x00, 0x00];
        be.extend(7i32.to_be_bytes());
        be.extend(8u32.to_be_bytes());
        be.extend(1u32.to_be_bytes());
        be.extend([0, 0, 0, 0]); // the empty string's NUL and padding to 8
        for i in 0..(4 + 9 + 3 + 9 + 3 + 9) {
            be.extend((i as f64).to_be_bytes());
        }
        let m = decode_imu(&be).unwrap();
        assert_eq!((m.header.stamp.sec, m.header.stamp.nanosec), (7, 8));
        assert_eq!(m.angular_velocity, msg::Vector3 { x: 13.0, y: 14.0, z: 15.0 });
    }

    #[test]
    fn rejects_what_is_not_an_imu() {
        let b = hand_built("imu_link", [1.0, 2.0, 3.0]);
        assert!(decode_imu(&b[..3]).unwrap_err().contains("shorter than"));
        assert!(decode_imu(&b[..b.len() - 1]).is_err());
        assert!(decode_imu(&b[..40]).is_err());
        let mut xcdr2 = b.clone();
        xcdr2[1] = 0x07;
        assert!(decode_imu(&xcdr2).unwrap_err().contains("not plain CDR"));
        let mut longer = b.clone();
        longer.extend([0u8; 16]);
        assert!(decode_imu(&longer).unwrap_err().contains("left over"));
        // A string length past the end of the message.
        let mut bad = b;
        bad[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(decode_imu(&bad).is_err());
    }
}

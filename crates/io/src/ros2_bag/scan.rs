//! One pass over an MCAP file's records: schemas and channels gathered into topics (noting which are Imu topics
//! octavar reads), the messages of the wanted topics decoded into samples, and the MCAP reader's errors reported as
//! a truncated or corrupt file at a byte offset. The `chunks` module opens chunks; their records come back here.

use std::collections::HashMap;
use std::path::Path;

use mcap::records::{op, Record};
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
use mcap::McapError;

use super::imu::{decode_imu, kept};
use super::{BagError, IMU_TYPE};
use crate::imu_topic::{Topics, Want};
use crate::rosbag2_dir::Storage;

/// What a cut-off MCAP file's error suggests.
const TRUNCATED_HINT: &str =
    " (a recording that was cut off? the mcap CLI's `mcap recover` rescues the complete chunks)";

struct Channel {
    topic: usize,
    imu: bool,
}

struct Schema {
    name: String,
    encoding: String,
}

/// The state of one pass over a bag.
pub(super) struct Scan {
    pub(super) path: String,
    want: Want,
    schemas: HashMap<u16, Schema>,
    channels: HashMap<u16, Channel>,
    pub(super) topics: Topics,
    pub(super) zstd: Option<ruzstd::decoding::FrameDecoder>,
    /// Decompressed chunk content, reused.
    pub(super) scratch: Vec<u8>,
}

/// A failed walk over records: the reader's error at a record's offset, or the caller's.
pub(super) enum WalkError {
    Mcap { offset: u64, err: McapError },
    Stop(BagError),
}

/// Walk the records of `buf`, a whole file (`chunk` false) or a chunk's content, calling `f` with each record
/// that octavar reads (schemas, channels, messages, chunks) and the byte offset it starts at.
pub(super) fn walk_records(
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

/// One pass over the bag at `path` (an MCAP file, or a rosbag2 folder of them read in split order): its topics,
/// and the samples of those `want` names.
pub(super) fn scan(path: &Path, want: Want) -> Result<Scan, BagError> {
    let files = Storage::Mcap.bag_files(path)?;
    let mut scan = Scan {
        topics: Topics::new(path.display().to_string(), IMU_TYPE),
        path: String::new(),
        want,
        schemas: HashMap::new(),
        channels: HashMap::new(),
        zstd: None,
        scratch: Vec::new(),
    };
    for file in files {
        scan.file(&file)?;
    }
    Ok(scan)
}

impl Scan {
    /// One MCAP file of the bag, its schema and channel ids its own.
    fn file(&mut self, path: &Path) -> Result<(), BagError> {
        let name = path.display().to_string();
        let mut buf = std::fs::read(path).map_err(|err| BagError::Io { path: name.clone(), err })?;
        if crate::rosbag2_zstd::is_zstd(&buf) {
            // A storage file that rosbag2 compressed whole (`NAME_0.mcap.zstd`).
            buf = crate::rosbag2_zstd::whole(&buf).map_err(|e| BagError::Decompress {
                path: name.clone(),
                what: format!("decompressing it (zstd, rosbag2's file compression): {e}"),
            })?;
        }
        if !buf.starts_with(mcap::MAGIC) {
            let hint = match buf.len() {
                0 => ": the file is empty",
                n if n < mcap::MAGIC.len() && mcap::MAGIC.starts_with(&buf) => ": the file is cut short",
                _ if buf.starts_with(b"SQLite format 3") => {
                    ": it is SQLite, rosbag2's older storage: read it as such (--format db3)"
                }
                _ if buf.starts_with(b"#ROSBAG") => ": it is a ROS 1 bag",
                _ => "",
            };
            return Err(BagError::NotMcap { path: name, hint });
        }
        (self.path, self.schemas, self.channels) = (name, HashMap::new(), HashMap::new());
        let len = buf.len() as u64;
        walk_records(&buf, false, |offset, record| self.record(offset, record, false)).map_err(|e| match e {
            WalkError::Stop(err) => err,
            WalkError::Mcap { offset, err } => self.mcap_error(offset, len, err),
        })
    }
}

impl Scan {
    /// The error for the reader's `err` at the record starting at `offset` of a file of `len` bytes.
    fn mcap_error(&self, offset: u64, len: u64, err: McapError) -> BagError {
        let path = self.path.clone();
        match err {
            McapError::UnexpectedEof => BagError::Truncated { path, offset, len, hint: TRUNCATED_HINT },
            McapError::RecordTooLarge { len: record, .. } | McapError::ChunkTooLarge(record)
                if offset.saturating_add(9).saturating_add(record) > len =>
            {
                BagError::Truncated { path, offset, len, hint: TRUNCATED_HINT }
            }
            err => BagError::Corrupt { path, format: "MCAP", offset, what: err.to_string() },
        }
    }

    /// Take one record: top-level, or (`in_chunk`) from a chunk that starts at `offset`.
    pub(super) fn record(&mut self, offset: u64, record: Record<'_>, in_chunk: bool) -> Result<(), BagError> {
        match record {
            Record::Schema { header, .. } => {
                self.schemas.insert(header.id, Schema { name: header.name, encoding: header.encoding });
            }
            Record::Channel(c) => self.channel(offset, c)?,
            Record::Message { header, data } => self.message(offset, header.channel_id, header.log_time, &data)?,
            // Chunks hold schemas, channels and messages only; one inside another is damage (and would recurse).
            Record::Chunk { .. } if in_chunk => {
                let what = "a chunk inside the chunk".to_string();
                return Err(BagError::Corrupt { path: self.path.clone(), format: "MCAP", offset, what });
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
                format: "MCAP",
                offset,
                what: format!(
                    "channel {} ({:?}) refers to schema {id}, which no record before it defines",
                    c.id, c.topic
                ),
            })?),
        };
        let imu = schema.is_some_and(|s| s.name == IMU_TYPE && matches!(s.encoding.as_str(), "ros2msg" | "ros2idl"))
            && c.message_encoding == "cdr";
        let topic = self.topics.index(&c.topic);
        self.topics.connection(topic, imu, || match schema {
            None => format!("schemaless {:?}", c.message_encoding),
            Some(s) if s.name == IMU_TYPE => {
                format!("{IMU_TYPE} with a {:?} schema in {:?}", s.encoding, c.message_encoding)
            }
            Some(s) => format!("{} ({:?})", s.name, c.message_encoding),
        });
        self.channels.insert(c.id, Channel { topic, imu });
        Ok(())
    }

    fn message(&mut self, offset: u64, channel: u16, log_time: u64, data: &[u8]) -> Result<(), BagError> {
        let Some(c) = self.channels.get(&channel) else {
            return Err(BagError::Corrupt {
                path: self.path.clone(),
                format: "MCAP",
                offset,
                what: format!("a message on channel {channel}, which no record before it defines"),
            });
        };
        let t = &mut self.topics.list[c.topic];
        if !t.count(&self.want, c.imu) {
            return Ok(());
        }
        let decoded = decode_imu(data);
        let decoded = decoded.as_ref().map(|m| kept(m, log_time));
        t.take(&self.path, IMU_TYPE, String::new, decoded.map_err(Clone::clone));
        Ok(())
    }
}

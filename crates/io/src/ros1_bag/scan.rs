//! One pass over a ROS 1 bag (format 2.0): the bag header, then the chunks in file order (their connection and
//! message records), then the index (the connections again and the chunk infos). Connections become topics; the
//! messages of the wanted topics are decoded into samples. The bag header's counts of chunks and connections and
//! the index position check that the file is whole: a bag cut off at a record boundary is an error too.

use std::collections::HashMap;
use std::path::Path;

use super::chunk::{self, ChunkError};
use super::imu::decode_imu;
use super::record::{op, Fields, Record, RecordError, Records};
use super::IMU_TYPE;
use crate::imu_topic::{BagError, Message, Topics, Want};

/// The first bytes of a ROS 1 bag of format 2.0.
pub(super) const MAGIC: &[u8] = b"#ROSBAG V2.0\n";

/// What the error about a cut-off bag suggests.
const TRUNCATED_HINT: &str = " (a recording that was cut off? `rosbag reindex` rebuilds a bag from its whole chunks)";

/// The format's name in errors.
const FORMAT: &str = "ROS 1 bag";

struct Connection {
    topic: usize,
    imu: bool,
}

/// The state of one pass over a bag.
pub(super) struct Scan {
    pub(super) topics: Topics,
    path: String,
    want: Want,
    connections: HashMap<u32, Connection>,
    /// Decompressed chunk content, reused.
    scratch: Vec<u8>,
}

/// One pass over the bag at `path`: its topics, and the samples of those `want` names.
pub(super) fn scan(path: &Path, want: Want) -> Result<Scan, BagError> {
    let name = path.display().to_string();
    let buf = std::fs::read(path).map_err(|err| BagError::Io { path: name.clone(), err })?;
    let mut scan = Scan {
        topics: Topics::new(name.clone(), IMU_TYPE),
        path: name,
        want,
        connections: HashMap::new(),
        scratch: Vec::new(),
    };
    scan.file(&buf)?;
    Ok(scan)
}

impl Scan {
    fn corrupt(&self, offset: usize, what: String) -> BagError {
        BagError::Corrupt { path: self.path.clone(), format: FORMAT, offset: offset as u64, what }
    }

    /// The error for a record of the file that does not parse or is cut short.
    fn record_error(&self, err: RecordError, len: usize) -> BagError {
        match err {
            RecordError::Short { offset } => BagError::Truncated {
                path: self.path.clone(),
                offset: offset as u64,
                len: len as u64,
                hint: TRUNCATED_HINT,
            },
            RecordError::Bad { offset, what } => self.corrupt(offset, what),
        }
    }

    /// Walk the whole file.
    fn file(&mut self, buf: &[u8]) -> Result<(), BagError> {
        if !buf.starts_with(MAGIC) {
            let hint = match buf.len() {
                0 => ": the file is empty",
                n if n < MAGIC.len() && MAGIC.starts_with(buf) => ": the file is cut short",
                _ if buf.starts_with(b"#ROSBAG V") || buf.starts_with(b"#ROSRECORD V") => {
                    ": it is a bag of an older format; `rosbag filter OLD.bag NEW.bag True` rewrites it as 2.0"
                }
                _ if buf.starts_with(b"\x89MCAP") => ": it is MCAP, a ROS 2 bag",
                _ if buf.starts_with(b"SQLite format 3") => ": it is SQLite, a ROS 2 bag's .db3",
                _ => "",
            };
            return Err(BagError::NotRos1Bag { path: self.path.clone(), hint });
        }
        let len = buf.len();
        let mut records = Records::new(buf, MAGIC.len());
        let header = match records.next() {
            None => return Err(self.record_error(RecordError::Short { offset: MAGIC.len() }, len)),
            Some(r) => r.map_err(|e| self.record_error(e, len))?,
        };
        let at = header.offset;
        if header.fields.op != Some(op::BAG_HEADER) {
            return Err(
                self.corrupt(at, format!("the first record has op {:?}, not the bag header's", header.fields.op))
            );
        }
        let (Some(index_pos), Some(conn_count), Some(chunk_count)) =
            (header.fields.index_pos, header.fields.conn_count, header.fields.chunk_count)
        else {
            return Err(self.corrupt(at, "the bag header lacks index_pos, conn_count or chunk_count".into()));
        };
        if index_pos == 0 {
            return Err(self.corrupt(
                at,
                "the bag header has no index: the recorder did not close the bag (`rosbag reindex` rebuilds it)".into(),
            ));
        }
        let (mut chunks, mut chunk_infos) = (0u64, 0u64);
        for record in records {
            let r = record.map_err(|e| self.record_error(e, len))?;
            match r.fields.op {
                Some(op::CHUNK) => {
                    chunks += 1;
                    self.chunk(&r)?;
                }
                Some(op::CONNECTION) => self.connection(r.offset, &r)?,
                Some(op::MESSAGE) => {
                    let at = r.offset;
                    self.message(r.offset, &r, || format!(" (byte offset {at})"))?
                }
                Some(op::CHUNK_INFO) => chunk_infos += 1,
                Some(op::INDEX_DATA) => {}
                other => return Err(self.corrupt(r.offset, format!("a record with op {other:?} at the top level"))),
            }
        }
        if index_pos > len as u64 {
            let what = format!(
                "the bag header puts the index at byte {index_pos}, past the file's end at byte {len}: cut \
                 off?{TRUNCATED_HINT}"
            );
            return Err(self.corrupt(at, what));
        }
        if chunk_infos != u64::from(chunk_count) && chunks == u64::from(chunk_count) {
            let what = format!(
                "the index ends after {chunk_infos} of its {chunk_count} chunk infos: cut off?{TRUNCATED_HINT}"
            );
            return Err(self.corrupt(at, what));
        }
        if chunks != u64::from(chunk_count) || self.connections.len() as u64 != u64::from(conn_count) {
            return Err(self.corrupt(
                at,
                format!(
                    "the bag header counts {chunk_count} chunks and {conn_count} connections, the file has {chunks} \
                     and {}",
                    self.connections.len()
                ),
            ));
        }
        Ok(())
    }

    /// Decompress a chunk and take its connections and messages.
    fn chunk(&mut self, r: &Record<'_>) -> Result<(), BagError> {
        let at = r.offset;
        let (Some(compression), Some(size)) = (r.fields.compression, r.fields.size) else {
            return Err(self.corrupt(at, "a chunk header without compression or size".into()));
        };
        let mut out = std::mem::take(&mut self.scratch);
        let content = match chunk::content(compression, r.data, size, &mut out) {
            Ok(c) => c,
            Err(ChunkError::Unsupported(compression)) => {
                return Err(BagError::UnsupportedCompression {
                    path: self.path.clone(),
                    offset: at as u64,
                    compression,
                    reads: chunk::READS,
                })
            }
            Err(ChunkError::Bad(what)) => return Err(self.corrupt(at, what)),
        };
        let walked = self.chunk_records(at, content, size);
        self.scratch = out;
        walked
    }

    /// The records of a chunk's content.
    fn chunk_records(&mut self, at: usize, content: &[u8], size: u32) -> Result<(), BagError> {
        let inner = |offset: usize, what: &str| format!("in the chunk, at byte {offset} of its {size} bytes: {what}");
        for record in Records::new(content, 0) {
            let r = match record {
                Ok(r) => r,
                Err(RecordError::Short { offset }) => {
                    return Err(self.corrupt(at, inner(offset, "a record longer than the chunk")))
                }
                Err(RecordError::Bad { offset, what }) => return Err(self.corrupt(at, inner(offset, &what))),
            };
            match r.fields.op {
                Some(op::CONNECTION) => self.connection(at, &r)?,
                Some(op::MESSAGE) => self.message(at, &r, || format!(" (in the chunk at byte offset {at})"))?,
                other => return Err(self.corrupt(at, inner(r.offset, &format!("a record with op {other:?}")))),
            }
        }
        Ok(())
    }

    /// A connection record at `at` (its own offset, or its chunk's): a topic and its message type.
    fn connection(&mut self, at: usize, r: &Record<'_>) -> Result<(), BagError> {
        let (Some(conn), Some(topic)) = (r.fields.conn, r.fields.topic) else {
            return Err(self.corrupt(at, "a connection record without conn or topic".into()));
        };
        if self.connections.contains_key(&conn) {
            return Ok(()); // The index repeats the connections of the chunks.
        }
        let data = Fields::parse(r.data).map_err(|e| self.corrupt(at, format!("connection {conn}: {e}")))?;
        let kind = String::from_utf8_lossy(data.kind.unwrap_or_default()).into_owned();
        let imu = kind == IMU_TYPE;
        let topic = self.topics.index(&String::from_utf8_lossy(topic));
        self.topics.connection(topic, imu, || if kind.is_empty() { "of no type".into() } else { kind.clone() });
        self.connections.insert(conn, Connection { topic, imu });
        Ok(())
    }

    /// A message record at `at` (its own offset, or its chunk's); `place` says where it is, for a decoding error.
    fn message(&mut self, at: usize, r: &Record<'_>, place: impl FnOnce() -> String) -> Result<(), BagError> {
        let (Some(conn), Some((sec, nsec))) = (r.fields.conn, r.fields.time) else {
            return Err(self.corrupt(at, "a message record without conn or time".into()));
        };
        let Some(c) = self.connections.get(&conn) else {
            return Err(self.corrupt(at, format!("a message on connection {conn}, which no record before it defines")));
        };
        let t = &mut self.topics.list[c.topic];
        if !t.count(&self.want, c.imu) {
            return Ok(());
        }
        let decoded = decode_imu(r.data).map(|m| Message {
            stamp_ns: i64::from(m.sec) * 1_000_000_000 + i64::from(m.nsec),
            log_time: u64::from(sec) * 1_000_000_000 + u64::from(nsec),
            frame_id: m.frame_id,
            w: m.w,
            a: m.a,
            a_cov0: m.a_cov0,
        });
        t.take(&self.path, IMU_TYPE, place, decoded);
        Ok(())
    }
}

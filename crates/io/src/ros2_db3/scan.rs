//! One pass over the SQLite files of a rosbag2 bag: the `topics` table gives each topic's name, type and
//! serialization format; the `messages` table, read in row order, gives each message's topic, the time the
//! recorder received it (`timestamp`, ns) and its CDR bytes, decoded for the wanted topics. The files are opened
//! read-only; SQLite's own errors (a file that is not a database, a damaged page) come back naming the file and
//! the last row read.

use std::collections::HashMap;
use std::path::Path;

use rusqlite::{Connection, OpenFlags};

use crate::imu_topic::{BagError, Topics, Want};
use crate::ros2_bag::{decode_imu, kept, IMU_TYPE};
use crate::rosbag2_dir::Storage;

/// The first bytes of a SQLite database file.
const SQLITE_MAGIC: &[u8] = b"SQLite format 3\0";

/// One topic of one file: its index among the bag's topics, and whether it is an Imu topic in CDR.
struct FileTopic {
    topic: usize,
    imu: bool,
}

/// One pass over the bag at `path` (a `.db3` file or a bag directory): its topics, and the samples of those
/// `want` names.
pub(super) fn scan(path: &Path, want: Want) -> Result<Topics, BagError> {
    let mut topics = Topics::new(path.display().to_string(), IMU_TYPE);
    for file in Storage::Sqlite.bag_files(path)? {
        scan_file(&file, &want, &mut topics)?;
    }
    Ok(topics)
}

fn scan_file(path: &Path, want: &Want, topics: &mut Topics) -> Result<(), BagError> {
    let name = path.display().to_string();
    let sqlite = |what: String| BagError::Sqlite { path: name.clone(), what };
    let head = file_head(path, &name)?;
    if crate::rosbag2_zstd::is_zstd(&head) {
        // A storage file that rosbag2 compressed whole (`NAME_0.db3.zstd`): SQLite reads a decompressed copy.
        let copy = crate::rosbag2_zstd::to_temp_file(path)
            .map_err(|what| BagError::Decompress { path: name.clone(), what })?;
        return scan_database(copy.path(), &name, want, topics);
    }
    if head != SQLITE_MAGIC {
        let hint = match &head[..] {
            [] => "the file is empty",
            h if h.starts_with(b"\x89MCAP") => "it is MCAP: read it as such (--format mcap)",
            h if h.starts_with(b"#ROSBAG") => "it is a ROS 1 bag (--format bag)",
            h if h.len() < SQLITE_MAGIC.len() && SQLITE_MAGIC.starts_with(h) => "the file is cut short",
            _ => "it does not start with the SQLite magic bytes",
        };
        return Err(sqlite(format!("not a rosbag2 SQLite file: {hint}")));
    }
    scan_database(path, &name, want, topics)
}

/// The first bytes of the file at `path` (as many as the SQLite magic, fewer in a shorter file).
fn file_head(path: &Path, name: &str) -> Result<Vec<u8>, BagError> {
    use std::io::Read;
    let io = |err| BagError::Io { path: name.to_string(), err };
    let mut head = Vec::with_capacity(SQLITE_MAGIC.len());
    std::fs::File::open(path).map_err(io)?.take(SQLITE_MAGIC.len() as u64).read_to_end(&mut head).map_err(io)?;
    Ok(head)
}

/// Scan the SQLite database at `path`, named `name` in errors (the bag's file, where `path` is a decompressed copy).
fn scan_database(path: &Path, name: &str, want: &Want, topics: &mut Topics) -> Result<(), BagError> {
    let name = name.to_string();
    let sqlite = |what: String| BagError::Sqlite { path: name.clone(), what };
    let flags = OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX;
    let db = Connection::open_with_flags(path, flags).map_err(|e| sqlite(format!("SQLite cannot open it: {e}")))?;

    let mut by_id: HashMap<i64, FileTopic> = HashMap::new();
    let table = |e: rusqlite::Error| sqlite(format!("reading the topics table: {e} (not a rosbag2 bag?)"));
    let mut stmt = db.prepare("SELECT id, name, type, serialization_format FROM topics").map_err(table)?;
    let mut rows = stmt.query([]).map_err(table)?;
    while let Some(row) = rows.next().map_err(table)? {
        let id: i64 = row.get(0).map_err(table)?;
        let (topic, kind, format): (String, String, String) =
            (row.get(1).map_err(table)?, row.get(2).map_err(table)?, row.get(3).map_err(table)?);
        let imu = kind == IMU_TYPE && format == "cdr";
        let i = topics.index(&topic);
        topics.connection(i, imu, || format!("{kind} ({format:?})"));
        by_id.insert(id, FileTopic { topic: i, imu });
    }
    drop(rows);
    drop(stmt);

    let mut last = None::<i64>;
    let messages = |e: rusqlite::Error, last: Option<i64>| {
        let after = last.map_or("at the first row".to_string(), |id| format!("after row id {id}"));
        sqlite(format!("reading the messages table {after}: {e}"))
    };
    if matches!(want, Want::Nothing) {
        let mut stmt =
            db.prepare("SELECT topic_id, COUNT(*) FROM messages GROUP BY topic_id").map_err(|e| messages(e, None))?;
        let mut rows = stmt.query([]).map_err(|e| messages(e, None))?;
        while let Some(row) = rows.next().map_err(|e| messages(e, None))? {
            let (id, n): (i64, i64) =
                (row.get(0).map_err(|e| messages(e, None))?, row.get(1).map_err(|e| messages(e, None))?);
            let t = by_id
                .get(&id)
                .ok_or_else(|| sqlite(format!("messages of topic id {id}, which the topics table does not have")))?;
            topics.list[t.topic].messages += n as u64;
        }
        return Ok(());
    }
    let mut stmt =
        db.prepare("SELECT id, topic_id, timestamp, data FROM messages ORDER BY id").map_err(|e| messages(e, None))?;
    let mut rows = stmt.query([]).map_err(|e| messages(e, None))?;
    loop {
        let row = match rows.next() {
            Ok(Some(row)) => row,
            Ok(None) => break,
            Err(e) => return Err(messages(e, last)),
        };
        let value = |i: usize, last: Option<i64>| row.get_ref(i).map_err(|e| messages(e, last));
        let int = |i: usize, last| value(i, last)?.as_i64().map_err(|e| messages(e.into(), last));
        let id = int(0, last)?;
        last = Some(id);
        let topic_id = int(1, last)?;
        let Some(t) = by_id.get(&topic_id) else {
            return Err(sqlite(format!(
                "row id {id}: a message of topic id {topic_id}, which the topics table does not have"
            )));
        };
        let topic = &mut topics.list[t.topic];
        if !topic.count(want, t.imu) {
            continue;
        }
        let timestamp = int(2, last)?;
        let data = value(3, last)?.as_blob().map_err(|e| messages(e.into(), last))?;
        let decoded = decode_imu(data);
        let decoded = decoded.as_ref().map(|m| kept(m, u64::try_from(timestamp).unwrap_or(0)));
        topic.take(&name, IMU_TYPE, || format!(" (row id {id})"), decoded.map_err(Clone::clone));
    }
    Ok(())
}

//! rosbag2 SQLite files written here with rosbag2's schema and hand-built CDR messages: a file and a split bag
//! directory read, stamps out of order and repeated, topics chosen, and the errors of damaged, foreign and
//! topic-less files.

use std::path::{Path, PathBuf};

use rusqlite::Connection;

use super::*;
use crate::ros2_bag::IMU_TYPE;

/// A CDR_LE `sensor_msgs/msg/Imu` with this stamp and angular velocity (acceleration 0, 0, 9.81).
fn cdr(stamp_ns: i64, w: [f64; 3]) -> Vec<u8> {
    let mut b = vec![0x00, 0x01, 0x00, 0x00];
    b.extend(((stamp_ns / 1_000_000_000) as i32).to_le_bytes());
    b.extend(((stamp_ns % 1_000_000_000) as u32).to_le_bytes());
    b.extend(4u32.to_le_bytes());
    b.extend(b"imu\0");
    let floats = [0.0, 0.0, 0.0, 1.0].into_iter().chain([0.0; 9]).chain(w).chain([0.0; 9]);
    for v in floats.chain([0.0, 0.0, 9.81]).chain([0.0; 9]) {
        b.extend(v.to_le_bytes());
    }
    b
}

/// A `.db3` with rosbag2's tables: `topics` (id, name, type) and `messages` (topic id, timestamp, data).
fn db3(path: &Path, topics: &[(i64, &str, &str)], messages: &[(i64, i64, Vec<u8>)]) -> PathBuf {
    let db = Connection::open(path).unwrap();
    db.execute_batch(
        "CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL);
         CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,
             serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);
         CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp INTEGER NOT NULL,
             data BLOB NOT NULL);
         CREATE INDEX timestamp_idx ON messages (timestamp ASC);",
    )
    .unwrap();
    for (id, name, kind) in topics {
        db.execute("INSERT INTO topics VALUES (?1, ?2, ?3, 'cdr', '')", rusqlite::params![id, name, kind]).unwrap();
    }
    for (topic, t, data) in messages {
        db.execute(
            "INSERT INTO messages (topic_id, timestamp, data) VALUES (?1, ?2, ?3)",
            rusqlite::params![topic, t, data],
        )
        .unwrap();
    }
    path.to_path_buf()
}

const T0: i64 = 1_700_000_000_000_000_000;
const MS: i64 = 1_000_000;

/// 10 ms stamps `k`, logged 1 ms later.
fn imu_rows(topic: i64, ks: &[i64]) -> Vec<(i64, i64, Vec<u8>)> {
    ks.iter().map(|&k| (topic, T0 + k * 10 * MS + MS, cdr(T0 + k * 10 * MS, [k as f64, 0.5, -0.5]))).collect()
}

#[test]
fn a_file_and_a_split_directory_read_alike() {
    let dir = tempfile::tempdir().unwrap();
    // 2 logged before 1, 4 twice, 6 missing.
    let ks = [0, 2, 1, 3, 4, 4, 5, 7, 8, 9];
    let topics = [(1, "/imu", IMU_TYPE), (2, "/status", "std_msgs/msg/String")];
    let mut rows = imu_rows(1, &ks);
    rows.insert(3, (2, T0, vec![0, 1, 0, 0, 1, 0, 0, 0, 0]));
    let file = db3(&dir.path().join("one.db3"), &topics, &rows);
    let b = read_imu_bag(&file, None, None).unwrap();
    assert_eq!((b.messages, b.out_of_order, b.duplicates, b.start_ns), (10, 1, 1, T0));
    let r = &b.recording;
    assert_eq!((r.rate_hz, r.info.samples, r.info.gaps), (100.0, 10, 6));
    let k = 180.0 / std::f64::consts::PI;
    assert_eq!(r.channels[0][..6], [0.0, k, 2.0 * k, 3.0 * k, 4.0 * k, 5.0 * k]);
    assert!(r.channels[0][6].is_nan() && r.channels[5][6].is_nan());
    assert_eq!(r.channels[5][9], 9.81);
    assert_eq!(imu_topics(&file).unwrap(), [("/imu".to_string(), 10)]);

    // The same rows split over two files of a bag directory (topic ids differing between them).
    let bag = dir.path().join("rosbag2_split");
    std::fs::create_dir(&bag).unwrap();
    std::fs::write(bag.join("metadata.yaml"), "rosbag2_bagfile_information:\n").unwrap();
    db3(&bag.join("rosbag2_split_0.db3"), &topics, &rows[..5]);
    let topics2 = [(7, "/imu", IMU_TYPE), (2, "/status", "std_msgs/msg/String")];
    let rest: Vec<_> = rows[5..].iter().map(|(t, ts, d)| (if *t == 1 { 7 } else { *t }, *ts, d.clone())).collect();
    db3(&bag.join("rosbag2_split_1.db3"), &topics2, &rest);
    assert!(crate::rosbag2_dir::Storage::Sqlite.is_bag_dir(&bag));
    let split = read_imu_bag(&bag, Some("/imu"), None).unwrap();
    assert_eq!(format!("{:?}", split.recording.channels), format!("{:?}", b.recording.channels));
    assert_eq!((split.out_of_order, split.duplicates), (1, 1));
    assert_eq!(imu_topics(&bag).unwrap(), [("/imu".to_string(), 10)]);
}

#[test]
fn topics_are_chosen_and_listed() {
    let dir = tempfile::tempdir().unwrap();
    let none = db3(&dir.path().join("none.db3"), &[(1, "/s", "std_msgs/msg/String")], &[(1, 5, vec![1, 2])]);
    let err = read_imu_bag(&none, None, None).unwrap_err();
    assert!(matches!(err, BagError::NoImuTopic { .. }), "{err}");
    assert!(err.to_string().contains("none.db3: no sensor_msgs/msg/Imu topic (the bag has: /s (std_msgs"), "{err}");
    let mut rows = imu_rows(1, &[0, 1, 2]);
    rows.extend(imu_rows(2, &[0, 1]));
    let two = db3(&dir.path().join("two.db3"), &[(1, "/a", IMU_TYPE), (2, "/b", IMU_TYPE)], &rows);
    let err = read_imu_bag(&two, None, None).unwrap_err();
    assert!(matches!(err, BagError::SeveralImuTopics { .. }), "{err}");
    assert!(err.to_string().contains("/a (3 messages), /b (2 messages); choose one with --topic"), "{err}");
    assert_eq!(read_imu_bag(&two, Some("/b"), None).unwrap().recording.info.samples, 2);
}

#[test]
fn a_bad_message_names_its_row() {
    let dir = tempfile::tempdir().unwrap();
    let mut rows = imu_rows(1, &[0, 1, 2, 3]);
    rows[2].2.truncate(30);
    let file = db3(&dir.path().join("bad.db3"), &[(1, "/imu", IMU_TYPE)], &rows);
    let err = read_imu_bag(&file, None, None).unwrap_err();
    assert!(matches!(err, BagError::Decode { index: 3, .. }), "{err}");
    assert!(err.to_string().contains("bad.db3: message 3 (row id 3) of topic \"/imu\""), "{err}");
}

#[test]
fn foreign_cut_and_damaged_files_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let rows = imu_rows(1, &(0..2000).collect::<Vec<_>>());
    let file = db3(&dir.path().join("whole.db3"), &[(1, "/imu", IMU_TYPE)], &rows);
    let whole = std::fs::read(&file).unwrap();
    let n = whole.len();
    let cut = dir.path().join("cut.db3");
    // Cut short: SQLite's error (or, cut at a page boundary past the data, the rows that are there), no panic.
    for len in (0..n).step_by(n / 97) {
        std::fs::write(&cut, &whole[..len]).unwrap();
        match read_imu_bag(&cut, None, None) {
            Err(e) => assert!(e.to_string().contains("cut.db3"), "{e}"),
            Ok(b) => assert!(b.recording.info.samples > 0),
        }
    }
    for at in (0..n).step_by(n / 300) {
        let mut damaged = whole.clone();
        damaged[at] ^= 0x5A;
        std::fs::write(&cut, &damaged).unwrap();
        if let Err(e) = read_imu_bag(&cut, None, None) {
            assert!(e.to_string().contains("cut.db3"), "{e}");
        }
    }
    for (bytes, hint) in [(&b""[..], "empty"), (b"#ROSBAG V2.0\n", "ROS 1"), (b"\x89MCAP0\r\n", "MCAP")] {
        std::fs::write(&cut, bytes).unwrap();
        let err = read_imu_bag(&cut, None, None).unwrap_err();
        assert!(matches!(err, BagError::Sqlite { .. }) && err.to_string().contains(hint), "{err}");
    }
    // SQLite, but not a bag.
    let other = dir.path().join("other.db3");
    Connection::open(&other).unwrap().execute_batch("CREATE TABLE t(x);").unwrap();
    let err = read_imu_bag(&other, None, None).unwrap_err();
    assert!(err.to_string().contains("other.db3: reading the topics table: no such table: topics"), "{err}");
    let err = read_imu_bag(&dir.path().join("absent.db3"), None, None).unwrap_err();
    assert!(matches!(err, BagError::Io { .. }), "{err}");
}

//! ROS 1 bags built byte by byte: records and fields, the three chunk compressions, the Imu layout, and the
//! errors of files that are cut short, damaged, never closed or not bags at all.

use std::io::Write;

use super::encode::{field, record, time};
use super::record::{op, Fields, RecordError, Records};
use super::*;
use crate::imu_topic::TimeSource;

/// A ROS 1 `sensor_msgs/Imu`: seq, stamp, frame_id, then 37 float64.
fn imu_msg(stamp_ns: u64, frame: &str, w: [f64; 3], a: [f64; 3]) -> Vec<u8> {
    let mut m = 7u32.to_le_bytes().to_vec();
    m.extend(time(stamp_ns));
    m.extend((frame.len() as u32).to_le_bytes());
    m.extend(frame.as_bytes());
    let floats = [0.0, 0.0, 0.0, 1.0].into_iter().chain([0.0; 9]).chain(w).chain([0.0; 9]).chain(a).chain([0.0; 9]);
    for v in floats {
        m.extend(v.to_le_bytes());
    }
    m
}

/// A connection record: conn and topic in the header, topic and type in the data.
fn connection(conn: u32, topic: &str, kind: &str) -> Vec<u8> {
    let data: Vec<u8> =
        [field("topic", topic.as_bytes()), field("type", kind.as_bytes()), field("md5sum", b"*")].concat();
    record(&[("op", &[op::CONNECTION]), ("conn", &conn.to_le_bytes()), ("topic", topic.as_bytes())], &data)
}

/// A message: (connection, record time ns, data).
type Msg = (u32, u64, Vec<u8>);

/// A whole bag: each chunk's messages (their connections' records first, as the recorder writes them) compressed
/// with `compression`, then the index (the connections again, a chunk info per chunk).
fn bag(connections: &[(u32, &str, &str)], chunks: &[Vec<Msg>], compression: &str) -> Vec<u8> {
    let conn_record = |id: u32| {
        let (_, topic, kind) = connections.iter().find(|c| c.0 == id).unwrap();
        connection(id, topic, kind)
    };
    let mut body = Vec::new();
    for msgs in chunks {
        let mut content = Vec::new();
        let mut seen = Vec::new();
        for (conn, t, data) in msgs {
            if !seen.contains(conn) {
                seen.push(*conn);
                content.extend(conn_record(*conn));
            }
            content.extend(record(&[("op", &[op::MESSAGE]), ("conn", &conn.to_le_bytes()), ("time", &time(*t))], data));
        }
        let packed = match compression {
            "bz2" => {
                let mut e = bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::best());
                e.write_all(&content).unwrap();
                e.finish().unwrap()
            }
            "lz4" => {
                let mut e = lz4_flex::frame::FrameEncoder::new(Vec::new());
                e.write_all(&content).unwrap();
                e.finish().unwrap()
            }
            _ => content.clone(),
        };
        let size = (content.len() as u32).to_le_bytes();
        body.extend(record(&[("op", &[op::CHUNK]), ("compression", compression.as_bytes()), ("size", &size)], &packed));
        for conn in seen {
            let count = 1u32.to_le_bytes();
            let fields: [(&str, &[u8]); 4] = [
                ("op", &[op::INDEX_DATA]),
                ("ver", &1u32.to_le_bytes()),
                ("conn", &conn.to_le_bytes()),
                ("count", &count),
            ];
            body.extend(record(&fields, &[0u8; 12]));
        }
    }
    let header_len = super::scan::MAGIC.len() + record_header(0, 0, 0).len();
    let index_pos = (header_len + body.len()) as u64;
    for (id, ..) in connections {
        body.extend(conn_record(*id));
    }
    for _ in chunks {
        body.extend(record(&[("op", &[op::CHUNK_INFO]), ("ver", &1u32.to_le_bytes())], &[]));
    }
    let mut out = super::scan::MAGIC.to_vec();
    out.extend(record_header(index_pos, connections.len() as u32, chunks.len() as u32));
    out.extend(body);
    out
}

fn bag_header(index_pos: u64, conns: u32, chunks: u32) -> [(&'static str, Vec<u8>); 4] {
    [
        ("op", vec![op::BAG_HEADER]),
        ("index_pos", index_pos.to_le_bytes().to_vec()),
        ("conn_count", conns.to_le_bytes().to_vec()),
        ("chunk_count", chunks.to_le_bytes().to_vec()),
    ]
}

fn record_owned(fields: &[(&'static str, Vec<u8>)], data: &[u8]) -> Vec<u8> {
    let f: Vec<(&str, &[u8])> = fields.iter().map(|(n, v)| (*n, v.as_slice())).collect();
    record(&f, data)
}

/// 200 messages at 100 Hz on `/imu` (the 50th missing), 20 on `/status`, in chunks of 64 messages.
fn imu_bag(compression: &str, zero_stamps: bool) -> Vec<u8> {
    const T0: u64 = 1_700_000_000_000_000_000;
    let mut msgs = Vec::new();
    for k in (0..200u64).filter(|&k| k != 50) {
        let stamp = if zero_stamps { 0 } else { T0 + k * 10_000_000 };
        let w = [k as f64 * 1e-3, -0.5, 0.25];
        msgs.push((0, T0 + k * 10_000_000 + 777, imu_msg(stamp, "imu_link", w, [0.1, 0.2, 9.8 + k as f64])));
        if k % 10 == 0 {
            msgs.push((1, T0 + k * 10_000_000, b"\x05\x00\x00\x00hello".to_vec()));
        }
    }
    let chunks: Vec<Vec<Msg>> = msgs.chunks(64).map(|c| c.to_vec()).collect();
    bag(&[(0, "/imu", IMU_TYPE), (1, "/status", "std_msgs/String")], &chunks, compression)
}

fn write(dir: &tempfile::TempDir, name: &str, bytes: &[u8]) -> std::path::PathBuf {
    let p = dir.path().join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

// `bag_header` gives owned values; `record` takes borrowed ones.
fn record_header(index_pos: u64, conns: u32, chunks: u32) -> Vec<u8> {
    record_owned(&bag_header(index_pos, conns, chunks), &[b' '; 64])
}

#[test]
fn reads_stored_bz2_and_lz4_chunks_alike() {
    let dir = tempfile::tempdir().unwrap();
    let k = 180.0 / std::f64::consts::PI;
    let mut sizes = Vec::new();
    for compression in ["none", "bz2", "lz4"] {
        let bytes = imu_bag(compression, false);
        sizes.push(bytes.len());
        let path = write(&dir, &format!("{compression}.bag"), &bytes);
        let b = read_imu_bag(&path, None, None).unwrap_or_else(|e| panic!("{compression}: {e}"));
        assert_eq!((b.topic.as_str(), b.frame_id.as_str(), b.messages), ("/imu", "imu_link", 199));
        assert_eq!((b.out_of_order, b.duplicates, b.time_source), (0, 0, TimeSource::HeaderStamp));
        let r = &b.recording;
        assert_eq!(r.names, ["x", "y", "z", "ax", "ay", "az"]);
        assert_eq!((r.rate_hz, r.info.samples, r.info.gaps), (100.0, 200, 6));
        assert!(r.channels[0][50].is_nan() && r.channels[5][50].is_nan());
        assert_eq!(r.channels[0][123], 0.123 * k);
        assert_eq!(r.channels[1][7], -0.5 * k);
        assert_eq!(r.channels[5][199], 9.8 + 199.0);
        assert_eq!(imu_topics(&path).unwrap(), [("/imu".to_string(), 199)]);
    }
    assert!(sizes[1] < sizes[0] && sizes[2] < sizes[0], "{sizes:?}");
}

#[test]
fn zero_stamps_use_the_record_time() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(&dir, "zero.bag", &imu_bag("lz4", true));
    let b = read_imu_bag(&path, Some("/imu"), None).unwrap();
    assert_eq!(b.time_source, TimeSource::LogTime);
    assert_eq!(b.start_ns, 1_700_000_000_000_000_777);
    assert_eq!((b.recording.info.samples, b.recording.info.gaps), (200, 6));
}

#[test]
fn topics_are_chosen_and_listed() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(&dir, "b.bag", &imu_bag("none", false));
    let err = read_imu_bag(&path, Some("/status"), None).unwrap_err();
    assert!(matches!(err, BagError::NotImu { .. }), "{err}");
    assert!(err.to_string().contains("is std_msgs/String, not sensor_msgs/Imu"), "{err}");
    let err = read_imu_bag(&path, Some("/nope"), None).unwrap_err();
    assert!(err.to_string().contains("/imu (199 messages)"), "{err}");
    // Two Imu topics and no --topic.
    let m = |t: u64| imu_msg(t, "", [0.0; 3], [0.0; 3]);
    let two =
        bag(&[(3, "/a", IMU_TYPE), (4, "/b", IMU_TYPE)], &[vec![(3, 1, m(1)), (4, 2, m(2)), (3, 3, m(3))]], "none");
    let path = write(&dir, "two.bag", &two);
    let err = read_imu_bag(&path, None, None).unwrap_err();
    assert!(matches!(err, BagError::SeveralImuTopics { .. }), "{err}");
    assert!(err.to_string().contains("/a (2 messages), /b (1 messages)"), "{err}");
    assert_eq!(read_imu_bag(&path, Some("/a"), None).unwrap().recording.info.samples, 2);
    // None.
    let none = bag(&[(0, "/s", "std_msgs/String")], &[vec![(0, 1, vec![0; 4])]], "none");
    let err = read_imu_bag(&write(&dir, "none.bag", &none), None, None).unwrap_err();
    assert!(matches!(err, BagError::NoImuTopic { .. }) && err.to_string().contains("/s (std_msgs/String, 1"), "{err}");
}

#[test]
fn a_message_of_another_layout_names_its_chunk() {
    let dir = tempfile::tempdir().unwrap();
    let good = imu_msg(5, "f", [1.0; 3], [0.0; 3]);
    let bytes =
        bag(&[(0, "/imu", IMU_TYPE)], &[vec![(0, 1, good.clone()), (0, 2, good[..good.len() - 8].to_vec())]], "none");
    let path = write(&dir, "bad.bag", &bytes);
    let err = read_imu_bag(&path, None, None).unwrap_err();
    assert!(matches!(err, BagError::Decode { index: 2, .. }), "{err}");
    let text = err.to_string();
    assert!(text.contains("message 2 (in the chunk at byte offset ") && text.contains("sensor_msgs/Imu"), "{text}");
    assert!(text.contains("bad.bag"), "{text}");
}

#[test]
fn cut_damaged_unclosed_and_foreign_files_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    for compression in ["none", "bz2", "lz4"] {
        let whole = imu_bag(compression, false);
        let n = whole.len();
        // Cut anywhere: an error that names the file, never a panic or a short recording.
        for len in (0..n).step_by(n / 300).chain([n - 1]) {
            let path = write(&dir, "cut.bag", &whole[..len]);
            let err = read_imu_bag(&path, None, None).err().unwrap_or_else(|| panic!("cut at {len}: read"));
            assert!(err.to_string().contains("cut.bag"), "{err}");
            match len {
                0..=12 => assert!(matches!(err, BagError::NotRos1Bag { .. }), "{len}: {err}"),
                _ => assert!(matches!(err, BagError::Truncated { .. } | BagError::Corrupt { .. }), "{len}: {err}"),
            }
        }
        // A flipped byte anywhere: an error or data, never a panic.
        for at in (0..n).step_by(n / 300) {
            let mut damaged = whole.clone();
            damaged[at] ^= 0x5A;
            let path = write(&dir, "damaged.bag", &damaged);
            if let Ok(b) = read_imu_bag(&path, None, None) {
                assert!(b.recording.info.samples > 0);
            }
        }
    }
    // A corrupt bz2 stream: the chunk's offset.
    let mut bytes = imu_bag("bz2", false);
    let chunk = bytes.windows(4).position(|w| w == b"BZh9").unwrap();
    bytes[chunk + 200] ^= 0xFF;
    let err = read_imu_bag(&write(&dir, "bz.bag", &bytes), None, None).unwrap_err();
    let text = err.to_string();
    assert!(
        matches!(err, BagError::Corrupt { .. }) && text.contains("bz.bag: corrupt ROS 1 bag at byte offset"),
        "{text}"
    );
    assert!(text.contains("bz2 chunk does not decompress"), "{text}");
    // Never closed: no index.
    let mut open = imu_bag("none", false);
    let at = super::scan::MAGIC.len();
    let fresh = record_header(0, 2, 4);
    open[at..at + fresh.len()].copy_from_slice(&fresh);
    let err = read_imu_bag(&write(&dir, "open.bag", &open), None, None).unwrap_err();
    assert!(err.to_string().contains("rosbag reindex"), "{err}");
    // A compression octavar does not read.
    let odd = bag(&[(0, "/imu", IMU_TYPE)], &[vec![(0, 1, imu_msg(1, "", [0.0; 3], [0.0; 3]))]], "zstd");
    let err = read_imu_bag(&write(&dir, "zstd.bag", &odd), None, None).unwrap_err();
    assert!(matches!(err, BagError::UnsupportedCompression { .. }), "{err}");
    // Not a bag.
    for (bytes, hint) in [
        (&b"\x89MCAP0\r\n"[..], "MCAP"),
        (b"SQLite format 3\0", "SQLite"),
        (b"#ROSBAG V1.2\n", "older"),
        (b"#ROSRECORD V1.2\n", "rewrites it as 2.0"),
    ] {
        let err = read_imu_bag(&write(&dir, "x.bag", bytes), None, None).unwrap_err();
        assert!(matches!(err, BagError::NotRos1Bag { .. }) && err.to_string().contains(hint), "{err}");
    }
    let err = read_imu_bag(&dir.path().join("absent.bag"), None, None).unwrap_err();
    assert!(matches!(err, BagError::Io { .. }), "{err}");
}

#[test]
fn records_and_fields_parse_and_refuse() {
    let r = record(&[("op", &[op::MESSAGE]), ("conn", &9u32.to_le_bytes()), ("time", &time(3_000_000_004))], b"xyz");
    let mut two = r.clone();
    two.extend(&r);
    let got: Vec<_> = Records::new(&two, 0).collect::<Result<_, _>>().unwrap();
    assert_eq!((got.len(), got[1].offset, got[1].data), (2, r.len(), &b"xyz"[..]));
    assert_eq!((got[0].fields.op, got[0].fields.conn, got[0].fields.time), (Some(2), Some(9), Some((3, 4))));
    for len in 1..r.len() {
        let e = Records::new(&r[..len], 0).next().unwrap().err();
        assert_eq!(e, Some(RecordError::Short { offset: 0 }), "{len}");
    }
    // A field without '=', a field longer than its header, a fixed-size field of the wrong size.
    assert!(Fields::parse(&[3, 0, 0, 0, b'a', b'b', b'c']).is_err());
    assert!(Fields::parse(&[9, 0, 0, 0, b'a', b'=', b'c']).is_err());
    assert!(Fields::parse(&field("conn", &[1, 2])).unwrap_err().contains("takes 4"));
    assert!(Fields::parse(&[1, 0]).is_err());
    // A header length past the end.
    let huge = [0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0, 0];
    assert_eq!(Records::new(&huge, 0).next().unwrap().err(), Some(RecordError::Short { offset: 0 }));
}

#[test]
fn the_imu_layout_is_exact() {
    let m = imu_msg(1_500_000_123, "imu", [1.0, 2.0, 3.0], [4.0, 5.0, 6.0]);
    let d = imu::decode_imu(&m).unwrap();
    assert_eq!(
        (d.sec, d.nsec, d.frame_id, d.w, d.a, d.a_cov0),
        (1, 500_000_123, "imu", [1.0, 2.0, 3.0], [4.0, 5.0, 6.0], 0.0)
    );
    assert!(imu::decode_imu(&m[..m.len() - 1]).unwrap_err().contains("different message layout"));
    assert!(imu::decode_imu(&[m.clone(), vec![0]].concat()).is_err());
    assert!(imu::decode_imu(&m[..10]).unwrap_err().contains("shorter than a Header"));
    let mut bad = m.clone();
    bad[16] = 0xFF;
    assert!(imu::decode_imu(&bad).unwrap_err().contains("UTF-8"));
    let mut long = m;
    long[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(imu::decode_imu(&long).is_err());
}

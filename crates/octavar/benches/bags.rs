//! Reading ROS bags of IMU messages, MB/s of file: 1e6 `sensor_msgs` Imu messages (a 2.8-hour record at 100 Hz)
//! written here as a ROS 1 bag with stored chunks and with lz4 chunks (the records laid out by hand), as a rosbag2
//! SQLite file (through rusqlite, rosbag2's schema) and as MCAP (through the mcap crate's writer, uncompressed
//! chunks), then read whole by the readers `analyze` uses: topic found, every message decoded, sorted, placed on
//! the grid.
//!
//! `cargo bench -p octavar --bench bags`. The files go to a temporary directory (about 1.3 GB, removed after).

use std::io::Write;
use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use octavar::io::ros1_bag::encode::{field, record, time};
use octavar::io::{ros1_bag, ros2_bag, ros2_db3};

const MESSAGES: u64 = 1_000_000;
const T0_NS: u64 = 1_700_000_000_000_000_000;
const PERIOD_NS: u64 = 10_000_000;

/// A deterministic angular velocity and acceleration for message `k`.
fn values(k: u64) -> ([f64; 3], [f64; 3]) {
    let s = k.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    let u = |shift: u32| ((s >> shift) & 0xFFFF) as f64 / 65536.0 - 0.5;
    ([u(0) * 1e-2, u(16) * 1e-2, u(32) * 1e-2], [u(48), u(8), 9.81 + u(24)])
}

/// The 37 float64 after the header: orientation, its covariance, w, its covariance, a, its covariance.
fn floats(w: [f64; 3], a: [f64; 3]) -> impl Iterator<Item = f64> {
    [0.0, 0.0, 0.0, 1.0].into_iter().chain([0.0; 9]).chain(w).chain([0.0; 9]).chain(a).chain([0.0; 9])
}

/// ROS 1 serialization of `sensor_msgs/Imu` with frame_id "imu_link".
fn ros1_msg(k: u64) -> Vec<u8> {
    let (w, a) = values(k);
    let t = T0_NS + k * PERIOD_NS;
    let mut m = (k as u32).to_le_bytes().to_vec();
    m.extend(((t / 1_000_000_000) as u32).to_le_bytes());
    m.extend(((t % 1_000_000_000) as u32).to_le_bytes());
    m.extend(8u32.to_le_bytes());
    m.extend(b"imu_link");
    floats(w, a).for_each(|v| m.extend(v.to_le_bytes()));
    m
}

/// CDR (little-endian) of `sensor_msgs/msg/Imu` with frame_id "imu_link".
fn cdr_msg(k: u64) -> Vec<u8> {
    let (w, a) = values(k);
    let t = T0_NS + k * PERIOD_NS;
    let mut m = vec![0, 1, 0, 0];
    m.extend(((t / 1_000_000_000) as i32).to_le_bytes());
    m.extend(((t % 1_000_000_000) as u32).to_le_bytes());
    m.extend(9u32.to_le_bytes());
    m.extend(b"imu_link\0");
    m.extend([0u8; 7]); // to the 8-byte boundary after the 4-byte encapsulation header
    floats(w, a).for_each(|v| m.extend(v.to_le_bytes()));
    m
}

/// A ROS 1 bag of format 2.0 with one Imu connection, in chunks of about 768 KiB (rosbag's default).
fn write_ros1(path: &Path, lz4: bool) {
    let connection = {
        let data = [field("topic", b"/imu/data"), field("type", b"sensor_msgs/Imu"), field("md5sum", b"*")].concat();
        record(&[("op", &[7]), ("conn", &0u32.to_le_bytes()), ("topic", b"/imu/data")], &data)
    };
    let mut body = Vec::new();
    let mut chunks = 0u32;
    let mut k = 0;
    while k < MESSAGES {
        let mut content = connection.clone();
        let mut count = 0u32;
        while k < MESSAGES && content.len() < 768 * 1024 {
            let t = time(T0_NS + k * PERIOD_NS + 500_000);
            content.extend(record(&[("op", &[2]), ("conn", &0u32.to_le_bytes()), ("time", &t)], &ros1_msg(k)));
            k += 1;
            count += 1;
        }
        let size = (content.len() as u32).to_le_bytes();
        let (compression, data): (&[u8], Vec<u8>) = if lz4 {
            let mut e = lz4_flex::frame::FrameEncoder::new(Vec::new());
            e.write_all(&content).unwrap();
            (b"lz4", e.finish().unwrap())
        } else {
            (b"none", content)
        };
        body.extend(record(&[("op", &[5]), ("compression", compression), ("size", &size)], &data));
        let index = [("op", &[4u8][..]), ("ver", &1u32.to_le_bytes()), ("conn", &0u32.to_le_bytes())];
        body.extend(record(
            &[index[0], index[1], index[2], ("count", &count.to_le_bytes())],
            &vec![0; 12 * count as usize],
        ));
        chunks += 1;
    }
    let header = |index_pos: u64| {
        let fields = [
            ("op", &[3u8][..]),
            ("index_pos", &index_pos.to_le_bytes()),
            ("conn_count", &1u32.to_le_bytes()),
            ("chunk_count", &chunks.to_le_bytes()),
        ];
        record(&fields, &[b' '; 4000])
    };
    let index_pos = (13 + header(0).len() + body.len()) as u64;
    body.extend(connection);
    for _ in 0..chunks {
        body.extend(record(&[("op", &[6]), ("ver", &1u32.to_le_bytes())], &[]));
    }
    let mut out = b"#ROSBAG V2.0\n".to_vec();
    out.extend(header(index_pos));
    out.extend(body);
    std::fs::write(path, out).unwrap();
}

/// A rosbag2 SQLite file with one Imu topic.
fn write_db3(path: &Path) {
    let mut db = rusqlite::Connection::open(path).unwrap();
    db.execute_batch(
        "PRAGMA journal_mode = OFF; PRAGMA synchronous = OFF;
         CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,
             serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);
         CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp INTEGER NOT NULL,
             data BLOB NOT NULL);
         CREATE INDEX timestamp_idx ON messages (timestamp ASC);
         INSERT INTO topics VALUES (1, '/imu/data', 'sensor_msgs/msg/Imu', 'cdr', '');",
    )
    .unwrap();
    let tx = db.transaction().unwrap();
    {
        let mut insert = tx.prepare("INSERT INTO messages (topic_id, timestamp, data) VALUES (1, ?1, ?2)").unwrap();
        for k in 0..MESSAGES {
            insert.execute(rusqlite::params![(T0_NS + k * PERIOD_NS + 500_000) as i64, cdr_msg(k)]).unwrap();
        }
    }
    tx.commit().unwrap();
}

/// An MCAP file with one Imu channel, uncompressed chunks.
fn write_mcap(path: &Path) {
    let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut w = mcap::WriteOptions::new().compression(None).create(file).unwrap();
    let schema = w.add_schema("sensor_msgs/msg/Imu", "ros2msg", b"").unwrap();
    let channel = w.add_channel(schema, "/imu/data", "cdr", &Default::default()).unwrap();
    for k in 0..MESSAGES {
        let t = T0_NS + k * PERIOD_NS + 500_000;
        let header =
            mcap::records::MessageHeader { channel_id: channel, sequence: k as u32, log_time: t, publish_time: t };
        w.write_to_known_channel(&header, &cdr_msg(k)).unwrap();
    }
    w.finish().unwrap();
}

fn bags(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name);
    write_ros1(&p("none.bag"), false);
    write_ros1(&p("lz4.bag"), true);
    write_db3(&p("imu.db3"));
    write_mcap(&p("imu.mcap"));
    type Read = fn(
        &Path,
        Option<&str>,
        Option<f64>,
    ) -> Result<octavar::io::imu_topic::ImuBag, octavar::io::imu_topic::BagError>;
    let cases: [(&str, &str, Read); 4] = [
        ("ros1_bag", "none.bag", ros1_bag::read_imu_bag),
        ("ros1_bag_lz4", "lz4.bag", ros1_bag::read_imu_bag),
        ("ros2_db3", "imu.db3", ros2_db3::read_imu_bag),
        ("ros2_mcap", "imu.mcap", ros2_bag::read_imu_bag),
    ];
    let mut g = c.benchmark_group("bags");
    g.sample_size(10);
    for (name, file, read) in cases {
        let path = p(file);
        let bytes = std::fs::metadata(&path).unwrap().len();
        let b = read(&path, None, None).unwrap();
        assert_eq!((b.messages, b.recording.info.gaps), (MESSAGES, 0), "{name}");
        g.throughput(Throughput::Bytes(bytes));
        g.bench_function(name, |bench| bench.iter(|| read(&path, None, None).unwrap().recording.info.samples));
    }
    g.finish();
}

criterion_group!(benches, bags);
criterion_main!(benches);

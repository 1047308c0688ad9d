//! ROS 2 bags against an independent writer: bags of sensor_msgs/msg/Imu written by the Python `mcap` and
//! `mcap-ros2-support` packages (tests/reference/ros2_imu_bag.py) with known angular velocities, which octavar
//! must read back exactly (deg/s = rad/s * 180/pi), NaN where messages are missing, at the positions the sample
//! indices say; and files cut short or damaged must give errors, never a panic.

use std::path::{Path, PathBuf};

use octavar::io::recording::Recording;
use octavar::io::ros2_bag::{imu_topics, read_imu_bag, BagError, TimeSource};
use serde_json::{json, Value};

use crate::util;

const T0_NS: i64 = 1_700_000_000_123_456_789;

/// Write a bag from `spec` (see the script) into `dir` as `name.mcap`, or `None` without the reference Python.
fn write_bag(dir: &Path, name: &str, mut spec: Value) -> Option<PathBuf> {
    let py = util::reference_python("mcap_ros2")?;
    let bag = dir.join(format!("{name}.mcap"));
    spec["out"] = json!(bag.to_str().unwrap());
    let spec_path = dir.join(format!("{name}.json"));
    std::fs::write(&spec_path, spec.to_string()).unwrap();
    let out = std::process::Command::new(py)
        .arg(util::reference_script("ros2_imu_bag.py"))
        .arg(&spec_path)
        .output()
        .expect("run the bag writer");
    assert!(out.status.success(), "bag writer failed: {}", String::from_utf8_lossy(&out.stderr));
    Some(bag)
}

/// The samples the writer wrote for topic `j`: grid index and angular velocity, rad/s.
fn truth(bag: &Path, j: usize) -> Vec<(usize, [f64; 3])> {
    let bytes = std::fs::read(format!("{}.{j}.f64", bag.display())).unwrap();
    let v: Vec<f64> = bytes.chunks_exact(8).map(|b| f64::from_le_bytes(b.try_into().unwrap())).collect();
    v.chunks_exact(4).map(|r| (r[0] as usize, [r[1], r[2], r[3]])).collect()
}

/// The recording holds exactly the truth in deg/s at its indices, NaN everywhere else; the writer's linear
/// accelerations (given in every message) are channels ax, ay, az with the same gaps.
fn assert_matches(rec: &Recording, truth: &[(usize, [f64; 3])]) {
    let len = truth.last().unwrap().0 + 1;
    assert_eq!(truth[0].0, 0);
    assert_eq!(rec.names, ["x", "y", "z", "ax", "ay", "az"]);
    assert_eq!(rec.info.columns, rec.names);
    assert_eq!(rec.channels.len(), 6);
    assert!(rec.temp_c.is_none());
    assert_eq!(rec.info.samples, len as u64);
    assert_eq!(rec.info.gaps, 6 * (len - truth.len()) as u64);
    assert_eq!(rec.info.rate_hz, rec.rate_hz);
    let mut expected = vec![[f64::NAN; 3]; len];
    for &(k, w) in truth {
        expected[k] = w;
    }
    for (c, ch) in rec.channels.iter().enumerate() {
        assert_eq!(ch.len(), len, "channel {c}");
        for (k, (&got, want)) in ch.iter().zip(&expected).enumerate() {
            if c >= 3 {
                assert_eq!(got.is_nan(), want[0].is_nan(), "channel {c} sample {k}: {got}");
                continue;
            }
            let want = want[c] * 180.0 / std::f64::consts::PI;
            if want.is_nan() {
                assert!(got.is_nan(), "channel {c} sample {k}: {got}, expected a gap");
            } else {
                assert!((got - want).abs() <= 1e-12 * want.abs(), "channel {c} sample {k}: {got} vs {want}");
            }
        }
    }
}

fn imu(name: &str, n: usize, rate: f64) -> Value {
    json!({"name": name, "n": n, "rate": rate, "t0_ns": T0_NS})
}

#[test]
fn ros2_bag_plain_200_hz() {
    let dir = util::temp_dir("ros2-bag-plain");
    let Some(bag) = write_bag(&dir, "plain", json!({"topics": [imu("/imu/data", 2000, 200.0)]})) else { return };
    let b = read_imu_bag(&bag, None, None).unwrap();
    assert_matches(&b.recording, &truth(&bag, 0));
    assert_eq!(b.recording.rate_hz, 200.0);
    assert_eq!(b.recording.info.gaps, 0);
    assert_eq!(b.recording.source, bag.display().to_string());
    assert_eq!((b.topic.as_str(), b.frame_id.as_str()), ("/imu/data", "imu_link"));
    assert_eq!(b.time_source, TimeSource::HeaderStamp);
    assert_eq!((b.messages, b.out_of_order, b.duplicates, b.start_ns), (2000, 0, 0, T0_NS));
    assert_eq!(imu_topics(&bag).unwrap(), [("/imu/data".to_string(), 2000)]);

    // A rate given is used as is; the topic named is the same topic.
    let given = read_imu_bag(&bag, Some("/imu/data"), Some(200.0)).unwrap();
    assert_eq!(given, b);
    assert!(matches!(read_imu_bag(&bag, None, Some(0.0)), Err(BagError::BadRate(_))));
    assert!(matches!(read_imu_bag(&bag, None, Some(f64::NAN)), Err(BagError::BadRate(_))));
}

#[test]
fn ros2_bag_dropped_messages_are_nan_gaps() {
    let dir = util::temp_dir("ros2-bag-gaps");
    let drop: Vec<usize> = [1, 50, 51, 52].into_iter().chain(500..600).chain([1998]).collect();
    let mut t = imu("/imu/data", 2000, 200.0);
    t["drop"] = json!(drop);
    let Some(bag) = write_bag(&dir, "gaps", json!({"topics": [t]})) else { return };
    let b = read_imu_bag(&bag, None, None).unwrap();
    let truth = truth(&bag, 0);
    assert_eq!(truth.len(), 2000 - 105);
    assert_matches(&b.recording, &truth);
    assert_eq!(b.recording.info.samples, 2000);
    assert_eq!(b.recording.info.gaps, 6 * 105);
    assert_eq!(b.recording.rate_hz, 200.0);
    assert_eq!(b.messages, 1895);
}

#[test]
fn ros2_bag_jittered_stamps_stay_gap_free() {
    let dir = util::temp_dir("ros2-bag-jitter");
    let mut t = imu("/imu/data", 4000, 200.0);
    t["jitter"] = json!(0.2);
    let mut dropped = t.clone();
    dropped["drop"] = json!([100, 200, 201, 3000, 3001, 3002]);
    dropped["name"] = json!("/imu/dropped");
    let Some(bag) = write_bag(&dir, "jitter", json!({"topics": [t, dropped]})) else { return };
    let b = read_imu_bag(&bag, Some("/imu/data"), None).unwrap();
    assert_matches(&b.recording, &truth(&bag, 0));
    assert_eq!(b.recording.info.gaps, 0);
    assert!((b.recording.rate_hz - 200.0).abs() < 1.0, "rate {}", b.recording.rate_hz);
    // Jitter on top of gaps: each gap still counts its missing samples exactly.
    let d = read_imu_bag(&bag, Some("/imu/dropped"), None).unwrap();
    assert_matches(&d.recording, &truth(&bag, 1));
    assert_eq!(d.recording.info.gaps, 6 * 6);
}

#[test]
fn ros2_bag_out_of_order_and_duplicates() {
    let dir = util::temp_dir("ros2-bag-order");
    let mut t = imu("/imu/data", 3000, 200.0);
    t["swap"] = json!([10, 100, 2500]);
    t["duplicate"] = json!([700, 701]);
    let Some(bag) = write_bag(&dir, "order", json!({"topics": [t]})) else { return };
    let b = read_imu_bag(&bag, None, None).unwrap();
    // Sorted back into place; of each repeated stamp the first message logged is kept (the repeat is negated).
    assert_matches(&b.recording, &truth(&bag, 0));
    assert_eq!(b.recording.info.gaps, 0);
    assert_eq!((b.messages, b.out_of_order, b.duplicates), (3002, 3, 2));
    assert_eq!(b.recording.rate_hz, 200.0);
}

#[test]
fn ros2_bag_topics_choose_and_list() {
    let dir = util::temp_dir("ros2-bag-topics");
    let mut raw = imu("/imu/raw", 300, 100.0);
    raw["seed"] = json!(2);
    raw["frame_id"] = json!("raw_link");
    let spec = json!({"topics": [imu("/imu/data", 600, 200.0), raw], "other_topic": true});
    let Some(bag) = write_bag(&dir, "topics", spec) else { return };
    let path = bag.display().to_string();

    let several = read_imu_bag(&bag, None, None).unwrap_err();
    assert!(matches!(several, BagError::SeveralImuTopics { .. }), "{several}");
    let text = several.to_string();
    assert!(text.contains(&path), "{text}");
    assert!(text.contains("/imu/data (600 messages)") && text.contains("/imu/raw (300 messages)"), "{text}");
    assert!(text.contains("--topic"), "{text}");

    let raw = read_imu_bag(&bag, Some("/imu/raw"), None).unwrap();
    assert_matches(&raw.recording, &truth(&bag, 1));
    assert_eq!((raw.recording.rate_hz, raw.frame_id.as_str(), raw.messages), (100.0, "raw_link", 300));
    let data = read_imu_bag(&bag, Some("/imu/data"), None).unwrap();
    assert_matches(&data.recording, &truth(&bag, 0));
    assert_eq!(data.recording.rate_hz, 200.0);

    let missing = read_imu_bag(&bag, Some("/nope"), None).unwrap_err();
    assert!(matches!(missing, BagError::TopicNotFound { .. }), "{missing}");
    let text = missing.to_string();
    assert!(text.contains("\"/nope\"") && text.contains(&path), "{text}");
    assert!(text.contains("/imu/data (600 messages)") && text.contains("/imu/raw (300 messages)"), "{text}");

    let status = read_imu_bag(&bag, Some("/status"), None).unwrap_err();
    assert!(matches!(status, BagError::NotImu { .. }), "{status}");
    let text = status.to_string();
    assert!(text.contains("\"/status\"") && text.contains("std_msgs/msg/String"), "{text}");
    assert!(text.contains("/imu/raw (300 messages)"), "{text}");

    let topics = imu_topics(&bag).unwrap();
    assert_eq!(topics, [("/imu/data".to_string(), 600), ("/imu/raw".to_string(), 300)]);

    // A bag with no Imu topic lists what it has.
    let Some(none) = write_bag(&dir, "none", json!({"topics": [], "other_topic": true})) else { return };
    let err = read_imu_bag(&none, None, None).unwrap_err();
    assert!(matches!(err, BagError::NoImuTopic { .. }), "{err}");
    assert!(err.to_string().contains("/status (std_msgs/msg/String"), "{err}");
    assert!(imu_topics(&none).unwrap().is_empty());
}

#[test]
fn ros2_bag_compressions_and_chunking() {
    let dir = util::temp_dir("ros2-bag-compression");
    let mut t = imu("/imu/data", 3000, 200.0);
    t["drop"] = json!([7, 8, 2000]);
    let mut sizes = Vec::new();
    for (name, compression, chunked) in
        [("zstd", "zstd", true), ("lz4", "lz4", true), ("none", "none", true), ("unchunked", "none", false)]
    {
        // Small chunks, so that messages straddle many of them.
        let spec = json!({"topics": [t.clone()], "compression": compression, "chunked": chunked,
                          "chunk_size": 16384, "other_topic": true});
        let Some(bag) = write_bag(&dir, name, spec) else { return };
        let b = read_imu_bag(&bag, None, None).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_matches(&b.recording, &truth(&bag, 0));
        assert_eq!(b.recording.info.gaps, 6 * 3, "{name}");
        assert_eq!(b.messages, 2997, "{name}");
        sizes.push(std::fs::metadata(&bag).unwrap().len());
    }
    // The compressed bags are compressed.
    assert!(sizes[0] * 2 < sizes[2] && sizes[1] * 2 < sizes[2], "sizes {sizes:?}");
}

#[test]
fn ros2_bag_zero_stamps_use_log_time() {
    let dir = util::temp_dir("ros2-bag-zero");
    let mut t = imu("/imu/data", 1000, 400.0);
    t["zero_stamps"] = json!(true);
    t["drop"] = json!([30, 31, 999]);
    let Some(bag) = write_bag(&dir, "zero", json!({"topics": [t]})) else { return };
    let b = read_imu_bag(&bag, None, None).unwrap();
    assert_eq!(b.time_source, TimeSource::LogTime);
    assert_eq!(b.time_source.as_str(), "log_time");
    assert_matches(&b.recording, &truth(&bag, 0));
    assert_eq!(b.recording.info.gaps, 6 * 2);
    assert_eq!(b.recording.rate_hz, 400.0);
    assert_eq!(b.start_ns, T0_NS);
}

#[test]
fn ros2_bag_message_that_is_not_an_imu() {
    let dir = util::temp_dir("ros2-bag-bad");
    let mut bad = imu("/bad", 20, 200.0);
    bad["bad_schema"] = json!(true);
    let Some(bag) = write_bag(&dir, "bad", json!({"topics": [imu("/imu/data", 20, 200.0), bad]})) else { return };
    let err = read_imu_bag(&bag, Some("/bad"), None).unwrap_err();
    assert!(matches!(err, BagError::Decode { index: 1, .. }), "{err}");
    let text = err.to_string();
    assert!(text.contains("message 1 of topic \"/bad\" does not decode as sensor_msgs/msg/Imu"), "{text}");
    // The good topic of the same bag reads.
    let good = read_imu_bag(&bag, Some("/imu/data"), None).unwrap();
    assert_matches(&good.recording, &truth(&bag, 0));
}

/// A deterministic byte stream.
fn noise(n: usize, seed: u64) -> Vec<u8> {
    let mut s = seed;
    (0..n)
        .map(|_| {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 56) as u8
        })
        .collect()
}

#[test]
fn ros2_bag_truncated_and_garbage_files_are_errors() {
    let dir = util::temp_dir("ros2-bag-damage");
    let mut t = imu("/imu/data", 2000, 200.0);
    t["drop"] = json!([5]);
    let Some(zstd) = write_bag(&dir, "zstd", json!({"topics": [t.clone()], "chunk_size": 8192})) else { return };
    let spec = json!({"topics": [t], "compression": "none", "chunked": false});
    let Some(flat) = write_bag(&dir, "flat", spec) else { return };
    let cut = dir.join("cut.mcap");
    let cut_name = cut.display().to_string();

    for bag in [&zstd, &flat] {
        let whole = std::fs::read(bag).unwrap();
        let n = whole.len();
        for len in [0, 3, 8, 9, 20, 100, n / 3, n / 2, n - 200, n - 9, n - 1] {
            std::fs::write(&cut, &whole[..len]).unwrap();
            let err = read_imu_bag(&cut, None, None).expect_err("a truncated bag must not read");
            let text = err.to_string();
            assert!(text.contains(&cut_name), "{text}");
            match len {
                0..=7 => assert!(matches!(err, BagError::NotMcap { .. }), "{len}: {text}"),
                _ => assert!(matches!(err, BagError::Truncated { .. } | BagError::Corrupt { .. }), "{len}: {text}"),
            }
            assert!(imu_topics(&cut).is_err(), "{len}");
        }
        // Damage anywhere (about 600 places, every part of the file): an error or (where the damage is in a part
        // not read or not checked) data, never a panic.
        for at in (0..n).step_by((n / 600) | 1) {
            let mut damaged = whole.clone();
            damaged[at] ^= 0x5A;
            std::fs::write(&cut, &damaged).unwrap();
            if let Ok(b) = read_imu_bag(&cut, None, None) {
                assert!(b.recording.info.samples > 0);
            }
        }
    }

    // Not MCAP at all.
    let garbage = dir.join("garbage.mcap");
    std::fs::write(&garbage, noise(10_000, 1)).unwrap();
    let err = read_imu_bag(&garbage, None, None).unwrap_err();
    assert!(matches!(err, BagError::NotMcap { .. }), "{err}");
    assert!(err.to_string().contains("garbage.mcap") && err.to_string().contains("not an MCAP file"), "{err}");
    // The MCAP magic followed by garbage.
    for seed in 1..50 {
        let mut bytes = b"\x89MCAP0\r\n".to_vec();
        bytes.extend(noise(5_000, seed));
        std::fs::write(&garbage, &bytes).unwrap();
        let err = read_imu_bag(&garbage, None, None).unwrap_err();
        assert!(matches!(err, BagError::Truncated { .. } | BagError::Corrupt { .. }), "{err}");
    }
    let err = read_imu_bag(&dir.join("absent.mcap"), None, None).unwrap_err();
    assert!(matches!(err, BagError::Io { .. }), "{err}");
}

#[test]
fn the_command_s_read_path_takes_a_bag_by_extension_and_picks_axes() {
    use octavar::io::csv::CsvOptions;
    use octavar::io::formats::{read_recording, ReadError, ReadOptions, RecordingFormat};
    let dir = util::temp_dir("ros2-bag-formats");
    let Some(bag) = write_bag(&dir, "axes", json!({"topics": [imu("/imu/data", 500, 100.0)]})) else { return };
    assert_eq!(RecordingFormat::of(&bag, None), Some(RecordingFormat::Mcap));
    let all = read_recording(&bag, RecordingFormat::Mcap, &ReadOptions::default()).unwrap();
    assert_eq!(all.names, ["x", "y", "z", "ax", "ay", "az"]);
    let csv = CsvOptions { columns: vec!["z".into(), "x".into()], ..Default::default() };
    let opts = ReadOptions { csv, topic: Some("/imu/data".into()), channels: 1 };
    let picked = read_recording(&bag, RecordingFormat::Mcap, &opts).unwrap();
    assert_eq!(picked.names, ["z", "x"]);
    assert_eq!(picked.channels, [all.channels[2].clone(), all.channels[0].clone()]);
    let csv = CsvOptions { columns: vec!["w".into()], ..Default::default() };
    let err = read_recording(&bag, RecordingFormat::Mcap, &ReadOptions { csv, ..Default::default() }).unwrap_err();
    assert!(matches!(err, ReadError::NoSuchAxis { .. }), "{err}");
}

//! The device path from the outside: `octavar record`, `decode` and `verify` on captures of a simulated device,
//! exit codes, and errors that name the problem and where it is.

mod common;
use common::{octavar, stderr, stdout};

use std::path::{Path, PathBuf};

use octavar::board::simulated::{device_frames, DeviceConfig, DeviceSim};
use octavar_shared::proto::{Encoder, Frame, SnapshotPart};

fn scan(i: u32) -> [u16; 5] {
    let x = (i.wrapping_mul(2654435761) >> 20) as u16;
    [2000 + x % 97, 2040 + x % 13, 1900 + x % 301, 2048 + x % 5, 1950]
}

/// Three rounds of a simulated device streaming every channel raw.
fn capture_bytes() -> Vec<u8> {
    device_frames(DeviceConfig::F405, 0x1f, (0..6100).map(scan))
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn verify_and_decode_a_simulated_device() {
    let dir = tempfile::tempdir().unwrap();
    let cap = write(dir.path(), "run.cap", &capture_bytes());

    let o = octavar(&["verify", s(&cap)], None);
    assert_eq!(o.status.code(), Some(0), "{}{}", stdout(&o), stderr(&o));
    assert!(stdout(&o).contains("OK: all 12 checked snapshots match the replay bit for bit"), "{}", stdout(&o));

    let csv = dir.path().join("csv");
    let json = dir.path().join("summary.json");
    let o = octavar(&["decode", s(&cap), "--csv", s(&csv), "--json", s(&json)], None);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stdout(&o).contains("lost frames 0, CRC errors 0"), "{}", stdout(&o));
    let first_line = |name: &str| std::fs::read_to_string(csv.join(name)).unwrap().lines().next().unwrap().to_string();
    assert_eq!(first_line("samples.csv"), "sample,IDG1215 X,IDG1215 Y,ADXRS300,ENV-05H,ADXRS300 TEMP");
    assert_eq!(first_line("snapshots.csv"), "frame_seq,channel,samples,level,m,tau_s,n,sum_sq,avar_codes2,adev_codes");
    assert_eq!(
        first_line("status.csv"),
        "frame_seq,uptime_ms,samples_per_channel,adc_overruns,frames_dropped,temperature_c,samples_lost,stack_peak_bytes"
    );
    let samples = std::fs::read_to_string(csv.join("samples.csv")).unwrap();
    assert_eq!(samples.lines().count(), 1 + 6100);
    let row = scan(7);
    assert_eq!(samples.lines().nth(8).unwrap(), format!("7,{},{},{},{},{}", row[0], row[1], row[2], row[3], row[4]));

    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["hello"]["sample_rate_hz"], 2000);
    assert_eq!(v["stats"]["crc_errors"], 0);
    assert_eq!(v["snapshots"].as_array().unwrap().len(), 4);
    assert_eq!(v["snapshots"][2]["samples"], 6000);
    assert_eq!(v["statuses"].as_array().unwrap().len(), 3);
    assert_eq!(v["estimates"].as_array().unwrap().len(), 3);
    // The summary's keys are an interface (users' scripts read them): exactly these.
    let mut keys: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
    keys.sort_unstable();
    let want = [
        "csv_files",
        "estimates",
        "estimates_every",
        "field_log",
        "field_log_checkpoint",
        "hello",
        "samples_per_channel",
        "snapshots",
        "source",
        "stats",
        "statuses",
        "statuses_every",
    ];
    assert_eq!(keys, want);

    // JSON to stdout; the same report for verify.
    let o = octavar(&["decode", "-", "--json", "-"], Some(&capture_bytes()));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["source"], "stdin");
    let o = octavar(&["verify", s(&cap), "--json"], None);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!((v["checked"].as_u64(), v["matched"].as_u64()), (Some(12), Some(12)));
}

#[test]
fn verify_exits_1_on_a_wrong_snapshot_and_when_nothing_can_be_checked() {
    let dir = tempfile::tempdir().unwrap();
    // A device whose snapshot of channel 2 is off in level 5 (a valid frame: the CRC is right).
    let mut dev = DeviceSim::new(DeviceConfig::F405, 0x1f);
    let mut bytes = Vec::new();
    dev.boot(&mut bytes);
    (0..2100).for_each(|i| dev.push_scan(&scan(i), &mut bytes));
    let mut bad = dev.snapshot(2);
    bad.levels[5].n += 1;
    let mut enc = Encoder::starting_at(5000);
    for p in SnapshotPart::split(2, &bad) {
        bytes.extend_from_slice(&enc.encode_to_vec(&Frame::AllanSnapshot(p)).unwrap());
    }
    let cap = write(dir.path(), "bad.cap", &bytes);
    let o = octavar(&["verify", s(&cap)], None);
    assert_eq!(o.status.code(), Some(1), "{}", stdout(&o));
    assert!(stdout(&o).contains("MISMATCH channel 2, snapshot at sample 2048 (frame 5000"), "{}", stdout(&o));
    assert!(stdout(&o).contains("level 5: n "), "{}", stdout(&o));
    assert!(stdout(&o).contains("FAILED: 1 of 5 checked snapshots differ"), "{}", stdout(&o));

    // No raw streaming: nothing can be checked.
    let cap = write(dir.path(), "noraw.cap", &device_frames(DeviceConfig::F405, 0, (0..4100).map(scan)));
    let o = octavar(&["verify", s(&cap)], None);
    assert_eq!(o.status.code(), Some(1));
    assert!(stdout(&o).contains("no raw samples of this channel"), "{}", stdout(&o));
    assert!(stdout(&o).contains("FAILED: no snapshot could be checked"), "{}", stdout(&o));
}

#[test]
fn bad_captures_get_clear_errors_and_counts_never_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    for cmd in ["decode", "verify"] {
        let o = octavar(&[cmd, "/nonexistent/run.cap"], None);
        assert_eq!(o.status.code(), Some(2), "{cmd}");
        assert!(stderr(&o).contains("cannot open capture /nonexistent/run.cap"), "{}", stderr(&o));

        let empty = write(dir.path(), "empty.cap", b"");
        let o = octavar(&[cmd, s(&empty)], None);
        assert_eq!(o.status.code(), Some(2), "{cmd}");
        assert!(stderr(&o).contains("empty.cap is empty (0 bytes)"), "{}", stderr(&o));
    }

    // Not a capture at all.
    let text = write(dir.path(), "notes.txt", &b"hello world\n".repeat(100));
    let o = octavar(&["decode", s(&text)], None);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("no intact frame in"), "{}", stderr(&o));

    // Cut mid-frame: every frame before the cut, and the tail is reported.
    let full = capture_bytes();
    let cut = full.len() - 40;
    let cap = write(dir.path(), "cut.cap", &full[..cut]);
    let o = octavar(&["decode", s(&cap)], None);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stdout(&o).contains("truncated tail"), "{}", stdout(&o));
    assert!(!stdout(&o).contains("truncated tail 0 bytes"), "{}", stdout(&o));

    // Corrupted bytes: counted with their offsets; verify still checks what it can and finds no mismatch.
    let mut damaged = full.clone();
    for i in (1000..damaged.len()).step_by(9000) {
        damaged[i] ^= 0x5a;
    }
    let cap = write(dir.path(), "damaged.cap", &damaged);
    let o = octavar(&["decode", s(&cap)], None);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stdout(&o).contains("bad frame at byte "), "{}", stdout(&o));
    let o = octavar(&["verify", s(&cap), "--json"], None);
    assert!(matches!(o.status.code(), Some(0 | 1)), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["mismatched_snapshots"], 0, "{v}");
    for o in [octavar(&["decode", s(&cap)], None), octavar(&["verify", s(&cap)], None)] {
        assert!(!stderr(&o).contains("panicked"), "{}", stderr(&o));
    }
}

#[test]
fn record_copies_the_exact_bytes_and_never_overwrites() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = capture_bytes();
    let src = write(dir.path(), "in.cap", &bytes);
    let out = dir.path().join("out.cap");
    let o = octavar(&["record", "--from", s(&src), "-o", s(&out)], None);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(std::fs::read(&out).unwrap(), bytes);
    assert!(stdout(&o).contains("6100 samples"), "{}", stdout(&o));
    assert!(stdout(&o).contains("the input ended"), "{}", stdout(&o));
    // Not a terminal: plain status lines, the last one with the live ADEV at 1 s in deg/s.
    let last = stderr(&o).lines().last().unwrap_or_default().to_string();
    assert!(last.contains("6100 samples") && last.contains("IDG1215 X: ADEV(1 s)") && last.contains("deg/s"), "{last}");

    let o = octavar(&["record", "--from", s(&src), "-o", s(&out)], None);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("already exists"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&out).unwrap(), bytes, "untouched");

    // stdin, appended.
    let o = octavar(&["record", "--from", "-", "-o", s(&out), "--append", "--json"], Some(&bytes[..1000]));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["ended"], "source_ended");
    assert_eq!(std::fs::read(&out).unwrap().len(), bytes.len() + 1000);

    let o = octavar(&["record", "--from", "/nonexistent/in.cap", "-o", s(&dir.path().join("x.cap"))], None);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("/nonexistent/in.cap"), "{}", stderr(&o));
}

#[test]
fn record_names_a_missing_port() {
    let dir = tempfile::tempdir().unwrap();
    let o = octavar(&["record", "/dev/ttyOCTAVAR-NONE", "-o", s(&dir.path().join("x.cap")), "--once"], None);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("cannot open /dev/ttyOCTAVAR-NONE"), "{}", stderr(&o));
    assert!(!stderr(&o).contains("panicked"));
    let o = octavar(&["record", "-o", s(&dir.path().join("y.cap"))], None);
    assert_eq!(o.status.code(), Some(2), "a port or --from is required");
}

#[test]
fn a_capture_s_raw_samples_are_a_recording_with_its_lost_samples_as_gaps() {
    use octavar::io::csv::CsvOptions;
    use octavar::io::formats::{read_recording, ReadOptions, RecordingFormat};
    use octavar_shared::sensor::{temperature_c, Channel, ADXRS300};
    let dir = tempfile::tempdir().unwrap();
    let mut dev = DeviceSim::new(DeviceConfig::F405, 0x1f);
    let mut bytes = Vec::new();
    dev.boot(&mut bytes);
    (0..1000).for_each(|i| dev.push_scan(&scan(i), &mut bytes));
    dev.lose_samples(300, &mut bytes);
    (1000..2000).for_each(|i| dev.push_scan(&scan(i), &mut bytes));
    let cap = write(dir.path(), "run.cap", &bytes);
    assert_eq!(RecordingFormat::of(&cap, None), Some(RecordingFormat::Capture));
    let csv = CsvOptions {
        columns: vec!["ADXRS300".into()],
        temp_column: Some("ADXRS300 TEMP".into()),
        ..Default::default()
    };
    let rec = read_recording(&cap, RecordingFormat::Capture, &ReadOptions { csv, ..Default::default() }).unwrap();
    assert_eq!(rec.rate_hz, 2000.0);
    // Every scan pushed before the loss is there, then 300 NaN, then the scans after it that whole blocks of 128
    // scans carried, each code through the ADXRS300's bench channel.
    let ch = Channel::bench(ADXRS300);
    let x = &rec.channels[0];
    let t = rec.temp_c.as_ref().unwrap();
    assert_eq!(x.len(), 1300 + 1000 / 128 * 128, "{}", x.len());
    for (k, (&v, &tc)) in x.iter().zip(t).enumerate() {
        let i = match k {
            0..1000 => k,
            1000..1300 => {
                assert!(v.is_nan() && tc.is_nan(), "sample {k}");
                continue;
            }
            _ => k - 300,
        };
        let code = scan(i as u32);
        assert_eq!(v, ch.code_to_dps(code[2]), "sample {k}");
        assert_eq!(tc, f64::from(temperature_c(f64::from(code[4]))), "sample {k}");
    }
    assert_eq!(rec.info.gaps, 300);
}

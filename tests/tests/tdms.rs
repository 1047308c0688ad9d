//! The TDMS reader against an independent writer: files written by npTDMS (and bytes written by hand from NI's
//! format description, checked by npTDMS's reader), with the values expected written beside them by numpy.
//! Unscaled values must come out bit for bit; scaled ones within 1e-12 of npTDMS's own scaled read.

use std::path::{Path, PathBuf};

use octavar::io::recording::RateUnit;
use octavar::io::tdms::{read_tdms, TdmsError};

use crate::util;

/// Run `tdms_write.py MODE` into a fresh directory: the directory, or `None` (with a printed line) without npTDMS.
fn write(mode: &str, tag: &str) -> Option<PathBuf> {
    let py = util::reference_python("nptdms")?;
    let dir = util::temp_dir(&format!("tdms-{tag}"));
    let out = std::process::Command::new(py)
        .arg(util::reference_script("tdms_write.py"))
        .arg(mode)
        .arg(&dir)
        .output()
        .expect("run tdms_write.py");
    assert!(out.status.success(), "tdms_write.py {mode} failed: {}", String::from_utf8_lossy(&out.stderr));
    Some(dir)
}

/// The values numpy wrote for `group/channel`.
fn expected(dir: &Path, name: &str) -> Vec<f64> {
    let bytes = std::fs::read(dir.join(format!("{}.f64", name.replace('/', "_")))).expect("expected values");
    bytes.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap())).collect()
}

fn columns(names: &[&str]) -> Vec<String> {
    names.iter().map(|s| s.to_string()).collect()
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

const IMU: [&str; 4] = ["imu/gx", "imu/gy", "imu/gz", "aux/temp"];

#[test]
fn nptdms_segments_read_bit_for_bit() {
    let Some(dir) = write("segments", "segments") else { return };
    let rec = read_tdms(&dir.join("file.tdms"), &columns(&IMU), RateUnit::DegPerS, None).unwrap();
    assert_eq!(rec.names, IMU);
    for (name, got) in IMU.iter().zip(&rec.channels) {
        let want = expected(&dir, name);
        assert_eq!(want.len(), 1778, "{name}");
        assert_eq!(bits(got), bits(&want), "{name}");
    }
    // wf_increment = 1/400 s.
    assert!((rec.rate_hz - 400.0).abs() < 1e-9, "{}", rec.rate_hz);
    assert_eq!(rec.info.samples, 1778);
    assert_eq!(rec.info.gaps, 2);
    assert_eq!(rec.info.columns, IMU);
    // --rate that agrees is taken; one that does not is an error naming both.
    let rec = read_tdms(&dir.join("file.tdms"), &columns(&["imu/gy"]), RateUnit::DegPerS, Some(400.0)).unwrap();
    assert_eq!(rec.channels[0], expected(&dir, "imu/gy"));
    let err = read_tdms(&dir.join("file.tdms"), &columns(&["imu/gy"]), RateUnit::DegPerS, Some(500.0)).unwrap_err();
    assert!(matches!(err, TdmsError::RateMismatch { .. }), "{err}");
    let msg = err.to_string();
    assert!(msg.contains("wf_increment 0.0025 s (400 Hz), but --rate is 500 Hz"), "{msg}");
}

#[test]
fn rad_per_s_is_converted() {
    let Some(dir) = write("segments", "radps") else { return };
    let rec = read_tdms(&dir.join("file.tdms"), &columns(&IMU[..3]), RateUnit::RadPerS, None).unwrap();
    let k = RateUnit::RadPerS.to_dps();
    for (name, got) in IMU.iter().zip(&rec.channels) {
        let want: Vec<f64> = expected(&dir, name).iter().map(|v| v * k).collect();
        assert_eq!(bits(got), bits(&want), "{name}");
    }
}

#[test]
fn linear_polynomial_and_chained_scales_match_nptdms() {
    let Some(dir) = write("scaled", "scaled") else { return };
    let names = ["dev/lin", "dev/poly", "dev/chain", "dev/already"];
    let rec = read_tdms(&dir.join("file.tdms"), &columns(&names), RateUnit::DegPerS, None).unwrap();
    assert!((rec.rate_hz - 1000.0).abs() < 1e-9, "{}", rec.rate_hz);
    for (name, got) in names.iter().zip(&rec.channels) {
        let want = expected(&dir, name);
        assert_eq!(got.len(), 1001, "{name}");
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            assert!((g - w).abs() <= 1e-12 * w.abs(), "{name}[{i}]: {g} vs npTDMS {w}");
        }
    }
    // Linear: raw * slope + intercept, as npTDMS computes it, to the bit; already scaled: as stored.
    assert_eq!(bits(&rec.channels[0]), bits(&expected(&dir, "dev/lin")));
    assert_eq!(bits(&rec.channels[3]), bits(&expected(&dir, "dev/already")));
}

#[test]
fn unsupported_scale_is_an_error_naming_it() {
    let Some(dir) = write("scaled", "table") else { return };
    let err = read_tdms(&dir.join("file.tdms"), &columns(&["dev/lin", "dev/table"]), RateUnit::DegPerS, None)
        .unwrap_err()
        .to_string();
    assert!(err.contains("channel \"dev/table\": scale 0 is of type \"Table\", which octavar does not apply"), "{err}");
}

#[test]
fn carried_over_metadata_interleaved_and_big_endian() {
    let Some(dir) = write("handbuilt", "handbuilt") else { return };
    let path = dir.join("file.tdms");
    let rec = read_tdms(&path, &columns(&["g/a", "g/b"]), RateUnit::DegPerS, None).unwrap();
    assert_eq!(rec.rate_hz, 50.0);
    for (name, got) in ["g/a", "g/b"].iter().zip(&rec.channels) {
        let want = expected(&dir, name);
        assert_eq!(want.len(), 37, "{name}");
        assert_eq!(bits(got), bits(&want), "{name}");
    }
    let rec = read_tdms(&path, &columns(&["g/c"]), RateUnit::DegPerS, Some(1.0)).unwrap();
    assert_eq!(rec.channels[0], expected(&dir, "g/c"));
}

#[test]
fn missing_channel_lists_the_file_s_channels() {
    let Some(dir) = write("segments", "missing") else { return };
    let path = dir.join("file.tdms");
    let err = read_tdms(&path, &columns(&["imu/gx", "imu/gw"]), RateUnit::DegPerS, None).unwrap_err().to_string();
    assert_eq!(
        err,
        format!(
            "{}: no channel \"imu/gw\" (the file has: imu/gx, imu/gy, imu/gz, aux/temp, odd/short)",
            path.display()
        )
    );
}

#[test]
fn channels_of_different_lengths_are_an_error() {
    let Some(dir) = write("segments", "lengths") else { return };
    let path = dir.join("file.tdms");
    let err = read_tdms(&path, &columns(&["imu/gx", "odd/short"]), RateUnit::DegPerS, Some(400.0)).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, TdmsError::UnequalLengths { .. }), "{msg}");
    assert!(
        msg.contains("channels \"imu/gx\" (1778 samples) and \"odd/short\" (10 samples) differ in length"),
        "{msg}"
    );
    // odd/short has no wf_increment: --rate is needed, and taken.
    let err = read_tdms(&path, &columns(&["odd/short"]), RateUnit::DegPerS, None).unwrap_err().to_string();
    assert!(err.ends_with("no sample rate: the channels have no wf_increment property; give --rate HZ"), "{err}");
    let rec = read_tdms(&path, &columns(&["odd/short"]), RateUnit::DegPerS, Some(10.0)).unwrap();
    assert_eq!(rec.rate_hz, 10.0);
    assert_eq!(rec.channels[0], expected(&dir, "odd/short"));
}

#[test]
fn truncated_and_garbage_files_are_errors() {
    let Some(dir) = write("segments", "truncated") else { return };
    let bytes = std::fs::read(dir.join("file.tdms")).unwrap();
    let cut = dir.join("cut.tdms");
    // Cuts in the first segment's lead-in, its metadata, its data, and in the last segment.
    for n in [10, 100, 20_000, bytes.len() - 1] {
        std::fs::write(&cut, &bytes[..n]).unwrap();
        let err = read_tdms(&cut, &columns(&IMU), RateUnit::DegPerS, None).unwrap_err();
        let msg = err.to_string();
        assert!(matches!(err, TdmsError::Truncated { .. }), "cut at {n}: {msg}");
        assert!(msg.starts_with(&format!("{}, byte {n} (segment ", cut.display())), "{msg}");
        assert!(msg.contains("the file is truncated"), "{msg}");
    }
    // Every cut is an error or (between segments) a shorter file, never a panic.
    for n in (0..bytes.len()).step_by(97) {
        std::fs::write(&cut, &bytes[..n]).unwrap();
        let _ = read_tdms(&cut, &columns(&IMU), RateUnit::DegPerS, None);
    }
    // Garbage: not TDMS at all, and a TDMS tag followed by noise.
    let mut s = 0x2545_F491_4F6C_DD1Du64;
    let noise: Vec<u8> = (0..4096)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s as u8
        })
        .collect();
    let garbage = dir.join("garbage.tdms");
    std::fs::write(&garbage, &noise).unwrap();
    let err = read_tdms(&garbage, &columns(&IMU), RateUnit::DegPerS, None).unwrap_err();
    assert!(matches!(err, TdmsError::NotTdms { .. }), "{err}");
    std::fs::write(&garbage, [b"TDSm".as_slice(), &noise].concat()).unwrap();
    let err = read_tdms(&garbage, &columns(&IMU), RateUnit::DegPerS, None).unwrap_err();
    assert!(matches!(err, TdmsError::Corrupt { .. } | TdmsError::Truncated { .. }), "{err}");
}

#[test]
fn the_command_s_read_path_takes_tdms_by_extension_with_a_temperature_channel() {
    use octavar::io::csv::CsvOptions;
    use octavar::io::formats::{read_recording, ReadError, ReadOptions, RecordingFormat};
    let Some(dir) = write("segments", "formats") else { return };
    let path = dir.join("file.tdms");
    assert_eq!(RecordingFormat::of(&path, None), Some(RecordingFormat::Tdms));
    let csv = CsvOptions { columns: columns(&["imu/gx"]), temp_column: Some("aux/temp".into()), ..Default::default() };
    let rec = read_recording(&path, RecordingFormat::Tdms, &ReadOptions { csv, ..Default::default() }).unwrap();
    assert_eq!(bits(&rec.channels[0]), bits(&expected(&dir, "imu/gx")));
    assert_eq!(bits(rec.temp_c.as_ref().unwrap()), bits(&expected(&dir, "aux/temp")));
    // CSV-only options are refused by name.
    let csv = CsvOptions { columns: columns(&["imu/gx"]), time_column: Some("t".into()), ..Default::default() };
    let err = read_recording(&path, RecordingFormat::Tdms, &ReadOptions { csv, ..Default::default() }).unwrap_err();
    assert!(matches!(err, ReadError::CsvOnly { option: "--time-column", .. }), "{err}");
}

//! The device path in one process: virtual gyros (shared::sim) -> the firmware's accumulation and frames
//! (octavar::board::simulated: one `OctaveAllan<8>` per gyro, hello, raw samples, snapshot rounds, status) -> a capture
//! -> decode -> verify, with every snapshot bit for bit.

use std::sync::atomic::AtomicBool;
use std::time::Duration;

use octavar::board::recorder::{record, ReaderSource, RecordOptions};
use octavar::board::simulated::{DeviceConfig, DeviceSim};
use octavar::board::verify::{verify, verify_path};
use octavar::io::capture::CaptureWriter;
use octavar::io::decode::{CaptureReader, Message, StreamDecoder};
use octavar_shared::acc::{OctaveAllan, Snapshot};
use octavar_shared::proto::Command;
use octavar_shared::sensor::temperature_code;
use octavar_shared::sensor::SensorKind;
use octavar_shared::sim::{Bench, BenchSim, ChannelSim, GyroSim, TemperatureProfile};

/// The paper's four gyros (N, B from its Table 1) on the bench at 2 kS/s, 22-25 degC.
pub fn bench(seed: u64) -> Bench {
    let parts = [
        (SensorKind::Idg1215X, 3.2e-3, 14e-3),
        (SensorKind::Idg1215Y, 3.0e-3, 13e-3),
        (SensorKind::Adxrs300, 46e-3, 26e-3),
        (SensorKind::Env05h, 4.0e-4, 9.5e-4),
    ];
    let temperature = TemperatureProfile { min_c: 22.0, max_c: 25.0, period_s: 600.0, ..Default::default() };
    let mut model = BenchSim { rate_hz: 2000.0, seed, temperature, channels: Default::default() };
    for (sensor, n, b) in parts {
        let gyro = GyroSim { n_deg_per_rt_s: n, b_dps: b, ..Default::default() };
        model.channels.push(ChannelSim { sensor, channel: None, gyro }).unwrap();
    }
    Bench::new(&model).unwrap()
}

/// The next scan as the firmware's ADC sees it: four gyro codes, then the ADXRS300 TEMP code.
pub fn next_scan(b: &mut Bench) -> [u16; 5] {
    let s = b.next_sample();
    let c = s.codes();
    [c[0], c[1], c[2], c[3], temperature_code(s.temp_c)]
}

/// `seconds` of the bench through a simulated device streaming every channel raw; also the scans.
pub fn device_capture(seed: u64, seconds: u32) -> (Vec<u8>, Vec<[u16; 5]>) {
    let mut b = bench(seed);
    let mut dev = DeviceSim::new(DeviceConfig::F405, 0x1f);
    let mut cap = CaptureWriter::new(Vec::new(), std::path::Path::new("pipeline.cap"));
    let mut out = Vec::new();
    dev.boot(&mut out);
    let mut scans = Vec::new();
    for _ in 0..seconds * 2000 {
        let s = next_scan(&mut b);
        dev.push_scan(&s, &mut out);
        scans.push(s);
        if out.len() > 4096 {
            cap.append(&out).unwrap();
            out.clear();
        }
    }
    dev.flush_block(&mut out);
    cap.append(&out).unwrap();
    (cap.into_inner().unwrap(), scans)
}

#[test]
fn bench_codes_through_device_frames_verify_bit_for_bit() {
    let (wire, scans) = device_capture(11, 20);
    let report = verify(CaptureReader::new(&wire[..], "pipeline.cap")).unwrap();
    assert_eq!(report.snapshots, 4 * 20);
    assert_eq!((report.checked, report.matched, report.unchecked), (80, 80, 0), "{report:#?}");
    assert!(report.passed());
    assert_eq!(report.stride, Some(8));
    assert_eq!(report.decode.bad_frame_count() + report.decode.lost_frames, 0);

    // Independently of device_sim: one OctaveAllan<8> per gyro over the same codes, snapshot every 2000 scans;
    // the decoded snapshots are exactly those, in order, and the decoded raw codes are exactly the scans.
    let mut accs = [OctaveAllan::<8>::new(), OctaveAllan::new(), OctaveAllan::new(), OctaveAllan::new()];
    let mut expected: Vec<(u8, Snapshot)> = Vec::new();
    for (i, s) in scans.iter().enumerate() {
        for (g, acc) in accs.iter_mut().enumerate() {
            acc.push(s[g]);
        }
        if (i + 1) % 2000 == 0 {
            expected.extend(accs.iter().enumerate().map(|(g, a)| (g as u8, a.snapshot())));
        }
    }
    let mut got = Vec::new();
    let mut raw = Vec::new();
    for (i, d) in CaptureReader::new(&wire[..], "pipeline.cap").enumerate() {
        let d = d.unwrap();
        assert_eq!(i == 0, matches!(d.message, Message::Hello(_)), "the hello comes first, once");
        match d.message {
            Message::Snapshot(c) => got.push((c.channel, c.snapshot)),
            Message::Samples(s) => {
                assert_eq!(s.first_sample, raw.len() as u64);
                for set in 0..s.sets() {
                    raw.push([0, 1, 2, 3, 4].map(|slot| s.code(set, slot).unwrap()));
                }
            }
            Message::Hello(h) => assert_eq!((h.rate_hz, h.stride, h.channels.len()), (2000, 8, 5)),
            Message::Status(st) => {
                let t = st.temperature_c.unwrap();
                assert!((21.0..26.0).contains(&t), "bench temperature {t}");
            }
            _ => {}
        }
    }
    assert_eq!(got, expected);
    assert_eq!(raw, scans);
}

#[test]
fn chunking_does_not_change_what_is_decoded() {
    let (wire, _) = device_capture(3, 3);
    let whole: Vec<_> = CaptureReader::new(&wire[..], "w").map(Result::unwrap).collect();
    let mut dec = StreamDecoder::new();
    let mut pieces = Vec::new();
    let mut at = 0;
    let mut step = 1;
    while at < wire.len() {
        let end = (at + step).min(wire.len());
        dec.feed(&wire[at..end], &mut |d| pieces.push(d));
        at = end;
        step = step * 7 % 1013 + 1;
    }
    dec.finish();
    assert_eq!(pieces, whole);
    // Every delimiter that ends a frame (the lone one the device starts with ends none).
    assert_eq!(dec.stats().frames as usize, wire.windows(2).filter(|w| w[1] == 0 && w[0] != 0).count());
}

#[test]
fn device_gaps_are_pooled_and_a_reset_starts_a_new_session() {
    let mut b = bench(5);
    let mut dev = DeviceSim::new(DeviceConfig::F405, 0x1f);
    let mut out = Vec::new();
    dev.boot(&mut out);
    for i in 0..9000u32 {
        if i == 3000 || i == 5555 {
            dev.lose_samples(40 + u64::from(i % 7), &mut out); // ADC overruns
        }
        if i == 7100 {
            dev.command(Command::Reset, &mut out);
        }
        dev.push_scan(&next_scan(&mut b), &mut out);
    }
    for _ in 0..2100 {
        dev.push_scan(&next_scan(&mut b), &mut out);
    }
    // Rounds at 2000, 4000, 6000 accumulated samples are checked across the two gaps (pooled as the device
    // pools); after the reset the raw index starts again at 0 (as the firmware's does), so the host sees a new
    // session and checks its round too: every snapshot is checked and matches.
    let report = verify(CaptureReader::new(&out[..], "gaps.cap")).unwrap();
    assert_eq!((report.checked, report.matched, report.mismatched_snapshots), (16, 16, 0), "{report:#?}");
    assert_eq!(report.unchecked, 0, "{report:#?}");
}

#[test]
fn record_from_a_stream_then_verify_the_file() {
    let (wire, _) = device_capture(8, 3);
    let dir = std::env::temp_dir().join(format!("octavar-pipeline-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("rec.cap");
    let _ = std::fs::remove_file(&path);
    let mut cap = CaptureWriter::create(&path, false).unwrap();
    let mut src = ReaderSource::new("pipe", Box::new(std::io::Cursor::new(wire.clone())), Duration::from_millis(5));
    let stop = AtomicBool::new(false);
    let summary = record(&mut src, &mut cap, &RecordOptions::default(), &stop, &mut |_| {}).unwrap();
    assert_eq!(cap.close().unwrap(), wire.len() as u64);
    assert_eq!(summary.stats.sample_sets, 6000);
    assert_eq!(summary.stats.adev_1s.len(), 4);
    let report = verify_path(&path).unwrap();
    assert_eq!((report.checked, report.matched), (12, 12));
    std::fs::remove_dir_all(&dir).unwrap();
}

//! The reader on files built byte by byte: segments of every kind, every numeric type, rates, channel names, and
//! damaged or truncated files.

mod scaling;
mod writer;

use super::format::{TOC_BIG_ENDIAN, TOC_DAQMX_RAW_DATA, TOC_INTERLEAVED, TOC_NEW_OBJ_LIST};
use super::metadata::{object_path, parse_path};
use super::*;
use writer::*;

#[test]
fn contiguous_segments_give_values_names_and_rate() {
    let (a0, b0, a1, b1) = (seq_f64(0, 5), seq_i16(0, 5), seq_f64(5, 5), seq_i16(5, 5));
    let mut file = first_segment(&a0, &b0, 0);
    file.extend(first_segment(&a1, &b1, 0));
    let rec = read(&file, &["g/a", "g/b"], None).unwrap();
    assert_eq!(rec.names, ["g/a", "g/b"]);
    assert_eq!(bits(&rec.channels[0]), bits(&[a0, a1].concat()));
    let b = as_f64(&[b0, b1].concat());
    assert_eq!(rec.channels[1], b);
    assert_eq!(rec.rate_hz, 100.0);
    assert_eq!(rec.info.samples, 10);
    assert_eq!(rec.info.gaps, 0);
    assert_eq!(rec.info.columns, rec.names);
    assert_eq!(rec.source, "test.tdms");
    assert!(rec.temp_c.is_none());
    // The same channel twice, and in the other order.
    let rec = read(&file, &["g/b", "g/a", "g/b"], Some(100.0)).unwrap();
    assert_eq!(rec.channels[0], rec.channels[2]);
    assert_eq!(rec.channels[0], b);
}

#[test]
fn metadata_carries_over_between_segments() {
    let (mut a, mut b, mut c) = (Vec::new(), Vec::new(), Vec::new());
    let next = |n: usize, a: &mut Vec<f64>, b: &mut Vec<i16>| {
        let (x, y) = (seq_f64(a.len(), n), seq_i16(b.len() + 1000, n));
        a.extend(&x);
        b.extend(&y);
        (x, y)
    };
    // 1: a and b, 3 values each.
    let (x, y) = next(3, &mut a, &mut b);
    let mut file = first_segment(&x, &y, 0);
    // 2: no metadata, two chunks of the same layout.
    let (x0, y0) = next(3, &mut a, &mut b);
    let (x1, y1) = next(3, &mut a, &mut b);
    file.extend(segment(0, None, &[f64s(&x0, false), i16s(&y0, false), f64s(&x1, false), i16s(&y1, false)].concat()));
    // 3: a "same as previous", c (u8) appended; b, unmentioned, keeps its data.
    let (x, y) = next(3, &mut a, &mut b);
    let z = [200u8, 3];
    c.extend(z.map(f64::from));
    let objs = [obj(&chan("g", "a"), Ix::Same, vec![]), obj(&chan("g", "c"), Ix::New(5, 2), vec![])];
    file.extend(segment(0, Some(&objs), &[f64s(&x, false), i16s(&y, false), z.to_vec()].concat()));
    // 4: b has no data here; a gets a new index; c carries on.
    let x = seq_f64(a.len(), 4);
    a.extend(&x);
    let z = [9u8, 10];
    c.extend(z.map(f64::from));
    let objs = [obj(&chan("g", "b"), Ix::NoData, vec![]), obj(&chan("g", "a"), Ix::New(10, 4), vec![])];
    file.extend(segment(0, Some(&objs), &[f64s(&x, false), z.to_vec()].concat()));
    // 5: a has no data; b comes back with its old index (3 values).
    let y = seq_i16(b.len() + 1000, 3);
    b.extend(&y);
    let objs = [obj(&chan("g", "a"), Ix::NoData, vec![]), obj(&chan("g", "b"), Ix::Same, vec![])];
    file.extend(segment(0, Some(&objs), &[i16s(&y, false), vec![11, 12]].concat()));
    c.extend([11.0, 12.0]);

    let rec = read(&file, &["g/a"], None).unwrap();
    assert_eq!(bits(&rec.channels[0]), bits(&a));
    let rec = read(&file, &["g/b"], None).unwrap();
    assert_eq!(rec.channels[0], as_f64(&b));
    let rec = read(&file, &["g/c"], Some(1.0)).unwrap();
    assert_eq!(rec.channels[0], c);
    // a and b have 16 and 15 values.
    let err = read(&file, &["g/a", "g/b"], None).unwrap_err().to_string();
    assert!(err.contains("\"g/a\" (16 samples) and \"g/b\" (15 samples) differ in length"), "{err}");
}

#[test]
fn interleaved_and_big_endian_segments() {
    let (a0, b0) = (seq_f64(0, 8), seq_i16(0, 8));
    // 1: interleaved, little-endian, two chunks of 4 rows.
    let objs = [
        obj(&chan("g", "a"), Ix::New(10, 4), vec![("wf_increment", Pv::F64(0.5))]),
        obj(&chan("g", "b"), Ix::New(2, 4), vec![]),
    ];
    let mut file = segment(TOC_NEW_OBJ_LIST | TOC_INTERLEAVED, Some(&objs), &rows(&a0, &b0, false));
    // 2: big-endian, contiguous, a new list (the property updated in big-endian too).
    let (a1, b1) = (seq_f64(8, 2), seq_i16(8, 2));
    let objs = [
        obj(&chan("g", "a"), Ix::New(10, 2), vec![("wf_increment", Pv::F64(0.25))]),
        obj(&chan("g", "b"), Ix::New(2, 2), vec![]),
    ];
    let big = TOC_BIG_ENDIAN | TOC_NEW_OBJ_LIST;
    file.extend(segment(big, Some(&objs), &[f64s(&a1, true), i16s(&b1, true)].concat()));
    // 3: big-endian and interleaved, indexes "same as previous".
    let (a2, b2) = (seq_f64(10, 2), seq_i16(10, 2));
    let objs = [obj(&chan("g", "a"), Ix::Same, vec![]), obj(&chan("g", "b"), Ix::Same, vec![])];
    file.extend(segment(TOC_BIG_ENDIAN | TOC_INTERLEAVED, Some(&objs), &rows(&a2, &b2, true)));
    // 4: no metadata: big-endian interleaved again, three chunks.
    let (a3, b3) = (seq_f64(12, 6), seq_i16(12, 6));
    file.extend(segment(TOC_BIG_ENDIAN | TOC_INTERLEAVED, None, &rows(&a3, &b3, true)));

    let rec = read(&file, &["g/a", "g/b"], None).unwrap();
    assert_eq!(bits(&rec.channels[0]), bits(&[a0, a1, a2, a3].concat()));
    assert_eq!(rec.channels[1], as_f64(&[b0, b1, b2, b3].concat()));
    assert_eq!(rec.rate_hz, 4.0);
}

#[test]
fn every_numeric_type() {
    let cases: Vec<(u32, Vec<u8>, Vec<f64>, usize)> = vec![
        (1, vec![0x80, 0x7f, 0xff], vec![-128.0, 127.0, -1.0], 1),
        (2, [i16::MIN, i16::MAX, -2].iter().flat_map(|v| v.to_le_bytes()).collect(), vec![-32768.0, 32767.0, -2.0], 2),
        (
            3,
            [i32::MIN, i32::MAX, -3].iter().flat_map(|v| v.to_le_bytes()).collect(),
            vec![-2147483648.0, 2147483647.0, -3.0],
            4,
        ),
        (
            4,
            [i64::MIN, 1 << 53, -4].iter().flat_map(|v| v.to_le_bytes()).collect(),
            vec![-9.223372036854776e18, 9007199254740992.0, -4.0],
            8,
        ),
        (5, vec![0, 255, 1], vec![0.0, 255.0, 1.0], 1),
        (6, [0u16, u16::MAX, 6].iter().flat_map(|v| v.to_le_bytes()).collect(), vec![0.0, 65535.0, 6.0], 2),
        (7, [0u32, u32::MAX, 7].iter().flat_map(|v| v.to_le_bytes()).collect(), vec![0.0, 4294967295.0, 7.0], 4),
        (
            8,
            [0u64, u64::MAX, 8].iter().flat_map(|v| v.to_le_bytes()).collect(),
            vec![0.0, 1.8446744073709552e19, 8.0],
            8,
        ),
        (
            9,
            [0.1f32, -3.5, 1e30].iter().flat_map(|v| v.to_le_bytes()).collect(),
            vec![f64::from(0.1f32), -3.5, f64::from(1e30f32)],
            4,
        ),
        (
            0x19,
            [0.1f32, -3.5, 2.0].iter().flat_map(|v| v.to_le_bytes()).collect(),
            vec![f64::from(0.1f32), -3.5, 2.0],
            4,
        ),
        (10, f64s(&[0.1, -1e300, 5e-324], false), vec![0.1, -1e300, 5e-324], 8),
        (0x1A, f64s(&[0.1, 2.5, -0.0], false), vec![0.1, 2.5, -0.0], 8),
    ];
    for (code, data, expected, size) in cases {
        assert_eq!(data.len(), 3 * size);
        let objs = [obj(&chan("t", "x"), Ix::New(code, 3), vec![])];
        let file = segment(TOC_NEW_OBJ_LIST, Some(&objs), &data);
        let rec = read(&file, &["t/x"], Some(1.0)).unwrap();
        assert_eq!(bits(&rec.channels[0]), bits(&expected), "type {code:#x}");
        // Big-endian: the same values.
        let data: Vec<u8> = data.chunks(size).flat_map(|c| c.iter().rev().copied().collect::<Vec<_>>()).collect();
        let file = segment(TOC_NEW_OBJ_LIST | TOC_BIG_ENDIAN, Some(&objs), &data);
        let rec = read(&file, &["t/x"], Some(1.0)).unwrap();
        assert_eq!(bits(&rec.channels[0]), bits(&expected), "big-endian type {code:#x}");
    }
}

#[test]
fn other_channels_are_skipped_whatever_their_type() {
    // A string channel (offsets then bytes) and a time stamp channel between two numeric ones.
    let strings = [3u32.to_le_bytes().to_vec(), 5u32.to_le_bytes().to_vec(), b"abcde".to_vec()].concat();
    let objs = [
        obj(&chan("g", "a"), Ix::New(10, 2), vec![]),
        obj(&chan("g", "s"), Ix::Strings(2, strings.len() as u64), vec![]),
        obj(&chan("g", "t"), Ix::New(0x44, 1), vec![]),
        obj(&chan("g", "b"), Ix::New(2, 2), vec![]),
    ];
    let data = [f64s(&[1.5, 2.5], false), strings, vec![0; 16], i16s(&[-7, 8], false)].concat();
    let mut file = segment(TOC_NEW_OBJ_LIST, Some(&objs), &data);
    file.extend(segment(0, None, &data));
    let rec = read(&file, &["g/a", "g/b"], Some(1.0)).unwrap();
    assert_eq!(rec.channels, [vec![1.5, 2.5, 1.5, 2.5], vec![-7.0, 8.0, -7.0, 8.0]]);
    let err = read(&file, &["g/s"], Some(1.0)).unwrap_err().to_string();
    assert!(err.contains("channel \"g/s\" holds string values, not numbers"), "{err}");
    let err = read(&file, &["g/t"], Some(1.0)).unwrap_err().to_string();
    assert!(err.contains("channel \"g/t\" holds time stamp values, not numbers"), "{err}");
}

#[test]
fn units_nan_gaps_and_infinities() {
    let objs = [obj(&chan("g", "a"), Ix::New(10, 3), vec![])];
    let file = segment(TOC_NEW_OBJ_LIST, Some(&objs), &f64s(&[1.0, f64::NAN, -2.0], false));
    let cols = ["g/a".to_string()];
    let rec = read_bytes(&file, "x", &cols, RateUnit::RadPerS, Some(10.0)).unwrap();
    let k = RateUnit::RadPerS.to_dps();
    assert_eq!(rec.channels[0][0], k);
    assert!(rec.channels[0][1].is_nan());
    assert_eq!(rec.channels[0][2], -2.0 * k);
    assert_eq!(rec.info.gaps, 1);
    let file = segment(TOC_NEW_OBJ_LIST, Some(&objs), &f64s(&[1.0, 2.0, f64::INFINITY], false));
    let err = read(&file, &["g/a"], Some(1.0)).unwrap_err().to_string();
    assert_eq!(err, "test.tdms: channel \"g/a\", sample 2: inf is not finite");
}

#[test]
fn rate_from_wf_increment_and_rate() {
    let (a, b) = (seq_f64(0, 3), seq_i16(0, 3));
    let file = first_segment(&a, &b, 0);
    assert_eq!(read(&file, &["g/a"], Some(100.0)).unwrap().rate_hz, 100.0);
    assert_eq!(read(&file, &["g/a"], Some(100.00001)).unwrap().rate_hz, 100.0);
    let err = read(&file, &["g/a"], Some(200.0)).unwrap_err().to_string();
    assert_eq!(err, "test.tdms: channel \"g/a\" has wf_increment 0.01 s (100 Hz), but --rate is 200 Hz");
    assert!(matches!(read(&file, &["g/a"], Some(-1.0)), Err(TdmsError::BadRate(_))));
    // No wf_increment: --rate is needed.
    let objs = [
        obj(&chan("g", "a"), Ix::New(10, 3), vec![]),
        obj(&chan("g", "c"), Ix::New(10, 3), vec![("wf_increment", Pv::F64(0.02))]),
    ];
    let file = segment(TOC_NEW_OBJ_LIST, Some(&objs), &f64s(&[1.0; 6], false));
    let err = read(&file, &["g/a"], None).unwrap_err().to_string();
    assert_eq!(err, "test.tdms: no sample rate: the channels have no wf_increment property; give --rate HZ");
    assert_eq!(read(&file, &["g/a"], Some(7.0)).unwrap().rate_hz, 7.0);
    // One of two channels has it.
    assert_eq!(read(&file, &["g/a", "g/c"], None).unwrap().rate_hz, 50.0);
    // Channels that disagree.
    let objs = [
        obj(&chan("g", "a"), Ix::New(10, 3), vec![("wf_increment", Pv::F64(0.01))]),
        obj(&chan("g", "c"), Ix::New(10, 3), vec![("wf_increment", Pv::F64(0.02))]),
    ];
    let file = segment(TOC_NEW_OBJ_LIST, Some(&objs), &f64s(&[1.0; 6], false));
    let err = read(&file, &["g/a", "g/c"], None).unwrap_err().to_string();
    assert!(err.contains("\"g/a\" (wf_increment 0.01 s) and \"g/c\" (wf_increment 0.02 s)"), "{err}");
    let objs = [obj(&chan("g", "a"), Ix::New(10, 3), vec![("wf_increment", Pv::Str("fast"))])];
    let file = segment(TOC_NEW_OBJ_LIST, Some(&objs), &f64s(&[1.0; 3], false));
    let err = read(&file, &["g/a"], None).unwrap_err().to_string();
    assert!(err.contains("wf_increment \"fast\", which is not a positive number"), "{err}");
}

#[test]
fn missing_channels_list_what_the_file_has() {
    let file = first_segment(&seq_f64(0, 3), &seq_i16(0, 3), 0);
    let err = read(&file, &["g/a", "g/z"], None).unwrap_err().to_string();
    assert_eq!(err, "test.tdms: no channel \"g/z\" (the file has: g/a, g/b)");
    let err = read(&file, &[], None).unwrap_err().to_string();
    assert_eq!(err, "test.tdms: no channel asked for (give --column 'group/channel'; the file has: g/a, g/b)");
}

#[test]
fn object_paths() {
    assert_eq!(parse_path("/"), Some((None, None)));
    assert_eq!(parse_path("/'g'"), Some((Some("g".into()), None)));
    assert_eq!(parse_path("/'it''s'/'a/b'"), Some((Some("it's".into()), Some("a/b".into()))));
    assert_eq!(parse_path("/''/''"), Some((Some(String::new()), Some(String::new()))));
    for bad in ["", "g", "/g", "/'g", "/'g'x", "/'a'/'b'/'c'", "//"] {
        assert_eq!(parse_path(bad), None, "{bad}");
    }
    assert_eq!(object_path(Some("it's")), "/'it''s'");
    // Names with quotes and slashes are found by their plain group/channel.
    let objs = [obj("/'it''s'/'a/b'", Ix::New(10, 1), vec![])];
    let file = segment(TOC_NEW_OBJ_LIST, Some(&objs), &f64s(&[4.0], false));
    assert_eq!(read(&file, &["it's/a/b"], Some(1.0)).unwrap().channels[0], [4.0]);
    // Two channels whose names read the same.
    let objs = [obj("/'x/y'/'z'", Ix::New(10, 1), vec![]), obj("/'x'/'y/z'", Ix::New(10, 1), vec![])];
    let file = segment(TOC_NEW_OBJ_LIST, Some(&objs), &f64s(&[4.0, 5.0], false));
    let err = read(&file, &["x/y/z"], Some(1.0)).unwrap_err().to_string();
    assert!(err.contains("\"x/y/z\" names two channels: /'x/y'/'z' and /'x'/'y/z'"), "{err}");
}

#[test]
fn not_tdms_index_files_and_daqmx() {
    let err = read(b"time,gx\n0,1\n", &["g/a"], None).unwrap_err().to_string();
    assert_eq!(err, "test.tdms: not a TDMS file (it starts with \"time\", not \"TDSm\")");
    let err = read(&[0u8, 1, 2, 250], &["g/a"], None).unwrap_err().to_string();
    assert_eq!(err, "test.tdms: not a TDMS file (it starts with 00 01 02 fa, not \"TDSm\")");
    assert!(read(b"", &["g/a"], None).unwrap_err().to_string().contains("the file is empty"));
    let mut index = first_segment(&[1.0], &[1], 0);
    index[3] = b'h';
    assert!(matches!(read(&index, &["g/a"], None), Err(TdmsError::IndexFile { .. })));
    let objs = [obj(&chan("g", "a"), Ix::Daqmx, vec![])];
    let file = segment(TOC_NEW_OBJ_LIST | TOC_DAQMX_RAW_DATA, Some(&objs), &[0; 8]);
    let err = read(&file, &["g/a"], None).unwrap_err().to_string();
    assert!(err.contains("segment 1): channel \"g/a\" holds DAQmx raw data, which octavar does not read"), "{err}");
}

/// A file of every kind of segment.
fn mixed_file() -> Vec<u8> {
    let mut file = first_segment(&seq_f64(0, 4), &seq_i16(0, 4), TOC_INTERLEAVED);
    file.extend(segment(0, None, &rows(&seq_f64(4, 4), &seq_i16(4, 4), false)));
    let objs =
        [obj(&chan("g", "a"), Ix::Same, vec![("wf_increment", Pv::F64(0.01))]), obj(&chan("g", "b"), Ix::Same, vec![])];
    file.extend(segment(
        TOC_BIG_ENDIAN,
        Some(&objs),
        &[f64s(&seq_f64(8, 4), true), i16s(&seq_i16(8, 4), true)].concat(),
    ));
    file
}

#[test]
fn truncated_files_are_errors_that_locate_the_cut() {
    let file = mixed_file();
    let whole = read(&file, &["g/a", "g/b"], None).unwrap();
    assert_eq!(whole.info.samples, 12);
    let mut boundaries = 0;
    for n in 1..file.len() {
        match read(&file[..n], &["g/a", "g/b"], None) {
            // A cut between segments leaves a shorter file that is whole.
            Ok(rec) => {
                boundaries += 1;
                assert!(rec.info.samples == 4 || rec.info.samples == 8, "{n}");
                assert_eq!(rec.channels[0][..], whole.channels[0][..rec.channels[0].len()]);
            }
            Err(TdmsError::Truncated { segment, offset, .. }) => {
                assert_eq!(offset, n as u64);
                assert!((1..=3).contains(&segment));
            }
            Err(e) => panic!("cut at {n}: {e}"),
        }
    }
    assert_eq!(boundaries, 2);
    let err = read(&file[..file.len() - 3], &["g/a"], None).unwrap_err().to_string();
    assert!(err.contains("(segment 3, which starts at byte"), "{err}");
    assert!(err.contains("the file is truncated: the segment's lead-in says"), "{err}");
}

#[test]
fn damaged_bytes_never_panic() {
    let file = mixed_file();
    for i in 0..file.len() {
        for flip in [0xff, 0x01, 0x80] {
            let mut f = file.clone();
            f[i] ^= flip;
            let _ = read(&f, &["g/a", "g/b"], None);
        }
    }
    // Garbage after a good file: the next "segment" has no tag.
    let mut f = file.clone();
    f.extend([0x55; 40]);
    let err = read(&f, &["g/a"], None).unwrap_err().to_string();
    assert!(
        err.contains(&format!(
            "byte {} (segment 4, which starts at byte {}): corrupt: no segment tag",
            file.len(),
            file.len()
        )),
        "{err}"
    );
}

#[test]
fn inconsistent_sizes_are_corrupt() {
    // Raw data that is not a whole number of chunks.
    let objs = [obj(&chan("g", "a"), Ix::New(10, 2), vec![])];
    let file = segment(TOC_NEW_OBJ_LIST, Some(&objs), &[0; 24]);
    let err = read(&file, &["g/a"], Some(1.0)).unwrap_err().to_string();
    assert!(err.contains("corrupt: 24 bytes of raw data are not a whole number of chunks of 16 bytes"), "{err}");
    // "Same as previous" for an object never seen.
    let objs = [obj(&chan("g", "a"), Ix::Same, vec![])];
    let file = segment(TOC_NEW_OBJ_LIST, Some(&objs), &[0; 16]);
    let err = read(&file, &["g/a"], Some(1.0)).unwrap_err().to_string();
    let want = "byte 44 (segment 1, which starts at byte 0): corrupt: channel \"g/a\" reuses the previous raw \
                data index, but none came before";
    assert!(err.contains(want), "{err}");
    // Raw data and no metadata in the first segment.
    let file = segment(0, None, &[0; 16]);
    assert!(read(&file, &["g/a"], Some(1.0)).unwrap_err().to_string().contains("no earlier segment"));
    // A version that is not TDMS's.
    let mut file = first_segment(&[1.0], &[1], 0);
    file[8] = 0;
    assert!(read(&file, &["g/a"], None).unwrap_err().to_string().contains("is not a TDMS version"));
    // Interleaved channels of different lengths.
    let objs = [obj(&chan("g", "a"), Ix::New(10, 2), vec![]), obj(&chan("g", "b"), Ix::New(10, 1), vec![])];
    let file = segment(TOC_NEW_OBJ_LIST | TOC_INTERLEAVED, Some(&objs), &[0; 24]);
    assert!(read(&file, &["g/a"], Some(1.0))
        .unwrap_err()
        .to_string()
        .contains("interleaved data whose channels differ"));
}

#[test]
fn an_unfinished_last_segment_gives_its_whole_chunks() {
    let (a, b) = (seq_f64(0, 6), seq_i16(0, 6));
    let mut file = first_segment(&a[..2], &b[..2], 0);
    let start = file.len();
    // Two whole chunks of 2 values each, then half of a third; the length was never written.
    let chunk = |i: usize| [f64s(&a[2 * i..2 * i + 2], false), i16s(&b[2 * i..2 * i + 2], false)].concat();
    file.extend(segment(0, None, &[chunk(1), chunk(2)[..10].to_vec()].concat()));
    file[start + 12..start + 20].copy_from_slice(&u64::MAX.to_le_bytes());
    let rec = read(&file, &["g/a", "g/b"], None).unwrap();
    assert_eq!(rec.channels[0], a[..4]);
    assert_eq!(rec.channels[1], as_f64(&b[..4]));
    // Interleaved: the whole rows.
    let mut file = first_segment(&a[..2], &b[..2], TOC_INTERLEAVED);
    let start = file.len();
    file.extend(segment(TOC_INTERLEAVED, None, &rows(&a[2..], &b[2..], false)[..3 * 10 + 4]));
    file[start + 12..start + 20].copy_from_slice(&u64::MAX.to_le_bytes());
    let rec = read(&file, &["g/a", "g/b"], None).unwrap();
    assert_eq!(rec.channels[0], a[..5]);
}

#[test]
fn empty_channels_are_errors() {
    let objs = [obj(&chan("g", "a"), Ix::NoData, vec![])];
    let file = segment(TOC_NEW_OBJ_LIST, Some(&objs), &[]);
    let err = read(&file, &["g/a"], Some(1.0)).unwrap_err().to_string();
    assert_eq!(err, "test.tdms: channel \"g/a\" holds no samples");
}

#[test]
fn reads_a_file_from_disk() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("x.tdms");
    std::fs::write(&path, first_segment(&[1.0, 2.0], &[3, 4], 0)).unwrap();
    let rec = read_tdms(&path, &["g/b".to_string()], RateUnit::DegPerS, None).unwrap();
    assert_eq!(rec.channels[0], [3.0, 4.0]);
    assert_eq!(rec.source, path.display().to_string());
    let err = read_tdms(&dir.path().join("none.tdms"), &[], RateUnit::DegPerS, None).unwrap_err().to_string();
    assert!(err.starts_with("reading ") && err.contains("none.tdms"), "{err}");
}

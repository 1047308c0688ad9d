//! Tests of the CSV reader: units, faults and their places, gaps, filters, dialects, and values against the csv
//! crate's.

use super::*;

fn opts(cols: &[&str]) -> CsvOptions {
    CsvOptions { columns: cols.iter().map(|s| s.to_string()).collect(), rate_hz: Some(10.0), ..Default::default() }
}

#[test]
fn reads_columns_with_units() {
    let text = "a,b\n1,2\n3,4\n";
    let mut o = opts(&["b", "a"]);
    o.unit = RateUnit::parse("deg/h").unwrap();
    let r = read_csv(text.as_bytes(), "f.csv", &o).unwrap();
    assert_eq!(
        r.channels,
        vec![vec![2.0 * (1.0 / 3600.0), 4.0 * (1.0 / 3600.0)], vec![1.0 / 3600.0, 3.0 * (1.0 / 3600.0)]]
    );
    assert_eq!(r.rate_hz, 10.0);
    let o = CsvOptions { unit: RateUnit::MradPerS, ..opts(&["a"]) };
    let r = read_csv("a\n1000\n".as_bytes(), "f.csv", &o).unwrap();
    assert!((r.channels[0][0] - 180.0 / std::f64::consts::PI).abs() < 1e-9);
}

#[test]
fn errors_locate_the_fault() {
    let e = read_csv("a,b\n1,2\n3,x\n".as_bytes(), "f.csv", &opts(&["b"])).unwrap_err();
    assert_eq!(e.to_string(), "f.csv, line 3, column \"b\": \"x\" is not a number");
    let e = read_csv("a,b\n1,2\n".as_bytes(), "f.csv", &opts(&["c"])).unwrap_err();
    assert_eq!(e.to_string(), "f.csv, line 1: no column \"c\" (the header has: a, b; split at ',')");
    let e = read_csv("".as_bytes(), "f.csv", &opts(&["a"])).unwrap_err();
    assert!(matches!(e, RecordingError::Empty { .. }), "{e}");
    let e = read_csv("a,b\n1\n".as_bytes(), "f.csv", &opts(&["b"])).unwrap_err();
    assert!(e.to_string().starts_with("f.csv, line 2:"), "{e}");
    assert!(RateUnit::parse("furlong/fortnight").unwrap_err().to_string().contains("furlong"));
    let e = read_csv("a\n1\n".as_bytes(), "f.csv", &CsvOptions { rate_hz: None, ..opts(&["a"]) }).unwrap_err();
    assert!(matches!(e, RecordingError::NoRate { .. }));
}

#[test]
fn empty_cells_and_time_jumps_are_gaps() {
    let text = "t,g\n0.0,1\n0.1,\n0.2,NaN\n0.5,4\n0.6,5\n";
    let o = CsvOptions { rate_hz: None, time_column: Some("t".into()), ..opts(&["g"]) };
    let r = read_csv(text.as_bytes(), "f.csv", &o).unwrap();
    let g = &r.channels[0];
    assert!((r.rate_hz - 10.0).abs() < 1e-9);
    // 0.2 -> 0.5 is three steps: two samples missing.
    assert_eq!(g.len(), 7);
    assert_eq!(g.iter().filter(|v| v.is_nan()).count(), 4);
    assert_eq!(g[6], 5.0);
    let bad = "t,g\n0.0,1\n0.1,2\n0.1,3\n";
    let e = read_csv(bad.as_bytes(), "f.csv", &o).unwrap_err();
    assert!(e.to_string().contains("line 4") && e.to_string().contains("does not increase"), "{e}");
}

#[test]
fn an_infinite_cell_is_an_error_that_names_its_line_and_column() {
    for cell in ["inf", "-Infinity", "1e999"] {
        let text = format!("g,temp\n1,20\n2,20\n{cell},20\n");
        let e = read_csv(text.as_bytes(), "f.csv", &opts(&["g"])).unwrap_err();
        assert!(matches!(e, RecordingError::NotFinite { line: 4, .. }), "{cell}: {e:?}");
        assert!(e.to_string().contains("column \"g\"") && e.to_string().contains("not a finite number"), "{e}");
    }
    // The temperature column is read by the same rule.
    let text = "g,temp\n1,20\n2,inf\n";
    let o = CsvOptions { temp_column: Some("temp".into()), ..opts(&["g"]) };
    let e = read_csv(text.as_bytes(), "f.csv", &o).unwrap_err();
    assert!(matches!(e, RecordingError::NotFinite { line: 3, .. }), "{e:?}");
}

#[test]
fn filters_and_skipped_rows() {
    let text = "# logger v2\n# units: deg/s\nperiod,g,temp\n0,9,20\n1,1,21\n1,2,22\n2,3,23\n";
    let o = CsvOptions {
        skip_rows: 2,
        filters: vec![RowFilter::parse("period=1").unwrap()],
        temp_column: Some("temp".into()),
        ..opts(&["g"])
    };
    let r = read_csv(text.as_bytes(), "f.csv", &o).unwrap();
    assert_eq!(r.channels[0], vec![1.0, 2.0]);
    assert_eq!(r.temp_c, Some(vec![21.0, 22.0]));
    assert_eq!(r.info.filtered_out, 2);
    let e = read_csv(
        "p,g\n1,2\n".as_bytes(),
        "f.csv",
        &CsvOptions { filters: vec![RowFilter::parse("q=1").unwrap()], ..opts(&["g"]) },
    )
    .unwrap_err();
    assert!(e.to_string().contains("no column \"q\""), "{e}");
    assert!(RowFilter::parse("novalue").is_err());
}

fn read(text: &str, o: &CsvOptions) -> Result<Recording, RecordingError> {
    read_csv(text.as_bytes(), "f.csv", o)
}

#[test]
fn dialects_are_read_right_without_flags() {
    // Semicolons with decimal commas (a European spreadsheet export).
    let r = read("t;rate\n0,001;1,25\n0,002;-3,5e-3\n", &opts(&["rate"])).unwrap();
    assert_eq!(r.channels[0], vec![1.25, -3.5e-3]);
    // Semicolons with points, tabs, whitespace, quoted names.
    assert_eq!(read("t;rate\n1;2.5\n", &opts(&["rate"])).unwrap().channels[0], vec![2.5]);
    assert_eq!(read("t\trate\n1\t2.5\n", &opts(&["rate"])).unwrap().channels[0], vec![2.5]);
    assert_eq!(read("t   rate\n 1   2.5\n2 3\n", &opts(&["rate"])).unwrap().channels[0], vec![2.5, 3.0]);
    assert_eq!(read("t rate\n1 2,5\n", &opts(&["rate"])).unwrap().channels[0], vec![2.5]);
    assert_eq!(read("\"t\",\"rate\"\n1,\"2.5\"\n", &opts(&["rate"])).unwrap().channels[0], vec![2.5]);
    // A byte-order mark before the first name, CRLF line ends.
    let r = read("\u{feff}rate,t\r\n1.5,0\r\n2.5,1\r\n", &opts(&["rate"])).unwrap();
    assert_eq!(r.channels[0], vec![1.5, 2.5]);
}

#[test]
fn a_decimal_comma_in_a_one_column_file_is_an_error_until_it_is_named() {
    // The file that was read as its integer parts, exit 0: now an error naming the line and the likely cause.
    let text = "rate\n1,2881847531554629\n-0,5\n";
    let e = read(text, &opts(&["rate"])).unwrap_err();
    assert!(matches!(e, RecordingError::FieldCount { line: 2, found: 2, expected: 1, .. }), "{e:?}");
    assert!(e.to_string().contains("decimal comma?"), "{e}");
    let o = CsvOptions { decimal_comma: Some(true), ..opts(&["rate"]) };
    assert_eq!(read(text, &o).unwrap().channels[0], vec![1.2881847531554629, -0.5]);
    // Given a comma delimiter explicitly, a decimal comma cannot be told apart: an error, not a guess.
    let o = CsvOptions { decimal_comma: Some(true), delimiter: Some(Delimiter::Byte(b',')), ..opts(&["rate"]) };
    assert!(read(text, &o).unwrap_err().to_string().contains("needs a delimiter other than the comma"));
    // A semicolon file whose cells carry a comma but are read with a point: the cell's error says why.
    let o = CsvOptions { decimal_comma: Some(false), ..opts(&["rate"]) };
    let e = read("t;rate\n1;2,5\n", &o).unwrap_err();
    assert!(e.to_string().contains("line 2") && e.to_string().contains("decimal comma?"), "{e}");
}

#[test]
fn field_counts_and_duplicate_names_are_checked() {
    let e = read("a,b\n1,2\n1,2,3\n", &opts(&["b"])).unwrap_err();
    assert_eq!(e.to_string(), "f.csv, line 3: 3 fields where the header has 2; a decimal comma? give --decimal-comma (and --delimiter for a file with several columns)");
    let e = read("a;b\n1;2;3\n", &opts(&["b"])).unwrap_err();
    assert!(e.to_string().ends_with("give --flexible to read such rows anyway"), "{e}");
    let o = CsvOptions { flexible: true, ..opts(&["b"]) };
    assert_eq!(read("a,b\n1,2,3\n4,5\n", &o).unwrap().channels[0], vec![2.0, 5.0]);
    let e = read("a,b,a\n1,2,3\n", &opts(&["b"])).unwrap_err();
    assert_eq!(e.to_string(), "f.csv, line 1: column \"a\" appears twice in the header (fields 1 and 3)");
    let e = read("a,b\n\"1,2\n", &opts(&["b"])).unwrap_err();
    assert!(e.to_string().contains("line 2") && e.to_string().contains("quoted"), "{e}");
    let e = read("a;b\n1;2\n", &opts(&["c"])).unwrap_err();
    assert!(e.to_string().contains("split at ';'"), "{e}");
}

#[test]
fn faults_far_into_a_file_name_their_line_across_blocks_and_tasks() {
    // Lines beyond the first parallel task (and a blank line to count): the error's line is exact.
    const ROWS: usize = 120_000; // about 1.3 MB: several tasks of 64 KiB or more
    let mut text = String::from("# a logger's banner\ng,t\n");
    for i in 0..ROWS {
        if i == 100 {
            text.push('\n');
        }
        let cell = if i == ROWS - 1000 { "1.5x".to_string() } else { format!("{}.25", i % 7) };
        text.push_str(&format!("{cell},{i}\n"));
    }
    let o = CsvOptions { skip_rows: 1, ..opts(&["g"]) };
    let e = read(&text, &o).unwrap_err();
    // Line 1 the banner, 2 the header, 3.. the rows, one blank line before row 100.
    let want = 3 + (ROWS - 1000) as u64 + 1;
    assert!(matches!(e, RecordingError::NotANumber { line, .. } if line == want), "{e}");
}

/// A byte that is not UTF-8 (a Latin-1 degree sign in a comment column) far into the file: the error names its
/// line, in whichever parallel task it falls.
#[test]
fn a_byte_that_is_not_utf8_names_its_line() {
    const ROWS: usize = 120_000;
    let mut bytes = b"g,note\n".to_vec();
    for i in 0..ROWS {
        bytes.extend_from_slice(format!("{}.5,", i % 9).as_bytes());
        if i == ROWS - 500 {
            bytes.extend_from_slice(b"25 \xb0C");
        }
        bytes.push(b'\n');
    }
    let e = read_csv(&bytes[..], "f.csv", &opts(&["g"])).unwrap_err();
    let want = 2 + (ROWS - 500) as u64;
    assert!(matches!(e, RecordingError::BadRow { line, .. } if line == want), "{e}");
    assert_eq!(e.to_string(), format!("f.csv, line {want}: not valid UTF-8"));
}

#[test]
fn the_values_are_those_of_the_csv_crate() {
    // An independent reader (the csv crate with str::parse) on the same file, with gaps and odd spacing.
    // Lines in many spellings, so that both the plain-row path and the careful one are taken: exponents
    // short and long, 17 and 9 digits, plain decimals, huge and tiny magnitudes, spaces, CRLF, quoted and
    // empty cells.
    let mut text = String::from("time, g ,temp\n");
    let mut s = 7u64;
    for i in 0..20000 {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let g = ((s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0) * 10f64.powi((s % 61) as i32 - 30);
        let cell = match i % 11 {
            _ if i % 997 == 3 => String::new(),
            0 => format!("{g:.17e}"),
            1 => format!("{g}"),
            2 => format!("{g:.9e}"),
            3 => format!(" {g:.6} "),
            4 => format!("\"{g:e}\""),
            5 => format!("{g:+.3E}"),
            6 => format!("{:.25}", g.abs()),
            7 => format!("{g:.30e}"),
            _ => format!("{g:e}"),
        };
        let end = if i % 3 == 0 { "\r\n" } else { "\n" };
        let time = if i % 7 == 0 { format!("\"{i}\"") } else { format!("{}", i as f64 * 0.01) };
        text.push_str(&format!("{time},{cell},{:.4}{end}", 20.0 + g.clamp(-1.0, 1.0)));
    }
    let o = CsvOptions { temp_column: Some("temp".into()), ..opts(&["g"]) };
    let r = read(&text, &o).unwrap();
    let (mut reference, mut temps) = (Vec::new(), Vec::new());
    let mut rdr = csv::ReaderBuilder::new().trim(csv::Trim::All).from_reader(text.as_bytes());
    for rec in rdr.records() {
        let rec = rec.unwrap();
        reference.push(if rec[1].is_empty() { f64::NAN } else { rec[1].parse::<f64>().unwrap() });
        temps.push(rec[2].parse::<f64>().unwrap());
    }
    assert_eq!(r.channels[0].len(), reference.len());
    for (a, b) in r.channels[0].iter().zip(&reference) {
        assert!(a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()), "{a} vs {b}");
    }
    assert_eq!(r.temp_c.as_deref(), Some(&temps[..]));
}

#[test]
fn rows_of_many_blocks_come_out_in_order_and_a_late_fault_names_its_line() {
    // About 2.5 times BLOCK_BYTES, so that blocks are parsed while the one before is handed on: every row arrives
    // once and in file order, and a fault in the third block is reported at its own line with nothing after it.
    let rows = 5 * super::BLOCK_BYTES / 10;
    let mut text = String::with_capacity(rows * 12 + 8);
    text.push_str("i,g\n");
    for i in 0..rows {
        text.push_str(&format!("{i},{}.5\n", i % 10));
    }
    let r = read(&text, &opts(&["i"])).unwrap();
    assert_eq!(r.channels[0].len(), rows);
    assert!(r.channels[0].iter().enumerate().all(|(i, &v)| v == i as f64), "rows out of order");

    let bad = rows - 1234;
    let text = text.replacen(&format!("\n{bad},"), &format!("\n{bad}x,"), 1);
    let mut seen = 0usize;
    let e = read_csv_stream(text.as_bytes(), "f.csv", &CsvOptions { rate_hz: Some(1.0), ..opts(&["i"]) }, |row, _| {
        assert_eq!(row[0], seen as f64);
        seen += 1;
    })
    .unwrap_err();
    assert!(matches!(e, RecordingError::NotANumber { line, .. } if line == bad as u64 + 2), "{e}");
    assert_eq!(seen, bad, "every row before the fault and none after it");
}

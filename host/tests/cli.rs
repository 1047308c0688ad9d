//! The `octavar` command from the outside: exit codes, error messages that locate the fault, pipelines.

mod common;
use common::{octavar, sinusoid_record, stderr, stdout};

#[test]
fn accumulate_rejects_bad_codes_with_the_line() {
    let o = octavar(&["accumulate", "-"], Some(b"100\n101\n1.5\n"));
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("stdin, line 3: \"1.5\" is not an integer code"), "{}", stderr(&o));

    let o = octavar(&["accumulate", "-"], Some(b"100\n65536\n"));
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("line 2") && stderr(&o).contains("outside 0..=65535"), "{}", stderr(&o));

    let o = octavar(&["accumulate", "-"], Some(b""));
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("no samples"), "{}", stderr(&o));

    let o = octavar(&["accumulate", "/nonexistent/codes.txt"], None);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("/nonexistent/codes.txt"), "{}", stderr(&o));
    assert!(!stderr(&o).contains("panicked"));
}

#[test]
fn accumulate_json_has_the_documented_keys_and_reproduces_nbs14() {
    // The NBS-14 10-point set (integers, tau0 = 1 s). Published (NIST SP 1065 p. 107): ADEV(1) = 91.22945,
    // ADEV(2) = 115.8082, OADEV(2) = 85.95287. Stride 1 is ADEV; stride 2 is fully overlapping at m <= 2.
    let data = b"892\n809\n823\n798\n671\n644\n883\n903\n677\n";
    let run = |stride: &str| {
        let o = octavar(&["accumulate", "-", "--json", "--rate", "1", "--stride", stride], Some(data));
        assert!(o.status.success(), "{}", stderr(&o));
        serde_json::from_slice::<serde_json::Value>(&o.stdout).unwrap()
    };
    let adev = run("1");
    let first = &adev["octaves"][0];
    for key in ["m", "tau_s", "n", "sum_sq", "avar", "adev"] {
        assert!(first.get(key).is_some(), "missing {key}");
    }
    // Differences -83 14 -25 -127 -27 239 20 -226: an exact integer sum, printed as a decimal string.
    assert_eq!(first["sum_sq"], "133165");
    assert_eq!(first["n"], 8);
    let close = |v: &serde_json::Value, published: f64| (v.as_f64().unwrap() / published - 1.0).abs() < 1e-6;
    assert!(close(&first["adev"], 91.22945), "{}", first["adev"]);
    assert!(close(&adev["octaves"][1]["adev"], 115.8082), "{}", adev["octaves"][1]["adev"]);
    let oadev = run("2");
    assert!(close(&oadev["octaves"][1]["adev"], 85.95287), "{}", oadev["octaves"][1]["adev"]);
    assert_eq!(oadev["octaves"][1]["n"], 6);
}

#[test]
fn simulate_is_deterministic_and_pipes_into_accumulate() {
    let args = ["simulate", "--sensor", "adxrs300", "--n", "0.046", "--duration", "20s", "--seed", "5", "--codes"];
    let a = octavar(&args, None);
    let b = octavar(&args, None);
    assert!(a.status.success(), "{}", stderr(&a));
    assert_eq!(a.stdout, b.stdout, "same seed, same codes");
    let c = octavar(
        &["simulate", "--sensor", "adxrs300", "--n", "0.046", "--duration", "20s", "--seed", "6", "--codes"],
        None,
    );
    assert_ne!(a.stdout, c.stdout, "another seed, other codes");
    assert_eq!(a.stdout.iter().filter(|&&ch| ch == b'\n').count(), 40_000);

    let acc = octavar(&["accumulate", "-", "--json"], Some(&a.stdout));
    assert!(acc.status.success(), "{}", stderr(&acc));
    let v: serde_json::Value = serde_json::from_slice(&acc.stdout).unwrap();
    // White rate noise: AVAR(m = 1) in codes^2 is the per-sample variance, N^2 rate_hz / (deg/s per code)^2.
    let ch = octavar_shared::sensor::Channel::bench(octavar_shared::sensor::ADXRS300);
    let sigma_codes = 0.046 * 2000f64.sqrt() / ch.dps_per_code();
    let avar0 = v["octaves"][0]["avar"].as_f64().unwrap();
    let expected = sigma_codes * sigma_codes + 1.0 / 12.0; // plus the quantisation's own variance
    assert!((avar0 / expected - 1.0).abs() < 0.05, "avar(m=1) {avar0} vs {expected}");
}

#[test]
fn simulate_rejects_bad_flags_and_models() {
    let o = octavar(&["simulate", "--duration", "ten"], None);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("\"ten\""), "{}", stderr(&o));

    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("model.toml");
    std::fs::write(
        &model,
        "fs_hz = 100.0\n[[channels]]\nsensor = \"adxrs300\"\n[channels.gyro]\nn_deg_per_rt_s = -1.0\n",
    )
    .unwrap();
    let o = octavar(&["simulate", "--model", model.to_str().unwrap(), "--duration", "1s"], None);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(!stderr(&o).contains("panicked"), "{}", stderr(&o));

    std::fs::write(&model, "fs_hz = 100.0\nchannels = [\n").unwrap();
    let o = octavar(&["simulate", "--model", model.to_str().unwrap()], None);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("model.toml"), "{}", stderr(&o));
}

#[test]
fn simulate_writes_temperature_when_the_model_has_it() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("model.toml");
    std::fs::write(
        &model,
        "fs_hz = 10.0\nseed = 1\n[temperature]\nmin_c = 22.0\nmax_c = 25.0\nperiod_s = 60.0\n\
         [[channels]]\nsensor = \"idg1215_y\"\n[channels.gyro]\nn_deg_per_rt_s = 0.003\n\
         temperature = { dps_per_c = 0.05, lag_s = 5.0 }\n",
    )
    .unwrap();
    let out = dir.path().join("sim.csv");
    let o = octavar(
        &["simulate", "--model", model.to_str().unwrap(), "--duration", "60s", "-o", out.to_str().unwrap()],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next().unwrap(), "t_s,idg1215_y_dps,temp_c");
    let temps: Vec<f64> = lines.map(|l| l.split(',').nth(2).unwrap().parse().unwrap()).collect();
    assert_eq!(temps.len(), 600);
    let (lo, hi) = temps.iter().fold((f64::MAX, f64::MIN), |(a, b), &t| (a.min(t), b.max(t)));
    assert!(lo >= 21.99 && hi <= 25.01 && hi - lo > 2.9, "temperature {lo}..{hi}");
}

#[test]
fn analyze_rejects_malformed_csv_naming_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rec.csv");
    let p = path.to_str().unwrap();
    let run = |text: &str, extra: &[&str]| {
        std::fs::write(&path, text).unwrap();
        let mut args = vec!["analyze", p, "--rate", "10"];
        args.extend_from_slice(extra);
        octavar(&args, None)
    };
    // A text cell.
    let mut text = String::from("t,g\n");
    for i in 0..200 {
        text += &format!("{i},{}\n", if i == 57 { "oops".to_string() } else { format!("{}", (i % 7) as f64 * 0.1) });
    }
    let o = run(&text, &["--column", "g"]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(e.contains("rec.csv") && e.contains("line 59") && e.contains("column \"g\"") && e.contains("oops"), "{e}");
    // A missing column.
    let o = run("t,g\n0,1\n1,2\n", &["--column", "gyro"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("rec.csv, line 1: no column \"gyro\""), "{}", stderr(&o));
    // An empty file.
    let o = run("", &["--column", "g"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("rec.csv") && stderr(&o).contains("no samples"), "{}", stderr(&o));
    // A unit octavar does not know.
    let o = run("t,g\n0,1\n", &["--column", "g", "--unit", "furlongs/fortnight"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("unknown unit \"furlongs/fortnight\""), "{}", stderr(&o));
    let o = run("t,g\n0,1\n", &["--column", "g", "--unit", "parsec"]);
    assert!(!stderr(&o).contains("panicked"));
}

#[test]
fn gap_rejects_bad_input_with_located_errors() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rec.csv");
    let p = path.to_str().unwrap();
    std::fs::write(&path, "t,g\n0,1\n1,2\n2,x\n").unwrap();
    let o = octavar(&["gap", p, "--column", "g", "--rate", "1"], None);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("rec.csv, line 4, column \"g\": \"x\" is not a number"), "{}", stderr(&o));
    let o = octavar(&["gap", p, "--column", "q", "--rate", "1"], None);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("no column \"q\""), "{}", stderr(&o));
    std::fs::write(&path, "t,g\n0,1\n1,2\n2,3\n").unwrap();
    let o = octavar(&["gap", p, "--column", "g", "--rate", "1"], None);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("needs at least"), "{}", stderr(&o));
    assert!(!stderr(&o).contains("panicked"));
}

/// A bad `--export` or `--inflate` is refused by analyze and gap before the recording is read (here a file that
/// does not exist), and a bad datasheet names its file, section, key and the dimensions.
#[test]
fn analyze_refuses_bad_exports_before_reading_and_datasheet_faults_are_located() {
    for command in ["analyze", "gap"] {
        let o =
            octavar(&[command, "/no/such/rec.csv", "--column", "g", "--rate", "1", "--export", "rovio=x.yaml"], None);
        assert_eq!(o.status.code(), Some(2), "{command}");
        assert!(stderr(&o).contains("unknown format \"rovio\""), "{command}: {}", stderr(&o));
    }
    let o = octavar(
        &["analyze", "/no/such/rec.csv", "--column", "g", "--rate", "1", "--kalibr", "k.yaml", "--inflate=-1"],
        None,
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--inflate -1: give a positive factor"), "{}", stderr(&o));
    let dir = tempfile::tempdir().unwrap();
    let sheet = dir.path().join("sheet.toml");
    std::fs::write(&sheet, "[accel]\nB = \"0.04 mg/sqrt(Hz)\"\n").unwrap();
    let o = octavar(&["datasheet", sheet.to_str().unwrap()], None);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("sheet.toml: [accel] B:") && stderr(&o).contains("needs m s^-2"), "{}", stderr(&o));
    assert!(!stderr(&o).contains("panicked"));
}

/// `octavar gap --holdout-check predictive` on white noise with a sinusoid: the sinusoid is named, and the JSON
/// has the plain held-out check and the predictive one beside it, each cured by the sinusoid.
#[test]
fn gap_predictive_holdout_check_is_in_the_json() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("rec.csv");
    let json = dir.path().join("gap.json");
    let text = sinusoid_record(3);
    std::fs::write(&csv, text).unwrap();
    let (c, j) = (csv.to_str().unwrap(), json.to_str().unwrap());
    let args =
        ["gap", c, "--column", "g", "--rate", "10", "--seeds", "8", "--holdout-check", "predictive", "--json", j];
    let o = octavar(&args, None);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stdout(&o).contains("against the predictive ensembles"), "{}", stdout(&o));
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["effect"], "sinusoid");
    for key in ["holdout", "holdout_predictive"] {
        let h = &v[key];
        let (b, a) = (h["gap_before"].as_f64().unwrap(), h["gap_after"].as_f64().unwrap());
        assert!(b > 2.5 && a < 0.5 * b, "{key}: {h}");
    }
}

/// A white-noise record of `n` samples written in a dialect: `(header, row)` builders.
fn dialect_file(n: usize, header: &str, row: impl Fn(usize, f64) -> String) -> Vec<u8> {
    let mut s = 12345u64;
    let mut text = String::from(header);
    for i in 0..n {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let g = ((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.1;
        text.push_str(&row(i, g));
    }
    text.into_bytes()
}

/// The analyze JSON's OADEV at m = 1, 2, 4, or the failed run's exit code and stderr.
fn first_oadev(args: &[&str], input: &[u8]) -> Result<f64, (Option<i32>, String)> {
    let dir = tempfile::tempdir().expect("a temp dir");
    let json = dir.path().join("a.json");
    let json_arg = json.display().to_string();
    let mut all = vec!["analyze", "-", "--column", "rate", "--rate", "100", "--stats", "oadev", "--json", &json_arg];
    all.extend_from_slice(args);
    let o = octavar(&all, Some(input));
    if !o.status.success() {
        return Err((o.status.code(), stderr(&o)));
    }
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).expect("the JSON")).expect("JSON");
    let points = &v["channels"][0]["stats"]["oadev"];
    Ok((0..3).map(|k| points[k]["dev"].as_f64().unwrap_or_else(|| panic!("no OADEV in {v}"))).sum())
}

#[test]
fn every_dialect_reads_the_same_numbers_and_a_misread_is_never_exit_0() {
    let n = 2000;
    let reference = first_oadev(&[], &dialect_file(n, "t,rate\n", |i, g| format!("{},{g:.15e}\n", i as f64 / 100.0)))
        .expect("the plain file");
    let dialects: Vec<(&str, Vec<u8>, Vec<&str>)> = vec![
        ("semicolon", dialect_file(n, "t;rate\n", |i, g| format!("{};{g:.15e}\n", i)), vec![]),
        ("tab", dialect_file(n, "t\trate\n", |i, g| format!("{}\t{g:.15e}\n", i)), vec![]),
        ("whitespace", dialect_file(n, "t  rate\n", |i, g| format!("{}  {g:.15e}\n", i)), vec![]),
        (
            "semicolon, decimal comma",
            dialect_file(n, "t;rate\n", |i, g| format!("{i};{}\n", format!("{g:.15e}").replace('.', ","))),
            vec![],
        ),
        (
            "one column, decimal comma, named",
            dialect_file(n, "rate\n", |_, g| format!("{}\n", format!("{g:.15e}").replace('.', ","))),
            vec!["--decimal-comma"],
        ),
        ("BOM and CRLF", dialect_file(n, "\u{feff}t,rate\r\n", |i, g| format!("{i},{g:.15e}\r\n")), vec![]),
        ("forced delimiter", dialect_file(n, "t|rate\n", |i, g| format!("{i}|{g:.15e}\n")), vec!["--delimiter", "|"]),
    ];
    for (name, file, args) in &dialects {
        let got = first_oadev(args, file).unwrap_or_else(|e| panic!("{name}: {e:?}"));
        assert!((got / reference - 1.0).abs() < 1e-12, "{name}: {got} vs {reference}");
    }

    // Faults: exit 2 and a message that names the line; never exit 0 with the wrong numbers.
    let one_col_dc = dialect_file(5, "rate\n", |_, g| format!("{}\n", format!("{g:.15e}").replace('.', ",")));
    let faults: Vec<(&str, Vec<u8>, Vec<&str>, &str)> = vec![
        ("decimal comma unnamed", one_col_dc, vec![], "line 2: 2 fields where the header has 1; a decimal comma?"),
        ("a row too long", b"t,rate\n1,2\n1,2,3\n".to_vec(), vec![], "line 3: 3 fields where the header has 2"),
        ("a row too short", b"t;rate\n1;2\n1\n".to_vec(), vec![], "line 3: 1 fields where the header has 2"),
        ("duplicate column", b"rate,rate\n1,2\n".to_vec(), vec![], "column \"rate\" appears twice"),
        ("unclosed quote", b"t,rate\n1,\"2\n".to_vec(), vec![], "line 2: a quoted cell is not closed"),
        ("bad delimiter flag", b"t,rate\n1,2\n".to_vec(), vec!["--delimiter", "x"], "is not one of"),
    ];
    for (name, file, args, message) in &faults {
        let (code, err) = first_oadev(args, file).expect_err(name);
        assert_eq!(code, Some(2), "{name}: {err}");
        assert!(err.contains(message) && !err.contains("panicked"), "{name}: {err}");
    }
    // --flexible reads the long row's first fields.
    let file = dialect_file(n, "t,rate\n", |i, g| format!("{},{g:.15e},extra\n", i as f64 / 100.0));
    let got = first_oadev(&["--flexible"], &file).expect("flexible");
    assert!((got / reference - 1.0).abs() < 1e-12);
}

#[test]
fn tdms_and_bag_inputs_are_chosen_by_extension_and_their_faults_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    for (name, says) in [("broken.tdms", "broken.tdms"), ("broken.mcap", "broken.mcap")] {
        let path = dir.path().join(name);
        std::fs::write(&path, b"this is not a recording at all").unwrap();
        let p = path.to_str().unwrap();
        for args in [vec!["analyze", p, "--column", "g/c"], vec!["gap", p, "--column", "x"]] {
            let o = octavar(&args, None);
            assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
            assert!(stderr(&o).contains(says) && !stderr(&o).contains("panicked"), "{}", stderr(&o));
        }
    }
    let o = octavar(&["analyze", dir.path().join("x.tdms").to_str().unwrap()], None);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--column 'GROUP/CHANNEL'"), "{}", stderr(&o));
}

#[test]
fn gap_reads_raw_samples() {
    // White noise, N = 0.01 deg/sqrt(s) at 10 Hz, as f64le: the diagnosis runs and finds no gap to explain.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rate.f64");
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut bytes = Vec::new();
    for _ in 0..40_000 {
        // Sum of 12 uniforms - 6: unit variance, near Gaussian.
        let mut s = -6.0;
        for _ in 0..12 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            s += (state >> 11) as f64 / (1u64 << 53) as f64;
        }
        bytes.extend_from_slice(&(0.01 * 10f64.sqrt() * s).to_le_bytes());
    }
    std::fs::write(&path, bytes).unwrap();
    let json = dir.path().join("gap.json");
    let p = path.to_str().unwrap();
    let args = ["gap", p, "--column", "rate", "--format", "f64le", "--rate", "10", "--seeds", "8"];
    let o = octavar(&[&args[..], &["--json", json.to_str().unwrap()]].concat(), None);
    assert!(o.status.success(), "{}", stderr(&o));
    let doc: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    // N from 40000 samples: its 95% interval is about 1.5% wide.
    let n = doc["base_fit"]["N"]["value"].as_f64().expect("N in the report");
    assert!((n / 0.01 - 1.0).abs() < 0.05, "N {n}");
    // Without --rate a raw input is refused by name.
    let o = octavar(&["gap", p, "--column", "rate", "--format", "f64le"], None);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--rate HZ is required"), "{}", stderr(&o));
}

#[test]
fn no_fit_leaves_the_statistics_and_drops_the_fit_in_text_and_json() {
    let input = dialect_file(4000, "rate\n", |_, g| format!("{g:.9e}\n"));
    let dir = tempfile::tempdir().expect("a temp dir");
    let json = dir.path().join("a.json");
    let json_arg = json.display().to_string();
    let args = ["analyze", "-", "--column", "rate", "--rate", "100", "--json", &json_arg];
    let with = octavar(&args, Some(&input));
    assert!(with.status.success(), "{}", stderr(&with));
    assert!(stdout(&with).contains("IEEE 952 fit"), "{}", stdout(&with));
    let fitted: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let without = octavar(&[&args[..], &["--no-fit"]].concat(), Some(&input));
    assert!(without.status.success(), "{}", stderr(&without));
    let text = stdout(&without);
    assert!(!text.contains("IEEE 952 fit") && text.contains("no fit: no fit was asked for"), "{text}");
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    assert_eq!(v["channels"][0]["stats"], fitted["channels"][0]["stats"], "the statistics do not depend on the fit");
    assert!(fitted["channels"][0]["fit"]["N"]["value"].is_f64());
    assert!(v["channels"][0]["fit"]["error"].as_str().is_some_and(|e| e.contains("asked for")), "{v}");
    // A model or a Kalibr file needs the fit: asking for both is a usage error (exit 2), not a silent empty file.
    let model = dir.path().join("m.toml").display().to_string();
    let clash = octavar(&[&args[..], &["--no-fit", "--model-out", &model]].concat(), Some(&input));
    assert_eq!(clash.status.code(), Some(2), "{}", stderr(&clash));
}

/// `--json -` writes the document to stdout instead of the text report, for `analyze` and `gap` as for `decode`:
/// the whole output is one JSON document a pipe can read, and no file named `-` appears.
#[test]
fn json_dash_is_stdout_for_analyze_and_gap() {
    let dir = tempfile::tempdir().unwrap();
    let record = sinusoid_record(3);
    for (args, key) in [
        (vec!["analyze", "-", "--column", "g", "--rate", "10", "--json", "-"], "channels"),
        (vec!["gap", "-", "--column", "g", "--rate", "10", "--seeds", "6", "--json", "-"], "verdict"),
    ] {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_octavar"))
            .args(&args)
            .current_dir(dir.path())
            .stdin(std::process::Stdio::piped())
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .and_then(|mut c| {
                use std::io::Write;
                c.stdin.take().unwrap().write_all(record.as_bytes())?;
                c.wait_with_output()
            })
            .unwrap();
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        let doc: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap_or_else(|e| panic!("{args:?}: {e}"));
        assert!(doc.get(key).is_some(), "{args:?}: no {key} in {doc}");
        assert!(!dir.path().join("-").exists(), "{args:?} wrote a file named -");
    }
}

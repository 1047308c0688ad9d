//! The reports, pinned by snapshots (`tests/snapshots/`): the JSON documents' key sets, which users' scripts read
//! (a key that disappears or is renamed fails here; adding keys is free), and the text reports of `analyze` and
//! `gap` whole, layout and figures, on a fixed record, so what README and the docs quote cannot drift unseen. A
//! change is reviewed into the snapshot (`cargo insta review`, or `INSTA_UPDATE=always` and read the diff) and
//! committed.

mod common;
use common::{octavar, sinusoid_record, stderr};

/// Every key path of `v`, sorted: `a.b` for an object's member, `a[].b` for a member of any element of an array.
fn key_paths(v: &serde_json::Value) -> String {
    fn walk(v: &serde_json::Value, prefix: &str, out: &mut std::collections::BTreeSet<String>) {
        match v {
            serde_json::Value::Object(m) => {
                for (k, child) in m {
                    let path = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
                    out.insert(path.clone());
                    walk(child, &path, out);
                }
            }
            serde_json::Value::Array(items) => {
                for item in items {
                    walk(item, &format!("{prefix}[]"), out);
                }
            }
            _ => {}
        }
    }
    let mut out = std::collections::BTreeSet::new();
    walk(v, "", &mut out);
    out.into_iter().collect::<Vec<_>>().join("\n")
}

/// White noise plus a 50 s sinusoid, 16384 samples at 10 Hz, in one column `g`.
fn record() -> String {
    sinusoid_record(7)
}

/// Run `args` with the record on stdin and `--json FILE` appended; the document.
fn json_of(args: &[&str]) -> serde_json::Value {
    let dir = tempfile::tempdir().expect("a temp dir");
    let json = dir.path().join("out.json");
    let all = [args, &["--json", json.to_str().unwrap()]].concat();
    let o = octavar(&all, Some(record().as_bytes()));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    serde_json::from_str(&std::fs::read_to_string(&json).expect("the JSON")).expect("valid JSON")
}

#[test]
fn analyze_json_keys() {
    let v = json_of(&["analyze", "-", "--column", "g", "--rate", "10"]);
    insta::assert_snapshot!("analyze", key_paths(&v));
}

#[test]
fn gap_json_keys() {
    let v = json_of(&["gap", "-", "--column", "g", "--rate", "10", "--seeds", "8"]);
    insta::assert_snapshot!("gap", key_paths(&v));
}

/// Run `args` with the record on stdin; what it printed, the run's own duration (`diagnosed in 0.2 s`) masked.
fn text_of(args: &[&str]) -> String {
    let o = octavar(args, Some(record().as_bytes()));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).expect("UTF-8");
    text.lines()
        .map(|l| match l.split_once("diagnosed in ") {
            Some((head, tail)) => format!("{head}diagnosed in [time]{}", tail.split_once(" s").map_or("", |(_, r)| r)),
            None => l.to_string(),
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The text reports, whole: their layout and every figure on a fixed record (README and the docs quote them).
#[test]
fn analyze_and_gap_text_reports() {
    insta::assert_snapshot!("analyze_text", text_of(&["analyze", "-", "--column", "g", "--rate", "10"]));
    insta::assert_snapshot!("gap_text", text_of(&["gap", "-", "--column", "g", "--rate", "10", "--seeds", "8"]));
}

//! octavar::stats against the NBS-14 test suite: the published deviations of the 1000-point and 10-point sets
//! (NIST SP 1065, W. J. Riley 2008, pp. 107-108; values as encoded in allantools' tests and copied to
//! `shared/data/reference/nbs14/expected_nbs14.csv`), for every statistic octavar implements, within 1e-6
//! relative (the values carry 7 significant digits).

use std::path::Path;

use octavar::stats::{analyze, DataKind, Options, Statistic, TauSpec};

use crate::util;

/// The NBS-14 1000-point set, generated as published: n[0] = 1234567890, n[i+1] = 16807 n[i] mod (2^31 - 1),
/// y[i] = n[i] / (2^31 - 1).
fn nbs14_1000() -> Vec<f64> {
    let mut n: u64 = 1_234_567_890;
    let mut y = Vec::with_capacity(1000);
    for _ in 0..1000 {
        y.push(n as f64 / 2_147_483_647.0);
        n = n * 16_807 % 2_147_483_647;
    }
    y
}

fn read_values(path: &Path) -> Vec<f64> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(|l| l.split_whitespace().next().unwrap().parse::<f64>().unwrap())
        .collect()
}

fn statistic(name: &str) -> Option<Statistic> {
    Statistic::ALL.into_iter().find(|s| s.name() == name)
}

/// (dataset, statistic, tau_s, expected) for the statistics octavar implements.
fn expected(dir: &Path) -> Vec<(String, Statistic, f64, f64)> {
    let text = std::fs::read_to_string(dir.join("reference/nbs14/expected_nbs14.csv")).unwrap();
    let mut rows = Vec::new();
    for line in text.lines().filter(|l| !l.starts_with('#')).skip(1) {
        let f: Vec<&str> = line.splitn(5, ',').collect();
        if let Some(stat) = statistic(f[1]) {
            rows.push((f[0].to_string(), stat, f[2].parse().unwrap(), f[3].parse().unwrap()));
        }
    }
    rows
}

fn dev_at(data: &[f64], kind: DataKind, stat: Statistic, tau_s: f64) -> (f64, u64) {
    let opts = Options { intervals: false, parallel: false, ..Options::default() };
    let rows = analyze(data, kind, 1.0, stat, &TauSpec::Explicit(vec![tau_s]), &opts).unwrap();
    assert_eq!(rows.len(), 1, "{} at tau {tau_s}", stat.name());
    (rows[0].dev, rows[0].n)
}

#[test]
fn nbs14_generator_matches_the_printed_sequence() {
    let Some(dir) = util::data_dir() else { return };
    let printed = read_values(&dir.join("reference/nbs14/nbs14_1000_freq.txt"));
    let y = nbs14_1000();
    assert_eq!(printed.len(), 1000);
    // Published check values of the generator (NOTES.md): n[1] = 395529916.
    assert_eq!((y[1] * 2_147_483_647.0).round() as u64, 395_529_916);
    for (a, b) in y.iter().zip(&printed) {
        assert!(((a - b) / b).abs() < 1e-15);
    }
}

#[test]
fn nbs14_1000_point_published_values() {
    let Some(dir) = util::data_dir() else { return };
    let y = nbs14_1000();
    let mut checked = 0;
    let mut failures = Vec::new();
    for (set, stat, tau, want) in expected(&dir).into_iter().filter(|r| r.0 == "nbs14_1000") {
        let (got, _) = dev_at(&y, DataKind::Frequency, stat, tau);
        let rel = ((got - want) / want).abs();
        if rel > 1e-6 {
            failures
                .push(format!("{set} {} tau {tau}: got {got:.9e}, published {want:.7e} (rel {rel:.1e})", stat.name()));
        }
        checked += 1;
    }
    // ADEV, OADEV, MDEV, TOTDEV, HDEV, TDEV, OHDEV at tau = 1, 10, 100.
    assert_eq!(checked, 21);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn nbs14_10_point_published_values() {
    let Some(dir) = util::data_dir() else { return };
    let freq = read_values(&dir.join("reference/nbs14/nbs14_10_freq.txt"));
    let phase = read_values(&dir.join("reference/nbs14/nbs14_10_phase.txt"));
    assert_eq!((freq.len(), phase.len()), (9, 10));
    let mut checked = 0;
    let mut failures = Vec::new();
    for (set, stat, tau, want) in expected(&dir).into_iter().filter(|r| r.0 == "nbs14_10") {
        // The same set as frequency (exact) and as the printed phase (5 decimals: 1e-6 still holds).
        for (kind, data) in [(DataKind::Frequency, &freq), (DataKind::Phase, &phase)] {
            let (got, n) = dev_at(data, kind, stat, tau);
            assert_eq!(n as usize, stat.terms(10, tau as usize), "{} tau {tau} terms", stat.name());
            let rel = ((got - want) / want).abs();
            if rel > 1e-6 {
                failures.push(format!(
                    "{set} {kind:?} {} tau {tau}: got {got:.9e}, published {want} (rel {rel:.1e})",
                    stat.name()
                ));
            }
            checked += 1;
        }
    }
    assert_eq!(checked, 28);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

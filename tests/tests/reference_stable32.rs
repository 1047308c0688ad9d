//! octavar::stats against Stable32's result tables (Stable32 1.53/1.60 runs shipped in allantools' test suite,
//! aewallin/allantools @ 599dc9e `tests/`, copied to `shared/data/reference/stable32`; conventions in its
//! NOTES.md): for every statistic octavar implements, on every table of phasedat, ocxo, pink_frequency, gps,
//! Cs5071A and the Keysight TIC floor:
//! - Sigma within 5e-5 relative (Stable32 prints 5 significant digits), `#` exactly (exception: the ocxo octave
//!   tables, computed on another file: see [`SIGMA_FROM_OTHER_FILE`]);
//! - where the table has them (confidence intervals on), Min/Max Sigma within 1e-3 relative:
//!   1. with Stable32's alpha, on every row: Greenhall's EDF (TOTDEV: SP 1065 Table 11) + chi-square quantiles
//!      (one documented exception: TOTDEV with flicker PM, see `check_table`);
//!   2. end to end with octavar's own noise identification, on every row where it finds Stable32's alpha.
//!
//! Noise identification differs from Stable32 on 58 of about 450 rows with intervals, a number each test pins
//! (more fails). Stable32's exact rule is not published; octavar follows Riley & Greenhall (2004) / allantools for
//! the lag-1 autocorrelation (>= 30 points) and NIST SP 1065's B1 / R(n) below that. The differences are:
//! - the B1 fallback with fewer than 30 averages (large m): with 8-20 averages B1 is too noisy to split white FM
//!   from PM, and Stable32 often keeps white FM where B1 says PM or random-walk FM (phasedat m = 64/128, pink
//!   m = 1024/2048, gps m >= 32768, Cs5071A m >= 20000, ocxo m >= 1024, TIC m = 8192/16384);
//! - Cs5071A at m = 10000 (55 decimated points): the lag-1 ACF says white PM, Stable32 white FM;
//! - Cs5071A TOTDEV decade and ocxo TOTDEV: Stable32's TOTDEV alpha column differs from its own OADEV column at
//!   the same m (e.g. Cs5071A m = 10..100: TOTDEV 0, OADEV 1), so that run used another noise setting than the
//!   automatic one; octavar identifies the same alpha for TOTDEV as for OADEV.

use std::io::BufRead;
use std::path::Path;

use octavar::stats::{analyze_series, DataKind, DevPoint, NoiseSpec, Options, Series, Statistic, TauSpec};

use crate::util;

/// One Stable32 row: AF, #, alpha, min, sigma, max.
#[derive(Debug, Clone, Copy)]
struct Row {
    m: u64,
    n: u64,
    alpha: i32,
    min: f64,
    sigma: f64,
    max: f64,
}

fn read_table(path: &Path) -> Vec<Row> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            Row {
                m: f[0].parse().unwrap(),
                n: f[2].parse().unwrap(),
                alpha: f[3].parse().unwrap(),
                min: f[4].parse().unwrap(),
                sigma: f[5].parse().unwrap(),
                max: f[6].parse().unwrap(),
            }
        })
        .collect()
}

/// First number of every non-comment line (plain or gzip).
fn read_column(path: &Path) -> Vec<f64> {
    let input = octavar::io::input::open(path).unwrap();
    let mut v = Vec::new();
    for line in input.reader.lines() {
        let line = line.unwrap();
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        v.push(t.split_whitespace().next().unwrap().parse::<f64>().unwrap());
    }
    v
}

/// Tables whose Sigma column cannot be reproduced from the shipped data file: the ocxo `*_octave.txt` runs were
/// made on "ocxo_frequency.001" (frequency normalised to 1.0, header "Average = 1.000000e+00"), not on the
/// fractional-frequency file the `*_alltau.txt` runs used. They are internally inconsistent: at m = 1 OADEV,
/// MDEV, TOTDEV and ADEV are the same number by definition, yet the OADEV/MDEV/TOTDEV tables print 7.6143e-11 and
/// the ADEV table 7.6106e-11 (allantools compares these tables at 2e-3 for that reason). octavar matches the
/// ADEV table at m = 1 and every all-tau table to 5e-5. For these tables `#` is still checked exactly, Sigma is
/// not, and the interval is checked relative to the sigma it was built on: lo/dev against Min/Sigma and hi/dev
/// against Max/Sigma, within 1e-3.
const SIGMA_FROM_OTHER_FILE: &[&str] = &[
    "ocxo/adev_octave.txt",
    "ocxo/oadev_octave.txt",
    "ocxo/mdev_octave.txt",
    "ocxo/tdev_octave.txt",
    "ocxo/hdev_octave.txt",
    "ocxo/ohdev_octave.txt",
    "ocxo/totdev_octave.txt",
];

/// Outcome of one table.
#[derive(Default)]
struct Report {
    /// Hard failures.
    bad: Vec<String>,
    /// Rows whose identified alpha differs from Stable32's (their end-to-end bounds are not compared).
    alpha_differs: Vec<String>,
}

/// Compare every row of `table` (in `dir`) for `stat`.
fn check_table(series: &Series, dir: &Path, table: &str, stat: Statistic, rep: &mut Report) {
    let rows = read_table(&dir.join(table));
    assert!(!rows.is_empty(), "{table}: no rows");
    let key = format!("{}/{table}", dir.file_name().unwrap().to_string_lossy());
    let other_file = SIGMA_FROM_OTHER_FILE.contains(&key.as_str());
    let tau0 = series.tau0_s();
    let taus = TauSpec::Explicit(rows.iter().map(|r| r.m as f64 * tau0).collect());
    let got: Vec<DevPoint> = analyze_series(series, stat, &taus, &Options::default()).unwrap();
    if got.len() != rows.len() {
        rep.bad.push(format!("{key}: {} rows computed, {} in the table", got.len(), rows.len()));
        return;
    }
    // Relative error of a bound; for the tables of the other file, of the bound relative to its sigma.
    let rel = |mine: f64, dev: f64, theirs: f64, sigma: f64| {
        if other_file {
            ((mine / dev) / (theirs / sigma) - 1.0).abs()
        } else {
            ((mine - theirs) / theirs).abs()
        }
    };
    for (r, g) in rows.iter().zip(&got) {
        let at = format!("{key} {} m={}", stat.name(), r.m);
        assert_eq!(g.m, r.m, "{at}");
        if g.n != r.n {
            rep.bad.push(format!("{at}: # {} vs Stable32 {}", g.n, r.n));
        }
        let rs = ((g.dev - r.sigma) / r.sigma).abs();
        if rs > 5e-5 && !other_file {
            rep.bad.push(format!("{at}: sigma {:.5e} vs {:.4e} (rel {rs:.1e})", g.dev, r.sigma));
        }
        if !(r.min > 0.0 && r.max > 0.0) {
            continue; // an all-tau run with confidence intervals off
        }
        // 1. The EDF + chi-square path with Stable32's own alpha. TOTDEV with flicker PM (alpha 1) is the one
        // case left out: NIST SP 1065 Table 11 gives TOTDEV EDF coefficients only for white, flicker and
        // random-walk FM; octavar then uses the simple OADEV formula of SP 1065 Table 5 (as allantools'
        // edf_totdev), and Stable32 uses something else that octavar cannot reproduce: gps TOTDEV m = 65536
        // (N/m = 3.7) differs by 2e-3/3e-3 at the same alpha.
        if !(stat == Statistic::Totdev && r.alpha == 1) {
            let fixed = Options { noise: NoiseSpec::Fixed(r.alpha), parallel: false, ..Options::default() };
            let one = TauSpec::Explicit(vec![r.m as f64 * tau0]);
            let f = analyze_series(series, stat, &one, &fixed).unwrap()[0];
            let (rlo, rhi) = (rel(f.lo, f.dev, r.min, r.sigma), rel(f.hi, f.dev, r.max, r.sigma));
            if !(rlo <= 1e-3 && rhi <= 1e-3) {
                rep.bad.push(format!(
                    "{at}: EDF path (alpha {} given): min/max {:.5e}/{:.5e} vs {:.4e}/{:.4e} (rel {rlo:.1e}/{rhi:.1e}), edf {:.3}",
                    r.alpha, f.lo, f.hi, r.min, r.max, f.edf
                ));
            }
        }
        // 2. End to end with octavar's own noise identification, where it agrees with Stable32's alpha.
        if g.alpha != r.alpha {
            rep.alpha_differs.push(format!("{at}: alpha {} ({:?}) vs Stable32 {}", g.alpha, g.noise_method, r.alpha));
            continue;
        }
        if stat == Statistic::Totdev && r.alpha == 1 {
            continue; // see 1.
        }
        let (rlo, rhi) = (rel(g.lo, g.dev, r.min, r.sigma), rel(g.hi, g.dev, r.max, r.sigma));
        if !(rlo <= 1e-3 && rhi <= 1e-3) {
            rep.bad.push(format!(
                "{at}: min/max {:.5e}/{:.5e} vs {:.4e}/{:.4e} (rel {rlo:.1e}/{rhi:.1e}); alpha {}, edf {:.2}",
                g.lo, g.hi, r.min, r.max, g.alpha, g.edf
            ));
        }
    }
}

/// Check all `tables`; `max_alpha_differs` is the documented number of rows (with intervals) whose noise type
/// octavar identifies differently from Stable32 (see the module doc of this file's tests and the README of
/// `octavar::stats::noise_id`): more than that fails.
fn run(series: &Series, dir: &Path, tables: &[(&str, Statistic)], max_alpha_differs: usize) {
    let mut rep = Report::default();
    for &(table, stat) in tables {
        check_table(series, dir, table, stat, &mut rep);
    }
    for line in &rep.alpha_differs {
        println!("noise type differs from Stable32 (interval not compared): {line}");
    }
    assert!(rep.bad.is_empty(), "{} mismatches:\n{}", rep.bad.len(), rep.bad.join("\n"));
    assert!(
        rep.alpha_differs.len() <= max_alpha_differs,
        "{} rows with a different noise type (documented: {max_alpha_differs}):\n{}",
        rep.alpha_differs.len(),
        rep.alpha_differs.join("\n")
    );
}

use Statistic::{Adev, Hdev, Mdev, Oadev, Ohdev, Tdev, Totdev};

#[test]
fn stable32_phasedat() {
    let Some(root) = util::data_dir() else { return };
    let dir = root.join("reference/stable32/phasedat");
    let x = read_column(&dir.join("PHASE.DAT"));
    assert_eq!(x.len(), 1001);
    let s = Series::new(&x, DataKind::Phase, 1.0).unwrap();
    run(
        &s,
        &dir,
        &[
            ("phase_dat_adev.txt", Adev),
            ("phase_dat_adev_octave.txt", Adev),
            ("phase_dat_oadev.txt", Oadev),
            ("phase_dat_oadev_octave.txt", Oadev),
            ("phase_dat_mdev.txt", Mdev),
            ("phase_dat_mdev_octave.txt", Mdev),
            ("phase_dat_tdev.txt", Tdev),
            ("phase_dat_tdev_octave.txt", Tdev),
            ("phase_dat_hdev.txt", Hdev),
            ("phase_dat_hdev_octave.txt", Hdev),
            ("phase_dat_ohdev.txt", Ohdev),
            ("phase_dat_ohdev_octave.txt", Ohdev),
            ("phase_dat_totdev.txt", Totdev),
            ("phase_dat_totdev_octave.txt", Totdev),
        ],
        7,
    );
}

#[test]
fn stable32_ocxo() {
    let Some(root) = util::data_dir() else { return };
    let dir = root.join("reference/stable32/ocxo");
    // Hz -> fractional frequency, allantools frequency2fractional(f, mean_frequency=1e7).
    let y: Vec<f64> = read_column(&dir.join("ocxo_frequency.txt")).iter().map(|f| (f - 1e7) / 1e7).collect();
    assert_eq!(y.len(), 19_982);
    let s = Series::new(&y, DataKind::Frequency, 1.0).unwrap();
    run(
        &s,
        &dir,
        &[
            ("adev_octave.txt", Adev),
            ("oadev_octave.txt", Oadev),
            ("mdev_octave.txt", Mdev),
            ("tdev_octave.txt", Tdev),
            ("hdev_octave.txt", Hdev),
            ("ohdev_octave.txt", Ohdev),
            ("totdev_octave.txt", Totdev),
            ("stable32_adev_alltau.txt", Adev),
            ("stable32_oadev_alltau.txt", Oadev),
            ("stable32_mdev_alltau.txt", Mdev),
            ("stable32_tdev_alltau.txt", Tdev),
            ("stable32_hdev_alltau.txt", Hdev),
            ("stable32_ohdev_alltau.txt", Ohdev),
            ("stable32_totdev_alltau.txt", Totdev),
        ],
        14,
    );
}

#[test]
fn stable32_pink_frequency() {
    let Some(root) = util::data_dir() else { return };
    let dir = root.join("reference/stable32/pink_frequency");
    let y = read_column(&dir.join("pink_frequency.txt"));
    assert_eq!(y.len(), 10_000);
    // The all-tau tables were run with tau0 = 42 s, the octave OADEV table with tau0 = 1 s (NOTES.md).
    let s42 = Series::new(&y, DataKind::Frequency, 42.0).unwrap();
    run(
        &s42,
        &dir,
        &[
            ("adev.txt", Adev),
            ("oadev.txt", Oadev),
            ("mdev.txt", Mdev),
            ("tdev.txt", Tdev),
            ("hdev.txt", Hdev),
            ("ohdev.txt", Ohdev),
            ("totdev_alpha0.txt", Totdev),
        ],
        0,
    );
    let s1 = Series::new(&y, DataKind::Frequency, 1.0).unwrap();
    run(&s1, &dir, &[("s32_oadev_octave.txt", Oadev)], 2);
}

#[test]
fn stable32_gps() {
    let Some(root) = util::data_dir() else { return };
    let dir = root.join("reference/stable32/gps");
    let x = read_column(&dir.join("gps_1pps_phase_data.txt.gz"));
    assert_eq!(x.len(), 241_218);
    let s = Series::new(&x, DataKind::Phase, 1.0).unwrap();
    run(
        &s,
        &dir,
        &[
            ("stable32_ADEV_decade.txt", Adev),
            ("stable32_OADEV_octave.txt", Oadev),
            ("stable32_MDEV_octave.txt", Mdev),
            ("stable32_TDEV_octave.txt", Tdev),
            ("stable32_HDEV_octave.txt", Hdev),
            ("stable32_OHDEV_octave.txt", Ohdev),
            ("stable32_TOTDEV_octave.txt", Totdev),
        ],
        3,
    );
}

#[test]
fn stable32_cs5071a() {
    let Some(root) = util::data_dir() else { return };
    let dir = root.join("reference/stable32/Cs5071A");
    let x = read_column(&dir.join("5071A_phase.txt.gz"));
    assert_eq!(x.len(), 556_990);
    let s = Series::new(&x, DataKind::Phase, 1.0).unwrap();
    run(
        &s,
        &dir,
        &[
            ("adev_decade.txt", Adev),
            ("oadev_decade.txt", Oadev),
            ("mdev_decade.txt", Mdev),
            ("tdev_decade.txt", Tdev),
            ("hdev_decade.txt", Hdev),
            ("ohdev_decade.txt", Ohdev),
            ("totdev_decade.txt", Totdev),
            ("adev_all.txt", Adev),
            ("oadev_all.txt", Oadev),
            ("mdev_all.txt", Mdev),
            ("tdev_all.txt", Tdev),
            ("hdev_all.txt", Hdev),
            ("ohdev_all.txt", Ohdev),
            ("totdev_all.txt", Totdev),
        ],
        29,
    );
}

#[test]
fn stable32_keysight_tic() {
    let Some(root) = util::data_dir() else { return };
    let dir = root.join("reference/stable32/Keysight53230A_ti_noise_floor");
    let x = read_column(&dir.join("tic_phase.txt"));
    assert_eq!(x.len(), 55_688);
    let s = Series::new(&x, DataKind::Phase, 1.0).unwrap();
    run(
        &s,
        &dir,
        &[
            ("tic_adev.txt", Adev),
            ("tic_oadev.txt", Oadev),
            ("tic_mdev.txt", Mdev),
            ("tic_tdev.txt", Tdev),
            ("tic_hdev.txt", Hdev),
            ("tic_ohdev.txt", Ohdev),
            ("tic_totdev.txt", Totdev),
        ],
        3,
    );
}

//! The gap diagnosis on real recordings (issue 5, Deliver 3).
//!
//! CATS tag, motionless, temperature cycled 5-20 degC (../shared/data/README.md): run 1 (`period=1`) trains, run 2
//! (`period=2`) is held out; 1 Hz, gyro in mrad/s, `temp_C`. gyro_y follows the temperature (about +0.45 mrad/s per
//! degC): the diagnosis must name `temperature`, and the gap it locates must shrink on run 2 with every parameter
//! frozen from run 1. gyro_x hardly follows the temperature: it must not come out as `temperature`. gyro_z is
//! reported (it follows weakly, and run 2 has the tag turned, gravity on x). Run 2 also trains with run 1 held
//! out: its 70 s disturbance must be found, reported and masked. The ADIS16405 session (1,000,000 samples at 100
//! Hz, half held out) runs where CI is set: x and y `bandwidth`, z `resonance` near 20 Hz. Its time against the
//! floor (30 s a million samples) is measured by the benchmark `cargo bench -p octavar --bench gap`, not here.

use std::path::Path;
use std::time::Instant;

use octavar::gap::transients::Part;
use octavar::gap::{diagnose, Effect, GapInput, GapOptions, GapReport, HoldoutCheck};
use octavar::io::csv::{read_csv, CsvOptions, RowFilter};
use octavar::io::recording::RateUnit;

use crate::util::data_dir;

fn read(
    path: &Path,
    column: &str,
    unit: RateUnit,
    rate: f64,
    temp: Option<&str>,
    filter: Option<&str>,
) -> (Vec<f64>, Option<Vec<f64>>) {
    let input = octavar::io::input::open(path).expect("open recording");
    let opts = CsvOptions {
        columns: vec![column.to_string()],
        temp_column: temp.map(str::to_string),
        rate_hz: Some(rate),
        unit,
        filters: filter.map(|f| vec![RowFilter::parse(f).unwrap()]).unwrap_or_default(),
        ..Default::default()
    };
    let mut rec = read_csv(input.reader, &input.name, &opts).expect("read recording");
    (rec.channels.remove(0), rec.temp_c.take())
}

/// The CATS diagnosis of one gyro axis: run 1 trains and run 2 is held out, or the other way round.
fn cats_runs(dir: &Path, axis: &str, train: u32, hold: u32) -> GapReport {
    cats_runs_checked(dir, axis, train, hold, HoldoutCheck::Plain)
}

/// As [`cats_runs`], with the holdout judged by `check`.
fn cats_runs_checked(dir: &Path, axis: &str, train: u32, hold: u32, check: HoldoutCheck) -> GapReport {
    let path = dir.join("imu/cats_temperature_p12.csv.gz");
    let col = format!("gyro_{axis}_mrads");
    let run = |k: u32| read(&path, &col, RateUnit::MradPerS, 1.0, Some("temp_C"), Some(&format!("period={k}")));
    let ((x1, t1), (x2, t2)) = (run(train), run(hold));
    let input = GapInput::joined(x1, t1, x2, t2, 1.0).unwrap();
    let t0 = Instant::now();
    let r = diagnose(&input, &GapOptions { holdout_check: check, ..Default::default() }, &|_, _, _| {}).unwrap();
    println!("== CATS gyro_{axis}, run {train} trains ({:.1} s)\n{}", t0.elapsed().as_secs_f64(), r.text());
    r
}

/// Run 1 trains, run 2 is held out.
fn cats(dir: &Path, axis: &str) -> GapReport {
    cats_runs(dir, axis, 1, 2)
}

/// Run 2 trains (it holds a disturbance of about 70 s, steps up to 200 mrad/s, starting 2021-09-21T23:16:16:
/// 45373 s into the run) and run 1 is held out. Left in, the disturbance makes the distribution view's gap
/// thousands and the answer `outliers`; found and masked, the answer is the temperature coupling, and it holds on
/// run 1.
#[test]
fn cats_run_2_trains_its_disturbance_is_masked_and_the_coupling_holds_on_run_1() {
    let Some(dir) = data_dir() else { return };
    let r = cats_runs(&dir, "y", 2, 1);
    assert_eq!(r.effect(), Some(Effect::Temperature), "{}", r.text());
    let t: Vec<_> = r.input.transients.iter().filter(|t| t.part == Part::Training).collect();
    assert_eq!(t.len(), 1, "{:?}", r.input.transients);
    assert!((t[0].start_s - 45373.0).abs() < 60.0 && (30.0..150.0).contains(&t[0].duration_s), "{:?}", t[0]);
    // Steps up to 200 mrad/s: 11.5 deg/s; the peak is taken from the local baseline.
    assert!(t[0].peak_dps > 3.0, "{:?}", t[0]);
    assert!(r.text().lines().next().unwrap().contains("1 transient masked"), "{}", r.text());
    let h = r.holdout.first.unwrap();
    println!(
        "CATS gyro_y, run 2 trains: held-out gap {:.2} -> {:.2}, shrink {:.3}",
        h.gap_before, h.gap_after, h.shrink
    );
    assert!(h.shrink >= 0.6, "{h:?}");
    let j = r.to_json();
    let tj = &j["transients"][0];
    for k in ["part", "start_s", "duration_s", "peak_dps"] {
        assert!(!tj[k].is_null(), "transients[0].{k}");
    }
    assert_eq!(tj["part"], "training");
}

#[test]
fn cats_gyro_y_is_temperature_and_the_fix_holds_on_run_2() {
    let Some(dir) = data_dir() else { return };
    let r = cats(&dir, "y");
    assert_eq!(r.effect(), Some(Effect::Temperature), "{}", r.text());
    assert!(r.base.significant);
    let loc = r.base.location.as_ref().unwrap();
    // The temperature correlation (or the long-tau Allan deviation) is where the gap lies, above 10 s.
    assert!(loc.band_s[1] > 10.0, "{loc:?}");
    let c = r.chosen().unwrap().fit.as_ref().unwrap().gyro.temperature.unwrap();
    // The README's +0.45 mrad/s per degC is 0.0258 deg/s per degC.
    let k_mrad = c.dps_per_c / (0.18 / std::f64::consts::PI);
    assert!((0.3..0.6).contains(&k_mrad), "coupling {k_mrad} mrad/s/degC");
    assert!(r.training.shrink > 0.7, "{:?}", r.training);
    let h = r.holdout.first.unwrap();
    println!("CATS gyro_y held-out: gap {:.2} -> {:.2}, shrink {:.3}", h.gap_before, h.gap_after, h.shrink);
    assert!(h.shrink > 0.7, "{h:?}");
    // Judged against the predictive ensembles (the fitted parameters' uncertainty carried into the simulation),
    // the fix holds as well.
    let p = cats_runs_checked(&dir, "y", 1, 2, HoldoutCheck::Predictive);
    assert_eq!(p.effect(), Some(Effect::Temperature), "{}", p.text());
    let hp = p.holdout.predictive.expect("the predictive check");
    println!(
        "CATS gyro_y held-out, predictive: gap {:.2} -> {:.2}, shrink {:.3}",
        hp.gap_before, hp.gap_after, hp.shrink
    );
    assert!(hp.shrink > 0.7, "{hp:?}");
    // The JSON has the documented keys.
    let j = r.to_json();
    for k in [
        "effects",
        "holdout_total",
        "transients",
        "verdict",
        "effect",
        "view",
        "band_s",
        "sign",
        "gap_before",
        "gap_after",
        "shrink",
        "holdout",
        "candidates",
        "model",
        "effect_params",
    ] {
        assert!(j.get(k).is_some(), "missing {k}");
    }
    assert_eq!(j["effect"], "temperature");
    assert_eq!(j["candidates"].as_array().unwrap().len(), Effect::ALL.len());
    for k in ["gap_before", "gap_after", "shrink", "shrink_if_right"] {
        assert!(j["holdout"][k].is_number(), "holdout.{k}");
    }
    let before = j["holdout"]["gap_before"].as_f64().unwrap();
    assert!((j["holdout"]["shrink_if_right"].as_f64().unwrap() - (1.0 - 1.0 / before)).abs() < 1e-12);
    assert!(j["model"]["temperature"]["dps_per_c"].is_number());
}

/// The CATS gyro_y holdout judged against the predictive ensembles (the fitted parameters' uncertainty carried
/// into the simulation): the fix holds as well. A study (30 s more than the plain check):
/// `cargo test -p octavar-tests --test octavar-tests gap_real::cats_gyro_y_predictive -- --ignored --nocapture`.
#[test]
#[ignore = "a study: 30 s; docs/gap.md quotes it"]
fn cats_gyro_y_predictive() {
    let Some(dir) = data_dir() else { return };
    let p = cats_runs_checked(&dir, "y", 1, 2, HoldoutCheck::Predictive);
    assert_eq!(p.effect(), Some(Effect::Temperature), "{}", p.text());
    let h = p.holdout.predictive.expect("the predictive check");
    println!("CATS gyro_y held-out, predictive: gap {:.2} -> {:.2}, shrink {:.3}", h.gap_before, h.gap_after, h.shrink);
    assert!(h.shrink > 0.7, "{h:?}");
}

#[test]
fn cats_gyro_x_and_z_are_reported() {
    let Some(dir) = data_dir() else { return };
    let x = cats(&dir, "x");
    // gyro_x hardly follows the temperature.
    assert_ne!(x.effect(), Some(Effect::Temperature), "{}", x.text());
    let z = cats(&dir, "z");
    println!(
        "CATS gyro_x: {} (gap {:.2}); gyro_z: {} (gap {:.2}, holdout {:?})",
        x.effect_name(),
        x.training.gap_before,
        z.effect_name(),
        z.training.gap_before,
        z.holdout
    );
}

/// The ADIS16405 session, half held out, each gyro axis (CI only: 1,000,000 samples x 3 axes, 10-30 s in release):
/// x and y show the part's internal filter (`bandwidth`, about 30 Hz); z a spectral bump at 19-21 Hz with ten times
/// the power around it, a resonance, wider than a line.
#[test]
fn adis16405_session_is_diagnosed() {
    if std::env::var_os("CI").is_none() {
        println!("skipped: the ADIS16405 diagnosis runs where CI is set (1,000,000 samples x 3 axes)");
        return;
    }
    let Some(dir) = data_dir() else { return };
    let path = dir.join("imu/adis16405_session1.csv.gz");
    for axis in ["x", "y", "z"] {
        let (x, _) = read(&path, &format!("gyro_{axis}_dps"), RateUnit::DegPerS, 100.0, None, None);
        assert_eq!(x.len(), 1_000_000);
        let input = GapInput::split(x, None, 100.0, 0.5).unwrap();
        let t0 = Instant::now();
        let r = diagnose(&input, &GapOptions::default(), &|_, _, _| {}).unwrap();
        let secs = t0.elapsed().as_secs_f64();
        println!("== ADIS16405 gyro_{axis} ({secs:.1} s)\n{}", r.text());
        if axis == "z" {
            assert_eq!(r.effect(), Some(Effect::Resonance), "{}", r.text());
            let f = r.chain.steps[0].fit.gyro.resonance.expect("a resonance in the model");
            assert!((18.0..23.0).contains(&f.freq_hz), "{f:?}");
            // Wider than a line: a quality factor of tens, not thousands.
            assert!(f.q < 100.0, "{f:?}");
        } else {
            assert_eq!(r.effect(), Some(Effect::Bandwidth), "{}", r.text());
            let h = r.holdout.total.unwrap();
            assert!(h.gap_after < 2.5, "{h:?}");
        }
    }
}

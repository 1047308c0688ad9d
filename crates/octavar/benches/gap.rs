//! The gap diagnosis's floor (issue 5): `octavar gap` on a 1-million-sample recording in at most 30 s on two
//! cores. One timed run per record (criterion's repeated sampling would take minutes): the three axes of the
//! ADIS16405 session (1,000,000 samples at 100 Hz) from `OCTAVAR_DATA` (default `../shared/data`) where it is, and
//! in any case a simulated million-sample record (white noise, flicker and a 30 Hz output bandwidth at 100 Hz).
//! Each is timed with the plain held-out check (the floor) and with `--holdout-check predictive` (reported).
//! `cargo bench -p octavar --bench gap`.

use std::path::PathBuf;
use std::time::Instant;

use octavar::analyze::fine_channel;
use octavar::gap::{diagnose, ensemble, GapInput, GapOptions, HoldoutCheck};
use octavar::io::csv::{read_csv, CsvOptions};
use octavar::io::recording::RateUnit;
use octavar_shared::sim::GyroSim;

/// The floor, s per million samples.
const FLOOR_S: f64 = 30.0;

fn time(name: &str, x: &[f64], rate_hz: f64) -> f64 {
    let mut plain = f64::NAN;
    for check in [HoldoutCheck::Plain, HoldoutCheck::Predictive] {
        let input = GapInput::split(x.to_vec(), None, rate_hz, 0.5).expect("a valid split");
        let t0 = Instant::now();
        let r = diagnose(&input, &GapOptions { holdout_check: check, ..Default::default() }, &|_, _, _| {})
            .expect("the diagnosis runs");
        let secs = t0.elapsed().as_secs_f64();
        let chain: Vec<&str> = r.effects().into_iter().map(|e| e.name()).collect();
        let named = if chain.is_empty() { "none".to_string() } else { chain.join(" + ") };
        println!("  {name:<18} {:>10}: {secs:>5.1} s ({} samples): {named}", check.name(), x.len());
        if check == HoldoutCheck::Plain {
            plain = secs;
        }
    }
    plain
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return; // `cargo test --benches` asks for a list
    }
    println!(
        "octavar gap on a million samples ({} threads; floor {FLOOR_S} s, plain check):",
        rayon::current_num_threads()
    );
    let mut worst: f64 = 0.0;
    let data = std::env::var_os("OCTAVAR_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"));
    let adis = data.join("imu/adis16405_session1.csv.gz");
    if adis.is_file() {
        for axis in ["x", "y", "z"] {
            let input = octavar::io::input::open(&adis).expect("open the ADIS session");
            let opts = CsvOptions {
                columns: vec![format!("gyro_{axis}_dps")],
                rate_hz: Some(100.0),
                unit: RateUnit::DegPerS,
                ..Default::default()
            };
            let mut rec = read_csv(input.reader, &input.name, &opts).expect("read the ADIS session");
            worst = worst.max(time(&format!("ADIS16405 gyro_{axis}"), &rec.channels.remove(0), 100.0));
        }
    } else {
        println!("  skipped: the ADIS16405 session is not at {} (set OCTAVAR_DATA)", adis.display());
    }
    let model = GyroSim { n_deg_per_rt_s: 0.01, b_dps: 0.003, bandwidth_hz: Some(30.0), ..Default::default() };
    let x = ensemble::one_record(&model, &fine_channel(1.0), 100.0, 1_000_000, None, 5).expect("a valid model");
    worst = worst.max(time("simulated", &x, 100.0));
    assert!(worst <= FLOOR_S, "octavar gap took {worst:.1} s on a million samples (floor {FLOOR_S} s)");
}

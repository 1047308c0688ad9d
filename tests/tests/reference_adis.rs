//! A real MEMS IMU against published values: the ADIS16405 session 1 (100 Hz, 1e6 samples) gyro channels,
//! octavar's overlapping Allan variance against the maximal-overlap values published with the R package avar,
//! m = 2 .. 262144, within 1e-5 relative (avar's estimator omits one term of N - 2m + 1; the difference is at
//! most 6e-6 here, see the data folder's notes).

use octavar::io::csv::{read_csv, CsvOptions};
use octavar::stats::{deviation_at, DataKind, Series, Statistic};

use crate::util;

#[test]
fn adis16405_gyro_oadev_matches_the_published_maximal_overlap_avar() {
    let Some(dir) = util::data_dir() else { return };
    let imu = dir.join("imu");
    let input = octavar::io::input::open(&imu.join("adis16405_session1.csv.gz")).unwrap();
    let channels = ["gyro_x_dps", "gyro_y_dps", "gyro_z_dps"];
    let opts = CsvOptions {
        columns: channels.iter().map(|c| c.to_string()).collect(),
        rate_hz: Some(100.0),
        ..Default::default()
    };
    let rec = read_csv(input.reader, &input.name, &opts).unwrap();
    assert_eq!(rec.channels[0].len(), 1_000_000);
    let expected = std::fs::read_to_string(imu.join("adis16405_session1_expected_avar.csv")).unwrap();
    let mut checked = 0;
    for (name, data) in channels.iter().zip(&rec.channels) {
        let series = Series::new(data, DataKind::Frequency, 0.01).unwrap();
        for line in expected.lines().filter(|l| l.starts_with(&format!("{name},"))) {
            let f: Vec<&str> = line.split(',').collect();
            let m: usize = f[1].parse().unwrap();
            let published: f64 = f[3].parse().unwrap();
            let ours = deviation_at(&series, Statistic::Oadev, m).unwrap().dev.powi(2);
            let rel = (ours / published - 1.0).abs();
            assert!(rel < 1e-5, "{name} m={m}: {ours} vs published {published} (rel {rel:.2e})");
            checked += 1;
        }
    }
    assert_eq!(checked, 3 * 18, "every gyro row of the published table");
}

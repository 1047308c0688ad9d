//! The exports against values worked out by hand from each format's documented convention, and the number
//! formats their loaders need.

use super::*;
use crate::analyze::{analyze_channel, AnalyzeOptions, ChannelAnalysis};
use crate::quantity::Quantity;

/// A fitted gyro axis (white noise of N deg/sqrt(s) plus a random walk of K) and an accelerometer axis.
fn channels() -> Vec<ChannelAnalysis> {
    let rate: f64 = 100.0;
    let n = 400_000;
    let w = crate::test_signals::white(n, 21);
    let v = crate::test_signals::white(n, 22);
    let mut walk = 0.0;
    let gyro: Vec<f64> = (0..n)
        .map(|i| {
            walk += 2e-4 / rate.sqrt() * v[i];
            0.01 * rate.sqrt() * w[i] + walk
        })
        .collect();
    let u = crate::test_signals::white(n, 23);
    let accel: Vec<f64> = (0..n).map(|i| 9.81 + 0.002 * rate.sqrt() * u[i]).collect();
    let opts = AnalyzeOptions::default();
    vec![
        analyze_channel("gz", &gyro, rate, &opts).unwrap(),
        analyze_channel("az", &accel, rate, &opts).unwrap().with_quantity(Quantity::Acceleration),
    ]
}

/// The number after `key:` (or `key =`) on its line.
fn value(text: &str, key: &str) -> f64 {
    let line = text.lines().find(|l| l.trim_start().starts_with(key)).unwrap_or_else(|| panic!("no {key} in\n{text}"));
    let rest = line.trim_start()[key.len()..].trim_start_matches([':', ' ', '=']);
    rest.split(['#', ' ', ';', ',']).next().unwrap().trim().parse().unwrap_or_else(|e| panic!("{line}: {e}"))
}

#[test]
fn kalibr_vins_and_orbslam3_follow_their_documented_conventions() {
    let ch = channels();
    let (g, a) = (ch[0].fit.as_ref().unwrap(), ch[1].fit.as_ref().unwrap());
    let d2r = std::f64::consts::PI / 180.0;
    // By hand: continuous densities in SI. N deg/sqrt(s) -> rad/s/sqrt(Hz) is x pi/180; K deg/s/sqrt(s) ->
    // rad/s^2/sqrt(Hz) is x pi/180; the accelerometer's are already SI.
    let gn = g.n.value.unwrap() * d2r;
    let gk = g.k.value.expect("the gyro's random walk is identifiable") * d2r;
    let an = a.n.value.unwrap();
    let noise = ImuNoise::from_channels(&ch, "test", 100.0, "/imu0", 1.0);
    let close = |got: f64, want: f64, what: &str| assert!((got / want - 1.0).abs() < 1e-6, "{what}: {got} vs {want}");

    let k = ExportFormat::Kalibr.render(&noise);
    close(value(&k, "gyroscope_noise_density"), gn, "kalibr gyro density");
    close(value(&k, "gyroscope_random_walk"), gk, "kalibr gyro walk");
    close(value(&k, "accelerometer_noise_density"), an, "kalibr accel density");
    assert_eq!(value(&k, "update_rate"), 100.0);
    assert!(k.contains("rostopic: /imu0"));

    let v = ExportFormat::Vins.render(&noise);
    assert!(v.starts_with("%YAML:1.0\n"), "OpenCV's directive first");
    close(value(&v, "gyr_n"), gn, "vins gyr_n");
    close(value(&v, "gyr_w"), gk, "vins gyr_w");
    close(value(&v, "acc_n"), an, "vins acc_n");

    let o = ExportFormat::OrbSlam3.render(&noise);
    close(value(&o, "IMU.NoiseGyro"), gn, "orbslam3 NoiseGyro");
    close(value(&o, "IMU.GyroWalk"), gk, "orbslam3 GyroWalk");
    close(value(&o, "IMU.NoiseAcc"), an, "orbslam3 NoiseAcc");
    assert_eq!(value(&o, "IMU.Frequency"), 100.0);

    // The inflation is explicit: every noise figure times X, and said so.
    let inflated = ImuNoise::from_channels(&ch, "test", 100.0, "/imu0", 10.0);
    let k10 = ExportFormat::Kalibr.render(&inflated);
    close(value(&k10, "gyroscope_noise_density"), 10.0 * gn, "inflated");
    assert!(k10.contains("multiplied by 10 (--inflate)"));
}

#[test]
fn gz_and_kfgins_write_per_sample_and_gauss_markov_figures() {
    let ch = channels();
    let g = ch[0].fit.as_ref().unwrap();
    let d2r = std::f64::consts::PI / 180.0;
    let noise = ImuNoise::from_channels(&ch, "test", 100.0, "/imu0", 1.0);
    // gz: per-sample deviation = density x sqrt(rate).
    let z = ExportFormat::Gz.render(&noise);
    let stddev: f64 = z.split("<stddev>").nth(1).unwrap().split('<').next().unwrap().parse().unwrap();
    assert!((stddev / (g.n.value.unwrap() * d2r * 10.0) - 1.0).abs() < 1e-6, "{stddev}");
    // KF-GINS: arw in deg/sqrt(h) = N deg/sqrt(s) x 60.
    let k = ExportFormat::KfGins.render(&noise);
    let arw = k.lines().find(|l| l.trim_start().starts_with("arw:")).unwrap();
    let first: f64 = arw.split('[').nth(1).unwrap().split(',').next().unwrap().parse().unwrap();
    assert!((first / (g.n.value.unwrap() * 60.0) - 1.0).abs() < 1e-5, "{arw}");
    assert!(k.contains("gsstd") && k.contains("not measured"));
}

#[test]
fn every_format_opens_with_the_provenance_of_every_number() {
    let noise = ImuNoise::from_channels(&channels(), "test.csv", 100.0, "/imu0", 1.0);
    for (name, f) in ExportFormat::ALL {
        let text = f.render(&noise);
        assert!(text.contains("Where each number comes from"), "{name}");
        assert!(text.contains("test.csv"), "{name}");
        assert!(text.contains("N of gz"), "{name}: the gyro density's source\n{text}");
    }
}

#[test]
fn a_gyro_only_record_says_the_accelerometer_figures_are_missing() {
    let ch = channels();
    let noise = ImuNoise::from_channels(&ch[..1], "test", 100.0, "/imu0", 1.0);
    let k = ExportFormat::Kalibr.render(&noise);
    assert!(k.contains("# accelerometer_noise_density: (missing"), "{k}");
    assert!(k.contains("no accelerometer channel was analysed"), "{k}");
}

#[test]
fn numbers_are_written_as_yaml_and_opencv_read_them() {
    assert_eq!(sci(1.5e3), "1.500000e+03");
    assert_eq!(sci(2.0e-4), "2.000000e-04");
    assert_eq!(sci(0.0), "0.000000e+00");
    assert_eq!(real(200.0), "200.0");
    assert_eq!(real(0.5), "0.5");
}

#[test]
fn export_requests_parse_and_bad_ones_name_the_problem() {
    let r = ExportRequest::parse("vins=out/vins.yaml").unwrap();
    assert_eq!((r.format, r.path.to_str().unwrap()), (ExportFormat::Vins, "out/vins.yaml"));
    let e = ExportRequest::parse("rovio=x.yaml").unwrap_err();
    assert!(e.to_string().contains("unknown format \"rovio\"") && e.to_string().contains("kalibr"), "{e}");
    assert!(ExportRequest::parse("kalibr").unwrap_err().to_string().contains("no '='"));
}

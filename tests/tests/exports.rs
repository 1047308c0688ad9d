//! The IMU noise exports read back by each target's own loader (tests/reference/export_loaders.py: PyYAML,
//! OpenCV's FileStorage, GTSAM's PreintegrationCombinedParams, an XML parser), and the numbers the loaders read
//! against values worked out here by hand from each format's documented convention and the fits.

use octavar::analyze::{analyze_channel, AnalyzeOptions, ChannelAnalysis};
use octavar::export::{ExportFormat, ImuNoise};
use octavar::quantity::Quantity;
use octavar_shared::sim::rng::SimRng;

use crate::util;

const RATE: f64 = 100.0;

/// White noise of density `n` plus a random walk of `k` (per second), `len` samples, around `mean`.
fn axis(rng: &mut SimRng, n: f64, k: f64, mean: f64, len: usize) -> Vec<f64> {
    let mut walk = 0.0;
    (0..len)
        .map(|_| {
            walk += k / RATE.sqrt() * rng.normal();
            mean + n * RATE.sqrt() * rng.normal() + walk
        })
        .collect()
}

fn six_axes() -> Vec<ChannelAnalysis> {
    let mut rng = SimRng::new(77);
    let len = 300_000;
    let opts = AnalyzeOptions::default();
    let mut out = Vec::new();
    for (i, name) in ["gx", "gy", "gz"].iter().enumerate() {
        let data = axis(&mut rng, 0.01 * (1.0 + 0.1 * i as f64), 2e-3, 0.0, len);
        out.push(analyze_channel(name, &data, RATE, &opts).unwrap());
    }
    for (i, (name, mean)) in [("ax", 0.1), ("ay", -0.2), ("az", 9.79)].iter().enumerate() {
        let data = axis(&mut rng, 0.002 * (1.0 + 0.1 * i as f64), 4e-4, *mean, len);
        out.push(analyze_channel(name, &data, RATE, &opts).unwrap().with_quantity(Quantity::Acceleration));
    }
    out
}

/// The largest identifiable value of a term over the axes of `q`, in the series' units.
fn largest(ch: &[ChannelAnalysis], q: Quantity, term: fn(&octavar::fit::NoiseFit) -> Option<f64>) -> f64 {
    ch.iter()
        .filter(|c| c.quantity == q)
        .map(|c| term(c.fit.as_ref().unwrap()).expect("identifiable on every axis"))
        .fold(0.0, f64::max)
}

#[test]
fn every_export_loads_in_its_targets_loader_with_the_numbers_its_convention_gives() {
    let Some(py) = util::reference_python("cv2, gtsam, yaml") else { return };
    let ch = six_axes();
    let dir = util::temp_dir("exports");
    let noise = ImuNoise::from_channels(&ch, "six axes", RATE, "/imu0", 1.0);
    let files = [
        (ExportFormat::Kalibr, "kalibr.yaml"),
        (ExportFormat::OpenVins, "openvins.yaml"),
        (ExportFormat::Vins, "vins.yaml"),
        (ExportFormat::OrbSlam3, "orbslam3.yaml"),
        (ExportFormat::Gtsam, "gtsam.yaml"),
        (ExportFormat::KfGins, "kfgins.yaml"),
        (ExportFormat::Gz, "gz.sdf"),
    ];
    for (f, name) in files {
        std::fs::write(dir.join(name), f.render(&noise)).unwrap();
    }
    let out = std::process::Command::new(py)
        .arg(util::reference_script("export_loaders.py"))
        .arg(&dir)
        .output()
        .expect("run the loaders");
    assert!(out.status.success(), "the loaders failed: {}", String::from_utf8_lossy(&out.stderr));
    let read: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();

    // By hand: continuous-time densities in SI. A gyro's N deg/sqrt(s) and K deg/s/sqrt(s) times pi/180; an
    // accelerometer's are SI already. Each config takes the largest of the three axes.
    let d2r = std::f64::consts::PI / 180.0;
    let g_n = largest(&ch, Quantity::AngularRate, |f| f.n.value);
    let g_k = largest(&ch, Quantity::AngularRate, |f| f.k.value);
    let a_n = largest(&ch, Quantity::Acceleration, |f| f.n.value);
    let a_k = largest(&ch, Quantity::Acceleration, |f| f.k.value);
    let (gn, gk, an, ak) = (g_n * d2r, g_k * d2r, a_n, a_k);
    let close = |v: &serde_json::Value, want: f64, what: &str| {
        let got = v.as_f64().unwrap_or_else(|| panic!("{what}: {v}"));
        assert!((got / want - 1.0).abs() < 2e-6, "{what}: the loader read {got}, the convention gives {want}");
    };
    for (fmt, keys) in [
        (
            "kalibr",
            [
                "gyroscope_noise_density",
                "gyroscope_random_walk",
                "accelerometer_noise_density",
                "accelerometer_random_walk",
            ],
        ),
        (
            "openvins",
            [
                "gyroscope_noise_density",
                "gyroscope_random_walk",
                "accelerometer_noise_density",
                "accelerometer_random_walk",
            ],
        ),
        ("vins", ["gyr_n", "gyr_w", "acc_n", "acc_w"]),
        ("orbslam3", ["IMU.NoiseGyro", "IMU.GyroWalk", "IMU.NoiseAcc", "IMU.AccWalk"]),
    ] {
        for (key, want) in keys.iter().zip([gn, gk, an, ak]) {
            close(&read[fmt][key], want, &format!("{fmt} {key}"));
        }
    }
    close(&read["kalibr"]["update_rate"], RATE, "kalibr update_rate");
    close(&read["orbslam3"]["IMU.Frequency"], RATE, "orbslam3 IMU.Frequency");
    assert_eq!(read["openvins"]["T_i_b_rows"], 4);
    // VINS's and GTSAM's gravity: the magnitude of the three accelerometer axes' means.
    let means: Vec<f64> = ch.iter().filter(|c| c.quantity == Quantity::Acceleration).map(|c| c.mean.unwrap()).collect();
    let g = means.iter().map(|m| m * m).sum::<f64>().sqrt();
    close(&read["vins"]["g_norm"], g, "vins g_norm");
    close(&read["gtsam"]["gravity"], g, "gtsam gravity");
    // GTSAM: covariances are the squares of the densities, on the diagonal.
    for (key, d) in [
        ("gyroscopeCovariance", gn),
        ("accelerometerCovariance", an),
        ("biasOmegaCovariance", gk),
        ("biasAccCovariance", ak),
    ] {
        let m = &read["gtsam"][key];
        for i in 0..3 {
            for j in 0..3 {
                if i == j {
                    close(&m[i][j], d * d, &format!("gtsam {key}[{i}][{i}]"));
                } else {
                    assert_eq!(m[i][j].as_f64(), Some(0.0), "gtsam {key}[{i}][{j}]");
                }
            }
        }
    }
    // KF-GINS: arw deg/sqrt(h) = N deg/sqrt(s) x 60; vrw m/s/sqrt(h) = N m/s/sqrt(s) x 60 (six digits written).
    let kf = &read["kfgins"];
    assert!((kf["arw"][0].as_f64().unwrap() - g_n * 60.0).abs() < 1e-6, "{kf}");
    assert!((kf["vrw"][2].as_f64().unwrap() - a_n * 60.0).abs() < 1e-6, "{kf}");
    assert!(kf["corrtime"].as_f64().unwrap() > 0.0 && kf["gbstd"][0].as_f64().unwrap() > 0.0, "{kf}");
    // gz: a per-sample deviation, the density times sqrt(rate); the gyro's static mean as its bias_mean.
    let gz = &read["gz"];
    close(&gz["angular_velocity/x"]["stddev"], gn * RATE.sqrt(), "gz gyro stddev");
    close(&gz["linear_acceleration/z"]["stddev"], an * RATE.sqrt(), "gz accel stddev");
    close(&gz["angular_velocity/y"]["bias_mean"], ch[1].mean.unwrap() * d2r, "gz gyro bias_mean");
    assert_eq!(gz["linear_acceleration/z"]["bias_mean"].as_f64(), Some(0.0));
    let _ = std::fs::remove_dir_all(&dir);
}

/// `gap --export`: where the diagnosis names a Gauss-Markov bias, the exports' bias model is that process, and
/// KF-GINS's gbstd and corrtime are its sigma in deg/h and its correlation time in hours. The record comes from
/// the independent generator (circulant embedding of the exponential autocovariance, not shared::sim).
#[test]
fn a_gauss_markov_bias_the_gap_diagnosis_names_is_the_exports_bias_model() {
    use crate::indep_gyro::{IndepGyro, Markov};
    use octavar::gap::{diagnose, Effect, GapInput, GapOptions};
    let (sigma, tau_c, rate) = (0.02, 20.0, 50.0);
    let gyro = IndepGyro {
        bias_dps: 0.3,
        n_deg_per_rt_s: 0.01,
        gauss_markov: Some(Markov { sigma_dps: sigma, tau_s: tau_c }),
        ..Default::default()
    };
    let rec = gyro.generate(rate, 2 * 3600 * 50, 5);
    let input = GapInput::split(rec.rate_dps, None, rate, 0.5).unwrap();
    let opts = GapOptions { seeds: 12, ..Default::default() };
    let report = diagnose(&input, &opts, &|_, _, _| {}).unwrap();
    assert_eq!(report.effects(), [Effect::GaussMarkov], "the diagnosis names the Gauss-Markov bias alone");
    let mean = input.rate_dps[..input.n_train].iter().sum::<f64>() / input.n_train as f64;
    let noise = ImuNoise::from_gap(&report, "rate", Some(mean), "gm.csv", "/imu0", 1.0);
    let g = noise.gyro.as_ref().expect("a gyro");
    let m = g.bias_model.as_ref().expect("a bias model");
    assert!(m.how.contains("gauss_markov effect the gap diagnosis named"), "{}", m.how);
    let named = report.model().gauss_markov.expect("the final model carries it");
    assert!((m.sigma - named.sigma_dps.to_radians()).abs() < 1e-12 * m.sigma, "sigma {} in rad/s", m.sigma);
    assert_eq!(m.tau_c_s, named.tau_s);
    let sigma_rel = named.sigma_dps / sigma - 1.0;
    let tau_rel = named.tau_s / tau_c - 1.0;
    assert!(sigma_rel.abs() < 0.25 && tau_rel.abs() < 0.5, "sigma {sigma_rel:+.2}, T {tau_rel:+.2} from the truth");
    // KF-GINS by hand: gbstd in deg/h, corrtime in hours.
    let kf = ExportFormat::KfGins.render(&noise);
    let field = |key: &str| -> f64 {
        let line = kf.lines().find(|l| l.trim_start().starts_with(key)).unwrap_or_else(|| panic!("{key} in\n{kf}"));
        let text = line.split(':').nth(1).unwrap().split('#').next().unwrap().trim();
        text.trim_start_matches('[').split(',').next().unwrap().trim().trim_end_matches(']').parse().unwrap()
    };
    let gbstd = named.sigma_dps * 3600.0;
    assert!((field("gbstd:") / gbstd - 1.0).abs() < 1e-5, "gbstd {} against {gbstd}", field("gbstd:"));
    assert!((field("corrtime:") / (named.tau_s / 3600.0) - 1.0).abs() < 1e-3, "corrtime {}", field("corrtime:"));
    // The density is the base fit's N, as analyze would write it.
    let n = report.base.fit.n.value.unwrap().to_radians();
    assert!((g.density.as_ref().unwrap().value / n - 1.0).abs() < 1e-12);
}

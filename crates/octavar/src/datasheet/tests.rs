//! Datasheet units against conversions worked out by hand, and the comparison's verdicts.

use super::*;
use crate::fit::TermEstimate;

fn close(got: f64, want: f64, what: &str) {
    assert!((got / want - 1.0).abs() < 1e-12, "{what}: {got} vs {want}");
}

#[test]
fn customary_units_convert_to_octavars_as_worked_by_hand() {
    use Quantity::{Acceleration as A, AngularRate as G};
    let pi = std::f64::consts::PI;
    let g0 = 9.80665;
    // (figure, term, quantity, the value in octavar's unit worked out by hand)
    let cases: [(&str, Term, Quantity, f64); 22] = [
        // Gyro N in deg/sqrt(s): deg/sqrt(h) / 60; a density in deg/s/sqrt(Hz) is the same number.
        ("0.3 deg/sqrt(h)", Term::N, G, 0.3 / 60.0),
        ("0.3 deg/√h", Term::N, G, 0.3 / 60.0),
        ("0.005 deg/s/sqrt(Hz)", Term::N, G, 0.005),
        ("5 mdps/sqrt(Hz)", Term::N, G, 0.005),
        ("0.005 dps/√Hz", Term::N, G, 0.005),
        ("1e-4 rad/s/sqrt(Hz)", Term::N, G, 1e-4 * 180.0 / pi),
        ("18 deg/h/sqrt(Hz)", Term::N, G, 18.0 / 3600.0),
        // Gyro B in deg/s.
        ("4 deg/h", Term::B, G, 4.0 / 3600.0),
        ("4 deg/hr", Term::B, G, 4.0 / 3600.0),
        ("1e-5 rad/s", Term::B, G, 1e-5 * 180.0 / pi),
        // Gyro K in deg/s/sqrt(s): deg/h/sqrt(h) / 3600 / 60; deg/h^1.5 the same.
        ("0.1 deg/h/sqrt(h)", Term::K, G, 0.1 / 216_000.0),
        ("0.1 deg/h^1.5", Term::K, G, 0.1 / 216_000.0),
        ("2e-5 rad/s^2/sqrt(Hz)", Term::K, G, 2e-5 * 180.0 / pi),
        // Gyro Q in deg.
        ("3 arcsec", Term::Q, G, 3.0 / 3600.0),
        // Accelerometer N in m/s/sqrt(s).
        ("60 ug/sqrt(Hz)", Term::N, A, 60e-6 * g0),
        ("0.06 mg/√Hz", Term::N, A, 0.06e-3 * g0),
        ("0.12 m/s/sqrt(h)", Term::N, A, 0.12 / 60.0),
        ("2e-3 m/s^2/sqrt(Hz)", Term::N, A, 2e-3),
        // Accelerometer B in m/s^2.
        ("0.04 mg", Term::B, A, 0.04e-3 * g0),
        ("250 mGal", Term::B, A, 250e-5),
        ("40 ug", Term::B, A, 40e-6 * g0),
        // Accelerometer K in m/s^2/sqrt(s): mg/sqrt(h) x g0 / 1000 / 60.
        ("0.5 mg/sqrt(h)", Term::K, A, 0.5e-3 * g0 / 60.0),
    ];
    for (text, t, q, want) in cases {
        close(figure_in_base(text, t, q).unwrap_or_else(|e| panic!("{text}: {e}")), want, text);
    }
}

#[test]
fn a_figure_of_the_wrong_dimension_is_refused_with_both_dimensions() {
    let e = figure_in_base("0.3 deg/h", Term::N, Quantity::AngularRate).unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("rad s^-1") && msg.contains("rad s^-0.5") && msg.contains("deg/sqrt(h)"), "{msg}");
    assert!(matches!(figure_in_base("deg/h", Term::B, Quantity::AngularRate), Err(UnitError::NoNumber { .. })));
    let e = figure_in_base("4 furlong/h", Term::B, Quantity::AngularRate).unwrap_err();
    assert!(e.to_string().contains("unknown unit \"furlong\""), "{e}");
}

#[test]
fn a_datasheet_file_parses_and_names_its_faults() {
    let text = r#"
        rate_hz = 200
        topic = "/imu/data"
        [gyro]
        arw = "0.3 deg/sqrt(h)"
        bias_instability = "4 deg/h"
        bias_correlation_time = "2 min"
        [accel]
        N = "60 ug/sqrt(Hz)"
    "#;
    let d = Datasheet::parse(text, "bmi.toml").unwrap();
    assert_eq!(d.rate_hz, Some(200.0));
    let g = d.gyro.as_ref().unwrap();
    close(g.get(Term::N).unwrap(), 0.005, "arw");
    assert_eq!(g.bias_correlation_time_s, Some(120.0));
    let bad = Datasheet::parse("[gyro]\nN = \"0.3 deg/h\"\n", "x.toml").unwrap_err().to_string();
    assert!(bad.starts_with("x.toml: [gyro] N:"), "{bad}");
    let bad = Datasheet::parse("[gyro]\nwobble = \"1 deg\"\n", "x.toml").unwrap_err().to_string();
    assert!(bad.contains("unknown key"), "{bad}");
    assert!(matches!(Datasheet::parse("rate_hz = 100\n", "x.toml"), Err(DatasheetError::Empty { .. })));
}

#[test]
fn verdicts_follow_the_interval() {
    let est = |v: Option<f64>, lo: Option<f64>, hi: Option<f64>| TermEstimate {
        value: v,
        lo,
        hi,
        unit: "deg/sqrt(s)",
        identifiable: v.is_some(),
    };
    let sheet = SensorSheet {
        terms: [("N", 0.01)].into_iter().collect(),
        written: [("N", "0.6 deg/sqrt(h)".to_string())].into_iter().collect(),
        bias_correlation_time_s: None,
    };
    let data = crate::test_signals::white(20_000, 5);
    let a = crate::analyze::analyze_channel("g", &data, 10.0, &Default::default()).unwrap();
    let base = a.fit.unwrap();
    for (n, want) in [
        (est(Some(0.008), Some(0.007), Some(0.009)), "meets"),
        (est(Some(0.012), Some(0.011), Some(0.013)), "exceeds"),
        (est(Some(0.0099), Some(0.009), Some(0.011)), "consistent"),
        (est(None, None, Some(0.005)), "below bound"),
    ] {
        let f = NoiseFit { n, ..base.clone() };
        let c = compare(&f, &sheet);
        assert_eq!(c[0].verdict, want);
        if let Some(v) = f.n.value {
            assert!((c[0].ratio.unwrap() - v / 0.01).abs() < 1e-12);
        }
    }
}

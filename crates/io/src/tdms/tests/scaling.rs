//! NI scales on a one-channel file: each scale type, chains through input sources, group and file scales, and
//! the scales octavar refuses.

use super::writer::*;
use crate::tdms::format::TOC_NEW_OBJ_LIST;

/// A file with one i16 channel "g/x" holding -2, 0, 3, 1000 and these properties (and group `group_props`).
fn scaled_file(props: Vec<(&str, Pv)>, group_props: Vec<(&str, Pv)>) -> Vec<u8> {
    let objs = [obj("/'g'", Ix::NoData, group_props), obj(&chan("g", "x"), Ix::New(2, 4), props)];
    segment(TOC_NEW_OBJ_LIST, Some(&objs), &i16s(&[-2, 0, 3, 1000], false))
}

fn scaled(props: Vec<(&str, Pv)>) -> Result<Vec<f64>, String> {
    read(&scaled_file(props, vec![]), &["g/x"], Some(1.0)).map(|r| r.channels[0].clone()).map_err(|e| e.to_string())
}

fn linear(i: u32, slope: f64, intercept: f64) -> Vec<(String, Pv)> {
    vec![
        (format!("NI_Scale[{i}]_Scale_Type"), Pv::Str("Linear")),
        (format!("NI_Scale[{i}]_Linear_Slope"), Pv::F64(slope)),
        (format!("NI_Scale[{i}]_Linear_Y_Intercept"), Pv::F64(intercept)),
    ]
}

fn props(v: &[(String, Pv)]) -> Vec<(&str, Pv)> {
    v.iter()
        .map(|(k, p)| {
            let p = match p {
                Pv::I32(x) => Pv::I32(*x),
                Pv::U32(x) => Pv::U32(*x),
                Pv::F64(x) => Pv::F64(*x),
                Pv::Str(s) => Pv::Str(s),
                Pv::Bool => Pv::Bool,
                Pv::Time => Pv::Time,
            };
            (k.as_str(), p)
        })
        .collect()
}

#[test]
fn linear_and_polynomial_scales() {
    let raw = [-2.0, 0.0, 3.0, 1000.0];
    let mut p = linear(0, 0.00875, -0.25);
    p.push(("NI_Number_Of_Scales".into(), Pv::I32(1)));
    p.push(("NI_Scaling_Status".into(), Pv::Str("unscaled")));
    let expect: Vec<f64> = raw.iter().map(|x| x * 0.00875 + -0.25).collect();
    assert_eq!(scaled(props(&p)).unwrap(), expect);
    // Without NI_Number_Of_Scales and NI_Scaling_Status: the scale types count them, and unscaled is assumed.
    assert_eq!(scaled(props(&linear(0, 0.00875, -0.25))).unwrap(), expect);
    // Already scaled: left alone.
    p[4] = ("NI_Scaling_Status".into(), Pv::Str("scaled"));
    assert_eq!(scaled(props(&p)).unwrap(), raw);

    // Polynomial 1 - 0.5 x + 0.25 x^2 (size given), fed by a linear scale 2x + 1: the last scale applies.
    let mut p = linear(0, 2.0, 1.0);
    p.extend([
        ("NI_Scale[1]_Scale_Type".to_string(), Pv::Str("Polynomial")),
        ("NI_Scale[1]_Polynomial_Coefficients_Size".to_string(), Pv::I32(3)),
        ("NI_Scale[1]_Polynomial_Coefficients[0]".to_string(), Pv::F64(1.0)),
        ("NI_Scale[1]_Polynomial_Coefficients[1]".to_string(), Pv::F64(-0.5)),
        ("NI_Scale[1]_Polynomial_Coefficients[2]".to_string(), Pv::F64(0.25)),
        ("NI_Scale[1]_Polynomial_Input_Source".to_string(), Pv::U32(0)),
        ("NI_Number_Of_Scales".to_string(), Pv::I32(2)),
    ]);
    let poly = |y: f64| 1.0 + y * (-0.5 + y * 0.25);
    let expect: Vec<f64> = raw.iter().map(|x| poly(x * 2.0 + 1.0)).collect();
    assert_eq!(scaled(props(&p)).unwrap(), expect);
    // Fed by the raw data instead.
    p[8] = ("NI_Scale[1]_Polynomial_Input_Source".to_string(), Pv::U32(0xFFFF_FFFF));
    assert_eq!(scaled(props(&p)).unwrap(), raw.iter().map(|&x| poly(x)).collect::<Vec<_>>());
    // Four coefficients when the size is not given.
    let p: Vec<(String, Pv)> = vec![
        ("NI_Scale[0]_Scale_Type".into(), Pv::Str("Polynomial")),
        ("NI_Scale[0]_Polynomial_Coefficients[0]".into(), Pv::F64(0.0)),
        ("NI_Scale[0]_Polynomial_Coefficients[1]".into(), Pv::F64(0.0)),
        ("NI_Scale[0]_Polynomial_Coefficients[2]".into(), Pv::F64(0.0)),
        ("NI_Scale[0]_Polynomial_Coefficients[3]".into(), Pv::F64(1.0)),
    ];
    assert_eq!(scaled(props(&p)).unwrap(), raw.iter().map(|x| x * x * x).collect::<Vec<_>>());
}

#[test]
fn add_subtract_and_advanced_api_scales() {
    // Scale 0: 2x; scale 1: x + 10; scale 2: Subtract (right - left) of 0 and 1; scale 3: AdvancedAPI of 2.
    let mut p = linear(0, 2.0, 0.0);
    p.extend(linear(1, 1.0, 10.0));
    p.extend([
        ("NI_Scale[2]_Scale_Type".to_string(), Pv::Str("Subtract")),
        ("NI_Scale[2]_Subtract_Left_Operand_Input_Source".to_string(), Pv::U32(0)),
        ("NI_Scale[2]_Subtract_Right_Operand_Input_Source".to_string(), Pv::U32(1)),
        ("NI_Scale[3]_Scale_Type".to_string(), Pv::Str("AdvancedAPI")),
        ("NI_Scale[3]_AdvancedAPI_Input_Source".to_string(), Pv::U32(2)),
        ("NI_Number_Of_Scales".to_string(), Pv::I32(4)),
    ]);
    let raw = [-2.0, 0.0, 3.0, 1000.0];
    assert_eq!(scaled(props(&p)).unwrap(), raw.iter().map(|x| (x + 10.0) - 2.0 * x).collect::<Vec<_>>());
    p[6] = ("NI_Scale[2]_Scale_Type".to_string(), Pv::Str("Add"));
    p[7] = ("NI_Scale[2]_Add_Left_Operand_Input_Source".to_string(), Pv::U32(0));
    p[8] = ("NI_Scale[2]_Add_Right_Operand_Input_Source".to_string(), Pv::I32(-1));
    assert_eq!(scaled(props(&p)).unwrap(), raw.iter().map(|x| 2.0 * x + x).collect::<Vec<_>>());
}

#[test]
fn group_and_file_scales_apply_where_the_channel_has_none() {
    let file = scaled_file(vec![], props(&linear(0, 3.0, 1.0)));
    let rec = read(&file, &["g/x"], Some(1.0)).unwrap();
    assert_eq!(rec.channels[0], [-5.0, 1.0, 10.0, 3001.0]);
    // The channel's own scale wins.
    let file = scaled_file(props(&linear(0, 1.0, 0.5)), props(&linear(0, 3.0, 1.0)));
    let rec = read(&file, &["g/x"], Some(1.0)).unwrap();
    assert_eq!(rec.channels[0], [-1.5, 0.5, 3.5, 1000.5]);
}

#[test]
fn scales_octavar_cannot_apply_are_errors() {
    let mut p = linear(0, 1.0, 0.0);
    p[0].1 = Pv::Str("Thermocouple");
    let err = scaled(props(&p)).unwrap_err();
    assert_eq!(
        err,
        "test.tdms: channel \"g/x\": scale 0 is of type \"Thermocouple\", which octavar does not apply (it \
         applies Linear, Polynomial, Add, Subtract and AdvancedAPI scales); export the channel scaled"
    );
    // A DAQmx scaler: counted, but without a type.
    let err = scaled(vec![("NI_Number_Of_Scales", Pv::I32(1))]).unwrap_err();
    assert!(err.contains("scale 0 is of type \"DAQmx scaler (no Scale_Type)\""), "{err}");
    // A missing slope.
    let err = scaled(props(
        &linear(0, 1.0, 0.0)[..2].iter().map(|(k, _)| (k.clone(), Pv::Str("Linear"))).collect::<Vec<_>>(),
    ));
    assert!(err.unwrap_err().contains("NI_Scale[0]_Linear_Slope is \"Linear\", not a number"));
    let mut p = linear(0, 1.0, 0.0);
    p.truncate(2);
    assert!(scaled(props(&p)).unwrap_err().ends_with("scale 0 has no NI_Scale[0]_Linear_Y_Intercept"));
    // Input sources in a loop, and out of range.
    let mut p = linear(0, 1.0, 0.0);
    p.push(("NI_Scale[0]_Linear_Input_Source".into(), Pv::U32(0)));
    assert!(scaled(props(&p)).unwrap_err().contains("loop"));
    p[3].1 = Pv::U32(5);
    assert!(scaled(props(&p)).unwrap_err().contains("neither the raw data (4294967295) nor one of the 1 scales"));
}

//! OpenVINS's `kalibr_imu_chain.yaml`: Kalibr's four continuous-time densities under `imu0`, with the rate, the
//! topic and identity intrinsics (`model: kalibr`), read by OpenVINS through OpenCV's FileStorage
//! (<https://docs.openvins.com/propagation.html>, <https://docs.openvins.com/gs-calibration.html>).

use std::fmt::Write as _;

use super::{kalibr, provenance, real, value_line, ImuNoise};

const CONVENTION: &str = "OpenVINS takes Kalibr's continuous-time densities (its propagation divides them by \
    sqrt(dt) itself): *_noise_density the white noise N, *_random_walk the bias random walk K, in SI. The \
    intrinsics (Tw, R_IMUtoGYRO, Ta, R_IMUtoACC, Tg) and T_i_b are not measured by octavar: they are written as \
    identity (no scale, misalignment or g-sensitivity), as for a calibrated IMU. \
    https://docs.openvins.com/propagation.html";

pub(super) fn render(n: &ImuNoise) -> String {
    let f = kalibr::fields(n);
    // OpenCV's FileStorage wants its directive on the first line; the comment follows it.
    let mut s = String::from("%YAML:1.0\n");
    s += &provenance(
        "#",
        n,
        "OpenVINS kalibr_imu_chain.yaml",
        CONVENTION,
        &f.iter().map(|x| x.2.clone()).collect::<Vec<_>>(),
    );
    let eye = |k: usize| -> String {
        (0..k)
            .map(|i| {
                let row: Vec<&str> = (0..k).map(|j| if i == j { "1.0" } else { "0.0" }).collect();
                format!("    - [{}]\n", row.join(", "))
            })
            .collect()
    };
    let zeros3 = "    - [0.0, 0.0, 0.0]\n".repeat(3);
    s += "imu0:\n  T_i_b:\n";
    s += &eye(4);
    for (name, value, _) in &f {
        value_line(&mut s, "  ", name, *value);
    }
    let _ = writeln!(s, "  rostopic: {}", n.topic);
    s += "  time_offset: 0.0\n";
    let _ = writeln!(s, "  update_rate: {}", real(n.rate_hz));
    s += "  model: \"kalibr\"\n  Tw:\n";
    s += &eye(3);
    s += "  R_IMUtoGYRO:\n";
    s += &eye(3);
    s += "  Ta:\n";
    s += &eye(3);
    s += "  R_IMUtoACC:\n";
    s += &eye(3);
    s += "  Tg:\n";
    s += &zeros3;
    s
}

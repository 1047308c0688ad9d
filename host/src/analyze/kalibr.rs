//! The Kalibr `imu.yaml` `octavar analyze --kalibr` writes.

use super::ChannelAnalysis;

/// A Kalibr `imu.yaml` for one channel's fit. Kalibr wants continuous-time densities in SI units:
/// `gyroscope_noise_density` = N in rad/s/sqrt(Hz) (N deg/sqrt(s) times pi/180), and `gyroscope_random_walk` =
/// the bias random walk K in rad/s^2/sqrt(Hz) (K deg/s/sqrt(s) times pi/180). Where K is not identifiable the
/// bias-instability line is used as a conservative stand-in, B / sqrt(tau_B) (documented in the file).
pub fn kalibr_yaml(c: &ChannelAnalysis, rate_hz: f64) -> Option<String> {
    let f = c.fit.as_ref().ok()?;
    let d2r = std::f64::consts::PI / 180.0;
    let n = f.n.value.or(f.classic.n)?;
    let (rw, note) = match f.k.value {
        Some(k) => (k * d2r, "K, the rate random walk of the fit".to_string()),
        None => {
            let (b, tau) = (f.b.value.or(f.classic.b)?, f.classic.b_tau_s?);
            (b * d2r / tau.sqrt(), format!("K not identifiable: B / sqrt(tau_B) with tau_B = {tau:.3e} s"))
        }
    };
    Some(format!(
        "# octavar analyze: gyro channel {name}. Gyroscope terms only; add your accelerometer's.\n\
         # gyroscope_noise_density = N [rad/s/sqrt(Hz)] = {n:.6e} deg/sqrt(s) * pi/180\n\
         # gyroscope_random_walk   = {note} [rad/s^2/sqrt(Hz)]\n\
         rostopic: /imu0\n\
         update_rate: {rate_hz}\n\
         gyroscope_noise_density: {gnd:.6e}\n\
         gyroscope_random_walk: {rw:.6e}\n",
        name = c.name,
        gnd = n * d2r,
    ))
}

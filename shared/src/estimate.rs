//! The onboard estimate of angle random walk N and bias instability B from an octave snapshot.
//!
//! The firmware runs this every second on each gyro's [`Snapshot`], so a user with no PC at hand still sees the
//! two numbers that matter (defmt log, estimate frame), and the host can check them against its full analysis.
//! It follows the IEEE 952 reading of an Allan deviation plot, restricted to what octave levels give:
//!
//! - **N** (deg/sqrt(s)): white rate noise is the line ADEV(tau) = N / sqrt(tau) of slope -1/2, so N is its value
//!   at tau = 1 s. The line is fitted (slope fixed at -1/2, least squares in log-log, i.e. a geometric mean of
//!   `ADEV(tau) * sqrt(tau)`) through the octave levels within one octave of 1 s: tau in [0.5 s, 2 s].
//! - **B** (deg/s): the flicker floor, `min ADEV / 0.6643` (sqrt(2 ln 2 / pi) = 0.6643) over the levels that hold
//!   enough independent differences.
//!
//! Work is in `f32` with [`micromath::F32Ext`] called explicitly, so host tests exercise the same square root the
//! microcontroller uses (on the host `f32::sqrt` would resolve to std's). micromath's square root is a bit-level
//! approximation within 5%; [`sqrt`] refines it with three Newton steps to full `f32` precision.
//!
//! # Examples
//! ```
//! use octavar_shared::acc::OctaveAllan;
//! use octavar_shared::estimate::{estimate, EstimateConfig};
//! let mut acc = OctaveAllan::<8>::new();
//! let mut s = 1u32;
//! for _ in 0..20_000 {
//!     s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
//!     acc.push(2048 + (s >> 30) as u16); // white noise, 4 codes wide
//! }
//! let e = estimate(&acc.snapshot(), &EstimateConfig { sample_rate_hz: 2000.0, dps_per_code: 0.01, ..Default::default() });
//! assert!(e.n_dps_per_rt_s.is_some() && e.b_dps.is_some());
//! ```

use micromath::F32Ext;

use crate::acc::{Snapshot, LEVELS};

/// sqrt(2 ln 2 / pi): the flicker floor of the Allan deviation is 0.6643 B.
pub const FLICKER_FLOOR_FACTOR: f32 = 0.6643;

/// How to read a snapshot.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EstimateConfig {
    /// Samples per second of the channel.
    pub sample_rate_hz: f32,
    /// deg/s per ADC code (see [`crate::sensor::Channel::dps_per_code`]).
    pub dps_per_code: f32,
    /// A level counts only with at least this many independent differences (pairs / stride factor).
    pub min_independent: u32,
}

impl Default for EstimateConfig {
    fn default() -> Self {
        Self { sample_rate_hz: 2000.0, dps_per_code: 1.0, min_independent: 4 }
    }
}

/// The onboard estimate for one gyro channel. `None` where the snapshot does not yet hold the levels needed.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NoiseEstimate {
    /// Angle random walk N, in deg/sqrt(s) (times 60 for deg/sqrt(h)).
    pub n_dps_per_rt_s: Option<f32>,
    /// Bias instability B, in deg/s (times 3600 for deg/h).
    pub b_dps: Option<f32>,
    /// The averaging time of the ADEV minimum B was read at, in s.
    pub tau_b_s: Option<f32>,
}

/// Square root: micromath's approximation (within 5%) refined by three Newton steps (relative error about 1e-7).
pub fn sqrt(x: f32) -> f32 {
    if x <= 0.0 {
        return if x == 0.0 { 0.0 } else { f32::NAN };
    }
    let mut y = F32Ext::sqrt(x);
    y = 0.5 * (y + x / y);
    y = 0.5 * (y + x / y);
    0.5 * (y + x / y)
}

/// Allan deviation of `level` in deg/s, if the level has enough independent differences.
fn adev_dps(snap: &Snapshot, level: usize, cfg: &EstimateConfig) -> Option<f32> {
    let l = snap.levels.get(level)?;
    let independent = l.n / snap.stride_factor(level).max(1);
    if l.n == 0 || independent < u64::from(cfg.min_independent) {
        return None;
    }
    let m = (1u64 << level) as f32;
    let avar_codes2 = l.sum_sq as f32 / (2.0 * l.n as f32 * m * m);
    Some(sqrt(avar_codes2) * cfg.dps_per_code)
}

/// Estimate N and B of one channel from its snapshot.
pub fn estimate(snap: &Snapshot, cfg: &EstimateConfig) -> NoiseEstimate {
    let tau0 = 1.0 / cfg.sample_rate_hz;
    let mut out = NoiseEstimate::default();

    // N: geometric mean of ADEV * sqrt(tau) over the levels with tau in [0.5 s, 2 s].
    let (mut product, mut count) = (1.0f32, 0u32);
    for level in 0..LEVELS {
        let tau = tau0 * (1u64 << level) as f32;
        if !(0.5..=2.0).contains(&tau) {
            continue;
        }
        if let Some(adev) = adev_dps(snap, level, cfg) {
            product *= adev * sqrt(tau);
            count += 1;
        }
    }
    out.n_dps_per_rt_s = match count {
        0 => None,
        1 => Some(product),
        2 => Some(sqrt(product)),
        // Only at sample rates where more than two octaves fall in [0.5, 2] s (never at octave spacing); kept
        // general with micromath's power function.
        c => Some(F32Ext::powf(product, 1.0 / c as f32)),
    };

    // B: the lowest ADEV over the usable levels.
    for level in 0..LEVELS {
        if let Some(adev) = adev_dps(snap, level, cfg) {
            if out.b_dps.is_none_or(|b| adev / FLICKER_FLOOR_FACTOR < b) {
                out.b_dps = Some(adev / FLICKER_FLOOR_FACTOR);
                out.tau_b_s = Some(tau0 * (1u64 << level) as f32);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::acc::{LevelSum, OctaveAllan};

    /// A snapshot whose ADEV at each level follows `adev(tau)` exactly (in codes), with plenty of pairs.
    fn shaped(fs: f64, adev: impl Fn(f64) -> f64) -> Snapshot {
        let mut s = Snapshot::empty(8).unwrap();
        s.samples = 1 << 28;
        for (k, l) in s.levels.iter_mut().enumerate().take(24) {
            let m = (1u64 << k) as f64;
            let n = 1u64 << 20;
            let avar = adev(m / fs).powi(2);
            *l = LevelSum { n, sum_sq: (avar * 2.0 * n as f64 * m * m) as u128 };
        }
        s
    }

    #[test]
    fn refined_sqrt_is_accurate() {
        for x in [1e-12f32, 3e-7, 0.5, 1.0, 2.0, 10.0, 12345.678, 3.3e9] {
            let got = sqrt(x);
            assert!((f64::from(got) / f64::from(x).sqrt() - 1.0).abs() < 1e-6, "{x}: {got}");
        }
        assert_eq!(sqrt(0.0), 0.0);
        assert!(sqrt(-1.0).is_nan());
    }

    #[test]
    fn white_noise_line_gives_n_at_one_second() {
        let fs = 2000.0;
        let n_true = 3.0e-3; // IDG1215 Y, deg/sqrt(s)
        let dps_per_code = 0.05;
        let snap = shaped(fs, |tau| n_true / tau.sqrt() / dps_per_code);
        let cfg = EstimateConfig { sample_rate_hz: fs as f32, dps_per_code: dps_per_code as f32, min_independent: 4 };
        let e = estimate(&snap, &cfg);
        let n = e.n_dps_per_rt_s.unwrap();
        assert!((f64::from(n) / n_true - 1.0).abs() < 1e-3, "{n}");
    }

    #[test]
    fn flicker_floor_gives_b() {
        let fs = 2000.0;
        let (n_true, b_true) = (4.0e-4, 9.5e-4); // ENV-05H, paper Table 1
        let floor = 0.6643 * b_true;
        // White noise meeting a floor, then a random-walk rise: the minimum is the floor.
        let dps_per_code = 1e-4;
        let snap = shaped(fs, |tau| ((n_true * n_true / tau) + floor * floor + (1e-6 * tau).powi(2)).sqrt() / dps_per_code);
        let cfg = EstimateConfig { sample_rate_hz: fs as f32, dps_per_code: dps_per_code as f32, min_independent: 4 };
        let e = estimate(&snap, &cfg);
        let b = e.b_dps.unwrap();
        assert!((f64::from(b) / b_true - 1.0).abs() < 0.05, "{b}");
        assert!(e.tau_b_s.unwrap() > 1.0);
        // With the ENV-05H's numbers the floor already dominates at 1 s: the -1/2 line read there is biased up.
        let n = f64::from(e.n_dps_per_rt_s.unwrap());
        assert!(n > n_true && n < 2.0 * n_true, "{n}");
    }

    #[test]
    fn real_accumulator_white_noise() {
        // Sum of four uniform 8-bit draws: variance 4 * (256^2 - 1) / 12 codes^2.
        let mut acc = OctaveAllan::<8>::new();
        let mut s = 7u64;
        let mut draw = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 56) as u16
        };
        for _ in 0..(1 << 16) {
            let c = 1500 + draw() + draw() + draw() + draw();
            acc.push(c);
        }
        let fs = 2000.0f32;
        let dps_per_code = 0.01f32;
        let sigma_codes = (4.0 * (256.0f64 * 256.0 - 1.0) / 12.0).sqrt();
        let n_true = sigma_codes * f64::from(dps_per_code) / f64::from(fs).sqrt();
        let e = estimate(&acc.snapshot(), &EstimateConfig { sample_rate_hz: fs, dps_per_code, min_independent: 4 });
        let n = f64::from(e.n_dps_per_rt_s.unwrap());
        assert!((n / n_true - 1.0).abs() < 0.15, "{n} vs {n_true}");
    }

    #[test]
    fn too_little_data_gives_nothing() {
        let mut acc = OctaveAllan::<8>::new();
        for i in 0..500u16 {
            acc.push(2000 + i % 3);
        }
        let e = estimate(&acc.snapshot(), &EstimateConfig::default());
        assert_eq!(e.n_dps_per_rt_s, None); // 500 samples: no level near tau = 1 s
        assert!(e.b_dps.is_some());
        assert_eq!(estimate(&Snapshot::empty(8).unwrap(), &EstimateConfig::default()), NoiseEstimate::default());
    }
}

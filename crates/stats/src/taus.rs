//! Which averaging factors m (tau = m tau0) to evaluate: octave, decade, all, N per decade, or explicit.
//!
//! Generated lists stop where Stable32 stops: at `m <= floor(N_freq / stop_ratio)` with N_freq the number of
//! frequency intervals (phase points - 1) and the stop ratio of the statistic (W. J. Riley, "Evolution of
//! frequency stability analysis software", Table III; the same numbers appear in allantools' `tau_generator`):
//! ADEV 5, OADEV 4, MDEV 4, TDEV 4, HDEV 5, OHDEV 4, TOTDEV 2. This reproduces the last rows of every Stable32
//! table in allantools' test data (e.g. PHASE.DAT, 1001 points: ADEV octave ends at m = 128, TOTDEV at 256).
//! Explicit lists are rounded to the nearest m, sorted and de-duplicated, and keep every m the statistic can
//! compute at all (at least one term), without the stop ratio.

use super::error::StatsError;

/// A request for tau values.
#[derive(Debug, Clone, PartialEq)]
pub enum TauSpec {
    /// m = 1, 2, 4, 8, ...
    Octave,
    /// m = 1, 2, 4, 10, 20, 40, 100, ... (Stable32's decade spacing).
    Decade,
    /// Every m = 1, 2, 3, ...
    All,
    /// About n values per decade: m = round(10^(k/n)), de-duplicated.
    PerDecade(u32),
    /// Explicit tau values in seconds.
    Explicit(Vec<f64>),
}

/// The averaging factors for `spec`, given the stop ratio, the largest m the statistic can compute at all
/// (`m_limit`), the number of phase points and tau0.
///
/// # Errors
/// [`StatsError::BadTau`] for a non-positive or non-finite explicit tau or a per-decade count of 0.
pub(crate) fn averaging_factors(
    spec: &TauSpec,
    stop_ratio: u64,
    m_limit: u64,
    n_phase: usize,
    tau0_s: f64,
) -> Result<Vec<u64>, StatsError> {
    let n_freq = n_phase.saturating_sub(1) as u64;
    let m_stop = (n_freq / stop_ratio).min(m_limit);
    let mut ms: Vec<u64> = match spec {
        TauSpec::Octave => (0..64).map(|k| 1u64 << k).take_while(|&m| m <= m_stop).collect(),
        TauSpec::Decade => {
            let mut v = Vec::new();
            let mut p = 1u64;
            'outer: loop {
                for f in [1u64, 2, 4] {
                    let m = f.saturating_mul(p);
                    if m > m_stop {
                        break 'outer;
                    }
                    v.push(m);
                }
                p = p.saturating_mul(10);
            }
            v
        }
        TauSpec::All => (1..=m_stop).collect(),
        TauSpec::PerDecade(k) => {
            if *k == 0 {
                return Err(StatsError::BadTau("0 points per decade".into()));
            }
            let mut v = Vec::new();
            for i in 0.. {
                let m = 10f64.powf(i as f64 / *k as f64).round() as u64;
                if m > m_stop {
                    break;
                }
                v.push(m);
            }
            v
        }
        TauSpec::Explicit(taus) => {
            let mut v = Vec::with_capacity(taus.len());
            for &t in taus {
                if !(t > 0.0 && t.is_finite()) {
                    return Err(StatsError::BadTau(format!("tau {t} s")));
                }
                let m = (t / tau0_s).round();
                if m >= 1.0 && m <= m_limit as f64 {
                    v.push(m as u64);
                }
            }
            v
        }
    };
    ms.sort_unstable();
    ms.dedup();
    Ok(ms)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stable32_last_rows() {
        // PHASE.DAT: 1001 phase points. Stable32 octave tables end at 128 (ADEV, ratio 5; OADEV, ratio 4)
        // and 256 (TOTDEV, ratio 2).
        let oct = |r| averaging_factors(&TauSpec::Octave, r, u64::MAX, 1001, 1.0).unwrap();
        assert_eq!(*oct(5).last().unwrap(), 128);
        assert_eq!(*oct(4).last().unwrap(), 128);
        assert_eq!(*oct(2).last().unwrap(), 256);
        // GPS, 241218 phase points, ADEV decade ends at 40000 (stable32_ADEV_decade.txt).
        let dec = averaging_factors(&TauSpec::Decade, 5, u64::MAX, 241_218, 1.0).unwrap();
        assert_eq!(dec[..7], [1, 2, 4, 10, 20, 40, 100]);
        assert_eq!(*dec.last().unwrap(), 40_000);
        let pd = averaging_factors(&TauSpec::PerDecade(10), 4, u64::MAX, 1001, 1.0).unwrap();
        assert_eq!(pd[..8], [1, 2, 3, 4, 5, 6, 8, 10]);
        let ex = averaging_factors(&TauSpec::Explicit(vec![20.0, 2.0, 2.2, 1e9]), 4, 300, 1001, 2.0).unwrap();
        assert_eq!(ex, [1, 10]);
    }
}

//! One call from data to a Stable32-like table: tau list, deviations, noise type, EDF and confidence interval.
//!
//! Each row carries what Stable32 prints (AF = m, tau, `#` = n, alpha, min sigma, sigma, max sigma) plus the EDF.
//! The interval is the chi-square one on the deviation ([`super::edf::confidence_interval`]) with:
//! - Greenhall's EDF for ADEV (d = 2, F = m, S = 1), OADEV (S = m), MDEV and TDEV (F = 1, S = m), HDEV (d = 3,
//!   S = 1), OHDEV (d = 3, S = m), with N = the number of phase points;
//! - NIST SP 1065's TOTDEV formula (Table 11) for TOTDEV.
//!
//! The noise type is identified at every m ([`super::noise_id`]): lag-1 autocorrelation with at least 30 points,
//! else the B1 ratio (with R(n) for PM noise); alpha is limited to the statistic's convergent range (>= -2 for
//! the Allan family, >= -4 for Hadamard), as the EDF needs `alpha + 2 d > 1`.
//!
//! Work per tau is O(N) and taus run in parallel (rayon) unless [`Options::parallel`] is off.
//!
//! # Examples
//! ```
//! use octavar_stats::{analyze, DataKind, Options, Statistic, TauSpec};
//! // 1000 samples of a deterministic pseudo-random frequency record (NBS-14's generator).
//! let mut n: u64 = 1_234_567_890;
//! let y: Vec<f64> = (0..1000).map(|_| { let v = n as f64 / 2147483647.0; n = n * 16807 % 2147483647; v }).collect();
//! let rows = analyze(&y, DataKind::Frequency, 1.0, Statistic::Oadev, &TauSpec::Octave, &Options::default()).unwrap();
//! assert_eq!(rows[0].n, 999);
//! assert!((rows[0].dev - 0.2922319).abs() < 1e-6);
//! assert!(rows[0].lo < rows[0].dev && rows[0].dev < rows[0].hi);
//! ```

use rayon::prelude::*;

use super::deviation::{deviation_at, deviations_at, RawDeviation, Statistic};
use super::error::StatsError;
use super::noise_id::identify_with;
use super::point::{row, DevPoint, Options};
use super::series::{DataKind, Series, GROUP_LEN};

/// Records from this many samples on take the OADEV sums of the smaller averaging factors in the pass that
/// builds the phase.
const FUSED_MIN_SAMPLES: usize = 4 * GROUP_LEN;

use super::taus::{averaging_factors, TauSpec};

/// Analyse `data` (phase or frequency, one sample every `tau0_s` seconds) with statistic `stat` at the taus of
/// `taus`.
///
/// # Errors
/// See [`Series::new`]; also [`StatsError::BadConfidence`], [`StatsError::BadTau`], and [`StatsError::NoTau`]
/// when no requested tau can be computed.
pub fn analyze(
    data: &[f64],
    kind: DataKind,
    tau0_s: f64,
    stat: Statistic,
    taus: &TauSpec,
    opts: &Options,
) -> Result<Vec<DevPoint>, StatsError> {
    if stat == Statistic::Oadev && kind == DataKind::Frequency {
        // Long gap-free records: no phase array (see `octave`).
        if let Some(rows) = super::octave::analyze_octave(data, tau0_s, taus, opts) {
            return rows;
        }
    }
    if matches!(stat, Statistic::Adev | Statistic::Hdev) && kind == DataKind::Frequency {
        // Gap-free records at power-of-two taus: block sums of the samples (see `blocks`).
        if let Some(rows) = super::blocks::analyze_blocks(data, tau0_s, stat, taus, opts) {
            return rows;
        }
    }
    let series = if stat == Statistic::Oadev && opts.parallel && data.len() >= FUSED_MIN_SAMPLES {
        // The smaller averaging factors are summed in the pass that builds the phase (a shorter record has too
        // few groups of that pass to keep every core busy: the blocked kernel takes them all).
        Series::with_oadev(data, kind, tau0_s, |n_phase| {
            averaging_factors(taus, stat.stop_ratio(), stat.m_limit(n_phase), n_phase, tau0_s)
                .map(|ms| ms.iter().map(|&m| m as usize).collect())
                .unwrap_or_default()
        })?
    } else {
        Series::new(data, kind, tau0_s)?
    };
    analyze_series(&series, stat, taus, opts)
}

/// As [`analyze`], on a prepared [`Series`] (prepare once, analyse several statistics).
///
/// # Errors
/// As [`analyze`].
pub fn analyze_series(
    series: &Series,
    stat: Statistic,
    taus: &TauSpec,
    opts: &Options,
) -> Result<Vec<DevPoint>, StatsError> {
    if opts.intervals && !(opts.confidence > 0.0 && opts.confidence < 1.0) {
        return Err(StatsError::BadConfidence(opts.confidence));
    }
    let n_phase = series.n_phase();
    let ms = averaging_factors(taus, stat.stop_ratio(), stat.m_limit(n_phase), n_phase, series.tau0_s())?;
    let ms: Vec<usize> = ms.iter().map(|&m| m as usize).collect();
    let estimates = if opts.parallel {
        deviations_at(series, stat, &ms)
    } else {
        ms.iter().map(|&m| deviation_at(series, stat, m)).collect()
    };
    let row = |(&m, est): (&usize, &Option<RawDeviation>)| est.map(|e| point(series, stat, m, e, opts));
    let rows: Vec<DevPoint> = if opts.parallel && opts.intervals {
        ms.par_iter().zip(estimates.par_iter()).filter_map(row).collect()
    } else {
        ms.iter().zip(estimates.iter()).filter_map(row).collect()
    };
    if rows.is_empty() {
        return Err(StatsError::NoTau { n_phase, gaps: series.gap_count() });
    }
    Ok(rows)
}

/// One row at averaging factor m.
fn point(series: &Series, stat: Statistic, m: usize, est: RawDeviation, opts: &Options) -> DevPoint {
    row(m, series.tau0_s(), series.n_phase(), stat, est, opts, || identify_with(series, stat, m, Some(est.dev)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The same record gives the same bits on one thread and on several, for each path of the parallel sums: the
    /// phase-free octave OADEV, OADEV at decade taus (the fused sums and the far levels), OHDEV (the blocked
    /// pass) and the phase-data OADEV. With rayon's fold and reduce, the last bits moved with the threads.
    #[test]
    fn results_do_not_depend_on_the_number_of_threads() {
        let white = crate::test_signals::white(1 << 20, 8);
        let mut walk = 0.0;
        let y: Vec<f64> = white
            .iter()
            .map(|w| {
                walk += 1e-3 * w;
                w + walk
            })
            .collect();
        let opts = Options::default();
        let cases = [
            (DataKind::Frequency, Statistic::Oadev, TauSpec::Octave),
            (DataKind::Frequency, Statistic::Oadev, TauSpec::Explicit(vec![1.0, 3.0, 40_000.0, 2.0 * 16_384.0])),
            (DataKind::Frequency, Statistic::Ohdev, TauSpec::Octave),
            (DataKind::Phase, Statistic::Oadev, TauSpec::Decade),
        ];
        for (kind, stat, taus) in cases {
            let run = |threads: usize| {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                let rows = pool.install(|| analyze(&y, kind, 1.0, stat, &taus, &opts).unwrap());
                rows.iter().map(|r| (r.m, r.dev.to_bits(), r.lo.to_bits())).collect::<Vec<_>>()
            };
            let one = run(1);
            assert!(one.len() >= 4, "{stat:?} {taus:?}: {} taus", one.len());
            for threads in [2, 3, 4] {
                assert_eq!(run(threads), one, "{kind:?} {stat:?} {taus:?} on {threads} threads");
            }
        }
    }

    /// A record whose every other sample is a gap has no two whole clusters side by side at any tau: the error
    /// says so, with the share of gaps, instead of only that no tau could be computed.
    #[test]
    fn no_tau_in_a_record_of_dense_gaps_names_the_gaps() {
        let y: Vec<f64> = (0..1000).map(|i| if i % 2 == 1 { f64::NAN } else { (i % 7) as f64 }).collect();
        let e =
            analyze(&y, DataKind::Frequency, 1.0, Statistic::Oadev, &TauSpec::Octave, &Options::default()).unwrap_err();
        let StatsError::NoTau { n_phase, gaps } = e else { panic!("{e:?}") };
        // 999 samples after trimming, 1000 phase points; the 499 NaN samples leave 499 intervals undefined.
        assert_eq!((n_phase, gaps), (1000, 499), "{e}");
        assert!(e.to_string().contains("50%, fall in gaps"), "{e}");
        let whole = vec![1.0; 1000];
        assert!(
            analyze(&whole, DataKind::Frequency, 1.0, Statistic::Oadev, &TauSpec::Octave, &Options::default()).is_ok()
        );
    }

    /// A corrupted sample of 1e200 (its square overflows) is named, with its index, on the phase-free octave path
    /// (a long gap-free record), on the phase-array path and for phase data, instead of every deviation reading
    /// infinity; 1e99 is still a sample, and the deviations stay finite.
    #[test]
    fn a_sample_too_large_to_square_is_named() {
        let white = crate::test_signals::white(1 << 17, 5);
        let cases = [
            (DataKind::Frequency, Statistic::Oadev, TauSpec::Octave),
            (DataKind::Frequency, Statistic::Oadev, TauSpec::Explicit(vec![3.0, 5.0])),
            (DataKind::Frequency, Statistic::Mdev, TauSpec::Octave),
            (DataKind::Phase, Statistic::Oadev, TauSpec::Octave),
        ];
        for at in [0, 777, (1 << 17) - 1] {
            for sign in [1.0, -1.0] {
                let mut y = white.clone();
                y[at] = sign * 1e200;
                for (kind, stat, taus) in &cases {
                    let e = analyze(&y, *kind, 1.0, *stat, taus, &Options::default()).unwrap_err();
                    assert_eq!(e, StatsError::TooLarge { index: at, value: sign * 1e200 }, "{kind:?} {stat:?} at {at}");
                    assert!(e.to_string().starts_with(&format!("sample {at} is ")), "{e}");
                }
                y[at] = sign * 1e99;
                let rows =
                    analyze(&y, DataKind::Frequency, 1.0, Statistic::Oadev, &TauSpec::Octave, &Options::default())
                        .unwrap();
                assert!(rows.iter().all(|r| r.dev.is_finite() && r.dev > 0.0));
            }
        }
    }

    /// Process CPU time, s (both cores summed): steadier than wall time on a loaded machine.
    fn cpu_s() -> f64 {
        let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
        // SAFETY: a valid out-pointer.
        unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
        ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
    }

    /// Best wall and CPU time of `reps` runs, ms.
    fn timed<R>(reps: usize, mut f: impl FnMut() -> R) -> (f64, f64, R) {
        let (mut wall, mut cpu, mut out) = (f64::INFINITY, f64::INFINITY, None);
        for _ in 0..reps {
            let (c0, t0) = (cpu_s(), std::time::Instant::now());
            let r = f();
            wall = wall.min(t0.elapsed().as_secs_f64() * 1e3);
            cpu = cpu.min((cpu_s() - c0) * 1e3);
            out = Some(r);
        }
        (wall, cpu, out.unwrap())
    }

    /// Timing of OADEV at octave tau on 1e7 frequency samples; run with
    /// `cargo test --release -p octavar-stats --lib speed_oadev -- --ignored --nocapture`.
    /// (allantools 2024.6, numpy, same machine: about 1.0 s for the same 22 taus.)
    #[test]
    #[ignore]
    fn speed_oadev_octave_1e7() {
        let mut g = crate::test_signals::Lcg::new(0x9E37_79B9_7F4A_7C15);
        let y: Vec<f64> = (0..10_000_000).map(|_| g.uniform() - 0.5).collect();
        let (w, c, series) = timed(5, || Series::new(&y, DataKind::Frequency, 1.0).unwrap());
        println!("Series::new: {w:.1} ms wall, {c:.1} ms cpu");
        let ms: Vec<usize> = (0..22).map(|k| 1usize << k).collect();
        let (w, c, _) = timed(5, || deviations_at(&series, Statistic::Oadev, &ms));
        println!("deviations_at (22 octaves): {w:.1} ms wall, {c:.1} ms cpu");
        for m in [1usize, 64, 1 << 19, 1 << 21] {
            let e = deviation_at(&series, Statistic::Oadev, m).unwrap();
            let (w, c, id) = timed(3, || identify_with(&series, Statistic::Oadev, m, Some(e.dev)));
            println!("identify m={m}: {w:.1} ms wall, {c:.1} ms cpu ({id:?})");
        }
        for (label, intervals) in [("deviations only", false), ("with noise ID + EDF + CI", true)] {
            let opts = Options { intervals, ..Options::default() };
            let (w, c, rows) =
                timed(5, || analyze(&y, DataKind::Frequency, 1.0, Statistic::Oadev, &TauSpec::Octave, &opts).unwrap());
            println!("OADEV octave 1e7 ({label}): {w:.1} ms wall, {c:.1} ms cpu, {} taus", rows.len());
        }
    }
}

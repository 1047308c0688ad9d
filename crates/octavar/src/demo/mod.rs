//! `octavar demo`: the paper's experiment on the virtual bench.
//!
//! Four gyros (ENV-05H, IDG-1215 Y, IDG-1215 X, ADXRS300) with the paper's Table 1 values of N and B, a
//! plausible rate random walk, the bench's 600 Hz anti-alias low-pass, 12-bit ADC codes and the lab's
//! temperature (22-25 degC on a 24 h cycle) coupled into each bias through a thermal lag, sampled at 2 kS/s per
//! channel for 72 h by default. Each channel's codes go through the firmware's accumulator (shared::acc with
//! S = 8); the host reads the snapshots, fits the IEEE 952 terms and prints the recovered Table 1 beside the
//! paper's. Channels run in parallel, one per core.

use std::sync::atomic::{AtomicU64, Ordering};

use octavar_shared::acc::{OctaveAllan, Snapshot};
use octavar_shared::sensor::{Channel, GyroModel, SensorKind};
use octavar_shared::sim::{Bench, BenchSim, ChannelSim, GyroSim, TempCoupling, TemperatureProfile, Wander};
use rayon::prelude::*;
use serde::Serialize;

use crate::fit::{fit_deviations, FitOptions, NoiseFit};
use crate::stats::strided::snapshot_points;
use crate::stats::DevPoint;

/// Sample rate of the bench, per channel (Hz).
pub const BENCH_RATE_HZ: f64 = 2000.0;
/// The anti-alias low-pass in front of the ADC (Hz).
pub const ANTI_ALIAS_HZ: f64 = 600.0;
/// The accumulator stride the firmware uses.
pub const STRIDE: usize = 8;

/// One row of the paper's Table 1 and how octavar's bench models that part.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PaperChannel {
    /// Label as in the paper.
    pub label: &'static str,
    /// The part.
    pub sensor: SensorKind,
    /// The paper's angle random walk, deg/sqrt(s).
    pub paper_n: f64,
    /// The paper's bias instability, deg/s.
    pub paper_b: f64,
    /// The rate random walk the bench adds (not in Table 1): its +1/2 slope crosses the floor at about ten hours.
    pub k: f64,
    /// Temperature coefficient of the bias, deg/s per degC (a plausible value; not in Table 1).
    pub dps_per_c: f64,
    /// Thermal lag of the part, s.
    pub lag_s: f64,
}

/// The paper's Table 1 (ENV-05H, IDG-1215 Y, IDG-1215 X, ADXRS300), in the bench's channel order.
pub const TABLE1: [PaperChannel; 4] = [
    PaperChannel {
        label: "ENV-05H",
        sensor: SensorKind::Env05h,
        paper_n: 4.0e-4,
        paper_b: 9.5e-4,
        k: 4.0e-6,
        dps_per_c: 5.0e-3,
        lag_s: 900.0,
    },
    PaperChannel {
        label: "IDG1215 Y",
        sensor: SensorKind::Idg1215Y,
        paper_n: 3.0e-3,
        paper_b: 13e-3,
        k: 5.0e-5,
        dps_per_c: 5.0e-2,
        lag_s: 600.0,
    },
    PaperChannel {
        label: "IDG1215 X",
        sensor: SensorKind::Idg1215X,
        paper_n: 3.2e-3,
        paper_b: 14e-3,
        k: 5.5e-5,
        dps_per_c: 5.0e-2,
        lag_s: 600.0,
    },
    PaperChannel {
        label: "ADXRS300",
        sensor: SensorKind::Adxrs300,
        paper_n: 46e-3,
        paper_b: 26e-3,
        k: 1.0e-4,
        dps_per_c: 1.0e-1,
        lag_s: 1200.0,
    },
];

/// The lab: 22-25 degC over a 24 h cycle, with the air conditioning's wander of 0.3 degC over 20 minutes.
pub fn lab_temperature() -> TemperatureProfile {
    TemperatureProfile {
        min_c: 22.0,
        max_c: 25.0,
        period_s: 86_400.0,
        phase_rad: 0.0,
        wander: Some(Wander { sigma_c: 0.3, tau_s: 1200.0 }),
    }
}

/// The paper's bench as a simulation model.
pub fn paper_bench(seed: u64) -> BenchSim {
    let mut channels = heapless::Vec::new();
    for p in TABLE1 {
        let gyro = GyroSim {
            bias_dps: 0.0,
            n_deg_per_rt_s: p.paper_n,
            b_dps: p.paper_b,
            k_dps_per_rt_s: p.k,
            bandwidth_hz: Some(ANTI_ALIAS_HZ),
            temperature: Some(TempCoupling { dps_per_c: p.dps_per_c, ref_c: 23.5, lag_s: p.lag_s }),
            ..Default::default()
        };
        let _ = channels.push(ChannelSim { sensor: p.sensor, channel: None, gyro });
    }
    BenchSim { rate_hz: BENCH_RATE_HZ, seed, temperature: lab_temperature(), channels }
}

/// What one channel of the bench produced: its snapshots in time order (one every `snapshot_every` samples and
/// the last), and its rate and temperature averaged over blocks of `decimate` samples (deg/s, degC), the record
/// the gap diagnosis reads.
#[derive(Clone, Debug)]
pub struct ChannelRun {
    /// Snapshots, oldest first.
    pub snapshots: Vec<Snapshot>,
    /// Block means of the rate the ADC reports, deg/s.
    pub rate_dps: Vec<f64>,
    /// Block means of the bench temperature, degC.
    pub temp_c: Vec<f64>,
}

/// Run a bench for `samples` scans and accumulate each channel's codes as the firmware does (S = 8). The channels
/// are split into as many groups as rayon has threads (two on a 2-core machine: channels 0-1 and 2-3), and the
/// groups run in parallel, each with [`Bench::only_channels`], which gives exactly the samples the whole bench
/// would; a group computes the bench temperature once for all of its channels. `progress` receives the scans done
/// so far (averaged over channels).
///
/// # Errors
/// The model's own errors ([`octavar_shared::sim::SimError`]).
pub fn accumulate_bench(
    model: &BenchSim,
    samples: u64,
    snapshot_every: u64,
    decimate: u64,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Vec<ChannelRun>, octavar_shared::sim::SimError> {
    let n_ch = model.channels.len();
    let per_group = n_ch.div_ceil(rayon::current_num_threads().max(1)).max(1);
    let indices: Vec<usize> = (0..n_ch).collect();
    let done = AtomicU64::new(0);
    let groups: Vec<Vec<ChannelRun>> = indices
        .par_chunks(per_group)
        .map(|group| {
            let bench = Bench::only_channels(model, group)?;
            Ok(accumulate_group(bench, samples, snapshot_every, decimate, &|n| {
                let total = done.fetch_add(n, Ordering::Relaxed) + n;
                progress(total / n_ch as u64);
            }))
        })
        .collect::<Result<_, octavar_shared::sim::SimError>>()?;
    Ok(groups.into_iter().flatten().collect())
}

/// [`accumulate_bench`] for one group of channels on one thread: `done` receives the channel-samples of each
/// block as it ends.
fn accumulate_group(
    mut bench: Bench,
    samples: u64,
    snapshot_every: u64,
    decimate: u64,
    done: &dyn Fn(u64),
) -> Vec<ChannelRun> {
    const BLOCK: usize = 8000;
    let every = snapshot_every.max(1);
    let decimate = decimate.max(1);
    let channels = bench.channels().to_vec();
    let k = channels.len();
    let mut accs: Vec<Box<OctaveAllan<STRIDE>>> = (0..k).map(|_| Box::new(OctaveAllan::new())).collect();
    let mut runs = vec![ChannelRun { snapshots: Vec::new(), rate_dps: Vec::new(), temp_c: Vec::new() }; k];
    let mut blocks = vec![[0u16; BLOCK]; k];
    let mut temps = [0.0f64; BLOCK];
    let (mut sum_codes, mut sum_temp, mut in_block) = (vec![0u64; k], 0.0f64, 0u64);
    let mut count = 0u64;
    while count < samples {
        // Blocks end on snapshot instants, as the firmware's rounds do.
        let to_snap = every - count % every;
        let n = (BLOCK as u64).min(samples - count).min(to_snap) as usize;
        let mut views: Vec<&mut [u16]> = blocks.iter_mut().map(|b| &mut b[..n]).collect();
        bench.fill_block(&mut temps[..n], &mut views);
        // Block means for the gap diagnosis: the decimation runs across the snapshot blocks.
        let mut j = 0;
        while j < n {
            let take = ((decimate - in_block) as usize).min(n - j);
            for (block, sum) in blocks.iter().zip(&mut sum_codes) {
                *sum += block[j..j + take].iter().map(|&c| u64::from(c)).sum::<u64>();
            }
            for &t in &temps[j..j + take] {
                sum_temp += t;
            }
            in_block += take as u64;
            j += take;
            if in_block == decimate {
                for ((run, sum), ch) in runs.iter_mut().zip(&mut sum_codes).zip(&channels) {
                    // The mean of the codes, converted through the (affine) channel model.
                    let mean = *sum as f64 / decimate as f64;
                    let lo = ch.code_to_dps(0);
                    run.rate_dps.push(lo + mean * (ch.code_to_dps(1) - lo));
                    run.temp_c.push(sum_temp / decimate as f64);
                    *sum = 0;
                }
                (sum_temp, in_block) = (0.0, 0);
            }
        }
        count += n as u64;
        for ((acc, block), run) in accs.iter_mut().zip(&blocks).zip(&mut runs) {
            acc.push_slice(&block[..n]);
            if count.is_multiple_of(every) || count == samples {
                run.snapshots.push(acc.snapshot());
            }
        }
        done((n * k) as u64);
    }
    runs
}

/// The device's frames for the snapshots of every channel: a hello (the demo's channels in bench order, its
/// sample rate and the firmware's stride), then, round after round, each channel's snapshot parts, as the
/// device core sends them. This is the capture the host would have recorded.
pub fn snapshot_capture(snapshots: &[Vec<Snapshot>]) -> Vec<u8> {
    use octavar_shared::device::{ChannelSpec, DeviceConfig};
    use octavar_shared::proto::{Encoder, Frame, SnapshotPart};
    const CHANNELS: [ChannelSpec<'static>; TABLE1.len()] = {
        let mut out = [ChannelSpec { kind: SensorKind::Generic, name: "" }; TABLE1.len()];
        let mut i = 0;
        while i < TABLE1.len() {
            out[i] = ChannelSpec { kind: TABLE1[i].sensor, name: TABLE1[i].label };
            i += 1;
        }
        out
    };
    let cfg = DeviceConfig {
        channels: &CHANNELS,
        gyros: TABLE1.len(),
        temp_channel: None,
        rate_hz: BENCH_RATE_HZ as u32,
        firmware: concat!("octavar demo ", env!("CARGO_PKG_VERSION")),
        ..DeviceConfig::F405
    };
    let mut enc = Encoder::new();
    let mut out = Vec::new();
    let mut put = |enc: &mut Encoder, f: &Frame| {
        let bytes = enc.encode_to_vec(f).expect("every frame fits its buffer");
        out.extend_from_slice(&bytes);
    };
    put(&mut enc, &cfg.hello());
    let rounds = snapshots.iter().map(Vec::len).max().unwrap_or(0);
    for r in 0..rounds {
        for (ch, snaps) in snapshots.iter().enumerate() {
            if let Some(snap) = snaps.get(r) {
                for part in SnapshotPart::split(ch as u8, snap) {
                    put(&mut enc, &Frame::AllanSnapshot(part));
                }
            }
        }
    }
    out
}

/// Decode a capture and keep the last snapshot of each channel (the host side of the pipeline).
///
/// # Errors
/// A capture with damaged frames or no snapshot for a channel (the demo's own capture has neither).
pub fn last_snapshots(capture: &[u8], channels: usize) -> Result<Vec<Snapshot>, String> {
    use crate::io::decode::{CaptureReader, Message};
    let mut last: Vec<Option<Snapshot>> = vec![None; channels];
    let mut reader = CaptureReader::new(capture, "demo capture");
    for item in reader.by_ref() {
        let d = item.map_err(|e| e.to_string())?;
        if let Message::Snapshot(cs) = d.message {
            if let Some(slot) = last.get_mut(usize::from(cs.channel)) {
                *slot = Some(cs.snapshot);
            }
        }
    }
    let stats = reader.stats();
    if stats.bad_frame_count() > 0 || stats.lost_frames > 0 {
        return Err(format!(
            "the demo capture decoded with {} bad and {} lost frames",
            stats.bad_frame_count(),
            stats.lost_frames
        ));
    }
    last.into_iter()
        .enumerate()
        .map(|(i, s)| s.ok_or_else(|| format!("no snapshot of channel {i} in the capture")))
        .collect()
}

/// Keep freed blocks of up to 32 MB in the process for reuse (glibc's malloc; elsewhere nothing). By default glibc
/// maps every block above 128 KB afresh (its threshold rises only as such blocks are freed) and gives the top of
/// the heap back above 128 KB; the gap diagnoses allocate and free records of megabytes thousands of times, and
/// faulting those pages in again took about 15% of their time (1.7 of 11 CPU-s of the demo's four diagnoses); the
/// peak memory stays about the same (210-270 MB). The setting is process-wide: `octavar demo` and its benchmark
/// make it before the run.
pub fn retain_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only sets two of malloc's tuning parameters; it takes no pointers.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 1 << 30);
    }
}

/// Seconds per sample of the record the gap diagnosis reads (block means of the 2 kS/s codes): the temperature
/// lives at long tau, and a 1 Hz record of 72 h keeps the diagnosis to seconds per channel.
pub const GAP_BLOCK_S: f64 = 1.0;

/// Sub-samples per 1 Hz sample in the gap ensemble: each simulated sample is the mean of 16, so the members have
/// the block mean's sinc response that the real 1 Hz means have (simulated at 1 Hz, white noise is flat to the
/// Nyquist frequency and the PSD view shows a gap of 20 or more near 0.5 Hz that no gyro effect explains); 16
/// sub-samples match the continuous block mean within 1% of power below 0.4 Hz.
pub const GAP_OVERSAMPLE: usize = 16;

/// The gap diagnosis of one channel: its 1 Hz record with the bench temperature, the part after the middle
/// snapshot held out. The base model is the IEEE fit of the training part's own full-rate snapshot (the device's
/// snapshot at the middle of the record), because a 1 Hz record cannot show the white-noise line.
///
/// # Errors
/// As [`crate::gap::diagnose`].
pub fn diagnose_channel(
    run: &ChannelRun,
    paper: &PaperChannel,
    progress: &crate::gap::ProgressFn,
) -> Result<crate::gap::GapReport, crate::gap::GapError> {
    let train = training_snapshot(run);
    let channel = Channel::bench(GyroModel::of(paper.sensor).expect("the paper's channels are gyros"));
    let points = snapshot_points(&train, BENCH_RATE_HZ, channel.dps_per_code(), 0.683);
    let base_fit = fit_deviations(&points, Some(&bench_fit_options())).ok();
    let opts = crate::gap::GapOptions { base_fit, oversample: GAP_OVERSAMPLE, ..Default::default() };
    crate::gap::diagnose(&gap_input(run), &opts, progress)
}

/// The record [`diagnose_channel`] diagnoses (and the gap figure draws): the channel's 1 Hz means with the bench
/// temperature, training up to the middle snapshot.
pub fn gap_input(run: &ChannelRun) -> crate::gap::GapInput {
    let decimate = (GAP_BLOCK_S * BENCH_RATE_HZ) as u64;
    crate::gap::GapInput {
        rate_dps: run.rate_dps.clone(),
        temp_c: Some(run.temp_c.clone()),
        rate_hz: 1.0 / GAP_BLOCK_S,
        n_train: (training_snapshot(run).samples / decimate) as usize,
    }
}

/// The device's snapshot nearest the middle of the record: the training part ends there.
fn training_snapshot(run: &ChannelRun) -> Snapshot {
    let decimate = (GAP_BLOCK_S * BENCH_RATE_HZ) as u64;
    let total = run.rate_dps.len() as u64 * decimate;
    run.snapshots
        .iter()
        .min_by_key(|s| s.samples.abs_diff(total / 2))
        .copied()
        .unwrap_or_else(|| Snapshot::empty(STRIDE).expect("stride 8 is valid"))
}

/// [`diagnose_channel`] for every channel of a bench run (`runs` in [`TABLE1`]'s order), the channels at once:
/// each diagnosis also runs its ensemble's members in parallel, and the others fill its serial stretches (the
/// fits, the views of the record). `progress(channel, done, total)` follows each one.
pub fn diagnose_channels(
    runs: &[ChannelRun],
    progress: &(dyn Fn(usize, usize, usize) + Sync),
) -> Vec<Result<crate::gap::GapReport, crate::gap::GapError>> {
    runs.par_iter()
        .zip(TABLE1.par_iter())
        .enumerate()
        .map(|(i, (run, paper))| diagnose_channel(run, paper, &|_, done, total| progress(i, done, total)))
        .collect()
}

/// The fit of the bench's full-rate snapshots: the white term shaped by the 600 Hz anti-alias filter, and the
/// first octaves (m < 16, tau < 8 ms), where the discrete filter's shape differs from the continuous form the fit
/// uses and whose huge EDF would let that pull N, left out.
pub fn bench_fit_options() -> FitOptions {
    FitOptions { bandwidth_hz: Some(ANTI_ALIAS_HZ), tau_min_s: 16.0 / BENCH_RATE_HZ, ..Default::default() }
}

/// One channel's outcome.
#[derive(Clone, Debug)]
pub struct ChannelResult {
    /// The paper's row.
    pub paper: PaperChannel,
    /// The channel wiring (deg/s per code).
    pub channel: Channel,
    /// The device snapshot.
    pub snapshot: Snapshot,
    /// Allan deviation points in deg/s with 68.3% intervals.
    pub points: Vec<DevPoint>,
    /// The IEEE 952 fit.
    pub fit: NoiseFit,
}

/// One row of `table1.json`.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Table1Row {
    /// Channel label.
    pub channel: String,
    /// Recovered N, deg/sqrt(s).
    #[serde(rename = "N")]
    pub n: Option<f64>,
    /// Recovered B, deg/s.
    #[serde(rename = "B")]
    pub b: Option<f64>,
    /// The paper's N, deg/sqrt(s).
    #[serde(rename = "paper_N")]
    pub paper_n: f64,
    /// The paper's B, deg/s.
    #[serde(rename = "paper_B")]
    pub paper_b: f64,
}

/// Analyse each channel's snapshot: ADEV points and the fit (the white term shaped by the anti-alias filter).
pub fn analyse(snapshots: &[Snapshot], model: &BenchSim) -> Vec<ChannelResult> {
    snapshots
        .iter()
        .zip(TABLE1)
        .zip(&model.channels)
        .map(|((snap, paper), cs)| {
            let channel = cs
                .channel
                .unwrap_or_else(|| Channel::bench(GyroModel::of(cs.sensor).expect("the paper's channels are gyros")));
            let points = snapshot_points(snap, model.rate_hz, channel.dps_per_code(), 0.683);
            let opts = FitOptions {
                bandwidth_hz: cs.gyro.bandwidth_hz,
                tau_min_s: 16.0 / model.rate_hz,
                ..bench_fit_options()
            };
            let fit = fit_deviations(&points, Some(&opts)).expect("a 2 kS/s record has many octaves");
            ChannelResult { paper, channel, snapshot: *snap, points, fit }
        })
        .collect()
}

/// The recovered Table 1.
pub fn table1(results: &[ChannelResult]) -> Vec<Table1Row> {
    results
        .iter()
        .map(|r| Table1Row {
            channel: r.paper.label.to_string(),
            n: r.fit.n.value,
            b: r.fit.b.value,
            paper_n: r.paper.paper_n,
            paper_b: r.paper.paper_b,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn snapshots_survive_the_frame_pipeline_bit_for_bit() {
        let mut model = paper_bench(3);
        model.rate_hz = 200.0;
        let runs = accumulate_bench(&model, 20_000, 2_000, 200, &|_| {}).unwrap();
        assert!(runs.iter().all(|r| r.rate_dps.len() == 100 && r.temp_c.len() == 100));
        let snaps: Vec<Vec<Snapshot>> = runs.into_iter().map(|r| r.snapshots).collect();
        assert!(snaps.iter().all(|s| s.len() == 10));
        let capture = snapshot_capture(&snaps);
        let last = last_snapshots(&capture, 4).unwrap();
        for (decoded, sent) in last.iter().zip(&snaps) {
            assert_eq!(decoded, sent.last().unwrap());
        }
        // A damaged capture is refused, not analysed.
        let mut bad = capture.clone();
        let mid = bad.len() / 2;
        bad[mid] ^= 0x40;
        assert!(last_snapshots(&bad, 4).is_err());
    }

    /// The grouped, blocked run equals the plainest replay: the whole bench scan by scan, every code pushed into
    /// its channel's accumulator one at a time, a snapshot at every `every` samples and at the end, the block
    /// means formed from the scans. Run on one thread and on two, so that one group of four and two groups of two
    /// are both checked, with a snapshot interval that is no multiple of the block.
    #[test]
    fn grouped_runs_equal_the_whole_bench_replayed_scan_by_scan() {
        let mut model = paper_bench(5);
        model.rate_hz = 200.0;
        let (samples, every, decimate) = (23_456u64, 9_001u64, 200u64);
        let mut bench = Bench::new(&model).unwrap();
        let mut accs: Vec<OctaveAllan<STRIDE>> = (0..4).map(|_| OctaveAllan::new()).collect();
        let mut want = vec![ChannelRun { snapshots: Vec::new(), rate_dps: Vec::new(), temp_c: Vec::new() }; 4];
        let (mut sums, mut temp) = ([0u64; 4], 0.0);
        for t in 1..=samples {
            let s = bench.next_sample();
            temp += s.temp_c;
            for (i, acc) in accs.iter_mut().enumerate() {
                acc.push(s.codes[i]);
                sums[i] += u64::from(s.codes[i]);
                if t % every == 0 || t == samples {
                    want[i].snapshots.push(acc.snapshot());
                }
            }
            if t % decimate == 0 {
                for (i, run) in want.iter_mut().enumerate() {
                    let ch = bench.channels()[i];
                    let lo = ch.code_to_dps(0);
                    run.rate_dps.push(lo + sums[i] as f64 / decimate as f64 * (ch.code_to_dps(1) - lo));
                    run.temp_c.push(temp / decimate as f64);
                    sums[i] = 0;
                }
                temp = 0.0;
            }
        }
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let got = pool.install(|| accumulate_bench(&model, samples, every, decimate, &|_| {})).unwrap();
            assert_eq!(got.len(), 4);
            for (g, w) in got.iter().zip(&want) {
                assert_eq!(g.snapshots, w.snapshots, "{threads} thread(s)");
                assert_eq!((&g.rate_dps, &g.temp_c), (&w.rate_dps, &w.temp_c), "{threads} thread(s)");
            }
        }
        assert_eq!(want[0].snapshots.len(), 3);
    }

    #[test]
    fn table1_rows_have_the_issues_keys() {
        let row = Table1Row { channel: "ENV-05H".into(), n: Some(4e-4), b: None, paper_n: 4e-4, paper_b: 9.5e-4 };
        let v = serde_json::to_value(&row).unwrap();
        let mut keys: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
        keys.sort_unstable();
        assert_eq!(keys, ["B", "N", "channel", "paper_B", "paper_N"]);
    }

    #[test]
    fn bench_model_is_valid_and_has_the_papers_channels() {
        let m = paper_bench(1);
        assert_eq!(m.channels.len(), 4);
        assert!(Bench::new(&m).is_ok());
        for (c, p) in m.channels.iter().zip(TABLE1) {
            assert_eq!(c.gyro.n_deg_per_rt_s, p.paper_n);
            assert_eq!(c.gyro.b_dps, p.paper_b);
        }
    }
}

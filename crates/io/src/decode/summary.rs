//! What `octavar decode` reports of a capture: its snapshots level by level, statuses and estimates (thinned
//! evenly for long captures), gathered in a [`DecodeSummary`].

use super::*;

/// Keeps at most `cap` items of a series, evenly spaced: when full, every other one is dropped and the
/// spacing doubles.
#[derive(Clone, Debug)]
pub struct Thinned<T> {
    items: Vec<T>,
    step: u64,
    seen: u64,
    cap: usize,
}

impl<T> Thinned<T> {
    /// An empty series keeping at most `cap` items (at least 2).
    pub fn new(cap: usize) -> Self {
        Thinned { items: Vec::new(), step: 1, seen: 0, cap: cap.max(2) }
    }

    /// Offer the next item of the series.
    pub fn push(&mut self, item: T) {
        if self.seen.is_multiple_of(self.step) {
            self.items.push(item);
            if self.items.len() > self.cap {
                let mut i = 0;
                self.items.retain(|_| {
                    i += 1;
                    i % 2 == 1
                });
                self.step *= 2;
            }
        }
        self.seen += 1;
    }

    /// Items offered.
    pub fn seen(&self) -> u64 {
        self.seen
    }

    /// The kept items, and the spacing between them.
    pub fn into_parts(self) -> (Vec<T>, u64) {
        (self.items, self.step)
    }
}

/// One level of a snapshot in the summary.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LevelRow {
    /// Level k: clusters of m = 2^k samples.
    pub level: u8,
    /// Cluster size, samples.
    pub m: u64,
    /// Averaging time, s (`None` without a hello giving the sample rate).
    pub tau_s: Option<f64>,
    /// Second differences.
    pub n: u64,
    /// Their exact sum of squares, codes^2 (a decimal string in JSON).
    #[serde(serialize_with = "decimal")]
    pub sum_sq: u128,
    /// Allan variance, codes^2.
    pub avar_codes2: f64,
    /// Allan deviation, codes.
    pub adev_codes: f64,
}

fn decimal<S: serde::Serializer>(v: &u128, s: S) -> Result<S::Ok, S::Error> {
    s.collect_str(v)
}

/// The rows of every level with n > 0.
pub fn level_rows(snap: &Snapshot, rate_hz: Option<f64>) -> Vec<LevelRow> {
    (0..LEVELS)
        .filter_map(|k| {
            let avar = snap.avar_codes2(k)?;
            let m = 1u64 << k;
            let l = snap.levels[k];
            Some(LevelRow {
                level: k as u8,
                m,
                tau_s: rate_hz.map(|r| m as f64 / r),
                n: l.n,
                sum_sq: l.sum_sq,
                avar_codes2: avar,
                adev_codes: avar.sqrt(),
            })
        })
        .collect()
}

/// Allan deviation in codes at `tau_s`, interpolated log-log between the octaves around it (`None` when the
/// snapshot does not reach both).
pub fn adev_codes_at(snap: &Snapshot, rate_hz: f64, tau_s: f64) -> Option<f64> {
    if !(rate_hz > 0.0 && tau_s > 0.0) {
        return None;
    }
    let x = (tau_s * rate_hz).log2(); // level, fractional
    if x < 0.0 {
        return None;
    }
    let lo = x.floor() as usize;
    let a = snap.adev_codes(lo)?;
    let frac = x - lo as f64;
    if frac == 0.0 {
        return Some(a);
    }
    let b = snap.adev_codes(lo + 1)?;
    if a <= 0.0 || b <= 0.0 {
        return Some(a + (b - a) * frac);
    }
    Some((a.ln() + (b.ln() - a.ln()) * frac).exp())
}

/// A snapshot in the summary.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SnapshotSummary {
    /// Sequence number of its last frame.
    pub frame_seq: u32,
    /// Channel index.
    pub channel: u8,
    /// Channel name from the hello.
    pub name: Option<String>,
    /// Stride S.
    pub stride: u8,
    /// Samples accumulated.
    pub samples: u64,
    /// Allan deviation at tau = 1 s, codes (interpolated between octaves; `None` without a rate or so long a
    /// record).
    pub adev_1s_codes: Option<f64>,
    /// Levels with n > 0.
    pub levels: Vec<LevelRow>,
}

/// A status in the summary.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StatusSummary {
    /// Frame sequence number.
    pub frame_seq: u32,
    /// The status.
    #[serde(flatten)]
    pub status: Status,
}

/// An estimate in the summary.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EstimateSummary {
    /// Frame sequence number.
    pub frame_seq: u32,
    /// The estimate.
    #[serde(flatten)]
    pub estimate: Estimate,
}

/// What `octavar decode` reports: the JSON document.
#[derive(Clone, Debug, Serialize)]
pub struct DecodeSummary {
    /// The capture.
    pub source: String,
    /// The last hello.
    pub hello: Option<Hello>,
    /// Every count.
    pub stats: DecodeStats,
    /// Sample sets received per channel index.
    pub samples_per_channel: BTreeMap<u8, u64>,
    /// The last snapshot of each channel.
    pub snapshots: Vec<SnapshotSummary>,
    /// Statuses (all of them up to [`MAX_SERIES`], evenly thinned beyond).
    pub statuses: Vec<StatusSummary>,
    /// Spacing of the kept statuses (1: all).
    pub statuses_every: u64,
    /// Estimates, kept as statuses are.
    pub estimates: Vec<EstimateSummary>,
    /// Spacing of the kept estimates.
    pub estimates_every: u64,
    /// The field log's snapshots: the newest whole checkpoint's (every session it pools), else the last
    /// field-log snapshot of each channel. `frame_seq` is the checkpoint's number for a whole checkpoint.
    pub field_log: Vec<SnapshotSummary>,
    /// The newest whole field-log checkpoint: what it pools, and the onboard estimate of each channel from it.
    pub field_log_checkpoint: Option<CheckpointSummary>,
    /// CSV files written.
    pub csv_files: Vec<PathBuf>,
}

/// A field-log checkpoint in the summary.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CheckpointSummary {
    /// Its number in the device's log.
    pub checkpoint: u32,
    /// Power-on sessions pooled.
    pub sessions: u32,
    /// Sampling time covered, s.
    pub time_s: u32,
    /// Sample losses over those sessions.
    pub adc_overruns: u32,
    /// Samples per channel.
    pub samples: u64,
    /// The onboard estimate (N, B) of each gyro channel from the checkpoint, as the device computes it.
    pub estimates: Vec<ChannelEstimate>,
}

/// One channel's onboard estimate.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ChannelEstimate {
    /// Channel index.
    pub channel: u8,
    /// Its name from the hello.
    pub name: Option<String>,
    /// Angle random walk N, deg/sqrt(s).
    pub n_dps_per_rt_s: Option<f32>,
    /// Bias instability B, deg/s.
    pub b_dps: Option<f32>,
    /// Where B was read, s.
    pub tau_b_s: Option<f32>,
}

/// Summarise a checkpoint: its counts, and `shared::estimate` on each channel's snapshot (the device's own
/// estimate, in deg/s where the hello names the gyro).
pub(super) fn checkpoint_summary(
    cp: &super::Checkpoint,
    hello: Option<&Hello>,
    rate: Option<f64>,
) -> CheckpointSummary {
    let estimates = cp
        .channels
        .iter()
        .map(|(&channel, snap)| {
            let info = hello.and_then(|h| h.channels.get(usize::from(channel)));
            let cfg = octavar_shared::estimate::EstimateConfig {
                rate_hz: rate.unwrap_or(2000.0) as f32,
                dps_per_code: info.map_or(1.0, |c| octavar_shared::sensor::dps_per_code(c.kind) as f32),
                ..Default::default()
            };
            let e = octavar_shared::estimate::noise_estimate(snap, &cfg);
            ChannelEstimate {
                channel,
                name: info.map(|c| c.name.to_string()),
                n_dps_per_rt_s: e.n_dps_per_rt_s,
                b_dps: e.b_dps,
                tau_b_s: e.tau_b_s,
            }
        })
        .collect();
    CheckpointSummary {
        checkpoint: cp.number,
        sessions: cp.sessions,
        time_s: cp.time_s,
        adc_overruns: cp.adc_overruns,
        samples: cp.samples(),
        estimates,
    }
}

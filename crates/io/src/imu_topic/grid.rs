//! From one topic's messages to samples on a regular grid: times from `header.stamp` (or the log time where no
//! stamp was set), sorted and de-duplicated, the rate from the median step where none is given, each message
//! placed by [`grid_positions`] and the positions between them left NaN, clock jumps refused. The angular velocity
//! becomes channels `x`, `y`, `z` in deg/s and the linear acceleration `ax`, `ay`, `az` in m/s^2 (where the
//! messages give it).

use super::topics::Topic;
use super::{BagError, ImuBag, TimeSource};
use crate::recording::{RateUnit, Recording, StreamInfo};
use octavar_stats::quantity::Quantity;

/// Place samples on a sample grid from their timestamps: the position of each sample, the first at 0.
///
/// `stamps_ns` are increasing times in ns, `rate_hz` the grid's rate. A step of up to 1.5 sample periods is the
/// next sample (real stamps jitter); a longer step of `d` periods skips `round(d) - 1` positions, the samples
/// missing there. The positions increase; the last plus one is the grid's length, and the positions not listed
/// are the gaps. A step that is not positive (stamps out of order or repeated) counts as one sample.
pub fn grid_positions(stamps_ns: &[i64], rate_hz: f64) -> Vec<u64> {
    let mut out = Vec::with_capacity(stamps_ns.len());
    let mut pos = 0u64;
    for (i, &t) in stamps_ns.iter().enumerate() {
        if i > 0 {
            // The step is exact in i128; dividing last keeps a step of exactly 1.5 periods at 1.5.
            let periods = (i128::from(t) - i128::from(stamps_ns[i - 1])) as f64 * rate_hz / 1e9;
            pos += if periods > 1.5 { periods.round() as u64 } else { 1 };
        }
        out.push(pos);
    }
    out
}

/// The recording of one topic's samples: sorted, de-duplicated, placed on the grid.
pub(crate) fn build(path: String, t: Topic, rate_hz: Option<f64>) -> Result<ImuBag, BagError> {
    let mut samples = t.samples;
    let too_few =
        |hint| BagError::TooFewMessages { path: path.clone(), topic: t.name.clone(), messages: t.messages, hint };
    if samples.is_empty() || (samples.len() < 2 && rate_hz.is_none()) {
        return Err(too_few(if samples.is_empty() { "" } else { ": give --rate to read one sample" }));
    }
    let time_source = if samples.iter().all(|s| s.stamp_ns == 0) {
        for s in &mut samples {
            s.stamp_ns = i64::try_from(s.log_time).unwrap_or(i64::MAX);
        }
        TimeSource::LogTime
    } else {
        TimeSource::HeaderStamp
    };

    let mut out_of_order = 0u64;
    let mut latest = i64::MIN;
    for s in &samples {
        if s.stamp_ns < latest {
            out_of_order += 1;
        }
        latest = latest.max(s.stamp_ns);
    }
    if out_of_order > 0 {
        samples.sort_by_key(|s| s.stamp_ns); // Stable: of equal stamps, the first logged stays first.
    }
    let before = samples.len();
    samples.dedup_by_key(|s| s.stamp_ns);
    let duplicates = (before - samples.len()) as u64;
    if samples.len() < 2 && rate_hz.is_none() {
        return Err(too_few(": one distinct stamp; give --rate to read one sample"));
    }

    let stamps: Vec<i64> = samples.iter().map(|s| s.stamp_ns).collect();
    let rate_hz = match rate_hz {
        Some(r) => r,
        None => {
            let mut steps: Vec<i64> = stamps.windows(2).map(|w| w[1] - w[0]).collect();
            let mid = steps.len() / 2;
            let (_, &mut upper, _) = steps.select_nth_unstable(mid);
            let median = if steps.len() % 2 == 1 {
                upper as f64
            } else {
                let lower = *steps[..mid].iter().max().expect("an even count of at least 2");
                (lower as f64 + upper as f64) / 2.0
            };
            1e9 / median
        }
    };

    let positions = grid_positions(&stamps, rate_hz);
    let n = positions.len() as u64;
    let len = positions.last().map_or(0, |p| p + 1);
    if len - n > 9 * n && len > 10_000_000 {
        let (i, jump) = (1..stamps.len()).map(|i| (i, stamps[i] - stamps[i - 1])).max_by_key(|p| p.1).unwrap_or((0, 0));
        return Err(BagError::ClockJump {
            path,
            topic: t.name,
            jump_s: jump as f64 * 1e-9,
            from_ns: stamps[i.saturating_sub(1)],
            to_ns: stamps[i],
            gap_samples: len - n,
            rate_hz,
            messages: n,
        });
    }

    let k = RateUnit::RadPerS.to_dps();
    // The acceleration is read where some message gives it: a gyro-only driver leaves it zero or marks it -1.
    let accel = samples.iter().any(|s| s.a_given && s.a.iter().any(|v| *v != 0.0));
    let mut channels = vec![vec![f64::NAN; len as usize]; if accel { 6 } else { 3 }];
    for (s, &p) in samples.iter().zip(&positions) {
        for (c, w) in channels.iter_mut().zip(s.w) {
            c[p as usize] = w * k;
        }
        if accel && s.a_given {
            for (c, a) in channels[3..].iter_mut().zip(s.a) {
                c[p as usize] = a;
            }
        }
    }
    let gaps = channels.iter().flatten().filter(|v| v.is_nan()).count() as u64;
    let axes: &[&str] = if accel { &["x", "y", "z", "ax", "ay", "az"] } else { &["x", "y", "z"] };
    let names: Vec<String> = axes.iter().map(|s| s.to_string()).collect();
    let quantities =
        names.iter().map(|n| if n.starts_with('a') { Quantity::Acceleration } else { Quantity::AngularRate }).collect();
    let info = StreamInfo { columns: names.clone(), rate_hz, samples: len, gaps, filtered_out: 0 };
    Ok(ImuBag {
        recording: Recording { source: path, names, channels, quantities, temp_c: None, rate_hz, info },
        topic: t.name,
        frame_id: t.frame_id.unwrap_or_default(),
        time_source,
        messages: t.messages,
        out_of_order,
        duplicates,
        start_ns: stamps[0],
    })
}

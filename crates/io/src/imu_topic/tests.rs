//! The grid, and the building of a recording from a topic's samples: sorting, repeated stamps, gaps, the rate,
//! the log-time fallback, clock jumps.

use super::topics::{Sample, Topic};
use super::*;
use crate::recording::RateUnit;

#[test]
fn grid_steps_jitter_and_gaps() {
    let ms = 1_000_000i64; // 200 Hz: 5 ms periods
    assert_eq!(grid_positions(&[], 200.0), Vec::<u64>::new());
    assert_eq!(grid_positions(&[7], 200.0), vec![0]);
    // Regular, then jittered steps up to 1.5 periods: one sample each.
    let t = [0, 5 * ms, 10 * ms, 13 * ms, 20 * ms, 27 * ms + ms / 2];
    assert_eq!(grid_positions(&t, 200.0), vec![0, 1, 2, 3, 4, 5]);
    // 1.6 periods: one missing; 3 periods: two; 2.5 rounds to 3 (two missing); 10.4 periods: nine.
    let t = [0, 8 * ms, 23 * ms, 35 * ms + ms / 2, 87 * ms + ms / 2];
    assert_eq!(grid_positions(&t, 200.0), vec![0, 2, 5, 8, 18]);
    // Steps that are not positive count as one sample.
    assert_eq!(grid_positions(&[10, 10, 5], 200.0), vec![0, 1, 2]);
    // Stamps far from zero (since the epoch) lose nothing.
    let base = 1_700_000_000_123_456_789i64;
    let t: Vec<i64> = [0, 1, 2, 5, 6].iter().map(|k| base + k * 5 * ms).collect();
    assert_eq!(grid_positions(&t, 200.0), vec![0, 1, 2, 5, 6]);
}

fn topic(stamps: &[i64]) -> Topic {
    let samples = stamps
        .iter()
        .enumerate()
        .map(|(i, &t)| Sample {
            stamp_ns: t,
            log_time: 1000 + i as u64 * 10,
            w: [i as f64, 0.0, -1.0],
            a: [0.0; 3],
            a_given: false,
        })
        .collect::<Vec<_>>();
    Topic { name: "/imu".into(), imu: true, messages: stamps.len() as u64, samples, ..Topic::default() }
}

#[test]
fn build_sorts_drops_repeats_and_places_gaps() {
    let ms = 1_000_000;
    // Logged out of order (3 before 2), 4 repeated, 6 missing; the rate is the median step, 1 ms.
    let b = build("b.mcap".into(), topic(&[0, ms, 3 * ms, 2 * ms, 4 * ms, 4 * ms, 5 * ms, 7 * ms]), None).unwrap();
    assert_eq!((b.out_of_order, b.duplicates, b.messages), (1, 1, 8));
    assert_eq!(b.recording.rate_hz, 1000.0);
    assert_eq!(b.time_source, TimeSource::HeaderStamp);
    let k = RateUnit::RadPerS.to_dps();
    let want = [0.0, 1.0, 3.0, 2.0, 4.0, 6.0, f64::NAN, 7.0];
    let x = &b.recording.channels[0];
    assert_eq!(x.len(), want.len());
    for (i, (g, w)) in x.iter().zip(want).enumerate() {
        assert!(g.to_bits() == (w * k).to_bits() || (g.is_nan() && w.is_nan()), "{i}: {x:?}");
    }
    assert_eq!((b.recording.info.samples, b.recording.info.gaps), (8, 3));
    // An even count of steps: the median is the mean of the middle two (1 and 3 ms).
    let b = build("b.mcap".into(), topic(&[0, ms, 4 * ms]), None).unwrap();
    assert_eq!(b.recording.rate_hz, 500.0);
    // Every stamp zero: the log times (10 ns apart) instead.
    let b = build("b.mcap".into(), topic(&[0, 0, 0, 0]), None).unwrap();
    assert_eq!((b.time_source, b.start_ns, b.recording.rate_hz), (TimeSource::LogTime, 1000, 1e8));
    // One message needs a rate; none is an error.
    assert!(matches!(build("b".into(), topic(&[5]), None), Err(BagError::TooFewMessages { .. })));
    assert_eq!(build("b".into(), topic(&[5]), Some(100.0)).unwrap().recording.info.samples, 1);
    assert!(matches!(build("b".into(), topic(&[]), Some(100.0)), Err(BagError::TooFewMessages { .. })));
    // A clock jump of a day at 1 kHz is refused rather than filled with 86 million NaN.
    let mut stamps: Vec<i64> = (0..1000).map(|i| i * ms).collect();
    stamps.push(86_400_000 * ms);
    let err = build("b".into(), topic(&stamps), None).unwrap_err();
    assert!(matches!(err, BagError::ClockJump { messages: 1001, .. }), "{err}");
}

//! Unit tests of the transient scan: odd inputs, the side medians against a direct computation, and the shapes
//! that must and must not become events (white noise, a swell of three samples, lone spikes, a spread burst, a bump).

use super::stats::side_medians;
use super::*;
use octavar_stats::test_signals::{white, Lcg};

#[test]
fn white_noise_has_no_events() {
    for seed in 0..5 {
        let x = white(1 << 17, seed);
        let s = scan(&x, 100.0);
        assert!(s.events.is_empty(), "seed {seed}: {:?}", s.events);
    }
}

/// Empty, short, all-gap, constant, infinite and coarse-lattice inputs and invalid rates: no panic, no event.
#[test]
fn odd_inputs_give_no_events() {
    let gappy: Vec<f64> = (0..1000).map(|i| if i % 7 == 0 { f64::NAN } else { 0.25 }).collect();
    for x in [vec![], vec![1.0], vec![f64::NAN; 1000], vec![0.5; 1000], gappy] {
        assert!(scan(&x, 10.0).events.is_empty());
    }
    for n in 0..200 {
        assert!(scan(&white(n, n as u64), 1.0).events.is_empty());
    }
    let mut x = white(5000, 2);
    x[100] = f64::INFINITY;
    x[200..300].iter_mut().for_each(|v| *v = f64::NAN);
    assert!(scan(&x, 10.0).events.is_empty());
    // An invalid rate gives an empty scan (its sigma NaN, which no equality holds for).
    for rate_hz in [0.0, f64::NAN, -1.0] {
        let s = scan(&x, rate_hz);
        assert!(s.events.is_empty() && s.left_alone.is_empty() && s.scales.is_empty() && s.spikes == 0, "{s:?}");
    }
    // A lattice much coarser than the noise: a few percent of the samples flip to a neighbouring code.
    let lattice: Vec<f64> = white(20_000, 4).iter().map(|v| (0.2 * v).round()).collect();
    assert!(scan(&lattice, 10.0).events.is_empty());
    // Masking clamps to the series.
    let mut y = vec![0.0; 10];
    mask(
        &mut y,
        &[Transient { start: 8, len: 5, peak_dps: 0.0, mean_dps: 0.0, shape: Shape::Offset, scale: 1, z: 0.0 }],
    );
    assert!(y[8].is_nan() && y[9].is_nan() && y[7] == 0.0);
}

/// The side medians against a direct computation, with gaps and the reflected ends.
#[test]
fn side_medians_match_a_direct_computation() {
    let mut v = white(300, 5);
    for i in [0, 7, 8, 150, 151, 152, 299] {
        v[i] = f64::NAN;
    }
    let (first, last) = (1, 298);
    let at = |j: isize| -> f64 {
        if j < 0 {
            2.0 * v[first] - v[(-j) as usize]
        } else if j as usize >= v.len() {
            2.0 * v[last] - v[2 * (v.len() - 1) - j as usize]
        } else {
            v[j as usize]
        }
    };
    let med = |lo: isize, hi: isize| -> f64 {
        let w: Vec<f64> = (lo..=hi).map(at).filter(|x| x.is_finite()).collect();
        let mut w = w.clone();
        w.sort_by(f64::total_cmp);
        let c = w.len();
        if c < 3 {
            f64::NAN
        } else if c % 2 == 1 {
            w[c / 2]
        } else {
            0.5 * (w[c / 2 - 1] + w[c / 2])
        }
    };
    for (h, e) in [(16, 0), (16, 1)] {
        let (left, right) = side_medians(&v, h, e);
        for i in 0..v.len() {
            let ii = i as isize;
            let (h, e) = (h as isize, e as isize);
            let (l, r) = if v[i].is_finite() {
                (med(ii - h, ii - e - 1), med(ii + e + 1, ii + h))
            } else {
                (f64::NAN, f64::NAN)
            };
            assert!(
                l.total_cmp(&left[i]).is_eq() && r.total_cmp(&right[i]).is_eq(),
                "{i}: {l} {r} {:?}",
                (left[i], right[i])
            );
        }
    }
}

/// Ad-hoc timing (`cargo test -p octavar-gap --release --lib transients::tests::timing -- --ignored
/// --nocapture`): a million samples of white noise with a bump.
#[test]
#[ignore = "timing, by hand"]
fn timing() {
    let mut x = white(1_000_000, 9);
    x[500_000..501_000].iter_mut().for_each(|v| *v += 2.0);
    for _ in 0..3 {
        let t0 = std::time::Instant::now();
        let s = scan(&x, 100.0);
        println!("{} events in {:.3} s", s.events.len(), t0.elapsed().as_secs_f64());
    }
}

/// A swell of three samples (half a sine: 6, 12 and 6 sigmas) is an event, though only its peak is a large
/// sample; 40 lone spikes of 12 sigmas at a steady rate are not, and are counted as spikes.
#[test]
fn a_three_sample_swell_is_an_event_and_lone_spikes_are_not() {
    for seed in 0..4 {
        let mut x = white(1 << 18, seed);
        let at = 100_000 + 7_919 * seed as usize;
        for (v, w) in x[at..at + 3].iter_mut().zip([6.0, 12.0, 6.0]) {
            *v += w;
        }
        let s = scan(&x, 1.0);
        assert_eq!(s.events.len(), 1, "seed {seed}: {:?}", s.events);
        assert!(s.events[0].start <= at && s.events[0].end() >= at + 3, "seed {seed}: {:?}", s.events);
        let mut y = white(1 << 18, seed + 10);
        for k in 0..40 {
            y[3_001 + 6_469 * k] += if k % 2 == 0 { 12.0 } else { -12.0 };
        }
        let s = scan(&y, 1.0);
        assert!(s.events.is_empty(), "seed {seed}: {:?}", s.events);
        assert!(s.spikes >= 40, "seed {seed}: {} spikes", s.spikes);
    }
}

/// A burst of 8 spikes of both signs spread over 6000 samples of a record that wanders (white noise and a
/// random walk that moves the level by several sigmas over the burst) is a burst, not an offset that does not
/// return: it is found, as one event over its spikes.
#[test]
fn a_spread_burst_on_a_wandering_level_is_found() {
    for seed in 0..3 {
        let w = white(1 << 18, seed + 20);
        let steps = white(1 << 18, seed + 40);
        let mut level = 0.0;
        let mut x: Vec<f64> = w
            .iter()
            .zip(&steps)
            .map(|(v, s)| {
                level += 0.05 * s;
                v + level
            })
            .collect();
        let at = 50_000 + 10_007 * seed as usize;
        for k in 0..8 {
            x[at + 750 * k + 11] += if k % 3 == 0 { -30.0 } else { 30.0 };
        }
        let s = scan(&x, 100.0);
        let hit: Vec<&Transient> = s.events.iter().filter(|e| e.start <= at + 11 && e.end() > at + 5261).collect();
        assert_eq!(hit.len(), 1, "seed {seed}: {:?} left alone {:?}", s.events, s.left_alone);
        assert_eq!(hit[0].shape, Shape::Burst, "seed {seed}");
    }
}

#[test]
fn a_bump_is_found() {
    let mut x = white(1 << 16, 3);
    for v in &mut x[20_000..20_500] {
        *v += 3.0;
    }
    let s = scan(&x, 100.0);
    println!("{s:#?}");
    assert_eq!(s.events.len(), 1);
    let _ = Lcg::new(1);
}

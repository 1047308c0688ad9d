//! The accumulator against allantools: S = 1 must reproduce `adev(y, rate, data_type="freq", taus=2**k*tau0)`
//! (same pair counts, values within 1e-12 relative); S >= m must reproduce `oadev` exactly, and larger strides
//! must approach it.

use std::io::Write;

use octavar_shared::acc::{OctaveAllan, Snapshot, LEVELS};
use serde_json::Value;

use crate::util;

/// Deterministic test signals of 12-bit codes: white, a bounded random walk, and a sine with white noise.
fn signals(n: usize) -> Vec<(&'static str, Vec<u16>)> {
    let mut s = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = move || {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (s >> 32) as u32
    };
    let white: Vec<u16> = (0..n).map(|_| (next() >> 20) as u16).collect();
    let mut level = 2048i32;
    let walk: Vec<u16> = (0..n)
        .map(|_| {
            level = (level + (next() % 7) as i32 - 3).clamp(0, 4095);
            level as u16
        })
        .collect();
    let sine: Vec<u16> = (0..n)
        .map(|i| {
            let v = 2048.0 + 900.0 * (i as f64 * 0.013).sin() + f64::from(next() >> 24) - 128.0;
            v.round().clamp(0.0, 4095.0) as u16
        })
        .collect();
    vec![("white", white), ("walk", walk), ("sine", sine)]
}

fn allantools(codes: &[u16], rate: f64, tag: &str) -> Option<Value> {
    let py = util::allantools_python()?;
    let dir = util::temp_dir(tag);
    let path = dir.join("codes.txt");
    let mut f = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
    for c in codes {
        writeln!(f, "{c}").unwrap();
    }
    drop(f);
    let out = std::process::Command::new(py)
        .arg(util::reference_script("allantools_octaves.py"))
        .arg(&path)
        .arg(rate.to_string())
        .output()
        .expect("run allantools");
    assert!(out.status.success(), "allantools failed: {}", String::from_utf8_lossy(&out.stderr));
    Some(serde_json::from_slice(&out.stdout).expect("allantools JSON"))
}

fn rows(v: &Value, key: &str) -> Vec<(u64, u64, f64)> {
    v[key]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| (r[0].as_u64().unwrap(), r[1].as_u64().unwrap(), r[2].as_f64().unwrap()))
        .collect()
}

fn snapshot<const S: usize>(codes: &[u16]) -> Snapshot {
    let mut acc = OctaveAllan::<S>::new();
    acc.push_slice(codes);
    acc.snapshot()
}

#[test]
fn stride_1_matches_allantools_adev() {
    let rate = 2000.0;
    for (name, codes) in signals(100_003) {
        let Some(reference) = allantools(&codes, rate, name) else { return };
        let snap = snapshot::<1>(&codes);
        let adev = rows(&reference, "adev");
        assert!(adev.len() >= 15, "{name}: allantools gave {} octaves", adev.len());
        for (m, n, dev) in adev {
            let level = m.trailing_zeros() as usize;
            assert_eq!(1u64 << level, m);
            assert_eq!(snap.levels[level].n, n, "{name} m={m}: pair count");
            let ours = snap.adev_codes(level).unwrap();
            let rel = (ours / dev - 1.0).abs();
            assert!(rel < 1e-12, "{name} m={m}: {ours} vs allantools {dev} (rel {rel:e})");
        }
    }
}

#[test]
fn strides_approach_allantools_oadev() {
    let rate = 100.0;
    for (name, codes) in signals(65_536 + 77) {
        let Some(reference) = allantools(&codes, rate, &format!("o{name}")) else { return };
        let oadev = rows(&reference, "oadev");
        let s8 = snapshot::<8>(&codes);
        let s64 = snapshot::<64>(&codes);
        let mut worse_8 = 0.0f64;
        let mut worse_64 = 0.0f64;
        for &(m, n, dev) in &oadev {
            let level = m.trailing_zeros() as usize;
            for (stride, snap) in [(8u64, &s8), (64, &s64)] {
                let ours = snap.adev_codes(level).unwrap();
                let rel = (ours / dev - 1.0).abs();
                if m <= stride {
                    // Fully overlapping at these levels: the same estimator, the same count.
                    assert_eq!(snap.levels[level].n, n, "{name} S={stride} m={m}");
                    assert!(rel < 1e-12, "{name} S={stride} m={m}: {ours} vs {dev}");
                } else {
                    // Clusters every m/S samples: a subset of the overlapping differences, so the estimates
                    // differ only by sampling. Bound it by the non-overlapping estimator's own relative
                    // standard deviation, 1/sqrt(2 (N/m - 1)).
                    let sd = 1.0 / (2.0 * (codes.len() as f64 / m as f64 - 1.0)).sqrt();
                    assert!(rel < 2.0 * sd, "{name} S={stride} m={m}: {ours} vs {dev}");
                    if stride == 8 {
                        worse_8 = worse_8.max(rel / sd);
                    } else {
                        worse_64 = worse_64.max(rel / sd);
                    }
                }
            }
        }
        assert!(worse_64 <= worse_8 + 1e-9, "{name}: S=64 ({worse_64}) should be closer than S=8 ({worse_8})");
        const { assert!(LEVELS >= 32) };
    }
}

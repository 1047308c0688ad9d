//! TOTDEV's sums of squares on a gap-free phase record, at many averaging factors.
//!
//! TOTDEV takes OADEV's second differences `x*[i-m] - 2x*[i] + x*[i+m]` at every centre i = 1 .. N-2 of the
//! record extended at both ends by odd reflection (`x*[-j] = 2x[0] - x[j]`, `x*[N-1+j] = 2x[N-1] - x[N-1-j]`).
//! The centres m .. N-1-m reach no reflection: their terms are OADEV's at m, summed by the cache-blocked
//! multi-level kernel ([`oadev_sums`]). The 2(m-1) centres near the ends (or all of them, when 2m > N-1) are
//! summed in runs over which each side is reflected or not throughout, reading the reflected side backwards.

use rayon::prelude::*;

use super::kernel::oadev_sums;

/// `sum_i (x*[i-m] - 2x*[i] + x*[i+m])^2` over the centres i = 1 ..= N-2, for each m of `ms` (0 where m is 0 or
/// beyond N - 2). The same bits on any number of threads.
pub(crate) fn totdev_sums(x: &[f64], ms: &[usize]) -> Vec<f64> {
    let n = x.len();
    let valid = |m: usize| n >= 3 && m >= 1 && m <= n - 2;
    let inner: Vec<usize> = ms.iter().map(|&m| if valid(m) { m } else { 0 }).collect();
    // Centres m ..= N-1-m: OADEV's terms at m (oadev_sums gives 0 where there are none).
    let interior = oadev_sums(x, &inner);
    let edges: Vec<f64> = inner.par_iter().map(|&m| if m == 0 { 0.0 } else { edge_sums(x, m) }).collect();
    interior.iter().zip(&edges).map(|(a, b)| a + b).collect()
}

/// The terms of the centres that reach a reflection, 1 <= m <= N - 2: `1 ..= m-1` (left) and `N-m ..= N-2`
/// (right) when the interior is not empty (2m <= N - 1); else every centre, in up to three runs: left only,
/// both sides, right only.
fn edge_sums(x: &[f64], m: usize) -> f64 {
    let last = x.len() - 1;
    if 2 * m <= last {
        return region(x, m, 1, m - 1) + region(x, m, last + 1 - m, last - 1);
    }
    region(x, m, 1, last - m) + region(x, m, (last + 1 - m).max(1), (m - 1).min(last - 1)) + region(x, m, m, last - 1)
}

/// The terms of the centres i0 ..= i1 (none when i1 < i0), each side reflected or not as the whole run is:
/// `x*[i-m]` is `2x[0] - x[m-i]` for i < m, `x*[i+m]` is `2x[N-1] - x[2(N-1)-i-m]` for i + m > N - 1.
fn region(x: &[f64], m: usize, i0: usize, i1: usize) -> f64 {
    if i1 < i0 {
        return 0.0;
    }
    let last = x.len() - 1;
    let (left, right) = (i0 < m, i1 + m > last);
    debug_assert!(left == (i1 < m) && right == (i0 + m > last));
    let b = &x[i0..=i1];
    let a = if left { &x[m - i1..=m - i0] } else { &x[i0 - m..=i1 - m] };
    let c = if right { &x[2 * last - i1 - m..=2 * last - i0 - m] } else { &x[i0 + m..=i1 + m] };
    let (ka, kc) = (2.0 * x[0], 2.0 * x[last]);
    match (left, right) {
        (false, false) => run::<false, false>(a, b, c, ka, kc),
        (true, false) => run::<true, false>(a, b, c, ka, kc),
        (false, true) => run::<false, true>(a, b, c, ka, kc),
        (true, true) => run::<true, true>(a, b, c, ka, kc),
    }
}

/// `sum_t (A_t - 2 b[t] + C_t)^2` with `A_t = ka - a[len-1-t]` when `RA` (a reflected run, read backwards),
/// else `a[t]`, and C_t likewise: [`run_body`] compiled for AVX2 + FMA where the CPU has them.
fn run<const RA: bool, const RC: bool>(a: &[f64], b: &[f64], c: &[f64], ka: f64, kc: f64) -> f64 {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
            // SAFETY: the features were just detected on this CPU.
            return unsafe { run_avx2::<RA, RC>(a, b, c, ka, kc) };
        }
    }
    run_body::<RA, RC>(a, b, c, ka, kc)
}

/// [`run`] four terms per vector, a reflected side loaded forwards and reversed in the register.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn run_avx2<const RA: bool, const RC: bool>(a: &[f64], b: &[f64], c: &[f64], ka: f64, kc: f64) -> f64 {
    use std::arch::x86_64::*;
    let len = b.len();
    assert!(a.len() >= len && c.len() >= len);
    let (pa, pb, pc) = (a.as_ptr(), b.as_ptr(), c.as_ptr());
    let mut s = 0.0;
    let mut t = 0;
    // SAFETY (whole block): every vector load covers t .. t + 4 <= len (forwards) or len - 4 - t .. len - t
    // (backwards), inside the three runs of at least len points.
    unsafe {
        let (two, kav, kcv) = (_mm256_set1_pd(2.0), _mm256_set1_pd(ka), _mm256_set1_pd(kc));
        macro_rules! side {
            ($p:expr, $rev:expr, $k:expr, $t:expr) => {
                if $rev {
                    _mm256_sub_pd($k, _mm256_permute4x64_pd::<0x1B>(_mm256_loadu_pd($p.add(len - 4 - $t))))
                } else {
                    _mm256_loadu_pd($p.add($t))
                }
            };
        }
        macro_rules! term {
            ($t:expr) => {{
                let ac = _mm256_add_pd(side!(pa, RA, kav, $t), side!(pc, RC, kcv, $t));
                _mm256_fnmadd_pd(two, _mm256_loadu_pd(pb.add($t)), ac)
            }};
        }
        // Four accumulators: the FMA's latency does not bound the loop.
        let mut acc = [_mm256_setzero_pd(); 4];
        while t + 16 <= len {
            for (k, a) in acc.iter_mut().enumerate() {
                let v = term!(t + 4 * k);
                *a = _mm256_fmadd_pd(v, v, *a);
            }
            t += 16;
        }
        while t + 4 <= len {
            let v = term!(t);
            acc[0] = _mm256_fmadd_pd(v, v, acc[0]);
            t += 4;
        }
        let mut lanes = [0.0f64; 4];
        _mm256_storeu_pd(
            lanes.as_mut_ptr(),
            _mm256_add_pd(_mm256_add_pd(acc[0], acc[1]), _mm256_add_pd(acc[2], acc[3])),
        );
        s += (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
    }
    let tail = len - t;
    let a = if RA { &a[..tail] } else { &a[t..len] };
    let c = if RC { &c[..tail] } else { &c[t..len] };
    s + run_body::<RA, RC>(a, &b[t..], c, ka, kc)
}

/// [`run`], eight lanes (the reversed runs vectorise as permuted loads).
#[inline(always)]
fn run_body<const RA: bool, const RC: bool>(a: &[f64], b: &[f64], c: &[f64], ka: f64, kc: f64) -> f64 {
    let len = b.len();
    let (a, c) = (&a[..len], &c[..len]);
    let term = |t: usize| {
        let av = if RA { ka - a[len - 1 - t] } else { a[t] };
        let cv = if RC { kc - c[len - 1 - t] } else { c[t] };
        let v = (av + cv) - 2.0 * b[t];
        v * v
    };
    let mut acc = [0.0f64; 8];
    let mut t = 0;
    while t + 8 <= len {
        for (k, s) in acc.iter_mut().enumerate() {
            *s += term(t + k);
        }
        t += 8;
    }
    let mut s = acc.iter().sum::<f64>();
    while t < len {
        s += term(t);
        t += 1;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each term from the reflected record's definition.
    fn reference(x: &[f64], m: usize) -> f64 {
        let last = x.len() as i64 - 1;
        let ext = |k: i64| {
            if k < 0 {
                2.0 * x[0] - x[(-k) as usize]
            } else if k > last {
                2.0 * x[last as usize] - x[(2 * last - k) as usize]
            } else {
                x[k as usize]
            }
        };
        let mi = m as i64;
        (1..last)
            .map(|i| {
                let v = ext(i - mi) - 2.0 * ext(i) + ext(i + mi);
                v * v
            })
            .sum()
    }

    /// The interior from the OADEV kernel and the reflected ends add up to the definition, for m with and
    /// without an interior, and the largest m.
    #[test]
    fn interior_and_ends_match_the_definition() {
        let mut g = crate::test_signals::Lcg::new(7);
        let mut walk = 0.0;
        let x: Vec<f64> = (0..1001)
            .map(|_| {
                walk += g.uniform() - 0.5;
                walk
            })
            .collect();
        let ms = [1usize, 2, 3, 64, 499, 500, 501, 700, 998, 999, 0];
        let got = totdev_sums(&x, &ms);
        for (&m, &g) in ms.iter().zip(&got) {
            let want = if m == 0 || m > 999 { 0.0 } else { reference(&x, m) };
            assert!((g - want).abs() <= 1e-12 * want, "m={m}: {g} vs {want}");
        }
    }
}

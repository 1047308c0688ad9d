//! How far an ADC lattice's own residuals reach: the smallest magnitude, in steps, beyond which a clean record on
//! the lattice leaves next to no residual (a sample less the median of its neighbours), so that the spikes' law
//! can be read from there out.
//!
//! On a lattice coarser than the noise, most residuals are exactly 0 and most of the rest one step (or half a
//! step, where the median falls between two values): a sample two steps off its neighbours needs the noise to
//! move a whole step. Spikes of two steps then stand clear of the lattice's own residuals when the noise is a
//! quarter of a step, and only beyond three steps when it is near a step. The noise's share of the step is read
//! from the ratio of residuals of half a step or one step to residuals of 0, which spikes of two steps or more
//! hardly move (they take a sample out of either count alike), against the same ratio on clean synthetic records
//! (white noise of sd `s` steps over a level that moves slowly across the lattice, rounded), computed once. The
//! reach of a record is the largest reach among the noises whose clean ratio is at most the record's own (with a
//! [`RATIO_MARGIN`]): an unsure reading errs towards the farther bound.

use std::sync::OnceLock;

use octavar_shared::sim::rng::SimRng;
use octavar_stats::tails::poisson_sf;

/// The reaches tried, steps (residuals on a lattice are whole or half steps). Where the noise is more than about
/// half a step, even three steps do not hold the clean residuals, and the lattice has no reach: its dithered
/// residuals are then close to a Gaussian core, and the spikes are read beyond [`FAR_STEPS`] as the core allows.
const REACHES: [f64; 4] = [1.5, 2.0, 2.5, 3.0];

/// A reach holds where the clean residuals at or beyond it are at most this share of all.
const CLEAN_SHARE: f64 = 1e-4;

/// The white noise's sds tried, steps.
const NOISES: [f64; 13] = [0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45, 0.5, 0.6, 0.7, 0.85, 1.0];

/// Samples of each clean synthetic record: 20 residuals at the [`CLEAN_SHARE`].
const SYNTHETIC_LEN: usize = 200_000;

/// Lattice levels the synthetic record's level crosses over its length (not a whole number, so that every
/// offset against the lattice is visited).
const LEVEL_CROSSINGS: f64 = 61.3;

/// `x` over a level that crosses the lattice of step `q` slowly ([`LEVEL_CROSSINGS`] levels over its length),
/// rounded to it: a clean record on the lattice, every offset against it visited alike.
pub(super) fn rounded_over_slow_level(x: &[f64], q: f64) -> Vec<f64> {
    let n = x.len() as f64;
    x.iter().enumerate().map(|(i, v)| q * (v / q + LEVEL_CROSSINGS * i as f64 / n).round()).collect()
}

/// The record's ratio may exceed a clean noise's by this factor before that noise is ruled out.
const RATIO_MARGIN: f64 = 1.1;

/// The stream of the synthetic records (fixed, so the diagnosis is repeatable).
const SEED: u64 = 0x1a7_1ce;

/// Where the spikes' law is held from on a lattice that has no reach, or where spikes between the reach and
/// here are too few to read, steps: the distribution view's tail threshold on a lattice (a sample a step or two
/// off its neighbours is the lattice's own where the noise is near a step).
pub(super) const FAR_STEPS: f64 = crate::views::LATTICE_TAIL_STEPS;

/// A clean noise level's off-lattice ratio and reach (`None`: none of [`REACHES`] holds).
struct Clean {
    ratio: f64,
    reach: Option<f64>,
}

/// Residuals of half a step or one step over residuals of 0 (`q` the step; NaN residuals left out), or `None`
/// without residuals of 0.
fn off_lattice_ratio(r: &[f64], q: f64) -> Option<f64> {
    let (mut zero, mut near) = (0usize, 0usize);
    for a in r.iter().filter(|v| v.is_finite()).map(|v| (v / q).abs()) {
        if a < 0.25 {
            zero += 1;
        } else if a < 1.25 {
            near += 1;
        }
    }
    (zero > 0).then(|| near as f64 / zero as f64)
}

/// The clean record of white noise `noise` steps over the slow level: its ratio and reach.
fn clean(noise: f64, seed: u64) -> Clean {
    let mut rng = SimRng::new(seed);
    let white: Vec<f64> = (0..SYNTHETIC_LEN).map(|_| noise * rng.normal()).collect();
    let x = rounded_over_slow_level(&white, 1.0);
    let r = super::residuals(&x, &vec![false; x.len()], None);
    let ratio = off_lattice_ratio(&r, 1.0).unwrap_or(f64::INFINITY);
    let read = r.iter().filter(|v| v.is_finite()).count().max(1) as f64;
    let beyond = |l: f64| r.iter().filter(|v| v.abs() >= l - 0.25).count() as f64 / read;
    let reach = REACHES.iter().copied().find(|&l| beyond(l) <= CLEAN_SHARE);
    Clean { ratio, reach }
}

/// The clean noise levels, computed once.
fn table() -> &'static [Clean] {
    static TABLE: OnceLock<Vec<Clean>> = OnceLock::new();
    TABLE.get_or_init(|| NOISES.iter().enumerate().map(|(k, &s)| clean(s, SEED + k as u64)).collect())
}

/// What the residuals on a lattice say of it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Reading {
    /// The lattice's reach, steps.
    pub reach_steps: f64,
    /// The white noise under the lattice whose clean ratio is the record's, steps (interpolated between the
    /// table's levels, held within them).
    pub noise_steps: f64,
    /// Where the spikes' magnitude law is held from, steps: the reach where more than [`BUSY_SHARE`] of the
    /// residuals stand between it and [`FAR_STEPS`] (spikes there to be read), [`FAR_STEPS`] otherwise.
    pub least_steps: f64,
    /// Residuals read, and those at or beyond the reach.
    pub read: usize,
    pub beyond: usize,
    /// How many residuals at or beyond the reach a clean lattice under this noise leaves, at most
    /// ([`clean_share_bound`]).
    pub clean_beyond: f64,
}

impl Reading {
    /// Whether spikes stand between the reach and [`FAR_STEPS`], so that their law is read from the reach.
    pub fn busy(&self) -> bool {
        self.least_steps < FAR_STEPS
    }

    /// Whether more residuals stand at or beyond the reach than a clean lattice leaves there, at [`RARE_ALPHA`]
    /// (at least [`RARE_LEAST`] of them): spikes, however few.
    pub fn spiked(&self) -> bool {
        self.beyond >= RARE_LEAST && poisson_sf(self.clean_beyond, self.beyond) <= RARE_ALPHA
    }
}

/// A bound on the share of a clean lattice's residuals at or beyond a reach of a step and a half or more, under
/// white noise of `noise_steps` steps: `2 Q(0.9 / s)`. A residual of a step and a half needs the sample to move
/// about a step against its neighbours' median: on clean records of two million samples the share measured is
/// `2 Q(d / s)` with `d` from 1.01 steps (noise 0.2 steps) to 1.10 (0.35 steps), so the bound stands about ten
/// times above it (at 0.2 steps 5e-7 against 7e-6, at 0.25 steps 3e-5 against 3e-4), which also covers a noise
/// read a few percent low (`the_clean_share_bound_holds` below checks it at every level of the table).
pub(super) fn clean_share_bound(noise_steps: f64) -> f64 {
    2.0 * crate::effects::common::normal_sf(0.9 / noise_steps)
}

/// The chance, under a clean lattice's bound ([`clean_share_bound`]), of as many residuals at or beyond the reach
/// as the record has, below which they are spikes ([`Reading::spiked`]), however few.
pub(super) const RARE_ALPHA: f64 = 1e-4;

/// Fewest residuals beyond the reach that make spikes on the count alone.
const RARE_LEAST: usize = 5;

/// A record's samples on a lattice that has a reach: the step, the residuals read on the samples as they are
/// (undithered) and what those say of the lattice.
pub(super) struct OnLattice {
    /// The step, deg/s.
    pub step: f64,
    /// [`super::residuals`] of the samples, undithered (NaN where not read).
    pub residuals: Vec<f64>,
    /// What the residuals say of the lattice.
    pub reading: Reading,
}

impl OnLattice {
    /// The residuals `residuals` of samples on the lattice of step `q`, read ([`read`]); `None` where the lattice
    /// has no reach.
    pub fn read(residuals: Vec<f64>, q: f64) -> Option<Self> {
        let reading = read(&residuals, q)?;
        Some(Self { step: q, residuals, reading })
    }

    /// The lattice's reach, deg/s: every residual beyond it is a spike's.
    pub fn reach(&self) -> f64 {
        self.reading.reach_steps * self.step
    }

    /// Where the spikes' magnitude law is held from, deg/s ([`Reading::least_steps`]).
    pub fn least(&self) -> f64 {
        self.reading.least_steps * self.step
    }

    /// Whether the spikes' law is read from the reach ([`Reading::busy`]).
    pub fn busy(&self) -> bool {
        self.reading.busy()
    }
}

/// The share of residuals between the reach and [`FAR_STEPS`] beyond which spikes stand there: ten times what a
/// clean record leaves beyond its reach. Below it, the law is held beyond the far bound, since the dithered core
/// of a coarse lattice (residuals of 0 and one step, blurred) is a little heavier than a Gaussian just beyond a
/// step and a half, and a law free to start there takes that excess for rare spikes of two steps.
const BUSY_SHARE: f64 = 10.0 * CLEAN_SHARE;

/// What the residuals `r` of samples on the lattice of step `q` say of it ([`super::residuals`] undithered; the
/// samples on the lattice, or on it less a smooth part an earlier step took out); `None` where the lattice has no
/// reach (the noise near a step or more) or the record gives no reading.
pub(super) fn read(r: &[f64], q: f64) -> Option<Reading> {
    let t = table();
    let far = FAR_STEPS;
    let ratio = off_lattice_ratio(r, q)?;
    let mut reach_steps = REACHES[0];
    for c in t.iter().filter(|c| c.ratio <= RATIO_MARGIN * ratio) {
        reach_steps = reach_steps.max(c.reach?);
    }
    let above = t.partition_point(|c| c.ratio < ratio);
    let noise_steps = if above == 0 {
        NOISES[0]
    } else if above == t.len() {
        NOISES[NOISES.len() - 1]
    } else {
        let (lo, hi) = (&t[above - 1], &t[above]);
        let w = (ratio - lo.ratio) / (hi.ratio - lo.ratio);
        NOISES[above - 1] + w * (NOISES[above] - NOISES[above - 1])
    };
    let (mut read, mut between, mut beyond) = (0usize, 0usize, 0usize);
    for a in r.iter().filter(|v| v.is_finite()).map(|v| (v / q).abs()) {
        read += 1;
        beyond += usize::from(a >= reach_steps - 0.25);
        between += usize::from(a >= reach_steps - 0.25 && a < far - 0.25);
    }
    let clean_beyond = read as f64 * clean_share_bound(noise_steps);
    let busy = between as f64 > BUSY_SHARE * read as f64;
    Some(Reading {
        reach_steps,
        noise_steps,
        least_steps: if busy { reach_steps } else { far },
        read,
        beyond,
        clean_beyond,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The reach grows with the noise's share of the step, from a step and a half on a coarse lattice to none
    /// near a step.
    #[test]
    fn the_reach_grows_with_the_noise() {
        let t = table();
        for (c, s) in t.iter().zip(NOISES) {
            eprintln!("noise {s}: ratio {:.3}, reach {:?}", c.ratio, c.reach);
        }
        let far = |r: Option<f64>| r.unwrap_or(f64::INFINITY);
        assert!(t.windows(2).all(|w| far(w[1].reach) >= far(w[0].reach) && w[1].ratio > w[0].ratio));
        assert_eq!(t[0].reach, Some(REACHES[0]));
        assert_eq!(t[t.len() - 1].reach, None);
    }

    /// On clean records the reach read keeps the residuals beyond it at most a few times [`CLEAN_SHARE`], at
    /// noise levels between the table's and from another stream; it is a step and a half on a coarse lattice and
    /// none where the noise is most of a step.
    #[test]
    fn the_reach_read_off_a_clean_record_holds_its_residuals() {
        for (k, noise) in [0.17, 0.27, 0.33, 0.42, 0.55, 0.8].into_iter().enumerate() {
            let q = 0.01;
            let mut rng = SimRng::new(99 + k as u64);
            let n = 150_000;
            let x: Vec<f64> =
                (0..n).map(|i| q * (17.7 * i as f64 / n as f64 + noise * rng.normal()).round() + 0.3).collect();
            let gap = vec![false; n];
            let r = super::super::residuals(&x, &gap, None);
            let got = read(&r, q);
            eprintln!("noise {noise}: {got:?}");
            match got {
                Some(g) => {
                    let beyond = r.iter().filter(|v| v.abs() >= (g.reach_steps - 0.25) * q).count() as f64 / n as f64;
                    assert!(beyond <= 5.0 * CLEAN_SHARE, "noise {noise}: {g:?}, share beyond {beyond}");
                    assert_eq!(g.least_steps, FAR_STEPS, "noise {noise}: clean, yet spikes read between");
                    if noise < 0.3 {
                        assert_eq!(g.reach_steps, REACHES[0], "noise {noise}");
                    }
                }
                None => assert!(noise > 0.5, "noise {noise}: no reach"),
            }
        }
    }

    /// The clean share bound holds: on clean records of two million samples at each noise level of the table up
    /// to half a step, the residuals at or beyond each reach (to [`FAR_STEPS`]) are no more than
    /// [`clean_share_bound`] gives, and a count test against it finds no spikes there.
    #[test]
    fn the_clean_share_bound_holds() {
        let n = 2_000_000;
        for (k, &s) in NOISES.iter().filter(|&&s| s <= 0.5).enumerate() {
            let mut rng = SimRng::new(70 + k as u64);
            let white: Vec<f64> = (0..n).map(|_| s * rng.normal()).collect();
            let x = rounded_over_slow_level(&white, 1.0);
            let r = super::super::residuals(&x, &vec![false; n], None);
            let n_read = r.iter().filter(|v| v.is_finite()).count() as f64;
            let bound = clean_share_bound(s);
            for l in REACHES {
                let c = r.iter().filter(|v| v.abs() >= l - 0.25 && v.abs() < FAR_STEPS - 0.25).count();
                eprintln!("noise {s}, reach {l}: {c} beyond, bound {:.2}", bound * n_read);
                assert!(c as f64 <= bound * n_read, "noise {s}, reach {l}: {c} beyond, bound {:.3e}", bound * n_read);
            }
            if let Some(g) = read(&r, 1.0) {
                assert!(!g.busy() && !g.spiked(), "noise {s}: clean, yet spiked: {g:?}");
            }
        }
    }

    /// Eleven spikes of 2.2 steps in a quarter of a million samples on a lattice seven times coarser than the
    /// noise: too few for the share, but far more than a clean lattice leaves beyond its reach.
    #[test]
    fn rare_spikes_beyond_the_reach_are_counted() {
        let q = 0.1;
        let n = 250_000;
        for seed in [1, 2, 3] {
            let mut rng = SimRng::new(seed);
            let mut x: Vec<f64> = (0..n).map(|_| 0.15 * q * rng.normal()).collect();
            let clean = read(&super::super::residuals(&rounded_over_slow_level(&x, q), &vec![false; n], None), q);
            assert!(!clean.expect("a reach").spiked(), "seed {seed}: the clean record reads spiked");
            for k in 0..11 {
                x[9_001 + 22_003 * k] += if k % 2 == 0 { 2.2 * q } else { -2.2 * q };
            }
            let got = read(&super::super::residuals(&rounded_over_slow_level(&x, q), &vec![false; n], None), q)
                .expect("a reach");
            assert!(got.reach_steps == 1.5 && got.spiked() && !got.busy(), "seed {seed}: {got:?}");
            // A spike beside a neighbour's median half a step off may round in under the reach.
            assert!((10..=11).contains(&got.beyond), "seed {seed}: {got:?}");
        }
    }

    /// Spikes of two steps on a lattice four times coarser than the noise stand beyond the reach: the reach is a
    /// step and a half, the law is held from there, and the noise under the lattice is read within 15%.
    #[test]
    fn spikes_of_two_steps_stand_beyond_a_coarse_lattices_reach() {
        let q = 0.02;
        let mut rng = SimRng::new(5);
        let n = 100_000;
        let x: Vec<f64> = (0..n)
            .map(|i| {
                let spike = if rng.uniform() < 0.1 { 2.2 * q * rng.sign() } else { 0.0 };
                q * ((11.1 * q * i as f64 / n as f64 + 0.23 * q * rng.normal() + spike) / q).round()
            })
            .collect();
        let got = read(&super::super::residuals(&x, &vec![false; n], None), q).expect("a reach");
        assert_eq!((got.reach_steps, got.least_steps), (1.5, 1.5));
        assert!((got.noise_steps / 0.23 - 1.0).abs() < 0.15, "noise {} steps against 0.23", got.noise_steps);
    }
}

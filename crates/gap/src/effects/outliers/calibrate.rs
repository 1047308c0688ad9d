//! The spike law read off a record, corrected for the estimator's own bias by indirect inference.
//!
//! Where the spikes stand near the core (a centre of a few core sds) the reading is biased in ways no closed
//! form follows: a run's partner in the median's window pulls each spike's residual in (the magnitudes read low),
//! run members are flagged less often than the fitted law says (the runs read short), and part of the law hides
//! in the core's shoulders. What matters to the diagnosis is that the simulation of the law reproduces the
//! record, so the law is corrected against the estimator itself: a synthetic record is drawn from the law read
//! (white noise plus shared::sim's spikes, the generator the simulation uses), read again by the same estimator,
//! and each parameter is moved by the difference between what the record gave and what the synthetic record
//! gave (`theta <- theta + (read(record) - read(synthetic(theta)))`, [`ROUNDS`] times). Scale parameters (the
//! core's sd, the share, the centre) are corrected on a log scale; the spread and the run law on their own.
//!
//! Spikes that stand clear of the core are read without such bias (every one of them flagged, their runs
//! counted whole), and correcting them would only add the synthetic record's sampling noise: the law is then
//! left as read.

use octavar_shared::sim::effects::Spikes;
use octavar_shared::sim::rng::SimRng;
use octavar_shared::sim::Outliers;

use super::mixture::Mixture;
use super::{read, Contamination, CLEAR_SIGMAS};

/// What the correction moves: the law and the run law.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Law {
    pub mix: Mixture,
    pub rho1: f64,
    pub cont_next: f64,
}

impl Law {
    /// The law as `c` read it.
    pub fn of(c: &Contamination) -> Law {
        Law { mix: c.mix, rho1: c.rho1, cont_next: c.cont_next }
    }

    /// The mean run length, samples (`1 / (1 - rho_1)`).
    pub fn run_mean(&self) -> f64 {
        1.0 / (1.0 - self.rho1)
    }

    /// The spikes of this law as shared::sim draws them.
    pub fn outliers(&self) -> Outliers {
        Outliers {
            per_sample: self.mix.eps,
            size_dps: self.mix.centre,
            spread_dps: self.mix.spread,
            run_mean: if self.rho1 > 0.0 { self.run_mean() } else { 0.0 },
            run_continue: self.cont_next,
            ..Default::default()
        }
    }
}

/// Correction rounds: the runs' continuation, which carries most of their fourth moment, takes about four to
/// settle from where the residuals read it.
const ROUNDS: usize = 4;

/// Spikes the synthetic record should hold (its length grows up to [`MAX_LENGTHS`] record lengths to reach them),
/// so that its own sampling noise stays below the record's.
const SYNTHETIC_SPIKES: f64 = 4000.0;

/// Longest synthetic record, in record lengths.
const MAX_LENGTHS: f64 = 4.0;

/// The core sd of the residual (a sample less the median of its eight neighbours) over the white noise's
/// per-sample sd: a starting value, which the first round corrects.
const RESIDUAL_INFLATION: f64 = 1.08;

/// The stream of the synthetic records (fixed, so the diagnosis is repeatable).
const SEED: u64 = 0x5_b1a5;

/// The ADC lattice a record sits on, as the synthetic records copy it.
#[derive(Clone, Copy, Debug)]
pub(super) struct OnLattice {
    /// The step, deg/s.
    pub step: f64,
    /// The sd of the white noise under the lattice, deg/s ([`super::lattice_reach::Reading::noise_steps`]).
    pub white: f64,
    /// The spikes' magnitudes are read beyond this, deg/s: the lattice's reach, where spikes stand between it and
    /// three steps (the only laws on a lattice that are calibrated; [`super::lattice_reach::OnLattice::least`]).
    pub least: f64,
}

impl OnLattice {
    /// The lattice that `at` read, as the synthetic records are rounded to it.
    pub fn of(at: &super::lattice_reach::OnLattice) -> Self {
        OnLattice { step: at.step, white: at.reading.noise_steps * at.step, least: at.least() }
    }
}

/// The law of `read_off` (read from a record of `n` samples) corrected for the estimator's bias; as read where the
/// spikes stand clear of the core, or where a synthetic record gives no reading.
///
/// On an ADC lattice the synthetic records are rounded to it, over a level that crosses it slowly, and read as the
/// record was (dithered, the magnitudes beyond the lattice's reach); their white noise is the one under the
/// lattice, which the dithered core's scale (mostly the dither's and the rounding's) does not follow.
pub(super) fn corrected(read_off: &Contamination, n: usize, lattice: Option<OnLattice>) -> Law {
    let seen = Law::of(read_off);
    let m = seen.mix;
    if m.centre - m.spread >= CLEAR_SIGMAS * m.sigma || n < 64 {
        return seen;
    }
    let len = ((SYNTHETIC_SPIKES / m.eps.max(1e-12)) as usize).clamp(n, (MAX_LENGTHS * n as f64) as usize);
    let mut law = seen;
    let mut white = lattice.map_or(m.sigma / RESIDUAL_INFLATION, |l| l.white);
    let no_gaps = vec![false; len];
    for round in 0..ROUNDS {
        let x = synthetic(&law, white, len, SEED + round as u64);
        let got = match lattice {
            Some(l) => {
                let x = super::lattice_reach::rounded_over_slow_level(&x, l.step);
                read(&super::dither(&x, l.step), &no_gaps, l.least)
            }
            None => read(&x, &no_gaps, 0.0),
        };
        let Some(got) = got else { return law };
        let got = Law::of(&got);
        let scale = |now: f64, want: f64, have: f64| now * (want / have).clamp(0.5, 2.0);
        if lattice.is_none() {
            white = scale(white, seen.mix.sigma, got.mix.sigma);
        }
        let eps = scale(law.mix.eps, seen.mix.eps, got.mix.eps).min(0.5);
        let centre = scale(law.mix.centre, seen.mix.centre, got.mix.centre);
        let spread = (law.mix.spread + seen.mix.spread - got.mix.spread).clamp(0.0, centre);
        let rho1 = if seen.rho1 > 0.0 { (law.rho1 + seen.rho1 - got.rho1).clamp(0.0, 0.9) } else { 0.0 };
        let cont_next = if rho1 > 0.0 { (law.cont_next + seen.cont_next - got.cont_next).clamp(0.0, 0.9) } else { 0.0 };
        law = Law { mix: Mixture { eps, centre, spread, ..law.mix }, rho1, cont_next };
    }
    law
}

/// `len` samples of white noise of sd `white` plus the spikes of `law`, stream `seed`.
fn synthetic(law: &Law, white: f64, len: usize, seed: u64) -> Vec<f64> {
    let mut rng = SimRng::new(seed);
    let mut spikes = Spikes::new(&law.outliers(), white, &mut rng);
    (0..len).map(|_| white * rng.normal() + spikes.next(&mut rng)).collect()
}

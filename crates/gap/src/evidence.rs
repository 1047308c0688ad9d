//! Naming an effect by its estimator's own test, where no view's gap shows it.
//!
//! The views compare stationary statistics of the record with the ensemble: an Allan deviation, a spectrum, a
//! distribution, a coherence. A warm-up that settles in the first minutes, or a small temperature coupling beside
//! a larger effect, moves none of them beyond the significance threshold, yet its estimator sees it plainly: a
//! generalised least-squares estimate many standard errors from zero. Such an effect is named on that evidence
//! when its statistic passes a threshold whose false-alarm rate on effect-free records is at most 1% per effect
//! per record, measured on records of octavar's simulator and of an independent generator
//! (tests/tests/gap_evidence.rs).
//!
//! | effect | statistic | threshold | why |
//! |---|---|---|---|
//! | temperature | `t`: coefficient / its GLS standard error (the lag searched) | 5 | the estimator's own acceptance |
//! | warm_up | `t`: size / its GLS standard error (block length and tau searched) | 5 | the estimator's own acceptance |
//! | resonance | `delta_chi2`: the fall of the Welch spectrum's chi-square with the bump | 100 | the estimator's own acceptance |
//! | bandwidth | `delta_chi2`: the fall of the Allan curve's log chi-square with the corner | 30 | the estimator's own acceptance |
//! | outliers | `lr`: twice the log-likelihood the spike law gains over the Gaussian core | 50 | the estimator's own acceptance |
//! | sinusoid | `short_period_z`: amplitude / its standard error, among sinusoids of 8 cycles or more per part | 8 | effect-free records reach 5.5 |
//!
//! Beside a significant gap the model leaves, the two chi-square tests name only an effect that takes that gap
//! below significance itself: a curve's chi-square falls with any added freedom where the model misses something
//! else, so there it measures that gap (a filter corner took 8,000 of the Allan curve's chi-square beside a
//! sinusoid and a bistable bias the chain had not named), while a t weighs its effect against the noise alone.
//!
//! On 300 effect-free records of each generator (`evidence_statistics` in tests/tests/gap_evidence.rs) these six
//! estimators found a trace beyond its threshold once: a temperature t of 5.46 on one record of the independent
//! generator (a rate of 0.3%, below 1.6% at 95% confidence). The sinusoid's test is its amplitude over its
//! standard error under the noise model, only among sinusoids of at least [`effects::SHORT_PERIOD_CYCLES`] (8)
//! cycles in the training part: its periodogram finds traces on 4-7% of effect-free records, nearly all at periods
//! of a third to a fifth of the record, where flicker and random walk make the lowest bins of a short record stand
//! above any smooth background, and a record whose slow wander the noise model lacks would raise them further. On
//! 1,000 effect-free records of each generator (`sinusoid_z_by_cycles`) the amplitude's z stays at or below 4.6
//! (shared::sim) and 5.5 (independent) at 8 cycles and more, 4.3 below, while a sinusoid the views lose beside a
//! bistable bias stands at 33 and one of 12 cycles beside a Gauss-Markov process and a warm-up at 21. The
//! Gauss-Markov process's fall of the Allan chi-square has no test here: it reaches 160 on 3% of effect-free
//! records (flicker is a sum of Gauss-Markov processes). The other effects' estimators find a trace only where a
//! view would show it too (a lattice), or their detection threshold is a rate of events, not a standard error. Rare spikes are the
//! exception among events: a dozen spikes of 6 sigma in a quarter of a million samples leave every view's gap
//! below 1, while the spike law's likelihood ratio stands at 80-150; no effect-free record of either generator
//! gave the outliers estimator a trace at all.

use serde::Serialize;

use super::effects::{self, Effect, EffectFit, TrainingData};

/// How strongly an estimator's own test names its effect.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Evidence {
    /// The statistic: `t`, the estimate over its standard error.
    pub statistic: &'static str,
    /// Its value.
    pub value: f64,
    /// The threshold of |value| beyond which the effect is named without a view's gap.
    pub threshold: f64,
}

impl Evidence {
    /// Whether the statistic names the effect on its own.
    pub fn names(&self) -> bool {
        self.value.abs() >= self.threshold
    }

    /// |value| over the threshold: which of several effects the evidence names first.
    pub fn strength(&self) -> f64 {
        self.value.abs() / self.threshold
    }
}

/// The test of `effect`'s estimator: the statistic's name (its key in the effect's parameters) and the threshold
/// of |value| beyond which it names the effect alone (`None`: the effect has no such test).
pub fn test(effect: Effect) -> Option<(&'static str, f64)> {
    match effect {
        Effect::Temperature | Effect::WarmUp => Some(("t_stat", 5.0)),
        Effect::Resonance => Some(("delta_chi2", RESONANCE_DELTA_CHI2)),
        Effect::Bandwidth => Some(("delta_chi2", BANDWIDTH_DELTA_CHI2)),
        Effect::Outliers => Some(("lr", OUTLIERS_LR)),
        Effect::Sinusoid => Some(("short_period_z", SINUSOID_Z)),
        _ => None,
    }
}

/// The threshold of `effect`'s test statistic (`None`: the effect has no test that names it alone).
pub fn threshold(effect: Effect) -> Option<f64> {
    test(effect).map(|(_, t)| t)
}

/// The evidence of a fit's own test, for the effects that have one.
pub fn of(fit: &EffectFit) -> Option<Evidence> {
    let (key, threshold) = test(fit.effect)?;
    let value = fit.params.test_statistic()?;
    let statistic = if key == "t_stat" { "t" } else { key };
    Some(Evidence { statistic, value, threshold })
}

/// The resonance's: the fall of the Welch spectrum's chi-square with its bump (the estimator's own acceptance).
const RESONANCE_DELTA_CHI2: f64 = 100.0;
/// The bandwidth's: the fall of the Allan curve's log chi-square with its corner (the estimator's own
/// acceptance).
const BANDWIDTH_DELTA_CHI2: f64 = 30.0;

/// The sinusoid's: the amplitude over its standard error, among sinusoids of at least
/// [`effects::SHORT_PERIOD_CYCLES`] cycles in the training part.
const SINUSOID_Z: f64 = 8.0;

/// The outliers': twice the log-likelihood the spike law gains over a Gaussian core (the estimator's own
/// acceptance, with its other checks: the law's centre clear of the core, an excess of residuals beyond 5 core
/// sds, the spikes spread over the record).
const OUTLIERS_LR: f64 = effects::OUTLIERS_MIN_LR;

/// How much worse than the model before it the views may find a model with an effect named by its estimator:
/// the effect is named because the views cannot see it, so they should not move, but the ensemble's draw moves the
/// total by a few percent.
pub const VIEWS_TOLERANCE: f64 = 1.1;

/// The views' total below which a model agrees with the record as well as the ensemble's own members agree
/// with each other (each view's gap is about 1 there): a model named by its estimator may take the total up to
/// it, however far below it the model before stood. Beneath 1 a total moves by far more than
/// [`VIEWS_TOLERANCE`] from one ensemble draw to the next (0.5 to 0.9 with a resonance added to a bistable bias
/// that had taken every view to agreement), so a tolerance relative to it alone would refuse the true effect.
pub const AGREEMENT_TOTAL: f64 = 1.0;

/// The views' total up to which a model with an effect named by its estimator still agrees with the record,
/// however far below it the model before stood, so long as no view's gap is significant and the band the chain
/// located (the worst view's decade) is no worse: the effect is named because no view sees it, and adding it
/// moves the views by the ensemble's response to it, not by a misfit. A sinusoid of 6.5 s the chain's bistable
/// bias had hidden (66 standard errors from zero once the flips were out of the samples) took the total from 0.91
/// to 1.04, beyond [`AGREEMENT_TOTAL`], with every view's gap near 1 and the located band's from 0.95 to 0.89. A
/// warm-up read at t = 5.7 beside a coarse ADC lattice that has none took the located band from 0.90 to 1.38: a
/// misfit there, refused.
pub const NAMED_AGREEMENT_TOTAL: f64 = 1.5;

/// Whether a model named by an estimator, whose views' `total` is given and whose views have a significant gap
/// or not, still agrees with the record ([`NAMED_AGREEMENT_TOTAL`]; the caller checks the located band).
pub fn still_agrees(total: f64, significant: bool) -> bool {
    total <= NAMED_AGREEMENT_TOTAL && !significant
}

/// How far beyond its threshold an estimator's statistic must stand ([`Evidence::strength`]) for the effect to be
/// named wherever the views still agree with the record ([`still_agrees`]), however the located band moves. Below
/// a total of [`NAMED_AGREEMENT_TOTAL`] a band's RMS z moves by the ensemble's draw as much as by a misfit: a
/// resonance read at a chi-square fall of 209 (twice its threshold, true to 0.2% in frequency) beside a bistable
/// bias and a warm-up that had taken every view to 0.5-0.6 moved the located band, a decade at long tau far from
/// its own frequency, from 0.63 to 1.27, and the total to 1.001. The band's check guards against an estimator that
/// found something near its threshold that is not its effect (a warm-up read at t = 5.7 beside an ADC lattice);
/// twice the threshold is beyond anything effect-free records reach on either generator
/// (tests/tests/gap_evidence.rs), and the views must still agree.
pub const STRONG_EVIDENCE: f64 = 2.0;

/// Whether `ev` names its effect whatever the located band does, so long as the views, at `total` and with a
/// significant gap or not, still agree with the record ([`STRONG_EVIDENCE`]).
pub fn names_whatever_the_band(ev: &Evidence, total: f64, significant: bool) -> bool {
    ev.strength() >= STRONG_EVIDENCE && still_agrees(total, significant)
}

/// Whether `effect`'s test is the fall of a curve's chi-square (the Allan curve's for a filter corner, the
/// spectrum's for a resonance), which measures the effect only against a model that fits the rest of the curve:
/// where the model leaves a significant gap, the curve's misfit is that gap's, and any added freedom lowers it.
/// Such an effect is named beside a significant gap only where it takes that gap below significance itself; a
/// generalised least-squares t weighs the effect against the noise alone, and holds beside an unexplained gap.
pub fn needs_a_fitting_model(effect: Effect) -> bool {
    matches!(effect, Effect::Resonance | Effect::Bandwidth)
}

/// Whether `effect`'s curve test may name it beside a model that already agrees with the record in every view
/// (a views' total at most [`AGREEMENT_TOTAL`]), where the views cannot find the model with it better. A bump
/// with a centre and a width (a resonance) is a shape no other process of the vocabulary draws, so a spectrum's
/// chi-square that falls by more than its threshold with the bump in place is the bump's. A filter corner is not:
/// a Gauss-Markov process's roll-off over the white noise bends the Allan curve the same way, and a corner read
/// into it lowers the curve's chi-square and nothing else.
pub fn curve_test_names_beside_agreement(effect: Effect) -> bool {
    effect == Effect::Resonance
}

/// The fits, among the `remaining` effects that have a test, whose evidence names them, strongest first (the
/// statistic furthest beyond its threshold), each estimated on `data`, or taken from `estimated` where the step's
/// ranking estimated it already (`Some(fit)`, with `None` inside where its estimator found nothing).
pub fn named(
    remaining: &[Effect],
    estimated: impl Fn(Effect) -> Option<Option<EffectFit>>,
    data: &TrainingData,
) -> Vec<EffectFit> {
    let mut out: Vec<(f64, EffectFit)> = remaining
        .iter()
        .filter(|&&e| threshold(e).is_some())
        .filter_map(|&e| estimated(e).unwrap_or_else(|| effects::fit_effect(e, data)))
        .filter_map(|f| of(&f).filter(Evidence::names).map(|ev| (ev.strength(), f)))
        .collect();
    out.sort_by(|a, b| b.0.total_cmp(&a.0));
    out.into_iter().map(|(_, f)| f).collect()
}

#[cfg(test)]
mod tests {
    use octavar_shared::sensor::{Channel, ADXRS300};
    use octavar_shared::sim::{GyroSim, VirtualGyro, WarmUpSim};

    use crate::chain::NamedBy;
    use crate::{diagnose, rank, Effect, GapInput, GapOptions};

    /// Half a day at 10 Hz of white noise, flicker and a little random walk, settling from `size_dps` with a
    /// time constant of 10 minutes.
    fn record(size_dps: f64, seed: u64) -> Vec<f64> {
        let warm_up = (size_dps != 0.0).then_some(WarmUpSim { size_dps, tau_s: 600.0 });
        simulated(&GyroSim { warm_up, ..quiet() }, seed)
    }

    /// White noise (0.0316 deg/s per sample at 10 Hz), flicker and a little random walk.
    fn quiet() -> GyroSim {
        GyroSim { n_deg_per_rt_s: 0.01, b_dps: 0.002, k_dps_per_rt_s: 1e-5, ..Default::default() }
    }

    /// Half a day of `m` at 10 Hz.
    fn simulated(m: &GyroSim, seed: u64) -> Vec<f64> {
        let mut g = VirtualGyro::new(m, Channel::bench(ADXRS300), 10.0, seed).unwrap();
        (0..1 << 19).map(|_| g.next_rate(25.0)).collect()
    }

    fn diagnosed(size_dps: f64, seed: u64) -> crate::GapReport {
        diagnosed_record(record(size_dps, seed))
    }

    fn diagnosed_record(x: Vec<f64>) -> crate::GapReport {
        let opts = GapOptions { seeds: 8, ..Default::default() };
        let input = GapInput::split(x, None, 10.0, 0.5).unwrap();
        diagnose(&input, &opts, &|_, _, _| {}).unwrap()
    }

    /// A warm-up of 0.032 deg/s settling over 10 minutes at the start of a 7-hour training part: 24 times the
    /// flicker's Allan floor (0.0013 deg/s), yet no view of the base model sees it, since it lives in the first few
    /// hundred of the part's 26,000 seconds (the views' gap stays below significance). The warm-up's estimator names
    /// it with its t (8.6-12.7 on these seeds, beyond 5), and the report says so, in the text and in the step's
    /// JSON evidence; the same record without the warm-up names nothing.
    #[test]
    fn a_warm_up_no_view_sees_is_named_by_its_estimator() {
        for seed in [1, 2, 3] {
            let r = diagnosed(0.032, seed);
            let base_gap = rank::gap_of(&r.base.eval.training);
            assert!(base_gap < rank::SIGNIFICANT_GAP, "seed {seed}: premise: a view sees it ({base_gap:.2})");
            assert_eq!(r.effects(), [Effect::WarmUp], "seed {seed}");
            let NamedBy::Estimator(ev) = r.chain.steps[0].named_by else {
                panic!("seed {seed}: named by {:?}", r.chain.steps[0].named_by)
            };
            assert!(ev.statistic == "t" && ev.names() && ev.threshold == 5.0, "seed {seed}: {ev:?}");
            assert!(r.text().contains("named by its estimator's test where no view's gap did (t = "), "{}", r.text());
            let json = r.to_json();
            assert_eq!(json["effects"][0]["evidence"]["route"], "estimator", "seed {seed}");
            assert_eq!(json["verdict"], "explained", "seed {seed}");
        }
        let control = diagnosed(0.0, 1);
        assert!(control.effects().is_empty(), "{:?}", control.effects());
    }

    /// Twelve spikes of 6.5 sigma (0.2 deg/s, signs alternating) spread over the training part of 262,144
    /// samples: every view's gap stays below significance (a dozen samples of heavy tail move no Allan
    /// difference's kurtosis far), yet the spike law's likelihood ratio over a Gaussian core names them, and the
    /// step says so.
    #[test]
    fn rare_spikes_no_view_sees_are_named_by_their_estimator() {
        for seed in [1, 2, 3] {
            let mut x = simulated(&quiet(), seed);
            for k in 0..12 {
                x[10_007 + 20_011 * k] += if k % 2 == 0 { 0.2 } else { -0.2 };
            }
            let r = diagnosed_record(x);
            let base_gap = rank::gap_of(&r.base.eval.training);
            assert!(base_gap < rank::SIGNIFICANT_GAP, "seed {seed}: premise: a view sees them ({base_gap:.2})");
            assert_eq!(r.effects(), [Effect::Outliers], "seed {seed}: {}", r.text());
            let NamedBy::Estimator(ev) = r.chain.steps[0].named_by else {
                panic!("seed {seed}: named by {:?}", r.chain.steps[0].named_by)
            };
            assert!(ev.statistic == "lr" && ev.names() && ev.threshold == 50.0, "seed {seed}: {ev:?}");
        }
        let control = diagnosed_record(simulated(&quiet(), 1));
        assert!(control.effects().is_empty(), "{:?}", control.effects());
    }

    /// The same twelve spikes beside bias steps (20 an hour of 0.1 deg/s sd, which the views name first and the
    /// chain takes out of the samples): the spikes' reading leaves the samples beside each step taken out aside,
    /// so the spikes are still named on their estimator's test, and the steps alone name nothing else.
    #[test]
    fn rare_spikes_beside_bias_steps_taken_out_are_named_by_their_estimator() {
        use octavar_shared::sim::BiasSteps;
        let stepped = GyroSim { bias_steps: Some(BiasSteps { per_hour: 20.0, sigma_dps: 0.1 }), ..quiet() };
        for seed in [1] {
            let mut x = simulated(&stepped, seed);
            let control = diagnosed_record(x.clone());
            assert_eq!(control.effects(), [Effect::BiasSteps], "seed {seed}: {}", control.text());
            for k in 0..12 {
                x[10_007 + 20_011 * k] += if k % 2 == 0 { 0.2 } else { -0.2 };
            }
            let r = diagnosed_record(x);
            assert_eq!(r.effects(), [Effect::BiasSteps, Effect::Outliers], "seed {seed}: {}", r.text());
            let NamedBy::Estimator(ev) = r.chain.steps[1].named_by else {
                panic!("seed {seed}: named by {:?}", r.chain.steps[1].named_by)
            };
            assert!(ev.statistic == "lr" && ev.names(), "seed {seed}: {ev:?}");
        }
    }
}

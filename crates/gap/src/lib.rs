//! The sim-to-real gap diagnosis (`octavar gap`): where a gyro and its fitted simulation part, which unmodelled
//! effects cause it, and how far the gap shrinks on data the fit never saw.
//!
//! 1. **Split** ([`input`]): training is the first part of the record, the holdout the rest
//!    ([`GapInput::split`]), or a second record ([`GapInput::joined`]). **Transients** ([`transients`], [`transients::parts`]): bumps and bursts found in each part are masked as gaps before anything else
//!    ([`GapOptions::keep_transients`] leaves them in). The estimators see the gaps filled ([`fill`]).
//! 2. **Base model** ([`base`]): the IEEE 952 fit ([`octavar_stats::fit::fit`], default options) on the training OADEV at
//!    octave tau; its fitted terms and the training mean as the bias, on the record's ADC when it is known
//!    ([`GapOptions::channel`]), else as the analog rate (no ADC: nothing quantises or clips it; a fine ADC over
//!    a few times the record's range clipped members whose random walk or ramp wandered further than the
//!    record's, and their stuck samples read as a heavy-tailed distribution).
//! 3. **Ensemble** ([`ensemble`]): the model simulated with [`GapOptions::seeds`] seeds over the whole record,
//!    driven by the real temperature; measured on each part and compared with the real record ([`Judge`]).
//! 4. **Views** ([`views`], one module per view, on the tools of [`spectral`]): ADEV, PSD, distribution,
//!    temperature; z-scores of the real values against the ensemble ([`compare`]).
//! 5. **Gap and location** ([`rank`]): the worst view's RMS z over its worst decade of tau, that band, its sign
//!    and size.
//! 6. **Candidates** ([`effects`]): each effect of the vocabulary fitted on the training data, re-simulated with the
//!    same seeds, re-measured; ranked by total gap with a penalty per parameter; the best is named, or `none` when
//!    the base gap is not significant.
//! 7. **The chain** ([`chain`]): while a significant gap remains, the remaining candidates are ranked again on the
//!    model that already has the effects found, and the best is added when it removes a quarter of the gap's
//!    excess over what a right model leaves ([`rank::explains`]), or the best pair when no single one does. Where
//!    the views name nothing, an effect whose own estimator's test passes its calibrated threshold is added
//!    ([`evidence`]): a warm-up over the first minutes, a small coupling beside a larger effect.
//! 8. **Holdout** ([`holdout`] for the predictive check): every parameter frozen from training, the gap on the
//!    holdout before and after each step and for the whole chain.
//! 9. **What is left** ([`describe`]): a significant gap that no candidate explains is described by its view,
//!    band, sign, size and shape.
//!
//! [`diagnose()`] runs these steps; [`report`] turns the result into text and the JSON document.
//!
//! Imports run one way: `fill` imports nothing; `input`, `error`, `spectral` and `base` import nothing of the diagnosis but each other;
//! `views` the spectral tools; `compare` the views; `ensemble` and `judge` those; `rank` the comparison and the
//! judge; `evidence` the ranking and the effects; `chain` the evidence and the ranking; `describe` and `holdout`
//! the ranking; `report` all of these; `diagnose` everything.
//!
//! # Examples
//! ```
//! use octavar_gap::{diagnose, GapInput, GapOptions};
//! // White noise of 0.01 deg/sqrt(s) at 10 Hz: the fitted model explains it; no gap.
//! let mut s: u64 = 7;
//! let x: Vec<f64> = (0..40_000).map(|_| {
//!     let mut a = 0.0;
//!     for _ in 0..12 { s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407); a += (s >> 11) as f64 / (1u64 << 53) as f64; }
//!     (a - 6.0) * 0.01 * 10f64.sqrt()
//! }).collect();
//! let input = GapInput::split(x, None, 10.0, 0.5).unwrap();
//! let r = diagnose(&input, &GapOptions { seeds: 20, ..Default::default() }, &|_, _, _| {}).unwrap();
//! assert_eq!(r.effect_name(), "none");
//! ```

// `!(x > 0.0)` rejects NaN along with the non-positive values; clippy's rewrite (`x <= 0.0`) would let NaN
// through, so its lints against the form are off. Numeric kernels index several arrays in step, which reads
// better than zipped iterators.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::nonminimal_bool, clippy::needless_range_loop)]

pub mod base;
pub mod chain;
pub mod compare;
pub mod describe;
mod diagnose;
pub mod effects;
pub mod ensemble;
pub mod error;
pub mod evidence;
pub mod fill;
pub mod holdout;
pub mod input;
pub mod judge;
pub mod rank;
pub mod report;
pub mod spectral;
pub mod transients;
pub mod views;

pub use base::{base_model, fit_base};
pub use chain::ProgressFn;
pub use compare::ViewGap;
pub use diagnose::diagnose;
pub use effects::{Effect, EffectFit};
pub use error::GapError;
pub use fill::{fill_gaps, gap_runs, refill};
pub use input::{GapInput, GapOptions, HoldoutCheck, MIN_PART};
pub use judge::{Evaluated, Judge};
pub use rank::{CandidateResult, PartGap};
pub use report::{BaseResult, ChainResult, GapReport, HoldoutResult, InputSummary};
pub use views::ViewKind;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaps_are_filled_linearly() {
        let x = [f64::NAN, 1.0, f64::NAN, f64::NAN, 4.0, f64::NAN];
        assert_eq!(fill_gaps(&x), vec![1.0, 1.0, 2.0, 3.0, 4.0, 4.0]);
    }

    /// Gaps are counted per part and reported (text and JSON); a part that is mostly gaps is refused with the
    /// count of its valid samples, before any statistic is tried on it.
    #[test]
    fn gaps_are_reported_and_a_part_of_gaps_is_too_short() {
        let mut x = octavar_stats::test_signals::white(8192, 3);
        for i in [10, 11, 500, 6000] {
            x[i] = f64::NAN;
        }
        let opts = GapOptions { seeds: 3, effects: vec![], ..Default::default() };
        let r = diagnose(&GapInput::split(x.clone(), None, 100.0, 0.5).unwrap(), &opts, &|_, _, _| {}).unwrap();
        assert_eq!(r.input.missing, [3, 1]);
        let text = r.text();
        assert!(
            text.starts_with("gap diagnosis: 4096 training samples (3 missing) at 100 Hz, 4096 held out (1 missing)"),
            "{text}"
        );
        let doc = r.to_json();
        assert_eq!(doc["missing_samples"], serde_json::json!({"training": 3, "holdout": 1}));
        // The report's keys are an interface (users' scripts read them): exactly these.
        let mut keys: Vec<&str> = doc.as_object().unwrap().keys().map(String::as_str).collect();
        keys.sort_unstable();
        let want = [
            "band_s",
            "base",
            "base_fit",
            "base_model",
            "candidates",
            "chain",
            "effect",
            "effect_params",
            "effects",
            "explained",
            "fit_strain",
            "fs_hz",
            "gap_after",
            "gap_before",
            "holdout",
            "holdout_predictive",
            "holdout_total",
            "input",
            "missing_samples",
            "model",
            "model_channel",
            "n_holdout",
            "n_train",
            "pruned",
            "seeds",
            "shrink",
            "sign",
            "significant",
            "size",
            "threshold",
            "total_after",
            "total_before",
            "transients",
            "unexplained",
            "verdict",
            "view",
            "views",
            "views_detail",
            "worst",
        ];
        assert_eq!(keys, want);
        // The nested sections say what the flat keys say, under names of their own.
        let section_keys = |s: &str| -> Vec<String> {
            let mut k: Vec<String> = doc[s].as_object().unwrap().keys().cloned().collect();
            k.sort_unstable();
            k
        };
        let input =
            ["channel", "fs_hz", "has_temperature", "kind", "missing_samples", "n_holdout", "n_train", "seeds", "unit"];
        assert_eq!(section_keys("input"), [&input[..8], &["transients"], &input[8..]].concat());
        assert_eq!((doc["input"]["kind"].as_str(), doc["input"]["unit"].as_str()), (Some("gyro"), Some("deg/s")));
        let base = ["band_s", "fit", "fit_strain", "model", "sign", "significant", "size", "total", "view", "worst"];
        assert_eq!(section_keys("base"), base);
        let chain = [
            "effects",
            "exchanged",
            "model",
            "model_channel",
            "pruned",
            "retried",
            "total",
            "unexplained",
            "verdict",
            "worst",
        ];
        assert_eq!(section_keys("chain"), chain);
        for (section, key, flat) in [
            ("input", "missing_samples", "missing_samples"),
            ("input", "fs_hz", "fs_hz"),
            ("base", "model", "base_model"),
            ("base", "fit", "base_fit"),
            ("base", "total", "total_before"),
            ("chain", "effects", "effects"),
            ("chain", "total", "total_after"),
            ("chain", "verdict", "verdict"),
        ] {
            assert_eq!(doc[section][key], doc[flat], "{section}.{key}");
        }
        assert_eq!(doc["holdout"]["worst"]["base"], doc["worst"]["holdout"][0]);
        assert_eq!(doc["holdout"]["total"], doc["holdout_total"]);

        // The holdout keeps one sample in 20 (sample 6000 was a gap already): 204 that are not gaps.
        for (i, v) in x.iter_mut().enumerate().skip(4096) {
            if i % 20 != 0 {
                *v = f64::NAN;
            }
        }
        let e = diagnose(&GapInput::split(x, None, 100.0, 0.5).unwrap(), &opts, &|_, _, _| {}).unwrap_err();
        assert!(matches!(e, GapError::TooShort { part: "holdout", n: 4096, missing: 3892, .. }), "{e:?}");
        assert_eq!(
            e.to_string(),
            "the holdout part has 204 samples that are not gaps (3892 of its 4096 are NaN); the gap diagnosis needs \
             at least 256"
        );
    }

    /// A corrupted sample (infinite, or too large for any sensor) is refused up front, named by its column, part
    /// and index in the part, wherever it falls: a holdout's would otherwise leave that part's Allan view empty.
    #[test]
    fn a_corrupted_sample_is_named_by_part_and_index() {
        let x = octavar_stats::test_signals::white(2048, 4);
        let opts = GapOptions { seeds: 3, effects: vec![], ..Default::default() };
        for (at, value, part, index) in
            [(5, 1e200, "training", 5), (1500, -3e101, "holdout", 476), (2047, f64::INFINITY, "holdout", 1023)]
        {
            let mut y = x.clone();
            y[at] = value;
            let e = diagnose(&GapInput::split(y, None, 10.0, 0.5).unwrap(), &opts, &|_, _, _| {}).unwrap_err();
            assert!(
                matches!(e, GapError::BadSample { column: "rate", part: p, index: i, .. } if p == part && i == index),
                "{e:?}"
            );
        }
        let mut t = vec![23.0; 2048];
        t[2000] = 1e150;
        let e = diagnose(&GapInput::split(x, Some(t), 10.0, 0.5).unwrap(), &opts, &|_, _, _| {}).unwrap_err();
        assert_eq!(
            e.to_string(),
            "the holdout part's temperature sample 976 (sample 2000 of the record) is 1e150: no sensor reports a \
             value beyond 1e100 (a corrupted sample?)"
        );
    }

    #[test]
    fn split_and_join() {
        let i = GapInput::split(vec![0.0; 1000], None, 1.0, 0.25).unwrap();
        assert_eq!((i.n_train, i.n_holdout()), (750, 250));
        assert!(GapInput::split(vec![0.0; 10], None, 1.0, 1.0).is_err());
        let j = GapInput::joined(vec![0.0; 3], Some(vec![1.0; 3]), vec![0.0; 2], Some(vec![2.0; 2]), 1.0).unwrap();
        assert_eq!(j.temp_c.unwrap(), vec![1.0, 1.0, 1.0, 2.0, 2.0]);
        assert!(GapInput::joined(vec![0.0; 3], Some(vec![1.0; 3]), vec![0.0; 2], None, 1.0).is_err());
    }
}

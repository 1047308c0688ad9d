//! The report as text a person reads: the record and what was masked, the base model, every view's gap, where the
//! gap lies, each step's candidates, the held-out checks and the verdict. Scripts read some of these lines: their
//! wording is stable.

use std::io::{self, Write};

use serde_json::Value;

use super::{GapReport, Verdict};
use crate::chain::{NamedBy, Step};
use crate::compare::ViewGap;
use crate::effects::{Effect, EffectParams};
use crate::rank::{self, CandidateResult, Location, PartGap};
use crate::transients;
use crate::views::ViewKind;
use octavar_stats::fit::Term;

/// Below this shrink of a right model ([`rank::shrink_if_right`]) the text report says the held-out check is
/// weak.
const WEAK_HOLDOUT_SHRINK: f64 = 0.7;

impl GapReport {
    /// A short text a person can read: what, where, how big, how sure, what the fix buys on held-out data.
    pub fn text(&self) -> String {
        let mut out = Vec::new();
        self.write_text(&mut out).expect("writing to memory does not fail");
        String::from_utf8(out).expect("the report is UTF-8")
    }

    /// Write [`GapReport::text`] to `w`, section by section.
    ///
    /// # Errors
    /// The sink's.
    pub fn write_text(&self, w: &mut dyn Write) -> io::Result<()> {
        self.input_lines(w)?;
        self.base_lines(w)?;
        self.view_lines(w)?;
        self.chain_lines(w)?;
        self.worst_holdout_line(w)?;
        self.diagnosis_lines(w)?;
        self.verdict_line(w)
    }

    /// The record: its parts, what is missing and what was masked.
    fn input_lines(&self, s: &mut dyn Write) -> io::Result<()> {
        let missing = |m: usize| if m > 0 { format!(" ({m} missing)") } else { String::new() };
        let hold = if self.input.n_holdout > 0 {
            format!("{} held out{}", self.input.n_holdout, missing(self.input.missing[1]))
        } else {
            "no holdout".to_string()
        };
        let [mt, mh] = transients::parts::seconds(&self.input.transients);
        let masked = if self.input.transients.is_empty() {
            "no transient masked".to_string()
        } else {
            format!(
                "{} transient{} masked ({mt:.1} s of training, {mh:.1} s of holdout)",
                self.input.transients.len(),
                if self.input.transients.len() == 1 { "" } else { "s" }
            )
        };
        writeln!(
            s,
            "gap diagnosis: {} training samples{} at {} Hz, {hold}; {masked}; ensemble of {} seeds{}",
            self.input.n_train,
            missing(self.input.missing[0]),
            self.input.rate_hz,
            self.input.seeds,
            if self.input.has_temperature { ", driven by the recorded temperature" } else { "" }
        )?;
        for t in &self.input.transients {
            writeln!(
                s,
                "  transient in the {} part at {:.1} s for {:.1} s, peak {:.3e} {}: masked as a gap",
                t.part.name(),
                t.start_s,
                t.duration_s,
                t.peak_dps,
                self.input.quantity.unit()
            )?;
        }
        Ok(())
    }

    /// The base model's terms, and a note where its fit cannot follow the curve.
    fn base_lines(&self, s: &mut dyn Write) -> io::Result<()> {
        let b = &self.base;
        let q = self.input.quantity;
        writeln!(
            s,
            "base model (IEEE 952 fit on training): N {:.3e} {}, B {:.3e} {}, K {:.3e} {}, R {:.3e} {}, bias {:.4e} {}",
            b.gyro.n_deg_per_rt_s,
            Term::N.unit_of(q),
            b.gyro.b_dps,
            Term::B.unit_of(q),
            b.gyro.k_dps_per_rt_s,
            Term::K.unit_of(q),
            b.gyro.r_dps_per_s,
            Term::R.unit_of(q),
            b.gyro.bias_dps,
            q.unit()
        )?;
        if let Some(r) = self.fit_strain() {
            writeln!(
                s,
                "note: the IEEE five-term fit cannot follow the training curve (reduced chi-square {r:.1}, about 1 when it can): the record has a shape those terms lack"
            )?;
        }
        Ok(())
    }

    /// Every view's gap on training and holdout, base and after the chain.
    fn view_lines(&self, s: &mut dyn Write) -> io::Result<()> {
        writeln!(s, "views (gap: the RMS z of real against the ensemble over the worst decade of tau; about 1 when they agree; base -> {}):", if self.chain.steps.is_empty() { "base" } else { "with the chain" })?;
        let after = self.final_eval();
        let f = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.2}"));
        let gap = |v: &[ViewGap], k: ViewKind| v.iter().find(|x| x.view == k).map(|x| x.gap);
        for g in &self.base.eval.training {
            writeln!(
                s,
                "  {:<13} training {:>7.2} -> {:>7}   holdout {:>7} -> {:>7}",
                g.view.name(),
                g.gap,
                f(gap(&after.training, g.view)),
                f(gap(&self.base.eval.holdout, g.view)),
                f(gap(&after.holdout, g.view))
            )?;
        }
        Ok(())
    }

    /// Where the gap lies, and each step's candidates.
    fn chain_lines(&self, s: &mut dyn Write) -> io::Result<()> {
        if let Some(l) = &self.base.location {
            writeln!(
                s,
                "gap {:.2} (threshold {:.1}: {}): {}",
                self.training.gap_before,
                rank::SIGNIFICANT_GAP,
                if self.base.significant { "significant" } else { "not significant" },
                where_text(l)
            )?;
        }
        for (k, step) in self.chain.steps.iter().enumerate() {
            if k > 0 {
                writeln!(
                    s,
                    "step {}: the gap left on the model with {}: {:.2}: {}",
                    k + 1,
                    chain_names(&self.chain.steps[..k]),
                    step.training.gap_before,
                    where_text(&step.location)
                )?;
            }
            writeln!(
                s,
                "candidates{} (gap after in that view, total over views, score = total x (1 + 0.05 x params); holdout gap after):",
                if self.chain.steps.len() > 1 { format!(" of step {}", k + 1) } else { String::new() }
            )?;
            candidate_lines(s, &step.candidates, Some(step.effect))?;
        }
        if !self.chain.last_tried.is_empty() {
            writeln!(
                s,
                "candidates tried on the model with {} (none removes a quarter of the gap it leaves):",
                chain_names(&self.chain.steps)
            )?;
            candidate_lines(s, &self.chain.last_tried, None)?;
        }
        if let Some(r) = &self.chain.retried {
            let greedy: Vec<&str> = r.greedy.iter().map(|e| e.name()).collect();
            writeln!(
                s,
                "searched again from {}, the first ranking's runner-up: the greedy chain ({}) left a significant gap ({:.2}; total over views {:.2}) that this chain explains",
                r.first.name(),
                greedy.join(" + "),
                r.greedy_worst,
                r.greedy_total
            )?;
        }
        for p in &self.chain.pruned {
            writeln!(
                s,
                "taken out of the chain: {}, made redundant by the rest of the chain (the chain learnt without it: total over views {:.2}, with it {:.2})",
                p.effect.name(),
                p.total_without,
                p.total_with
            )?;
        }
        for x in &self.chain.exchanged {
            writeln!(
                s,
                "exchanged: {} for {}, the runner-up of its step (the chain learnt with it: total over views {:.2}, with {} {:.2})",
                x.effect.name(),
                x.replacement.name(),
                x.total_after,
                x.effect.name(),
                x.total_with
            )?;
        }
        if self.chain.steps.is_empty() {
            writeln!(
                s,
                "candidates (gap after in that view, total over views, score = total x (1 + 0.05 x params); holdout gap after):"
            )?;
            candidate_lines(s, &self.chain.candidates, None)?;
        }
        Ok(())
    }

    /// The worst view on the holdout.
    fn worst_holdout_line(&self, s: &mut dyn Write) -> io::Result<()> {
        if self.worst[2].is_finite() {
            writeln!(
                s,
                "worst view on the holdout: {:.2} -> {:.2}{}",
                self.worst[2],
                self.worst[3],
                match self.base.eval.holdout.iter().max_by(|a, b| a.gap.total_cmp(&b.gap)) {
                    Some(w) if self.base.significant && Some(w.view) != self.base.location.as_ref().map(|l| l.view) =>
                        format!(" ({}: the holdout has a gap of its own that training did not show)", w.view.name()),
                    _ => String::new(),
                }
            )?;
        }
        Ok(())
    }

    /// The chain's effects, each with its gap before and after on training and held out.
    fn diagnosis_lines(&self, s: &mut dyn Write) -> io::Result<()> {
        if let Some(first) = self.chain.steps.first() {
            write!(
                s,
                "diagnosis: {}{} (gap {:.2} -> {:.2} on training, shrink {:.0}%",
                first.effect.name(),
                named_by_text(first),
                self.training.gap_before,
                self.training.gap_after,
                100.0 * self.training.shrink
            )?;
            if let Some(h) = self.holdout.first {
                write!(
                    s,
                    "; held out, parameters frozen: {:.2} -> {:.2}, shrink {:.0}%{}",
                    h.gap_before,
                    h.gap_after,
                    100.0 * h.shrink,
                    match self.holdout.predictive {
                        Some(p) => format!(
                            "; against the predictive ensembles, which carry the learnt parameters' error: {:.2} -> {:.2}, shrink {:.0}%",
                            p.gap_before,
                            p.gap_after,
                            100.0 * p.shrink
                        ),
                        None => String::new(),
                    }
                )?;
            }
            writeln!(s, ")")?;
            for step in &self.chain.steps[1..] {
                writeln!(
                    s,
                    "  then {}{} ({} {}, gap {:.2} -> {:.2} on training{})",
                    step.effect.name(),
                    named_by_text(step),
                    step.location.view.name(),
                    band_text(&step.location),
                    step.training.gap_before,
                    step.training.gap_after,
                    step.holdout
                        .map_or(String::new(), |h| format!(", {:.2} -> {:.2} held out", h.gap_before, h.gap_after))
                )?;
            }
            let refitted: Vec<&str> = self.chain.steps.iter().filter(|s| s.moved()).map(|s| s.effect.name()).collect();
            if !refitted.is_empty() {
                writeln!(
                    s,
                    "backfitted: {} estimated again with every other effect of the chain in place (the model carries the values of the last round)",
                    refitted.join(", ")
                )?;
            }
            if let Some(last) = self.chain.steps.iter().rposition(|s| s.joint) {
                writeln!(
                    s,
                    "jointly re-estimated: the base terms with {} (deterministic parts by least squares, the rest on the Allan curve)",
                    chain_names(&self.chain.steps[..=last])
                )?;
            }
            if let (true, Some(t)) = (self.chain.steps.len() > 1, self.holdout.total) {
                writeln!(
                    s,
                    "the whole chain ({}), held out with every parameter frozen, at the worst of its bands: {:.2} -> {:.2}, shrink {:.0}%",
                    chain_names(&self.chain.steps),
                    t.gap_before,
                    t.gap_after,
                    100.0 * t.shrink
                )?;
            }
            if let Some(note) = self.holdout.first.as_ref().and_then(weak_holdout_note) {
                writeln!(s, "{note}")?;
            }
        }
        Ok(())
    }

    /// The verdict where no effect explains the gap.
    fn verdict_line(&self, s: &mut dyn Write) -> io::Result<()> {
        match self.verdict() {
            Verdict::NoGap => {
                writeln!(s, "diagnosis: none (the simulation of the fitted model agrees with the record)")?;
            }
            Verdict::Unexplained => {
                let what = match &self.chain.unexplained {
                    Some(u) => format!(
                        ": {} view, {} the simulation, |z| RMS {:.1}: {}",
                        u.view.name(),
                        u.sign.name(),
                        u.z_rms,
                        u.text
                    ),
                    None => String::new(),
                };
                if self.chain.steps.is_empty() {
                    writeln!(s, "diagnosis: none: the gap is significant, but no candidate removes a quarter of it; it is not one of the known effects{what}")?;
                } else {
                    writeln!(s, "left unexplained after the chain: a significant gap that no candidate removes a quarter of{what}")?;
                }
            }
            Verdict::Explained => {}
        }
        Ok(())
    }
}

/// `, named by its estimator's test where no view's gap did (t = 6.20, beyond 5)` for a step its estimator named
/// (beside a significant gap no view's candidate took: `..., beside a gap no view's candidate took`); empty for a
/// step the views named.
fn named_by_text(step: &Step) -> String {
    match step.named_by {
        NamedBy::View => String::new(),
        NamedBy::ViewsLessJumps { gap_before, gap_after } => format!(
            ", named by the views with the jumps taken out of the record and of every member alike, where the members' \
             fresh jumps hid it (gap {gap_before:.2} -> {gap_after:.2})"
        ),
        NamedBy::Estimator(ev) => {
            let route = if step.training.gap_before > rank::SIGNIFICANT_GAP {
                "beside a gap no view's candidate took"
            } else {
                "where no view's gap did"
            };
            format!(
                ", named by its estimator's test {route} ({} = {:.2}, beyond {})",
                ev.statistic, ev.value, ev.threshold
            )
        }
    }
}

/// `a, b then c` of a chain's effects.
fn chain_names(steps: &[Step]) -> String {
    steps.iter().map(|s| s.effect.name()).collect::<Vec<_>>().join(" + ")
}

/// `tau 1.0e0 .. 2.0e1 s`.
fn band_text(l: &Location) -> String {
    format!("tau {:.3e} .. {:.3e} s", l.band_s[0], l.band_s[1])
}

/// Where a gap lies and its size, as the report's line says it.
fn where_text(l: &Location) -> String {
    let size = match (l.ratio, l.correlation) {
        (Some(r), _) if l.view == ViewKind::Adev => format!(", real/sim Allan deviation x{r:.3}"),
        (Some(r), _) => format!(", real/sim power x{r:.3}"),
        (_, Some([a, b])) => format!(", coherence with temperature {a:.2} real vs {b:.2} simulated"),
        _ => format!(" ({})", l.labels.join(", ")),
    };
    format!(
        "worst view {}, {}, real {} the simulation, |z| RMS {:.1} over {} point(s){size}",
        l.view.name(),
        band_text(l),
        l.sign.name(),
        l.z_rms,
        l.points
    )
}

/// One line per candidate of a step, the chosen one starred.
fn candidate_lines(s: &mut dyn Write, candidates: &[CandidateResult], chosen: Option<Effect>) -> io::Result<()> {
    for c in candidates {
        let mark = if Some(c.effect) == chosen { "*" } else { " " };
        match (&c.fit, c.gap_after, c.total_after, c.score) {
            (Some(f), Some(g), Some(t), Some(sc)) => {
                let h = c.holdout_after.map_or("-".to_string(), |h| format!("{h:.2}"));
                writeln!(
                    s,
                    " {mark}{:<13} gap {g:>7.2} total {t:>7.2} score {sc:>7.2}  holdout {h:>7}  {}",
                    c.effect.name(),
                    compact(&f.params)
                )?;
            }
            _ => {
                writeln!(s, " {mark}{:<13} no trace in the training data", c.effect.name())?;
            }
        }
    }
    Ok(())
}

/// An effect's parameters as `a=1.000e0 b=2.000e0`, in the order of their JSON object.
fn compact(params: &EffectParams) -> String {
    match serde_json::to_value(params).unwrap_or(Value::Null) {
        Value::Object(m) => m
            .into_iter()
            .map(|(k, v)| match v {
                Value::Number(n) => format!("{k}={:.4e}", n.as_f64().unwrap_or(f64::NAN)),
                other => format!("{k}={}", other),
            })
            .collect::<Vec<_>>()
            .join(" "),
        other => other.to_string(),
    }
}

/// The report's `note:` line when the holdout's gap before a fix is too small for a right model to shrink it by
/// [`WEAK_HOLDOUT_SHRINK`] (see [`rank::shrink_if_right`]); `None` when it is large enough.
fn weak_holdout_note(h: &PartGap) -> Option<String> {
    let expected = rank::shrink_if_right(h.gap_before);
    (expected < WEAK_HOLDOUT_SHRINK).then(|| {
        format!(
            "note: the holdout's gap before a fix is only {:.2}, and a model that is right still scores about {:.0} there (an RMS z), so about {:.0}% is the shrink to expect even of the right effect; a smaller shrink here is weak evidence against it",
            h.gap_before,
            rank::RIGHT_MODEL_GAP,
            100.0 * expected
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The note appears exactly below a gap of 1 / (1 - 0.7) = 3.33 before a fix, and states the shrink a right
    /// model (RMS z of 1 after) would reach: 1 - 1/1.8 = 44% at 1.8.
    #[test]
    fn a_weak_holdout_gets_a_note_with_the_shrink_a_right_model_reaches() {
        let part = |before: f64| PartGap::new(before, 1.0);
        let note = weak_holdout_note(&part(1.8)).expect("a note at 1.8");
        assert!(note.starts_with("note:") && note.contains("only 1.80") && note.contains("about 44%"), "{note}");
        assert!(weak_holdout_note(&part(3.30)).is_some());
        assert!(weak_holdout_note(&part(3.36)).is_none());
        assert!(weak_holdout_note(&part(12.0)).is_none());
        // A holdout that shows no gap at all: a right model cannot shrink it, and the note says 0%, not a negative.
        assert!(weak_holdout_note(&part(0.8)).unwrap().contains("about 0%"));
    }
}

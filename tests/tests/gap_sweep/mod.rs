//! The gap diagnosis over every effect, every pair and random triples of them, on records from two generators
//! (issue 31): shared::sim, and the independent generator of [`crate::indep_gyro`], which shares no code with it.
//!
//! A case is a kind (the effects present, or a control) and a seed. The seed draws the record (its rate, its
//! length, the base gyro) and each effect's parameters from its own stream, so an effect has the same parameters
//! at a seed alone, in a pair and in a triple, except where a partner bounds it (a resonance below a filter's
//! corner). The truth is drawn once as the independent generator's parameters ([`crate::indep_gyro::IndepGyro`]);
//! shared::sim makes its record from that truth's `GyroSim` ([`crate::indep_gyro::oracle`]), the independent
//! generator from the truth itself, each with its own noise. Each generator's cases count on their own.
//!
//! Kinds: each item alone, every pair of items, [`TRIPLES`] triples of them drawn once from a fixed seed, and
//! three controls. The items are the effects of [`Effect::ALL`] and `contamination` (epsilon-contaminated noise,
//! which a right diagnosis names `outliers`; [`cases::Item`]): 11 singles and 54 pairs, since rare spikes and a
//! contamination are one effect twice over and no kind holds both. The controls: `none`; `none+bump` (a transient
//! bump); `none+temperature` (a temperature channel the rate does not follow). A case passes, as in `gap_withheld`, when the effects named are the effects present and the
//! held-out gap after the whole chain is below [`octavar::gap::rank::SIGNIFICANT_GAP`]; a control passes on
//! `none`. The oracle (the true model's ensemble, judged at the bands the diagnosis located, or at the worst view
//! when it located none) runs beside every case.
//!
//! The record: a rate log-uniform in 1-200 Hz and a length log-uniform within 1.5-48 h and 1.7e5-1.1e6 samples
//! (1 Hz x 48 h to 200 Hz x 1.5 h). The base: N log-uniform 0.002-0.02 deg/sqrt(s), B 0.2-1 N, K 1e-3 B.
//!
//! Sizes are `s` times the effect's local noise, `s` log-uniform in [2, 30]. Local noise is the reference
//! `gap_withheld` draws each size against (the base Allan deviation at the tau where the signature peaks) times
//! its lower multiplier over 3, so that `s = 3` is `gap_withheld`'s smallest size:
//!
//! | effect | local noise (`s` times it) | time scale | why the time scale is bounded so |
//! |---|---|---|---|
//! | temperature | `adev(P/3) / (swing/2 |H|)` in deg/s per degC, swing 1-5 degC, `|H|` the lag's gain | cycle P from max(300 s, 20 samples) to D/3; lag from 3 samples to P/2 | a lag beyond half the cycle only scales the coupling down |
//! | sinusoid | `adev(0.37 P)` (amplitude) | P from 4 samples to D/3 | |
//! | bandwidth | (none: the white noise sets it) | corner 0.05-0.4 of the rate | above 0.4 the sampled filter hardly bends the curve; the corner time constant is then 0.4-3 samples |
//! | gauss_markov | `adev(2T) / 0.62` (sigma) | T from 4 samples to D/3 | |
//! | quantization | `sigma_w / 3` (the step; sigma_w the white noise's per-sample sd): steps of 0.7-10 sigma_w | (K raised so the walk crosses a few steps) | the case's other effects are sized against the record's noise: the base with that walk and the rounding's white noise (`step^2 / 12` a sample) |
//! | bias_steps | `(5/3) sqrt(2) floor` (step sd; floor the smallest base Allan deviation) | 8 to 80 steps per record | fewer than 8 is not a rate; more, each step is a random walk's |
//! | outliers | `(8/3) sigma_w` (spike size; sizes spread 0.9-1.1 of it): 5-80 sigma_w | 10 to 300 spikes per half record | |
//! | contamination | (its own ranges) a share log-uniform from 1e-5 (20 spikes a record at least) to 0.2 of the samples; sizes 3-50 local sds (the white noise's, with the sample-to-sample part of a Gauss-Markov process, a resonance or a sinusoid beside it: `cases::local_sd`), uniform over up to 1.5 times either way of a centre at least one sd beyond `sqrt(2 ln(1 / share))` (where a Gaussian's tails hold the same share); runs of up to 1, 2 or 3 samples | | a centre inside the noise's own tail is no contamination, whatever the share |
//! | resonance | the white noise's PSD (the bump's peak PSD is s times it) | f0 from 256 Q / D (a bump 4 bins wide in a Welch segment of D/64) to 0.4 of the rate, or 0.7 of a filter's corner; Q 3-30 | a bump the anti-alias filter removes is not there to be named |
//! | bistable | `(8/3) sqrt(2) adev(dwell/10)` (step) | each dwell from max(30 samples, D/3000) to D/40 | a dwell of a few samples is white noise, and fewer than 40 flips are not a rate |
//! | warm_up | `10 sqrt(2) adev(tau)` (size, either sign) | tau from D/400 to D/3 | shorter, the warm-up is a transient of the first samples |
//!
//! Running it (`SWEEP_SEEDS=a..b`, `SWEEP_KINDS` a comma list of kinds such as `temperature`,
//! `bandwidth+resonance`, `none+bump`, or of groups `singles`, `pairs`, `pairs:K` (K pairs evenly spread),
//! `triples`, `triples:K`, `controls`, `all`, each at every seed, or `random_triples` (`random_triples:K`), each
//! triple at one seed of its own, the seeds taken in turn ([`cases::seeded_kinds_from`]);
//! `SWEEP_GEN=sim|indep|both`; `SWEEP_OUT=file`; `SWEEP_DUMP=folder` writes each case's record there as CSV, for
//! `octavar gap` by hand; `SWEEP_ABLATION=1` also runs the true model without each effect present, its other
//! terms fitted again, and the summary says in how many cases every effect is visible to the views and how the
//! diagnosis does there):
//!
//! ```sh
//! SWEEP_SEEDS=0..2 SWEEP_KINDS=singles,pairs:10 cargo test -p octavar-tests --release gap_sweep::sweep -- --ignored --nocapture
//! SWEEP_SEEDS=0..10 SWEEP_KINDS=random_triples cargo test -p octavar-tests --release gap_sweep::sweep -- --ignored --nocapture
//! cargo test -p octavar-tests --release gap_sweep::summary_of_file -- --ignored --nocapture
//! CI=1 cargo test -p octavar-tests --release gap_sweep::guard -- --nocapture
//! ```
//!
//! `sweep` appends one JSON line per finished case to `SWEEP_OUT` (default `target/gap_sweep.jsonl`) and skips
//! the cases already there (by generator, kind and seed), so a sweep that outlives a session resumes; it ends
//! with the summary, which `summary_of_file` prints alone. A file holds one version of the draw: start a new one
//! after changing a range.
//!
//! The kinds follow [`cases::Item::all`]: an effect added to the vocabulary joins the singles, pairs and triples
//! once [`cases::draw`] has its range. A contamination is the independent generator's `Contamination` (runs of
//! 1-3 spikes, weights 4:2:1); shared::sim draws it through `indep_gyro::oracle::outliers`, whose runs have a
//! geometric tail.
//!
//! Both generators read the resonance's damped oscillator at each sample: shared::sim by the ARMA(2,1) process
//! with its autocovariance, the independent generator by circulant embedding of that autocovariance; each is
//! checked against the oscillator's closed form on its own.

mod cases;

use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use octavar::gap::{diagnose, Effect, GapInput, GapOptions, Judge};
use octavar_shared::sensor::Channel;
use octavar_shared::sim::GyroSim;
use serde::{Deserialize, Serialize};

pub use cases::{Gen, Kind};

/// The number of random triples.
pub const TRIPLES: usize = 100;

const PASS_GAP: f64 = octavar::gap::rank::SIGNIFICANT_GAP;

/// One finished case, as a line of the sweep's file.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Row {
    pub gen: String,
    pub kind: String,
    pub seed: u64,
    pub group: String,
    pub pass: bool,
    pub oracle_pass: bool,
    pub named: Vec<String>,
    /// The worst view's held-out gap of the base model and of the whole chain.
    pub holdout_before: Option<f64>,
    pub holdout_after: Option<f64>,
    /// The oracle's held-out gap.
    pub oracle_gap: Option<f64>,
    /// The worst view's training gap of the whole chain: above significance, the chain stopped beside a gap it
    /// could not explain; below, nothing was left for a view to see.
    #[serde(default)]
    pub training_after: Option<f64>,
    pub transients: usize,
    pub rate_hz: f64,
    pub samples: usize,
    pub what: String,
    pub secs: f64,
    /// With `SWEEP_ABLATION=1`: for each effect present, the training gap (the worst view over its worst decade)
    /// of the true model without it, its other terms fitted again on the training part ([`refitted_without`]).
    /// Below the significance threshold, no view can tell the effect from its absence on this record, whatever
    /// the diagnosis does.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub ablation: Vec<(String, f64)>,
}

impl Row {
    /// Whether every effect present moves some view beyond significance when it is taken out of the true model
    /// (`None` when the ablation was not run, or for a control).
    pub fn views_can_see_all(&self) -> Option<bool> {
        (!self.ablation.is_empty()).then(|| self.ablation.iter().all(|(_, g)| *g >= PASS_GAP))
    }
}

/// The true model `gyro` (on `channel`) without `effect`: its field cleared, or for quantisation the record's
/// lattice taken away.
fn without(gyro: &GyroSim, channel: Option<&Channel>, effect: Effect) -> (GyroSim, Option<Channel>) {
    match effect.taken_from(gyro) {
        Some(g) => (g, channel.cloned()),
        None => (gyro.clone(), None),
    }
}

/// The training part as the refit of [`refitted_without`] reads it: the samples with their missing or masked runs
/// filled, those runs, and the temperature.
struct Training<'a> {
    filled: Vec<f64>,
    gaps: Vec<std::ops::Range<usize>>,
    temp_c: Option<&'a [f64]>,
    rate_hz: f64,
}

impl<'a> Training<'a> {
    fn of(masked: &'a GapInput) -> Training<'a> {
        let train = &masked.rate_dps[..masked.n_train];
        Training {
            filled: octavar::gap::fill_gaps(train),
            gaps: octavar::gap::gap_runs(train),
            temp_c: masked.temp_c.as_ref().map(|t| &t[..masked.n_train]),
            rate_hz: masked.rate_hz,
        }
    }
}

/// The true model without `effect`, its other terms fitted again on the training part as the diagnosis would fit
/// them once the effect was left out: the base terms from the diagnosis's own IEEE fit `base`, then the base, the
/// other stochastic effects and the deterministic ones re-estimated jointly on the training samples
/// ([`octavar::gap::chain::joint::reestimate`]). A slow effect the base terms can take up (a Gauss-Markov process
/// of a long correlation time read as a random walk) then leaves no gap, as on the record it leaves none. The other
/// effects keep their true form; where one is a jump process, its jumps stay in the samples the refit sees.
fn refitted_without(
    base: &GyroSim,
    training: &Training,
    gyro: &GyroSim,
    channel: Option<&Channel>,
    effect: Effect,
) -> (GyroSim, Option<Channel>) {
    let (g, ch) = without(gyro, channel, effect);
    let g = GyroSim {
        bias_dps: base.bias_dps,
        n_deg_per_rt_s: base.n_deg_per_rt_s,
        b_dps: base.b_dps,
        k_dps_per_rt_s: base.k_dps_per_rt_s,
        r_dps_per_s: base.r_dps_per_s,
        ..g
    };
    let t = training;
    let model = octavar::gap::chain::Model { gyro: g, spreads: Vec::new(), channel: ch };
    let refit = octavar::gap::chain::joint::reestimate(&model, &t.filled, None, &t.gaps, t.temp_c, t.rate_hz);
    (refit.map_or(model.gyro, |m| m.gyro), ch)
}

fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

/// Diagnose one case of one generator, with the oracle beside it.
pub fn run_case(gen: Gen, kind: &Kind, seed: u64) -> Row {
    let t0 = Instant::now();
    let case = cases::draw(kind, seed);
    let (x, t) = case.record(gen, seed);
    if let Some(dir) = std::env::var_os("SWEEP_DUMP") {
        dump(&PathBuf::from(dir), gen, kind, seed, case.rate_hz, &x, t.as_deref());
    }
    let input = GapInput::split(x, t, case.rate_hz, 0.5).unwrap();
    let r = diagnose(&input, &GapOptions::default(), &|_, _, _| {}).unwrap();
    let named: Vec<Effect> = r.effects();
    let after = r.holdout.total.map_or(f64::NAN, |h| h.gap_after);
    let before = r.holdout.total.map_or(f64::NAN, |h| h.gap_before);
    let present = kind.effects();
    let named_right = named.len() == present.len() && present.iter().all(|e| named.contains(e));
    let pass = if present.is_empty() { named.is_empty() } else { named_right && after < PASS_GAP };
    // The oracle: the true model's ensemble on the record as the diagnosis saw it, at its located bands.
    let masked = r.masked_input(&input);
    let judge = Judge::new(&masked, &GapOptions::default());
    let (model, channel) = case.oracle();
    let e = judge.evaluate(&model, &[], channel.as_ref(), None, "truth").unwrap();
    let worst = e.holdout.iter().map(|v| v.gap).fold(f64::NAN, f64::max);
    let oracle_gap = octavar::gap::rank::chain_gap(&e.holdout, r.judged_locations()).unwrap_or(worst);
    let ablation = if std::env::var_os("SWEEP_ABLATION").is_some() {
        let training = Training::of(&masked);
        present
            .iter()
            .map(|&eff| {
                let (g, ch) = refitted_without(&r.base.gyro, &training, &model, channel.as_ref(), eff);
                let gap = judge
                    .evaluate(&g, &[], ch.as_ref(), None, "truth without one effect")
                    .map_or(f64::NAN, |e| octavar::gap::rank::gap_of(&e.training));
                (eff.name().to_string(), gap)
            })
            .collect()
    } else {
        Vec::new()
    };
    Row {
        gen: gen.name().into(),
        kind: kind.name(),
        seed,
        group: kind.group().into(),
        pass,
        oracle_pass: oracle_gap < PASS_GAP,
        named: named.iter().map(|e| e.name().to_string()).collect(),
        holdout_before: finite(before),
        holdout_after: finite(after),
        oracle_gap: finite(oracle_gap),
        training_after: finite(r.worst[1]),
        transients: r.input.transients.len(),
        rate_hz: case.rate_hz,
        samples: case.samples,
        what: case.what.clone(),
        secs: t0.elapsed().as_secs_f64(),
        ablation,
    }
}

/// The record of a case as CSV (`rate_dps` and, where it has one, `temp_c`) in `dir`, named by generator, kind,
/// seed and rate, so that `octavar gap` can be run on it by hand.
fn dump(dir: &std::path::Path, gen: Gen, kind: &Kind, seed: u64, rate_hz: f64, x: &[f64], t: Option<&[f64]>) {
    std::fs::create_dir_all(dir).expect("SWEEP_DUMP is a writable folder");
    let path = dir.join(format!("{}-{}-{seed}-{rate_hz:.4}Hz.csv", gen.name(), kind.name()));
    let mut w = std::io::BufWriter::new(std::fs::File::create(&path).expect("the dump file opens"));
    let header = if t.is_some() { "rate_dps,temp_c" } else { "rate_dps" };
    writeln!(w, "{header}").unwrap();
    for (i, v) in x.iter().enumerate() {
        match t {
            Some(t) => writeln!(w, "{v},{}", t[i]).unwrap(),
            None => writeln!(w, "{v}").unwrap(),
        }
    }
}

fn show(x: Option<f64>) -> String {
    x.map_or("-".into(), |v| format!("{v:.2}"))
}

/// One line per case on stderr.
fn log_row(r: &Row) {
    eprintln!(
        "{:<5} {:<38} seed {:>3} fs {:>7.2} n {:>7}: named {:<30} holdout {} -> {} oracle {} {} ({:.1} s) [{}]",
        r.gen,
        r.kind,
        r.seed,
        r.rate_hz,
        r.samples,
        if r.named.is_empty() { "none".into() } else { r.named.join("+") },
        show(r.holdout_before),
        show(r.holdout_after),
        show(r.oracle_gap),
        if r.pass { "ok" } else { "FAIL" },
        r.secs,
        r.what
    );
}

/// The sweep's file: `SWEEP_OUT`, or `gap_sweep.jsonl` in the target directory.
fn out_path() -> PathBuf {
    if let Some(p) = std::env::var_os("SWEEP_OUT") {
        return PathBuf::from(p);
    }
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../target"), PathBuf::from);
    target.join("gap_sweep.jsonl")
}

/// The rows of a sweep's file (none when there is no file; a torn last line is skipped).
pub fn read_rows(path: &std::path::Path) -> Vec<Row> {
    let Ok(text) = std::fs::read_to_string(path) else { return Vec::new() };
    text.lines().filter_map(|l| serde_json::from_str(l).ok()).collect()
}

fn env_seeds(default: &str) -> std::ops::Range<u64> {
    let s = std::env::var("SWEEP_SEEDS").unwrap_or_else(|_| default.into());
    let (a, b) = s.split_once("..").expect("SWEEP_SEEDS=a..b");
    a.parse().unwrap()..b.parse().unwrap()
}

fn env_gens() -> Vec<Gen> {
    match std::env::var("SWEEP_GEN").as_deref() {
        Ok("sim") => vec![Gen::Sim],
        Ok("indep") => vec![Gen::Indep],
        Ok("both") | Err(_) => vec![Gen::Sim, Gen::Indep],
        Ok(other) => panic!("SWEEP_GEN={other}: sim, indep or both"),
    }
}

/// Run every case of `gens` x `kinds` x `seeds` not yet in `path`, appending a line for each as it finishes.
pub fn sweep_into(path: &std::path::Path, gens: &[Gen], cases: &[(Kind, u64)]) -> Vec<Row> {
    let done: std::collections::HashSet<(String, String, u64)> =
        read_rows(path).into_iter().map(|r| (r.gen, r.kind, r.seed)).collect();
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).unwrap();
    }
    let mut rows = Vec::new();
    for (kind, seed) in cases {
        for &gen in gens {
            if done.contains(&(gen.name().to_string(), kind.name(), *seed)) {
                continue;
            }
            let row = run_case(gen, kind, *seed);
            log_row(&row);
            let mut f = std::fs::OpenOptions::new().create(true).append(true).open(path).unwrap();
            writeln!(f, "{}", serde_json::to_string(&row).unwrap()).unwrap();
            rows.push(row);
        }
    }
    rows
}

/// A floor: the group, whether it holds per kind or overall, the share.
struct Floor {
    group: &'static str,
    each: bool,
    share: f64,
}

/// The issue's floors (printed, not asserted, by the sweep).
const FLOORS: [Floor; 6] = [
    Floor { group: "single", each: false, share: 0.95 },
    Floor { group: "single", each: true, share: 0.85 },
    Floor { group: "pair", each: false, share: 0.85 },
    Floor { group: "pair", each: true, share: 0.60 },
    Floor { group: "triple", each: false, share: 0.70 },
    Floor { group: "control", each: false, share: 0.95 },
];

/// Tally of one kind: (kind, group, passes, oracle passes, cases, missed seeds).
type Tally = (String, String, usize, usize, usize, Vec<u64>);

fn tallies(rows: &[Row], gen: &str) -> Vec<Tally> {
    let mut out: Vec<Tally> = Vec::new();
    for r in rows.iter().filter(|r| r.gen == gen) {
        let i = match out.iter().position(|t| t.0 == r.kind) {
            Some(i) => i,
            None => {
                out.push((r.kind.clone(), r.group.clone(), 0, 0, 0, Vec::new()));
                out.len() - 1
            }
        };
        let t = &mut out[i];
        t.2 += usize::from(r.pass);
        t.3 += usize::from(r.oracle_pass);
        t.4 += 1;
        if !r.pass {
            t.5.push(r.seed);
        }
    }
    let order = |g: &str| ["single", "pair", "triple", "control"].iter().position(|x| *x == g).unwrap_or(9);
    out.sort_by(|a, b| order(&a.1).cmp(&order(&b.1)).then(a.0.cmp(&b.0)));
    for t in &mut out {
        t.5.sort_unstable();
    }
    out
}

/// The markdown table of each generator and the floors, PASS or FAIL each; returns the floors that fail.
pub fn summary(rows: &[Row]) -> Vec<String> {
    let mut fails = Vec::new();
    for gen in [Gen::Sim, Gen::Indep] {
        let t = tallies(rows, gen.name());
        if t.is_empty() {
            continue;
        }
        let secs: Vec<f64> = rows.iter().filter(|r| r.gen == gen.name()).map(|r| r.secs).collect();
        println!(
            "\n### generator {} ({} cases, {:.1} s per case on average)\n",
            gen.name(),
            secs.len(),
            secs.iter().sum::<f64>() / secs.len() as f64
        );
        println!("| case | diagnosis | oracle | missed seeds |\n|---|---|---|---|");
        for (kind, _, pass, oracle, total, misses) in &t {
            let m: Vec<String> = misses.iter().map(u64::to_string).collect();
            println!("| {kind} | {pass}/{total} | {oracle}/{total} | {} |", m.join(", "));
        }
        println!();
        for f in &FLOORS {
            let of: Vec<&Tally> = t.iter().filter(|x| x.1 == f.group).collect();
            if of.is_empty() {
                continue;
            }
            let line = if f.each {
                let worst = of.iter().min_by(|a, b| (a.2 * b.4).cmp(&(b.2 * a.4))).unwrap();
                let share = worst.2 as f64 / worst.4 as f64;
                let ok = of.iter().all(|x| x.2 as f64 >= f.share * x.4 as f64);
                format!(
                    "{} floor {} each >= {:.0}%: worst {} {}/{} ({:.1}%)",
                    if ok { "PASS" } else { "FAIL" },
                    f.group,
                    100.0 * f.share,
                    worst.0,
                    worst.2,
                    worst.4,
                    100.0 * share
                )
            } else {
                let (p, o, n) = of.iter().fold((0, 0, 0), |(p, o, n), x| (p + x.2, o + x.3, n + x.4));
                let ok = p as f64 >= f.share * n as f64;
                format!(
                    "{} floor {} overall >= {:.0}%: {p}/{n} ({:.1}%), oracle {o}/{n}",
                    if ok { "PASS" } else { "FAIL" },
                    f.group,
                    100.0 * f.share,
                    100.0 * p as f64 / n as f64
                )
            };
            println!("{} {line}", gen.name());
            if line.starts_with("FAIL") {
                fails.push(format!("{} {line}", gen.name()));
            }
        }
        ablation_line(rows, gen);
    }
    fails
}

/// Where the sweep ran the ablation (`SWEEP_ABLATION=1`): per group, the cases in which every effect present is
/// visible to the views (the true model without it leaves a significant training gap), and the diagnosis's pass
/// rate on those and on the rest. Not a floor: it says which misses no view could have avoided.
fn ablation_line(rows: &[Row], gen: Gen) {
    for group in ["single", "pair", "triple"] {
        let of: Vec<(&Row, bool)> = rows
            .iter()
            .filter(|r| r.gen == gen.name() && r.group == group)
            .filter_map(|r| r.views_can_see_all().map(|v| (r, v)))
            .collect();
        if of.is_empty() {
            continue;
        }
        let count = |visible: bool| {
            let c: Vec<&Row> = of.iter().filter(|x| x.1 == visible).map(|x| x.0).collect();
            (c.iter().filter(|r| r.pass).count(), c.len())
        };
        let ((pv, nv), (ph, nh)) = (count(true), count(false));
        println!(
            "{} ablation {group}: every effect visible to the views in {nv} of {} cases, diagnosis {pv}/{nv} there; \
             {ph}/{nh} where the views cannot see an effect present",
            gen.name(),
            of.len()
        );
    }
}

/// The sweep over `SWEEP_SEEDS` (default 0..2) of `SWEEP_KINDS` (default all) on `SWEEP_GEN` (default both),
/// resumable through `SWEEP_OUT`; then the summary of everything in that file.
#[test]
#[ignore = "benchmark-sized: SWEEP_SEEDS, SWEEP_KINDS, SWEEP_GEN, SWEEP_OUT choose the cases (module doc)"]
fn sweep() {
    let path = out_path();
    let list = std::env::var("SWEEP_KINDS").unwrap_or_else(|_| "all".into());
    let rows = sweep_into(&path, &env_gens(), &cases::seeded_kinds_from(&list, env_seeds("0..2")));
    eprintln!("{} new case(s) in {}", rows.len(), path.display());
    summary(&read_rows(&path));
}

/// The sweep's case lists: `random_triples` puts each of the [`TRIPLES`] triples at exactly one seed, the seeds
/// taken in turn (ten a seed over ten seeds), and every other kind at every seed; `random_triples:K` spreads K.
#[test]
fn random_triples_take_one_seed_each() {
    let cases = cases::seeded_kinds_from("random_triples,controls", 0..10);
    let triples: Vec<&(Kind, u64)> = cases.iter().filter(|(k, _)| k.group() == "triple").collect();
    assert_eq!(triples.len(), TRIPLES);
    let mut names: Vec<String> = triples.iter().map(|(k, _)| k.name()).collect();
    names.sort();
    names.dedup();
    assert_eq!(names.len(), TRIPLES, "a triple at two seeds");
    for seed in 0..10 {
        assert_eq!(triples.iter().filter(|(_, s)| *s == seed).count(), TRIPLES / 10, "seed {seed}");
        assert_eq!(cases.iter().filter(|(k, s)| *s == seed && k.group() == "control").count(), 3, "seed {seed}");
    }
    let all = cases::kinds_from("triples");
    for (i, (kind, seed)) in triples.iter().enumerate() {
        let at = all.iter().position(|k| k == kind).expect("one of the triples");
        assert_eq!(*seed, (at % 10) as u64, "{} is triple {at}, met {i}th", kind.name());
    }
    let some = cases::seeded_kinds_from("random_triples:20", 3..8);
    assert_eq!(some.len(), 20);
    assert!((3..8).all(|s| some.iter().filter(|(_, x)| *x == s).count() == 4));
}

/// The tables and floors of the sweep's file, without running anything.
#[test]
#[ignore = "prints the tables of SWEEP_OUT (default target/gap_sweep.jsonl)"]
fn summary_of_file() {
    let path = out_path();
    let rows = read_rows(&path);
    println!("{} case(s) in {}", rows.len(), path.display());
    summary(&rows);
}

/// The guard (CI only): on each generator, every single item and control of five seeds whose records are short
/// ([`GUARD_SEEDS`]: 0.2-0.5 million samples at 2-16 Hz, about 2 s a case), ten pairs spread over the 54
/// (`pairs:10`) and four triples spread over the 100 (`triples:4`) of the cheapest of them
/// ([`GUARD_MIXED_SEED`]), against floors a little below what this code reaches there ([`GUARD_SINGLES`],
/// [`GUARD_PAIRS`], [`GUARD_TRIPLES`], [`GUARD_CONTROLS`]), so that a change that loses ground fails. Its cases
/// are not written to the sweep's file. Each generator is a test of its own ([`guard_shared_sim`],
/// [`guard_independent`]; `gap_sweep::guard` runs both), so the two share the test threads.
fn guard(gen: Gen) {
    if std::env::var_os("CI").is_none() {
        println!("skipped: the sweep's guard runs where CI is set");
        return;
    }
    let alone = cases::kinds_from("singles,controls");
    let mixed = cases::kinds_from("pairs:10,triples:4");
    let mut rows = Vec::new();
    let seeded = GUARD_SEEDS.iter().flat_map(|&s| alone.iter().map(move |k| (k, s)));
    for (kind, seed) in seeded.chain(mixed.iter().map(|k| (k, GUARD_MIXED_SEED))) {
        let row = run_case(gen, kind, seed);
        log_row(&row);
        rows.push(row);
    }
    summary(&rows);
    let mut fails = Vec::new();
    for (group, need) in
        [("single", GUARD_SINGLES), ("pair", GUARD_PAIRS), ("triple", GUARD_TRIPLES), ("control", GUARD_CONTROLS)]
    {
        let pass = rows.iter().filter(|r| r.group == group && r.pass).count();
        if pass < need {
            fails.push(format!("{} {group}: {pass} pass, the guard wants {need}", gen.name()));
        }
    }
    assert!(fails.is_empty(), "{fails:?}");
}

/// The [`guard`] on shared::sim's records.
#[test]
fn guard_shared_sim() {
    guard(Gen::Sim);
}

/// The [`guard`] on the independent generator's records.
#[test]
fn guard_independent() {
    guard(Gen::Indep);
}

/// The cheap cases' seed: a record of 0.29e6 samples at 8.7 Hz (34 h), a short one of the sweep's range.
const CHEAP_SEED: u64 = 2;
/// The guard's seeds for singles and controls: the sweep's five shortest records (seeds 2, 3, 5, 6 and 7: 0.20 to
/// 0.42 million samples at 2.3 to 50 Hz).
const GUARD_SEEDS: [u64; 5] = [2, 3, 5, 6, 7];
/// The guard's seed for its pairs and triples: 0.20 million samples at 2.3 Hz.
const GUARD_MIXED_SEED: u64 = 6;
/// Single items of the guard's seeds (55) each generator must pass: both reach 52 (shared::sim misses the slow
/// sinusoid of seed 2, the Gauss-Markov process of seed 7 and the contamination of seed 7; the independent
/// generator the slow sinusoid, the Gauss-Markov process of seed 7 and the temperature coupling of seed 3).
const GUARD_SINGLES: usize = 51;
/// Pairs of the `pairs:10` picks each generator must pass (9 on each generator).
const GUARD_PAIRS: usize = 7;
/// Triples of the `triples:4` picks each generator must pass (3 of 4 on each generator; over the 100 random
/// triples the issue's 70% is not met, docs/gap.md).
const GUARD_TRIPLES: usize = 1;
/// Controls of the guard's seeds (15) each generator must pass.
const GUARD_CONTROLS: usize = 15;

/// One single-effect case that passes on shared::sim's record, in every `cargo test`.
#[test]
fn a_case_from_shared_sim() {
    let row = run_case(Gen::Sim, &Kind::of(&[Effect::GaussMarkov]), CHEAP_SEED);
    log_row(&row);
    assert!(row.pass, "{row:?}");
}

/// One single-effect case that passes on the independent generator's record, in every `cargo test`.
#[test]
fn a_case_from_the_independent_generator() {
    let row = run_case(Gen::Indep, &Kind::of(&[Effect::GaussMarkov]), CHEAP_SEED);
    log_row(&row);
    assert!(row.pass, "{row:?}");
}

/// Each of `cases` (generator, effects, seed) diagnosed and passing; `ci_only` cases run only where `CI` is set.
fn cases_pass(cases: &[(Gen, &[Effect], u64)], ci_only: bool) {
    if ci_only && std::env::var_os("CI").is_none() {
        println!("skipped: runs where CI is set");
        return;
    }
    for &(gen, effects, seed) in cases {
        let row = run_case(gen, &Kind::of(effects), seed);
        log_row(&row);
        assert!(row.pass, "seed {seed}: {row:?}");
    }
}

/// Two records of the sweep whose training part holds one or two of a Poisson process's bias steps (seeds 7 and 8
/// of shared::sim: 11 and 14 steps a record, most of them in the held-out part): the steps' heavy-tailed Allan
/// differences are a significant gap in the distribution view, and the process fitted to the steps the training
/// part shows takes it away, so the diagnosis names `bias_steps` and holds out below 2.5.
#[test]
fn bias_steps_seen_once_in_training_are_named() {
    cases_pass(&[(Gen::Sim, &[Effect::BiasSteps], 7), (Gen::Sim, &[Effect::BiasSteps], 8)], false);
}

/// A sinusoid of 6.5 s beside a bistable bias whose flips every few seconds hide it from every view (the
/// independent generator's pair of seed 0): once the flips are out of the samples the sinusoid's estimator finds
/// it 66 standard errors from zero, and adding it moves the views' total from 0.91 to 1.04, the ensemble's
/// response with every view's gap near 1, so it is named. Where `CI` is set (20 s).
#[test]
fn a_sinusoid_a_bistable_bias_hides_is_named() {
    cases_pass(&[(Gen::Indep, &[Effect::Sinusoid, Effect::Bistable], 0)], true);
}

/// A 214 s sinusoid, an ADC lattice of 3.1 sds a step and a bistable bias (shared::sim's triple of seed 8, an
/// 81 Hz record): with the telegraph and the sinusoid named, the search is stuck beside a significant gap; the
/// chain re-estimated jointly there and searched again names the lattice too, and the three hold out below 2.5
/// (stopped where it was stuck, the chain left the lattice unnamed and held out at 18.6). Where `CI` is set
/// (about 15 s).
#[test]
fn a_stuck_chain_re_estimated_jointly_names_what_it_left() {
    cases_pass(&[(Gen::Sim, &[Effect::Sinusoid, Effect::Quantization, Effect::Bistable], 8)], true);
}

/// A temperature coupling beside a 3.1 s sinusoid and a Gauss-Markov process of 1.2 s (shared::sim's triple of seed
/// 3, a 6.1 Hz record): with the sinusoid and the process named, the coupling takes the temperature view from 8.3
/// to 1.4 once its re-fit reads the base terms beside the process; taking the process off the curve at its
/// variance instead read a flicker floor out of the difference, the Allan view went to 5.8 and the coupling was
/// refused (held out 1.46, the temperature view at 7.6). Where `CI` is set (about 12 s).
#[test]
fn a_coupling_beside_a_markov_process_is_named() {
    cases_pass(&[(Gen::Sim, &[Effect::Temperature, Effect::Sinusoid, Effect::GaussMarkov], 3)], true);
}

/// A sinusoid of 62 minutes (12 cycles in the training part of seed 6's 2.3 Hz record) beside bias steps and a
/// warm-up: no view's candidate takes it, and its amplitude stands many standard errors from zero, so its own test
/// names it, which counts sinusoids of 8 cycles and more ([`octavar::gap::effects::SHORT_PERIOD_CYCLES`]); the
/// warm-up is named after it. Each generator's record, in every `cargo test` (5 s).
#[test]
fn a_sinusoid_of_twelve_cycles_no_view_takes_is_named() {
    let kind: &[Effect] = &[Effect::Sinusoid, Effect::BiasSteps, Effect::WarmUp];
    cases_pass(&[(Gen::Sim, kind, 6), (Gen::Indep, kind, 6)], false);
}

/// A contamination of 5% of the samples at 7-7.8 sds on an ADC lattice of 3.5 sds a step (the pair of seed 3, a
/// 6.1 Hz record): spikes of two steps, beyond the lattice's own reach (a step and a half at that noise) and short
/// of three steps, where the spike law was once held; read from the reach, the law and the quantisation beside it
/// hold out below 2.5. Each generator's record, in every `cargo test` (10 s); both missed with the law held beyond
/// three steps (a warm-up named too, or held out at 3.3).
#[test]
fn a_contamination_of_two_steps_on_a_coarse_lattice_is_read_from_its_reach() {
    for gen in [Gen::Sim, Gen::Indep] {
        let kind = &cases::kinds_from("quantization+contamination")[0];
        let row = run_case(gen, kind, 3);
        log_row(&row);
        assert!(row.pass, "{row:?}");
    }
}

/// A temperature coupling, a filter corner at 0.41 Hz and a resonance at 0.036 Hz (shared::sim's triple of seed 6,
/// a 2.3 Hz record): read before the resonance, a Gauss-Markov process of 2.2 s scores ahead of the corner, and the
/// chain names it; the exchange step trades it for the corner, whose chain scores better, and the diagnosis then
/// names the three effects present and holds out at 1.0. Where `CI` is set (15 s).
#[test]
fn a_process_read_in_a_corners_place_is_exchanged_for_it() {
    cases_pass(&[(Gen::Sim, &[Effect::Temperature, Effect::Bandwidth, Effect::Resonance], 6)], true);
}

/// Partners a bistable bias hides from the plain views, whose members each draw a fresh telegraph: a Gauss-Markov
/// process (the independent generator's pair of seed 0) and bias steps (shared::sim's pair of seed 0). Neither
/// has a test of its own, so only the views with the telegraph's jumps taken out of the record and of every member
/// alike name them (the chain's third route); without it each diagnosis names the bias alone. Where `CI` is set
/// (40 s).
#[test]
fn partners_a_bistable_bias_hides_are_named_with_its_jumps_out() {
    cases_pass(
        &[
            (Gen::Indep, &[Effect::GaussMarkov, Effect::Bistable], 0),
            (Gen::Sim, &[Effect::BiasSteps, Effect::Bistable], 0),
        ],
        true,
    );
}

/// Spikes beside a bistable bias (shared::sim's pair of seed 4: flips of 0.48 deg/s, 12 spikes of 24 robust
/// sigma a half) that one first step cannot explain alone: bias steps drawn over the flips also draw heavy tails
/// where the spikes stand and score best, and the chain from them leaves the Allan deviation at a tenth of the
/// simulation's. The chain searched again from the first ranking's runner-up, the bistable bias, names the spikes
/// after it and agrees with the record. Where `CI` is set (30 s).
#[test]
fn a_first_step_drawn_over_two_effects_is_searched_again() {
    cases_pass(&[(Gen::Sim, &[Effect::Outliers, Effect::Bistable], 4)], true);
}

/// A bistable bias alone (shared::sim's seed 4: 60 jumps of 0.48 deg/s) whose scan gives one stretch of 1,500 s
/// the wrong state: the levels put it back, so the views with the jumps out find no step the bias does not
/// explain, and the bias alone is named (with that stretch left wrong, `bias_steps` was named beside it). Where
/// `CI` is set (10 s).
#[test]
fn a_telegraph_read_whole_leaves_no_partner() {
    cases_pass(&[(Gen::Sim, &[Effect::Bistable], 4)], true);
}

/// Spikes beside a coarse ADC lattice (seed 5 of both generators: 5.6 white sds a step, 22 spikes of 34 robust
/// sigma a half): once the quantisation step has explained the lattice, no view's gap is significant, and the
/// spikes are named by their law's likelihood ratio, read on the dithered samples (the quantisation step takes
/// nothing out of the samples, so the estimators' route is open to the spikes after it). Where `CI` is set (20 s).
#[test]
fn spikes_on_a_lattice_are_named_after_it() {
    let lattice_spikes: &[Effect] = &[Effect::Quantization, Effect::Outliers];
    cases_pass(&[(Gen::Sim, lattice_spikes, 5), (Gen::Indep, lattice_spikes, 5)], true);
}

/// Estimates at their search's upper bound name nothing (seed 6, 2.29 Hz): beside a warm-up, a temperature
/// coupling lagging three records (the lag search's top, where the lagged temperature is a slow ramp) took the
/// warm-up's place (the independent generator's `temperature + warm_up`). With such an estimate refused, the
/// record names its true pair. Where `CI` is set (10 s).
#[test]
fn estimates_at_their_searchs_bound_name_nothing() {
    cases_pass(&[(Gen::Indep, &[Effect::Temperature, Effect::WarmUp], 6)], true);
}

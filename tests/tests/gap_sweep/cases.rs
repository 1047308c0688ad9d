//! The sweep's cases: the kinds, the record and parameters each seed draws (ranges in the parent module's doc),
//! and each generator's record of them.

use std::f64::consts::{PI, SQRT_2};

use octavar::gap::Effect;
use octavar_shared::sensor::Channel;
use octavar_shared::sim::rng::SimRng;
use octavar_shared::sim::temperature::Thermal;
use octavar_shared::sim::{GyroSim, TemperatureProfile, VirtualGyro};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

use super::TRIPLES;
use crate::indep_gyro::{
    oracle, BenchTemperature, Contamination, Coupling, IndepGyro, Jumps, Lattice, Markov, Oscillator, Settling, Sine,
    Telegraph,
};
use crate::util::coarse_channel;

/// Which generator makes a record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Gen {
    /// `octavar_shared::sim`'s virtual gyro.
    Sim,
    /// [`crate::indep_gyro`].
    Indep,
}

impl Gen {
    pub fn name(self) -> &'static str {
        match self {
            Gen::Sim => "sim",
            Gen::Indep => "indep",
        }
    }
}

/// A control: a record whose answer must be `none`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Control {
    /// The base gyro alone.
    None,
    /// The base gyro and a transient bump.
    Bump,
    /// The base gyro and a temperature channel the rate does not follow.
    Temperature,
}

/// One thing a case's record holds beside the base gyro: an effect of the vocabulary, or epsilon-contaminated
/// noise, which the vocabulary names `outliers` but which the sweep draws apart from rare spikes (a share of the
/// samples from 1e-5 to a fifth, 3-50 sigma, isolated or in runs of 2-3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Item {
    Effect(Effect),
    Contamination,
}

impl Item {
    /// Every item in the sweep's order: the vocabulary's, then contamination.
    pub fn all() -> Vec<Item> {
        Effect::ALL.iter().map(|&e| Item::Effect(e)).chain([Item::Contamination]).collect()
    }

    /// The effect a correct diagnosis names for it.
    pub fn effect(self) -> Effect {
        match self {
            Item::Effect(e) => e,
            Item::Contamination => Effect::Outliers,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Item::Effect(e) => e.name(),
            Item::Contamination => "contamination",
        }
    }

    pub fn parse(s: &str) -> Option<Item> {
        match s {
            "contamination" => Some(Item::Contamination),
            _ => Effect::parse(s).map(Item::Effect),
        }
    }
}

/// Whether items can share a record: rare spikes and a contamination are one effect, spikes, twice over (one
/// `outliers` law cannot hold both, nor can either generator's one spike process), so no kind holds both.
fn compatible(items: &[Item]) -> bool {
    !(items.contains(&Item::Effect(Effect::Outliers)) && items.contains(&Item::Contamination))
}

/// What a record holds besides the base gyro.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Kind {
    /// One or more items (effects of the vocabulary, or contamination).
    Effects(Vec<Item>),
    Control(Control),
}

impl Kind {
    /// A kind of effects of the vocabulary alone.
    pub fn of(effects: &[Effect]) -> Kind {
        Kind::Effects(effects.iter().map(|&e| Item::Effect(e)).collect())
    }

    /// The items drawn into the record.
    pub fn items(&self) -> Vec<Item> {
        match self {
            Kind::Effects(e) => e.clone(),
            Kind::Control(_) => Vec::new(),
        }
    }

    /// The effects a correct diagnosis names.
    pub fn effects(&self) -> Vec<Effect> {
        let mut out: Vec<Effect> = Vec::new();
        for e in self.items().into_iter().map(Item::effect) {
            if !out.contains(&e) {
                out.push(e);
            }
        }
        out
    }

    pub fn name(&self) -> String {
        match self {
            Kind::Effects(e) => e.iter().map(|e| e.name()).collect::<Vec<_>>().join("+"),
            Kind::Control(Control::None) => "none".into(),
            Kind::Control(Control::Bump) => "none+bump".into(),
            Kind::Control(Control::Temperature) => "none+temperature".into(),
        }
    }

    pub fn group(&self) -> &'static str {
        match self {
            Kind::Effects(e) if e.len() == 1 => "single",
            Kind::Effects(e) if e.len() == 2 => "pair",
            Kind::Effects(_) => "triple",
            Kind::Control(_) => "control",
        }
    }

    /// `temperature`, `contamination`, `bandwidth+resonance`, `a+b+c`, `none`, `none+bump`, `none+temperature`.
    pub fn parse(s: &str) -> Option<Kind> {
        match s {
            "none" => Some(Kind::Control(Control::None)),
            "none+bump" => Some(Kind::Control(Control::Bump)),
            "none+temperature" => Some(Kind::Control(Control::Temperature)),
            _ => s.split('+').map(Item::parse).collect::<Option<Vec<_>>>().filter(|i| compatible(i)).map(Kind::Effects),
        }
    }
}

/// Every pair of the sweep's items, in their order (54: the vocabulary's 45, and contamination beside each effect
/// but `outliers`).
pub fn pairs() -> Vec<Kind> {
    let all = Item::all();
    let mut out = Vec::new();
    for (i, &a) in all.iter().enumerate() {
        for &b in &all[i + 1..] {
            if compatible(&[a, b]) {
                out.push(Kind::Effects(vec![a, b]));
            }
        }
    }
    out
}

/// [`TRIPLES`] triples of the vocabulary (every one when there are fewer), drawn once from a fixed seed.
pub fn triples() -> Vec<Kind> {
    let all = Item::all();
    let mut every = Vec::new();
    for i in 0..all.len() {
        for j in i + 1..all.len() {
            for k in j + 1..all.len() {
                let t = vec![all[i], all[j], all[k]];
                if compatible(&t) {
                    every.push(t);
                }
            }
        }
    }
    let mut rng = StdRng::seed_from_u64(31);
    for i in (1..every.len()).rev() {
        let j = rng.random_range(0..=i);
        every.swap(i, j);
    }
    every.truncate(TRIPLES);
    every.into_iter().map(Kind::Effects).collect()
}

/// The kinds of a `SWEEP_KINDS` list (see the parent module's doc).
pub fn kinds_from(list: &str) -> Vec<Kind> {
    let spread = |all: Vec<Kind>, k: &str| -> Vec<Kind> {
        let k: usize = k.parse().expect("a count");
        let n = all.len();
        (0..k.min(n)).map(|i| all[i * n / k.min(n)].clone()).collect()
    };
    let mut out = Vec::new();
    for item in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        match item.split_once(':') {
            Some(("pairs", k)) => out.extend(spread(pairs(), k)),
            Some(("triples", k)) => out.extend(spread(triples(), k)),
            _ => match item {
                "all" => out.extend(kinds_from("singles,pairs,triples,controls")),
                "singles" => out.extend(Item::all().into_iter().map(|i| Kind::Effects(vec![i]))),
                "pairs" => out.extend(pairs()),
                "triples" => out.extend(triples()),
                "controls" => out.extend([Control::None, Control::Bump, Control::Temperature].map(Kind::Control)),
                s => out.push(Kind::parse(s).unwrap_or_else(|| panic!("not a kind: {s}"))),
            },
        }
    }
    out
}

/// The cases of a `SWEEP_KINDS` list over `seeds`: each kind of [`kinds_from`] at every seed, and for the group
/// `random_triples` (or `random_triples:K`, K of them evenly spread) each triple at one seed of its own, the
/// seeds taken in turn, so that the triples draw their records and parameters as many times as there are seeds
/// instead of sharing one draw.
pub fn seeded_kinds_from(list: &str, seeds: std::ops::Range<u64>) -> Vec<(Kind, u64)> {
    let seeds: Vec<u64> = seeds.collect();
    let (mut fixed, mut spread) = (Vec::new(), Vec::new());
    for item in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        match item.strip_prefix("random_triples") {
            Some(rest) => {
                let k = rest.strip_prefix(':').map_or_else(|| "triples".to_string(), |k| format!("triples:{k}"));
                spread.extend(kinds_from(&k));
            }
            None => fixed.extend(kinds_from(item)),
        }
    }
    let mut out: Vec<(Kind, u64)> = Vec::new();
    for (i, &seed) in seeds.iter().enumerate() {
        out.extend(fixed.iter().map(|k| (k.clone(), seed)));
        out.extend(spread.iter().skip(i).step_by(seeds.len()).map(|k| (k.clone(), seed)));
    }
    out
}

/// One drawn case.
#[derive(Clone, Debug)]
pub struct Case {
    /// The truth, as the independent generator's parameters.
    pub truth: IndepGyro,
    pub rate_hz: f64,
    pub samples: usize,
    /// A transient bump: start, length (samples), size (deg/s).
    pub bump: Option<(usize, usize, f64)>,
    pub what: String,
}

fn log_uniform(rng: &mut StdRng, lo: f64, hi: f64) -> f64 {
    (lo.ln() + (hi / lo).ln() * rng.random::<f64>()).exp()
}

fn uniform(rng: &mut StdRng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.random::<f64>()
}

/// The closed-form base Allan deviation (N, B, K) at tau.
fn adev(g: &IndepGyro, tau: f64) -> f64 {
    let f = 2.0 * std::f64::consts::LN_2 / PI;
    (g.n_deg_per_rt_s.powi(2) / tau + f * g.b_dps.powi(2) + g.k_dps_per_rt_s.powi(2) * tau / 3.0).sqrt()
}

/// The multiplier of an effect's local noise.
fn size(rng: &mut StdRng) -> f64 {
    log_uniform(rng, 2.0, 30.0)
}

/// The case of `kind` at `seed`: the record and base from the seed, each effect from its own stream.
pub fn draw(kind: &Kind, seed: u64) -> Case {
    let mut rng = StdRng::seed_from_u64(0x5eed_0000 ^ seed);
    let rate_hz = log_uniform(&mut rng, 1.0, 200.0);
    let lo = (1.7e5f64).max(5400.0 * rate_hz);
    let hi = (1.1e6f64).min(172_800.0 * rate_hz);
    let samples = (log_uniform(&mut rng, lo, hi.max(lo)) as usize) & !1;
    let n = log_uniform(&mut rng, 0.002, 0.02);
    let b = n * uniform(&mut rng, 0.2, 1.0);
    let base = IndepGyro {
        bias_dps: uniform(&mut rng, -0.5, 0.5),
        n_deg_per_rt_s: n,
        b_dps: b,
        k_dps_per_rt_s: b * 1e-3,
        ..Default::default()
    };
    let d = samples as f64 / rate_hz;
    let tau0 = 1.0 / rate_hz;
    let white = base.white_sd(rate_hz);
    let items = kind.items();
    let stream_of = |e: Effect| StdRng::seed_from_u64(0xeffe_c700 ^ (seed << 8) ^ e as u64);
    // A lattice raises K so that the walk crosses a few steps, and its rounding adds white noise of about
    // `step^2 / 12` a sample. Both are the record's noise: every other effect is sized against `noise`, the base
    // with them (at long taus the walk can be ten times the base's Allan deviation; a step of 3.8 white sds
    // doubles the white floor a resonance stands on).
    let lattice = items.contains(&Item::Effect(Effect::Quantization)).then(|| {
        let mut r = stream_of(Effect::Quantization);
        let step = size(&mut r) / 3.0 * white;
        Lattice { step_dps: step, offset_dps: uniform(&mut r, 0.0, step) }
    });
    let base = match &lattice {
        Some(q) => IndepGyro { k_dps_per_rt_s: base.k_dps_per_rt_s.max(q.step_dps / d.sqrt()), ..base },
        None => base,
    };
    let noise = match &lattice {
        Some(q) => IndepGyro {
            n_deg_per_rt_s: (base.n_deg_per_rt_s.powi(2) + q.step_dps.powi(2) / 12.0 / rate_hz).sqrt(),
            ..base.clone()
        },
        None => base.clone(),
    };
    // The white noise's per-sample sd with the rounding, in the analog white noise's sds.
    let white_ratio = noise.white_sd(rate_hz) / white;
    let mut g = base.clone();
    let mut what = Vec::new();
    let mut bump = None;
    for e in items.iter().filter_map(|i| match i {
        Item::Effect(e) => Some(*e),
        Item::Contamination => None,
    }) {
        let mut r = stream_of(e);
        match e {
            Effect::Temperature => {
                let p = log_uniform(&mut r, (300.0f64).max(20.0 * tau0), d / 3.0);
                let swing = uniform(&mut r, 1.0, 5.0);
                let lag = log_uniform(&mut r, 3.0 * tau0, 0.5 * p);
                let h = 1.0 / (1.0 + (2.0 * PI * lag / p).powi(2)).sqrt();
                let k = size(&mut r) * adev(&noise, p / 3.0) / (0.5 * swing * h)
                    * if r.random::<bool>() { 1.0 } else { -1.0 };
                g.bench = Some(bench(&mut r, p, swing));
                g.coupling = Some(Coupling { dps_per_c: k, lag_s: lag, ref_c: 23.5 });
                what.push(format!("temperature k {k:.2e} lag {lag:.3e} P {p:.3e} swing {swing:.1}"));
            }
            Effect::Sinusoid => {
                let p = log_uniform(&mut r, 4.0 * tau0, d / 3.0);
                let a = size(&mut r) * adev(&noise, 0.37 * p);
                g.sinusoids.push(Sine { amplitude_dps: a, period_s: p, phase_rad: uniform(&mut r, -PI, PI) });
                what.push(format!("sinusoid A {a:.2e} P {p:.3e}"));
            }
            Effect::Bandwidth => {
                let f = log_uniform(&mut r, 0.05, 0.4) * rate_hz;
                g.bandwidth_hz = Some(f);
                what.push(format!("bandwidth {f:.3e} Hz"));
            }
            Effect::GaussMarkov => {
                let t = log_uniform(&mut r, 4.0 * tau0, d / 3.0);
                let sigma = size(&mut r) * adev(&noise, 2.0 * t) / 0.62;
                g.gauss_markov = Some(Markov { sigma_dps: sigma, tau_s: t });
                what.push(format!("gauss_markov sigma {sigma:.2e} T {t:.3e}"));
            }
            Effect::Quantization => {
                let q = lattice.expect("drawn above");
                what.push(format!("quantization {:.2} sigma", q.step_dps / white));
                g.lattice = Some(q);
            }
            Effect::BiasSteps => {
                let count = log_uniform(&mut r, 8.0, 80.0);
                let floor = (0..60).map(|i| adev(&noise, tau0 * 1.4f64.powi(i))).fold(f64::INFINITY, f64::min);
                let sd = size(&mut r) * 5.0 / 3.0 * SQRT_2 * floor;
                g.jumps = Some(Jumps { per_hour: count / (d / 3600.0), sigma_dps: sd });
                what.push(format!("bias_steps {count:.0}/record sd {sd:.2e}"));
            }
            Effect::Outliers => {
                let per_half = log_uniform(&mut r, 10.0, 300.0);
                let s = size(&mut r) * 8.0 / 3.0 * white_ratio;
                g.contamination = Some(Contamination {
                    per_sample: per_half / (samples / 2) as f64,
                    size_sigma: [0.9 * s, 1.1 * s],
                    longest_run: 1,
                });
                what.push(format!("outliers {per_half:.0}/half {s:.1} sigma"));
            }
            Effect::Resonance => {
                let q = log_uniform(&mut r, 3.0, 30.0);
                let top = g.bandwidth_hz.map_or(0.4 * rate_hz, |f| (0.7 * f).min(0.4 * rate_hz));
                let f0 = log_uniform(&mut r, (256.0 * q / d).min(0.5 * top), top);
                let ratio = size(&mut r);
                let sigma = (ratio * noise.n_deg_per_rt_s.powi(2) * PI * f0 / q).sqrt();
                g.resonance = Some(Oscillator { sigma_dps: sigma, freq_hz: f0, q });
                what.push(format!("resonance f0 {f0:.3e} Q {q:.1} peak x{ratio:.1}"));
            }
            Effect::Bistable => {
                let (lo, hi) = ((30.0 * tau0).max(d / 3000.0), d / 40.0);
                let (low, high) = (log_uniform(&mut r, lo, hi), log_uniform(&mut r, lo, hi));
                let step = size(&mut r) * 8.0 / 3.0 * SQRT_2 * adev(&noise, 0.1 * low.min(high));
                g.telegraph = Some(Telegraph { step_dps: step, dwell_low_s: low, dwell_high_s: high });
                what.push(format!("bistable step {step:.2e} dwells {low:.3e}/{high:.3e}"));
            }
            Effect::WarmUp => {
                let tau = log_uniform(&mut r, d / 400.0, d / 3.0);
                let sign = if r.random::<bool>() { 1.0 } else { -1.0 };
                let s = sign * size(&mut r) * 10.0 * SQRT_2 * adev(&noise, tau);
                g.settling = Some(Settling { size_dps: s, tau_s: tau });
                what.push(format!("warm_up {s:.2e} tau {tau:.3e}"));
            }
        }
    }
    // A contamination is drawn last, against the local noise of every other effect the record holds.
    if items.contains(&Item::Contamination) {
        let mut r = StdRng::seed_from_u64(0xc047_a000 ^ (seed << 8));
        let c = contamination(&mut r, samples, white_ratio.max(local_sd(&g, rate_hz) / white));
        what.push(format!(
            "contamination {:.2e} of samples {:.1}-{:.1} sigma runs <= {}",
            c.per_sample, c.size_sigma[0], c.size_sigma[1], c.longest_run
        ));
        g.contamination = Some(c);
    }
    if let Kind::Control(c) = kind {
        let mut r = StdRng::seed_from_u64(0xc0de_0000 ^ seed);
        match c {
            Control::None => what.push("control".into()),
            Control::Temperature => {
                let p = log_uniform(&mut r, (300.0f64).max(20.0 * tau0), d / 3.0);
                let swing = uniform(&mut r, 1.0, 5.0);
                g.bench = Some(bench(&mut r, p, swing));
                what.push(format!("temperature channel P {p:.3e}, not followed"));
            }
            Control::Bump => {
                let len = ((log_uniform(&mut r, 1.0, 300.0) * rate_hz) as usize).clamp(3, samples / 20);
                let start = (r.random::<f64>() * (samples - len) as f64) as usize;
                let floor = 15.0 * adev(&base, len as f64 * tau0);
                let s = (uniform(&mut r, 10.0, 60.0) * white).max(floor) * if r.random::<bool>() { 1.0 } else { -1.0 };
                bump = Some((start, len, s));
                what.push(format!("bump {s:.2e} for {len} at {start}"));
            }
        }
    }
    Case { truth: g, rate_hz, samples, bump, what: what.join(" & ") }
}

/// The sd of what changes from one sample to the next in `g` (white noise, and the fast part of a Gauss-Markov
/// process, a resonance and a sinusoid: each one's variance times one less its lag-one autocorrelation), deg/s:
/// the scale a spike must stand out of, which the outliers estimator reads as its residuals' core. Slow terms
/// and jumps leave it, and a filter, which narrows it, is left out (spikes then stand out more).
fn local_sd(g: &IndepGyro, rate_hz: f64) -> f64 {
    let tau0 = 1.0 / rate_hz;
    let mut var = g.white_sd(rate_hz).powi(2);
    if let Some(m) = g.gauss_markov {
        var += m.sigma_dps.powi(2) * (1.0 - (-tau0 / m.tau_s).exp());
    }
    if let Some(o) = g.resonance {
        let rho1 = (2.0 * PI * o.freq_hz * tau0).cos() * (-PI * o.freq_hz * tau0 / o.q).exp();
        var += o.sigma_dps.powi(2) * (1.0 - rho1);
    }
    for s in &g.sinusoids {
        var += 0.5 * s.amplitude_dps.powi(2) * (1.0 - (2.0 * PI * tau0 / s.period_s).cos());
    }
    var.sqrt()
}

/// An epsilon-contamination of `samples` samples: a share log-uniform from 1e-5 (at least 20 spikes a record) to
/// a fifth; sizes uniform over a range around a centre log-uniform up to 50 white sds, the range up to 1.5 times
/// either way within 3-50; runs up to 1, 2 or 3 samples, one in three each. The centre stands at least one sd
/// beyond `sqrt(2 ln(1 / share))`, the Chernoff bound of where a Gaussian's tails hold the spikes' share, and at
/// least 3 sds: smaller, the spikes are the noise's own tail, whatever their number. The sds are the record's
/// local noise (the white noise with a lattice's rounding, or [`local_sd`] where it is larger); `local_ratio` is
/// that over the analog white noise's sd, in which the generator counts.
fn contamination(r: &mut StdRng, samples: usize, local_ratio: f64) -> Contamination {
    let share = log_uniform(r, (1e-5f64).max(20.0 / samples as f64), 0.2);
    let lowest = (3.0f64).max((2.0 * (1.0 / share).ln()).sqrt() + 1.0);
    let centre = log_uniform(r, lowest, 50.0);
    let width = uniform(r, 1.0, 1.5);
    let longest_run = r.random_range(1..=3usize);
    Contamination {
        per_sample: share,
        size_sigma: [(centre / width).max(3.0) * local_ratio, (centre * width).min(50.0) * local_ratio],
        longest_run,
    }
}

/// A daily-like bench temperature of cycle `p` s and swing `swing` degC.
fn bench(r: &mut StdRng, p: f64, swing: f64) -> BenchTemperature {
    BenchTemperature {
        mean_c: 23.5 + uniform(r, -1.0, 1.0),
        swing_c: swing,
        period_s: p,
        phase_rad: uniform(r, -PI, PI),
        harmonic: uniform(r, 0.0, 0.4),
        wander_sd_c: 0.05 * swing,
        wander_tau_s: p / 4.0,
    }
}

impl Case {
    /// The model that made the record, for the oracle: shared::sim's `GyroSim` and the lattice's channel.
    pub fn oracle(&self) -> (GyroSim, Option<Channel>) {
        oracle::gyro_sim(&self.truth)
    }

    /// The record of generator `gen` (noise stream `seed`): the rate, deg/s, and the temperature where there is
    /// a bench.
    pub fn record(&self, gen: Gen, seed: u64) -> (Vec<f64>, Option<Vec<f64>>) {
        let (mut x, t) = match gen {
            Gen::Indep => {
                let r = self.truth.generate(self.rate_hz, self.samples, 0x1d_0000 + seed);
                (r.rate_dps, r.temp_c)
            }
            Gen::Sim => self.sim_record(seed),
        };
        if let Some((start, len, s)) = self.bump {
            x[start..start + len].iter_mut().for_each(|v| *v += s);
        }
        (x, t)
    }

    fn sim_record(&self, seed: u64) -> (Vec<f64>, Option<Vec<f64>>) {
        let (model, channel) = self.oracle();
        let ch = channel.unwrap_or_else(|| coarse_channel(1e-6));
        let mut gyro = VirtualGyro::new(&model, ch, self.rate_hz, 0x51_0000 + seed).unwrap();
        let mut rng = SimRng::new(0x52_0000 + seed);
        let profile = self.truth.bench.as_ref().map_or_else(TemperatureProfile::default, oracle::profile);
        let mut thermal = Thermal::new(&profile, self.rate_hz, &mut rng);
        let mut x = Vec::with_capacity(self.samples);
        let mut t = Vec::with_capacity(self.samples);
        for _ in 0..self.samples {
            let tc = thermal.next(&mut rng);
            let s = gyro.next(tc);
            x.push(if channel.is_some() { ch.code_to_dps(s.code) } else { s.rate_dps });
            t.push(tc);
        }
        (x, self.truth.bench.is_some().then_some(t))
    }
}

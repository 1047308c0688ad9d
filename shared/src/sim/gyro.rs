//! One virtual gyro channel: the model's terms summed sample by sample, then the ADC.
//!
//! Order within a sample: bias + white (N) + differenced white angle (Q) + flicker + random walk + ramp +
//! Gauss-Markov + sinusoids + temperature coupling + bias steps + resonance + bistable bias + warm-up; that sum
//! goes through the sensor's first-order bandwidth (every one of them is a rate or bias the sensor sees); outliers
//! are added after the filter; the result is the analog rate at the ADC ([`Sample::rate_dps`]), which the
//! [`Quantizer`] turns into a code.
//!
//! A term draws from the random stream only when the model has it, and the terms added last (resonance,
//! bistable bias) draw after all the others at construction, so a model without them gives the same samples bit
//! for bit as before they existed.

use super::adc::Quantizer;
use super::effects::{Sinusoids, Spikes, Steps, Telegraph, WarmUp};
use super::flicker::{self, FlickerBank};
use super::model::GyroSim;
use super::noise::{GaussMarkov, LowPass, RandomWalk, Resonance};
use super::rng::SimRng;
use super::temperature::ThermalLag;
use crate::sensor::Channel;

/// Why a model cannot be simulated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SimError {
    /// The sample rate is not a positive finite number.
    InvalidSampleRate,
    /// A model parameter is out of its range (negative sd, zero period, probability above 1, not finite, ...);
    /// the field is named.
    InvalidParameter(&'static str),
    /// A bench channel names a temperature sensor as its gyro.
    NotAGyro,
}

impl core::fmt::Display for SimError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            SimError::InvalidSampleRate => f.write_str("sample rate must be a positive finite number of Hz"),
            SimError::InvalidParameter(field) => {
                write!(f, "model parameter `{field}` is out of range")
            }
            SimError::NotAGyro => f.write_str("a bench channel must be a gyro, not a temperature sensor"),
        }
    }
}

impl core::error::Error for SimError {}

/// One simulated sample of a channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// The analog rate at the ADC (every term and effect, before quantisation and clipping), deg/s.
    pub rate_dps: f64,
    /// The ADC code.
    pub code: u16,
    /// The rate fell outside the ADC's range: the code sits at a rail.
    pub clipped: bool,
}

/// A deterministic virtual gyro + ADC for one channel, in constant memory (see `size_of` in the tests).
#[derive(Clone, Debug, PartialEq)]
pub struct VirtualGyro {
    rng: SimRng,
    n: u64,
    bias: f64,
    white_sigma: f64,
    /// Q rate_hz and the last white angle draw, for the differenced white angle noise.
    angle_scale: f64,
    last_angle: f64,
    ramp_step: f64,
    flicker: Option<FlickerBank>,
    rw: Option<RandomWalk>,
    gm: Option<GaussMarkov>,
    sines: Sinusoids,
    temp: Option<ThermalLag>,
    steps: Option<Steps>,
    spikes: Option<Spikes>,
    resonance: Option<Resonance>,
    telegraph: Option<Telegraph>,
    warm_up: Option<WarmUp>,
    lowpass: Option<LowPass>,
    adc: Quantizer,
    clipped: u64,
    /// None of the terms outside the IEEE base model and its bench (Q, ramp, Gauss-Markov, sinusoids, steps,
    /// outliers, resonance, bistable bias, warm-up) is present: [`VirtualGyro::next_rate`] skips their checks.
    lean: bool,
}

fn check(ok: bool, field: &'static str) -> Result<(), SimError> {
    if ok {
        Ok(())
    } else {
        Err(SimError::InvalidParameter(field))
    }
}

fn nonneg(x: f64, field: &'static str) -> Result<(), SimError> {
    check(x.is_finite() && x >= 0.0, field)
}

fn positive(x: f64, field: &'static str) -> Result<(), SimError> {
    check(x.is_finite() && x > 0.0, field)
}

impl GyroSim {
    /// Check every parameter's range.
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] naming the first bad field.
    pub fn validate(&self) -> Result<(), SimError> {
        check(self.bias_dps.is_finite(), "bias_dps")?;
        nonneg(self.q_deg, "q_deg")?;
        nonneg(self.n_deg_per_rt_s, "n_deg_per_rt_s")?;
        nonneg(self.b_dps, "b_dps")?;
        nonneg(self.k_dps_per_rt_s, "k_dps_per_rt_s")?;
        check(self.r_dps_per_s.is_finite(), "r_dps_per_s")?;
        if let Some(g) = &self.gauss_markov {
            nonneg(g.sigma_dps, "gauss_markov.sigma_dps")?;
            positive(g.tau_s, "gauss_markov.tau_s")?;
        }
        if let Some(f) = self.bandwidth_hz {
            positive(f, "bandwidth_hz")?;
        }
        for s in &self.sinusoids {
            check(s.amplitude_dps.is_finite() && s.phase_rad.is_finite(), "sinusoids.amplitude_dps")?;
            positive(s.period_s, "sinusoids.period_s")?;
        }
        if let Some(t) = &self.temperature {
            check(t.dps_per_c.is_finite() && t.ref_c.is_finite(), "temperature.dps_per_c")?;
            nonneg(t.lag_s, "temperature.lag_s")?;
        }
        if let Some(b) = &self.bias_steps {
            nonneg(b.per_hour, "bias_steps.per_hour")?;
            nonneg(b.sigma_dps, "bias_steps.sigma_dps")?;
        }
        if let Some(o) = &self.outliers {
            check(o.per_sample.is_finite() && (0.0..=1.0).contains(&o.per_sample), "outliers.per_sample")?;
            check(o.size_dps.is_finite() && o.size_sigma.is_finite(), "outliers.size_dps")?;
            nonneg(o.spread_dps, "outliers.spread_dps")?;
            nonneg(o.spread_sigma, "outliers.spread_sigma")?;
            nonneg(o.run_mean, "outliers.run_mean")?;
            check(o.run_continue.is_finite() && (0.0..1.0).contains(&o.run_continue), "outliers.run_continue")?;
        }
        if let Some(r) = &self.resonance {
            nonneg(r.sigma_dps, "resonance.sigma_dps")?;
            positive(r.freq_hz, "resonance.freq_hz")?;
            check(r.q.is_finite() && r.q > 0.5, "resonance.q")?;
        }
        if let Some(b) = &self.bistable {
            nonneg(b.step_dps, "bistable.step_dps")?;
            positive(b.dwell_low_s, "bistable.dwell_low_s")?;
            positive(b.dwell_high_s, "bistable.dwell_high_s")?;
        }
        if let Some(w) = &self.warm_up {
            check(w.size_dps.is_finite(), "warm_up.size_dps")?;
            positive(w.tau_s, "warm_up.tau_s")?;
        }
        Ok(())
    }
}

impl VirtualGyro {
    /// A virtual gyro for `model` on `channel`, sampled at `rate_hz`, random stream `seed`.
    ///
    /// # Errors
    /// [`SimError::InvalidSampleRate`] or [`SimError::InvalidParameter`] (also for a resonance at or above half
    /// the sample rate).
    pub fn new(model: &GyroSim, channel: Channel, rate_hz: f64, seed: u64) -> Result<Self, SimError> {
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(SimError::InvalidSampleRate);
        }
        model.validate()?;
        if model.resonance.is_some_and(|r| r.freq_hz >= 0.5 * rate_hz) {
            return Err(SimError::InvalidParameter("resonance.freq_hz"));
        }
        let tau0 = 1.0 / rate_hz;
        let mut rng = SimRng::new(seed);
        let n_sigma = model.n_deg_per_rt_s * libm::sqrt(rate_hz);
        let flicker = (model.b_dps > 0.0).then(|| FlickerBank::new(model.b_dps, &mut rng));
        let white_var = n_sigma * n_sigma;
        let gm = model
            .gauss_markov
            .filter(|g| g.sigma_dps > 0.0)
            .map(|g| GaussMarkov::new(g.sigma_dps, g.tau_s, tau0, &mut rng));
        let steps = model.bias_steps.filter(|b| b.per_hour > 0.0).map(|b| Steps::new(&b, rate_hz, &mut rng));
        let spikes = model.outliers.filter(|o| o.per_sample > 0.0).map(|o| Spikes::new(&o, n_sigma, &mut rng));
        // The angle drawn "before" sample 0, so the first difference is stationary too (no draw without Q).
        let last_angle = if model.q_deg > 0.0 { rng.normal() } else { 0.0 };
        let resonance = model
            .resonance
            .filter(|r| r.sigma_dps > 0.0)
            .map(|r| Resonance::new(r.sigma_dps, r.freq_hz, r.q, tau0, &mut rng));
        let telegraph = model.bistable.filter(|b| b.step_dps > 0.0).map(|b| Telegraph::new(&b, tau0, &mut rng));
        let warm_up = model.warm_up.filter(|w| w.size_dps != 0.0).map(|w| WarmUp::new(&w, tau0));
        Ok(VirtualGyro {
            n: 0,
            bias: model.bias_dps,
            white_sigma: libm::sqrt(white_var),
            angle_scale: model.q_deg * rate_hz,
            last_angle,
            ramp_step: model.r_dps_per_s * tau0,
            flicker,
            rw: (model.k_dps_per_rt_s > 0.0).then(|| RandomWalk::new(model.k_dps_per_rt_s, tau0)),
            gm,
            sines: Sinusoids::new(&model.sinusoids, tau0),
            temp: model.temperature.map(|t| ThermalLag::new(&t, tau0)),
            steps,
            spikes,
            resonance,
            telegraph,
            warm_up,
            lowpass: model.bandwidth_hz.map(|f| LowPass::new(f, rate_hz)),
            adc: Quantizer::new(&channel),
            clipped: 0,
            lean: false,
            rng,
        }
        .with_path())
    }

    /// The next analog rate in deg/s, without the ADC (the noise-only path): `temp_c` is the bench
    /// temperature at this sample (ignored without temperature coupling).
    #[inline]
    pub fn next_rate(&mut self, temp_c: f64) -> f64 {
        let mut rate = 0.0;
        self.run(1, |_| temp_c, |_, r| rate = r);
        rate
    }

    /// `count` samples, sample i at temperature `temp_at(i)`, each analog rate handed to `out(i, rate)`: the
    /// loop of a lean gyro (the IEEE base model and its bench) or of one with any terms.
    #[inline(always)]
    fn run(&mut self, count: usize, temp_at: impl Fn(usize) -> f64, out: impl FnMut(usize, f64)) {
        if self.lean {
            self.run_path::<true>(count, temp_at, out);
        } else {
            self.run_path::<false>(count, temp_at, out);
        }
    }

    /// The sample loop. The state is copied into locals for the loop and written back after: held in registers,
    /// where through `self` every sample would store and reload it (the held flicker processes are written at a
    /// varying index, which the compiler cannot tell apart from the other fields). With `LEAN` the terms outside
    /// the base model are not even checked: the base models and the demo's bench take that loop billions of times.
    /// The order of the terms, and so of the random draws, is fixed: white, white angle, flicker, random walk,
    /// ramp, Gauss-Markov, sinusoids, temperature, bias steps, resonance, bistable bias, warm-up, then the
    /// low-pass, then the outliers.
    #[inline(always)]
    fn run_path<const LEAN: bool>(
        &mut self,
        count: usize,
        temp_at: impl Fn(usize) -> f64,
        mut out: impl FnMut(usize, f64),
    ) {
        let mut rng = self.rng.clone();
        let mut n = self.n;
        let (bias, white_sigma, angle_scale, ramp_step) =
            (self.bias, self.white_sigma, self.angle_scale, self.ramp_step);
        let mut last_angle = self.last_angle;
        let mut rw = self.rw.clone();
        let mut temp = self.temp.clone();
        let mut lowpass = self.lowpass.clone();
        let mut gm = self.gm.clone();
        let mut steps = self.steps.clone();
        let mut resonance = self.resonance.clone();
        let mut telegraph = self.telegraph.clone();
        let mut warm_up = self.warm_up.clone();
        let mut spikes = self.spikes.clone();
        let sines = &mut self.sines;
        let mut fast = self.flicker.as_ref().map(|f| f.fast);
        let mut slow = self.flicker.as_mut().map(|f| &mut f.slow);
        for i in 0..count {
            let mut r = bias;
            if white_sigma != 0.0 {
                r += white_sigma * rng.normal();
            }
            if !LEAN && angle_scale != 0.0 {
                let w = rng.normal();
                r += angle_scale * (w - last_angle);
                last_angle = w;
            }
            if let (Some(fast), Some(slow)) = (&mut fast, &mut slow) {
                r += flicker::step(fast, slow, n, &mut rng);
            }
            if let Some(w) = &mut rw {
                r += w.next(&mut rng);
            }
            if !LEAN {
                if ramp_step != 0.0 {
                    r += ramp_step * n as f64;
                }
                if let Some(g) = &mut gm {
                    r += g.next(&mut rng);
                }
                if !sines.is_empty() {
                    r += sines.next(n);
                }
            }
            if let Some(t) = &mut temp {
                r += t.next(temp_at(i));
            }
            if !LEAN {
                if let Some(s) = &mut steps {
                    r += s.next(&mut rng);
                }
                if let Some(x) = &mut resonance {
                    r += x.next(&mut rng);
                }
                if let Some(t) = &mut telegraph {
                    r += t.next(&mut rng);
                }
                if let Some(w) = &mut warm_up {
                    r += w.next_dps();
                }
            }
            if let Some(lp) = &mut lowpass {
                r = lp.next(r);
            }
            if !LEAN {
                if let Some(s) = &mut spikes {
                    r += s.next(&mut rng);
                }
            }
            n += 1;
            out(i, r);
        }
        if let (Some(f), Some(fast)) = (&mut self.flicker, fast) {
            f.fast = fast;
        }
        (self.rng, self.n, self.last_angle, self.rw, self.temp, self.lowpass) = (rng, n, last_angle, rw, temp, lowpass);
        (self.gm, self.steps, self.resonance, self.telegraph, self.warm_up, self.spikes) =
            (gm, steps, resonance, telegraph, warm_up, spikes);
    }

    /// Mark the gyro lean when it has none of the terms outside the base model and its bench.
    fn with_path(mut self) -> Self {
        self.lean = self.angle_scale == 0.0
            && self.ramp_step == 0.0
            && self.gm.is_none()
            && self.sines.is_empty()
            && self.steps.is_none()
            && self.spikes.is_none()
            && self.resonance.is_none()
            && self.telegraph.is_none()
            && self.warm_up.is_none();
        self
    }

    /// The next sample: analog rate, ADC code and clipping.
    #[inline]
    pub fn next(&mut self, temp_c: f64) -> Sample {
        let rate_dps = self.next_rate(temp_c);
        self.quantize(rate_dps)
    }

    #[inline(always)]
    fn quantize(&mut self, rate_dps: f64) -> Sample {
        let (code, clipped) = self.adc.quantize(rate_dps);
        self.clipped += u64::from(clipped);
        Sample { rate_dps, code, clipped }
    }

    /// Fill `codes` with consecutive ADC codes at a constant temperature.
    pub fn fill_codes(&mut self, temp_c: f64, codes: &mut [u16]) {
        self.fill_with(|_| temp_c, codes);
    }

    /// Fill `codes` with consecutive ADC codes, sample i at the bench temperature `temps_c[i]`. The same codes
    /// as calling [`VirtualGyro::next`] sample by sample.
    ///
    /// # Panics
    /// If `temps_c` is shorter than `codes`.
    pub fn fill_codes_at(&mut self, temps_c: &[f64], codes: &mut [u16]) {
        let temps_c = &temps_c[..codes.len()];
        self.fill_with(|i| temps_c[i], codes);
    }

    /// Fill `rates` with consecutive analog rates (deg/s, no ADC), sample i at the bench temperature `temps_c[i]`:
    /// the values of as many calls of [`VirtualGyro::next_rate`].
    ///
    /// # Panics
    /// If `temps_c` is shorter than `rates`.
    pub fn fill_rates_at(&mut self, temps_c: &[f64], rates: &mut [f64]) {
        let temps_c = &temps_c[..rates.len()];
        self.run(rates.len(), |i| temps_c[i], |i, r| rates[i] = r);
    }

    /// The block loop of the codes.
    #[inline(always)]
    fn fill_with(&mut self, temp_at: impl Fn(usize) -> f64, codes: &mut [u16]) {
        let adc = self.adc;
        let mut clipped = 0u64;
        self.run(codes.len(), temp_at, |i, r| {
            let (code, clip) = adc.quantize(r);
            clipped += u64::from(clip);
            codes[i] = code;
        });
        self.clipped += clipped;
    }

    /// Samples produced so far.
    pub fn count(&self) -> u64 {
        self.n
    }

    /// Samples that clipped at the ADC so far.
    pub fn clipped_count(&self) -> u64 {
        self.clipped
    }

    /// Bias steps taken so far.
    pub fn step_count(&self) -> u64 {
        self.steps.as_ref().map_or(0, Steps::count)
    }

    /// Flips of the bistable bias so far.
    pub fn flip_count(&self) -> u64 {
        self.telegraph.as_ref().map_or(0, Telegraph::flips)
    }

    /// Outliers injected so far.
    pub fn outlier_count(&self) -> u64 {
        self.spikes.as_ref().map_or(0, Spikes::count)
    }

    /// The per-sample sd of the white Gaussian drawn (N sqrt(rate_hz)), deg/s.
    pub fn white_sigma_dps(&self) -> f64 {
        self.white_sigma
    }

    /// The channel's ADC map.
    pub fn quantizer(&self) -> &Quantizer {
        &self.adc
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::{ADXRS300, IDG1215_X};
    use crate::sim::{BistableSim, ResonanceSim, TempCoupling, WarmUpSim};

    #[test]
    fn rejects_bad_parameters() {
        let ch = Channel::bench(ADXRS300);
        assert_eq!(VirtualGyro::new(&GyroSim::default(), ch, 0.0, 1).unwrap_err(), SimError::InvalidSampleRate);
        let m = GyroSim { n_deg_per_rt_s: -1.0, ..Default::default() };
        assert_eq!(VirtualGyro::new(&m, ch, 100.0, 1).unwrap_err(), SimError::InvalidParameter("n_deg_per_rt_s"));
        let m = GyroSim { bandwidth_hz: Some(f64::NAN), ..Default::default() };
        assert!(VirtualGyro::new(&m, ch, 100.0, 1).is_err());
        for q in [-1e-4, f64::NAN, f64::INFINITY] {
            let m = GyroSim { q_deg: q, ..Default::default() };
            assert_eq!(VirtualGyro::new(&m, ch, 100.0, 1).unwrap_err(), SimError::InvalidParameter("q_deg"));
        }
        let bad = |m: GyroSim| VirtualGyro::new(&m, ch, 100.0, 1).unwrap_err();
        let res =
            |freq_hz, q| GyroSim { resonance: Some(ResonanceSim { sigma_dps: 1.0, freq_hz, q }), ..Default::default() };
        assert_eq!(bad(res(10.0, 0.5)), SimError::InvalidParameter("resonance.q"));
        assert_eq!(bad(res(50.0, 5.0)), SimError::InvalidParameter("resonance.freq_hz"));
        assert_eq!(bad(res(0.0, 5.0)), SimError::InvalidParameter("resonance.freq_hz"));
        assert!(VirtualGyro::new(&res(49.9, 5.0), ch, 100.0, 1).is_ok());
        let bi = |dwell_low_s| GyroSim {
            bistable: Some(BistableSim { step_dps: 1.0, dwell_low_s, dwell_high_s: 1.0 }),
            ..Default::default()
        };
        assert_eq!(bad(bi(0.0)), SimError::InvalidParameter("bistable.dwell_low_s"));
        let warm = GyroSim { warm_up: Some(WarmUpSim { size_dps: 1.0, tau_s: -1.0 }), ..Default::default() };
        assert_eq!(bad(warm), SimError::InvalidParameter("warm_up.tau_s"));
    }

    /// Each of the resonance, the bistable bias and the warm-up sends a model down the full path, and a model
    /// that names one with nothing to add (zero sd, step or size) draws nothing for it: its samples are those of
    /// the model without it, bit for bit.
    #[test]
    fn the_new_terms_take_the_full_path_and_absent_ones_draw_nothing() {
        let ch = Channel::bench(ADXRS300);
        let base = GyroSim { n_deg_per_rt_s: 0.046, b_dps: 0.026, ..Default::default() };
        let with = [
            GyroSim { resonance: Some(ResonanceSim { sigma_dps: 0.1, freq_hz: 20.0, q: 5.0 }), ..base.clone() },
            GyroSim {
                bistable: Some(BistableSim { step_dps: 0.1, dwell_low_s: 1.0, dwell_high_s: 1.0 }),
                ..base.clone()
            },
            GyroSim { warm_up: Some(WarmUpSim { size_dps: 0.1, tau_s: 1.0 }), ..base.clone() },
        ];
        for m in &with {
            assert!(!VirtualGyro::new(m, ch, 200.0, 1).unwrap().lean);
        }
        let zero = GyroSim {
            resonance: Some(ResonanceSim { sigma_dps: 0.0, freq_hz: 20.0, q: 5.0 }),
            bistable: Some(BistableSim { step_dps: 0.0, dwell_low_s: 1.0, dwell_high_s: 1.0 }),
            warm_up: Some(WarmUpSim { size_dps: 0.0, tau_s: 1.0 }),
            ..base.clone()
        };
        let mut a = VirtualGyro::new(&base, ch, 200.0, 3).unwrap();
        let mut b = VirtualGyro::new(&zero, ch, 200.0, 3).unwrap();
        for _ in 0..10_000 {
            assert_eq!(a.next(25.0), b.next(25.0));
        }
    }

    /// A gyro of the base terms with the bench's filter and coupling takes the lean path; one sinusoid of zero
    /// amplitude (no draw, adds zero) sends the same model down the full path. Both give the same rates and
    /// codes, bit for bit, at a temperature that moves.
    #[test]
    fn the_lean_path_equals_the_full_path() {
        let ch = Channel::bench(ADXRS300);
        let lean = GyroSim {
            bias_dps: 0.3,
            n_deg_per_rt_s: 0.046,
            b_dps: 0.026,
            k_dps_per_rt_s: 1e-3,
            bandwidth_hz: Some(600.0),
            temperature: Some(TempCoupling { dps_per_c: 0.1, ref_c: 23.5, lag_s: 0.5 }),
            ..Default::default()
        };
        let mut full = lean.clone();
        full.sinusoids.push(crate::sim::Sinusoid { amplitude_dps: 0.0, period_s: 1.0, phase_rad: 0.0 }).unwrap();
        let mut a = VirtualGyro::new(&lean, ch, 2000.0, 11).unwrap();
        let mut b = VirtualGyro::new(&full, ch, 2000.0, 11).unwrap();
        assert!(a.lean && !b.lean);
        for i in 0..200_000u32 {
            let temp = 23.0 + f64::from(i % 1000) * 1e-3;
            assert_eq!(a.next(temp), b.next(temp), "sample {i}");
        }
    }

    #[test]
    fn constant_bias_gives_a_constant_code() {
        let ch = Channel::bench(IDG1215_X);
        let m = GyroSim { bias_dps: 1.25, ..Default::default() };
        let mut g = VirtualGyro::new(&m, ch, 100.0, 1).unwrap();
        let want = ch.dps_to_code(1.25);
        for _ in 0..100 {
            let s = g.next(25.0);
            assert_eq!((s.rate_dps, s.code, s.clipped), (1.25, want, false));
        }
    }

    #[test]
    fn clipping_is_counted() {
        let ch = Channel::bench(IDG1215_X);
        let m = GyroSim { bias_dps: 500.0, ..Default::default() };
        let mut g = VirtualGyro::new(&m, ch, 100.0, 1).unwrap();
        let s = g.next(25.0);
        assert_eq!((s.code, s.clipped), (4095, true));
        let m = GyroSim { bias_dps: -500.0, ..Default::default() };
        let mut g = VirtualGyro::new(&m, ch, 100.0, 1).unwrap();
        for _ in 0..9 {
            assert_eq!(g.next(25.0).code, 0);
        }
        assert_eq!(g.clipped_count(), 9);
    }
}

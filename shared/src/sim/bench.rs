//! A simulated bench: several gyro channels and one shared temperature, sampled together at one rate.
//!
//! Each channel gets its own random stream, derived from the bench seed and the channel's index, and the
//! temperature wander a stream of its own: adding a channel does not change the others' samples.

use super::gyro::{SimError, VirtualGyro};
use super::model::{BenchSim, MAX_CHANNELS};
use super::rng::SimRng;
use super::temperature::Thermal;
use crate::sensor::{Channel, GyroModel};

/// One scan of the bench: every channel's code and analog rate, and the temperature.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BenchSample {
    /// The bench temperature, degC.
    pub temp_c: f64,
    /// ADC codes, channels `0..len`.
    pub codes: [u16; MAX_CHANNELS],
    /// Analog rates at the ADC, deg/s.
    pub rate_dps: [f64; MAX_CHANNELS],
    /// Which channels clipped.
    pub clipped: [bool; MAX_CHANNELS],
    /// Number of channels.
    pub len: usize,
}

impl BenchSample {
    /// The codes of the channels.
    pub fn codes(&self) -> &[u16] {
        &self.codes[..self.len]
    }

    /// The analog rates of the channels, deg/s.
    pub fn rates_dps(&self) -> &[f64] {
        &self.rate_dps[..self.len]
    }
}

/// The running bench simulation.
#[derive(Clone, Debug, PartialEq)]
pub struct Bench {
    thermal: Thermal,
    rng: SimRng,
    gyros: heapless::Vec<VirtualGyro, MAX_CHANNELS>,
    channels: heapless::Vec<Channel, MAX_CHANNELS>,
    rate_hz: f64,
}

impl Bench {
    /// Start a bench from its model.
    ///
    /// # Errors
    /// [`SimError::InvalidSampleRate`], [`SimError::NotAGyro`] or [`SimError::InvalidParameter`].
    pub fn new(model: &BenchSim) -> Result<Self, SimError> {
        let rate_hz = model.rate_hz;
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(SimError::InvalidSampleRate);
        }
        let t = &model.temperature;
        let ok = t.min_c.is_finite() && t.max_c.is_finite() && t.phase_rad.is_finite() && t.period_s > 0.0;
        if !ok || t.wander.is_some_and(|w| !(w.sigma_c >= 0.0 && w.tau_s > 0.0)) {
            return Err(SimError::InvalidParameter("temperature"));
        }
        let mut rng = SimRng::new(SimRng::derive_seed(model.seed, u64::MAX));
        let thermal = Thermal::new(t, rate_hz, &mut rng);
        let mut gyros = heapless::Vec::new();
        let mut channels = heapless::Vec::new();
        for (i, c) in model.channels.iter().enumerate() {
            let channel = match c.channel {
                Some(ch) => ch,
                None => Channel::bench(GyroModel::of(c.sensor).ok_or(SimError::NotAGyro)?),
            };
            let g = VirtualGyro::new(&c.gyro, channel, rate_hz, SimRng::derive_seed(model.seed, i as u64))?;
            // Capacities match the model's own list, so neither push can fail.
            let _ = gyros.push(g);
            let _ = channels.push(channel);
        }
        Ok(Bench { thermal, rng, gyros, channels, rate_hz })
    }

    /// A bench that runs only channel `index` of `model`, with the same seeds and the same temperature: its
    /// scans carry, in channel 0, exactly the samples channel `index` has in the full bench. Channels can so
    /// run in parallel, one per core.
    ///
    /// # Errors
    /// As [`Bench::new`]; [`SimError::InvalidParameter`] for an index past the last channel.
    pub fn only_channel(model: &BenchSim, index: usize) -> Result<Self, SimError> {
        Bench::only_channels(model, &[index])
    }

    /// A bench that runs only the channels `indices` of `model` (in that order), with the same seeds and the
    /// same temperature: channel k of its scans carries exactly the samples channel `indices[k]` has in the full
    /// bench. Groups of channels can so run in parallel, each computing the bench temperature once for all of
    /// its channels.
    ///
    /// # Errors
    /// As [`Bench::new`]; [`SimError::InvalidParameter`] for an index past the last channel or more indices than
    /// a bench has channels.
    pub fn only_channels(model: &BenchSim, indices: &[usize]) -> Result<Self, SimError> {
        let mut full = Bench::new(model)?;
        if indices.len() > MAX_CHANNELS || indices.iter().any(|&i| i >= full.gyros.len()) {
            return Err(SimError::InvalidParameter("channel index"));
        }
        let gyros = indices.iter().map(|&i| full.gyros[i].clone()).collect();
        let channels = indices.iter().map(|&i| full.channels[i]).collect();
        (full.gyros, full.channels) = (gyros, channels);
        Ok(full)
    }

    /// The next scan (the bench is also an endless [`Iterator`] of scans).
    #[inline]
    pub fn next_sample(&mut self) -> BenchSample {
        let temp_c = self.thermal.next(&mut self.rng);
        let mut out = BenchSample {
            temp_c,
            codes: [0; MAX_CHANNELS],
            rate_dps: [0.0; MAX_CHANNELS],
            clipped: [false; MAX_CHANNELS],
            len: self.gyros.len(),
        };
        for (i, g) in self.gyros.iter_mut().enumerate() {
            let s = g.next(temp_c);
            out.codes[i] = s.code;
            out.rate_dps[i] = s.rate_dps;
            out.clipped[i] = s.clipped;
        }
        out
    }

    /// The next `temps_c.len()` scans a block at a time: the bench temperatures into `temps_c`, and channel i's
    /// ADC codes into `codes[i]` (each at least as long as `temps_c`). The same values as as many calls of
    /// [`Bench::next_sample`], made channel by channel, which keeps each gyro's state in registers.
    ///
    /// # Panics
    /// If `codes` has fewer slices than the bench has channels, or one is shorter than `temps_c`.
    pub fn fill_block(&mut self, temps_c: &mut [f64], codes: &mut [&mut [u16]]) {
        self.thermal.fill(&mut self.rng, temps_c);
        assert!(codes.len() >= self.gyros.len(), "one code slice per channel");
        for (g, c) in self.gyros.iter_mut().zip(codes.iter_mut()) {
            g.fill_codes_at(temps_c, &mut c[..temps_c.len()]);
        }
    }

    /// Sample rate, Hz.
    pub fn rate_hz(&self) -> f64 {
        self.rate_hz
    }

    /// The channels' wiring (for code -> deg/s).
    pub fn channels(&self) -> &[Channel] {
        &self.channels
    }

    /// The virtual gyros (counters: clipping, steps, outliers).
    pub fn gyros(&self) -> &[VirtualGyro] {
        &self.gyros
    }
}

impl Iterator for Bench {
    type Item = BenchSample;

    /// Never `None`: the bench runs until dropped.
    fn next(&mut self) -> Option<BenchSample> {
        Some(self.next_sample())
    }
}

#[cfg(test)]
mod only_channel_tests {
    use super::*;
    use crate::sensor::SensorKind;
    use crate::sim::model::{ChannelSim, GyroSim, TemperatureProfile, Wander};

    #[test]
    fn one_channel_alone_equals_that_channel_of_the_bench() {
        let mut channels = heapless::Vec::new();
        for (kind, n) in [(SensorKind::Adxrs300, 0.05), (SensorKind::Idg1215Y, 0.003), (SensorKind::Env05h, 4e-4)] {
            let gyro = GyroSim { n_deg_per_rt_s: n, b_dps: n, ..Default::default() };
            let _ = channels.push(ChannelSim { sensor: kind, channel: None, gyro });
        }
        let temperature = TemperatureProfile {
            min_c: 22.0,
            max_c: 25.0,
            period_s: 60.0,
            phase_rad: 0.0,
            wander: Some(Wander { sigma_c: 0.1, tau_s: 5.0 }),
        };
        let model = BenchSim { rate_hz: 100.0, seed: 9, temperature, channels };
        let full: heapless::Vec<BenchSample, 512> = Bench::new(&model).unwrap().take(512).collect();
        for i in 0..3 {
            let alone = Bench::only_channel(&model, i).unwrap();
            for (a, f) in alone.take(512).zip(&full) {
                assert_eq!(a.codes[0], f.codes[i]);
                assert_eq!(a.temp_c, f.temp_c);
            }
        }
        assert!(Bench::only_channel(&model, 3).is_err());
        // A group, in its own order.
        let group = Bench::only_channels(&model, &[2, 0]).unwrap();
        for (g, f) in group.take(512).zip(&full) {
            assert_eq!((g.len, g.codes[0], g.codes[1]), (2, f.codes[2], f.codes[0]));
            assert_eq!(g.temp_c, f.temp_c);
        }
        assert!(Bench::only_channels(&model, &[0, 3]).is_err());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::SensorKind;
    use crate::sim::model::{ChannelSim, GyroSim, TemperatureProfile};

    fn model(channels: &[(SensorKind, f64)]) -> BenchSim {
        let mut list = heapless::Vec::new();
        for &(sensor, n) in channels {
            let gyro = GyroSim { n_deg_per_rt_s: n, b_dps: 0.01, ..Default::default() };
            list.push(ChannelSim { sensor, channel: None, gyro }).unwrap();
        }
        BenchSim {
            rate_hz: 100.0,
            seed: 3,
            temperature: TemperatureProfile { min_c: 22.0, max_c: 25.0, period_s: 50.0, ..Default::default() },
            channels: list,
        }
    }

    #[test]
    fn adding_a_channel_leaves_the_others_alone() {
        let mut a = Bench::new(&model(&[(SensorKind::Adxrs300, 0.05)])).unwrap();
        let mut b = Bench::new(&model(&[(SensorKind::Adxrs300, 0.05), (SensorKind::Idg1215X, 0.003)])).unwrap();
        for _ in 0..1000 {
            let (x, y) = (a.next_sample(), b.next_sample());
            assert_eq!(x.codes()[0], y.codes()[0]);
            assert_eq!(x.temp_c, y.temp_c);
            assert_eq!(y.len, 2);
        }
    }

    #[test]
    fn temperature_channel_is_not_a_gyro() {
        assert_eq!(Bench::new(&model(&[(SensorKind::Temperature, 0.0)])).unwrap_err(), SimError::NotAGyro);
    }

    #[test]
    fn blocks_give_the_samples_of_scan_by_scan() {
        use crate::sim::model::{Sinusoid, TempCoupling};
        let mut m = model(&[(SensorKind::Adxrs300, 0.05), (SensorKind::Idg1215X, 0.003), (SensorKind::Env05h, 4e-4)]);
        for (i, c) in m.channels.iter_mut().enumerate() {
            c.gyro.k_dps_per_rt_s = 1e-3;
            c.gyro.bandwidth_hz = Some(30.0);
            c.gyro.temperature = Some(TempCoupling { dps_per_c: 0.05, ref_c: 23.0, lag_s: 5.0 });
            if i == 1 {
                // A term outside the lean path.
                let _ = c.gyro.sinusoids.push(Sinusoid { amplitude_dps: 0.1, period_s: 7.0, phase_rad: 0.3 });
            }
        }
        // A wander on the temperature, and blocks that cross the phasor's renormalisation at sample 4095.
        m.temperature.wander = Some(crate::sim::model::Wander { sigma_c: 0.3, tau_s: 2.0 });
        let mut scans = Bench::new(&m).unwrap();
        let mut blocks = Bench::new(&m).unwrap();
        let mut temps = [0.0; 5000];
        let mut codes = [[0u16; 5000]; 3];
        for len in [1, 256, 257, 100, 5000] {
            let [a, b, c] = &mut codes;
            blocks.fill_block(&mut temps[..len], &mut [&mut a[..], &mut b[..], &mut c[..]]);
            for j in 0..len {
                let s = scans.next_sample();
                assert_eq!(s.temp_c.to_bits(), temps[j].to_bits());
                assert_eq!(s.codes(), [codes[0][j], codes[1][j], codes[2][j]]);
            }
        }
        assert_eq!(scans.gyros(), blocks.gyros());
    }
}

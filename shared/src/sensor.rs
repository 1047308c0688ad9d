//! Gyro, front-end and ADC models: ADC code <-> volts <-> deg/s for each channel of the bench.
//!
//! A channel is a gyro (sensitivity, null output, range, bandwidth, optional temperature output), the analog
//! front end between it and the microcontroller (a divider or an amplifier with a level shift) and the ADC (bits,
//! reference voltage). Every datasheet number carries its source; numbers that could not be confirmed from a
//! datasheet are listed in [`GyroModel::assumptions`], and every field is public so a user can override them.
//!
//! # Examples
//! ```
//! use octavar_shared::sensor::{Channel, ADXRS300};
//! let ch = Channel::bench(ADXRS300);
//! let code = ch.dps_to_code(0.0);             // the null maps near mid-scale after the 5 V -> 3.3 V divider
//! assert!((ch.code_to_dps(code) - 0.0).abs() <= ch.dps_per_code());
//! ```

use serde::{Deserialize, Serialize};

/// Which part a channel carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[serde(rename_all = "snake_case")]
pub enum SensorKind {
    /// InvenSense IDG-1215, X output.
    Idg1215X,
    /// InvenSense IDG-1215, Y output.
    Idg1215Y,
    /// Analog Devices ADXRS300.
    Adxrs300,
    /// muRata ENV-05H (Gyrostar).
    Env05h,
    /// Any analog rate gyro described by the user.
    Generic,
    /// A temperature channel (not a gyro).
    Temperature,
}

/// A temperature output: volts = `mv_at_25c + mv_per_c * (T - 25)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TempOutput {
    /// Output at 25 degC, in mV.
    pub mv_at_25c: f64,
    /// Slope in mV per degC.
    pub mv_per_c: f64,
}

/// An analog rate gyro as its datasheet describes it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GyroModel {
    /// Which part.
    pub kind: SensorKind,
    /// Output change per deg/s, in mV.
    pub sensitivity_mv_per_dps: f64,
    /// Output at zero rate, in mV.
    pub null_mv: f64,
    /// Full-scale range, +/- deg/s.
    pub range_dps: f64,
    /// Output bandwidth (-3 dB), in Hz.
    pub bandwidth_hz: f64,
    /// Supply voltage, in mV.
    pub supply_mv: f64,
    /// The temperature output, where the part has one.
    pub temp_output: Option<TempOutput>,
    /// Numbers above that no datasheet at hand confirmed (by field name).
    #[serde(skip)]
    pub assumptions: &'static [&'static str],
}

/// IDG-1215 X output. Datasheet PS-IDG-1215 (InvenSense), section 2 "Features" and section 3 "Specifications":
/// +/-67 deg/s full scale, 15 mV/(deg/s), zero-rate output 1.35 V at a 3.0 V supply, 140 Hz low-pass.
pub const IDG1215_X: GyroModel = GyroModel {
    kind: SensorKind::Idg1215X,
    sensitivity_mv_per_dps: 15.0,
    null_mv: 1350.0,
    range_dps: 67.0,
    bandwidth_hz: 140.0,
    supply_mv: 3000.0,
    temp_output: None,
    assumptions: &["bandwidth_hz"],
};

/// IDG-1215 Y output: same electrical figures as X (same datasheet).
pub const IDG1215_Y: GyroModel = GyroModel { kind: SensorKind::Idg1215Y, ..IDG1215_X };

/// ADXRS300. Datasheet (Analog Devices, Rev. B), "Specifications": +/-300 deg/s, 5 mV/(deg/s), null 2.50 V at
/// 5 V, TEMP output 2.50 V at 25 degC and 8.4 mV/K; 40 Hz bandwidth with the recommended filter capacitors.
pub const ADXRS300: GyroModel = GyroModel {
    kind: SensorKind::Adxrs300,
    sensitivity_mv_per_dps: 5.0,
    null_mv: 2500.0,
    range_dps: 300.0,
    bandwidth_hz: 40.0,
    supply_mv: 5000.0,
    temp_output: Some(TempOutput { mv_at_25c: 2500.0, mv_per_c: 8.4 }),
    assumptions: &[],
};

/// muRata ENV-05H (Gyrostar piezoelectric vibrating gyro), 5 V part with a 2.5 V static output.
/// Its datasheet could not be confirmed here: scale factor, range and bandwidth follow the ENV-05 family
/// (22.2 mV/(deg/s), +/-90 deg/s, about 50 Hz) and are assumptions; override them for your part.
pub const ENV05H: GyroModel = GyroModel {
    kind: SensorKind::Env05h,
    sensitivity_mv_per_dps: 22.2,
    null_mv: 2500.0,
    range_dps: 90.0,
    bandwidth_hz: 50.0,
    supply_mv: 5000.0,
    temp_output: None,
    assumptions: &["sensitivity_mv_per_dps", "range_dps", "bandwidth_hz"],
};

/// A generic analog gyro: 10 mV/(deg/s) around a 1.65 V null, for recordings of unknown parts.
pub const GENERIC: GyroModel = GyroModel {
    kind: SensorKind::Generic,
    sensitivity_mv_per_dps: 10.0,
    null_mv: 1650.0,
    range_dps: 150.0,
    bandwidth_hz: 1000.0,
    supply_mv: 3300.0,
    temp_output: None,
    assumptions: &["sensitivity_mv_per_dps", "null_mv", "range_dps", "bandwidth_hz", "supply_mv"],
};

impl GyroModel {
    /// The built-in model of a part (`None` for [`SensorKind::Temperature`]).
    pub const fn of(kind: SensorKind) -> Option<GyroModel> {
        match kind {
            SensorKind::Idg1215X => Some(IDG1215_X),
            SensorKind::Idg1215Y => Some(IDG1215_Y),
            SensorKind::Adxrs300 => Some(ADXRS300),
            SensorKind::Env05h => Some(ENV05H),
            SensorKind::Generic => Some(GENERIC),
            SensorKind::Temperature => None,
        }
    }

    /// Sensor output in mV for a rate in deg/s (linear, before clipping at the rails).
    pub fn dps_to_mv(&self, rate_dps: f64) -> f64 {
        self.null_mv + self.sensitivity_mv_per_dps * rate_dps
    }

    /// Rate in deg/s for a sensor output in mV.
    pub fn mv_to_dps(&self, mv: f64) -> f64 {
        (mv - self.null_mv) / self.sensitivity_mv_per_dps
    }
}

/// The analog path from the sensor pin to the ADC pin: `v_adc = offset_mv + gain * (v_sensor - ref_mv)`.
///
/// A resistive divider is `gain < 1` with `ref_mv = offset_mv = 0`; an amplifier around the null is
/// `ref_mv = null`, `offset_mv = vref / 2`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FrontEnd {
    /// Voltage gain (V/V).
    pub gain: f64,
    /// Sensor voltage the gain is taken around, in mV.
    pub ref_mv: f64,
    /// ADC-side voltage at `ref_mv`, in mV.
    pub offset_mv: f64,
}

impl FrontEnd {
    /// A straight wire.
    pub const WIRE: FrontEnd = FrontEnd { gain: 1.0, ref_mv: 0.0, offset_mv: 0.0 };

    /// A resistive divider with ratio `gain` (for example 2/3 to bring a 5 V part into a 3.3 V ADC).
    pub const fn divider(gain: f64) -> FrontEnd {
        FrontEnd { gain, ref_mv: 0.0, offset_mv: 0.0 }
    }

    /// ADC-pin voltage for a sensor voltage.
    pub fn apply(&self, sensor_mv: f64) -> f64 {
        self.offset_mv + self.gain * (sensor_mv - self.ref_mv)
    }

    /// Sensor voltage for an ADC-pin voltage.
    pub fn invert(&self, adc_mv: f64) -> f64 {
        self.ref_mv + (adc_mv - self.offset_mv) / self.gain
    }
}

/// A successive-approximation ADC: `bits` bits over 0..`vref_mv`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Adc {
    /// Resolution in bits (12 on the STM32F405).
    pub bits: u8,
    /// Reference voltage in mV (VREF+ = VDDA = 3.3 V on the usual F405 boards).
    pub vref_mv: f64,
}

impl Adc {
    /// The STM32F405's ADC as wired on the bench: 12 bits, 3.3 V reference (RM0090 section 13).
    pub const STM32F405: Adc = Adc { bits: 12, vref_mv: 3300.0 };

    /// The largest code.
    pub const fn max_code(&self) -> u16 {
        ((1u32 << self.bits) - 1) as u16
    }

    /// Volts per code step, in mV.
    pub fn mv_per_code(&self) -> f64 {
        self.vref_mv / (1u32 << self.bits) as f64
    }

    /// Unquantised code for an input voltage (code c covers [c, c+1) LSB; its centre is c + 0.5).
    pub fn mv_to_code_f(&self, mv: f64) -> f64 {
        mv / self.mv_per_code()
    }

    /// Quantise and clip: the code the converter reports for `mv`.
    pub fn quantize(&self, mv: f64) -> u16 {
        let c = libm::floor(self.mv_to_code_f(mv));
        if c <= 0.0 {
            0
        } else if c >= f64::from(self.max_code()) {
            self.max_code()
        } else {
            c as u16
        }
    }

    /// The voltage a code stands for (the centre of its step), in mV.
    pub fn code_to_mv(&self, code: u16) -> f64 {
        (f64::from(code) + 0.5) * self.mv_per_code()
    }
}

/// One gyro channel of the bench: part, front end and ADC.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Channel {
    /// The gyro.
    pub gyro: GyroModel,
    /// The analog path to the ADC pin.
    pub front: FrontEnd,
    /// The converter.
    pub adc: Adc,
}

impl Channel {
    /// The bench wiring of octavar's board (README, wiring table): 3 V parts straight into the 3.3 V ADC;
    /// the ADXRS300 through a 2/3 divider (2.5 V null -> 1.67 V, +/-300 deg/s -> 0.67..2.67 V); the ENV-05H,
    /// whose noise is below one 12-bit step at its own scale, through a x3 amplifier around its null, centred
    /// at 1.65 V (+/-24 deg/s at the pin: plenty on a motionless bench).
    pub fn bench(gyro: GyroModel) -> Channel {
        let front = match gyro.kind {
            SensorKind::Env05h => FrontEnd { gain: 3.0, ref_mv: gyro.null_mv, offset_mv: 1650.0 },
            _ if gyro.supply_mv > 3600.0 => FrontEnd::divider(2.0 / 3.0),
            _ => FrontEnd::WIRE,
        };
        Channel { gyro, front, adc: Adc::STM32F405 }
    }

    /// The largest rate magnitude the channel converts without clipping, in deg/s.
    pub fn usable_range_dps(&self) -> f64 {
        let lo = self.dps_to_code_f(0.0);
        let span = f64::from(self.adc.max_code()) - lo;
        let per_dps = 1.0 / self.dps_per_code();
        (lo.min(span) / per_dps).min(self.gyro.range_dps)
    }

    /// deg/s per ADC code step.
    pub fn dps_per_code(&self) -> f64 {
        self.adc.mv_per_code() / (self.front.gain * self.gyro.sensitivity_mv_per_dps)
    }

    /// Unquantised code for a rate (before clipping).
    pub fn dps_to_code_f(&self, rate_dps: f64) -> f64 {
        self.adc.mv_to_code_f(self.front.apply(self.gyro.dps_to_mv(rate_dps)))
    }

    /// The code the converter reports for a rate: quantised and clipped.
    pub fn dps_to_code(&self, rate_dps: f64) -> u16 {
        self.adc.quantize(self.front.apply(self.gyro.dps_to_mv(rate_dps)))
    }

    /// The rate a code stands for.
    pub fn code_to_dps(&self, code: u16) -> f64 {
        self.gyro.mv_to_dps(self.front.invert(self.adc.code_to_mv(code)))
    }
}

/// The bench scale of the part `kind`: deg/s per ADC code through [`Channel::bench`] (1 for a channel without a
/// built-in model, whose codes are already the unit).
pub fn dps_per_code(kind: SensorKind) -> f64 {
    GyroModel::of(kind).map_or(1.0, |g| Channel::bench(g).dps_per_code())
}

/// The ADC code of the bench's temperature channel at `temp_c`: the ADXRS300 TEMP output (2.50 V at 25 degC,
/// 8.4 mV/K) through the same 2/3 divider as its rate output.
pub fn temperature_code(temp_c: f64) -> u16 {
    let (ch, t) = adxrs300_temp();
    ch.adc.quantize(ch.front.apply(t.mv_at_25c + t.mv_per_c * (temp_c - 25.0)))
}

/// The temperature in degC that a mean code of the bench's temperature channel stands for (the inverse of
/// [`temperature_code`], at the centre of the code's step).
pub fn temperature_c(mean_code: f64) -> f32 {
    let (ch, t) = adxrs300_temp();
    let sensor_mv = ch.front.invert((mean_code + 0.5) * ch.adc.mv_per_code());
    (25.0 + (sensor_mv - t.mv_at_25c) / t.mv_per_c) as f32
}

fn adxrs300_temp() -> (Channel, TempOutput) {
    let t = ADXRS300.temp_output.expect("the ADXRS300 has a TEMP output");
    (Channel::bench(ADXRS300), t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temperature_code_round_trips() {
        for t in [20.0, 22.5, 25.0, 31.0] {
            let back = temperature_c(f64::from(temperature_code(t)));
            // One code is 1/7 K: the round trip lands within half a step.
            assert!((f64::from(back) - t).abs() < 0.08, "{t} -> {back}");
        }
    }

    #[test]
    fn code_round_trip_within_one_step() {
        for gyro in [IDG1215_X, IDG1215_Y, ADXRS300, ENV05H, GENERIC] {
            let ch = Channel::bench(gyro);
            for r in [-0.9, -0.3, 0.0, 0.25, 0.8] {
                let rate = r * ch.usable_range_dps();
                let back = ch.code_to_dps(ch.dps_to_code(rate));
                assert!((back - rate).abs() <= ch.dps_per_code() * 0.5 + 1e-12, "{gyro:?} {rate} -> {back}");
            }
        }
    }

    #[test]
    fn full_range_stays_inside_the_adc() {
        for gyro in [IDG1215_X, ADXRS300, ENV05H] {
            let ch = Channel::bench(gyro);
            let r = ch.usable_range_dps();
            assert!(r >= 20.0, "{gyro:?}: usable range {r}");
            let lo = ch.dps_to_code_f(-r * 0.999);
            let hi = ch.dps_to_code_f(r * 0.999);
            assert!(lo > 0.0 && hi < f64::from(ch.adc.max_code()), "{gyro:?}: {lo}..{hi}");
        }
    }

    #[test]
    fn adc_clips_at_the_rails() {
        let adc = Adc::STM32F405;
        assert_eq!(adc.quantize(-5.0), 0);
        assert_eq!(adc.quantize(4000.0), 4095);
        assert_eq!(adc.quantize(1650.0), 2048);
    }

    #[test]
    fn adxrs300_divider_scale() {
        // 5 mV/(deg/s) * 2/3 = 3.33 mV/(deg/s) at the pin; one 12-bit step of 3.3 V is 0.806 mV: 0.242 deg/s.
        let ch = Channel::bench(ADXRS300);
        assert!((ch.dps_per_code() - 3300.0 / 4096.0 / (5.0 * 2.0 / 3.0)).abs() < 1e-12);
    }
}

//! `octavar simulate`: run the virtual bench (shared::sim) and write its samples as CSV or raw ADC codes.
//!
//! The model comes from a `model.toml` ([`load_model`]) or is built from a few flags ([`single_channel`]). The
//! output is either rates in deg/s (the ADC's codes converted back through the channel model, so quantisation
//! and clipping show as they would in a real recording; or the analog rate before the ADC) with a time column
//! and, where the model has one, the temperature; or the raw ADC codes that the firmware would accumulate.

use std::io::Write;
use std::path::Path;

use octavar_shared::sensor::{GyroModel, SensorKind};
use octavar_shared::sim::{Bench, BenchSim, ChannelSim, GyroSim};

/// What went wrong.
#[derive(Debug, thiserror::Error)]
pub enum SimulateError {
    /// The model file could not be read.
    #[error("reading model {path}: {err}")]
    ReadModel { path: String, err: std::io::Error },
    /// The model file is not a valid model.
    #[error("model {path}: {message}")]
    ParseModel { path: String, message: String },
    /// The model is inconsistent (a parameter out of range, a temperature channel used as a gyro...).
    #[error("model: {0}")]
    Model(octavar_shared::sim::SimError),
    /// A duration that is not a positive number of seconds.
    #[error("duration {0:?} is not a positive time such as 600, 600s, 30m, 72h or 3d")]
    BadDuration(String),
    /// Writing the output failed.
    #[error("writing output: {0}")]
    Write(#[from] std::io::Error),
}

/// What to write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputKind {
    /// `t_s`, one column per channel of the rate the ADC reports (code -> deg/s), `temp_c` where modelled.
    Rates,
    /// Like `Rates`, with the analog rate before quantisation and clipping.
    AnalogRates,
    /// Raw ADC codes: one integer per line for one channel, a CSV with a header of channel names otherwise.
    Codes,
}

/// Options of [`simulate`].
#[derive(Clone, Debug)]
pub struct SimulateOptions {
    /// How many seconds of samples.
    pub duration_s: f64,
    /// What to write.
    pub output: OutputKind,
}

/// Counters of a finished run.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SimulateStats {
    /// Scans written (samples per channel).
    pub samples: u64,
    /// Samples that clipped at an ADC rail, per channel.
    pub clipped: Vec<u64>,
}

/// Parse a duration: seconds, or a number with an `s`, `m`, `h` or `d` suffix.
///
/// # Errors
/// [`SimulateError::BadDuration`] for anything else, zero or negative.
pub fn parse_duration(text: &str) -> Result<f64, SimulateError> {
    let t = text.trim();
    let (num, unit) = match t.char_indices().last() {
        Some((i, c)) if c.is_ascii_alphabetic() => (&t[..i], c),
        _ => (t, 's'),
    };
    let scale = match unit {
        's' => 1.0,
        'm' => 60.0,
        'h' => 3600.0,
        'd' => 86_400.0,
        _ => return Err(SimulateError::BadDuration(text.to_string())),
    };
    match num.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v * scale),
        _ => Err(SimulateError::BadDuration(text.to_string())),
    }
}

/// Read a bench model from a `model.toml`.
///
/// # Errors
/// The file cannot be read, or is not a valid model (the message names the key and line).
pub fn load_model(path: &Path) -> Result<BenchSim, SimulateError> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|err| SimulateError::ReadModel { path: name.clone(), err })?;
    parse_model(&text, &name)
}

/// Parse a bench model from TOML text (`name` is used in errors).
///
/// # Errors
/// [`SimulateError::ParseModel`] with TOML's own description of the fault.
pub fn parse_model(text: &str, name: &str) -> Result<BenchSim, SimulateError> {
    toml::from_str(text).map_err(|e| SimulateError::ParseModel { path: name.to_string(), message: e.to_string() })
}

/// Write a bench model as TOML.
pub fn model_to_toml(model: &BenchSim) -> String {
    toml::to_string_pretty(model).expect("a bench model always serialises")
}

/// A one-channel bench from flags: the part, its noise terms and the sample rate.
pub fn single_channel(sensor: SensorKind, gyro: GyroSim, rate_hz: f64, seed: u64) -> BenchSim {
    let mut channels = heapless::Vec::new();
    let _ = channels.push(ChannelSim { sensor, channel: None, gyro });
    BenchSim { rate_hz, seed, temperature: Default::default(), channels }
}

/// A column name for each channel: the part's name, with `_2`, `_3`... where a part repeats.
pub fn channel_names(model: &BenchSim) -> Vec<String> {
    let base: Vec<&str> = model.channels.iter().map(|c| sensor_name(c.sensor)).collect();
    base.iter()
        .enumerate()
        .map(|(i, b)| {
            let same_before = base[..i].iter().filter(|x| *x == b).count();
            let total = base.iter().filter(|x| *x == b).count();
            if total > 1 {
                format!("{b}_{}", same_before + 1)
            } else {
                (*b).to_string()
            }
        })
        .collect()
}

/// The short name of a part, as used in column names and on the command line.
pub fn sensor_name(kind: SensorKind) -> &'static str {
    match kind {
        SensorKind::Idg1215X => "idg1215_x",
        SensorKind::Idg1215Y => "idg1215_y",
        SensorKind::Adxrs300 => "adxrs300",
        SensorKind::Env05h => "env05h",
        SensorKind::Generic => "generic",
        SensorKind::Temperature => "temperature",
    }
}

/// Whether the model's temperature matters: a varying profile or a channel coupled to it.
pub fn has_temperature(model: &BenchSim) -> bool {
    let t = &model.temperature;
    t.max_c != t.min_c || t.wander.is_some() || model.channels.iter().any(|c| c.gyro.temperature.is_some())
}

/// Run the bench for `opts.duration_s` and write its samples to `out`. `progress` is called with the number of
/// scans done, now and then.
///
/// # Errors
/// An invalid model, or a failed write.
pub fn simulate<W: Write>(
    model: &BenchSim,
    opts: &SimulateOptions,
    out: W,
    mut progress: impl FnMut(u64),
) -> Result<SimulateStats, SimulateError> {
    let mut bench = Bench::new(model).map_err(SimulateError::Model)?;
    for c in &model.channels {
        GyroModel::of(c.sensor).ok_or(SimulateError::Model(octavar_shared::sim::SimError::NotAGyro))?;
    }
    let total = (opts.duration_s * model.rate_hz).round() as u64;
    let names = channel_names(model);
    let with_temp = has_temperature(model);
    let channels: Vec<_> = bench.channels().to_vec();
    let mut w = std::io::BufWriter::with_capacity(1 << 20, out);
    let mut ints = itoa::Buffer::new();
    let mut floats = ryu::Buffer::new();
    let plain_codes = opts.output == OutputKind::Codes && names.len() == 1;
    match opts.output {
        OutputKind::Codes if plain_codes => {}
        OutputKind::Codes => writeln!(w, "{}", names.join(","))?,
        _ => {
            write!(w, "t_s")?;
            for n in &names {
                write!(w, ",{n}_dps")?;
            }
            if with_temp {
                write!(w, ",temp_c")?;
            }
            writeln!(w)?;
        }
    }
    let mut clipped = vec![0u64; names.len()];
    for i in 0..total {
        let s = bench.next_sample();
        for (c, &clip) in clipped.iter_mut().zip(&s.clipped[..s.len]) {
            *c += u64::from(clip);
        }
        match opts.output {
            OutputKind::Codes => {
                for (k, code) in s.codes().iter().enumerate() {
                    if k > 0 {
                        w.write_all(b",")?;
                    }
                    w.write_all(ints.format(*code).as_bytes())?;
                }
            }
            OutputKind::Rates | OutputKind::AnalogRates => {
                w.write_all(floats.format(i as f64 / model.rate_hz).as_bytes())?;
                for k in 0..s.len {
                    let v = if opts.output == OutputKind::Rates {
                        channels[k].code_to_dps(s.codes[k])
                    } else {
                        s.rate_dps[k]
                    };
                    w.write_all(b",")?;
                    w.write_all(floats.format(v).as_bytes())?;
                }
                if with_temp {
                    w.write_all(b",")?;
                    w.write_all(floats.format(s.temp_c).as_bytes())?;
                }
            }
        }
        w.write_all(b"\n")?;
        if i & 0xFFFF == 0 {
            progress(i);
        }
    }
    w.flush()?;
    progress(total);
    Ok(SimulateStats { samples: total, clipped })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations() {
        assert_eq!(parse_duration("600").unwrap(), 600.0);
        assert_eq!(parse_duration("30m").unwrap(), 1800.0);
        assert_eq!(parse_duration("72h").unwrap(), 259_200.0);
        assert_eq!(parse_duration("0.5d").unwrap(), 43_200.0);
        assert!(parse_duration("-3").is_err());
        assert!(parse_duration("3x").is_err());
        assert!(parse_duration("").is_err());
    }

    #[test]
    fn names_disambiguate_repeats() {
        let mut m = single_channel(SensorKind::Adxrs300, GyroSim::default(), 100.0, 1);
        let _ = m.channels.push(m.channels[0].clone());
        let _ = m.channels.push(ChannelSim { sensor: SensorKind::Env05h, channel: None, gyro: GyroSim::default() });
        assert_eq!(channel_names(&m), ["adxrs300_1", "adxrs300_2", "env05h"]);
    }

    #[test]
    fn model_toml_round_trips() {
        let gyro = GyroSim { n_deg_per_rt_s: 3e-3, b_dps: 13e-3, ..Default::default() };
        let m = single_channel(SensorKind::Idg1215Y, gyro, 2000.0, 7);
        let text = model_to_toml(&m);
        assert_eq!(parse_model(&text, "m.toml").unwrap(), m);
        let e = parse_model("fs_hz = 100.0\nchannels = []\nbogus = 1\n", "m.toml").unwrap_err();
        assert!(e.to_string().contains("bogus"), "{e}");
    }

    #[test]
    fn codes_and_rates_agree_through_the_channel_model() {
        let gyro = GyroSim { n_deg_per_rt_s: 3e-3, bias_dps: 0.5, ..Default::default() };
        let m = single_channel(SensorKind::Idg1215X, gyro, 100.0, 3);
        let run = |output| {
            let mut buf = Vec::new();
            simulate(&m, &SimulateOptions { duration_s: 2.0, output }, &mut buf, |_| {}).unwrap();
            String::from_utf8(buf).unwrap()
        };
        let codes = run(OutputKind::Codes);
        let rates = run(OutputKind::Rates);
        let codes: Vec<u16> = codes.lines().map(|l| l.parse().unwrap()).collect();
        assert_eq!(codes.len(), 200);
        let ch = octavar_shared::sensor::Channel::bench(octavar_shared::sensor::IDG1215_X);
        for (line, code) in rates.lines().skip(1).zip(&codes) {
            let v: f64 = line.split(',').nth(1).unwrap().parse().unwrap();
            assert_eq!(v, ch.code_to_dps(*code));
        }
        let mean: f64 = codes.iter().map(|&c| ch.code_to_dps(c)).sum::<f64>() / codes.len() as f64;
        assert!((mean - 0.5).abs() < 0.1, "bias 0.5 deg/s, mean {mean}");
    }
}

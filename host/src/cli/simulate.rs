//! `octavar simulate`: flags -> a bench model -> samples on a file or stdout.

use std::fs::File;
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Context};
use octavar::simulate::{self, OutputKind, SimulateOptions};
use octavar_shared::sensor::SensorKind;
use octavar_shared::sim::GyroSim;

use super::progress::Progress;

/// Simulate a gyro bench (the virtual gyro + ADC of the shared core) and write CSV: t_s, one rate column per
/// channel in deg/s, and temp_c where the model has a temperature; or raw ADC codes with --codes.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// A model.toml (as written by `analyze --model-out`); without it, one channel from the flags below.
    #[arg(long, value_name = "FILE")]
    pub model: Option<PathBuf>,
    /// The part of the one-channel model.
    #[arg(long, value_enum, default_value = "generic")]
    pub sensor: Sensor,
    /// Angle random walk N, deg/sqrt(s) (white rate noise).
    #[arg(long, value_name = "DEG_PER_RT_S")]
    pub n: Option<f64>,
    /// Bias instability B, deg/s (flicker; Allan floor 0.6643 B).
    #[arg(long, value_name = "DPS")]
    pub b: Option<f64>,
    /// Rate random walk K, deg/s/sqrt(s).
    #[arg(long, value_name = "DPS_PER_RT_S")]
    pub k: Option<f64>,
    /// Rate ramp R, deg/s^2.
    #[arg(long, value_name = "DPS_PER_S")]
    pub r: Option<f64>,
    /// Constant bias, deg/s.
    #[arg(long, value_name = "DPS")]
    pub bias: Option<f64>,
    /// Sample rate per channel, Hz (default: the model's, or 2000).
    #[arg(long, value_name = "HZ")]
    pub rate: Option<f64>,
    /// How long: seconds, or with a suffix s, m, h, d (72h).
    #[arg(long, default_value = "600s")]
    pub duration: String,
    /// Seed of the run (default: the model's, or 0). The same seed gives the same samples, bit for bit.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Write raw ADC codes instead of deg/s (one integer per line for one channel, CSV for several).
    #[arg(long, conflicts_with = "analog")]
    pub codes: bool,
    /// Write the analog rate before the ADC instead of the converted codes.
    #[arg(long)]
    pub analog: bool,
    /// Output file; - is stdout.
    #[arg(short, long, default_value = "-")]
    pub output: PathBuf,
    /// Also write the model used, as TOML.
    #[arg(long, value_name = "FILE")]
    pub write_model: Option<PathBuf>,
}

/// The parts octavar knows, as named on the command line.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum Sensor {
    /// InvenSense IDG-1215, X output.
    #[value(name = "idg1215-x")]
    Idg1215X,
    /// InvenSense IDG-1215, Y output.
    #[value(name = "idg1215-y")]
    Idg1215Y,
    /// Analog Devices ADXRS300.
    Adxrs300,
    /// muRata ENV-05H.
    Env05h,
    /// A generic 10 mV/(deg/s) analog gyro.
    Generic,
}

impl From<Sensor> for SensorKind {
    fn from(s: Sensor) -> SensorKind {
        match s {
            Sensor::Idg1215X => SensorKind::Idg1215X,
            Sensor::Idg1215Y => SensorKind::Idg1215Y,
            Sensor::Adxrs300 => SensorKind::Adxrs300,
            Sensor::Env05h => SensorKind::Env05h,
            Sensor::Generic => SensorKind::Generic,
        }
    }
}

impl Args {
    pub fn run(self) -> anyhow::Result<ExitCode> {
        let term_flags = [self.n, self.b, self.k, self.r, self.bias].iter().any(Option::is_some);
        let mut model = match &self.model {
            Some(path) => {
                if term_flags {
                    bail!("--n, --b, --k, --r and --bias describe a one-channel model: not with --model");
                }
                simulate::load_model(path)?
            }
            None => {
                let gyro = GyroSim {
                    n_deg_per_rt_s: self.n.unwrap_or(0.0),
                    b_dps: self.b.unwrap_or(0.0),
                    k_dps_per_rt_s: self.k.unwrap_or(0.0),
                    r_dps_per_s: self.r.unwrap_or(0.0),
                    bias_dps: self.bias.unwrap_or(0.0),
                    ..Default::default()
                };
                simulate::single_channel(self.sensor.into(), gyro, 2000.0, 0)
            }
        };
        if let Some(rate) = self.rate {
            model.rate_hz = rate;
        }
        if let Some(seed) = self.seed {
            model.seed = seed;
        }
        let duration_s = simulate::parse_duration(&self.duration)?;
        if let Some(path) = &self.write_model {
            std::fs::write(path, simulate::model_to_toml(&model))
                .with_context(|| format!("writing {}", path.display()))?;
        }
        let output = if self.codes {
            OutputKind::Codes
        } else if self.analog {
            OutputKind::AnalogRates
        } else {
            OutputKind::Rates
        };
        let opts = SimulateOptions { duration_s, output };
        let total = (duration_s * model.rate_hz).round() as u64;
        let bar = Progress::new(total, "simulating");
        let stats = if self.output.as_os_str() == "-" {
            simulate::simulate(&model, &opts, std::io::stdout().lock(), |n| bar.set(n))?
        } else {
            let file = File::create(&self.output).with_context(|| format!("creating {}", self.output.display()))?;
            simulate::simulate(&model, &opts, file, |n| bar.set(n))
                .with_context(|| format!("writing {}", self.output.display()))?
        };
        bar.finish();
        let names = simulate::channel_names(&model);
        for (name, clipped) in names.iter().zip(&stats.clipped) {
            if *clipped > 0 {
                let _ = writeln!(
                    std::io::stderr(),
                    "octavar: warning: {name}: {clipped} of {} samples clipped at an ADC rail",
                    stats.samples
                );
            }
        }
        Ok(ExitCode::SUCCESS)
    }
}

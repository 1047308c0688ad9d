//! `octavar gap`: flags -> recording (training, holdout) -> diagnosis -> report, JSON, plot.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Mutex;

use anyhow::{bail, Context};
use octavar::export::ImuNoise;
use octavar::gap::{self, GapInput, GapOptions};
use octavar::io::formats::{self, RecordingFormat};
use octavar::io::recording::Recording;
use octavar::plot;
use octavar_shared::sensor::SensorKind;
use octavar_shared::sim::{BenchSim, ChannelSim};

use super::csv_args::CsvArgs;
use super::export_args::ExportArgs;
use super::progress::Progress;

/// Diagnose the sim-to-real gap: fit the IEEE 952 terms on the training part, simulate an ensemble of the fitted
/// model, find where real and simulation part (ADEV, PSD, distribution, temperature), try each candidate effect
/// (temperature, sinusoid, bandwidth, gauss_markov, quantization, bias_steps, outliers, resonance, bistable,
/// warm_up), add the best and rank the rest again while a significant gap remains, and check the chain on held-out data with every parameter frozen.
/// Transient disturbances are found and masked first; a gap no candidate explains is described.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The recording: CSV with a header (.gz is read as such; - is stdin), .tdms, a ROS bag (.mcap or .db3, also
    /// zstd-compressed, or a rosbag2 folder of them; a ROS 1 .bag), a device capture (its raw samples), or raw
    /// samples (--format).
    pub input: PathBuf,
    /// The rate column to diagnose (`group/channel` in a TDMS file; x, y or z of a bag's angular velocity).
    #[arg(long, value_name = "NAME", required_unless_present = "accel_column", conflicts_with = "accel_column")]
    pub column: Option<String>,
    /// An accelerometer column to diagnose instead (in --accel-unit; ax, ay or az of a bag's linear acceleration).
    #[arg(long, value_name = "NAME")]
    pub accel_column: Option<String>,
    /// Input format: csv (default), tdms (default for .tdms), mcap (default for .mcap and a rosbag2 folder of them),
    /// db3 (default for .db3 and a rosbag2 folder of them), bag (default for .bag: ROS 1), capture (default for
    /// .cap/.capture: the raw samples, --column a channel's name), or one channel of raw little-endian samples
    /// f64le, f32le, i16le, u16le (with --rate).
    #[arg(long, value_name = "FORMAT")]
    pub format: Option<String>,
    /// How to read the recording.
    #[command(flatten)]
    pub reading: CsvArgs,
    /// A temperature column (degC): the ensemble is driven by it and the temperature view compares coherences.
    #[arg(long, value_name = "NAME")]
    pub temp_column: Option<String>,
    /// A separate held-out recording with the same columns (default: the later part of INPUT).
    #[arg(long, value_name = "FILE", conflicts_with = "holdout_fraction")]
    pub holdout: Option<PathBuf>,
    /// Row filters for the held-out recording instead of --where (repeatable); without --holdout they select the
    /// holdout from INPUT itself, e.g. --where period=1 --holdout-where period=2.
    #[arg(long = "holdout-where", value_name = "COLUMN=VALUE")]
    pub holdout_filters: Vec<String>,
    /// Fraction of INPUT held out at its end.
    #[arg(long, value_name = "F", default_value_t = 0.5)]
    pub holdout_fraction: f64,
    /// Ensemble size.
    #[arg(long, value_name = "N", default_value_t = 20)]
    pub seeds: usize,
    /// Each sample of the record is the mean of N of the sensor's samples (a decimated record, such as 1 Hz
    /// means of a 2 kHz gyro): the ensemble is simulated at N times the rate and averaged the same way, so its
    /// spectrum has the block mean's shape too (16 is enough for a long block).
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub oversample: u32,
    /// How the held-out gap is judged: `plain`, against the ensembles of the models learnt from the real training
    /// part (their spread is the noise's); `predictive` adds a check against predictive ensembles, whose members
    /// each re-learn the model from a simulated training part, so their spread carries the error of the learnt
    /// parameters too (JSON `holdout_predictive`; it costs two more ensembles and the estimator on each member).
    #[arg(long, value_name = "CHECK", value_enum, default_value_t = HoldoutCheckArg::Plain)]
    pub holdout_check: HoldoutCheckArg,
    /// Leave transient disturbances (bumps, bursts of spikes, seconds to minutes long) in the record; by default
    /// they are found in both parts, reported, and masked as gaps before the diagnosis.
    #[arg(long)]
    pub keep_transients: bool,
    /// Write the model with every effect the diagnosis found (the base fit and the chain, parameters from the
    /// training part) as a model.toml for `octavar simulate --model` (a temperature coupling acts only where the
    /// simulation has a temperature profile).
    #[arg(long, value_name = "FILE")]
    pub model_out: Option<PathBuf>,
    /// Write the JSON document here (`-`: to stdout, instead of the text report).
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Noise configs for a state estimator or simulator from the base fit (--export FORMAT=FILE, --kalibr FILE,
    /// --inflate X, as analyze writes them); the bias model is the gauss_markov effect where the diagnosis named
    /// one.
    #[command(flatten)]
    pub export: ExportArgs,
    /// Draw the gap figure (.png or .svg): a panel per view (ADEV, PSD, distribution, temperature) with the record,
    /// the ensemble bands of the base model and of the model with every effect found, and where the gap lay; and
    /// the record over time with its masked transients.
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,
}

impl Args {
    /// The column diagnosed: the rate column or the accelerometer column.
    fn column_name(&self) -> &str {
        self.column.as_deref().or(self.accel_column.as_deref()).unwrap_or_default()
    }

    fn read(&self, path: &Path, filters: &[String]) -> anyhow::Result<Recording> {
        let format = RecordingFormat::of(path, self.format.as_deref()).with_context(|| {
            format!("--format {:?}: use csv, tdms, mcap, bag, db3, capture, f64le, f32le, i16le or u16le", self.format)
        })?;
        let columns = (self.column.iter().cloned().collect(), self.accel_column.iter().cloned().collect());
        let opts = self.reading.read_options(columns, self.temp_column.clone(), filters, 1)?;
        Ok(formats::read_recording(path, format, &opts)?)
    }

    pub fn run(self) -> anyhow::Result<ExitCode> {
        // A bad --export or --inflate is reported before the recording is read, not after the diagnosis.
        self.export.requests()?;
        let mut rec = self.read(&self.input, &self.reading.filters)?;
        let rate_hz = rec.rate_hz;
        let quantity = rec.quantity(0);
        let separate = self.holdout.is_some() || !self.holdout_filters.is_empty();
        let input = if separate {
            let path = self.holdout.clone().unwrap_or_else(|| self.input.clone());
            let filters = if self.holdout_filters.is_empty() { &self.reading.filters } else { &self.holdout_filters };
            let mut hold = self.read(&path, filters)?;
            if (hold.rate_hz - rate_hz).abs() > 1e-6 * rate_hz {
                bail!("the holdout is sampled at {} Hz, the training at {} Hz", hold.rate_hz, rate_hz);
            }
            GapInput::joined(
                rec.channels.remove(0),
                rec.temp_c.take(),
                hold.channels.remove(0),
                hold.temp_c.take(),
                rate_hz,
            )?
        } else {
            GapInput::split(rec.channels.remove(0), rec.temp_c.take(), rate_hz, self.holdout_fraction)?
        };
        let opts = GapOptions {
            seeds: self.seeds,
            oversample: self.oversample as usize,
            holdout_check: self.holdout_check.into(),
            keep_transients: self.keep_transients,
            quantity,
            ..Default::default()
        };
        let bar = Mutex::new(None::<Progress>);
        let progress = |_stage: &str, done: usize, total: usize| {
            let mut b = bar.lock().expect("progress lock");
            let p = b.get_or_insert_with(|| Progress::new(total as u64, "gap"));
            p.set(done as u64);
        };
        let t0 = std::time::Instant::now();
        let report = gap::diagnose(&input, &opts, &progress)?;
        if let Some(b) = bar.lock().expect("progress lock").as_ref() {
            b.finish();
        }
        if !super::json_out::to_stdout(self.json.as_deref()) {
            let mut out = std::io::stdout().lock();
            writeln!(
                out,
                "# {}, column {}: diagnosed in {:.1} s",
                rec.source,
                self.column_name(),
                t0.elapsed().as_secs_f64()
            )?;
            report.write_text(&mut out)?;
        }
        if let Some(path) = &self.json {
            super::json_out::write(path, &report.to_json(), &mut std::io::stdout().lock())?;
        }
        if self.export.any() {
            let topic = self.reading.topic.clone().unwrap_or_else(|| "/imu0".to_string());
            let train = &input.rate_dps[..input.n_train];
            let (sum, n) = train.iter().filter(|v| v.is_finite()).fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
            let mean = (n > 0).then(|| sum / n as f64);
            let noise = ImuNoise::from_gap(&report, self.column_name(), mean, &rec.source, &topic, self.export.inflate);
            self.export.write(&noise)?;
        }
        if let Some(path) = &self.model_out {
            let range = input.rate_dps.iter().filter(|v| v.is_finite()).fold(0.0f64, |m, v| m.max(v.abs()));
            let channel =
                report.chain.model.channel.unwrap_or_else(|| octavar::analyze::fine_channel(4.0 * range.max(1e-3)));
            let mut channels = heapless::Vec::new();
            let _ = channels.push(ChannelSim {
                sensor: SensorKind::Generic,
                channel: Some(channel),
                gyro: report.model().clone(),
            });
            let bench = BenchSim { rate_hz, seed: 0, temperature: Default::default(), channels };
            std::fs::write(path, octavar::simulate::model_to_toml(&bench))
                .with_context(|| format!("writing {}", path.display()))?;
        }
        if let Some(path) = &self.plot {
            let name = Path::new(&rec.source).file_name().map_or(rec.source.clone(), |n| n.to_string_lossy().into());
            let title = format!("Sim-to-real gap: {name} {} ({})", self.column_name(), effects_text(&report));
            let figure = plot::GapFigure::new(&report, &input);
            plot::gap_plot(&figure, &plot::PlotOptions::gap_figure(title), path)
                .with_context(|| format!("drawing {}", path.display()))?;
        }
        Ok(ExitCode::SUCCESS)
    }
}

/// The chain's effects joined with ` + `, or `none`.
pub(super) fn effects_text(report: &gap::GapReport) -> String {
    match report.effects() {
        e if e.is_empty() => "none".to_string(),
        e => e.iter().map(|e| e.name()).collect::<Vec<_>>().join(" + "),
    }
}

/// `--holdout-check`: the flag's values for [`gap::HoldoutCheck`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum HoldoutCheckArg {
    /// Against the ensembles of the models learnt from the real training part.
    Plain,
    /// Also against predictive ensembles, whose members re-learn the model from a simulated training part.
    Predictive,
}

impl From<HoldoutCheckArg> for gap::HoldoutCheck {
    fn from(arg: HoldoutCheckArg) -> Self {
        match arg {
            HoldoutCheckArg::Plain => gap::HoldoutCheck::Plain,
            HoldoutCheckArg::Predictive => gap::HoldoutCheck::Predictive,
        }
    }
}

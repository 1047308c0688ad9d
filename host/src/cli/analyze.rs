//! `octavar analyze`: flags -> recording -> Allan family, fit -> table, JSON, CSV, plot, model.toml, imu.yaml.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Context};
use octavar::analyze::{self, AnalyzeOptions, ChannelAnalysis};
use octavar::datasheet::Datasheet;
use octavar::export::ImuNoise;
use octavar::fit::FitOptions;
use octavar::io::csv::CsvOptions;
use octavar::io::formats::{self, RecordingFormat};
use octavar::plot;
use octavar::stats::{Statistic, TauSpec};

use super::csv_args::CsvArgs;
use super::export_args::ExportArgs;

/// Analyse a rate recording (CSV, CSV.gz or stdin, NI TDMS, a ROS 2 bag, a device capture or raw samples): the
/// Allan deviation family with confidence intervals (Stable32's table), the IEEE 952 noise terms N, B, K, R, Q
/// with intervals, and the files to go on with.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The recording: CSV with a header (.gz is read as such; - is stdin), .tdms, a ROS bag (.mcap or .db3, also
    /// zstd-compressed, or a rosbag2 folder of them; a ROS 1 .bag), a capture.
    pub input: PathBuf,
    /// A rate column to analyse (repeat for several channels; required for CSV; `group/channel` in a TDMS file;
    /// x, y or z of a bag's angular velocity, all three by default; names the channels of a binary input).
    #[arg(long = "column", value_name = "NAME")]
    pub columns: Vec<String>,
    /// An accelerometer column (repeat for x, y, z in order; in --accel-unit); ax, ay or az of a bag's linear
    /// acceleration, which is read beside its angular velocity when no column is named.
    #[arg(long = "accel-column", value_name = "NAME")]
    pub accel_columns: Vec<String>,
    /// How to read a CSV recording.
    #[command(flatten)]
    pub reading: CsvArgs,
    /// Statistics, comma-separated: adev, oadev, mdev, hdev, ohdev, tdev, totdev, or all.
    #[arg(long, default_value = "oadev", value_delimiter = ',')]
    pub stats: Vec<String>,
    /// Taus: octave, decade, all, N (per decade), or explicit seconds separated by commas.
    #[arg(long, default_value = "octave")]
    pub taus: String,
    /// Confidence of the deviation intervals (Stable32's 0.683).
    #[arg(long, default_value_t = 0.683)]
    pub confidence: f64,
    /// Fit only taus from this value up, s (for example above an anti-alias filter's corner).
    #[arg(long, value_name = "S")]
    pub fit_min_tau: Option<f64>,
    /// Fit only taus up to this value, s.
    #[arg(long, value_name = "S")]
    pub fit_max_tau: Option<f64>,
    /// A known first-order bandwidth of the sensor, Hz: shapes the white-noise term of the fit.
    #[arg(long, value_name = "HZ")]
    pub bandwidth: Option<f64>,
    /// Skip the noise-term fit: the statistics only.
    #[arg(long, conflicts_with_all = ["model_out", "kalibr", "exports"])]
    pub no_fit: bool,
    /// Write the JSON document here (`-`: to stdout, instead of the text report).
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Write every point as CSV here.
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    /// Draw the Allan deviation plot (.png or .svg).
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,
    /// Write the fitted model as a model.toml (for simulate and gap).
    #[arg(long, value_name = "FILE")]
    pub model_out: Option<PathBuf>,
    /// The exports: --export FORMAT=FILE, --kalibr FILE, --inflate X.
    #[command(flatten)]
    pub export: ExportArgs,
    /// A datasheet (TOML, figures in any customary unit; docs/exports.md): each fitted term against it, measured /
    /// datasheet with the interval, in the report and the JSON.
    #[arg(long, value_name = "FILE.toml")]
    pub datasheet: Option<PathBuf>,
    /// Input format: csv (default), tdms (default for .tdms), mcap (default for .mcap and a rosbag2 folder of them:
    /// a ROS 2 bag), db3 (default for .db3 and a rosbag2 folder of them: a ROS 2 bag in SQLite), bag (default for
    /// .bag: a ROS 1 bag), capture
    /// (default for .cap/.capture files), or raw little-endian samples f64le, f32le, i16le, u16le (streamed: OADEV
    /// at octave tau and the fit, any length in bounded memory).
    #[arg(long, value_name = "FORMAT")]
    pub format: Option<String>,
    /// Interleaved channels of a raw binary input.
    #[arg(long, default_value_t = 1, value_name = "N")]
    pub channels: usize,
    /// Stream a CSV too (automatic above 1 GiB): OADEV at octave tau and the fit in bounded memory.
    #[arg(long)]
    pub stream: bool,
    /// Which of a capture's data to analyse: auto (the newest whole field-log checkpoint if the capture holds a
    /// read-out of the log, else the raw samples, else the device's snapshots), field-log, raw or snapshots.
    #[arg(long, value_enum, default_value_t = CaptureDataArg::Auto, value_name = "DATA")]
    pub capture_data: CaptureDataArg,
    /// Stride S of the streamed OADEV: fully overlapping up to m = S, clusters every m/S samples above.
    #[arg(long, default_value_t = octavar::stats::stream_oadev::DEFAULT_STRIDE, value_name = "S")]
    pub stride: usize,
}

/// Parse `--stats`.
pub fn parse_stats(names: &[String]) -> anyhow::Result<Vec<Statistic>> {
    let mut out = Vec::new();
    for n in names {
        let n = n.trim().to_ascii_lowercase();
        if n == "all" {
            return Ok(Statistic::ALL.to_vec());
        }
        match Statistic::ALL.iter().find(|s| s.name().eq_ignore_ascii_case(&n)) {
            Some(s) => out.push(*s),
            None => bail!("unknown statistic {n:?}: use adev, oadev, mdev, hdev, ohdev, tdev, totdev or all"),
        }
    }
    Ok(out)
}

/// Parse `--taus`.
pub fn parse_taus(text: &str) -> anyhow::Result<TauSpec> {
    Ok(match text.trim() {
        "octave" => TauSpec::Octave,
        "decade" => TauSpec::Decade,
        "all" => TauSpec::All,
        t if t.contains(',') => TauSpec::Explicit(
            t.split(',')
                .map(|v| v.trim().parse::<f64>().with_context(|| format!("--taus: {v:?} is not a number")))
                .collect::<anyhow::Result<_>>()?,
        ),
        t => match t.parse::<u32>() {
            Ok(n) if n > 0 => TauSpec::PerDecade(n),
            _ => bail!("--taus {t:?}: use octave, decade, all, a count per decade, or seconds separated by commas"),
        },
    })
}

impl Args {
    /// The fit's options from the flags (the tau range and a known bandwidth), for both the in-memory and the
    /// streamed path.
    fn fit_options(&self) -> Option<FitOptions> {
        (!self.no_fit).then(|| FitOptions {
            tau_min_s: self.fit_min_tau.unwrap_or(0.0),
            tau_max_s: self.fit_max_tau.unwrap_or(f64::INFINITY),
            bandwidth_hz: self.bandwidth,
            ..Default::default()
        })
    }

    /// The rate columns and the accelerometer columns of the flags.
    fn column_lists(&self) -> (Vec<String>, Vec<String>) {
        (self.columns.clone(), self.accel_columns.clone())
    }

    /// How to read the CSV: the columns, rate or time column, unit, skipped rows and filters of the flags.
    fn csv_options(&self) -> anyhow::Result<CsvOptions> {
        self.reading.options(self.column_lists(), None, &self.reading.filters)
    }

    pub fn run(self) -> anyhow::Result<ExitCode> {
        // A bad --export or --inflate is reported before the recording is read, not after its analysis.
        self.export.requests()?;
        if let Some(kind) = self.stream_kind()? {
            return self.run_stream(kind);
        }
        let format = RecordingFormat::of(&self.input, self.format.as_deref()).unwrap_or(RecordingFormat::Csv);
        let bag = matches!(format, RecordingFormat::Mcap | RecordingFormat::Db3 | RecordingFormat::Ros1Bag);
        if self.columns.is_empty() && self.accel_columns.is_empty() && !bag {
            let what = if format == RecordingFormat::Tdms { "'GROUP/CHANNEL' for a TDMS" } else { "NAME for a CSV" };
            bail!("--column {what} input is required (repeat it for several channels)");
        }
        let stats = parse_stats(&self.stats)?;
        let taus = parse_taus(&self.taus)?;
        let read = self.reading.read_options(self.column_lists(), None, &self.reading.filters, self.channels)?;
        let rec = formats::read_recording(&self.input, format, &read)?;
        let opts = AnalyzeOptions { stats, taus, confidence: self.confidence, fit: self.fit_options() };
        // The channels side by side on the cores: each one's fit is serial, while its deviations are parallel.
        let results: Vec<ChannelAnalysis> = {
            use rayon::prelude::*;
            rec.names
                .par_iter()
                .zip(&rec.channels)
                .enumerate()
                .map(|(i, (name, data))| {
                    Ok(analyze::analyze_channel(name, data, rec.rate_hz, &opts)?.with_quantity(rec.quantity(i)))
                })
                .collect::<anyhow::Result<_>>()?
        };
        // The largest |rate| sets the simulated ADC's range of a model written with --model-out.
        let range = || {
            use rayon::prelude::*;
            rec.channels
                .par_iter()
                .flat_map(|c| c.par_iter().copied().filter(|v| v.is_finite()))
                .map(f64::abs)
                .reduce(|| 0.0, f64::max)
        };
        self.emit(&rec.source, rec.info.samples, rec.rate_hz, range, &results)
    }

    /// Print the tables and fits, and write the files asked for.
    fn emit(
        &self,
        source: &str,
        samples: u64,
        rate_hz: f64,
        range: impl FnOnce() -> f64,
        results: &[ChannelAnalysis],
    ) -> anyhow::Result<ExitCode> {
        let sheet = self.datasheet.as_deref().map(Datasheet::read).transpose()?;
        if !super::json_out::to_stdout(self.json.as_deref()) {
            analyze::write_report(&mut std::io::stdout().lock(), source, samples, rate_hz, results, sheet.as_ref())?;
        }
        if let Some(path) = &self.json {
            super::json_out::write(
                path,
                &analyze::to_json_with(results, sheet.as_ref()),
                &mut std::io::stdout().lock(),
            )?;
        }
        if let Some(path) = &self.csv {
            std::fs::write(path, analyze::to_csv(results)).with_context(|| format!("writing {}", path.display()))?;
        }
        if let Some(path) = &self.model_out {
            let model = analyze::model_from_fits(results, rate_hz, 4.0 * range().max(1e-3));
            std::fs::write(path, octavar::simulate::model_to_toml(&model))
                .with_context(|| format!("writing {}", path.display()))?;
        }
        if self.export.any() {
            if results.iter().all(|c| c.fit.is_err()) {
                bail!("no channel has a fit to export from");
            }
            let topic = self.reading.topic.clone().unwrap_or_else(|| "/imu0".to_string());
            self.export.write(&ImuNoise::from_channels(results, source, rate_hz, &topic, self.export.inflate))?;
        }
        if let Some(path) = &self.plot {
            let series: Vec<plot::AdevSeries> = results
                .iter()
                .map(|c| plot::AdevSeries {
                    name: c.name.clone(),
                    points: c.fit_points.clone(),
                    fit: c.fit.clone().ok(),
                    quantity: c.quantity,
                })
                .collect();
            let title = format!("Overlapping Allan deviation: {source}");
            let opts = plot::PlotOptions { title, ..Default::default() };
            plot::adev_plot(&series, &opts, path).with_context(|| format!("drawing {}", path.display()))?;
        }
        Ok(ExitCode::SUCCESS)
    }
}

/// Which streamed input `octavar analyze` reads.
enum StreamKind {
    Binary(octavar::io::binary::BinaryFormat),
    Capture,
    Csv,
}

/// CSV inputs above this size are streamed.
const STREAM_CSV_BYTES: u64 = 1 << 30;

impl Args {
    /// The streamed input, if this one is streamed: raw binary, capture, or a CSV with --stream or above 1 GiB.
    fn stream_kind(&self) -> anyhow::Result<Option<StreamKind>> {
        let kind = match self.format.as_deref().map(|f| f.trim().to_ascii_lowercase()) {
            Some(f) if f == "csv" => None,
            Some(f) if matches!(f.as_str(), "tdms" | "mcap" | "bag" | "db3") => return Ok(None),
            Some(f) if f == "capture" => Some(StreamKind::Capture),
            Some(f) => Some(StreamKind::Binary(octavar::io::binary::BinaryFormat::parse(&f).with_context(|| {
                format!("--format {f:?}: use csv, tdms, mcap, db3, bag, capture, f64le, f32le, i16le or u16le")
            })?)),
            // The format the path says (its extension, or a rosbag2 folder): only a CSV may be streamed.
            None => match RecordingFormat::of(&self.input, None) {
                Some(RecordingFormat::Capture) => Some(StreamKind::Capture),
                Some(RecordingFormat::Csv) => None,
                _ => return Ok(None),
            },
        };
        let size = std::fs::metadata(&self.input).map(|m| m.len()).unwrap_or(0);
        let kind = kind.or((self.stream || size > STREAM_CSV_BYTES).then_some(StreamKind::Csv));
        if kind.is_some() {
            let stats = parse_stats(&self.stats)?;
            if stats != [Statistic::Oadev] || parse_taus(&self.taus)? != TauSpec::Octave {
                bail!("streamed inputs (binary, capture, --stream) give OADEV at octave tau: drop --stats/--taus");
            }
        }
        Ok(kind)
    }

    /// Analyse a streamed input in bounded memory, with a progress bar on stderr.
    fn run_stream(self, kind: StreamKind) -> anyhow::Result<ExitCode> {
        use octavar::analyze::streamed::{self as st, StreamOptions};
        let unit = self.reading.rate_unit()?;
        let opts = StreamOptions {
            rate_hz: self.reading.rate.unwrap_or(f64::NAN),
            stride: self.stride,
            confidence: self.confidence,
            scale: unit.to_dps(),
            fit: self.fit_options(),
            capture_data: self.capture_data.into(),
        };
        let size = std::fs::metadata(&self.input).map(|m| m.len()).unwrap_or(0);
        let bar = (size > 0).then(|| super::progress::Progress::new(size, "analyze"));
        let bar_ref = std::sync::Mutex::new(bar.as_ref());
        let progress = move |done: u64| {
            if let Some(b) = *bar_ref.lock().unwrap() {
                b.set(done);
            }
        };
        let result = match kind {
            StreamKind::Binary(format) => {
                if self.reading.rate.is_none() {
                    bail!("--rate HZ is required for a raw binary input");
                }
                let input = octavar::io::input::open(&self.input)?;
                st::analyze_binary(input.reader, &input.name, format, self.channels, &self.columns, &opts, &progress)?
            }
            StreamKind::Capture => st::analyze_capture(octavar::io::decode::open(&self.input)?, &opts, &progress)?,
            StreamKind::Csv => {
                if self.columns.is_empty() && self.accel_columns.is_empty() {
                    bail!("--column NAME is required for a CSV input (repeat it for several channels)");
                }
                let csv_opts = self.csv_options()?;
                let input = octavar::io::input::open(&self.input)?;
                st::analyze_csv(input.reader, &input.name, &csv_opts, &opts, &|_| {})?
            }
        };
        if let Some(b) = &bar {
            b.finish();
        }
        eprintln!("# {}", result.method);
        let range =
            result.channels.iter().flat_map(|c| c.fit_points.first().map(|p| p.dev * 10.0)).fold(0.0f64, f64::max);
        self.emit(&result.source, result.samples, result.rate_hz, || range, &result.channels)
    }
}

/// `--capture-data`'s values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum CaptureDataArg {
    /// The field log if the capture holds one, else raw samples, else snapshots.
    Auto,
    /// The newest whole field-log checkpoint.
    FieldLog,
    /// The raw samples.
    Raw,
    /// The device's snapshots.
    Snapshots,
}

impl From<CaptureDataArg> for octavar::analyze::streamed::CaptureData {
    fn from(a: CaptureDataArg) -> Self {
        use octavar::analyze::streamed::CaptureData;
        match a {
            CaptureDataArg::Auto => CaptureData::Auto,
            CaptureDataArg::FieldLog => CaptureData::FieldLog,
            CaptureDataArg::Raw => CaptureData::Raw,
            CaptureDataArg::Snapshots => CaptureData::Snapshots,
        }
    }
}

//! `octavar demo`: the paper's bench on the virtual gyros, end to end.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use octavar::demo::{self, BENCH_RATE_HZ};
use octavar::fit::Term;
use octavar::plot;

use super::progress::Progress;

/// The main job: the paper's experiment on the built-in virtual bench. Four gyros (ENV-05H, IDG1215 Y, IDG1215 X,
/// ADXRS300) with Table 1's N and B, a 600 Hz anti-alias filter, 12-bit codes and a 22-25 degC daily cycle,
/// 72 h at 2 kS/s through the firmware's accumulator; prints the recovered Table 1 beside the paper's.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Hours of recording to simulate.
    #[arg(long, default_value_t = 72.0)]
    pub hours: f64,
    /// Folder for the files (table1.json, adev.csv, figure5.png, figure5.svg).
    #[arg(long, default_value = "octavar-demo")]
    pub out: PathBuf,
    /// Seed of the bench.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

impl Args {
    pub fn run(self) -> anyhow::Result<ExitCode> {
        if !(self.hours.is_finite() && self.hours > 0.0) {
            anyhow::bail!("--hours {} must be a positive number", self.hours);
        }
        std::fs::create_dir_all(&self.out).with_context(|| format!("creating {}", self.out.display()))?;
        demo::retain_freed_memory();
        let model = demo::paper_bench(self.seed);
        let samples = (self.hours * 3600.0 * BENCH_RATE_HZ).round() as u64;
        let started = Instant::now();
        let bar = Progress::new(samples, "bench");
        // The firmware's pipeline: S = 8 accumulators on the ADC codes, a snapshot round every 10 minutes of
        // samples (the field-log interval; the device sends one every second), frames, a capture, the host decoder.
        let every = (600.0 * BENCH_RATE_HZ) as u64;
        let decimate = (demo::GAP_BLOCK_S * BENCH_RATE_HZ) as u64;
        let runs = demo::accumulate_bench(&model, samples, every, decimate, &|n| bar.set(n))?;
        let rounds: Vec<_> = runs.iter().map(|r| r.snapshots.clone()).collect();
        let capture = demo::snapshot_capture(&rounds);
        let capture_path = self.out.join("demo.capture");
        std::fs::write(&capture_path, &capture).with_context(|| format!("writing {}", capture_path.display()))?;
        let snaps = demo::last_snapshots(&capture, rounds.len()).map_err(anyhow::Error::msg)?;
        bar.finish();
        let results = demo::analyse(&snaps, &model);
        let rows = demo::table1(&results);
        let elapsed = started.elapsed().as_secs_f64();

        let mut out = std::io::stdout().lock();
        writeln!(
            out,
            "octavar demo: {:.1} h at {} Hz, 4 channels, {} samples per channel, {:.1} s\n",
            self.hours, BENCH_RATE_HZ, samples, elapsed
        )?;
        table1_text(&mut out, &results)?;
        self.write_bench_files(&results, &rows)?;
        writeln!(out, "\nwrote {}/table1.json, adev.csv, figure5.png and figure5.svg", self.out.display())?;
        out.flush()?;
        drop(out);

        // The sim-to-real gap of each channel: its 1 Hz record and the bench temperature, later half held out.
        let mut out = std::io::stdout().lock();
        self.gap_diagnoses(&mut out, &runs, &results)?;
        writeln!(out, "\nwrote gap_<channel>.json, .txt and .png; total {:.1} s", started.elapsed().as_secs_f64())?;
        Ok(ExitCode::SUCCESS)
    }

    /// Table 1's JSON, the ADEV points as CSV and Figure 5 (PNG and SVG) in the output folder.
    fn write_bench_files(&self, results: &[demo::ChannelResult], rows: &[demo::Table1Row]) -> anyhow::Result<()> {
        let path = self.out.join("table1.json");
        std::fs::write(&path, serde_json::to_string_pretty(&rows)?)
            .with_context(|| format!("writing {}", path.display()))?;
        let path = self.out.join("adev.csv");
        let csv = octavar::analyze::points_csv(
            results.iter().map(|r| (r.paper.label, octavar::stats::Statistic::Oadev, &r.points[..])),
        );
        std::fs::write(&path, csv).with_context(|| format!("writing {}", path.display()))?;
        let series: Vec<plot::AdevSeries> = results
            .iter()
            .map(|r| plot::AdevSeries {
                name: r.paper.label.to_string(),
                points: r.points.clone(),
                fit: Some(r.fit.clone()),
                quantity: Default::default(),
            })
            .collect();
        let opts = plot::PlotOptions {
            title: format!(
                "Allan deviation of the four gyros, {} h at {} kS/s (the paper's Figure 5)",
                self.hours,
                BENCH_RATE_HZ / 1000.0
            ),
            ..Default::default()
        };
        for name in ["figure5.png", "figure5.svg"] {
            plot::adev_plot(&series, &opts, &self.out.join(name))?;
        }
        Ok(())
    }

    /// Each channel's gap diagnosis (run at once, each with its bar): a line of the summary table, and its JSON,
    /// text and figure in the output folder.
    fn gap_diagnoses(
        &self,
        out: &mut impl Write,
        runs: &[demo::ChannelRun],
        results: &[demo::ChannelResult],
    ) -> anyhow::Result<()> {
        writeln!(
            out,
            "\nSim-to-real gap (the IEEE model alone vs the bench; 1 Hz block means, the later half held out)"
        )?;
        writeln!(
            out,
            "{:<10} {:>13} {:>12} {:>22} {:>24} {:>10}",
            "channel", "effect", "view", "band (s)", "held-out gap -> after", "shrink"
        )?;
        // The four diagnoses run at once, each with its bar.
        let group = indicatif::MultiProgress::new();
        let bars: Vec<Progress> =
            results.iter().map(|r| Progress::in_group(&group, 1, &format!("gap {}", r.paper.label))).collect();
        let reports = demo::diagnose_channels(runs, &|i, done, total| {
            bars[i].set_length(total as u64);
            bars[i].set(done as u64);
        });
        bars.iter().for_each(Progress::finish);
        for ((report, r), run) in reports.into_iter().zip(results).zip(runs) {
            let report = report?;
            let slug: String = r
                .paper
                .label
                .chars()
                .map(|c| if c.is_ascii_alphanumeric() { c.to_ascii_lowercase() } else { '_' })
                .collect();
            let path = self.out.join(format!("gap_{slug}.json"));
            std::fs::write(&path, serde_json::to_string_pretty(&report.to_json())?)
                .with_context(|| format!("writing {}", path.display()))?;
            let title = format!("Sim-to-real gap: {} ({})", r.paper.label, super::gap::effects_text(&report));
            let figure = plot::GapFigure::new(&report, &demo::gap_input(run));
            plot::gap_plot(&figure, &plot::PlotOptions::gap_figure(title), &self.out.join(format!("gap_{slug}.png")))?;
            let path = self.out.join(format!("gap_{slug}.txt"));
            std::fs::write(&path, report.text()).with_context(|| format!("writing {}", path.display()))?;
            let loc = report.base.location.as_ref();
            let band = loc.map_or("-".to_string(), |l| format!("{:.3e}..{:.3e}", l.band_s[0], l.band_s[1]));
            let h = report.holdout.first.unwrap_or(octavar::gap::PartGap::new(f64::NAN, f64::NAN));
            writeln!(
                out,
                "{:<10} {:>13} {:>12} {:>22} {:>11.2} -> {:>9.2} {:>9.1}%",
                r.paper.label,
                report.effect_name(),
                loc.map_or("-", |l| l.view.name()),
                band,
                h.gap_before,
                h.gap_after,
                100.0 * h.shrink
            )?;
        }
        Ok(())
    }
}

/// Table 1: the recovered N and B with their 95% intervals beside the paper's.
fn table1_text(out: &mut impl Write, results: &[demo::ChannelResult]) -> anyhow::Result<()> {
    writeln!(out, "Table 1: recovered (95% interval) beside the paper")?;
    writeln!(out, "{:<10} {:>34} {:>12} {:>30} {:>12}", "channel", "N deg/sqrt(s)", "paper N", "B deg/s", "paper B")?;
    for r in results {
        let show = |t: Term| {
            let e = r.fit.term(t);
            match (e.value, e.lo, e.hi) {
                (Some(v), Some(lo), Some(hi)) => format!("{v:.3e} ({lo:.2e}..{hi:.2e})"),
                _ => "not identifiable".to_string(),
            }
        };
        writeln!(
            out,
            "{:<10} {:>34} {:>12.2e} {:>30} {:>12.2e}",
            r.paper.label,
            show(Term::N),
            r.paper.paper_n,
            show(Term::B),
            r.paper.paper_b
        )?;
    }
    Ok(())
}

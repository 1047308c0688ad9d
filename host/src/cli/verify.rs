//! `octavar verify`: replay a capture's raw samples and check every device snapshot.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use octavar::board::verify::{verify_path, VerifyReport};

/// Replay the raw samples of a capture through the exact accumulator (the stride of the device's hello) and
/// compare every snapshot the device sent, bit for bit (n and the sum of squares of every level, the sample
/// count). Snapshots the raw samples do not cover are reported as not checked, with the reason. Exit 0 only when
/// at least one snapshot was checked and all checked snapshots match; 1 otherwise.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The capture file (recorded with `octavar record --raw`); - is stdin.
    pub capture: PathBuf,
    /// Print the report as JSON (every mismatch with channel, level, expected and got).
    #[arg(long)]
    pub json: bool,
}

/// Mismatches printed in the text report (the JSON has them all).
const PRINTED: usize = 20;

impl Args {
    pub fn run(self) -> anyhow::Result<ExitCode> {
        let report = verify_path(&self.capture)?;
        let mut out = std::io::stdout().lock();
        if self.json {
            serde_json::to_writer_pretty(&mut out, &report)?;
            writeln!(out)?;
        } else {
            print_report(&mut out, &report)?;
        }
        out.flush()?;
        Ok(if report.passed() { ExitCode::SUCCESS } else { ExitCode::from(1) })
    }
}

fn print_report(out: &mut dyn Write, r: &VerifyReport) -> std::io::Result<()> {
    let d = &r.decode;
    writeln!(
        out,
        "{}: {} frames ({} lost, {} CRC errors, {} other bad), stride {}",
        r.source,
        d.frames,
        d.lost_frames,
        d.crc_errors,
        d.bad_frame_count() - d.crc_errors,
        r.stride.map_or("unknown (no hello)".to_string(), |s| s.to_string())
    )?;
    writeln!(
        out,
        "snapshots: {} received, {} checked, {} match, {} differ, {} not checked",
        r.snapshots, r.checked, r.matched, r.mismatched_snapshots, r.unchecked
    )?;
    writeln!(
        out,
        "{:>8} {:<16} {:>12} {:>10} {:>8} {:>8} {:>12}",
        "channel", "name", "raw samples", "snapshots", "checked", "match", "not checked"
    )?;
    for c in &r.channels {
        writeln!(
            out,
            "{:>8} {:<16} {:>12} {:>10} {:>8} {:>8} {:>12}",
            c.channel,
            c.name.as_deref().unwrap_or("-"),
            c.raw_samples,
            c.snapshots,
            c.checked,
            c.matched,
            c.unchecked
        )?;
    }
    if !r.device_gaps.is_empty() || r.status_samples_lost.is_some_and(|n| n > 0) {
        writeln!(
            out,
            "device gaps: {} ({} samples lost{}), pooled across as the device does",
            r.device_gaps.len(),
            r.device_samples_lost,
            r.status_samples_lost.map_or(String::new(), |n| format!("; its last status says {n} this session"))
        )?;
        for g in r.device_gaps.iter().take(20) {
            writeln!(out, "  {} samples lost at raw sample {}", g.lost, g.at_sample)?;
        }
    }
    for g in &r.unchecked_why {
        writeln!(
            out,
            "not checked: channel {}, {} snapshot(s) from frame {} (byte {}): {}",
            g.channel, g.count, g.first_seq, g.first_offset, g.reason
        )?;
    }
    for m in r.mismatches.iter().take(PRINTED) {
        writeln!(out, "MISMATCH {m}")?;
    }
    if r.mismatch_count > PRINTED as u64 {
        writeln!(out, "... {} differing values in all (--json lists them)", r.mismatch_count)?;
    }
    let verdict = if r.passed() {
        format!("OK: all {} checked snapshots match the replay bit for bit", r.checked)
    } else if r.checked == 0 {
        "FAILED: no snapshot could be checked (see why above; `octavar record --raw` streams the raw samples)"
            .to_string()
    } else {
        format!("FAILED: {} of {} checked snapshots differ from the replay", r.mismatched_snapshots, r.checked)
    };
    writeln!(out, "{verdict}")
}

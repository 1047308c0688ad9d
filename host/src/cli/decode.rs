//! `octavar decode`: a capture to a summary, CSV files and JSON.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use octavar::io::decode::{self, DecodeSummary, ExportOptions};

/// Decode a capture file (the bytes `octavar record` wrote): print a summary (frames, lost frames, CRC errors,
/// the last snapshot of each channel), and optionally write CSV files and a JSON summary. Damaged frames are
/// counted and located (byte offset), never fatal. Exit 0 when at least one intact frame was found, 1 when none.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The capture file; - is stdin.
    pub capture: PathBuf,
    /// Write samples.csv (sample,<channel names...>, codes), snapshots.csv (frame_seq,channel,samples,level,m,
    /// tau_s,n,sum_sq,avar_codes2,adev_codes), status.csv, estimates.csv and fieldlog.csv into this directory.
    #[arg(long, value_name = "DIR")]
    pub csv: Option<PathBuf>,
    /// Write the JSON summary (hello, counts, the last snapshot per channel, statuses, estimates) here; - is
    /// stdout (then no text summary is printed).
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
}

impl Args {
    pub fn run(self) -> anyhow::Result<ExitCode> {
        let reader = decode::open(&self.capture)?;
        let summary = decode::export(reader, &ExportOptions { csv_dir: self.csv.clone() })?;
        let mut out = std::io::stdout().lock();
        let json_to_stdout = super::json_out::to_stdout(self.json.as_deref());
        if let Some(path) = &self.json {
            super::json_out::write(path, &summary, &mut out)?;
        }
        if !json_to_stdout {
            print_summary(&mut out, &summary)?;
        }
        out.flush()?;
        if summary.stats.frames == 0 {
            eprintln!(
                "octavar: no intact frame in {} ({} bytes, {} in damaged frames): not an octavar capture?",
                summary.source, summary.stats.bytes, summary.stats.bytes_dropped
            );
            return Ok(ExitCode::from(1));
        }
        Ok(ExitCode::SUCCESS)
    }
}

fn print_summary(out: &mut dyn Write, s: &DecodeSummary) -> std::io::Result<()> {
    let st = &s.stats;
    writeln!(out, "{}: {} bytes, {} frames", s.source, st.bytes, st.frames)?;
    writeln!(
        out,
        "  lost frames {}, CRC errors {}, other bad frames {}, bytes dropped {}, truncated tail {} bytes, device restarts {}",
        st.lost_frames,
        st.crc_errors,
        st.bad_frame_count() - st.crc_errors,
        st.bytes_dropped,
        st.truncated_tail,
        st.restarts
    )?;
    for b in st.bad_frames.iter().take(5) {
        writeln!(out, "  bad frame at byte {} ({} bytes): {}", b.offset, b.len, b.reason.describe())?;
    }
    if st.bad_frames.len() > 5 {
        writeln!(
            out,
            "  ... {} bad frames in all (the JSON lists the first {})",
            st.bad_frame_count(),
            st.bad_frames.len()
        )?;
    }
    writeln!(
        out,
        "  hello {}, samples frames {} ({} sets), snapshots {} ({} incomplete), status {}, estimates {}, field log {}",
        st.hellos,
        st.samples_frames,
        st.sample_sets,
        st.snapshots,
        st.incomplete_snapshots,
        st.statuses,
        st.estimates,
        st.field_log_snapshots
    )?;
    if let Some(v) = st.unknown_protocol {
        writeln!(
            out,
            "  warning: protocol version {v} (this octavar knows {})",
            octavar_shared::proto::PROTOCOL_VERSION
        )?;
    }
    if let Some(h) = &s.hello {
        writeln!(
            out,
            "device: {} firmware {}, {} Hz, {}-bit ADC at {} mV, stride {}, {} channels",
            h.board,
            h.firmware,
            h.rate_hz,
            h.adc_bits,
            h.vref_mv,
            h.stride,
            h.channels.len()
        )?;
    }
    for snap in &s.snapshots {
        let name = snap.name.clone().unwrap_or_else(|| format!("channel {}", snap.channel));
        writeln!(
            out,
            "  {name}: last snapshot at {} samples, {} levels, ADEV(1 s) {}",
            snap.samples,
            snap.levels.len(),
            snap.adev_1s_codes.map_or("n/a".to_string(), |a| format!("{a:.4e} codes"))
        )?;
    }
    if let Some(cp) = &s.field_log_checkpoint {
        writeln!(
            out,
            "field log: checkpoint {}, {} session(s), {} s, {} samples per channel, {} sample loss(es)",
            cp.checkpoint, cp.sessions, cp.time_s, cp.samples, cp.adc_overruns
        )?;
        for e in &cp.estimates {
            let name = e.name.clone().unwrap_or_else(|| format!("channel {}", e.channel));
            let n = e.n_dps_per_rt_s.map_or("n/a".into(), |n| format!("{:.3e} deg/sqrt(s)", n));
            let b = match (e.b_dps, e.tau_b_s) {
                (Some(b), Some(t)) => format!("{b:.3e} deg/s at {t:.3} s"),
                (Some(b), None) => format!("{b:.3e} deg/s"),
                _ => "n/a".into(),
            };
            writeln!(out, "  {name}: onboard estimate N {n}, B {b}")?;
        }
    }
    if let Some(last) = s.statuses.last() {
        let t = &last.status;
        writeln!(
            out,
            "  last status: uptime {:.1} s, {} samples per channel, ADC overruns {}, frames dropped on the device {}{}{}",
            t.uptime_ms as f64 / 1000.0,
            t.samples_per_channel,
            t.adc_overruns,
            t.frames_dropped,
            t.temperature_c.map(|c| format!(", {c:.1} degC")).unwrap_or_default(),
            t.stack_peak_bytes.map(|b| format!(", stack peak {b} bytes")).unwrap_or_default()
        )?;
    }
    for f in &s.csv_files {
        writeln!(out, "  wrote {}", f.display())?;
    }
    Ok(())
}

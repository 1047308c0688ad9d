//! Bringing up a board: the firmware README's bring-up list as checks against a live device, each with a pass or
//! fail and the figures behind it.
//!
//! Over one port ([`super::link::Source`]: a serial port, or `tcp:HOST:PORT` for QEMU), in order:
//! - **hello**: the device introduces itself (protocol version, firmware, board, channels) and, on a USB port,
//!   its serial number (the chip's unique ID);
//! - **clock**: the device's sample clock against the host's over the run, in ppm (a line fitted to every raw
//!   frame's last scan against its arrival time);
//! - **gaps**: no jump in the raw sample index and no scan lost over the run;
//! - **counters**: no new ADC overrun, dropped frame or lost scan; the stack's high-water mark;
//! - **checkpoint**: a field-log checkpoint forced now (`Command::Checkpoint`): written, its measured stalls,
//!   and no scan lost to them;
//! - **reconnect**: the port closed and opened again (a DTR drop on USB): on a serial port the hello comes first,
//!   and sampling went on (the sample count kept growing);
//! - **reset**: `Command::Reset` acknowledged, and the sample count restarted.
//!
//! A check the link cannot answer (a hello first after a TCP reconnect, which has no DTR) is marked skipped with
//! the reason, never passed.

use std::io;
use std::time::{Duration, Instant};

use octavar_shared::proto::{CheckpointReport, Command, Encoder, Hello, Status, PROTOCOL_VERSION};
use serde::Serialize;

use super::link::{Link, ReadOutcome, Source};
use crate::io::decode::{Decoded, Message, StreamDecoder};

/// How [`bringup`] runs.
#[derive(Clone, Debug)]
pub struct BringupOptions {
    /// How long the clock, gap and counter checks watch the raw stream.
    pub duration: Duration,
    /// The clock check passes within this many ppm of the host's clock.
    pub clock_ppm_limit: f64,
    /// How long to wait for each answer (the hello, an acknowledgement, a report).
    pub answer_within: Duration,
    /// A USB serial number to report (from the port's descriptor), where the link has one.
    pub serial_number: Option<String>,
    /// Whether the link drops like USB's DTR (a hello must come first after a reconnect).
    pub hello_on_connect: bool,
}

impl Default for BringupOptions {
    fn default() -> Self {
        BringupOptions {
            duration: Duration::from_secs(30),
            clock_ppm_limit: 1000.0,
            answer_within: Duration::from_secs(5),
            serial_number: None,
            hello_on_connect: true,
        }
    }
}

/// A check's outcome.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    /// It held.
    Pass,
    /// It did not.
    Fail,
    /// The link cannot answer it (the reason is in the detail).
    Skipped,
}

/// One check.
#[derive(Clone, Debug, Serialize)]
pub struct CheckResult {
    /// Its name: hello, clock, gaps, counters, checkpoint, reconnect, reset.
    pub name: &'static str,
    /// Pass, fail or skipped.
    pub outcome: Outcome,
    /// What was seen.
    pub detail: String,
}

/// Everything [`bringup`] saw.
#[derive(Clone, Debug, Serialize)]
pub struct BringupReport {
    /// The port.
    pub port: String,
    /// The hello.
    pub hello: Option<Hello>,
    /// The USB serial number, where the port has one.
    pub serial_number: Option<String>,
    /// The device clock's offset from the host's, ppm (positive: the device runs fast).
    pub clock_ppm: Option<f64>,
    /// Raw frames the clock fit used.
    pub clock_frames: usize,
    /// Jumps in the raw sample index over the run.
    pub raw_gaps: u64,
    /// The first and last status of the run.
    pub status_first: Option<Status>,
    /// The last status of the run.
    pub status_last: Option<Status>,
    /// The forced checkpoint's report.
    pub checkpoint: Option<CheckpointReport>,
    /// Each check, in order.
    pub checks: Vec<CheckResult>,
    /// Every check passed or was skipped.
    pub passed: bool,
}

/// What went wrong before any check could run.
#[derive(Debug, thiserror::Error)]
pub enum BringupError {
    /// The port could not be opened.
    #[error("cannot open {name}: {source}")]
    Connect {
        /// The port.
        name: String,
        /// The I/O error.
        source: io::Error,
    },
}

/// One connection: the link, its decoder, the commands' numbering.
struct Session<L> {
    link: L,
    dec: StreamDecoder,
    enc: Encoder,
    buf: Vec<u8>,
}

impl<L: Link> Session<L> {
    fn new(link: L) -> Self {
        Session { link, dec: StreamDecoder::new(), enc: Encoder::new(), buf: vec![0; 1 << 14] }
    }

    /// Send a command; returns its sequence number.
    fn send(&mut self, cmd: Command) -> io::Result<u32> {
        let seq = self.enc.next_seq();
        let frame =
            self.enc.encode_to_vec(&cmd).map_err(|e| io::Error::new(io::ErrorKind::InvalidData, e.to_string()))?;
        self.link.write_all(&frame)?;
        Ok(seq)
    }

    /// Read until `until`, or until `f` (given each record and the time its bytes arrived) says done; returns
    /// whether it did.
    fn pump(&mut self, until: Instant, f: &mut dyn FnMut(&Decoded, Instant) -> bool) -> io::Result<bool> {
        loop {
            if Instant::now() >= until {
                return Ok(false);
            }
            match self.link.read(&mut self.buf)? {
                ReadOutcome::Data(n) => {
                    let at = Instant::now();
                    let mut done = false;
                    self.dec.feed(&self.buf[..n], &mut |d| done |= f(&d, at));
                    if done {
                        return Ok(true);
                    }
                }
                ReadOutcome::Idle => {}
                ReadOutcome::End => return Err(io::ErrorKind::UnexpectedEof.into()),
            }
        }
    }
}

fn check(name: &'static str, pass: bool, detail: String) -> CheckResult {
    CheckResult { name, outcome: if pass { Outcome::Pass } else { Outcome::Fail }, detail }
}

/// Run the bring-up checks on the device at `source`.
///
/// # Errors
/// [`BringupError::Connect`] when the port cannot be opened; every later failure is a failed check.
pub fn bringup<S: Source>(source: &mut S, opts: &BringupOptions) -> Result<BringupReport, BringupError> {
    let name = source.name();
    let link = source.connect().map_err(|e| BringupError::Connect { name: name.clone(), source: e })?;
    let mut s = Session::new(link);
    let mut report = BringupReport {
        port: name,
        hello: None,
        serial_number: opts.serial_number.clone(),
        clock_ppm: None,
        clock_frames: 0,
        raw_gaps: 0,
        status_first: None,
        status_last: None,
        checkpoint: None,
        checks: Vec::new(),
        passed: false,
    };
    let hello = hello_check(&mut s, opts, &mut report);
    report.checks.push(hello);
    let run = watch_run(&mut s, opts, &mut report);
    report.checks.extend(run);
    let checkpoint = checkpoint_check(&mut s, opts, &mut report);
    report.checks.push(checkpoint);
    let (reconnect, session) = reconnect_check(s, source, opts);
    report.checks.push(reconnect);
    match session {
        Some(mut s) => {
            report.checks.push(reset_check(&mut s, opts));
            let _ = s.send(Command::StopRaw);
        }
        None => report.checks.push(check("reset", false, "no connection after the reconnect".into())),
    }
    report.passed = report.checks.iter().all(|c| c.outcome != Outcome::Fail);
    Ok(report)
}

/// Ask for a hello and raw streaming; the hello's protocol version must be this host's.
fn hello_check<L: Link>(s: &mut Session<L>, opts: &BringupOptions, report: &mut BringupReport) -> CheckResult {
    if let Err(e) = s.send(Command::Hello).and_then(|_| s.send(Command::StartRaw { channel_mask: 0xff })) {
        return check("hello", false, format!("sending the hello request: {e}"));
    }
    let mut hello = None;
    let got = s.pump(Instant::now() + opts.answer_within, &mut |d, _| match &d.message {
        Message::Hello(h) => {
            hello = Some(h.clone());
            true
        }
        _ => false,
    });
    let Some(h) = hello else {
        let why = got.err().map_or("none within the wait".to_string(), |e| e.to_string());
        return check("hello", false, format!("no hello: {why}"));
    };
    let serial = report.serial_number.as_deref().unwrap_or("none on this link");
    let detail = format!(
        "protocol {}, firmware {}, board {}, {} Hz, {} channels, serial number {serial}",
        h.protocol_version,
        h.firmware,
        h.board,
        h.rate_hz,
        h.channels.len()
    );
    let pass = h.protocol_version == PROTOCOL_VERSION && h.rate_hz > 0;
    let detail = if pass { detail } else { format!("{detail}; this host speaks protocol {PROTOCOL_VERSION}") };
    report.hello = Some(h);
    check("hello", pass, detail)
}

/// Watch the raw stream and the statuses for the run: the clock, the gaps and the counters.
fn watch_run<L: Link>(s: &mut Session<L>, opts: &BringupOptions, report: &mut BringupReport) -> Vec<CheckResult> {
    let rate = report.hello.as_ref().map_or(0.0, |h| f64::from(h.rate_hz));
    let t0 = Instant::now();
    let mut points: Vec<(f64, f64)> = Vec::new();
    let mut next: Option<u64> = None;
    let (mut gaps, mut first, mut last) = (0u64, None::<Status>, None::<Status>);
    let ended = s.pump(t0 + opts.duration, &mut |d, at| {
        match &d.message {
            Message::Samples(sm) => {
                if next.is_some_and(|n| n != sm.first_sample) {
                    gaps += 1;
                }
                let end = sm.first_sample + sm.sets() as u64;
                next = Some(end);
                if rate > 0.0 {
                    points.push(((at - t0).as_secs_f64(), end as f64 / rate));
                }
            }
            Message::Status(st) => {
                if first.is_none() {
                    first = Some(st.clone());
                }
                last = Some(st.clone());
            }
            _ => {}
        }
        false
    });
    report.raw_gaps = gaps;
    report.clock_frames = points.len();
    report.clock_ppm = clock_ppm(&points);
    report.status_first = first.clone();
    report.status_last = last.clone();
    let lost_link = ended.err().map(|e| format!(" (the link failed: {e})")).unwrap_or_default();
    let clock = match report.clock_ppm {
        Some(ppm) => check(
            "clock",
            ppm.abs() <= opts.clock_ppm_limit,
            format!("{ppm:+.0} ppm against the host over {} raw frames (limit {})", points.len(), opts.clock_ppm_limit),
        ),
        None => check("clock", false, format!("too few raw frames ({}) to time the clock{lost_link}", points.len())),
    };
    let (f, l) = match (first, last) {
        (Some(f), Some(l)) => (f, l),
        _ => {
            let none = format!("no status frames over the run{lost_link}");
            return vec![clock, check("gaps", false, none.clone()), check("counters", false, none)];
        }
    };
    let lost = l.samples_lost.saturating_sub(f.samples_lost);
    let gaps_check = check(
        "gaps",
        gaps == 0 && lost == 0 && !points.is_empty(),
        format!(
            "{gaps} jumps in the raw index, {lost} scans lost over {:.1} s{lost_link}",
            opts.duration.as_secs_f64()
        ),
    );
    let overruns = l.adc_overruns.saturating_sub(f.adc_overruns);
    let dropped = l.frames_dropped.saturating_sub(f.frames_dropped);
    let stack = l.stack_peak_bytes.map_or("not measured".to_string(), |b| format!("{b} bytes"));
    let counters = check(
        "counters",
        overruns == 0 && dropped == 0 && lost == 0,
        format!(
            "over the run: {overruns} ADC overruns, {dropped} frames dropped, {lost} scans lost (since boot: {}, {}, \
             {}); stack high-water {stack}",
            l.adc_overruns, l.frames_dropped, l.samples_lost
        ),
    );
    vec![clock, gaps_check, counters]
}

/// The device clock's rate against the host's, ppm off 1, from (arrival time, device time) pairs.
///
/// A frame arrives no earlier than the device sent it, and late by however long the link, the host and any
/// flash stall held it; so the earliest arrivals carry the clock. The run is cut into [`CLOCK_WINDOWS`] windows
/// of device time, and a line is fitted through each window's earliest arrival (its smallest arrival less
/// device time): the clock is that line's slope.
fn clock_ppm(points: &[(f64, f64)]) -> Option<f64> {
    if points.len() < 4 * CLOCK_WINDOWS {
        return None;
    }
    let (t0, t1) = (points.first()?.1, points.last()?.1);
    let span = t1 - t0;
    if span <= 0.0 {
        return None;
    }
    let mut lowest: Vec<Option<(f64, f64)>> = vec![None; CLOCK_WINDOWS];
    for &(arrival, device) in points {
        let w = (((device - t0) / span * CLOCK_WINDOWS as f64) as usize).min(CLOCK_WINDOWS - 1);
        let offset = arrival - device;
        if lowest[w].is_none_or(|(_, o)| offset < o) {
            lowest[w] = Some((device, offset));
        }
    }
    let pts: Vec<(f64, f64)> = lowest.into_iter().flatten().collect();
    let n = pts.len() as f64;
    let (mx, my) = pts.iter().fold((0.0, 0.0), |(a, b), (x, y)| (a + x / n, b + y / n));
    let (sxy, sxx) = pts.iter().fold((0.0, 0.0), |(a, b), (x, y)| (a + (x - mx) * (y - my), b + (x - mx).powi(2)));
    // Arrival less device time falls by ppm * 1e-6 per second when the device runs fast.
    (sxx > 0.0 && pts.len() >= 3).then(|| -sxy / sxx * 1e6)
}

/// Windows of the run in which the clock fit takes the earliest arrival.
const CLOCK_WINDOWS: usize = 8;

/// Force a checkpoint and read its report.
fn checkpoint_check<L: Link>(s: &mut Session<L>, opts: &BringupOptions, report: &mut BringupReport) -> CheckResult {
    let seq = match s.send(Command::Checkpoint) {
        Ok(seq) => seq,
        Err(e) => return check("checkpoint", false, format!("sending the request: {e}")),
    };
    let mut got = None;
    // Written at the next snapshot round (each second), then the sampler settles.
    let _ = s.pump(Instant::now() + opts.answer_within + Duration::from_secs(2), &mut |d, _| match &d.message {
        Message::CheckpointReport(r) if r.seq == seq => {
            got = Some(*r);
            true
        }
        _ => false,
    });
    let Some(r) = got else {
        return check("checkpoint", false, "no report of the checkpoint (a firmware before protocol 4?)".into());
    };
    report.checkpoint = Some(r);
    let erase = if r.erase_us > 0 {
        format!(", then an erase of {:.1} ms", f64::from(r.erase_us) / 1e3)
    } else {
        String::new()
    };
    let detail = format!(
        "checkpoint {} programmed in {:.1} ms{erase}; {} scans lost{}",
        r.checkpoint,
        f64::from(r.program_us) / 1e3,
        r.samples_lost,
        if r.flash_error != 0 { format!("; flash error flags {:#x}", r.flash_error) } else { String::new() }
    );
    check("checkpoint", r.checkpoint > 0 && r.flash_error == 0 && r.samples_lost == 0, detail)
}

/// Close the link and open it again: frames resume and the sample count went on.
fn reconnect_check<S: Source>(
    s: Session<S::Link>,
    source: &mut S,
    opts: &BringupOptions,
) -> (CheckResult, Option<Session<S::Link>>) {
    let before = Instant::now();
    drop(s);
    std::thread::sleep(Duration::from_millis(300));
    let link = match source.connect() {
        Ok(l) => l,
        Err(e) => return (check("reconnect", false, format!("reopening the port: {e}")), None),
    };
    let mut s = Session::new(link);
    let (mut first_is_hello, mut first_seen, mut status) = (false, false, None::<Status>);
    let _ = s.pump(Instant::now() + opts.answer_within, &mut |d, _| {
        if !first_seen {
            first_seen = true;
            first_is_hello = matches!(d.message, Message::Hello(_));
        }
        if let Message::Status(st) = &d.message {
            status = Some(st.clone());
            return true;
        }
        false
    });
    let Some(st) = status else {
        return (check("reconnect", false, "no status frame after reopening the port".into()), Some(s));
    };
    let away = before.elapsed().as_secs_f64();
    if opts.hello_on_connect && !first_is_hello {
        let detail = "the first frame after reopening the port was not a hello".to_string();
        return (check("reconnect", false, detail), Some(s));
    }
    let hello = if opts.hello_on_connect { "a hello first, " } else { "" };
    let detail =
        format!("{hello}sampling went on: {} samples per channel after {away:.1} s away", st.samples_per_channel);
    let mut result = check("reconnect", st.samples_per_channel > 0, detail);
    if !opts.hello_on_connect && result.outcome == Outcome::Pass {
        result.detail.push_str(" (no DTR on this link: the hello-first part is not checked)");
    }
    (result, Some(s))
}

/// `Command::Reset`: acknowledged, and the next status counts from the start again.
fn reset_check<L: Link>(s: &mut Session<L>, opts: &BringupOptions) -> CheckResult {
    let mut before = None::<u64>;
    let _ = s.pump(Instant::now() + opts.answer_within, &mut |d, _| match &d.message {
        Message::Status(st) => {
            before = Some(st.samples_per_channel);
            true
        }
        _ => false,
    });
    let seq = match s.send(Command::Reset) {
        Ok(seq) => seq,
        Err(e) => return check("reset", false, format!("sending the reset: {e}")),
    };
    let (mut acked, mut after) = (false, None::<u64>);
    let _ = s.pump(Instant::now() + opts.answer_within, &mut |d, _| {
        match &d.message {
            Message::Ack(a) if a.seq == seq => acked = true,
            Message::Status(st) if acked => after = Some(st.samples_per_channel),
            _ => {}
        }
        after.is_some()
    });
    match (acked, before, after) {
        (true, Some(b), Some(a)) => {
            check("reset", a < b, format!("acknowledged; samples per channel {b} before, {a} after"))
        }
        (true, _, _) => check("reset", false, "acknowledged, but no status frame around it".into()),
        _ => check("reset", false, "not acknowledged".into()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_clock_fit_reads_a_known_rate_offset_through_late_bursts() {
        // A device 250 ppm fast over 4 s; its frames arrive a few ms late, and those after each of three 0.5 s
        // flash stalls come in a burst when it ends.
        let pts: Vec<(f64, f64)> = (0..250)
            .map(|i| {
                let device = i as f64 * 0.016;
                let sent = device / 1.000_25;
                let held = [0.6, 1.9, 3.1]
                    .iter()
                    .map(|s| if sent > *s && sent < s + 0.5 { s + 0.5 - sent } else { 0.0 })
                    .sum::<f64>();
                (sent + held + [0.002, 0.005, 0.003, 0.009][i % 4], device)
            })
            .collect();
        let ppm = clock_ppm(&pts).unwrap();
        assert!((ppm - 250.0).abs() < 50.0, "{ppm}");
        assert!(clock_ppm(&pts[..5]).is_none(), "too few frames");
    }
}

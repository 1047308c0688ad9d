//! The streamed analysis: raw binary samples, CSV and device captures read in pieces and fed to the bounded-memory
//! OADEV engine ([`crate::stats::stream_oadev::StreamOadev`]), then fitted like the in-memory path, so a record of any
//! length is analysed in constant memory.
//!
//! # Inputs
//! [`BinaryFormat`] reads raw little-endian samples (f64, f32, i16, u16; one channel or interleaved);
//! [`analyze_capture`] reads a capture's raw samples (or, without raw samples, its device snapshots); and
//! [`analyze_csv`] streams a CSV through [`crate::io::csv::read_csv_stream`].

use std::io::{BufRead, Read};

use crate::analyze::{ChannelAnalysis, Counts};
use crate::fit::FitOptions;
use crate::io::binary::BinaryFormat;
use crate::io::csv::{CsvOptions, RecordingError};
use crate::io::decode::{CaptureReader, DecodeError, Message};
use crate::stats::stream_oadev::{StreamOadev, StreamTotals, DEFAULT_STRIDE};
use crate::stats::{DevPoint, Statistic, StatsError};

/// What went wrong.
#[derive(Debug, thiserror::Error)]
pub enum StreamError {
    /// Reading failed.
    #[error("reading {name}: {source}")]
    Io {
        /// The input.
        name: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A binary input that is not a whole number of sample sets.
    #[error("{name}: {bytes} bytes is not a whole number of {channels}-channel {format} sample sets ({set} bytes each): {rest} bytes left over at the end")]
    Truncated {
        /// The input.
        name: String,
        /// Its length.
        bytes: u64,
        /// Channels per set.
        channels: usize,
        /// The format's name.
        format: &'static str,
        /// Bytes per set.
        set: usize,
        /// Bytes after the last whole set.
        rest: usize,
    },
    /// No sample at all.
    #[error("{name}: no samples")]
    Empty {
        /// The input.
        name: String,
    },
    /// The engine refused its settings (a stride that is not a power of two from 1 to 2^16).
    #[error(transparent)]
    Stats(#[from] StatsError),
    /// A sample rate that is not positive and finite.
    #[error("sample rate {0} Hz: must be positive and finite")]
    BadRate(f64),
    /// Too few samples for any tau.
    #[error("{name}: channel {channel}: {samples} samples are too few for an Allan deviation (need at least 8)")]
    TooShort {
        /// The input.
        name: String,
        /// The channel.
        channel: String,
        /// Samples seen.
        samples: u64,
    },
    /// A capture that could not be decoded.
    #[error(transparent)]
    Decode(#[from] DecodeError),
    /// A capture without a hello (no sample rate) or without samples and snapshots.
    #[error("{name}: {what}")]
    Capture {
        /// The capture.
        name: String,
        /// What is missing.
        what: String,
    },
    /// A CSV that could not be read.
    #[error(transparent)]
    Csv(#[from] RecordingError),
}

/// Options of the streamed analysis.
#[derive(Clone, Debug)]
pub struct StreamOptions {
    /// Sample rate, Hz (a capture's hello overrides it).
    pub rate_hz: f64,
    /// Stride S.
    pub stride: usize,
    /// Confidence of the intervals.
    pub confidence: f64,
    /// Multiply samples by this (a unit conversion to deg/s; a capture uses each channel's deg/s per code).
    pub scale: f64,
    /// The noise-term fit; `None` skips it.
    pub fit: Option<FitOptions>,
    /// Which of a capture's data to analyse.
    pub capture_data: CaptureData,
}

/// Which of a capture's data [`analyze_capture`] analyses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CaptureData {
    /// The newest whole field-log checkpoint if the capture holds one (a read-out of the log: the whole logged
    /// deployment), else the raw samples, else the device's snapshots.
    #[default]
    Auto,
    /// The newest whole field-log checkpoint.
    FieldLog,
    /// The raw samples.
    Raw,
    /// The device's accumulator snapshots (the last of each session, pooled).
    Snapshots,
}

impl Default for StreamOptions {
    fn default() -> Self {
        StreamOptions {
            rate_hz: 1.0,
            stride: DEFAULT_STRIDE,
            confidence: 0.683,
            scale: 1.0,
            fit: Some(FitOptions::default()),
            capture_data: CaptureData::Auto,
        }
    }
}

/// A streamed analysis: the channels (OADEV at octave tau and the fit, in the shape the in-memory path gives).
#[derive(Clone, Debug)]
pub struct StreamAnalysis {
    /// The input's name.
    pub source: String,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Samples per channel.
    pub samples: u64,
    /// The channels.
    pub channels: Vec<ChannelAnalysis>,
    /// Where the numbers came from (for the report): "samples, stride S" or "device snapshots".
    pub method: String,
}

/// Progress callback: units done so far (bytes read).
pub type Progress<'a> = &'a (dyn Fn(u64) + Sync);

fn channel_result(
    name: &str,
    totals: &StreamTotals,
    tau0_s: f64,
    scale: f64,
    opts: &StreamOptions,
    source: &str,
) -> Result<ChannelAnalysis, StreamError> {
    let points = totals.points(tau0_s, scale, opts.confidence);
    if points.is_empty() {
        return Err(StreamError::TooShort { name: source.into(), channel: name.into(), samples: totals.samples });
    }
    let counts = Counts { tau0_s, n_samples: totals.samples as usize, n_gaps: totals.gaps as usize };
    Ok(octave_channel(name, counts, points, opts))
}

/// A streamed channel: its one statistic is the OADEV at octave tau, which is also what the fit reads.
fn octave_channel(name: &str, counts: Counts, points: Vec<DevPoint>, opts: &StreamOptions) -> ChannelAnalysis {
    ChannelAnalysis::fitted(name, counts, vec![(Statistic::Oadev, points.clone())], points, opts.fit.as_ref())
}

/// Read exactly `buf.len()` bytes or up to the end; returns the bytes read.
fn read_full(r: &mut dyn Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut got = 0;
    while got < buf.len() {
        match r.read(&mut buf[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(got)
}

/// Analyse a raw binary input: `channels` interleaved channels of `format`, named `names` (or ch0, ch1...).
///
/// # Errors
/// I/O errors, [`StreamError::Truncated`] for a length that is not a whole number of sample sets,
/// [`StreamError::Empty`], [`StreamError::TooShort`].
pub fn analyze_binary(
    mut reader: impl Read + Send,
    name: &str,
    format: BinaryFormat,
    channels: usize,
    names: &[String],
    opts: &StreamOptions,
    progress: Progress<'_>,
) -> Result<StreamAnalysis, StreamError> {
    if !(opts.rate_hz.is_finite() && opts.rate_hz > 0.0) {
        return Err(StreamError::BadRate(opts.rate_hz));
    }
    let channels = channels.max(1);
    let set = format.size() * channels;
    let sets_per_read = (1usize << 20).div_ceil(channels);
    let mut accs: Vec<StreamOadev> = (0..channels).map(|_| StreamOadev::new(opts.stride)).collect::<Result<_, _>>()?;
    // A reader thread reads and converts blocks while the accumulators work; used blocks go back to it.
    type Block = (Vec<Vec<f64>>, u64);
    let (tx, rx) = std::sync::mpsc::sync_channel::<Result<Block, StreamError>>(2);
    let (back_tx, back_rx) = std::sync::mpsc::channel::<Vec<Vec<f64>>>();
    let bytes = std::thread::scope(|sc| -> Result<u64, StreamError> {
        sc.spawn(move || {
            let mut raw = vec![0u8; sets_per_read * set];
            let mut bytes: u64 = 0;
            let sz = format.size();
            loop {
                let got = match read_full(&mut reader, &mut raw) {
                    Ok(g) => g,
                    Err(source) => {
                        let _ = tx.send(Err(StreamError::Io { name: name.into(), source }));
                        return;
                    }
                };
                bytes += got as u64;
                if got % set != 0 {
                    let _ = tx.send(Err(StreamError::Truncated {
                        name: name.into(),
                        bytes,
                        channels,
                        format: format.name(),
                        set,
                        rest: (bytes % set as u64) as usize,
                    }));
                    return;
                }
                let mut cols = back_rx.try_recv().unwrap_or_else(|_| vec![Vec::with_capacity(sets_per_read); channels]);
                let body = &raw[..got];
                for (c, col) in cols.iter_mut().enumerate() {
                    col.clear();
                    col.extend(body.chunks_exact(set).map(|b| format.decode(&b[c * sz..(c + 1) * sz])));
                }
                if tx.send(Ok((cols, bytes))).is_err() || got < raw.len() {
                    return;
                }
            }
        });
        let mut bytes = 0;
        for msg in rx {
            let (cols, b) = msg?;
            for (acc, col) in accs.iter_mut().zip(&cols) {
                acc.push(col);
            }
            bytes = b;
            progress(bytes);
            let _ = back_tx.send(cols);
        }
        Ok(bytes)
    })?;
    if bytes == 0 {
        return Err(StreamError::Empty { name: name.into() });
    }
    let tau0 = 1.0 / opts.rate_hz;
    let mut out = Vec::new();
    let mut samples = 0;
    for (c, acc) in accs.into_iter().enumerate() {
        let totals = acc.finish();
        samples = totals.samples;
        let ch = names.get(c).cloned().unwrap_or_else(|| format!("ch{c}"));
        out.push(channel_result(&ch, &totals, tau0, opts.scale, opts, name)?);
    }
    Ok(StreamAnalysis {
        source: name.into(),
        rate_hz: opts.rate_hz,
        samples,
        channels: out,
        method: format!("streamed {} samples, stride {}", format.name(), opts.stride),
    })
}

/// Analyse a CSV recording in a stream (the columns of `csv`, converted to deg/s by the reader).
///
/// # Errors
/// The reader's errors (file, line, column), [`StreamError::TooShort`].
pub fn analyze_csv(
    reader: impl BufRead + Send,
    name: &str,
    csv: &CsvOptions,
    opts: &StreamOptions,
    progress: Progress<'_>,
) -> Result<StreamAnalysis, StreamError> {
    let n = csv.columns.len() + csv.accel_columns.len();
    let quantities = csv.quantities();
    let mut accs: Vec<StreamOadev> = (0..n).map(|_| StreamOadev::new(opts.stride)).collect::<Result<_, _>>()?;
    let mut cols: Vec<Vec<f64>> = vec![Vec::with_capacity(1 << 16); n];
    let mut rows: u64 = 0;
    let info = crate::io::csv::read_csv_stream(reader, name, csv, |row, _| {
        for (c, v) in cols.iter_mut().zip(row) {
            c.push(*v);
        }
        rows += 1;
        if cols[0].len() == 1 << 16 {
            for (acc, col) in accs.iter_mut().zip(cols.iter_mut()) {
                acc.push(col);
                col.clear();
            }
            progress(rows);
        }
    })?;
    for (acc, col) in accs.iter_mut().zip(&cols) {
        acc.push(col);
    }
    let tau0 = 1.0 / info.rate_hz;
    let mut out = Vec::new();
    for (c, acc) in accs.into_iter().enumerate() {
        let totals = acc.finish();
        out.push(channel_result(&info.columns[c], &totals, tau0, 1.0, opts, name)?.with_quantity(quantities[c]));
    }
    Ok(StreamAnalysis {
        source: name.into(),
        rate_hz: info.rate_hz,
        samples: info.samples,
        channels: out,
        method: format!("streamed CSV, stride {}", opts.stride),
    })
}

/// Analyse a capture: the newest whole field-log checkpoint (a read-out of the device's log, which pools every
/// session it logged), its raw samples through the streaming accumulator (scaled by each channel's deg/s per
/// code), or the device's accumulator snapshots (the last of each session, pooled), as
/// [`StreamOptions::capture_data`] says.
///
/// # Errors
/// Decoding errors, a capture without hello, or without the data asked for.
pub fn analyze_capture<R: Read>(
    mut capture: CaptureReader<R>,
    opts: &StreamOptions,
    progress: Progress<'_>,
) -> Result<StreamAnalysis, StreamError> {
    let name = capture.name().to_string();
    let mut tally = CaptureTally::default();
    let mut frames = 0u64;
    for item in capture.by_ref() {
        let d = item?;
        frames += 1;
        if frames.is_multiple_of(4096) {
            progress(d.meta.offset);
        }
        tally.take(d, opts.stride)?;
    }
    let Some(hello) = tally.hello.take() else {
        return Err(StreamError::Capture { name, what: "no hello frame: the sample rate is unknown".into() });
    };
    let rate = f64::from(hello.rate_hz);
    if rate.is_nan() || rate <= 0.0 {
        return Err(StreamError::BadRate(rate));
    }
    let channels = CaptureChannels { hello: &hello, rate, name: &name, opts };
    let have_samples = tally.accs.iter().any(|a| a.samples() > 0);
    let use_log = match opts.capture_data {
        CaptureData::Auto => tally.checkpoints.newest_whole().is_some(),
        CaptureData::FieldLog => true,
        CaptureData::Raw | CaptureData::Snapshots => false,
    };
    if use_log {
        return channels.field_log_analysis(&tally.checkpoints);
    }
    if opts.capture_data == CaptureData::Raw && !have_samples {
        return Err(StreamError::Capture { name, what: "no raw samples (record with --raw)".into() });
    }
    if have_samples && opts.capture_data != CaptureData::Snapshots {
        return channels.raw_analysis(tally.accs);
    }
    channels.snapshot_analysis(tally.snaps)
}

/// A channel's accumulator snapshots: those of finished sessions (pooled) and the latest of the current one.
type SessionSnapshots = (Option<octavar_shared::acc::Snapshot>, Option<octavar_shared::acc::Snapshot>);

/// What a capture's frames add up to, per channel: the raw samples through the streaming accumulator, the
/// snapshots, the field-log checkpoints, and the hello that names the channels.
#[derive(Default)]
struct CaptureTally {
    hello: Option<octavar_shared::proto::Hello>,
    accs: Vec<StreamOadev>,
    /// The next sample index each channel expects (a jump ends the accumulator's segment).
    next_sample: Vec<Option<u64>>,
    /// Each channel's codes of the current frame, as f64.
    cols: Vec<Vec<f64>>,
    snaps: Vec<SessionSnapshots>,
    checkpoints: crate::io::decode::Checkpoints,
}

impl CaptureTally {
    /// Take one decoded frame into the tally.
    fn take(&mut self, d: crate::io::decode::Decoded, stride: usize) -> Result<(), StreamError> {
        self.checkpoints.take(&d);
        if d.meta.restart {
            for (pooled, cur) in self.snaps.iter_mut() {
                if let Some(c) = cur.take() {
                    match pooled {
                        Some(p) => {
                            let _ = p.merge(&c);
                        }
                        None => *pooled = Some(c),
                    }
                }
            }
        }
        match d.message {
            Message::Hello(h) => {
                self.grow(h.channels.len(), stride)?;
                self.hello = Some(h);
            }
            Message::Samples(s) => {
                if s.channels() == 0 {
                    return Ok(());
                }
                let chans: Vec<usize> = s.mask_channels().collect();
                for &c in &chans {
                    self.grow(c + 1, stride)?;
                    if self.next_sample[c].is_some_and(|n| n != s.first_sample) {
                        self.accs[c].end_segment();
                    }
                    self.next_sample[c] = Some(s.first_sample + s.sets() as u64);
                }
                for (j, &c) in chans.iter().enumerate() {
                    self.cols[c].clear();
                    self.cols[c].extend(s.slot_codes(j).map(f64::from));
                    self.accs[c].push(&self.cols[c]);
                }
            }
            Message::Snapshot(cs) => {
                let c = cs.channel as usize;
                if c >= self.snaps.len() {
                    self.snaps.resize(c + 1, (None, None));
                }
                self.snaps[c].1 = Some(cs.snapshot);
            }
            _ => {}
        }
        Ok(())
    }

    /// Room for at least `n` channels.
    fn grow(&mut self, n: usize, stride: usize) -> Result<(), StreamError> {
        if self.accs.len() < n {
            for _ in self.accs.len()..n {
                self.accs.push(StreamOadev::new(stride)?);
            }
            self.next_sample.resize(n, None);
            self.cols.resize(n, Vec::new());
            self.snaps.resize(n.max(self.snaps.len()), (None, None));
        }
        Ok(())
    }
}

/// A capture's channels as its hello names them, and the analysis of each from one of its three sources.
struct CaptureChannels<'a> {
    hello: &'a octavar_shared::proto::Hello,
    rate: f64,
    name: &'a str,
    opts: &'a StreamOptions,
}

impl CaptureChannels<'_> {
    fn ch_name(&self, c: usize) -> String {
        self.hello.channels.get(c).map_or_else(|| format!("ch{c}"), |i| i.name.as_str().to_string())
    }

    fn ch_scale(&self, c: usize) -> f64 {
        self.hello.channels.get(c).map_or(1.0, |i| octavar_shared::sensor::dps_per_code(i.kind))
    }

    /// One channel's octave points from an accumulator snapshot; `None` where it has none.
    fn snapshot_channel(&self, c: usize, snap: &octavar_shared::acc::Snapshot) -> Option<ChannelAnalysis> {
        let points = crate::stats::strided::snapshot_points(snap, self.rate, self.ch_scale(c), self.opts.confidence);
        if points.is_empty() {
            return None;
        }
        let counts = Counts { tau0_s: 1.0 / self.rate, n_samples: snap.samples as usize, n_gaps: 0 };
        Some(octave_channel(&self.ch_name(c), counts, points, self.opts))
    }

    /// The newest whole field-log checkpoint (which pools every session the device logged).
    fn field_log_analysis(&self, checkpoints: &crate::io::decode::Checkpoints) -> Result<StreamAnalysis, StreamError> {
        let Some(cp) = checkpoints.newest_whole() else {
            let why = if checkpoints.by_number.is_empty() {
                "no field-log checkpoint"
            } else {
                "no whole field-log checkpoint (parts lost: read the log again)"
            };
            return Err(StreamError::Capture { name: self.name.to_string(), what: why.into() });
        };
        let channels =
            cp.channels.iter().filter_map(|(&c, snap)| self.snapshot_channel(usize::from(c), snap)).collect();
        Ok(StreamAnalysis {
            source: self.name.to_string(),
            rate_hz: self.rate,
            samples: cp.samples(),
            channels,
            method: format!(
                "field-log checkpoint {}: {} session(s), {} s, {} sample loss(es)",
                cp.number, cp.sessions, cp.time_s, cp.adc_overruns
            ),
        })
    }

    /// The raw samples, through the streaming accumulators.
    fn raw_analysis(&self, accs: Vec<StreamOadev>) -> Result<StreamAnalysis, StreamError> {
        let mut out = Vec::new();
        let mut samples = 0;
        for (c, acc) in accs.into_iter().enumerate() {
            if acc.samples() == 0 {
                continue;
            }
            let totals = acc.finish();
            samples = samples.max(totals.samples);
            out.push(channel_result(
                &self.ch_name(c),
                &totals,
                1.0 / self.rate,
                self.ch_scale(c),
                self.opts,
                self.name,
            )?);
        }
        Ok(StreamAnalysis {
            source: self.name.to_string(),
            rate_hz: self.rate,
            samples,
            channels: out,
            method: format!("raw samples of the capture, stride {}", self.opts.stride),
        })
    }

    /// The device's accumulator snapshots: the last of each session, pooled.
    fn snapshot_analysis(&self, snaps: Vec<SessionSnapshots>) -> Result<StreamAnalysis, StreamError> {
        let mut out = Vec::new();
        let mut samples = 0;
        for (c, (pooled, cur)) in snaps.into_iter().enumerate() {
            let snap = match (pooled, cur) {
                (Some(mut p), Some(c)) => {
                    let _ = p.merge(&c);
                    p
                }
                (Some(p), None) | (None, Some(p)) => p,
                (None, None) => continue,
            };
            samples = samples.max(snap.samples);
            out.extend(self.snapshot_channel(c, &snap));
        }
        if out.is_empty() {
            return Err(StreamError::Capture {
                name: self.name.to_string(),
                what: "neither raw samples nor snapshots".into(),
            });
        }
        Ok(StreamAnalysis {
            source: self.name.to_string(),
            rate_hz: self.rate,
            samples,
            channels: out,
            method: "device snapshots".into(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Uniform white noise of mean 3.
    fn white(n: usize, seed: u64) -> Vec<f64> {
        let mut g = crate::test_signals::Lcg::new(seed);
        (0..n).map(|_| g.uniform() - 0.5 + 3.0).collect()
    }

    /// A capture's raw samples (two channels, split across frames, with a break in the numbering) give the
    /// same numbers as the same codes through the binary path, scaled by each channel's deg/s per code.
    #[test]
    fn capture_raw_samples_are_streamed() {
        use octavar_shared::proto::{ChannelInfo, Encoder, Frame, Hello, Samples, MAX_CODES};
        use octavar_shared::sensor::SensorKind;
        let mut enc = Encoder::new();
        let mut bytes = Vec::new();
        let mut hello = Hello::new("t", "b", 500, 12, 3300, 8);
        let _ = hello.channels.push(ChannelInfo::new(SensorKind::Adxrs300, "gx"));
        let _ = hello.channels.push(ChannelInfo::new(SensorKind::Env05h, "gy"));
        bytes.extend_from_slice(&enc.encode_to_vec(&Frame::Hello(hello)).unwrap());
        let codes: Vec<u16> = white(20_000, 4).iter().map(|v| (v * 1000.0) as u16).collect();
        let sets = MAX_CODES / 2;
        let mut first = 0u64;
        for (f, part) in codes.chunks(sets).enumerate() {
            if f == 3 {
                first += 1000; // lost frames: a break
            }
            let mut s = Samples::new(first, 0b11);
            for &c in part {
                let _ = s.codes.push(c);
                let _ = s.codes.push(4095 - c);
            }
            first += part.len() as u64;
            bytes.extend_from_slice(&enc.encode_to_vec(&Frame::Samples(s)).unwrap());
        }
        let opts = StreamOptions::default();
        let a = analyze_capture(CaptureReader::new(&bytes[..], "t.capture"), &opts, &|_| {}).unwrap();
        assert_eq!((a.rate_hz, a.channels.len()), (500.0, 2));
        assert_eq!((a.channels[0].name.as_str(), a.channels[1].name.as_str()), ("gx", "gy"));
        // The same codes as one binary channel with the break as a NaN.
        let mut y: Vec<f64> = codes.iter().map(|&c| f64::from(c)).collect();
        y.insert(3 * sets, f64::NAN);
        let mut acc = StreamOadev::new(DEFAULT_STRIDE).unwrap();
        acc.push(&y);
        let t = acc.finish();
        let scale = octavar_shared::sensor::dps_per_code(SensorKind::Adxrs300);
        let want = t.points(1.0 / 500.0, scale, 0.683);
        for (p, q) in a.channels[0].fit_points.iter().zip(&want) {
            assert_eq!(p.n, q.n);
            assert!((p.dev / q.dev - 1.0).abs() < 1e-12, "m={}: {} vs {}", p.m, p.dev, q.dev);
        }
    }

    #[test]
    fn binary_inputs_parse_and_odd_lengths_are_errors() {
        let y = white(40_000, 3);
        let mut bytes = Vec::new();
        for v in &y {
            bytes.extend_from_slice(&(*v as f32).to_le_bytes());
            bytes.extend_from_slice(&((v * 1000.0) as i16).to_le_bytes());
        }
        // Two channels of different formats cannot be one file; use f32 pairs instead.
        let mut f32s = Vec::new();
        for v in &y {
            f32s.extend_from_slice(&(*v as f32).to_le_bytes());
            f32s.extend_from_slice(&(-*v as f32).to_le_bytes());
        }
        let opts = StreamOptions { rate_hz: 100.0, ..Default::default() };
        let a = analyze_binary(&f32s[..], "t.bin", BinaryFormat::F32, 2, &[], &opts, &|_| {}).unwrap();
        assert_eq!(a.channels.len(), 2);
        assert_eq!(a.channels[1].name, "ch1");
        assert_eq!(a.samples, y.len() as u64);
        let (p0, p1) = (&a.channels[0].fit_points[0], &a.channels[1].fit_points[0]);
        assert!((p0.dev / p1.dev - 1.0).abs() < 1e-12 && (p0.tau_s - 0.01).abs() < 1e-15);
        let u16s: Vec<u8> = y.iter().flat_map(|v| ((v * 1000.0) as u16).to_le_bytes()).collect();
        let b = analyze_binary(&u16s[..], "c.bin", BinaryFormat::U16, 1, &["gx".into()], &opts, &|_| {}).unwrap();
        assert_eq!(b.channels[0].name, "gx");
        let err = analyze_binary(&u16s[..u16s.len() - 1], "odd.bin", BinaryFormat::U16, 1, &[], &opts, &|_| {})
            .unwrap_err()
            .to_string();
        assert!(err.contains("odd.bin") && err.contains("1 bytes left over"), "{err}");
        let err = analyze_binary(&f32s[..12], "short.bin", BinaryFormat::F32, 2, &[], &opts, &|_| {}).unwrap_err();
        assert!(err.to_string().contains("left over"), "{err}");
        assert!(matches!(
            analyze_binary(&[][..], "e.bin", BinaryFormat::F64, 1, &[], &opts, &|_| {}),
            Err(StreamError::Empty { .. })
        ));
        let _ = bytes;
    }
}

//! `octavar decode`'s files: every record as CSV (samples, snapshots, levels, statuses, estimates) and the
//! summary as JSON.

use super::*;

/// Options of [`export`].
#[derive(Clone, Debug, Default)]
pub struct ExportOptions {
    /// Write samples.csv, snapshots.csv, status.csv, estimates.csv and fieldlog.csv here (created if missing).
    pub csv_dir: Option<PathBuf>,
}

struct Csv {
    path: PathBuf,
    w: csv::Writer<BufWriter<File>>,
}

impl Csv {
    fn create(dir: &Path, name: &str, header: &[String]) -> Result<Self, DecodeError> {
        let path = dir.join(name);
        let file = File::create(&path).map_err(|source| DecodeError::Write { path: path.clone(), source })?;
        let w = csv::WriterBuilder::new().flexible(false).from_writer(BufWriter::new(file));
        let mut c = Csv { path, w };
        c.row(header)?;
        Ok(c)
    }

    fn row<I, T>(&mut self, fields: I) -> Result<(), DecodeError>
    where
        I: IntoIterator<Item = T>,
        T: AsRef<[u8]>,
    {
        self.w.write_record(fields).map_err(|e| csv_error(&self.path, e))
    }

    fn finish(mut self) -> Result<PathBuf, DecodeError> {
        self.w.flush().map_err(|source| DecodeError::Write { path: self.path.clone(), source })?;
        Ok(self.path)
    }
}

fn csv_error(path: &Path, e: csv::Error) -> DecodeError {
    let source = match e.into_kind() {
        csv::ErrorKind::Io(io) => io,
        other => io::Error::other(format!("{other:?}")),
    };
    DecodeError::Write { path: path.to_path_buf(), source }
}

fn opt<T: ToString>(v: Option<T>) -> String {
    v.map(|x| x.to_string()).unwrap_or_default()
}

fn header(cols: &[&str]) -> Vec<String> {
    cols.iter().map(|s| s.to_string()).collect()
}

/// The CSV outputs while they are being written.
struct CsvSet {
    dir: PathBuf,
    samples: Option<(Csv, usize)>,
    snapshots: Csv,
    status: Csv,
    estimates: Csv,
    field_log: Csv,
}

const SNAPSHOT_COLS: [&str; 10] =
    ["frame_seq", "channel", "samples", "level", "m", "tau_s", "n", "sum_sq", "avar_codes2", "adev_codes"];

impl CsvSet {
    fn create(dir: &Path) -> Result<Self, DecodeError> {
        std::fs::create_dir_all(dir).map_err(|source| DecodeError::Write { path: dir.to_path_buf(), source })?;
        let mut log_cols = header(&["frame_seq", "checkpoint", "time_s", "sessions", "adc_overruns"]);
        log_cols.extend(header(&SNAPSHOT_COLS[1..]));
        Ok(CsvSet {
            dir: dir.to_path_buf(),
            samples: None,
            snapshots: Csv::create(dir, "snapshots.csv", &header(&SNAPSHOT_COLS))?,
            status: Csv::create(
                dir,
                "status.csv",
                &header(&[
                    "frame_seq",
                    "uptime_ms",
                    "samples_per_channel",
                    "adc_overruns",
                    "frames_dropped",
                    "temperature_c",
                    "samples_lost",
                    "stack_peak_bytes",
                ]),
            )?,
            estimates: Csv::create(
                dir,
                "estimates.csv",
                &header(&["frame_seq", "samples", "channel", "n_dps_per_rt_s", "b_dps", "tau_b_s"]),
            )?,
            field_log: Csv::create(dir, "fieldlog.csv", &log_cols)?,
        })
    }

    fn snapshot_rows(csv: &mut Csv, prefix: &[String], snap: &Snapshot, rate: Option<f64>) -> Result<(), DecodeError> {
        for r in level_rows(snap, rate) {
            let mut row = prefix.to_vec();
            row.extend([
                snap.samples.to_string(),
                r.level.to_string(),
                r.m.to_string(),
                opt(r.tau_s),
                r.n.to_string(),
                r.sum_sq.to_string(),
                r.avar_codes2.to_string(),
                r.adev_codes.to_string(),
            ]);
            csv.row(&row)?;
        }
        Ok(())
    }

    /// Write one decoded frame's rows to the CSV files it belongs to.
    fn write_frame(&mut self, d: &Decoded, hello: Option<&Hello>) -> Result<(), DecodeError> {
        let seq = d.meta.seq.to_string();
        let rate = hello.map(|h| f64::from(h.rate_hz));
        match &d.message {
            Message::Samples(s) => {
                if self.samples.is_none() {
                    // Columns: the hello's channels, or ch0..ch7 without one.
                    let names: Vec<String> = match hello {
                        Some(h) if !h.channels.is_empty() => h.channels.iter().map(|c| c.name.to_string()).collect(),
                        _ => (0..proto::MAX_CHANNELS).map(|i| format!("ch{i}")).collect(),
                    };
                    let mut cols = vec!["sample".to_string()];
                    let n = names.len();
                    cols.extend(names);
                    self.samples = Some((Csv::create(&self.dir, "samples.csv", &cols)?, n));
                }
                let (csv, columns) = self.samples.as_mut().expect("created above");
                let slots: Vec<usize> = s.mask_channels().collect();
                let mut row = vec![String::new(); *columns + 1];
                for set in 0..s.sets() {
                    row.iter_mut().for_each(String::clear);
                    row[0] = (s.first_sample + set as u64).to_string();
                    for (slot, &ch) in slots.iter().enumerate() {
                        if ch < *columns {
                            row[ch + 1] = s.code(set, slot).map(|c| c.to_string()).unwrap_or_default();
                        }
                    }
                    csv.row(&row)?;
                }
            }
            Message::Snapshot(c) => {
                Self::snapshot_rows(&mut self.snapshots, &[seq, c.channel.to_string()], &c.snapshot, rate)?;
            }
            Message::FieldLog(f) => {
                let prefix = [
                    seq,
                    f.checkpoint.to_string(),
                    f.time_s.to_string(),
                    f.sessions.to_string(),
                    f.adc_overruns.to_string(),
                    f.channel.to_string(),
                ];
                Self::snapshot_rows(&mut self.field_log, &prefix, &f.snapshot, rate)?;
            }
            Message::Status(s) => self.status.row([
                seq,
                s.uptime_ms.to_string(),
                s.samples_per_channel.to_string(),
                s.adc_overruns.to_string(),
                s.frames_dropped.to_string(),
                opt(s.temperature_c),
                s.samples_lost.to_string(),
                opt(s.stack_peak_bytes),
            ])?,
            Message::Estimate(e) => {
                for c in &e.channels {
                    self.estimates.row([
                        seq.clone(),
                        e.samples.to_string(),
                        c.channel.to_string(),
                        opt(c.n_dps_per_rt_s),
                        opt(c.b_dps),
                        opt(c.tau_b_s),
                    ])?;
                }
            }
            Message::Hello(_) | Message::FieldLogEnd(_) | Message::Ack(_) | Message::CheckpointReport(_) => {}
        }
        Ok(())
    }

    fn finish(self) -> Result<Vec<PathBuf>, DecodeError> {
        let mut files = Vec::new();
        if let Some((c, _)) = self.samples {
            files.push(c.finish()?);
        }
        for c in [self.snapshots, self.status, self.estimates, self.field_log] {
            files.push(c.finish()?);
        }
        Ok(files)
    }
}

/// Decode a whole capture: write the CSV files (if asked) as records come, and gather the summary.
///
/// # Errors
/// Reading the capture ([`DecodeError::Read`], [`DecodeError::Empty`]) or writing an output
/// ([`DecodeError::Write`]). Damaged frames are not errors: they are counted in the summary's stats.
pub fn export<R: Read>(mut reader: CaptureReader<R>, opts: &ExportOptions) -> Result<DecodeSummary, DecodeError> {
    let mut csv = opts.csv_dir.as_deref().map(CsvSet::create).transpose()?;
    let mut hello: Option<Hello> = None;
    let mut last: BTreeMap<u8, (u32, Snapshot)> = BTreeMap::new();
    let mut last_log: BTreeMap<u8, (u32, Snapshot)> = BTreeMap::new();
    let mut per_channel: BTreeMap<u8, u64> = BTreeMap::new();
    let mut statuses = Thinned::new(MAX_SERIES);
    let mut estimates = Thinned::new(MAX_SERIES);
    let mut checkpoints = super::Checkpoints::new();
    for d in reader.by_ref() {
        let d = d?;
        checkpoints.take(&d);
        if let Some(csv) = csv.as_mut() {
            csv.write_frame(&d, hello.as_ref())?;
        }
        let seq = d.meta.seq;
        match d.message {
            Message::Hello(h) => hello = Some(h),
            Message::Samples(s) => {
                for ch in s.mask_channels().map(|c| c as u8) {
                    *per_channel.entry(ch).or_default() += s.sets() as u64;
                }
            }
            Message::Snapshot(c) => {
                last.insert(c.channel, (seq, c.snapshot));
            }
            Message::FieldLog(f) => {
                last_log.insert(f.channel, (seq, f.snapshot));
            }
            Message::Status(status) => statuses.push(StatusSummary { frame_seq: seq, status }),
            Message::Estimate(estimate) => estimates.push(EstimateSummary { frame_seq: seq, estimate }),
            Message::FieldLogEnd(_) | Message::Ack(_) | Message::CheckpointReport(_) => {}
        }
    }
    let csv_files = csv.map(CsvSet::finish).transpose()?.unwrap_or_default();
    let rate = hello.as_ref().map(|h| f64::from(h.rate_hz));
    let name_of = |ch: u8| hello.as_ref().and_then(|h| h.channels.get(usize::from(ch))).map(|c| c.name.to_string());
    let summarize = |m: BTreeMap<u8, (u32, Snapshot)>| -> Vec<SnapshotSummary> {
        m.into_iter()
            .map(|(channel, (frame_seq, s))| SnapshotSummary {
                frame_seq,
                channel,
                name: name_of(channel),
                stride: s.stride,
                samples: s.samples,
                adev_1s_codes: rate.and_then(|r| adev_codes_at(&s, r, 1.0)),
                levels: level_rows(&s, rate),
            })
            .collect()
    };
    let snapshots = summarize(last);
    // The newest whole checkpoint when there is one (it pools the whole logged deployment), else the last
    // field-log snapshot of each channel.
    let whole = checkpoints.newest_whole();
    let field_log_checkpoint = whole.map(|cp| super::summary::checkpoint_summary(cp, hello.as_ref(), rate));
    let field_log = match whole {
        Some(cp) => summarize(cp.channels.iter().map(|(&c, s)| (c, (cp.number, *s))).collect()),
        None => summarize(last_log),
    };
    let (statuses, statuses_every) = statuses.into_parts();
    let (estimates, estimates_every) = estimates.into_parts();
    Ok(DecodeSummary {
        source: reader.name().to_string(),
        hello,
        stats: reader.stats().clone(),
        samples_per_channel: per_channel,
        snapshots,
        statuses,
        statuses_every,
        estimates,
        estimates_every,
        field_log,
        field_log_checkpoint,
        csv_files,
    })
}

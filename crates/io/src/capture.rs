//! Capture files: the exact bytes a device sent, appended as they arrive.
//!
//! A capture is the raw byte stream of a recording session (COBS frames, see `octavar_shared::proto`), with
//! nothing added or removed, so `decode` and `verify` see exactly what the link carried, damage included. The
//! writer appends each chunk as soon as it is received (no user-space buffer: a crash of the process loses
//! nothing already received) and syncs to the disk periodically and on close (a power cut loses at most one
//! sync interval). A write that fails (a full disk, a quota) is reported with the number of bytes safely in
//! the file; those bytes are never truncated or rewritten.
//!
//! # Examples
//! ```
//! use octavar_io::capture::CaptureWriter;
//! let dir = tempfile::tempdir().unwrap();
//! let path = dir.path().join("run.cap");
//! let mut w = CaptureWriter::create(&path, false).unwrap();
//! w.append(&[1, 2, 3, 0]).unwrap();
//! assert_eq!(w.close().unwrap(), 4);
//! assert_eq!(std::fs::read(&path).unwrap(), [1, 2, 3, 0]);
//! ```

use std::fs::{File, OpenOptions};
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// How often the writer syncs the file to the disk by default.
pub const SYNC_EVERY: Duration = Duration::from_secs(1);

/// What went wrong with a capture file, and where.
#[derive(Debug, thiserror::Error)]
pub enum CaptureError {
    /// The capture exists and is not empty: recording into it would mix two sessions unless asked to append.
    #[error("capture {} already exists ({len} bytes); choose another name or append to it", path.display())]
    Exists {
        /// The capture.
        path: PathBuf,
        /// Its size, bytes.
        len: u64,
    },
    /// The capture could not be created or opened for writing.
    #[error("cannot create capture {}: {source}", path.display())]
    Create {
        /// The capture.
        path: PathBuf,
        /// The I/O error.
        source: io::Error,
    },
    /// The disk (or the quota) is full: the bytes before `written` are in the file, the rest of the chunk is not.
    #[error(
        "capture {}: the disk is full; the first {written} bytes are saved, {lost} bytes of the last chunk were not written",
        path.display()
    )]
    DiskFull {
        /// The capture.
        path: PathBuf,
        /// Bytes of the capture safely in the file.
        written: u64,
        /// Bytes of the chunk being appended that did not fit.
        lost: u64,
    },
    /// Another write error.
    #[error("writing capture {} at byte {offset}: {source}", path.display())]
    Write {
        /// The capture.
        path: PathBuf,
        /// Where the failed write started (bytes before it are in the file).
        offset: u64,
        /// The I/O error.
        source: io::Error,
    },
    /// Syncing to the disk failed.
    #[error("syncing capture {} ({offset} bytes written): {source}", path.display())]
    Sync {
        /// The capture.
        path: PathBuf,
        /// Bytes written so far.
        offset: u64,
        /// The I/O error.
        source: io::Error,
    },
    /// The capture could not be opened for reading.
    #[error("cannot open capture {}: {source}", path.display())]
    Open {
        /// The capture.
        path: PathBuf,
        /// The I/O error.
        source: io::Error,
    },
}

/// Where capture bytes go: a file (synced with `sync_data`) or, for tests and in-memory pipelines, a `Vec<u8>`.
pub trait CaptureSink: Write {
    /// Make the bytes written so far durable.
    ///
    /// # Errors
    /// The I/O error of the sync.
    fn sync(&mut self) -> io::Result<()>;
}

impl CaptureSink for File {
    fn sync(&mut self) -> io::Result<()> {
        self.sync_data()
    }
}

impl CaptureSink for Vec<u8> {
    fn sync(&mut self) -> io::Result<()> {
        Ok(())
    }
}

/// Appends received bytes to a capture, unbuffered, syncing every [`SYNC_EVERY`] and on [`CaptureWriter::close`].
#[derive(Debug)]
pub struct CaptureWriter<W: CaptureSink = File> {
    sink: W,
    path: PathBuf,
    /// Bytes in the sink (including those there before an append-open).
    written: u64,
    /// Bytes written since the last sync.
    unsynced: u64,
    last_sync: Instant,
    sync_every: Duration,
}

impl CaptureWriter<File> {
    /// Create the capture at `path`, or with `append` open it for appending. Without `append`, an existing
    /// non-empty file is an error (recording never overwrites data).
    ///
    /// # Errors
    /// [`CaptureError::Exists`] or [`CaptureError::Create`].
    pub fn create(path: &Path, append: bool) -> Result<Self, CaptureError> {
        if !append {
            if let Ok(meta) = std::fs::metadata(path) {
                if meta.is_file() && meta.len() > 0 {
                    return Err(CaptureError::Exists { path: path.to_path_buf(), len: meta.len() });
                }
            }
        }
        let file = OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .map_err(|source| CaptureError::Create { path: path.to_path_buf(), source })?;
        let written = file.metadata().map(|m| m.len()).unwrap_or(0);
        let mut w = CaptureWriter::new(file, path);
        w.written = written;
        Ok(w)
    }
}

impl<W: CaptureSink> CaptureWriter<W> {
    /// A writer over any sink; `path` names it in errors.
    pub fn new(sink: W, path: &Path) -> Self {
        CaptureWriter {
            sink,
            path: path.to_path_buf(),
            written: 0,
            unsynced: 0,
            last_sync: Instant::now(),
            sync_every: SYNC_EVERY,
        }
    }

    /// Sync at most this often (zero: after every append).
    pub fn with_sync_every(mut self, every: Duration) -> Self {
        self.sync_every = every;
        self
    }

    /// The capture's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Bytes in the capture.
    pub fn written(&self) -> u64 {
        self.written
    }

    /// The sink (for in-memory captures).
    pub fn get_ref(&self) -> &W {
        &self.sink
    }

    /// Append `bytes` now (each write goes straight to the operating system), and sync if the interval has
    /// passed.
    ///
    /// # Errors
    /// [`CaptureError::DiskFull`] when the disk or quota is full, [`CaptureError::Write`] or
    /// [`CaptureError::Sync`] otherwise; [`CaptureWriter::written`] then counts exactly the bytes in the file.
    pub fn append(&mut self, bytes: &[u8]) -> Result<(), CaptureError> {
        let mut rest = bytes;
        while !rest.is_empty() {
            match self.sink.write(rest) {
                Ok(0) => {
                    let e = io::Error::new(io::ErrorKind::WriteZero, "the file accepted no more bytes");
                    return Err(self.write_failed(e, rest.len()));
                }
                Ok(n) => {
                    self.written += n as u64;
                    self.unsynced += n as u64;
                    rest = &rest[n..];
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(self.write_failed(e, rest.len())),
            }
        }
        if self.last_sync.elapsed() >= self.sync_every {
            self.sync()?;
        }
        Ok(())
    }

    fn write_failed(&mut self, e: io::Error, lost: usize) -> CaptureError {
        // Whatever made it into the file stays there: try to make it durable, and report the first error.
        let _ = self.sink.flush();
        let _ = self.sink.sync();
        if is_disk_full(&e) {
            CaptureError::DiskFull { path: self.path.clone(), written: self.written, lost: lost as u64 }
        } else {
            CaptureError::Write { path: self.path.clone(), offset: self.written, source: e }
        }
    }

    /// Flush and sync the bytes written so far.
    ///
    /// # Errors
    /// [`CaptureError::Sync`] (or [`CaptureError::DiskFull`] where the disk reports it on sync).
    pub fn sync(&mut self) -> Result<(), CaptureError> {
        self.last_sync = Instant::now();
        if self.unsynced == 0 {
            return Ok(());
        }
        let r = self.sink.flush().and_then(|()| self.sink.sync());
        match r {
            Ok(()) => {
                self.unsynced = 0;
                Ok(())
            }
            Err(e) if is_disk_full(&e) => {
                Err(CaptureError::DiskFull { path: self.path.clone(), written: self.written, lost: 0 })
            }
            Err(source) => Err(CaptureError::Sync { path: self.path.clone(), offset: self.written, source }),
        }
    }

    /// Sync and close; returns the bytes in the capture.
    ///
    /// # Errors
    /// As [`CaptureWriter::sync`].
    pub fn close(mut self) -> Result<u64, CaptureError> {
        self.unsynced = self.unsynced.max(1);
        self.sync()?;
        Ok(self.written)
    }

    /// The sink, after a final sync.
    ///
    /// # Errors
    /// As [`CaptureWriter::sync`].
    pub fn into_inner(mut self) -> Result<W, CaptureError> {
        self.unsynced = self.unsynced.max(1);
        self.sync()?;
        Ok(self.sink)
    }
}

/// ENOSPC or EDQUOT.
fn is_disk_full(e: &io::Error) -> bool {
    matches!(e.kind(), io::ErrorKind::StorageFull | io::ErrorKind::QuotaExceeded)
        || matches!(e.raw_os_error(), Some(28) | Some(122))
}

/// A capture opened for reading: a file, or stdin for `-`.
pub struct CaptureInput {
    /// The path as given, or `stdin`.
    pub name: String,
    /// The path, `None` for stdin.
    pub path: Option<PathBuf>,
    /// The bytes.
    pub reader: Box<dyn Read + Send>,
    /// The size in bytes where known (a regular file).
    pub len: Option<u64>,
}

/// Open a capture for reading; `-` is stdin.
///
/// # Errors
/// [`CaptureError::Open`] with the path (a missing file, a directory, no permission).
pub fn open(path: &Path) -> Result<CaptureInput, CaptureError> {
    if path == Path::new("-") {
        return Ok(CaptureInput { name: "stdin".into(), path: None, reader: Box::new(io::stdin()), len: None });
    }
    let err = |source| CaptureError::Open { path: path.to_path_buf(), source };
    let file = File::open(path).map_err(err)?;
    let meta = file.metadata().map_err(err)?;
    if meta.is_dir() {
        return Err(err(io::Error::new(io::ErrorKind::InvalidInput, "it is a directory")));
    }
    Ok(CaptureInput {
        name: path.display().to_string(),
        path: Some(path.to_path_buf()),
        reader: Box::new(file),
        len: meta.is_file().then_some(meta.len()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Accepts `room` bytes, then fails every write with `kind` (a disk that fills up).
    struct Filling {
        data: Vec<u8>,
        room: usize,
        errno: i32,
    }

    impl Write for Filling {
        fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
            let n = buf.len().min(self.room - self.data.len());
            if n == 0 {
                return Err(io::Error::from_raw_os_error(self.errno));
            }
            self.data.extend_from_slice(&buf[..n]);
            Ok(n)
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    impl CaptureSink for Filling {
        fn sync(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn a_full_disk_keeps_every_byte_written_and_says_how_many() {
        let sink = Filling { data: Vec::new(), room: 10, errno: 28 };
        let mut w = CaptureWriter::new(sink, Path::new("x.cap"));
        w.append(&[1; 6]).unwrap();
        let e = w.append(&[2; 6]).unwrap_err();
        match &e {
            CaptureError::DiskFull { written, lost, .. } => assert_eq!((*written, *lost), (10, 2)),
            other => panic!("{other:?}"),
        }
        assert!(e.to_string().contains("x.cap: the disk is full; the first 10 bytes are saved"), "{e}");
        assert_eq!(w.written(), 10);
        assert_eq!(w.get_ref().data, [1, 1, 1, 1, 1, 1, 2, 2, 2, 2]);
        let other = Filling { data: Vec::new(), room: 0, errno: 5 };
        let mut w = CaptureWriter::new(other, Path::new("y.cap"));
        let e = w.append(&[1]).unwrap_err();
        assert!(matches!(e, CaptureError::Write { offset: 0, .. }), "{e:?}");
    }

    #[test]
    fn dev_full_is_reported_as_a_full_disk() {
        if !Path::new("/dev/full").exists() {
            return;
        }
        let mut w = CaptureWriter::create(Path::new("/dev/full"), true).unwrap();
        let e = w.append(&[1, 2, 3]).unwrap_err();
        assert!(matches!(e, CaptureError::DiskFull { written: 0, lost: 3, .. }), "{e:?}");
    }

    #[test]
    fn never_overwrites_and_appends_on_request() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.cap");
        let mut w = CaptureWriter::create(&path, false).unwrap().with_sync_every(Duration::ZERO);
        w.append(b"abc").unwrap();
        // Unbuffered: the bytes are in the file before close.
        assert_eq!(std::fs::read(&path).unwrap(), b"abc");
        drop(w);
        let e = CaptureWriter::create(&path, false).unwrap_err();
        assert!(e.to_string().contains("already exists (3 bytes)"), "{e}");
        let mut w = CaptureWriter::create(&path, true).unwrap();
        assert_eq!(w.written(), 3);
        w.append(b"de").unwrap();
        assert_eq!(w.close().unwrap(), 5);
        assert_eq!(std::fs::read(&path).unwrap(), b"abcde");
        let e = CaptureWriter::create(&dir.path().join("no/such/dir/x.cap"), false).unwrap_err();
        assert!(e.to_string().starts_with("cannot create capture"), "{e}");
    }

    #[test]
    fn open_names_the_missing_file() {
        let e = open(Path::new("/nonexistent/run.cap")).err().unwrap();
        assert!(e.to_string().contains("/nonexistent/run.cap"), "{e}");
        let dir = tempfile::tempdir().unwrap();
        let e = open(dir.path()).err().unwrap();
        assert!(e.to_string().contains("directory"), "{e}");
    }
}

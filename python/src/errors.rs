//! The library's errors as Python exceptions: a file that cannot be read is an `OSError` (with its errno, so
//! Python raises `FileNotFoundError`, `PermissionError`, ... where one applies), everything else a `ValueError`.
//! Each carries the message the `octavar` command prints for the same fault.

use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::PyErr;

use octavar::io::csv::RecordingError;
use octavar::io::formats::ReadError;
use octavar::io::imu_topic::BagError;
use octavar::io::tdms::TdmsError;

/// A `ValueError` with this message.
pub fn value_error(message: impl Into<String>) -> PyErr {
    PyValueError::new_err(message.into())
}

/// An `OSError` for `err`, with `message` (which names the file) as its text. Its errno (the system's, or the one
/// of its kind where the error was made in Rust) makes Python raise the matching subclass.
pub fn os_error(err: &std::io::Error, message: String) -> PyErr {
    use std::io::ErrorKind;
    // POSIX numbers, the same on Linux and macOS (and in the Windows C runtime).
    let errno = err.raw_os_error().or(match err.kind() {
        ErrorKind::NotFound => Some(2),
        ErrorKind::PermissionDenied => Some(13),
        ErrorKind::AlreadyExists => Some(17),
        ErrorKind::NotADirectory => Some(20),
        ErrorKind::IsADirectory => Some(21),
        _ => None,
    });
    match errno {
        Some(errno) => PyOSError::new_err((errno, message)),
        None => PyOSError::new_err(message),
    }
}

/// A reader's error: `OSError` where the file could not be read, `ValueError` where its content or the options
/// were at fault.
pub fn read_error(e: ReadError) -> PyErr {
    let io = match &e {
        ReadError::Io { err, .. }
        | ReadError::Csv(RecordingError::Io { err, .. })
        | ReadError::Tdms(TdmsError::Io { err, .. })
        | ReadError::Bag(BagError::Io { err, .. }) => Some(err),
        _ => None,
    };
    match io {
        Some(err) => os_error(err, e.to_string()),
        None => value_error(e.to_string()),
    }
}

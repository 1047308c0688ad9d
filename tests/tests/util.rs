//! Shared helpers: where the reference data is, and skipping politely when it is absent.

use std::path::PathBuf;

/// The reference data folder: `OCTAVAR_DATA`, or `../shared/data` from the workspace root.
#[allow(dead_code)]
pub fn data_dir() -> Option<PathBuf> {
    let dir = match std::env::var_os("OCTAVAR_DATA") {
        Some(d) => PathBuf::from(d),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data"),
    };
    if dir.is_dir() {
        Some(dir)
    } else {
        println!("skipped: reference data not found at {} (set OCTAVAR_DATA)", dir.display());
        None
    }
}

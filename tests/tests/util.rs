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

/// A Python with allantools (the independent reference): `OCTAVAR_PYTHON`, or the `.venv-ref` that `.ci/run`
/// makes. `None`, with a printed line, where there is none.
#[allow(dead_code)]
pub fn allantools_python() -> Option<PathBuf> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let candidates = [std::env::var_os("OCTAVAR_PYTHON").map(PathBuf::from), Some(root.join(".venv-ref/bin/python"))];
    for py in candidates.into_iter().flatten() {
        let ok = std::process::Command::new(&py)
            .args(["-c", "import allantools"])
            .output()
            .is_ok_and(|o| o.status.success());
        if ok {
            return Some(py);
        }
    }
    if std::env::var_os("CI").is_some() {
        panic!("CI must have allantools: .ci/run installs it into .venv-ref");
    }
    println!("skipped: no Python with allantools (run .ci/run once, or set OCTAVAR_PYTHON)");
    None
}

/// Path of a file under `tests/reference/`.
#[allow(dead_code)]
pub fn reference_script(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("reference").join(name)
}

/// A fresh temporary directory for one test.
#[allow(dead_code)]
pub fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("octavar-test-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create temp dir");
    dir
}

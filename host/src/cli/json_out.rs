//! Where `--json FILE` writes: the file, or stdout for `-` (then the command prints no text report beside it, so
//! the output is one JSON document a pipe can read).

use std::io::Write;
use std::path::Path;

use anyhow::Context;
use serde::Serialize;

/// Whether `--json` names stdout.
pub fn to_stdout(path: Option<&Path>) -> bool {
    path == Some(Path::new("-"))
}

/// Write `doc` as pretty JSON to `path`, or to stdout for `-`.
pub fn write(path: &Path, doc: &impl Serialize) -> anyhow::Result<()> {
    let text = serde_json::to_string_pretty(doc)?;
    if to_stdout(Some(path)) {
        let mut out = std::io::stdout().lock();
        writeln!(out, "{text}")?;
        out.flush()?;
        return Ok(());
    }
    std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))
}

//! Where `--json FILE` writes: the file, or stdout for `-` (then the command prints no text report beside it, so
//! the output is one JSON document a pipe can read).

use std::io::{BufWriter, Write};
use std::path::Path;

use anyhow::Context;
use serde::Serialize;

/// Whether `--json` names stdout.
pub fn to_stdout(path: Option<&Path>) -> bool {
    path == Some(Path::new("-"))
}

/// Write `doc` as pretty JSON, ended by a newline, to `path`, or to `stdout` for `-`.
pub fn write(path: &Path, doc: &impl Serialize, stdout: &mut dyn Write) -> anyhow::Result<()> {
    if to_stdout(Some(path)) {
        serde_json::to_writer_pretty(&mut *stdout, doc)?;
        writeln!(stdout)?;
        return stdout.flush().context("writing stdout");
    }
    let written = || -> std::io::Result<()> {
        let mut w = BufWriter::new(std::fs::File::create(path)?);
        serde_json::to_writer_pretty(&mut w, doc)?;
        writeln!(w)?;
        w.flush()
    };
    written().with_context(|| format!("writing {}", path.display()))
}

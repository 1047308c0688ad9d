//! Opening inputs: a file path, a gzip-compressed file (recognised by its magic bytes), or `-` for stdin.

use std::fs::File;
use std::io::{self, BufRead, BufReader, Read};
use std::path::Path;

use flate2::read::MultiGzDecoder;

/// A readable input and the name to use for it in error messages.
pub struct Input {
    /// `stdin` or the path as given.
    pub name: String,
    /// The (decompressed) bytes.
    pub reader: Box<dyn BufRead + Send>,
    /// How many bytes `reader` gives, where that is known (an uncompressed file).
    pub size: Option<u64>,
}

/// Open `path` for reading; `-` is stdin. Gzip is detected from the first two bytes, whatever the file is called.
///
/// # Errors
/// The I/O error of opening or peeking at the file, with the path in the message.
pub fn open(path: &Path) -> io::Result<Input> {
    let name = if path == Path::new("-") { "stdin".to_string() } else { path.display().to_string() };
    let mut size = None;
    let raw: Box<dyn Read + Send> = if path == Path::new("-") {
        Box::new(io::stdin())
    } else {
        let file = File::open(path).map_err(|e| io::Error::new(e.kind(), format!("cannot open {name}: {e}")))?;
        size = file.metadata().ok().filter(|m| m.is_file()).map(|m| m.len());
        Box::new(file)
    };
    let mut buffered = BufReader::with_capacity(1 << 16, raw);
    let head = buffered.fill_buf()?;
    let reader: Box<dyn BufRead + Send> = if head.starts_with(&[0x1f, 0x8b]) {
        size = None;
        Box::new(BufReader::with_capacity(1 << 16, MultiGzDecoder::new(buffered)))
    } else {
        Box::new(buffered)
    };
    Ok(Input { name, reader, size })
}

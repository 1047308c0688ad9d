//! rosbag2's zstd compression, undone: `ros2 bag record --compression-format zstd` either compresses each storage
//! file whole when it is closed (file mode: `NAME_0.db3.zstd`, `NAME_0.mcap.zstd`) or each message's serialized
//! bytes (message mode: the storage file is plain, its payloads are zstd frames). Both are recognised by the zstd
//! frame's magic number, not by the bag's `metadata.yaml`, so a compressed file read on its own works too; a CDR
//! payload starts with its encapsulation header (`00 01` or `00 00`) and can never be taken for one.
//!
//! Decompression is ruzstd's (pure Rust). A file may hold several frames one after another (a streaming compressor
//! or `pzstd` writes them); they are joined.

use std::io::{BufRead, BufReader, Read, Write};
use std::path::Path;

use ruzstd::decoding::StreamingDecoder;

/// The first four bytes of a zstd frame (RFC 8878, 0xFD2FB528 little-endian).
const MAGIC: [u8; 4] = [0x28, 0xb5, 0x2f, 0xfd];

/// The largest message octavar decompresses: an Imu message in CDR is about 330 bytes, so anything near this is
/// not one (and a corrupt frame cannot claim memory without bound).
const MAX_MESSAGE_BYTES: u64 = 1 << 20;

/// Whether `bytes` start with a zstd frame.
pub(crate) fn is_zstd(bytes: &[u8]) -> bool {
    bytes.starts_with(&MAGIC)
}

/// The frames of `input`, decompressed one after another into `out`: the bytes written.
///
/// # Errors
/// A frame that does not decode (as text), or one of `out`'s write errors.
fn decode_frames<R: Read, W: Write>(input: R, out: &mut W, limit: u64) -> Result<u64, String> {
    let mut input = BufReader::new(input);
    let mut written = 0u64;
    loop {
        if input.fill_buf().map_err(|e| e.to_string())?.is_empty() {
            return Ok(written);
        }
        let frame = StreamingDecoder::new(&mut input)
            .map_err(|e| format!("the zstd frame after {written} decompressed bytes: {e}"))?;
        let mut frame = frame.take(limit.saturating_sub(written).saturating_add(1));
        let n = std::io::copy(&mut frame, out).map_err(|e| e.to_string())?;
        written += n;
        if written > limit {
            return Err(format!("it decompresses to more than {limit} bytes"));
        }
    }
}

/// A message's bytes, decompressed when they are a zstd frame (rosbag2's message mode).
///
/// # Errors
/// A frame that does not decompress, or one larger than any Imu message.
pub(crate) fn message(data: &[u8]) -> Result<std::borrow::Cow<'_, [u8]>, String> {
    if !is_zstd(data) {
        return Ok(std::borrow::Cow::Borrowed(data));
    }
    let mut out = Vec::new();
    decode_frames(data, &mut out, MAX_MESSAGE_BYTES).map_err(|e| {
        format!("a zstd-compressed message (rosbag2's message compression) that does not decompress: {e}")
    })?;
    Ok(std::borrow::Cow::Owned(out))
}

/// A whole zstd-compressed storage file held in memory, decompressed.
///
/// # Errors
/// A frame that does not decompress (as text).
pub(crate) fn whole(data: &[u8]) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    decode_frames(data, &mut out, u64::MAX)?;
    Ok(out)
}

/// The zstd-compressed storage file at `path`, decompressed into a temporary file (deleted when dropped) in the
/// system's temporary directory: SQLite reads a file, and a bag can be larger than memory.
///
/// # Errors
/// The file cannot be read, the temporary file cannot be written (a full disk), or a frame does not decompress;
/// as text naming which.
pub(crate) fn to_temp_file(path: &Path) -> Result<tempfile::NamedTempFile, String> {
    let input = std::fs::File::open(path).map_err(|e| format!("cannot open it: {e}"))?;
    let mut tmp = tempfile::Builder::new()
        .prefix("octavar-rosbag2-")
        .suffix(".db3")
        .tempfile()
        .map_err(|e| format!("cannot make a temporary file to decompress it into: {e}"))?;
    let mut out = std::io::BufWriter::new(tmp.as_file_mut());
    decode_frames(input, &mut out, u64::MAX)
        .map_err(|e| format!("decompressing it (zstd, rosbag2's file compression): {e}"))?;
    out.flush().map_err(|e| format!("writing the decompressed copy to {}: {e}", std::env::temp_dir().display()))?;
    drop(out);
    Ok(tmp)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ruzstd::encoding::{compress_to_vec, CompressionLevel};

    #[test]
    fn frames_are_undone_and_joined_and_plain_bytes_pass_through() {
        let text: Vec<u8> = (0..50_000u32).flat_map(|i| (i % 251).to_le_bytes()).collect();
        let (a, b) = text.split_at(77_777);
        let mut two = compress_to_vec(a, CompressionLevel::Fastest);
        two.extend(compress_to_vec(b, CompressionLevel::Uncompressed));
        assert!(is_zstd(&two));
        assert_eq!(whole(&two).unwrap(), text);
        let cdr = [0u8, 1, 0, 0, 9, 9];
        assert!(matches!(message(&cdr).unwrap(), std::borrow::Cow::Borrowed(_)));
        assert_eq!(&*message(&compress_to_vec(&cdr[..], CompressionLevel::Fastest)).unwrap(), &cdr);
    }

    #[test]
    fn a_damaged_or_oversized_frame_is_an_error() {
        let text = vec![7u8; 3 << 20];
        let z = compress_to_vec(&text[..], CompressionLevel::Fastest);
        assert!(message(&z).unwrap_err().contains("more than"), "a 3 MB message");
        let mut cut =
            compress_to_vec(&b"rosbag2 message bytes, long enough to be a frame"[..], CompressionLevel::Fastest);
        cut.truncate(cut.len() - 5);
        assert!(message(&cut).unwrap_err().contains("does not decompress"));
    }
}

//! The content of a ROS 1 bag's chunk: stored as is (`none`), or compressed with `bz2` (a bzip2 stream,
//! decompressed by the pure-Rust libbz2-rs-sys) or `lz4` (an LZ4 frame, decompressed by lz4_flex). The content must
//! be exactly the `size` the chunk's header gives.

use std::io::Read;

/// Why a chunk's content could not be had.
pub(super) enum ChunkError {
    /// A compression octavar does not read.
    Unsupported(String),
    /// The content does not decompress, or not to its size.
    Bad(String),
}

/// The compressions octavar reads, for the error about the others.
pub(super) const READS: &str = "bz2, lz4 and uncompressed chunks";

/// The uncompressed content of a chunk whose data is `data`, decompressed into `out` where it is compressed.
pub(super) fn content<'a>(
    compression: &[u8],
    data: &'a [u8],
    size: u32,
    out: &'a mut Vec<u8>,
) -> Result<&'a [u8], ChunkError> {
    let size = u64::from(size);
    let decompress = |name: &str, reader: &mut dyn Read, out: &mut Vec<u8>| -> Result<(), ChunkError> {
        out.clear();
        // One byte more than the size, to see a stream that decompresses to more.
        reader
            .take(size + 1)
            .read_to_end(out)
            .map_err(|e| ChunkError::Bad(format!("the {name} chunk does not decompress: {e}")))?;
        Ok(())
    };
    let content: &[u8] = match compression {
        b"none" => data,
        b"bz2" => {
            decompress("bz2", &mut bzip2::read::BzDecoder::new(data), out)?;
            out
        }
        b"lz4" => {
            decompress("lz4", &mut lz4_flex::frame::FrameDecoder::new(data), out)?;
            out
        }
        other => return Err(ChunkError::Unsupported(String::from_utf8_lossy(other).into_owned())),
    };
    if content.len() as u64 != size {
        let more = if content.len() as u64 > size { "more than " } else { "" };
        return Err(ChunkError::Bad(format!(
            "the chunk holds {more}{} bytes where its header says {size}",
            content.len().min(size as usize)
        )));
    }
    Ok(content)
}

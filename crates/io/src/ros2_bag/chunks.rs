//! MCAP chunks: decompressed (zstd with ruzstd, lz4 with lz4_flex, or stored) into the scan's reused buffer,
//! checked against their uncompressed size and CRC, and their records taken as if they were top-level.

use std::io::Read;

use super::scan::{walk_records, Scan, WalkError};
use super::BagError;

/// The largest chunk octavar decompresses (writers make chunks of about a megabyte): a bigger size in a chunk
/// header is taken for corruption rather than allocated.
const MAX_CHUNK_BYTES: u64 = 1 << 32;
/// MCAP's CRC-32 (the zlib one, CRC-32/ISO-HDLC), with the `crc` crate the frame protocol uses, sixteen bytes a
/// step.
const CRC32: crc::Crc<u32, crc::Table<16>> = crc::Crc::<u32, crc::Table<16>>::new(&crc::CRC_32_ISO_HDLC);

impl Scan {
    /// Decompress a chunk, check its CRC, and take the records in it.
    pub(super) fn chunk(
        &mut self,
        offset: u64,
        header: &mcap::records::ChunkHeader,
        data: &[u8],
    ) -> Result<(), BagError> {
        let path = self.path.clone();
        let corrupt = |what: String| BagError::Corrupt { path: path.clone(), format: "MCAP", offset, what };
        let size = header.uncompressed_size;
        let compression = header.compression.as_str();
        if size > MAX_CHUNK_BYTES {
            return Err(corrupt(format!("the chunk claims {size} bytes uncompressed")));
        }
        let mut out = std::mem::take(&mut self.scratch);
        let content: &[u8] = match compression {
            "" => data,
            "zstd" | "lz4" => {
                out.clear();
                out.try_reserve_exact(size as usize)
                    .map_err(|_| corrupt(format!("the chunk claims {size} bytes uncompressed")))?;
                out.resize(size as usize, 0);
                let done = if compression == "zstd" {
                    let dec = self.zstd.get_or_insert_with(ruzstd::decoding::FrameDecoder::new);
                    dec.decode_all(data, &mut out).map_err(|e| e.to_string()).and_then(|n| {
                        if n as u64 == size {
                            Ok(())
                        } else {
                            Err(format!("{n} bytes decompressed where the chunk header says {size}"))
                        }
                    })
                } else {
                    lz4_flex::frame::FrameDecoder::new(data).read_exact(&mut out).map_err(|e| e.to_string())
                };
                done.map_err(|e| corrupt(format!("the {compression} chunk does not decompress: {e}")))?;
                &out
            }
            _ => {
                return Err(BagError::UnsupportedCompression {
                    path: self.path.clone(),
                    offset,
                    compression: compression.to_string(),
                    reads: "zstd, lz4 and uncompressed chunks",
                })
            }
        };
        if content.len() as u64 != size {
            return Err(corrupt(format!("the chunk holds {} bytes where its header says {size}", content.len())));
        }
        if header.uncompressed_crc != 0 {
            let crc = CRC32.checksum(content);
            if crc != header.uncompressed_crc {
                return Err(corrupt(format!(
                    "the chunk's CRC is {crc:08x} where its header says {:08x}",
                    header.uncompressed_crc
                )));
            }
        }
        let walked = walk_records(content, true, |_, record| self.record(offset, record, true));
        let walked = walked.map_err(|e| match e {
            WalkError::Stop(err) => err,
            WalkError::Mcap { offset: inner, err } => BagError::Corrupt {
                path: self.path.clone(),
                format: "MCAP",
                offset,
                what: format!("in the chunk, at byte {inner} of its {size} uncompressed bytes: {err}"),
            },
        });
        self.scratch = out;
        walked
    }
}

//! A segment's raw data: TDMS data types and their sizes, where each requested channel's values lie in the
//! segment's chunks (contiguous or interleaved, whole chunks or rows only in an unfinished final segment), and
//! decoding them in either byte order into numbers.

use super::segment::{Fault, FileReader, TOC_BIG_ENDIAN, TOC_INTERLEAVED};

// Data type codes.
pub(super) const TYPE_STRING: u32 = 0x20;
pub(super) const TYPE_DAQMX: u32 = 0xFFFF_FFFF;

/// Bytes per value of a data type, where it has a fixed size.
pub(super) fn type_size(code: u32) -> Option<u64> {
    Some(match code {
        0 => 0,
        1 | 5 | 0x21 => 1,
        2 | 6 => 2,
        3 | 7 | 9 | 0x19 => 4,
        4 | 8 | 10 | 0x1A | 0x08_000C => 8,
        0x44 | 0x10_000D => 16,
        _ => return None,
    })
}

/// Whether a data type is a real number octavar reads.
pub(super) fn is_numeric(code: u32) -> bool {
    matches!(code, 1..=10 | 0x19 | 0x1A)
}

/// A data type's name, for errors.
pub(super) fn type_name(code: u32) -> String {
    match code {
        0 => "void",
        1 => "i8",
        2 => "i16",
        3 => "i32",
        4 => "i64",
        5 => "u8",
        6 => "u16",
        7 => "u32",
        8 => "u64",
        9 => "f32",
        10 => "f64",
        11 => "extended float",
        0x19 => "f32 with unit",
        0x1A => "f64 with unit",
        0x1B => "extended float with unit",
        TYPE_STRING => "string",
        0x21 => "boolean",
        0x44 => "time stamp",
        0x4F => "fixed point",
        0x08_000C => "complex f32",
        0x10_000D => "complex f64",
        TYPE_DAQMX => "DAQmx raw",
        other => return format!("unknown (type code {other:#x})"),
    }
    .to_string()
}

impl FileReader<'_> {
    /// Decode the requested channels' values in the raw data `start..end` of a segment.
    pub(super) fn read_data(&mut self, toc: u32, start: usize, end: usize, unwritten: bool) -> Result<(), Fault> {
        let mut with_data = Vec::new();
        let mut chunk = 0u64;
        for &(id, has) in &self.list {
            if !has {
                continue;
            }
            let Some(index) = self.objects[id].index else { continue };
            if index.values == 0 {
                continue;
            }
            chunk = chunk.checked_add(index.bytes).ok_or_else(|| Fault::Corrupt {
                offset: start,
                message: "the channels' data sizes overflow".to_string(),
            })?;
            with_data.push((id, index));
        }
        let total = (end - start) as u64;
        if chunk == 0 {
            if total != 0 {
                return Err(Fault::Corrupt {
                    offset: start,
                    message: format!("{total} bytes of raw data, but no channel has data in this segment"),
                });
            }
            return Ok(());
        }
        let (chunks, rest) = (total / chunk, total % chunk);
        if rest != 0 && !unwritten {
            return Err(Fault::Corrupt {
                offset: start,
                message: format!(
                    "{total} bytes of raw data are not a whole number of chunks of {chunk} bytes (the channels' \
                     values)"
                ),
            });
        }
        for &(id, index) in &with_data {
            let o = &self.objects[id];
            if o.slot.is_some() && !is_numeric(index.data_type) {
                return Err(Fault::NotNumeric {
                    channel: format!("{}/{}", o.group.as_deref().unwrap_or(""), o.channel.as_deref().unwrap_or("")),
                    data_type: type_name(index.data_type),
                });
            }
        }
        let big = toc & TOC_BIG_ENDIAN != 0;
        if toc & TOC_INTERLEAVED != 0 {
            let values = with_data[0].1.values;
            let mut width = 0usize;
            for &(id, index) in &with_data {
                if index.values != values {
                    return Err(Fault::Corrupt {
                        offset: start,
                        message: format!(
                            "interleaved data whose channels differ in length ({} has {values} values, {} has {})",
                            self.name(with_data[0].0),
                            self.name(id),
                            index.values
                        ),
                    });
                }
                match type_size(index.data_type) {
                    Some(s) if index.data_type != TYPE_STRING => width += s as usize,
                    _ => {
                        return Err(Fault::Corrupt {
                            offset: start,
                            message: format!(
                                "interleaved data with {} of type {}, which has no fixed size",
                                self.name(id),
                                type_name(index.data_type)
                            ),
                        })
                    }
                }
            }
            // Whole rows only: an unfinished segment may stop inside a chunk.
            let rows = (end - start) / width;
            let mut offset = start;
            for &(id, index) in &with_data {
                if let Some(slot) = self.objects[id].slot {
                    let data_type = index.data_type;
                    let job =
                        Job { slot, data_type, big, start: offset, stride: width, count: rows, runs: 1, run_stride: 0 };
                    self.add(job);
                }
                offset += type_size(index.data_type).unwrap_or(0) as usize;
            }
        } else if chunks > 0 {
            // Every value counted here lies inside `start..end`, so the sizes fit in usize.
            let mut offset = start;
            for &(id, index) in &with_data {
                if let Some(slot) = self.objects[id].slot {
                    let job = Job {
                        slot,
                        data_type: index.data_type,
                        big,
                        start: offset,
                        stride: type_size(index.data_type).unwrap_or(1) as usize,
                        count: index.values as usize,
                        runs: chunks as usize,
                        run_stride: chunk as usize,
                    };
                    self.add(job);
                }
                offset += index.bytes as usize;
            }
        }
        Ok(())
    }

    fn add(&mut self, job: Job) {
        self.lengths[job.slot] += job.count * job.runs;
        self.jobs.push(job);
    }
}

/// Where a requested channel's values are in one segment: `runs` runs (chunks) of `count` values `stride` bytes
/// apart, the runs `run_stride` bytes apart from byte `start` of the file.
#[derive(Clone, Copy, Debug)]
pub(super) struct Job {
    pub(super) slot: usize,
    data_type: u32,
    big: bool,
    start: usize,
    stride: usize,
    count: usize,
    runs: usize,
    run_stride: usize,
}

impl Job {
    pub(super) fn decode(&self, bytes: &[u8], out: &mut Vec<f64>) {
        for r in 0..self.runs {
            decode(self.data_type, self.big, &bytes[self.start + r * self.run_stride..], self.stride, self.count, out);
        }
    }
}

/// Append `count` values of `data_type` to `out`, one every `stride` bytes of `src` from its start.
fn decode(data_type: u32, big: bool, src: &[u8], stride: usize, count: usize, out: &mut Vec<f64>) {
    fn push<const N: usize>(src: &[u8], stride: usize, count: usize, out: &mut Vec<f64>, f: impl Fn([u8; N]) -> f64) {
        if count == 0 {
            return;
        }
        let bytes = |c: &[u8]| -> [u8; N] { c[..N].try_into().unwrap_or([0; N]) };
        if stride == N {
            out.extend(src[..count * N].chunks_exact(N).map(|c| f(bytes(c))));
        } else {
            out.extend(src[..(count - 1) * stride + N].chunks(stride).map(|c| f(bytes(c))));
        }
    }
    macro_rules! number {
        ($t:ty, $n:literal) => {
            if big {
                push::<$n>(src, stride, count, out, |b| <$t>::from_be_bytes(b) as f64)
            } else {
                push::<$n>(src, stride, count, out, |b| <$t>::from_le_bytes(b) as f64)
            }
        };
    }
    match data_type {
        1 => number!(i8, 1),
        2 => number!(i16, 2),
        3 => number!(i32, 4),
        4 => number!(i64, 8),
        5 => number!(u8, 1),
        6 => number!(u16, 2),
        7 => number!(u32, 4),
        8 => number!(u64, 8),
        9 | 0x19 => number!(f32, 4),
        10 | 0x1A => number!(f64, 8),
        _ => {}
    }
}

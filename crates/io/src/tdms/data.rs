//! A segment's raw data: TDMS data types and their sizes, where each requested channel's values lie in the
//! segment's chunks (contiguous or interleaved, whole chunks or rows only in an unfinished final segment), and
//! decoding them in either byte order into numbers.

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

/// Where a requested channel's values are in one segment: `runs` runs (chunks) of `count` values `stride` bytes
/// apart, the runs `run_stride` bytes apart from byte `start` of the file.
#[derive(Clone, Copy, Debug)]
pub(super) struct Job {
    pub(super) slot: usize,
    pub(super) data_type: u32,
    pub(super) big: bool,
    pub(super) start: usize,
    pub(super) stride: usize,
    pub(super) count: usize,
    pub(super) runs: usize,
    pub(super) run_stride: usize,
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

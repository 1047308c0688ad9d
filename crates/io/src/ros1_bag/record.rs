//! The records of a ROS 1 bag (format 2.0): each is a header (length-prefixed `name=value` fields, among them the
//! op code) and a data block, both prefixed with their length in bytes (u32, little-endian). [`Records`] walks a
//! buffer of them (the file, or a chunk's content) and [`Fields`] reads the fields octavar uses.

/// Op codes of the records (the `op` field).
pub(super) mod op {
    pub const MESSAGE: u8 = 0x02;
    pub const BAG_HEADER: u8 = 0x03;
    pub const INDEX_DATA: u8 = 0x04;
    pub const CHUNK: u8 = 0x05;
    pub const CHUNK_INFO: u8 = 0x06;
    pub const CONNECTION: u8 = 0x07;
}

/// One record: where it starts in its buffer, its header's fields and its data.
pub(super) struct Record<'a> {
    pub(super) offset: usize,
    pub(super) fields: Fields<'a>,
    pub(super) data: &'a [u8],
}

/// Why a walk stopped.
#[derive(Debug, PartialEq)]
pub(super) enum RecordError {
    /// The buffer ends inside the record that starts at `offset`.
    Short { offset: usize },
    /// The record at `offset` does not parse.
    Bad { offset: usize, what: String },
}

/// The records of a buffer, in order, from `offset`.
pub(super) struct Records<'a> {
    buf: &'a [u8],
    pos: usize,
}

impl<'a> Records<'a> {
    pub(super) fn new(buf: &'a [u8], offset: usize) -> Records<'a> {
        Records { buf, pos: offset }
    }
}

/// The `u32` at `at` of `buf`, if there are four bytes there.
fn u32_at(buf: &[u8], at: usize) -> Option<u32> {
    let b = buf.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes(b.try_into().ok()?))
}

impl<'a> Iterator for Records<'a> {
    type Item = Result<Record<'a>, RecordError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.pos >= self.buf.len() {
            return None;
        }
        let offset = self.pos;
        let short = RecordError::Short { offset };
        // Sums of a position and a u32 length: checked, as a 32-bit target could overflow.
        let ends = |at: usize, len: u32| at.checked_add(4)?.checked_add(len as usize);
        let header_start = offset + 4;
        let lengths = u32_at(self.buf, offset).and_then(|header_len| {
            let header_end = ends(offset, header_len)?;
            let data_end = ends(header_end, u32_at(self.buf, header_end)?)?;
            (data_end <= self.buf.len()).then_some((header_end, data_end))
        });
        let Some((header_end, data_end)) = lengths else {
            self.pos = self.buf.len();
            return Some(Err(short));
        };
        let data_start = header_end + 4;
        self.pos = data_end;
        let fields = match Fields::parse(&self.buf[header_start..header_end]) {
            Ok(f) => f,
            Err(what) => {
                self.pos = self.buf.len();
                return Some(Err(RecordError::Bad { offset, what }));
            }
        };
        Some(Ok(Record { offset, fields, data: &self.buf[data_start..data_end] }))
    }
}

/// The header fields octavar reads (a bag's records may carry others, which are skipped).
#[derive(Debug, Default)]
pub(super) struct Fields<'a> {
    pub(super) op: Option<u8>,
    pub(super) conn: Option<u32>,
    /// `time`: seconds and nanoseconds.
    pub(super) time: Option<(u32, u32)>,
    pub(super) topic: Option<&'a [u8]>,
    /// A connection's message type (in its data block's fields).
    pub(super) kind: Option<&'a [u8]>,
    pub(super) compression: Option<&'a [u8]>,
    pub(super) size: Option<u32>,
    pub(super) index_pos: Option<u64>,
    pub(super) conn_count: Option<u32>,
    pub(super) chunk_count: Option<u32>,
}

impl<'a> Fields<'a> {
    /// Read the fields of a header (or of a connection's data block, which has the same layout).
    pub(super) fn parse(mut b: &'a [u8]) -> Result<Fields<'a>, String> {
        let mut f = Fields::default();
        while !b.is_empty() {
            let Some(len) = u32_at(b, 0) else {
                return Err(format!("{} stray bytes at the end of a header", b.len()));
            };
            let Some(field) = b[4..].get(..len as usize) else {
                return Err(format!("a header field of {len} bytes where {} remain", b.len() - 4));
            };
            b = &b[4 + field.len()..];
            let Some(eq) = field.iter().position(|&c| c == b'=') else {
                return Err(format!("a header field without '=': {:?}", String::from_utf8_lossy(field)));
            };
            let (name, value) = (&field[..eq], &field[eq + 1..]);
            let exact = |n: usize| -> Result<&[u8], String> {
                if value.len() == n {
                    Ok(value)
                } else {
                    Err(format!(
                        "header field {:?} has {} bytes where it takes {n}",
                        String::from_utf8_lossy(name),
                        value.len()
                    ))
                }
            };
            let le32 = |v: &[u8]| u32::from_le_bytes([v[0], v[1], v[2], v[3]]);
            match name {
                b"op" => f.op = Some(exact(1)?[0]),
                b"conn" => f.conn = Some(le32(exact(4)?)),
                b"time" => {
                    let v = exact(8)?;
                    f.time = Some((le32(&v[..4]), le32(&v[4..])));
                }
                b"topic" => f.topic = Some(value),
                b"type" => f.kind = Some(value),
                b"compression" => f.compression = Some(value),
                b"size" => f.size = Some(le32(exact(4)?)),
                b"index_pos" => {
                    let v = exact(8)?;
                    f.index_pos = Some(u64::from(le32(&v[..4])) | (u64::from(le32(&v[4..])) << 32));
                }
                b"conn_count" => f.conn_count = Some(le32(exact(4)?)),
                b"chunk_count" => f.chunk_count = Some(le32(exact(4)?)),
                _ => {}
            }
        }
        Ok(f)
    }
}

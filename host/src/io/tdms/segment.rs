//! The walk over a TDMS file's segments: each segment's lead-in (tag, table of contents, version, lengths) checked
//! against the file, its metadata and raw data handed on, a file whose last segment was never finished read to
//! its end, and every fault located by segment and byte offset. [`FileReader`] holds what the segments so far have
//! said; its metadata, raw data and scaling parts are in the sibling modules.

use std::collections::HashMap;

use super::data::Job;
use super::metadata::{Cursor, Object};
use super::TdmsError;

// The lead-in's table of contents flags.
pub(super) const TOC_META_DATA: u32 = 1 << 1;
pub(super) const TOC_NEW_OBJ_LIST: u32 = 1 << 2;
pub(super) const TOC_RAW_DATA: u32 = 1 << 3;
pub(super) const TOC_INTERLEAVED: u32 = 1 << 5;
pub(super) const TOC_BIG_ENDIAN: u32 = 1 << 6;
pub(super) const TOC_DAQMX_RAW_DATA: u32 = 1 << 7;
/// Bytes of a segment's lead-in: tag, table of contents, version, next segment offset, raw data offset.
const LEAD_IN: usize = 28;
/// The next segment offset of a segment whose writer never finished it: the segment runs to the end of the file.
const LENGTH_UNWRITTEN: u64 = u64::MAX;

/// A fault in a segment, before the file's name and the segment are put to it.
pub(super) enum Fault {
    Corrupt { offset: usize, message: String },
    Truncated { offset: usize, message: String },
    Daqmx { offset: usize, object: String },
    NotNumeric { channel: String, data_type: String },
    Ambiguous { column: String, first: String, second: String },
}

/// The parser's state across segments.
pub(super) struct FileReader<'a> {
    pub(super) bytes: &'a [u8],
    source: &'a str,
    /// Requested column name -> its first slot.
    pub(super) wanted: HashMap<&'a str, usize>,
    pub(super) objects: Vec<Object>,
    pub(super) by_path: HashMap<String, usize>,
    /// The current segment's objects, in order, and whether each has data in it.
    pub(super) list: Vec<(usize, bool)>,
    /// Whether a segment has set the object list.
    have_list: bool,
    /// Where each requested channel's values are, segment by segment.
    pub(super) jobs: Vec<Job>,
    /// Values per slot.
    pub(super) lengths: Vec<usize>,
    /// The object of each slot.
    pub(super) slot_object: Vec<Option<usize>>,
}

impl<'a> FileReader<'a> {
    pub(super) fn new(bytes: &'a [u8], source: &'a str, columns: &'a [String]) -> FileReader<'a> {
        let mut wanted = HashMap::new();
        for (i, c) in columns.iter().enumerate() {
            wanted.entry(c.as_str()).or_insert(i);
        }
        FileReader {
            bytes,
            source,
            wanted,
            objects: Vec::new(),
            by_path: HashMap::new(),
            list: Vec::new(),
            have_list: false,
            jobs: Vec::new(),
            lengths: vec![0; columns.len()],
            slot_object: vec![None; columns.len()],
        }
    }

    /// The file's channels as `group/channel`, in order of appearance.
    pub(super) fn channel_list(&self) -> String {
        const SHOWN: usize = 60;
        let names: Vec<String> = self
            .objects
            .iter()
            .filter_map(|o| Some(format!("{}/{}", o.group.as_ref()?, o.channel.as_ref()?)))
            .collect();
        if names.is_empty() {
            return "no channels".to_string();
        }
        let mut s = names.iter().take(SHOWN).map(String::as_str).collect::<Vec<_>>().join(", ");
        if names.len() > SHOWN {
            s += &format!(" and {} more", names.len() - SHOWN);
        }
        s
    }

    /// Walk every segment, decoding the requested channels.
    pub(super) fn read_segments(&mut self) -> Result<(), TdmsError> {
        let len = self.bytes.len();
        let start = &self.bytes[..len.min(4)];
        if start == b"TDSh" {
            return Err(TdmsError::IndexFile { path: self.source.to_string() });
        }
        // A file cut inside its first tag is a truncated TDMS file, not another kind of file.
        if len == 0 || !b"TDSm".starts_with(start) {
            let start = if len == 0 { "nothing: the file is empty".to_string() } else { show_bytes(start) };
            return Err(TdmsError::NotTdms { path: self.source.to_string(), start });
        }
        let mut pos = 0usize;
        let mut segment = 1usize;
        while pos < len {
            match self.read_segment(pos, segment) {
                Ok(next) => pos = next,
                Err(fault) => return Err(self.locate(fault, segment, pos)),
            }
            segment += 1;
        }
        Ok(())
    }

    /// The error for a fault in the segment that starts at `start`.
    fn locate(&self, fault: Fault, segment: usize, start: usize) -> TdmsError {
        let path = self.source.to_string();
        let start = start as u64;
        match fault {
            Fault::Corrupt { offset, message } => {
                TdmsError::Corrupt { path, segment, start, offset: offset as u64, message }
            }
            Fault::Truncated { offset, message } => {
                TdmsError::Truncated { path, segment, start, offset: offset as u64, message }
            }
            Fault::Daqmx { offset, object } => TdmsError::Daqmx { path, segment, offset: offset as u64, object },
            Fault::NotNumeric { channel, data_type } => TdmsError::NotNumeric { path, channel, data_type },
            Fault::Ambiguous { column, first, second } => TdmsError::Ambiguous { path, column, first, second },
        }
    }

    /// Read the segment at `pos`; the position of the next one.
    fn read_segment(&mut self, pos: usize, segment: usize) -> Result<usize, Fault> {
        let bytes = self.bytes;
        let len = bytes.len();
        let corrupt = |offset: usize, message: String| Fault::Corrupt { offset, message };
        if len - pos < LEAD_IN {
            return Err(Fault::Truncated {
                offset: len,
                message: format!("the file ends {} bytes into the segment's {LEAD_IN}-byte lead-in", len - pos),
            });
        }
        let tag = &bytes[pos..pos + 4];
        if tag != b"TDSm" {
            return Err(corrupt(
                pos,
                format!(
                    "no segment tag \"TDSm\" (found {}){}",
                    show_bytes(tag),
                    if segment > 1 { "; the previous segment's length is wrong, or the file is damaged" } else { "" }
                ),
            ));
        }
        let toc = u32::from_le_bytes(bytes[pos + 4..pos + 8].try_into().unwrap_or([0; 4]));
        let mut lead = Cursor { bytes, pos: pos + 8, end: pos + LEAD_IN, big: toc & TOC_BIG_ENDIAN != 0 };
        let version = lead.u32("the version")?;
        let next_offset = lead.u64("the next segment offset")?;
        let raw_offset = lead.u64("the raw data offset")?;
        if version != 4712 && version != 4713 {
            return Err(corrupt(pos + 8, format!("version {version} is not a TDMS version (4712 or 4713)")));
        }
        let meta_start = pos + LEAD_IN;
        let unwritten = next_offset == LENGTH_UNWRITTEN;
        let end = if unwritten {
            len
        } else {
            match usize::try_from(next_offset).ok().and_then(|n| meta_start.checked_add(n)) {
                Some(end) if end <= len => end,
                _ => {
                    return Err(Fault::Truncated {
                        offset: len,
                        message: format!(
                            "the segment's lead-in says {next_offset} bytes follow it, but the file ends {} bytes \
                             after it",
                            len - meta_start
                        ),
                    })
                }
            }
        };
        let data_start = match usize::try_from(raw_offset).ok().and_then(|n| meta_start.checked_add(n)) {
            Some(d) if d <= end => d,
            _ => {
                return Err(corrupt(
                    pos + 20,
                    format!(
                        "the raw data offset {raw_offset} is past the segment's end ({} bytes after the lead-in)",
                        end - meta_start
                    ),
                ))
            }
        };
        if toc & TOC_META_DATA != 0 {
            let new_list = toc & TOC_NEW_OBJ_LIST != 0 || !self.have_list;
            let mut cur = Cursor { bytes, pos: meta_start, end: data_start, big: toc & TOC_BIG_ENDIAN != 0 };
            self.read_metadata(&mut cur, new_list)?;
            self.have_list = true;
        } else if toc & TOC_RAW_DATA != 0 && !self.have_list {
            return Err(corrupt(pos + 4, "raw data without metadata, and no earlier segment to take it from".into()));
        }
        if toc & TOC_RAW_DATA != 0 {
            self.read_data(toc, data_start, end, unwritten)?;
        } else if toc & TOC_DAQMX_RAW_DATA != 0 {
            let object = self.list.iter().find(|e| e.1).map_or_else(|| "a channel".to_string(), |e| self.name(e.0));
            return Err(Fault::Daqmx { offset: data_start, object });
        }
        Ok(end)
    }

    /// An object's name for errors: `group/channel`, or its path.
    pub(super) fn name(&self, id: usize) -> String {
        let o = &self.objects[id];
        match (&o.group, &o.channel) {
            (Some(g), Some(c)) => format!("channel \"{g}/{c}\""),
            _ => format!("object {}", o.path),
        }
    }
}

/// The first bytes of a file, for an error.
fn show_bytes(b: &[u8]) -> String {
    if b.iter().all(|c| c.is_ascii_graphic() || *c == b' ') {
        format!("{:?}", String::from_utf8_lossy(b))
    } else {
        b.iter().map(|c| format!("{c:02x}")).collect::<Vec<_>>().join(" ")
    }
}

//! The walk over a TDMS file's segments: each segment's lead-in (tag, table of contents, version, lengths) checked
//! against the file, its metadata and raw data handed on, a file whose last segment was never finished read to
//! its end, and every fault located by segment and byte offset. [`FileReader`] holds what the segments so far have
//! said: it reads each segment's object list and properties (with the types of [`super::metadata`]) and where each
//! requested channel's values lie in its raw data ([`super::data`] decodes them).

use std::collections::HashMap;

use super::data::*;
use super::format::*;
use super::metadata::*;
use super::TdmsError;

/// Bytes of a segment's lead-in: tag, table of contents, version, next segment offset, raw data offset.
const LEAD_IN: usize = 28;
/// The next segment offset of a segment whose writer never finished it: the segment runs to the end of the file.
const LENGTH_UNWRITTEN: u64 = u64::MAX;

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

impl FileReader<'_> {
    /// The object with this path, registered on first sight.
    fn object_id(&mut self, path: String, at: usize) -> Result<usize, Fault> {
        if let Some(&id) = self.by_path.get(&path) {
            return Ok(id);
        }
        let Some((group, channel)) = parse_path(&path) else {
            return Err(Fault::Corrupt { offset: at, message: format!("{path:?} is not a TDMS object path") });
        };
        let mut slot = None;
        if let (Some(g), Some(c)) = (&group, &channel) {
            let display = format!("{g}/{c}");
            if let Some(&s) = self.wanted.get(display.as_str()) {
                if let Some(other) = self.slot_object[s] {
                    return Err(Fault::Ambiguous {
                        column: display,
                        first: self.objects[other].path.clone(),
                        second: path,
                    });
                }
                slot = Some(s);
            }
        }
        let id = self.objects.len();
        if let Some(s) = slot {
            self.slot_object[s] = Some(id);
        }
        self.by_path.insert(path.clone(), id);
        self.objects.push(Object { path, group, channel, props: HashMap::new(), index: None, slot, in_list: None });
        Ok(id)
    }

    /// Read a segment's metadata, updating the object list and the objects' indexes and properties.
    pub(super) fn read_metadata(&mut self, cur: &mut Cursor, new_list: bool) -> Result<(), Fault> {
        if new_list {
            for &(id, _) in &self.list {
                self.objects[id].in_list = None;
            }
            self.list.clear();
        }
        let count = cur.u32("the object count")?;
        for _ in 0..count {
            let at = cur.pos;
            let path = cur.string("an object path")?;
            let id = self.object_id(path, at)?;
            let index_at = cur.pos;
            let header = cur.u32("a raw data index")?;
            let has_data = match header {
                INDEX_NO_DATA => false,
                INDEX_SAME_AS_PREVIOUS => {
                    if self.objects[id].index.is_none() {
                        return Err(Fault::Corrupt {
                            offset: index_at,
                            message: format!(
                                "{} reuses the previous raw data index, but none came before",
                                self.name(id)
                            ),
                        });
                    }
                    true
                }
                INDEX_DAQMX_FORMAT_CHANGING | INDEX_DAQMX_DIGITAL_LINE => {
                    return Err(Fault::Daqmx { offset: index_at, object: self.name(id) })
                }
                _ => {
                    let data_type = cur.u32("a data type")?;
                    let dimension = cur.u32("an array dimension")?;
                    let values = cur.u64("a value count")?;
                    if data_type == TYPE_DAQMX {
                        return Err(Fault::Daqmx { offset: index_at, object: self.name(id) });
                    }
                    if data_type == 0 && values != 0 {
                        return Err(Fault::Corrupt {
                            offset: index_at + 4,
                            message: format!("{} has {values} values of type void", self.name(id)),
                        });
                    }
                    if dimension != 1 {
                        return Err(Fault::Corrupt {
                            offset: index_at + 8,
                            message: format!(
                                "{} has array dimension {dimension}, where TDMS has only 1",
                                self.name(id)
                            ),
                        });
                    }
                    let bytes = if data_type == TYPE_STRING {
                        cur.u64("a string data size")?
                    } else if values == 0 {
                        0
                    } else {
                        match type_size(data_type).and_then(|s| s.checked_mul(values)) {
                            Some(b) => b,
                            None => {
                                return Err(Fault::Corrupt {
                                    offset: index_at + 4,
                                    message: format!(
                                        "{} has {values} values of type {}, whose size is unknown or too large",
                                        self.name(id),
                                        type_name(data_type)
                                    ),
                                })
                            }
                        }
                    };
                    self.objects[id].index = Some(RawIndex { data_type, values, bytes });
                    true
                }
            };
            match self.objects[id].in_list {
                Some(i) => self.list[i].1 = has_data,
                None => {
                    self.objects[id].in_list = Some(self.list.len());
                    self.list.push((id, has_data));
                }
            }
            let props = cur.u32("a property count")?;
            for _ in 0..props {
                let name = cur.string("a property name")?;
                let code = cur.u32("a property's data type")?;
                let value = cur.prop(code, &name)?;
                self.objects[id].props.insert(name, value);
            }
        }
        Ok(())
    }
}

impl FileReader<'_> {
    /// Decode the requested channels' values in the raw data `start..end` of a segment.
    pub(super) fn read_data(&mut self, toc: u32, start: usize, end: usize, unwritten: bool) -> Result<(), Fault> {
        let (with_data, chunk) = self.objects_with_data(start)?;
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
        self.check_numeric(&with_data)?;
        let big = toc & TOC_BIG_ENDIAN != 0;
        if toc & TOC_INTERLEAVED != 0 {
            let width = self.row_width(&with_data, start)?;
            self.interleaved_jobs(&with_data, big, start, end, width);
        } else if chunks > 0 {
            self.chunked_jobs(&with_data, big, start, chunks, chunk);
        }
        Ok(())
    }

    /// The current segment's objects with values in it, and the bytes of one chunk (all their values).
    fn objects_with_data(&self, start: usize) -> Result<(Vec<(usize, RawIndex)>, u64), Fault> {
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
        Ok((with_data, chunk))
    }

    /// An error for a requested channel among `with_data` whose values are not numbers.
    fn check_numeric(&self, with_data: &[(usize, RawIndex)]) -> Result<(), Fault> {
        for &(id, index) in with_data {
            let o = &self.objects[id];
            if o.slot.is_some() && !is_numeric(index.data_type) {
                return Err(Fault::NotNumeric {
                    channel: format!("{}/{}", o.group.as_deref().unwrap_or(""), o.channel.as_deref().unwrap_or("")),
                    data_type: type_name(index.data_type),
                });
            }
        }
        Ok(())
    }

    /// The bytes of a row of interleaved data; channels of unequal lengths, or without a fixed size, are errors.
    fn row_width(&self, with_data: &[(usize, RawIndex)], start: usize) -> Result<usize, Fault> {
        let values = with_data[0].1.values;
        let mut width = 0usize;
        for &(id, index) in with_data {
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
        Ok(width)
    }

    /// The jobs of the requested channels in interleaved data `start..end`, rows of `width` bytes.
    fn interleaved_jobs(&mut self, with_data: &[(usize, RawIndex)], big: bool, start: usize, end: usize, width: usize) {
        // Whole rows only: an unfinished segment may stop inside a chunk.
        let rows = (end - start) / width;
        let mut offset = start;
        for &(id, index) in with_data {
            if let Some(slot) = self.objects[id].slot {
                let data_type = index.data_type;
                let job =
                    Job { slot, data_type, big, start: offset, stride: width, count: rows, runs: 1, run_stride: 0 };
                self.add(job);
            }
            offset += type_size(index.data_type).unwrap_or(0) as usize;
        }
    }

    /// The jobs of the requested channels in `chunks` chunks of `chunk` bytes from `start` (not interleaved).
    fn chunked_jobs(&mut self, with_data: &[(usize, RawIndex)], big: bool, start: usize, chunks: u64, chunk: u64) {
        // Every value counted here lies inside `start..end`, so the sizes fit in usize.
        let mut offset = start;
        for &(id, index) in with_data {
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

    fn add(&mut self, job: Job) {
        self.lengths[job.slot] += job.count * job.runs;
        self.jobs.push(job);
    }
}

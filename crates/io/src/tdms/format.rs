//! The TDMS lead-in's table of contents flags, and a fault found in a segment before it is located in the
//! file.

// The lead-in's table of contents flags.
pub(super) const TOC_META_DATA: u32 = 1 << 1;
pub(super) const TOC_NEW_OBJ_LIST: u32 = 1 << 2;
pub(super) const TOC_RAW_DATA: u32 = 1 << 3;
pub(super) const TOC_INTERLEAVED: u32 = 1 << 5;
pub(super) const TOC_BIG_ENDIAN: u32 = 1 << 6;
pub(super) const TOC_DAQMX_RAW_DATA: u32 = 1 << 7;

/// A fault in a segment, before the file's name and the segment are put to it.
pub(super) enum Fault {
    Corrupt { offset: usize, message: String },
    Truncated { offset: usize, message: String },
    Daqmx { offset: usize, object: String },
    NotNumeric { channel: String, data_type: String },
    Ambiguous { column: String, first: String, second: String },
}

//! A segment's metadata: the object list (root, groups, channels by their TDMS paths), each object's raw data
//! index (new, "same as previous", or none in this segment) and its properties, read with a bounded [`Cursor`] in
//! the segment's byte order and carried over from segment to segment in the [`FileReader`].

use std::collections::HashMap;

use super::data::{type_name, TYPE_STRING};
use super::format::Fault;

// Raw data index headers with a meaning of their own.
pub(super) const INDEX_NO_DATA: u32 = 0xFFFF_FFFF;
pub(super) const INDEX_SAME_AS_PREVIOUS: u32 = 0;
pub(super) const INDEX_DAQMX_FORMAT_CHANGING: u32 = 0x6912_0000;
pub(super) const INDEX_DAQMX_DIGITAL_LINE: u32 = 0x6913_0000;

/// A property's value.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Prop {
    /// Any integer or real number.
    Num(f64),
    /// A string.
    Str(String),
    /// A value octavar has no use for (boolean, time stamp, complex), by type name.
    Other(&'static str),
}

impl Prop {
    pub(super) fn num(&self) -> Option<f64> {
        match self {
            Prop::Num(v) => Some(*v),
            _ => None,
        }
    }

    pub(super) fn show(&self) -> String {
        match self {
            Prop::Num(v) => v.to_string(),
            Prop::Str(s) => format!("{s:?}"),
            Prop::Other(t) => format!("a {t}"),
        }
    }
}

/// Where an object's values are in each chunk of a segment with data.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct RawIndex {
    pub(super) data_type: u32,
    pub(super) values: u64,
    pub(super) bytes: u64,
}

/// One object (root, group or channel) of the file, with what the segments so far have said about it.
#[derive(Debug)]
pub(super) struct Object {
    pub(super) path: String,
    /// Group and channel names; the channel is `None` for the root and for a group.
    pub(super) group: Option<String>,
    pub(super) channel: Option<String>,
    pub(super) props: HashMap<String, Prop>,
    /// The latest raw data index, which a later "same as previous" index reuses.
    pub(super) index: Option<RawIndex>,
    /// The requested column whose series this channel's values go to.
    pub(super) slot: Option<usize>,
    /// Position in the current segment's object list.
    pub(super) in_list: Option<usize>,
}

/// A bounded reader of a segment's metadata.
pub(super) struct Cursor<'a> {
    pub(super) bytes: &'a [u8],
    pub(super) pos: usize,
    pub(super) end: usize,
    pub(super) big: bool,
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], Fault> {
        if self.end - self.pos < n {
            return Err(Fault::Corrupt {
                offset: self.pos,
                message: format!("{what} needs {n} bytes, but the segment's metadata has {} left", self.end - self.pos),
            });
        }
        let s = &self.bytes[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    fn array<const N: usize>(&mut self, what: &str) -> Result<[u8; N], Fault> {
        let mut a: [u8; N] = self.take(N, what)?.try_into().unwrap_or([0; N]);
        if self.big {
            a.reverse();
        }
        Ok(a)
    }

    pub(super) fn u32(&mut self, what: &str) -> Result<u32, Fault> {
        self.array::<4>(what).map(u32::from_le_bytes)
    }

    pub(super) fn u64(&mut self, what: &str) -> Result<u64, Fault> {
        self.array::<8>(what).map(u64::from_le_bytes)
    }

    pub(super) fn string(&mut self, what: &str) -> Result<String, Fault> {
        let at = self.pos;
        let n = self.u32(what)? as usize;
        if self.end - self.pos < n {
            return Err(Fault::Corrupt {
                offset: at,
                message: format!("{what} of {n} bytes runs past the segment's metadata"),
            });
        }
        Ok(String::from_utf8_lossy(self.take(n, what)?).into_owned())
    }

    /// A property value of data type `code`.
    pub(super) fn prop(&mut self, code: u32, name: &str) -> Result<Prop, Fault> {
        let what = format!("property {name:?}");
        let at = self.pos;
        Ok(match code {
            1 => Prop::Num(f64::from(i8::from_le_bytes(self.array::<1>(&what)?))),
            2 => Prop::Num(f64::from(i16::from_le_bytes(self.array::<2>(&what)?))),
            3 => Prop::Num(f64::from(i32::from_le_bytes(self.array::<4>(&what)?))),
            4 => Prop::Num(i64::from_le_bytes(self.array::<8>(&what)?) as f64),
            5 => Prop::Num(f64::from(self.array::<1>(&what)?[0])),
            6 => Prop::Num(f64::from(u16::from_le_bytes(self.array::<2>(&what)?))),
            7 => Prop::Num(f64::from(u32::from_le_bytes(self.array::<4>(&what)?))),
            8 => Prop::Num(u64::from_le_bytes(self.array::<8>(&what)?) as f64),
            9 | 0x19 => Prop::Num(f64::from(f32::from_le_bytes(self.array::<4>(&what)?))),
            10 | 0x1A => Prop::Num(f64::from_le_bytes(self.array::<8>(&what)?)),
            TYPE_STRING => Prop::Str(self.string(&what)?),
            0x21 => {
                self.take(1, &what)?;
                Prop::Other("boolean")
            }
            0x44 => {
                self.take(16, &what)?;
                Prop::Other("time stamp")
            }
            0x08_000C => {
                self.take(8, &what)?;
                Prop::Other("complex f32")
            }
            0x10_000D => {
                self.take(16, &what)?;
                Prop::Other("complex f64")
            }
            other => {
                return Err(Fault::Corrupt {
                    offset: at,
                    message: format!("property {name:?} has data type {}, which has no known size", type_name(other)),
                })
            }
        })
    }
}

/// The TDMS path of the root (`None`) or a group.
pub(super) fn object_path(group: Option<&str>) -> String {
    match group {
        None => "/".to_string(),
        Some(g) => format!("/'{}'", g.replace('\'', "''")),
    }
}

/// Split an object path (`/`, `/'group'`, `/'group'/'channel'`, a quote inside a name doubled) into its group and
/// channel names; `None` where it is not one.
pub(super) fn parse_path(path: &str) -> Option<(Option<String>, Option<String>)> {
    let mut names = Vec::new();
    let mut chars = path.chars().peekable();
    if path == "/" {
        return Some((None, None));
    }
    while chars.peek().is_some() {
        if chars.next()? != '/' || chars.next()? != '\'' {
            return None;
        }
        let mut name = String::new();
        loop {
            match chars.next()? {
                '\'' if chars.peek() == Some(&'\'') => {
                    chars.next();
                    name.push('\'');
                }
                '\'' => break,
                c => name.push(c),
            }
        }
        names.push(name);
    }
    let mut names = names.into_iter();
    match (names.next(), names.next(), names.next()) {
        (Some(g), c, None) => Some((Some(g), c)),
        _ => None,
    }
}

//! A TDMS writer written from NI's description of the format, enough to build every case the reader handles, with
//! the helpers the tests make values with and compare them by.

use crate::recording::{RateUnit, Recording};
use crate::tdms::data::TYPE_STRING;
use crate::tdms::format::{TOC_BIG_ENDIAN, TOC_INTERLEAVED, TOC_META_DATA, TOC_NEW_OBJ_LIST, TOC_RAW_DATA};
use crate::tdms::metadata::{INDEX_DAQMX_FORMAT_CHANGING, INDEX_NO_DATA, INDEX_SAME_AS_PREVIOUS};
use crate::tdms::{read_bytes, TdmsError};

/// A raw data index to write.
#[derive(Clone, Copy)]
pub(super) enum Ix {
    NoData,
    Same,
    New(u32, u64),
    /// A string channel: value count and total bytes.
    Strings(u64, u64),
    Daqmx,
}

/// A property value to write.
pub(super) enum Pv {
    I32(i32),
    U32(u32),
    F64(f64),
    Str(&'static str),
    Bool,
    Time,
}

pub(super) struct Obj {
    path: String,
    index: Ix,
    props: Vec<(String, Pv)>,
}

pub(super) fn obj(path: &str, index: Ix, props: Vec<(&str, Pv)>) -> Obj {
    Obj { path: path.to_string(), index, props: props.into_iter().map(|(k, v)| (k.to_string(), v)).collect() }
}

pub(super) fn chan(group: &str, channel: &str) -> String {
    format!("/'{group}'/'{channel}'")
}

struct W {
    out: Vec<u8>,
    big: bool,
}

impl W {
    fn u32(&mut self, v: u32) {
        self.out.extend(if self.big { v.to_be_bytes() } else { v.to_le_bytes() });
    }
    fn u64(&mut self, v: u64) {
        self.out.extend(if self.big { v.to_be_bytes() } else { v.to_le_bytes() });
    }
    fn str(&mut self, s: &str) {
        self.u32(s.len() as u32);
        self.out.extend(s.as_bytes());
    }
}

fn metadata(objs: &[Obj], big: bool) -> Vec<u8> {
    let mut w = W { out: Vec::new(), big };
    w.u32(objs.len() as u32);
    for o in objs {
        w.str(&o.path);
        match o.index {
            Ix::NoData => w.u32(INDEX_NO_DATA),
            Ix::Same => w.u32(INDEX_SAME_AS_PREVIOUS),
            Ix::Daqmx => w.u32(INDEX_DAQMX_FORMAT_CHANGING),
            Ix::New(t, n) => {
                w.u32(20);
                w.u32(t);
                w.u32(1);
                w.u64(n);
            }
            Ix::Strings(n, bytes) => {
                w.u32(28);
                w.u32(TYPE_STRING);
                w.u32(1);
                w.u64(n);
                w.u64(bytes);
            }
        }
        w.u32(o.props.len() as u32);
        for (k, v) in &o.props {
            w.str(k);
            match v {
                Pv::I32(x) => {
                    w.u32(3);
                    w.u32(*x as u32);
                }
                Pv::U32(x) => {
                    w.u32(7);
                    w.u32(*x);
                }
                Pv::F64(x) => {
                    w.u32(10);
                    w.u64(x.to_bits());
                }
                Pv::Str(s) => {
                    w.u32(TYPE_STRING);
                    w.str(s);
                }
                Pv::Bool => {
                    w.u32(0x21);
                    w.out.push(1);
                }
                Pv::Time => {
                    w.u32(0x44);
                    w.out.extend([7u8; 16]);
                }
            }
        }
    }
    w.out
}

/// A segment: lead-in, metadata (when `objs` is given), raw data.
pub(super) fn segment(toc: u32, objs: Option<&[Obj]>, data: &[u8]) -> Vec<u8> {
    let big = toc & TOC_BIG_ENDIAN != 0;
    let meta = objs.map(|o| metadata(o, big)).unwrap_or_default();
    let toc = toc | if objs.is_some() { TOC_META_DATA } else { 0 } | if data.is_empty() { 0 } else { TOC_RAW_DATA };
    let mut w = W { out: b"TDSm".to_vec(), big };
    w.out.extend(toc.to_le_bytes());
    w.u32(4713);
    w.u64((meta.len() + data.len()) as u64);
    w.u64(meta.len() as u64);
    w.out.extend(meta);
    w.out.extend(data);
    w.out
}

pub(super) fn f64s(v: &[f64], big: bool) -> Vec<u8> {
    v.iter().flat_map(|x| if big { x.to_be_bytes() } else { x.to_le_bytes() }).collect()
}

pub(super) fn i16s(v: &[i16], big: bool) -> Vec<u8> {
    v.iter().flat_map(|x| if big { x.to_be_bytes() } else { x.to_le_bytes() }).collect()
}

/// Rows of interleaved (f64, i16) values.
pub(super) fn rows(a: &[f64], b: &[i16], big: bool) -> Vec<u8> {
    a.iter().zip(b).flat_map(|(x, y)| [f64s(&[*x], big), i16s(&[*y], big)].concat()).collect()
}

pub(super) fn read(bytes: &[u8], cols: &[&str], rate: Option<f64>) -> Result<Recording, TdmsError> {
    let cols: Vec<String> = cols.iter().map(|s| s.to_string()).collect();
    read_bytes(bytes, "test.tdms", &cols, RateUnit::DegPerS, rate)
}

pub(super) fn seq_f64(from: usize, n: usize) -> Vec<f64> {
    (from..from + n).map(|i| (i as f64 * 0.37).sin() * 100.0 + 0.125).collect()
}

pub(super) fn seq_i16(from: usize, n: usize) -> Vec<i16> {
    (from..from + n).map(|i| ((i * 7919) % 65536) as u16 as i16).collect()
}

pub(super) fn as_f64(v: &[i16]) -> Vec<f64> {
    v.iter().map(|&x| f64::from(x)).collect()
}

pub(super) fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// The first segment of most cases: root and group with properties of every kind, channels a (f64) and b
/// (i16), `n` values each, 10 ms apart.
pub(super) fn first_segment(a: &[f64], b: &[i16], toc: u32) -> Vec<u8> {
    let big = toc & TOC_BIG_ENDIAN != 0;
    let n = a.len() as u64;
    let objs = [
        obj(
            "/",
            Ix::NoData,
            vec![
                ("name", Pv::Str("hand-built")),
                ("flag", Pv::Bool),
                ("when", Pv::Time),
                ("count", Pv::I32(-3)),
                ("u", Pv::U32(7)),
            ],
        ),
        obj("/'g'", Ix::NoData, vec![("gain", Pv::F64(2.0))]),
        obj(&chan("g", "a"), Ix::New(10, n), vec![("wf_increment", Pv::F64(0.01)), ("unit_string", Pv::Str("deg/s"))]),
        obj(&chan("g", "b"), Ix::New(2, n), vec![("wf_increment", Pv::F64(0.01))]),
    ];
    let data = if toc & TOC_INTERLEAVED != 0 { rows(a, b, big) } else { [f64s(a, big), i16s(b, big)].concat() };
    segment(toc | TOC_NEW_OBJ_LIST, Some(&objs), &data)
}

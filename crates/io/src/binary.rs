//! Raw little-endian samples (f64, f32, i16, u16): the formats `--format` names and how one sample decodes.

/// Raw little-endian sample formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BinaryFormat {
    /// IEEE 754 double.
    F64,
    /// IEEE 754 single.
    F32,
    /// Signed 16-bit integer.
    I16,
    /// Unsigned 16-bit integer (ADC codes).
    U16,
}

impl BinaryFormat {
    /// Parse `f64le`, `f32le`, `i16le`, `u16le`.
    pub fn parse(name: &str) -> Option<BinaryFormat> {
        Some(match name.trim().to_ascii_lowercase().as_str() {
            "f64le" | "f64" => BinaryFormat::F64,
            "f32le" | "f32" => BinaryFormat::F32,
            "i16le" | "i16" => BinaryFormat::I16,
            "u16le" | "u16" => BinaryFormat::U16,
            _ => return None,
        })
    }

    /// Bytes per sample.
    pub fn size(self) -> usize {
        match self {
            BinaryFormat::F64 => 8,
            BinaryFormat::F32 => 4,
            BinaryFormat::I16 | BinaryFormat::U16 => 2,
        }
    }

    /// The name, as parsed.
    pub fn name(self) -> &'static str {
        match self {
            BinaryFormat::F64 => "f64le",
            BinaryFormat::F32 => "f32le",
            BinaryFormat::I16 => "i16le",
            BinaryFormat::U16 => "u16le",
        }
    }

    /// One sample of this format from its little-endian bytes (`b` holds exactly one).
    pub fn decode(self, b: &[u8]) -> f64 {
        match self {
            BinaryFormat::F64 => f64::from_le_bytes(b.try_into().unwrap_or([0; 8])),
            BinaryFormat::F32 => f64::from(f32::from_le_bytes(b.try_into().unwrap_or([0; 4]))),
            BinaryFormat::I16 => f64::from(i16::from_le_bytes(b.try_into().unwrap_or([0; 2]))),
            BinaryFormat::U16 => f64::from(u16::from_le_bytes(b.try_into().unwrap_or([0; 2]))),
        }
    }
}

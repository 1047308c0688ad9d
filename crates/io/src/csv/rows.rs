//! CSV rows without silent misreads: the dialect (delimiter, decimal comma) detected from the file or given, a
//! byte-order mark and CRLF line ends accepted, each line split into its cells, and numbers parsed: plain decimals
//! by [`parse_plain`] (Clinger's exact fast path, eight digits at a time), everything else with `fast-float2` (a
//! decimal comma read as a point where the dialect has one).
//!
//! The reader in [`crate::csv`] hands whole blocks of lines to [`parse_plain`], [`split`] and
//! [`parse_number`] on every core; this module only knows one cell or line at a time. Quoted cells (`"a,b"`, with `""` for a quote) are understood; a
//! quoted cell that runs over a line end is not (a numeric recording has none), and is reported as an error.

use std::fmt;

/// What separates the cells of a line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Delimiter {
    /// One byte: `,` `;` or a tab.
    Byte(u8),
    /// Any run of spaces and tabs (and none at the ends), as in many loggers' text exports.
    Whitespace,
}

impl Delimiter {
    /// Parse a `--delimiter` value: `,` `;` `tab` (or a tab character, or `\t`), `whitespace` (or `space`).
    ///
    /// # Errors
    /// A message listing the accepted values.
    pub fn parse(text: &str) -> Result<Delimiter, String> {
        match text {
            "," | "comma" => Ok(Delimiter::Byte(b',')),
            ";" | "semicolon" => Ok(Delimiter::Byte(b';')),
            "\t" | "\\t" | "tab" => Ok(Delimiter::Byte(b'\t')),
            " " | "space" | "whitespace" => Ok(Delimiter::Whitespace),
            "|" | "pipe" => Ok(Delimiter::Byte(b'|')),
            other => Err(format!("delimiter {other:?} is not one of , ; tab whitespace |")),
        }
    }
}

impl fmt::Display for Delimiter {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Delimiter::Byte(b'\t') => f.write_str("tab"),
            Delimiter::Byte(b) => write!(f, "'{}'", char::from(*b)),
            Delimiter::Whitespace => f.write_str("whitespace"),
        }
    }
}

/// How a file writes its rows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Dialect {
    /// Between cells.
    pub delimiter: Delimiter,
    /// Numbers are written `1,25` rather than `1.25`.
    pub decimal_comma: bool,
}

impl Dialect {
    /// The delimiter of a header line: the most frequent of `,` `;` tab (counting only outside quotes), else
    /// whitespace if the line has several words, else `None`: a one-field header says nothing about it.
    pub fn detect_delimiter(header: &str) -> Option<Delimiter> {
        let mut counts = [(b',', 0usize), (b';', 0), (b'\t', 0)];
        let mut quoted = false;
        for b in header.bytes() {
            if b == b'"' {
                quoted = !quoted;
            } else if !quoted {
                for (d, n) in counts.iter_mut() {
                    if b == *d {
                        *n += 1;
                    }
                }
            }
        }
        // Ties go to the earlier of , ; tab.
        let (best, n) = counts.iter().fold((b',', 0), |acc, &(d, n)| if n > acc.1 { (d, n) } else { acc });
        if n > 0 {
            Some(Delimiter::Byte(best))
        } else if header.split_whitespace().nth(1).is_some() {
            Some(Delimiter::Whitespace)
        } else {
            None
        }
    }

    /// Whether data rows written with `delimiter` use a decimal comma: the delimiter is not a comma, and every
    /// non-empty cell of the first rows that holds a comma holds exactly one and reads as a number with it taken
    /// for a point, with at least one such cell.
    pub fn detect_decimal_comma(delimiter: Delimiter, rows: &[&str]) -> bool {
        if delimiter == Delimiter::Byte(b',') {
            return false;
        }
        let mut cells = Vec::new();
        let mut seen = 0;
        for row in rows {
            if split(row, delimiter, &mut cells).is_err() {
                return false;
            }
            for cell in &cells {
                match cell.bytes().filter(|&b| b == b',').count() {
                    0 => {}
                    1 if parse_number(cell, true).is_some() => seen += 1,
                    _ => return false,
                }
            }
        }
        seen > 0
    }
}

/// Why a line could not be split.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SplitError {
    /// A quote opened and not closed on this line.
    UnclosedQuote,
}

impl fmt::Display for SplitError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SplitError::UnclosedQuote => f.write_str("a quoted cell is not closed on its line"),
        }
    }
}

/// Split `line` (no line end) into its cells, trimmed of spaces; quotes around a cell are removed (a cell with an
/// escaped `""` keeps one `"` per pair, as far as a numeric reader cares: it is then not a number).
///
/// # Errors
/// [`SplitError::UnclosedQuote`].
pub fn split<'a>(line: &'a str, delimiter: Delimiter, out: &mut Vec<&'a str>) -> Result<(), SplitError> {
    out.clear();
    match delimiter {
        Delimiter::Whitespace => out.extend(line.split_ascii_whitespace()),
        Delimiter::Byte(d) => {
            let bytes = line.as_bytes();
            let mut start = 0;
            // One pass over the line for delimiters and quotes; a quote sends the line to the careful splitter.
            for i in memchr::memchr2_iter(d, b'"', bytes) {
                if bytes[i] == b'"' {
                    return split_quoted(line, d, out);
                }
                out.push(line[start..i].trim_ascii());
                start = i + 1;
            }
            out.push(line[start..].trim_ascii());
        }
    }
    Ok(())
}

/// [`split`] for a line with quotes.
fn split_quoted<'a>(line: &'a str, d: u8, out: &mut Vec<&'a str>) -> Result<(), SplitError> {
    out.clear();
    let bytes = line.as_bytes();
    let mut start = 0;
    let mut quoted = false;
    for (i, &b) in bytes.iter().enumerate() {
        if b == b'"' {
            quoted = !quoted;
        } else if b == d && !quoted {
            out.push(unquote(&line[start..i]));
            start = i + 1;
        }
    }
    if quoted {
        return Err(SplitError::UnclosedQuote);
    }
    out.push(unquote(&line[start..]));
    Ok(())
}

fn unquote(cell: &str) -> &str {
    let t = cell.trim_ascii();
    t.strip_prefix('"').and_then(|s| s.strip_suffix('"')).map_or(t, str::trim_ascii)
}

/// A cell as a number: `None` if it is not one. With `decimal_comma`, one comma stands for the point (and a point
/// is then not accepted, so `1.234,5` is not silently read as 1.2345).
pub fn parse_number(cell: &str, decimal_comma: bool) -> Option<f64> {
    if !decimal_comma {
        return fast_float2::parse::<f64, _>(cell).ok();
    }
    let bytes = cell.as_bytes();
    if bytes.len() > 64 || bytes.contains(&b'.') {
        return None;
    }
    let mut buf = [0u8; 64];
    for (o, &b) in buf.iter_mut().zip(bytes) {
        *o = if b == b',' { b'.' } else { b };
    }
    fast_float2::parse::<f64, _>(&buf[..bytes.len()]).ok()
}

/// Powers of ten that an `f64` holds exactly: the range of the fast path in [`parse_plain`].
const EXACT_POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20,
    1e21, 1e22,
];

/// A plain decimal number at the start of `bytes` (`-1.25`, `4.569959756e-01`, `.5`, `3.`), with `decimal` as its
/// point: the value and the bytes it took, or `None` for anything else (a sign or digits with nothing after,
/// `inf`, more than 19 significant digits, a long exponent), which the caller hands to [`parse_number`].
///
/// With at most 2^53 as the digits and a power of ten up to 22 either way, both are exact in an `f64` and one
/// multiplication or division rounds correctly (Clinger's fast path), so the value is the one [`parse_number`]
/// gives; other digit strings go to `fast-float2`.
#[inline]
pub fn parse_plain(bytes: &[u8], decimal: u8) -> Option<(f64, usize)> {
    let mut i = 0;
    let negative = match bytes.first() {
        Some(b'-') => {
            i = 1;
            true
        }
        Some(b'+') => {
            i = 1;
            false
        }
        _ => false,
    };
    let mut mantissa = 0u64;
    let int_digits = digit_run(bytes, &mut i, &mut mantissa)?;
    let mut scale = 0i32;
    let mut digits = int_digits;
    if bytes.get(i) == Some(&decimal) {
        i += 1;
        let frac_digits = digit_run(bytes, &mut i, &mut mantissa)?;
        scale = -(frac_digits as i32);
        digits += frac_digits;
    }
    if digits == 0 {
        return None;
    }
    if let Some(b'e' | b'E') = bytes.get(i) {
        i += 1;
        let sign = match bytes.get(i) {
            Some(b'-') => {
                i += 1;
                -1
            }
            Some(b'+') => {
                i += 1;
                1
            }
            _ => 1,
        };
        let start = i;
        let mut exponent = 0i32;
        while let Some(&b) = bytes.get(i).filter(|b| b.is_ascii_digit()) {
            exponent = exponent * 10 + i32::from(b - b'0');
            i += 1;
            if i - start > 4 {
                return None;
            }
        }
        if i == start {
            return None;
        }
        scale += sign * exponent;
    }
    let magnitude = if mantissa == 0 {
        0.0
    } else if mantissa <= 1 << 53 && scale.unsigned_abs() <= 22 {
        let m = mantissa as f64;
        let p = EXACT_POW10[scale.unsigned_abs() as usize];
        if scale < 0 {
            m / p
        } else {
            m * p
        }
    } else {
        let text = std::str::from_utf8(&bytes[usize::from(negative || bytes[0] == b'+')..i]).ok()?;
        parse_number(text, decimal == b',').filter(|v| v.is_finite())?
    };
    Some((if negative { -magnitude } else { magnitude }, i))
}

/// The digits at `bytes[*i..]` appended to `mantissa`, eight at a time where it can: how many there were, or
/// `None` where `mantissa` would pass 19 digits.
#[inline]
fn digit_run(bytes: &[u8], i: &mut usize, mantissa: &mut u64) -> Option<u32> {
    let mut count = 0;
    while let Some(eight) = eight_digits(bytes, *i) {
        if *mantissa >= 100_000_000_000 {
            return None;
        }
        *mantissa = *mantissa * 100_000_000 + eight;
        *i += 8;
        count += 8;
    }
    while let Some(&b) = bytes.get(*i).filter(|b| b.is_ascii_digit()) {
        if *mantissa >= 1_000_000_000_000_000_000 {
            return None;
        }
        *mantissa = *mantissa * 10 + u64::from(b - b'0');
        *i += 1;
        count += 1;
    }
    Some(count)
}

/// The eight bytes at `bytes[i..]` as a number when all are ASCII digits (the first the most significant), with
/// three multiplications on the bytes as one `u64`.
#[inline]
fn eight_digits(bytes: &[u8], i: usize) -> Option<u64> {
    let word = u64::from_le_bytes(bytes.get(i..i + 8)?.try_into().ok()?);
    let digits = word.wrapping_sub(0x3030_3030_3030_3030);
    if (word.wrapping_add(0x4646_4646_4646_4646) | digits) & 0x8080_8080_8080_8080 != 0 {
        return None;
    }
    let pairs = (digits.wrapping_mul(10) + (digits >> 8)) & 0x00ff_00ff_00ff_00ff;
    let quads = (pairs.wrapping_mul(100) + (pairs >> 16)) & 0x0000_ffff_0000_ffff;
    Some((quads.wrapping_mul(10_000) + (quads >> 32)) & 0xffff_ffff)
}

/// The header line's text: a UTF-8 byte-order mark and a line end removed.
pub fn clean_header(line: &str) -> &str {
    trim_line_end(line.strip_prefix('\u{feff}').unwrap_or(line))
}

/// A line without its `\n` or `\r\n`.
pub fn trim_line_end(line: &str) -> &str {
    let line = line.strip_suffix('\n').unwrap_or(line);
    line.strip_suffix('\r').unwrap_or(line)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn delimiters_are_detected_from_the_header() {
        assert_eq!(Dialect::detect_delimiter("t,rate"), Some(Delimiter::Byte(b',')));
        assert_eq!(Dialect::detect_delimiter("t;rate;temp"), Some(Delimiter::Byte(b';')));
        assert_eq!(Dialect::detect_delimiter("t\trate"), Some(Delimiter::Byte(b'\t')));
        assert_eq!(Dialect::detect_delimiter("time   rate  temp"), Some(Delimiter::Whitespace));
        assert_eq!(Dialect::detect_delimiter("rate"), None);
        // A comma inside a quoted name does not count.
        assert_eq!(Dialect::detect_delimiter("\"rate, x\";t"), Some(Delimiter::Byte(b';')));
        assert_eq!(Dialect::detect_delimiter("\"rate,x\""), None);
    }

    #[test]
    fn a_decimal_comma_is_detected_only_where_it_is_unambiguous() {
        let semi = Delimiter::Byte(b';');
        assert!(Dialect::detect_decimal_comma(semi, &["0,001;1,25", "0,002;-3,5e-3"]));
        assert!(!Dialect::detect_decimal_comma(semi, &["0.001;1.25"]));
        assert!(!Dialect::detect_decimal_comma(semi, &["1,234,5;2"]), "two commas in a cell");
        assert!(!Dialect::detect_decimal_comma(Delimiter::Byte(b','), &["1,25"]), "a comma delimiter");
        assert!(Dialect::detect_decimal_comma(Delimiter::Whitespace, &["0,5 1,25"]));
    }

    #[test]
    fn cells_split_trimmed_and_unquoted() {
        let mut out = Vec::new();
        split(" 1 , 2,,\"3\" ", Delimiter::Byte(b','), &mut out).unwrap();
        assert_eq!(out, ["1", "2", "", "3"]);
        split("\"a,b\";2", Delimiter::Byte(b';'), &mut out).unwrap();
        assert_eq!(out, ["a,b", "2"]);
        split("\"a,b\",2", Delimiter::Byte(b','), &mut out).unwrap();
        assert_eq!(out, ["a,b", "2"]);
        split("  0.1 \t 2  ", Delimiter::Whitespace, &mut out).unwrap();
        assert_eq!(out, ["0.1", "2"]);
        assert_eq!(split("\"a,2", Delimiter::Byte(b','), &mut out), Err(SplitError::UnclosedQuote));
    }

    #[test]
    fn numbers_with_a_point_or_a_decimal_comma() {
        assert_eq!(parse_number("1.2881847531554629", false), Some(1.2881847531554629));
        assert_eq!(parse_number("-3.5e-3", false), Some(-3.5e-3));
        assert_eq!(parse_number("1,2881847531554629", true), Some(1.2881847531554629));
        assert_eq!(parse_number("1,25", false), None);
        assert_eq!(parse_number("1.234,5", true), None);
        assert_eq!(parse_number("x", false), None);
        assert_eq!(parse_number("", false), None);
    }

    #[test]
    fn a_byte_order_mark_and_crlf_are_removed() {
        assert_eq!(clean_header("\u{feff}t;rate\r\n"), "t;rate");
        assert_eq!(trim_line_end("1,2\r\n"), "1,2");
        assert_eq!(trim_line_end("1,2"), "1,2");
    }

    #[test]
    fn plain_numbers_are_those_of_fast_float() {
        for text in [
            "4.569959756e-01",
            "-3.5e-3",
            "0",
            "-0.0",
            "1",
            "+2.5",
            ".5",
            "5.",
            "1e22",
            "1E-22",
            "123456789012345678",
            "9007199254740993",
            "0.30000000000000004",
            "1.7976931348623157e308",
            "4.9e-324",
            "2.2250738585072014e-308",
            "0.000001234",
            "1234567890123456789",
            "1e+05",
            "00012.5000",
            "12345678.87654321",
            "0.0000000000000000001",
        ] {
            let (v, n) = parse_plain(text.as_bytes(), b'.').unwrap_or_else(|| panic!("{text}"));
            assert_eq!(n, text.len(), "{text}");
            assert_eq!(v.to_bits(), fast_float2::parse::<f64, _>(text).unwrap().to_bits(), "{text}");
        }
        assert_eq!(parse_plain(b"1,25;7", b','), Some((1.25, 4)));
        assert_eq!(parse_plain(b"2.5,7", b'.'), Some((2.5, 3)));
        for text in
            ["", "-", ".", "e5", "1e", "1e+", "inf", "nan", "12345678901234567890", "1e12345", "1.2345678901234567890"]
        {
            assert_eq!(parse_plain(text.as_bytes(), b'.'), None, "{text}");
        }
    }

    proptest::proptest! {
        #[test]
        fn plain_numbers_round_trip(v in proptest::num::f64::NORMAL | proptest::num::f64::SUBNORMAL | proptest::num::f64::ZERO, digits in 1usize..18) {
            for text in [format!("{v:.digits$e}"), format!("{v}"), format!("{v:.digits$}")] {
                if let Some((parsed, n)) = parse_plain(text.as_bytes(), b'.') {
                    proptest::prop_assert_eq!(n, text.len());
                    proptest::prop_assert_eq!(parsed.to_bits(), fast_float2::parse::<f64, _>(&text).unwrap().to_bits());
                }
            }
        }
    }
}

//! Figures in any customary unit: a small parser of unit expressions (`deg/sqrt(h)`, `mdps/√Hz`, `ug/sqrt(Hz)`,
//! `m/s/h^1.5`, `mGal`) into a dimension (angle, length, time) and a factor to SI, and the conversion of a figure
//! to the base unit of a noise term (deg/s-based for a gyro, m/s^2-based for an accelerometer).
//!
//! Checking dimensions, not matching names, is what lets every spelling of a unit through and stops a wrong one:
//! `0.3 deg/h` given for an angle random walk is refused, with the dimension it has and the one it needs.

use crate::fit::Term;
use crate::quantity::{Quantity, STANDARD_GRAVITY};

/// Exponents of angle, length and time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dimension {
    pub angle: f64,
    pub length: f64,
    pub time: f64,
}

impl Dimension {
    const NONE: Dimension = Dimension { angle: 0.0, length: 0.0, time: 0.0 };

    fn times(self, o: Dimension, k: f64) -> Dimension {
        Dimension { angle: self.angle + k * o.angle, length: self.length + k * o.length, time: self.time + k * o.time }
    }

    fn close(self, o: Dimension) -> bool {
        (self.angle - o.angle).abs() < 1e-9
            && (self.length - o.length).abs() < 1e-9
            && (self.time - o.time).abs() < 1e-9
    }

    /// The dimension as an SI unit (`rad s^-0.5`).
    pub fn describe(self) -> String {
        let mut parts = Vec::new();
        for (name, e) in [("rad", self.angle), ("m", self.length), ("s", self.time)] {
            if e.abs() > 1e-9 {
                parts.push(if (e - 1.0).abs() < 1e-9 { name.to_string() } else { format!("{name}^{e}") });
            }
        }
        if parts.is_empty() {
            "1".to_string()
        } else {
            parts.join(" ")
        }
    }
}

/// A unit: its dimension and the factor from it to SI (rad, m, s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Unit {
    pub dim: Dimension,
    pub to_si: f64,
}

/// A unit expression that does not parse, or a figure of the wrong dimension.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum UnitError {
    #[error("{text:?}: {why}")]
    Syntax { text: String, why: String },
    #[error("{text:?}: unknown unit {name:?} (known: deg, rad, mrad, urad, arcsec, arcmin, dps, mdps, rpm, s, ms, min, h, hr, Hz, kHz, m, mm, cm, km, ft, g, mg, ug, Gal, mGal, uGal, sqrt(...), ^)")]
    Unknown { text: String, name: String },
    #[error("{text:?} is {has}, but {what} needs {needs} (for example {example})")]
    Dimension { text: String, has: String, what: String, needs: String, example: &'static str },
    #[error("{text:?}: no number before the unit (write it as \"0.3 deg/sqrt(h)\")")]
    NoNumber { text: String },
}

fn atom(name: &str) -> Option<Unit> {
    let d = |angle, length, time| Dimension { angle, length, time };
    let deg = std::f64::consts::PI / 180.0;
    let g = STANDARD_GRAVITY;
    let (dim, k) = match name {
        "deg" | "°" | "degree" | "degrees" => (d(1.0, 0.0, 0.0), deg),
        "rad" => (d(1.0, 0.0, 0.0), 1.0),
        "mrad" => (d(1.0, 0.0, 0.0), 1e-3),
        "urad" | "µrad" | "μrad" => (d(1.0, 0.0, 0.0), 1e-6),
        "arcsec" => (d(1.0, 0.0, 0.0), deg / 3600.0),
        "arcmin" => (d(1.0, 0.0, 0.0), deg / 60.0),
        "dps" => (d(1.0, 0.0, -1.0), deg),
        "mdps" => (d(1.0, 0.0, -1.0), deg * 1e-3),
        "rpm" => (d(1.0, 0.0, -1.0), 2.0 * std::f64::consts::PI / 60.0),
        "s" | "sec" => (d(0.0, 0.0, 1.0), 1.0),
        "ms" => (d(0.0, 0.0, 1.0), 1e-3),
        "min" => (d(0.0, 0.0, 1.0), 60.0),
        "h" | "hr" | "hour" => (d(0.0, 0.0, 1.0), 3600.0),
        "hz" => (d(0.0, 0.0, -1.0), 1.0),
        "khz" => (d(0.0, 0.0, -1.0), 1e3),
        "m" => (d(0.0, 1.0, 0.0), 1.0),
        "mm" => (d(0.0, 1.0, 0.0), 1e-3),
        "cm" => (d(0.0, 1.0, 0.0), 1e-2),
        "km" => (d(0.0, 1.0, 0.0), 1e3),
        "ft" => (d(0.0, 1.0, 0.0), 0.3048),
        "g" => (d(0.0, 1.0, -2.0), g),
        "mg" => (d(0.0, 1.0, -2.0), g * 1e-3),
        "ug" | "µg" | "μg" => (d(0.0, 1.0, -2.0), g * 1e-6),
        "gal" => (d(0.0, 1.0, -2.0), 1e-2),
        "mgal" => (d(0.0, 1.0, -2.0), 1e-5),
        "ugal" | "µgal" | "μgal" => (d(0.0, 1.0, -2.0), 1e-8),
        _ => return None,
    };
    Some(Unit { dim, to_si: k })
}

/// Parse a unit expression: names joined by `/` and `*` (or a space), each with an optional `^p`, and `sqrt(...)`
/// or `√name` for a square root. Names are case-insensitive but for `mg` and `Mg`-free spellings (`g` is standard
/// gravity, never grams).
pub fn parse_unit(text: &str) -> Result<Unit, UnitError> {
    let syntax = |why: &str| UnitError::Syntax { text: text.to_string(), why: why.to_string() };
    let chars: Vec<char> = text.trim().chars().collect();
    let mut pos = 0;
    let unit = expression(&chars, &mut pos, text)?;
    if pos != chars.len() {
        return Err(syntax(&format!("unexpected {:?}", chars[pos..].iter().collect::<String>())));
    }
    Ok(unit)
}

fn expression(c: &[char], pos: &mut usize, text: &str) -> Result<Unit, UnitError> {
    let mut acc = factor(c, pos, text)?;
    loop {
        skip_spaces(c, pos);
        let sign = match c.get(*pos) {
            Some('/') => -1.0,
            Some('*') | Some('·') | Some('.') => 1.0,
            Some(')') | None => return Ok(acc),
            Some(_) => {
                // A space between two names multiplies them (`m s^-2`).
                let f = factor(c, pos, text)?;
                acc = Unit { dim: acc.dim.times(f.dim, 1.0), to_si: acc.to_si * f.to_si };
                continue;
            }
        };
        *pos += 1;
        let f = factor(c, pos, text)?;
        acc = Unit { dim: acc.dim.times(f.dim, sign), to_si: acc.to_si * f.to_si.powf(sign) };
    }
}

fn skip_spaces(c: &[char], pos: &mut usize) {
    while c.get(*pos).is_some_and(|ch| ch.is_whitespace()) {
        *pos += 1;
    }
}

fn factor(c: &[char], pos: &mut usize, text: &str) -> Result<Unit, UnitError> {
    let syntax = |why: &str| UnitError::Syntax { text: text.to_string(), why: why.to_string() };
    skip_spaces(c, pos);
    let base = if c.get(*pos) == Some(&'√') {
        *pos += 1;
        let inner = factor(c, pos, text)?;
        Unit { dim: Dimension::NONE.times(inner.dim, 0.5), to_si: inner.to_si.sqrt() }
    } else if c.get(*pos) == Some(&'(') {
        *pos += 1;
        let inner = expression(c, pos, text)?;
        if c.get(*pos) != Some(&')') {
            return Err(syntax("a '(' is not closed"));
        }
        *pos += 1;
        inner
    } else {
        let start = *pos;
        while c.get(*pos).is_some_and(|ch| ch.is_alphabetic() || *ch == '°' || *ch == 'µ' || *ch == 'μ') {
            *pos += 1;
        }
        let name: String = c[start..*pos].iter().collect();
        if name.is_empty() {
            return Err(syntax("a unit name was expected"));
        }
        if name.eq_ignore_ascii_case("sqrt") {
            if c.get(*pos) != Some(&'(') {
                return Err(syntax("sqrt needs parentheses: sqrt(Hz)"));
            }
            *pos += 1;
            let inner = expression(c, pos, text)?;
            if c.get(*pos) != Some(&')') {
                return Err(syntax("a sqrt( is not closed"));
            }
            *pos += 1;
            Unit { dim: Dimension::NONE.times(inner.dim, 0.5), to_si: inner.to_si.sqrt() }
        } else {
            let lower = name.to_lowercase();
            atom(&lower).ok_or_else(|| UnitError::Unknown { text: text.to_string(), name: name.clone() })?
        }
    };
    skip_spaces(c, pos);
    if c.get(*pos) == Some(&'^') {
        *pos += 1;
        let start = *pos;
        while c.get(*pos).is_some_and(|ch| ch.is_ascii_digit() || *ch == '.' || *ch == '-' || *ch == '+') {
            *pos += 1;
        }
        let p: f64 = c[start..*pos]
            .iter()
            .collect::<String>()
            .parse()
            .map_err(|_| syntax("a power after '^' is not a number"))?;
        return Ok(Unit { dim: Dimension::NONE.times(base.dim, p), to_si: base.to_si.powf(p) });
    }
    if c.get(*pos) == Some(&'²') {
        *pos += 1;
        return Ok(Unit { dim: Dimension::NONE.times(base.dim, 2.0), to_si: base.to_si.powi(2) });
    }
    Ok(base)
}

/// The dimension of a term's coefficient for a channel of `q`.
pub fn term_dimension(t: Term, q: Quantity) -> Dimension {
    let time = match t {
        Term::Q => 0.0,
        Term::N => -0.5,
        Term::B => -1.0,
        Term::K => -1.5,
        Term::R => -2.0,
    };
    match q {
        Quantity::AngularRate => Dimension { angle: 1.0, length: 0.0, time },
        Quantity::Acceleration => Dimension { angle: 0.0, length: 1.0, time: time - 1.0 },
    }
}

fn example(t: Term, q: Quantity) -> &'static str {
    match (q, t) {
        (Quantity::AngularRate, Term::Q) => "arcsec",
        (Quantity::AngularRate, Term::N) => "deg/sqrt(h) or mdps/sqrt(Hz)",
        (Quantity::AngularRate, Term::B) => "deg/h",
        (Quantity::AngularRate, Term::K) => "deg/h/sqrt(h)",
        (Quantity::AngularRate, Term::R) => "deg/h^2",
        (Quantity::Acceleration, Term::Q) => "m/s",
        (Quantity::Acceleration, Term::N) => "m/s/sqrt(h) or ug/sqrt(Hz)",
        (Quantity::Acceleration, Term::B) => "mg",
        (Quantity::Acceleration, Term::K) => "m/s^3/sqrt(Hz) or mg/sqrt(h)",
        (Quantity::Acceleration, Term::R) => "m/s^3",
    }
}

/// A figure `"VALUE UNIT"`: the number and its unit.
///
/// # Errors
/// A missing number or a unit that does not parse.
pub fn value_and_unit(text: &str) -> Result<(f64, Unit), UnitError> {
    let trimmed = text.trim();
    let split = trimmed
        .char_indices()
        .find(|&(i, ch)| {
            let exponent = (ch == 'e' || ch == 'E')
                && i > 0
                && trimmed[i + 1..].starts_with(|n: char| n.is_ascii_digit() || n == '-' || n == '+');
            !(ch.is_ascii_digit() || ch == '.' || ch == '-' || ch == '+' || exponent)
        })
        .map_or(trimmed.len(), |(i, _)| i);
    let value: f64 = trimmed[..split].parse().map_err(|_| UnitError::NoNumber { text: text.to_string() })?;
    Ok((value, parse_unit(&trimmed[split..])?))
}

/// A figure `"VALUE UNIT"` as the value of term `t` of a channel of `q` in octavar's unit of it
/// ([`Term::unit_of`]: deg/sqrt(s), deg/s, ... for a gyro; m/s/sqrt(s), m/s^2, ... for an accelerometer).
///
/// # Errors
/// A missing number, a unit that does not parse, or one of another dimension than the term's.
pub fn figure_in_base(text: &str, t: Term, q: Quantity) -> Result<f64, UnitError> {
    let (value, unit) = value_and_unit(text)?;
    let needs = term_dimension(t, q);
    if !unit.dim.close(needs) {
        return Err(UnitError::Dimension {
            text: text.to_string(),
            has: unit.dim.describe(),
            what: format!("{} of {}", t.name(), if q == Quantity::AngularRate { "a gyro" } else { "an accelerometer" }),
            needs: needs.describe(),
            example: example(t, q),
        });
    }
    let base = parse_unit(t.unit_of(q)).expect("octavar's own units parse");
    Ok(value * unit.to_si / base.to_si)
}

//! NI scaling: the `NI_Scale[n]` properties of a channel, else of its group, else of the file, built into a chain
//! of Linear, Polynomial, Add, Subtract and AdvancedAPI scales through their input sources, and applied to raw
//! values; `NI_Scaling_Status` "scaled" means the values need none.

use std::collections::HashMap;

use super::metadata::{object_path, Prop};
use super::segment::FileReader;

/// A scale that cannot be applied.
pub(super) enum ScaleFault {
    Unsupported { index: u32, scale_type: String },
    Bad(String),
}

impl FileReader<'_> {
    /// The scale of a channel: from its own properties, else its group's, else the file's; `None` for none (or
    /// data already scaled).
    pub(super) fn scale_of(&self, id: usize) -> Result<Option<Scale>, ScaleFault> {
        let o = &self.objects[id];
        let group = o.group.as_ref().and_then(|g| self.by_path.get(&object_path(Some(g))));
        let root = self.by_path.get("/");
        let levels =
            std::iter::once(&o.props).chain([group, root].into_iter().flatten().map(|&i| &self.objects[i].props));
        for props in levels {
            let n = number_of_scales(props)?;
            if n == 0 {
                continue;
            }
            let scaled =
                matches!(props.get("NI_Scaling_Status"), Some(Prop::Str(s)) if s.eq_ignore_ascii_case("scaled"));
            if scaled {
                return Ok(None);
            }
            return build_scale(props, n - 1, n, &mut Vec::new()).map(Some);
        }
        Ok(None)
    }
}

/// A raw input or a chain of NI scales.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Scale {
    Raw,
    Linear {
        slope: f64,
        intercept: f64,
        input: Box<Scale>,
    },
    /// Coefficients from the constant term up.
    Polynomial {
        coefficients: Vec<f64>,
        input: Box<Scale>,
    },
    Add {
        left: Box<Scale>,
        right: Box<Scale>,
    },
    /// `right - left`, as NI's Excel importer and nptdms compute it.
    Subtract {
        left: Box<Scale>,
        right: Box<Scale>,
    },
}

impl Scale {
    pub(super) fn apply(&self, x: f64) -> f64 {
        match self {
            Scale::Raw => x,
            Scale::Linear { slope, intercept, input } => input.apply(x) * slope + intercept,
            Scale::Polynomial { coefficients, input } => {
                let x = input.apply(x);
                // Horner's rule from the highest power down, as numpy's polyval.
                coefficients
                    .iter()
                    .rev()
                    .fold(None, |acc: Option<f64>, &c| Some(acc.map_or(c, |a| c + a * x)))
                    .unwrap_or(0.0)
            }
            Scale::Add { left, right } => left.apply(x) + right.apply(x),
            Scale::Subtract { left, right } => right.apply(x) - left.apply(x),
        }
    }
}

/// The input source that means the raw data.
const RAW_INPUT: f64 = 4_294_967_295.0;
/// More scales than any writer makes: a count past this is a damaged property.
const MAX_SCALES: u32 = 1024;

/// How many scales the properties define: `NI_Number_Of_Scales`, else one past the highest `NI_Scale[n]_Scale_Type`.
fn number_of_scales(props: &HashMap<String, Prop>) -> Result<u32, ScaleFault> {
    if let Some(p) = props.get("NI_Number_Of_Scales") {
        return match p.num() {
            Some(n) if n >= 0.0 && n <= f64::from(MAX_SCALES) && n.fract() == 0.0 => Ok(n as u32),
            _ => Err(ScaleFault::Bad(format!("NI_Number_Of_Scales is {}, not a count of scales", p.show()))),
        };
    }
    let highest = props
        .keys()
        .filter_map(|k| k.strip_prefix("NI_Scale[")?.strip_suffix("]_Scale_Type")?.parse::<u32>().ok())
        .filter(|&i| i < MAX_SCALES)
        .max();
    Ok(highest.map_or(0, |i| i + 1))
}

/// Scale `index` of `count`, with the scales it takes its input from; `visiting` holds the scales under way.
fn build_scale(
    props: &HashMap<String, Prop>,
    index: u32,
    count: u32,
    visiting: &mut Vec<u32>,
) -> Result<Scale, ScaleFault> {
    let key = |name: &str| format!("NI_Scale[{index}]_{name}");
    let num = |name: &str| -> Result<f64, ScaleFault> {
        let k = key(name);
        match props.get(&k) {
            Some(Prop::Num(v)) => Ok(*v),
            Some(other) => Err(ScaleFault::Bad(format!("{k} is {}, not a number", other.show()))),
            None => Err(ScaleFault::Bad(format!("scale {index} has no {k}"))),
        }
    };
    if visiting.contains(&index) {
        return Err(ScaleFault::Bad(format!("scale {index} takes its own output as input (the input sources loop)")));
    }
    visiting.push(index);
    let input = |name: &str, required: bool, visiting: &mut Vec<u32>| -> Result<Box<Scale>, ScaleFault> {
        let k = key(name);
        let source = match props.get(&k) {
            None if !required => return Ok(Box::new(Scale::Raw)),
            None => return Err(ScaleFault::Bad(format!("scale {index} has no {k}"))),
            Some(p) => p.num().ok_or_else(|| ScaleFault::Bad(format!("{k} is {}, not a number", p.show())))?,
        };
        if source == RAW_INPUT || source == -1.0 {
            return Ok(Box::new(Scale::Raw));
        }
        if !(source >= 0.0) || source >= f64::from(count) || source.fract() != 0.0 {
            return Err(ScaleFault::Bad(format!(
                "{k} is {source}, neither the raw data (4294967295) nor one of the {count} scales"
            )));
        }
        build_scale(props, source as u32, count, visiting).map(Box::new)
    };
    let scale_type = match props.get(&key("Scale_Type")) {
        Some(Prop::Str(s)) => s.clone(),
        Some(other) => {
            return Err(ScaleFault::Bad(format!("{} is {}, not a scale type", key("Scale_Type"), other.show())))
        }
        None => return Err(ScaleFault::Unsupported { index, scale_type: "DAQmx scaler (no Scale_Type)".to_string() }),
    };
    let scale = match scale_type.as_str() {
        "Linear" => Scale::Linear {
            slope: num("Linear_Slope")?,
            intercept: num("Linear_Y_Intercept")?,
            input: input("Linear_Input_Source", false, visiting)?,
        },
        "Polynomial" => {
            let size = match props.get(&key("Polynomial_Coefficients_Size")) {
                None => 4.0,
                Some(_) => num("Polynomial_Coefficients_Size")?,
            };
            if !(size >= 0.0) || size > 64.0 || size.fract() != 0.0 {
                return Err(ScaleFault::Bad(format!(
                    "{} is {size}, not a count of coefficients",
                    key("Polynomial_Coefficients_Size")
                )));
            }
            let coefficients =
                (0..size as u32).map(|k| num(&format!("Polynomial_Coefficients[{k}]"))).collect::<Result<_, _>>()?;
            Scale::Polynomial { coefficients, input: input("Polynomial_Input_Source", false, visiting)? }
        }
        "Add" | "Subtract" => {
            let left = input(&format!("{scale_type}_Left_Operand_Input_Source"), true, visiting)?;
            let right = input(&format!("{scale_type}_Right_Operand_Input_Source"), true, visiting)?;
            if scale_type == "Add" {
                Scale::Add { left, right }
            } else {
                Scale::Subtract { left, right }
            }
        }
        "AdvancedAPI" => *input("AdvancedAPI_Input_Source", false, visiting)?,
        _ => return Err(ScaleFault::Unsupported { index, scale_type }),
    };
    visiting.pop();
    Ok(scale)
}

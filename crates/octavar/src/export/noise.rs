//! The figures a state estimator's configuration wants, taken from the fits and converted to SI: per sensor
//! (gyro, accelerometer) the white-noise density, the bias random walk, the bias instability, a Gauss-Markov
//! bias model and the static bias, each with the text that says where it came from.
//!
//! A configuration takes one number per sensor, not per axis, so each figure is the largest of the sensor's axes
//! (the conservative choice for a filter), and its provenance names the axis. Every noise figure is multiplied by
//! the user's `inflate` factor, never silently.

use crate::analyze::ChannelAnalysis;
use crate::datasheet::{Datasheet, SensorSheet};
use crate::fit::{Term, FLICKER_AVAR_FACTOR};
use crate::quantity::Quantity;

/// One figure in SI units, with its interval where the fit gave one and the text that explains it.
#[derive(Clone, Debug, PartialEq)]
pub struct Figure {
    /// The value, SI, inflated.
    pub value: f64,
    /// The interval's ends, SI, inflated (none for a stand-in or an upper bound).
    pub lo: Option<f64>,
    pub hi: Option<f64>,
    /// The SI unit.
    pub unit: &'static str,
    /// Where it came from: the term, the axis, its interval and the conversion.
    pub how: String,
}

/// A first-order Gauss-Markov bias: stationary deviation and correlation time.
#[derive(Clone, Debug, PartialEq)]
pub struct BiasModel {
    /// Stationary standard deviation, SI, inflated.
    pub sigma: f64,
    /// Correlation time, s.
    pub tau_c_s: f64,
    /// Where it came from, with the match's quality.
    pub how: String,
}

/// The figures of one sensor (the gyro or the accelerometer), from its axes' fits.
#[derive(Clone, Debug, PartialEq)]
pub struct SensorNoise {
    /// Gyro or accelerometer.
    pub quantity: Quantity,
    /// The axes' channel names, in order.
    pub axes: Vec<String>,
    /// White-noise density N, SI/sqrt(Hz) (rad/s/sqrt(Hz), m/s^2/sqrt(Hz)).
    pub density: Option<Figure>,
    /// Bias random walk K, SI/s/sqrt(Hz) (rad/s^2/sqrt(Hz), m/s^3/sqrt(Hz)).
    pub random_walk: Option<Figure>,
    /// Bias instability B, SI.
    pub bias_instability: Option<Figure>,
    /// The Gauss-Markov bias model.
    pub bias_model: Option<BiasModel>,
    /// Each axis's static mean, SI (gravity included on an accelerometer).
    pub means: Vec<f64>,
}

/// Everything an export writes: the sensors' figures, the rate, the topic and where it all came from.
#[derive(Clone, Debug, PartialEq)]
pub struct ImuNoise {
    /// The recording's name.
    pub source: String,
    /// The update rate, Hz.
    pub rate_hz: f64,
    /// The ROS topic a config names.
    pub topic: String,
    /// The factor every noise figure was multiplied by.
    pub inflate: f64,
    /// The gyro's figures, if gyro channels were analysed.
    pub gyro: Option<SensorNoise>,
    /// The accelerometer's figures, if accelerometer channels were analysed.
    pub accel: Option<SensorNoise>,
}

/// The peak of a Gauss-Markov process's Allan deviation over its stationary deviation, and where it lies in
/// units of the correlation time: the stand-in read from the flicker floor where no process matches.
const GM_PEAK_ADEV: f64 = 0.6184;
const GM_PEAK_TAU: f64 = 1.89;

impl ImuNoise {
    /// The figures of `channels` (fitted, each a gyro or an accelerometer axis) for a config at `rate_hz`.
    pub fn from_channels(channels: &[ChannelAnalysis], source: &str, rate_hz: f64, topic: &str, inflate: f64) -> Self {
        let sensor = |q: Quantity| {
            let axes: Vec<&ChannelAnalysis> = channels.iter().filter(|c| c.quantity == q).collect();
            (!axes.is_empty()).then(|| SensorNoise::of(q, &axes, inflate))
        };
        ImuNoise {
            source: source.to_string(),
            rate_hz,
            topic: topic.to_string(),
            inflate,
            gyro: sensor(Quantity::AngularRate),
            accel: sensor(Quantity::Acceleration),
        }
    }

    /// The figures of a datasheet for a config at `rate_hz`.
    pub fn from_datasheet(sheet: &Datasheet, source: &str, rate_hz: f64, topic: &str, inflate: f64) -> Self {
        let sensor = |q: Quantity| sheet.sensor(q).map(|s| SensorNoise::of_sheet(q, s, inflate));
        ImuNoise {
            source: source.to_string(),
            rate_hz,
            topic: topic.to_string(),
            inflate,
            gyro: sensor(Quantity::AngularRate),
            accel: sensor(Quantity::Acceleration),
        }
    }

    /// The static specific force's magnitude, m/s^2, where three accelerometer axes were analysed.
    pub fn gravity(&self) -> Option<f64> {
        let a = self.accel.as_ref()?;
        (a.means.len() == 3 && a.means.iter().all(|m| m.is_finite()))
            .then(|| a.means.iter().map(|m| m * m).sum::<f64>().sqrt())
    }
}

impl SensorNoise {
    fn of(q: Quantity, axes: &[&ChannelAnalysis], inflate: f64) -> Self {
        let si = q.to_si();
        let names: Vec<String> = axes.iter().map(|c| c.name.clone()).collect();
        let all = names.join(", ");
        let of_axes = if axes.len() > 1 { format!(" (the largest of {all})") } else { String::new() };
        let inflated = if inflate != 1.0 { format!(" x {inflate} (--inflate)") } else { String::new() };
        let conv = if si != 1.0 { " x pi/180".to_string() } else { String::new() };
        // The largest identifiable value of a term over the axes: (axis, value, lo, hi) in the series' units.
        let largest = |t: Term| {
            axes.iter()
                .filter_map(|c| {
                    let f = c.fit.as_ref().ok()?;
                    let e = f.term(t);
                    Some((c.name.as_str(), e.value?, e.lo, e.hi))
                })
                .max_by(|a, b| a.1.total_cmp(&b.1))
        };
        let figure = |t: Term, unit: &'static str| {
            largest(t).map(|(axis, v, lo, hi)| Figure {
                value: v * si * inflate,
                lo: lo.map(|x| x * si * inflate),
                hi: hi.map(|x| x * si * inflate),
                unit,
                how: format!(
                    "{} of {axis}{of_axes} = {v:.4e} {}{}{conv}{inflated}",
                    t.name(),
                    t.unit_of(q),
                    interval(lo, hi, axes)
                ),
            })
        };
        let density = figure(Term::N, density_unit(q));
        let random_walk = figure(Term::K, walk_unit(q)).or_else(|| {
            // No axis shows a random walk: its upper bound where the fit gives one, else the +1/2 line through the
            // flicker floor.
            let bound = axes
                .iter()
                .filter_map(|c| Some((c.name.as_str(), c.fit.as_ref().ok()?.k.hi?)))
                .max_by(|a, b| a.1.total_cmp(&b.1));
            if let Some((axis, hi)) = bound {
                return Some(Figure {
                    value: hi * si * inflate,
                    lo: None,
                    hi: None,
                    unit: walk_unit(q),
                    how: format!(
                        "K is not identifiable on any axis: the upper bound of its 95% interval on {axis}{of_axes} = \
                         {hi:.4e} {}{conv}{inflated}",
                        Term::K.unit_of(q)
                    ),
                });
            }
            let (axis, b, tau) = flicker_floor(axes)?;
            let k = FLICKER_AVAR_FACTOR.sqrt() * b * (3.0 / tau).sqrt();
            Some(Figure {
                value: k * si * inflate,
                lo: None,
                hi: None,
                unit: walk_unit(q),
                how: format!(
                    "K is not identifiable and has no bound: the +1/2 line through the flicker floor of {axis}, \
                     0.664 B sqrt(3 / tau_B) with B = {b:.4e} {} at tau_B = {tau:.3e} s, = {k:.4e} {}{conv}{inflated}",
                    Term::B.unit_of(q),
                    Term::K.unit_of(q)
                ),
            })
        });
        let bias_instability = figure(Term::B, q.si_unit()).or_else(|| {
            let (axis, b) = axes
                .iter()
                .filter_map(|c| Some((c.name.as_str(), c.fit.as_ref().ok()?.classic.b?)))
                .max_by(|a, b| a.1.total_cmp(&b.1))?;
            Some(Figure {
                value: b * si * inflate,
                lo: None,
                hi: None,
                unit: q.si_unit(),
                how: format!(
                    "B is not identifiable: the classic readout (the ADEV floor / 0.664) of {axis}{of_axes} = {b:.4e} \
                     {}{conv}{inflated}",
                    Term::B.unit_of(q)
                ),
            })
        });
        let bias_model = bias_model(q, axes, inflate, &of_axes, &conv, &inflated);
        let means = axes.iter().map(|c| c.mean.unwrap_or(f64::NAN) * si).collect();
        SensorNoise { quantity: q, axes: names, density, random_walk, bias_instability, bias_model, means }
    }
}

impl SensorNoise {
    fn of_sheet(q: Quantity, sheet: &SensorSheet, inflate: f64) -> Self {
        let si = q.to_si();
        let inflated = if inflate != 1.0 { format!(" x {inflate} (--inflate)") } else { String::new() };
        let conv = if si != 1.0 { " x pi/180" } else { "" };
        let figure = |t: Term, unit: &'static str| {
            let v = sheet.get(t)?;
            let written = sheet.written.get(t.name()).cloned().unwrap_or_default();
            Some(Figure {
                value: v * si * inflate,
                lo: None,
                hi: None,
                unit,
                how: format!("the datasheet's {} = \"{written}\" = {v:.4e} {}{conv}{inflated}", t.name(), t.unit_of(q)),
            })
        };
        let bias_model = match (sheet.get(Term::B), sheet.bias_correlation_time_s) {
            (Some(b), Some(tc)) => {
                let sigma = FLICKER_AVAR_FACTOR.sqrt() * b / GM_PEAK_ADEV;
                Some(BiasModel {
                    sigma: sigma * si * inflate,
                    tau_c_s: tc,
                    how: format!(
                        "the Gauss-Markov process whose ADEV peak (0.618 sigma) sits on the datasheet's flicker floor \
                         (B = {b:.4e} {}), with its bias_correlation_time: sigma = {sigma:.4e} {}{conv}{inflated}",
                        Term::B.unit_of(q),
                        q.unit()
                    ),
                })
            }
            _ => None,
        };
        SensorNoise {
            quantity: q,
            axes: Vec::new(),
            density: figure(Term::N, density_unit(q)),
            random_walk: figure(Term::K, walk_unit(q)),
            bias_instability: figure(Term::B, q.si_unit()),
            bias_model,
            means: Vec::new(),
        }
    }
}

/// The Gauss-Markov bias of the axis with the largest one, or the stand-in from the flicker floor.
fn bias_model(
    q: Quantity,
    axes: &[&ChannelAnalysis],
    inflate: f64,
    of_axes: &str,
    conv: &str,
    inflated: &str,
) -> Option<BiasModel> {
    let si = q.to_si();
    let matched = axes
        .iter()
        .filter_map(|c| Some((c.name.as_str(), c.bias_model.clone()?)))
        .max_by(|a, b| a.1.sigma.total_cmp(&b.1.sigma));
    if let Some((axis, gm)) = matched {
        return Some(BiasModel {
            sigma: gm.sigma * si * inflate,
            tau_c_s: gm.tau_c_s,
            how: format!(
                "the first-order Gauss-Markov process matched to the ADEV of {axis}{of_axes} over tau {:.3e}..{:.3e} s \
                 ({} points, within {:.0}% where precise, chi2/dof {:.2}): sigma = {:.4e} {}{conv}{inflated}, \
                 correlation time {:.4e} s",
                gm.tau_range_s[0],
                gm.tau_range_s[1],
                gm.points,
                gm.max_misfit * 100.0,
                gm.chi2_per_dof,
                gm.sigma,
                q.unit(),
                gm.tau_c_s
            ),
        });
    }
    let (axis, b, tau) = flicker_floor(axes)?;
    let sigma = FLICKER_AVAR_FACTOR.sqrt() * b / GM_PEAK_ADEV;
    Some(BiasModel {
        sigma: sigma * si * inflate,
        tau_c_s: tau / GM_PEAK_TAU,
        how: format!(
            "no Gauss-Markov process matches the ADEV: the one whose ADEV peak (0.618 sigma at 1.89 T) sits on the \
             flicker floor of {axis} (B = {b:.4e} {} at tau {tau:.3e} s): sigma = {sigma:.4e} {}{conv}{inflated}",
            Term::B.unit_of(q),
            q.unit()
        ),
    })
}

/// The axis with the largest flicker floor: its name, its B (the fit's, or else the classic readout) and the tau
/// of its ADEV floor, in the series' units; the stand-ins for K and for the Gauss-Markov bias are read from it.
fn flicker_floor<'a>(axes: &[&'a ChannelAnalysis]) -> Option<(&'a str, f64, f64)> {
    axes.iter()
        .filter_map(|c| {
            let f = c.fit.as_ref().ok()?;
            Some((c.name.as_str(), f.b.value.or(f.classic.b)?, f.classic.b_tau_s?))
        })
        .max_by(|a, b| a.1.total_cmp(&b.1))
}

/// ` (95%: lo .. hi)` of an interval, or nothing.
fn interval(lo: Option<f64>, hi: Option<f64>, axes: &[&ChannelAnalysis]) -> String {
    let conf = axes.iter().find_map(|c| c.fit.as_ref().ok().map(|f| f.confidence)).unwrap_or(0.95);
    match (lo, hi) {
        (Some(lo), Some(hi)) => format!(" ({:.0}%: {lo:.3e} .. {hi:.3e})", conf * 100.0),
        _ => String::new(),
    }
}

/// The SI unit of a white-noise density.
pub fn density_unit(q: Quantity) -> &'static str {
    match q {
        Quantity::AngularRate => "rad/s/sqrt(Hz)",
        Quantity::Acceleration => "m/s^2/sqrt(Hz)",
    }
}

/// The SI unit of a bias random walk.
pub fn walk_unit(q: Quantity) -> &'static str {
    match q {
        Quantity::AngularRate => "rad/s^2/sqrt(Hz)",
        Quantity::Acceleration => "m/s^3/sqrt(Hz)",
    }
}

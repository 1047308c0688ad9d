//! The ADC stage of a simulated channel: the affine map rate -> code of [`Channel::dps_to_code`], quantised and
//! clipped like [`crate::sensor::Adc::quantize`], with clipping reported.
//!
//! The map `code_f = offset + gain * rate` is precomputed from the channel, so a sample costs one multiply-add, a
//! saturating float-to-integer conversion and a compare (no division, no `floor` call). It agrees with
//! `Channel::dps_to_code` except where `code_f` lies within rounding of a code edge.

use crate::sensor::Channel;

/// Rate -> code for one channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quantizer {
    offset: f64,
    gain: f64,
    max_code: u16,
    max_f: f64,
}

impl Quantizer {
    /// The quantiser of `ch`.
    pub fn new(ch: &Channel) -> Self {
        let per_code = ch.adc.mv_per_code();
        let gain = ch.front.gain * ch.gyro.sensitivity_mv_per_dps / per_code;
        let offset = ch.front.apply(ch.gyro.null_mv) / per_code;
        let max_code = ch.adc.max_code();
        Quantizer { offset, gain, max_code, max_f: f64::from(max_code) + 1.0 }
    }

    /// Unquantised code for a rate (before clipping).
    #[inline]
    pub fn code_f(&self, rate_dps: f64) -> f64 {
        self.offset + self.gain * rate_dps
    }

    /// Codes per deg/s.
    pub fn codes_per_dps(&self) -> f64 {
        self.gain
    }

    /// The code for a rate and whether it clipped (fell below code 0 or beyond the top code's step).
    #[inline]
    pub fn quantize(&self, rate_dps: f64) -> (u16, bool) {
        let x = self.code_f(rate_dps);
        // `as` saturates: negative -> 0, NaN -> 0; truncation is floor for x >= 0.
        let code = (x as u16).min(self.max_code);
        (code, !(0.0..self.max_f).contains(&x))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::{ADXRS300, ENV05H, IDG1215_X};
    use crate::sim::rng::SimRng;

    #[test]
    fn agrees_with_channel_dps_to_code() {
        let mut rng = SimRng::new(4);
        for gyro in [IDG1215_X, ADXRS300, ENV05H] {
            let ch = Channel::bench(gyro);
            let q = Quantizer::new(&ch);
            let span = 1.5 * ch.usable_range_dps();
            let mut edge = 0;
            for _ in 0..200_000 {
                let r = (2.0 * rng.uniform() - 1.0) * span;
                let (code, clipped) = q.quantize(r);
                let want = ch.dps_to_code(r);
                let x = ch.dps_to_code_f(r);
                if code != want {
                    // Only where the two roundings straddle a code edge.
                    assert!((x - libm::round(x)).abs() < 1e-9, "{gyro:?} {r}: {code} vs {want}");
                    edge += 1;
                }
                assert_eq!(clipped, !(0.0..4096.0).contains(&x), "{gyro:?} {r} {x}");
            }
            assert!(edge < 5);
        }
    }
}

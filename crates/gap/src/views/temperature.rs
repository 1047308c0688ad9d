//! The `temperature` view: the coherence of the rate and the temperature in octave bands of frequency, from one
//! cycle per part up (the point's tau is 1/f).
//!
//! Both series are block-averaged to at most 8192 points, and the magnitude-squared coherence is summed over the
//! band's bins and five sine tapers; atanh of its root is the point's value. A coherence is the correlation of the
//! two within the band at whatever phase fits best, so a thermal lag costs nothing, and it looks where the
//! temperature moves rather than at block means that red noise dominates; the multitaper estimate weighs the whole
//! part evenly, and its points are independent bands, not one correlation repeated at every block length. A model
//! with a temperature coupling is judged on what its coupling leaves ([`super::Plan::measure_explained`]).

use std::sync::Arc;

use rustfft::num_complex::Complex;

use super::PointInfo;
use crate::spectral::{block_means, centred, Multitaper, WHOLE_PART_TAPERS};

/// The bands of a part's temperature view.
#[derive(Clone)]
pub(super) struct TemperaturePlan {
    taper: Option<Arc<Multitaper>>,
    /// FFT bin ranges (inclusive) of the bands `[2^i, 2^(i+1))` cycles per part (empty without a temperature).
    bands: Vec<(usize, usize)>,
}

impl TemperaturePlan {
    /// The bands of a part of `n` samples at `rate_hz` with the temperature `temp_c` (none without one).
    pub fn new(
        n: usize,
        rate_hz: f64,
        temp_c: Option<&[f64]>,
        taper: Option<Arc<Multitaper>>,
    ) -> (TemperaturePlan, Vec<PointInfo>) {
        let tau0 = 1.0 / rate_hz;
        let mut bands = Vec::new();
        let mut points = Vec::new();
        if let (Some(t), Some(mt)) = (temp_c, &taper) {
            if t.iter().any(|v| v.is_finite()) && t.len() == n {
                let part_s = mt.part_s(tau0);
                let mut u = 1.0f64;
                while u < mt.nb as f64 / 4.0 {
                    if let Some((k0, k1)) = mt.bins(u, 2.0 * u) {
                        let per_cycle = mt.nb as f64 / mt.nfft as f64;
                        let (u0, u1) = (k0 as f64 * per_cycle, (k1 + 1) as f64 * per_cycle);
                        let dof = (k1 + 1 - k0) as f64 * per_cycle * WHOLE_PART_TAPERS as f64;
                        points.push(PointInfo {
                            label: "band",
                            tau_s: part_s / (u0 * u1).sqrt(),
                            tau_lo_s: part_s / u1,
                            tau_hi_s: part_s / u0,
                            floor_sd: 0.4 / dof.sqrt(),
                        });
                        bands.push((k0, k1));
                    }
                    u *= 2.0;
                }
            }
        }
        (TemperaturePlan { taper, bands }, points)
    }

    /// True when the view has bands.
    pub fn is_empty(&self) -> bool {
        self.bands.is_empty()
    }

    /// One NaN per band.
    pub fn nan(&self) -> Vec<f64> {
        vec![f64::NAN; self.bands.len()]
    }

    /// atanh of the coherence's root between `x` and the temperature `t` in every band.
    pub fn values(&self, x: &[f64], t: &[f64]) -> Vec<f64> {
        let bands = &self.bands;
        let nan = vec![f64::NAN; bands.len()];
        let Some(l) = &self.taper else { return nan };
        let mut rate = block_means(x, l.decim);
        let mut temp = block_means(t, l.decim);
        rate.truncate(l.nb);
        temp.truncate(l.nb);
        // A block missing in either is left out of both (zero after the mean is removed).
        let valid: Vec<bool> = rate.iter().zip(&temp).map(|(r, t)| r.is_finite() && t.is_finite()).collect();
        let (Some(rate), Some(temp)) = (centred(&rate, &valid), centred(&temp, &valid)) else { return nan };
        let mut sxy = vec![Complex::new(0.0, 0.0); bands.len()];
        let mut sxx = vec![0.0; bands.len()];
        let mut syy = vec![0.0; bands.len()];
        let mut bx = vec![Complex::new(0.0, 0.0); l.nfft];
        let mut by = vec![Complex::new(0.0, 0.0); l.nfft];
        let mut scratch = vec![Complex::new(0.0, 0.0); l.scratch_len()];
        for w in &l.tapers {
            l.transform(&temp, w, &mut bx, &mut scratch);
            l.transform(&rate, w, &mut by, &mut scratch);
            for (b, &(k0, k1)) in bands.iter().enumerate() {
                for k in k0..=k1 {
                    sxy[b] += bx[k].conj() * by[k];
                    sxx[b] += bx[k].norm_sqr();
                    syy[b] += by[k].norm_sqr();
                }
            }
        }
        (0..bands.len())
            .map(|b| {
                if sxx[b] > 0.0 && syy[b] > 0.0 {
                    let c = (sxy[b].norm_sqr() / (sxx[b] * syy[b])).sqrt();
                    c.min(1.0 - 1e-12).atanh()
                } else {
                    f64::NAN
                }
            })
            .collect()
    }
}

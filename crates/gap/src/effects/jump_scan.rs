//! The jumps of a named bias process found again on any series of the training part's length: the views that
//! compare a record with its simulated members beside such a process take the jumps out of both the same way
//! ([`crate::judge::Judge::less_jumps`]), so a partner effect the process's own spread hides shows again.

use super::params::EffectParams;
use super::{bias_steps, bistable, EffectFit};

/// How a named jump process is found again: its estimator's scan at the window its fit chose, with no test of its
/// own (the effect is already named).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JumpScan {
    /// Random bias steps: the moving-sum scan, each step's size added to the level.
    BiasSteps {
        /// Window, samples.
        window: usize,
    },
    /// A bistable bias: the scan, missed jumps put back, the two states' zero-mean levels.
    Bistable {
        /// Window, samples.
        window: usize,
        /// The least distance between two jumps kept, samples.
        apart: usize,
    },
}

impl JumpScan {
    /// The scan of `fit`'s effect where the chain took its realisation out of the samples (a bistable bias, a
    /// bias-step process of several steps); `x` are the training samples (gaps filled) at `rate_hz`. `None` for
    /// any other fit.
    pub fn of(fit: &EffectFit, x: &[f64], rate_hz: f64) -> Option<JumpScan> {
        fit.cleaned.as_ref()?;
        match &fit.params {
            EffectParams::Bistable(p) => {
                let window = ((p.window_s * rate_hz).round() as usize).max(1);
                Some(JumpScan::Bistable { window, apart: p.jumps_apart_windows * window })
            }
            EffectParams::BiasSteps(_) => {
                bias_steps::scan_window(x, rate_hz).map(|window| JumpScan::BiasSteps { window })
            }
            _ => None,
        }
    }

    /// `x` (no gaps) less the jumps this scan finds in it; `x` as it is where it finds none.
    pub fn take_out(&self, x: &mut [f64]) {
        let levels = match *self {
            JumpScan::BiasSteps { window } => bias_steps::recovered_levels(x, window),
            JumpScan::Bistable { window, apart } => bistable::recovered_levels(x, window, apart),
        };
        for (v, l) in x.iter_mut().zip(levels.iter().flatten()) {
            *v -= l;
        }
    }
}

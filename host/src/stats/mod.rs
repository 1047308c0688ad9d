//! The Allan deviation family and its confidence intervals.
//!
//! - [`edf`]: equivalent degrees of freedom (Greenhall's algorithm and the simple formulas) and chi-square intervals.

pub mod edf;

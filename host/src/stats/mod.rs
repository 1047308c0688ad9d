//! The Allan deviation family and its confidence intervals (being written).

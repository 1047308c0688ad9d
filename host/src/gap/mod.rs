//! The sim-to-real gap diagnosis (`octavar gap`).

pub mod effects;

//! The frame protocol (being written).

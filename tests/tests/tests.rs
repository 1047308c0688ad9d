//! octavar's end-to-end tests, built as one binary (one module per claim area).

mod util;

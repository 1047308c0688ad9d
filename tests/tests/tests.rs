//! octavar's end-to-end tests, built as one binary (one module per claim area).

mod acc_allantools;
mod util;

//! The host's side of the octavar board (the device core on it is `octavar_shared::device`): recording its frames
//! into a capture, verifying a capture bit for bit against the exact accumulator, the on-board statistics of its
//! snapshots, the accumulator over integer codes, and a simulated board that sends the firmware's exact byte stream.
//!
//! Above `io` (captures and frame decoding) and `stats`; below `cli` and `demo`.

pub mod accumulate;
pub mod bringup;
pub mod link;
pub mod log_readout;
pub mod recorder;
pub mod simulated;
pub mod verify;

//! The commands the host sends to the device.
//!
//! Commands travel in the same framing as frames (sequence number, CRC-32, COBS); the device decodes them with
//! a [`super::Decoder<Command>`]. The order of the variants is the wire format.

use serde::{Deserialize, Serialize};

/// Everything the host asks of the device (the body of a host -> device frame).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Command {
    /// Start streaming raw codes ([`super::Frame::Samples`]) of the channels in the mask.
    StartRaw {
        /// Bit `i` set: stream channel `i`.
        channel_mask: u8,
    },
    /// Stop raw streaming.
    StopRaw,
    /// Reset every accumulator; sample counts restart at 0.
    Reset,
    /// Send the field log ([`super::Frame::FieldLog`] parts, then [`super::Frame::FieldLogEnd`]).
    ReadFieldLog {
        /// First checkpoint to send (0 for all): lets the host resume an interrupted read-out.
        from_checkpoint: u32,
    },
    /// Send a [`super::Frame::Hello`].
    Hello,
    /// Write a field-log checkpoint at the next snapshot round, whether or not one is due, and answer with a
    /// [`super::Frame::CheckpointReport`]: what the flash cost (the bring-up's check of a checkpoint's stall).
    Checkpoint,
}

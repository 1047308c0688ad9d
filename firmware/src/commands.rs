//! Host commands, from whichever link carries them (USB on the board, USART1 in QEMU), to the task that acts on
//! them: field-log reads and checkpoint requests to the store task, the rest to characterize. Each goes with its frame's sequence
//! number, which the device acknowledges once the command has taken effect.

use octavar_shared::proto::Command;

use crate::characterize::COMMANDS;
use crate::store::{LogRead, CHECKPOINT_NOW, LOG_READ};

/// Hand a command to the task that acts on it; a full queue drops it (unacknowledged, so the host can resend).
pub fn route(seq: u32, cmd: Command) {
    match cmd {
        Command::ReadFieldLog { from_checkpoint } => LOG_READ.signal(LogRead { seq, from: from_checkpoint }),
        Command::Checkpoint => CHECKPOINT_NOW.signal(seq),
        other => {
            if COMMANDS.try_send((seq, other)).is_err() {
                defmt::warn!("command queue full: {} ({}) dropped", other, seq);
            }
        }
    }
}

//! Frames out: every task that reports something encodes a [`Frame`] here and queues the bytes for the link.
//!
//! A frame gets its sequence number when it is encoded, so a frame dropped because the queue was full (the host
//! is absent or slow) shows up at the host as a gap in the sequence numbers, and here in [`FRAMES_DROPPED`],
//! which the status frame reports. Producers never wait: sampling must not stall on the link.

use core::sync::atomic::{AtomicU32, Ordering};

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use octavar_shared::proto::{encode_to_vec, Frame, FrameBuf};

/// Encoded frames waiting for the link (USB on the board, USART1 in QEMU).
pub const FRAME_QUEUE: usize = 16;

/// Encoded frames, from characterize, store and usb to the task that owns the link.
pub static FRAMES_OUT: Channel<CriticalSectionRawMutex, FrameBuf, FRAME_QUEUE> = Channel::new();
/// Frames dropped because [`FRAMES_OUT`] was full; reported in the status frame.
pub static FRAMES_DROPPED: AtomicU32 = AtomicU32::new(0);
/// The next frame's sequence number.
static NEXT_SEQ: AtomicU32 = AtomicU32::new(0);

fn encode(frame: &Frame) -> Option<FrameBuf> {
    let seq = NEXT_SEQ.fetch_add(1, Ordering::Relaxed);
    match encode_to_vec(seq, frame) {
        Ok(buf) => Some(buf),
        Err(e) => {
            // Every frame type fits by construction (proto's size proofs): this is a bug.
            defmt::error!("frame {} does not encode: {}", seq, defmt::Debug2Format(&e));
            None
        }
    }
}

/// Queue a frame without waiting; a full queue drops it and counts the drop.
pub fn send(frame: &Frame) {
    if let Some(buf) = encode(frame) {
        if FRAMES_OUT.try_send(buf).is_err() {
            FRAMES_DROPPED.fetch_add(1, Ordering::Relaxed);
        }
    }
}

/// Queue a frame, waiting for room: for replies to the host (field-log read-out) from tasks that may wait.
/// The frame is encoded (and dropped) before the wait, so only its bytes are kept across it.
pub async fn send_wait(frame: Frame) {
    let buf = encode(&frame);
    drop(frame);
    if let Some(buf) = buf {
        FRAMES_OUT.send(buf).await;
    }
}

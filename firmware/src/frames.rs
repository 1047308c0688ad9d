//! Frames out: every task that reports something encodes a [`Frame`] here and queues the bytes for the link.
//!
//! A frame gets its sequence number when it is encoded, so a frame dropped because the queue was full (the host
//! is absent or slow) shows up at the host as a gap in the sequence numbers, and here in [`FRAMES_DROPPED`],
//! which the status frame reports. Producers never wait without a bound: sampling must not stall on the link,
//! and a read-out for a host that went away is abandoned.

use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use embassy_time::{with_timeout, Duration, Instant, Timer};
use octavar_shared::proto::{encode_to_vec, Frame, FrameBuf};

/// Encoded frames waiting for the link (USB on the board, USART1 in QEMU).
pub const FRAME_QUEUE: usize = 16;

/// Encoded frames, from characterize, store and the link task to the task that owns the link.
pub static FRAMES_OUT: Channel<CriticalSectionRawMutex, FrameBuf, FRAME_QUEUE> = Channel::new();
/// Frames dropped because [`FRAMES_OUT`] was full or stale at a new connection; reported in the status frame.
pub static FRAMES_DROPPED: AtomicU32 = AtomicU32::new(0);
/// The most frames [`FRAMES_OUT`] has held at once: how close a burst came to dropping frames.
pub static FRAMES_PEAK: AtomicU32 = AtomicU32::new(0);
/// A host is connected and listening (DTR set on USB; always in QEMU).
pub static LINK_UP: AtomicBool = AtomicBool::new(false);
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
        } else {
            note_queued();
        }
    }
}

/// A frame went into the queue: keep [`FRAMES_PEAK`].
fn note_queued() {
    FRAMES_PEAK.fetch_max(FRAMES_OUT.len() as u32, Ordering::Relaxed);
}

/// How often [`drained_within`] looks at the queue.
const DRAIN_POLL: Duration = Duration::from_micros(100);

/// Wait until the link has taken every queued frame, at most `limit`, while a host listens: a producer about to
/// queue a burst (characterize's next block) lets the link take the last one first, so bursts never pile up in
/// the queue. Without a host it returns at once: its frames are dropped and counted either way.
pub async fn drained_within(limit: Duration) {
    let deadline = Instant::now() + limit;
    while LINK_UP.load(Ordering::Relaxed) && !FRAMES_OUT.is_empty() && Instant::now() < deadline {
        Timer::after(DRAIN_POLL).await;
    }
}

/// The link went away, or did not take a frame within the bound.
#[derive(Debug, defmt::Format)]
pub struct NotSent;

/// Queue a frame, waiting at most `limit` for room and only while a host listens: for replies (the field-log
/// read-out) from tasks that may wait. The frame is encoded (and dropped) before the wait.
pub async fn send_within(frame: Frame, limit: Duration) -> Result<(), NotSent> {
    let buf = encode(&frame).ok_or(NotSent)?;
    drop(frame);
    if !LINK_UP.load(Ordering::Relaxed) {
        FRAMES_DROPPED.fetch_add(1, Ordering::Relaxed);
        return Err(NotSent);
    }
    with_timeout(limit, FRAMES_OUT.send(buf)).await.map_err(|_| {
        FRAMES_DROPPED.fetch_add(1, Ordering::Relaxed);
        NotSent
    })?;
    note_queued();
    Ok(())
}

/// A new host connected: drop what was queued for nobody (counted), so the hello comes first.
pub fn flush_stale() {
    while FRAMES_OUT.try_receive().is_ok() {
        FRAMES_DROPPED.fetch_add(1, Ordering::Relaxed);
    }
}

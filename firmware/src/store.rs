//! The store task: the field log. Checkpoints the snapshot rounds to flash at most every ten minutes and reads
//! them back for the host after a power cycle.
//!
//! The log logic (record format, recovery, write order, power-cut safety) is `octavar_shared::fieldlog`, tested
//! on the host, and so is the policy (`octavar_shared::fieldlog::CheckpointPolicy`): at boot, and after a host reset, the
//! newest checkpoint is read back, and every checkpoint of the session pools it with the session's snapshots
//! (`Checkpoint::merge_session`), so the log always covers the whole deployment, and a power cut or a reset loses
//! at most the samples since the last checkpoint. Here: the flash driver behind its `LogFlash` trait.
//!
//! On the board the log lives in flash sectors 1 and 2 (0x0800_4000 and 0x0800_8000, 16 KiB each), between the
//! vector table in sector 0 and the program, which the root `memory.x` starts at sector 4. The STM32F405 has one
//! flash bank: while a sector is erased the CPU cannot fetch from flash, interrupts included, but the ADC, its
//! DMA and the trigger counter run on. A 16 KiB sector erases in at most 0.5 s (DS8626 table 44) and the sample
//! ring holds 1.024 s, so an erase loses no sample; should one ever take longer, the loss is an exact gap in the
//! hardware sample index, pooled across (`sampler.rs`). A sector holds five checkpoints, so an erase comes every
//! five checkpoints (50 minutes).
//!
//! A read-out never blocks the log: each frame waits at most [`READ_OUT_FRAME_WAIT`] for room, and only while a
//! host listens; a host that goes away mid read-out ends it, and checkpoints go on.

use core::sync::atomic::Ordering;
use embassy_futures::select::{select3, Either3};
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::signal::Signal;

use embassy_time::{Duration, Timer};
use octavar_shared::fieldlog::{
    read_out_frame, Checkpoint, CheckpointPolicy, FieldLog, LogError, LogFlash, RoundOutcome, OVERHEAD_WORDS,
};
use octavar_shared::flash_f4::{erase_worst_us, program_worst_us, FlashError, PARALLELISM};
use octavar_shared::proto::{Ack, CheckpointReport, FieldLogEnd, Frame};

use crate::characterize::SNAPSHOT_READY;
use crate::config::*;
use crate::frames;
use crate::timebase;

/// The checkpoint type of this firmware: one snapshot per gyro.
pub type GyroCheckpoint = Checkpoint<GYROS>;
/// Payload words of one checkpoint.
pub const CHECKPOINT_WORDS: usize = GyroCheckpoint::WORDS;

/// The longest the flash stalls the CPU in one go, microseconds: a log sector's erase or one checkpoint's
/// programming at the controller's parallelism, whichever is longer, at the datasheet's worst case.
pub const FLASH_STALL_WORST_US: u64 = {
    let erase = erase_worst_us(octavar_shared::fieldlog::STM32F405_LOG_SECTORS[0].bytes, PARALLELISM);
    let program = program_worst_us(CHECKPOINT_WORDS + OVERHEAD_WORDS, PARALLELISM);
    if erase > program {
        erase
    } else {
        program
    }
};

/// The build fails unless the ring's stall budget covers the worst flash stall at least 1.5 times.
pub const RING_COVERS_THE_WORST_STALL: () = assert!(
    2 * STALL_BUDGET_SCANS as u64 * 1_000_000 >= 3 * FLASH_STALL_WORST_US * SAMPLE_RATE_HZ as u64,
    "the sample ring must outlive the worst-case flash stall 1.5 times"
);
const _: () = RING_COVERS_THE_WORST_STALL;

/// How many sampler polls [`settle`] waits at most (characterize may be behind and keep blocks in the ring).
const SETTLE_POLLS: u32 = 32;

/// Before a flash stall: wait until the sampler has taken every complete block from the ring (what the stall
/// budget assumes), for at most [`SETTLE_POLLS`] polls.
async fn settle() {
    for _ in 0..SETTLE_POLLS {
        if crate::sampler::BACKLOG_SCANS.load(Ordering::Relaxed) < BLOCK_SCANS as u32 {
            return;
        }
        Timer::after(SAMPLER_POLL).await;
    }
}

/// Make the next checkpoint's slot ready (erasing a sector if it is due), after letting the sampler drain.
/// Returns how long the erase held the CPU, us (0: none was due).
async fn prepare<F: LogFlash>(log: &mut FieldLog<F>) -> u32 {
    settle().await;
    let t0 = timebase::now_us();
    match log.prepare_append() {
        Ok(true) => {
            let us = saturate(timebase::now_us() - t0);
            defmt::info!("field log: sector erased for the next checkpoint in {} us", us);
            us
        }
        Ok(false) => 0,
        Err(e) => {
            defmt::warn!("field log: erase failed (the next checkpoint tries again): {}", defmt::Debug2Format(&e));
            0
        }
    }
}

/// A host asked for the field log from this checkpoint on, in the command frame with this sequence number
/// (link task -> store).
pub static LOG_READ: Signal<CriticalSectionRawMutex, LogRead> = Signal::new();

/// A host asked for a checkpoint now, in the command frame with this sequence number (link task -> store).
pub static CHECKPOINT_NOW: Signal<CriticalSectionRawMutex, u32> = Signal::new();

/// A field-log read request.
#[derive(Clone, Copy)]
pub struct LogRead {
    /// The command frame's sequence number (acknowledged before the read-out).
    pub seq: u32,
    /// The first checkpoint wanted.
    pub from: u32,
}

/// The longest a read-out waits for room in the frame queue, per frame.
pub const READ_OUT_FRAME_WAIT: Duration = Duration::from_secs(2);

/// Checkpoints snapshot rounds, answers field-log reads, and writes a checkpoint when a host asks, with a report
/// of what it cost; generic over the controller behind the flash (the board's or QEMU's model).
///
/// Only the log, the policy (with its base checkpoint), one record's words and, while [`settle`] waits before
/// a checkpoint, that round live across the waits (this future is a static).
pub async fn run<F: LogFlash<Error = FlashError>>(flash: F) -> ! {
    let mut words = [0u32; CHECKPOINT_WORDS];
    let mut log = match FieldLog::open(flash, CHECKPOINT_WORDS) {
        Ok(log) => log,
        Err(e) => panic!("field log: {:?}", e),
    };
    let (mut policy, boot) = CheckpointPolicy::<GYROS>::open(&mut log, &mut words, CHECKPOINT_EVERY_SCANS);
    match (boot, policy.base()) {
        (Ok(Some(seq)), Some(cp)) => {
            defmt::info!(
                "field log: checkpoint {} of {} sessions, {} samples",
                seq,
                cp.sessions,
                cp.snapshots[0].samples
            )
        }
        (Ok(_), _) => defmt::info!("field log: empty"),
        (Err(e), _) => defmt::warn!("field log: {}", defmt::Debug2Format(&e)),
    }
    prepare(&mut log).await;
    // A host's request for a checkpoint, written at the next round.
    let mut forced: Option<u32> = None;
    loop {
        // The round lives only in this arm, so it is not kept across the read-out's waits.
        let read = match select3(SNAPSHOT_READY.wait(), LOG_READ.wait(), CHECKPOINT_NOW.wait()).await {
            Either3::First(round) => {
                let force = forced.take();
                if force.is_none() && !policy.due(round.samples) {
                    continue;
                }
                settle().await;
                let lost_before = crate::sampler::SCANS_LOST.load(Ordering::Relaxed);
                let t0 = timebase::now_us();
                let (snaps, overruns, samples) = (&round.snapshots, round.adc_overruns, round.samples);
                let written = match force {
                    Some(_) => policy.round_now(&mut log, &mut words, snaps, overruns, samples),
                    None => policy.round(&mut log, &mut words, snaps, overruns, samples),
                };
                let program_us = timebase::now_us() - t0;
                let (checkpoint, flash_error) = match written {
                    Ok(RoundOutcome::Written { seq, sessions, new_session }) => {
                        defmt::info!(
                            "field log: checkpoint {} ({} samples this session, {} sessions{}), {} us",
                            seq,
                            samples,
                            sessions,
                            if new_session { ", after a reset" } else { "" },
                            program_us
                        );
                        (seq, 0)
                    }
                    Ok(RoundOutcome::NotDue) => (0, 0),
                    Err(e) => {
                        defmt::warn!("field log: checkpoint failed: {}", defmt::Debug2Format(&e));
                        (0, flash_flags(&e))
                    }
                };
                let erase_us = prepare(&mut log).await;
                if let Some(seq) = force {
                    // The sampler has caught up after the stalls: what it lost is counted.
                    settle().await;
                    let samples_lost = crate::sampler::SCANS_LOST.load(Ordering::Relaxed).wrapping_sub(lost_before);
                    let report = CheckpointReport {
                        seq,
                        checkpoint,
                        program_us: saturate(program_us),
                        erase_us,
                        samples_lost,
                        flash_error,
                    };
                    if frames::send_within(Frame::CheckpointReport(report), READ_OUT_FRAME_WAIT).await.is_err() {
                        defmt::warn!("field log: the checkpoint report found no room in the frame queue");
                    }
                }
                continue;
            }
            Either3::Second(read) => read,
            Either3::Third(seq) => {
                forced = Some(seq);
                continue;
            }
        };
        match read_out(&mut log, read, &mut words).await {
            Ok(()) => defmt::info!("field log: read out"),
            Err(_) => defmt::warn!("field log: read-out abandoned (the host went away or stopped reading)"),
        }
    }
}

/// Microseconds in a u32 (71 minutes at most).
fn saturate(us: u64) -> u32 {
    us.min(u64::from(u32::MAX)) as u32
}

/// FLASH_SR's error flags of a failed checkpoint (`u32::MAX` when the log itself refused it).
fn flash_flags(e: &LogError<FlashError>) -> u32 {
    match e {
        LogError::Flash(f) if f.flags != 0 => f.flags,
        _ => u32::MAX,
    }
}

/// Acknowledge the request, then send the newest checkpoint one frame at a time (decode the record, send its
/// i-th part, until there are no more), then the end frame. Any frame not taken within the bound ends it.
async fn read_out<F: LogFlash>(
    log: &mut FieldLog<F>,
    read: LogRead,
    words: &mut [u32; CHECKPOINT_WORDS],
) -> Result<(), frames::NotSent> {
    frames::send_within(Frame::Ack(Ack { seq: read.seq }), READ_OUT_FRAME_WAIT).await?;
    let mut sent = 0;
    let mut i = 0;
    while let Some(frame) = read_out_frame::<_, GYROS>(log, read.from, words, i, SAMPLE_RATE_HZ) {
        frames::send_within(frame, READ_OUT_FRAME_WAIT).await?;
        sent = 1;
        i += 1;
    }
    frames::send_within(Frame::FieldLogEnd(FieldLogEnd { checkpoints: sent }), READ_OUT_FRAME_WAIT).await
}

/// The field log's flash on the board: sectors 1 and 2 through the shared controller sequences at x32.
#[cfg(not(feature = "qemu"))]
pub type BoardFlash = octavar_shared::flash_f4::F4LogFlash<crate::flash_regs::PacFlash>;

/// The board's log flash from the store's parts.
#[cfg(not(feature = "qemu"))]
pub fn board_flash(parts: crate::board::StoreParts) -> BoardFlash {
    let sectors = octavar_shared::fieldlog::STM32F405_LOG_SECTORS;
    BoardFlash::new(parts.flash, sectors, sectors[0].bytes as usize / 4)
}

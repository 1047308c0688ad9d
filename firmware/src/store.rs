//! The store task: the field log. Checkpoints the snapshot rounds to flash at most every ten minutes and reads
//! them back for the host after a power cycle.
//!
//! The log logic (record format, recovery, write order, power-cut safety) is `octavar_shared::fieldlog`, tested
//! on the host, and so is the policy (`octavar_shared::fieldlog::Recorder`): at boot, and after a host reset, the
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

use embassy_futures::select::{select, Either};
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::signal::Signal;
use embassy_time::Duration;
use octavar_shared::fieldlog::{Checkpoint, FieldLog, LogFlash, Recorded, Recorder};
use octavar_shared::proto::{Ack, FieldLogEnd, FieldLogRecord, Frame, SnapshotPart};

use crate::characterize::SNAPSHOT_READY;
use crate::config::*;
use crate::frames;

/// The checkpoint type of this firmware: one snapshot per gyro.
pub type GyroCheckpoint = Checkpoint<GYROS>;
/// Payload words of one checkpoint.
pub const CHECKPOINT_WORDS: usize = GyroCheckpoint::WORDS;

/// A host asked for the field log from this checkpoint on, in the command frame with this sequence number
/// (link task -> store).
pub static LOG_READ: Signal<CriticalSectionRawMutex, LogRead> = Signal::new();

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

/// Checkpoints snapshot rounds and answers field-log reads; generic over the flash (real or RAM).
///
/// Only the log, the recorder (with its base checkpoint) and one record's words live across the waits (this
/// future is a static).
pub async fn run<F: LogFlash>(flash: F) -> ! {
    let mut words = [0u32; CHECKPOINT_WORDS];
    let mut log = match FieldLog::open(flash, CHECKPOINT_WORDS) {
        Ok(log) => log,
        Err(e) => panic!("field log: {:?}", e),
    };
    let (mut recorder, boot) = Recorder::<GYROS>::open(&mut log, &mut words, CHECKPOINT_EVERY_SCANS);
    match (boot, recorder.base()) {
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
    loop {
        // The round is handled inside the match (no await there), so it is not kept across the read-out's waits.
        let read_from = match select(SNAPSHOT_READY.wait(), LOG_READ.wait()).await {
            Either::First(round) => {
                match recorder.round(&mut log, &mut words, &round.snapshots, round.adc_overruns, round.samples) {
                    Ok(Recorded::Written { seq, sessions, new_session }) => defmt::info!(
                        "field log: checkpoint {} ({} samples this session, {} sessions{})",
                        seq,
                        round.samples,
                        sessions,
                        if new_session { ", after a reset" } else { "" }
                    ),
                    Ok(Recorded::NotDue) => {}
                    Err(e) => defmt::warn!("field log: checkpoint failed: {}", defmt::Debug2Format(&e)),
                }
                None
            }
            Either::Second(from) => Some(from),
        };
        if let Some(read) = read_from {
            match read_out(&mut log, read, &mut words).await {
                Ok(()) => defmt::info!("field log: read out"),
                Err(_) => defmt::warn!("field log: read-out abandoned (the host went away or stopped reading)"),
            }
        }
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
    while let Some(frame) = log_frame(log, read.from, words, i) {
        frames::send_within(frame, READ_OUT_FRAME_WAIT).await?;
        sent = 1;
        i += 1;
    }
    frames::send_within(Frame::FieldLogEnd(FieldLogEnd { checkpoints: sent }), READ_OUT_FRAME_WAIT).await
}

/// The `i`-th field-log frame of the newest checkpoint, if its number is at least `from`.
fn log_frame<F: LogFlash>(
    log: &mut FieldLog<F>,
    from: u32,
    words: &mut [u32; CHECKPOINT_WORDS],
    i: usize,
) -> Option<Frame> {
    let seq = log.read_latest(words).ok()??;
    if seq < from {
        return None;
    }
    let cp = GyroCheckpoint::decode::<()>(words).ok()?;
    let mut k = 0;
    for (g, snap) in cp.snapshots.iter().enumerate() {
        for part in SnapshotPart::split(g as u8, snap) {
            if k == i {
                return Some(Frame::FieldLog(FieldLogRecord {
                    checkpoint: seq,
                    time_s: (snap.samples / u64::from(SAMPLE_RATE_HZ)) as u32,
                    sessions: cp.sessions,
                    adc_overruns: cp.adc_overruns,
                    part,
                }));
            }
            k += 1;
        }
    }
    None
}

/// The field log's flash on the board: sectors 1 and 2 through embassy-stm32's blocking flash driver.
#[cfg(not(feature = "qemu"))]
pub struct BoardFlash {
    flash: embassy_stm32::flash::Flash<'static, embassy_stm32::flash::Blocking>,
}

#[cfg(not(feature = "qemu"))]
impl BoardFlash {
    /// Take the flash from the store's parts.
    pub fn new(parts: crate::board::StoreParts) -> Self {
        Self { flash: parts.flash }
    }

    /// Byte offset from the start of flash (what embassy-stm32 takes) of `word` in `sector`.
    fn offset(sector: usize, word: usize) -> u32 {
        use octavar_shared::fieldlog::STM32F405_LOG_SECTORS;
        STM32F405_LOG_SECTORS[sector].address - embassy_stm32::flash::FLASH_BASE as u32 + 4 * word as u32
    }
}

#[cfg(not(feature = "qemu"))]
impl LogFlash for BoardFlash {
    type Error = embassy_stm32::flash::Error;

    fn sector_words(&self) -> usize {
        octavar_shared::fieldlog::STM32F405_LOG_SECTORS[0].bytes as usize / 4
    }

    fn erase(&mut self, sector: usize) -> Result<(), Self::Error> {
        let from = Self::offset(sector, 0);
        let to = from + octavar_shared::fieldlog::STM32F405_LOG_SECTORS[sector].bytes;
        defmt::info!("field log: erasing sector {}", octavar_shared::fieldlog::STM32F405_LOG_SECTORS[sector].index);
        let result = self.flash.blocking_erase(from, to);
        crate::board::flash_caches_reset();
        result
    }

    fn write(&mut self, sector: usize, offset: usize, words: &[u32]) -> Result<(), Self::Error> {
        let mut bytes = [0u8; 64];
        let written = words.chunks(16).enumerate().try_for_each(|(i, chunk)| {
            for (b, w) in bytes.chunks_exact_mut(4).zip(chunk) {
                b.copy_from_slice(&w.to_le_bytes());
            }
            self.flash.blocking_write(Self::offset(sector, offset + 16 * i), &bytes[..4 * chunk.len()])
        });
        // Once for the whole record, whether or not it was all written.
        crate::board::flash_caches_reset();
        written
    }

    fn read(&mut self, sector: usize, offset: usize, buf: &mut [u32]) -> Result<(), Self::Error> {
        let mut bytes = [0u8; 64];
        for (i, chunk) in buf.chunks_mut(16).enumerate() {
            let n = 4 * chunk.len();
            self.flash.blocking_read(Self::offset(sector, offset + 16 * i), &mut bytes[..n])?;
            for (w, b) in chunk.iter_mut().zip(bytes.chunks_exact(4)) {
                *w = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
            }
        }
        Ok(())
    }
}

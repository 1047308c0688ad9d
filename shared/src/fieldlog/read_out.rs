//! The field log read out over the link: the frames that carry the newest checkpoint to the host.
//!
//! The firmware's store task and the host tests' simulated board answer `ReadFieldLog` with the same frames, so
//! the framing lives here once. Each frame is built on demand from the flash (one checkpoint buffer, no frame
//! list), because the firmware sends them one at a time as the link takes them.

use super::{Checkpoint, FieldLog, LogFlash};
use crate::proto::{FieldLogRecord, Frame, SnapshotPart};

/// The `i`-th [`Frame::FieldLog`] of the newest checkpoint in `log`, if that checkpoint's number is at least
/// `from` and it has an `i`-th part; `None` ends the read-out.
///
/// The checkpoint holds `CH` gyro snapshots; each is sent as its [`SnapshotPart::split`] parts, gyro by gyro.
/// `words` is a buffer of [`Checkpoint::<CH>::WORDS`](Checkpoint::WORDS) words; `rate_hz` turns each snapshot's
/// sample count into the record's `time_s`. A log that cannot be read, or a checkpoint of another length, gives
/// `None`: the host then sees an end frame with nothing before it.
pub fn read_out_frame<F: LogFlash, const CH: usize>(
    log: &mut FieldLog<F>,
    from: u32,
    words: &mut [u32],
    i: usize,
    rate_hz: u32,
) -> Option<Frame> {
    let seq = log.read_latest(words).ok()??;
    if seq < from {
        return None;
    }
    let cp = Checkpoint::<CH>::decode::<()>(words).ok()?;
    let (snap, part) = cp
        .snapshots
        .iter()
        .enumerate()
        .flat_map(|(g, snap)| SnapshotPart::split(g as u8, snap).map(move |part| (snap, part)))
        .nth(i)?;
    Some(Frame::FieldLog(FieldLogRecord {
        checkpoint: seq,
        time_s: (snap.samples / u64::from(rate_hz.max(1))) as u32,
        sessions: cp.sessions,
        adc_overruns: cp.adc_overruns,
        part,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::acc::OctaveAllan;
    use crate::fieldlog::RamFlash;

    /// A checkpoint of two gyros that saw `n` samples each, with different signals.
    fn checkpoint(n: u32) -> Checkpoint<2> {
        let mut a = OctaveAllan::<1>::new();
        let mut b = OctaveAllan::<1>::new();
        for k in 0..n {
            a.push((32_768 + (k.wrapping_mul(2_654_435_761) >> 22)) as u16);
            b.push((30_000 + (k * 7 % 13)) as u16);
        }
        Checkpoint { sessions: 3, adc_overruns: 2, snapshots: [a.snapshot(), b.snapshot()] }
    }

    /// Every frame of a read-out, in order, until the first `None`.
    fn read_all(log: &mut FieldLog<RamFlash<4096>>, from: u32) -> Vec<FieldLogRecord> {
        let mut words = [0u32; Checkpoint::<2>::WORDS];
        (0..)
            .map_while(|i| read_out_frame::<_, 2>(log, from, &mut words, i, 100))
            .map(|f| match f {
                Frame::FieldLog(r) => r,
                other => panic!("a field-log frame, not {other:?}"),
            })
            .collect()
    }

    #[test]
    fn the_frames_join_back_into_the_newest_checkpoint() {
        let mut log = FieldLog::open(RamFlash::<4096>::new(), Checkpoint::<2>::WORDS).unwrap();
        let mut words = [0u32; Checkpoint::<2>::WORDS];
        checkpoint(5_000).encode::<()>(&mut words).unwrap();
        log.append(&words).unwrap();
        let newest = checkpoint(70_000);
        newest.encode::<()>(&mut words).unwrap();
        log.append(&words).unwrap();

        let records = read_all(&mut log, 0);
        assert!(records.iter().all(|r| r.checkpoint == 2 && r.sessions == 3 && r.adc_overruns == 2));
        assert!(records.iter().all(|r| r.time_s == 700), "70,000 samples at 100 Hz");
        for g in 0..2u8 {
            let parts: Vec<_> = records.iter().filter(|r| r.part.channel == g).map(|r| r.part.clone()).collect();
            let (channel, snap) = SnapshotPart::join(parts.iter()).unwrap();
            assert_eq!((channel, snap), (g, newest.snapshots[usize::from(g)]));
        }
        assert!(records.windows(2).all(|w| w[0].part.channel <= w[1].part.channel), "gyro by gyro");
    }

    #[test]
    fn nothing_is_sent_from_an_empty_log_or_before_from() {
        let mut log = FieldLog::open(RamFlash::<4096>::new(), Checkpoint::<2>::WORDS).unwrap();
        assert!(read_all(&mut log, 0).is_empty(), "an empty log");
        let mut words = [0u32; Checkpoint::<2>::WORDS];
        checkpoint(1_000).encode::<()>(&mut words).unwrap();
        log.append(&words).unwrap();
        assert!(read_all(&mut log, 2).is_empty(), "the newest checkpoint is number 1");
        assert!(!read_all(&mut log, 1).is_empty());
    }
}

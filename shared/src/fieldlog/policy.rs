//! The field log's policy: when to write a checkpoint and what to pool into it, across power cycles and host
//! resets. The firmware's store task runs it on the board's flash; the tests run it on [`super::RamFlash`].

use super::{Checkpoint, FieldLog, LogError, LogFlash};
use crate::acc::Snapshot;

/// Writes the checkpoints of a deployment: each one pools every earlier session (the newest checkpoint in the
/// log when the session began) with the current session's snapshots, at most one per `every` samples.
///
/// A session begins at power-on ([`CheckpointPolicy::open`]) and at a host reset, which empties the accumulators and
/// restarts the session's sample count. The policy sees a reset as a round with fewer samples than its last
/// checkpoint had, and then takes the log's newest checkpoint (the one that pooled the session just ended) as
/// the new base, so the log keeps covering the whole deployment. Without that, a reset made every later
/// checkpoint pool only the power-on base (the ended session vanished from the log) and held off the next
/// checkpoint until the new session had as many samples as the old one had at its last checkpoint. As with a
/// power cut, what the ended session gathered after its last checkpoint is not in the log.
///
/// Only the base lives in RAM (no copy of the last checkpoint written: a reset reads it back from the log).
pub struct CheckpointPolicy<const CH: usize> {
    base: Option<Checkpoint<CH>>,
    last: Option<u64>,
    every: u64,
}

/// What [`CheckpointPolicy::round`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RoundOutcome {
    /// The last checkpoint is too recent; nothing written.
    NotDue,
    /// A checkpoint was written with this sequence number; `new_session` when a reset was seen first.
    Written {
        /// Its sequence number in the log.
        seq: u32,
        /// Sessions it pools.
        sessions: u32,
        /// Whether this round began a new session (a host reset).
        new_session: bool,
    },
}

impl<const CH: usize> CheckpointPolicy<CH> {
    /// At power-on: the log's newest checkpoint (if any, and readable) is the base of this session. `words` is a
    /// buffer of [`Checkpoint::WORDS`] words. Returns the policy and the base's sequence number.
    ///
    /// # Errors
    /// The log's [`LogError`] when it cannot be read; the policy then starts without a base.
    pub fn open<F: LogFlash>(
        log: &mut FieldLog<F>,
        words: &mut [u32],
        every: u64,
    ) -> (Self, Result<Option<u32>, LogError<F::Error>>) {
        let mut r = CheckpointPolicy { base: None, last: None, every };
        let read = r.reload(log, words);
        (r, read)
    }

    /// The base this session pools with.
    pub fn base(&self) -> Option<&Checkpoint<CH>> {
        self.base.as_ref()
    }

    /// Whether [`CheckpointPolicy::round`] with `samples` would write a checkpoint: none yet this session, a reset (fewer
    /// samples than at the last one), or the last one at least `every` samples old.
    pub fn due(&self, samples: u64) -> bool {
        self.last.is_none_or(|s| samples < s || samples >= s + self.every)
    }

    /// A round of snapshots of the current session (`samples` scans since the session began): writes the pooled
    /// checkpoint when the last one is at least `every` samples old (or there is none this session).
    ///
    /// # Errors
    /// The log's [`LogError`]: encoding or appending failed (the round is not checkpointed; the next one tries
    /// again).
    pub fn round<F: LogFlash>(
        &mut self,
        log: &mut FieldLog<F>,
        words: &mut [u32],
        snapshots: &[Snapshot; CH],
        adc_overruns: u32,
        samples: u64,
    ) -> Result<RoundOutcome, LogError<F::Error>> {
        self.checkpoint(log, words, snapshots, adc_overruns, samples, false)
    }

    /// As [`CheckpointPolicy::round`], but written whether or not it is due (a host asked for a checkpoint).
    ///
    /// # Errors
    /// As [`CheckpointPolicy::round`].
    pub fn round_now<F: LogFlash>(
        &mut self,
        log: &mut FieldLog<F>,
        words: &mut [u32],
        snapshots: &[Snapshot; CH],
        adc_overruns: u32,
        samples: u64,
    ) -> Result<RoundOutcome, LogError<F::Error>> {
        self.checkpoint(log, words, snapshots, adc_overruns, samples, true)
    }

    fn checkpoint<F: LogFlash>(
        &mut self,
        log: &mut FieldLog<F>,
        words: &mut [u32],
        snapshots: &[Snapshot; CH],
        adc_overruns: u32,
        samples: u64,
        force: bool,
    ) -> Result<RoundOutcome, LogError<F::Error>> {
        let new_session = self.last.is_some_and(|s| samples < s);
        if new_session {
            // A reset: the checkpoint last written pooled the session that ended.
            self.reload(log, words)?;
        }
        if !force && self.last.is_some_and(|s| samples < s + self.every) {
            return Ok(RoundOutcome::NotDue);
        }
        let cp = Checkpoint::merge_session(self.base.as_ref(), snapshots, adc_overruns);
        cp.encode(words)?;
        let seq = log.append(words)?;
        self.last = Some(samples);
        Ok(RoundOutcome::Written { seq, sessions: cp.sessions, new_session })
    }

    /// Take the log's newest checkpoint as the base (none when the log is empty or it does not decode) and
    /// start a session. When the log cannot be read, nothing changes: after a reset the next round sees it again
    /// and tries again, rather than checkpointing the new session without the deployment's history.
    fn reload<F: LogFlash>(
        &mut self,
        log: &mut FieldLog<F>,
        words: &mut [u32],
    ) -> Result<Option<u32>, LogError<F::Error>> {
        let seq = log.read_latest(words)?;
        self.base = seq.and_then(|_| Checkpoint::decode::<F::Error>(words).ok());
        self.last = None;
        Ok(seq)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::acc::OctaveAllan;
    use crate::fieldlog::RamFlash;

    const EVERY: u64 = 1000;

    /// `n` more samples into both accumulators.
    fn feed(accs: &mut [OctaveAllan<8>; 2], n: u32, salt: u32) {
        for i in 0..n {
            accs[0].push((2048 + (i * 7919 + salt) % 61) as u16);
            accs[1].push((1000 + (i * 104_729 + salt) % 4000) as u16);
        }
    }

    /// Two fresh accumulators with `n` samples each.
    fn fed(n: u32, salt: u32) -> [OctaveAllan<8>; 2] {
        let mut accs = [OctaveAllan::<8>::new(), OctaveAllan::<8>::new()];
        feed(&mut accs, n, salt);
        accs
    }

    fn snaps(accs: &[OctaveAllan<8>; 2]) -> [Snapshot; 2] {
        [accs[0].snapshot(), accs[1].snapshot()]
    }

    fn newest(log: &mut FieldLog<RamFlash<4096>>) -> Checkpoint<2> {
        let mut w = vec![0u32; Checkpoint::<2>::WORDS];
        log.read_latest(&mut w).unwrap().expect("a checkpoint");
        Checkpoint::decode::<()>(&w).unwrap()
    }

    #[test]
    fn checkpoints_come_every_interval_and_pool_power_cycles() {
        let mut log = FieldLog::open(RamFlash::<4096>::new(), Checkpoint::<2>::WORDS).unwrap();
        let mut w = vec![0u32; Checkpoint::<2>::WORDS];
        let (mut rec, read) = CheckpointPolicy::<2>::open(&mut log, &mut w, EVERY);
        assert_eq!(read, Ok(None));
        let mut accs = [OctaveAllan::<8>::new(), OctaveAllan::<8>::new()];
        let mut written = 0;
        for k in 1..=10u32 {
            feed(&mut accs, 300, k);
            let due = rec.due(u64::from(300 * k));
            let r = rec.round(&mut log, &mut w, &snaps(&accs), 0, u64::from(300 * k)).unwrap();
            assert_eq!(due, matches!(r, RoundOutcome::Written { .. }), "due says what the round does");
            written += usize::from(due);
        }
        // At 300 (the first), 1500, 2700: every 1000 samples at the earliest.
        assert_eq!(written, 3);
        assert_eq!(newest(&mut log).snapshots[0].samples, 2700);
        // Power cycle: the new session pools with the newest checkpoint.
        let mut log = FieldLog::open(log.into_flash(), Checkpoint::<2>::WORDS).unwrap();
        let (mut rec, read) = CheckpointPolicy::<2>::open(&mut log, &mut w, EVERY);
        assert!(matches!(read, Ok(Some(_))));
        let r = rec.round(&mut log, &mut w, &snaps(&fed(500, 99)), 2, 500).unwrap();
        assert!(matches!(r, RoundOutcome::Written { sessions: 2, new_session: false, .. }), "{r:?}");
        let cp = newest(&mut log);
        assert_eq!((cp.sessions, cp.adc_overruns, cp.snapshots[1].samples), (2, 2, 3200));
    }

    /// A checkpoint a host asks for is written when none is due, and the schedule runs on from it.
    #[test]
    fn a_forced_checkpoint_is_written_when_none_is_due() {
        let mut log = FieldLog::open(RamFlash::<4096>::new(), Checkpoint::<2>::WORDS).unwrap();
        let mut w = vec![0u32; Checkpoint::<2>::WORDS];
        let (mut rec, _) = CheckpointPolicy::<2>::open(&mut log, &mut w, EVERY);
        let mut accs = fed(1500, 1);
        assert!(matches!(rec.round(&mut log, &mut w, &snaps(&accs), 0, 1500).unwrap(), RoundOutcome::Written { .. }));
        feed(&mut accs, 200, 2);
        assert_eq!(rec.round(&mut log, &mut w, &snaps(&accs), 0, 1700).unwrap(), RoundOutcome::NotDue);
        let r = rec.round_now(&mut log, &mut w, &snaps(&accs), 0, 1700).unwrap();
        assert!(matches!(r, RoundOutcome::Written { seq: 2, sessions: 1, new_session: false }), "{r:?}");
        assert_eq!(newest(&mut log).snapshots[0].samples, 1700);
        assert!(!rec.due(1700 + EVERY - 1) && rec.due(1700 + EVERY));
    }

    /// A host reset restarts the session's count: the next round is checkpointed at once, pooled with the
    /// checkpoint that covered the ended session (not only with the power-on base).
    #[test]
    fn a_reset_starts_a_session_pooled_with_the_one_it_ended() {
        let mut log = FieldLog::open(RamFlash::<4096>::new(), Checkpoint::<2>::WORDS).unwrap();
        let mut w = vec![0u32; Checkpoint::<2>::WORDS];
        let (mut rec, _) = CheckpointPolicy::<2>::open(&mut log, &mut w, EVERY);
        let mut accs = fed(5000, 1);
        rec.round(&mut log, &mut w, &snaps(&accs), 1, 5000).unwrap();
        feed(&mut accs, 200, 2);
        assert_eq!(rec.round(&mut log, &mut w, &snaps(&accs), 1, 5200).unwrap(), RoundOutcome::NotDue);
        // Reset: empty accumulators, the count from 0.
        let mut after = fed(300, 3);
        assert!(rec.due(300), "a reset is due at once");
        let r = rec.round(&mut log, &mut w, &snaps(&after), 0, 300).unwrap();
        assert!(matches!(r, RoundOutcome::Written { sessions: 2, new_session: true, .. }), "{r:?}");
        let cp = newest(&mut log);
        // 5000 logged before the reset (the 200 after the last checkpoint are lost, as in a power cut) + 300.
        assert_eq!((cp.sessions, cp.adc_overruns, cp.snapshots[0].samples), (2, 1, 5300));
        // The next checkpoint of the new session comes EVERY samples later and still pools the ended one.
        feed(&mut after, 1000, 4);
        let r = rec.round(&mut log, &mut w, &snaps(&after), 0, 1300).unwrap();
        assert!(matches!(r, RoundOutcome::Written { sessions: 2, new_session: false, .. }), "{r:?}");
        assert_eq!(newest(&mut log).snapshots[1].samples, 6300);
    }

    /// A reset seen while the log cannot be read changes nothing: the next round sees the reset again and pools
    /// the ended session once the log reads (rather than checkpointing the new session alone).
    #[test]
    fn a_reset_met_by_an_unreadable_log_is_retried() {
        let mut log = FieldLog::open(RamFlash::<4096>::new(), Checkpoint::<2>::WORDS).unwrap();
        let mut w = vec![0u32; Checkpoint::<2>::WORDS];
        let (mut rec, _) = CheckpointPolicy::<2>::open(&mut log, &mut w, EVERY);
        let accs = fed(5000, 1);
        rec.round(&mut log, &mut w, &snaps(&accs), 0, 5000).unwrap();
        // The power fails during the next checkpoint: the flash reads nothing until it is powered on again.
        let mut flash = log.into_flash();
        flash.cut_after(1, 7);
        let mut log = FieldLog::open(flash, Checkpoint::<2>::WORDS).unwrap();
        assert!(rec.round(&mut log, &mut w, &snaps(&fed(6100, 2)), 0, 6100).is_err());
        // A reset now: the log cannot be read back.
        assert!(rec.round(&mut log, &mut w, &snaps(&fed(300, 3)), 0, 300).is_err());
        let mut flash = log.into_flash();
        flash.power_on();
        let mut log = FieldLog::open(flash, Checkpoint::<2>::WORDS).unwrap();
        let r = rec.round(&mut log, &mut w, &snaps(&fed(400, 4)), 0, 400).unwrap();
        assert!(matches!(r, RoundOutcome::Written { sessions: 2, new_session: true, .. }), "{r:?}");
        assert_eq!(newest(&mut log).snapshots[0].samples, 5400);
    }
}

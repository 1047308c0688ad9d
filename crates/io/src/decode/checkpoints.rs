//! The field-log checkpoints of a capture: the [`FieldLogSnapshot`]s of a read-out grouped by checkpoint, and
//! which checkpoints arrived whole.
//!
//! A checkpoint pools every session of the deployment up to the moment it was written (the device merges each
//! session into the newest checkpoint before it), so the newest whole checkpoint is the logged session's whole
//! record; older ones are earlier states of it. A checkpoint is whole when every gyro channel of the device's
//! hello (or, without a hello, channels 0..k with none missing) arrived joined from intact parts (each frame's
//! CRC-32 checked by the decoder, and each record's CRC in flash by the device before it sent it), the read-out
//! that carried it ended with its `FieldLogEnd` with no frame lost since its acknowledgement (the frames'
//! sequence numbers), and the channels agree on the sample count.

use std::collections::BTreeMap;

use octavar_shared::acc::Snapshot;
use octavar_shared::proto::Hello;
use octavar_shared::sensor::GyroModel;

use super::{Decoded, FieldLogSnapshot, Message};

/// One checkpoint as read back.
#[derive(Clone, Debug, PartialEq)]
pub struct Checkpoint {
    /// Its number in the device's log.
    pub number: u32,
    /// Sampling time covered, s.
    pub time_s: u32,
    /// Power-on sessions pooled.
    pub sessions: u32,
    /// Sample losses over those sessions.
    pub adc_overruns: u32,
    /// Each channel's pooled snapshot, by channel index.
    pub channels: BTreeMap<u8, Snapshot>,
    /// A `FieldLogEnd` followed its frames.
    pub ended: bool,
}

impl Checkpoint {
    /// Whether it arrived whole for the gyro channels `expected` (`None`: 0..k, none missing).
    pub fn is_whole(&self, expected: Option<&[u8]>) -> bool {
        let have: Vec<u8> = self.channels.keys().copied().collect();
        let channels_ok = match expected {
            Some(e) => e == have.as_slice(),
            None => !have.is_empty() && have.iter().enumerate().all(|(i, &c)| usize::from(c) == i),
        };
        let mut counts = self.channels.values().map(|s| s.samples);
        let first = counts.next();
        self.ended && channels_ok && counts.all(|n| Some(n) == first)
    }

    /// Samples per channel (the same on every channel of a whole checkpoint).
    pub fn samples(&self) -> u64 {
        self.channels.values().map(|s| s.samples).max().unwrap_or(0)
    }
}

/// Collects the checkpoints of a stream of decoded records.
#[derive(Clone, Debug, Default)]
pub struct Checkpoints {
    /// Every checkpoint seen, by number (a checkpoint read twice keeps its latest copy).
    pub by_number: BTreeMap<u32, Checkpoint>,
    /// The gyro channels of the last hello.
    pub gyros: Option<Vec<u8>>,
    /// Checkpoint numbers that went down within one read-out (a log that was cleared, or frames from two
    /// devices).
    pub out_of_order: u32,
    last_number: Option<u32>,
    /// Checkpoints of the read-out in progress (not yet ended).
    open: Vec<u32>,
    /// A frame was lost (a sequence gap, a damaged frame) or the device restarted since the read-out's
    /// acknowledgement: its checkpoints cannot be trusted whole.
    damaged: bool,
}

impl Checkpoints {
    /// Nothing yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Take one decoded record.
    pub fn take(&mut self, d: &Decoded) {
        if d.meta.lost > 0 || d.meta.restart {
            self.damaged = true;
        }
        match &d.message {
            Message::Hello(h) => self.gyros = Some(gyro_channels(h)),
            // A read-out starts with its acknowledgement: what was lost before it does not touch it.
            Message::Ack(_) => self.damaged = d.meta.restart,
            Message::FieldLog(f) => self.snapshot(f),
            Message::FieldLogEnd(_) => {
                for n in self.open.drain(..) {
                    if let Some(cp) = self.by_number.get_mut(&n) {
                        cp.ended = !self.damaged;
                    }
                }
                self.last_number = None;
                self.damaged = false;
            }
            _ => {}
        }
    }

    fn snapshot(&mut self, f: &FieldLogSnapshot) {
        if self.last_number.is_some_and(|n| f.checkpoint < n) {
            self.out_of_order += 1;
        }
        self.last_number = Some(f.checkpoint);
        if !self.open.contains(&f.checkpoint) {
            // A fresh read-out of this checkpoint replaces an older copy.
            self.open.push(f.checkpoint);
            self.by_number.insert(
                f.checkpoint,
                Checkpoint {
                    number: f.checkpoint,
                    time_s: f.time_s,
                    sessions: f.sessions,
                    adc_overruns: f.adc_overruns,
                    channels: BTreeMap::new(),
                    ended: false,
                },
            );
        }
        if let Some(cp) = self.by_number.get_mut(&f.checkpoint) {
            cp.channels.insert(f.channel, f.snapshot);
        }
    }

    /// The newest checkpoint that arrived whole.
    pub fn newest_whole(&self) -> Option<&Checkpoint> {
        self.by_number.values().rev().find(|cp| cp.is_whole(self.gyros.as_deref()))
    }
}

/// The channels of a hello that are gyros (the ones the device accumulates and checkpoints).
pub fn gyro_channels(hello: &Hello) -> Vec<u8> {
    hello.channels.iter().enumerate().filter(|(_, c)| GyroModel::of(c.kind).is_some()).map(|(i, _)| i as u8).collect()
}

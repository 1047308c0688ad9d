//! Snapshots on the wire: an accumulator [`Snapshot`] split into parts that each fit one frame, and joined again.
//!
//! Only the levels up to the last one with `n > 0` travel (with `n` decreasing in the level, that is exactly the
//! levels with `n > 0`), [`LEVELS_PER_PART`] levels per part: worst case two parts per channel, usually one or
//! two. All parts of one snapshot carry the same channel, stride and sample count, which is how the host
//! matches them; `level_count` tells it when it has them all.
//!
//! # Examples
//! ```
//! use octavar_shared::acc::OctaveAllan;
//! use octavar_shared::proto::SnapshotPart;
//! let mut acc = OctaveAllan::<8>::new();
//! (0..100_000u32).for_each(|i| acc.push((i * 7919 % 4096) as u16));
//! let snap = acc.snapshot();
//! let parts: Vec<SnapshotPart> = SnapshotPart::split(3, &snap).collect();
//! assert_eq!(parts.len(), 1); // 15 levels with n > 0
//! assert_eq!(SnapshotPart::join(&parts), Ok((3, snap)));
//! ```

use heapless::Vec;
use serde::{Deserialize, Serialize};

use super::LEVELS_PER_PART;
use crate::acc::{LevelSum, Snapshot, LEVELS};

/// A run of consecutive levels of one channel's snapshot: the payload of [`super::Frame::AllanSnapshot`] and
/// [`super::Frame::FieldLog`].
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SnapshotPart {
    /// Channel index.
    pub channel: u8,
    /// Stride S of the accumulator.
    pub stride: u8,
    /// Samples accumulated when the snapshot was taken (the same in every part of it).
    pub samples: u64,
    /// Level of `levels[0]`.
    pub first_level: u8,
    /// Levels the whole snapshot sends: levels from `level_count` on have `n == 0`.
    pub level_count: u8,
    /// Levels `first_level ..` of the snapshot: n and the exact sum of squares.
    pub levels: Vec<LevelSum, LEVELS_PER_PART>,
}

/// Why parts do not join into a snapshot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SnapshotError {
    /// No part was given.
    Empty,
    /// The parts differ in channel, stride, sample count or level count.
    Mismatch,
    /// A part is missing or repeated: the levels are not consecutive from 0 to `level_count`.
    Gap,
    /// A part's levels reach beyond its `level_count` or beyond the accumulator's 32 levels.
    BadRange,
    /// The stride is not a power of two in 1..=64.
    BadStride,
}

impl core::fmt::Display for SnapshotError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            SnapshotError::Empty => "no snapshot part",
            SnapshotError::Mismatch => "snapshot parts differ in channel, stride, sample count or level count",
            SnapshotError::Gap => "snapshot parts are missing or repeated",
            SnapshotError::BadRange => "snapshot part levels out of range",
            SnapshotError::BadStride => "snapshot stride must be a power of two from 1 to 64",
        })
    }
}

impl core::error::Error for SnapshotError {}

impl SnapshotPart {
    /// The parts of `snap` for channel `channel`, in level order; at least one (an empty snapshot still tells
    /// its sample count).
    pub fn split(channel: u8, snap: &Snapshot) -> SnapshotParts<'_> {
        let count = snap.levels.iter().rposition(|l| l.n > 0).map_or(0, |k| k + 1);
        SnapshotParts { channel, snap, count, next: 0, done: false }
    }

    /// Whether this part carries the snapshot's last level.
    pub fn is_last(&self) -> bool {
        usize::from(self.first_level) + self.levels.len() >= usize::from(self.level_count)
    }

    /// Join the parts of one snapshot, in level order, back into the channel index and the [`Snapshot`].
    ///
    /// # Errors
    /// A [`SnapshotError`] when the parts are not exactly one snapshot's parts in order.
    pub fn join<'a, I>(parts: I) -> Result<(u8, Snapshot), SnapshotError>
    where
        I: IntoIterator<Item = &'a SnapshotPart>,
    {
        let mut parts = parts.into_iter();
        let first = parts.next().ok_or(SnapshotError::Empty)?;
        let mut snap = Snapshot::empty(usize::from(first.stride)).map_err(|_| SnapshotError::BadStride)?;
        snap.samples = first.samples;
        let mut next = 0usize;
        for part in core::iter::once(first).chain(parts) {
            if (part.channel, part.stride, part.samples, part.level_count)
                != (first.channel, first.stride, first.samples, first.level_count)
            {
                return Err(SnapshotError::Mismatch);
            }
            let start = usize::from(part.first_level);
            let end = start + part.levels.len();
            if end > usize::from(part.level_count) || end > LEVELS {
                return Err(SnapshotError::BadRange);
            }
            if start != next || (part.levels.is_empty() && part.level_count != 0) {
                return Err(SnapshotError::Gap);
            }
            snap.levels[start..end].copy_from_slice(&part.levels);
            next = end;
        }
        if next != usize::from(first.level_count) {
            return Err(SnapshotError::Gap);
        }
        Ok((first.channel, snap))
    }
}

/// Iterator over the parts of a snapshot (see [`SnapshotPart::split`]).
#[derive(Clone, Debug)]
pub struct SnapshotParts<'a> {
    channel: u8,
    snap: &'a Snapshot,
    /// Levels to send.
    count: usize,
    /// First level of the next part.
    next: usize,
    done: bool,
}

impl Iterator for SnapshotParts<'_> {
    type Item = SnapshotPart;

    fn next(&mut self) -> Option<SnapshotPart> {
        if self.done {
            return None;
        }
        let end = (self.next + LEVELS_PER_PART).min(self.count);
        let mut levels = Vec::new();
        for l in &self.snap.levels[self.next..end] {
            // Cannot fail: at most LEVELS_PER_PART levels.
            let _ = levels.push(*l);
        }
        let part = SnapshotPart {
            channel: self.channel,
            stride: self.snap.stride,
            samples: self.snap.samples,
            first_level: self.next as u8,
            level_count: self.count as u8,
            levels,
        };
        self.next = end;
        self.done = end >= self.count;
        Some(part)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::acc::OctaveAllan;

    fn snapshot_with_levels(count: usize) -> Snapshot {
        let mut s = Snapshot::empty(8).unwrap();
        s.samples = 1 << 40;
        for (k, l) in s.levels.iter_mut().enumerate().take(count) {
            *l = LevelSum { n: 1000 - k as u64, sum_sq: (k as u128) << 100 };
        }
        s
    }

    #[test]
    fn split_and_join_every_level_count() {
        for count in 0..=LEVELS {
            let snap = snapshot_with_levels(count);
            let parts: std::vec::Vec<_> = SnapshotPart::split(5, &snap).collect();
            assert_eq!(parts.len(), count.div_ceil(LEVELS_PER_PART).max(1), "count {count}");
            assert!(parts.last().unwrap().is_last());
            assert!(parts.iter().rev().skip(1).all(|p| !p.is_last()));
            assert_eq!(SnapshotPart::join(&parts), Ok((5, snap)));
        }
    }

    #[test]
    fn join_rejects_wrong_parts() {
        let snap = snapshot_with_levels(32);
        let parts: std::vec::Vec<_> = SnapshotPart::split(1, &snap).collect();
        assert_eq!(SnapshotPart::join(&parts[..1]), Err(SnapshotError::Gap));
        assert_eq!(SnapshotPart::join(&parts[1..]), Err(SnapshotError::Gap));
        assert_eq!(SnapshotPart::join([&parts[1], &parts[0]]), Err(SnapshotError::Gap));
        assert_eq!(SnapshotPart::join([&parts[0], &parts[0]]), Err(SnapshotError::Gap));
        assert_eq!(SnapshotPart::join(core::iter::empty()), Err(SnapshotError::Empty));
        let mut other = parts[1].clone();
        other.samples += 1;
        assert_eq!(SnapshotPart::join([&parts[0], &other]), Err(SnapshotError::Mismatch));
        let mut bad = parts[0].clone();
        bad.level_count = 3;
        assert_eq!(SnapshotPart::join([&bad]), Err(SnapshotError::BadRange));
        bad.level_count = 255;
        bad.first_level = 250;
        assert_eq!(SnapshotPart::join([&bad]), Err(SnapshotError::BadRange));
        bad = parts[0].clone();
        bad.stride = 3;
        assert_eq!(SnapshotPart::join([&bad]), Err(SnapshotError::BadStride));
    }

    #[test]
    fn real_accumulator_round_trip() {
        let mut acc = OctaveAllan::<4>::new();
        (0..300_000u32).for_each(|i| acc.push((i.wrapping_mul(2654435761) >> 20) as u16));
        let snap = acc.snapshot();
        let parts: std::vec::Vec<_> = SnapshotPart::split(0, &snap).collect();
        assert_eq!(parts[0].level_count, 18); // 2 * 2^17 <= 300000 < 2 * 2^18
        assert_eq!(parts.len(), 2);
        assert_eq!(SnapshotPart::join(&parts), Ok((0, snap)));
    }
}

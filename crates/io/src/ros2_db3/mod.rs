//! Reading ROS 2 bags in rosbag2's SQLite storage: one `sensor_msgs/msg/Imu` topic of a `.db3` file, or of a bag
//! directory (`metadata.yaml` beside one or more `.db3` files, read in split order), as a
//! [`Recording`](crate::recording::Recording).
//!
//! SQLite storage was rosbag2's default before MCAP (Humble and earlier), so many recorded bags are in it. The
//! `topics` table names each topic's type and serialization; the `messages` table holds each message's CDR
//! bytes, decoded as [`crate::ros2_bag`] decodes MCAP's. The topic choice, sorting, repeated stamps, the grid
//! and the errors are [`crate::imu_topic`]'s; a row's `timestamp` (when the recorder received the message)
//! stands in for `header.stamp` when every stamp is zero. SQLite is compiled from rusqlite's bundled source.
//!
//! Bags compressed by rosbag2 are read as they are: a storage file compressed whole (`.db3.zstd`) is decompressed
//! into a temporary file, and zstd-compressed messages one at a time (see `rosbag2_zstd`).
//!
//! ```no_run
//! let bag = octavar_io::ros2_db3::read_imu_bag(std::path::Path::new("rosbag2_run/"), None, None)?;
//! println!("{}: {} samples", bag.topic, bag.recording.info.samples);
//! # Ok::<(), octavar_io::imu_topic::BagError>(())
//! ```

mod scan;
#[cfg(test)]
mod tests;

use std::path::Path;

use crate::imu_topic::{self, BagError, ImuBag, Want};
use scan::scan;

/// The Imu topics of a bag (a `.db3` file or a bag directory) with their message counts, by name.
///
/// # Errors
/// A file that cannot be read or is not a rosbag2 SQLite file, a directory without `.db3` files.
pub fn imu_topics(path: &Path) -> Result<Vec<(String, u64)>, BagError> {
    Ok(scan(path, Want::Nothing)?.imu_topics())
}

/// Read one Imu topic of a bag (a `.db3` file or a bag directory): `topic`, or without one the bag's only Imu
/// topic, at `rate_hz` or else the median step of the stamps. Gaps (a step of more than 1.5 periods) become NaN
/// samples.
///
/// # Errors
/// See [`BagError`]: a file SQLite cannot read or that is not rosbag2's, a topic that is missing, ambiguous or not
/// an Imu topic, a message that does not decode (named by its row id), too few messages, a clock jump.
pub fn read_imu_bag(path: &Path, topic: Option<&str>, rate_hz: Option<f64>) -> Result<ImuBag, BagError> {
    imu_topic::check_rate(rate_hz)?;
    imu_topic::read(scan(path, imu_topic::want(topic))?, topic, rate_hz)
}

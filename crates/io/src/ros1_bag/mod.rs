//! Reading ROS 1 bags: one `sensor_msgs/Imu` topic as a [`Recording`](crate::recording::Recording).
//!
//! Reads bags of format 2.0 (what `rosbag record` has written since ROS C Turtle) with chunks stored, bz2 or lz4
//! compressed. Of each message of the topic (a connection of type `sensor_msgs/Imu`, ROS 1 serialization) it
//! keeps `header.stamp`, `angular_velocity` and `linear_acceleration`. The topic choice, sorting, repeated stamps,
//! the grid and the errors are [`crate::imu_topic`]'s, shared with the ROS 2 readers; the message record's time
//! (when the recorder received it) stands in for `header.stamp` when every stamp is zero.
//!
//! The whole file is read: a bag cut short or damaged, or one the recorder never closed (no index), is an error
//! naming the byte offset, as an Allan deviation of silently partial data is worse than none.
//!
//! ```no_run
//! let bag = octavar_io::ros1_bag::read_imu_bag(std::path::Path::new("run.bag"), Some("/imu/data"), None)?;
//! println!("{} samples at {} Hz", bag.recording.info.samples, bag.recording.rate_hz);
//! # Ok::<(), octavar_io::imu_topic::BagError>(())
//! ```

mod chunk;
#[doc(hidden)]
pub mod encode;
mod imu;
mod record;
mod scan;
#[cfg(test)]
mod tests;

use std::path::Path;

use crate::imu_topic::{self, BagError, ImuBag, Want};
use scan::scan;

/// The ROS 1 message type read.
pub const IMU_TYPE: &str = "sensor_msgs/Imu";

/// The Imu topics of a bag with their message counts, by name.
///
/// # Errors
/// A file that cannot be read, is not a ROS 1 bag, or is truncated or corrupt.
pub fn imu_topics(path: &Path) -> Result<Vec<(String, u64)>, BagError> {
    Ok(scan(path, Want::Nothing)?.topics.imu_topics())
}

/// Read one Imu topic of a ROS 1 bag: `topic`, or without one the bag's only Imu topic, at `rate_hz` or else the
/// median step of the stamps. Gaps (a step of more than 1.5 periods) become NaN samples.
///
/// # Errors
/// See [`BagError`]: a file that is not a whole ROS 1 bag, a topic that is missing, ambiguous or not an Imu topic,
/// a message that does not decode, too few messages, a clock jump.
pub fn read_imu_bag(path: &Path, topic: Option<&str>, rate_hz: Option<f64>) -> Result<ImuBag, BagError> {
    imu_topic::check_rate(rate_hz)?;
    let scan = scan(path, imu_topic::want(topic))?;
    imu_topic::read(scan.topics, topic, rate_hz)
}

//! Reading ROS 2 bags in MCAP format: one `sensor_msgs/msg/Imu` topic as a
//! [`Recording`](crate::recording::Recording).
//!
//! Reads MCAP files (rosbag2's default storage, and what the `mcap` writers make), alone or as a rosbag2 bag folder
//! (`metadata.yaml` beside the split files, read in order; see [`crate::rosbag2_dir`]), with chunks uncompressed,
//! zstd or lz4 (decompressed in pure Rust and checked against their CRC), or no chunks at all. Of each message
//! of the topic (schema `sensor_msgs/msg/Imu`, definition `ros2msg` or `ros2idl`, message encoding `cdr`, plain
//! CDR in either byte order) it keeps `header.stamp`, `angular_velocity` and `linear_acceleration`; orientation and
//! the covariances are decoded (to check the message's layout) but not kept. The topic choice, sorting, repeated
//! stamps, the grid and the errors are [`crate::imu_topic`]'s, shared with the ROS 1 and SQLite readers, and
//! re-exported here.
//!
//! Not read: XCDR2 encapsulation (ROS 2 middlewares send plain CDR), and files cut short or damaged anywhere in the
//! data: an Allan deviation of silently partial data is worse than an error naming the byte offset. The log time
//! stands in for `header.stamp` when every stamp is zero.

mod chunks;
mod imu;
mod scan;
#[cfg(test)]
mod tests;

use std::path::Path;

use crate::imu_topic::{self, Want};
pub use crate::imu_topic::{grid_positions, BagError, ImuBag, TimeSource};
pub(crate) use imu::kept;
pub use imu::{decode_imu, msg};
use scan::scan;

/// The ROS 2 message type read.
pub const IMU_TYPE: &str = "sensor_msgs/msg/Imu";

/// The Imu topics of a bag with their message counts (for listing in errors and for the CLI), by name.
///
/// # Errors
/// A file that cannot be read, is not MCAP, or is truncated or corrupt.
pub fn imu_topics(path: &Path) -> Result<Vec<(String, u64)>, BagError> {
    Ok(scan(path, Want::Nothing)?.topics.imu_topics())
}

/// Read one Imu topic of a bag.
///
/// `topic` names it; without one the bag must have exactly one Imu topic. `rate_hz` sets the sample rate; without
/// it the rate is the median step of the stamps. Gaps (a step of more than 1.5 periods) become NaN samples.
///
/// # Errors
/// See [`BagError`]: a file that is not a readable MCAP file, a topic that is missing, ambiguous or not an Imu
/// topic, a message that does not decode, too few messages, a clock jump.
pub fn read_imu_bag(path: &Path, topic: Option<&str>, rate_hz: Option<f64>) -> Result<ImuBag, BagError> {
    imu_topic::check_rate(rate_hz)?;
    let scan = scan(path, imu_topic::want(topic))?;
    imu_topic::read(scan.topics, topic, rate_hz)
}

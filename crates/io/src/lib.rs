//! Reading what users and devices write: opening a file (gzip and stdin included), choosing the reader by
//! format, and the readers themselves. Every reader gives samples in deg/s with NaN for gaps, or a typed error that
//! names the file and the place in it.
//!
//! Below the `octavar` library's `analyze` and `device`; imports only `octavar_stats` and `octavar_shared`.

// `!(x > 0.0)` rejects NaN along with the non-positive values; clippy's rewrite (`x <= 0.0`) would let NaN
// through, so its lints against the form are off. Numeric kernels index several arrays in step, which reads
// better than zipped iterators.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::nonminimal_bool, clippy::needless_range_loop)]

pub mod binary;
pub mod capture;
pub mod csv;
pub mod decode;
pub mod formats;
pub mod imu_topic;
pub mod input;
pub mod recording;
pub mod ros1_bag;
pub mod ros2_bag;
pub mod ros2_db3;
pub mod rosbag2_dir;
mod rosbag2_zstd;
pub mod tdms;

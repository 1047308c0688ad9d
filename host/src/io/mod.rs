//! Reading what users and devices write: opening a file (gzip and stdin included), choosing the reader by
//! format, and the readers themselves. Every reader gives samples in deg/s with NaN for gaps, or a typed error that
//! names the file and the place in it.
//!
//! Below `analyze`, `gap` and `device`; imports only `stats`-free pieces of its own and `octavar_shared`.

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
pub mod tdms;

//! The messages read: `sensor_msgs/msg/Imu` as serde structs in CDR field order, and the decoding of one message
//! from its CDR bytes (either byte order) with the checks that catch another message layout.

use byteorder::{BigEndian, LittleEndian};

use crate::imu_topic::Message;

/// `sensor_msgs/msg/Imu` and the types it contains, as serde structs in CDR field order.
pub mod msg {
    use serde::Deserialize;

    /// `builtin_interfaces/Time`.
    #[derive(Clone, Debug, Deserialize, PartialEq)]
    pub struct Time {
        pub sec: i32,
        pub nanosec: u32,
    }

    /// `std_msgs/Header`.
    #[derive(Clone, Debug, Deserialize, PartialEq)]
    pub struct Header {
        pub stamp: Time,
        pub frame_id: String,
    }

    /// `geometry_msgs/Quaternion`.
    #[derive(Clone, Debug, Deserialize, PartialEq)]
    pub struct Quaternion {
        pub x: f64,
        pub y: f64,
        pub z: f64,
        pub w: f64,
    }

    /// `geometry_msgs/Vector3`.
    #[derive(Clone, Debug, Deserialize, PartialEq)]
    pub struct Vector3 {
        pub x: f64,
        pub y: f64,
        pub z: f64,
    }

    /// `sensor_msgs/msg/Imu`.
    #[derive(Clone, Debug, Deserialize, PartialEq)]
    pub struct Imu {
        pub header: Header,
        pub orientation: Quaternion,
        pub orientation_covariance: [f64; 9],
        pub angular_velocity: Vector3,
        pub angular_velocity_covariance: [f64; 9],
        pub linear_acceleration: Vector3,
        pub linear_acceleration_covariance: [f64; 9],
    }
}

/// Decode one CDR-encoded `sensor_msgs/msg/Imu` (the 4-byte encapsulation header, then the message), first
/// decompressed where rosbag2 compressed it (a zstd frame: its message compression mode).
///
/// # Errors
/// What is wrong, as text: a short payload, an encapsulation other than plain CDR, bytes left over, a compressed
/// message that does not decompress.
pub fn decode_imu(data: &[u8]) -> Result<msg::Imu, String> {
    let data = &*crate::rosbag2_zstd::message(data)?;
    let Some((head, body)) = data.split_first_chunk::<4>() else {
        return Err(format!("{} bytes, shorter than the 4-byte CDR encapsulation header", data.len()));
    };
    let decoded = match [head[0], head[1]] {
        [0, 1] => cdr_encoding::from_bytes::<msg::Imu, LittleEndian>(body),
        [0, 0] => cdr_encoding::from_bytes::<msg::Imu, BigEndian>(body),
        [a, b] => {
            return Err(format!(
                "encapsulation {a:#04x}{b:02x} is not plain CDR (octavar reads CDR_LE 0x0001 and CDR_BE 0x0000)"
            ))
        }
    };
    let (imu, used) = decoded.map_err(|e| format!("{e} (a {}-byte message)", data.len()))?;
    // A message ends on an 8-byte boundary at most 7 bytes of padding away; more left over is another layout.
    let left = body.len() - used;
    if left >= 8 {
        return Err(format!("{left} bytes left over after the message (a different message layout?)"));
    }
    Ok(imu)
}

/// The fields octavar keeps of a decoded message that the recorder logged at `log_time` (ns).
pub(crate) fn kept(m: &msg::Imu, log_time: u64) -> Message<'_> {
    Message {
        stamp_ns: i64::from(m.header.stamp.sec) * 1_000_000_000 + i64::from(m.header.stamp.nanosec),
        log_time,
        frame_id: &m.header.frame_id,
        w: [m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z],
        a: [m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z],
        a_cov0: m.linear_acceleration_covariance[0],
    }
}
